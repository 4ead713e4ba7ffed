//! Single-camera calibration from views of a planar target.
//!
//! Given, for each view, the board points (on the plane `Z = 0`) and the pixels where they were
//! detected, [`calibrate()`] estimates the intrinsics `fx, fy, cx, cy`, the lens distortion
//! (Brown-Conrady `k1, k2, p1, p2` by default; any [`camera_model::CameraModel`] through
//! [`CalibrationOptions::model`]) and one board-to-camera pose per view, with standard deviations
//! for all of them:
//!
//! 1. a homography per view (normalized DLT and Gauss-Newton refinement, crate `homography`),
//! 2. closed-form intrinsics: principal point at the image centre, square pixels, the focal length
//!    from the orthogonality of the board's axes and diagonals (Bouguet's solution by default),
//! 3. closed-form poses from `K^-1 H`, made orthonormal by SVD,
//! 4. Levenberg-Marquardt over all parameters with analytic Jacobians and the poses eliminated by
//!    the Schur complement; the covariance of the solution gives the standard deviations.
//!
//! The pipeline is a thin front end over the engine `calib_core`, which it shares with the stereo
//! and rig front ends. Pixels follow OpenCV's convention (`(0, 0)` is the centre of the top-left
//! pixel) and poses map board coordinates to camera coordinates. The walk-through with formulas
//! is in `docs/calib-single.md`; the JSON formats are in `docs/formats.md`.
//!
//! ```
//! use calib_single::{CalibrationOptions, calibrate, synthetic};
//!
//! // Twelve views of a 9x6 board by a known camera, with 0.1 px noise.
//! let mut config = synthetic::SyntheticConfig::default();
//! config.views = 12;
//! config.noise_px = 0.1;
//! let data = synthetic::generate(&config).unwrap();
//! let result = calibrate(&data.observations, &CalibrationOptions::default()).unwrap();
//! assert!(result.solver.termination.is_converged());
//! assert!((result.camera.intrinsics.fx - data.camera.intrinsics.fx).abs() < 5.0 * result.intrinsics_std[0] + 1e-9);
//! assert!(result.rms < 0.2);
//! println!("{}", result.summary());
//! ```
#![deny(missing_docs)]

pub mod bootstrap;
pub mod calibrate;
pub mod compare;
pub mod observations;
pub mod result;
pub mod synthetic;

pub use bootstrap::{Bootstrap, BootstrapOptions, BootstrapStart, add_bootstrap, bootstrap};
pub use calib_core::{
    CalibrationError, CalibrationOptions, FocalInit, JsonFile, OutlierView, PointKind,
    default_solver_options,
};
pub use calib_core::{error, init, options};
pub use calibrate::{calibrate, reproject};
pub use compare::{ModelComparison, ModelRow, compare_models};
pub use observations::{ImageSize, Observations, ReadError, View};
pub use result::{
    Calibration, CameraEstimate, ResultFormatError, SkippedView, StageTimes, ViewResult,
};

pub use camera_model;
/// The linear-algebra crate of the public API.
pub use nalgebra;
