//! Writes overlay PNGs of detections: `overlay COLS ROWS OUT_DIR IMAGES...`.
use board_detect::{Board, DetectOptions, detect_image, load_gray, write_overlay_png};
use std::path::{Path, PathBuf};

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    if a.len() < 4 {
        eprintln!("usage: overlay COLS ROWS OUT_DIR IMAGES...");
        std::process::exit(2);
    }
    let board = Board::new(
        a[0].parse().expect("cols"),
        a[1].parse().expect("rows"),
        1.0,
    )
    .expect("board");
    let out = PathBuf::from(&a[2]);
    let opts = DetectOptions::default();
    for f in &a[3..] {
        let path = Path::new(f);
        let img = match load_gray(path, &opts) {
            Ok(i) => i,
            Err(e) => {
                eprintln!("{f}: {e}");
                continue;
            }
        };
        let det = detect_image(&img, &board, &opts);
        if let Err(e) = &det {
            eprintln!("{f}: {e}");
        }
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let target = out.join(format!("{name}.png"));
        if let Err(e) = write_overlay_png(&target, &img, &board, det.as_ref().ok()) {
            eprintln!("{e}");
        }
    }
}
