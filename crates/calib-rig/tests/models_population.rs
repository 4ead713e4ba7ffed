//! Rigs of the lens models users bring, beyond the `brown-conrady4` population of
//! `convergence_population.rs`: fisheye rigs (100 to 190 degrees), and rigs mixing `rational8`
//! with polynomial cameras, whose joint stage crawled along the rational valley to the
//! iteration limit before it got the stagnation rule (`calib_core::single::joint_stage_solver`).
//! Each rig is calibrated from the default start and, as the reference, by the same joint
//! optimization from the truth (no outlier rejection on either side). Not timed; split over two
//! threads.

use calib_core::SolveOptions;
use calib_core::data::ImageSize;
use calib_core::synthetic::fisheye_distortion;
use calib_rig::synthetic::{SyntheticRigConfig, generate_rig, population};
use calib_rig::{RigOptions, calibrate_rig, rig_problem};
use calib_test_support::{Outcome, ended, judge, reference_from_truth, sweep};
use camera_model::{CameraModel, Intrinsics};
use lm_solver::Rng;

/// Rigs per sweep (`CALIB_MODELS_POPULATION=N` for more).
fn problems() -> u64 {
    std::env::var("CALIB_MODELS_POPULATION")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(16)
}

/// A rig of the population whose cameras are fisheyes of 100 to 190 degrees diagonal (the first
/// camera's focal length from the field, the others within 15% of it), 1280x960 images.
fn fisheye_rig(seed: u64) -> SyntheticRigConfig {
    let mut config = population(seed);
    let mut rng = Rng::new(0xAB_0000 + seed);
    let fov = rng.range(100.0, 190.0);
    let size = ImageSize::new(1280, 960);
    let f = size.half_diagonal() / (fov.to_radians() / 2.0);
    let (cx, cy) = size.centre();
    config.base.image_size = size;
    config.base.intrinsics = Intrinsics::new(
        f,
        f * rng.range(0.99, 1.01),
        cx + rng.range(-20.0, 20.0),
        cy + rng.range(-20.0, 20.0),
    );
    config.base.model = CameraModel::KannalaBrandt4;
    config.base.distortion = fisheye_distortion(&mut rng);
    config.base.square = 30.0;
    config.models = vec![CameraModel::KannalaBrandt4];
    config
}

/// A rig of the population whose cameras are, in turn, `brown-conrady5`, `brown-conrady4` and
/// `rational8` (the default synthetic coefficients scaled by 0.7 to 1.3 per camera): narrow
/// rational8 cameras, whose k1..k6 the views do not determine.
fn mixed_rig(seed: u64) -> SyntheticRigConfig {
    let mut config = population(seed);
    config.models = vec![
        CameraModel::BrownConrady5,
        CameraModel::BrownConrady4,
        CameraModel::Rational8,
    ];
    config
}

/// The outcome of `config`'s rig from the default start against the truth start, and the
/// amount (px) by which its RMS exceeds the reference's.
fn outcome(seed: u64, config: &SyntheticRigConfig) -> (Outcome, f64) {
    let Ok(set) = generate_rig(config) else {
        return (Outcome::NotGenerated, 0.0);
    };
    let problem = rig_problem(
        &set.observations,
        &set.cameras,
        &set.transforms,
        &set.frame_poses,
        0,
    );
    let mut solve = SolveOptions::default();
    solve.outliers = None;
    solve.compute_uncertainty = false;
    let what = format!(
        "seed {seed} ({} cameras, {} frames, tilt {:.1} deg, noise {:.2} px)",
        config.cameras, config.frames, config.base.max_tilt_deg, config.base.noise_px
    );
    let mut ours = RigOptions::default();
    ours.outliers = None;
    ours.models = set.cameras.iter().map(|c| Some(c.model)).collect();
    let reference = match reference_from_truth(&what, calib_core::solve(&problem, &solve), || {
        calibrate_rig(&set.observations, &ours).is_err()
    }) {
        Ok(r) => r,
        Err(outcome) => return (outcome, 0.0),
    };
    let (used, sum) = reference
        .errors
        .iter()
        .fold((0, 0.0), |(n, s), e| (n + e.used, s + e.sum_sq));
    let reference_rms = (sum / used as f64).sqrt();
    let result = calibrate_rig(&set.observations, &ours).map(|r| {
        ended(
            r.rms,
            r.solver.termination.is_converged(),
            r.solver.termination,
        )
    });
    let excess = result.as_ref().map_or(0.0, |r| r.0 - reference_rms);
    (judge(&what, result, reference_rms, 1e-5), excess)
}

/// Fisheye rigs of 3 to 8 cameras: every one reaches the truth start's minimum (measured: 200
/// of 200 rigs, `CALIB_MODELS_POPULATION=200`).
#[test]
fn fisheye_rigs_reach_the_true_minimum() {
    let n = problems();
    let all = sweep(n, |seed| outcome(seed, &fisheye_rig(seed)).0);
    println!("{}", all.report("fisheye rigs"));
    assert!(all.not_generated < n as usize / 5);
    assert_eq!(all.at_minimum + all.not_generated, n as usize);
}

/// Rigs mixing rational8 with polynomial cameras do not crawl to the iteration limit: the
/// sweep's first rigs and four that did (seeds 34, 60, 68, 73; before the rule 14 of 196 rigs
/// over 200 seeds, now none). The rule costs at most a few thousandths of a pixel where it
/// ends a crawl that would have gone on: over those 196 rigs the RMS rose by a median of 1e-9
/// px, 95th percentile 8e-5 px, at most 5.1e-3 px (noise 0.05 to 1 px); the bound here is 0.01
/// px above the truth start's minimum.
#[test]
fn rigs_mixing_rational8_do_not_crawl_to_the_iteration_limit() {
    let seeds: Vec<u64> = [34, 60, 68, 73].into_iter().chain(0..problems()).collect();
    let all = sweep(seeds.len() as u64, |i| {
        let seed = seeds[i as usize];
        match outcome(seed, &mixed_rig(seed)) {
            // Higher minima of the valley within the bound count as reached here.
            (Outcome::Above(_), excess) if excess < 0.01 => Outcome::AtMinimum,
            (outcome, _) => outcome,
        }
    });
    println!("{}", all.report("rigs mixing rational8"));
    assert_eq!(
        all.at_minimum + all.not_generated + all.not_determined,
        seeds.len(),
        "{}",
        all.report("rigs mixing rational8")
    );
}
