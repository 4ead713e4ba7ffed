//! End-to-end single-camera calibration, `calib_single::calibrate` with default options on one
//! thread: input checks, homographies, closed-form start, Levenberg-Marquardt, covariance and
//! per-view RMS. Synthetic sets (0.2 px noise, tilt up to 45 degrees, seed 1) of M = 10, 100,
//! 1000 views of a 9x6 or 20x20 board, plus the bundled real set `data/sourishg1/left.json`
//! (29 views, 9x6) when it is present.
//!
//! Stereo end-to-end benchmarks: `benches/calibrate_stereo.rs`, same sizes.

use calib_benches::{BOARD_9X6, BOARD_20X20, single_thread_options};
use calib_core::JsonFile;
use calib_single::{Observations, calibrate};
use criterion::{
    BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

const VIEWS: [usize; 3] = [10, 100, 1000];
const BOARDS: [(usize, usize); 2] = [BOARD_9X6, BOARD_20X20];

fn bench_set(c: &mut Criterion, label: &str, observations: &Observations) {
    let options = single_thread_options();
    let points = observations.num_points();
    let result = calibrate(observations, &options).expect("calibrate");
    eprintln!(
        "calibrate_single {label}: {}, {} step attempts, RMS {:.6} px, untimed run {:.2} ms \
         (solver {:.2} ms)",
        result.solver.termination,
        result.solver.iterations.len(),
        result.rms,
        result.elapsed.as_secs_f64() * 1e3,
        result.solver.total_time.as_secs_f64() * 1e3,
    );
    let mut group = c.benchmark_group("calibrate_single");
    group.throughput(Throughput::Elements(points as u64));
    if points >= 40_000 {
        group
            .sample_size(10)
            .sampling_mode(SamplingMode::Flat)
            .warm_up_time(Duration::from_secs(1))
            .measurement_time(Duration::from_secs(if points >= 200_000 { 10 } else { 4 }));
    } else {
        group
            .sample_size(30)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(2));
    }
    group.bench_function(BenchmarkId::from_parameter(label), |b| {
        b.iter(|| black_box(calibrate(black_box(observations), &options).expect("calibrate")))
    });
    group.finish();
}

fn calibrate_single(c: &mut Criterion) {
    let real = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/sourishg1/left.json");
    if let Ok(observations) = Observations::read(&real) {
        bench_set(c, "sourishg1_left_29x54", &observations);
    }
    for board in BOARDS {
        for views in VIEWS {
            let set = calib_benches::synthetic(views, board, 45.0, 1);
            let label = format!("{views}x{}", board.0 * board.1);
            bench_set(c, &label, &set.observations);
        }
    }
}

criterion_group!(benches, calibrate_single);
criterion_main!(benches);
