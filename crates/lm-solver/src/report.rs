//! What a solve did: termination reason, per-iteration records and totals.

use crate::linear_solver::LinearSolverKind;
use std::time::Duration;

/// Why the Levenberg-Marquardt iteration stopped.
#[derive(Debug, Clone, PartialEq)]
pub enum Termination {
    /// Converged: the largest gradient entry fell below `gradient_tolerance`.
    GradientTolerance,
    /// Converged: an accepted step changed the cost by less than `function_tolerance` times the
    /// cost.
    FunctionTolerance,
    /// Converged: the step was shorter than `parameter_tolerance * (|x| + parameter_tolerance)`.
    ParameterTolerance,
    /// Stopped: `max_iterations` step attempts were made.
    MaxIterations,
    /// Stopped: the damping grew beyond its maximum without finding a step that lowers the cost.
    /// The parameters are the best found; usually they are at a minimum that rounding prevents
    /// from being refined further.
    DampingExhausted,
    /// Stopped: the cost or gradient at the current point became non-finite.
    NumericalFailure(String),
}

impl Termination {
    /// True for the three convergence criteria.
    pub fn is_converged(&self) -> bool {
        matches!(
            self,
            Termination::GradientTolerance
                | Termination::FunctionTolerance
                | Termination::ParameterTolerance
        )
    }
}

impl std::fmt::Display for Termination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Termination::GradientTolerance => write!(f, "converged (gradient tolerance)"),
            Termination::FunctionTolerance => write!(f, "converged (function tolerance)"),
            Termination::ParameterTolerance => write!(f, "converged (parameter tolerance)"),
            Termination::MaxIterations => write!(f, "stopped (maximum iterations)"),
            Termination::DampingExhausted => write!(f, "stopped (damping exhausted)"),
            Termination::NumericalFailure(why) => write!(f, "stopped (numerical failure: {why})"),
        }
    }
}

/// One step attempt of the Levenberg-Marquardt loop.
#[derive(Debug, Clone, PartialEq)]
pub struct IterationRecord {
    /// Attempt number, starting at 1.
    pub iteration: usize,
    /// Cost after this attempt (the new cost if accepted, the unchanged cost otherwise).
    pub cost: f64,
    /// Cost at the trial point (infinite if it could not be evaluated or the solve failed).
    pub trial_cost: f64,
    /// Maximum absolute gradient entry at the point the step was computed from.
    pub gradient_max_norm: f64,
    /// Euclidean norm of the step (0 if the linear solve failed).
    pub step_norm: f64,
    /// Actual over predicted cost reduction (NaN if not computed).
    pub gain_ratio: f64,
    /// Damping parameter used for this step.
    pub lambda: f64,
    /// Whether the step was accepted.
    pub accepted: bool,
    /// Whether the linear solve succeeded.
    pub solve_succeeded: bool,
    /// Time spent evaluating residuals and Jacobians for this attempt.
    pub evaluate_time: Duration,
    /// Time spent in the linear solver for this attempt.
    pub solve_time: Duration,
}

/// Summary of a solve.
#[derive(Debug, Clone, PartialEq)]
pub struct SolverReport {
    /// Why the iteration stopped.
    pub termination: Termination,
    /// Cost `0.5 * sum rho(|r_b|^2)` at the initial parameters.
    pub initial_cost: f64,
    /// Cost at the returned parameters.
    pub final_cost: f64,
    /// Every step attempt, in order.
    pub iterations: Vec<IterationRecord>,
    /// Number of accepted steps.
    pub accepted_steps: usize,
    /// Evaluations of residuals only (trial points).
    pub residual_evaluations: usize,
    /// Evaluations of residuals and Jacobians (linearizations).
    pub jacobian_evaluations: usize,
    /// Linear solves attempted.
    pub linear_solves: usize,
    /// The linear solver used.
    pub linear_solver: LinearSolverKind,
    /// Number of scalar residuals.
    pub num_residuals: usize,
    /// Number of free parameters.
    pub num_free_parameters: usize,
    /// Total time spent evaluating.
    pub evaluate_time: Duration,
    /// Total time spent in linear solves.
    pub solve_time: Duration,
    /// Wall time of the whole solve.
    pub total_time: Duration,
}
