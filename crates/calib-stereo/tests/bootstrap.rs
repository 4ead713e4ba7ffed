//! The pair bootstrap (`calib_stereo::bootstrap`) against synthetic truth: on rational8 pairs,
//! whose linearized principal-point sigmas are several times too small, the bootstrap's sigmas
//! cover the errors; on brown-conrady5, whose linearized sigmas hold, the two agree. Refusals
//! are typed errors. Measured over 30 seeds per case by `benches/bootstrap/run.sh --stereo`
//! (docs/calib-stereo.md, "Honest standard deviations").

use calib_core::synthetic::default_distortion;
use calib_single::synthetic::SyntheticConfig;
use calib_stereo::synthetic::{SyntheticStereoConfig, SyntheticStereoSet, generate_stereo};
use calib_stereo::{
    BootstrapOptions, StereoCalibration, StereoError, StereoOptions, add_bootstrap, bootstrap,
    calibrate_stereo,
};
use camera_model::CameraModel;

/// `calib synth stereo --model MODEL --noise 0.5 --views PAIRS --seed SEED` (both cameras of
/// MODEL, the default rig), calibrated with MODEL.
fn calibrate(
    model: CameraModel,
    seed: u64,
    pairs: usize,
) -> (SyntheticStereoSet, StereoOptions, StereoCalibration) {
    let config = SyntheticStereoConfig {
        left: SyntheticConfig {
            model,
            distortion: default_distortion(model),
            noise_px: 0.5,
            views: pairs,
            seed,
            ..Default::default()
        },
        right_model: model,
        right_distortion: right_distortion(model),
        ..Default::default()
    };
    let set = generate_stereo(&config).unwrap();
    let mut options = StereoOptions::default();
    options.left.model = model;
    options.right.model = model;
    let result = calibrate_stereo(&set.observations, &options).unwrap();
    (set, options, result)
}

/// The right camera's true distortion as `calib synth stereo` makes it for `model`: its own
/// default for brown-conrady4, the model's default (the left camera's) otherwise.
fn right_distortion(model: CameraModel) -> Vec<f64> {
    if model == CameraModel::BrownConrady4 {
        SyntheticStereoConfig::default().right_distortion
    } else {
        default_distortion(model)
    }
}

/// [`calibrate`] and a bootstrap of `resamples` resamples.
fn run(model: CameraModel, seed: u64, resamples: usize) -> (SyntheticStereoSet, StereoCalibration) {
    let (set, options, mut result) = calibrate(model, seed, 20);
    let settings = BootstrapOptions {
        resamples,
        ..Default::default()
    };
    add_bootstrap(&mut result, &set.observations, &options, &settings).unwrap();
    (set, result)
}

/// Per run: the errors of left and right fx, fy, cx, cy (pixels), with their linearized and
/// bootstrap sigmas.
fn camera_errors(set: &SyntheticStereoSet, r: &StereoCalibration) -> Vec<(f64, f64, f64)> {
    let b = r.bootstrap.as_ref().unwrap();
    let mut out = Vec::new();
    for (truth, estimate, spread) in [
        (&set.left, &r.left, &b.left),
        (&set.right, &r.right, &b.right),
    ] {
        let t = truth.intrinsics;
        let e = estimate.camera.intrinsics;
        let (t, e) = ([t.fx, t.fy, t.cx, t.cy], [e.fx, e.fy, e.cx, e.cy]);
        for j in 0..4 {
            out.push((
                e[j] - t[j],
                estimate.intrinsics_std[j],
                spread.intrinsics_std[j],
            ));
        }
    }
    out
}

/// RMS of `(error / linearized sigma)` and of `(error / bootstrap sigma)` over `values`.
fn z_rms(values: &[(f64, f64, f64)]) -> (f64, f64) {
    let n = values.len() as f64;
    let lin = values.iter().map(|(e, l, _)| (e / l).powi(2)).sum::<f64>() / n;
    let boot = values.iter().map(|(e, _, b)| (e / b).powi(2)).sum::<f64>() / n;
    (lin.sqrt(), boot.sqrt())
}

fn warned(r: &StereoCalibration) -> bool {
    r.warnings
        .iter()
        .any(|w| w.code.name() == "bootstrap-spread")
}

/// Twelve rational8 pairs: over both cameras' principal points (48 errors) the linearized
/// sigmas are far too small and the bootstrap's cover the errors. Over 30 seeds
/// (`benches/bootstrap/run.sh --stereo`) the RMS of z for the four is 3.9 to 7.1 with the
/// linearized sigmas and 0.77 to 1.02 with a bootstrap of 100 resamples. The bounds: 48 z values
/// give an RMS within 20% of its expectation (relative standard error 1 / sqrt(96) = 0.10,
/// twice that for 95%), 30 resamples add 13% to each sigma (1 / sqrt(58)) and the valley's
/// errors are heavier-tailed than a normal's: the bootstrap's must lie in 0.5 to 1.5, the
/// linearized one's above 2.5, more than ten standard errors above 1.
#[test]
fn rational8_bootstrap_sigmas_cover_the_principal_point_errors() {
    let runs: Vec<_> = (1..=12)
        .map(|seed| run(CameraModel::Rational8, seed, 30))
        .collect();
    let principal: Vec<(f64, f64, f64)> = runs
        .iter()
        .flat_map(|(set, r)| {
            let e = camera_errors(set, r);
            [e[2], e[3], e[6], e[7]]
        })
        .collect();
    let (lin, boot) = z_rms(&principal);
    println!("rational8 left and right cx, cy: z RMS linearized {lin:.2}, bootstrap {boot:.2}");
    assert!(lin > 2.5, "linearized z RMS {lin}");
    assert!((0.5..1.5).contains(&boot), "bootstrap z RMS {boot}");
    let warned = runs.iter().filter(|(_, r)| warned(r)).count();
    assert!(
        warned >= 6,
        "bootstrap-spread warned in {warned} of 12 runs"
    );
    // The warning names the camera.
    let message = &runs
        .iter()
        .flat_map(|(_, r)| &r.warnings)
        .find(|w| w.code.name() == "bootstrap-spread")
        .unwrap()
        .message;
    assert!(
        message.contains("left c") || message.contains("right c"),
        "{message}"
    );
}

/// brown-conrady5, whose linearized sigmas hold (z RMS 1.0 to 1.2 over 30 seeds): the
/// bootstrap's sigmas of both cameras' fx, fy, cx, cy and of the rig's six parameters agree
/// with them. Over 4 seeds and 14 parameters, the median ratio lies within 0.7 to 1.4: the
/// bootstrap std of 30 resamples has a relative standard error of 13%, and the bootstrap of 20
/// pairs itself scatters by about 15% around the spread it estimates. No run warns.
#[test]
fn brown_conrady5_bootstrap_agrees_with_the_linearized_sigmas() {
    let runs: Vec<_> = (1..=4)
        .map(|seed| run(CameraModel::BrownConrady5, seed, 30))
        .collect();
    let mut ratios: Vec<f64> = runs
        .iter()
        .flat_map(|(set, r)| {
            let b = r.bootstrap.as_ref().unwrap();
            camera_errors(set, r)
                .into_iter()
                .map(|(_, l, b)| b / l)
                .chain((0..6).map(|j| b.rig_std[j] / r.rig_std[j]))
                .collect::<Vec<_>>()
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    let median = (ratios[27] + ratios[28]) / 2.0;
    println!("brown-conrady5 bootstrap / linearized sigma: median {median:.2}, {ratios:.2?}");
    assert!((0.7..1.4).contains(&median), "median ratio {median}");
    for (_, r) in &runs {
        assert!(!warned(r), "{:?}", r.warnings);
        assert!(r.bootstrap.as_ref().unwrap().baseline_std > 0.0);
    }
}

/// The same seed gives the same bootstrap, another seed another one; the result's JSON carries
/// it and reads it back; the summary prints it; without a bootstrap the file has no key.
#[test]
fn bootstrap_is_deterministic_and_round_trips() {
    let (set, options, result) = calibrate(CameraModel::BrownConrady4, 3, 10);
    let settings = BootstrapOptions {
        resamples: 10,
        ..Default::default()
    };
    let a = bootstrap(&set.observations, &options, &result, &settings).unwrap();
    let b = bootstrap(&set.observations, &options, &result, &settings).unwrap();
    assert_eq!(a.left, b.left);
    assert_eq!(a.rig_std, b.rig_std);
    let other = BootstrapOptions {
        seed: 2,
        ..settings
    };
    let c = bootstrap(&set.observations, &options, &result, &other).unwrap();
    assert_ne!(a.left, c.left);
    assert!(
        a.left
            .intrinsics_std
            .iter()
            .chain(&a.right.intrinsics_std)
            .chain(&a.rig_std)
            .all(|s| s.is_finite() && *s > 0.0)
    );
    let mut with = result.clone();
    add_bootstrap(&mut with, &set.observations, &options, &settings).unwrap();
    let json = with.to_json();
    assert_eq!(json["bootstrap"]["resamples"], 10);
    assert!(json["bootstrap"]["left"]["std"]["cx"].as_f64().unwrap() > 0.0);
    assert!(
        json["bootstrap"]["right"]["std"]["distortion"]["k1"]
            .as_f64()
            .is_some()
    );
    assert_eq!(json["bootstrap"]["rig_std"].as_array().unwrap().len(), 6);
    let back = StereoCalibration::from_json(json).unwrap();
    assert_eq!(back.bootstrap, with.bootstrap);
    let summary = with.summary();
    assert!(
        summary.contains("pair bootstrap (10 resamples)"),
        "{summary}"
    );
    assert!(summary.contains("rig: rotation ="), "{summary}");
    assert!(result.to_json().get("bootstrap").is_none());
}

/// Fewer than 10 resamples, fewer than 3 used pairs, a warm start, or a calibration of other
/// observations: typed errors, and the calibration is left unchanged.
#[test]
fn bootstrap_refusals_are_typed_errors() {
    let (set, options, result) = calibrate(CameraModel::BrownConrady4, 1, 6);
    let few = BootstrapOptions {
        resamples: 9,
        ..Default::default()
    };
    let e = bootstrap(&set.observations, &options, &result, &few).unwrap_err();
    assert!(matches!(e, StereoError::Bootstrap(_)), "{e}");
    assert!(e.to_string().contains("at least 10"), "{e}");

    let warm = BootstrapOptions {
        start: calib_single::BootstrapStart::Solution,
        ..Default::default()
    };
    let e = bootstrap(&set.observations, &options, &result, &warm).unwrap_err();
    assert!(matches!(e, StereoError::Bootstrap(_)), "{e}");

    let mut two = result.clone();
    two.pairs.truncate(2);
    let e = bootstrap(
        &set.observations,
        &options,
        &two,
        &BootstrapOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, StereoError::Bootstrap(_)), "{e}");
    assert!(e.to_string().contains("at least 3"), "{e}");

    let mut other = set.observations.clone();
    other.pairs.truncate(3);
    let mut unchanged = result.clone();
    let e = add_bootstrap(
        &mut unchanged,
        &other,
        &options,
        &BootstrapOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, StereoError::Bootstrap(_)), "{e}");
    assert!(e.to_string().contains("not in the observations"), "{e}");
    // (The results hold NaN gain ratios of rejected steps: compared by their JSON form.)
    assert!(unchanged.bootstrap.is_none());
    assert_eq!(unchanged.to_json(), result.to_json());
}

/// Six pairs: the bootstrap runs, and a `poorly-determined` warning says it is rough (a
/// resample holds about 4 distinct pairs); twelve pairs: no such warning.
#[test]
fn a_bootstrap_over_few_pairs_is_warned_rough() {
    let rough = |pairs: usize| {
        let (set, options, mut result) = calibrate(CameraModel::BrownConrady4, 1, pairs);
        let settings = BootstrapOptions {
            resamples: 10,
            ..Default::default()
        };
        add_bootstrap(&mut result, &set.observations, &options, &settings).unwrap();
        result
            .warnings
            .iter()
            .find(|w| w.message.contains("pair bootstrap over"))
            .map(|w| (w.code.name(), w.message.clone()))
    };
    let (code, message) = rough(6).expect("no warning over 6 pairs");
    assert_eq!(code, "poorly-determined");
    assert!(
        message.contains("over 6 pairs is rough") && message.contains("about 4 distinct"),
        "{message}"
    );
    assert!(rough(12).is_none());
}

/// The captures users bring, not the generator's default boards: pairs of the stereo
/// population (3 to 40 pairs, largest tilts from 5 degrees, principal points off the centre,
/// three board sizes, noise 0.05 to 1 px) with rational8 cameras. Each bootstrap either gives
/// finite, non-negative sigmas for every parameter (positive for the intrinsics and the rig)
/// over most of its resamples, or is refused with a typed error (too few pairs or refits);
/// never a panic or NaN.
#[test]
fn the_bootstrap_of_population_captures_is_finite_or_refused() {
    let (mut done, mut refused) = (0, 0);
    for seed in 0..8 {
        let mut config = calib_stereo::synthetic::population(seed);
        config.left.model = CameraModel::Rational8;
        config.left.distortion = default_distortion(CameraModel::Rational8);
        config.right_model = CameraModel::Rational8;
        config.right_distortion = config.left.distortion.clone();
        let Ok(set) = generate_stereo(&config) else {
            continue;
        };
        let mut options = StereoOptions::default();
        options.left.model = CameraModel::Rational8;
        options.right.model = CameraModel::Rational8;
        let Ok(result) = calibrate_stereo(&set.observations, &options) else {
            continue;
        };
        let settings = BootstrapOptions {
            resamples: 10,
            ..Default::default()
        };
        match bootstrap(&set.observations, &options, &result, &settings) {
            Ok(b) => {
                done += 1;
                assert!(
                    b.failed <= 5,
                    "seed {seed}: {} of 10 refits failed",
                    b.failed
                );
                for s in [&b.left, &b.right] {
                    assert!(
                        s.intrinsics_std.iter().all(|v| v.is_finite() && *v > 0.0),
                        "seed {seed}: {:?}",
                        s.intrinsics_std
                    );
                    assert!(
                        s.distortion_std.iter().all(|v| v.is_finite() && *v >= 0.0),
                        "seed {seed}: {:?}",
                        s.distortion_std
                    );
                }
                assert!(
                    b.rig_std.iter().all(|v| v.is_finite() && *v > 0.0),
                    "seed {seed}: {:?}",
                    b.rig_std
                );
                assert!(b.baseline_std.is_finite() && b.baseline_std > 0.0);
            }
            Err(e) => {
                assert!(matches!(e, StereoError::Bootstrap(_)), "seed {seed}: {e}");
                refused += 1;
            }
        }
    }
    println!("population captures: {done} bootstrapped, {refused} refused");
    assert!(done >= 4, "{done} bootstrapped, {refused} refused");
}
