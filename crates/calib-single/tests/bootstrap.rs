//! The view bootstrap (`calib_single::bootstrap`) against synthetic truth: on a rational8 camera,
//! whose linearized principal-point sigmas are several times too small, the bootstrap's sigmas
//! cover the errors; on brown-conrady5, whose linearized sigmas hold, the two agree. Refusals are
//! typed errors. Measured over 50 seeds per case by `benches/bootstrap/run.sh`
//! (docs/camera-model.md, "Terms the data does not determine").

use calib_core::synthetic::default_distortion;
use calib_single::synthetic::{SyntheticConfig, generate};
use calib_single::{
    BootstrapOptions, Calibration, CalibrationError, CalibrationOptions, add_bootstrap, bootstrap,
    calibrate,
};
use camera_model::CameraModel;

/// `calib synth single --model MODEL --noise 0.5 --views 20 --seed SEED`, calibrated with MODEL
/// and bootstrapped with `resamples` resamples; with the truth's fx, fy, cx, cy.
fn run(model: CameraModel, seed: u64, resamples: usize) -> (Calibration, [f64; 4]) {
    let config = SyntheticConfig {
        model,
        distortion: default_distortion(model),
        noise_px: 0.5,
        views: 20,
        seed,
        ..Default::default()
    };
    let set = generate(&config).unwrap();
    let mut options = CalibrationOptions::default();
    options.model = model;
    let mut result = calibrate(&set.observations, &options).unwrap();
    let settings = BootstrapOptions {
        resamples,
        ..Default::default()
    };
    add_bootstrap(&mut result, &set.observations, &options, &settings).unwrap();
    let k = set.camera.intrinsics;
    (result, [k.fx, k.fy, k.cx, k.cy])
}

/// RMS over the runs and over `params` of `(estimate - truth) / sigma`, with the linearized
/// sigmas and with the bootstrap's.
fn z_rms(runs: &[(Calibration, [f64; 4])], params: &[usize]) -> (f64, f64) {
    let (mut lin, mut boot, mut n) = (0.0, 0.0, 0.0);
    for (r, truth) in runs {
        let k = r.camera.intrinsics;
        let estimate = [k.fx, k.fy, k.cx, k.cy];
        let b = r.bootstrap.as_ref().unwrap();
        for &j in params {
            let e = estimate[j] - truth[j];
            lin += (e / r.intrinsics_std[j]).powi(2);
            boot += (e / b.intrinsics_std[j]).powi(2);
            n += 1.0;
        }
    }
    ((lin / n).sqrt(), (boot / n).sqrt())
}

/// Twelve rational8 cameras: over their principal points (24 errors) the linearized sigmas are
/// far too small and the bootstrap's cover the errors. Over 50 seeds (`benches/bootstrap/run.sh`,
/// views20.rational8) the RMS of z for cx, cy is 5.0 and 6.2 with the linearized sigmas and 0.82
/// and 0.84 with a bootstrap of 100 resamples (on the safe side). The bounds: 24 z values give
/// an RMS within 30% of its expectation (relative standard error 1 / sqrt(48) = 0.14, twice
/// that for 95%), 30 resamples add 13% to each sigma (1 / sqrt(58)) and the valley's errors are
/// heavier-tailed than a normal's: the bootstrap's must lie in 0.5 to 1.5 (0.68 here), the
/// linearized one's above 2.5, more than ten standard errors above 1 (6.0 here).
#[test]
fn rational8_bootstrap_sigmas_cover_the_principal_point_errors() {
    let runs: Vec<_> = (1..=12)
        .map(|seed| run(CameraModel::Rational8, seed, 30))
        .collect();
    let (lin, boot) = z_rms(&runs, &[2, 3]);
    println!("rational8 cx, cy: z RMS linearized {lin:.2}, bootstrap {boot:.2}");
    assert!(lin > 2.5, "linearized z RMS {lin}");
    assert!((0.5..1.5).contains(&boot), "bootstrap z RMS {boot}");
    let warned = runs
        .iter()
        .filter(|(r, _)| {
            r.warnings
                .iter()
                .any(|w| w.code.name() == "bootstrap-spread")
        })
        .count();
    assert!(
        warned >= 6,
        "bootstrap-spread warned in {warned} of 12 runs"
    );
}

/// brown-conrady5, whose linearized sigmas hold (z RMS 0.9 to 1.1 over 50 seeds): the
/// bootstrap's sigmas of fx, fy, cx, cy agree with them. Over 4 seeds and 4 parameters, the
/// median ratio lies within 0.7 to 1.4: the bootstrap std of 30 resamples has a relative
/// standard error of 13%, and the bootstrap of 20 views itself scatters by about 15% around the
/// spread it estimates (over 50 seeds the per-camera ratio's median is 0.9 to 1.0). No run
/// warns.
#[test]
fn brown_conrady5_bootstrap_agrees_with_the_linearized_sigmas() {
    let runs: Vec<_> = (1..=4)
        .map(|seed| run(CameraModel::BrownConrady5, seed, 30))
        .collect();
    let mut ratios: Vec<f64> = runs
        .iter()
        .flat_map(|(r, _)| {
            let b = r.bootstrap.as_ref().unwrap().intrinsics_std;
            (0..4).map(move |j| b[j] / r.intrinsics_std[j])
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    let median = (ratios[7] + ratios[8]) / 2.0;
    println!("brown-conrady5 bootstrap / linearized sigma: median {median:.2}, {ratios:.2?}");
    assert!((0.7..1.4).contains(&median), "median ratio {median}");
    for (r, _) in &runs {
        assert!(
            !r.warnings
                .iter()
                .any(|w| w.code.name() == "bootstrap-spread"),
            "{:?}",
            r.warnings
        );
    }
}

/// The same seed gives the same bootstrap; the result's JSON carries it and reads it back; the
/// summary prints it.
#[test]
fn bootstrap_is_deterministic_and_round_trips() {
    let (a, _) = run(CameraModel::BrownConrady4, 3, 10);
    let (b, _) = run(CameraModel::BrownConrady4, 3, 10);
    let (sa, sb) = (a.bootstrap.as_ref().unwrap(), b.bootstrap.as_ref().unwrap());
    assert_eq!(sa.intrinsics_std, sb.intrinsics_std);
    assert_eq!(sa.distortion_std, sb.distortion_std);
    assert_eq!(sa.resamples, 10);
    assert!(sa.intrinsics_std.iter().all(|s| s.is_finite() && *s > 0.0));
    let json = a.to_json();
    assert_eq!(json["bootstrap"]["resamples"], 10);
    assert!(json["bootstrap"]["std"]["cx"].as_f64().unwrap() > 0.0);
    assert!(
        json["bootstrap"]["std"]["distortion"]["k1"]
            .as_f64()
            .is_some()
    );
    let back = Calibration::from_json(json).unwrap();
    assert_eq!(
        back.bootstrap.as_ref().unwrap().intrinsics_std,
        sa.intrinsics_std
    );
    assert!(a.summary().contains("view bootstrap (10 resamples)"));
    // Without a bootstrap the file has no `bootstrap` key.
    let mut plain = a.clone();
    plain.bootstrap = None;
    assert!(plain.to_json().get("bootstrap").is_none());
}

/// Fewer than 10 resamples, fewer than 3 used views, or a calibration of other observations:
/// typed errors, and the calibration is left unchanged.
#[test]
fn bootstrap_refusals_are_typed_errors() {
    let config = SyntheticConfig {
        views: 6,
        ..Default::default()
    };
    let set = generate(&config).unwrap();
    let options = CalibrationOptions::default();
    let result = calibrate(&set.observations, &options).unwrap();
    let few = BootstrapOptions {
        resamples: 9,
        ..Default::default()
    };
    let e = bootstrap(&set.observations, &options, &result, &few).unwrap_err();
    assert!(matches!(e, CalibrationError::Bootstrap(_)), "{e}");
    assert!(e.to_string().contains("at least 10"), "{e}");

    let mut two = result.clone();
    two.views.truncate(2);
    let e = bootstrap(
        &set.observations,
        &options,
        &two,
        &BootstrapOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, CalibrationError::Bootstrap(_)), "{e}");
    assert!(e.to_string().contains("at least 3"), "{e}");

    let mut other = set.observations.clone();
    other.views.truncate(3);
    let mut unchanged = result.clone();
    let e = add_bootstrap(
        &mut unchanged,
        &other,
        &options,
        &BootstrapOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, CalibrationError::Bootstrap(_)), "{e}");
    // (The results hold NaN gain ratios of rejected steps: compared by their JSON form.)
    assert!(unchanged.bootstrap.is_none());
    assert_eq!(unchanged.to_json(), result.to_json());
}

/// Six views: the bootstrap runs, and a `poorly-determined` warning says it is rough (a resample
/// holds about 4 distinct views); twenty views: no such warning.
#[test]
fn a_bootstrap_over_few_views_is_warned_rough() {
    let rough = |views: usize| {
        let config = SyntheticConfig {
            views,
            ..Default::default()
        };
        let set = generate(&config).unwrap();
        let options = CalibrationOptions::default();
        let mut result = calibrate(&set.observations, &options).unwrap();
        let settings = BootstrapOptions {
            resamples: 10,
            ..Default::default()
        };
        add_bootstrap(&mut result, &set.observations, &options, &settings).unwrap();
        result
            .warnings
            .iter()
            .find(|w| w.message.contains("view bootstrap over"))
            .map(|w| (w.code.name(), w.message.clone()))
    };
    let (code, message) = rough(6).expect("no warning over 6 views");
    assert_eq!(code, "poorly-determined");
    assert!(
        message.contains("over 6 views is rough") && message.contains("about 4 distinct"),
        "{message}"
    );
    assert!(rough(20).is_none());
}
