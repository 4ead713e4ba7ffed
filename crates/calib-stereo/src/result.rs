//! The stereo calibration result, its summary and its JSON form (`docs/formats.md`).

use calib_single::ImageSize;
use calib_single::result::{distortion_params, named_distortion_json, write_camera_summary};
use camera_model::{
    AxisAngle, Camera, EulerXyz, LensDistortion, Pose, RotationKind, RotationParameterization,
};
use lm_solver::SolverReport;
use nalgebra::Matrix3;
use serde_json::{Value, json};
use std::fmt::Write;
use std::time::Duration;

/// One camera of the rig with its uncertainties.
#[derive(Debug, Clone)]
pub struct CameraEstimate<D> {
    /// Intrinsics and distortion.
    pub camera: Camera<D>,
    /// Standard deviations of `fx, fy, cx, cy` (zero for fixed ones).
    pub intrinsics_std: [f64; 4],
    /// Standard deviations of the distortion coefficients (zero for fixed ones).
    pub distortion_std: Vec<f64>,
    /// Names of the parameters held fixed.
    pub fixed_parameters: Vec<String>,
    /// Image size.
    pub image_size: ImageSize,
    /// RMS reprojection error of this camera's points, pixels.
    pub rms: f64,
}

/// The estimate for one pair.
#[derive(Debug, Clone, PartialEq)]
pub struct PairResult {
    /// Index of the pair in the input.
    pub index: usize,
    /// Names of the two views.
    pub names: (String, String),
    /// Board-to-left-camera pose.
    pub left_pose: Pose,
    /// Its parameters `[rho, t]` in the calibration's rotation parameterization.
    pub pose_params: [f64; 6],
    /// Their standard deviations.
    pub pose_std: [f64; 6],
    /// RMS of the left view, pixels.
    pub rms_left: f64,
    /// RMS of the right view, pixels.
    pub rms_right: f64,
    /// Points per view.
    pub num_points: usize,
}

/// A pair left out by `skip_bad_pairs`.
#[derive(Debug, Clone, PartialEq)]
pub struct SkippedPair {
    /// Index in the input.
    pub index: usize,
    /// Why.
    pub reason: String,
}

/// A calibrated stereo rig.
#[derive(Debug, Clone)]
pub struct StereoCalibration<D> {
    /// The left (reference) camera.
    pub left: CameraEstimate<D>,
    /// The right camera.
    pub right: CameraEstimate<D>,
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
    /// RMS over all points of both cameras, pixels: `sqrt(sum |e|^2 / (2 x points per camera))`.
    pub rms: f64,
    /// One entry per used pair.
    pub pairs: Vec<PairResult>,
    /// Pairs that were skipped.
    pub skipped_pairs: Vec<SkippedPair>,
    /// Residual variance used to scale the covariance, pixels^2.
    pub residual_variance: f64,
    /// The rig before the joint optimization.
    pub initial_rig: Pose,
    /// RMS at the start of the joint optimization (single-camera estimates and initial rig).
    pub initial_rms: f64,
    /// The joint Levenberg-Marquardt report.
    pub solver: SolverReport,
    /// Wall time of the whole stereo calibration (single-camera calibrations included).
    pub elapsed: Duration,
    /// Wall time of the single-camera calibrations (left, right), the joint optimization and the
    /// covariance with result assembly.
    pub stage_times: [Duration; 4],
}

fn matrix_json(m: &Matrix3<f64>) -> Value {
    json!([
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]]
    ])
}

impl<D: LensDistortion> CameraEstimate<D> {
    fn to_json(&self) -> Value {
        let k = &self.camera.intrinsics;
        let named = named_distortion_json::<D>;
        let d = distortion_params(&self.camera);
        let s = &self.intrinsics_std;
        json!({
            "image_size": [self.image_size.width, self.image_size.height],
            "fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy,
            "distortion": named(&d),
            "camera_matrix": matrix_json(&k.matrix()),
            "dist_coeffs": d,
            "std": { "fx": s[0], "fy": s[1], "cx": s[2], "cy": s[3], "distortion": named(&self.distortion_std) },
            "fixed_parameters": self.fixed_parameters,
            "rms": self.rms,
        })
    }

    fn summary_lines(&self, name: &str, out: &mut String) {
        let _ = writeln!(out, "  {name} camera (RMS {:.5} px):", self.rms);
        write_camera_summary(
            out,
            "    ",
            &self.camera,
            &self.intrinsics_std,
            &self.distortion_std,
            &self.fixed_parameters,
        );
    }
}

impl<D: LensDistortion> StereoCalibration<D> {
    /// The JSON form of the result.
    pub fn to_json(&self) -> Value {
        let r = &self.rig;
        let w = AxisAngle::from_matrix(&r.rotation);
        let e = EulerXyz::from_matrix(&r.rotation);
        json!({
            "format": "calib-stereo-result/1",
            "pixel_convention": "OpenCV: (0,0) is the centre of the top-left pixel, x right, y down",
            "rig_convention": "X_right = R X_left + T; poses map board to left camera",
            "distortion_model": D::NAME,
            "rms": self.rms,
            "elapsed_seconds": self.elapsed.as_secs_f64(),
            "stage_seconds": {
                "left_single_camera": self.stage_times[0].as_secs_f64(),
                "right_single_camera": self.stage_times[1].as_secs_f64(),
                "joint_optimization": self.stage_times[2].as_secs_f64(),
                "uncertainty": self.stage_times[3].as_secs_f64(),
            },
            "num_pairs": self.pairs.len(),
            "left": self.left.to_json(),
            "right": self.right.to_json(),
            "R": matrix_json(&r.rotation),
            "rotation_vector": [w.x, w.y, w.z],
            "euler_xyz": [e.x, e.y, e.z],
            "rotation_angle_deg": w.norm().to_degrees(),
            "T": [r.translation.x, r.translation.y, r.translation.z],
            "baseline": self.baseline,
            "rig_parameterization": self.rotation.name(),
            "rig_params": self.rig_params,
            "rig_std": self.rig_std,
            "E": matrix_json(&self.essential),
            "F": matrix_json(&self.fundamental),
            "residual_variance": self.residual_variance,
            "initial": {
                "rms": self.initial_rms,
                "R": matrix_json(&self.initial_rig.rotation),
                "T": [self.initial_rig.translation.x, self.initial_rig.translation.y, self.initial_rig.translation.z],
            },
            "pairs": self.pairs.iter().map(|p| {
                let mut pose = calib_single::result::pose_json(&p.left_pose);
                pose["index"] = json!(p.index);
                pose["left_image"] = json!(p.names.0);
                pose["right_image"] = json!(p.names.1);
                pose["rms_left"] = json!(p.rms_left);
                pose["rms_right"] = json!(p.rms_right);
                pose["points"] = json!(p.num_points);
                pose["pose_params"] = json!(p.pose_params);
                pose["pose_std"] = json!(p.pose_std);
                pose
            }).collect::<Vec<_>>(),
            "skipped_pairs": self.skipped_pairs.iter().map(|s| json!({"index": s.index, "reason": s.reason})).collect::<Vec<_>>(),
            "solver": calib_single::result::solver_json(&self.solver),
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
        self.left.summary_lines("left", &mut out);
        self.right.summary_lines("right", &mut out);
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
        for skipped in &self.skipped_pairs {
            let _ = writeln!(out, "  skipped pair {}: {}", skipped.index, skipped.reason);
        }
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
