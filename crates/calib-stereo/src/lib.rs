//! Stereo rig calibration from pairs of views of a planar target.
//!
//! Both cameras see the board at the same time in each pair. [`calibrate_stereo`] estimates both
//! cameras (intrinsics and distortion of any lens model), the board pose in the left camera for
//! every pair and the rig transform `X_right = R X_left + T`, with standard deviations, the
//! essential and fundamental matrices and the baseline:
//!
//! 1. each camera is calibrated alone (the single-camera pipeline of `calib_core`),
//! 2. the initial rig comes from the per-pair poses: `R_R = R_s R_L` stacked over all pairs and
//!    solved by least squares then made a rotation by SVD, `T` the mean of `t_R - R_s t_L`,
//! 3. Levenberg-Marquardt over both cameras, the rig (6) and one left pose per pair (6,
//!    eliminated by the Schur complement), with the engine's one cost for any number of cameras.
//!
//! This crate is a thin front end: the stereo file format, options, the epipolar geometry and
//! the result. Walk-through with the Jacobian's block pattern: `docs/calib-stereo.md`.
//!
//! ```
//! use calib_stereo::{StereoOptions, calibrate_stereo, synthetic};
//!
//! let mut config = synthetic::SyntheticStereoConfig::default();
//! config.left.views = 10;
//! config.left.noise_px = 0.1;
//! let data = synthetic::generate_stereo(&config).unwrap();
//! let rig = calibrate_stereo(&data.observations, &StereoOptions::default()).unwrap();
//! assert!(rig.solver.termination.is_converged());
//! assert!((rig.baseline - data.rig.translation.norm()).abs() < 5.0 * rig.rig_std[3].max(rig.rig_std[4]).max(rig.rig_std[5]) + 0.5);
//! println!("{}", rig.summary());
//! ```
#![deny(missing_docs)]

pub mod bootstrap;
pub mod calibrate;
pub mod error;
pub mod observations;
pub mod options;
pub mod result;
pub mod synthetic;

pub use bootstrap::{CameraSpread, StereoBootstrap, add_bootstrap, bootstrap};
pub use calib_core::rig;
pub use calib_core::rig::RigInit;
pub use calib_core::{JsonFile, ResultFormatError};
pub use calib_single::BootstrapOptions;
pub use calibrate::{calibrate_stereo, stereo_problem};
pub use error::{Side, StereoError};
pub use observations::{StereoObservations, StereoPair};
pub use options::StereoOptions;
pub use result::{CameraEstimate, PairResult, SkippedPair, StereoCalibration};
