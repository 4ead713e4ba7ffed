//! Manifolds (local parameterizations): parameter blocks that are not updated by `x + step`.
//!
//! A rotation stored as a quaternion has four numbers but three degrees of freedom; a rotation
//! vector near `pi` is badly conditioned for additive steps. A block with a [`Manifold`] keeps its
//! *ambient* values in the parameter vector `x` (`ambient_dim` numbers) while the normal equations,
//! the step, the gradient, fixed components and the covariance live in its *tangent space*
//! (`tangent_dim` numbers). The solver moves the block with [`Manifold::plus`],
//! `x' = x ⊞ delta`, instead of `x + delta`.
//!
//! The cost function's Jacobian block for such a parameter block is taken with respect to the
//! tangent increment at zero: column `k` is `d r(x ⊞ delta) / d delta_k` at `delta = 0` (rows x
//! `tangent_dim`). This is the convention of factor-graph libraries (GTSAM, sophus-rs); it lets a
//! cost function write the derivative of a rotation directly as `R [e_k]x` instead of chaining
//! through the ambient coordinates.
//!
//! Blocks without a manifold are Euclidean: ambient and tangent coincide and `x ⊞ delta = x +
//! delta`.

use nalgebra::{Quaternion, Rotation3, UnitQuaternion as NaQuaternion, Vector3};

/// A parameter block's update rule `x ⊞ delta` (see the module documentation).
pub trait Manifold: Send + Sync + std::fmt::Debug {
    /// Number of values stored in the parameter vector.
    fn ambient_dim(&self) -> usize;

    /// Number of degrees of freedom (length of `delta`).
    fn tangent_dim(&self) -> usize;

    /// Writes `x ⊞ delta` into `out` (`x`, `out`: `ambient_dim` values; `delta`: `tangent_dim`).
    /// Must satisfy `x ⊞ 0 = x` and be smooth in `delta` near zero.
    fn plus(&self, x: &[f64], delta: &[f64], out: &mut [f64]);
}

/// The rotation group SO(3) stored as a rotation vector `w` (axis times angle, radians) and
/// updated on the right: `w ⊞ delta = log(exp(w) exp(delta))`.
///
/// Tangent vectors are rotation increments in the rotated (body) frame, so the derivative of
/// `R(w ⊞ delta) X` at `delta = 0` is `R [e_k]x X`, the same for every `w`: no singularity at
/// `|w| = pi`, where additive updates of a rotation vector break down.
///
/// With `extra > 0` the block holds `extra` Euclidean values after the rotation (for example a
/// translation: `extra = 3` gives a rigid pose `[w, t]` updated as `[w ⊞ delta_w, t + delta_t]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RotationVector {
    /// Euclidean components stored after the three rotation components.
    pub extra: usize,
}

impl RotationVector {
    /// A pure rotation block (3 values).
    pub const fn rotation() -> Self {
        Self { extra: 0 }
    }

    /// A rigid pose block `[w (3), t (3)]`.
    pub const fn pose() -> Self {
        Self { extra: 3 }
    }
}

impl Manifold for RotationVector {
    fn ambient_dim(&self) -> usize {
        3 + self.extra
    }

    fn tangent_dim(&self) -> usize {
        3 + self.extra
    }

    fn plus(&self, x: &[f64], delta: &[f64], out: &mut [f64]) {
        let r = Rotation3::from_scaled_axis(Vector3::new(x[0], x[1], x[2]));
        let d = Rotation3::from_scaled_axis(Vector3::new(delta[0], delta[1], delta[2]));
        let w = (r * d).scaled_axis();
        out[..3].copy_from_slice(w.as_slice());
        for i in 3..3 + self.extra {
            out[i] = x[i] + delta[i];
        }
    }
}

/// The rotation group stored as a unit quaternion `[w, x, y, z]` (4 values, 3 degrees of
/// freedom), updated on the right: `q ⊞ delta = q exp(delta)` with `exp` of a rotation vector.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct UnitQuaternion;

impl Manifold for UnitQuaternion {
    fn ambient_dim(&self) -> usize {
        4
    }

    fn tangent_dim(&self) -> usize {
        3
    }

    fn plus(&self, x: &[f64], delta: &[f64], out: &mut [f64]) {
        let q = NaQuaternion::from_quaternion(Quaternion::new(x[0], x[1], x[2], x[3]));
        let d = NaQuaternion::from_scaled_axis(Vector3::new(delta[0], delta[1], delta[2]));
        let p = (q * d).into_inner();
        out.copy_from_slice(&[p.w, p.i, p.j, p.k]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plus_zero_is_the_identity_and_steps_compose_on_the_right() {
        let m = RotationVector::pose();
        let x = [0.3, -2.9, 0.4, 1.0, 2.0, 3.0];
        let mut out = [0.0; 6];
        m.plus(&x, &[0.0; 6], &mut out);
        for (a, b) in out.iter().zip(&x) {
            assert!((a - b).abs() < 1e-12);
        }
        let delta = [0.01, -0.02, 0.03, 0.1, 0.2, 0.3];
        m.plus(&x, &delta, &mut out);
        let r = Rotation3::from_scaled_axis(Vector3::new(x[0], x[1], x[2]))
            * Rotation3::from_scaled_axis(Vector3::new(delta[0], delta[1], delta[2]));
        let back = Rotation3::from_scaled_axis(Vector3::new(out[0], out[1], out[2]));
        assert!((back.matrix() - r.matrix()).norm() < 1e-12);
        assert!((out[5] - 3.3).abs() < 1e-12);

        let q = UnitQuaternion;
        let mut p = [0.0; 4];
        q.plus(&[1.0, 0.0, 0.0, 0.0], &[0.0, 0.0, 0.5], &mut p);
        assert!((p[0] - 0.25f64.cos()).abs() < 1e-12 && (p[3] - 0.25f64.sin()).abs() < 1e-12);
    }
}
