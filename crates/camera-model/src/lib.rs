//! Camera models (projection x lens distortion x intrinsics), rotation parameterizations and
//! analytic Jacobians.
//!
//! A camera maps a point `X` of the world (board) frame to a distorted pixel:
//!
//! 1. camera frame: `s = R X + t` ([`Pose`], world to camera; `z` points forward),
//! 2. projection plane: `n = projection(s)` ([`Projection`]: [`Pinhole`] `(s_x / s_z, s_y / s_z)`
//!    or the fisheye [`Equidistant`]),
//! 3. lens distortion: `d = distortion(n)` ([`LensDistortion`], e.g. [`BrownConrady`] with
//!    OpenCV's `k1, k2, p1, p2`, [`Rational8`], [`KannalaBrandt4`]),
//! 4. pixel: `(fx d_x + cx, fy d_y + cy)` ([`Intrinsics`]).
//!
//! [`Camera`] is generic over distortion and projection (static dispatch in the hot loops);
//! [`CameraModel`] and [`AnyCamera`] choose the model at run time (command lines, files).
//!
//! Pixels follow OpenCV's convention: `(0, 0)` is the centre of the top-left pixel, `x` to the
//! right, `y` down. Rotations are parameterized by Euler X-Y-Z angles ([`EulerXyz`],
//! `R = Rz Ry Rx`) or rotation vectors ([`AxisAngle`]).
//!
//! [`Camera::project_with_jacobians`] returns the pixel with its analytic derivatives with respect
//! to the intrinsics, the distortion, the pose and the point; [`Camera::undistort_pixel`] and
//! [`Camera::pixel_to_ray`] invert the model. Derivations are in `docs/camera-model.md`.
//!
//! ```
//! use camera_model::{BrownConrady, Camera, DifferentiablePose, EulerXyz, Intrinsics, Pose};
//! use camera_model::UndistortOptions;
//! use nalgebra::{Point3, Vector6};
//!
//! let camera = Camera::new(
//!     Intrinsics::new(800.0, 800.0, 319.5, 239.5),
//!     BrownConrady::new(-0.2, 0.05, 0.001, -0.0005),
//! );
//! // Board 1 m in front of the camera, turned 10 degrees about the vertical axis.
//! let pose_params = Vector6::new(0.0, 10f64.to_radians(), 0.0, -0.1, -0.05, 1.0);
//! let corner = Point3::new(0.03, 0.06, 0.0);
//!
//! let pose = Pose::from_params::<EulerXyz>(&pose_params);
//! let pixel = camera.project(&pose, &corner).unwrap();
//!
//! // The same pixel with its derivatives, e.g. d pixel / d fx:
//! let j = camera.project_with_jacobians(&DifferentiablePose::new::<EulerXyz>(&pose_params), &corner).unwrap();
//! assert!((j.pixel - pixel).norm() < 1e-12);
//! assert!(j.d_intrinsics[(0, 0)] != 0.0);
//!
//! // Back from the pixel to the viewing ray through the corner.
//! let ray = camera.pixel_to_ray(&pixel, &UndistortOptions::default()).unwrap();
//! let expected = pose.transform_point(&corner).normalize();
//! assert!((ray.into_inner() - expected).norm() < 1e-12);
//! ```
#![deny(missing_docs)]

pub mod camera;
pub mod distortion;
pub mod error;
pub mod intrinsics;
pub mod model;
pub mod pose;
pub mod projection;
pub mod rotation;
pub mod undistort;
pub mod validity;

pub use camera::{Camera, CameraPointJacobians, ProjectionJacobians};
pub use distortion::{
    BrownConrady, BrownConrady4, BrownConrady5, KannalaBrandt4, LensDistortion, ParamJacobian,
    Rational8, RowSparseJacobian, RowSupport, ThinPrism12, ThinPrismRows,
};
pub use error::CameraModelError;
pub use intrinsics::Intrinsics;
pub use model::{AnyCamera, CameraModel};
/// The linear-algebra crate of the public API.
pub use nalgebra;
pub use pose::{DifferentiablePose, Pose};
pub use projection::{Equidistant, Pinhole, Projection};
pub use rotation::{
    AxisAngle, EulerXyz, RotationKind, RotationParameterization, So3, nearest_rotation, skew,
};
pub use undistort::{UndistortOptions, undistort_normalized};
pub use validity::Validity;
