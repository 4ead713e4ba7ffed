//! A fixed workload to profile with `perf` or `valgrind --tool=callgrind`:
//!
//! ```text
//! cargo build --release -p calib-benches --example profile_target
//! perf record -g target/release/examples/profile_target linearize 1000 400 50
//! perf record -g target/release/examples/profile_target calibrate 1000 400 5
//! ```
//!
//! Arguments: `linearize | solve | calibrate`, views, points per view (54 = 9x6 or 400 = 20x20
//! board), repetitions. Single thread, synthetic set with seed 1 (the benchmarks' problem).

use calib_benches::{
    BOARD_9X6, BOARD_20X20, CalibrationProblem, single_thread_options,
    single_thread_solver_options, synthetic,
};

use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "profile_target linearize|solve|calibrate VIEWS 54|400 REPETITIONS";
    let (mode, views, points, reps) = match args.as_slice() {
        [m, v, p, r] => (
            m.as_str(),
            v.parse::<usize>().expect(usage),
            p.parse::<usize>().expect(usage),
            r.parse::<usize>().expect(usage),
        ),
        _ => panic!("{usage}"),
    };
    let board = match points {
        54 => BOARD_9X6,
        400 => BOARD_20X20,
        _ => panic!("{usage}"),
    };
    let set = synthetic(views, board, 45.0, 1);
    let t = Instant::now();
    match mode {
        "calibrate" => {
            let options = single_thread_options();
            for _ in 0..reps {
                let r = calib_single::calibrate(&set.observations, &options).expect("calibrate");
                std::hint::black_box(r);
            }
        }
        "linearize" | "solve" => {
            let p = CalibrationProblem::new(&set.observations);
            let max_iterations = if mode == "linearize" { 0 } else { 100 };
            let mut options = single_thread_solver_options();
            options.max_iterations = max_iterations;
            let mut solver = p.solver(options);
            let cost = p.cost();
            let mut x = p.start.clone();
            for _ in 0..reps {
                x.copy_from_slice(&p.start);
                std::hint::black_box(solver.solve(&cost, &mut x).expect("solve"));
            }
        }
        _ => panic!("{usage}"),
    }
    let elapsed = t.elapsed().as_secs_f64();
    println!(
        "{mode} {views}x{points}: {reps} repetitions, {:.3} ms each",
        elapsed * 1e3 / reps as f64
    );
}
