//! Errors of a rig calibration. Messages name cameras by their names and frames by their index
//! in the input.

use calib_core::CalibrationError;

/// What can go wrong in a rig calibration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RigError {
    /// No cameras or no frames.
    #[error("the rig file has no {0}")]
    Empty(&'static str),
    /// An observation names a camera that does not exist, or a camera twice in one frame.
    #[error("frame {frame}: {reason}")]
    BadFrame {
        /// Frame index.
        frame: usize,
        /// What is wrong.
        reason: String,
    },
    /// An option is invalid (unknown camera name, reference out of range, ...).
    #[error("invalid option: {0}")]
    InvalidOption(String),
    /// A camera saw the board in too few frames to calibrate its own intrinsics.
    #[error(
        "camera '{camera}' saw the board in {views} frame{}: at least {needed} are needed for its own intrinsics; calibrate it alone and give its intrinsics (--intrinsics {camera}=RESULT.json; Python: known={{'{camera}': (K, dist)}})",
        if *.views == 1 { "" } else { "s" }
    )]
    TooFewViews {
        /// The camera.
        camera: String,
        /// Frames in which it saw the board.
        views: usize,
        /// Frames needed.
        needed: usize,
    },
    /// The per-camera calibration that starts a camera failed. An error about one view's input
    /// reads `frame 7, camera 'front': ...` (its view index is the frame index).
    #[error("{}", camera_failure(.camera, .source))]
    Camera {
        /// The camera.
        camera: String,
        /// Why.
        source: CalibrationError,
    },
    /// Some cameras share no chain of frames with the reference camera.
    #[error(
        "cameras {} share no frames with the reference camera's group {}: their position in the rig cannot be found; add frames where the board is seen by cameras of both groups",
        .groups[1..].iter().map(|g| format!("[{}]", g.join(", "))).collect::<Vec<_>>().join(" and "),
        format!("[{}]", .groups[0].join(", "))
    )]
    Disconnected {
        /// Camera names per connected group, the reference's group first.
        groups: Vec<Vec<String>>,
    },
    /// Views whose board pose (rotation or position) contradicts the rest of the rig (one entry
    /// per frame, naming the cameras).
    #[error(
        "views disagree with the rig (corners numbered differently, views from different moments, or a board of another size): {}; fix the correspondences, remove those views, or leave them out (--skip-bad-views; Python: skip_bad_views=True)",
        .0.join("; ")
    )]
    InconsistentViews(Vec<String>),
    /// The initial transform of a camera could not be computed.
    #[error("initial transform of camera '{0}' from its shared frames failed")]
    Initialization(String),
    /// The joint optimization failed (the message names cameras and frames).
    #[error("{0}")]
    Joint(CalibrationError),
}

/// A [`RigError::Camera`]'s message: `frame 7, camera 'front': ...` for an error about one view,
/// or about views that mostly miss the camera's model, else `initial calibration of camera
/// 'front': ...`.
fn camera_failure(camera: &str, source: &CalibrationError) -> String {
    match source.view() {
        Some(frame) => format!("frame {frame}, camera '{camera}': {}", source.detail()),
        // Its location names the frame and the camera already.
        None if matches!(source, CalibrationError::MostlyOutliers { .. }) => source.to_string(),
        None => format!("initial calibration of camera '{camera}': {source}"),
    }
}
