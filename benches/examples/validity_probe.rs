//! The lens-validity audit's Rust side (`benches/validity/run.sh`): for one camera, the
//! validity check's answer, its time, and the undistortion of given pixels, so that a brute-force
//! analysis (`benches/validity/analyse.py`) can compare both with a dense 2-D sampling of the
//! distortion map.
//!
//! Input on stdin: a first line `MODEL WIDTH HEIGHT FX FY CX CY D1 D2 ...` (the model's name as on
//! the command line, its distortion coefficients in OpenCV's order), then one pixel `X Y` per line
//! (OpenCV's convention: the first pixel's centre at 0,0). Output on stdout: a first line
//! `validity VALID_RADIUS_PX IMAGE_RADIUS_PX COVERAGE COVERS_IMAGE_5% MICROSECONDS` (the median
//! time of one `AnyCamera::validity` call over 50), then per pixel `X Y NX NY` (the undistorted
//! normalized point from `AnyCamera::undistort_pixel` with the default options) or `X Y error`.
//!
//! Run: `cargo run --release -p calib-benches --example validity_probe < CAMERA.txt`.
use camera_model::{AnyCamera, CameraModel, Intrinsics, UndistortOptions, nalgebra::Vector2};
use std::io::{BufRead, Write};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let stdin = std::io::stdin();
    let mut lines = stdin.lock().lines();
    let first = lines
        .next()
        .ok_or("empty input: expected a camera line")??;
    let fields: Vec<&str> = first.split_whitespace().collect();
    if fields.len() < 7 {
        return Err("camera line: MODEL WIDTH HEIGHT FX FY CX CY D1 D2 ...".into());
    }
    let model = CameraModel::NAMES
        .iter()
        .position(|n| *n == fields[0])
        .map(|i| CameraModel::ALL[i])
        .ok_or_else(|| format!("unknown model {}", fields[0]))?;
    let (width, height): (u32, u32) = (fields[1].parse()?, fields[2].parse()?);
    let numbers = fields[3..]
        .iter()
        .map(|f| f.parse::<f64>())
        .collect::<Result<Vec<_>, _>>()?;
    let camera = AnyCamera::new(
        model,
        Intrinsics::new(numbers[0], numbers[1], numbers[2], numbers[3]),
        numbers[4..].to_vec(),
    )?;
    let mut times = Vec::new();
    let mut validity = camera.validity(width, height);
    for _ in 0..50 {
        let start = Instant::now();
        validity = std::hint::black_box(camera.validity(width, height));
        times.push(start.elapsed().as_secs_f64() * 1e6);
    }
    times.sort_by(f64::total_cmp);
    let out = std::io::stdout();
    let mut out = std::io::BufWriter::new(out.lock());
    writeln!(
        out,
        "validity {} {} {} {} {:.1}",
        validity.valid_radius_px,
        validity.image_radius_px,
        validity.coverage,
        validity.covers_image(0.05),
        times[times.len() / 2]
    )?;
    let options = UndistortOptions::default();
    for line in lines {
        let line = line?;
        let xy: Vec<f64> = line
            .split_whitespace()
            .map(str::parse)
            .collect::<Result<_, _>>()?;
        if xy.len() != 2 {
            return Err(format!("pixel line '{line}': expected X Y").into());
        }
        match camera.undistort_pixel(&Vector2::new(xy[0], xy[1]), &options) {
            Ok(n) => writeln!(out, "{} {} {:e} {:e}", xy[0], xy[1], n.x, n.y)?,
            Err(_) => writeln!(out, "{} {} error", xy[0], xy[1])?,
        }
    }
    Ok(())
}
