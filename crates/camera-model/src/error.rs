//! Errors of the camera model.

/// What can go wrong when projecting or back-projecting points.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
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
    /// The pixel's only preimages found lie beyond a fold or a pole of the distortion map, not on
    /// the branch that starts at the principal point: the pixel is outside the region where the
    /// lens model is valid (`crate::validity`), and no direction can be trusted for it.
    #[error(
        "the pixel lies beyond the region where the lens model is one-to-one (its only undistorted points lie past a fold or pole of the distortion)"
    )]
    UndistortBeyondValidRegion,
    /// The undistorted point is the image of no direction (beyond the projection's range, e.g. a
    /// fisheye angle of 180 degrees or more).
    #[error("the undistorted point lies outside the projection's range")]
    OutsideProjection,
    /// A camera model name that is not known.
    #[error("unknown camera model '{0}' (known: {known})", known = crate::model::CameraModel::NAMES.join(", "))]
    UnknownModel(String),
    /// An intrinsic parameter vector `[fx, fy, cx, cy, distortion...]` of the wrong length.
    #[error(
        "model {model} takes {expected} intrinsic parameters (fx, fy, cx, cy and its distortion coefficients), got {found}"
    )]
    ParameterVectorLength {
        /// The model name.
        model: &'static str,
        /// Expected number.
        expected: usize,
        /// Given number.
        found: usize,
    },
    /// A distortion coefficient list of the wrong length for its model.
    #[error("model {model} has {expected} distortion coefficients, got {found}")]
    ParameterCount {
        /// The model name.
        model: &'static str,
        /// Expected number.
        expected: usize,
        /// Given number.
        found: usize,
    },
}
