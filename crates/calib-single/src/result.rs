//! The calibration result, its human summary and its JSON form (`docs/formats.md`).

use crate::observations::ImageSize;
use camera_model::{
    AxisAngle, Camera, EulerXyz, Intrinsics, LensDistortion, Pose, RotationKind,
    RotationParameterization,
};
use lm_solver::SolverReport;
use serde_json::{Value, json};
use std::fmt::Write;
use std::time::Duration;

/// The estimate for one view.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewResult {
    /// Index of the view in the input.
    pub index: usize,
    /// The view's name.
    pub name: String,
    /// Board-to-camera pose.
    pub pose: Pose,
    /// The pose parameters `[rho (3), t (3)]` in the calibration's rotation parameterization.
    pub pose_params: [f64; 6],
    /// Standard deviations of `pose_params` (same units: radians, board units).
    pub pose_std: [f64; 6],
    /// RMS reprojection error of this view, pixels.
    pub rms: f64,
    /// Number of points.
    pub num_points: usize,
}

/// A view left out because it failed the checks (only with `skip_bad_views`).
#[derive(Debug, Clone, PartialEq)]
pub struct SkippedView {
    /// Index in the input.
    pub index: usize,
    /// The view's name.
    pub name: String,
    /// Why it was skipped.
    pub reason: String,
}

/// Wall time of each stage of a calibration.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StageTimes {
    /// Input checks and homographies.
    pub homographies: Duration,
    /// Closed-form intrinsics and poses.
    pub initialization: Duration,
    /// Levenberg-Marquardt.
    pub optimization: Duration,
    /// Covariance and result assembly.
    pub uncertainty: Duration,
}

/// A calibrated camera with uncertainties and diagnostics.
#[derive(Debug, Clone)]
pub struct Calibration<D> {
    /// Intrinsics and distortion.
    pub camera: Camera<D>,
    /// Standard deviations of `fx, fy, cx, cy` (pixels; zero for fixed parameters).
    pub intrinsics_std: [f64; 4],
    /// Standard deviations of the distortion coefficients (zero for fixed ones).
    pub distortion_std: Vec<f64>,
    /// Names of the parameters held fixed.
    pub fixed_parameters: Vec<String>,
    /// Image size.
    pub image_size: ImageSize,
    /// Rotation parameterization used for the poses.
    pub rotation: RotationKind,
    /// One entry per used view, in input order.
    pub views: Vec<ViewResult>,
    /// Views that were skipped.
    pub skipped_views: Vec<SkippedView>,
    /// Overall RMS reprojection error, pixels: `sqrt(sum |e|^2 / number of points)` (OpenCV's
    /// definition).
    pub rms: f64,
    /// Sample standard deviations of the x and y residuals separately (Bouguet's "pixel error").
    pub residual_std: [f64; 2],
    /// Residual variance `|r|^2 / (2 N - p)` used to scale the covariance (pixels^2).
    pub residual_variance: f64,
    /// Number of points used.
    pub num_points: usize,
    /// The closed-form initial intrinsics (or the given guess).
    pub initial_intrinsics: Intrinsics,
    /// RMS at the initial guess, pixels.
    pub initial_rms: f64,
    /// The Levenberg-Marquardt report.
    pub solver: SolverReport,
    /// Wall time of the whole calibration (checks, homographies, initialization, optimization,
    /// covariance).
    pub elapsed: Duration,
    /// Wall time per stage.
    pub stage_times: StageTimes,
}

fn round_trip_rotation(pose: &Pose) -> (Vec<f64>, Vec<f64>) {
    let w = AxisAngle::from_matrix(&pose.rotation);
    let e = EulerXyz::from_matrix(&pose.rotation);
    (vec![w.x, w.y, w.z], vec![e.x, e.y, e.z])
}

/// A pose as JSON: rotation matrix, rotation vector, Euler X-Y-Z angles and translation.
pub fn pose_json(pose: &Pose) -> Value {
    let r = &pose.rotation;
    let (rvec, euler) = round_trip_rotation(pose);
    json!({
        "rotation_matrix": [[r[(0,0)], r[(0,1)], r[(0,2)]], [r[(1,0)], r[(1,1)], r[(1,2)]], [r[(2,0)], r[(2,1)], r[(2,2)]]],
        "rotation_vector": rvec,
        "euler_xyz": euler,
        "translation": [pose.translation.x, pose.translation.y, pose.translation.z],
    })
}

/// A solver report as JSON (termination, counts, costs, times, per-iteration records).
pub fn solver_json(report: &SolverReport) -> Value {
    json!({
        "termination": report.termination.to_string(),
        "converged": report.termination.is_converged(),
        "iterations": report.iterations.len(),
        "accepted_steps": report.accepted_steps,
        "initial_cost": report.initial_cost,
        "final_cost": report.final_cost,
        "residual_evaluations": report.residual_evaluations,
        "jacobian_evaluations": report.jacobian_evaluations,
        "linear_solver": format!("{:?}", report.linear_solver),
        "evaluate_seconds": report.evaluate_time.as_secs_f64(),
        "solve_seconds": report.solve_time.as_secs_f64(),
        "total_seconds": report.total_time.as_secs_f64(),
        "per_iteration": report.iterations.iter().map(|r| json!({
            "cost": r.cost,
            "trial_cost": if r.trial_cost.is_finite() { json!(r.trial_cost) } else { Value::Null },
            "gradient_max_norm": r.gradient_max_norm,
            "step_norm": r.step_norm,
            "gain_ratio": if r.gain_ratio.is_finite() { json!(r.gain_ratio) } else { Value::Null },
            "lambda": r.lambda,
            "accepted": r.accepted,
        })).collect::<Vec<_>>(),
    })
}

/// The coefficients of `camera`'s distortion model, in the model's order (`D::PARAM_NAMES`).
pub fn distortion_params<D: LensDistortion>(camera: &Camera<D>) -> Vec<f64> {
    let mut d = vec![0.0; D::NUM_PARAMS];
    camera.distortion.write_params(&mut d);
    d
}

/// A JSON object `{name: value}` for a distortion model's coefficients (or their deviations).
pub fn named_distortion_json<D: LensDistortion>(values: &[f64]) -> Value {
    D::PARAM_NAMES
        .iter()
        .zip(values)
        .map(|(n, v)| (n.to_string(), json!(v)))
        .collect::<serde_json::Map<_, _>>()
        .into()
}

/// Appends the camera lines of a human summary (focal length, principal point, distortion, each
/// with +- 3 sigma, and the parameters held fixed), every line prefixed with `indent`.
/// `intrinsics_std` holds the deviations of `fx, fy, cx, cy` in pixels, `distortion_std` those of
/// the distortion coefficients in the model's order.
pub fn write_camera_summary<D: LensDistortion>(
    out: &mut String,
    indent: &str,
    camera: &Camera<D>,
    intrinsics_std: &[f64; 4],
    distortion_std: &[f64],
    fixed_parameters: &[String],
) {
    let k = &camera.intrinsics;
    let s = intrinsics_std;
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
    let values: Vec<String> = distortion_params(camera)
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
        D::PARAM_NAMES.join(", "),
        values.join(" "),
        sigmas.join(" ")
    );
    if !fixed_parameters.is_empty() {
        let _ = writeln!(out, "{indent}held fixed: {}", fixed_parameters.join(", "));
    }
}

impl<D: LensDistortion> Calibration<D> {
    /// The distortion coefficients in the model's order.
    pub fn distortion_coefficients(&self) -> Vec<f64> {
        distortion_params(&self.camera)
    }

    /// The views sorted by decreasing RMS (worst first).
    pub fn worst_views(&self) -> Vec<&ViewResult> {
        let mut v: Vec<&ViewResult> = self.views.iter().collect();
        v.sort_by(|a, b| b.rms.total_cmp(&a.rms));
        v
    }

    /// The JSON form of the result (schema in `docs/formats.md`).
    pub fn to_json(&self) -> Value {
        let k = &self.camera.intrinsics;
        let dist = self.distortion_coefficients();
        let named = named_distortion_json::<D>;
        let s = &self.intrinsics_std;
        json!({
            "format": "calib-single-result/1",
            "pixel_convention": "OpenCV: (0,0) is the centre of the top-left pixel, x right, y down",
            "pose_convention": "board (world) to camera: X_cam = R X_board + t",
            "distortion_model": D::NAME,
            "image_size": [self.image_size.width, self.image_size.height],
            "rms": self.rms,
            "elapsed_seconds": self.elapsed.as_secs_f64(),
            "stage_seconds": {
                "homographies": self.stage_times.homographies.as_secs_f64(),
                "initialization": self.stage_times.initialization.as_secs_f64(),
                "optimization": self.stage_times.optimization.as_secs_f64(),
                "uncertainty": self.stage_times.uncertainty.as_secs_f64(),
            },
            "num_points": self.num_points,
            "num_views": self.views.len(),
            "camera": {
                "fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy,
                "distortion": named(&dist),
                "camera_matrix": [[k.fx, 0.0, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]],
                "dist_coeffs": dist,
            },
            "std": {
                "fx": s[0], "fy": s[1], "cx": s[2], "cy": s[3],
                "distortion": named(&self.distortion_std),
            },
            "fixed_parameters": self.fixed_parameters,
            "residual_std_xy": self.residual_std,
            "residual_variance": self.residual_variance,
            "initial": {
                "fx": self.initial_intrinsics.fx, "fy": self.initial_intrinsics.fy,
                "cx": self.initial_intrinsics.cx, "cy": self.initial_intrinsics.cy,
                "rms": self.initial_rms,
            },
            "rotation_parameterization": self.rotation.name(),
            "views": self.views.iter().map(|v| {
                let mut pose = pose_json(&v.pose);
                pose["index"] = json!(v.index);
                pose["image"] = json!(v.name);
                pose["rms"] = json!(v.rms);
                pose["points"] = json!(v.num_points);
                pose["pose_params"] = json!(v.pose_params);
                pose["pose_std"] = json!(v.pose_std);
                pose
            }).collect::<Vec<_>>(),
            "skipped_views": self.skipped_views.iter().map(|s| json!({
                "index": s.index, "image": s.name, "reason": s.reason,
            })).collect::<Vec<_>>(),
            "solver": solver_json(&self.solver),
        })
    }

    /// A human summary in the style of Bouguet's toolbox: every parameter with +- 3 sigma, the
    /// RMS, the worst views and how the solver ended.
    pub fn summary(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "Calibration results ({} views, {} points, image {}x{}), uncertainties +- 3 sigma:",
            self.views.len(),
            self.num_points,
            self.image_size.width,
            self.image_size.height
        );
        write_camera_summary(
            &mut out,
            "  ",
            &self.camera,
            &self.intrinsics_std,
            &self.distortion_std,
            &self.fixed_parameters,
        );
        let _ = writeln!(
            out,
            "  pixel error (std x, y) = {:.5} {:.5}",
            self.residual_std[0], self.residual_std[1]
        );
        let _ = writeln!(
            out,
            "  RMS reprojection error = {:.5} px (initial guess: {:.3} px)",
            self.rms, self.initial_rms
        );
        let worst: Vec<String> = self
            .worst_views()
            .iter()
            .take(3)
            .map(|v| format!("{} {:.3} px", v.name, v.rms))
            .collect();
        let _ = writeln!(out, "  worst views: {}", worst.join(", "));
        for skipped in &self.skipped_views {
            let _ = writeln!(
                out,
                "  skipped view {} ({}): {}",
                skipped.index, skipped.name, skipped.reason
            );
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
