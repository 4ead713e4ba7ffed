//! Warnings: the calibration finished, but something in the data or the result deserves the
//! user's attention. Each has a stable code (for scripts) and a message in user terms that says
//! what to do. Every warning is listed in `docs/calib-single.md`.

use serde::{Deserialize, Serialize};
use std::fmt;

/// What a [`Warning`] is about. Codes are written in files as kebab-case strings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
#[non_exhaustive]
pub enum WarningCode {
    /// The solver stopped at its iteration limit before converging.
    IterationLimit,
    /// Points were rejected as outliers.
    OutliersRejected,
    /// Two or more views have identical points; the copies were dropped.
    DuplicateViews,
    /// The principal point is far from the image centre (a wrong image size?).
    PrincipalPointOffCentre,
    /// A parameter's standard deviation is large relative to its value.
    PoorlyDetermined,
    /// Points lie outside the image (a wrong image size?).
    PointsOutsideImage,
    /// One view's error is far above the others'.
    InconsistentView,
    /// The baseline between two cameras is short relative to the board distance.
    ShortBaseline,
    /// The board covers little of the image: the distortion is extrapolated elsewhere.
    PoorCoverage,
    /// A lens model is not valid over the whole image (not monotonic, denominator near zero).
    ModelInvalid,
    /// Images (or stereo pairs) given to calibrate from photographs were left out: the board
    /// was not found in them (the result lists them with the reasons).
    ImagesSkipped,
    /// The errors vary with the distance from the principal point far beyond the noise: the
    /// lens model does not fit, and the standard deviations do not cover that misfit.
    ModelMisfit,
    /// A parameter's view-bootstrap standard deviation far exceeds its linearized sigma: the
    /// linearized sigmas of the fit understate its uncertainty.
    BootstrapSpread,
    /// A code written by a newer version.
    #[serde(other)]
    Other,
}

impl WarningCode {
    /// The code as written in files.
    pub fn name(self) -> &'static str {
        match self {
            WarningCode::IterationLimit => "iteration-limit",
            WarningCode::OutliersRejected => "outliers-rejected",
            WarningCode::DuplicateViews => "duplicate-views",
            WarningCode::PrincipalPointOffCentre => "principal-point-off-centre",
            WarningCode::PoorlyDetermined => "poorly-determined",
            WarningCode::PointsOutsideImage => "points-outside-image",
            WarningCode::InconsistentView => "inconsistent-view",
            WarningCode::ShortBaseline => "short-baseline",
            WarningCode::PoorCoverage => "poor-coverage",
            WarningCode::ModelInvalid => "model-invalid",
            WarningCode::ImagesSkipped => "images-skipped",
            WarningCode::ModelMisfit => "model-misfit",
            WarningCode::BootstrapSpread => "bootstrap-spread",
            WarningCode::Other => "other",
        }
    }
}

/// A warning attached to a result.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Warning {
    /// What it is about.
    pub code: WarningCode,
    /// What happened and what to do, in user terms.
    pub message: String,
}

impl Warning {
    /// A warning with `code` and `message`.
    pub fn new(code: WarningCode, message: impl Into<String>) -> Self {
        Self {
            code,
            message: message.into(),
        }
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "warning [{}]: {}", self.code.name(), self.message)
    }
}

/// Appends one summary line per warning, prefixed with `indent`.
pub fn write_warnings(out: &mut String, indent: &str, warnings: &[Warning]) {
    use fmt::Write;
    for w in warnings {
        let _ = writeln!(out, "{indent}{w}");
    }
}
