//! What the exporters write and the importers read: one calibrated camera, a stereo rig, or a
//! rig of N cameras.
//!
//! Conventions are the workspace's: pixels as in OpenCV (`(0, 0)` is the centre of the top-left
//! pixel), distortion coefficients in OpenCV's order for the model, and a stereo rig maps the
//! left camera's frame to the right one's, `X_right = R X_left + T` (`T` in board units); an
//! N-camera rig gives each camera's transform from the reference camera, `X_cam = R X_ref + T`.

use crate::error::ExportError;
use calib_core::ImageSize;
use camera_model::{AnyCamera, Pose};
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

/// A calibrated rig of N cameras (`calib rig`): each camera and its transform from the
/// reference camera.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraRig {
    /// The cameras, in the rig's order; names are unique.
    pub cameras: Vec<CameraCalibration>,
    /// Each camera's transform from the reference camera's frame: `X_cam = R X_ref + T`
    /// (`T` in board units; the identity for the reference).
    pub transforms: Vec<Pose>,
    /// The reference camera (index into `cameras`).
    pub reference: usize,
    /// For each camera, the cameras it shares views with (Kalibr's `cam_overlaps`); every other
    /// camera when unknown.
    pub overlaps: Vec<Vec<usize>>,
}

/// A calibration as read from any supported file.
#[derive(Debug, Clone, PartialEq)]
pub enum Calibrated {
    /// One camera.
    Single(CameraCalibration),
    /// A stereo rig.
    Stereo(StereoRig),
    /// A rig of N cameras.
    Rig(CameraRig),
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
        check_rotation(&self.rotation, "stereo rig R")?;
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

/// Refuses a matrix that is not a rotation (orthonormal to 1e-6, determinant +1): the error
/// names the value as `what` (`R: not a rotation matrix (...)`).
pub fn check_rotation(r: &Matrix3<f64>, what: &str) -> Result<(), ExportError> {
    let orthogonality = (r.transpose() * r - Matrix3::identity()).amax();
    if !(orthogonality < 1e-6 && (r.determinant() - 1.0).abs() < 1e-6) {
        return Err(ExportError::invalid(
            what,
            format!("not a rotation matrix (|R^T R - I| = {orthogonality:e})"),
        ));
    }
    Ok(())
}

impl CameraRig {
    /// A rig with every other camera as overlap; checks it ([`CameraRig::check`]).
    pub fn new(
        cameras: Vec<CameraCalibration>,
        transforms: Vec<Pose>,
        reference: usize,
    ) -> Result<Self, ExportError> {
        let n = cameras.len();
        let rig = Self {
            cameras,
            transforms,
            reference,
            overlaps: (0..n)
                .map(|i| (0..n).filter(|&j| j != i).collect())
                .collect(),
        };
        rig.check()?;
        Ok(rig)
    }

    /// Refuses fewer than two cameras, a transform count that differs from the camera count,
    /// empty or repeated names, a reference out of range or not at the identity, transforms
    /// that are not rotations with finite translations, and overlaps naming unknown cameras.
    pub fn check(&self) -> Result<(), ExportError> {
        let n = self.cameras.len();
        if n < 2 {
            return Err(ExportError::invalid(
                "rig",
                format!("a rig needs at least two cameras, got {n}"),
            ));
        }
        if self.transforms.len() != n || self.overlaps.len() != n {
            return Err(ExportError::invalid(
                "rig",
                format!(
                    "{n} cameras but {} transforms and {} overlap lists",
                    self.transforms.len(),
                    self.overlaps.len()
                ),
            ));
        }
        for (i, c) in self.cameras.iter().enumerate() {
            c.check()?;
            if c.name.is_empty() {
                return Err(ExportError::invalid(
                    format!("rig camera {i}"),
                    "the name is empty",
                ));
            }
            if self.cameras[..i].iter().any(|o| o.name == c.name) {
                return Err(ExportError::invalid(
                    format!("rig camera {i}"),
                    format!("the name '{}' is used twice", c.name),
                ));
            }
        }
        if self.reference >= n {
            return Err(ExportError::invalid(
                "rig",
                format!("reference camera {} of {n} cameras", self.reference),
            ));
        }
        for (c, t) in self.cameras.iter().zip(&self.transforms) {
            let what = format!("rig transform of camera '{}'", c.name);
            check_rotation(&t.rotation, &what)?;
            if !t.translation.iter().all(|v| v.is_finite()) {
                return Err(ExportError::invalid(
                    what,
                    format!("T is not finite: {:?}", t.translation.as_slice()),
                ));
            }
        }
        let r = &self.transforms[self.reference];
        if (r.rotation - Matrix3::identity()).amax() > 1e-9 || r.translation.amax() > 1e-9 {
            return Err(ExportError::invalid(
                "rig",
                format!(
                    "the reference camera '{}' must have the identity transform",
                    self.cameras[self.reference].name
                ),
            ));
        }
        for (i, o) in self.overlaps.iter().enumerate() {
            if let Some(j) = o.iter().find(|&&j| j >= n || j == i) {
                return Err(ExportError::invalid(
                    format!("rig camera '{}'", self.cameras[i].name),
                    format!("overlap with camera {j}: not another camera of the rig"),
                ));
            }
        }
        Ok(())
    }

    /// The index of the camera named `name`, or an error listing the names.
    pub fn camera_index(&self, name: &str) -> Result<usize, ExportError> {
        self.cameras
            .iter()
            .position(|c| c.name == name)
            .ok_or_else(|| {
                let names: Vec<&str> = self.cameras.iter().map(|c| c.name.as_str()).collect();
                ExportError::invalid(
                    "rig",
                    format!(
                        "no camera named '{name}' (the cameras are {})",
                        names.join(", ")
                    ),
                )
            })
    }

    /// The transform from camera `from`'s frame to camera `to`'s: `X_to = R X_from + T`.
    pub fn relative(&self, from: usize, to: usize) -> Pose {
        self.transforms[to].compose(&self.transforms[from].inverse())
    }

    /// Cameras `left` and `right` (indices) as a stereo rig, for stereo exports and
    /// rectification.
    pub fn pair(&self, left: usize, right: usize) -> Result<StereoRig, ExportError> {
        let n = self.cameras.len();
        if left >= n || right >= n || left == right {
            return Err(ExportError::invalid(
                "rig pair",
                format!("cameras {left} and {right}: two different cameras of {n} are needed"),
            ));
        }
        let t = self.relative(left, right);
        let pair = StereoRig {
            left: self.cameras[left].clone(),
            right: self.cameras[right].clone(),
            rotation: t.rotation,
            translation: t.translation,
        };
        pair.check().map_err(|e| {
            ExportError::invalid(
                format!(
                    "rig pair '{}', '{}'",
                    self.cameras[left].name, self.cameras[right].name
                ),
                e.to_string(),
            )
        })?;
        Ok(pair)
    }
}

impl Calibrated {
    /// The cameras: one, left and right, or the rig's.
    pub fn cameras(&self) -> Vec<&CameraCalibration> {
        match self {
            Calibrated::Single(c) => vec![c],
            Calibrated::Stereo(s) => vec![&s.left, &s.right],
            Calibrated::Rig(r) => r.cameras.iter().collect(),
        }
    }

    /// Checks every camera (and the rig).
    pub fn check(&self) -> Result<(), ExportError> {
        match self {
            Calibrated::Single(c) => c.check(),
            Calibrated::Stereo(s) => s.check(),
            Calibrated::Rig(r) => r.check(),
        }
    }

    /// What it is, in messages: "a single camera", "a stereo rig", "a rig of 4 cameras".
    pub fn kind(&self) -> String {
        match self {
            Calibrated::Single(_) => "a single camera".into(),
            Calibrated::Stereo(_) => "a stereo rig".into(),
            Calibrated::Rig(r) => format!("a rig of {} cameras", r.cameras.len()),
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

impl From<&calib_rig::RigCalibration> for CameraRig {
    fn from(r: &calib_rig::RigCalibration) -> Self {
        let n = r.cameras.len();
        let mut overlaps = vec![Vec::new(); n];
        for frame in &r.frames {
            for a in &frame.views {
                for b in &frame.views {
                    if a.camera != b.camera
                        && a.camera < n
                        && !overlaps[a.camera].contains(&b.camera)
                    {
                        overlaps[a.camera].push(b.camera);
                    }
                }
            }
        }
        for o in &mut overlaps {
            o.sort_unstable();
        }
        CameraRig {
            cameras: r
                .cameras
                .iter()
                .map(|c| CameraCalibration::from(&c.estimate))
                .collect(),
            transforms: r.cameras.iter().map(|c| c.transform).collect(),
            reference: r.reference,
            overlaps,
        }
    }
}

/// The camera matrix `K` of intrinsics `[fx, fy, cx, cy]`, and back (no skew).
pub(crate) fn intrinsics_of(k: &Matrix3<f64>) -> camera_model::Intrinsics {
    camera_model::Intrinsics::new(k[(0, 0)], k[(1, 1)], k[(0, 2)], k[(1, 2)])
}
