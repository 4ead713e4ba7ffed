//! The calibration engine shared by the single-camera, stereo and multi-camera front ends.
//!
//! A calibration is described as data ([`JointProblem`]): cameras with a lens model and masks,
//! frames (board poses), observations (which camera saw which board points where in which frame)
//! and rig transforms. One cost implementation ([`JointCost`]) serves one camera, a stereo pair
//! and N cameras with any mix of lens models, with per-point weights and robust losses; one
//! solve ([`solve()`]) builds the `lm_solver` problem (cameras and rig reduced, frame poses
//! eliminated by the Schur complement), runs Levenberg-Marquardt and reads the solution back
//! with standard deviations. The closed-form starts ([`init`], [`rig`]) are shared as well.
//!
//! Layers and a picture of the blocks: `docs/architecture.md`.
#![deny(missing_docs)]

pub mod cost;
pub mod data;
pub mod diagnostics;
pub mod error;
pub mod init;
pub mod io;
mod kernel;
pub mod options;
pub mod outliers;
pub mod problem;
pub mod result;
pub mod rig;
pub mod single;
pub mod solve;
pub mod synthetic;
pub mod warnings;

pub use cost::JointCost;
pub use data::{ImageSize, View};
pub use error::{CalibrationError, OutlierView, PointKind, view_location};
pub use init::FocalInit;
pub use io::{JsonFile, ReadError, read_text, write_atomically};
pub use options::{CalibrationOptions, default_solver_options};
pub use outliers::OutlierRejection;
pub use problem::{CameraSpec, JointProblem, ObservationSpec, ProblemError};
pub use result::{CameraEstimate, ResultFormatError, SkippedView, StageTimes, ViewResult};
pub use single::{PreparedCamera, prepare_camera};
pub use solve::{JointSolution, ObservationErrors, SolveOptions, reprojection_errors, solve};
pub use warnings::{Warning, WarningCode};

pub use camera_model;
pub use lm_solver;
/// The linear-algebra crate of the public API.
pub use nalgebra;
