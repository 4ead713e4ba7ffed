//! `calib rig`: calibrate a rig of N cameras.

use crate::Failure;
use crate::detect::{self, BoardArgs};
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
    /// points and each camera's pixels. Or photographs: --board, --square and --camera per camera.
    #[arg(value_name = "RIG.json", required_unless_present = "camera_images")]
    pub input: Option<String>,
    /// Board detection for --camera (--board COLSxROWS, --square SIZE, --draw DIR: overlays in
    /// DIR/NAME/).
    #[command(flatten)]
    pub board: BoardArgs,
    /// A camera's name and its photographs, one per frame in frame order (repeat per camera:
    /// --camera left L1.jpg L2.jpg ... --camera right R1.jpg R2.jpg ...). Frame f is the f-th
    /// image of every camera, so every camera gives the same number of images (with
    /// --frames-by-number, frames are matched by the numbers in the file names instead, and a
    /// camera may lack some); an image without a usable board leaves that camera out of that
    /// frame (listed in rejected_images).
    #[arg(
        long = "camera",
        num_args = 2..,
        action = clap::ArgAction::Append,
        value_names = ["NAME", "IMAGE"],
        conflicts_with = "input"
    )]
    pub camera_images: Vec<String>,
    /// The --camera groups, `(name, images)` (filled from the parsed command line: clap's derive
    /// flattens them).
    #[arg(skip)]
    pub cameras: Vec<(String, Vec<String>)>,
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

/// The rig observations: the file, or detected in the --camera images.
fn observations(
    args: &RigArgs,
) -> Result<
    (
        RigObservations,
        String,
        Vec<String>,
        Option<detect::Skipped>,
    ),
    Failure,
> {
    if args.cameras.is_empty() {
        let Some(input) = &args.input else {
            return Err(Failure(
                "give a rig observation file, or photographs with --board COLSxROWS --square SIZE and --camera NAME IMAGE... per camera".into(),
            ));
        };
        args.output.check_against(&[input.as_str()])?;
        if args.board.board.is_some() {
            return Err(Failure(format!(
                "--board: {input} is an observation file; with --board give each camera's photographs with --camera NAME IMAGE..."
            )));
        }
        if args.board.frames_by_number {
            return Err(Failure(format!(
                "--frames-by-number: {input} is an observation file, whose frames are already matched; the option matches photographs (--camera NAME IMAGE...)"
            )));
        }
        if looks_like_image(input) {
            return Err(Failure(format!(
                "{input} is an image: give each camera's photographs with --board COLSxROWS --square SIZE --camera NAME IMAGE... (or detect the corners first and write a rig observation file)"
            )));
        }
        let observations = RigObservations::read_bounded(input, args.output.max_input())?;
        return Ok((observations, input.clone(), vec![input.clone()], None));
    }
    let board = args.board.board()?.ok_or_else(|| {
        Failure("--camera: give the board too (--board COLSxROWS --square SIZE)".into())
    })?;
    let inputs: Vec<String> = args.cameras.iter().flat_map(|(_, p)| p.clone()).collect();
    args.output
        .check_against(&inputs.iter().map(String::as_str).collect::<Vec<_>>())?;
    for (k, (name, _)) in args.cameras.iter().enumerate() {
        if args.cameras[..k].iter().any(|(n, _)| n == name) {
            return Err(Failure(format!(
                "--camera {name} is given twice: give each camera once, with all its images"
            )));
        }
    }
    let cameras: Vec<(String, Vec<std::path::PathBuf>)> = args
        .cameras
        .iter()
        .map(|(n, p)| (n.clone(), p.iter().map(std::path::PathBuf::from).collect()))
        .collect();
    let (results, file) =
        detect::rig_observations(&cameras, &board, &args.board, args.camera.threads)?;
    args.output.say().text(&detect::summary(&results, &file))?;
    let frames = file["frames"].as_array().map_or(0, Vec::len);
    let skipped = detect::Skipped::from_file(&file, results.len());
    let observations = RigObservations::from_file(serde_json::from_value(file)?);
    Ok((
        observations,
        format!("{} cameras x {frames} frames of images", cameras.len()),
        inputs,
        Some(skipped),
    ))
}

pub fn run(args: &RigArgs) -> Result<(), Failure> {
    let (observations, source, inputs, skipped) = observations(args)?;
    let options = args.options(&observations)?;
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let result = calibrate_and_report(&source, &inputs, &args.output, skipped.as_ref(), || {
        calibrate_rig(&observations, &options).map_err(|e| Failure(format!("{source}: {e}")))
    })?;
    if let Some(dir) = &args.output.report {
        let input = calib_export::ReportInput::rig(&result, Some(&observations))?;
        crate::after::write_report_to(&input, dir, args.output.say(), "--report")?;
    }
    Ok(())
}
