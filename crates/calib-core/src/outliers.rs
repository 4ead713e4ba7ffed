//! Outlier rejection: points whose reprojection error is far beyond the noise are left out and
//! the problem is solved again, until the set of rejected points stops changing.
//!
//! The noise level is estimated robustly per camera from the point errors `|e|` of the used
//! points: with isotropic Gaussian noise of standard deviation `sigma` per axis, `|e|` follows a
//! Rayleigh distribution whose median is `sigma sqrt(2 ln 2)`, so `sigma = median |e| / 1.1774`.
//! A point is rejected when `|e| > max(k sigma, min_threshold_px)` (default `k = 5`: a Gaussian
//! point exceeds it with probability `exp(-k^2 / 2) = 4e-6`, so clean data loses nothing; and
//! 1 px: a model's systematic errors on real data reach most of a pixel, a mis-detected corner
//! is pixels off). Every
//! point is re-tested each round, so a point rejected early (or suspected by the robust
//! homography) comes back when the calibrated model fits it. A view that loses more than half of
//! its points in the final rejected set is not a view with a few bad corners but a wrong one, and
//! is reported. Before a further round, a view past that limit has its pose refitted alone,
//! robustly, with the cameras held (its own stray corners may have pulled it; `solve.rs`,
//! `refit_poses`).
//!
//! Cost: one extra solve, warm-started from the previous solution (a few iterations), per round
//! in which the rejected set changes; none on clean data.

use crate::problem::JointProblem;
use crate::solve::JointSolution;

/// `sqrt(2 ln 2)`: the median of a Rayleigh distribution with unit scale.
const RAYLEIGH_MEDIAN: f64 = 1.177_410_022_515_474_7;

/// Settings of the outlier rejection.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct OutlierRejection {
    /// Reject points whose error exceeds this many robust standard deviations of the noise
    /// (default 5).
    pub threshold_sigmas: f64,
    /// ... and this many pixels (default 1: errors below a pixel are never outliers. On real
    /// captures the largest errors of an adequate model are often systematic, e.g. 0.5 to 0.8 px
    /// at the board's corners with `k3` held at zero, five to eight robust sigmas; rejecting them
    /// would hide a model error, not remove a mis-detection, which is pixels off).
    pub min_threshold_px: f64,
    /// At most this many re-solves (default 5).
    pub max_rounds: usize,
    /// A view (one camera's observation in one frame) losing more than this fraction of its
    /// points is reported as wrong instead (default 0.5).
    pub max_view_fraction: f64,
}

impl Default for OutlierRejection {
    fn default() -> Self {
        Self {
            threshold_sigmas: 5.0,
            min_threshold_px: 1.0,
            max_rounds: 5,
            max_view_fraction: 0.5,
        }
    }
}

impl OutlierRejection {
    /// Rejection with threshold `k` robust standard deviations and the other defaults.
    pub fn with_threshold(k: f64) -> Self {
        Self {
            threshold_sigmas: k,
            ..Self::default()
        }
    }
}

fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mid = values.len() / 2;
    values.select_nth_unstable_by(mid, f64::total_cmp);
    values[mid]
}

/// Above this many points per camera the noise level is estimated on an evenly strided sample of
/// about this size (the median's relative error is about `1 / sqrt(n)`, 0.5%, far below what the
/// threshold needs).
pub const MEDIAN_SAMPLE: usize = 40_000;

/// The robust per-axis noise level (pixels) of error norms `|e|`: `median |e| / sqrt(2 ln 2)`.
/// Reorders `norms`.
pub fn noise_sigma(norms: &mut [f64]) -> f64 {
    median(norms) / RAYLEIGH_MEDIAN
}

/// The rejection threshold (pixels) of each camera of a solution: `max(k sigma, floor)`.
pub fn thresholds(solution: &JointSolution, options: &OutlierRejection) -> Vec<f64> {
    solution
        .noise_sample
        .iter()
        .map(|sample| {
            let sigma = noise_sigma(&mut sample.clone());
            (options.threshold_sigmas * sigma).max(options.min_threshold_px)
        })
        .collect()
}

/// The points (per observation, sorted indices) that `options` rejects at `solution`: the
/// candidates above the floor whose error also exceeds their camera's threshold. Points with a
/// zero user weight are never marked: they are not used either way.
pub(crate) fn mark(
    problem: &JointProblem,
    solution: &JointSolution,
    options: &OutlierRejection,
) -> Vec<Vec<usize>> {
    let thresholds = thresholds(solution, options);
    let mut marked = vec![Vec::new(); problem.observations.len()];
    for &(o, point, norm) in &solution.outlier_candidates {
        let within = norm <= thresholds[problem.observations[o].camera];
        if !within {
            marked[o].push(point);
        }
    }
    for m in &mut marked {
        m.sort_unstable();
    }
    marked
}

/// `problem` with the rejected points' weights set to zero (other weights kept).
pub(crate) fn apply(problem: &mut JointProblem, rejected: &[Vec<usize>]) {
    for (o, r) in problem.observations.iter_mut().zip(rejected) {
        if !r.is_empty() {
            let mut w = o
                .weights
                .clone()
                .unwrap_or_else(|| vec![1.0; o.object.len()]);
            for &i in r {
                w[i] = 0.0;
            }
            o.weights = Some(w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rayleigh_median_recovers_the_noise_level() {
        // Norms spread like a Rayleigh(0.3): quantiles of the distribution.
        let n = 2001;
        let sigma = 0.3;
        let mut norms: Vec<f64> = (0..n)
            .map(|i| {
                let q = (i as f64 + 0.5) / n as f64;
                sigma * (-2.0 * (1.0 - q).ln()).sqrt()
            })
            .collect();
        let s = noise_sigma(&mut norms);
        assert!((s - sigma).abs() < 1e-3, "{s}");
    }

    #[test]
    fn rejected_points_get_zero_weight_and_other_weights_stay() {
        use crate::problem::{CameraSpec, ObservationSpec};
        use camera_model::{AnyCamera, CameraModel, Intrinsics, Pose};
        use nalgebra::{Point3, Vector2};
        let camera = AnyCamera::new(
            CameraModel::default(),
            Intrinsics::new(500.0, 500.0, 320.0, 240.0),
            vec![0.0; 4],
        )
        .unwrap();
        let mut o = ObservationSpec::new(
            0,
            0,
            "v",
            vec![Point3::origin(); 4],
            vec![Vector2::zeros(); 4],
        );
        o.weights = Some(vec![1.0, 0.5, 1.0, 0.0]);
        let mut problem = JointProblem {
            cameras: vec![CameraSpec::new(
                "c",
                crate::ImageSize::new(640, 480),
                camera,
            )],
            reference: 0,
            rig: vec![Pose::identity()],
            rig_fixed: vec![true],
            frames: vec![Pose::identity()],
            frame_names: vec!["view 0".into()],
            observations: vec![o],
        };
        apply(&mut problem, &[vec![0, 2]]);
        assert_eq!(
            problem.observations[0].weights.as_deref(),
            Some(&[0.0, 0.5, 0.0, 0.0][..])
        );
    }
}
