//! The rig convergence sweep (issue 14) over `calib_rig::synthetic::population`: 3 to 8 cameras
//! on rings or lines, partial overlap, per-camera intrinsics, the single-camera population's
//! boards, tilts and noise. Each problem is calibrated from the default start and, as the
//! reference, from the truth (every camera, transform and frame pose); the goal is no refusal, no
//! iteration-limit stop and no result above the true minimum by more than 1e-5 px. Not timed;
//! split over two threads.

use calib_core::SolveOptions;
use calib_rig::synthetic::{generate_rig, population};
use calib_rig::{RigOptions, calibrate_rig, rig_problem};
use calib_test_support::{Outcome, ended, judge, reference_from_truth, sweep};

fn problem(seed: u64) -> Outcome {
    let config = population(seed);
    let Ok(set) = generate_rig(&config) else {
        return Outcome::NotGenerated;
    };
    // The reference: the same joint optimization (no outlier rejection on either side, so both
    // minimize the same cost) started from the truth.
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
    let reference = match reference_from_truth(&what, calib_core::solve(&problem, &solve), || {
        calibrate_rig(&set.observations, &ours).is_err()
    }) {
        Ok(r) => r,
        Err(outcome) => return outcome,
    };
    let (used, sum) = reference
        .errors
        .iter()
        .fold((0, 0.0), |(n, s), e| (n + e.used, s + e.sum_sq));
    let reference_rms = (sum / used as f64).sqrt();
    let ours = calibrate_rig(&set.observations, &ours).map(|r| {
        ended(
            r.rms,
            r.solver.termination.is_converged(),
            r.solver.termination,
        )
    });
    judge(&what, ours, reference_rms, 1e-5)
}

#[test]
fn every_rig_of_the_population_reaches_the_true_minimum() {
    let problems: u64 = std::env::var("RIG_POPULATION")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(300);
    let all = sweep(problems, problem);
    println!("{}", all.report("rigs"));
    assert!(all.not_generated < problems as usize / 10);
    assert_eq!(
        all.at_minimum + all.not_generated + all.not_determined,
        problems as usize
    );
}
