//! The single-camera pipeline: a thin front end over the engine (`calib_core`). Walk-through
//! with formulas: `docs/calib-single.md`.

use crate::observations::{Observations, View};
use crate::result::Calibration;
use calib_core::single::camera_param_names;
use calib_core::{
    CalibrationError, CalibrationOptions, SkippedView, StageTimes, ViewResult, prepare_camera,
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
    let mut dropped: Vec<SkippedView> = Vec::new();
    let (prepared, solution, solve_time) = loop {
        let views: Vec<(usize, &View)> = observations
            .views
            .iter()
            .enumerate()
            .filter(|(i, _)| !dropped.iter().any(|d| d.index == *i))
            .collect();
        let mut prepared = prepare_camera(&views, observations.image_size, options)?;
        let problem = prepared.take_problem("camera");
        let solve_start = Instant::now();
        match calib_core::solve(&problem, &prepared.solve_options(&options.solve_options())) {
            Ok(solution) => break (prepared, solution, solve_start.elapsed()),
            // A view whose points mostly miss the model is wrong as a whole: drop it (and
            // others of its round, `views_to_skip`) and start again without it.
            Err(e @ CalibrationError::MostlyOutliers { .. }) if options.skip_bad_views => {
                dropped.extend(e.skipped_views(&prepared.views));
            }
            Err(e) => return Err(e),
        }
    };
    let mut skipped = prepared.skipped.clone();
    skipped.extend(dropped);
    skipped.sort_by_key(|s| s.index);

    let names = camera_param_names(options.model);
    let std = &solution.camera_std[0];
    let mut total = calib_core::ObservationErrors::default();
    let mut views = Vec::with_capacity(prepared.views.len());
    for (k, (index, name)) in prepared.views.iter().enumerate() {
        let errors = &solution.errors[k];
        total.add(errors);
        views.push(ViewResult {
            index: *index,
            name: name.clone(),
            pose: solution.frames[k],
            pose_params: solution.frame_params[k],
            pose_std: solution.frame_std[k],
            rms: errors.rms(),
            num_points: errors.used,
            rejected_points: solution.rejected[k].clone(),
        });
    }
    let num_points = total.used;
    let np = num_points as f64;
    let sample_std = |s: f64, ss: f64| ((ss - s * s / np) / (np - 1.0).max(1.0)).max(0.0).sqrt();
    let (sum, sum_sq) = (total.sum, total.sum_sq_xy);
    let (homographies, initialization) = prepared.times;
    let optimization = solution.optimization_time;
    let calibration = Calibration {
        camera: solution.cameras[0].clone(),
        intrinsics_std: [std[0], std[1], std[2], std[3]],
        distortion_std: std[4..].to_vec(),
        fixed_parameters: prepared
            .fixed
            .iter()
            .map(|&i| names[i].to_string())
            .collect(),
        image_size: prepared.image_size,
        rotation: options.rotation,
        views,
        skipped_views: skipped,
        rms: total.rms(),
        rms_all_points: total.rms_all(),
        num_rejected: solution.num_rejected(),
        residual_std: [sample_std(sum.x, sum_sq.x), sample_std(sum.y, sum_sq.y)],
        residual_variance: solution.residual_variance,
        num_points,
        initial_intrinsics: prepared.initial.intrinsics,
        initial_method: prepared.start_method,
        // The cost is half the (weighted) sum of squared residuals of the first solve.
        initial_rms: (2.0 * solution.initial_cost / np).sqrt(),
        warnings: prepared
            .warnings
            .iter()
            .chain(&solution.warnings)
            .cloned()
            .collect(),
        solver: solution.report,
        elapsed: start.elapsed(),
        stage_times: StageTimes {
            homographies,
            initialization,
            optimization,
            uncertainty: solve_time.saturating_sub(optimization),
        },
        bootstrap: None,
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
