//! Planar homography estimation for camera calibration.
//!
//! A homography `H` maps a point `(X, Y)` of the calibration plane, in board units, to
//! homogeneous pixel coordinates: `(u', v', w')^T = H (X, Y, 1)^T`, pixel
//! `(x, y) = (u'/w', v'/w')`. For a pinhole camera it equals `A [r1 r2 t]` up to scale.
//! Pixel coordinates are whatever the caller passes; in this workspace they follow OpenCV:
//! `(0, 0)` is the centre of the top-left pixel, `x` to the right, `y` down. Every
//! homography returned by the crate is scaled so that `H[(2, 2)] == 1`.
//!
//! The estimation has two stages, each in its own module:
//!
//! * [`normalization_matrix`] (`normalization.rs`): similarity transforms that centre each
//!   point set and scale it to a mean distance of `sqrt(2)`, conditioning the linear system;
//! * [`dlt()`] (`dlt.rs`): the normalized direct linear transform, a closed-form estimate
//!   that minimizes an algebraic error;
//! * [`refine()`] (`refine.rs`): Gauss-Newton on the eight free entries of `H`, minimizing the
//!   pixel reprojection error with the analytic Jacobian of [`project_with_jacobian`]
//!   (`projection.rs`);
//! * [`estimate`]: both stages, the normal entry point;
//! * [`estimate_robust`] (`robust.rs`): [`estimate`], or least median of squares when some
//!   correspondences are wrong (stray corners), with the inliers; its four-point samples are
//!   fitted in closed form (`minimal.rs`) rather than by the DLT.
//!
//! Degenerate input (too few, non-finite, coincident or collinear points, configurations
//! without a unique solution, a plane origin mapped to infinity) is reported as a
//! [`HomographyError`]; nothing panics on user data and no NaN is returned.
//!
//! # Example
//!
//! ```
//! use homography::{estimate, RefineOptions};
//! use nalgebra::{Matrix3, Point2};
//!
//! // A 4 x 3 grid of board corners with 25 mm squares, seen by a slightly tilted camera.
//! let h_true = Matrix3::new(
//!     2.1, 0.15, 180.0,
//!     -0.1, 2.0, 95.0,
//!     2e-4, -1e-4, 1.0,
//! );
//! let object: Vec<Point2<f64>> = (0..12)
//!     .map(|i| Point2::new(25.0 * (i % 4) as f64, 25.0 * (i / 4) as f64))
//!     .collect();
//! let image: Vec<Point2<f64>> = object.iter().map(|p| h_true.transform_point(p)).collect();
//!
//! let est = estimate(&object, &image, &RefineOptions::default())?;
//! println!(
//!     "DLT rms {:.2e} px, refined rms {:.2e} px after {} iterations ({:?})",
//!     est.dlt_rms, est.rms, est.iterations, est.termination
//! );
//! assert!(est.rms < 1e-9);
//! assert!(est.rms <= est.dlt_rms);
//! assert!((est.h - h_true).norm() < 1e-9 * h_true.norm());
//! # Ok::<(), homography::HomographyError>(())
//! ```
#![deny(missing_docs)]

mod dlt;
mod error;
mod minimal;
mod normalization;
mod projection;
mod refine;
mod robust;
mod validate;

pub use dlt::{RANK_THRESHOLD, dlt};
pub use error::{HomographyError, PointSet};
pub use normalization::{COINCIDENCE_THRESHOLD, COLLINEARITY_THRESHOLD, normalization_matrix};
pub use projection::{Matrix2x8, project_with_jacobian, reprojection_rms};
pub use refine::{HomographyEstimate, RefineOptions, RefineTermination, estimate, refine};
pub use robust::{RobustEstimate, RobustOptions, estimate_robust};
pub use validate::H33_THRESHOLD;
