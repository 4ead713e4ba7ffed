//! `calib synth`: synthetic observation files with known truth, for tests and benchmarks.

use crate::{Failure, parse_list, parse_size, write_json};
use calib_rig::synthetic::{RigLayout, SyntheticRigConfig, generate_rig};
use calib_single::ImageSize;
use calib_single::synthetic::{SyntheticConfig, generate};
use calib_stereo::synthetic::{SyntheticStereoConfig, generate_stereo};
use camera_model::{AxisAngle, CameraModel, Intrinsics, Pose, RotationParameterization};
use clap::{Args, Subcommand};
use nalgebra::Vector3;
use serde_json::json;

#[derive(Subcommand, Debug)]
pub enum SynthCommand {
    /// One camera.
    Single(SynthArgs),
    /// A stereo rig (the camera settings above describe the left camera).
    Stereo(SynthStereoArgs),
    /// A rig of N cameras on a ring or in a line around a shared volume (the camera settings
    /// describe the first camera; --views is the number of frames).
    Rig(SynthRigArgs),
}

#[derive(clap::ValueEnum, Debug, Clone, Copy)]
pub enum Layout {
    /// On a horizontal arc around the volume (see --arc).
    Ring,
    /// On a horizontal line (see --spacing), turned towards the volume.
    Line,
}

/// Settings of a synthetic rig.
#[derive(Args, Debug)]
pub struct SynthRigArgs {
    #[command(flatten)]
    pub base: SynthArgs,
    /// Number of cameras.
    #[arg(long, default_value_t = 4)]
    pub cameras: usize,
    /// Where the cameras stand.
    #[arg(long, value_enum, default_value_t = Layout::Ring)]
    pub layout: Layout,
    /// Arc covered by a ring, degrees (360: all around). Neighbouring cameras should stand at
    /// most about 140 degrees apart (a board both see faces each within 70 degrees): two
    /// cameras at most 140.
    #[arg(long, default_value_t = 180.0, value_name = "DEG")]
    pub arc: f64,
    /// Distance between neighbours of a line, board widths.
    #[arg(long, default_value_t = 0.6, value_name = "WIDTHS")]
    pub spacing: f64,
    /// Lens model per camera, repeated cyclically, e.g. brown-conrady4,kannala-brandt4
    /// (default: --model for all; default distortions, scaled per camera).
    #[arg(long, value_name = "MODEL,...")]
    pub models: Option<String>,
}

/// Settings of synthetic stereo data.
#[derive(Args, Debug)]
pub struct SynthStereoArgs {
    #[command(flatten)]
    pub left: SynthArgs,
    /// True right intrinsics fx,fy,cx,cy (default 810,805,325,235).
    #[arg(long, value_name = "FX,FY,CX,CY", allow_hyphen_values = true)]
    pub right_intrinsics: Option<String>,
    /// Lens model of the right camera (default: the left camera's).
    #[arg(long, value_name = "MODEL")]
    pub right_model: Option<String>,
    /// True right distortion in the model's order (default for brown-conrady4:
    /// -0.18,0.04,-0.0005,0.0008; see --distortion for the other models).
    #[arg(long, value_name = "K1,K2,...", allow_hyphen_values = true)]
    pub right_distortion: Option<String>,
    /// Right image size WIDTHxHEIGHT (default: the left one).
    #[arg(long)]
    pub right_image: Option<String>,
    /// True rig: rotation vector and translation rx,ry,rz,tx,ty,tz (X_right = R X_left + T; board
    /// units). Default: a 4-square baseline (100 for the default 25 mm squares) and a 1.3 degree
    /// rotation.
    #[arg(long, value_name = "RX,RY,RZ,TX,TY,TZ", allow_hyphen_values = true)]
    pub rig: Option<String>,
}

/// Settings of the synthetic data.
#[derive(Args, Debug)]
pub struct SynthArgs {
    /// Output file ("-" for stdout).
    #[arg(short, long, value_name = "FILE.json")]
    pub output: String,
    /// Number of views.
    #[arg(long, default_value_t = 20)]
    pub views: usize,
    /// Inner corners COLSxROWS.
    #[arg(long, default_value = "9x6")]
    pub board: String,
    /// Square size (board units).
    #[arg(long, default_value_t = 25.0)]
    pub square: f64,
    /// Pixel noise (standard deviation per coordinate, px).
    #[arg(long, default_value_t = 0.2)]
    pub noise: f64,
    /// Largest board tilt, degrees.
    #[arg(long, default_value_t = 45.0)]
    pub tilt: f64,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "640x480")]
    pub image: String,
    /// True intrinsics fx,fy,cx,cy (default: 800,800 and the image centre).
    #[arg(long, value_name = "FX,FY,CX,CY", allow_hyphen_values = true)]
    pub intrinsics: Option<String>,
    /// True lens model (see `calib single --help`).
    #[arg(long, default_value = "brown-conrady4", value_name = "MODEL")]
    pub model: String,
    /// True distortion in the model's order. Defaults: brown-conrady4 -0.2,0.05,0.001,-0.0005;
    /// brown-conrady5 adds k3 = 0.02; rational8 adds k3..k6 = 0.02,0.1,0.01,0.002; thin-prism12
    /// adds s1..s4 = 0.001,-0.0005,0.0008,0.0002; kannala-brandt4 0.05,-0.01,0.003,-0.0005.
    #[arg(long, value_name = "K1,K2,...", allow_hyphen_values = true)]
    pub distortion: Option<String>,
}

/// The default true distortion of a model for synthetic data (see `SynthArgs::distortion`).
pub use calib_core::synthetic::default_distortion;

fn model_and_distortion(
    model: &str,
    distortion: Option<&str>,
    what: &str,
) -> Result<(CameraModel, Vec<f64>), Failure> {
    let model: CameraModel = model
        .parse()
        .map_err(|e| Failure(format!("--{what}model: {e}")))?;
    let d = match distortion {
        Some(text) => parse_list(
            text,
            model.num_distortion_params(),
            &format!("--{what}distortion"),
        )?,
        None => default_distortion(model),
    };
    Ok((model, d))
}

impl SynthArgs {
    /// The generator configuration.
    pub fn config(&self) -> Result<SyntheticConfig, Failure> {
        let (cols, rows) = parse_size(&self.board, "--board")?;
        let (width, height) = parse_size(&self.image, "--image")?;
        let image_size = ImageSize::new(width, height);
        let (cx, cy) = image_size.centre();
        let intrinsics = match &self.intrinsics {
            Some(text) => {
                let v = parse_list(text, 4, "--intrinsics")?;
                Intrinsics::new(v[0], v[1], v[2], v[3])
            }
            None => Intrinsics::new(800.0, 800.0, cx, cy),
        };
        let (model, distortion) =
            model_and_distortion(&self.model, self.distortion.as_deref(), "")?;
        Ok(SyntheticConfig {
            image_size,
            model,
            intrinsics,
            distortion,
            board_cols: cols as usize,
            board_rows: rows as usize,
            square: self.square,
            views: self.views,
            noise_px: self.noise,
            max_tilt_deg: self.tilt,
            seed: self.seed,
        })
    }
}

/// The truth section written next to the observations.
pub fn truth_json(config: &SyntheticConfig, poses: &[Pose]) -> serde_json::Value {
    let k = config.intrinsics;
    json!({
        "model": config.model.name(),
        "fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy,
        "distortion": config.distortion,
        "poses": poses.iter().map(|p| {
            let r = p.rotation;
            json!({
                "rotation_matrix": [[r[(0,0)], r[(0,1)], r[(0,2)]], [r[(1,0)], r[(1,1)], r[(1,2)]], [r[(2,0)], r[(2,1)], r[(2,2)]]],
                "translation": [p.translation.x, p.translation.y, p.translation.z],
            })
        }).collect::<Vec<_>>(),
    })
}

fn stereo_config(args: &SynthStereoArgs) -> Result<SyntheticStereoConfig, Failure> {
    let left = args.left.config()?;
    let defaults = SyntheticStereoConfig::default();
    let right_image_size = match &args.right_image {
        Some(text) => {
            let (w, h) = parse_size(text, "--right-image")?;
            ImageSize::new(w, h)
        }
        None => left.image_size,
    };
    let right_intrinsics = match &args.right_intrinsics {
        Some(text) => {
            let v = parse_list(text, 4, "--right-intrinsics")?;
            Intrinsics::new(v[0], v[1], v[2], v[3])
        }
        None => defaults.right_intrinsics,
    };
    let right_model = args
        .right_model
        .clone()
        .unwrap_or_else(|| args.left.model.clone());
    let (right_model, right_distortion) = match (&args.right_model, &args.right_distortion) {
        (None, None) if left.model == CameraModel::BrownConrady4 => {
            (left.model, defaults.right_distortion.clone())
        }
        _ => model_and_distortion(&right_model, args.right_distortion.as_deref(), "right-")?,
    };
    let rig = match &args.rig {
        Some(text) => {
            let v = parse_list(text, 6, "--rig")?;
            Pose::new(
                AxisAngle::matrix(&Vector3::new(v[0], v[1], v[2])),
                Vector3::new(v[3], v[4], v[5]),
            )
        }
        // The default baseline is in squares, so a board in other units gives the same rig.
        None => Pose::new(
            defaults.rig.rotation,
            defaults.rig.translation * (left.square / defaults.left.square),
        ),
    };
    Ok(SyntheticStereoConfig {
        left,
        right_model,
        right_intrinsics,
        right_distortion,
        right_image_size,
        rig,
    })
}

fn rig_config(args: &SynthRigArgs) -> Result<SyntheticRigConfig, Failure> {
    let base = args.base.config()?;
    let layout = match args.layout {
        Layout::Ring if args.arc.is_finite() && args.arc > 0.0 && args.arc <= 360.0 => {
            RigLayout::Ring { arc_deg: args.arc }
        }
        Layout::Line if args.spacing.is_finite() && args.spacing >= 0.0 => RigLayout::Line {
            spacing: args.spacing,
        },
        _ => {
            return Err(Failure(format!(
                "--arc must be in (0, 360] degrees and --spacing at least 0 (got {} and {})",
                args.arc, args.spacing
            )));
        }
    };
    let models = match &args.models {
        Some(text) => text
            .split(',')
            .map(|m| {
                m.trim()
                    .parse::<CameraModel>()
                    .map_err(|e| Failure(format!("--models: {e}")))
            })
            .collect::<Result<Vec<_>, _>>()?,
        None => Vec::new(),
    };
    Ok(SyntheticRigConfig {
        cameras: args.cameras,
        layout,
        frames: base.views,
        base,
        models,
    })
}

fn pose_json(p: &Pose) -> serde_json::Value {
    let r = p.rotation;
    json!({
        "R": [[r[(0,0)], r[(0,1)], r[(0,2)]], [r[(1,0)], r[(1,1)], r[(1,2)]], [r[(2,0)], r[(2,1)], r[(2,2)]]],
        "T": [p.translation.x, p.translation.y, p.translation.z],
    })
}

pub fn run(command: &SynthCommand) -> Result<(), Failure> {
    match command {
        SynthCommand::Rig(args) => {
            let config = rig_config(args)?;
            let set = generate_rig(&config)?;
            let mut out = set.observations.to_json_value();
            let c = &config.base;
            out["name"] = json!(format!(
                "synthetic rig, {} cameras, {} frames, {}x{} board, noise {} px, seed {}",
                config.cameras, config.frames, c.board_cols, c.board_rows, c.noise_px, c.seed
            ));
            out["board"] = json!({"cols": c.board_cols, "rows": c.board_rows, "square": c.square});
            let cameras: Vec<serde_json::Value> = set
                .cameras
                .iter()
                .zip(&set.transforms)
                .map(|(camera, transform)| {
                    let k = camera.intrinsics;
                    let mut v = json!({
                        "model": camera.model.name(),
                        "fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy,
                        "distortion": camera.distortion,
                    });
                    let t = pose_json(transform);
                    v["R"] = t["R"].clone();
                    v["T"] = t["T"].clone();
                    v
                })
                .collect();
            out["truth"] = json!({
                "convention": "X_cam = R X_cam0 + T; frame poses map board to camera 0",
                "cameras": cameras,
                "frame_poses": set.frame_poses.iter().map(pose_json).collect::<Vec<_>>(),
            });
            write_json(&args.base.output, &out)
        }
        SynthCommand::Stereo(args) => {
            let config = stereo_config(args)?;
            let set = generate_stereo(&config)?;
            let mut out = set.observations.to_json_value();
            let c = &config.left;
            out["name"] = json!(format!(
                "synthetic stereo, {} pairs, {}x{} board, noise {} px, seed {}",
                c.views, c.board_cols, c.board_rows, c.noise_px, c.seed
            ));
            out["board"] = json!({"cols": c.board_cols, "rows": c.board_rows, "square": c.square});
            let right = SyntheticConfig {
                model: config.right_model,
                intrinsics: config.right_intrinsics,
                distortion: config.right_distortion.clone(),
                image_size: config.right_image_size,
                ..config.left.clone()
            };
            let right_poses: Vec<Pose> = set
                .left_poses
                .iter()
                .map(|p| config.rig.compose(p))
                .collect();
            let r = config.rig.rotation;
            out["truth"] = json!({
                "left": truth_json(&config.left, &set.left_poses),
                "right": truth_json(&right, &right_poses),
                "R": [[r[(0,0)], r[(0,1)], r[(0,2)]], [r[(1,0)], r[(1,1)], r[(1,2)]], [r[(2,0)], r[(2,1)], r[(2,2)]]],
                "T": [config.rig.translation.x, config.rig.translation.y, config.rig.translation.z],
            });
            write_json(&args.left.output, &out)
        }
        SynthCommand::Single(args) => {
            let config = args.config()?;
            let set = generate(&config)?;
            let mut out = set.observations.to_json_value();
            out["name"] = json!(format!(
                "synthetic single, {} views, {}x{} board, noise {} px, seed {}",
                config.views, config.board_cols, config.board_rows, config.noise_px, config.seed
            ));
            out["board"] = json!({"cols": config.board_cols, "rows": config.board_rows, "square": config.square});
            out["truth"] = truth_json(&config, &set.poses);
            write_json(&args.output, &out)
        }
    }
}
