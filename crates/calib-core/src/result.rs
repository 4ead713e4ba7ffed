//! Result pieces shared by the single-camera, stereo and rig results: a calibrated camera with
//! its uncertainties, per-view estimates, skipped views, timings and the summary lines. All are
//! serde types; the JSON keys are documented in `docs/formats.md`.

use crate::data::ImageSize;
use camera_model::{AnyCamera, CameraModel, Intrinsics, Pose};
use serde::{Deserialize, Serialize};
use std::fmt::Write;
use std::time::Duration;

/// Serde helpers: durations as seconds (`f64`).
pub mod seconds {
    use serde::{Deserialize, Deserializer, Serializer};
    use std::time::Duration;

    /// Writes a duration as seconds.
    pub fn serialize<S: Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f64(d.as_secs_f64())
    }

    /// Reads seconds into a duration (negative or non-finite values become zero).
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Duration, D::Error> {
        let v = f64::deserialize(d)?;
        Ok(Duration::try_from_secs_f64(v.max(0.0)).unwrap_or_default())
    }
}

/// Why a result's JSON form could not be read back (`from_json` of the single, stereo and rig
/// results, and of a rectification).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ResultFormatError {
    /// The `format` key is missing or names another kind of file (a stereo result given where a
    /// single-camera one is read, say).
    #[error("not a {expected} (format '{found}')")]
    WrongKind {
        /// The kind that was expected ("single-camera result", "rectification file", ...).
        expected: &'static str,
        /// The `format` key found (empty if missing).
        found: String,
    },
    /// A key is missing or has the wrong type or an invalid value (a camera with the wrong
    /// number of coefficients, a negative focal length): serde's message names it.
    #[error("{0}")]
    Malformed(#[from] serde_json::Error),
    /// A key holds a name the result does not know (a rotation parameterization, a start
    /// method).
    #[error("{key}: {reason}")]
    UnknownName {
        /// The JSON key.
        key: &'static str,
        /// What is wrong, with the accepted names.
        reason: String,
    },
}

impl ResultFormatError {
    /// Parses the name held by `key` (an enum with a `FromStr` whose error is its message).
    pub fn parse_name<T: std::str::FromStr<Err = String>>(
        key: &'static str,
        name: &str,
    ) -> Result<T, Self> {
        name.parse()
            .map_err(|reason| ResultFormatError::UnknownName { key, reason })
    }
}

/// Deserializes a result file of type `T` after checking that its `format` key starts with
/// `prefix` (e.g. `calib-single-result/`); `what` names the kind for the message
/// ("single-camera result").
pub fn deserialize_versioned<T: serde::de::DeserializeOwned>(
    value: serde_json::Value,
    prefix: &str,
    what: &'static str,
) -> Result<T, ResultFormatError> {
    let format = value.get("format").and_then(|f| f.as_str()).unwrap_or("");
    if !format.starts_with(prefix) {
        return Err(ResultFormatError::WrongKind {
            expected: what,
            found: format.to_string(),
        });
    }
    Ok(serde_json::from_value(value)?)
}

/// A duration from seconds (negative or non-finite values become zero).
pub fn duration_from_seconds(seconds: f64) -> Duration {
    Duration::try_from_secs_f64(seconds.max(0.0)).unwrap_or_default()
}

/// A calibrated camera with its uncertainties.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(into = "CameraEstimateJson", try_from = "CameraEstimateJson")]
pub struct CameraEstimate {
    /// The camera's name ("camera" for a single camera, "left", "cam2", ...).
    pub name: String,
    /// Lens model, intrinsics and distortion (OpenCV's order).
    pub camera: AnyCamera,
    /// Image size.
    pub image_size: ImageSize,
    /// Standard deviations of `fx, fy, cx, cy` (pixels; zero for fixed ones).
    pub intrinsics_std: [f64; 4],
    /// Standard deviations of the distortion coefficients (zero for fixed ones).
    pub distortion_std: Vec<f64>,
    /// Names of the parameters held fixed.
    pub fixed_parameters: Vec<String>,
    /// RMS reprojection error of this camera's points, pixels.
    pub rms: f64,
    /// Number of points used.
    pub num_points: usize,
}

#[derive(Serialize, Deserialize)]
struct StdJson {
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    distortion: serde_json::Map<String, serde_json::Value>,
    #[serde(default)]
    dist_coeffs: Vec<f64>,
}

#[derive(Serialize, Deserialize)]
struct CameraEstimateJson {
    #[serde(default)]
    name: String,
    model: CameraModel,
    #[serde(default)]
    projection: String,
    image_size: ImageSize,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    distortion: serde_json::Map<String, serde_json::Value>,
    camera_matrix: [[f64; 3]; 3],
    dist_coeffs: Vec<f64>,
    std: StdJson,
    #[serde(default)]
    fixed_parameters: Vec<String>,
    #[serde(default)]
    rms: f64,
    #[serde(default)]
    num_points: usize,
    /// Written for the reader, recomputed from the camera: not read back.
    #[serde(default, skip_deserializing)]
    validity: Option<ValidityJson>,
}

/// Where the lens model is one-to-one (`camera_model::validity`), in result files.
#[derive(Serialize, Deserialize)]
struct ValidityJson {
    /// Pixel radius from the principal point where the model stops being one-to-one; `null`:
    /// valid as far as it was checked (4 image radii, or the projection's range).
    valid_radius_px: Option<f64>,
    /// Distance to the farthest image corner.
    image_radius_px: f64,
    /// Valid over the whole image with a 5% margin.
    covers_image: bool,
}

/// `{name: value}` in the model's coefficient order.
pub fn named(model: CameraModel, values: &[f64]) -> serde_json::Map<String, serde_json::Value> {
    model
        .distortion_names()
        .iter()
        .zip(values)
        .map(|(n, v)| (n.to_string(), serde_json::json!(v)))
        .collect()
}

impl From<CameraEstimate> for CameraEstimateJson {
    fn from(e: CameraEstimate) -> Self {
        let k = e.camera.intrinsics;
        let s = e.intrinsics_std;
        let m = k.matrix();
        CameraEstimateJson {
            name: e.name,
            model: e.camera.model,
            projection: e.camera.model.projection_name().to_string(),
            image_size: e.image_size,
            fx: k.fx,
            fy: k.fy,
            cx: k.cx,
            cy: k.cy,
            distortion: named(e.camera.model, &e.camera.distortion),
            camera_matrix: std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)])),
            dist_coeffs: e.camera.distortion.clone(),
            std: StdJson {
                fx: s[0],
                fy: s[1],
                cx: s[2],
                cy: s[3],
                distortion: named(e.camera.model, &e.distortion_std),
                dist_coeffs: e.distortion_std,
            },
            fixed_parameters: e.fixed_parameters,
            rms: e.rms,
            num_points: e.num_points,
            validity: Some({
                let v = e.camera.validity(e.image_size.width, e.image_size.height);
                ValidityJson {
                    valid_radius_px: v.valid_radius_px.is_finite().then_some(v.valid_radius_px),
                    image_radius_px: v.image_radius_px,
                    covers_image: v.covers_image(crate::diagnostics::VALIDITY_MARGIN),
                }
            }),
        }
    }
}

impl TryFrom<CameraEstimateJson> for CameraEstimate {
    type Error = String;
    fn try_from(j: CameraEstimateJson) -> Result<Self, String> {
        let camera = AnyCamera::new(
            j.model,
            Intrinsics::new(j.fx, j.fy, j.cx, j.cy),
            j.dist_coeffs,
        )
        .map_err(|e| e.to_string())?;
        let n = camera.distortion.len();
        let distortion_std = if j.std.dist_coeffs.len() == n {
            j.std.dist_coeffs
        } else {
            j.model
                .distortion_names()
                .iter()
                .map(|name| {
                    j.std
                        .distortion
                        .get(*name)
                        .and_then(|v| v.as_f64())
                        .unwrap_or(0.0)
                })
                .collect()
        };
        Ok(CameraEstimate {
            name: j.name,
            camera,
            image_size: j.image_size,
            intrinsics_std: [j.std.fx, j.std.fy, j.std.cx, j.std.cy],
            distortion_std,
            fixed_parameters: j.fixed_parameters,
            rms: j.rms,
            num_points: j.num_points,
        })
    }
}

/// The estimate for one view (one camera's view of the board in one frame).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ViewResult {
    /// Index of the view in the input.
    pub index: usize,
    /// The view's name (image file).
    #[serde(rename = "image")]
    pub name: String,
    /// Board-to-camera pose (`rotation_matrix`, `rotation_vector`, `euler_xyz`, `translation`).
    #[serde(flatten)]
    pub pose: Pose,
    /// The pose parameters `[rho (3), t (3)]` in the calibration's rotation parameterization.
    pub pose_params: [f64; 6],
    /// Standard deviations of `pose_params` (same units: radians, board units).
    pub pose_std: [f64; 6],
    /// RMS reprojection error of this view's used points, pixels.
    pub rms: f64,
    /// Number of points used (rejected outliers not counted).
    #[serde(rename = "points")]
    pub num_points: usize,
    /// Points rejected as outliers: their indices in the view's input lists.
    #[serde(default)]
    pub rejected_points: Vec<usize>,
}

/// A view left out because it failed the checks (only with `skip_bad_views`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkippedView {
    /// Index in the input.
    pub index: usize,
    /// The view's name.
    #[serde(rename = "image")]
    pub name: String,
    /// Why it was skipped.
    pub reason: String,
}

/// Wall time of each stage of a calibration (seconds in files).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct StageTimes {
    /// Input checks and homographies.
    #[serde(with = "seconds")]
    pub homographies: Duration,
    /// Closed-form intrinsics and poses.
    #[serde(with = "seconds")]
    pub initialization: Duration,
    /// Levenberg-Marquardt.
    #[serde(with = "seconds")]
    pub optimization: Duration,
    /// Covariance and result assembly.
    #[serde(with = "seconds")]
    pub uncertainty: Duration,
}

/// Appends the camera lines of a human summary (focal length, principal point, distortion, each
/// with +- 3 sigma, the parameters held fixed, and where the lens model is one-to-one over a
/// `image_size` image), every line prefixed with `indent`.
pub fn write_camera_summary(
    out: &mut String,
    indent: &str,
    camera: &AnyCamera,
    image_size: ImageSize,
    intrinsics_std: &[f64; 4],
    distortion_std: &[f64],
    fixed_parameters: &[String],
) {
    let k = &camera.intrinsics;
    let s = intrinsics_std;
    let _ = writeln!(out, "{indent}model            {}", camera.model);
    let _ = writeln!(
        out,
        "{indent}focal length     fx, fy = {:>11.5} {:>11.5}   +- {:.5} {:.5}",
        k.fx,
        k.fy,
        3.0 * s[0],
        3.0 * s[1]
    );
    let _ = writeln!(
        out,
        "{indent}principal point  cx, cy = {:>11.5} {:>11.5}   +- {:.5} {:.5}",
        k.cx,
        k.cy,
        3.0 * s[2],
        3.0 * s[3]
    );
    let values: Vec<String> = camera
        .distortion
        .iter()
        .map(|v| format!("{v:>9.5}"))
        .collect();
    let sigmas: Vec<String> = distortion_std
        .iter()
        .map(|v| format!("{:.5}", 3.0 * v))
        .collect();
    let _ = writeln!(
        out,
        "{indent}distortion ({}) = {}   +- {}",
        camera.model.distortion_names().join(", "),
        values.join(" "),
        sigmas.join(" ")
    );
    if !fixed_parameters.is_empty() {
        let _ = writeln!(out, "{indent}held fixed: {}", fixed_parameters.join(", "));
    }
    let v = camera.validity(image_size.width, image_size.height);
    if v.covers_image(crate::diagnostics::VALIDITY_MARGIN) {
        let _ = writeln!(out, "{indent}lens model one-to-one over the whole image");
    } else {
        let _ = writeln!(
            out,
            "{indent}lens model one-to-one only within {:.0} px of the principal point (image corners at {:.0} px)",
            v.valid_radius_px, v.image_radius_px
        );
    }
}

impl CameraEstimate {
    /// The summary lines of this camera (see [`write_camera_summary`]).
    pub fn write_summary(&self, out: &mut String, indent: &str) {
        write_camera_summary(
            out,
            indent,
            &self.camera,
            self.image_size,
            &self.intrinsics_std,
            &self.distortion_std,
            &self.fixed_parameters,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_estimate_round_trips_with_named_coefficients() {
        let e = CameraEstimate {
            name: "left".into(),
            camera: AnyCamera::new(
                CameraModel::Rational8,
                Intrinsics::new(500.0, 510.0, 320.0, 240.0),
                vec![0.1, 0.2, 0.001, 0.002, 0.3, 0.01, 0.02, 0.03],
            )
            .unwrap(),
            image_size: ImageSize::new(640, 480),
            intrinsics_std: [1.0, 1.1, 0.5, 0.6],
            distortion_std: vec![0.01; 8],
            fixed_parameters: vec!["k6".into()],
            rms: 0.2,
            num_points: 540,
        };
        let json = serde_json::to_value(&e).unwrap();
        assert_eq!(json["model"], "rational8");
        assert_eq!(json["distortion"]["k5"], 0.02);
        assert_eq!(json["dist_coeffs"].as_array().unwrap().len(), 8);
        assert_eq!(json["camera_matrix"][1][2], 240.0);
        assert_eq!(json["std"]["distortion"]["p1"], 0.01);
        let back: CameraEstimate = serde_json::from_value(json).unwrap();
        assert_eq!(back, e);
    }
}
