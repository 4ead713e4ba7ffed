//! Options of a rig calibration.

use calib_core::{CalibrationOptions, OutlierRejection, default_solver_options};
use camera_model::{AnyCamera, CameraModel, RotationKind};
use lm_solver::{Loss, SolverOptions};

/// What to estimate and how. The default estimates every camera's intrinsics (each from its own
/// views first), every camera's transform from camera 0 and one board pose per frame.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct RigOptions {
    /// Options of each camera's own calibration (masks, start, homographies); the lens model is
    /// overridden per camera by [`RigOptions::models`] or the file's `model`.
    pub camera: CalibrationOptions,
    /// Lens model per camera (`None`: the file's, else `camera.model`); shorter than the camera
    /// list is fine.
    pub models: Vec<Option<CameraModel>>,
    /// Known cameras (intrinsics and distortion), held fixed, per camera (`None`: estimated).
    pub given: Vec<Option<AnyCamera>>,
    /// Names of distortion coefficients ("k3", "p1") held at their start value in every camera
    /// whose model has them (on top of `camera.fixed_distortion`, which is by position in
    /// `camera.model` and carried to other models by name).
    pub hold_fixed: Vec<String>,
    /// Per camera (index), more names held in that camera only; each must be one of its
    /// model's coefficients. Shorter than the camera list is fine.
    pub hold_fixed_by_camera: Vec<Vec<String>>,
    /// The reference camera: its frame is the rig's, its transform the identity.
    pub reference: usize,
    /// Rotation parameterization of frame poses and camera transforms (default
    /// [`RotationKind::So3`]: Euler angles are singular at 90 degrees about y, a common angle
    /// between the cameras of a rig).
    pub rotation: RotationKind,
    /// Outlier rejection for the per-camera stages and the joint optimization (`None`: every
    /// point).
    pub outliers: Option<OutlierRejection>,
    /// Robust loss of the joint optimization.
    pub loss: Loss,
    /// Fewest frames a camera must see for its own intrinsics (default 3).
    pub min_views: usize,
    /// Levenberg-Marquardt settings of the joint optimization (its thread count also applies to
    /// the per-camera stages).
    pub solver: SolverOptions,
}

impl Default for RigOptions {
    fn default() -> Self {
        Self {
            camera: CalibrationOptions::default(),
            models: Vec::new(),
            given: Vec::new(),
            hold_fixed: Vec::new(),
            hold_fixed_by_camera: Vec::new(),
            reference: 0,
            rotation: RotationKind::So3,
            outliers: Some(OutlierRejection::default()),
            loss: Loss::Trivial,
            min_views: 3,
            solver: default_solver_options(),
        }
    }
}
