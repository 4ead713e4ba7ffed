//! The single-camera pipeline: a thin front end over the engine (`calib_core`). Walk-through
//! with formulas: `docs/calib-single.md`.

use crate::observations::{Observations, View};
use crate::result::Calibration;
use calib_core::single::camera_param_names;
use calib_core::{
    CalibrationError, CalibrationOptions, SolveOptions, StageTimes, ViewResult, prepare_camera,
};
use camera_model::{AnyCamera, Pose};
use nalgebra::Vector2;
use std::time::Instant;

/// Calibrates a camera with the lens model of `options.model` (default `brown-conrady4`):
///
/// 1. checks every view (counts, finiteness, planarity) and estimates its homography,
/// 2. closed-form intrinsics (principal point at the image centre, square pixels, focal length
///    from the vanishing points) unless a guess is given, distortion zero,
/// 3. closed-form pose per view from `K^-1 H`,
/// 4. Levenberg-Marquardt over the camera and all poses (poses eliminated by the Schur
///    complement), then the covariance of every parameter.
///
/// Errors name the view (and point) at fault; with `options.skip_bad_views` bad views are listed
/// in the result instead.
pub fn calibrate(
    observations: &Observations,
    options: &CalibrationOptions,
) -> Result<Calibration, CalibrationError> {
    let start = Instant::now();
    let views: Vec<(usize, &View)> = observations.views.iter().enumerate().collect();
    let prepared = prepare_camera(&views, observations.image_size, options)?;
    let used = prepared.views.clone();
    let (fixed, skipped, times) = (
        prepared.fixed.clone(),
        prepared.skipped.clone(),
        prepared.times,
    );
    let (image_size, initial_intrinsics) = (prepared.image_size, prepared.initial.intrinsics);
    let initial_method = prepared.start_method;
    let problem = prepared.into_problem("camera");
    let mut solve_options = SolveOptions::default();
    solve_options.rotation = options.rotation;
    solve_options.solver = options.solver.clone();
    solve_options.compute_uncertainty = options.compute_uncertainty;
    let solve_start = Instant::now();
    let solution = calib_core::solve(&problem, &solve_options)?;
    let solve_time = solve_start.elapsed();

    let num_points: usize = problem.observations.iter().map(|o| o.object.len()).sum();
    let names = camera_param_names(options.model);
    let std = &solution.camera_std[0];
    let (mut sum_sq, mut sum_x, mut sum_y, mut sum_xx, mut sum_yy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let mut views = Vec::with_capacity(used.len());
    for (k, (index, name)) in used.iter().enumerate() {
        let errors: &[Vector2<f64>] = &solution.residuals[k];
        let view_sq: f64 = errors.iter().map(|e| e.norm_squared()).sum();
        for e in errors {
            sum_x += e.x;
            sum_y += e.y;
            sum_xx += e.x * e.x;
            sum_yy += e.y * e.y;
        }
        sum_sq += view_sq;
        views.push(ViewResult {
            index: *index,
            name: name.clone(),
            pose: solution.frames[k],
            pose_params: solution.frame_params[k],
            pose_std: solution.frame_std[k],
            rms: (view_sq / errors.len() as f64).sqrt(),
            num_points: errors.len(),
        });
    }
    let np = num_points as f64;
    let sample_std = |s: f64, ss: f64| ((ss - s * s / np) / (np - 1.0).max(1.0)).max(0.0).sqrt();
    let (homographies, initialization) = times;
    let optimization = solution.report.total_time;
    let calibration = Calibration {
        camera: solution.cameras[0].clone(),
        intrinsics_std: [std[0], std[1], std[2], std[3]],
        distortion_std: std[4..].to_vec(),
        fixed_parameters: fixed.iter().map(|&i| names[i].to_string()).collect(),
        image_size,
        rotation: options.rotation,
        views,
        skipped_views: skipped,
        rms: (sum_sq / np).sqrt(),
        residual_std: [sample_std(sum_x, sum_xx), sample_std(sum_y, sum_yy)],
        residual_variance: solution.residual_variance,
        num_points,
        initial_intrinsics,
        initial_method,
        // The cost is half the sum of squared residuals.
        initial_rms: (2.0 * solution.report.initial_cost / np).sqrt(),
        solver: solution.report,
        elapsed: start.elapsed(),
        stage_times: StageTimes {
            homographies,
            initialization,
            optimization,
            uncertainty: solve_time.saturating_sub(optimization),
        },
    };
    Ok(calibration)
}

/// Projects the board points of a view with a calibrated camera (a convenience for checks and
/// examples): the pixels the model predicts for `pose`.
pub fn reproject(
    camera: &AnyCamera,
    pose: &Pose,
    view: &View,
) -> Result<Vec<Vector2<f64>>, camera_model::CameraModelError> {
    view.object_points
        .iter()
        .map(|x| camera.project(pose, x))
        .collect()
}
