//! Development harness: detect a list of images with chosen options, write the observation
//! file, print counts and the median time. Not a test.
//!
//! `cargo run --release -p board-detect --example eval -- COLS ROWS SQUARE OUT.json [--refine SPEC]
//! [--warp DEGREE] [--threads N] [--repeats N] IMAGES...`
//! SPEC: `none`, `gradient:WINDOW:MAXHW`, `saddle:BLUR:WINDOW[:MAXBLUR[:MAXWINDOW]]`.
//! Threads default to 1 (the benchmark's single-thread timing).
use board_detect::{Board, DetectOptions, Refinement, detect_files, observations_json};
use std::path::PathBuf;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 5 {
        eprintln!("usage: eval COLS ROWS SQUARE OUT.json [--refine SPEC] [--threads N] IMAGES...");
        std::process::exit(2);
    }
    let board = Board::new(
        args[0].parse().unwrap(),
        args[1].parse().unwrap(),
        args[2].parse().unwrap(),
    )
    .unwrap();
    let out = &args[3];
    let mut opts = DetectOptions::default();
    let mut threads = Some(1);
    let mut repeats = 1usize;
    let mut files = Vec::new();
    let mut i = 4;
    while i < args.len() {
        match args[i].as_str() {
            "--refine" => {
                let s: Vec<&str> = args[i + 1].split(':').collect();
                opts.refinement = match s[0] {
                    "none" => Refinement::None,
                    "gradient" => Refinement::Gradient {
                        window: s[1].parse().unwrap(),
                        max_half_window: s[2].parse().unwrap(),
                    },
                    "saddle" => Refinement::Saddle {
                        blur: s[1].parse().unwrap(),
                        window: s[2].parse().unwrap(),
                        max_blur: s.get(3).map_or(6.0, |v| v.parse().unwrap()),
                        max_window: s.get(4).map_or(15, |v| v.parse().unwrap()),
                    },
                    other => panic!("unknown refinement {other}"),
                };
                i += 1;
            }
            "--warp" => {
                opts.joint_warp_degree = Some(args[i + 1].parse().unwrap());
                i += 1;
            }
            "--repeats" => {
                repeats = args[i + 1].parse().unwrap();
                i += 1;
            }
            "--threads" => {
                threads = Some(args[i + 1].parse().unwrap());
                i += 1;
            }
            f => files.push(PathBuf::from(f)),
        }
        i += 1;
    }
    let mut res = detect_files(&files, &board, &opts, threads);
    // Repeats: keep each image's fastest detection time (the corners are identical).
    for _ in 1..repeats {
        let again = detect_files(&files, &board, &opts, threads);
        for (r, a) in res.iter_mut().zip(again) {
            if let (Some(t), Some(u)) = (r.detection_seconds, a.detection_seconds) {
                r.detection_seconds = Some(t.min(u));
            }
        }
    }
    let v = observations_json(&res, &board);
    for r in &res {
        if let Err(e) = &r.outcome {
            eprintln!("{}: {e}", r.file_name());
        }
    }
    eprintln!(
        "found {}/{} median {:.3} ms",
        v["views"].as_array().map_or(0, |a| a.len()),
        res.len(),
        v["detection_seconds_per_image"].as_f64().unwrap_or(0.0) * 1e3
    );
    std::fs::write(out, serde_json::to_string(&v).unwrap()).unwrap();
}
