//! The rig calibration result, its summary and its JSON form (`docs/formats.md`, format
//! `calib-rig-result/1`).

use calib_core::result::{
    CameraEstimate, ResultFormatError, deserialize_versioned, duration_from_seconds,
};
use calib_core::warnings::{Warning, write_warnings};
use camera_model::{AxisAngle, Pose, RotationKind, RotationParameterization};
use lm_solver::SolverReport;
use serde::{Deserialize, Serialize};
use std::fmt::Write;
use std::time::Duration;

/// The `format` key of rig result files.
pub const FORMAT: &str = "calib-rig-result/1";

/// One camera of a calibrated rig.
#[derive(Debug, Clone, PartialEq)]
pub struct RigCamera {
    /// Intrinsics, distortion, their standard deviations, RMS and points.
    pub estimate: CameraEstimate,
    /// The camera's transform from the reference camera: `X_cam = R X_ref + T` (identity for the
    /// reference).
    pub transform: Pose,
    /// Its parameters `[rho, T]` in the result's rotation parameterization.
    pub transform_params: [f64; 6],
    /// Their standard deviations (radians, board units; zero for the reference).
    pub transform_std: [f64; 6],
    /// Frames in which the camera saw the board.
    pub num_views: usize,
    /// Where the camera's start came from (`initial.method` of its own calibration, or `given`).
    pub initial_method: String,
}

/// One camera's view in one frame, in results.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameView {
    /// The camera (index).
    pub camera: usize,
    /// RMS of its used points, pixels.
    pub rms: f64,
    /// Points used.
    pub points: usize,
    /// Points rejected as outliers (indices in the observation's input lists).
    pub rejected_points: Vec<usize>,
}

/// One frame of a calibrated rig.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameResult {
    /// Index in the input.
    pub index: usize,
    /// Board pose in the reference camera's frame (`rotation_matrix`, `rotation_vector`,
    /// `euler_xyz`, `translation`).
    #[serde(flatten)]
    pub pose: Pose,
    /// Its parameters and their standard deviations.
    pub pose_params: [f64; 6],
    /// Standard deviations of `pose_params`.
    pub pose_std: [f64; 6],
    /// Each camera that saw the board in this frame.
    pub views: Vec<FrameView>,
}

/// A calibrated rig.
#[derive(Debug, Clone, PartialEq)]
pub struct RigCalibration {
    /// The cameras, in input order.
    pub cameras: Vec<RigCamera>,
    /// The reference camera.
    pub reference: usize,
    /// The frames used.
    pub frames: Vec<FrameResult>,
    /// RMS over the used points of every camera, pixels.
    pub rms: f64,
    /// RMS over every point, rejected outliers included.
    pub rms_all_points: f64,
    /// Points rejected as outliers.
    pub num_rejected: usize,
    /// Residual variance scaling the covariance, px^2.
    pub residual_variance: f64,
    /// Rotation parameterization of poses and transforms.
    pub rotation: RotationKind,
    /// Parent of each camera in the initialization's spanning tree (`None` for the reference).
    pub tree_parent: Vec<Option<usize>>,
    /// RMS at the start of the joint optimization.
    pub initial_rms: f64,
    /// What deserves attention.
    pub warnings: Vec<Warning>,
    /// The joint Levenberg-Marquardt report.
    pub solver: SolverReport,
    /// Wall time of the whole calibration.
    pub elapsed: Duration,
    /// Wall time of the per-camera calibrations, the joint optimization and the covariance.
    pub stage_times: [Duration; 3],
}

fn rows(m: &nalgebra::Matrix3<f64>) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

#[derive(Serialize, Deserialize)]
struct RigCameraJson {
    #[serde(flatten)]
    estimate: CameraEstimate,
    #[serde(rename = "R")]
    r: [[f64; 3]; 3],
    rotation_vector: [f64; 3],
    #[serde(rename = "T")]
    t: [f64; 3],
    transform_params: [f64; 6],
    transform_std: [f64; 6],
    num_views: usize,
    initial_method: String,
}

#[derive(Serialize, Deserialize)]
struct StageSeconds {
    #[serde(with = "calib_core::result::seconds")]
    per_camera: Duration,
    #[serde(with = "calib_core::result::seconds")]
    joint_optimization: Duration,
    #[serde(with = "calib_core::result::seconds")]
    uncertainty: Duration,
}

#[derive(Serialize, Deserialize)]
struct RigJson {
    format: String,
    #[serde(default)]
    convention: String,
    rms: f64,
    rms_all_points: f64,
    num_rejected: usize,
    elapsed_seconds: f64,
    stage_seconds: StageSeconds,
    warnings: Vec<Warning>,
    reference: usize,
    rotation_parameterization: String,
    residual_variance: f64,
    initial_rms: f64,
    tree_parent: Vec<Option<usize>>,
    cameras: Vec<RigCameraJson>,
    frames: Vec<FrameResult>,
    solver: SolverReport,
}

impl RigCalibration {
    /// The JSON form (schema in `docs/formats.md`).
    pub fn to_json(&self) -> serde_json::Value {
        let file = RigJson {
            format: FORMAT.into(),
            convention: "X_cam = R X_ref + T; frame poses map board to the reference camera; pixels: OpenCV, (0,0) is the centre of the top-left pixel".into(),
            rms: self.rms,
            rms_all_points: self.rms_all_points,
            num_rejected: self.num_rejected,
            elapsed_seconds: self.elapsed.as_secs_f64(),
            stage_seconds: StageSeconds {
                per_camera: self.stage_times[0],
                joint_optimization: self.stage_times[1],
                uncertainty: self.stage_times[2],
            },
            warnings: self.warnings.clone(),
            reference: self.reference,
            rotation_parameterization: self.rotation.name().into(),
            residual_variance: self.residual_variance,
            initial_rms: self.initial_rms,
            tree_parent: self.tree_parent.clone(),
            cameras: self
                .cameras
                .iter()
                .map(|c| {
                    let w = AxisAngle::from_matrix(&c.transform.rotation);
                    let t = c.transform.translation;
                    RigCameraJson {
                        estimate: c.estimate.clone(),
                        r: rows(&c.transform.rotation),
                        rotation_vector: [w.x, w.y, w.z],
                        t: [t.x, t.y, t.z],
                        transform_params: c.transform_params,
                        transform_std: c.transform_std,
                        num_views: c.num_views,
                        initial_method: c.initial_method.clone(),
                    }
                })
                .collect(),
            frames: self.frames.clone(),
            solver: self.solver.clone(),
        };
        serde_json::to_value(file).unwrap_or(serde_json::Value::Null)
    }

    /// Reads a result written by [`RigCalibration::to_json`].
    pub fn from_json(value: serde_json::Value) -> Result<Self, ResultFormatError> {
        let j: RigJson = deserialize_versioned(value, "calib-rig-result/", "rig result")?;
        Ok(RigCalibration {
            cameras: j
                .cameras
                .into_iter()
                .map(|c| RigCamera {
                    estimate: c.estimate,
                    transform: Pose::new(nalgebra::Matrix3::from_fn(|i, k| c.r[i][k]), c.t.into()),
                    transform_params: c.transform_params,
                    transform_std: c.transform_std,
                    num_views: c.num_views,
                    initial_method: c.initial_method,
                })
                .collect(),
            reference: j.reference,
            frames: j.frames,
            rms: j.rms,
            rms_all_points: j.rms_all_points,
            num_rejected: j.num_rejected,
            residual_variance: j.residual_variance,
            rotation: ResultFormatError::parse_name(
                "rotation_parameterization",
                &j.rotation_parameterization,
            )?,
            tree_parent: j.tree_parent,
            initial_rms: j.initial_rms,
            warnings: j.warnings,
            solver: j.solver,
            elapsed: duration_from_seconds(j.elapsed_seconds),
            stage_times: [
                j.stage_seconds.per_camera,
                j.stage_seconds.joint_optimization,
                j.stage_seconds.uncertainty,
            ],
        })
    }

    /// A human summary with +- 3 sigma, in the style of `calib single`.
    pub fn summary(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "Rig calibration ({} cameras, {} frames), uncertainties +- 3 sigma:",
            self.cameras.len(),
            self.frames.len()
        );
        let reference = &self.cameras[self.reference].estimate.name;
        for c in &self.cameras {
            let _ = writeln!(
                out,
                "  camera '{}' ({} frames, RMS {:.5} px, start {}):",
                c.estimate.name, c.num_views, c.estimate.rms, c.initial_method
            );
            c.estimate.write_summary(&mut out, "    ");
            if c.estimate.name != *reference {
                let w = AxisAngle::from_matrix(&c.transform.rotation);
                let t = c.transform.translation;
                let s = &c.transform_std;
                let _ = writeln!(
                    out,
                    "    from '{reference}': rotation vector {:>9.6} {:>9.6} {:>9.6} rad ({:.3} deg)  +- ({}) {:.6} {:.6} {:.6}",
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
                    "                    T {:>10.5} {:>10.5} {:>10.5}  +- {:.5} {:.5} {:.5}  (|T| = {:.5})",
                    t.x,
                    t.y,
                    t.z,
                    3.0 * s[3],
                    3.0 * s[4],
                    3.0 * s[5],
                    t.norm()
                );
            }
        }
        let _ = writeln!(
            out,
            "  RMS reprojection error = {:.5} px over all cameras (initial {:.3} px)",
            self.rms, self.initial_rms
        );
        if self.num_rejected > 0 {
            let _ = writeln!(
                out,
                "  {} points rejected as outliers (RMS over all points {:.5} px)",
                self.num_rejected, self.rms_all_points
            );
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

/// The rotation parameters of `pose` in `kind` (for the reference camera's zero transform).
pub(crate) fn params_of(pose: &Pose, kind: RotationKind) -> [f64; 6] {
    let rho = kind.from_matrix(&pose.rotation);
    let t = pose.translation;
    [rho.x, rho.y, rho.z, t.x, t.y, t.z]
}
