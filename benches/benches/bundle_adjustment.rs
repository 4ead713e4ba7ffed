//! The Levenberg-Marquardt core on 2D bundle-adjustment-shaped problems
//! (`lm_solver::test_problems::BearingAdjustment`): cameras `(x, y, heading)` in the reduced
//! system, landmarks `(x, y)` eliminated, one scalar residual block per observation. Single
//! thread, default (additive) damping, start = truth perturbed by up to 0.1 in every non-gauge
//! parameter, 1e-3 rad bearing noise.
//!
//! Problems (`C` cameras x `L` landmarks):
//!
//! * `dense CxL`: every camera sees every landmark (`BearingAdjustment::generate`), so the reduced
//!   camera system is dense: 50x2000 (100 000 observations) and 200x5000 (1 000 000).
//! * `window20 CxL`: each landmark seen by 20 consecutive cameras
//!   (`calib_benches::windowed_bearing_adjustment`), a block-banded reduced system like real
//!   bundle adjustment: 200x5000 (100 000 observations).
//!
//! Benchmarks:
//!
//! * `bundle_adjustment/linearize/P`: one evaluation into the normal equations
//!   (`max_iterations = 0`; independent of the linear solver).
//! * `bundle_adjustment/full_solve/{DenseSchur,SparseSchur}/P`: a complete solve. The step attempts
//!   and the evaluate / linear-solve split of one untimed solve are printed first.
//!
//! The dense 200x5000 full solves take about 30 s each (the dense Schur update of a 600-parameter
//! reduced system dominates), so they only run with `CALIB_BENCH_LARGE_BA=1` in the environment.

use calib_benches::windowed_bearing_adjustment;
use criterion::{
    BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use lm_solver::test_problems::BearingAdjustment;
use lm_solver::{LinearSolverKind, Solver, SolverOptions};
use std::hint::black_box;
use std::time::Duration;

const NOISE_RAD: f64 = 1e-3;
const PERTURBATION: f64 = 0.1;

fn options(kind: LinearSolverKind, max_iterations: usize) -> SolverOptions {
    {
        let mut o = SolverOptions::default();
        o.num_threads = 1;
        o.linear_solver = kind;
        o.max_iterations = max_iterations;
        o
    }
}

fn bench_problem(c: &mut Criterion, label: &str, ba: &BearingAdjustment, full_solves: bool) {
    let problem = ba.build(true).problem;
    let start = ba.perturbed(PERTURBATION, 8);
    let mut group = c.benchmark_group("bundle_adjustment");
    group
        .throughput(Throughput::Elements(ba.observations.len() as u64))
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));

    let mut linearizer = Solver::new(problem.clone(), options(LinearSolverKind::DenseSchur, 0))
        .expect("solver setup");
    group.bench_function(BenchmarkId::new("linearize", label), |b| {
        let mut x = start.clone();
        b.iter(|| {
            x.copy_from_slice(&start);
            black_box(linearizer.solve(ba, &mut x).expect("linearize"))
        })
    });
    if !full_solves {
        eprintln!(
            "bundle_adjustment {label}: full solves skipped (set CALIB_BENCH_LARGE_BA=1 to run them)"
        );
        group.finish();
        return;
    }
    for kind in [LinearSolverKind::DenseSchur, LinearSolverKind::SparseSchur] {
        let mut solver = Solver::new(problem.clone(), options(kind, 200)).expect("solver setup");
        let mut x = start.clone();
        let report = solver.solve(ba, &mut x).expect("solve");
        eprintln!(
            "bundle_adjustment {kind:?} {label}: {}, {} step attempts, {} accepted, {} residual \
             + {} Jacobian evaluations, cost {:.6e} -> {:.6e}, untimed run {:.1} ms (evaluate \
             {:.1} ms, linear solves {:.1} ms)",
            report.termination,
            report.iterations.len(),
            report.accepted_steps,
            report.residual_evaluations,
            report.jacobian_evaluations,
            report.initial_cost,
            report.final_cost,
            report.total_time.as_secs_f64() * 1e3,
            report.evaluate_time.as_secs_f64() * 1e3,
            report.solve_time.as_secs_f64() * 1e3,
        );
        group.bench_function(
            BenchmarkId::new(format!("full_solve/{kind:?}"), label),
            |b| {
                let mut x = start.clone();
                b.iter(|| {
                    x.copy_from_slice(&start);
                    black_box(solver.solve(ba, &mut x).expect("solve"))
                })
            },
        );
    }
    group.finish();
}

fn bundle_adjustment(c: &mut Criterion) {
    let large = std::env::var_os("CALIB_BENCH_LARGE_BA").is_some_and(|v| v != "0");
    let dense_small = BearingAdjustment::generate(50, 2000, NOISE_RAD, 7);
    bench_problem(c, "dense_50x2000", &dense_small, true);
    let windowed = windowed_bearing_adjustment(200, 5000, 20, NOISE_RAD, 7);
    bench_problem(c, "window20_200x5000", &windowed, true);
    let dense_large = BearingAdjustment::generate(200, 5000, NOISE_RAD, 7);
    bench_problem(c, "dense_200x5000", &dense_large, large);
}

criterion_group!(benches, bundle_adjustment);
criterion_main!(benches);
