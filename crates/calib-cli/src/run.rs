//! What `calib single` and `calib stereo` share once the options are built: repeated runs for
//! warm timings, failure and warning reporting, the summary and the JSON output.

use crate::{Failure, write_json};
use clap::Args;
use lm_solver::Termination;
use serde_json::Value;
use std::time::Duration;

/// Output arguments of the calibration commands.
#[derive(Args, Debug)]
pub struct OutputArgs {
    /// Write the full result as JSON to this file ("-" for stdout).
    #[arg(short, long, value_name = "RESULT.json")]
    pub output: Option<String>,
    /// Do not print the summary.
    #[arg(short, long)]
    pub quiet: bool,
    /// Run the calibration this many times in one process and report the median time in
    /// `elapsed_seconds` (all times in `elapsed_seconds_all`): a warm timing, like a benchmark's.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub repeat: usize,
}

/// The parts of a calibration result the command line reports.
pub trait Report {
    /// Wall time of the calibration.
    fn elapsed_mut(&mut self) -> &mut Duration;
    /// How the optimization ended.
    fn termination(&self) -> &Termination;
    /// The human summary.
    fn summary(&self) -> String;
    /// The JSON form.
    fn to_json(&self) -> Value;
}

impl Report for calib_single::Calibration {
    fn elapsed_mut(&mut self) -> &mut Duration {
        &mut self.elapsed
    }
    fn termination(&self) -> &Termination {
        &self.solver.termination
    }
    fn summary(&self) -> String {
        calib_single::Calibration::summary(self)
    }
    fn to_json(&self) -> Value {
        calib_single::Calibration::to_json(self)
    }
}

impl Report for calib_stereo::StereoCalibration {
    fn elapsed_mut(&mut self) -> &mut Duration {
        &mut self.elapsed
    }
    fn termination(&self) -> &Termination {
        &self.solver.termination
    }
    fn summary(&self) -> String {
        calib_stereo::StereoCalibration::summary(self)
    }
    fn to_json(&self) -> Value {
        calib_stereo::StereoCalibration::to_json(self)
    }
}

/// A warning line for a solve that stopped without meeting a convergence criterion.
pub fn termination_warning(termination: &Termination) -> Option<String> {
    (!termination.is_converged()).then(|| {
        format!("warning: the optimization {termination}; the result may not be at the minimum")
    })
}

/// Runs `calibrate` `output.repeat` times (at least once), keeps the last result with the median
/// wall time, and reports it: an error for a numerical failure, otherwise the summary on stdout
/// (unless quiet), a warning on stderr when the solver did not converge, and the JSON file.
/// `source` names the input in messages.
pub fn calibrate_and_report<R: Report>(
    source: &str,
    output: &OutputArgs,
    mut calibrate: impl FnMut() -> Result<R, Failure>,
) -> Result<(), Failure> {
    let mut result = calibrate()?;
    let mut times = vec![*result.elapsed_mut()];
    for _ in 1..output.repeat {
        result = calibrate()?;
        times.push(*result.elapsed_mut());
    }
    let all: Vec<f64> = times.iter().map(Duration::as_secs_f64).collect();
    times.sort();
    *result.elapsed_mut() = times[times.len() / 2];
    if let Termination::NumericalFailure(why) = result.termination() {
        return Err(Failure(format!("{source}: calibration failed: {why}")));
    }
    if !output.quiet {
        print!("{}", result.summary());
    }
    if let Some(warning) = termination_warning(result.termination()) {
        eprintln!("calib: {warning}");
    }
    if let Some(path) = &output.output {
        let mut json = result.to_json();
        json["elapsed_seconds_all"] = serde_json::json!(all);
        write_json(path, &json)?;
    }
    Ok(())
}
