//! Rigid poses (world/board frame to camera frame) and their derivatives.

use crate::rotation::RotationParameterization;
use nalgebra::{Matrix3, Matrix3x6, Point3, Vector3, Vector6};

/// A rigid transform from the world (board) frame to the camera frame:
/// `X_camera = rotation * X_world + translation`.
///
/// The camera frame is OpenCV's: `x` right, `y` down, `z` forward along the optical axis, so points
/// in front of the camera have positive `z`. `translation` is the world origin expressed in the
/// camera frame, in the world's length unit.
///
/// In files (serde) a pose is `{"rotation_matrix": [[...], [...], [...]], "rotation_vector":
/// [...], "euler_xyz": [...], "translation": [...]}` (rows of `R`; the rotation vector and Euler
/// X-Y-Z angles are for readers); reading takes `rotation_matrix` (as it is if orthonormal to
/// 1e-12, else projected onto the rotations) or, if absent, `rotation_vector`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Rotation matrix `R` (world to camera).
    pub rotation: Matrix3<f64>,
    /// Translation `t` (world origin in camera coordinates).
    pub translation: Vector3<f64>,
}

#[derive(serde::Serialize, serde::Deserialize)]
struct PoseJson {
    #[serde(default)]
    rotation_matrix: Option<[[f64; 3]; 3]>,
    #[serde(default)]
    rotation_vector: Option<[f64; 3]>,
    #[serde(default, skip_deserializing)]
    euler_xyz: Option<[f64; 3]>,
    translation: [f64; 3],
}

impl serde::Serialize for Pose {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use crate::rotation::{AxisAngle, EulerXyz};
        let r = &self.rotation;
        let w = AxisAngle::from_matrix(r);
        let e = EulerXyz::from_matrix(r);
        PoseJson {
            rotation_matrix: Some(std::array::from_fn(|i| std::array::from_fn(|j| r[(i, j)]))),
            rotation_vector: Some([w.x, w.y, w.z]),
            euler_xyz: Some([e.x, e.y, e.z]),
            translation: [self.translation.x, self.translation.y, self.translation.z],
        }
        .serialize(serializer)
    }
}

impl<'de> serde::Deserialize<'de> for Pose {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        use crate::rotation::{AxisAngle, nearest_rotation};
        let j = PoseJson::deserialize(deserializer)?;
        let rotation = match (j.rotation_matrix, j.rotation_vector) {
            (Some(m), _) => {
                let m = Matrix3::from_fn(|i, k| m[i][k]);
                // A rotation written by this crate reads back bit for bit; anything else is
                // projected onto the rotations.
                let orthonormal = (m.transpose() * m - Matrix3::identity()).norm() < 1e-12
                    && m.determinant() > 0.0;
                if orthonormal {
                    m
                } else {
                    nearest_rotation(&m).ok_or_else(|| {
                        serde::de::Error::custom("rotation_matrix is not close to a rotation")
                    })?
                }
            }
            (None, Some(w)) => AxisAngle::matrix(&Vector3::from(w)),
            (None, None) => {
                return Err(serde::de::Error::custom(
                    "a pose needs rotation_matrix or rotation_vector",
                ));
            }
        };
        Ok(Pose::new(rotation, Vector3::from(j.translation)))
    }
}

impl Default for Pose {
    fn default() -> Self {
        Self::identity()
    }
}

impl Pose {
    /// Pose from a rotation matrix and a translation.
    pub fn new(rotation: Matrix3<f64>, translation: Vector3<f64>) -> Self {
        Self {
            rotation,
            translation,
        }
    }

    /// The identity transform.
    pub fn identity() -> Self {
        Self::new(Matrix3::identity(), Vector3::zeros())
    }

    /// Pose from the 6-vector `[rotation parameters (3), translation (3)]` in parameterization `P`.
    pub fn from_params<P: RotationParameterization>(params: &Vector6<f64>) -> Self {
        Self::new(
            P::matrix(&params.fixed_rows::<3>(0).into_owned()),
            params.fixed_rows::<3>(3).into_owned(),
        )
    }

    /// The 6-vector `[rotation parameters (3), translation (3)]` in parameterization `P`.
    pub fn to_params<P: RotationParameterization>(&self) -> Vector6<f64> {
        let r = P::from_matrix(&self.rotation);
        Vector6::new(
            r.x,
            r.y,
            r.z,
            self.translation.x,
            self.translation.y,
            self.translation.z,
        )
    }

    /// Transforms a world point into the camera frame.
    #[inline]
    pub fn transform_point(&self, p: &Point3<f64>) -> Vector3<f64> {
        self.rotation * p.coords + self.translation
    }

    /// The composition `self * other`: first `other`, then `self`.
    ///
    /// For a stereo rig with `self` = rig (left camera to right camera) and `other` = left camera
    /// pose, the result is the right camera's pose: `R_R = R_s R_L`, `t_R = R_s t_L + t_s`.
    pub fn compose(&self, other: &Pose) -> Pose {
        Pose::new(
            self.rotation * other.rotation,
            self.rotation * other.translation + self.translation,
        )
    }

    /// The inverse transform (camera to world).
    pub fn inverse(&self) -> Pose {
        let rt = self.rotation.transpose();
        Pose::new(rt, -(rt * self.translation))
    }
}

/// A pose prepared for differentiation: the rotation matrix and its three derivatives with respect
/// to the rotation parameters are computed once, then reused for every point of a view.
///
/// The pose parameters are `m = [rho (3 rotation parameters), t (3)]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DifferentiablePose {
    /// Rotation matrix `R(rho)`.
    pub rotation: Matrix3<f64>,
    /// `dR / d rho_k`, `k = 0, 1, 2`.
    pub rotation_derivatives: [Matrix3<f64>; 3],
    /// Translation `t`.
    pub translation: Vector3<f64>,
}

impl DifferentiablePose {
    /// Prepares the pose with parameters `[rho, t]` in parameterization `P`.
    #[inline]
    pub fn new<P: RotationParameterization>(params: &Vector6<f64>) -> Self {
        let rho = Vector3::new(params[0], params[1], params[2]);
        let (rotation, rotation_derivatives) = P::matrix_and_derivatives(&rho);
        Self {
            rotation,
            rotation_derivatives,
            translation: Vector3::new(params[3], params[4], params[5]),
        }
    }

    /// The body-frame generators `omega_k` of the rotation parameters: `dR/drho_k = R [omega_k]x`
    /// (columns of the returned matrix). For any parameterization `R^T dR/drho_k` is skew
    /// symmetric, and its vector is `omega_k`. They let a derivative `(dR/drho_k) X` be written as
    /// `R (omega_k x X)`, which is linear in `omega_k` with a point-dependent factor.
    pub fn body_generators(&self) -> Matrix3<f64> {
        let mut omega = Matrix3::zeros();
        for (k, d) in self.rotation_derivatives.iter().enumerate() {
            let m = self.rotation.transpose() * d;
            omega.set_column(
                k,
                &Vector3::new(
                    0.5 * (m[(2, 1)] - m[(1, 2)]),
                    0.5 * (m[(0, 2)] - m[(2, 0)]),
                    0.5 * (m[(1, 0)] - m[(0, 1)]),
                ),
            );
        }
        omega
    }

    /// The plain pose.
    pub fn pose(&self) -> Pose {
        Pose::new(self.rotation, self.translation)
    }

    /// The camera-frame point `s = R X + t` and `ds/dm` (3x6): the columns `dR/drho_k X`, then the
    /// identity for the translation.
    ///
    /// This is the specification's chain `d[R|t]/dm` contracted with the point first: each column
    /// of `d[R|t]/dm` is one `dR/drho_k` (or a unit translation), and multiplying it by `[X; 1]`
    /// gives the corresponding column here. Doing the contraction before the product with
    /// `dp/d[R|t]` costs 3x6 instead of 2x12x6 operations per point.
    #[inline]
    pub fn transform_with_jacobian(&self, p: &Point3<f64>) -> (Vector3<f64>, Matrix3x6<f64>) {
        let s = self.rotation * p.coords + self.translation;
        let d0 = self.rotation_derivatives[0] * p.coords;
        let d1 = self.rotation_derivatives[1] * p.coords;
        let d2 = self.rotation_derivatives[2] * p.coords;
        let jac = Matrix3x6::new(
            d0.x, d1.x, d2.x, 1.0, 0.0, 0.0, //
            d0.y, d1.y, d2.y, 0.0, 1.0, 0.0, //
            d0.z, d1.z, d2.z, 0.0, 0.0, 1.0,
        );
        (s, jac)
    }
}

/// Derivatives of a composed pose `C = A * B` (`R_C = R_A R_B`, `t_C = R_A t_B + t_A`).
///
/// A pose is written as the 12-vector `Rt = [R11, R21, R31, R12, R22, R32, R13, R23, R33, tx, ty,
/// tz]` (the rotation column by column, then the translation). For a stereo rig, `A` is the rig
/// (left camera to right camera) and `B` the left camera's pose, so `C` is the right camera's pose.
pub mod composition {
    use super::{DifferentiablePose, Pose};
    use crate::rotation::RotationParameterization;
    use nalgebra::{Matrix3, Matrix3x6, Point3, SMatrix, Vector3, Vector6};

    /// `d Rt_C / d Rt_B`: each column of `R_B`, and `t_B`, is multiplied by `R_A`, so the matrix is
    /// block diagonal with four copies of `R_A`.
    pub fn d_composed_d_inner(outer: &Pose) -> SMatrix<f64, 12, 12> {
        let mut m = SMatrix::<f64, 12, 12>::zeros();
        for block in 0..4 {
            m.fixed_view_mut::<3, 3>(3 * block, 3 * block)
                .copy_from(&outer.rotation);
        }
        m
    }

    /// `d Rt_C / d Rt_A`: column `j` of `R_C` is `sum_k R_B[k, j] (column k of R_A)` and
    /// `t_C = sum_k t_B[k] (column k of R_A) + t_A`, so each 3x3 block is a multiple of the
    /// identity, and `t_A` enters with the identity.
    pub fn d_composed_d_outer(inner: &Pose) -> SMatrix<f64, 12, 12> {
        let mut m = SMatrix::<f64, 12, 12>::zeros();
        for k in 0..3 {
            for j in 0..3 {
                let value = inner.rotation[(k, j)];
                for i in 0..3 {
                    m[(3 * j + i, 3 * k + i)] = value;
                }
            }
            for i in 0..3 {
                m[(9 + i, 3 * k + i)] = inner.translation[k];
            }
        }
        for i in 0..3 {
            m[(9 + i, 9 + i)] = 1.0;
        }
        m
    }

    /// `d Rt / d m` for pose parameters `m = [rho, t]` in parameterization `P` (12x6): the
    /// derivatives of the rotation entries with respect to `rho`, and the identity for `t`.
    pub fn d_rt_d_params<P: RotationParameterization>(
        params: &Vector6<f64>,
    ) -> SMatrix<f64, 12, 6> {
        let (_, derivatives) =
            P::matrix_and_derivatives(&Vector3::new(params[0], params[1], params[2]));
        let mut m = SMatrix::<f64, 12, 6>::zeros();
        for (k, d) in derivatives.iter().enumerate() {
            for (row, value) in d.iter().enumerate() {
                m[(row, k)] = *value;
            }
        }
        for i in 0..3 {
            m[(9 + i, 3 + i)] = 1.0;
        }
        m
    }

    /// The composition `C = A * B` prepared for differentiation with respect to both poses'
    /// parameters. The per-point derivatives are the chains
    /// `ds/dm_B = ds/dRt_C * dRt_C/dRt_B * dRt_B/dm_B` and the same for `A`, contracted with the
    /// point first as in [`DifferentiablePose::transform_with_jacobian`]:
    /// `ds/drho_B,k = R_A (dR_B/drho_k) X`, `ds/dt_B = R_A`, `ds/drho_A,k = (dR_A/drho_k)(R_B X + t_B)`,
    /// `ds/dt_A = I`.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct DifferentiableComposition {
        /// The outer pose `A` (e.g. the stereo rig).
        pub outer: DifferentiablePose,
        /// The inner pose `B` (e.g. the left camera's pose).
        pub inner: DifferentiablePose,
        /// `R_A dR_B/drho_k`, `k = 0, 1, 2`.
        outer_times_inner_derivatives: [Matrix3<f64>; 3],
        /// `R_C = R_A R_B`.
        composed_rotation: Matrix3<f64>,
        /// `t_C = R_A t_B + t_A`.
        composed_translation: Vector3<f64>,
    }

    impl DifferentiableComposition {
        /// Prepares `A * B` from the parameters of `A` (outer) and `B` (inner).
        pub fn new<P: RotationParameterization>(
            outer: &Vector6<f64>,
            inner: &Vector6<f64>,
        ) -> Self {
            let outer = DifferentiablePose::new::<P>(outer);
            let inner = DifferentiablePose::new::<P>(inner);
            Self {
                outer_times_inner_derivatives: inner
                    .rotation_derivatives
                    .map(|d| outer.rotation * d),
                composed_rotation: outer.rotation * inner.rotation,
                composed_translation: outer.rotation * inner.translation + outer.translation,
                outer,
                inner,
            }
        }

        /// The composed pose `C`.
        pub fn composed(&self) -> Pose {
            Pose::new(self.composed_rotation, self.composed_translation)
        }

        /// `s = R_C X + t_C`, with `ds/dm_inner` and `ds/dm_outer` (3x6 each).
        #[inline]
        pub fn transform_with_jacobians(
            &self,
            p: &Point3<f64>,
        ) -> (Vector3<f64>, Matrix3x6<f64>, Matrix3x6<f64>) {
            let inner_point = self.inner.rotation * p.coords + self.inner.translation;
            let s = self.outer.rotation * inner_point + self.outer.translation;
            let mut d_inner = Matrix3x6::zeros();
            let mut d_outer = Matrix3x6::zeros();
            for k in 0..3 {
                d_inner.set_column(k, &(self.outer_times_inner_derivatives[k] * p.coords));
                d_outer.set_column(k, &(self.outer.rotation_derivatives[k] * inner_point));
            }
            d_inner
                .fixed_view_mut::<3, 3>(0, 3)
                .copy_from(&self.outer.rotation);
            d_outer
                .fixed_view_mut::<3, 3>(0, 3)
                .copy_from(&Matrix3::identity());
            (s, d_inner, d_outer)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::composition::*;
    use super::*;
    use crate::rotation::{AxisAngle, EulerXyz};
    use lm_solver::numdiff::{central_difference, compare_jacobians};
    use nalgebra::SMatrix;
    use proptest::prelude::*;

    fn rt_vector(p: &Pose) -> Vec<f64> {
        let mut v: Vec<f64> = p.rotation.iter().copied().collect();
        v.extend(p.translation.iter());
        v
    }

    fn pose_from_rt(v: &[f64]) -> Pose {
        Pose::new(
            Matrix3::from_column_slice(&v[..9]),
            Vector3::new(v[9], v[10], v[11]),
        )
    }

    fn params() -> impl Strategy<Value = Vector6<f64>> {
        (
            -1.5f64..1.5,
            -1.2f64..1.2,
            -3.0f64..3.0,
            -1.0f64..1.0,
            -1.0f64..1.0,
            -1.0f64..2.0,
        )
            .prop_map(|(a, b, c, x, y, z)| Vector6::new(a, b, c, x, y, z))
    }

    proptest! {
        /// The specification's dRt_R/dRt_L and dRt_R/dRt_s (here for all 12 entries of [R|t])
        /// against central differences of the composition over free 12-vectors. The composition is
        /// bilinear, so there is no truncation error; rounding is eps |f| / h ~ 3e-10 for entries of
        /// order one, so the bound is 1e-9 (|numeric| + 1).
        #[test]
        fn composition_jacobians_match_finite_differences(a in params(), b in params()) {
            let (outer, inner) = (Pose::from_params::<EulerXyz>(&a), Pose::from_params::<EulerXyz>(&b));
            let numeric_inner = central_difference(
                |v: &[f64], out: &mut [f64]| out.copy_from_slice(&rt_vector(&outer.compose(&pose_from_rt(v)))),
                &rt_vector(&inner), 12, 1e-6);
            prop_assert!(compare_jacobians(d_composed_d_inner(&outer).as_slice(), &numeric_inner, 12, 1e-9, 1.0).is_ok());
            let numeric_outer = central_difference(
                |v: &[f64], out: &mut [f64]| out.copy_from_slice(&rt_vector(&pose_from_rt(v).compose(&inner))),
                &rt_vector(&outer), 12, 1e-6);
            let r = compare_jacobians(d_composed_d_outer(&inner).as_slice(), &numeric_outer, 12, 1e-9, 1.0);
            prop_assert!(r.is_ok(), "{:?}", r);
        }

        /// dRt/dm against central differences (rotation entries and the translation are O(1), so
        /// the bound of the rotation test applies: 1e-6 relative, 1e-3 floor).
        #[test]
        fn rt_params_jacobian_matches_finite_differences(m in params()) {
            let numeric = central_difference(
                |v: &[f64], out: &mut [f64]| out.copy_from_slice(&rt_vector(&Pose::from_params::<AxisAngle>(&Vector6::from_column_slice(v)))),
                m.as_slice(), 12, 1e-6);
            let r = compare_jacobians(d_rt_d_params::<AxisAngle>(&m).as_slice(), &numeric, 12, 1e-6, 1e-3);
            prop_assert!(r.is_ok(), "{:?}", r);
        }

        /// `dR/drho_k = R [omega_k]x` with the body-frame generators, for both parameterizations.
        #[test]
        fn body_generators_reproduce_the_rotation_derivatives(m in params(), axis_angle in prop::bool::ANY) {
            let pose = if axis_angle { DifferentiablePose::new::<AxisAngle>(&m) } else { DifferentiablePose::new::<EulerXyz>(&m) };
            let omega = pose.body_generators();
            for k in 0..3 {
                let rebuilt = pose.rotation * crate::rotation::skew(&omega.column(k).into_owned());
                prop_assert!((rebuilt - pose.rotation_derivatives[k]).norm() < 1e-12);
            }
        }

        /// The per-point contracted derivatives equal the literal chain of the specification:
        /// ds/dm_B = ds/dRt_C * dRt_C/dRt_B * dRt_B/dm_B, and the same for A.
        #[test]
        fn contracted_chain_equals_the_literal_chain(a in params(), b in params(), x in -1.0f64..1.0, y in -1.0f64..1.0, z in -0.5f64..0.5) {
            let c = DifferentiableComposition::new::<EulerXyz>(&a, &b);
            let point = Point3::new(x, y, z);
            let (s, d_inner, d_outer) = c.transform_with_jacobians(&point);
            prop_assert!((s - c.composed().transform_point(&point)).norm() < 1e-12);
            // ds/dRt = [X I, Y I, Z I, I].
            let mut ds_drt = SMatrix::<f64, 3, 12>::zeros();
            for k in 0..3 {
                for i in 0..3 {
                    ds_drt[(i, 3 * k + i)] = point[k];
                }
            }
            for i in 0..3 {
                ds_drt[(i, 9 + i)] = 1.0;
            }
            let (outer, inner) = (c.outer.pose(), c.inner.pose());
            let literal_inner = ds_drt * d_composed_d_inner(&outer) * d_rt_d_params::<EulerXyz>(&b);
            let literal_outer = ds_drt * d_composed_d_outer(&inner) * d_rt_d_params::<EulerXyz>(&a);
            prop_assert!((literal_inner - d_inner).norm() < 1e-12);
            prop_assert!((literal_outer - d_outer).norm() < 1e-12);
        }
    }
}
