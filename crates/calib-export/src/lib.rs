//! After calibration: files other tools read (and reading them back), undistortion and stereo
//! rectification of points and images, and an HTML report.
//!
//! * [`export`] writes a [`Calibrated`] camera or stereo rig as OpenCV FileStorage YAML
//!   ([`opencv`]), ROS camera_info YAML ([`ros`]) or a Kalibr camchain ([`kalibr`]);
//!   [`read_calibration`] reads any of them, or a `calib` result JSON, back.
//! * [`undistort`] maps pixels to undistorted normalized coordinates or to the pixels of a new
//!   camera matrix, chosen like OpenCV's `getOptimalNewCameraMatrix`; [`rectify`] computes
//!   Bouguet's stereo rectification (`R1`, `R2`, `P1`, `P2`, `Q`); [`remap`] builds the pixel
//!   maps once per camera and resamples images (bilinear) in parallel.
//! * [`report`] writes an HTML page with SVG plots (residuals, coverage, per-view RMS, board
//!   poses, distortion field, projection uncertainty).
//!
//! Conventions are the workspace's: pixels as in OpenCV (`(0, 0)` is the centre of the top-left
//! pixel), distortion coefficients in OpenCV's order, `X_right = R X_left + T`. The math and the
//! file layouts are described in `docs/after-calibration.md` and `docs/formats.md`.
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

pub use calibration::{Calibrated, CameraCalibration, CameraRig, StereoRig};
pub use error::ExportError;
pub use files::{
    ExportOptions, Format, check_format_takes_model, export, export_paths, export_texts,
    parse_calibration, read_calibration,
};
pub use rectify::{Rectification, stereo_rectify};
pub use remap::{PixelMap, remap_image};
pub use report::{ReportInput, RigLayout, write_report};
pub use undistort::{Rect, optimal_new_camera_matrix, undistort_point, undistort_points};
