//! Lens distortion models acting on normalized image coordinates.
//!
//! A model maps an ideal point `n` of the projection plane (pinhole: `(x/z, y/z)`; equidistant:
//! `theta (x, y) / r`) to the distorted point `d(n)`; intrinsics then turn `d(n)` into pixels.
//! Models implement [`LensDistortion`], whose parameter Jacobian is a fixed-size matrix type
//! chosen by the model, so nothing allocates. The solver and the calibration pipelines only see
//! the parameter vector and the Jacobians, so a new model is a new implementation of this trait
//! (plus a variant of [`crate::CameraModel`]) and nothing else.
//!
//! | model | parameters (OpenCV order) | acts on |
//! |---|---|---|
//! | [`BrownConrady`] (`brown-conrady4`) | k1 k2 p1 p2 | pinhole |
//! | [`BrownConrady5`] | k1 k2 p1 p2 k3 | pinhole |
//! | [`Rational8`] | k1 k2 p1 p2 k3 k4 k5 k6 | pinhole |
//! | [`ThinPrism12`] | k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4 | pinhole |
//! | [`KannalaBrandt4`] | k1 k2 k3 k4 | equidistant |
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

/// Which parameters each distorted coordinate depends on, for a model whose `x_d` and `y_d` each
/// depend on only `M` of its parameters (the thin-prism terms `s3, s4` never enter `x_d`, nor
/// `s1, s2` `y_d`). The fused normal-equation kernels of `calib-core` then accumulate rows of `M`
/// distortion derivatives instead of all of them: for [`ThinPrism12`] 10 instead of 12, 18%
/// fewer products per pixel row (`docs/benchmarks-models.md`, section 3).
pub trait RowSupport<const M: usize>:
    Copy + Clone + Send + Sync + std::fmt::Debug + PartialEq + 'static
{
    /// `ROWS[0]`: the indices (in parameter order, increasing) of the parameters `x_d` may
    /// depend on; `ROWS[1]`: those of `y_d`. Every other entry of that row of the parameter
    /// Jacobian is exactly zero at every point.
    const ROWS: [[usize; M]; 2];
}

/// The parameter Jacobian (2 x `N`) of a model whose rows have the structural zeros that `S`
/// describes ([`RowSupport`]). Read and used like the plain matrix; the type only carries the
/// row support to the kernels that exploit it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowSparseJacobian<S, const N: usize, const M: usize> {
    /// The whole matrix, zeros included.
    pub matrix: SMatrix<f64, 2, N>,
    support: std::marker::PhantomData<S>,
}

impl<S, const N: usize, const M: usize> From<SMatrix<f64, 2, N>> for RowSparseJacobian<S, N, M> {
    #[inline]
    fn from(matrix: SMatrix<f64, 2, N>) -> Self {
        Self {
            matrix,
            support: std::marker::PhantomData,
        }
    }
}

impl<S: RowSupport<M>, const N: usize, const M: usize> ParamJacobian
    for RowSparseJacobian<S, N, M>
{
    #[inline]
    fn as_slice(&self) -> &[f64] {
        self.matrix.as_slice()
    }

    #[inline]
    fn scale_rows(&self, a: f64, b: f64) -> Self {
        self.matrix.scale_rows(a, b).into()
    }
}

/// The row support of [`ThinPrism12`]: `x_d` depends on `k1..k6, p1, p2, s1, s2`, `y_d` on
/// `k1..k6, p1, p2, s3, s4`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinPrismRows;

impl RowSupport<10> for ThinPrismRows {
    const ROWS: [[usize; 10]; 2] = [
        [0, 1, 2, 3, 4, 5, 6, 7, 8, 9],
        [0, 1, 2, 3, 4, 5, 6, 7, 10, 11],
    ];
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

    /// The model that leaves every point where it is (the calibration's start before any
    /// distortion is estimated). For every model in this crate these are the zero parameters,
    /// but a model need not be built that way, so each states its own.
    fn identity() -> Self;

    /// The model's denominator at `n` for rational models (it must stay positive wherever the
    /// model is used: a vanishing denominator sends points to infinity), `None` for polynomial
    /// ones.
    fn denominator(&self, n: &Vector2<f64>) -> Option<f64> {
        let _ = n;
        None
    }

    /// For rational models whose denominator depends on the radius only, the smallest
    /// normalized radius at which it vanishes (`None`: never, or a polynomial model). A walk
    /// that samples [`LensDistortion::denominator`] can step over a band where it is negative
    /// between two close roots (seen 6e-7 wide in `r`); this finds it exactly.
    fn pole_radius(&self) -> Option<f64> {
        None
    }

    /// The radial factor as polynomials in `t = |n|^2`: `(numerator, denominator)`, coefficients
    /// from the constant term up, such that with its non-radial terms (tangential, thin prism) at
    /// zero the model maps `n` to `n N(t) / D(t)`. `None` for a model not of that form. The
    /// validity check finds the radial fold from it exactly (`crate::validity`): a fold band
    /// between close roots can be far narrower than a sampled walk's step.
    fn radial_factor(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        None
    }
}

/// The smallest `t > 0` with `1 + a t + b t^2 + c t^3 = 0` (a double root counts), if any.
/// Between the roots of the derivative the cubic is monotonic: each such interval holds at most
/// one root, found by bisection.
pub(crate) fn smallest_positive_cubic_root(a: f64, b: f64, c: f64) -> Option<f64> {
    let p = |t: f64| 1.0 + t * (a + t * (b + t * c));
    // Critical points: a + 2 b t + 3 c t^2 = 0.
    let mut knots: Vec<f64> = Vec::with_capacity(3);
    if c != 0.0 {
        let disc = 4.0 * b * b - 12.0 * a * c;
        if disc >= 0.0 {
            let s = disc.sqrt();
            knots.extend([(-2.0 * b - s) / (6.0 * c), (-2.0 * b + s) / (6.0 * c)]);
        }
    } else if b != 0.0 {
        knots.push(-a / (2.0 * b));
    }
    knots.retain(|t| t.is_finite() && *t > 0.0);
    knots.sort_by(f64::total_cmp);
    // Beyond the last critical point the cubic is monotonic: a root there lies below the
    // Cauchy bound 1 + max |coefficient / leading coefficient|.
    let lead = [c, b, a].into_iter().find(|v| *v != 0.0)?;
    let bound = 1.0
        + [1.0, a, b, c]
            .iter()
            .map(|v| (v / lead).abs())
            .fold(0.0, f64::max);
    knots.push(bound.max(knots.last().copied().unwrap_or(0.0)) * 2.0);
    let mut lo = 0.0;
    for hi in knots {
        if p(hi) <= 0.0 {
            // p(lo) > 0 >= p(hi), p monotonic between: bisect.
            let (mut l, mut h) = (lo, hi);
            for _ in 0..200 {
                let m = 0.5 * (l + h);
                if p(m) > 0.0 {
                    l = m
                } else {
                    h = m
                }
                if h - l <= 1e-16 * h {
                    break;
                }
            }
            return Some(h);
        }
        lo = hi;
    }
    None
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
    const NAME: &'static str = "brown-conrady4";
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

    fn identity() -> Self {
        Self::default()
    }

    fn radial_factor(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        Some((vec![1.0, self.k1, self.k2], vec![1.0]))
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

/// The Brown-Conrady model with `k1, k2, p1, p2` (the name OpenCV and the issue tracker use for
/// [`BrownConrady`]).
pub type BrownConrady4 = BrownConrady;

/// The rational radial + tangential + thin-prism model with all twelve OpenCV coefficients
/// `[k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4]`, shared by [`BrownConrady5`], [`Rational8`]
/// and [`ThinPrism12`] (which hold the unused ones at zero). With `r^2 = x^2 + y^2`,
/// `c = (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6)`:
///
/// ```text
/// x_d = x c + 2 p1 x y + p2 (r^2 + 2 x^2) + s1 r^2 + s2 r^4
/// y_d = y c + p1 (r^2 + 2 y^2) + 2 p2 x y + s3 r^2 + s4 r^4
/// ```
#[inline]
fn rational_thin_prism<const N: usize>(
    k: &[f64; 12],
    n: &Vector2<f64>,
    jacobians: bool,
) -> (Vector2<f64>, Matrix2<f64>, SMatrix<f64, 2, N>) {
    let (x, y) = (n.x, n.y);
    let (x2, y2, xy) = (x * x, y * y, x * y);
    let r2 = x2 + y2;
    let r4 = r2 * r2;
    let r6 = r4 * r2;
    let num = 1.0 + k[0] * r2 + k[1] * r4 + k[4] * r6;
    let den = 1.0 + k[5] * r2 + k[6] * r4 + k[7] * r6;
    let inv_den = 1.0 / den;
    let c = num * inv_den;
    let (p1, p2) = (k[2], k[3]);
    let distorted = Vector2::new(
        x * c + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x2) + k[8] * r2 + k[9] * r4,
        y * c + p1 * (r2 + 2.0 * y2) + 2.0 * p2 * xy + k[10] * r2 + k[11] * r4,
    );
    if !jacobians {
        return (distorted, Matrix2::zeros(), SMatrix::zeros());
    }
    // dc / d(r^2), then the chain d(r^2)/dx = 2x; again differentiating r^2 avoids 0/0 at 0.
    let dnum = k[0] + 2.0 * k[1] * r2 + 3.0 * k[4] * r4;
    let dden = k[5] + 2.0 * k[6] * r2 + 3.0 * k[7] * r4;
    let dc = (dnum - c * dden) * inv_den;
    let prism_x = k[8] + 2.0 * k[9] * r2;
    let prism_y = k[10] + 2.0 * k[11] * r2;
    let d_point = Matrix2::new(
        c + 2.0 * dc * x2 + 2.0 * p1 * y + 6.0 * p2 * x + 2.0 * prism_x * x,
        2.0 * dc * xy + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * prism_x * y,
        2.0 * dc * xy + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * prism_y * x,
        c + 2.0 * dc * y2 + 6.0 * p1 * y + 2.0 * p2 * x + 2.0 * prism_y * y,
    );
    // Columns in OpenCV order; a model with N < 12 coefficients takes the first N.
    let radial = [r2 * inv_den, r4 * inv_den, r6 * inv_den];
    let columns: [[f64; 2]; 12] = [
        [x * radial[0], y * radial[0]],
        [x * radial[1], y * radial[1]],
        [2.0 * xy, r2 + 2.0 * y2],
        [r2 + 2.0 * x2, 2.0 * xy],
        [x * radial[2], y * radial[2]],
        [-x * c * radial[0], -y * c * radial[0]],
        [-x * c * radial[1], -y * c * radial[1]],
        [-x * c * radial[2], -y * c * radial[2]],
        [r2, 0.0],
        [r4, 0.0],
        [0.0, r2],
        [0.0, r4],
    ];
    let mut d_params = SMatrix::<f64, 2, N>::zeros();
    for (j, column) in columns.iter().take(N).enumerate() {
        d_params[(0, j)] = column[0];
        d_params[(1, j)] = column[1];
    }
    (distorted, d_point, d_params)
}

macro_rules! rational_family_model {
    ($(#[$doc:meta])* $name:ident, $n:literal, $label:literal, [$($field:ident),*], $jacobian:ty) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Default)]
        pub struct $name {
            /// The coefficients in OpenCV's order (see [`LensDistortion::PARAM_NAMES`]).
            pub coefficients: [f64; $n],
        }

        impl $name {
            /// The model with the given coefficients (OpenCV's order).
            pub const fn new(coefficients: [f64; $n]) -> Self {
                Self { coefficients }
            }

            #[inline]
            fn full(&self) -> [f64; 12] {
                let mut k = [0.0; 12];
                k[..$n].copy_from_slice(&self.coefficients);
                k
            }
        }

        impl LensDistortion for $name {
            const NUM_PARAMS: usize = $n;
            const NAME: &'static str = $label;
            const PARAM_NAMES: &'static [&'static str] = &[$(stringify!($field)),*];
            const TANGENTIAL_PARAMS: &'static [usize] = &[2, 3];
            type ParamJacobian = $jacobian;

            #[inline]
            fn from_params(p: &[f64]) -> Self {
                let mut coefficients = [0.0; $n];
                coefficients.copy_from_slice(&p[..$n]);
                Self { coefficients }
            }

            #[inline]
            fn write_params(&self, out: &mut [f64]) {
                out[..$n].copy_from_slice(&self.coefficients);
            }

            fn identity() -> Self {
                Self::default()
            }

            #[inline]
            fn distort(&self, n: &Vector2<f64>) -> Vector2<f64> {
                rational_thin_prism::<$n>(&self.full(), n, false).0
            }

            #[inline]
            fn distort_with_jacobians(
                &self,
                n: &Vector2<f64>,
            ) -> (Vector2<f64>, Matrix2<f64>, $jacobian) {
                let (distorted, d_point, d_params) = rational_thin_prism::<$n>(&self.full(), n, true);
                (distorted, d_point, d_params.into())
            }

            fn denominator(&self, n: &Vector2<f64>) -> Option<f64> {
                let k = self.full();
                let r2 = n.norm_squared();
                ($n > 5).then(|| 1.0 + k[5] * r2 + k[6] * r2 * r2 + k[7] * r2 * r2 * r2)
            }

            fn radial_factor(&self) -> Option<(Vec<f64>, Vec<f64>)> {
                let k = self.full();
                Some((vec![1.0, k[0], k[1], k[4]], vec![1.0, k[5], k[6], k[7]]))
            }

            fn pole_radius(&self) -> Option<f64> {
                let k = self.full();
                if $n > 5 {
                    smallest_positive_cubic_root(k[5], k[6], k[7]).map(f64::sqrt)
                } else {
                    None
                }
            }
        }
    };
}

rational_family_model!(
    /// Brown-Conrady with `k3`: `[k1, k2, p1, p2, k3]`, OpenCV's default model (ROS
    /// `plumb_bob`): radial factor `1 + k1 r^2 + k2 r^4 + k3 r^6` plus the tangential terms of
    /// [`BrownConrady`].
    BrownConrady5, 5, "brown-conrady5", [k1, k2, p1, p2, k3],
    SMatrix<f64, 2, 5>
);

rational_family_model!(
    /// OpenCV's rational model (`CALIB_RATIONAL_MODEL`, ROS `rational_polynomial`):
    /// `[k1, k2, p1, p2, k3, k4, k5, k6]`, radial factor
    /// `(1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6)`. The denominator must
    /// stay positive over the image ([`LensDistortion::denominator`]).
    Rational8, 8, "rational8", [k1, k2, p1, p2, k3, k4, k5, k6],
    SMatrix<f64, 2, 8>
);

rational_family_model!(
    /// [`Rational8`] plus OpenCV's thin-prism terms (`CALIB_THIN_PRISM_MODEL`):
    /// `[k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4]`, adding `s1 r^2 + s2 r^4` to `x_d` and
    /// `s3 r^2 + s4 r^4` to `y_d`.
    ThinPrism12, 12, "thin-prism12", [k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4],
    RowSparseJacobian<ThinPrismRows, 12, 10>
);

/// The Kannala-Brandt fisheye model with four coefficients, acting on the equidistant
/// projection (`|n| = theta`, the angle off the optical axis): the distorted angle is
/// `theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)` along the same
/// direction, i.e. `d = n (1 + k1 |n|^2 + k2 |n|^4 + k3 |n|^6 + k4 |n|^8)`. The same model and
/// coefficient order as OpenCV's `cv2.fisheye` (`D = [k1, k2, k3, k4]`) and Kalibr/ROS
/// `equidistant`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct KannalaBrandt4 {
    /// `[k1, k2, k3, k4]`.
    pub coefficients: [f64; 4],
}

impl KannalaBrandt4 {
    /// The model with the given coefficients.
    pub const fn new(coefficients: [f64; 4]) -> Self {
        Self { coefficients }
    }
}

impl LensDistortion for KannalaBrandt4 {
    const NUM_PARAMS: usize = 4;
    const NAME: &'static str = "kannala-brandt4";
    const PARAM_NAMES: &'static [&'static str] = &["k1", "k2", "k3", "k4"];
    type ParamJacobian = SMatrix<f64, 2, 4>;

    #[inline]
    fn from_params(p: &[f64]) -> Self {
        Self::new([p[0], p[1], p[2], p[3]])
    }

    #[inline]
    fn write_params(&self, out: &mut [f64]) {
        out[..4].copy_from_slice(&self.coefficients);
    }

    fn identity() -> Self {
        Self::default()
    }

    /// In `t = theta^2`: `theta_d = theta (1 + k1 t + k2 t^2 + k3 t^3 + k4 t^4)`.
    fn radial_factor(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        let [k1, k2, k3, k4] = self.coefficients;
        Some((vec![1.0, k1, k2, k3, k4], vec![1.0]))
    }

    #[inline]
    fn distort(&self, n: &Vector2<f64>) -> Vector2<f64> {
        let [k1, k2, k3, k4] = self.coefficients;
        let t2 = n.x * n.x + n.y * n.y;
        let f = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)));
        Vector2::new(n.x * f, n.y * f)
    }

    #[inline]
    fn distort_with_jacobians(
        &self,
        n: &Vector2<f64>,
    ) -> (Vector2<f64>, Matrix2<f64>, SMatrix<f64, 2, 4>) {
        let [k1, k2, k3, k4] = self.coefficients;
        let (x, y) = (n.x, n.y);
        let t2 = x * x + y * y;
        let f = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)));
        // df / d(theta^2).
        let df = k1 + t2 * (2.0 * k2 + t2 * (3.0 * k3 + t2 * 4.0 * k4));
        let d_point = Matrix2::new(
            f + 2.0 * df * x * x,
            2.0 * df * x * y,
            2.0 * df * x * y,
            f + 2.0 * df * y * y,
        );
        let (t4, t6) = (t2 * t2, t2 * t2 * t2);
        let t8 = t4 * t4;
        let d_params = SMatrix::<f64, 2, 4>::new(
            x * t2,
            x * t4,
            x * t6,
            x * t8,
            y * t2,
            y * t4,
            y * t6,
            y * t8,
        );
        (Vector2::new(x * f, y * f), d_point, d_params)
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

    /// Checks one model's Jacobians against central differences at `n`. Same error budget as
    /// the Brown-Conrady test above: values below 10 and third derivatives below 1e3 over the
    /// sampled ranges give central-difference errors below 1e-8 with h = 1e-6, far under the
    /// tolerance 1e-6 (|J| + 1e-3).
    fn check_model<D: LensDistortion>(d: D, n: Vector2<f64>) -> Result<(), TestCaseError> {
        let (value, d_point, d_params) = d.distort_with_jacobians(&n);
        prop_assert_eq!(value, d.distort(&n));
        let by_point = central_difference(
            |v: &[f64], out: &mut [f64]| {
                out.copy_from_slice(d.distort(&Vector2::new(v[0], v[1])).as_slice())
            },
            n.as_slice(),
            2,
            1e-6,
        );
        let r = compare_jacobians(d_point.as_slice(), &by_point, 2, 1e-6, 1e-3);
        prop_assert!(r.is_ok(), "{}: d/dn {:?}", D::NAME, r);
        let mut params = vec![0.0; D::NUM_PARAMS];
        d.write_params(&mut params);
        let by_params = central_difference(
            |p: &[f64], out: &mut [f64]| {
                out.copy_from_slice(D::from_params(p).distort(&n).as_slice())
            },
            &params,
            2,
            1e-6,
        );
        let r = compare_jacobians(
            ParamJacobian::as_slice(&d_params),
            &by_params,
            2,
            1e-6,
            1e-3,
        );
        prop_assert!(r.is_ok(), "{}: d/dk {:?}", D::NAME, r);
        prop_assert_eq!(D::identity().distort(&n), n);
        Ok(())
    }

    proptest! {
        #[test]
        fn every_model_has_correct_jacobians(
            k in prop::array::uniform12(-0.3f64..0.3), x in -1.0f64..1.0, y in -1.0f64..1.0
        ) {
            let n = Vector2::new(x, y);
            // Tangential and prism terms are small in real lenses. The rational denominator
            // 1 + k4 r^2 + k5 r^4 + k6 r^6 is kept at 0.4 or more over the sampled r^2 < 2
            // (|k4| < 0.1, |k5| < 0.05, |k6| < 0.025): near its zeros the derivatives grow
            // without bound (a drawn k4..k6 of -0.13, -0.29, -0.10 at r^2 = 1.38 made them 1e7
            // and the central differences 6e-5 off), and the model is invalid there anyway.
            let mut c = k;
            for i in [2, 3, 8, 9, 10, 11] {
                c[i] *= 0.05;
            }
            c[5] /= 3.0;
            c[6] /= 6.0;
            c[7] /= 12.0;
            check_model(BrownConrady5::new([c[0], c[1], c[2], c[3], c[4]]), n)?;
            check_model(Rational8::new([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]), n)?;
            check_model(ThinPrism12::new(c), n)?;
            check_model(KannalaBrandt4::new([c[0], c[1] * 0.3, c[4] * 0.1, c[5] * 0.03]), n)?;
        }
    }

    /// The row support [`ThinPrismRows`] declares is the Jacobian's: every entry outside it is
    /// exactly zero, and every entry inside it is non-zero at a generic point (a support that
    /// left out a live entry would drop it from the kernels' normal equations).
    #[test]
    fn thin_prism_row_support_holds_every_live_entry() {
        let model = ThinPrism12::new([
            -0.21, 0.05, 0.0013, -0.0021, 0.012, 0.03, -0.004, 0.002, 0.0011, -0.0004, 0.0007,
            0.0003,
        ]);
        for n in [
            Vector2::new(0.4, -0.3),
            Vector2::new(-0.7, 0.1),
            Vector2::new(0.05, 0.6),
        ] {
            let (_, _, j) = model.distort_with_jacobians(&n);
            for (row, support) in ThinPrismRows::ROWS.iter().enumerate() {
                for k in 0..12 {
                    let value = j.matrix[(row, k)];
                    if support.contains(&k) {
                        assert!(value != 0.0, "row {row}, parameter {k} at {n:?}");
                    } else {
                        assert_eq!(value, 0.0, "row {row}, parameter {k} at {n:?}");
                    }
                }
                assert!(support.windows(2).all(|w| w[0] < w[1]), "{support:?}");
            }
        }
    }

    /// Each richer model reduces to the simpler one when its extra coefficients are zero.
    #[test]
    fn models_nest() {
        let n = Vector2::new(0.4, -0.3);
        let four = BrownConrady::new(-0.2, 0.05, 0.001, -0.002);
        let five = BrownConrady5::new([-0.2, 0.05, 0.001, -0.002, 0.0]);
        let eight = Rational8::new([-0.2, 0.05, 0.001, -0.002, 0.0, 0.0, 0.0, 0.0]);
        let twelve = ThinPrism12::new([
            -0.2, 0.05, 0.001, -0.002, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        ]);
        for other in [five.distort(&n), eight.distort(&n), twelve.distort(&n)] {
            assert!((other - four.distort(&n)).norm() < 1e-15);
        }
        assert_eq!(eight.denominator(&n), Some(1.0));
        assert_eq!(five.denominator(&n), None);
        // Kannala-Brandt: the distorted length is theta_d(theta).
        let kb = KannalaBrandt4::new([0.1, -0.02, 0.003, -0.0004]);
        let theta: f64 = 1.2;
        let m = Vector2::new(theta * 0.6, theta * 0.8);
        let theta_d = theta
            * (1.0 + 0.1 * theta.powi(2) - 0.02 * theta.powi(4) + 0.003 * theta.powi(6)
                - 0.0004 * theta.powi(8));
        assert!((kb.distort(&m).norm() - theta_d).abs() < 1e-14);
    }
}
