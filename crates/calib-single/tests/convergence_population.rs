//! The convergence sweep of issue 11 over the population users produce
//! (`calib_core::synthetic::population`: 3 to 40 views, largest tilt 5 to 60 degrees, noise
//! 0.05 to 1 px, 7x5 / 9x6 / 12x9 boards, principal point up to 15 px off-centre, k1 about
//! -0.2). Each problem is calibrated from the default start and from the truth; the goal is no
//! refusal, no iteration-limit stop and no result above the true minimum by more than 1e-5 px.
//! Not timed; the problems are split over two threads.

use calib_single::synthetic::generate;
use calib_single::{CalibrationOptions, calibrate};

#[derive(Default)]
struct Counts {
    at_minimum: usize,
    unobservable: usize,
    refused: Vec<String>,
    iteration_limit: Vec<String>,
    above: Vec<String>,
}

fn sweep(seeds: std::ops::Range<u64>) -> Counts {
    let mut counts = Counts::default();
    for seed in seeds {
        let config = calib_core::synthetic::population(seed);
        let set = generate(&config).unwrap();
        let options = CalibrationOptions::default();
        let mut truth = options.clone();
        truth.intrinsic_guess = Some(set.camera.intrinsics);
        truth.distortion_guess = Some(set.camera.distortion.clone());
        let reference = calibrate(&set.observations, &truth);
        let reference = match reference {
            Ok(r) => r,
            // Not determined even from the truth: the data cannot fix the answer, and the
            // default start must refuse it too.
            Err(e) if e.to_string().contains("not determined") => {
                let ours = calibrate(&set.observations, &options);
                assert!(
                    ours.is_err(),
                    "seed {seed}: accepted an undetermined problem"
                );
                counts.unobservable += 1;
                continue;
            }
            Err(e) => panic!("seed {seed}: the truth start fails: {e}"),
        };
        let what = format!(
            "seed {seed} ({} views, tilt {:.1} deg, noise {:.2} px)",
            config.views, config.max_tilt_deg, config.noise_px
        );
        match calibrate(&set.observations, &options) {
            Err(e) => counts.refused.push(format!("{what}: {e}")),
            Ok(r) if !r.solver.termination.is_converged() => counts
                .iteration_limit
                .push(format!("{what}: {}", r.solver.termination)),
            // The same points must be in use for the RMS to compare.
            Ok(r) if r.rms_all_points > reference.rms_all_points + 1e-5 => {
                counts.above.push(format!(
                    "{what}: {} vs {}",
                    r.rms_all_points, reference.rms_all_points
                ))
            }
            Ok(_) => counts.at_minimum += 1,
        }
    }
    counts
}

#[test]
fn every_problem_of_the_population_reaches_the_true_minimum() {
    let problems = 500;
    let halves = std::thread::scope(|s| {
        let a = s.spawn(|| sweep(0..problems / 2));
        let b = s.spawn(|| sweep(problems / 2..problems));
        [a.join().unwrap(), b.join().unwrap()]
    });
    let mut all = Counts::default();
    for h in halves {
        all.at_minimum += h.at_minimum;
        all.unobservable += h.unobservable;
        all.refused.extend(h.refused);
        all.iteration_limit.extend(h.iteration_limit);
        all.above.extend(h.above);
    }
    println!(
        "{problems} problems: {} at the minimum, {} not determined (refused from the truth too), {} refused, {} iteration limit, {} above",
        all.at_minimum,
        all.unobservable,
        all.refused.len(),
        all.iteration_limit.len(),
        all.above.len()
    );
    for line in all
        .refused
        .iter()
        .chain(&all.iteration_limit)
        .chain(&all.above)
    {
        println!("  {line}");
    }
    assert!(all.unobservable <= 2);
    assert_eq!(all.at_minimum + all.unobservable, problems as usize);
}
