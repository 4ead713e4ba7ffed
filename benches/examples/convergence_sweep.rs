//! Convergence sweep over the population of `calib_core::synthetic::population`: calibrates each
//! problem from the closed-form start and from the truth, and counts refusals, iteration-limit
//! stops and results above the true minimum. `cargo run --release -p calib-benches --example
//! convergence_sweep [PROBLEMS] [FIRST_SEED]`.

use calib_single::synthetic::generate;
use calib_single::{CalibrationOptions, calibrate};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let problems: u64 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(500);
    let first: u64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(0);
    let mut options = CalibrationOptions::default();
    match args.get(3).map(String::as_str) {
        Some("marquardt") => options.solver.damping = lm_solver::DampingPolicy::marquardt(),
        Some("additive") => options.solver.damping = lm_solver::DampingPolicy::additive(),
        Some("hybrid") => options.solver.damping = lm_solver::DampingPolicy::hybrid(),
        _ => {}
    }
    if let Some(n) = args.get(4).and_then(|a| a.parse().ok()) {
        options.solver.max_iterations = n;
    }
    let (mut refused, mut max_iter, mut worse, mut ok) = (0, 0, 0, 0);
    let mut iterations = 0;
    for seed in first..first + problems {
        let config = calib_core::synthetic::population(seed);
        let Ok(set) = generate(&config) else {
            println!("seed {seed}: generation failed");
            continue;
        };
        let mut truth_options = options.clone();
        truth_options.intrinsic_guess = Some(set.camera.intrinsics);
        truth_options.distortion_guess = Some(set.camera.distortion.clone());
        let reference = calibrate(&set.observations, &truth_options);
        let result = calibrate(&set.observations, &options);
        match (&result, &reference) {
            (Err(e), reference) => {
                refused += 1;
                println!(
                    "seed {seed}: refused ({} views, tilt {:.1}): {e}",
                    config.views, config.max_tilt_deg
                );
                if let Ok(t) = reference {
                    println!(
                        "    reference: fx {:.1} +- {:.1}, rms {:.6}, {} iterations",
                        t.camera.intrinsics.fx,
                        t.intrinsics_std[0],
                        t.rms,
                        t.solver.iterations.len()
                    );
                }
                let mut o = options.clone();
                o.compute_uncertainty = false;
                if let Ok(r) = calibrate(&set.observations, &o) {
                    println!(
                        "    ours without covariance: fx {:.1}, rms {:.6}, {} iterations, {}",
                        r.camera.intrinsics.fx,
                        r.rms,
                        r.solver.iterations.len(),
                        r.solver.termination
                    );
                }
            }
            (Ok(r), Ok(t)) => {
                if !r.solver.termination.is_converged() {
                    max_iter += 1;
                    println!(
                        "seed {seed}: {} after {} iterations (views {}, tilt {:.1}, start fx {:.0} true {:.0})",
                        r.solver.termination,
                        r.solver.iterations.len(),
                        config.views,
                        config.max_tilt_deg,
                        r.initial_intrinsics.fx,
                        config.intrinsics.fx
                    );
                } else if r.rms > t.rms + 1e-5 || !t.solver.termination.is_converged() {
                    worse += 1;
                    println!(
                        "seed {seed}: rms {:.6} vs {:.6} (views {}, tilt {:.1}, start fx {:.0} true {:.0})",
                        r.rms,
                        t.rms,
                        config.views,
                        config.max_tilt_deg,
                        r.initial_intrinsics.fx,
                        config.intrinsics.fx
                    );
                } else {
                    ok += 1;
                    iterations += r.solver.iterations.len();
                }
            }
            (Ok(_), Err(e)) => println!("seed {seed}: reference failed: {e}"),
        }
    }
    println!(
        "{problems} problems: {ok} at the minimum, {refused} refused, {max_iter} stopped without converging, {worse} above the minimum; {:.1} iterations on average at the minimum",
        iterations as f64 / ok.max(1) as f64
    );
}
