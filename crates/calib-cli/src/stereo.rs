//! `calib stereo`: calibrate a stereo rig.

use crate::detect::{self, BoardArgs};
use crate::run::{OutputArgs, calibrate_and_report};
use crate::single::{CameraArgs, looks_like_image};
use crate::{Failure, parse_list};
use calib_core::JsonFile;
use calib_stereo::{RigInit, StereoObservations, StereoOptions, calibrate_stereo};
use camera_model::{AxisAngle, Intrinsics, Pose, RotationKind, RotationParameterization};
use clap::{Args, ValueEnum};
use nalgebra::Vector3;
use std::path::PathBuf;

#[derive(ValueEnum, Debug, Clone, Copy)]
pub enum RigMethod {
    /// Least squares over all pairs.
    LeastSquares,
    /// Median of the per-pair estimates.
    Median,
}

/// Arguments of `calib stereo`.
#[derive(Args, Debug)]
pub struct StereoArgs {
    /// Stereo observation file (JSON), or the left camera's images with --board (and the right
    /// camera's with --right, paired in order).
    #[arg(required = true, value_name = "PAIRS.json | LEFT_IMAGE...")]
    pub inputs: Vec<String>,
    /// The right camera's images (with --board), paired in order with the left ones.
    #[arg(long, num_args = 1.., value_name = "RIGHT_IMAGE")]
    pub right: Vec<String>,
    #[command(flatten)]
    pub board: BoardArgs,
    #[command(flatten)]
    pub output: OutputArgs,
    /// Options for both cameras (a per-camera guess below overrides --guess).
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Lens model of the right camera (default: --model), e.g. a fisheye right camera with
    /// --right-model kannala-brandt4.
    #[arg(long, value_name = "MODEL")]
    pub right_model: Option<String>,
    /// Initial intrinsics of the left camera: fx,fy,cx,cy.
    #[arg(long, value_name = "FX,FY,CX,CY", allow_hyphen_values = true)]
    pub left_guess: Option<String>,
    /// Initial intrinsics of the right camera: fx,fy,cx,cy.
    #[arg(long, value_name = "FX,FY,CX,CY", allow_hyphen_values = true)]
    pub right_guess: Option<String>,
    /// Start the left camera from a single camera's calibration file (any format; see
    /// --intrinsics).
    #[arg(long, value_name = "FILE")]
    pub left_intrinsics: Option<String>,
    /// Start the right camera from a single camera's calibration file.
    #[arg(long, value_name = "FILE")]
    pub right_intrinsics: Option<String>,
    /// Hold the left camera's intrinsics and distortion: those of --left-intrinsics FILE (or
    /// --intrinsics) if given, else its single-camera estimate or guess.
    #[arg(long)]
    pub fix_left_intrinsics: bool,
    /// Hold the right camera's intrinsics and distortion: those of --right-intrinsics FILE (or
    /// --intrinsics) if given, else its single-camera estimate or guess.
    #[arg(long)]
    pub fix_right_intrinsics: bool,
    /// Both cameras share fx and fy.
    #[arg(long)]
    pub same_focal_length: bool,
    /// Initial rig: rotation vector and translation rx,ry,rz,tx,ty,tz (X_right = R X_left + T).
    #[arg(long, value_name = "RX,RY,RZ,TX,TY,TZ", allow_hyphen_values = true)]
    pub rig_guess: Option<String>,
    /// How the initial rig is computed from the single-camera poses.
    #[arg(long, value_enum, default_value_t = RigMethod::LeastSquares)]
    pub rig_init: RigMethod,
    /// Also estimate the standard deviations of both cameras and of the rig with a pair
    /// bootstrap: N times, draw as many pairs as were used (with replacement, seeded: the same
    /// every run), calibrate them as the pairs were (no outlier rejection: the rejected points
    /// left out), and report each parameter's spread about the estimate (`bootstrap` in the
    /// JSON, printed next to the linearized sigmas; a `bootstrap-spread` warning where it exceeds
    /// them 3x). Worth it for rational8 and thin-prism12, whose linearized principal-point and
    /// rig-rotation sigmas are several times too small (docs/calib-stereo.md). Costs about N
    /// stereo calibrations (10 to 10000)
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(10..=10000))]
    pub bootstrap: Option<u32>,
    /// Seed of --bootstrap's resampling (default 1): another seed draws other resamples
    #[arg(long, value_name = "SEED", requires = "bootstrap")]
    pub bootstrap_seed: Option<u64>,
}

fn intrinsics(text: &str, what: &str) -> Result<Intrinsics, Failure> {
    let v = parse_list(text, 4, what)?;
    Ok(Intrinsics::new(v[0], v[1], v[2], v[3]))
}

impl StereoArgs {
    /// The library options.
    pub fn options(&self) -> Result<StereoOptions, Failure> {
        // --fix holds each name in the camera(s) whose model has it.
        let camera = self.camera.options_without_fix(self.camera.model_name()?)?;
        let mut left = camera.clone();
        let mut right = camera.clone();
        if let Some(name) = &self.right_model {
            let model: camera_model::CameraModel = name
                .parse()
                .map_err(|e| Failure(format!("--right-model: {e}")))?;
            if model != camera.model {
                if self.camera.distortion_guess.is_some() {
                    return Err(Failure(
                        "--distortion-guess applies to --model; with a different --right-model give no distortion guess".into(),
                    ));
                }
                right.model = model;
            }
        }
        if self.camera.zero_tangential
            && left.model.tangential_params().is_empty()
            && right.model.tangential_params().is_empty()
        {
            return Err(Failure(format!(
                "--zero-tangential: neither camera's model ({}, {}) has tangential coefficients",
                left.model, right.model
            )));
        }
        let names = self.camera.fix_names();
        crate::single::check_fix_names(&names, &[left.model, right.model], "camera's model")?;
        crate::single::hold_present(&mut left, &names)?;
        crate::single::hold_present(&mut right, &names)?;
        for (camera, names) in self.camera.fix_per_camera() {
            let side = match camera {
                "left" => &mut left,
                "right" => &mut right,
                other => {
                    return Err(Failure(format!(
                        "--fix {other}=...: calib stereo's cameras are left and right"
                    )));
                }
            };
            side.fix_distortion_by_name(&names)
                .map_err(|e| Failure(format!("--fix {camera}=...: {e}")))?;
        }
        if let Some(text) = &self.left_guess {
            left.intrinsic_guess = Some(intrinsics(text, "--left-guess")?);
        }
        if let Some(text) = &self.right_guess {
            right.intrinsic_guess = Some(intrinsics(text, "--right-guess")?);
        }
        let rig_guess = match &self.rig_guess {
            Some(text) => {
                let v = parse_list(text, 6, "--rig-guess")?;
                Some(Pose::new(
                    AxisAngle::matrix(&Vector3::new(v[0], v[1], v[2])),
                    Vector3::new(v[3], v[4], v[5]),
                ))
            }
            None => None,
        };
        let mut options = StereoOptions::default();
        options.solver = camera.solver.clone();
        // Euler angles are singular where the right camera turns 90 degrees about y from the
        // left one (the rig's rotation then looked undetermined): so3 unless asked.
        options.rotation = if self.camera.rotation.is_none() {
            RotationKind::So3
        } else {
            camera.rotation
        };
        options.skip_bad_pairs = camera.skip_bad_views;
        options.outliers = camera.outliers;
        options.loss = camera.loss;
        options.left = left;
        options.right = right;
        options.fix_left_intrinsics = self.fix_left_intrinsics;
        options.fix_right_intrinsics = self.fix_right_intrinsics;
        options.same_focal_length = self.same_focal_length;
        options.rig_guess = rig_guess;
        options.rig_init = match self.rig_init {
            RigMethod::LeastSquares => RigInit::LeastSquares,
            RigMethod::Median => RigInit::Median,
        };
        Ok(options)
    }
}

/// The stereo observations: the file named by `inputs`, or detected in the images.
fn observations(
    args: &StereoArgs,
) -> Result<(StereoObservations, String, Option<detect::Skipped>), Failure> {
    let inputs: Vec<&str> = args
        .inputs
        .iter()
        .chain(&args.right)
        .map(String::as_str)
        .collect();
    args.output.check_against(&inputs)?;
    match args.board.board()? {
        Some(board) => {
            if args.right.is_empty() {
                return Err(Failure(
                    "stereo from images needs the right camera's images: --right IMAGE...".into(),
                ));
            }
            let left: Vec<PathBuf> = args.inputs.iter().map(PathBuf::from).collect();
            let right: Vec<PathBuf> = args.right.iter().map(PathBuf::from).collect();
            let (results, file) = detect::stereo_observations(
                &left,
                &right,
                &board,
                &args.board,
                args.camera.threads,
            )?;
            args.output.say().text(&detect::summary(&results, &file))?;
            // Every pair given is either used or rejected (with --frames-by-number the pairs
            // are the numbers either camera has).
            let given = ["pairs", "rejected_pairs"]
                .iter()
                .map(|k| file[*k].as_array().map_or(0, Vec::len))
                .sum();
            let skipped = detect::Skipped::from_file(&file, given);
            let observations = StereoObservations::from_file(serde_json::from_value(file)?);
            Ok((observations, format!("{given} image pairs"), Some(skipped)))
        }
        None => {
            let ([path], true) = (args.inputs.as_slice(), args.right.is_empty()) else {
                return Err(Failure(
                    "give one stereo observation file, or images with --board COLSxROWS --square SIZE and --right".into(),
                ));
            };
            if args.board.frames_by_number {
                return Err(Failure(format!(
                    "--frames-by-number: {path} is an observation file, whose pairs are already matched; the option matches photographs (--board COLSxROWS --square SIZE and --right)"
                )));
            }
            if looks_like_image(path) {
                return Err(Failure(format!(
                    "{path} is an image: give --board COLSxROWS and --square SIZE to detect the board"
                )));
            }
            let observations = StereoObservations::read_bounded(path, args.output.max_input())?;
            Ok((observations, path.clone(), None))
        }
    }
}

/// The cameras of `--intrinsics` (a rig file) and `--left-intrinsics` / `--right-intrinsics`.
fn camera_files(
    args: &StereoArgs,
) -> Result<[Option<(calib_export::CameraCalibration, String)>; 2], Failure> {
    let mut cameras = [None, None];
    if let Some(path) = args.camera.intrinsics_file()? {
        if args.left_intrinsics.is_some() || args.right_intrinsics.is_some() {
            return Err(Failure(
                "--intrinsics (a rig) and --left-intrinsics/--right-intrinsics exclude each other"
                    .into(),
            ));
        }
        match calib_export::read_calibration(std::path::Path::new(path))
            .map_err(|e| Failure(format!("--intrinsics: {e}")))?
        {
            calib_export::Calibrated::Stereo(rig) => {
                cameras = [
                    Some((rig.left, format!("--intrinsics {path} (left)"))),
                    Some((rig.right, format!("--intrinsics {path} (right)"))),
                ];
            }
            calib_export::Calibrated::Single(_) => {
                return Err(Failure(format!(
                    "--intrinsics {path}: a single camera; give a rig's file, or single cameras' files with --left-intrinsics and --right-intrinsics"
                )));
            }
            calib_export::Calibrated::Rig(r) => {
                let names: Vec<&str> = r.cameras.iter().map(|c| c.name.as_str()).collect();
                return Err(Failure(format!(
                    "--intrinsics {path}: a rig of {} cameras ({}); give one pair's file (calib export {path} --pair LEFT,RIGHT --format opencv -o PAIR.yaml)",
                    names.len(),
                    names.join(", ")
                )));
            }
        }
    }
    for (k, (option, name)) in [
        (&args.left_intrinsics, "--left-intrinsics"),
        (&args.right_intrinsics, "--right-intrinsics"),
    ]
    .into_iter()
    .enumerate()
    {
        if let Some(path) = option {
            cameras[k] = Some((
                crate::after::read_single_camera(path, name)?,
                format!("{name} {path}"),
            ));
        }
    }
    Ok(cameras)
}

pub fn run(args: &StereoArgs) -> Result<(), Failure> {
    let mut options = args.options()?;
    let files = camera_files(args)?;
    if args.camera.fix_intrinsics && files.iter().all(Option::is_none) {
        return Err(Failure(
            "--fix-intrinsics: give the intrinsics with --intrinsics RIG or --left-intrinsics/--right-intrinsics".into(),
        ));
    }
    let (observations, source, skipped) = observations(args)?;
    let sizes = [
        observations.image_size,
        observations.right_image_size.or(observations.image_size),
    ];
    for (k, file) in files.iter().enumerate() {
        if let Some((camera, what)) = file {
            crate::after::check_image_size(camera, sizes[k], what)?;
            let side = if k == 0 {
                &mut options.left
            } else {
                &mut options.right
            };
            // An explicit model for this camera: --model, or --right-model for the right one.
            let explicit_model =
                !args.camera.model.is_empty() || (k == 1 && args.right_model.is_some());
            // --fix-left/right-intrinsics with a file hold the file's camera, as
            // --fix-intrinsics does (not a calibration of the pairs' views started from it).
            let hold = args.camera.fix_intrinsics
                || if k == 0 {
                    args.fix_left_intrinsics
                } else {
                    args.fix_right_intrinsics
                };
            crate::after::apply_camera_file(side, camera, explicit_model, hold, what)?;
            if args.camera.fix_intrinsics {
                if k == 0 {
                    options.fix_left_intrinsics = true;
                } else {
                    options.fix_right_intrinsics = true;
                }
            }
        }
    }
    let targets = crate::after::export_targets(&args.output.export)?;
    crate::after::check_export_models(&targets, &[options.left.model, options.right.model])?;
    let inputs: Vec<&str> = args
        .inputs
        .iter()
        .chain(&args.right)
        .map(String::as_str)
        .collect();
    let result = calibrate_and_report(&source, &inputs, &args.output, skipped.as_ref(), || {
        let mut result = calibrate_stereo(&observations, &options)
            .map_err(|e| Failure(format!("{source}: {}", observations.describe(&e))))?;
        if let Some(n) = args.bootstrap {
            let mut settings = calib_stereo::BootstrapOptions {
                resamples: n as usize,
                ..Default::default()
            };
            if let Some(seed) = args.bootstrap_seed {
                settings.seed = seed;
            }
            calib_stereo::add_bootstrap(&mut result, &observations, &options, &settings)
                .map_err(|e| Failure(format!("{source}: {e}")))?;
        }
        Ok(result)
    })?;
    if let Some(dir) = &args.output.report {
        let input = calib_export::ReportInput::stereo(&result, Some(&observations))?;
        crate::after::write_report_to(&input, dir, args.output.say(), "--report")?;
    }
    Ok(())
}
