//! What `calib single` and `calib stereo` share once the options are built: repeated runs for
//! warm timings, failure and warning reporting, the summary and the JSON output.

use crate::{Failure, Say, write_json};
use clap::Args;
use lm_solver::Termination;
use serde_json::Value;
use std::io::Write as _;
use std::time::Duration;

/// Output arguments of the calibration commands.
#[derive(Args, Debug)]
pub struct OutputArgs {
    /// Write the full result as JSON to this file ("-" for stdout). A previous file is replaced
    /// whole, only once the run has succeeded (a failed or interrupted run leaves it as it was);
    /// a read-only one is refused.
    #[arg(short, long, value_name = "RESULT.json")]
    pub output: Option<String>,
    /// Do not print the summary.
    #[arg(short, long)]
    pub quiet: bool,
    /// Run the calibration this many times in one process and report the median time in
    /// `elapsed_seconds` (all times in `elapsed_seconds_all`): a warm timing, like a benchmark's
    /// (1 to 10000).
    #[arg(long, default_value_t = 1, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=10000))]
    pub repeat: u32,
    /// Also write the result for another tool: FORMAT=FILE with FORMAT opencv, ros or kalibr
    /// (repeatable; see calib export).
    #[arg(long, value_name = "FORMAT=FILE")]
    pub export: Vec<String>,
    /// Write an HTML report with plots (residuals, mean residuals, residual scatter, coverage,
    /// per-view RMS, board poses, distortion, projection uncertainty) into DIR (see calib
    /// report; other files in DIR are left alone).
    #[arg(long, value_name = "DIR")]
    pub report: Option<std::path::PathBuf>,
    /// Refuse input files larger than this many megabytes.
    #[arg(long, default_value_t = 2048, value_name = "MB")]
    pub max_input_mb: u64,
}

impl OutputArgs {
    /// Whether the result JSON goes to standard output (`-o -`): the human text (summaries,
    /// files written) then goes to standard error, so that standard output is the JSON alone.
    pub fn json_to_stdout(&self) -> bool {
        self.output.as_deref() == Some("-")
    }

    /// Where human text (summaries, files written) goes: standard output, or standard error
    /// when the JSON goes to standard output; nowhere when quiet.
    pub fn say(&self) -> Say {
        if self.quiet {
            Say::Nothing
        } else if self.json_to_stdout() {
            Say::Stderr
        } else {
            Say::Stdout
        }
    }

    /// The input size limit in bytes.
    pub fn max_input(&self) -> u64 {
        self.max_input_mb.saturating_mul(1 << 20)
    }

    /// Refuses, before any work, output files (`-o`, `--export`) whose directory does not exist, and
    /// a `--report` folder that is a file:
    /// found after the calibration, the failure would come after some files were written.
    pub fn check_directories(&self, targets: &[crate::after::ExportTarget]) -> Result<(), Failure> {
        if let Some(dir) = self.report.as_deref().filter(|d| d.exists() && !d.is_dir()) {
            // A file where the report's folder should be: refused before the result is written.
            crate::create_folder(dir, "--report")?;
        }
        let outputs = self
            .output
            .iter()
            .filter(|o| o.as_str() != "-")
            .map(|o| ("-o".to_string(), std::path::PathBuf::from(o)))
            .chain(
                targets
                    .iter()
                    .map(|t| (format!("--export {}=", t.format), t.path.clone())),
            );
        for (option, path) in outputs {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty())
                && !dir.is_dir()
            {
                return Err(Failure(format!(
                    "{option}{}{}: the directory {} does not exist",
                    if option == "-o" { " " } else { "" },
                    path.display(),
                    dir.display()
                )));
            }
        }
        Ok(())
    }

    /// Refuses an output path that names one of the inputs: the result would replace the data.
    pub fn check_against(&self, inputs: &[&str]) -> Result<(), Failure> {
        if let Some(out) = &self.output {
            check_not_input(out, inputs)?;
        }
        for target in crate::after::export_targets(&self.export)? {
            check_not_input(&target.path.to_string_lossy(), inputs)?;
        }
        Ok(())
    }
}

/// Fails if `output` is the same file as one of `inputs` (after resolving links and `..`).
pub fn check_not_input(output: &str, inputs: &[&str]) -> Result<(), Failure> {
    if output == "-" {
        return Ok(());
    }
    let resolve = |p: &str| {
        let path = std::path::Path::new(p);
        std::fs::canonicalize(path).ok().or_else(|| {
            // A new file: resolve its directory.
            let parent = path.parent().filter(|d| !d.as_os_str().is_empty());
            let dir = std::fs::canonicalize(parent.unwrap_or(std::path::Path::new("."))).ok()?;
            Some(dir.join(path.file_name()?))
        })
    };
    let out = resolve(output);
    for input in inputs {
        if out.is_some() && out == resolve(input) {
            return Err(Failure(format!(
                "-o {output}: that is the input file {input}; choose another output path"
            )));
        }
    }
    Ok(())
}

/// The parts of a calibration result the command line reports.
pub trait Report {
    /// Wall time of the calibration.
    fn elapsed_mut(&mut self) -> &mut Duration;
    /// How the optimization ended.
    fn termination(&self) -> &Termination;
    /// The result's warnings.
    fn warnings(&self) -> &[calib_core::Warning];
    /// The result's warnings, to add one.
    fn warnings_mut(&mut self) -> &mut Vec<calib_core::Warning>;
    /// The human summary.
    fn summary(&self) -> String;
    /// The JSON form.
    fn to_json(&self) -> Value;
    /// The calibration for exports.
    fn calibrated(&self) -> calib_export::Calibrated;
}

/// [`Report`] for a result type with `elapsed`, `solver`, `warnings`, `summary()` and
/// `to_json()`, exported as the `Calibrated` variant `$variant` of `$export::from(result)`.
macro_rules! report_for {
    ($result:ty, $variant:ident, $export:ty) => {
        impl Report for $result {
            fn elapsed_mut(&mut self) -> &mut Duration {
                &mut self.elapsed
            }
            fn termination(&self) -> &Termination {
                &self.solver.termination
            }
            fn warnings(&self) -> &[calib_core::Warning] {
                &self.warnings
            }
            fn warnings_mut(&mut self) -> &mut Vec<calib_core::Warning> {
                &mut self.warnings
            }
            fn summary(&self) -> String {
                <$result>::summary(self)
            }
            fn to_json(&self) -> Value {
                <$result>::to_json(self)
            }
            fn calibrated(&self) -> calib_export::Calibrated {
                calib_export::Calibrated::$variant(<$export>::from(self))
            }
        }
    };
}

report_for!(
    calib_single::Calibration,
    Single,
    calib_export::CameraCalibration
);
report_for!(
    calib_stereo::StereoCalibration,
    Stereo,
    calib_export::StereoRig
);
report_for!(calib_rig::RigCalibration, Rig, calib_export::CameraRig);

/// Runs `calibrate` `output.repeat` times (at least once), keeps the last result with the median
/// wall time, and reports it: an error for a numerical failure, otherwise the summary on stdout
/// (unless quiet; it lists the warnings; on stderr when the JSON goes to stdout), the warnings
/// on stderr when quiet, and the JSON file (written atomically), then the exports (`--export`).
/// `source` names the input in messages; `inputs` are the input files (never overwritten).
/// `skipped`: the images a calibration from photographs left out, added to the result as the
/// `images-skipped` warning and the JSON's `rejected_images` / `rejected_pairs`.
pub fn calibrate_and_report<R: Report>(
    source: &str,
    inputs: &[&str],
    output: &OutputArgs,
    skipped: Option<&crate::detect::Skipped>,
    mut calibrate: impl FnMut() -> Result<R, Failure>,
) -> Result<R, Failure> {
    let targets = crate::after::export_targets(&output.export)?;
    output.check_directories(&targets)?;
    let mut result = calibrate()?;
    let mut times = vec![*result.elapsed_mut()];
    for _ in 1..output.repeat.max(1) {
        result = calibrate()?;
        times.push(*result.elapsed_mut());
    }
    let all: Vec<f64> = times.iter().map(Duration::as_secs_f64).collect();
    times.sort();
    *result.elapsed_mut() = times[times.len() / 2];
    if let Termination::NumericalFailure(why) = result.termination() {
        return Err(Failure(format!("{source}: calibration failed: {why}")));
    }
    if let Some(warning) = skipped.and_then(crate::detect::Skipped::warning) {
        result.warnings_mut().push(warning);
    }
    if !output.quiet {
        output.say().text(&result.summary())?;
    } else {
        for w in result.warnings() {
            let _ = writeln!(std::io::stderr(), "calib: {w}");
        }
    }
    // Every export is rendered before anything is written: a failing one leaves all files as
    // they were.
    let exports = if targets.is_empty() {
        crate::after::RenderedExports::default()
    } else {
        crate::after::render_exports(&result.calibrated(), &targets, inputs)?
    };
    if let Some(path) = &output.output {
        let mut json = result.to_json();
        json["elapsed_seconds_all"] = serde_json::json!(all);
        if let Some(skipped) = skipped {
            json[skipped.key] = Value::Array(skipped.entries.clone());
        }
        write_json(path, &json)?;
    }
    crate::after::write_rendered(&exports, output.say())?;
    Ok(result)
}
