//! The Levenberg-Marquardt loop.
//!
//! Each iteration solves `(J^T J + lambda D) step = -J^T r` for the step, evaluates the cost at
//! `x + step`, and accepts or rejects the step. A rejected step is retried with more damping from
//! the same linearization (the Jacobian is not re-evaluated). See `docs/lm-solver.md` for the
//! damping policies and the termination rules.

use crate::cost::CostFunction;
use crate::linear_solver::{LinearSolver, LinearSolverKind};
use crate::normal_equations::{EvaluationFailure, NormalEquations};
use crate::problem::Problem;
use crate::report::{IterationRecord, SolverReport, Termination};
use std::time::{Duration, Instant};

/// How the damping `lambda` and the damping matrix `D` evolve.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DampingPolicy {
    /// The calibration text's policy: `D = I` (additive `lambda I`), `lambda` starts at `initial`
    /// (0.01 in the text), is divided by `factor` (10) after a step that lowers the cost, and is
    /// multiplied by `factor` after one that does not, the step being recomputed from the same
    /// linearization.
    Additive {
        /// Initial `lambda`.
        initial: f64,
        /// Multiplicative update factor.
        factor: f64,
    },
    /// Marquardt scaling with Nielsen's update, as in Ceres' Levenberg-Marquardt: `D` is the
    /// diagonal of `J^T J` clamped to `[min_diagonal, max_diagonal]`; a step is accepted when the
    /// gain ratio (actual over predicted reduction) exceeds `min_gain_ratio`; then
    /// `lambda *= max(1/3, 1 - (2 rho - 1)^3)`, otherwise `lambda *= nu` and `nu` doubles (`nu`
    /// resets to 2 on acceptance).
    Marquardt {
        /// Initial `lambda` (Ceres' default trust-region radius 1e4 corresponds to 1e-4).
        initial: f64,
        /// Lower clamp of the diagonal scaling.
        min_diagonal: f64,
        /// Upper clamp of the diagonal scaling.
        max_diagonal: f64,
        /// Minimum gain ratio for accepting a step.
        min_gain_ratio: f64,
    },
    /// The additive policy for the first `switch_after` step attempts, then, if the solve has not
    /// converged, [`DampingPolicy::marquardt`] from where it is. Easy problems finish in the
    /// additive policy's fewer steps; problems whose parameters differ wildly in scale or whose
    /// minimum lies in a long flat valley (a focal length that weakly tilted boards hardly
    /// determine) get the scale-invariant Marquardt steps, which cross such valleys in tens of
    /// steps instead of hundreds (`docs/benchmarks-solver.md`).
    Hybrid {
        /// Initial `lambda` of the additive phase.
        initial: f64,
        /// Update factor of the additive phase.
        factor: f64,
        /// Step attempts before switching to the Marquardt policy.
        switch_after: usize,
        /// Marquardt's initial `lambda` at the switch.
        marquardt_initial: f64,
    },
}

impl DampingPolicy {
    /// The calibration text's additive policy with its constants (`lambda0 = 0.01`, factor 10).
    pub const fn additive() -> Self {
        DampingPolicy::Additive {
            initial: 0.01,
            factor: 10.0,
        }
    }

    /// The additive policy (the text's constants) for 20 step attempts, then Marquardt's (from
    /// Ceres' initial `lambda`, 1e-4).
    pub const fn hybrid() -> Self {
        DampingPolicy::Hybrid {
            initial: 0.01,
            factor: 10.0,
            switch_after: 20,
            marquardt_initial: 1e-4,
        }
    }

    /// The hybrid policy for a *warm* start, one that already minimizes a nested simpler
    /// problem (a rational lens model started from the `brown-conrady5` minimum): 12 additive
    /// attempts, then Marquardt's from `lambda = 1e-8`. From such a start the additive phase
    /// alternates accepted and rejected steps along the new parameters' flat valley, and
    /// Marquardt's damping, which falls by at most 3x per accepted step, spends about 8 steps
    /// coming down from 1e-4 to the Gauss-Newton regime that valley needs. Measured on rational
    /// models: 30 to 40% fewer iterations to the same minimum (`docs/benchmarks-models.md`).
    pub const fn hybrid_warm() -> Self {
        DampingPolicy::Hybrid {
            initial: 0.01,
            factor: 10.0,
            switch_after: 12,
            marquardt_initial: 1e-8,
        }
    }

    /// Marquardt's policy from `lambda = 1e-8` (Gauss-Newton-like steps at once), for a warm
    /// start whose new parameters the nested minimum leaves in a smooth valley: calibration uses
    /// it for a rational8 lens model started from the `brown-conrady5` minimum, where it takes
    /// 14 to 32 iterations instead of [`DampingPolicy::hybrid_warm`]'s 22 to 37 on the bundled
    /// cameras, to the same minima (`docs/benchmarks-models.md`). Its pole retry is the hybrid
    /// policy, a path of another kind.
    pub const fn marquardt_warm() -> Self {
        DampingPolicy::Marquardt {
            initial: 1e-8,
            min_diagonal: 1e-6,
            max_diagonal: 1e32,
            min_gain_ratio: 1e-3,
        }
    }

    /// The Ceres-style policy with Ceres' default constants.
    pub const fn marquardt() -> Self {
        DampingPolicy::Marquardt {
            initial: 1e-4,
            min_diagonal: 1e-6,
            max_diagonal: 1e32,
            min_gain_ratio: 1e-3,
        }
    }

    fn initial_lambda(&self) -> f64 {
        match *self {
            DampingPolicy::Additive { initial, .. }
            | DampingPolicy::Marquardt { initial, .. }
            | DampingPolicy::Hybrid { initial, .. } => initial,
        }
    }
}

impl Default for DampingPolicy {
    /// The additive policy: on the calibration benchmarks (84 problems, real and synthetic) it
    /// reached the minimum in fewer evaluations than the Marquardt policy on every problem from the
    /// closed-form start (numbers in `docs/benchmarks-solver.md`).
    fn default() -> Self {
        DampingPolicy::additive()
    }
}

/// Settings of a solve.
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq)]
pub struct SolverOptions {
    /// Maximum number of step attempts (accepted or rejected). Default 200.
    pub max_iterations: usize,
    /// Converged when `max |g_i| <= gradient_tolerance` (gradient of the cost `0.5 |r|^2`, in
    /// cost units per parameter unit). Default 1e-10.
    pub gradient_tolerance: f64,
    /// Converged when an accepted step lowers the cost by less than `function_tolerance * cost`,
    /// or when the linear model predicts less than that for a step that was rejected. Default
    /// 1e-12.
    pub function_tolerance: f64,
    /// Converged when `|step| <= parameter_tolerance * (|x| + parameter_tolerance)`. Default 1e-12.
    pub parameter_tolerance: f64,
    /// Damping policy. Default [`DampingPolicy::additive`].
    pub damping: DampingPolicy,
    /// Stop (`DampingExhausted`) when `lambda` exceeds this. Default 1e16.
    pub max_lambda: f64,
    /// Smallest `lambda` used. Default 1e-16.
    pub min_lambda: f64,
    /// Linear solver. Default `Auto`.
    pub linear_solver: LinearSolverKind,
    /// Threads for evaluation and elimination: 1 runs on the calling thread, 0 uses all available
    /// cores, `n` uses `n`. Results are bit-for-bit identical for any value. Default 0.
    pub num_threads: usize,
    /// Target size of one parallel work chunk, in residual rows times Jacobian columns (default
    /// 150 000, about 20 calibration views of 400 points). The chunking depends only on the
    /// problem and this value, never on the thread count, which is what makes results
    /// independent of the number of threads.
    pub chunk_work: usize,
    /// Evaluate each trial point with its Jacobian and normal equations at once (default
    /// `true`), instead of the cost alone followed by a linearization if the step is accepted.
    /// When most steps are accepted (as in calibration) this saves one pass over the residuals per
    /// iteration; each rejected step then wastes a linearization. Uses a second set of
    /// normal-equation buffers. Even when eager, a trial whose rejection is predicted gets the
    /// cost alone: one whose `lambda` is at or below that of the most recent rejected trial
    /// (along a flat valley the damping alternates between an accepted `lambda` and a rejected
    /// smaller one) until such a prediction fails (a trial at or below it is accepted) or the
    /// hybrid policy switches, and under Marquardt's policy every trial right after a rejection
    /// (its `lambda` grows through runs of rejections). Both modes take the same steps, bit for
    /// bit when a fused cost function ([`CostFunction::evaluate_gram`]) sums its cost group by
    /// group in residual order, as the cost-only pass does.
    pub eager_linearization: bool,
    /// Damping search under Marquardt's policy (default 0: off): after a step accepted with a
    /// gain ratio within 0.1 of one, when the previous accepted step's was too, up to this many
    /// steps with `lambda / 8`, `lambda / 64`, ... from the same linearization, each evaluated
    /// for its cost alone; the point with the lowest cost (gain ratio at least 0.5) is taken and
    /// the damping continues from its `lambda`. Nielsen's rule lowers `lambda` by at most 3x per
    /// step, so a long run of well-predicted steps in a valley that the damping still holds
    /// back costs one linearization per 3x; a cost-only trial is about a tenth of one. Each
    /// trial counts as a step attempt (recorded after the one it extends).
    pub damping_search: usize,
    /// Stagnation rule (default 0: off): converged (`FunctionTolerance`) when the last
    /// `stagnation_window` accepted steps together lowered the cost by at most
    /// `stagnation_tolerance` times the cost before them. Ends the runaways of a model whose
    /// cost keeps falling along a direction the data does not determine (a rational lens model's
    /// coefficients growing without bound, each step lowering the cost by 1e-8 relative for
    /// hundreds of steps), where `function_tolerance`, judged step by step, never triggers.
    pub stagnation_window: usize,
    /// See `stagnation_window` (relative; default 1e-5).
    pub stagnation_tolerance: f64,
}

/// The solver's buffers a damping search works on.
struct SearchParts<'a> {
    problem: &'a Problem,
    options: &'a SolverOptions,
    linear: &'a mut LinearSolver,
    ne: &'a mut NormalEquations,
    pool: Option<&'a rayon::ThreadPool>,
    step: &'a mut [f64],
    trial: &'a mut [f64],
    best: &'a mut [f64],
    damping: &'a mut [f64],
    diagonal: &'a [f64],
}

/// The damping search after an accepted trial at `lambda` (`SolverOptions::damping_search`):
/// from the same linearization, steps with `lambda / 8`, `lambda / 64`, ... (at most `room`
/// of them), each evaluated for its cost alone, while each lowers the cost below the best
/// so far with a gain ratio of at least 0.5, and stops after one whose gain ratio is not
/// within 0.1 of one. Leaves the best point in `trial` and returns its `lambda` and
/// gain ratio; pushes one record per trial (accepted = it became the best).
fn search_damping<C: CostFunction>(
    parts: SearchParts<'_>,
    cost_fn: &C,
    x: &[f64],
    (cost, trial_cost, gain, lambda): (f64, f64, f64, f64),
    gradient_max_norm: f64,
    room: usize,
    records: &mut Vec<IterationRecord>,
) -> (f64, f64) {
    let SearchParts {
        problem,
        options,
        linear,
        ne,
        pool,
        step,
        trial,
        best,
        damping,
        diagonal,
    } = parts;
    best.copy_from_slice(trial);
    let (mut best_cost, mut best_lambda, mut best_gain) = (trial_cost, lambda, gain);
    let mut trial_lambda = lambda;
    for _ in 0..room {
        trial_lambda = (trial_lambda / DAMPING_SEARCH_FACTOR).max(options.min_lambda);
        for (i, d) in damping.iter_mut().enumerate() {
            if !problem.fixed_mask[i] {
                *d = trial_lambda * diagonal[i];
            }
        }
        let ts = Instant::now();
        let solved = linear.solve(problem, ne, damping, step, pool);
        let mut record = IterationRecord {
            iteration: 0,
            cost: best_cost,
            trial_cost: f64::INFINITY,
            gradient_max_norm,
            step_norm: 0.0,
            gain_ratio: f64::NAN,
            lambda: trial_lambda,
            accepted: false,
            solve_succeeded: solved.is_ok(),
            evaluate_time: Duration::ZERO,
            solve_time: ts.elapsed(),
        };
        if solved.is_err() {
            records.push(record);
            break;
        }
        record.step_norm = step.iter().map(|v| v * v).sum::<f64>().sqrt();
        let predicted = 0.5
            * step
                .iter()
                .zip(&ne.g)
                .zip(damping.iter())
                .map(|((s, g), d)| -g * s + d * s * s)
                .sum::<f64>();
        problem.plus(x, step, trial);
        let te = Instant::now();
        let trial_cost = ne
            .evaluate(problem, cost_fn, trial, false, pool)
            .unwrap_or(f64::INFINITY);
        record.evaluate_time = te.elapsed();
        record.trial_cost = trial_cost;
        let gain = (cost - trial_cost) / predicted;
        record.gain_ratio = gain;
        let better = trial_cost.is_finite() && trial_cost < best_cost && gain >= 0.5;
        record.accepted = better;
        if better {
            (best_cost, best_lambda, best_gain) = (trial_cost, trial_lambda, gain);
            record.cost = best_cost;
            best.copy_from_slice(trial);
        }
        records.push(record);
        if !better || !model_reliable(gain) {
            break;
        }
    }
    trial.copy_from_slice(best);
    (best_lambda, best_gain)
}

/// Each trial of the damping search divides `lambda` by this.
const DAMPING_SEARCH_FACTOR: f64 = 8.0;

/// A gain ratio within 0.1 of one: the linear model predicted the step's decrease well.
fn model_reliable(gain: f64) -> bool {
    (0.9..=1.1).contains(&gain)
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            gradient_tolerance: 1e-10,
            function_tolerance: 1e-12,
            parameter_tolerance: 1e-12,
            damping: DampingPolicy::default(),
            max_lambda: 1e16,
            min_lambda: 1e-16,
            linear_solver: LinearSolverKind::Auto,
            num_threads: 0,
            chunk_work: 150_000,
            eager_linearization: true,
            damping_search: 0,
            stagnation_window: 0,
            stagnation_tolerance: 1e-5,
        }
    }
}

/// Errors of a solve: problems with the inputs or the setup, never with convergence (that is
/// reported in [`SolverReport::termination`]).
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SolverError {
    /// The parameter vector has the wrong length.
    #[error("parameter vector has {found} entries, the problem has {expected}")]
    ParameterLength {
        /// Expected length.
        expected: usize,
        /// Given length.
        found: usize,
    },
    /// An initial parameter is NaN or infinite.
    #[error("initial parameter {index} is not finite")]
    NonFiniteParameter {
        /// Index in the flat parameter vector.
        index: usize,
    },
    /// The cost function failed at the initial parameters.
    #[error("residual block {residual} cannot be evaluated at the initial parameters: {message}")]
    InitialEvaluation {
        /// The failing residual block.
        residual: usize,
        /// What went wrong.
        message: String,
    },
    /// The linear solver could not be prepared (index overflow or out of memory in the symbolic
    /// analysis).
    #[error("linear solver setup failed: {0}")]
    LinearSolverSetup(String),
    /// The thread pool could not be created.
    #[error("thread pool setup failed: {0}")]
    ThreadPool(String),
    /// A solver option is out of its range (a NaN or negative tolerance, `min_lambda` above
    /// `max_lambda`, ...).
    #[error("invalid solver option: {0}")]
    InvalidOption(String),
}

impl SolverOptions {
    /// Errors unless the tolerances are finite and not negative and
    /// `0 < min_lambda <= max_lambda` (both finite).
    pub fn check(&self) -> Result<(), SolverError> {
        for (name, value) in [
            ("gradient_tolerance", self.gradient_tolerance),
            ("function_tolerance", self.function_tolerance),
            ("parameter_tolerance", self.parameter_tolerance),
            ("stagnation_tolerance", self.stagnation_tolerance),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(SolverError::InvalidOption(format!(
                    "{name} = {value}: expected a finite number, 0 or more"
                )));
            }
        }
        let (low, high) = (self.min_lambda, self.max_lambda);
        if !(low.is_finite() && high.is_finite() && low > 0.0 && low <= high) {
            return Err(SolverError::InvalidOption(format!(
                "min_lambda = {low}, max_lambda = {high}: expected 0 < min_lambda <= max_lambda, both finite"
            )));
        }
        Ok(())
    }
}

pub(crate) fn describe(failure: &EvaluationFailure) -> (usize, String) {
    match failure {
        EvaluationFailure::Error { residual, error } => (*residual, error.message.clone()),
        EvaluationFailure::NonFinite { residual } => (
            *residual,
            "non-finite residual or Jacobian entry".to_string(),
        ),
    }
}

/// What an [`Observer`] asks of the solve after a step attempt.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ObserverAction {
    /// Go on.
    #[default]
    Continue,
    /// Stop now ([`Termination::StoppedByObserver`]); `x` keeps the best parameters so far.
    Stop,
}

/// Watches a solve: called after every step attempt with its record (see
/// [`Solver::solve_with_observer`]). Implemented for closures `FnMut(&IterationRecord) ->
/// ObserverAction`.
pub trait Observer {
    /// Called after each step attempt; the return value can stop the solve.
    fn observe(&mut self, record: &IterationRecord) -> ObserverAction;
}

impl<F: FnMut(&IterationRecord) -> ObserverAction> Observer for F {
    fn observe(&mut self, record: &IterationRecord) -> ObserverAction {
        self(record)
    }
}

/// A Levenberg-Marquardt solver prepared for one problem structure.
///
/// Construction does all the structural work once (chunking, storage for the normal equations,
/// symbolic factorization, thread pool); [`Solver::solve`] then runs without allocating per
/// iteration (apart from appending the iteration records).
pub struct Solver {
    pub(crate) problem: Problem,
    options: SolverOptions,
    pub(crate) ne: NormalEquations,
    /// Second buffers for eager linearization of trial points.
    trial_ne: Option<NormalEquations>,
    /// The parameters `ne` was last linearized at (so a covariance at the solution can reuse it).
    pub(crate) linearized_at: Option<Vec<f64>>,
    linear: LinearSolver,
    pub(crate) pool: Option<rayon::ThreadPool>,
    step: Vec<f64>,
    trial: Vec<f64>,
    best: Vec<f64>,
    damping: Vec<f64>,
    diagonal: Vec<f64>,
}

impl std::fmt::Debug for Solver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Solver")
            .field("problem", &self.problem)
            .field("options", &self.options)
            .field("linear_solver", &self.linear.kind())
            .field("chunks", &self.ne.chunks.len())
            .finish()
    }
}

impl Solver {
    /// Prepares a solver for `problem`.
    pub fn new(problem: Problem, options: SolverOptions) -> Result<Self, SolverError> {
        options.check()?;
        let dense = options.linear_solver.resolve(&problem) == LinearSolverKind::DenseSchur;
        let mut ne = NormalEquations::new(&problem, options.chunk_work, dense);
        let linear = LinearSolver::new(options.linear_solver, &problem, &mut ne)
            .map_err(|e| SolverError::LinearSolverSetup(e.0))?;
        let trial_ne = options.eager_linearization.then(|| {
            let mut trial = NormalEquations::new(&problem, options.chunk_work, dense);
            linear.prepare(&problem, &mut trial);
            trial
        });
        let threads = match options.num_threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n,
        };
        let pool = if threads > 1 && ne.chunks.len() > 1 {
            Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .map_err(|e| SolverError::ThreadPool(e.to_string()))?,
            )
        } else {
            None
        };
        let (n, n_ambient) = (problem.num_tangent, problem.num_parameters);
        Ok(Self {
            problem,
            options,
            ne,
            trial_ne,
            linearized_at: None,
            linear,
            pool,
            step: vec![0.0; n],
            trial: vec![0.0; n_ambient],
            best: vec![0.0; n_ambient],
            damping: vec![0.0; n],
            diagonal: vec![0.0; n],
        })
    }

    /// The problem structure.
    pub fn problem(&self) -> &Problem {
        &self.problem
    }

    /// The options.
    pub fn options(&self) -> &SolverOptions {
        &self.options
    }

    /// The linear solver in use (`Auto` resolved).
    pub fn linear_solver(&self) -> LinearSolverKind {
        self.linear.kind()
    }

    /// Number of evaluation chunks (the unit of parallel work).
    pub fn num_chunks(&self) -> usize {
        self.ne.chunks.len()
    }

    /// Minimizes the cost starting from `x`, which receives the solution.
    pub fn solve<C: CostFunction>(
        &mut self,
        cost_fn: &C,
        x: &mut [f64],
    ) -> Result<SolverReport, SolverError> {
        self.solve_with_observer(cost_fn, x, |_: &IterationRecord| ObserverAction::Continue)
    }

    /// Like [`Solver::solve`], calling `observer` after every step attempt (for logging, progress
    /// or a time budget). When the observer returns [`ObserverAction::Stop`] the solve ends with
    /// [`Termination::StoppedByObserver`] and `x` holds the best parameters so far.
    pub fn solve_with_observer<C: CostFunction, O: Observer>(
        &mut self,
        cost_fn: &C,
        x: &mut [f64],
        mut observer: O,
    ) -> Result<SolverReport, SolverError> {
        let start = Instant::now();
        let problem = &self.problem;
        let options = &self.options;
        if x.len() != problem.num_parameters {
            return Err(SolverError::ParameterLength {
                expected: problem.num_parameters,
                found: x.len(),
            });
        }
        if let Some(index) = x.iter().position(|v| !v.is_finite()) {
            return Err(SolverError::NonFiniteParameter { index });
        }
        let pool = self.pool.as_ref();
        let t = Instant::now();
        self.linearized_at = None;
        self.ne
            .evaluate(problem, cost_fn, x, true, pool)
            .map_err(|f| {
                let (residual, message) = describe(&f);
                SolverError::InitialEvaluation { residual, message }
            })?;
        let mut evaluate_time = t.elapsed();
        let mut solve_time = Duration::ZERO;
        let mut cost = self.ne.cost;
        let initial_cost = cost;
        let mut iterations = Vec::with_capacity(options.max_iterations.min(1024));
        let (mut residual_evaluations, mut jacobian_evaluations, mut linear_solves) = (0, 1, 0);
        let mut accepted_steps = 0;
        let mut lambda = options.damping.initial_lambda();
        // The policy in force: the hybrid policy starts additive and may switch.
        let mut policy = match options.damping {
            DampingPolicy::Hybrid {
                initial, factor, ..
            } => DampingPolicy::Additive { initial, factor },
            other => other,
        };
        let mut nu = 2.0;
        let mut diagonal_stale = true;
        let mut last_gain: Option<f64> = None;
        // `lambda` of the most recent rejected trial while it predicts rejections (see
        // `SolverOptions::eager_linearization`).
        let mut rejected_lambda: Option<f64> = None;
        // Trials of the damping search (`SolverOptions::damping_search`), recorded after the
        // step attempt they extend.
        let mut search_records: Vec<IterationRecord> = Vec::new();
        let mut accepted_costs: Vec<f64> = Vec::new();

        let termination = loop {
            let gradient_max_norm = self.ne.gradient_max_norm();
            if !gradient_max_norm.is_finite() {
                break Termination::NumericalFailure("non-finite gradient".into());
            }
            if gradient_max_norm <= options.gradient_tolerance {
                break Termination::GradientTolerance;
            }
            if iterations.len() >= options.max_iterations {
                break Termination::MaxIterations;
            }
            if let DampingPolicy::Hybrid {
                switch_after,
                marquardt_initial,
                ..
            } = options.damping
                && iterations.len() == switch_after
            {
                policy = DampingPolicy::marquardt();
                lambda = marquardt_initial;
                nu = 2.0;
                diagonal_stale = true;
                rejected_lambda = None;
            }
            if let DampingPolicy::Marquardt {
                min_diagonal,
                max_diagonal,
                ..
            } = policy
                && diagonal_stale
            {
                self.ne.hessian_diagonal(problem, &mut self.diagonal);
                for d in &mut self.diagonal {
                    *d = d.clamp(min_diagonal, max_diagonal);
                }
                diagonal_stale = false;
            }
            for (i, d) in self.damping.iter_mut().enumerate() {
                *d = if problem.fixed_mask[i] {
                    1.0
                } else if matches!(policy, DampingPolicy::Additive { .. }) {
                    lambda
                } else {
                    lambda * self.diagonal[i]
                };
            }

            let ts = Instant::now();
            let solved =
                self.linear
                    .solve(problem, &mut self.ne, &self.damping, &mut self.step, pool);
            let this_solve = ts.elapsed();
            solve_time += this_solve;
            linear_solves += 1;
            let mut record = IterationRecord {
                iteration: iterations.len() + 1,
                cost,
                trial_cost: f64::INFINITY,
                gradient_max_norm,
                step_norm: 0.0,
                gain_ratio: f64::NAN,
                lambda,
                accepted: false,
                solve_succeeded: solved.is_ok(),
                evaluate_time: Duration::ZERO,
                solve_time: this_solve,
            };

            let mut accepted = false;
            let mut converged = None;
            if solved.is_ok() {
                let step_norm = self.step.iter().map(|v| v * v).sum::<f64>().sqrt();
                let x_norm = x.iter().map(|v| v * v).sum::<f64>().sqrt();
                record.step_norm = step_norm;
                if step_norm <= options.parameter_tolerance * (x_norm + options.parameter_tolerance)
                {
                    iterations.push(record.clone());
                    observer.observe(&record);
                    break Termination::ParameterTolerance;
                }
                // Model decrease: -g.step - 0.5 step^T H step = 0.5 (-g.step + step^T D step),
                // using (H + D) step = -g.
                let predicted = 0.5
                    * self
                        .step
                        .iter()
                        .zip(&self.ne.g)
                        .zip(&self.damping)
                        .map(|((s, g), d)| -g * s + d * s * s)
                        .sum::<f64>();
                // When the linear model has been reliable (the last accepted step's gain ratio was
                // close to one) and it promises less than the tolerance, the minimum is reached to
                // the tolerance: evaluating the trial point could not change that.
                if last_gain.is_some_and(|g: f64| (0.75..=1.25).contains(&g))
                    && predicted.is_finite()
                    && predicted <= options.function_tolerance * cost
                {
                    record.gain_ratio = f64::NAN;
                    iterations.push(record.clone());
                    observer.observe(&record);
                    break Termination::FunctionTolerance;
                }
                problem.plus(x, &self.step, &mut self.trial);
                let te = Instant::now();
                let rejection_predicted = rejected_lambda.is_some_and(|r| lambda <= r)
                    || (matches!(policy, DampingPolicy::Marquardt { .. })
                        && iterations
                            .last()
                            .is_some_and(|r: &IterationRecord| !r.accepted));
                // A search may follow this trial: then the trial gets its cost alone, and the
                // point finally taken is linearized.
                let search_possible = options.damping_search > 0
                    && matches!(policy, DampingPolicy::Marquardt { .. })
                    && last_gain.is_some_and(model_reliable);
                let eager = self
                    .trial_ne
                    .as_mut()
                    .filter(|_| !rejection_predicted && !search_possible);
                let linearized = eager.is_some();
                let trial_cost = match eager {
                    Some(trial_ne) => {
                        jacobian_evaluations += 1;
                        trial_ne
                            .evaluate(problem, cost_fn, &self.trial, true, pool)
                            .unwrap_or(f64::INFINITY)
                    }
                    None => {
                        residual_evaluations += 1;
                        self.ne
                            .evaluate(problem, cost_fn, &self.trial, false, pool)
                            .unwrap_or(f64::INFINITY)
                    }
                };
                record.trial_cost = trial_cost;
                let actual = cost - trial_cost;
                let gain = actual / predicted;
                record.gain_ratio = gain;
                accepted = trial_cost.is_finite()
                    && match policy {
                        DampingPolicy::Marquardt { min_gain_ratio, .. } => gain > min_gain_ratio,
                        _ => trial_cost < cost,
                    };
                let mut gain = gain;
                if accepted && search_possible && model_reliable(gain) {
                    // At most as many trials as the iteration limit leaves.
                    let room = options
                        .max_iterations
                        .saturating_sub(iterations.len() + 1)
                        .min(options.damping_search);
                    let parts = SearchParts {
                        problem,
                        options,
                        linear: &mut self.linear,
                        ne: &mut self.ne,
                        pool,
                        step: &mut self.step,
                        trial: &mut self.trial,
                        best: &mut self.best,
                        damping: &mut self.damping,
                        diagonal: &self.diagonal,
                    };
                    let (searched_lambda, searched_gain) = search_damping(
                        parts,
                        cost_fn,
                        x,
                        (cost, trial_cost, gain, lambda),
                        gradient_max_norm,
                        room,
                        &mut search_records,
                    );
                    let searched = search_records.iter().filter(|r| r.accepted).count();
                    // A trial whose solve failed was not evaluated.
                    residual_evaluations +=
                        search_records.iter().filter(|r| r.solve_succeeded).count();
                    linear_solves += search_records.len();
                    for r in &search_records {
                        evaluate_time += r.evaluate_time;
                        solve_time += r.solve_time;
                    }
                    if searched > 0 {
                        lambda = searched_lambda;
                        gain = searched_gain;
                    }
                }
                if accepted {
                    x.copy_from_slice(&self.trial);
                    let previous = cost;
                    if rejection_predicted {
                        rejected_lambda = None;
                    }
                    if let Some(trial_ne) = self.trial_ne.as_mut().filter(|_| linearized) {
                        // The trial point is already linearized: make it current.
                        std::mem::swap(&mut self.ne, trial_ne);
                    } else {
                        match self.ne.evaluate(problem, cost_fn, x, true, pool) {
                            Ok(_) => {}
                            Err(f) => {
                                let (residual, message) = describe(&f);
                                record.evaluate_time = te.elapsed();
                                evaluate_time += record.evaluate_time;
                                iterations.push(record.clone());
                                observer.observe(&record);
                                break Termination::NumericalFailure(format!(
                                    "linearization failed at an accepted point (residual block {residual}: {message})"
                                ));
                            }
                        }
                        jacobian_evaluations += 1;
                    }
                    accepted_steps += 1;
                    last_gain = Some(gain);
                    cost = self.ne.cost;
                    diagonal_stale = true;
                    match policy {
                        DampingPolicy::Additive { factor, .. }
                        | DampingPolicy::Hybrid { factor, .. } => lambda /= factor,
                        DampingPolicy::Marquardt { .. } => {
                            lambda *= (1.0 - (2.0 * gain - 1.0).powi(3)).max(1.0 / 3.0);
                            nu = 2.0;
                        }
                    }
                    lambda = lambda.max(options.min_lambda);
                    let window = options.stagnation_window;
                    if window > 0 {
                        accepted_costs.push(cost);
                    }
                    let stagnant = window > 0 && accepted_costs.len() > window && {
                        let before = accepted_costs[accepted_costs.len() - 1 - window];
                        before - cost <= options.stagnation_tolerance * before
                    };
                    if stagnant || previous - cost <= options.function_tolerance * previous {
                        converged = Some(Termination::FunctionTolerance);
                    }
                } else if predicted.is_finite() && predicted <= options.function_tolerance * cost {
                    // The model itself promises less than the tolerance: the step was lost to
                    // rounding at the minimum, not to a poor model.
                    converged = Some(Termination::FunctionTolerance);
                }
                record.evaluate_time = te.elapsed();
                evaluate_time += record.evaluate_time;
            }
            if !accepted {
                rejected_lambda = Some(lambda);
                match policy {
                    DampingPolicy::Additive { factor, .. }
                    | DampingPolicy::Hybrid { factor, .. } => lambda *= factor,
                    DampingPolicy::Marquardt { .. } => {
                        lambda *= nu;
                        nu *= 2.0;
                    }
                }
            }
            record.accepted = accepted;
            record.cost = cost;
            iterations.push(record.clone());
            let mut action = observer.observe(&record);
            for mut trial in search_records.drain(..) {
                trial.iteration = iterations.len() + 1;
                if observer.observe(&trial) == ObserverAction::Stop {
                    action = ObserverAction::Stop;
                }
                iterations.push(trial);
            }
            if let Some(termination) = converged {
                break termination;
            }
            if action == ObserverAction::Stop {
                break Termination::StoppedByObserver;
            }
            if !accepted && lambda > options.max_lambda {
                break Termination::DampingExhausted;
            }
        };

        // The normal equations belong to the returned parameters whatever the termination reason
        // (rejected trials leave them untouched): a covariance at `x` can reuse them.
        if !matches!(termination, Termination::NumericalFailure(_)) {
            self.linearized_at = Some(x.to_vec());
        }
        Ok(SolverReport {
            termination,
            initial_cost,
            final_cost: cost,
            iterations,
            accepted_steps,
            residual_evaluations,
            jacobian_evaluations,
            linear_solves,
            linear_solver: self.linear.kind(),
            num_residuals: problem.num_residuals,
            num_free_parameters: problem.num_free,
            evaluate_time,
            solve_time,
            total_time: start.elapsed(),
        })
    }
}
