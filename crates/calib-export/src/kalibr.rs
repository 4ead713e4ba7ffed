//! Kalibr camchain YAML (`camchain.yaml`, what Kalibr writes and its tools and VIO systems read):
//!
//! ```text
//! cam0:
//!   cam_overlaps: [1]
//!   camera_model: pinhole
//!   distortion_coeffs: [k1, k2, r1, r2]
//!   distortion_model: radtan
//!   intrinsics: [fu, fv, pu, pv]
//!   resolution: [640, 360]
//!   rostopic: /left/image_raw
//! cam1:
//!   T_cn_cnm1:
//!     - [r11, r12, r13, t1]
//!     - [r21, r22, r23, t2]
//!     - [r31, r32, r33, t3]
//!     - [0.0, 0.0, 0.0, 1.0]
//!   ...
//! ```
//!
//! The rows of `T_cn_cnm1` are indented below their key (Kalibr's own files put them at its
//! level, which YAML allows but OpenCV's `FileStorage` refuses): the file reads in both.
//!
//! `T_cn_cnm1` maps camera `n-1`'s frame to camera `n`'s: for a stereo rig it is `[R | T]`
//! (`X_right = R X_left + T`), `T` in board units times the export's translation scale (Kalibr
//! uses metres). A rig of N cameras is written as the chain `cam0 ... cam{N-1}` in the rig's
//! camera order, each transform relative to the previous camera, and `cam_overlaps` lists the
//! cameras that shared views; reading a chain of three or more cameras gives a rig whose
//! reference is `cam0`. Models: `brown-conrady4` is `pinhole` with `radtan`, `kannala-brandt4` is
//! `pinhole` with `equidistant`, `brown-conrady5` only with `k3 = 0` (radtan has no k3);
//! `rational8` and `thin-prism12` have no Kalibr equivalent and give
//! [`ExportError::UnsupportedModel`]. Kalibr's pixel convention is OpenCV's. A camera's name
//! travels in its `rostopic`, `/NAME/image_raw` (`/camN/image_raw` for a name that cannot be a
//! topic segment: a letter, then letters, digits and underscores), and is read back from there
//! (else the camera is named by its key, `camN`).

use crate::calibration::{CameraCalibration, CameraRig, StereoRig};
use crate::error::ExportError;
use crate::yaml::{self, Doc};
use crate::{Calibrated, ExportOptions};
use calib_core::ImageSize;
use camera_model::{AnyCamera, CameraModel, Intrinsics, Pose};
use nalgebra::{Matrix3, Vector3};
use serde_norway::Value;
use std::fmt::Write;

/// Refuses a lens model Kalibr has no name for (before any calibration is run; brown-conrady5
/// passes, as its k3 may end at zero).
pub(crate) fn check_model(model: CameraModel) -> Result<(), ExportError> {
    let camera = AnyCamera::new(
        model,
        Intrinsics::new(1.0, 1.0, 0.0, 0.0),
        vec![0.0; model.num_distortion_params()],
    )
    .map_err(|e| ExportError::Unsupported(e.to_string()))?;
    kalibr_model(&camera).map(|_| ())
}

fn kalibr_model(camera: &AnyCamera) -> Result<(&'static str, Vec<f64>), ExportError> {
    let d = &camera.distortion;
    let unsupported = |detail: &str| ExportError::UnsupportedModel {
        format: "kalibr",
        model: camera.model,
        detail: detail.to_string(),
    };
    match camera.model {
        CameraModel::BrownConrady4 => Ok(("radtan", d.clone())),
        CameraModel::BrownConrady5 if d[4] == 0.0 => Ok(("radtan", d[..4].to_vec())),
        CameraModel::BrownConrady5 => Err(unsupported(&format!(
            " with k3 = {} (Kalibr's radtan has k1 k2 r1 r2 only; calibrate with --model brown-conrady4)",
            d[4]
        ))),
        CameraModel::KannalaBrandt4 => Ok(("equidistant", d.clone())),
        CameraModel::Rational8 | CameraModel::ThinPrism12 => Err(unsupported(
            " (Kalibr knows radtan and equidistant distortion; calibrate with --model brown-conrady4 or kannala-brandt4)",
        )),
    }
}

fn camera_block(
    out: &mut String,
    index: usize,
    camera: &CameraCalibration,
    overlaps: &[usize],
    transform: Option<(&Matrix3<f64>, &Vector3<f64>)>,
) -> Result<(), ExportError> {
    camera.check()?;
    let (model, d) = kalibr_model(&camera.camera)?;
    let k = camera.camera.intrinsics;
    let _ = writeln!(out, "cam{index}:");
    if let Some((r, t)) = transform {
        yaml::check_finite("T_cn_cnm1", r.as_slice())?;
        yaml::check_finite("T_cn_cnm1", t.as_slice())?;
        let _ = writeln!(out, "  T_cn_cnm1:");
        for i in 0..3 {
            let _ = writeln!(
                out,
                "    - {}",
                yaml::list(&[r[(i, 0)], r[(i, 1)], r[(i, 2)], t[i]])
            );
        }
        let _ = writeln!(out, "    - [0.0, 0.0, 0.0, 1.0]");
    }
    let overlaps: Vec<String> = overlaps.iter().map(usize::to_string).collect();
    let _ = writeln!(out, "  cam_overlaps: [{}]", overlaps.join(", "));
    let _ = writeln!(out, "  camera_model: pinhole");
    let _ = writeln!(out, "  distortion_coeffs: {}", yaml::list(&d));
    let _ = writeln!(out, "  distortion_model: {model}");
    let intrinsics = [k.fx, k.fy, k.cx, k.cy];
    yaml::check_finite("intrinsics", &intrinsics)?;
    let _ = writeln!(out, "  intrinsics: {}", yaml::list(&intrinsics));
    let _ = writeln!(
        out,
        "  resolution: [{}, {}]",
        camera.image_size.width, camera.image_size.height
    );
    let topic = if is_topic_name(&camera.name) {
        camera.name.clone()
    } else {
        format!("cam{index}")
    };
    let _ = writeln!(out, "  rostopic: /{topic}/image_raw");
    Ok(())
}

/// The camchain text of `calibration` (one camera: `cam0` only).
pub fn write(calibration: &Calibrated, options: &ExportOptions) -> Result<String, ExportError> {
    calibration.check()?;
    let mut out = String::new();
    match calibration {
        Calibrated::Single(c) => camera_block(&mut out, 0, c, &[], None)?,
        Calibrated::Stereo(s) => {
            let t = s.translation * options.translation_scale;
            camera_block(&mut out, 0, &s.left, &[1], None)?;
            camera_block(&mut out, 1, &s.right, &[0], Some((&s.rotation, &t)))?;
        }
        Calibrated::Rig(r) => {
            for (n, camera) in r.cameras.iter().enumerate() {
                let chain = (n > 0).then(|| {
                    let t = r.relative(n - 1, n);
                    (t.rotation, t.translation * options.translation_scale)
                });
                camera_block(
                    &mut out,
                    n,
                    camera,
                    &r.overlaps[n],
                    chain.as_ref().map(|(r, t)| (r, t)),
                )
                .map_err(|e| e.about_camera(&format!("camera '{}', cam{n}", camera.name)))?;
            }
        }
    }
    Ok(out)
}

/// True if a parsed document looks like a camchain.
pub(crate) fn recognizes(v: &Value) -> bool {
    v.get("cam0").is_some_and(|c| c.get("intrinsics").is_some())
}

fn camera(doc: &Doc, v: &Value, key: &str) -> Result<CameraCalibration, ExportError> {
    let cam = doc.get(v, "", key)?;
    let field = |k: &str| format!("{key}.{k}");
    let projection = doc.string(doc.get(cam, key, "camera_model")?, &field("camera_model"))?;
    if projection != "pinhole" {
        return Err(ExportError::field(
            doc.path,
            &field("camera_model"),
            format!(
                "'{projection}' is not supported (only pinhole, with radtan or equidistant distortion)"
            ),
        ));
    }
    let k = doc.numbers(
        doc.get(cam, key, "intrinsics")?,
        &field("intrinsics"),
        Some(4),
    )?;
    let d = doc.numbers(
        doc.get(cam, key, "distortion_coeffs")?,
        &field("distortion_coeffs"),
        None,
    )?;
    let name = doc.string(
        doc.get(cam, key, "distortion_model")?,
        &field("distortion_model"),
    )?;
    let model = match (name, d.len()) {
        ("radtan", 4) => CameraModel::BrownConrady4,
        ("equidistant", 4) => CameraModel::KannalaBrandt4,
        (m, n) => {
            return Err(ExportError::field(
                doc.path,
                &field("distortion_model"),
                format!(
                    "'{m}' with {n} coefficients is not supported (radtan or equidistant, 4 coefficients)"
                ),
            ));
        }
    };
    let res = doc.numbers(
        doc.get(cam, key, "resolution")?,
        &field("resolution"),
        Some(2),
    )?;
    if res
        .iter()
        .any(|r| *r < 1.0 || r.fract() != 0.0 || *r > u32::MAX as f64)
    {
        return Err(ExportError::field(
            doc.path,
            &field("resolution"),
            format!("expected two positive integers, got {res:?}"),
        ));
    }
    let camera = AnyCamera::new(model, Intrinsics::new(k[0], k[1], k[2], k[3]), d)
        .map_err(|e| ExportError::field(doc.path, &field("distortion_coeffs"), e.to_string()))?;
    // The camera's name travels in its topic, `/NAME/image_raw` (what the writer puts there).
    let name = cam
        .get("rostopic")
        .and_then(Value::as_str)
        .and_then(|t| t.strip_prefix('/')?.strip_suffix("/image_raw"))
        .filter(|n| is_topic_name(n))
        .unwrap_or(key);
    let c = CameraCalibration {
        name: name.to_string(),
        camera,
        image_size: ImageSize::new(res[0] as u32, res[1] as u32),
    };
    c.check()
        .map_err(|e| ExportError::field(doc.path, &field("intrinsics"), e.to_string()))?;
    Ok(c)
}

/// A camera name that can stand as one segment of a ROS topic (`/NAME/image_raw`): a letter,
/// then letters, digits and underscores.
fn is_topic_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// The transform `T_cn_cnm1` of camera block `key`.
fn chain_transform(doc: &Doc, v: &Value, key: &str) -> Result<Pose, ExportError> {
    let field = format!("{key}.T_cn_cnm1");
    let cam = doc.get(v, "", key)?;
    let rows = cam
        .get("T_cn_cnm1")
        .and_then(Value::as_sequence)
        .ok_or_else(|| ExportError::field(doc.path, &field, "missing or not a list of 4 rows"))?;
    if rows.len() != 4 {
        return Err(ExportError::field(
            doc.path,
            &field,
            format!("expected 4 rows, got {}", rows.len()),
        ));
    }
    let mut m = [[0.0; 4]; 4];
    for (i, row) in rows.iter().enumerate() {
        let r = doc.numbers(row, &format!("{field}[{i}]"), Some(4))?;
        m[i].copy_from_slice(&r);
    }
    Ok(Pose::new(
        Matrix3::from_fn(|i, k| m[i][k]),
        Vector3::new(m[0][3], m[1][3], m[2][3]),
    ))
}

/// The `cam_overlaps` of camera block `key` (indices below `n`), if given.
fn overlaps(doc: &Doc, v: &Value, key: &str, n: usize) -> Result<Option<Vec<usize>>, ExportError> {
    let field = format!("{key}.cam_overlaps");
    let Some(list) = v.get(key).and_then(|c| c.get("cam_overlaps")) else {
        return Ok(None);
    };
    let numbers = doc.numbers(list, &field, None)?;
    numbers
        .iter()
        .map(|&x| {
            if x >= 0.0 && x.fract() == 0.0 && (x as usize) < n {
                Ok(x as usize)
            } else {
                Err(ExportError::field(
                    doc.path,
                    &field,
                    format!(
                        "{x} is not the index of another camera (cam0..cam{})",
                        n - 1
                    ),
                ))
            }
        })
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}

/// Reads a camchain: `cam0` alone is a single camera, `cam0` and `cam1` a stereo rig, three
/// or more consecutive cameras a rig with `cam0` as reference.
pub(crate) fn read(doc: &Doc, v: &Value) -> Result<Calibrated, ExportError> {
    let mut keys = Vec::new();
    while v.get(format!("cam{}", keys.len())).is_some() {
        keys.push(format!("cam{}", keys.len()));
    }
    if let Some(extra) = v.as_mapping().and_then(|m| {
        m.keys()
            .filter_map(Value::as_str)
            .find(|k| {
                k.starts_with("cam")
                    && k[3..].parse::<usize>().is_ok()
                    && !keys.iter().any(|c| c == k)
            })
            .map(str::to_string)
    }) {
        return Err(ExportError::field(
            doc.path,
            &extra,
            format!(
                "the cameras must be numbered cam0, cam1, ... without gaps (cam{} is missing)",
                keys.len()
            ),
        ));
    }
    let mut cameras = keys
        .iter()
        .map(|k| camera(doc, v, k))
        .collect::<Result<Vec<_>, _>>()?;
    // Names from topics that repeat (two cameras on one topic) cannot tell the cameras apart:
    // then every camera keeps its key.
    let mut names: Vec<&str> = cameras.iter().map(|c| c.name.as_str()).collect();
    names.sort_unstable();
    if names.windows(2).any(|w| w[0] == w[1]) {
        for (camera, key) in cameras.iter_mut().zip(&keys) {
            camera.name.clone_from(key);
        }
    }
    match cameras.len() {
        1 => Ok(Calibrated::Single(
            cameras.into_iter().next().expect("one camera"),
        )),
        2 => {
            let t = chain_transform(doc, v, "cam1")?;
            let mut cameras = cameras.into_iter();
            let rig = StereoRig {
                left: cameras.next().expect("two cameras"),
                right: cameras.next().expect("two cameras"),
                rotation: t.rotation,
                translation: t.translation,
            };
            rig.check()
                .map_err(|e| ExportError::field(doc.path, "cam1.T_cn_cnm1", e.to_string()))?;
            Ok(Calibrated::Stereo(rig))
        }
        n => {
            let mut transforms = vec![Pose::identity()];
            for k in &keys[1..] {
                let t = chain_transform(doc, v, k)?;
                crate::calibration::check_rotation(&t.rotation, &format!("{k}.T_cn_cnm1"))
                    .map_err(|e| {
                        ExportError::field(doc.path, &format!("{k}.T_cn_cnm1"), e.to_string())
                    })?;
                let previous = *transforms.last().expect("cam0");
                transforms.push(t.compose(&previous));
            }
            let mut rig = CameraRig::new(cameras, transforms, 0)
                .map_err(|e| ExportError::field(doc.path, "cam0", e.to_string()))?;
            for (i, k) in keys.iter().enumerate() {
                if let Some(o) = overlaps(doc, v, k, n)? {
                    rig.overlaps[i] = o.into_iter().filter(|&j| j != i).collect();
                }
            }
            Ok(Calibrated::Rig(rig))
        }
    }
}
