//! Development harness: repeat the detection of one image many times (for `perf`).
//! `cargo run --release -p board-detect --example profile -- IMAGE COLS ROWS REPEATS`
use board_detect::{Board, DetectOptions, detect_image, load_gray};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    if a.len() < 4 {
        eprintln!("usage: profile IMAGE COLS ROWS REPEATS");
        std::process::exit(2);
    }
    let opts = DetectOptions::default();
    let img = load_gray(std::path::Path::new(&a[0]), &opts).expect("image");
    let board = Board::new(a[1].parse().unwrap(), a[2].parse().unwrap(), 1.0).unwrap();
    let n: usize = a[3].parse().unwrap();
    let mut times = Vec::new();
    for _ in 0..n {
        let t = Instant::now();
        let r = detect_image(&img, &board, &opts);
        times.push(t.elapsed().as_secs_f64());
        assert!(r.is_ok(), "{r:?}");
    }
    times.sort_by(f64::total_cmp);
    println!(
        "min {:.3} ms median {:.3} ms",
        times[0] * 1e3,
        times[n / 2] * 1e3
    );
}
