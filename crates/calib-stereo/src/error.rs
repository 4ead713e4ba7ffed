//! Errors of the stereo calibration.

use calib_single::CalibrationError;
use lm_solver::{CovarianceError, SolverError};

/// Which camera of the rig.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The left (reference) camera.
    Left,
    /// The right camera.
    Right,
}

impl std::fmt::Display for Side {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Side::Left => "left",
            Side::Right => "right",
        })
    }
}

/// What can go wrong in a stereo calibration. Errors about the input name the pair (index in
/// the input, from 0) and the camera.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StereoError {
    /// The pair list is empty (or every pair was skipped).
    #[error("no usable pairs{}", if *.skipped > 0 { format!(" ({} skipped as bad)", .skipped) } else { String::new() })]
    NoPairs {
        /// Pairs skipped as bad.
        skipped: usize,
    },
    /// The image size is missing.
    #[error("image size is missing")]
    ImageSizeMissing,
    /// An image size has a zero dimension.
    #[error("invalid {camera} image size {width}x{height}")]
    InvalidImageSize {
        /// The camera.
        camera: Side,
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
    /// A view of a pair failed the single-camera checks.
    #[error("pair {pair}, {camera} view: {}", .source.detail())]
    View {
        /// Pair index.
        pair: usize,
        /// The camera.
        camera: Side,
        /// The single-camera error (its view index is the pair index).
        source: CalibrationError,
    },
    /// The single-camera calibration that initializes one camera failed.
    #[error("{}", camera_failure(*.camera, .source))]
    Camera {
        /// The camera.
        camera: Side,
        /// The single-camera error (its view index is the pair index).
        source: CalibrationError,
    },
    /// The left and right views of these pairs are the same image (same homography).
    #[error(
        "pair{} {}: the left and right views are the same image (the same file for both cameras?)",
        if .pairs.len() > 1 { "s" } else { "" },
        .pairs.iter().map(|p| p.to_string()).collect::<Vec<_>>().join(", ")
    )]
    IdenticalViews {
        /// The pairs (input indices).
        pairs: Vec<usize>,
    },
    /// These pairs see a different rig rotation than the others (by the given angle, degrees):
    /// the right view's points are numbered differently from the left's (a board seen rotated
    /// by 180 degrees, corners reversed), or the two views are from different moments.
    #[error(
        "{}: the rotation from the left to the right camera differs from the other pairs' by more than 30 degrees: are the right view's corners in the same order as the left's (not reversed or rotated), and are both views from the same moment?",
        .pairs.iter().map(|(p, a)| format!("pair {p} ({a:.0} deg)")).collect::<Vec<_>>().join(", ")
    )]
    MismatchedPairs {
        /// The pairs (input indices) with their disagreement in degrees.
        pairs: Vec<(usize, f64)>,
    },
    /// Not enough measurements for the free parameters.
    #[error("{residuals} residuals for {parameters} free parameters: add pairs or fix parameters")]
    TooFewObservations {
        /// Scalar residuals.
        residuals: usize,
        /// Free parameters.
        parameters: usize,
    },
    /// An invalid option value.
    #[error("invalid option: {0}")]
    InvalidOption(String),
    /// The rig could not be initialized.
    #[error("rig initialization failed: {0}")]
    RigInitialization(String),
    /// The solver could not be set up or started.
    #[error("solver: {0}")]
    Solver(#[from] SolverError),
    /// The parameters are not all determined by the data.
    #[error("the calibration is not unique: {0}")]
    Unobservable(#[from] CovarianceError),
    /// The joint optimization failed (messages name the camera and pair).
    #[error("{0}")]
    Joint(CalibrationError),
    /// A non-finite value came out of the optimization.
    #[error("the optimization diverged ({0})")]
    Diverged(String),
    /// The pair bootstrap (`crate::bootstrap`) cannot estimate a spread: too few resamples or
    /// pairs, a calibration of other observations, or too few refits that succeed.
    #[error("bootstrap: {0}")]
    Bootstrap(String),
}

impl StereoError {
    /// The view an error about one view's input is about: its pair (index from 0) and camera.
    /// Its message then starts with `pair {pair}, {camera} view`.
    pub fn view(&self) -> Option<(usize, Side)> {
        match self {
            StereoError::View { pair, camera, .. } => Some((*pair, *camera)),
            StereoError::Camera { camera, source } => source.view().map(|pair| (pair, *camera)),
            _ => None,
        }
    }
}

/// A [`StereoError::Camera`]'s message: `pair 3, left view: ...` for an error about one view
/// (whose view index is the pair index), else `initial calibration of the left camera: ...`.
fn camera_failure(camera: Side, source: &CalibrationError) -> String {
    match source.view() {
        Some(pair) => format!("pair {pair}, {camera} view: {}", source.detail()),
        None => format!("initial calibration of the {camera} camera: {source}"),
    }
}
