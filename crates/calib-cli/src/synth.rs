//! `calib synth`: synthetic observation files with known truth, for tests and benchmarks.

use crate::{Failure, parse_list, parse_size, write_json};
use calib_single::ImageSize;
use calib_single::synthetic::{SyntheticConfig, generate};
use camera_model::{BrownConrady, Intrinsics, Pose};
use clap::{Args, Subcommand};
use serde_json::json;

#[derive(Subcommand, Debug)]
pub enum SynthCommand {
    /// One camera.
    Single(SynthArgs),
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
    #[arg(long, value_name = "FX,FY,CX,CY")]
    pub intrinsics: Option<String>,
    /// True distortion k1,k2,p1,p2.
    #[arg(
        long,
        value_name = "K1,K2,P1,P2",
        default_value = "-0.2,0.05,0.001,-0.0005"
    )]
    pub distortion: String,
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
        let d = parse_list(&self.distortion, 4, "--distortion")?;
        Ok(SyntheticConfig {
            image_size,
            intrinsics,
            distortion: BrownConrady::new(d[0], d[1], d[2], d[3]),
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
    let d = config.distortion;
    json!({
        "fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy,
        "distortion": [d.k1, d.k2, d.p1, d.p2],
        "poses": poses.iter().map(|p| {
            let r = p.rotation;
            json!({
                "rotation_matrix": [[r[(0,0)], r[(0,1)], r[(0,2)]], [r[(1,0)], r[(1,1)], r[(1,2)]], [r[(2,0)], r[(2,1)], r[(2,2)]]],
                "translation": [p.translation.x, p.translation.y, p.translation.z],
            })
        }).collect::<Vec<_>>(),
    })
}

pub fn run(command: &SynthCommand) -> Result<(), Failure> {
    match command {
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
