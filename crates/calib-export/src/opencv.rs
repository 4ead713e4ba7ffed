//! OpenCV FileStorage YAML: what `cv2.FileStorage(path, cv2.FILE_STORAGE_READ)` reads.
//!
//! One camera:
//!
//! ```text
//! %YAML:1.0
//! ---
//! image_width: 640
//! image_height: 360
//! distortion_model: "brown-conrady4"
//! camera_matrix: !!opencv-matrix
//!    rows: 3
//!    cols: 3
//!    dt: d
//!    data: [ fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0 ]
//! distortion_coefficients: !!opencv-matrix
//!    rows: 1
//!    cols: 4
//!    dt: d
//!    data: [ k1, k2, p1, p2 ]
//! ```
//!
//! `distortion_coefficients` holds the model's coefficients in OpenCV's order (4, 5, 8 or 12 for
//! the pinhole models, ready for `cv2.undistort`; the 4 `cv2.fisheye` coefficients for
//! `kannala-brandt4`). `distortion_model` (our model name; OpenCV ignores keys it is not asked
//! for) tells a reader which model 4 coefficients mean; without it they are read as
//! `brown-conrady4`.
//!
//! A stereo rig uses the names of OpenCV's `stereo_calib` sample (`M1`, `D1`, `M2`, `D2`, `R`,
//! `T`) plus `E`, `F` and the rectification `R1`, `R2`, `P1`, `P2`, `Q`
//! ([`crate::rectify::stereo_rectify`] with the export's `alpha`), and `distortion_model_1`,
//! `distortion_model_2`. Cameras of different image sizes add `image_width_2`,
//! `image_height_2` and leave out the rectification (OpenCV's `stereoRectify` takes one size);
//! so does a rig whose rectification cannot be computed (a lens model that folds inside the
//! image, cameras turned too far apart for the export's `alpha`): `M1 ... F` are the whole
//! calibration, and a YAML comment where `R1 ... Q` would be says why they are missing and how
//! to get them ([`write_noting`] returns that reason too, for the caller to warn).
//!
//! A rig of N cameras (OpenCV has no layout of its own for it) is one map per camera,
//! `camera_0 ... camera_{N-1}`, each with the single camera's keys, its `name`, and `R`, `T`:
//! the camera's transform from the reference camera, `X_cam = R X_ref + T`:
//!
//! ```text
//! rig_cameras: 3
//! reference_camera: 0
//! camera_0:
//!    name: "left"
//!    image_width: 640
//!    image_height: 480
//!    distortion_model: "brown-conrady4"
//!    camera_matrix: !!opencv-matrix
//!       rows: 3
//!       ...
//!    distortion_coefficients: !!opencv-matrix ...
//!    R: !!opencv-matrix ...
//!    T: !!opencv-matrix ...
//! camera_1:
//!    ...
//! ```
//!
//! (`cv2.FileStorage(path, cv2.FILE_STORAGE_READ).getNode("camera_1").getNode("R").mat()`.)
//! The pair files of `M1 ... Q` for two cameras of a rig come from `calib export --pair`.

use crate::calibration::{CameraCalibration, CameraRig, StereoRig, intrinsics_of};
use crate::error::ExportError;
use crate::rectify::{Rectification, stereo_rectify};
use crate::yaml::{self, Doc};
use crate::{Calibrated, ExportOptions};
use calib_core::ImageSize;
use camera_model::{AnyCamera, CameraModel};
use nalgebra::{Matrix3, Vector3};
use serde_norway::Value;
use std::fmt::Write;

const HEADER: &str = "%YAML:1.0\n---\n";

/// Appends `name: !!opencv-matrix` with `rows x cols` row-major `data`.
fn matrix(
    out: &mut String,
    name: &str,
    rows: usize,
    cols: usize,
    data: &[f64],
) -> Result<(), ExportError> {
    nested_matrix(out, "", name, rows, cols, data)
}

/// [`matrix`] inside a map: every line starts with `indent`.
fn nested_matrix(
    out: &mut String,
    indent: &str,
    name: &str,
    rows: usize,
    cols: usize,
    data: &[f64],
) -> Result<(), ExportError> {
    yaml::check_finite(name, data)?;
    let items: Vec<String> = data.iter().map(|v| yaml::float(*v)).collect();
    let i = format!("{indent}   ");
    let _ = writeln!(
        out,
        "{indent}{name}: !!opencv-matrix\n{i}rows: {rows}\n{i}cols: {cols}\n{i}dt: d\n{i}data: [ {} ]",
        items.join(", ")
    );
    Ok(())
}

/// A string scalar OpenCV's parser takes: double-quoted, JSON escapes.
fn quoted(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into())
}

fn row_major<const R: usize, const C: usize>(m: &nalgebra::SMatrix<f64, R, C>) -> Vec<f64> {
    (0..R)
        .flat_map(|i| (0..C).map(move |k| m[(i, k)]))
        .collect()
}

/// The OpenCV YAML text of `calibration` ([`write_noting`] without the note).
pub fn write(calibration: &Calibrated, options: &ExportOptions) -> Result<String, ExportError> {
    write_noting(calibration, options).map(|(text, _)| text)
}

/// The rectification of a stereo rig for an OpenCV file, or why the file goes without it: the
/// two image sizes differ (`stereoRectify` takes one), or the rectification fails (a lens model
/// that is not one-to-one out to the image corners, cameras turned too far apart for `alpha`).
/// The calibration itself (`M1 ... F`) is valid either way, so it is written without `R1 ... Q`.
fn rectification_or_reason(s: &StereoRig, alpha: Option<f64>) -> Result<Rectification, String> {
    if s.right.image_size != s.left.image_size {
        return Err(format!(
            "the two cameras have different image sizes ({}x{} and {}x{}) and OpenCV's stereoRectify takes one size",
            s.left.image_size.width,
            s.left.image_size.height,
            s.right.image_size.width,
            s.right.image_size.height
        ));
    }
    stereo_rectify(s, alpha).map_err(|e| {
        format!(
            "they cannot be computed for this calibration ({e}); to get them, recalibrate with a lens model that is valid over the whole image (fewer terms, e.g. calib stereo --model brown-conrady5) or, where that says so, export again with another --alpha"
        )
    })
}

/// Appends `text` as YAML comment lines (`# ...`, at most about 100 characters each).
fn comment(out: &mut String, text: &str) {
    let mut line = String::from("#");
    for word in text.split_whitespace() {
        if line.len() > 1 && line.len() + 1 + word.len() > 100 {
            let _ = writeln!(out, "{line}");
            line = String::from("#");
        }
        line.push(' ');
        line.push_str(word);
    }
    let _ = writeln!(out, "{line}");
}

/// The OpenCV YAML text of `calibration`, and for a stereo rig written without its
/// rectification (`R1 ... Q`), the reason (also written in the file as a comment).
pub fn write_noting(
    calibration: &Calibrated,
    options: &ExportOptions,
) -> Result<(String, Option<String>), ExportError> {
    calibration.check()?;
    if let Some(a) = options.alpha {
        // A bad alpha is the caller's mistake, not a rig that cannot be rectified.
        crate::undistort::check_alpha(a)?;
    }
    let mut note = None;
    let mut out = String::from(HEADER);
    match calibration {
        Calibrated::Single(c) => {
            let _ = writeln!(out, "image_width: {}", c.image_size.width);
            let _ = writeln!(out, "image_height: {}", c.image_size.height);
            let _ = writeln!(out, "distortion_model: \"{}\"", c.camera.model);
            matrix(&mut out, "camera_matrix", 3, 3, &row_major(&c.matrix()))?;
            let d = &c.camera.distortion;
            matrix(&mut out, "distortion_coefficients", 1, d.len(), d)?;
        }
        Calibrated::Stereo(s) => {
            // OpenCV rectifies two images of one size (stereoRectify takes one imageSize): for
            // cameras of different sizes, or a rig that cannot be rectified, the file holds the
            // calibration without R1..Q, and a comment that says why.
            let rect = rectification_or_reason(s, options.alpha);
            let scale = options.translation_scale;
            let scaled = scaled_rig(s, scale);
            let _ = writeln!(out, "image_width: {}", s.left.image_size.width);
            let _ = writeln!(out, "image_height: {}", s.left.image_size.height);
            if s.right.image_size != s.left.image_size {
                let _ = writeln!(out, "image_width_2: {}", s.right.image_size.width);
                let _ = writeln!(out, "image_height_2: {}", s.right.image_size.height);
            }
            let _ = writeln!(out, "distortion_model_1: \"{}\"", s.left.camera.model);
            let _ = writeln!(out, "distortion_model_2: \"{}\"", s.right.camera.model);
            matrix(&mut out, "M1", 3, 3, &row_major(&s.left.matrix()))?;
            let d1 = &s.left.camera.distortion;
            matrix(&mut out, "D1", 1, d1.len(), d1)?;
            matrix(&mut out, "M2", 3, 3, &row_major(&s.right.matrix()))?;
            let d2 = &s.right.camera.distortion;
            matrix(&mut out, "D2", 1, d2.len(), d2)?;
            matrix(&mut out, "R", 3, 3, &row_major(&s.rotation))?;
            matrix(&mut out, "T", 3, 1, scaled.translation.as_slice())?;
            matrix(&mut out, "E", 3, 3, &row_major(&scaled.essential()))?;
            matrix(&mut out, "F", 3, 3, &row_major(&s.fundamental()))?;
            match rect {
                Ok(rect) => {
                    let mut p2 = rect.p2;
                    p2[(0, 3)] *= scale;
                    p2[(1, 3)] *= scale;
                    let mut q = rect.q;
                    q[(3, 2)] /= scale;
                    q[(3, 3)] /= scale;
                    matrix(&mut out, "R1", 3, 3, &row_major(&rect.r1))?;
                    matrix(&mut out, "R2", 3, 3, &row_major(&rect.r2))?;
                    matrix(&mut out, "P1", 3, 4, &row_major(&rect.p1))?;
                    matrix(&mut out, "P2", 3, 4, &row_major(&p2))?;
                    matrix(&mut out, "Q", 4, 4, &row_major(&q))?;
                }
                Err(reason) => {
                    comment(
                        &mut out,
                        &format!(
                            "R1, R2, P1, P2, Q (the rectification) are left out: {reason}. M1, D1, M2, D2, R, T, E, F above are the whole calibration."
                        ),
                    );
                    note = Some(format!(
                        "written without the rectification (R1, R2, P1, P2, Q): {reason}"
                    ));
                }
            }
        }
        Calibrated::Rig(r) => {
            let _ = writeln!(out, "rig_cameras: {}", r.cameras.len());
            let _ = writeln!(out, "reference_camera: {}", r.reference);
            for (i, (c, t)) in r.cameras.iter().zip(&r.transforms).enumerate() {
                let _ = writeln!(out, "camera_{i}:");
                let _ = writeln!(out, "   name: {}", quoted(&c.name));
                let _ = writeln!(out, "   image_width: {}", c.image_size.width);
                let _ = writeln!(out, "   image_height: {}", c.image_size.height);
                let _ = writeln!(out, "   distortion_model: \"{}\"", c.camera.model);
                let ind = "   ";
                nested_matrix(
                    &mut out,
                    ind,
                    "camera_matrix",
                    3,
                    3,
                    &row_major(&c.matrix()),
                )?;
                let d = &c.camera.distortion;
                nested_matrix(&mut out, ind, "distortion_coefficients", 1, d.len(), d)?;
                nested_matrix(&mut out, ind, "R", 3, 3, &row_major(&t.rotation))?;
                let tr = t.translation * options.translation_scale;
                nested_matrix(&mut out, ind, "T", 3, 1, tr.as_slice())?;
            }
        }
    }
    Ok((out, note))
}

/// The rig with its translation multiplied by `scale` (unit conversion for other tools).
pub(crate) fn scaled_rig(s: &StereoRig, scale: f64) -> StereoRig {
    let mut r = s.clone();
    r.translation *= scale;
    r
}

/// True if a parsed document looks like an OpenCV calibration file.
pub(crate) fn recognizes(text: &str, v: &Value) -> bool {
    let tagged = text.contains("!!opencv-matrix");
    (yaml::has_opencv_directive(text) || tagged)
        && (v.get("camera_matrix").is_some()
            || v.get("M1").is_some()
            || v.get("rig_cameras").is_some())
}

/// The model of `count` coefficients named `name` (if any) in a file.
pub(crate) fn model_of(
    doc: &Doc,
    name: Option<&Value>,
    key: &str,
    count: usize,
) -> Result<CameraModel, ExportError> {
    if let Some(name) = name {
        let name = doc.string(name, key)?;
        return name
            .parse::<CameraModel>()
            .map_err(|e| ExportError::field(doc.path, key, e.to_string()));
    }
    match count {
        4 => Ok(CameraModel::BrownConrady4),
        5 => Ok(CameraModel::BrownConrady5),
        8 => Ok(CameraModel::Rational8),
        12 => Ok(CameraModel::ThinPrism12),
        n => Err(ExportError::field(
            doc.path,
            key,
            format!(
                "{n} distortion coefficients match no supported model (4, 5, 8 or 12; the tilted 14-coefficient model is not supported)"
            ),
        )),
    }
}

/// The camera under keys `k_key`, `d_key`, `model_key` of map `v` (`prefix` is the map's key
/// in messages, empty at the top level).
#[allow(clippy::too_many_arguments)]
fn camera(
    doc: &Doc,
    v: &Value,
    prefix: &str,
    name: &str,
    k_key: &str,
    d_key: &str,
    model_key: &str,
    size: ImageSize,
) -> Result<CameraCalibration, ExportError> {
    let (k_field, d_field) = (yaml::join(prefix, k_key), yaml::join(prefix, d_key));
    let (_, _, k) = doc.matrix(doc.get(v, prefix, k_key)?, &k_field, Some((3, 3)))?;
    let (rows, cols, d) = doc.matrix(doc.get(v, prefix, d_key)?, &d_field, None)?;
    if rows != 1 && cols != 1 {
        return Err(ExportError::field(
            doc.path,
            &d_field,
            format!("expected a vector, got {rows}x{cols}"),
        ));
    }
    let model = model_of(
        doc,
        v.get(model_key),
        &yaml::join(prefix, model_key),
        d.len(),
    )?;
    let k = Matrix3::from_row_slice(&k);
    let camera = AnyCamera::new(model, intrinsics_of(&k), d)
        .map_err(|e| ExportError::field(doc.path, &d_field, e.to_string()))?;
    let c = CameraCalibration {
        name: name.into(),
        camera,
        image_size: size,
    };
    c.check()
        .map_err(|e| ExportError::field(doc.path, &k_field, e.to_string()))?;
    Ok(c)
}

/// A rotation and a 3-vector under `r_key`, `t_key` of map `v`.
fn rotation_translation(
    doc: &Doc,
    v: &Value,
    prefix: &str,
    r_key: &str,
    t_key: &str,
) -> Result<(Matrix3<f64>, Vector3<f64>), ExportError> {
    let t_field = yaml::join(prefix, t_key);
    let (_, _, r) = doc.matrix(
        doc.get(v, prefix, r_key)?,
        &yaml::join(prefix, r_key),
        Some((3, 3)),
    )?;
    let (rows, cols, t) = doc.matrix(doc.get(v, prefix, t_key)?, &t_field, None)?;
    if rows * cols != 3 {
        return Err(ExportError::field(
            doc.path,
            &t_field,
            format!("expected 3 numbers, got {rows}x{cols}"),
        ));
    }
    Ok((Matrix3::from_row_slice(&r), Vector3::from_row_slice(&t)))
}

/// Reads the `camera_0 ... camera_{N-1}` maps of a rig file.
fn read_rig(doc: &Doc, v: &Value) -> Result<CameraRig, ExportError> {
    let n = doc.size(doc.get(v, "", "rig_cameras")?, "rig_cameras")? as usize;
    if !(2..=10_000).contains(&n) {
        return Err(ExportError::field(
            doc.path,
            "rig_cameras",
            format!("expected 2 or more cameras, got {n}"),
        ));
    }
    let reference = match v.get("reference_camera") {
        Some(r) => doc.size(r, "reference_camera")? as usize,
        None => 0,
    };
    let mut cameras = Vec::with_capacity(n);
    let mut transforms = Vec::with_capacity(n);
    for i in 0..n {
        let key = format!("camera_{i}");
        let node = doc.get(v, "", &key)?;
        let field = |k: &str| yaml::join(&key, k);
        let size = ImageSize::new(
            doc.size(doc.get(node, &key, "image_width")?, &field("image_width"))?,
            doc.size(doc.get(node, &key, "image_height")?, &field("image_height"))?,
        );
        let name = match node.get("name") {
            Some(n) => doc.string(n, &field("name"))?.to_string(),
            None => key.clone(),
        };
        cameras.push(camera(
            doc,
            node,
            &key,
            &name,
            "camera_matrix",
            "distortion_coefficients",
            "distortion_model",
            size,
        )?);
        let (r, t) = rotation_translation(doc, node, &key, "R", "T")?;
        transforms.push(camera_model::Pose::new(r, t));
    }
    CameraRig::new(cameras, transforms, reference)
        .map_err(|e| ExportError::field(doc.path, "rig_cameras", e.to_string()))
}

/// Reads an OpenCV file written by [`write()`] (or by OpenCV with these keys).
pub(crate) fn read(doc: &Doc, v: &Value) -> Result<Calibrated, ExportError> {
    if v.get("rig_cameras").is_some() {
        return read_rig(doc, v).map(Calibrated::Rig);
    }
    let width = doc.size(doc.get(v, "", "image_width")?, "image_width")?;
    let height = doc.size(doc.get(v, "", "image_height")?, "image_height")?;
    let size = ImageSize::new(width, height);
    if v.get("M1").is_some() {
        let size2 = match (v.get("image_width_2"), v.get("image_height_2")) {
            (Some(w), Some(h)) => ImageSize::new(
                doc.size(w, "image_width_2")?,
                doc.size(h, "image_height_2")?,
            ),
            _ => size,
        };
        let left = camera(doc, v, "", "left", "M1", "D1", "distortion_model_1", size)?;
        let right = camera(doc, v, "", "right", "M2", "D2", "distortion_model_2", size2)?;
        let (rotation, translation) = rotation_translation(doc, v, "", "R", "T")?;
        let rig = StereoRig {
            left,
            right,
            rotation,
            translation,
        };
        rig.check()
            .map_err(|e| ExportError::field(doc.path, "R", e.to_string()))?;
        Ok(Calibrated::Stereo(rig))
    } else {
        Ok(Calibrated::Single(camera(
            doc,
            v,
            "",
            "camera",
            "camera_matrix",
            "distortion_coefficients",
            "distortion_model",
            size,
        )?))
    }
}
