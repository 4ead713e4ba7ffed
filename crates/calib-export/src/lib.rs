//! After calibration: files other tools read (and reading them back), undistortion and stereo
//! rectification of points and images, and an HTML report.
//!
//! * [`export`] writes a [`Calibrated`] camera, stereo rig or rig of N cameras as OpenCV
//!   FileStorage YAML ([`opencv`]), ROS camera_info YAML ([`ros`]) or a Kalibr camchain
//!   ([`kalibr`]);
//!   [`read_calibration`] reads any of them, or a `calib` result JSON, back.
//! * [`undistort`] maps pixels to undistorted normalized coordinates or to the pixels of a new
//!   camera matrix, chosen like OpenCV's `getOptimalNewCameraMatrix`; [`rectify`] computes
//!   Bouguet's stereo rectification (`R1`, `R2`, `P1`, `P2`, `Q`); [`remap`] builds the pixel
//!   maps once per camera and resamples images (bilinear) in parallel.
//! * [`report`] writes an HTML page with SVG plots (residuals, mean residuals, residual
//!   scatter, coverage, per-view RMS, board poses, distortion field, projection uncertainty;
//!   the layout of a stereo pair or rig).
//!
//! Conventions are the workspace's: pixels as in OpenCV (`(0, 0)` is the centre of the top-left
//! pixel), distortion coefficients in OpenCV's order, `X_right = R X_left + T`. The math and the
//! file layouts are described in `docs/after-calibration.md` and `docs/formats.md`.
//!
//! ```
//! use calib_export::camera_model::{AnyCamera, CameraModel, Intrinsics};
//! use calib_export::{
//!     Calibrated, CameraCalibration, ExportOptions, Format, ImageSize, export_texts,
//!     optimal_new_camera_matrix, undistort_point,
//! };
//! use nalgebra::Vector2;
//!
//! // A calibrated camera (e.g. a calib single result's `camera`), k1 k2 p1 p2 in OpenCV's order.
//! let lens = AnyCamera::new(
//!     CameraModel::BrownConrady4,
//!     Intrinsics::new(463.0, 463.0, 314.5, 187.3),
//!     vec![0.115, -0.199, -0.0017, -0.0024],
//! )?;
//! let camera = CameraCalibration::new("left", lens, ImageSize::new(640, 360))?;
//! // OpenCV's getOptimalNewCameraMatrix with alpha 0, and undistortPoints into its pixels.
//! let (k_new, valid_roi) = optimal_new_camera_matrix(&camera.camera, camera.image_size, 0.0)?;
//! let p = undistort_point(&camera.camera, &Vector2::new(600.0, 40.0), None, Some(&k_new))?;
//! assert!(p.x.is_finite() && valid_roi[2] > 0);
//! // The camera as OpenCV FileStorage YAML (cv2.FileStorage reads it).
//! let yaml = export_texts(&Calibrated::Single(camera), Format::OpenCv, &ExportOptions::default())?;
//! assert!(yaml[0].contains("camera_matrix"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

pub mod calibration;
pub mod covariance;
pub mod error;
pub mod files;
pub mod kalibr;
pub mod opencv;
pub mod rectify;
pub mod remap;
pub mod report;
pub mod ros;
pub mod undistort;
mod yaml;

pub use calib_core::{ImageSize, ResultFormatError};
pub use calibration::{Calibrated, CameraCalibration, CameraRig, StereoRig};
pub use camera_model;
pub use error::ExportError;
pub use files::{
    ExportOptions, Format, RenderedExport, check_format_takes_model, export, export_paths,
    export_texts, parse_calibration, read_calibration, render_export, write_export,
};
pub use rectify::{Rectification, stereo_rectify};
pub use remap::{PixelMap, remap_image};
pub use report::{ReportInput, RigLayout, write_report};
pub use undistort::{Rect, optimal_new_camera_matrix, undistort_point, undistort_points};
