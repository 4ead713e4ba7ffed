//! Multi-camera rig calibration: N cameras, each seeing a planar board in some of the frames,
//! calibrated jointly.
//!
//! A frame is one moment: the board is still and every camera listed in it saw the board.
//! [`calibrate_rig`] estimates every camera's intrinsics and distortion (any lens model, per
//! camera), every camera's transform from the reference camera `X_cam = R X_ref + T`, and one
//! board pose per frame (board to reference camera), with standard deviations:
//!
//! 1. each camera is calibrated alone on its frames (the single-camera pipeline of `calib_core`;
//!    cameras with given intrinsics hold them fixed),
//! 2. the camera graph (edge weight: frames two cameras share) and its maximum spanning tree from
//!    the reference give each camera's start transform, averaged over the frames it shares with
//!    its parent ([`calib_core::rig`], the stereo start) and chained along the tree; each frame's
//!    start pose comes from the camera nearest the reference that saw it,
//! 3. one Levenberg-Marquardt over all intrinsics, the `N - 1` transforms and the frame poses,
//!    the frame poses eliminated by the Schur complement (the engine `calib_core::solve`, the
//!    same one the single-camera and stereo pipelines use).
//!
//! The graph, the start, the parameter layout and the block structure: `docs/calib-rig.md`.
//!
//! ```
//! use calib_rig::{RigOptions, calibrate_rig, synthetic};
//!
//! let mut config = synthetic::SyntheticRigConfig::default();
//! config.cameras = 3;
//! let data = synthetic::generate_rig(&config).unwrap();
//! let rig = calibrate_rig(&data.observations, &RigOptions::default()).unwrap();
//! assert!(rig.solver.termination.is_converged());
//! let baseline = rig.cameras[1].transform.translation.norm();
//! assert!((baseline - data.transforms[1].translation.norm()).abs() < 1.0);
//! println!("{}", rig.summary());
//! ```
#![deny(missing_docs)]

pub mod calibrate;
pub mod error;
pub mod graph;
pub mod observations;
pub mod options;
pub mod result;
pub mod synthetic;

pub use calib_core::{JsonFile, ResultFormatError};
pub use calibrate::{calibrate_rig, rig_problem};
pub use error::RigError;
pub use observations::{RigCameraInput, RigFrame, RigObservation, RigObservations};
pub use options::RigOptions;
pub use result::{FrameResult, FrameView, RigCalibration, RigCamera};
