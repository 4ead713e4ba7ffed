//! The Levenberg-Marquardt core on calibration-shaped problems: one reduced camera block of 8,
//! `M` eliminated pose blocks of 6, one residual block of `2 N` rows per view, built exactly as
//! `calib_single::calibrate` builds it (see `calib_benches::CalibrationProblem`), single thread.
//!
//! * `solver_core/linearize/MxN`: `Solver::solve` with `max_iterations = 0`, i.e. one evaluation
//!   of all residuals and Jacobians accumulated into the block normal equations (plus the
//!   gradient check), no linear solve.
//! * `solver_core/full_solve/MxN`: a complete solve from the closed-form start (the start is
//!   computed once, outside the timed loop). The number of step attempts, accepted steps and
//!   evaluations of that solve are printed before the measurement, so per-iteration time is
//!   `full_solve / iterations`.

use calib_benches::{BOARD_9X6, BOARD_20X20, CalibrationProblem, single_thread_solver_options};
use criterion::{
    BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};

use std::hint::black_box;
use std::time::Duration;

const VIEWS: [usize; 3] = [10, 100, 1000];
const BOARDS: [(usize, usize); 2] = [BOARD_9X6, BOARD_20X20];
const SEED: u64 = 1;
const MAX_TILT_DEG: f64 = 45.0;

fn solver_core(c: &mut Criterion) {
    for board in BOARDS {
        for views in VIEWS {
            let n = board.0 * board.1;
            let label = format!("{views}x{n}");
            let set = calib_benches::synthetic(views, board, MAX_TILT_DEG, SEED);
            let p = CalibrationProblem::new(&set.observations);
            let cost = p.cost();

            // One untimed solve to report what a full solve does.
            let mut solver = p.solver(single_thread_solver_options());
            let mut x = p.start.clone();
            let report = solver.solve(&cost, &mut x).expect("solve");
            let rms = (2.0 * report.final_cost / p.num_points as f64).sqrt();
            eprintln!(
                "solver_core {label}: {} ({:?}), {} step attempts, {} accepted, {} residual + {} \
                 Jacobian evaluations, RMS {rms:.6} px, untimed run {:.2} ms (evaluate {:.2} ms, \
                 linear solves {:.2} ms)",
                report.termination,
                report.linear_solver,
                report.iterations.len(),
                report.accepted_steps,
                report.residual_evaluations,
                report.jacobian_evaluations,
                report.total_time.as_secs_f64() * 1e3,
                report.evaluate_time.as_secs_f64() * 1e3,
                report.solve_time.as_secs_f64() * 1e3,
            );

            let mut group = c.benchmark_group("solver_core");
            group.throughput(Throughput::Elements(p.num_points as u64));
            if views * n >= 40_000 {
                // 100x400 and up: tens to hundreds of milliseconds per run.
                group
                    .sample_size(10)
                    .sampling_mode(SamplingMode::Flat)
                    .warm_up_time(Duration::from_secs(1))
                    .measurement_time(Duration::from_secs(4));
            } else {
                group
                    .sample_size(30)
                    .warm_up_time(Duration::from_millis(500))
                    .measurement_time(Duration::from_secs(2));
            }

            let mut linearizer = p.solver({
                let mut o = single_thread_solver_options();
                o.max_iterations = 0;
                o
            });
            group.bench_function(BenchmarkId::new("linearize", &label), |b| {
                let mut x = p.start.clone();
                b.iter(|| {
                    x.copy_from_slice(&p.start);
                    black_box(linearizer.solve(&cost, &mut x).expect("linearize"))
                })
            });
            group.bench_function(BenchmarkId::new("full_solve", &label), |b| {
                let mut x = p.start.clone();
                b.iter(|| {
                    x.copy_from_slice(&p.start);
                    black_box(solver.solve(&cost, &mut x).expect("solve"))
                })
            });
            group.finish();
        }
    }
}

criterion_group!(benches, solver_core);
criterion_main!(benches);
