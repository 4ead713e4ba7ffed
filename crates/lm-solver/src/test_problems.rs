//! Synthetic problems with known answers for the solver's tests and the workspace benchmarks
//! (enabled by the `test-problems` feature; production code never needs them).
//!
//! * [`BearingAdjustment`]: 2D bundle adjustment (cameras observe landmarks by bearing angle), the
//!   shape of bundle adjustment with landmarks eliminated by the Schur complement.
//! * [`PoseGraph`]: a 2D pose graph (odometry and loop closures), where nothing is eliminated.

use crate::cost::{CostFunction, EvaluationError, JacobianBlocks};
use crate::problem::{ParameterBlockId, Problem, ProblemBuilder, ResidualBlockId};
pub use crate::rng::Rng;
use std::f64::consts::PI;

/// Wraps an angle to `(-pi, pi]`.
pub fn wrap_angle(a: f64) -> f64 {
    let mut a = a % (2.0 * PI);
    if a > PI {
        a -= 2.0 * PI;
    } else if a <= -PI {
        a += 2.0 * PI;
    }
    a
}

/// 2D bearing-only bundle adjustment.
///
/// Cameras `(x, y, heading)` on a circle look inwards at landmarks `(x, y)` scattered inside it;
/// each observation is the bearing of a landmark relative to the camera heading (radians), one
/// residual block of dimension 1 per observation. The gauge (translation, rotation and scale) is
/// fixed by holding camera 0 constant and fixing the `x` coordinate of camera 1.
#[derive(Debug, Clone)]
pub struct BearingAdjustment {
    /// True camera parameters `(x, y, heading)`.
    pub cameras: Vec<[f64; 3]>,
    /// True landmark positions.
    pub landmarks: Vec<[f64; 2]>,
    /// `(camera, landmark, measured bearing)`.
    pub observations: Vec<(usize, usize, f64)>,
}

/// A built [`BearingAdjustment`] problem with its block handles.
#[derive(Debug)]
pub struct BuiltProblem {
    /// The problem.
    pub problem: Problem,
    /// Camera parameter blocks, then landmark blocks (or poses for a pose graph).
    pub blocks: Vec<ParameterBlockId>,
}

impl BearingAdjustment {
    /// `num_cameras` cameras, `num_landmarks` landmarks, every camera observing every landmark,
    /// with Gaussian bearing noise of standard deviation `noise` radians.
    pub fn generate(num_cameras: usize, num_landmarks: usize, noise: f64, seed: u64) -> Self {
        let mut rng = Rng::new(seed);
        let cameras: Vec<[f64; 3]> = (0..num_cameras)
            .map(|i| {
                let a = 2.0 * PI * i as f64 / num_cameras as f64 + rng.range(-0.1, 0.1);
                let r = 10.0 + rng.range(-1.0, 1.0);
                [
                    r * a.cos(),
                    r * a.sin(),
                    wrap_angle(a + PI + rng.range(-0.2, 0.2)),
                ]
            })
            .collect();
        let landmarks: Vec<[f64; 2]> = (0..num_landmarks)
            .map(|_| [rng.range(-4.0, 4.0), rng.range(-4.0, 4.0)])
            .collect();
        let mut observations = Vec::with_capacity(num_cameras * num_landmarks);
        for (c, cam) in cameras.iter().enumerate() {
            for (l, lm) in landmarks.iter().enumerate() {
                let bearing = (lm[1] - cam[1]).atan2(lm[0] - cam[0]) - cam[2];
                observations.push((c, l, wrap_angle(bearing + noise * rng.normal())));
            }
        }
        Self {
            cameras,
            landmarks,
            observations,
        }
    }

    /// The problem: camera blocks (3) then landmark blocks (2), landmarks eliminated when
    /// `eliminate_landmarks`.
    pub fn build(&self, eliminate_landmarks: bool) -> BuiltProblem {
        let mut b = ProblemBuilder::new();
        let mut blocks: Vec<ParameterBlockId> = self
            .cameras
            .iter()
            .map(|_| b.add_parameter_block(3))
            .collect();
        for _ in &self.landmarks {
            let id = b.add_parameter_block(2);
            b.set_eliminated(id, eliminate_landmarks);
            blocks.push(id);
        }
        b.set_constant(blocks[0], true);
        if self.cameras.len() > 1 {
            b.set_fixed_components(blocks[1], &[0]);
        }
        let nc = self.cameras.len();
        for &(c, l, _) in &self.observations {
            b.add_residual_block(1, &[blocks[c], blocks[nc + l]]);
        }
        BuiltProblem {
            problem: b.build().expect("valid bearing problem"),
            blocks,
        }
    }

    /// The true parameters in the flat layout of [`BearingAdjustment::build`].
    pub fn truth(&self) -> Vec<f64> {
        let mut x: Vec<f64> = self.cameras.iter().flatten().copied().collect();
        x.extend(self.landmarks.iter().flatten());
        x
    }

    /// The truth perturbed by `scale` (uniform, in the parameters' units), except the gauge
    /// parameters, which stay exact.
    pub fn perturbed(&self, scale: f64, seed: u64) -> Vec<f64> {
        let mut rng = Rng::new(seed);
        let mut x = self.truth();
        for (i, v) in x.iter_mut().enumerate() {
            if i >= 4 {
                *v += rng.range(-scale, scale);
            }
        }
        x
    }
}

impl CostFunction for BearingAdjustment {
    fn evaluate(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        let (_, _, measured) = self.observations[block.0];
        let (cam, lm) = (params[0], params[1]);
        let (dx, dy) = (lm[0] - cam[0], lm[1] - cam[1]);
        let d2 = dx * dx + dy * dy;
        if d2 == 0.0 {
            return Err(EvaluationError::new("landmark at the camera centre"));
        }
        residuals[0] = wrap_angle(dy.atan2(dx) - cam[2] - measured);
        if let Some(j) = jacobians {
            if let Some(jc) = j.block_mut(0) {
                jc.copy_from_slice(&[dy / d2, -dx / d2, -1.0]);
            }
            if let Some(jl) = j.block_mut(1) {
                jl.copy_from_slice(&[-dy / d2, dx / d2]);
            }
        }
        Ok(())
    }
}

/// A 2D pose graph: poses `(x, y, heading)` along a loop, with odometry between consecutive poses
/// and loop closures between random pairs. Each edge is a residual block of dimension 3: the
/// position of pose `j` in the frame of pose `i` and the heading difference, minus the
/// measurement. Pose 0 is held constant.
#[derive(Debug, Clone)]
pub struct PoseGraph {
    /// True poses.
    pub poses: Vec<[f64; 3]>,
    /// `(i, j, measured [dx, dy, dheading] of j in the frame of i)`.
    pub edges: Vec<(usize, usize, [f64; 3])>,
}

impl PoseGraph {
    /// `num_poses` poses on a noisy circle, odometry edges plus `num_closures` random loop
    /// closures, with Gaussian noise `noise` on every measured component.
    pub fn generate(num_poses: usize, num_closures: usize, noise: f64, seed: u64) -> Self {
        let mut rng = Rng::new(seed);
        let poses: Vec<[f64; 3]> = (0..num_poses)
            .map(|i| {
                let a = 2.0 * PI * i as f64 / num_poses as f64;
                [
                    5.0 * a.cos() + rng.range(-0.3, 0.3),
                    5.0 * a.sin() + rng.range(-0.3, 0.3),
                    wrap_angle(a + PI / 2.0 + rng.range(-0.2, 0.2)),
                ]
            })
            .collect();
        let relative = |a: &[f64; 3], b: &[f64; 3]| {
            let (s, c) = a[2].sin_cos();
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            [c * dx + s * dy, -s * dx + c * dy, wrap_angle(b[2] - a[2])]
        };
        let mut edges = Vec::new();
        let mut add = |i: usize, j: usize, rng: &mut Rng| {
            let mut m = relative(&poses[i], &poses[j]);
            for v in &mut m {
                *v += noise * rng.normal();
            }
            edges.push((i, j, m));
        };
        for i in 0..num_poses {
            add(i, (i + 1) % num_poses, &mut rng);
        }
        for _ in 0..num_closures {
            let i = (rng.uniform() * num_poses as f64) as usize % num_poses;
            let j = (i + 2 + (rng.uniform() * (num_poses - 3) as f64) as usize) % num_poses;
            add(i, j, &mut rng);
        }
        Self { poses, edges }
    }

    /// The problem: one block of 3 per pose, pose 0 constant, nothing eliminated.
    pub fn build(&self) -> BuiltProblem {
        let mut b = ProblemBuilder::new();
        let blocks: Vec<ParameterBlockId> = self
            .poses
            .iter()
            .map(|_| b.add_parameter_block(3))
            .collect();
        b.set_constant(blocks[0], true);
        for &(i, j, _) in &self.edges {
            b.add_residual_block(3, &[blocks[i], blocks[j]]);
        }
        BuiltProblem {
            problem: b.build().expect("valid pose graph"),
            blocks,
        }
    }

    /// The true poses, flat.
    pub fn truth(&self) -> Vec<f64> {
        self.poses.iter().flatten().copied().collect()
    }
}

impl CostFunction for PoseGraph {
    fn evaluate(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        let (_, _, m) = self.edges[block.0];
        let (a, b) = (params[0], params[1]);
        let (s, c) = a[2].sin_cos();
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        residuals[0] = c * dx + s * dy - m[0];
        residuals[1] = -s * dx + c * dy - m[1];
        residuals[2] = wrap_angle(b[2] - a[2] - m[2]);
        if let Some(j) = jacobians {
            // Column-major 3x3 blocks.
            if let Some(ja) = j.block_mut(0) {
                ja.copy_from_slice(&[
                    -c,
                    s,
                    0.0,
                    -s,
                    -c,
                    0.0,
                    -s * dx + c * dy,
                    -c * dx - s * dy,
                    -1.0,
                ]);
            }
            if let Some(jb) = j.block_mut(1) {
                jb.copy_from_slice(&[c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0]);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numdiff::check_cost_function;
    use proptest::prelude::*;

    fn check_jacobians<C: CostFunction>(cost: &C, block: usize, a: &[f64], b: &[f64], rows: usize) {
        // Smooth functions of order one away from the angle wrap: central differences at
        // h = 1e-6 are good to ~1e-10, so 1e-6 relative with a 1e-3 floor (1e-9 absolute)
        // leaves a wide margin while catching any wrong term.
        let r = check_cost_function(
            cost,
            ResidualBlockId(block),
            &[a, b],
            rows,
            1e-6,
            1e-6,
            1e-3,
        );
        assert!(r.is_ok(), "{r:?}");
    }

    proptest! {
        #[test]
        fn bearing_jacobians_match_finite_differences(seed in 0u64..1000) {
            let p = BearingAdjustment::generate(4, 3, 0.0, seed);
            for (k, &(c, l, _)) in p.observations.iter().enumerate() {
                let cam = p.cameras[c];
                let lm = p.landmarks[l];
                check_jacobians(&p, k, &cam, &lm, 1);
            }
        }

        #[test]
        fn pose_graph_jacobians_match_finite_differences(seed in 0u64..1000) {
            let g = PoseGraph::generate(6, 2, 0.0, seed);
            for (k, &(i, j, _)) in g.edges.iter().enumerate() {
                check_jacobians(&g, k, &g.poses[i], &g.poses[j], 3);
            }
        }
    }

    #[test]
    fn rng_is_reproducible_and_roughly_normal() {
        let mut a = super::Rng::new(7);
        let mut b = super::Rng::new(7);
        assert_eq!(a.next_u64(), b.next_u64());
        let mut rng = super::Rng::new(1);
        let n = 20000;
        let samples: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let mean = samples.iter().sum::<f64>() / n as f64;
        let var = samples.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
        // Standard errors: 1/sqrt(n) = 0.007 for the mean, sqrt(2/n) = 0.01 for the variance.
        assert!(
            mean.abs() < 0.03 && (var - 1.0).abs() < 0.05,
            "{mean} {var}"
        );
    }
}
