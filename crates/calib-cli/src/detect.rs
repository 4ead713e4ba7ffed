//! `calib detect`, and the `--board` path of `calib single` / `calib stereo`: chessboard corners
//! from photographs (crate `board-detect`, `docs/board-detect.md`).

use crate::{Failure, parse_size, write_json};
use board_detect::{Board, DetectOptions, ImageResult, detect_file, write_overlay_png};
use clap::Args;
use serde_json::Value;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The board and detection options shared by `calib detect`, `calib single` and `calib stereo`.
#[derive(Args, Debug, Clone)]
pub struct BoardArgs {
    /// Chessboard inner corners COLSxROWS (a 9x6 board has 10x7 squares). With it, the inputs
    /// of `calib single` and `calib stereo` are images instead of an observation file.
    #[arg(long, value_name = "COLSxROWS")]
    pub board: Option<String>,
    /// Side of a square, in the unit the translations should have (mm, m, ...).
    #[arg(long, default_value_t = 1.0, value_name = "SIZE")]
    pub square: f64,
    /// Write each image as PNG into DIR with the detected corners, their labels and the board
    /// outline drawn.
    #[arg(long, value_name = "DIR")]
    pub draw: Option<PathBuf>,
}

impl BoardArgs {
    /// The board, if `--board` was given.
    pub fn board(&self) -> Result<Option<Board>, Failure> {
        let Some(text) = &self.board else {
            return Ok(None);
        };
        let (cols, rows) = parse_size(text, "--board")?;
        Board::new(cols as usize, rows as usize, self.square)
            .map(Some)
            .map_err(|e| Failure(format!("--board {text} --square {}: {e}", self.square)))
    }
}

/// Arguments of `calib detect`.
#[derive(Args, Debug)]
#[command(mut_arg("board", |a| a.required(true)))]
pub struct DetectArgs {
    /// Images (JPEG or PNG) of the left or only camera.
    #[arg(required = true, value_name = "IMAGE")]
    pub images: Vec<PathBuf>,
    /// Images of the right camera, paired in order with the others: writes the stereo
    /// observation file.
    #[arg(long, num_args = 1.., value_name = "IMAGE")]
    pub right: Vec<PathBuf>,
    #[command(flatten)]
    pub board: BoardArgs,
    /// Observation file to write ("-" for stdout).
    #[arg(short, long, value_name = "OBS.json")]
    pub output: String,
    /// Threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// No summary line.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Detects the board in every image (in parallel, with a progress line on a terminal when there
/// are more than a few images), drawing overlays if asked.
pub fn detect_all(
    paths: &[PathBuf],
    board: &Board,
    args: &BoardArgs,
    threads: usize,
    label: &str,
) -> Result<Vec<ImageResult>, Failure> {
    use rayon::prelude::*;
    if let Some(dir) = &args.draw {
        std::fs::create_dir_all(dir)
            .map_err(|e| Failure(format!("--draw {}: {e}", dir.display())))?;
    }
    let options = DetectOptions::default();
    let done = AtomicUsize::new(0);
    let total = paths.len();
    let progress = total > 4 && std::io::stderr().is_terminal();
    let run = || {
        paths
            .par_iter()
            .map(|p| {
                let r = detect_file(p, board, &options);
                if let Some(dir) = &args.draw {
                    draw(dir, p, board, &r, &options);
                }
                let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                if progress {
                    let _ = write!(std::io::stderr(), "\rdetecting {label}{n}/{total}");
                }
                r
            })
            .collect::<Vec<_>>()
    };
    let results = if threads == 0 {
        run()
    } else {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| Failure(format!("--threads {threads}: {e}")))?
            .install(run)
    };
    if progress {
        let _ = write!(std::io::stderr(), "\r{:40}\r", "");
    }
    Ok(results)
}

/// Writes the overlay of one image (a failure to draw is reported, not fatal).
fn draw(dir: &Path, path: &Path, board: &Board, result: &ImageResult, options: &DetectOptions) {
    let Ok(image) = board_detect::load_gray(path, options) else {
        return;
    };
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "image".into());
    let out = dir.join(format!("{stem}.png"));
    if let Err(e) = write_overlay_png(&out, &image, board, result.outcome.as_ref().ok()) {
        let _ = writeln!(
            std::io::stderr(),
            "calib: cannot draw {}: {e}",
            out.display()
        );
    }
}

/// A one-line summary of a detection run (and the rejected images, one per line).
pub fn summary(results: &[ImageResult], file: &Value) -> String {
    let found = results.iter().filter(|r| r.outcome.is_ok()).count();
    let mut out = format!("detected the board in {found} of {} images", results.len());
    if let Some(t) = file["detection_seconds_per_image"].as_f64() {
        out += &format!(" ({:.2} ms per image)", t * 1e3);
    }
    out.push('\n');
    for key in ["rejected_images", "rejected_pairs"] {
        for r in file[key].as_array().into_iter().flatten() {
            let name = r["image"].as_str().map(str::to_string).unwrap_or_else(|| {
                format!(
                    "{} / {}",
                    r["left_image"].as_str().unwrap_or("-"),
                    r["right_image"].as_str().unwrap_or("-")
                )
            });
            out += &format!(
                "  rejected {name}: {}\n",
                r["reason"].as_str().unwrap_or("")
            );
        }
    }
    out
}

/// Detects the board in single-camera images and returns the observation file.
pub fn single_observations(
    paths: &[PathBuf],
    board: &Board,
    args: &BoardArgs,
    threads: usize,
) -> Result<(Vec<ImageResult>, Value), Failure> {
    let results = detect_all(paths, board, args, threads, "")?;
    let file = board_detect::observations_json(&results, board);
    Ok((results, file))
}

/// Detects the board in paired images and returns the stereo observation file.
pub fn stereo_observations(
    left: &[PathBuf],
    right: &[PathBuf],
    board: &Board,
    args: &BoardArgs,
    threads: usize,
) -> Result<(Vec<ImageResult>, Value), Failure> {
    if left.len() != right.len() {
        return Err(Failure(format!(
            "{} left images but {} right images: the pairs are matched in order, so the counts must be equal",
            left.len(),
            right.len()
        )));
    }
    let l = detect_all(left, board, args, threads, "left ")?;
    let r = detect_all(right, board, args, threads, "right ")?;
    let file = board_detect::stereo_observations_json(&l, &r, board);
    let mut all = l;
    all.extend(r);
    Ok((all, file))
}

pub fn run(args: &DetectArgs) -> Result<(), Failure> {
    let board = args
        .board
        .board()?
        .ok_or_else(|| Failure("--board COLSxROWS is required".into()))?;
    crate::run::check_not_input(
        &args.output,
        &args
            .images
            .iter()
            .chain(&args.right)
            .map(|p| p.to_str().unwrap_or(""))
            .collect::<Vec<_>>(),
    )?;
    let (results, file) = if args.right.is_empty() {
        single_observations(&args.images, &board, &args.board, args.threads)?
    } else {
        stereo_observations(&args.images, &args.right, &board, &args.board, args.threads)?
    };
    write_json(&args.output, &file)?;
    if !args.quiet {
        let _ = write!(std::io::stderr(), "{}", summary(&results, &file));
    }
    Ok(())
}
