//! The calibration pipeline: checks, homographies, closed-form start, Levenberg-Marquardt,
//! covariance. Walk-through with formulas: `docs/calib-single.md`.

use crate::cost::{ReprojectionCost, ViewData};
use crate::error::CalibrationError;
use crate::init::{initial_intrinsics, initial_pose};
use crate::observations::{ImageSize, Observations, View, check_view};
use crate::options::CalibrationOptions;
use crate::result::{Calibration, SkippedView, ViewResult};
use camera_model::{
    AxisAngle, BrownConrady, Camera, EulerXyz, Intrinsics, LensDistortion, Pose, RotationKind,
    RotationParameterization,
};
use lm_solver::{CostFunction, ParameterBlockId, ProblemBuilder, ResidualBlockId, Solver};
use nalgebra::{Matrix3, Point2, Vector2, Vector6};
use std::time::Instant;

/// Calibrates a camera with the Brown-Conrady `k1, k2, p1, p2` model.
///
/// See [`calibrate_with_model`].
pub fn calibrate(
    observations: &Observations,
    options: &CalibrationOptions,
) -> Result<Calibration<BrownConrady>, CalibrationError> {
    calibrate_with_model::<BrownConrady>(observations, options)
}

/// Calibrates a camera with distortion model `D`:
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
pub fn calibrate_with_model<D: LensDistortion>(
    observations: &Observations,
    options: &CalibrationOptions,
) -> Result<Calibration<D>, CalibrationError> {
    let start = Instant::now();
    let image_size = observations
        .image_size
        .ok_or(CalibrationError::ImageSizeMissing)?;
    if image_size.width == 0 || image_size.height == 0 {
        return Err(CalibrationError::InvalidImageSize {
            width: image_size.width,
            height: image_size.height,
        });
    }
    check_options::<D>(options)?;
    let prepared = prepare_views(&observations.views, options)?;
    let Prepared {
        used,
        homographies,
        skipped,
    } = prepared;

    // Closed-form intrinsics.
    let initial = match options.intrinsic_guess {
        Some(guess) => guess,
        None => initial_intrinsics(&homographies, image_size, options.focal_init)?,
    };
    let mut initial_distortion = options
        .distortion_guess
        .clone()
        .unwrap_or_else(|| vec![0.0; D::NUM_PARAMS]);
    if options.zero_tangential_distortion {
        for &i in D::TANGENTIAL_PARAMS {
            initial_distortion[i] = 0.0;
        }
    }

    // Closed-form poses.
    let mut poses = Vec::with_capacity(used.len());
    for (&(index, view), h) in used.iter().zip(&homographies) {
        let pose = initial_pose(h, &initial).ok_or_else(|| CalibrationError::Initialization {
            reason: format!("view {index}: no pose from its homography"),
        })?;
        if let Some(point) = view
            .object_points
            .iter()
            .position(|x| pose.transform_point(x).z <= 0.0)
        {
            return Err(CalibrationError::PointBehindCamera { view: index, point });
        }
        poses.push(pose);
    }

    let setup = Setup {
        image_size,
        used,
        skipped,
        initial,
        initial_distortion,
        poses,
        start,
    };
    match options.rotation {
        RotationKind::EulerXyz => optimize::<D, EulerXyz>(setup, options),
        RotationKind::AxisAngle => optimize::<D, AxisAngle>(setup, options),
    }
}

fn check_options<D: LensDistortion>(options: &CalibrationOptions) -> Result<(), CalibrationError> {
    if let Some(&i) = options
        .fixed_distortion
        .iter()
        .find(|&&i| i >= D::NUM_PARAMS)
    {
        return Err(CalibrationError::InvalidOption(format!(
            "distortion index {i} out of range: the model {} has {} coefficients",
            D::NAME,
            D::NUM_PARAMS
        )));
    }
    if let Some(d) = &options.distortion_guess
        && (d.len() != D::NUM_PARAMS || d.iter().any(|v| !v.is_finite()))
    {
        return Err(CalibrationError::InvalidOption(format!(
            "distortion guess must have {} finite coefficients",
            D::NUM_PARAMS
        )));
    }
    if let Some(k) = &options.intrinsic_guess
        && !k.is_valid()
    {
        return Err(CalibrationError::InvalidOption(format!(
            "intrinsic guess must be finite with positive focal lengths: {k:?}"
        )));
    }
    Ok(())
}

struct Prepared<'a> {
    used: Vec<(usize, &'a View)>,
    homographies: Vec<Matrix3<f64>>,
    skipped: Vec<SkippedView>,
}

/// Checks every view and estimates its homography; bad views are skipped or reported.
fn prepare_views<'a>(
    views: &'a [View],
    options: &CalibrationOptions,
) -> Result<Prepared<'a>, CalibrationError> {
    let mut out = Prepared {
        used: Vec::new(),
        homographies: Vec::new(),
        skipped: Vec::new(),
    };
    for (index, view) in views.iter().enumerate() {
        let result = check_view(index, view).and_then(|()| {
            let object: Vec<Point2<f64>> = view
                .object_points
                .iter()
                .map(|p| Point2::new(p.x, p.y))
                .collect();
            homography::estimate(&object, &view.image_points, &options.homography)
                .map(|e| e.h)
                .map_err(|source| CalibrationError::Homography {
                    view: index,
                    source,
                })
        });
        match result {
            Ok(h) => {
                out.used.push((index, view));
                out.homographies.push(h);
            }
            Err(e) if options.skip_bad_views => out.skipped.push(SkippedView {
                index,
                name: view.name.clone(),
                reason: e.to_string(),
            }),
            Err(e) => return Err(e),
        }
    }
    if out.used.is_empty() {
        return Err(CalibrationError::NoViews {
            skipped: out.skipped.len(),
        });
    }
    Ok(out)
}

struct Setup<'a> {
    image_size: ImageSize,
    used: Vec<(usize, &'a View)>,
    skipped: Vec<SkippedView>,
    initial: Intrinsics,
    initial_distortion: Vec<f64>,
    poses: Vec<Pose>,
    start: Instant,
}

/// Names of the camera block's components: `fx, fy, cx, cy` and the distortion's.
pub fn camera_param_names<D: LensDistortion>() -> Vec<&'static str> {
    let mut names = vec!["fx", "fy", "cx", "cy"];
    names.extend_from_slice(D::PARAM_NAMES);
    names
}

/// Indices of the camera block `[fx, fy, cx, cy, distortion...]` held fixed by `options` for a
/// calibration with `num_views` views (sorted, unique).
pub fn fixed_camera_components<D: LensDistortion>(
    options: &CalibrationOptions,
    num_views: usize,
) -> Vec<usize> {
    let mut fixed = Vec::new();
    if options.fix_principal_point || num_views == 1 {
        fixed.extend([2, 3]);
    }
    if options.fix_focal_length {
        fixed.extend([0, 1]);
    }
    if options.fix_aspect_ratio {
        fixed.push(1);
    }
    if options.zero_tangential_distortion {
        fixed.extend(D::TANGENTIAL_PARAMS.iter().map(|i| 4 + i));
    }
    fixed.extend(options.fixed_distortion.iter().map(|i| 4 + i));
    fixed.sort_unstable();
    fixed.dedup();
    fixed
}

fn optimize<D: LensDistortion, P: RotationParameterization>(
    setup: Setup<'_>,
    options: &CalibrationOptions,
) -> Result<Calibration<D>, CalibrationError> {
    let Setup {
        image_size,
        used,
        skipped,
        initial,
        initial_distortion,
        poses,
        start,
    } = setup;
    let n_cam = 4 + D::NUM_PARAMS;
    let views: Vec<ViewData> = used
        .iter()
        .map(|(_, v)| ViewData {
            object: v.object_points.clone(),
            image: v.image_points.iter().map(|p| p.coords).collect(),
        })
        .collect();
    let aspect_ratio = options.fix_aspect_ratio.then(|| initial.fx / initial.fy);
    let cost = ReprojectionCost::<D, P>::new(&views, aspect_ratio);

    let fixed = fixed_camera_components::<D>(options, used.len());
    let mut builder = ProblemBuilder::new();
    let camera_block = builder.add_parameter_block(n_cam);
    builder.set_fixed_components(camera_block, &fixed);
    let pose_blocks: Vec<ParameterBlockId> = views
        .iter()
        .map(|v| {
            let b = builder.add_parameter_block(6);
            builder.set_eliminated(b, true);
            builder.add_residual_block(2 * v.object.len(), &[camera_block, b]);
            b
        })
        .collect();
    let problem = builder
        .build()
        .map_err(|e| CalibrationError::Initialization {
            reason: e.to_string(),
        })?;
    let num_points: usize = views.iter().map(|v| v.object.len()).sum();
    let (residuals, free) = (problem.num_residuals(), problem.num_free_parameters());
    if residuals <= free {
        return Err(CalibrationError::TooFewObservations {
            residuals,
            parameters: free,
        });
    }

    let mut x = vec![0.0; problem.num_parameters()];
    let camera0 = Camera::new(initial, D::from_params(&initial_distortion));
    camera0.write_params(problem.block_mut(&mut x, camera_block));
    for (pose, &b) in poses.iter().zip(&pose_blocks) {
        problem
            .block_mut(&mut x, b)
            .copy_from_slice(pose.to_params::<P>().as_slice());
    }
    let initial_rms = rms_of(&cost, &problem, &x, num_points);

    let mut solver = Solver::new(problem, options.solver.clone())?;
    let report = solver.solve(&cost, &mut x)?;
    let covariance = solver.covariance(&cost, &x)?;
    let problem = solver.problem();

    let camera = cost.camera(problem.block(&x, camera_block));
    let camera_std = covariance.standard_deviations(camera_block);
    let mut intrinsics_std = [camera_std[0], camera_std[1], camera_std[2], camera_std[3]];
    if let Some(r) = aspect_ratio {
        intrinsics_std[1] = intrinsics_std[0] / r;
    }
    let names = camera_param_names::<D>();
    let fixed_parameters = fixed.iter().map(|&i| names[i].to_string()).collect();

    // Residuals per view for the RMS figures.
    let mut view_results = Vec::with_capacity(views.len());
    let (mut sum_sq, mut sum_x, mut sum_y, mut sum_xx, mut sum_yy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let mut buffer = Vec::new();
    for (k, ((index, view), &b)) in used.iter().zip(&pose_blocks).enumerate() {
        let n = views[k].object.len();
        buffer.resize(2 * n, 0.0);
        cost.evaluate(
            ResidualBlockId(k),
            &[problem.block(&x, camera_block), problem.block(&x, b)],
            &mut buffer,
            None,
        )
        .map_err(|e| CalibrationError::Diverged(e.message))?;
        let view_sq: f64 = buffer.iter().map(|v| v * v).sum();
        for pair in buffer.chunks_exact(2) {
            sum_x += pair[0];
            sum_y += pair[1];
            sum_xx += pair[0] * pair[0];
            sum_yy += pair[1] * pair[1];
        }
        sum_sq += view_sq;
        let params: [f64; 6] = problem.block(&x, b).try_into().unwrap_or([0.0; 6]);
        let std = covariance.standard_deviations(b);
        view_results.push(ViewResult {
            index: *index,
            name: view.name.clone(),
            pose: Pose::from_params::<P>(&Vector6::from(params)),
            pose_params: params,
            pose_std: std.try_into().unwrap_or([0.0; 6]),
            rms: (view_sq / n as f64).sqrt(),
            num_points: n,
        });
    }
    let np = num_points as f64;
    let sample_std = |s: f64, ss: f64| ((ss - s * s / np) / (np - 1.0).max(1.0)).max(0.0).sqrt();
    let calibration = Calibration {
        camera,
        intrinsics_std,
        distortion_std: camera_std[4..].to_vec(),
        fixed_parameters,
        image_size,
        rotation: if P::NAME == AxisAngle::NAME {
            RotationKind::AxisAngle
        } else {
            RotationKind::EulerXyz
        },
        views: view_results,
        skipped_views: skipped,
        rms: (sum_sq / np).sqrt(),
        residual_std: [sample_std(sum_x, sum_xx), sample_std(sum_y, sum_yy)],
        residual_variance: covariance.residual_variance,
        num_points,
        initial_intrinsics: initial,
        initial_rms,
        solver: report,
        elapsed: start.elapsed(),
    };
    check_finite(&calibration)?;
    Ok(calibration)
}

/// RMS reprojection error of the parameters `x` (infinite if some point is behind the camera).
fn rms_of<C: CostFunction>(
    cost: &C,
    problem: &lm_solver::Problem,
    x: &[f64],
    num_points: usize,
) -> f64 {
    let mut sum = 0.0;
    let mut buffer = Vec::new();
    for r in 0..problem.num_residual_blocks() {
        let id = ResidualBlockId(r);
        buffer.resize(problem.residual_dim(id), 0.0);
        let params: Vec<&[f64]> = problem
            .residual_blocks_of(id)
            .map(|b| problem.block(x, b))
            .collect();
        if cost.evaluate(id, &params, &mut buffer, None).is_err() {
            return f64::INFINITY;
        }
        sum += buffer.iter().map(|v| v * v).sum::<f64>();
    }
    (sum / num_points as f64).sqrt()
}

fn check_finite<D: LensDistortion>(c: &Calibration<D>) -> Result<(), CalibrationError> {
    let k = &c.camera.intrinsics;
    let mut values = vec![k.fx, k.fy, k.cx, k.cy, c.rms, c.residual_variance];
    values.extend(c.distortion_coefficients());
    values.extend(c.intrinsics_std);
    values.extend(&c.distortion_std);
    for v in &c.views {
        values.extend(v.pose_params);
        values.extend(v.pose_std);
    }
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(CalibrationError::Diverged(
            "a parameter or its uncertainty is not finite".into(),
        ))
    }
}

/// Projects the board points of a view with a calibrated camera (a convenience for checks and
/// examples): the pixels the model predicts for `pose`.
pub fn reproject<D: LensDistortion>(
    camera: &Camera<D>,
    pose: &Pose,
    view: &View,
) -> Result<Vec<Vector2<f64>>, camera_model::CameraModelError> {
    view.object_points
        .iter()
        .map(|x| camera.project(pose, x))
        .collect()
}
