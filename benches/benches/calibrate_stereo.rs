//! End-to-end stereo calibration, `calib_stereo::calibrate_stereo` with default options on one
//! thread: checks, both single-camera calibrations, the initial rig, the joint Levenberg-Marquardt
//! over 22 + 6M parameters and the covariance. Synthetic rigs (0.2 px noise, tilt up to 45
//! degrees, seed 1) of M = 10, 100, 1000 pairs of a 9x6 or 20x20 board, plus the bundled real set
//! `data/sourishg1/stereo.json` (29 pairs, 9x6) when it is present.

use calib_benches::{BOARD_9X6, BOARD_20X20, NOISE_PX, single_thread_solver_options};
use calib_core::JsonFile;
use calib_single::synthetic::SyntheticConfig;
use calib_stereo::synthetic::{SyntheticStereoConfig, generate_stereo};
use calib_stereo::{StereoObservations, StereoOptions, calibrate_stereo};
use criterion::{
    BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

const PAIRS: [usize; 3] = [10, 100, 1000];
const BOARDS: [(usize, usize); 2] = [BOARD_9X6, BOARD_20X20];

fn bench_set(c: &mut Criterion, label: &str, observations: &StereoObservations) {
    let options = {
        let mut o = StereoOptions::default();
        o.solver = single_thread_solver_options();
        o
    };
    let points: usize = observations
        .pairs
        .iter()
        .map(|p| 2 * p.left.object_points.len())
        .sum();
    let result = calibrate_stereo(observations, &options).expect("calibrate_stereo");
    eprintln!(
        "calibrate_stereo {label}: {}, {} joint step attempts, RMS {:.6} px, untimed run {:.2} ms \
         (single-camera stages {:.2} + {:.2} ms, joint {:.2} ms)",
        result.solver.termination,
        result.solver.iterations.len(),
        result.rms,
        result.elapsed.as_secs_f64() * 1e3,
        result.stage_times[0].as_secs_f64() * 1e3,
        result.stage_times[1].as_secs_f64() * 1e3,
        result.stage_times[2].as_secs_f64() * 1e3,
    );
    let mut group = c.benchmark_group("calibrate_stereo");
    group.throughput(Throughput::Elements(points as u64));
    if points >= 80_000 {
        group
            .sample_size(10)
            .sampling_mode(SamplingMode::Flat)
            .warm_up_time(Duration::from_secs(1))
            .measurement_time(Duration::from_secs(if points >= 400_000 { 15 } else { 5 }));
    } else {
        group
            .sample_size(20)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(2));
    }
    group.bench_function(BenchmarkId::from_parameter(label), |b| {
        b.iter(|| {
            black_box(
                calibrate_stereo(black_box(observations), &options).expect("calibrate_stereo"),
            )
        })
    });
    group.finish();
}

fn calibrate_stereo_benches(c: &mut Criterion) {
    let real = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/sourishg1/stereo.json");
    if let Ok(observations) = StereoObservations::read(&real) {
        bench_set(c, "sourishg1_stereo_29x54", &observations);
    }
    for board in BOARDS {
        for pairs in PAIRS {
            let config = SyntheticStereoConfig {
                left: SyntheticConfig {
                    views: pairs,
                    board_cols: board.0,
                    board_rows: board.1,
                    noise_px: NOISE_PX,
                    seed: 1,
                    ..Default::default()
                },
                ..Default::default()
            };
            let set = generate_stereo(&config).expect("synthetic stereo set");
            let label = format!("{pairs}x{}", board.0 * board.1);
            bench_set(c, &label, &set.observations);
        }
    }
}

criterion_group!(benches, calibrate_stereo_benches);
criterion_main!(benches);
