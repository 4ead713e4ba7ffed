//! Stereo pairs of the lens models users bring, beyond the `brown-conrady4` population of
//! `convergence_population.rs`: fisheye pairs from 60 to 190 degrees, and pairs of narrow
//! `rational8` cameras, whose joint stage crawled along the rational valley to the iteration
//! limit before it got the stagnation rule (`calib_core::single::joint_stage_solver`). Each
//! problem is calibrated from the default start and, as the reference, from the truth (both
//! cameras and the rig). Not timed; split over two threads.

use calib_core::synthetic::{default_distortion, fisheye_distortion, fisheye_population};
use calib_stereo::synthetic::{SyntheticStereoConfig, generate_stereo, population};
use calib_stereo::{StereoOptions, calibrate_stereo};
use calib_test_support::{Outcome, ended, judge, sweep};
use camera_model::{CameraModel, EulerXyz, Intrinsics, Pose, RotationParameterization};
use lm_solver::Rng;
use nalgebra::Vector3;

/// Problems per sweep (`CALIB_MODELS_POPULATION=N` for more).
fn problems() -> u64 {
    std::env::var("CALIB_MODELS_POPULATION")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(60)
}

/// A fisheye pair: the left camera of [`fisheye_population`] (field of view `fov_deg`), the
/// right one of a field within 10% of it, 0.2 to 0.8 board widths apart and turned by up to 30
/// degrees about each axis.
fn fisheye_pair(seed: u64, fov_deg: f64) -> SyntheticStereoConfig {
    let left = fisheye_population(seed, fov_deg);
    let mut rng = Rng::new(0x5F15_E000 + seed);
    let size = left.image_size;
    let f = size.half_diagonal() / (fov_deg * rng.range(0.9, 1.1)).to_radians() * 2.0;
    let (cx, cy) = size.centre();
    let right_intrinsics = Intrinsics::new(
        f,
        f * rng.range(0.99, 1.01),
        cx + rng.range(-20.0, 20.0),
        cy + rng.range(-20.0, 20.0),
    );
    let right_distortion = fisheye_distortion(&mut rng);
    let baseline = rng.range(0.2, 0.8) * (left.board_cols - 1) as f64 * left.square;
    let angle = 30f64.to_radians();
    let mut turn = || rng.range(-angle, angle);
    let rotation = EulerXyz::matrix(&Vector3::new(turn(), turn(), turn()));
    let rig = Pose::new(
        rotation,
        Vector3::new(
            -baseline,
            rng.range(-0.05, 0.05) * baseline,
            rng.range(-0.05, 0.05) * baseline,
        ),
    );
    SyntheticStereoConfig {
        right_model: CameraModel::KannalaBrandt4,
        right_image_size: size,
        left,
        right_intrinsics,
        right_distortion,
        rig,
    }
}

/// The rational model of [`rational_pair`]: `rational8`, or `thin-prism12` with
/// `CALIB_MODELS_RATIONAL=thin-prism12`.
fn rational_model() -> CameraModel {
    match std::env::var("CALIB_MODELS_RATIONAL").as_deref() {
        Ok("thin-prism12") => CameraModel::ThinPrism12,
        _ => CameraModel::Rational8,
    }
}

/// A pair of the stereo population with cameras of the rational `model` (the default synthetic
/// coefficients, the right camera's scaled by 0.8): narrow lenses, whose k1..k6 the views do not
/// determine.
fn rational_pair(seed: u64, model: CameraModel) -> SyntheticStereoConfig {
    let mut config = population(seed);
    config.left.model = model;
    config.left.distortion = default_distortion(model);
    config.right_model = model;
    config.right_distortion = config.left.distortion.iter().map(|d| d * 0.8).collect();
    config
}

/// Calibrates `config`'s data from the default start and judges it against the truth start's
/// result; [`Outcome::NotDetermined`] when the truth start is refused (a pole of the rational
/// model or a pose the data leaves free: no reference to judge by).
fn outcome(seed: u64, config: &SyntheticStereoConfig) -> Outcome {
    let Ok(set) = generate_stereo(config) else {
        return Outcome::NotGenerated;
    };
    let mut options = StereoOptions::default();
    options.left.model = config.left.model;
    options.right.model = config.right_model;
    let mut truth = options.clone();
    truth.left.intrinsic_guess = Some(set.left.intrinsics);
    truth.left.distortion_guess = Some(set.left.distortion.clone());
    truth.right.intrinsic_guess = Some(set.right.intrinsics);
    truth.right.distortion_guess = Some(set.right.distortion.clone());
    truth.rig_guess = Some(set.rig);
    let Ok(reference) = calibrate_stereo(&set.observations, &truth) else {
        return Outcome::NotDetermined;
    };
    let what = format!(
        "seed {seed} ({}, fx {:.0}, {} pairs, tilt {:.1} deg, noise {:.2} px)",
        config.left.model.name(),
        config.left.intrinsics.fx,
        config.left.views,
        config.left.max_tilt_deg,
        config.left.noise_px
    );
    let ours = calibrate_stereo(&set.observations, &options).map(|r| {
        ended(
            r.rms_all_points,
            r.solver.termination.is_converged(),
            r.solver.termination,
        )
    });
    judge(&what, ours, reference.rms_all_points, 1e-5)
}

/// Fisheye pairs over 60 to 190 degrees, the cameras turned by up to 30 degrees: each reaches
/// the truth start's minimum (`CALIB_MODELS_POPULATION=200`: 185 of 185; the other 15 draws
/// could not be generated, the board not seen whole by both cameras).
#[test]
fn fisheye_pairs_from_60_to_190_degrees_reach_the_true_minimum() {
    let n = problems();
    let all = sweep(n, |seed| {
        // Fields of view spread over 60 to 190 degrees, in an order unrelated to the seed.
        let fov = 60.0 + 130.0 * ((seed * 37) % n) as f64 / (n - 1) as f64;
        outcome(seed, &fisheye_pair(seed, fov))
    });
    println!("{}", all.report("fisheye pairs"));
    assert!(all.not_generated < n as usize / 5);
    assert_eq!(all.at_minimum + all.not_generated, n as usize);
}

/// Pairs of narrow `rational8` cameras: the joint stage does not crawl along the rational
/// valley to the iteration limit. Before the stagnation rule 10 of these 60 pairs did (36 of
/// 195 over 200 seeds), now 2 (4 of 195: walks that keep lowering the cost for 500
/// iterations); the bound is 5% of the pairs. `thin-prism12` pairs
/// (`CALIB_MODELS_RATIONAL=thin-prism12`): 37 of 100 before, 9 now; the bound 15%. Where the
/// rule ends a crawl the RMS is higher than at the crawl's end by a median of 1e-8 px (95th
/// percentile 4e-4 px, at most 1.1e-3 px; docs/calib-stereo.md). Higher minima of the valley
/// (the truth start's lower by more than 1e-5 px) are counted, not failed: single cameras with
/// undetermined rational terms end in them as well (docs/camera-model.md, Convergence).
#[test]
fn rational8_pairs_do_not_crawl_to_the_iteration_limit() {
    let n = problems() as usize;
    let model = rational_model();
    let all = sweep(n as u64, |seed| outcome(seed, &rational_pair(seed, model)));
    let what = format!("{} pairs", model.name());
    println!("{}", all.report(&what));
    let limit = match model {
        CameraModel::ThinPrism12 => 3.max(n * 15 / 100),
        _ => 3.max(n / 20),
    };
    assert!(all.iteration_limit.len() <= limit, "{}", all.report(&what));
    assert!(all.refused.len() <= 2.max(n / 30), "{}", all.report(&what));
}
