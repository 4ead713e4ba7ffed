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
//! its points is not a view with a few bad corners but a wrong one, and is reported.
//!
//! Cost: one extra solve, warm-started from the previous solution (a few iterations), per round
//! in which the rejected set changes; none on clean data.

use crate::problem::JointProblem;
use nalgebra::Vector2;

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

/// The robust per-axis noise level of each camera, pixels: `median |e| / sqrt(2 ln 2)` over the
/// points with a positive user weight.
pub fn robust_sigma(problem: &JointProblem, residuals: &[Vec<Vector2<f64>>]) -> Vec<f64> {
    (0..problem.cameras.len())
        .map(|c| {
            let mut norms: Vec<f64> = problem
                .observations
                .iter()
                .zip(residuals)
                .filter(|(o, _)| o.camera == c)
                .flat_map(|(o, e)| {
                    e.iter()
                        .enumerate()
                        .filter(|(i, _)| o.weights.as_ref().is_none_or(|w| w[*i] > 0.0))
                        .map(|(_, e)| e.norm())
                })
                .collect();
            median(&mut norms) / RAYLEIGH_MEDIAN
        })
        .collect()
}

/// Which points of each observation `options` rejects given `residuals` (`true`: rejected).
/// Points with a zero user weight are never marked: they are not used either way.
pub fn mark(
    problem: &JointProblem,
    residuals: &[Vec<Vector2<f64>>],
    options: &OutlierRejection,
) -> Vec<Vec<bool>> {
    let thresholds: Vec<f64> = robust_sigma(problem, residuals)
        .into_iter()
        .map(|s| (options.threshold_sigmas * s).max(options.min_threshold_px))
        .collect();
    problem
        .observations
        .iter()
        .zip(residuals)
        .map(|(o, e)| {
            e.iter()
                .enumerate()
                .map(|(i, e)| {
                    let used = o.weights.as_ref().is_none_or(|w| w[i] > 0.0);
                    // False for NaN errors (a point the model cannot project): outliers too.
                    let within = e.norm() <= thresholds[o.camera];
                    used && !within
                })
                .collect()
        })
        .collect()
}

/// `problem` with the rejected points' weights set to zero (other weights kept).
pub(crate) fn apply(problem: &mut JointProblem, rejected: &[Vec<bool>]) {
    for (o, r) in problem.observations.iter_mut().zip(rejected) {
        if r.iter().any(|&r| r) {
            let mut w = o.weights.clone().unwrap_or_else(|| vec![1.0; r.len()]);
            for (w, &r) in w.iter_mut().zip(r) {
                if r {
                    *w = 0.0;
                }
            }
            o.weights = Some(w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::{CameraSpec, ObservationSpec};
    use crate::{ImageSize, JointProblem};
    use camera_model::{AnyCamera, CameraModel, Intrinsics, Pose};
    use nalgebra::Point3;

    fn problem(n: usize) -> JointProblem {
        let camera = AnyCamera::new(
            CameraModel::default(),
            Intrinsics::new(500.0, 500.0, 320.0, 240.0),
            vec![0.0; 4],
        )
        .unwrap();
        JointProblem {
            cameras: vec![CameraSpec::new("c", ImageSize::new(640, 480), camera)],
            reference: 0,
            rig: vec![Pose::identity()],
            rig_fixed: vec![true],
            frames: vec![Pose::identity()],
            frame_names: vec!["view 0".into()],
            observations: vec![ObservationSpec::new(
                0,
                0,
                "v",
                vec![Point3::origin(); n],
                vec![Vector2::zeros(); n],
            )],
        }
    }

    #[test]
    fn the_rayleigh_median_recovers_the_noise_level() {
        // Errors with |e| spread like a Rayleigh(0.3): quantiles of the distribution.
        let n = 2001;
        let p = problem(n);
        let sigma = 0.3;
        let e: Vec<Vector2<f64>> = (0..n)
            .map(|i| {
                let q = (i as f64 + 0.5) / n as f64;
                let r = sigma * (-2.0 * (1.0 - q).ln()).sqrt();
                Vector2::new(r, 0.0)
            })
            .collect();
        let s = robust_sigma(&p, &[e]);
        assert!((s[0] - sigma).abs() < 1e-3, "{}", s[0]);
    }

    #[test]
    fn far_points_and_nan_are_marked_and_masked_points_are_not() {
        let mut p = problem(6);
        let mut w = vec![1.0; 6];
        w[5] = 0.0;
        p.observations[0].weights = Some(w);
        let e = vec![
            Vector2::new(0.1, 0.0),
            Vector2::new(0.0, 0.12),
            Vector2::new(0.09, 0.0),
            Vector2::new(40.0, 0.0),
            Vector2::new(f64::NAN, 0.0),
            Vector2::new(100.0, 0.0),
        ];
        let marked = mark(&p, &[e], &OutlierRejection::default());
        assert_eq!(marked[0], vec![false, false, false, true, true, false]);
        apply(&mut p, &marked);
        assert_eq!(
            p.observations[0].weights.as_deref(),
            Some(&[1.0, 1.0, 1.0, 0.0, 0.0, 0.0][..])
        );
    }
}
