//! What a solve did: termination reason, per-iteration records and totals.

use crate::linear_solver::LinearSolverKind;
use std::time::Duration;

/// Why the Levenberg-Marquardt iteration stopped.
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq)]
pub enum Termination {
    /// Converged: the largest gradient entry fell below `gradient_tolerance`.
    GradientTolerance,
    /// Converged: an accepted step changed the cost by less than `function_tolerance` times the
    /// cost (or, with `SolverOptions::stagnation_window`, the last accepted steps together by
    /// less than `stagnation_tolerance`).
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
    /// Stopped: the observer asked to stop (see `Solver::solve_with_observer`).
    StoppedByObserver,
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

    /// A stable machine-readable code: `gradient_tolerance`, `function_tolerance`,
    /// `parameter_tolerance`, `max_iterations`, `damping_exhausted`, `numerical_failure`,
    /// `stopped_by_observer`.
    pub fn code(&self) -> &'static str {
        match self {
            Termination::GradientTolerance => "gradient_tolerance",
            Termination::FunctionTolerance => "function_tolerance",
            Termination::ParameterTolerance => "parameter_tolerance",
            Termination::MaxIterations => "max_iterations",
            Termination::DampingExhausted => "damping_exhausted",
            Termination::NumericalFailure(_) => "numerical_failure",
            Termination::StoppedByObserver => "stopped_by_observer",
        }
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
            Termination::StoppedByObserver => write!(f, "stopped (by the observer)"),
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

impl SolverReport {
    /// The report of a solve that was run again (`retry`, from the same start or not) after
    /// this one: the retry's termination and final cost, this solve's initial cost, and both
    /// solves' step attempts (renumbered to follow this one's), evaluations, solves and times.
    pub fn followed_by(self, mut retry: SolverReport) -> SolverReport {
        let mut iterations = self.iterations;
        let offset = iterations.len();
        for record in &mut retry.iterations {
            record.iteration += offset;
        }
        iterations.append(&mut retry.iterations);
        SolverReport {
            iterations,
            initial_cost: self.initial_cost,
            accepted_steps: self.accepted_steps + retry.accepted_steps,
            residual_evaluations: self.residual_evaluations + retry.residual_evaluations,
            jacobian_evaluations: self.jacobian_evaluations + retry.jacobian_evaluations,
            linear_solves: self.linear_solves + retry.linear_solves,
            evaluate_time: self.evaluate_time + retry.evaluate_time,
            solve_time: self.solve_time + retry.solve_time,
            total_time: self.total_time + retry.total_time,
            ..retry
        }
    }
}

/// JSON form of the report (with the `serde` feature): the keys of `docs/formats.md`
/// (`termination`, `converged`, `iterations`, ..., `per_iteration`), times in seconds.
#[cfg(feature = "serde")]
mod serde_impl {
    use super::*;
    use serde::{Deserialize, Serialize};

    #[derive(Serialize, Deserialize)]
    struct RecordJson {
        cost: f64,
        trial_cost: Option<f64>,
        gradient_max_norm: f64,
        step_norm: f64,
        gain_ratio: Option<f64>,
        lambda: f64,
        accepted: bool,
        #[serde(default = "yes")]
        solve_succeeded: bool,
        #[serde(default)]
        evaluate_seconds: f64,
        #[serde(default)]
        solve_seconds: f64,
    }

    fn yes() -> bool {
        true
    }

    #[derive(Serialize, Deserialize)]
    struct ReportJson {
        termination: String,
        termination_code: String,
        #[serde(default)]
        termination_detail: Option<String>,
        converged: bool,
        iterations: usize,
        accepted_steps: usize,
        initial_cost: f64,
        final_cost: f64,
        residual_evaluations: usize,
        jacobian_evaluations: usize,
        #[serde(default)]
        linear_solves: usize,
        linear_solver: String,
        #[serde(default)]
        num_residuals: usize,
        #[serde(default)]
        num_free_parameters: usize,
        evaluate_seconds: f64,
        solve_seconds: f64,
        total_seconds: f64,
        per_iteration: Vec<RecordJson>,
    }

    fn finite(v: f64) -> Option<f64> {
        v.is_finite().then_some(v)
    }

    impl Serialize for SolverReport {
        fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
            ReportJson {
                termination: self.termination.to_string(),
                termination_code: self.termination.code().to_string(),
                termination_detail: match &self.termination {
                    Termination::NumericalFailure(why) => Some(why.clone()),
                    _ => None,
                },
                converged: self.termination.is_converged(),
                iterations: self.iterations.len(),
                accepted_steps: self.accepted_steps,
                initial_cost: self.initial_cost,
                final_cost: self.final_cost,
                residual_evaluations: self.residual_evaluations,
                jacobian_evaluations: self.jacobian_evaluations,
                linear_solves: self.linear_solves,
                linear_solver: format!("{:?}", self.linear_solver),
                num_residuals: self.num_residuals,
                num_free_parameters: self.num_free_parameters,
                evaluate_seconds: self.evaluate_time.as_secs_f64(),
                solve_seconds: self.solve_time.as_secs_f64(),
                total_seconds: self.total_time.as_secs_f64(),
                per_iteration: self
                    .iterations
                    .iter()
                    .map(|r| RecordJson {
                        cost: r.cost,
                        trial_cost: finite(r.trial_cost),
                        gradient_max_norm: r.gradient_max_norm,
                        step_norm: r.step_norm,
                        gain_ratio: finite(r.gain_ratio),
                        lambda: r.lambda,
                        accepted: r.accepted,
                        solve_succeeded: r.solve_succeeded,
                        evaluate_seconds: r.evaluate_time.as_secs_f64(),
                        solve_seconds: r.solve_time.as_secs_f64(),
                    })
                    .collect(),
            }
            .serialize(serializer)
        }
    }

    fn seconds(s: f64) -> Duration {
        Duration::try_from_secs_f64(s.max(0.0)).unwrap_or_default()
    }

    impl<'de> Deserialize<'de> for SolverReport {
        fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
            let j = ReportJson::deserialize(deserializer)?;
            let termination = match j.termination_code.as_str() {
                "gradient_tolerance" => Termination::GradientTolerance,
                "function_tolerance" => Termination::FunctionTolerance,
                "parameter_tolerance" => Termination::ParameterTolerance,
                "max_iterations" => Termination::MaxIterations,
                "damping_exhausted" => Termination::DampingExhausted,
                "numerical_failure" => {
                    Termination::NumericalFailure(j.termination_detail.unwrap_or_default())
                }
                "stopped_by_observer" => Termination::StoppedByObserver,
                other => {
                    return Err(serde::de::Error::custom(format!(
                        "unknown termination code '{other}'"
                    )));
                }
            };
            let linear_solver = match j.linear_solver.as_str() {
                "DenseSchur" => LinearSolverKind::DenseSchur,
                "SparseSchur" => LinearSolverKind::SparseSchur,
                "SparseCholesky" => LinearSolverKind::SparseCholesky,
                "DenseReference" => LinearSolverKind::DenseReference,
                _ => LinearSolverKind::Auto,
            };
            Ok(SolverReport {
                termination,
                initial_cost: j.initial_cost,
                final_cost: j.final_cost,
                iterations: j
                    .per_iteration
                    .into_iter()
                    .enumerate()
                    .map(|(i, r)| IterationRecord {
                        iteration: i + 1,
                        cost: r.cost,
                        trial_cost: r.trial_cost.unwrap_or(f64::INFINITY),
                        gradient_max_norm: r.gradient_max_norm,
                        step_norm: r.step_norm,
                        gain_ratio: r.gain_ratio.unwrap_or(f64::NAN),
                        lambda: r.lambda,
                        accepted: r.accepted,
                        solve_succeeded: r.solve_succeeded,
                        evaluate_time: seconds(r.evaluate_seconds),
                        solve_time: seconds(r.solve_seconds),
                    })
                    .collect(),
                accepted_steps: j.accepted_steps,
                residual_evaluations: j.residual_evaluations,
                jacobian_evaluations: j.jacobian_evaluations,
                linear_solves: j.linear_solves,
                linear_solver,
                num_residuals: j.num_residuals,
                num_free_parameters: j.num_free_parameters,
                evaluate_time: seconds(j.evaluate_seconds),
                solve_time: seconds(j.solve_seconds),
                total_time: seconds(j.total_seconds),
            })
        }
    }
}

#[cfg(all(test, feature = "serde"))]
mod tests {
    use super::*;

    #[test]
    fn report_round_trips_through_json() {
        let report = SolverReport {
            termination: Termination::NumericalFailure("bad".into()),
            initial_cost: 2.0,
            final_cost: 1.0,
            iterations: vec![IterationRecord {
                iteration: 1,
                cost: 1.0,
                trial_cost: f64::INFINITY,
                gradient_max_norm: 0.5,
                step_norm: 0.1,
                gain_ratio: f64::NAN,
                lambda: 0.01,
                accepted: false,
                solve_succeeded: true,
                evaluate_time: Duration::from_millis(3),
                solve_time: Duration::from_millis(1),
            }],
            accepted_steps: 0,
            residual_evaluations: 0,
            jacobian_evaluations: 2,
            linear_solves: 1,
            linear_solver: LinearSolverKind::DenseSchur,
            num_residuals: 10,
            num_free_parameters: 3,
            evaluate_time: Duration::from_millis(3),
            solve_time: Duration::from_millis(1),
            total_time: Duration::from_millis(5),
        };
        let json = serde_json::to_value(&report).unwrap();
        assert_eq!(json["termination_code"], "numerical_failure");
        assert_eq!(json["iterations"], 1);
        assert!(json["per_iteration"][0]["trial_cost"].is_null());
        let back: SolverReport = serde_json::from_value(json).unwrap();
        assert_eq!(back.termination, report.termination);
        assert_eq!(back.iterations.len(), 1);
        assert!(back.iterations[0].gain_ratio.is_nan());
        assert_eq!(back.total_time, report.total_time);
    }
}

#[cfg(test)]
mod followed_by_tests {
    use super::*;

    fn report(attempts: usize, cost: (f64, f64), termination: Termination) -> SolverReport {
        let record = |i| IterationRecord {
            iteration: i + 1,
            cost: cost.0,
            trial_cost: cost.1,
            gradient_max_norm: 1.0,
            step_norm: 0.1,
            gain_ratio: 0.5,
            lambda: 0.01,
            accepted: true,
            solve_succeeded: true,
            evaluate_time: Duration::from_millis(1),
            solve_time: Duration::from_millis(1),
        };
        SolverReport {
            termination,
            initial_cost: cost.0,
            final_cost: cost.1,
            iterations: (0..attempts).map(record).collect(),
            accepted_steps: attempts,
            residual_evaluations: 1,
            jacobian_evaluations: attempts + 1,
            linear_solves: attempts,
            linear_solver: LinearSolverKind::DenseSchur,
            num_residuals: 10,
            num_free_parameters: 3,
            evaluate_time: Duration::from_millis(attempts as u64),
            solve_time: Duration::from_millis(attempts as u64),
            total_time: Duration::from_millis(3 * attempts as u64),
        }
    }

    #[test]
    fn a_retry_report_counts_both_solves() {
        let first = report(3, (9.0, 5.0), Termination::ParameterTolerance);
        let retry = report(2, (9.0, 4.0), Termination::FunctionTolerance);
        let both = first.followed_by(retry);
        assert_eq!(both.termination, Termination::FunctionTolerance);
        assert_eq!((both.initial_cost, both.final_cost), (9.0, 4.0));
        let numbers: Vec<usize> = both.iterations.iter().map(|r| r.iteration).collect();
        assert_eq!(numbers, [1, 2, 3, 4, 5]);
        assert_eq!(both.accepted_steps, 5);
        assert_eq!(both.residual_evaluations, 2);
        assert_eq!(both.jacobian_evaluations, 7);
        assert_eq!(both.linear_solves, 5);
        assert_eq!(both.evaluate_time, Duration::from_millis(5));
        assert_eq!(both.total_time, Duration::from_millis(15));
    }
}
