//! The single-camera calibration result, its human summary and its JSON form
//! (`docs/formats.md`). The result is a serde type: [`Calibration::to_json`] writes it and
//! [`Calibration::from_json`] reads it back.

use crate::bootstrap::Bootstrap;
use calib_core::ImageSize;
use calib_core::init::StartMethod;
pub use calib_core::result::ResultFormatError;
pub use calib_core::result::{
    CameraEstimate, SkippedView, StageTimes, ViewResult, write_camera_summary,
};
use calib_core::result::{deserialize_versioned, duration_from_seconds};
use calib_core::warnings::{Warning, write_warnings};
use camera_model::{AnyCamera, Intrinsics, RotationKind};
use lm_solver::SolverReport;
use serde::{Deserialize, Serialize};
use std::fmt::Write;
use std::time::Duration;

/// The `format` key of single-camera result files.
pub const FORMAT: &str = "calib-single-result/2";

/// A calibrated camera with uncertainties and diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// Lens model, intrinsics and distortion (OpenCV's order).
    pub camera: AnyCamera,
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
    /// Overall RMS reprojection error of the used points, pixels: `sqrt(sum |e|^2 / number of
    /// points)` (OpenCV's definition; rejected outliers left out).
    pub rms: f64,
    /// The RMS over every point, rejected outliers included, pixels.
    pub rms_all_points: f64,
    /// Number of points rejected as outliers (listed per view).
    pub num_rejected: usize,
    /// Sample standard deviations of the x and y residuals separately (Bouguet's "pixel error").
    pub residual_std: [f64; 2],
    /// Residual variance `|r|^2 / (2 N - p)` used to scale the covariance (pixels^2).
    pub residual_variance: f64,
    /// Number of points used.
    pub num_points: usize,
    /// The closed-form initial intrinsics (or the given guess).
    pub initial_intrinsics: Intrinsics,
    /// Where the initial intrinsics came from (`initial.method` in files).
    pub initial_method: StartMethod,
    /// RMS at the initial guess, pixels.
    pub initial_rms: f64,
    /// What deserves attention (empty when all is well).
    pub warnings: Vec<Warning>,
    /// The Levenberg-Marquardt report (of the last solve when outliers were rejected).
    pub solver: SolverReport,
    /// Wall time of the whole calibration (checks, homographies, initialization, optimization,
    /// covariance).
    pub elapsed: Duration,
    /// Wall time per stage.
    pub stage_times: StageTimes,
    /// The view bootstrap's standard deviations, when one was run ([`crate::add_bootstrap`],
    /// `calib single --bootstrap N`); `None` otherwise.
    pub bootstrap: Option<Bootstrap>,
}

#[derive(Serialize, Deserialize)]
struct InitialJson {
    method: String,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    rms: f64,
}

#[derive(Serialize, Deserialize)]
struct CalibrationJson {
    format: String,
    #[serde(default)]
    pixel_convention: String,
    #[serde(default)]
    pose_convention: String,
    distortion_model: String,
    image_size: ImageSize,
    rms: f64,
    #[serde(default)]
    rms_all_points: f64,
    #[serde(default)]
    num_rejected: usize,
    #[serde(default)]
    warnings: Vec<Warning>,
    elapsed_seconds: f64,
    stage_seconds: StageTimes,
    num_points: usize,
    num_views: usize,
    camera: CameraEstimate,
    residual_std_xy: [f64; 2],
    residual_variance: f64,
    initial: InitialJson,
    rotation_parameterization: String,
    views: Vec<ViewResult>,
    skipped_views: Vec<SkippedView>,
    solver: SolverReport,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    bootstrap: Option<BootstrapJson>,
}

/// The `bootstrap` object of result files: the camera's standard deviations over view resamples
/// in the shape of `camera.std`.
#[derive(Serialize, Deserialize)]
struct BootstrapJson {
    resamples: usize,
    failed: usize,
    seed: u64,
    elapsed_seconds: f64,
    std: BootstrapStdJson,
}

#[derive(Serialize, Deserialize)]
struct BootstrapStdJson {
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    distortion: serde_json::Map<String, serde_json::Value>,
    dist_coeffs: Vec<f64>,
}

impl Calibration {
    /// The camera with its uncertainties as a [`CameraEstimate`] named "camera".
    pub fn estimate(&self) -> CameraEstimate {
        CameraEstimate {
            name: "camera".into(),
            camera: self.camera.clone(),
            image_size: self.image_size,
            intrinsics_std: self.intrinsics_std,
            distortion_std: self.distortion_std.clone(),
            fixed_parameters: self.fixed_parameters.clone(),
            rms: self.rms,
            num_points: self.num_points,
        }
    }

    /// The distortion coefficients in the model's (OpenCV's) order.
    pub fn distortion_coefficients(&self) -> Vec<f64> {
        self.camera.distortion.clone()
    }

    /// The views sorted by decreasing RMS (worst first).
    pub fn worst_views(&self) -> Vec<&ViewResult> {
        let mut v: Vec<&ViewResult> = self.views.iter().collect();
        v.sort_by(|a, b| b.rms.total_cmp(&a.rms));
        v
    }

    fn to_file(&self) -> CalibrationJson {
        let k = &self.initial_intrinsics;
        CalibrationJson {
            format: FORMAT.into(),
            pixel_convention: "OpenCV: (0,0) is the centre of the top-left pixel, x right, y down"
                .into(),
            pose_convention: "board (world) to camera: X_cam = R X_board + t".into(),
            distortion_model: self.camera.model.to_string(),
            image_size: self.image_size,
            rms: self.rms,
            rms_all_points: self.rms_all_points,
            num_rejected: self.num_rejected,
            warnings: self.warnings.clone(),
            elapsed_seconds: self.elapsed.as_secs_f64(),
            stage_seconds: self.stage_times,
            num_points: self.num_points,
            num_views: self.views.len(),
            camera: self.estimate(),
            residual_std_xy: self.residual_std,
            residual_variance: self.residual_variance,
            initial: InitialJson {
                method: self.initial_method.name().into(),
                fx: k.fx,
                fy: k.fy,
                cx: k.cx,
                cy: k.cy,
                rms: self.initial_rms,
            },
            rotation_parameterization: self.rotation.name().into(),
            views: self.views.clone(),
            skipped_views: self.skipped_views.clone(),
            solver: self.solver.clone(),
            bootstrap: self.bootstrap.as_ref().map(|b| BootstrapJson {
                resamples: b.resamples,
                failed: b.failed,
                seed: b.seed,
                elapsed_seconds: b.elapsed_seconds,
                std: BootstrapStdJson {
                    fx: b.intrinsics_std[0],
                    fy: b.intrinsics_std[1],
                    cx: b.intrinsics_std[2],
                    cy: b.intrinsics_std[3],
                    distortion: self
                        .camera
                        .model
                        .distortion_names()
                        .iter()
                        .zip(&b.distortion_std)
                        .map(|(name, s)| (name.to_string(), serde_json::json!(s)))
                        .collect(),
                    dist_coeffs: b.distortion_std.clone(),
                },
            }),
        }
    }

    /// The JSON form of the result (schema in `docs/formats.md`).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self.to_file()).unwrap_or(serde_json::Value::Null)
    }

    /// Reads a result written by [`Calibration::to_json`].
    pub fn from_json(value: serde_json::Value) -> Result<Self, ResultFormatError> {
        let j: CalibrationJson =
            deserialize_versioned(value, "calib-single-result/", "single-camera result")?;
        Ok(Calibration {
            camera: j.camera.camera,
            intrinsics_std: j.camera.intrinsics_std,
            distortion_std: j.camera.distortion_std,
            fixed_parameters: j.camera.fixed_parameters,
            image_size: j.image_size,
            rotation: ResultFormatError::parse_name(
                "rotation_parameterization",
                &j.rotation_parameterization,
            )?,
            views: j.views,
            skipped_views: j.skipped_views,
            rms: j.rms,
            rms_all_points: j.rms_all_points,
            num_rejected: j.num_rejected,
            warnings: j.warnings,
            residual_std: j.residual_std_xy,
            residual_variance: j.residual_variance,
            num_points: j.num_points,
            initial_intrinsics: Intrinsics::new(
                j.initial.fx,
                j.initial.fy,
                j.initial.cx,
                j.initial.cy,
            ),
            initial_rms: j.initial.rms,
            initial_method: ResultFormatError::parse_name("initial.method", &j.initial.method)?,
            solver: j.solver,
            elapsed: duration_from_seconds(j.elapsed_seconds),
            stage_times: j.stage_seconds,
            bootstrap: j.bootstrap.map(|b| Bootstrap {
                resamples: b.resamples,
                failed: b.failed,
                seed: b.seed,
                intrinsics_std: [b.std.fx, b.std.fy, b.std.cx, b.std.cy],
                distortion_std: b.std.dist_coeffs,
                elapsed_seconds: b.elapsed_seconds,
            }),
        })
    }

    /// A human summary in the style of Bouguet's toolbox: every parameter with +- 3 sigma, the
    /// RMS, the worst views and how the solver ended.
    pub fn summary(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "Calibration results ({} view{}, {} points, image {}x{}), uncertainties +- 3 sigma:",
            self.views.len(),
            if self.views.len() == 1 { "" } else { "s" },
            self.num_points,
            self.image_size.width,
            self.image_size.height
        );
        write_camera_summary(
            &mut out,
            "  ",
            &self.camera,
            self.image_size,
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
            "  RMS reprojection error = {:.5} px (initial guess, {}: {:.3} px)",
            self.rms,
            self.initial_method.name(),
            self.initial_rms
        );
        if self.num_rejected > 0 {
            let _ = writeln!(
                out,
                "  {} points rejected as outliers (RMS over all points {:.5} px)",
                self.num_rejected, self.rms_all_points
            );
        }
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
