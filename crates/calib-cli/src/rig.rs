//! `calib rig`: calibrate a rig of N cameras.

use crate::Failure;
use crate::run::{OutputArgs, calibrate_and_report};
use crate::single::{CameraArgs, looks_like_image, split_named};
use calib_core::JsonFile;
use calib_rig::{RigObservations, RigOptions, calibrate_rig};
use camera_model::{AnyCamera, CameraModel, RotationKind};
use clap::Args;

/// Arguments of `calib rig`.
#[derive(Args, Debug)]
pub struct RigArgs {
    /// Rig observation file (JSON, see docs/formats.md): the cameras and, per frame, the board
    /// points and each camera's pixels.
    #[arg(value_name = "RIG.json")]
    pub input: String,
    #[command(flatten)]
    pub output: OutputArgs,
    /// Options for every camera. Per camera: --model NAME=MODEL (over the file's "model", which
    /// is over a plain --model MODEL) and --intrinsics NAME=FILE (a calib result or an exported
    /// OpenCV, ROS or Kalibr file: that camera's intrinsics and distortion, held fixed).
    #[command(flatten)]
    pub camera: CameraArgs,
    /// The reference camera (by name): the rig's frame is its frame. Default: the first camera.
    #[arg(long, value_name = "NAME")]
    pub reference: Option<String>,
    /// Fewest frames a camera must see to calibrate its own intrinsics.
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub min_views: usize,
}

/// The index of the camera named `name`, or a message listing the names.
pub fn camera_index(
    observations: &RigObservations,
    name: &str,
    what: &str,
) -> Result<usize, Failure> {
    observations
        .cameras
        .iter()
        .position(|c| c.name == name)
        .ok_or_else(|| {
            let names: Vec<&str> = observations
                .cameras
                .iter()
                .map(|c| c.name.as_str())
                .collect();
            Failure(format!(
                "{what}: no camera named '{name}' (the cameras are {})",
                names.join(", ")
            ))
        })
}

impl RigArgs {
    /// The library options for `observations`.
    pub fn options(&self, observations: &RigObservations) -> Result<RigOptions, Failure> {
        let n = observations.cameras.len();
        let (plain, named) = split_named(&self.camera.model);
        if plain.len() > 1 {
            return Err(Failure(format!(
                "--model given {} times without a camera name (per camera: --model NAME=MODEL)",
                plain.len()
            )));
        }
        let camera = self.camera.options_without_fix(plain.first().copied())?;
        let mut models = vec![None; n];
        for (name, model) in named {
            let c = camera_index(observations, name, "--model")?;
            models[c] = Some(
                model
                    .parse()
                    .map_err(|e| Failure(format!("--model {name}={model}: {e}")))?,
            );
        }
        let (plain, named) = split_named(&self.camera.intrinsics);
        if let Some(path) = plain.first() {
            return Err(Failure(format!(
                "--intrinsics {path}: calib rig takes one file per camera, --intrinsics NAME={path}"
            )));
        }
        // Given cameras are always held fixed; --fix-intrinsics without one would do nothing.
        if self.camera.fix_intrinsics && named.is_empty() {
            return Err(Failure(
                "--fix-intrinsics: give the intrinsics with --intrinsics NAME=FILE (calib rig holds every camera given that way fixed)"
                    .into(),
            ));
        }
        let mut given = vec![None; n];
        for (name, path) in named {
            let c = camera_index(observations, name, "--intrinsics")?;
            let what = format!("--intrinsics {name}={path}");
            let file = crate::after::read_camera(path, &what, Some(name))?;
            crate::after::check_image_size(&file, Some(observations.cameras[c].image_size), &what)?;
            if let Some(model) = models[c]
                && model != file.camera.model
            {
                return Err(Failure(format!(
                    "{what}: the file's camera is {}, but --model {name}={model}",
                    file.camera.model
                )));
            }
            given[c] = Some(file.camera);
        }
        // --fix holds each name in every camera whose model has it.
        let hold = self.camera.fix_names();
        let camera_models: Vec<CameraModel> = (0..n)
            .map(|c| {
                given[c]
                    .as_ref()
                    .map(|g: &AnyCamera| g.model)
                    .or(models[c])
                    .or(observations.cameras[c].model)
                    .unwrap_or(camera.model)
            })
            .collect();
        crate::single::check_fix_names(&hold, &camera_models, "camera's model")?;
        if self.camera.zero_tangential
            && camera_models
                .iter()
                .all(|m| m.tangential_params().is_empty())
        {
            return Err(Failure(
                "--zero-tangential: no camera's model has tangential coefficients".into(),
            ));
        }
        let targets = crate::after::export_targets(&self.output.export)?;
        crate::after::check_export_models(&targets, &camera_models)?;
        let mut hold_by_camera = vec![Vec::new(); n];
        for (name, names) in self.camera.fix_per_camera() {
            let c = camera_index(observations, name, "--fix")?;
            for coefficient in names {
                if !camera_models[c].distortion_names().contains(&coefficient) {
                    return Err(Failure(format!(
                        "--fix {name}=...: camera '{name}' ({}) has no coefficient '{coefficient}' (its coefficients: {})",
                        camera_models[c],
                        camera_models[c].distortion_names().join(", ")
                    )));
                }
                hold_by_camera[c].push(coefficient.to_string());
            }
        }
        let mut options = RigOptions::default();
        options.hold_fixed = hold.iter().map(|n| n.to_string()).collect();
        options.hold_fixed_by_camera = hold_by_camera;
        options.solver = camera.solver.clone();
        // Euler angles are singular where a camera turns 90 degrees about y from the
        // reference: common in rigs.
        if self.camera.rotation.is_none() {
            options.rotation = RotationKind::So3;
        } else {
            options.rotation = camera.rotation;
        }
        options.outliers = camera.outliers;
        options.loss = camera.loss;
        options.min_views = self.min_views.max(1);
        options.models = models;
        options.given = given;
        options.camera = camera;
        if let Some(name) = &self.reference {
            options.reference = camera_index(observations, name, "--reference")?;
        }
        Ok(options)
    }
}

pub fn run(args: &RigArgs) -> Result<(), Failure> {
    args.output.check_against(&[args.input.as_str()])?;
    if looks_like_image(&args.input) {
        return Err(Failure(format!(
            "{} is an image: calib rig reads a rig observation file (detect each camera's corners with calib detect first)",
            args.input
        )));
    }
    let observations = RigObservations::read_bounded(&args.input, args.output.max_input())?;
    let options = args.options(&observations)?;
    let source = args.input.clone();
    let result = calibrate_and_report(&source, &[args.input.as_str()], &args.output, None, || {
        calibrate_rig(&observations, &options).map_err(|e| Failure(format!("{source}: {e}")))
    })?;
    if let Some(dir) = &args.output.report {
        let input = calib_export::ReportInput::rig(&result, Some(&observations))?;
        crate::after::write_report_to(&input, dir, args.output.say(), "--report")?;
    }
    Ok(())
}
