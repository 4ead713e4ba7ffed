//! Shared helpers for the workspace benchmarks (`benches/*.rs`) and the damping-policy study
//! (`examples/damping_study.rs`). Results and commands: `docs/benchmarks-solver.md`.
//!
//! * [`synthetic`]: seeded single-camera data sets (640x480 camera of `SyntheticConfig::default`,
//!   0.2 px noise) for a number of views and a board size.
//! * [`CalibrationProblem`]: the Levenberg-Marquardt problem `calib_single::calibrate` builds (one
//!   camera block of 8 in the reduced system, one eliminated pose block of 6 per view, one
//!   residual block of `2 N` rows per view), with the same closed-form start, so the solver core
//!   can be timed without the rest of the pipeline.
//! * [`single_thread_options`], [`single_thread_solver_options`]: everything on one thread.
//! * [`windowed_bearing_adjustment`]: a bundle-adjustment problem with sparse visibility.

use calib_core::{JointCost, JointProblem, View};
use calib_single::synthetic::{SyntheticConfig, SyntheticSet, generate};
use calib_single::{CalibrationOptions, Observations, default_solver_options};
use camera_model::EulerXyz;
use lm_solver::test_problems::BearingAdjustment;
use lm_solver::{Problem, Solver, SolverOptions};

/// The two boards of the benchmarks: `(columns, rows)` of inner corners.
pub const BOARD_9X6: (usize, usize) = (9, 6);
/// 400 points per view.
pub const BOARD_20X20: (usize, usize) = (20, 20);

/// Pixel noise of every synthetic benchmark problem.
pub const NOISE_PX: f64 = 0.2;

/// A seeded synthetic single-camera set: `views` views of a `board` (columns, rows) board, 0.2 px
/// noise, boards tilted up to `max_tilt_deg`, otherwise `SyntheticConfig::default()`.
pub fn synthetic(
    views: usize,
    board: (usize, usize),
    max_tilt_deg: f64,
    seed: u64,
) -> SyntheticSet {
    generate(&SyntheticConfig {
        views,
        board_cols: board.0,
        board_rows: board.1,
        noise_px: NOISE_PX,
        max_tilt_deg,
        seed,
        ..Default::default()
    })
    .expect("synthetic benchmark set")
}

/// Calibration's default solver settings on one thread.
pub fn single_thread_solver_options() -> SolverOptions {
    {
        let mut o = default_solver_options();
        o.num_threads = 1;
        o
    }
}

/// `CalibrationOptions::default()` on one thread.
pub fn single_thread_options() -> CalibrationOptions {
    {
        let mut o = CalibrationOptions::default();
        o.solver = single_thread_solver_options();
        o
    }
}

/// The single-camera Levenberg-Marquardt problem exactly as `calib_single::calibrate` builds it
/// with default options (Brown-Conrady `k1, k2, p1, p2`, Euler X-Y-Z poses), with its closed-form
/// start: the engine's single-camera [`JointProblem`] and the solver problem and start vector
/// `calib_core::solve` builds from it, so the solver core can be timed without the rest of the
/// pipeline.
#[derive(Debug, Clone)]
pub struct CalibrationProblem {
    /// The engine's problem description (one camera, one frame per view).
    pub joint: JointProblem,
    /// Camera block, then one eliminated pose block per view with one residual block each.
    pub problem: Problem,
    /// The closed-form start (homographies, Bouguet focal length, poses from `K^-1 H`).
    pub start: Vec<f64>,
    /// Total number of observed points.
    pub num_points: usize,
}

impl CalibrationProblem {
    /// Builds the problem and its start from observations (all views must be usable).
    pub fn new(observations: &Observations) -> Self {
        let views: Vec<(usize, &View)> = observations.views.iter().enumerate().collect();
        let prepared =
            calib_core::prepare_camera(&views, observations.image_size, &single_thread_options())
                .expect("valid calibration problem");
        let joint = prepared.problem("camera");
        let (problem, start) = calib_core::solve::solver_problem::<EulerXyz>(
            &joint,
            &calib_core::SolveOptions::default(),
        )
        .expect("valid solver problem");
        Self {
            num_points: prepared.num_points(),
            joint,
            problem,
            start,
        }
    }

    /// The reprojection cost over these views.
    pub fn cost(&self) -> JointCost<'_, EulerXyz> {
        JointCost::new(&self.joint)
    }

    /// A solver prepared for this problem.
    pub fn solver(&self, options: SolverOptions) -> Solver {
        Solver::new(self.problem.clone(), options).expect("solver setup")
    }
}

/// `BearingAdjustment::generate(cameras, landmarks, noise, seed)` with sparse visibility: landmark
/// `l` is seen only by the `window` consecutive cameras `l, l + 1, ..., l + window - 1` (modulo
/// the number of cameras; cameras are ordered around the circle), so the reduced camera system
/// is block-banded (cyclically) instead of dense, as in real bundle adjustment.
pub fn windowed_bearing_adjustment(
    cameras: usize,
    landmarks: usize,
    window: usize,
    noise: f64,
    seed: u64,
) -> BearingAdjustment {
    let mut ba = BearingAdjustment::generate(cameras, landmarks, noise, seed);
    let window = window.min(cameras);
    ba.observations
        .retain(|&(c, l, _)| (c + cameras - l % cameras) % cameras < window);
    ba
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hand-built problem is the one `calibrate` solves: same start RMS, same solution.
    #[test]
    fn calibration_problem_matches_calibrate() {
        let set = synthetic(12, BOARD_9X6, 45.0, 3);
        let p = CalibrationProblem::new(&set.observations);
        let options = single_thread_options();
        let reference = calib_single::calibrate(&set.observations, &options).unwrap();
        let mut solver = p.solver(options.solver.clone());
        let mut x = p.start.clone();
        let report = solver.solve(&p.cost(), &mut x).unwrap();
        assert_eq!(report.initial_cost, reference.solver.initial_cost);
        assert_eq!(report.final_cost, reference.solver.final_cost);
        assert_eq!(report.iterations.len(), reference.solver.iterations.len());
        let rms = (2.0 * report.final_cost / p.num_points as f64).sqrt();
        assert!((rms - reference.rms).abs() <= 1e-12 * reference.rms);
    }

    #[test]
    fn windowed_bearing_adjustment_sees_each_landmark_window_times() {
        let ba = windowed_bearing_adjustment(10, 25, 4, 1e-3, 1);
        assert_eq!(ba.observations.len(), 25 * 4);
        for l in 0..25 {
            let seen: Vec<usize> = ba
                .observations
                .iter()
                .filter(|o| o.1 == l)
                .map(|o| o.0)
                .collect();
            let expected: Vec<usize> = {
                let mut v: Vec<usize> = (0..4).map(|k| (l + k) % 10).collect();
                v.sort_unstable();
                v
            };
            assert_eq!(seen, expected, "landmark {l}");
        }
    }
}
