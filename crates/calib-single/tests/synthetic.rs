//! Calibration of synthetic data with known truth.

use calib_single::synthetic::{SyntheticConfig, SyntheticSet, generate};
use calib_single::{Calibration, CalibrationOptions, FocalInit, calibrate};
use camera_model::{Intrinsics, RotationKind, RotationParameterization};
use lm_solver::Rng;

fn truth_vector(set: &SyntheticSet) -> Vec<f64> {
    let mut v = vec![0.0; 8];
    set.camera.write_params(&mut v);
    v
}

fn estimate_vector(c: &Calibration) -> Vec<f64> {
    let mut v = vec![0.0; 8];
    c.camera.write_params(&mut v);
    v
}

fn std_vector(c: &Calibration) -> Vec<f64> {
    let mut v = c.intrinsics_std.to_vec();
    v.extend(&c.distortion_std);
    v
}

#[test]
fn noise_free_data_recovers_every_parameter() {
    for seed in 1..=5 {
        let set = generate(&SyntheticConfig {
            views: 8 + seed as usize,
            noise_px: 0.0,
            seed,
            ..Default::default()
        })
        .unwrap();
        let result = calibrate(&set.observations, &CalibrationOptions::default()).unwrap();
        assert!(
            result.solver.termination.is_converged(),
            "{}",
            result.solver.termination
        );
        let (truth, est) = (truth_vector(&set), estimate_vector(&result));
        for (i, (t, e)) in truth.iter().zip(&est).enumerate() {
            assert!(
                (e - t).abs() <= 1e-8 * t.abs(),
                "seed {seed}, parameter {i}: {e} vs {t}"
            );
        }
        for (view, pose) in result.views.iter().zip(&set.poses) {
            let dr = (view.pose.rotation - pose.rotation).norm();
            let dt = (view.pose.translation - pose.translation).norm() / pose.translation.norm();
            assert!(
                dr < 1e-8 && dt < 1e-8,
                "seed {seed}, {}: {dr} {dt}",
                view.name
            );
        }
        assert!(result.rms < 1e-8);
    }
}

/// With Gaussian noise the errors must be consistent with the reported standard deviations:
/// |error| <= 3 sigma for at least 99% of all parameters (camera and poses) over many data sets.
/// For an honest sigma, 0.27% of the errors exceed 3 sigma.
#[test]
fn reported_sigmas_are_honest() {
    let (mut total, mut outside) = (0usize, 0usize);
    for seed in 0..150u64 {
        let mut rng = Rng::new(seed);
        let set = generate(&SyntheticConfig {
            views: 5 + (rng.uniform() * 20.0) as usize,
            noise_px: 0.2,
            max_tilt_deg: 50.0,
            seed: 1000 + seed,
            ..Default::default()
        })
        .unwrap();
        let result = calibrate(&set.observations, &CalibrationOptions::default()).unwrap();
        let (truth, est, std) = (
            truth_vector(&set),
            estimate_vector(&result),
            std_vector(&result),
        );
        for i in 0..8 {
            total += 1;
            if (est[i] - truth[i]).abs() > 3.0 * std[i] {
                outside += 1;
            }
        }
        for (view, pose) in result.views.iter().zip(&set.poses) {
            let truth_params = pose.to_params::<camera_model::EulerXyz>();
            for i in 0..6 {
                total += 1;
                if (view.pose_params[i] - truth_params[i]).abs() > 3.0 * view.pose_std[i] {
                    outside += 1;
                }
            }
        }
    }
    let fraction = outside as f64 / total as f64;
    println!(
        "{outside} of {total} parameters outside 3 sigma ({:.3}%)",
        100.0 * fraction
    );
    assert!(fraction <= 0.01, "{outside} of {total} outside 3 sigma");
}

/// From the closed-form start, the calibration reaches the same minimum as a start at the true
/// camera, on 500 random problems: 3 to 40 views, tilts up to 60 degrees, noise 0 to 1 px.
#[test]
fn closed_form_start_reaches_the_true_minimum() {
    let mut failures = Vec::new();
    let problems = 500;
    for seed in 0..problems as u64 {
        let mut rng = Rng::new(77 + seed);
        let config = SyntheticConfig {
            views: 3 + (rng.uniform() * 38.0) as usize,
            noise_px: rng.range(0.0, 1.0),
            max_tilt_deg: 60.0,
            intrinsics: {
                let f = rng.range(400.0, 1500.0);
                Intrinsics::new(
                    f,
                    f * rng.range(0.95, 1.05),
                    rng.range(290.0, 350.0),
                    rng.range(210.0, 270.0),
                )
            },
            distortion: vec![
                rng.range(-0.35, 0.15),
                rng.range(-0.1, 0.2),
                rng.range(-0.003, 0.003),
                rng.range(-0.003, 0.003),
            ],
            seed: 5000 + seed,
            ..Default::default()
        };
        let set = generate(&config).unwrap();
        let from_seed = calibrate(&set.observations, &CalibrationOptions::default());
        let from_truth = calibrate(&set.observations, &{
            let mut o = CalibrationOptions::default();
            o.intrinsic_guess = Some(set.camera.intrinsics);
            o.distortion_guess = Some(set.camera.distortion.clone());
            o
        })
        .unwrap();
        // Same minimum: equal RMS (to rounding) and parameters equal to a small fraction of their
        // standard deviation (the stopping tolerance leaves differences of order 1e-6 sigma).
        let ok = match &from_seed {
            Ok(r) => {
                let scale = from_truth.rms.max(1e-6);
                let sigma = std_vector(&from_truth);
                (r.rms - from_truth.rms).abs() <= 1e-7 * scale
                    && estimate_vector(r)
                        .iter()
                        .zip(estimate_vector(&from_truth))
                        .zip(&sigma)
                        .all(|((a, b), s)| (a - b).abs() <= 1e-3 * s + 1e-9 * b.abs())
            }
            Err(_) => false,
        };
        if !ok {
            failures.push((
                seed,
                config.views,
                from_seed.map(|r| r.rms).map_err(|e| e.to_string()),
                from_truth.rms,
            ));
        }
    }
    println!(
        "{} of {problems} problems reached the true minimum",
        problems - failures.len()
    );
    assert!(failures.is_empty(), "failures: {failures:?}");
}

fn base_set() -> SyntheticSet {
    generate(&SyntheticConfig {
        views: 12,
        noise_px: 0.1,
        seed: 42,
        ..Default::default()
    })
    .unwrap()
}

#[test]
fn option_fix_principal_point() {
    let set = base_set();
    let options = {
        let mut o = CalibrationOptions::default();
        o.fix_principal_point = true;
        o
    };
    let r = calibrate(&set.observations, &options).unwrap();
    assert_eq!(
        (r.camera.intrinsics.cx, r.camera.intrinsics.cy),
        (319.5, 239.5)
    );
    assert_eq!(&r.intrinsics_std[2..], &[0.0, 0.0]);
    assert_eq!(r.fixed_parameters, vec!["cx", "cy"]);
    assert!((r.camera.intrinsics.fx - 800.0).abs() < 1.0);
}

#[test]
fn option_fix_aspect_ratio() {
    let set = generate(&SyntheticConfig {
        intrinsics: Intrinsics::new(900.0, 900.0, 330.0, 230.0),
        ..SyntheticConfig {
            views: 12,
            noise_px: 0.1,
            seed: 3,
            ..Default::default()
        }
    })
    .unwrap();
    let options = {
        let mut o = CalibrationOptions::default();
        o.fix_aspect_ratio = true;
        o
    };
    let r = calibrate(&set.observations, &options).unwrap();
    let k = r.camera.intrinsics;
    assert_eq!(k.fx, k.fy);
    assert!((k.fx - 900.0).abs() < 2.0);
    assert_eq!(r.intrinsics_std[0], r.intrinsics_std[1]);
    assert!(r.intrinsics_std[0] > 0.0);
    // A guess with fx/fy = 1.1 is kept at 1.1.
    let options = {
        let mut o = CalibrationOptions::default();
        o.fix_aspect_ratio = true;
        o.intrinsic_guess = Some(Intrinsics::new(880.0, 800.0, 320.0, 240.0));
        o
    };
    let r = calibrate(&set.observations, &options).unwrap();
    assert!((r.camera.intrinsics.fx / r.camera.intrinsics.fy - 1.1).abs() < 1e-12);
}

#[test]
fn option_zero_tangential_and_fixed_terms() {
    let set = generate(&SyntheticConfig {
        distortion: vec![-0.25, 0.0, 0.0, 0.0],
        ..SyntheticConfig {
            views: 12,
            noise_px: 0.1,
            seed: 5,
            ..Default::default()
        }
    })
    .unwrap();
    let options = {
        let mut o = CalibrationOptions::default();
        o.zero_tangential_distortion = true;
        o.fixed_distortion = vec![1];
        o.distortion_guess = Some(vec![0.0, 0.0, 0.01, 0.02]);
        o
    };
    let r = calibrate(&set.observations, &options).unwrap();
    let d = &r.camera.distortion;
    assert_eq!((d[1], d[2], d[3]), (0.0, 0.0, 0.0));
    assert_eq!(&r.distortion_std[1..], &[0.0, 0.0, 0.0]);
    assert!((d[0] + 0.25).abs() < 0.01);
    assert_eq!(r.fixed_parameters, vec!["k2", "p1", "p2"]);
    let bad = {
        let mut o = CalibrationOptions::default();
        o.fixed_distortion = vec![4];
        o
    };
    assert!(calibrate(&set.observations, &bad).is_err());
}

#[test]
fn option_intrinsic_guess_and_focal_methods_reach_the_same_minimum() {
    let set = base_set();
    let reference = calibrate(&set.observations, &CalibrationOptions::default()).unwrap();
    let guessed = calibrate(&set.observations, &{
        let mut o = CalibrationOptions::default();
        o.intrinsic_guess = Some(Intrinsics::new(700.0, 720.0, 300.0, 250.0));
        o
    })
    .unwrap();
    assert_eq!(
        guessed.initial_intrinsics,
        Intrinsics::new(700.0, 720.0, 300.0, 250.0)
    );
    let least_squares = calibrate(&set.observations, &{
        let mut o = CalibrationOptions::default();
        o.focal_init = FocalInit::LeastSquares;
        o
    })
    .unwrap();
    assert_ne!(
        least_squares.initial_intrinsics.fx,
        reference.initial_intrinsics.fx
    );
    for other in [&guessed, &least_squares] {
        assert!((other.rms - reference.rms).abs() < 1e-9);
        assert!((other.camera.intrinsics.fx - reference.camera.intrinsics.fx).abs() < 1e-6);
    }
}

#[test]
fn option_axis_angle_rotations_reach_the_same_minimum() {
    let set = base_set();
    let euler = calibrate(&set.observations, &CalibrationOptions::default()).unwrap();
    let axis = calibrate(&set.observations, &{
        let mut o = CalibrationOptions::default();
        o.rotation = RotationKind::AxisAngle;
        o
    })
    .unwrap();
    assert_eq!(axis.rotation, RotationKind::AxisAngle);
    assert!((axis.rms - euler.rms).abs() < 1e-9);
    for (a, e) in axis.views.iter().zip(&euler.views) {
        assert!((a.pose.rotation - e.pose.rotation).norm() < 1e-8);
        let w = camera_model::AxisAngle::from_matrix(&a.pose.rotation);
        assert!(
            (w - nalgebra::Vector3::new(a.pose_params[0], a.pose_params[1], a.pose_params[2]))
                .norm()
                < 1e-9
        );
    }
    // Same uncertainty for the camera, whatever the pose parameterization.
    for i in 0..4 {
        assert!((axis.intrinsics_std[i] / euler.intrinsics_std[i] - 1.0).abs() < 1e-5);
    }
}

#[test]
fn option_solver_limits() {
    let set = base_set();
    let mut options = CalibrationOptions::default();
    options.solver.max_iterations = 1;
    let r = calibrate(&set.observations, &options).unwrap();
    assert_eq!(r.solver.termination, lm_solver::Termination::MaxIterations);
    assert_eq!(r.solver.iterations.len(), 1);
}

#[test]
fn single_view_holds_the_principal_point() {
    let set = generate(&SyntheticConfig {
        views: 1,
        noise_px: 0.0,
        max_tilt_deg: 40.0,
        board_cols: 12,
        board_rows: 9,
        square: 20.0,
        seed: 11,
        ..Default::default()
    })
    .unwrap();
    let r = calibrate(&set.observations, &CalibrationOptions::default()).unwrap();
    assert_eq!(r.fixed_parameters, vec!["cx", "cy"]);
    assert_eq!(
        (r.camera.intrinsics.cx, r.camera.intrinsics.cy),
        (319.5, 239.5)
    );
}

#[test]
fn bad_views_are_reported_or_skipped() {
    let mut set = base_set();
    // View 4 becomes degenerate: all its points on one line.
    let bad = &mut set.observations.views[4];
    for (i, p) in bad.image_points.iter_mut().enumerate() {
        *p = nalgebra::Point2::new(10.0 + i as f64, 20.0 + 2.0 * i as f64);
    }
    let err = calibrate(&set.observations, &CalibrationOptions::default()).unwrap_err();
    assert!(
        matches!(
            err,
            calib_single::CalibrationError::Homography { view: 4, .. }
        ),
        "{err}"
    );
    assert!(err.to_string().starts_with("view 4:"), "{err}");
    let r = calibrate(&set.observations, &{
        let mut o = CalibrationOptions::default();
        o.skip_bad_views = true;
        o
    })
    .unwrap();
    assert_eq!(r.skipped_views.len(), 1);
    assert_eq!(r.skipped_views[0].index, 4);
    assert_eq!(r.views.len(), 11);
    assert!(r.views.iter().all(|v| v.index != 4));
    assert!(r.summary().contains("skipped view 4"));
}

#[test]
fn result_json_has_the_documented_fields() {
    let set = base_set();
    let r = calibrate(&set.observations, &CalibrationOptions::default()).unwrap();
    let json = r.to_json();
    for key in [
        "rms",
        "elapsed_seconds",
        "camera",
        "distortion_model",
        "views",
        "solver",
        "image_size",
        "residual_std_xy",
    ] {
        assert!(json.get(key).is_some(), "missing {key}");
    }
    assert_eq!(
        json["camera"]["fx"].as_f64().unwrap(),
        r.camera.intrinsics.fx
    );
    assert_eq!(json["views"].as_array().unwrap().len(), 12);
    assert_eq!(json["camera"]["dist_coeffs"].as_array().unwrap().len(), 4);
    assert_eq!(
        json["camera"]["std"]["fx"].as_f64().unwrap(),
        r.intrinsics_std[0]
    );
    assert_eq!(json["distortion_model"], "brown-conrady4");
    assert!(json["solver"]["converged"].as_bool().unwrap());
    // The result reads back: the same calibration, the same JSON.
    let back = calib_single::Calibration::from_json(json.clone()).unwrap();
    assert_eq!(back.camera, r.camera);
    assert_eq!(back.views, r.views);
    assert_eq!(back.solver.iterations.len(), r.solver.iterations.len());
    assert_eq!(back.to_json(), json);
    // What cannot be read back says why, as a typed error.
    use calib_single::{Calibration, ResultFormatError};
    let err = Calibration::from_json(serde_json::json!({"format": "calib-stereo-result/2"}));
    assert!(
        matches!(&err, Err(ResultFormatError::WrongKind { expected, found })
            if *expected == "single-camera result" && found == "calib-stereo-result/2"),
        "{err:?}"
    );
    let mut unknown = json.clone();
    unknown["rotation_parameterization"] = "quaternion".into();
    let err = Calibration::from_json(unknown);
    assert!(
        matches!(&err, Err(ResultFormatError::UnknownName { key, reason })
            if *key == "rotation_parameterization" && reason.contains("quaternion")),
        "{err:?}"
    );
    let mut short = json.clone();
    short["camera"]["dist_coeffs"] = serde_json::json!([0.1, 0.0]);
    let err = Calibration::from_json(short).unwrap_err();
    assert!(matches!(err, ResultFormatError::Malformed(_)), "{err:?}");
    assert!(err.to_string().contains("coefficient"), "{err}");
    let mut missing = json.clone();
    missing.as_object_mut().unwrap().remove("rms");
    let err = Calibration::from_json(missing).unwrap_err();
    assert!(err.to_string().contains("`rms`"), "{err}");
}

#[test]
fn option_fix_focal_length() {
    let set = base_set();
    let options = {
        let mut o = CalibrationOptions::default();
        o.fix_focal_length = true;
        o.intrinsic_guess = Some(Intrinsics::new(805.0, 795.0, 320.0, 240.0));
        o
    };
    let r = calibrate(&set.observations, &options).unwrap();
    assert_eq!(
        (r.camera.intrinsics.fx, r.camera.intrinsics.fy),
        (805.0, 795.0)
    );
    assert_eq!(&r.intrinsics_std[..2], &[0.0, 0.0]);
    assert!(r.intrinsics_std[2] > 0.0);
    assert_eq!(r.fixed_parameters, vec!["fx", "fy"]);
}

/// Views are evaluated in parallel in chunks fixed by the problem, never by the thread count:
/// the calibration gives the same bits with one thread or several.
#[test]
fn results_do_not_depend_on_the_thread_count() {
    let set = generate(&SyntheticConfig {
        views: 60,
        noise_px: 0.3,
        seed: 8,
        ..Default::default()
    })
    .unwrap();
    let run = |threads: usize| {
        let mut options = CalibrationOptions::default();
        options.solver.num_threads = threads;
        // Small chunks, so that even this problem is split across threads.
        options.solver.chunk_work = 2_000;
        calibrate(&set.observations, &options).unwrap()
    };
    let one = run(1);
    for threads in [2, 3] {
        let many = run(threads);
        assert_eq!(estimate_vector(&many), estimate_vector(&one));
        assert_eq!(many.rms.to_bits(), one.rms.to_bits());
        assert_eq!(std_vector(&many), std_vector(&one));
        for (a, b) in many.views.iter().zip(&one.views) {
            assert_eq!(a.pose_params, b.pose_params);
        }
    }
}
