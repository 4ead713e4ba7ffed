//! Rotation parameterizations: Euler X-Y-Z angles and axis-angle (Rodrigues) vectors.
//!
//! Both map three numbers to a rotation matrix `R` and give the analytic derivative of `R` with
//! respect to each of the three numbers. Rotations are active and right-handed: a positive angle
//! turns a vector counter-clockwise about the axis when the axis points at the viewer.
//!
//! The derivations are in `docs/camera-model.md` (section "Rotation").

use nalgebra::{Matrix3, Vector3};

/// A way of describing a rotation with three parameters.
///
/// Implementations give the matrix, its derivatives with respect to the three parameters, and
/// the inverse map (matrix to parameters). They are zero-sized marker types so that code generic
/// over the parameterization compiles to straight-line arithmetic.
pub trait RotationParameterization: Copy + Clone + Send + Sync + std::fmt::Debug + 'static {
    /// A short name for reports ("euler-xyz", "axis-angle").
    const NAME: &'static str;

    /// The rotation matrix for parameters `p`.
    fn matrix(p: &Vector3<f64>) -> Matrix3<f64>;

    /// The rotation matrix and its derivatives `dR/dp_k` for `k = 0, 1, 2`.
    fn matrix_and_derivatives(p: &Vector3<f64>) -> (Matrix3<f64>, [Matrix3<f64>; 3]);

    /// Parameters of a rotation matrix. `r` must be a rotation (orthonormal, determinant +1);
    /// the result is the canonical representative (see each implementation).
    fn from_matrix(r: &Matrix3<f64>) -> Vector3<f64>;
}

/// Which rotation parameterization to use, chosen at run time (for options and file formats).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RotationKind {
    /// [`EulerXyz`]: the seed's parameterization, `R = Rz(theta_z) Ry(theta_y) Rx(theta_x)`.
    #[default]
    EulerXyz,
    /// [`AxisAngle`]: rotation vector (axis times angle in radians), as OpenCV's `rvec`.
    AxisAngle,
    /// [`So3`]: rotation vectors updated on the rotation manifold (body-frame increments).
    So3,
}

impl RotationKind {
    /// The rotation matrix for parameters `p` in this parameterization.
    pub fn matrix(self, p: &Vector3<f64>) -> Matrix3<f64> {
        match self {
            RotationKind::EulerXyz => EulerXyz::matrix(p),
            RotationKind::AxisAngle | RotationKind::So3 => AxisAngle::matrix(p),
        }
    }

    /// The parameters of rotation matrix `r` in this parameterization.
    pub fn from_matrix(self, r: &Matrix3<f64>) -> Vector3<f64> {
        match self {
            RotationKind::EulerXyz => EulerXyz::from_matrix(r),
            RotationKind::AxisAngle | RotationKind::So3 => AxisAngle::from_matrix(r),
        }
    }

    /// The name used in reports and files.
    pub fn name(self) -> &'static str {
        match self {
            RotationKind::EulerXyz => EulerXyz::NAME,
            RotationKind::AxisAngle => AxisAngle::NAME,
            RotationKind::So3 => So3::NAME,
        }
    }

    /// True if the solver must update rotation blocks on the manifold (`lm_solver::manifold::
    /// RotationVector`) rather than additively.
    pub fn needs_manifold(self) -> bool {
        self == RotationKind::So3
    }
}

impl std::str::FromStr for RotationKind {
    type Err = String;

    /// The names of [`RotationKind::name`]: `euler-xyz`, `axis-angle`, `so3`.
    fn from_str(s: &str) -> Result<Self, String> {
        [
            RotationKind::EulerXyz,
            RotationKind::AxisAngle,
            RotationKind::So3,
        ]
        .into_iter()
        .find(|k| k.name() == s)
        .ok_or_else(|| format!("unknown rotation parameterization '{s}'"))
    }
}

/// Euler angles `(theta_x, theta_y, theta_z)` in radians, applied about the fixed axes X, then Y,
/// then Z: `R = Rz(theta_z) * Ry(theta_y) * Rx(theta_x)`.
///
/// The parameterization is singular (gimbal lock) at `theta_y = +-pi/2`, where only
/// `theta_x - theta_z` (or `theta_x + theta_z`) is determined. For a camera looking at a board
/// that means a board seen exactly edge-on, which calibration never uses; for the rotation
/// between two cameras it means one camera turned 90 degrees about y from the other, a real
/// layout: stereo and rig calibration default to [`So3`] for that reason.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EulerXyz;

/// Elementary rotation about X by angle with sine `s` and cosine `c`.
#[inline]
fn rot_x(s: f64, c: f64) -> Matrix3<f64> {
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

/// Elementary rotation about Y.
#[inline]
fn rot_y(s: f64, c: f64) -> Matrix3<f64> {
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

/// Elementary rotation about Z.
#[inline]
fn rot_z(s: f64, c: f64) -> Matrix3<f64> {
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

// d/dtheta of an elementary rotation with (s, c) = (sin, cos) theta: the same pattern with
// s -> c, c -> -s, and the fixed axis' 1 -> 0.
#[inline]
fn d_rot_x(s: f64, c: f64) -> Matrix3<f64> {
    Matrix3::new(0.0, 0.0, 0.0, 0.0, -s, -c, 0.0, c, -s)
}

#[inline]
fn d_rot_y(s: f64, c: f64) -> Matrix3<f64> {
    Matrix3::new(-s, 0.0, c, 0.0, 0.0, 0.0, -c, 0.0, -s)
}

#[inline]
fn d_rot_z(s: f64, c: f64) -> Matrix3<f64> {
    Matrix3::new(-s, -c, 0.0, c, -s, 0.0, 0.0, 0.0, 0.0)
}

impl RotationParameterization for EulerXyz {
    const NAME: &'static str = "euler-xyz";

    #[inline]
    fn matrix(p: &Vector3<f64>) -> Matrix3<f64> {
        let (sx, cx) = p.x.sin_cos();
        let (sy, cy) = p.y.sin_cos();
        let (sz, cz) = p.z.sin_cos();
        rot_z(sz, cz) * rot_y(sy, cy) * rot_x(sx, cx)
    }

    #[inline]
    fn matrix_and_derivatives(p: &Vector3<f64>) -> (Matrix3<f64>, [Matrix3<f64>; 3]) {
        let (sx, cx) = p.x.sin_cos();
        let (sy, cy) = p.y.sin_cos();
        let (sz, cz) = p.z.sin_cos();
        let (rx, ry, rz) = (rot_x(sx, cx), rot_y(sy, cy), rot_z(sz, cz));
        let rzy = rz * ry;
        let r = rzy * rx;
        let d_x = rzy * d_rot_x(sx, cx);
        let d_y = rz * d_rot_y(sy, cy) * rx;
        let d_z = d_rot_z(sz, cz) * ry * rx;
        (r, [d_x, d_y, d_z])
    }

    /// `theta_x = atan2(R32, R33)`, `theta_y = atan2(-R31, sqrt(R11^2 + R21^2))`,
    /// `theta_z = atan2(R21, R11)` (one-based indices), so `theta_y` is in `[-pi/2, pi/2]` and the
    /// other two in `(-pi, pi]`. At gimbal lock (`cos theta_y` below `1e-12`) `theta_z` is set to
    /// zero and `theta_x` carries the whole remaining rotation.
    fn from_matrix(r: &Matrix3<f64>) -> Vector3<f64> {
        let cos_y = r[(0, 0)].hypot(r[(1, 0)]);
        let theta_y = (-r[(2, 0)]).atan2(cos_y);
        if cos_y > 1e-12 {
            Vector3::new(
                r[(2, 1)].atan2(r[(2, 2)]),
                theta_y,
                r[(1, 0)].atan2(r[(0, 0)]),
            )
        } else if r[(2, 0)] < 0.0 {
            // theta_y = +pi/2: R12 = sin(theta_x - theta_z), R22 = cos(theta_x - theta_z).
            Vector3::new(r[(0, 1)].atan2(r[(1, 1)]), theta_y, 0.0)
        } else {
            // theta_y = -pi/2: R12 = -sin(theta_x + theta_z), R22 = cos(theta_x + theta_z).
            Vector3::new((-r[(0, 1)]).atan2(r[(1, 1)]), theta_y, 0.0)
        }
    }
}

/// Rotations stored as rotation vectors (like [`AxisAngle`]) but differentiated on the rotation
/// manifold: the three parameters the solver sees are a body-frame increment `delta` at zero,
/// `R(w ⊞ delta) = R(w) exp([delta]x)`, so the "derivatives" are `dR/d delta_k = R [e_k]x` at any
/// rotation: no singularity anywhere, unlike Euler angles at `theta_y = pi/2` and additive
/// rotation vectors at `|w| = pi`.
///
/// Only meaningful with a solver that applies the update `w ⊞ delta = log(exp(w) exp(delta))`
/// (`lm_solver::manifold::RotationVector`), which calibration sets up for this kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct So3;

impl RotationParameterization for So3 {
    const NAME: &'static str = "so3";

    #[inline]
    fn matrix(p: &Vector3<f64>) -> Matrix3<f64> {
        AxisAngle::matrix(p)
    }

    #[inline]
    fn matrix_and_derivatives(p: &Vector3<f64>) -> (Matrix3<f64>, [Matrix3<f64>; 3]) {
        let r = AxisAngle::matrix(p);
        let d = [
            r * skew(&Vector3::x()),
            r * skew(&Vector3::y()),
            r * skew(&Vector3::z()),
        ];
        (r, d)
    }

    fn from_matrix(r: &Matrix3<f64>) -> Vector3<f64> {
        AxisAngle::from_matrix(r)
    }
}

/// Axis-angle (rotation vector) `w`: the rotation by angle `|w|` radians about the unit axis
/// `w / |w|` (Rodrigues' formula), the same convention as OpenCV's `rvec`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct AxisAngle;

/// The cross-product matrix `[w]x`, such that `[w]x v = w x v`.
#[inline]
pub fn skew(w: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -w.z, w.y, w.z, 0.0, -w.x, -w.y, w.x, 0.0)
}

/// The vector of a skew-symmetric part: `vee(M) = (M32 - M23, M13 - M31, M21 - M12) / 2`.
#[inline]
fn vee_antisymmetric(m: &Matrix3<f64>) -> Vector3<f64> {
    0.5 * Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    )
}

/// Coefficients of Rodrigues' formula `R = I + a K + b K^2` (`K = [w]x`, `theta = |w|`) and their
/// derivatives divided by theta: `c = a'(theta)/theta`, `d = b'(theta)/theta`.
/// Below theta = 1e-2 the Taylor series is used; its first omitted terms are below 1e-16.
#[inline]
fn rodrigues_coefficients(theta2: f64) -> (f64, f64, f64, f64) {
    if theta2 < 1e-4 {
        let t4 = theta2 * theta2;
        (
            1.0 - theta2 / 6.0 + t4 / 120.0,
            0.5 - theta2 / 24.0 + t4 / 720.0,
            -1.0 / 3.0 + theta2 / 30.0 - t4 / 840.0,
            -1.0 / 12.0 + theta2 / 180.0 - t4 / 6720.0,
        )
    } else {
        let theta = theta2.sqrt();
        let (s, c) = theta.sin_cos();
        let a = s / theta;
        let b = (1.0 - c) / theta2;
        let cc = (theta * c - s) / (theta2 * theta);
        let d = (theta * s - 2.0 * (1.0 - c)) / (theta2 * theta2);
        (a, b, cc, d)
    }
}

impl RotationParameterization for AxisAngle {
    const NAME: &'static str = "axis-angle";

    #[inline]
    fn matrix(w: &Vector3<f64>) -> Matrix3<f64> {
        let (a, b, _, _) = rodrigues_coefficients(w.norm_squared());
        let k = skew(w);
        Matrix3::identity() + a * k + b * (k * k)
    }

    fn matrix_and_derivatives(w: &Vector3<f64>) -> (Matrix3<f64>, [Matrix3<f64>; 3]) {
        // R = I + a K + b K^2 with a, b functions of theta = |w| and K = [w]x. By the product rule,
        // dR/dw_k = a E_k + b (E_k K + K E_k) + (c K + d K^2) w_k, with E_k = [e_k]x and
        // c = a'/theta, d = b'/theta (d theta / d w_k = w_k / theta).
        let (a, b, c, d) = rodrigues_coefficients(w.norm_squared());
        let k = skew(w);
        let k2 = k * k;
        let r = Matrix3::identity() + a * k + b * k2;
        let tail = c * k + d * k2;
        let mut derivatives = [Matrix3::zeros(); 3];
        for (axis, out) in derivatives.iter_mut().enumerate() {
            let e = skew(&Vector3::ith(axis, 1.0));
            *out = a * e + b * (e * k + k * e) + w[axis] * tail;
        }
        (r, derivatives)
    }

    /// The rotation vector with angle in `[0, pi]`. The angle comes from
    /// `atan2(|vee(R - R^T)| / 2, (trace R - 1) / 2)`, accurate at every angle; near `pi` the axis
    /// is taken from the symmetric part `R + I = 2 n n^T` (the antisymmetric part vanishes there).
    fn from_matrix(r: &Matrix3<f64>) -> Vector3<f64> {
        let v = vee_antisymmetric(r);
        let sin_theta = v.norm();
        let cos_theta = 0.5 * (r.trace() - 1.0);
        let theta = sin_theta.atan2(cos_theta);
        if theta < 1e-6 {
            // theta / sin(theta) = 1 + theta^2 / 6 + ...
            return v * (1.0 + theta * theta / 6.0);
        }
        if cos_theta > -0.9 {
            return v * (theta / sin_theta);
        }
        // Near pi: (R + R^T)/2 = cos(theta) I + (1 - cos theta) n n^T, so removing the cos(theta) I
        // leaves a rank-one matrix whose largest column is the most accurate multiple of n.
        let sym = 0.5 * (r + r.transpose()) - Matrix3::identity() * cos_theta;
        let mut best = 0;
        for i in 1..3 {
            if sym[(i, i)] > sym[(best, best)] {
                best = i;
            }
        }
        let mut n: Vector3<f64> = sym.column(best).into_owned();
        let norm = n.norm();
        if norm == 0.0 {
            return Vector3::zeros();
        }
        n /= norm;
        // The antisymmetric part is sin(theta) n: it fixes the sign of n when it is not negligible.
        if n.dot(&v) < 0.0 {
            n = -n;
        }
        n * theta
    }
}

/// The nearest rotation matrix (in the Frobenius norm) to `m`: `U V^T` from the SVD `m = U S V^T`,
/// with the sign of the last singular direction flipped if needed so that the determinant is +1.
///
/// Returns `None` if the SVD does not converge or `m` has non-finite entries.
pub fn nearest_rotation(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    if m.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let svd = m.svd(true, true);
    let u = svd.u?;
    let v_t = svd.v_t?;
    let mut r = u * v_t;
    if r.determinant() < 0.0 {
        // nalgebra sorts singular values in decreasing order, so the last one is the smallest.
        let mut u = u;
        u.column_mut(2).neg_mut();
        r = u * v_t;
    }
    Some(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use lm_solver::numdiff::{central_difference, compare_jacobians};
    use proptest::prelude::*;

    fn check_derivatives<P: RotationParameterization>(p: Vector3<f64>) -> Result<(), String> {
        let (r, d) = P::matrix_and_derivatives(&p);
        assert_relative_eq!(r, P::matrix(&p), epsilon = 1e-14);
        let f = |x: &[f64], out: &mut [f64]| {
            out.copy_from_slice(P::matrix(&Vector3::new(x[0], x[1], x[2])).as_slice());
        };
        let numeric = central_difference(f, p.as_slice(), 9, 1e-6);
        let analytic: Vec<f64> = d.iter().flat_map(|m| m.as_slice().to_vec()).collect();
        // Entries of R are bounded by 1 and are computed to a few ulps (~1e-15); the central
        // difference divides that rounding by 2h = 2e-6 max(|p|, 1), giving up to ~5e-10, while
        // truncation (h^2 |R'''| / 6 with |R'''| of order one) is ~1e-12. The tolerance
        // 1e-6 (|numeric| + 1e-3), at least 1e-9, is twice the worst noise; a wrong sign or a
        // missing term is off by 1e-2 or more.
        compare_jacobians(&analytic, &numeric, 9, 1e-6, 1e-3).map_err(|e| e.to_string())
    }

    fn is_rotation(r: &Matrix3<f64>) -> bool {
        (r.transpose() * r - Matrix3::identity()).norm() < 1e-12
            && (r.determinant() - 1.0).abs() < 1e-12
    }

    #[test]
    fn euler_matches_the_expanded_matrix_of_the_specification() {
        // Entries written out from the product Rz Ry Rx.
        let (tx, ty, tz) = (0.3_f64, -0.7_f64, 1.9_f64);
        let (sx, cx, sy, cy, sz, cz) = (tx.sin(), tx.cos(), ty.sin(), ty.cos(), tz.sin(), tz.cos());
        let expected = Matrix3::new(
            cy * cz,
            -cx * sz + sx * sy * cz,
            sx * sz + cx * sy * cz,
            cy * sz,
            cx * cz + sx * sy * sz,
            -sx * cz + cx * sy * sz,
            -sy,
            sx * cy,
            cx * cy,
        );
        assert_relative_eq!(
            EulerXyz::matrix(&Vector3::new(tx, ty, tz)),
            expected,
            epsilon = 1e-15
        );
    }

    #[test]
    fn euler_rotation_direction() {
        // A positive rotation about Z takes the X axis towards the Y axis.
        let r = EulerXyz::matrix(&Vector3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2));
        assert_relative_eq!(r * Vector3::x(), Vector3::y(), epsilon = 1e-15);
        let r = AxisAngle::matrix(&Vector3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2));
        assert_relative_eq!(r * Vector3::x(), Vector3::y(), epsilon = 1e-15);
    }

    #[test]
    fn euler_gimbal_lock_round_trips_the_matrix() {
        for ty in [std::f64::consts::FRAC_PI_2, -std::f64::consts::FRAC_PI_2] {
            let r = EulerXyz::matrix(&Vector3::new(0.4, ty, -0.3));
            let back = EulerXyz::matrix(&EulerXyz::from_matrix(&r));
            assert_relative_eq!(r, back, epsilon = 1e-12);
        }
    }

    #[test]
    fn axis_angle_near_zero_and_pi() {
        for w in [
            Vector3::new(1e-9, -2e-9, 3e-10),
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1e-3, 2e-3, -1e-3),
            Vector3::new(std::f64::consts::PI, 0.0, 0.0),
            Vector3::new(0.0, -std::f64::consts::PI, 0.0),
            Vector3::new(1.0, 1.0, 1.0).normalize() * (std::f64::consts::PI - 1e-9),
            Vector3::new(-1.0, 2.0, 0.5).normalize() * (std::f64::consts::PI - 1e-3),
        ] {
            let r = AxisAngle::matrix(&w);
            assert!(is_rotation(&r));
            let back = AxisAngle::from_matrix(&r);
            assert_relative_eq!(AxisAngle::matrix(&back), r, epsilon = 1e-12);
            if w.norm() < 3.0 {
                assert_relative_eq!(back, w, epsilon = 1e-12);
            }
        }
    }

    #[test]
    fn axis_angle_derivatives_at_zero_and_series_boundary() {
        for w in [
            Vector3::zeros(),
            Vector3::new(0.006, -0.005, 0.0051),
            Vector3::new(0.0058, 0.0, 0.0),
            Vector3::new(0.0101, 0.0, 0.0),
        ] {
            check_derivatives::<AxisAngle>(w).unwrap();
        }
    }

    #[test]
    fn nearest_rotation_projects_and_fixes_reflections() {
        let r = EulerXyz::matrix(&Vector3::new(0.2, -0.1, 0.4));
        let noisy = r + Matrix3::new(1e-3, 0.0, 2e-3, 0.0, -1e-3, 0.0, 1e-3, 0.0, 0.0);
        let q = nearest_rotation(&noisy).unwrap();
        assert!(is_rotation(&q));
        assert!((q - r).norm() < 5e-3);
        let reflection = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
        assert!(is_rotation(&nearest_rotation(&reflection).unwrap()));
        assert!(nearest_rotation(&Matrix3::from_element(f64::NAN)).is_none());
    }

    proptest! {
        #[test]
        fn euler_derivatives_match_finite_differences(
            x in -3.1f64..3.1, y in -1.45f64..1.45, z in -3.1f64..3.1
        ) {
            prop_assert!(check_derivatives::<EulerXyz>(Vector3::new(x, y, z)).is_ok());
        }

        #[test]
        fn axis_angle_derivatives_match_finite_differences(
            x in -2.0f64..2.0, y in -2.0f64..2.0, z in -2.0f64..2.0
        ) {
            let r = check_derivatives::<AxisAngle>(Vector3::new(x, y, z));
            prop_assert!(r.is_ok(), "{:?}", r);
        }

        #[test]
        fn euler_inverse_round_trips(x in -3.1f64..3.1, y in -1.5f64..1.5, z in -3.1f64..3.1) {
            let p = Vector3::new(x, y, z);
            let r = EulerXyz::matrix(&p);
            prop_assert!(is_rotation(&r));
            let back = EulerXyz::from_matrix(&r);
            // Away from gimbal lock the angles themselves come back.
            prop_assert!((back - p).norm() < 1e-9, "{back} vs {p}");
        }

        #[test]
        fn axis_angle_inverse_round_trips(x in -1.8f64..1.8, y in -1.8f64..1.8, z in -1.8f64..1.8) {
            let w = Vector3::new(x, y, z);
            prop_assume!(w.norm() < std::f64::consts::PI - 1e-6);
            let back = AxisAngle::from_matrix(&AxisAngle::matrix(&w));
            prop_assert!((back - w).norm() < 1e-9 * (1.0 + w.norm()));
        }

        #[test]
        fn euler_and_axis_angle_describe_the_same_rotations(
            x in -3.1f64..3.1, y in -1.5f64..1.5, z in -3.1f64..3.1
        ) {
            let r = EulerXyz::matrix(&Vector3::new(x, y, z));
            let w = AxisAngle::from_matrix(&r);
            prop_assert!((AxisAngle::matrix(&w) - r).norm() < 1e-10);
        }
    }
}
