//! Damping-policy study: the additive policy (`lambda I`, `lambda0 = 0.01`, /10 on success, x10
//! on failure) against the Ceres-style Marquardt policy (`lambda diag(J^T J)`, Nielsen's
//! gain-ratio update) on calibration problems, by the number of evaluations needed to reach the
//! minimum.
//!
//! ```text
//! cargo run --release -p calib-benches --example damping_study [-- OPTIONS]
//!   --seeds N      synthetic seeds 1..=N per configuration (default 5)
//!   --repeats N    timing repeats per run, the minimum is reported (default 3; 1 for problems
//!                  of 100 000 points or more)
//!   --max-views M  skip synthetic configurations with more than M views (default 1000)
//!   --data DIR     directory with sourishg1/ and sourishg2/ (default: the workspace's data/)
//!   --additive-initial L   initial lambda of the additive policy (default 0.01)
//!   --marquardt-initial L  initial lambda of the Marquardt policy (default 1e-4, Ceres'
//!                  1 / initial trust-region radius), for a sensitivity check
//!   --hard-starts  add 20 problems started far from the minimum (100x54, focal-length guess
//!                  x0.5, x0.7, x1.5, x2 and principal point off by (32, -24) px; seeds 1..=N)
//!   --trace TEXT   also print every step attempt (cost, lambda, gain ratio) of both policies on
//!                  the problems whose name contains TEXT (e.g. "sourishg1/left")
//! ```
//!
//! Every problem is calibrated with `calib_single::calibrate` and default options on one thread,
//! once per policy. Synthetic problems: `SyntheticConfig::default()` camera (640x480, fx = fy =
//! 800, mild barrel distortion), 0.2 px noise, M = 10, 100, 1000 views of a 9x6 or 20x20 board,
//! tilt up to 45 or 60 degrees. Real problems: `data/sourishg{1,2}/{left,right}.json`.
//! Prints a Markdown table and a summary; the results are in `docs/benchmarks-solver.md`.

use calib_benches::{BOARD_9X6, BOARD_20X20, single_thread_options, synthetic};
use calib_core::JsonFile;
use calib_single::{Observations, calibrate};
use camera_model::Intrinsics;
use lm_solver::{DampingPolicy, SolverReport, Termination};
use std::path::PathBuf;
use std::time::Duration;

/// Relative cost tolerance for "has reached the minimum".
const MINIMUM_TOLERANCE: f64 = 1e-9;

struct Args {
    seeds: u64,
    repeats: usize,
    max_views: usize,
    data: PathBuf,
    trace: Option<String>,
    hard_starts: bool,
    additive: DampingPolicy,
    marquardt: DampingPolicy,
}

fn parse_args() -> Args {
    let mut args = Args {
        seeds: 5,
        repeats: 3,
        max_views: 1000,
        data: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data"),
        trace: None,
        hard_starts: false,
        additive: DampingPolicy::additive(),
        marquardt: DampingPolicy::marquardt(),
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().unwrap_or_else(|| panic!("{flag} needs a value"));
        match flag.as_str() {
            "--seeds" => args.seeds = value().parse().expect("--seeds N"),
            "--repeats" => args.repeats = value().parse().expect("--repeats N"),
            "--max-views" => args.max_views = value().parse().expect("--max-views M"),
            "--data" => args.data = PathBuf::from(value()),
            "--trace" => args.trace = Some(value()),
            "--hard-starts" => args.hard_starts = true,
            "--additive-initial" => {
                let lambda: f64 = value().parse().expect("--additive-initial L");
                if let DampingPolicy::Additive { initial, .. } = &mut args.additive {
                    *initial = lambda;
                }
            }
            "--marquardt-initial" => {
                let lambda: f64 = value().parse().expect("--marquardt-initial L");
                if let DampingPolicy::Marquardt { initial, .. } = &mut args.marquardt {
                    *initial = lambda;
                }
            }
            "-h" | "--help" => {
                println!(
                    "damping_study [--seeds N] [--repeats N] [--max-views M] [--data DIR] \
                     [--additive-initial L] [--marquardt-initial L] [--hard-starts] [--trace TEXT]\n\
                     See the module documentation of benches/examples/damping_study.rs."
                );
                std::process::exit(0);
            }
            other => panic!("unknown argument {other:?} (try --help)"),
        }
    }
    args
}

/// One calibration with one policy.
#[derive(Debug, Clone)]
struct Run {
    rms: f64,
    converged: bool,
    termination: String,
    attempts: usize,
    accepted: usize,
    residual_evaluations: usize,
    jacobian_evaluations: usize,
    /// Fastest solver wall time over the repeats.
    solver_time: Duration,
    /// Fastest whole-`calibrate` time over the repeats.
    calibrate_time: Duration,
    /// Cost after each step attempt, with the evaluations made up to and including it.
    trace: Vec<(f64, usize)>,
    initial_cost: f64,
    final_cost: f64,
    /// One line per step attempt, for `--trace`.
    attempt_lines: Vec<String>,
}

impl Run {
    fn evaluations(&self) -> usize {
        self.residual_evaluations + self.jacobian_evaluations
    }

    /// Evaluations until the cost first came within `tolerance` (relative) of `target`: the
    /// minimum is reached there; what follows only confirms convergence.
    fn evaluations_to_reach(&self, target: f64, tolerance: f64) -> usize {
        if self.initial_cost <= target * (1.0 + tolerance) {
            return 1;
        }
        self.trace
            .iter()
            .find(|(cost, _)| *cost <= target * (1.0 + tolerance))
            .map_or(usize::MAX, |&(_, evals)| evals)
    }
}

fn run(problem: &Problem, damping: DampingPolicy, repeats: usize) -> Run {
    let observations = &problem.observations;
    let mut options = single_thread_options();
    options.solver.damping = damping;
    options.intrinsic_guess = problem.intrinsic_guess;
    let mut best: Option<Run> = None;
    for _ in 0..repeats.max(1) {
        let result = calibrate(observations, &options).expect("calibration");
        let report: &SolverReport = &result.solver;
        // The initial linearization, then per attempt one residual evaluation (when the linear
        // solve succeeded) and one linearization when the step was accepted.
        // (A step below the parameter tolerance stops the solve before its trial evaluation.)
        let attempts = report.iterations.len();
        let stopped_on_step = report.termination == Termination::ParameterTolerance;
        let mut evals = 1;
        let trace: Vec<(f64, usize)> = report
            .iterations
            .iter()
            .enumerate()
            .map(|(k, it)| {
                let evaluated = it.solve_succeeded && !(stopped_on_step && k + 1 == attempts);
                evals += usize::from(evaluated) + usize::from(it.accepted);
                (it.cost, evals)
            })
            .collect();
        assert_eq!(
            evals,
            report.residual_evaluations + report.jacobian_evaluations,
            "evaluation trace out of step with the report"
        );
        let attempt_lines = report
            .iterations
            .iter()
            .map(|it| {
                format!(
                    "| {} | {:.12e} | {:.12e} | {:.3e} | {:.3e} | {:.4} | {} |",
                    it.iteration,
                    it.cost,
                    it.trial_cost,
                    it.gradient_max_norm,
                    it.lambda,
                    it.gain_ratio,
                    if it.accepted { "yes" } else { "no" }
                )
            })
            .collect();
        let this = Run {
            attempt_lines,
            trace,
            initial_cost: report.initial_cost,
            final_cost: report.final_cost,
            rms: result.rms,
            converged: report.termination.is_converged(),
            termination: report.termination.to_string(),
            attempts: report.iterations.len(),
            accepted: report.accepted_steps,
            residual_evaluations: report.residual_evaluations,
            jacobian_evaluations: report.jacobian_evaluations,
            solver_time: report.total_time,
            calibrate_time: result.elapsed,
        };
        best = Some(match best {
            None => this,
            Some(b) => Run {
                solver_time: b.solver_time.min(this.solver_time),
                calibrate_time: b.calibrate_time.min(this.calibrate_time),
                ..b
            },
        });
    }
    best.expect("at least one repeat")
}

struct Problem {
    name: String,
    kind: &'static str,
    views: usize,
    points_per_view: String,
    observations: Observations,
    /// Start from these intrinsics instead of the closed-form guess (the `--hard-starts` set).
    intrinsic_guess: Option<Intrinsics>,
}

/// Selects the rows of a summary line.
type RowFilter = Box<dyn Fn(&Row) -> bool>;

struct Row {
    problem: Problem,
    additive: Run,
    marquardt: Run,
}

impl Row {
    /// Evaluations of each policy until its cost was within 1e-9 (relative) of the lower of the
    /// two final costs (`usize::MAX` if never).
    fn evaluations_to_minimum(&self) -> (usize, usize) {
        let target = self.additive.final_cost.min(self.marquardt.final_cost);
        (
            self.additive
                .evaluations_to_reach(target, MINIMUM_TOLERANCE),
            self.marquardt
                .evaluations_to_reach(target, MINIMUM_TOLERANCE),
        )
    }

    fn same_minimum(&self) -> bool {
        let (a, m) = (self.additive.rms, self.marquardt.rms);
        (a - m).abs() <= 1e-9 * a.max(m)
    }
}

fn ms(d: Duration) -> String {
    format!("{:.1}", d.as_secs_f64() * 1e3)
}

fn problems(args: &Args) -> Vec<Problem> {
    let mut out = Vec::new();
    for name in ["sourishg1", "sourishg2"] {
        for side in ["left", "right"] {
            let path = args.data.join(name).join(format!("{side}.json"));
            match Observations::read(&path) {
                Ok(observations) => out.push(Problem {
                    name: format!("{name}/{side}"),
                    kind: "real",
                    views: observations.views.len(),
                    points_per_view: "54".into(),
                    observations,
                    intrinsic_guess: None,
                }),
                Err(e) => eprintln!("skipping {}: {e}", path.display()),
            }
        }
    }
    for board in [BOARD_9X6, BOARD_20X20] {
        for views in [10, 100, 1000] {
            if views > args.max_views {
                continue;
            }
            for tilt in [45.0, 60.0] {
                for seed in 1..=args.seeds {
                    let set = synthetic(views, board, tilt, seed);
                    out.push(Problem {
                        name: format!(
                            "synth {views}x{} tilt {tilt} seed {seed}",
                            board.0 * board.1
                        ),
                        kind: "synthetic",
                        views,
                        points_per_view: format!("{}", board.0 * board.1),
                        observations: set.observations,
                        intrinsic_guess: None,
                    });
                }
            }
        }
    }
    if args.hard_starts {
        // Poor starts: the focal length guess off by a factor (the poses then come from the
        // homographies with the wrong K), principal point off by 5% of the image.
        for factor in [0.5, 0.7, 1.5, 2.0] {
            for seed in 1..=args.seeds {
                let set = synthetic(100, BOARD_9X6, 45.0, seed);
                let k = set.camera.intrinsics;
                out.push(Problem {
                    name: format!("hard start 100x54 fx x{factor} seed {seed}"),
                    kind: "hard start",
                    views: 100,
                    points_per_view: "54".into(),
                    observations: set.observations,
                    intrinsic_guess: Some(Intrinsics::new(
                        k.fx * factor,
                        k.fy * factor,
                        k.cx + 32.0,
                        k.cy - 24.0,
                    )),
                });
            }
        }
    }
    out
}

fn main() {
    let args = parse_args();
    let problems = problems(&args);
    eprintln!("{} problems", problems.len());
    println!(
        "Policies: additive = {:?}; Marquardt = {:?}.\n",
        args.additive, args.marquardt
    );
    let mut rows = Vec::with_capacity(problems.len());
    for problem in problems {
        let repeats = if problem.observations.num_points() >= 100_000 {
            1
        } else {
            args.repeats
        };
        let additive = run(&problem, args.additive, repeats);
        let marquardt = run(&problem, args.marquardt, repeats);
        eprintln!(
            "{}: additive {} evaluations ({}), marquardt {} evaluations ({})",
            problem.name,
            additive.evaluations(),
            additive.termination,
            marquardt.evaluations(),
            marquardt.termination
        );
        rows.push(Row {
            problem,
            additive,
            marquardt,
        });
    }

    println!(
        "Per problem: additive / Marquardt. \"attempts\" = solver iterations (step attempts), \
         \"evals\" = residual + Jacobian evaluations (the initial linearization counts as one \
         Jacobian evaluation), times are the fastest of the repeats, one thread.\n"
    );
    println!(
        "| problem | M x N | final RMS (px) | same min | attempts | accepted | residual evals | \
         Jacobian evals | total evals | evals to min | solver ms | calibrate ms | fewer evals |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        let (a, m) = (&r.additive, &r.marquardt);
        let better = match a.evaluations().cmp(&m.evaluations()) {
            std::cmp::Ordering::Less => "additive",
            std::cmp::Ordering::Greater => "Marquardt",
            std::cmp::Ordering::Equal => "tie",
        };
        let rms = if r.same_minimum() {
            format!("{:.6}", a.rms)
        } else {
            format!("{:.9} / {:.9}", a.rms, m.rms)
        };
        let flag = |run: &Run| if run.converged { "" } else { " (!)" };
        let (to_min_a, to_min_m) = r.evaluations_to_minimum();
        let never = |e: usize| {
            if e == usize::MAX {
                "never".to_string()
            } else {
                e.to_string()
            }
        };
        println!(
            "| {} | {}x{} | {} | {} | {} / {} | {} / {} | {} / {} | {} / {} | {}{} / {}{} | {} / {} | {} / {} | {} / {} | {} |",
            r.problem.name,
            r.problem.views,
            r.problem.points_per_view,
            rms,
            if r.same_minimum() { "yes" } else { "**no**" },
            a.attempts,
            m.attempts,
            a.accepted,
            m.accepted,
            a.residual_evaluations,
            m.residual_evaluations,
            a.jacobian_evaluations,
            m.jacobian_evaluations,
            a.evaluations(),
            flag(a),
            m.evaluations(),
            flag(m),
            never(to_min_a),
            never(to_min_m),
            ms(a.solver_time),
            ms(m.solver_time),
            ms(a.calibrate_time),
            ms(m.calibrate_time),
            better,
        );
    }
    let not_converged: Vec<String> = rows
        .iter()
        .flat_map(|r| {
            [("additive", &r.additive), ("Marquardt", &r.marquardt)]
                .into_iter()
                .filter(|(_, run)| !run.converged)
                .map(|(policy, run)| format!("{} {policy}: {}", r.problem.name, run.termination))
        })
        .collect();
    if !not_converged.is_empty() {
        println!("\n(!) not converged:");
        for line in &not_converged {
            println!("* {line}");
        }
    }

    if let Some(text) = &args.trace {
        for r in rows
            .iter()
            .filter(|r| r.problem.name.contains(text.as_str()))
        {
            for (policy, run) in [("additive", &r.additive), ("Marquardt", &r.marquardt)] {
                println!(
                    "\n{} ({policy}): initial cost {:.12e}, {}\n",
                    r.problem.name, run.initial_cost, run.termination
                );
                println!(
                    "| attempt | cost after | trial cost | max gradient | lambda | gain ratio | \
                     accepted |"
                );
                println!("|---|---|---|---|---|---|---|");
                for line in &run.attempt_lines {
                    println!("{line}");
                }
            }
        }
    }

    println!("\n### Summary\n");
    println!(
        "| subset | problems | same minimum | mean evals additive | mean evals Marquardt | \
         mean evals to min additive | mean evals to min Marquardt | mean attempts additive | \
         mean attempts Marquardt | additive fewer | Marquardt fewer | ties | \
         total solver s additive | total solver s Marquardt |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut subsets: Vec<(String, RowFilter)> = vec![
        (
            "real + synthetic".into(),
            Box::new(|r: &Row| r.problem.kind != "hard start"),
        ),
        ("real".into(), Box::new(|r: &Row| r.problem.kind == "real")),
        (
            "synthetic".into(),
            Box::new(|r: &Row| r.problem.kind == "synthetic"),
        ),
        (
            "hard starts".into(),
            Box::new(|r: &Row| r.problem.kind == "hard start"),
        ),
    ];
    for views in [10usize, 100, 1000] {
        for n in ["54", "400"] {
            subsets.push((
                format!("synthetic {views}x{n}"),
                Box::new(move |r: &Row| {
                    r.problem.kind == "synthetic"
                        && r.problem.views == views
                        && r.problem.points_per_view == n
                }),
            ));
        }
    }
    for tilt in ["tilt 45", "tilt 60"] {
        subsets.push((
            format!("synthetic {tilt}"),
            Box::new(move |r: &Row| r.problem.name.contains(tilt)),
        ));
    }
    for (name, keep) in &subsets {
        let sel: Vec<&Row> = rows.iter().filter(|r| keep(r)).collect();
        if sel.is_empty() {
            continue;
        }
        let n = sel.len() as f64;
        let mean = |f: &dyn Fn(&Row) -> usize| sel.iter().map(|r| f(r) as f64).sum::<f64>() / n;
        let count = |o: std::cmp::Ordering| {
            sel.iter()
                .filter(|r| r.additive.evaluations().cmp(&r.marquardt.evaluations()) == o)
                .count()
        };
        let total =
            |f: &dyn Fn(&Row) -> Duration| sel.iter().map(|r| f(r).as_secs_f64()).sum::<f64>();
        println!(
            "| {name} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {} | {} | {:.3} | {:.3} |",
            sel.len(),
            sel.iter().filter(|r| r.same_minimum()).count(),
            mean(&|r| r.additive.evaluations()),
            mean(&|r| r.marquardt.evaluations()),
            mean(&|r| r.evaluations_to_minimum().0),
            mean(&|r| r.evaluations_to_minimum().1),
            mean(&|r| r.additive.attempts),
            mean(&|r| r.marquardt.attempts),
            count(std::cmp::Ordering::Less),
            count(std::cmp::Ordering::Greater),
            count(std::cmp::Ordering::Equal),
            total(&|r| r.additive.solver_time),
            total(&|r| r.marquardt.solver_time),
        );
    }
}
