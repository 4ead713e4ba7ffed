//! `calib stereo`: calibrate a stereo rig.

use crate::run::{OutputArgs, calibrate_and_report};
use crate::single::CameraArgs;
use crate::{Failure, parse_list};
use calib_core::JsonFile;
use calib_stereo::{RigInit, StereoObservations, StereoOptions, calibrate_stereo};
use camera_model::{AxisAngle, Intrinsics, Pose, RotationParameterization};
use clap::{Args, ValueEnum};
use nalgebra::Vector3;

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
    /// Stereo observation file (JSON).
    pub pairs: String,
    #[command(flatten)]
    pub output: OutputArgs,
    /// Options for both cameras (a per-camera guess below overrides --guess).
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Initial intrinsics of the left camera: fx,fy,cx,cy.
    #[arg(long, value_name = "FX,FY,CX,CY")]
    pub left_guess: Option<String>,
    /// Initial intrinsics of the right camera: fx,fy,cx,cy.
    #[arg(long, value_name = "FX,FY,CX,CY")]
    pub right_guess: Option<String>,
    /// Hold the left camera's intrinsics and distortion (its single-camera estimate or guess).
    #[arg(long)]
    pub fix_left_intrinsics: bool,
    /// Hold the right camera's intrinsics and distortion.
    #[arg(long)]
    pub fix_right_intrinsics: bool,
    /// Both cameras share fx and fy.
    #[arg(long)]
    pub same_focal_length: bool,
    /// Initial rig: rotation vector and translation rx,ry,rz,tx,ty,tz (X_right = R X_left + T).
    #[arg(long, value_name = "RX,RY,RZ,TX,TY,TZ")]
    pub rig_guess: Option<String>,
    /// How the initial rig is computed from the single-camera poses.
    #[arg(long, value_enum, default_value_t = RigMethod::LeastSquares)]
    pub rig_init: RigMethod,
}

fn intrinsics(text: &str, what: &str) -> Result<Intrinsics, Failure> {
    let v = parse_list(text, 4, what)?;
    Ok(Intrinsics::new(v[0], v[1], v[2], v[3]))
}

impl StereoArgs {
    /// The library options.
    pub fn options(&self) -> Result<StereoOptions, Failure> {
        let camera = self.camera.options()?;
        let mut left = camera.clone();
        let mut right = camera.clone();
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
        options.rotation = camera.rotation;
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

pub fn run(args: &StereoArgs) -> Result<(), Failure> {
    args.output.check_against(&[&args.pairs])?;
    let observations = StereoObservations::read_bounded(&args.pairs, args.output.max_input())?;
    let options = args.options()?;
    calibrate_and_report(&args.pairs, &args.output, || {
        calibrate_stereo(&observations, &options)
            .map_err(|e| Failure(format!("{}: {e}", args.pairs)))
    })
}
