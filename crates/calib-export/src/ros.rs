//! ROS `camera_info` YAML (the `camera_calibration_parsers` layout that `camera_info_manager`
//! loads), one file per camera:
//!
//! ```text
//! image_width: 640
//! image_height: 360
//! camera_name: left
//! camera_matrix:
//!   rows: 3
//!   cols: 3
//!   data: [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]
//! distortion_model: plumb_bob
//! distortion_coefficients:
//!   rows: 1
//!   cols: 5
//!   data: [k1, k2, p1, p2, k3]
//! rectification_matrix:
//!   rows: 3
//!   cols: 3
//!   data: [...]
//! projection_matrix:
//!   rows: 3
//!   cols: 4
//!   data: [...]
//! ```
//!
//! | our model | `distortion_model` | coefficients |
//! |---|---|---|
//! | `brown-conrady4`, `brown-conrady5` | `plumb_bob` | k1 k2 p1 p2 k3 (k3 = 0 for brown-conrady4) |
//! | `rational8` | `rational_polynomial` | k1 k2 p1 p2 k3 k4 k5 k6 |
//! | `kannala-brandt4` | `equidistant` | k1 k2 k3 k4 |
//! | `thin-prism12` | none: an error | |
//!
//! A single camera gets `rectification_matrix = I` and `projection_matrix = [K' | 0]` with `K'`
//! the new camera matrix of [`crate::undistort::optimal_new_camera_matrix`] (the export's
//! `alpha`, 0 by default, as ROS's calibrator does). A stereo rig gets `R1`/`P1` and `R2`/`P2`
//! of [`crate::rectify::stereo_rectify`]; `P2[0][3] = f' T'x` is in board units times the
//! export's translation scale (ROS expects metres). A stereo rig that cannot be rectified
//! (cameras of different image sizes, a lens model that folds inside the image) is refused:
//! ROS's stereo pipeline takes camera_info as a rectified pair, so a stand-in (identity
//! rectification) would give wrong depth silently; the OpenCV export writes such a rig without
//! its rectification. Reading a `plumb_bob` file whose `k3` is
//! exactly zero gives a `brown-conrady4` camera.

use crate::calibration::{CameraCalibration, intrinsics_of};
use crate::error::ExportError;
use crate::rectify::stereo_rectify;
use crate::undistort::optimal_new_camera_matrix;
use crate::yaml::{self, Doc};
use crate::{Calibrated, ExportOptions};
use calib_core::ImageSize;
use camera_model::{AnyCamera, CameraModel};
use nalgebra::{Matrix3, Matrix3x4};
use serde_norway::Value;
use std::fmt::Write;

/// Refuses a lens model camera_info has no name for (before any calibration is run).
pub(crate) fn check_model(model: CameraModel) -> Result<(), ExportError> {
    let camera = AnyCamera::new(
        model,
        camera_model::Intrinsics::new(1.0, 1.0, 0.0, 0.0),
        vec![0.0; model.num_distortion_params()],
    )
    .map_err(|e| ExportError::Unsupported(e.to_string()))?;
    ros_model(&camera).map(|_| ())
}

/// ROS's name and coefficients for a camera, or the typed error for a model ROS lacks.
fn ros_model(camera: &AnyCamera) -> Result<(&'static str, Vec<f64>), ExportError> {
    let d = &camera.distortion;
    Ok(match camera.model {
        CameraModel::BrownConrady4 => ("plumb_bob", vec![d[0], d[1], d[2], d[3], 0.0]),
        CameraModel::BrownConrady5 => ("plumb_bob", d.clone()),
        CameraModel::Rational8 => ("rational_polynomial", d.clone()),
        CameraModel::KannalaBrandt4 => ("equidistant", d.clone()),
        CameraModel::ThinPrism12 => {
            return Err(ExportError::UnsupportedModel {
                format: "ros",
                model: camera.model,
                detail: " (camera_info knows plumb_bob, rational_polynomial and equidistant; calibrate with --model rational8 for ROS)".into(),
            });
        }
    })
}

fn block(
    out: &mut String,
    name: &str,
    rows: usize,
    cols: usize,
    data: &[f64],
) -> Result<(), ExportError> {
    yaml::check_finite(name, data)?;
    let _ = writeln!(
        out,
        "{name}:\n  rows: {rows}\n  cols: {cols}\n  data: {}",
        yaml::list(data)
    );
    Ok(())
}

/// The camera_info text of one camera with rectification `r` and projection `p`.
pub fn write_camera(
    camera: &CameraCalibration,
    r: &Matrix3<f64>,
    p: &Matrix3x4<f64>,
) -> Result<String, ExportError> {
    camera.check()?;
    let (model, d) = ros_model(&camera.camera)?;
    let mut out = String::new();
    let _ = writeln!(out, "image_width: {}", camera.image_size.width);
    let _ = writeln!(out, "image_height: {}", camera.image_size.height);
    let name = if camera.name.is_empty() {
        "camera"
    } else {
        camera.name.as_str()
    };
    let _ = writeln!(out, "camera_name: {}", quote(name));
    let k = camera.matrix();
    block(&mut out, "camera_matrix", 3, 3, &rows3(&k))?;
    let _ = writeln!(out, "distortion_model: {model}");
    block(&mut out, "distortion_coefficients", 1, d.len(), &d)?;
    block(&mut out, "rectification_matrix", 3, 3, &rows3(r))?;
    let pd: Vec<f64> = (0..3)
        .flat_map(|i| (0..4).map(move |c| p[(i, c)]))
        .collect();
    block(&mut out, "projection_matrix", 3, 4, &pd)?;
    Ok(out)
}

fn rows3(m: &Matrix3<f64>) -> Vec<f64> {
    (0..3)
        .flat_map(|i| (0..3).map(move |c| m[(i, c)]))
        .collect()
}

/// A YAML scalar for a name: plain when safe, double-quoted otherwise.
fn quote(name: &str) -> String {
    let plain = name
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '/' | '.'))
        && name
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_' || c == '/');
    if plain {
        name.to_string()
    } else {
        serde_json::to_string(name).unwrap_or_else(|_| "\"camera\"".into())
    }
}

/// The camera_info of a camera without rectification: identity `R`, `P = [K' | 0]` with `K'`
/// the new camera matrix of `alpha` (0 when `None`).
fn unrectified(c: &CameraCalibration, alpha: Option<f64>) -> Result<String, ExportError> {
    let (k, _) = optimal_new_camera_matrix(&c.camera, c.image_size, alpha.unwrap_or(0.0))?;
    let p = Matrix3x4::from_fn(|i, j| if j < 3 { k[(i, j)] } else { 0.0 });
    write_camera(c, &Matrix3::identity(), &p)
}

/// The camera_info texts: one for a single camera, left and right (rectified) for a stereo
/// rig, one per camera (unrectified, in the rig's order) for an N-camera rig.
pub fn write(
    calibration: &Calibrated,
    options: &ExportOptions,
) -> Result<Vec<String>, ExportError> {
    calibration.check()?;
    match calibration {
        Calibrated::Single(c) => Ok(vec![unrectified(c, options.alpha)?]),
        Calibrated::Rig(r) => r
            .cameras
            .iter()
            .map(|c| {
                unrectified(c, options.alpha)
                    .map_err(|e| e.about_camera(&format!("camera '{}'", c.name)))
            })
            .collect(),
        Calibrated::Stereo(s) => {
            // camera_info of a stereo pair is its rectification: stereo_image_proc matches
            // rows of the images rectified with R and P. Identity R and P = [K | 0] would be
            // read as a rectified pair and give wrong depth without a word, so a rig that
            // cannot be rectified is refused, naming the OpenCV file that holds it without.
            let rect = stereo_rectify(s, options.alpha).map_err(|e| {
                ExportError::Unsupported(format!(
                    "ROS camera_info files of a stereo pair need its rectification (rectification_matrix, projection_matrix), which cannot be computed: {e}; nothing was written (--format opencv writes this calibration without the rectification)"
                ))
            })?;
            let mut p2 = rect.p2;
            p2[(0, 3)] *= options.translation_scale;
            p2[(1, 3)] *= options.translation_scale;
            Ok(vec![
                write_camera(&s.left, &rect.r1, &rect.p1)?,
                write_camera(&s.right, &rect.r2, &p2)?,
            ])
        }
    }
}

/// True if a parsed document looks like a camera_info file.
pub(crate) fn recognizes(v: &Value) -> bool {
    v.get("camera_matrix").is_some()
        && v.get("distortion_model")
            .and_then(Value::as_str)
            .is_some_and(|m| {
                matches!(
                    m,
                    "plumb_bob" | "rational_polynomial" | "equidistant" | "fisheye"
                )
            })
}

/// Reads a camera_info file (the camera only: rectification and projection are derived data).
pub(crate) fn read(doc: &Doc, v: &Value) -> Result<CameraCalibration, ExportError> {
    let width = doc.size(doc.get(v, "", "image_width")?, "image_width")?;
    let height = doc.size(doc.get(v, "", "image_height")?, "image_height")?;
    let name = match v.get("camera_name") {
        Some(n) => doc.string(n, "camera_name")?.to_string(),
        None => "camera".into(),
    };
    let (_, _, k) = doc.matrix(
        doc.get(v, "", "camera_matrix")?,
        "camera_matrix",
        Some((3, 3)),
    )?;
    let model_name = doc.string(doc.get(v, "", "distortion_model")?, "distortion_model")?;
    let (_, _, mut d) = doc.matrix(
        doc.get(v, "", "distortion_coefficients")?,
        "distortion_coefficients",
        None,
    )?;
    let model = match (model_name, d.len()) {
        ("plumb_bob", 5) if d[4] == 0.0 => {
            d.truncate(4);
            CameraModel::BrownConrady4
        }
        ("plumb_bob", 5) => CameraModel::BrownConrady5,
        ("plumb_bob", 4) => CameraModel::BrownConrady4,
        ("rational_polynomial", 8) => CameraModel::Rational8,
        ("equidistant" | "fisheye", 4) => CameraModel::KannalaBrandt4,
        (m, n) => {
            return Err(ExportError::field(
                doc.path,
                "distortion_coefficients",
                format!(
                    "{n} coefficients do not fit distortion_model '{m}' (plumb_bob: 5, rational_polynomial: 8, equidistant: 4)"
                ),
            ));
        }
    };
    let k = Matrix3::from_row_slice(&k);
    let camera = AnyCamera::new(model, intrinsics_of(&k), d)
        .map_err(|e| ExportError::field(doc.path, "distortion_coefficients", e.to_string()))?;
    let c = CameraCalibration {
        name,
        camera,
        image_size: ImageSize::new(width, height),
    };
    c.check()
        .map_err(|e| ExportError::field(doc.path, "camera_matrix", e.to_string()))?;
    Ok(c)
}
