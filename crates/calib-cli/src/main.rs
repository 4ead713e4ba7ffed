//! The `calib` command: a thin front end over the calibration crates.
//!
//! Exit codes: 0 success; 1 bad input or failed calibration (one-line message on stderr); 2 bad
//! command line (from the argument parser); 128 + the signal (130 Ctrl-C, 143 SIGTERM, 129
//! SIGHUP) when a signal stopped the run, its temporary files removed (module `interrupt`).

mod after;
mod detect;
mod interrupt;
mod rig;
mod run;
mod single;
mod stereo;
mod synth;

use clap::{Parser, Subcommand};
use std::io::Write as _;
use std::process::ExitCode;

/// Camera calibration from detected planar-target corners.
#[derive(Parser)]
#[command(name = "calib", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Calibrate one camera from an observation file (JSON, see docs/formats.md) or from
    /// photographs of a chessboard (--board COLSxROWS --square SIZE IMAGE...).
    Single(single::SingleArgs),
    /// Calibrate a stereo rig from a stereo observation file, or from photographs (--board,
    /// --square, the left images, --right and the right images).
    Stereo(stereo::StereoArgs),
    /// Calibrate a rig of N cameras (any overlap) from a rig observation file, or from photographs (--board, --square, --camera NAME IMAGE... per camera): every camera's
    /// intrinsics, its transform from the reference camera and the board pose of every frame.
    Rig(rig::RigArgs),
    /// Detect a chessboard's corners in photographs and write an observation file.
    Detect(detect::DetectArgs),
    /// Write a calibration result (or any exported file) as OpenCV, ROS or Kalibr YAML.
    Export(after::ExportArgs),
    /// Undistort images with a calibrated camera (new camera matrix chosen like OpenCV's
    /// getOptimalNewCameraMatrix).
    Undistort(after::UndistortArgs),
    /// Stereo rectification (Bouguet's, as OpenCV's stereoRectify): R1, R2, P1, P2, Q as JSON
    /// and rectified images.
    Rectify(after::RectifyArgs),
    /// An HTML report with plots of a calibration result.
    Report(after::ReportArgs),
    /// Write a synthetic observation file with known truth.
    #[command(subcommand)]
    Synth(synth::SynthCommand),
}

/// A failure to report as one line on stderr.
pub struct Failure(pub String);

impl<E: std::fmt::Display> From<E> for Failure {
    fn from(e: E) -> Self {
        Failure(e.to_string())
    }
}

fn main() -> ExitCode {
    let matches = <Cli as clap::CommandFactory>::command().get_matches();
    let mut cli =
        <Cli as clap::FromArgMatches>::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    // clap's derive flattens repeated multi-value options: `--camera NAME IMAGE...` of calib
    // rig and calib detect is regrouped per occurrence here.
    let groups = |m: &clap::ArgMatches| -> Vec<(String, Vec<String>)> {
        m.get_occurrences::<String>("camera_images")
            .into_iter()
            .flatten()
            .map(|mut group| {
                let name = group.next().cloned().unwrap_or_default();
                (name, group.cloned().collect())
            })
            .collect()
    };
    match (&mut cli.command, matches.subcommand()) {
        (Command::Rig(args), Some(("rig", m))) => args.cameras = groups(m),
        (Command::Detect(args), Some(("detect", m))) => args.cameras = groups(m),
        _ => {}
    }
    interrupt::install();
    let result = match cli.command {
        Command::Single(args) => single::run(&args),
        Command::Stereo(args) => stereo::run(&args),
        Command::Rig(args) => rig::run(&args),
        Command::Detect(args) => detect::run(&args),
        Command::Export(args) => after::run_export(&args),
        Command::Undistort(args) => after::run_undistort(&args),
        Command::Rectify(args) => after::run_rectify(&args),
        Command::Report(args) => after::run_report(&args),
        Command::Synth(command) => synth::run(&command),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure(message)) => {
            interrupt::wait_if_stopping();
            let _ = writeln!(std::io::stderr(), "calib: {message}");
            ExitCode::from(1)
        }
    }
}

/// Writes JSON to a file (atomically: a failure leaves any previous file intact), or to stdout
/// for "-".
pub fn write_json(path: &str, value: &serde_json::Value) -> Result<(), Failure> {
    let text = serde_json::to_string_pretty(value)? + "\n";
    if path == "-" {
        print_stdout(&text)
    } else {
        calib_core::write_atomically(std::path::Path::new(path), text.as_bytes())
            .map_err(|e| Failure(format!("cannot write {path}: {e}")))
    }
}

/// Creates the output folder `dir` (of `option`) if needed; a file in its place is named as such
/// (instead of "File exists").
pub fn create_folder(dir: &std::path::Path, option: &str) -> Result<(), Failure> {
    if dir.exists() && !dir.is_dir() {
        return Err(Failure(format!(
            "{option} {}: that is a file, not a folder; give a folder for the output files",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir).map_err(|e| Failure(format!("{option} {}: {e}", dir.display())))
}

/// Writes to stdout, reporting a closed pipe or a full disk as a failure instead of panicking
/// like `print!`.
pub fn print_stdout(text: &str) -> Result<(), Failure> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .map_err(|e| Failure(format!("cannot write to standard output: {e}")))
}

/// Where a command's human lines (summaries, files written) go: standard output, standard
/// error (when the result JSON itself goes to standard output, `-o -`), or nowhere (`-q`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Say {
    Stdout,
    Stderr,
    Nothing,
}

impl Say {
    /// Prints `text` where this says.
    pub fn text(self, text: &str) -> Result<(), Failure> {
        match self {
            Say::Stdout => print_stdout(text),
            Say::Stderr => {
                use std::io::Write;
                let _ = std::io::stderr().write_all(text.as_bytes());
                Ok(())
            }
            Say::Nothing => Ok(()),
        }
    }
}

/// Parses `a,b,c` into numbers.
pub fn parse_list(text: &str, expected: usize, what: &str) -> Result<Vec<f64>, Failure> {
    let items: Vec<&str> = text.split(',').map(str::trim).collect();
    if items.len() != expected {
        return Err(Failure(format!(
            "{what}: expected {expected} comma-separated numbers, got {} in '{text}'",
            items.len()
        )));
    }
    items
        .iter()
        .enumerate()
        .map(|(i, item)| match item.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(Failure(format!(
                "{what}: value {} of {expected}, '{item}', is not a finite number",
                i + 1
            ))),
        })
        .collect()
}

/// Most threads `--threads` takes: far above any core count, and below the thousands that made
/// the system refuse (or take minutes) to create them.
pub const MAX_THREADS: usize = 1024;

/// Parses `--threads`: 0 (every core) to [`MAX_THREADS`].
pub fn parse_threads(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if n <= MAX_THREADS => Ok(n),
        _ => Err(format!(
            "expected 0 (every core) to {MAX_THREADS} threads, got '{text}'"
        )),
    }
}

/// Parses `WxH`.
pub fn parse_size(text: &str, what: &str) -> Result<(u32, u32), Failure> {
    let parts: Vec<&str> = text.split(['x', 'X']).collect();
    if let [a, b] = parts.as_slice()
        && let (Ok(a), Ok(b)) = (a.trim().parse(), b.trim().parse())
    {
        return Ok((a, b));
    }
    Err(Failure(format!(
        "{what}: expected WIDTHxHEIGHT, got '{text}'"
    )))
}
