//! Writes a stereo observation file from paired image lists:
//! `stereo COLS ROWS SQUARE OUT.json --left L1 L2 ... --right R1 R2 ...` (pairs in order).
use board_detect::{Board, DetectOptions, detect_files, stereo_observations_json};
use std::path::PathBuf;

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let (Some(pos_l), Some(pos_r)) = (
        a.iter().position(|s| s == "--left"),
        a.iter().position(|s| s == "--right"),
    ) else {
        eprintln!("usage: stereo COLS ROWS SQUARE OUT.json --left IMAGES... --right IMAGES...");
        std::process::exit(2);
    };
    if pos_l < 4 || pos_r < pos_l {
        eprintln!("usage: stereo COLS ROWS SQUARE OUT.json --left IMAGES... --right IMAGES...");
        std::process::exit(2);
    }
    let board = Board::new(
        a[0].parse().expect("cols"),
        a[1].parse().expect("rows"),
        a[2].parse().expect("square"),
    )
    .expect("board");
    let left: Vec<PathBuf> = a[pos_l + 1..pos_r].iter().map(PathBuf::from).collect();
    let right: Vec<PathBuf> = a[pos_r + 1..].iter().map(PathBuf::from).collect();
    let opts = DetectOptions::default();
    let l = detect_files(&left, &board, &opts, None);
    let r = detect_files(&right, &board, &opts, None);
    let v = stereo_observations_json(&l, &r, &board);
    eprintln!(
        "{} pairs, {} rejected",
        v["pairs"].as_array().map_or(0, |p| p.len()),
        v["rejected_pairs"].as_array().map_or(0, |p| p.len())
    );
    std::fs::write(&a[3], serde_json::to_string(&v).expect("json")).expect("write");
}
