//! Errors of the camera model.

/// What can go wrong when projecting or back-projecting points.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraModelError {
    /// The point is on or behind the camera's image plane (`z <= 0` in the camera frame), so it
    /// has no image.
    #[error("point is not in front of the camera (camera-frame depth z = {depth})")]
    PointBehindCamera {
        /// Camera-frame `z` of the point.
        depth: f64,
    },
    /// An input (point, pixel or parameter) is NaN or infinite.
    #[error("non-finite value in {what}")]
    NonFinite {
        /// Which input.
        what: &'static str,
    },
    /// The intrinsics cannot invert pixels (a focal length is zero, negative or not finite).
    #[error("invalid intrinsics: focal lengths must be finite and positive (fx = {fx}, fy = {fy})")]
    InvalidIntrinsics {
        /// Horizontal focal length.
        fx: f64,
        /// Vertical focal length.
        fy: f64,
    },
    /// Undistortion did not reach the tolerance: the pixel is probably outside the region where
    /// the distortion model can be inverted (beyond the radius where it folds back).
    #[error(
        "undistortion did not converge after {iterations} iterations (remaining error {residual:e} in normalized units)"
    )]
    UndistortNotConverged {
        /// Iterations performed.
        iterations: usize,
        /// Remaining distance between the re-distorted estimate and the target.
        residual: f64,
    },
    /// The distortion map is singular at the current estimate (its Jacobian is not invertible).
    #[error("distortion map is singular near the point being undistorted")]
    UndistortSingular,
}
