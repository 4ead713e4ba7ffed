//! What the exporters write and the importers read: one calibrated camera, or a stereo rig.
//!
//! Conventions are the workspace's: pixels as in OpenCV (`(0, 0)` is the centre of the top-left
//! pixel), distortion coefficients in OpenCV's order for the model, and the rig maps the left
//! camera's frame to the right one's, `X_right = R X_left + T` (`T` in board units).

use crate::error::ExportError;
use calib_core::ImageSize;
use camera_model::AnyCamera;
use nalgebra::{Matrix3, Vector3};

/// One calibrated camera: its model, parameters and image size.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraCalibration {
    /// A name ("camera", "left", "cam0", ...): ROS's `camera_name`.
    pub name: String,
    /// Lens model, intrinsics (pixels) and distortion coefficients (OpenCV's order).
    pub camera: AnyCamera,
    /// Image size, pixels.
    pub image_size: ImageSize,
}

/// A calibrated stereo rig: two cameras and the transform between them.
#[derive(Debug, Clone, PartialEq)]
pub struct StereoRig {
    /// The left (reference) camera.
    pub left: CameraCalibration,
    /// The right camera.
    pub right: CameraCalibration,
    /// Rotation from the left camera's frame to the right one's: `X_right = R X_left + T`.
    pub rotation: Matrix3<f64>,
    /// Translation `T`, board units (the unit of the calibration board's square size).
    pub translation: Vector3<f64>,
}

/// A calibration as read from any supported file.
#[derive(Debug, Clone, PartialEq)]
pub enum Calibrated {
    /// One camera.
    Single(CameraCalibration),
    /// A stereo rig.
    Stereo(StereoRig),
}

impl CameraCalibration {
    /// A camera; checks the parameters ([`CameraCalibration::check`]).
    pub fn new(
        name: impl Into<String>,
        camera: AnyCamera,
        image_size: ImageSize,
    ) -> Result<Self, ExportError> {
        let c = Self {
            name: name.into(),
            camera,
            image_size,
        };
        c.check()?;
        Ok(c)
    }

    /// Refuses non-finite parameters, non-positive focal lengths, a wrong coefficient count and
    /// an empty image.
    pub fn check(&self) -> Result<(), ExportError> {
        let what = format!("camera '{}'", self.name);
        if !self.camera.intrinsics.is_valid() {
            return Err(ExportError::invalid(
                what,
                format!(
                    "focal lengths must be finite and positive and the principal point finite (fx {}, fy {}, cx {}, cy {})",
                    self.camera.intrinsics.fx,
                    self.camera.intrinsics.fy,
                    self.camera.intrinsics.cx,
                    self.camera.intrinsics.cy
                ),
            ));
        }
        if self.camera.distortion.len() != self.camera.model.num_distortion_params() {
            return Err(ExportError::invalid(
                what,
                format!(
                    "model {} has {} distortion coefficients, got {}",
                    self.camera.model,
                    self.camera.model.num_distortion_params(),
                    self.camera.distortion.len()
                ),
            ));
        }
        if let Some(v) = self.camera.distortion.iter().find(|v| !v.is_finite()) {
            return Err(ExportError::invalid(
                what,
                format!("distortion coefficient {v} is not finite"),
            ));
        }
        if self.image_size.width == 0 || self.image_size.height == 0 {
            return Err(ExportError::invalid(
                what,
                format!(
                    "image size {}x{} is empty",
                    self.image_size.width, self.image_size.height
                ),
            ));
        }
        Ok(())
    }

    /// The camera matrix `K`.
    pub fn matrix(&self) -> Matrix3<f64> {
        self.camera.matrix()
    }
}

impl StereoRig {
    /// Checks both cameras, that `R` is a rotation (orthonormal to 1e-6, determinant +1) and
    /// that `T` is finite and not zero.
    pub fn check(&self) -> Result<(), ExportError> {
        self.left.check()?;
        self.right.check()?;
        let r = &self.rotation;
        let orthogonality = (r.transpose() * r - Matrix3::identity()).amax();
        if !(orthogonality < 1e-6 && (r.determinant() - 1.0).abs() < 1e-6) {
            return Err(ExportError::invalid(
                "stereo rig R",
                format!("not a rotation matrix (|R^T R - I| = {orthogonality:e})"),
            ));
        }
        if !self.translation.iter().all(|v| v.is_finite()) || self.translation.norm() == 0.0 {
            return Err(ExportError::invalid(
                "stereo rig T",
                format!(
                    "the baseline must be finite and non-zero, got {:?}",
                    self.translation.as_slice()
                ),
            ));
        }
        Ok(())
    }

    /// The essential matrix `E = [T]x R`: `x_R^T E x_L = 0` for normalized points.
    pub fn essential(&self) -> Matrix3<f64> {
        camera_model::skew(&self.translation) * self.rotation
    }

    /// The fundamental matrix `F = K_R^-T E K_L^-1` scaled so that `F[2][2] = 1` (when it is
    /// not near zero): `p_R^T F p_L = 0` for undistorted pixels.
    pub fn fundamental(&self) -> Matrix3<f64> {
        let kl = self
            .left
            .matrix()
            .try_inverse()
            .unwrap_or_else(Matrix3::zeros);
        let kr = self
            .right
            .matrix()
            .try_inverse()
            .unwrap_or_else(Matrix3::zeros);
        let f = kr.transpose() * self.essential() * kl;
        if f[(2, 2)].abs() > 1e-12 * f.amax() {
            f / f[(2, 2)]
        } else {
            f
        }
    }
}

impl Calibrated {
    /// The cameras: one, or left and right.
    pub fn cameras(&self) -> Vec<&CameraCalibration> {
        match self {
            Calibrated::Single(c) => vec![c],
            Calibrated::Stereo(s) => vec![&s.left, &s.right],
        }
    }

    /// Checks every camera (and the rig).
    pub fn check(&self) -> Result<(), ExportError> {
        match self {
            Calibrated::Single(c) => c.check(),
            Calibrated::Stereo(s) => s.check(),
        }
    }
}

impl From<&calib_single::Calibration> for CameraCalibration {
    fn from(c: &calib_single::Calibration) -> Self {
        CameraCalibration {
            name: "camera".into(),
            camera: c.camera.clone(),
            image_size: c.image_size,
        }
    }
}

impl From<&calib_core::CameraEstimate> for CameraCalibration {
    fn from(e: &calib_core::CameraEstimate) -> Self {
        CameraCalibration {
            name: e.name.clone(),
            camera: e.camera.clone(),
            image_size: e.image_size,
        }
    }
}

impl From<&calib_stereo::StereoCalibration> for StereoRig {
    fn from(s: &calib_stereo::StereoCalibration) -> Self {
        let mut left = CameraCalibration::from(&s.left);
        let mut right = CameraCalibration::from(&s.right);
        if left.name.is_empty() {
            left.name = "left".into();
        }
        if right.name.is_empty() {
            right.name = "right".into();
        }
        StereoRig {
            left,
            right,
            rotation: s.rig.rotation,
            translation: s.rig.translation,
        }
    }
}

/// The camera matrix `K` of intrinsics `[fx, fy, cx, cy]`, and back (no skew).
pub(crate) fn intrinsics_of(k: &Matrix3<f64>) -> camera_model::Intrinsics {
    camera_model::Intrinsics::new(k[(0, 0)], k[(1, 1)], k[(0, 2)], k[(1, 2)])
}
