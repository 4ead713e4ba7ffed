//! The stereo calibration result, its summary and its JSON form (`docs/formats.md`). The result
//! is a serde type: [`StereoCalibration::to_json`] writes it and [`StereoCalibration::from_json`]
//! reads it back.

use crate::bootstrap::{CameraSpread, StereoBootstrap};
use calib_core::init::StartMethod;
pub use calib_core::result::CameraEstimate;
use calib_core::result::{
    ResultFormatError, deserialize_versioned, duration_from_seconds, seconds,
};
use calib_core::warnings::{Warning, write_warnings};
use camera_model::{AxisAngle, EulerXyz, Pose, RotationKind, RotationParameterization};
use lm_solver::SolverReport;
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};
use std::fmt::Write;
use std::time::Duration;

/// The `format` key of stereo result files.
pub const FORMAT: &str = "calib-stereo-result/2";

/// The estimate for one pair.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairResult {
    /// Index of the pair in the input.
    pub index: usize,
    /// Names of the two views (`left_image`, `right_image` in files).
    #[serde(with = "names")]
    #[serde(flatten)]
    pub names: (String, String),
    /// Board-to-left-camera pose.
    #[serde(flatten)]
    pub left_pose: Pose,
    /// Its parameters `[rho, t]` in the calibration's rotation parameterization.
    pub pose_params: [f64; 6],
    /// Their standard deviations.
    pub pose_std: [f64; 6],
    /// RMS of the left view, pixels.
    pub rms_left: f64,
    /// RMS of the right view, pixels.
    pub rms_right: f64,
    /// Points per view (the left view's), rejected outliers included.
    #[serde(rename = "points")]
    pub num_points: usize,
    /// Points of the left view rejected as outliers (indices in its input lists).
    #[serde(default)]
    pub rejected_left: Vec<usize>,
    /// Points of the right view rejected as outliers.
    #[serde(default)]
    pub rejected_right: Vec<usize>,
}

mod names {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    #[derive(Serialize, Deserialize)]
    struct Names {
        left_image: String,
        right_image: String,
    }

    pub fn serialize<S: Serializer>(n: &(String, String), s: S) -> Result<S::Ok, S::Error> {
        Names {
            left_image: n.0.clone(),
            right_image: n.1.clone(),
        }
        .serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<(String, String), D::Error> {
        let n = Names::deserialize(d)?;
        Ok((n.left_image, n.right_image))
    }
}

/// A pair left out by `skip_bad_pairs`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkippedPair {
    /// Index in the input.
    pub index: usize,
    /// Why.
    pub reason: String,
}

/// A calibrated stereo rig.
#[derive(Debug, Clone, PartialEq)]
pub struct StereoCalibration {
    /// The left (reference) camera.
    pub left: CameraEstimate,
    /// The right camera.
    pub right: CameraEstimate,
    /// Left camera to right camera: `X_right = R X_left + T` (OpenCV's `R`, `T`).
    pub rig: Pose,
    /// The rig's parameters `[rho, T]` in `rotation`'s parameterization.
    pub rig_params: [f64; 6],
    /// Their standard deviations (radians, board units).
    pub rig_std: [f64; 6],
    /// Rotation parameterization of poses and rig.
    pub rotation: RotationKind,
    /// Essential matrix `E = [T]x R`: `x_R^T E x_L = 0` for normalized image points.
    pub essential: Matrix3<f64>,
    /// Fundamental matrix `F = K_R^-T E K_L^-1`, scaled so that `F[2][2] = 1` when possible:
    /// `p_R^T F p_L = 0` for undistorted pixels.
    pub fundamental: Matrix3<f64>,
    /// `|T|`, board units.
    pub baseline: f64,
    /// RMS over the used points of both cameras, pixels (rejected outliers left out).
    pub rms: f64,
    /// RMS over every point, rejected outliers included, pixels.
    pub rms_all_points: f64,
    /// Number of points rejected as outliers (listed per pair).
    pub num_rejected: usize,
    /// What deserves attention (empty when all is well).
    pub warnings: Vec<Warning>,
    /// One entry per used pair.
    pub pairs: Vec<PairResult>,
    /// Pairs that were skipped.
    pub skipped_pairs: Vec<SkippedPair>,
    /// Residual variance used to scale the covariance, pixels^2.
    pub residual_variance: f64,
    /// The rig before the joint optimization.
    pub initial_rig: Pose,
    /// Where each camera's initial intrinsics came from (left, right).
    pub initial_methods: [StartMethod; 2],
    /// RMS at the start of the joint optimization (single-camera estimates and initial rig).
    pub initial_rms: f64,
    /// The joint Levenberg-Marquardt report.
    pub solver: SolverReport,
    /// Wall time of the whole stereo calibration (single-camera calibrations included).
    pub elapsed: Duration,
    /// Wall time of the single-camera calibrations (left, right), the joint optimization and the
    /// covariance with result assembly.
    pub stage_times: [Duration; 4],
    /// The pair bootstrap's standard deviations, when one was run ([`crate::add_bootstrap`],
    /// `calib stereo --bootstrap N`); `None` otherwise.
    pub bootstrap: Option<StereoBootstrap>,
}

fn rows(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

fn from_rows(r: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| r[i][j])
}

#[derive(Serialize, Deserialize)]
struct StageSeconds {
    #[serde(with = "seconds")]
    left_single_camera: Duration,
    #[serde(with = "seconds")]
    right_single_camera: Duration,
    #[serde(with = "seconds")]
    joint_optimization: Duration,
    #[serde(with = "seconds")]
    uncertainty: Duration,
}

#[derive(Serialize, Deserialize)]
struct InitialJson {
    rms: f64,
    left_method: String,
    right_method: String,
    #[serde(rename = "R")]
    r: [[f64; 3]; 3],
    #[serde(rename = "T")]
    t: [f64; 3],
}

#[derive(Serialize, Deserialize)]
struct StereoJson {
    format: String,
    #[serde(default)]
    pixel_convention: String,
    #[serde(default)]
    rig_convention: String,
    rms: f64,
    #[serde(default)]
    rms_all_points: f64,
    #[serde(default)]
    num_rejected: usize,
    #[serde(default)]
    warnings: Vec<Warning>,
    elapsed_seconds: f64,
    stage_seconds: StageSeconds,
    num_pairs: usize,
    left: CameraEstimate,
    right: CameraEstimate,
    #[serde(rename = "R")]
    r: [[f64; 3]; 3],
    rotation_vector: [f64; 3],
    euler_xyz: [f64; 3],
    rotation_angle_deg: f64,
    #[serde(rename = "T")]
    t: [f64; 3],
    baseline: f64,
    rig_parameterization: String,
    rig_params: [f64; 6],
    rig_std: [f64; 6],
    #[serde(rename = "E")]
    e: [[f64; 3]; 3],
    #[serde(rename = "F")]
    f: [[f64; 3]; 3],
    residual_variance: f64,
    initial: InitialJson,
    pairs: Vec<PairResult>,
    skipped_pairs: Vec<SkippedPair>,
    solver: SolverReport,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    bootstrap: Option<BootstrapJson>,
}

/// The `bootstrap` object of stereo result files: each camera's standard deviations over pair
/// resamples in the shape of its `std`, and the rig's in that of `rig_std`.
#[derive(Serialize, Deserialize)]
struct BootstrapJson {
    resamples: usize,
    failed: usize,
    seed: u64,
    elapsed_seconds: f64,
    left: CameraSpreadJson,
    right: CameraSpreadJson,
    rig_std: [f64; 6],
    baseline_std: f64,
}

#[derive(Serialize, Deserialize)]
struct CameraSpreadJson {
    std: CameraStdJson,
}

#[derive(Serialize, Deserialize)]
struct CameraStdJson {
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    distortion: serde_json::Map<String, serde_json::Value>,
    dist_coeffs: Vec<f64>,
}

impl CameraSpreadJson {
    fn new(spread: &CameraSpread, estimate: &CameraEstimate) -> Self {
        let s = &spread.intrinsics_std;
        CameraSpreadJson {
            std: CameraStdJson {
                fx: s[0],
                fy: s[1],
                cx: s[2],
                cy: s[3],
                distortion: estimate
                    .camera
                    .model
                    .distortion_names()
                    .iter()
                    .zip(&spread.distortion_std)
                    .map(|(name, s)| (name.to_string(), serde_json::json!(s)))
                    .collect(),
                dist_coeffs: spread.distortion_std.clone(),
            },
        }
    }

    fn spread(self) -> CameraSpread {
        let s = self.std;
        CameraSpread {
            intrinsics_std: [s.fx, s.fy, s.cx, s.cy],
            distortion_std: s.dist_coeffs,
        }
    }
}

impl StereoCalibration {
    fn to_file(&self) -> StereoJson {
        let r = &self.rig;
        let w = AxisAngle::from_matrix(&r.rotation);
        let e = EulerXyz::from_matrix(&r.rotation);
        let t = r.translation;
        let t0 = self.initial_rig.translation;
        StereoJson {
            format: FORMAT.into(),
            pixel_convention: "OpenCV: (0,0) is the centre of the top-left pixel, x right, y down"
                .into(),
            rig_convention: "X_right = R X_left + T; poses map board to left camera".into(),
            rms: self.rms,
            rms_all_points: self.rms_all_points,
            num_rejected: self.num_rejected,
            warnings: self.warnings.clone(),
            elapsed_seconds: self.elapsed.as_secs_f64(),
            stage_seconds: StageSeconds {
                left_single_camera: self.stage_times[0],
                right_single_camera: self.stage_times[1],
                joint_optimization: self.stage_times[2],
                uncertainty: self.stage_times[3],
            },
            num_pairs: self.pairs.len(),
            left: self.left.clone(),
            right: self.right.clone(),
            r: rows(&r.rotation),
            rotation_vector: [w.x, w.y, w.z],
            euler_xyz: [e.x, e.y, e.z],
            rotation_angle_deg: w.norm().to_degrees(),
            t: [t.x, t.y, t.z],
            baseline: self.baseline,
            rig_parameterization: self.rotation.name().into(),
            rig_params: self.rig_params,
            rig_std: self.rig_std,
            e: rows(&self.essential),
            f: rows(&self.fundamental),
            residual_variance: self.residual_variance,
            initial: InitialJson {
                rms: self.initial_rms,
                left_method: self.initial_methods[0].name().into(),
                right_method: self.initial_methods[1].name().into(),
                r: rows(&self.initial_rig.rotation),
                t: [t0.x, t0.y, t0.z],
            },
            pairs: self.pairs.clone(),
            skipped_pairs: self.skipped_pairs.clone(),
            solver: self.solver.clone(),
            bootstrap: self.bootstrap.as_ref().map(|b| BootstrapJson {
                resamples: b.resamples,
                failed: b.failed,
                seed: b.seed,
                elapsed_seconds: b.elapsed_seconds,
                left: CameraSpreadJson::new(&b.left, &self.left),
                right: CameraSpreadJson::new(&b.right, &self.right),
                rig_std: b.rig_std,
                baseline_std: b.baseline_std,
            }),
        }
    }

    /// The JSON form of the result (schema in `docs/formats.md`).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self.to_file()).unwrap_or(serde_json::Value::Null)
    }

    /// Reads a result written by [`StereoCalibration::to_json`].
    pub fn from_json(value: serde_json::Value) -> Result<Self, ResultFormatError> {
        let j: StereoJson = deserialize_versioned(value, "calib-stereo-result/", "stereo result")?;
        let rotation: RotationKind =
            ResultFormatError::parse_name("rig_parameterization", &j.rig_parameterization)?;
        let rig_rotation = from_rows(&j.r);
        Ok(StereoCalibration {
            left: j.left,
            right: j.right,
            rig: Pose::new(rig_rotation, j.t.into()),
            rig_params: j.rig_params,
            rig_std: j.rig_std,
            rotation,
            essential: from_rows(&j.e),
            fundamental: from_rows(&j.f),
            baseline: j.baseline,
            rms: j.rms,
            rms_all_points: j.rms_all_points,
            num_rejected: j.num_rejected,
            warnings: j.warnings,
            pairs: j.pairs,
            skipped_pairs: j.skipped_pairs,
            residual_variance: j.residual_variance,
            initial_rig: Pose::new(from_rows(&j.initial.r), j.initial.t.into()),
            initial_rms: j.initial.rms,
            initial_methods: [
                ResultFormatError::parse_name("initial.left_method", &j.initial.left_method)?,
                ResultFormatError::parse_name("initial.right_method", &j.initial.right_method)?,
            ],
            solver: j.solver,
            elapsed: duration_from_seconds(j.elapsed_seconds),
            stage_times: [
                j.stage_seconds.left_single_camera,
                j.stage_seconds.right_single_camera,
                j.stage_seconds.joint_optimization,
                j.stage_seconds.uncertainty,
            ],
            bootstrap: j.bootstrap.map(|b| StereoBootstrap {
                resamples: b.resamples,
                failed: b.failed,
                seed: b.seed,
                left: b.left.spread(),
                right: b.right.spread(),
                rig_std: b.rig_std,
                baseline_std: b.baseline_std,
                elapsed_seconds: b.elapsed_seconds,
            }),
        })
    }

    /// A human summary with +- 3 sigma for every parameter.
    pub fn summary(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "Stereo calibration ({} pairs), uncertainties +- 3 sigma:",
            self.pairs.len()
        );
        for (name, camera) in [("left", &self.left), ("right", &self.right)] {
            let _ = writeln!(out, "  {name} camera (RMS {:.5} px):", camera.rms);
            camera.write_summary(&mut out, "    ");
        }
        let w = AxisAngle::from_matrix(&self.rig.rotation);
        let t = self.rig.translation;
        let s = &self.rig_std;
        let _ = writeln!(out, "  rig (X_right = R X_left + T):");
        let _ = writeln!(
            out,
            "    rotation vector  = {:>10.6} {:>10.6} {:>10.6} rad ({:.4} deg)   +- ({}) {:.6} {:.6} {:.6}",
            w.x,
            w.y,
            w.z,
            w.norm().to_degrees(),
            self.rotation.name(),
            3.0 * s[0],
            3.0 * s[1],
            3.0 * s[2]
        );
        let _ = writeln!(
            out,
            "    T                = {:>10.5} {:>10.5} {:>10.5}   +- {:.5} {:.5} {:.5}",
            t.x,
            t.y,
            t.z,
            3.0 * s[3],
            3.0 * s[4],
            3.0 * s[5]
        );
        let _ = writeln!(out, "    baseline |T|     = {:.5}", self.baseline);
        let _ = writeln!(
            out,
            "  RMS reprojection error = {:.5} px over both cameras (initial {:.3} px)",
            self.rms, self.initial_rms
        );
        let mut worst: Vec<&PairResult> = self.pairs.iter().collect();
        worst.sort_by(|a, b| (b.rms_left + b.rms_right).total_cmp(&(a.rms_left + a.rms_right)));
        let worst: Vec<String> = worst
            .iter()
            .take(3)
            .map(|p| format!("pair {} ({:.3}/{:.3} px)", p.index, p.rms_left, p.rms_right))
            .collect();
        let _ = writeln!(out, "  worst pairs (left/right RMS): {}", worst.join(", "));
        if self.num_rejected > 0 {
            let _ = writeln!(
                out,
                "  {} points rejected as outliers (RMS over all points {:.5} px)",
                self.num_rejected, self.rms_all_points
            );
        }
        for skipped in &self.skipped_pairs {
            let _ = writeln!(out, "  skipped pair {}: {}", skipped.index, skipped.reason);
        }
        if let Some(b) = &self.bootstrap {
            out.push_str(&b.summary(self));
        }
        write_warnings(&mut out, "  ", &self.warnings);
        let _ = writeln!(
            out,
            "  solver: {} after {} iterations ({} accepted), {:.3} ms in total",
            self.solver.termination,
            self.solver.iterations.len(),
            self.solver.accepted_steps,
            self.elapsed.as_secs_f64() * 1e3
        );
        out
    }
}
