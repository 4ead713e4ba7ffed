//! Options of the stereo calibration.

use calib_core::OutlierRejection;
use calib_core::rig::RigInit;
use calib_single::{CalibrationOptions, default_solver_options};
use camera_model::{Pose, RotationKind};
use lm_solver::{Loss, SolverOptions};

/// What to estimate and how. The default estimates both cameras, all left poses and the rig from
/// the single-camera calibrations, like OpenCV's `stereoCalibrate` with `CALIB_FIX_K3` and no
/// `CALIB_FIX_INTRINSIC`.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct StereoOptions {
    /// Options of the left camera: they drive its initial single-camera calibration, and the
    /// parameters they hold fixed (principal point, focal length, aspect ratio, tangential or
    /// individual distortion terms) stay fixed in the joint optimization.
    pub left: CalibrationOptions,
    /// Options of the right camera, likewise.
    pub right: CalibrationOptions,
    /// Hold the left camera's intrinsics and distortion at their initial values (its
    /// single-camera estimate, or the guess in `left`). Either camera can be fixed alone.
    pub fix_left_intrinsics: bool,
    /// Hold the right camera's intrinsics and distortion at their initial values.
    pub fix_right_intrinsics: bool,
    /// Give both cameras the same focal lengths (`fx_R = fx_L`, `fy_R = fy_L`).
    pub same_focal_length: bool,
    /// Start from this rig (left camera to right camera: `X_R = R X_L + T`) instead of the one
    /// computed from the single-camera poses.
    pub rig_guess: Option<Pose>,
    /// How the initial rig is computed.
    pub rig_init: RigInit,
    /// Rotation parameterization of the poses and the rig during the joint optimization
    /// (default [`RotationKind::So3`]: Euler angles are singular where the right camera turns
    /// 90 degrees about y from the left one, which made such a rig's rotation look undetermined).
    pub rotation: RotationKind,
    /// Outlier rejection for both the single-camera stages and the joint optimization (default
    /// on; `None` uses every point, like OpenCV). See `calib_core::outliers`.
    pub outliers: Option<OutlierRejection>,
    /// Robust loss on each point's squared error in the joint optimization, px^2.
    pub loss: Loss,
    /// Skip pairs that fail the checks (listed in the result) instead of failing.
    pub skip_bad_pairs: bool,
    /// Levenberg-Marquardt settings of the joint optimization (its thread count also applies to
    /// the single-camera calibrations).
    pub solver: SolverOptions,
}

impl Default for StereoOptions {
    fn default() -> Self {
        Self {
            left: CalibrationOptions::default(),
            right: CalibrationOptions::default(),
            fix_left_intrinsics: false,
            fix_right_intrinsics: false,
            same_focal_length: false,
            rig_guess: None,
            rig_init: RigInit::default(),
            rotation: RotationKind::So3,
            outliers: Some(OutlierRejection::default()),
            loss: Loss::Trivial,
            skip_bad_pairs: false,
            solver: default_solver_options(),
        }
    }
}
