//! Camera models chosen at run time: [`CameraModel`] names a projection x distortion pair and
//! [`AnyCamera`] holds a camera of any model with its parameters.
//!
//! The hot loops of calibration are generic over the distortion and projection types
//! ([`crate::Camera`]); [`dispatch_camera_model!`](crate::dispatch_camera_model) turns a runtime
//! [`CameraModel`] into those types once per call (per view), so command lines, files and
//! bindings choose models freely without dynamic dispatch per point.
//!
//! | name (CLI, files) | distortion | projection | OpenCV / ROS / Kalibr |
//! |---|---|---|---|
//! | `brown-conrady4` | k1 k2 p1 p2 | pinhole | `CALIB_FIX_K3`; the seed's heikkila97 |
//! | `brown-conrady5` | k1 k2 p1 p2 k3 | pinhole | default; ROS `plumb_bob` |
//! | `rational8` | k1 k2 p1 p2 k3 k4 k5 k6 | pinhole | `CALIB_RATIONAL_MODEL`; ROS `rational_polynomial` |
//! | `thin-prism12` | rational8 + s1 s2 s3 s4 | pinhole | `+ CALIB_THIN_PRISM_MODEL` |
//! | `kannala-brandt4` | k1 k2 k3 k4 on theta | equidistant | `cv2.fisheye`; ROS/Kalibr `equidistant` |
//!
//! The distortion coefficients are stored in exactly OpenCV's order for every model, so
//! `dist_coeffs` can be handed to `cv2` functions as they are (`cv2.fisheye` for
//! `kannala-brandt4`).

use crate::camera::Camera;
use crate::distortion::{
    BrownConrady, BrownConrady5, KannalaBrandt4, LensDistortion, Rational8, ThinPrism12,
};
use crate::error::CameraModelError;
use crate::intrinsics::Intrinsics;
use crate::pose::Pose;
use crate::projection::{Equidistant, Projection};
use crate::undistort::UndistortOptions;
use nalgebra::{Point3, Unit, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// A camera model: projection and lens distortion (see the module table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(into = "String", try_from = "String")]
// Not `#[non_exhaustive]`: `dispatch_camera_model!` matches every variant in downstream crates.
pub enum CameraModel {
    /// Pinhole, Brown-Conrady `k1 k2 p1 p2` ([`BrownConrady`]). The default.
    #[default]
    BrownConrady4,
    /// Pinhole, Brown-Conrady `k1 k2 p1 p2 k3` ([`BrownConrady5`]).
    BrownConrady5,
    /// Pinhole, rational `k1 k2 p1 p2 k3 k4 k5 k6` ([`Rational8`]).
    Rational8,
    /// Pinhole, rational + thin prism, 12 coefficients ([`ThinPrism12`]).
    ThinPrism12,
    /// Equidistant fisheye, Kannala-Brandt `k1 k2 k3 k4` ([`KannalaBrandt4`]).
    KannalaBrandt4,
}

/// Runs `$body` with the type aliases `$D` (distortion) and `$P` (projection) of a runtime
/// [`CameraModel`], once per call, so that `$body` is monomorphized for each model:
///
/// ```
/// use camera_model::{Camera, CameraModel, LensDistortion, dispatch_camera_model};
/// let model = CameraModel::KannalaBrandt4;
/// let count = dispatch_camera_model!(model, D, P => D::NUM_PARAMS);
/// assert_eq!(count, 4);
/// ```
#[macro_export]
macro_rules! dispatch_camera_model {
    ($model:expr, $D:ident, $P:ident => $body:expr) => {
        match $model {
            $crate::CameraModel::BrownConrady4 => {
                #[allow(dead_code)]
                type $D = $crate::BrownConrady;
                #[allow(dead_code)]
                type $P = $crate::Pinhole;
                $body
            }
            $crate::CameraModel::BrownConrady5 => {
                #[allow(dead_code)]
                type $D = $crate::BrownConrady5;
                #[allow(dead_code)]
                type $P = $crate::Pinhole;
                $body
            }
            $crate::CameraModel::Rational8 => {
                #[allow(dead_code)]
                type $D = $crate::Rational8;
                #[allow(dead_code)]
                type $P = $crate::Pinhole;
                $body
            }
            $crate::CameraModel::ThinPrism12 => {
                #[allow(dead_code)]
                type $D = $crate::ThinPrism12;
                #[allow(dead_code)]
                type $P = $crate::Pinhole;
                $body
            }
            $crate::CameraModel::KannalaBrandt4 => {
                #[allow(dead_code)]
                type $D = $crate::KannalaBrandt4;
                #[allow(dead_code)]
                type $P = $crate::Equidistant;
                $body
            }
        }
    };
}

impl CameraModel {
    /// Every model, simplest first.
    pub const ALL: [CameraModel; 5] = [
        CameraModel::BrownConrady4,
        CameraModel::BrownConrady5,
        CameraModel::Rational8,
        CameraModel::ThinPrism12,
        CameraModel::KannalaBrandt4,
    ];

    /// The names of [`CameraModel::ALL`], as used on the command line and in files.
    pub const NAMES: [&'static str; 5] = [
        BrownConrady::NAME,
        BrownConrady5::NAME,
        Rational8::NAME,
        ThinPrism12::NAME,
        KannalaBrandt4::NAME,
    ];

    /// The model's name ("brown-conrady4", ...).
    pub fn name(self) -> &'static str {
        dispatch_camera_model!(self, D, P => D::NAME)
    }

    /// The projection's name ("pinhole" or "equidistant").
    pub fn projection_name(self) -> &'static str {
        dispatch_camera_model!(self, D, P => P::NAME)
    }

    /// True for the fisheye (equidistant) models.
    pub fn is_fisheye(self) -> bool {
        self.projection_name() == Equidistant::NAME
    }

    /// Number of distortion coefficients.
    pub fn num_distortion_params(self) -> usize {
        dispatch_camera_model!(self, D, P => D::NUM_PARAMS)
    }

    /// Number of intrinsic parameters: `fx, fy, cx, cy` and the distortion coefficients.
    pub fn num_params(self) -> usize {
        4 + self.num_distortion_params()
    }

    /// Names of the distortion coefficients, in OpenCV's order.
    pub fn distortion_names(self) -> &'static [&'static str] {
        dispatch_camera_model!(self, D, P => D::PARAM_NAMES)
    }

    /// Indices of the tangential coefficients (`p1, p2`), empty for fisheye models.
    pub fn tangential_params(self) -> &'static [usize] {
        dispatch_camera_model!(self, D, P => D::TANGENTIAL_PARAMS)
    }
}

impl std::fmt::Display for CameraModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for CameraModel {
    type Err = CameraModelError;

    /// The model names of the table, and the other tools' names: `plumb_bob` (brown-conrady5),
    /// `rational_polynomial` (rational8), `equidistant` / `fisheye` (kannala-brandt4).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let name = s.trim().to_ascii_lowercase();
        if let Some(model) = CameraModel::ALL.iter().find(|m| m.name() == name) {
            return Ok(*model);
        }
        match name.as_str() {
            "plumb_bob" => Ok(CameraModel::BrownConrady5),
            "rational_polynomial" => Ok(CameraModel::Rational8),
            "equidistant" | "fisheye" => Ok(CameraModel::KannalaBrandt4),
            _ => Err(CameraModelError::UnknownModel(s.to_string())),
        }
    }
}

impl From<CameraModel> for String {
    fn from(m: CameraModel) -> String {
        m.name().to_string()
    }
}

impl TryFrom<String> for CameraModel {
    type Error = CameraModelError;
    fn try_from(s: String) -> Result<Self, Self::Error> {
        s.parse()
    }
}

/// A camera of any [`CameraModel`]: intrinsics and distortion coefficients (OpenCV's order).
///
/// Every operation dispatches once to the model's [`Camera`] type. [`AnyCamera::new`] and
/// deserialization check the camera (coefficient count, finite values, positive focal
/// lengths); the fields are public, so the operations check the coefficient count again and
/// return [`CameraModelError::ParameterCount`] rather than panic.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "AnyCameraFields")]
pub struct AnyCamera {
    /// The model.
    pub model: CameraModel,
    /// Focal lengths and principal point, pixels (OpenCV convention).
    pub intrinsics: Intrinsics,
    /// Distortion coefficients in the model's (OpenCV's) order.
    pub distortion: Vec<f64>,
}

/// The fields of an [`AnyCamera`] as read, checked by [`AnyCamera::new`] on deserialization.
#[derive(Deserialize)]
struct AnyCameraFields {
    model: CameraModel,
    intrinsics: Intrinsics,
    distortion: Vec<f64>,
}

impl TryFrom<AnyCameraFields> for AnyCamera {
    type Error = CameraModelError;

    fn try_from(f: AnyCameraFields) -> Result<Self, Self::Error> {
        AnyCamera::new(f.model, f.intrinsics, f.distortion)
    }
}

/// Runs `$body` with `$camera` bound to the typed [`Camera`] of an [`AnyCamera`], or returns
/// the coefficient-count error.
macro_rules! with_typed_camera {
    ($any:expr, $camera:ident => $body:expr) => {{
        $any.check_count()?;
        dispatch_camera_model!($any.model, D, P => {
            let $camera = Camera::<D, P>::from_parts($any.intrinsics, D::from_params(&$any.distortion));
            $body
        })
    }};
}

impl AnyCamera {
    /// A camera; errors if `distortion` does not have the model's number of coefficients, if a
    /// value is not finite, or if a focal length is not positive.
    pub fn new(
        model: CameraModel,
        intrinsics: Intrinsics,
        distortion: Vec<f64>,
    ) -> Result<Self, CameraModelError> {
        let camera = Self {
            model,
            intrinsics,
            distortion,
        };
        camera.check_count()?;
        let Intrinsics { fx, fy, cx, cy } = intrinsics;
        if !(fx.is_finite() && fy.is_finite() && fx > 0.0 && fy > 0.0) {
            return Err(CameraModelError::InvalidIntrinsics { fx, fy });
        }
        if !(cx.is_finite() && cy.is_finite()) {
            return Err(CameraModelError::NonFinite {
                what: "principal point",
            });
        }
        if camera.distortion.iter().any(|d| !d.is_finite()) {
            return Err(CameraModelError::NonFinite {
                what: "distortion coefficients",
            });
        }
        Ok(camera)
    }

    /// Errors unless `distortion` has the model's number of coefficients.
    fn check_count(&self) -> Result<(), CameraModelError> {
        if self.distortion.len() == self.model.num_distortion_params() {
            Ok(())
        } else {
            Err(CameraModelError::ParameterCount {
                model: self.model.name(),
                expected: self.model.num_distortion_params(),
                found: self.distortion.len(),
            })
        }
    }

    /// A camera of `model` without distortion.
    pub fn undistorted(model: CameraModel, intrinsics: Intrinsics) -> Self {
        Self {
            model,
            intrinsics,
            distortion: vec![0.0; model.num_distortion_params()],
        }
    }

    /// A camera from the intrinsic parameter vector `[fx, fy, cx, cy, distortion...]`.
    pub fn from_params(model: CameraModel, params: &[f64]) -> Result<Self, CameraModelError> {
        if params.len() != model.num_params() {
            return Err(CameraModelError::ParameterVectorLength {
                model: model.name(),
                expected: model.num_params(),
                found: params.len(),
            });
        }
        Self::new(
            model,
            Intrinsics::new(params[0], params[1], params[2], params[3]),
            params[4..].to_vec(),
        )
    }

    /// The typed camera; `None` unless `D` and `P` are this camera's model types (and the
    /// coefficient count is the model's).
    pub fn typed<D: LensDistortion, P: Projection>(&self) -> Option<Camera<D, P>> {
        (D::NAME == self.model.name()
            && P::NAME == self.model.projection_name()
            && self.check_count().is_ok())
        .then(|| Camera::from_parts(self.intrinsics, D::from_params(&self.distortion)))
    }

    /// The intrinsic parameter vector `[fx, fy, cx, cy, distortion...]`.
    pub fn params(&self) -> Vec<f64> {
        let mut p = self.intrinsics.to_vector().as_slice().to_vec();
        p.extend_from_slice(&self.distortion);
        p
    }

    /// Writes the intrinsic parameter vector into `out[..model.num_params()]`.
    pub fn write_params(&self, out: &mut [f64]) {
        out[..4].copy_from_slice(self.intrinsics.to_vector().as_slice());
        out[4..4 + self.distortion.len()].copy_from_slice(&self.distortion);
    }

    /// The camera matrix `K`.
    pub fn matrix(&self) -> nalgebra::Matrix3<f64> {
        self.intrinsics.matrix()
    }

    /// Pixel of a camera-frame point. Errors if the projection does not reach the point
    /// (behind a pinhole camera), or if the pixel is not finite (at a pole of a rational model:
    /// [`CameraModelError::NonFinite`]).
    pub fn project_camera_point(&self, s: &Vector3<f64>) -> Result<Vector2<f64>, CameraModelError> {
        let pixel = with_typed_camera!(self, camera => camera.project_camera_point(s))?;
        if pixel.x.is_finite() && pixel.y.is_finite() {
            Ok(pixel)
        } else {
            Err(CameraModelError::NonFinite {
                what: "pixel (the point lies on a pole of the lens model)",
            })
        }
    }

    /// Pixel of a world point seen from `pose` (world to camera).
    pub fn project(
        &self,
        pose: &Pose,
        point: &Point3<f64>,
    ) -> Result<Vector2<f64>, CameraModelError> {
        self.project_camera_point(&pose.transform_point(point))
    }

    /// The undistorted projection-plane point seen at `pixel` (pinhole: `(x/z, y/z)`;
    /// equidistant: `theta (x, y) / r`).
    pub fn undistort_pixel(
        &self,
        pixel: &Vector2<f64>,
        options: &UndistortOptions,
    ) -> Result<Vector2<f64>, CameraModelError> {
        with_typed_camera!(self, camera => camera.undistort_pixel(pixel, options))
    }

    /// The unit viewing ray (camera frame) through `pixel`. Where the distortion folds (beyond
    /// the validity radius, `crate::validity`) a pixel has several preimages, and the ray
    /// returned may be a non-physical one on the folded branch: check the camera's validity
    /// before trusting rays near or beyond the image border.
    pub fn pixel_to_ray(
        &self,
        pixel: &Vector2<f64>,
        options: &UndistortOptions,
    ) -> Result<Unit<Vector3<f64>>, CameraModelError> {
        with_typed_camera!(self, camera => camera.pixel_to_ray(pixel, options))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What users can build or read is checked: a wrong coefficient count (from a file, or
    /// the public field changed afterwards) is an error, never a panic; non-finite values and
    /// non-positive focal lengths are refused.
    #[test]
    fn malformed_cameras_are_errors_not_panics() {
        let k = Intrinsics::new(800.0, 800.0, 320.0, 240.0);
        let text = r#"{"model":"rational8","intrinsics":{"fx":800,"fy":800,"cx":320,"cy":240},"distortion":[0.1,0.2]}"#;
        assert!(serde_json::from_str::<AnyCamera>(text).is_err());
        let mut camera = AnyCamera::undistorted(CameraModel::Rational8, k);
        camera.distortion.truncate(2);
        let s = Vector3::new(0.1, 0.1, 1.0);
        assert!(matches!(
            camera.project_camera_point(&s),
            Err(CameraModelError::ParameterCount {
                expected: 8,
                found: 2,
                ..
            })
        ));
        assert!(
            camera
                .pixel_to_ray(&Vector2::new(1.0, 2.0), &UndistortOptions::default())
                .is_err()
        );
        assert!(camera.typed::<Rational8, crate::Pinhole>().is_none());
        for bad in [
            Intrinsics::new(f64::NAN, 800.0, 320.0, 240.0),
            Intrinsics::new(-800.0, 800.0, 320.0, 240.0),
            Intrinsics::new(800.0, 800.0, f64::INFINITY, 240.0),
        ] {
            assert!(AnyCamera::new(CameraModel::BrownConrady4, bad, vec![0.0; 4]).is_err());
        }
        assert!(
            AnyCamera::new(CameraModel::BrownConrady4, k, vec![f64::NAN, 0.0, 0.0, 0.0]).is_err()
        );
        // A point on the pole of a rational model (denominator 1 + k4 r^2 = 0 at r = 0.5) has
        // no finite pixel: an error, not Ok(inf).
        let mut pole = vec![0.0; 8];
        pole[5] = -4.0;
        let rational = AnyCamera::new(CameraModel::Rational8, k, pole).unwrap();
        assert!(matches!(
            rational.project_camera_point(&Vector3::new(0.5, 0.0, 1.0)),
            Err(CameraModelError::NonFinite { .. })
        ));
        assert!(matches!(
            AnyCamera::from_params(CameraModel::Rational8, &[800.0, 800.0, 1.0]),
            Err(CameraModelError::ParameterVectorLength {
                expected: 12,
                found: 3,
                ..
            })
        ));
    }

    #[test]
    fn names_parse_and_print() {
        for model in CameraModel::ALL {
            assert_eq!(model.name().parse::<CameraModel>().unwrap(), model);
            assert_eq!(model.to_string(), model.name());
            let json = serde_json::to_string(&model).unwrap();
            assert_eq!(serde_json::from_str::<CameraModel>(&json).unwrap(), model);
        }
        assert_eq!(
            "plumb_bob".parse::<CameraModel>().unwrap(),
            CameraModel::BrownConrady5
        );
        assert_eq!(
            "fisheye".parse::<CameraModel>().unwrap(),
            CameraModel::KannalaBrandt4
        );
        assert!(matches!(
            "pinhole-radial9".parse::<CameraModel>(),
            Err(CameraModelError::UnknownModel(_))
        ));
        assert_eq!(CameraModel::Rational8.num_params(), 12);
        assert!(CameraModel::KannalaBrandt4.is_fisheye());
        assert!(CameraModel::KannalaBrandt4.tangential_params().is_empty());
    }

    #[test]
    fn any_camera_projects_like_the_typed_camera() {
        let k = Intrinsics::new(400.0, 410.0, 320.0, 240.0);
        let s = Vector3::new(0.3, -0.2, 1.5);
        let any =
            AnyCamera::new(CameraModel::BrownConrady4, k, vec![-0.2, 0.05, 0.001, 0.0]).unwrap();
        let typed = Camera::new(k, BrownConrady::new(-0.2, 0.05, 0.001, 0.0));
        assert_eq!(
            any.project_camera_point(&s).unwrap(),
            typed.project_camera_point(&s).unwrap()
        );
        assert_eq!(any.typed::<BrownConrady, crate::Pinhole>(), Some(typed));
        assert!(any.typed::<KannalaBrandt4, Equidistant>().is_none());
        // A fisheye sees a point 100 degrees off-axis.
        let fisheye =
            AnyCamera::new(CameraModel::KannalaBrandt4, k, vec![0.01, 0.0, 0.0, 0.0]).unwrap();
        let side = Vector3::new(1.0, 0.0, -0.2);
        let pixel = fisheye.project_camera_point(&side).unwrap();
        let ray = fisheye
            .pixel_to_ray(&pixel, &UndistortOptions::default())
            .unwrap();
        assert!((ray.into_inner() - side.normalize()).norm() < 1e-10);
        assert!(AnyCamera::new(CameraModel::Rational8, k, vec![0.0; 4]).is_err());
        // A fisheye is not a pinhole camera with the same coefficients.
        assert!(fisheye.typed::<KannalaBrandt4, crate::Pinhole>().is_none());
        assert!(fisheye.typed::<KannalaBrandt4, Equidistant>().is_some());
        let json = serde_json::to_value(&fisheye).unwrap();
        assert_eq!(json["model"], "kannala-brandt4");
        assert_eq!(serde_json::from_value::<AnyCamera>(json).unwrap(), fisheye);
    }
}
