//! `calib single`: calibrate one camera.

use crate::detect::{self, BoardArgs};
use crate::run::{OutputArgs, calibrate_and_report};
use crate::{Failure, parse_list};
use calib_core::JsonFile;
use calib_core::OutlierRejection;
use calib_single::{CalibrationOptions, FocalInit, Observations, calibrate};
use camera_model::{CameraModel, Intrinsics, RotationKind};
use clap::{Args, ValueEnum};
use lm_solver::{DampingPolicy, Loss};
use std::path::PathBuf;

/// Options shared by the single and stereo commands.
#[derive(Args, Debug, Clone)]
pub struct CameraArgs {
    /// Lens model: brown-conrady4 (k1 k2 p1 p2), brown-conrady5 (+k3, OpenCV's default),
    /// rational8, thin-prism12, kannala-brandt4 (fisheye). Also accepted: plumb_bob,
    /// rational_polynomial, equidistant, fisheye.
    /// [default: brown-conrady4, or the model of --intrinsics]. calib rig also takes
    /// NAME=MODEL for one camera (repeatable).
    #[arg(long, value_name = "MODEL")]
    pub model: Vec<String>,
    /// Start from the camera in FILE: a calib result (JSON) or an exported OpenCV, ROS or Kalibr
    /// file (its model, intrinsics and distortion; the image size must match). calib stereo
    /// takes a rig's file here, and single cameras' files with --left-intrinsics and
    /// --right-intrinsics. calib rig takes NAME=FILE per camera (repeatable).
    #[arg(long, value_name = "FILE")]
    pub intrinsics: Vec<String>,
    /// Hold the intrinsics and distortion of --intrinsics (or --left/--right-intrinsics) fixed:
    /// only the poses (and a stereo rig's R, T) are estimated. calib rig always holds the
    /// cameras of --intrinsics NAME=FILE fixed.
    #[arg(long)]
    pub fix_intrinsics: bool,
    /// Hold the principal point at the image centre (or at --guess).
    #[arg(long)]
    pub fix_principal_point: bool,
    /// Hold fx/fy at its initial value (1, or the ratio of --guess).
    #[arg(long)]
    pub fix_aspect_ratio: bool,
    /// Hold the tangential distortion p1, p2 at zero.
    #[arg(long)]
    pub zero_tangential: bool,
    /// Hold these distortion coefficients at their initial value, e.g. --fix k2 or --fix k1,k2
    /// (repeatable). calib stereo, calib rig and --compare-models hold each name in every camera
    /// (model) that has it; calib stereo and calib rig also take CAMERA=NAMES for one camera
    /// (--fix right=k3,k4; stereo cameras are left and right). Names in any case (K3 = k3).
    #[arg(long, value_name = "NAMES", value_parser = coefficient_names_lowercase)]
    pub fix: Vec<String>,
    /// Start from these intrinsics instead of the closed-form guess: fx,fy,cx,cy (pixels).
    #[arg(long, value_name = "FX,FY,CX,CY", allow_hyphen_values = true)]
    pub guess: Option<String>,
    /// Initial distortion coefficients in the model's order, e.g. k1,k2,p1,p2 (default zero).
    #[arg(long, value_name = "K1,K2,...", allow_hyphen_values = true)]
    pub distortion_guess: Option<String>,
    /// Rotation parameterization of the poses during the optimization [default: euler for
    /// calib single; so3 for calib stereo and calib rig, whose cameras may face any direction].
    #[arg(long, value_enum)]
    pub rotation: Option<Rotation>,
    /// How the closed-form focal length is solved.
    #[arg(long, value_enum, default_value_t = FocalMethod::Bouguet)]
    pub focal_init: FocalMethod,
    /// Skip views that fail the checks (listed in the result) instead of stopping.
    #[arg(long)]
    pub skip_bad_views: bool,
    /// Use every point: no outlier rejection (OpenCV's behaviour).
    #[arg(long)]
    pub no_outlier_rejection: bool,
    /// Reject points whose error exceeds this many robust standard deviations of the noise
    /// (and 1 px), then solve again.
    #[arg(long, default_value_t = 5.0, value_name = "SIGMAS")]
    pub outlier_threshold: f64,
    /// Robust loss on each point's error (on top of or instead of outlier rejection).
    #[arg(long, value_enum, default_value_t = LossKind::None)]
    pub loss: LossKind,
    /// Scale of the robust loss, pixels: errors below it count in full.
    #[arg(long, default_value_t = 1.0, value_name = "PX")]
    pub loss_scale: f64,
    /// Maximum Levenberg-Marquardt step attempts.
    #[arg(long, default_value_t = 500)]
    pub max_iterations: usize,
    /// Damping policy of Levenberg-Marquardt.
    #[arg(long, value_enum, default_value_t = Damping::Hybrid)]
    pub damping: Damping,
    /// Threads (0 = all cores, at most 1024). The result does not depend on it.
    #[arg(long, default_value_t = 0, value_parser = crate::parse_threads)]
    pub threads: usize,
}

#[derive(ValueEnum, Debug, Clone, Copy)]
pub enum Rotation {
    /// Euler angles X-Y-Z (R = Rz Ry Rx).
    Euler,
    /// Rotation vector (Rodrigues).
    AxisAngle,
    /// Rotation vector updated on the rotation manifold (no singular rotation).
    So3,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum LossKind {
    /// Least squares.
    None,
    /// Huber: quadratic up to the scale, linear beyond.
    Huber,
    /// Cauchy: the influence of far points decays like 1/error.
    Cauchy,
}

#[derive(ValueEnum, Debug, Clone, Copy)]
pub enum FocalMethod {
    /// x = <b,b>/<a,b> (Bouguet's toolbox).
    Bouguet,
    /// Least squares.
    LeastSquares,
}

#[derive(ValueEnum, Debug, Clone, Copy)]
pub enum Damping {
    /// lambda I, lambda0 = 0.01, factor 10 (the specification's).
    Additive,
    /// lambda diag(J^T J) with Nielsen's update (Ceres-like).
    Marquardt,
    /// Additive for 20 step attempts, then Marquardt (the default).
    Hybrid,
}

/// The one plain value of a repeatable option (`None` if absent); `NAME=VALUE` forms are for
/// calib rig's cameras and refused here, as is a second plain value.
pub fn single_value<'a>(values: &'a [String], option: &str) -> Result<Option<&'a str>, Failure> {
    let (plain, named) = split_named(values);
    if let Some((name, _)) = named.first() {
        return Err(Failure(format!(
            "{option} {name}=...: a value per camera name is for calib rig; give one {option}"
        )));
    }
    match plain.as_slice() {
        [] => Ok(None),
        [one] => Ok(Some(one)),
        _ => Err(Failure(format!("{option} given {} times", plain.len()))),
    }
}

/// Splits a repeatable option's values into plain ones and `NAME=VALUE` pairs.
pub fn split_named(values: &[String]) -> (Vec<&str>, Vec<(&str, &str)>) {
    let mut plain = Vec::new();
    let mut named = Vec::new();
    for v in values {
        match v.split_once('=') {
            Some((name, value)) => named.push((name.trim(), value.trim())),
            None => plain.push(v.as_str()),
        }
    }
    (plain, named)
}

/// `--fix` value parser: coefficient names in lower case (OpenCV users write `K3`), the camera
/// name of `CAMERA=NAMES` as given (camera names are case-sensitive).
fn coefficient_names_lowercase(value: &str) -> Result<String, String> {
    Ok(match value.split_once('=') {
        Some((camera, names)) => format!("{camera}={}", names.to_ascii_lowercase()),
        None => value.to_ascii_lowercase(),
    })
}

impl CameraArgs {
    /// The `--model` value (one, without a camera name).
    pub fn model_name(&self) -> Result<Option<&str>, Failure> {
        single_value(&self.model, "--model")
    }

    /// The `--intrinsics` file (one, without a camera name).
    pub fn intrinsics_file(&self) -> Result<Option<&str>, Failure> {
        single_value(&self.intrinsics, "--intrinsics")
    }

    /// The `--fix` names for every camera (the values without `CAMERA=`), split at commas.
    pub fn fix_names(&self) -> Vec<&str> {
        split_named(&self.fix)
            .0
            .into_iter()
            .flat_map(|names| names.split(','))
            .map(str::trim)
            .filter(|n| !n.is_empty())
            .collect()
    }

    /// The `--fix CAMERA=NAMES` values: camera name and its names, split at commas.
    pub fn fix_per_camera(&self) -> Vec<(&str, Vec<&str>)> {
        split_named(&self.fix)
            .1
            .into_iter()
            .map(|(camera, names)| {
                let names = names
                    .split(',')
                    .map(str::trim)
                    .filter(|n| !n.is_empty())
                    .collect();
                (camera, names)
            })
            .collect()
    }

    /// Refuses `--fix CAMERA=NAMES` where there is one camera.
    fn no_fix_per_camera(&self) -> Result<(), Failure> {
        match self.fix_per_camera().first() {
            Some((camera, _)) => Err(Failure(format!(
                "--fix {camera}=...: a value per camera is for calib stereo (left, right) and calib rig; give the names alone"
            ))),
            None => Ok(()),
        }
    }

    /// The library options without `--fix`, for commands that hold its names per camera
    /// ([`hold_present`]).
    pub fn options_without_fix(&self, model: Option<&str>) -> Result<CalibrationOptions, Failure> {
        let mut plain = self.clone();
        plain.fix.clear();
        plain.options_for(model)
    }

    /// The library options these arguments describe (for one camera: `--fix CAMERA=...` is
    /// refused).
    pub fn options(&self) -> Result<CalibrationOptions, Failure> {
        self.no_fix_per_camera()?;
        self.options_for(self.model_name()?)
    }

    /// The library options with the lens model `model` (default brown-conrady4) instead of
    /// `--model`'s.
    pub fn options_for(&self, model: Option<&str>) -> Result<CalibrationOptions, Failure> {
        let model: CameraModel = model
            .unwrap_or("brown-conrady4")
            .parse()
            .map_err(|e| Failure(format!("--model: {e}")))?;
        let mut options = CalibrationOptions::default();
        options.model = model;
        options.fix_principal_point = self.fix_principal_point;
        options.fix_aspect_ratio = self.fix_aspect_ratio;
        options.zero_tangential_distortion = self.zero_tangential;
        options.skip_bad_views = self.skip_bad_views;
        options.rotation = match self.rotation.unwrap_or(Rotation::Euler) {
            Rotation::Euler => RotationKind::EulerXyz,
            Rotation::AxisAngle => RotationKind::AxisAngle,
            Rotation::So3 => RotationKind::So3,
        };
        options.focal_init = match self.focal_init {
            FocalMethod::Bouguet => FocalInit::Bouguet,
            FocalMethod::LeastSquares => FocalInit::LeastSquares,
        };
        options
            .fix_distortion_by_name(&self.fix_names())
            .map_err(|e| Failure(format!("--fix: {e}")))?;
        if let Some(text) = &self.guess {
            let v = parse_list(text, 4, "--guess")?;
            options.intrinsic_guess = Some(Intrinsics::new(v[0], v[1], v[2], v[3]));
        }
        if let Some(text) = &self.distortion_guess {
            options.distortion_guess = Some(parse_list(
                text,
                model.num_distortion_params(),
                "--distortion-guess",
            )?);
        }
        if !(self.outlier_threshold.is_finite() && self.outlier_threshold >= 2.0) {
            return Err(Failure(format!(
                "--outlier-threshold: expected a number of sigmas of at least 2, got {}",
                self.outlier_threshold
            )));
        }
        options.outliers = (!self.no_outlier_rejection)
            .then(|| OutlierRejection::with_threshold(self.outlier_threshold));
        if !(self.loss_scale.is_finite() && self.loss_scale > 0.0) {
            return Err(Failure(format!(
                "--loss-scale: expected a positive number of pixels, got {}",
                self.loss_scale
            )));
        }
        options.loss = match self.loss {
            LossKind::None => Loss::Trivial,
            LossKind::Huber => Loss::Huber(self.loss_scale),
            LossKind::Cauchy => Loss::Cauchy(self.loss_scale),
        };
        if self.max_iterations == 0 || self.max_iterations > 1_000_000 {
            return Err(Failure(format!(
                "--max-iterations: expected 1 to 1000000, got {}",
                self.max_iterations
            )));
        }
        options.solver.max_iterations = self.max_iterations;
        options.solver.num_threads = self.threads;
        options.solver.damping = match self.damping {
            Damping::Additive => DampingPolicy::additive(),
            Damping::Hybrid => DampingPolicy::hybrid(),
            Damping::Marquardt => DampingPolicy::marquardt(),
        };
        Ok(options)
    }
}

/// Arguments of `calib single`.
#[derive(Args, Debug)]
pub struct SingleArgs {
    /// Observation file (JSON), or images of the board with --board.
    #[arg(required = true, value_name = "OBS.json | IMAGE...")]
    pub inputs: Vec<String>,
    #[command(flatten)]
    pub board: BoardArgs,
    #[command(flatten)]
    pub output: OutputArgs,
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Instead of one calibration, fit every lens model and print a table: RMS, parameters,
    /// validity over the image, and the cross-validated RMS (fitted on half of the views,
    /// evaluated on the other half, both ways), with a recommendation. -o writes the table as
    /// JSON.
    #[arg(long)]
    pub compare_models: bool,
    /// Also estimate the camera's standard deviations with a view bootstrap: N times, draw as
    /// many views as were used (with replacement, seeded: the same every run), calibrate them as
    /// the views were (no outlier rejection: the rejected points left out), and report each
    /// parameter's spread about the estimate (`bootstrap` in the JSON, printed next to the
    /// linearized sigmas; a `bootstrap-spread` warning where it exceeds them 3x). Worth it for
    /// rational8 and thin-prism12, whose linearized principal-point sigmas are several times too
    /// small (docs/camera-model.md). Costs about N calibrations (10 to 10000)
    #[arg(long, value_name = "N", conflicts_with = "compare_models", value_parser = clap::value_parser!(u32).range(10..=10000))]
    pub bootstrap: Option<u32>,
    /// Start each --bootstrap refit at the calibration's solution instead of calibrating the
    /// resample from the start as the views were: no faster, and on rational8 and thin-prism12
    /// the refits stay near the calibration's minimum and the spread comes out too small (kept
    /// for comparison; docs/camera-model.md). Hidden from --help: it is the worse choice
    #[arg(long, requires = "bootstrap", hide = true)]
    pub bootstrap_warm: bool,
    /// Seed of --bootstrap's resampling (default 1): another seed draws other resamples
    #[arg(long, value_name = "SEED", requires = "bootstrap")]
    pub bootstrap_seed: Option<u64>,
}

/// The observation file named by `inputs`, or the observations detected in the images `inputs`
/// with `--board`; and a name for messages.
fn observations(
    args: &SingleArgs,
) -> Result<(Observations, String, Option<detect::Skipped>), Failure> {
    let inputs: Vec<&str> = args.inputs.iter().map(String::as_str).collect();
    args.output.check_against(&inputs)?;
    detect::refuse_frames_by_number(&args.board, "calib single")?;
    match args.board.board()? {
        Some(board) => {
            let paths: Vec<PathBuf> = args.inputs.iter().map(PathBuf::from).collect();
            let (results, file) =
                detect::single_observations(&paths, &board, &args.board, args.camera.threads)?;
            args.output.say().text(&detect::summary(&results, &file))?;
            let skipped = detect::Skipped::from_file(&file, paths.len());
            let observations = Observations::from_file(serde_json::from_value(file)?);
            Ok((
                observations,
                format!("{} images", args.inputs.len()),
                Some(skipped),
            ))
        }
        None => {
            let [path] = inputs.as_slice() else {
                return Err(Failure(format!(
                    "{} inputs: give one observation file, or images with --board COLSxROWS --square SIZE",
                    inputs.len()
                )));
            };
            if looks_like_image(path) {
                return Err(Failure(format!(
                    "{path} is an image: give --board COLSxROWS and --square SIZE to detect the board"
                )));
            }
            let observations = Observations::read_bounded(path, args.output.max_input())?;
            Ok((observations, path.to_string(), None))
        }
    }
}

/// True for file names with an image extension.
pub fn looks_like_image(path: &str) -> bool {
    let lower = path.to_ascii_lowercase();
    [".jpg", ".jpeg", ".png"].iter().any(|e| lower.ends_with(e))
}

/// Refuses `--fix` names that none of `models` has (`whose` says what they are: "compared
/// model", "camera's model").
pub fn check_fix_names(names: &[&str], models: &[CameraModel], whose: &str) -> Result<(), Failure> {
    match names
        .iter()
        .find(|n| !models.iter().any(|m| m.distortion_names().contains(n)))
    {
        Some(unknown) => Err(Failure(format!(
            "--fix: no {whose} has a coefficient '{unknown}'"
        ))),
        None => Ok(()),
    }
}

/// Holds the `names` that `options.model` has (a term the model lacks is zero in it).
pub fn hold_present(options: &mut CalibrationOptions, names: &[&str]) -> Result<(), Failure> {
    let own: Vec<&str> = names
        .iter()
        .copied()
        .filter(|n| options.model.distortion_names().contains(n))
        .collect();
    options
        .fix_distortion_by_name(&own)
        .map_err(|e| Failure(format!("--fix: {e}")))
}

/// `calib single --compare-models`: every model from its own start, `--fix` names held in each
/// model that has them (checked against all the compared models' names here).
fn compare(args: &SingleArgs) -> Result<(), Failure> {
    let camera = &args.camera;
    let refuse = |option: &str, why: &str| {
        Err(Failure(format!(
            "--compare-models fits every model from its own start; {option} {why}"
        )))
    };
    if !camera.model.is_empty() {
        return refuse("--model", "picks one (leave it out to compare them all)");
    }
    if camera.distortion_guess.is_some() {
        return refuse(
            "--distortion-guess",
            "has one model's coefficients (leave it out)",
        );
    }
    if !camera.intrinsics.is_empty() || camera.fix_intrinsics {
        return refuse(
            "--intrinsics",
            "would be one model's start (leave it and --fix-intrinsics out)",
        );
    }
    if !args.output.export.is_empty() || args.output.report.is_some() {
        return Err(Failure(
            "--compare-models writes a comparison, not a calibration: calibrate with the chosen --model to --export or --report"
                .into(),
        ));
    }
    args.output.check_directories(&[])?;
    camera.no_fix_per_camera()?;
    let models = &calib_single::compare::MODELS;
    let hold = camera.fix_names();
    check_fix_names(&hold, models, "compared model")?;
    let options = camera.options_without_fix(None)?;
    let (observations, _, _) = observations(args)?;
    let comparison = calib_single::compare_models(&observations, &options, models, &hold);
    args.output.say().text(&comparison.table())?;
    if let Some(path) = &args.output.output {
        crate::write_json(path, &serde_json::to_value(&comparison)?)?;
    }
    Ok(())
}

pub fn run(args: &SingleArgs) -> Result<(), Failure> {
    if args.compare_models {
        return compare(args);
    }
    let mut options = args.camera.options()?;
    if args.camera.fix_intrinsics && args.camera.intrinsics_file()?.is_none() {
        return Err(Failure(
            "--fix-intrinsics: give the intrinsics with --intrinsics FILE".into(),
        ));
    }
    let (observations, source, skipped) = observations(args)?;
    if let Some(path) = args.camera.intrinsics_file()? {
        let camera = crate::after::read_single_camera(path, "--intrinsics")?;
        crate::after::check_image_size(
            &camera,
            observations.image_size,
            &format!("--intrinsics {path}"),
        )?;
        crate::after::apply_camera_file(
            &mut options,
            &camera,
            !args.camera.model.is_empty(),
            args.camera.fix_intrinsics,
            &format!("--intrinsics {path}"),
        )?;
    }
    // The model is final here (an --intrinsics file may have chosen it).
    if args.camera.zero_tangential && options.model.tangential_params().is_empty() {
        return Err(Failure(format!(
            "--zero-tangential: the {} model has no tangential coefficients",
            options.model
        )));
    }
    let targets = crate::after::export_targets(&args.output.export)?;
    crate::after::check_export_models(&targets, &[options.model])?;
    let inputs: Vec<&str> = args.inputs.iter().map(String::as_str).collect();
    let result = calibrate_and_report(&source, &inputs, &args.output, skipped.as_ref(), || {
        let mut result = calibrate(&observations, &options)
            .map_err(|e| Failure(format!("{source}: {}", observations.describe(&e))))?;
        if let Some(n) = args.bootstrap {
            let mut settings = calib_single::BootstrapOptions {
                resamples: n as usize,
                start: if args.bootstrap_warm {
                    calib_single::BootstrapStart::Solution
                } else {
                    calib_single::BootstrapStart::Calibration
                },
                ..Default::default()
            };
            if let Some(seed) = args.bootstrap_seed {
                settings.seed = seed;
            }
            calib_single::add_bootstrap(&mut result, &observations, &options, &settings)
                .map_err(|e| Failure(format!("{source}: {e}")))?;
        }
        Ok(result)
    })?;
    if let Some(dir) = &args.output.report {
        let input = calib_export::ReportInput::single(&result, Some(&observations))?;
        crate::after::write_report_to(&input, dir, args.output.say(), "--report")?;
    }
    Ok(())
}
