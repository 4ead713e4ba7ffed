//! Errors of the export, import, undistortion, rectification and report code.

use camera_model::CameraModel;

/// What can go wrong after calibration: every variant names what and where.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    /// The target format has no equivalent of the camera's lens model.
    #[error("the {format} format has no equivalent of the {model} lens model{detail}")]
    UnsupportedModel {
        /// The format ("kalibr", "ros").
        format: &'static str,
        /// The lens model.
        model: CameraModel,
        /// More about why (may be empty).
        detail: String,
    },
    /// The format cannot hold this kind of calibration (e.g. a single camera as a Kalibr
    /// camchain is fine, a ROS file holds one camera only).
    #[error("{0}")]
    Unsupported(String),
    /// A file could not be read.
    #[error(transparent)]
    Read(#[from] calib_core::ReadError),
    /// A file is not valid YAML or JSON.
    #[error("{path}: {reason}")]
    Syntax {
        /// The file.
        path: String,
        /// The parser's message (with line and column).
        reason: String,
    },
    /// A key is missing or has the wrong type or size.
    #[error("{path}: key '{key}': {reason}")]
    Field {
        /// The file.
        path: String,
        /// The key (dotted for nested keys, e.g. `cam1.T_cn_cnm1`).
        key: String,
        /// What is wrong.
        reason: String,
    },
    /// The file is none of the known formats.
    #[error(
        "{path}: not a calibration file this tool knows (a calib result JSON, an OpenCV FileStorage YAML, a ROS camera_info YAML or a Kalibr camchain YAML)"
    )]
    UnknownFormat {
        /// The file.
        path: String,
    },
    /// A value is not usable (non-finite number, non-positive focal length, bad size, ...).
    #[error("{what}: {reason}")]
    Invalid {
        /// Which value.
        what: String,
        /// Why.
        reason: String,
    },
    /// The camera model could not map a point (outside the region where the model is valid).
    #[error("{what}: {source}")]
    Camera {
        /// What was being computed.
        what: String,
        /// The camera model's error.
        source: camera_model::CameraModelError,
    },
    /// An image could not be read, decoded or encoded.
    #[error("{path}: {reason}")]
    Image {
        /// The image file.
        path: String,
        /// What went wrong.
        reason: String,
    },
    /// A file could not be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
}

impl ExportError {
    /// Says which camera of a rig an unsupported-model error is about (`label`, e.g.
    /// "camera 'cam1', cam1"); other errors pass unchanged.
    pub(crate) fn about_camera(self, label: &str) -> Self {
        match self {
            ExportError::UnsupportedModel {
                format,
                model,
                detail,
            } => ExportError::UnsupportedModel {
                format,
                model,
                detail: format!("{detail} [{label}]"),
            },
            other => other,
        }
    }

    /// A [`ExportError::Field`] error.
    pub(crate) fn field(path: &str, key: &str, reason: impl Into<String>) -> Self {
        ExportError::Field {
            path: path.to_string(),
            key: key.to_string(),
            reason: reason.into(),
        }
    }

    /// A [`ExportError::Invalid`] error.
    pub(crate) fn invalid(what: impl Into<String>, reason: impl Into<String>) -> Self {
        ExportError::Invalid {
            what: what.into(),
            reason: reason.into(),
        }
    }
}
