//! The captures users bring that the first version mishandled (issue 11): boards in other units
//! or with an offset origin, nearly frontal boards, stray corners, data that cannot determine the
//! answer. Each finding has a test here.

use calib_core::synthetic::default_distortion;
use calib_single::synthetic::{SyntheticConfig, generate};
use calib_single::{CalibrationOptions, Observations, calibrate};
use camera_model::{CameraModel, Intrinsics};
use nalgebra::{Point3, Vector3};

fn base() -> Observations {
    let config = SyntheticConfig {
        views: 12,
        noise_px: 0.2,
        seed: 21,
        ..Default::default()
    };
    generate(&config).unwrap().observations
}

fn transform_board(obs: &Observations, f: impl Fn(&Point3<f64>) -> Point3<f64>) -> Observations {
    let mut out = obs.clone();
    for v in &mut out.views {
        for p in &mut v.object_points {
            *p = f(p);
        }
    }
    out
}

/// A board in micrometres, in 1e-8 units or with its origin far off the board is the same
/// calibration: the same intrinsics and RMS (to rounding), translations in the board's units.
#[test]
fn board_units_and_origin_do_not_matter() {
    let obs = base();
    let reference = calibrate(&obs, &CalibrationOptions::default()).unwrap();
    let cases: Vec<(&str, f64, Point3<f64>)> = vec![
        ("micrometres", 1000.0, Point3::origin()),
        ("1e-8 units", 1e-8, Point3::origin()),
        ("origin 300 mm off", 1.0, Point3::new(300.0, 0.0, 0.0)),
        ("origin 5 m off", 1.0, Point3::new(-5000.0, 2500.0, 0.0)),
        (
            "micrometres, far origin",
            1000.0,
            Point3::new(1e6, -3e5, 0.0),
        ),
    ];
    for (what, scale, shift) in cases {
        let changed = transform_board(&obs, |p| Point3::from(p.coords * scale + shift.coords));
        let r = calibrate(&changed, &CalibrationOptions::default())
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        assert!(r.solver.termination.is_converged(), "{what}");
        assert!(
            (r.rms - reference.rms).abs() < 1e-9 * reference.rms,
            "{what}: rms {} vs {}",
            r.rms,
            reference.rms
        );
        // The same minimum: parameters equal to a small fraction of their standard deviation
        // (the stopping tolerance leaves differences of order 1e-6 sigma), the same sigmas.
        let (a, b) = (r.camera.params(), reference.camera.params());
        let sigma = [
            reference.intrinsics_std.as_slice(),
            &reference.distortion_std,
        ]
        .concat();
        let sigma_r = [r.intrinsics_std.as_slice(), &r.distortion_std].concat();
        for i in 0..8 {
            assert!(
                (a[i] - b[i]).abs() <= 1e-3 * sigma[i],
                "{what}: parameter {i}: {} vs {} (sigma {})",
                a[i],
                b[i],
                sigma[i]
            );
            assert!(
                (sigma_r[i] - sigma[i]).abs() <= 1e-3 * sigma[i],
                "{what}: sigma {i}: {} vs {}",
                sigma_r[i],
                sigma[i]
            );
        }
        // Poses: the same rotation; the translation of the transformed board's origin.
        for (v, w) in r.views.iter().zip(&reference.views) {
            assert!((v.pose.rotation - w.pose.rotation).norm() < 1e-7, "{what}");
            let expected = w.pose.translation * scale - v.pose.rotation * shift.coords;
            assert!(
                (v.pose.translation - expected).norm() <= 1e-6 * expected.norm().max(scale),
                "{what}: {} vs {}",
                v.pose.translation,
                expected
            );
            // Rotation uncertainties are unit-free; translation ones scale with the units.
            for i in 0..3 {
                assert!(
                    (v.pose_std[i] - w.pose_std[i]).abs() <= 1e-3 * w.pose_std[i],
                    "{what}"
                );
            }
        }
    }
}

/// Every lens model with the board's origin 20 m, 50 m and 1.8 km off a 0.2 m board: the start
/// re-centres the board as the solver does. Before, the start worked on the user's coordinates:
/// at 20 m rational8 was refused ("the initial pose puts point 9 behind the camera"), at 50 m the
/// closed form was 1570 px off and brown-conrady4 refused "the board pose of view 0 is not
/// determined", kannala-brandt4 called a view's points outliers, and on sourishg1/left at 20 m
/// it returned a wrong camera (RMS 60 px) with exit code 0.
#[test]
fn every_lens_model_takes_a_board_origin_far_off_the_board() {
    for model in CameraModel::ALL {
        let mut config = SyntheticConfig {
            model,
            distortion: default_distortion(model),
            views: 12,
            noise_px: 0.2,
            seed: 21,
            ..Default::default()
        };
        if model.is_fisheye() {
            let f = config.image_size.half_diagonal() / 75f64.to_radians();
            config.intrinsics = Intrinsics::new(f, f, 322.0, 236.0);
        }
        let obs = generate(&config).unwrap().observations;
        let mut options = CalibrationOptions::default();
        options.model = model;
        let reference = calibrate(&obs, &options).unwrap();
        for shift in [
            Vector3::new(20_000.0, 0.0, 0.0),
            Vector3::new(0.0, -50_000.0, 0.0),
            Vector3::new(1.5e6, 1e6, 0.0),
        ] {
            let what = format!("{model}, origin moved by {shift:?}");
            let r = calibrate(&transform_board(&obs, |p| p + shift), &options)
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            assert!(r.solver.termination.is_converged(), "{what}");
            let (a, b) = (r.camera.params(), reference.camera.params());
            if model.num_distortion_params() <= 5 {
                // One minimum: the same to a small fraction of a sigma (as above).
                assert!(
                    (r.rms - reference.rms).abs() < 1e-9 * reference.rms,
                    "{what}"
                );
                for i in 0..4 {
                    let sigma = reference.intrinsics_std[i];
                    assert!((a[i] - b[i]).abs() <= 1e-3 * sigma, "{what}: {i}");
                }
            } else {
                // The rational valleys hold several minima, and which one a path ends in moves
                // with the last bits of the data (docs/camera-model.md, Convergence): measured,
                // rational8 ended 4e-5 and 1.1e-3 relative above the reference's RMS at two of the
                // three origins. A fit as good to 0.5% (the population test's higher minima are
                // within 0.4%), the same focal length within 3 sigma.
                assert!(
                    (r.rms - reference.rms).abs() < 5e-3 * reference.rms,
                    "{what}: rms {} vs {}",
                    r.rms,
                    reference.rms
                );
                assert!(
                    (a[0] - b[0]).abs() < 3.0 * reference.intrinsics_std[0],
                    "{what}"
                );
            }
        }
    }
}

/// A view that shows only a few of the board's corners (4, or 5) does not stop the fisheye
/// start: it needs 6 points per view for a fisheye pose, and such a view made every focal
/// length's score infinite ("no focal length of an equidistant (fisheye) camera explains the
/// views"), whichever view it was. It now scores on the other views and the short view starts
/// from its homography.
#[test]
fn a_fisheye_view_with_only_its_outer_corners_does_not_stop_the_start() {
    let mut config = SyntheticConfig {
        model: CameraModel::KannalaBrandt4,
        distortion: default_distortion(CameraModel::KannalaBrandt4),
        views: 12,
        noise_px: 0.2,
        seed: 21,
        ..Default::default()
    };
    let f = config.image_size.half_diagonal() / 75f64.to_radians();
    config.intrinsics = Intrinsics::new(f, f, 322.0, 236.0);
    let set = generate(&config).unwrap();
    let mut options = CalibrationOptions::default();
    options.model = CameraModel::KannalaBrandt4;
    for (short, keep) in [(0, 4), (5, 4), (11, 5)] {
        let mut obs = set.observations.clone();
        let view = &mut obs.views[short];
        let n = view.object_points.len();
        // The board's corners first (and its centre for 5).
        let pick: Vec<usize> = [
            0,
            config.board_cols - 1,
            n - config.board_cols,
            n - 1,
            n / 2,
        ]
        .into_iter()
        .take(keep)
        .collect();
        view.object_points = pick.iter().map(|&i| view.object_points[i]).collect();
        view.image_points = pick.iter().map(|&i| view.image_points[i]).collect();
        let r = calibrate(&obs, &options)
            .unwrap_or_else(|e| panic!("view {short} with {keep} points: {e}"));
        let k = r.camera.intrinsics;
        assert!(
            (k.fx - f).abs() < 3.0 * r.intrinsics_std[0] + 1.0,
            "view {short}: fx {} against {f}",
            k.fx
        );
        assert_eq!(r.views.len(), 12);
    }
}

/// Four nearly frontal views (tilts up to 2 degrees) do not determine the focal length:
/// brown-conrady5 is refused for it, and so is rational8, which starts from brown-conrady5's
/// solution of the same views. Before, that stage's failure was not looked at and rational8 went
/// on to a degenerate camera, fx = 8.7 +- 1.2 px against a true 800.
#[test]
fn models_started_from_a_simpler_one_are_refused_where_it_is() {
    let config = SyntheticConfig {
        model: CameraModel::Rational8,
        distortion: default_distortion(CameraModel::Rational8),
        views: 4,
        max_tilt_deg: 2.0,
        ..Default::default()
    };
    let obs = generate(&config).unwrap().observations;
    for model in [
        CameraModel::BrownConrady5,
        CameraModel::Rational8,
        CameraModel::ThinPrism12,
    ] {
        let mut options = CalibrationOptions::default();
        options.model = model;
        match calibrate(&obs, &options) {
            Err(e) => {
                let text = e.to_string();
                assert!(
                    text.contains("not unique") && text.contains("fx"),
                    "{model}: {text}"
                );
            }
            // thin-prism12's focal search starts elsewhere (it scores with the model's own
            // terms), and there brown-conrady5's matrix is only nearly singular: accepted, but
            // with the focal length flagged and a sigma that covers the truth (measured: fx
            // 1338 +- 768 against 800).
            Ok(r) if model == CameraModel::ThinPrism12 => {
                let fx = r.camera.intrinsics.fx;
                assert!(
                    (fx - 800.0).abs() < 3.0 * r.intrinsics_std[0],
                    "{model}: {fx}"
                );
                assert!(
                    r.warnings.iter().any(|w| w.message.contains("fx =")),
                    "{model}: {:?}",
                    r.warnings
                );
            }
            Ok(r) => panic!(
                "{model}: fx = {} +- {} accepted",
                r.camera.intrinsics.fx, r.intrinsics_std[0]
            ),
        }
    }
}

/// Pixels that are not square (an image resampled to another aspect ratio, like the bundled
/// sourishg2 webcam's `fy / fx = 1.18`): the two square-pixel closed forms disagree, which used
/// to send the start to the focal search (a hundred times slower); the closed form with `fx` and
/// `fy` apart starts at the right aspect and the calibration reaches the truth.
#[test]
fn non_square_pixels_start_from_the_aspect_closed_form() {
    for (seed, aspect) in [(3, 1.18), (4, 0.8), (5, 1.1)] {
        let mut config = SyntheticConfig {
            views: 20,
            noise_px: 0.2,
            seed,
            ..Default::default()
        };
        config.intrinsics.fy = config.intrinsics.fx * aspect;
        let data = generate(&config).unwrap();
        let result = calibrate(&data.observations, &CalibrationOptions::default()).unwrap();
        // At 10% the square-pixel forms still agree within 15% and start well enough.
        if (aspect - 1.0f64).abs() > 0.15 {
            assert_eq!(
                result.initial_method.name(),
                "closed-form-bouguet-aspect",
                "aspect {aspect}"
            );
        }
        let k = result.camera.intrinsics;
        let std = result.intrinsics_std;
        assert!((k.fx - config.intrinsics.fx).abs() < 5.0 * std[0], "{k:?}");
        assert!((k.fy - config.intrinsics.fy).abs() < 5.0 * std[1], "{k:?}");
    }
    // Square pixels keep the square closed form.
    let result = calibrate(&base(), &CalibrationOptions::default()).unwrap();
    assert_eq!(result.initial_method.name(), "closed-form-bouguet");
}
