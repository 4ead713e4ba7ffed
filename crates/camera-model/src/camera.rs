//! A camera = projection x distortion x intrinsics: world points to distorted pixels, with
//! analytic Jacobians.
//!
//! The chain for a world point `X` and pose parameters `m = [rho, t]`:
//!
//! ```text
//! s = R(rho) X + t                      camera frame
//! n = projection(s)                     projection plane (pinhole: (s_x / s_z, s_y / s_z))
//! d = distortion(n)                     distorted point
//! p = (fx d_x + cx, fy d_y + cy)        pixel (OpenCV convention)
//! ```
//!
//! so `dp/dm = diag(fx, fy) * dd/dn * dn/ds * ds/dm`. Derivations: `docs/camera-model.md`.

use crate::distortion::{LensDistortion, ParamJacobian};
use crate::error::CameraModelError;
use crate::intrinsics::Intrinsics;
use crate::pose::{DifferentiablePose, Pose};
use crate::projection::{Pinhole, Projection};
use nalgebra::{Matrix2, Matrix2x3, Matrix2x4, Matrix2x6, Point3, Vector2, Vector3};
use std::marker::PhantomData;

/// A camera: projection `P` (pinhole unless said otherwise), lens distortion `D` and intrinsics.
///
/// The intrinsic parameter vector used by the calibration is `[fx, fy, cx, cy, distortion...]`;
/// projections have no parameters. Projection and distortion are type parameters, so the
/// per-point arithmetic is monomorphized; [`crate::AnyCamera`] chooses the model at run time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera<D, P = Pinhole> {
    /// Focal lengths and principal point (pixels).
    pub intrinsics: Intrinsics,
    /// Lens distortion (on the projection plane).
    pub distortion: D,
    _projection: PhantomData<P>,
}

/// A projected pixel and the analytic Jacobians of the pixel with respect to every input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProjectionJacobians<D: LensDistortion> {
    /// The distorted pixel `(u, v)`.
    pub pixel: Vector2<f64>,
    /// `dp / d[fx, fy, cx, cy]` (2x4).
    pub d_intrinsics: Matrix2x4<f64>,
    /// `dp / d(distortion parameters)` (2 x `D::NUM_PARAMS`).
    pub d_distortion: D::ParamJacobian,
    /// `dp / d[rho, t]` (2x6), rotation parameters first.
    pub d_pose: Matrix2x6<f64>,
    /// `dp / dX` (2x3), with respect to the world point.
    pub d_point: Matrix2x3<f64>,
}

/// A projected camera-frame point and its Jacobians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraPointJacobians<D: LensDistortion> {
    /// The distorted pixel `(u, v)`.
    pub pixel: Vector2<f64>,
    /// `dp / d[fx, fy, cx, cy]` (2x4).
    pub d_intrinsics: Matrix2x4<f64>,
    /// `dp / d(distortion parameters)` (2 x `D::NUM_PARAMS`).
    pub d_distortion: D::ParamJacobian,
    /// `dp / ds` with respect to the camera-frame point (2x3).
    pub d_camera_point: Matrix2x3<f64>,
}

impl<D: LensDistortion> Camera<D, Pinhole> {
    /// A pinhole camera from intrinsics and a distortion model.
    pub fn new(intrinsics: Intrinsics, distortion: D) -> Self {
        Self::from_parts(intrinsics, distortion)
    }
}

impl<D: LensDistortion, P: Projection> Camera<D, P> {
    /// A camera from intrinsics and a distortion model, with the projection `P` of the type
    /// (`Camera::<KannalaBrandt4, Equidistant>::from_parts(...)`).
    pub fn from_parts(intrinsics: Intrinsics, distortion: D) -> Self {
        Self {
            intrinsics,
            distortion,
            _projection: PhantomData,
        }
    }

    /// Length of the intrinsic parameter vector: `4 + D::NUM_PARAMS`.
    pub const NUM_PARAMS: usize = 4 + D::NUM_PARAMS;

    /// Writes the intrinsic parameter vector `[fx, fy, cx, cy, distortion...]` into
    /// `out[..Self::NUM_PARAMS]`.
    pub fn write_params(&self, out: &mut [f64]) {
        out[..4].copy_from_slice(self.intrinsics.to_vector().as_slice());
        self.distortion.write_params(&mut out[4..]);
    }

    /// The camera from the parameter vector `[fx, fy, cx, cy, distortion...]`
    /// (`params[..Self::NUM_PARAMS]`), unchecked: the solver's hot path. Use
    /// [`crate::AnyCamera::from_params`] for a checked camera.
    ///
    /// # Panics
    /// If `params` is shorter than [`Self::NUM_PARAMS`].
    pub fn from_params(params: &[f64]) -> Self {
        let intrinsics = Intrinsics::new(params[0], params[1], params[2], params[3]);
        Self::from_parts(intrinsics, D::from_params(&params[4..]))
    }

    /// Pixel of a point given in the camera frame.
    ///
    /// Errors if the projection does not reach the point (behind a pinhole camera) or the point
    /// is not finite. The pixel itself is not checked (this is the solver's hot path, where a
    /// non-finite cost rejects the step): at a pole of a rational model it is infinite or NaN.
    /// [`crate::AnyCamera::project_camera_point`] checks it.
    #[inline]
    pub fn project_camera_point(&self, s: &Vector3<f64>) -> Result<Vector2<f64>, CameraModelError> {
        // Same arithmetic as `project_with_jacobians`, so both give identical bits.
        let n = P::project(s)?;
        Ok(self.intrinsics.to_pixel(&self.distortion.distort(&n)))
    }

    /// Pixel of a world point seen from `pose` (world to camera).
    #[inline]
    pub fn project(
        &self,
        pose: &Pose,
        point: &Point3<f64>,
    ) -> Result<Vector2<f64>, CameraModelError> {
        self.project_camera_point(&pose.transform_point(point))
    }

    /// Pixel of a camera-frame point and its Jacobians with respect to the intrinsics, the
    /// distortion parameters and the camera-frame point itself (`dp/ds`, 2x3). This is the part
    /// of the projection after the pose; chain `dp/ds` with any pose model (a stereo rig, say).
    #[inline]
    pub fn project_camera_point_with_jacobians(
        &self,
        s: &Vector3<f64>,
    ) -> Result<CameraPointJacobians<D>, CameraModelError> {
        let (n, dn_ds): (Vector2<f64>, Matrix2x3<f64>) = P::project_with_jacobian(s)?;
        let (d, dd_dn, dd_dk) = self.distortion.distort_with_jacobians(&n);
        let Intrinsics { fx, fy, cx, cy } = self.intrinsics;
        let scale = Matrix2::new(fx, 0.0, 0.0, fy);
        Ok(CameraPointJacobians {
            pixel: Vector2::new(fx * d.x + cx, fy * d.y + cy),
            d_intrinsics: Matrix2x4::new(d.x, 0.0, 1.0, 0.0, 0.0, d.y, 0.0, 1.0),
            d_distortion: dd_dk.scale_rows(fx, fy),
            d_camera_point: scale * dd_dn * dn_ds,
        })
    }

    /// Pixel of a world point and its Jacobians with respect to the intrinsics, the distortion
    /// parameters, the pose parameters (in the parameterization `pose` was prepared with) and the
    /// world point. Allocation-free.
    #[inline]
    pub fn project_with_jacobians(
        &self,
        pose: &DifferentiablePose,
        point: &Point3<f64>,
    ) -> Result<ProjectionJacobians<D>, CameraModelError> {
        let (s, ds_dm) = pose.transform_with_jacobian(point);
        let j = self.project_camera_point_with_jacobians(&s)?;
        Ok(ProjectionJacobians {
            pixel: j.pixel,
            d_intrinsics: j.d_intrinsics,
            d_distortion: j.d_distortion,
            d_pose: j.d_camera_point * ds_dm,
            d_point: j.d_camera_point * pose.rotation,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distortion::BrownConrady;
    use crate::rotation::{AxisAngle, EulerXyz, RotationParameterization};
    use lm_solver::numdiff::{central_difference, compare_jacobians};
    use nalgebra::{SMatrix, Vector6};
    use proptest::prelude::*;

    /// Random intrinsics and distortion in the ranges real lenses and sensors have.
    fn camera_strategy() -> impl Strategy<Value = Camera<BrownConrady>> {
        (
            200.0f64..2000.0,
            0.8f64..1.25,
            200.0f64..1000.0,
            150.0f64..800.0,
            (-0.5f64..0.5, -0.5f64..0.5, -0.01f64..0.01, -0.01f64..0.01),
        )
            .prop_map(|(fx, aspect, cx, cy, (k1, k2, p1, p2))| {
                Camera::new(
                    Intrinsics::new(fx, fx * aspect, cx, cy),
                    BrownConrady::new(k1, k2, p1, p2),
                )
            })
    }

    /// A pose looking at a board near the origin from 0.3..3 units away, tilted up to ~60 degrees,
    /// and a point on or near the board: the point is always well in front of the camera.
    fn pose_and_point<P: RotationParameterization>()
    -> impl Strategy<Value = (Vector6<f64>, Point3<f64>)> {
        (
            (-1.0f64..1.0, -1.0f64..1.0, -3.1f64..3.1),
            (-0.3f64..0.3, -0.3f64..0.3, 0.3f64..3.0),
            (-0.2f64..0.2, -0.2f64..0.2, -0.05f64..0.05),
            prop::bool::ANY,
        )
            .prop_map(|((ax, ay, az), (tx, ty, tz), (x, y, z), flip)| {
                // Flipping about X makes the board's Z axis point away from the camera, the usual
                // situation for boards; the other case is exercised too.
                let base = if flip { std::f64::consts::PI } else { 0.0 };
                let r = EulerXyz::matrix(&Vector3::new(base + ax, ay, az));
                let rho = P::from_matrix(&r);
                let params = Vector6::new(rho.x, rho.y, rho.z, tx, ty, tz);
                (params, Point3::new(x, y, z))
            })
            .prop_filter("point in front of the camera", |(params, p)| {
                Pose::from_params::<EulerXyz>(params).transform_point(p).z > 0.2
                    || Pose::from_params::<AxisAngle>(params).transform_point(p).z > 0.2
            })
    }

    fn check_all_jacobians<P: RotationParameterization>(
        camera: Camera<BrownConrady>,
        pose: Vector6<f64>,
        point: Point3<f64>,
    ) -> Result<(), TestCaseError> {
        let prepared = DifferentiablePose::new::<P>(&pose);
        if prepared.pose().transform_point(&point).z <= 0.2 {
            return Ok(());
        }
        let j = camera.project_with_jacobians(&prepared, &point).unwrap();
        let plain = camera.project(&prepared.pose(), &point).unwrap();
        // The two paths use the same arithmetic: the solver compares costs from both.
        prop_assert_eq!(j.pixel, plain);

        // Central-difference error bound: rounding eps |f| / h plus truncation h^2 |f'''| / 6, with
        // h = 1e-6 max(|x|, 1). Pixels stay below 5e3, so rounding is at most 1.1e-16 * 5e3 / 1e-6
        // = 6e-7 px per unit of a parameter of order one (less for fx, whose step is larger).
        // Truncation is largest for the depth: |d^3 u / dz^3| ~ 6 fx |x| / z^4 < 1e7 for z > 0.2,
        // and h^2 / 6 times that is below 2e-6 px. The tolerance 1e-5 (|numeric| + 1) px per unit
        // is therefore several times the worst-case noise, while a wrong or missing term (a
        // relative error of order one in some entry) is far above it.
        const REL: f64 = 1e-5;
        const FLOOR: f64 = 1.0;
        let project = |c: &Camera<BrownConrady>, m: &Vector6<f64>, x: &Point3<f64>| {
            c.project(&Pose::from_params::<P>(m), x).unwrap()
        };

        let mut intr = [0.0; 8];
        camera.write_params(&mut intr);
        let numeric = central_difference(
            |p: &[f64], out: &mut [f64]| {
                out.copy_from_slice(project(&Camera::from_params(p), &pose, &point).as_slice())
            },
            &intr,
            2,
            1e-6,
        );
        let mut analytic = Vec::from(j.d_intrinsics.as_slice());
        analytic.extend_from_slice(ParamJacobian::as_slice(&j.d_distortion));
        let r = compare_jacobians(&analytic, &numeric, 2, REL, FLOOR);
        prop_assert!(r.is_ok(), "intrinsics/distortion: {:?}", r);

        let numeric = central_difference(
            |m: &[f64], out: &mut [f64]| {
                let m = Vector6::from_column_slice(m);
                out.copy_from_slice(project(&camera, &m, &point).as_slice())
            },
            pose.as_slice(),
            2,
            1e-6,
        );
        let r = compare_jacobians(j.d_pose.as_slice(), &numeric, 2, REL, FLOOR);
        prop_assert!(r.is_ok(), "pose: {:?}", r);

        let numeric = central_difference(
            |x: &[f64], out: &mut [f64]| {
                let x = Point3::new(x[0], x[1], x[2]);
                out.copy_from_slice(project(&camera, &pose, &x).as_slice())
            },
            point.coords.as_slice(),
            2,
            1e-6,
        );
        let r = compare_jacobians(j.d_point.as_slice(), &numeric, 2, REL, FLOOR);
        prop_assert!(r.is_ok(), "point: {:?}", r);
        Ok(())
    }

    proptest! {
        #[test]
        fn jacobians_match_finite_differences_euler(
            camera in camera_strategy(), (pose, point) in pose_and_point::<EulerXyz>()
        ) {
            check_all_jacobians::<EulerXyz>(camera, pose, point)?;
        }

        #[test]
        fn jacobians_match_finite_differences_axis_angle(
            camera in camera_strategy(), (pose, point) in pose_and_point::<AxisAngle>()
        ) {
            check_all_jacobians::<AxisAngle>(camera, pose, point)?;
        }
    }

    /// The pose Jacobian computed literally as in the specification, `dp_n/d[R|t] * d[R|t]/dm`
    /// with the 2x9 and 9x6 matrices for a planar point, equals the contracted form.
    #[test]
    fn pose_jacobian_equals_the_specification_chain() {
        let params = Vector6::new(2.9, 0.3, -0.4, 0.05, -0.02, 0.8);
        let point = Point3::new(0.12, 0.07, 0.0);
        let prepared = DifferentiablePose::new::<EulerXyz>(&params);
        let camera = Camera::new(Intrinsics::new(1.0, 1.0, 0.0, 0.0), BrownConrady::default());
        let j = camera.project_with_jacobians(&prepared, &point).unwrap();

        let s = prepared.pose().transform_point(&point);
        let (xw, yw) = (point.x, point.y);
        // Columns: R11 R21 R31 R12 R22 R32 tx ty tz.
        let dpn_drt = SMatrix::<f64, 2, 9>::from_row_slice(&[
            xw / s.z,
            0.0,
            -s.x * xw / (s.z * s.z),
            yw / s.z,
            0.0,
            -s.x * yw / (s.z * s.z),
            1.0 / s.z,
            0.0,
            -s.x / (s.z * s.z),
            0.0,
            xw / s.z,
            -s.y * xw / (s.z * s.z),
            0.0,
            yw / s.z,
            -s.y * yw / (s.z * s.z),
            0.0,
            1.0 / s.z,
            -s.y / (s.z * s.z),
        ]);
        let mut drt_dm = SMatrix::<f64, 9, 6>::zeros();
        for k in 0..3 {
            let d = prepared.rotation_derivatives[k];
            // First two columns of dR/dtheta_k, column-major.
            for (row, (i, c)) in [(0, 0), (1, 0), (2, 0), (0, 1), (1, 1), (2, 1)]
                .into_iter()
                .enumerate()
            {
                drt_dm[(row, k)] = d[(i, c)];
            }
            drt_dm[(6 + k, 3 + k)] = 1.0;
        }
        let chain = dpn_drt * drt_dm;
        approx::assert_relative_eq!(chain, j.d_pose, epsilon = 1e-12);
    }

    #[test]
    fn points_behind_or_on_the_camera_plane_are_errors() {
        let camera = Camera::new(
            Intrinsics::new(500.0, 500.0, 320.0, 240.0),
            BrownConrady::default(),
        );
        for z in [0.0, -1.0] {
            let err = camera
                .project_camera_point(&Vector3::new(0.1, 0.2, z))
                .unwrap_err();
            assert_eq!(err, CameraModelError::PointBehindCamera { depth: z });
        }
        assert!(matches!(
            camera.project_camera_point(&Vector3::new(f64::NAN, 0.0, 1.0)),
            Err(CameraModelError::NonFinite { .. })
        ));
        let pose =
            DifferentiablePose::new::<EulerXyz>(&Vector6::new(0.0, 0.0, 0.0, 0.0, 0.0, -1.0));
        assert!(
            camera
                .project_with_jacobians(&pose, &Point3::origin())
                .is_err()
        );
    }

    #[test]
    fn principal_point_is_the_image_of_the_optical_axis() {
        let camera = Camera::new(
            Intrinsics::new(500.0, 510.0, 319.5, 239.5),
            BrownConrady::new(0.2, -0.1, 0.01, 0.01),
        );
        let p = camera
            .project_camera_point(&Vector3::new(0.0, 0.0, 2.0))
            .unwrap();
        assert_eq!(p, Vector2::new(319.5, 239.5));
        // A point right of and below the axis lands right of and below the principal point.
        let p = camera
            .project_camera_point(&Vector3::new(0.1, 0.1, 1.0))
            .unwrap();
        assert!(p.x > 319.5 && p.y > 239.5);
    }
}
