//! A generic sparse Levenberg-Marquardt engine with block-structured linear solvers.
//!
//! The engine knows nothing about cameras. A problem is a set of *parameter blocks* (small dense
//! vectors) and *residual blocks* (small dense residual vectors, each depending on a few parameter
//! blocks), described once with [`ProblemBuilder`]; a [`CostFunction`] fills each residual block's
//! residuals and analytic Jacobian blocks on request. Parameter blocks can be held constant, have
//! individual components fixed, or be marked for elimination by the Schur complement: calibration
//! eliminates the per-view poses and keeps the camera intrinsics in the reduced system; bundle
//! adjustment would eliminate the points.
//!
//! [`Solver`] prepares everything once (storage for the block normal equations, chunking for
//! parallel evaluation, the symbolic factorization) and then iterates without allocating. The
//! Jacobian is never stored as a whole: each residual block's Jacobian is multiplied into the
//! normal equations as soon as it is evaluated. Termination is data ([`Termination`]), and the
//! [`SolverReport`] records every step attempt. [`Solver::covariance`] gives the covariance of
//! the solution.
//!
//! The block layout, damping policies and termination rules are described in
//! `docs/lm-solver.md`.
//!
//! # Example: fitting `y = a exp(b t)`
//!
//! ```
//! use lm_solver::{CostFunction, EvaluationError, JacobianBlocks, ProblemBuilder, ResidualBlockId,
//!                 Solver, SolverOptions};
//!
//! struct ExpFit { t: Vec<f64>, y: Vec<f64> }
//!
//! impl CostFunction for ExpFit {
//!     fn evaluate(&self, block: ResidualBlockId, params: &[&[f64]], residuals: &mut [f64],
//!                 jacobians: Option<&mut JacobianBlocks<'_>>) -> Result<(), EvaluationError> {
//!         let (a, b) = (params[0][0], params[0][1]);
//!         let (t, y) = (self.t[block.0], self.y[block.0]);
//!         let e = (b * t).exp();
//!         residuals[0] = a * e - y;
//!         if let Some(j) = jacobians {
//!             if let Some(jac) = j.block_mut(0) {
//!                 jac[0] = e;         // d r / d a
//!                 jac[1] = a * t * e; // d r / d b
//!             }
//!         }
//!         Ok(())
//!     }
//! }
//!
//! let t: Vec<f64> = (0..20).map(|i| i as f64 * 0.1).collect();
//! let y: Vec<f64> = t.iter().map(|t| 2.0 * (-1.5 * t).exp()).collect();
//! let mut builder = ProblemBuilder::new();
//! let ab = builder.add_parameter_block(2);
//! for _ in 0..t.len() {
//!     builder.add_residual_block(1, &[ab]);
//! }
//! let mut solver = Solver::new(builder.build().unwrap(), SolverOptions::default()).unwrap();
//! let mut x = vec![1.0, 0.0];
//! let report = solver.solve(&ExpFit { t, y }, &mut x).unwrap();
//! assert!(report.termination.is_converged());
//! assert!((x[0] - 2.0).abs() < 1e-8 && (x[1] + 1.5).abs() < 1e-8);
//! ```
#![deny(missing_docs)]

pub mod cost;
pub mod covariance;
pub mod gram;
mod kernels;
pub mod levenberg_marquardt;
pub mod linear_solver;
pub mod loss;
pub mod manifold;
mod normal_equations;
pub mod numdiff;
pub mod problem;
pub mod report;
pub mod rng;
mod schur;
mod sparse;
#[cfg(any(test, feature = "test-problems"))]
pub mod test_problems;

pub use cost::{CostFunction, EvaluationError, GramBlocks, JacobianBlocks};
pub use covariance::{Covariance, CovarianceError, RANK_TOLERANCE};
pub use levenberg_marquardt::{
    DampingPolicy, Observer, ObserverAction, Solver, SolverError, SolverOptions,
};
pub use linear_solver::LinearSolverKind;
pub use loss::{CustomLoss, Loss};
pub use manifold::Manifold;
/// The linear-algebra crate of the public API (block values, covariance matrices).
pub use nalgebra;
pub use problem::{
    MAX_BLOCKS_PER_RESIDUAL, ParameterBlockId, Problem, ProblemBuilder, ProblemError,
    ResidualBlockId,
};
pub use report::{IterationRecord, SolverReport, Termination};
pub use rng::Rng;
