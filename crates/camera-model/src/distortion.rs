//! Lens distortion models acting on normalized image coordinates.
//!
//! A model maps an ideal normalized point `n = (x/z, y/z)` to the distorted normalized point
//! `d(n)`; intrinsics then turn `d(n)` into pixels. Models implement [`LensDistortion`], whose
//! parameter Jacobian is a fixed-size matrix type chosen by the model, so nothing allocates.
//! The solver and the calibration pipelines only see the parameter vector and the Jacobians, so a
//! new model (k3, rational, fisheye) is a new implementation of this trait and nothing else.
//!
//! Derivations: `docs/camera-model.md`, section "Distortion".

use nalgebra::{Matrix2, SMatrix, Vector2};

/// The Jacobian of a distortion model with respect to its parameters: a 2 x `NUM_PARAMS` matrix.
///
/// Implemented for nalgebra's fixed-size `SMatrix<f64, 2, N>`, so each model's Jacobian lives on
/// the stack while generic code reads it as a column-major slice.
pub trait ParamJacobian:
    Copy + Clone + Send + Sync + std::fmt::Debug + PartialEq + 'static
{
    /// The entries in column-major order: `[d x_d/d k_0, d y_d/d k_0, d x_d/d k_1, ...]`.
    fn as_slice(&self) -> &[f64];
    /// The matrix with its first row multiplied by `a` and its second row by `b`.
    fn scale_rows(&self, a: f64, b: f64) -> Self;
}

impl<const N: usize> ParamJacobian for SMatrix<f64, 2, N> {
    #[inline]
    fn as_slice(&self) -> &[f64] {
        SMatrix::as_slice(self)
    }

    #[inline]
    fn scale_rows(&self, a: f64, b: f64) -> Self {
        let mut out = *self;
        for mut column in out.column_iter_mut() {
            column[0] *= a;
            column[1] *= b;
        }
        out
    }
}

/// A lens distortion model acting on normalized image coordinates.
///
/// Parameters are exchanged as slices of length [`LensDistortion::NUM_PARAMS`]; passing a shorter
/// slice is a programming error and panics.
pub trait LensDistortion:
    Copy + Clone + Send + Sync + std::fmt::Debug + PartialEq + 'static
{
    /// Number of parameters.
    const NUM_PARAMS: usize;

    /// A short name for reports and files.
    const NAME: &'static str;

    /// Parameter names, in parameter order (length `NUM_PARAMS`).
    const PARAM_NAMES: &'static [&'static str];

    /// Indices of the tangential (decentering) parameters, which calibration can hold at zero
    /// (empty for purely radial models).
    const TANGENTIAL_PARAMS: &'static [usize] = &[];

    /// The type of `d d / d params`, a 2 x `NUM_PARAMS` matrix.
    type ParamJacobian: ParamJacobian;

    /// The model with parameters `params[..NUM_PARAMS]`.
    fn from_params(params: &[f64]) -> Self;

    /// Writes the parameters into `out[..NUM_PARAMS]`.
    fn write_params(&self, out: &mut [f64]);

    /// The distorted normalized point `d(n)`.
    fn distort(&self, n: &Vector2<f64>) -> Vector2<f64>;

    /// `d(n)` together with `d d / d n` (2x2) and `d d / d params` (2 x `NUM_PARAMS`).
    fn distort_with_jacobians(
        &self,
        n: &Vector2<f64>,
    ) -> (Vector2<f64>, Matrix2<f64>, Self::ParamJacobian);

    /// The model with all parameters zero: the identity map for every model in this crate.
    fn identity() -> Self {
        Self::from_params(&[0.0; 64][..Self::NUM_PARAMS])
    }
}

/// The Brown-Conrady / Heikkila 4-coefficient model: radial `k1`, `k2` and tangential (decentering)
/// `p1`, `p2`, with the same meaning and order as OpenCV's `[k1, k2, p1, p2]` (OpenCV with `k3`
/// fixed to zero) and Bouguet's toolbox. The calibration literature calls them `beta1..beta4`.
///
/// With `r^2 = x^2 + y^2` and `radial = 1 + k1 r^2 + k2 r^4`:
///
/// ```text
/// x_d = x radial + 2 p1 x y + p2 (r^2 + 2 x^2)
/// y_d = y radial + p1 (r^2 + 2 y^2) + 2 p2 x y
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BrownConrady {
    /// Second-order radial coefficient `k1` (`beta1`).
    pub k1: f64,
    /// Fourth-order radial coefficient `k2` (`beta2`).
    pub k2: f64,
    /// First tangential coefficient `p1` (`beta3`).
    pub p1: f64,
    /// Second tangential coefficient `p2` (`beta4`).
    pub p2: f64,
}

impl BrownConrady {
    /// The model with the given coefficients.
    pub const fn new(k1: f64, k2: f64, p1: f64, p2: f64) -> Self {
        Self { k1, k2, p1, p2 }
    }
}

impl LensDistortion for BrownConrady {
    const NUM_PARAMS: usize = 4;
    const NAME: &'static str = "brown-conrady-k1k2p1p2";
    const PARAM_NAMES: &'static [&'static str] = &["k1", "k2", "p1", "p2"];
    const TANGENTIAL_PARAMS: &'static [usize] = &[2, 3];
    type ParamJacobian = SMatrix<f64, 2, 4>;

    #[inline]
    fn from_params(p: &[f64]) -> Self {
        Self::new(p[0], p[1], p[2], p[3])
    }

    #[inline]
    fn write_params(&self, out: &mut [f64]) {
        out[..4].copy_from_slice(&[self.k1, self.k2, self.p1, self.p2]);
    }

    #[inline]
    fn distort(&self, n: &Vector2<f64>) -> Vector2<f64> {
        let (x, y) = (n.x, n.y);
        let (x2, y2, xy) = (x * x, y * y, x * y);
        let r2 = x2 + y2;
        // Same operation order as `distort_with_jacobians`, so both give identical bits.
        let radial = 1.0 + self.k1 * r2 + self.k2 * (r2 * r2);
        Vector2::new(
            x * radial + 2.0 * self.p1 * xy + self.p2 * (r2 + 2.0 * x2),
            y * radial + self.p1 * (r2 + 2.0 * y2) + 2.0 * self.p2 * xy,
        )
    }

    #[inline]
    fn distort_with_jacobians(
        &self,
        n: &Vector2<f64>,
    ) -> (Vector2<f64>, Matrix2<f64>, SMatrix<f64, 2, 4>) {
        let (x, y) = (n.x, n.y);
        let (x2, y2, xy) = (x * x, y * y, x * y);
        let r2 = x2 + y2;
        let r4 = r2 * r2;
        let radial = 1.0 + self.k1 * r2 + self.k2 * r4;
        let distorted = Vector2::new(
            x * radial + 2.0 * self.p1 * xy + self.p2 * (r2 + 2.0 * x2),
            y * radial + self.p1 * (r2 + 2.0 * y2) + 2.0 * self.p2 * xy,
        );
        // d radial / d r^2; differentiating r^2 rather than r avoids a 0/0 at the image centre.
        let dradial = self.k1 + 2.0 * self.k2 * r2;
        let two_dradial = 2.0 * dradial;
        let d_point = Matrix2::new(
            radial + two_dradial * x2 + 2.0 * self.p1 * y + 6.0 * self.p2 * x,
            two_dradial * xy + 2.0 * self.p1 * x + 2.0 * self.p2 * y,
            two_dradial * xy + 2.0 * self.p1 * x + 2.0 * self.p2 * y,
            radial + two_dradial * y2 + 6.0 * self.p1 * y + 2.0 * self.p2 * x,
        );
        let d_params = SMatrix::<f64, 2, 4>::new(
            x * r2,
            x * r4,
            2.0 * xy,
            r2 + 2.0 * x2,
            y * r2,
            y * r4,
            r2 + 2.0 * y2,
            2.0 * xy,
        );
        (distorted, d_point, d_params)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lm_solver::numdiff::{central_difference, compare_jacobians};
    use proptest::prelude::*;

    fn realistic() -> impl Strategy<Value = BrownConrady> {
        (-0.5f64..0.5, -0.5f64..0.5, -0.02f64..0.02, -0.02f64..0.02)
            .prop_map(|(k1, k2, p1, p2)| BrownConrady::new(k1, k2, p1, p2))
    }

    #[test]
    fn zero_parameters_are_the_identity() {
        let n = Vector2::new(0.3, -0.7);
        assert_eq!(BrownConrady::identity().distort(&n), n);
    }

    #[test]
    fn with_jacobians_agrees_with_distort() {
        let d = BrownConrady::new(0.1, -0.2, 0.003, -0.002);
        let n = Vector2::new(0.4, -0.25);
        assert_eq!(d.distort_with_jacobians(&n).0, d.distort(&n));
    }

    proptest! {
        #[test]
        fn jacobians_match_finite_differences(
            d in realistic(), x in -1.2f64..1.2, y in -1.2f64..1.2
        ) {
            let n = Vector2::new(x, y);
            let (_, d_point, d_params) = d.distort_with_jacobians(&n);
            let by_point = central_difference(
                |v: &[f64], out: &mut [f64]| {
                    out.copy_from_slice(d.distort(&Vector2::new(v[0], v[1])).as_slice())
                },
                n.as_slice(),
                2,
                1e-6,
            );
            // Central-difference error: rounding eps |f| / h plus truncation h^2 |f'''| / 6. Here
            // |f| < 5 and |f'''| < 100 over the range, with h = 1e-6, so the error is below 6e-10.
            // The tolerance 1e-6 (|n| + 1e-3) is at least 1e-9 for entries that vanish (on an
            // axis) and 1e-6 relative for the others: any wrong term shows up far above both.
            let r = compare_jacobians(d_point.as_slice(), &by_point, 2, 1e-6, 1e-3);
            prop_assert!(r.is_ok(), "{:?}", r);
            let by_params = central_difference(
                |p: &[f64], out: &mut [f64]| {
                    out.copy_from_slice(BrownConrady::from_params(p).distort(&n).as_slice())
                },
                &[d.k1, d.k2, d.p1, d.p2],
                2,
                1e-6,
            );
            let r = compare_jacobians(ParamJacobian::as_slice(&d_params), &by_params, 2, 1e-6, 1e-3);
            prop_assert!(r.is_ok(), "{:?}", r);
        }
    }
}
