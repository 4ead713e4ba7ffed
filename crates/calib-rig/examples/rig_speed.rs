//! Times a rig calibration on one thread: `cargo run --release -p calib-rig --example rig_speed
//! -- [CAMERAS] [FRAMES] [REPEAT]` (default 10 cameras, 500 frames, 9x6 board, full ring).

use calib_rig::synthetic::{RigLayout, SyntheticRigConfig, generate_rig};
use calib_rig::{RigOptions, calibrate_rig};
use std::time::Instant;

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("numbers: CAMERAS FRAMES REPEAT"))
        .collect();
    let config = SyntheticRigConfig {
        cameras: args.first().copied().unwrap_or(10),
        frames: args.get(1).copied().unwrap_or(500),
        layout: RigLayout::Ring { arc_deg: 360.0 },
        ..Default::default()
    };
    let repeat = args.get(2).copied().unwrap_or(3);
    let data = generate_rig(&config).expect("rig");
    let observations: usize = data
        .observations
        .frames
        .iter()
        .map(|f| f.observations.len())
        .sum();
    let mut options = RigOptions::default();
    options.solver.num_threads = 1;
    let mut best = f64::INFINITY;
    for _ in 0..repeat {
        let t = Instant::now();
        let rig = calibrate_rig(&data.observations, &options).expect("calibration");
        let seconds = t.elapsed().as_secs_f64();
        best = best.min(seconds);
        println!(
            "{} cameras, {} frames, {observations} views, {} points: {seconds:.3} s (per camera {:.3} s, joint {:.3} s, covariance {:.3} s), rms {:.4} px, {} iterations",
            config.cameras,
            config.frames,
            observations * config.base.board_cols * config.base.board_rows,
            rig.stage_times[0].as_secs_f64(),
            rig.stage_times[1].as_secs_f64(),
            rig.stage_times[2].as_secs_f64(),
            rig.rms,
            rig.solver.iterations.len()
        );
    }
    println!("best of {repeat}: {best:.3} s");
}
