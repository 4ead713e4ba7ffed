//! The calibration pipeline: checks, homographies, closed-form start, Levenberg-Marquardt,
//! covariance. Walk-through with formulas: `docs/calib-single.md`.

use crate::cost::{ReprojectionCost, ViewData};
use crate::error::CalibrationError;
use crate::init::{initial_intrinsics, initial_pose};
use crate::observations::{ImageSize, Observations, View, check_view};
use crate::options::CalibrationOptions;
use crate::result::{Calibration, SkippedView, StageTimes, ViewResult};
use camera_model::{
    AxisAngle, BrownConrady, Camera, EulerXyz, Intrinsics, LensDistortion, Pose, RotationKind,
    RotationParameterization,
};
use lm_solver::{CostFunction, ParameterBlockId, Problem, ProblemBuilder, ResidualBlockId, Solver};
use nalgebra::{Matrix3, Point2, Vector2, Vector6};
use std::marker::PhantomData;
use std::time::Duration;
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
    let prepared = CalibrationProblem::<D>::new(observations, options)?;
    match options.rotation {
        RotationKind::EulerXyz => solve::<D, EulerXyz>(prepared, options, start),
        RotationKind::AxisAngle => solve::<D, AxisAngle>(prepared, options, start),
        _ => Err(CalibrationError::InvalidOption(
            "rotation kind not supported".into(),
        )),
    }
}

/// A single-camera calibration set up for the solver: the checked views, the closed-form start
/// and the Levenberg-Marquardt problem (camera block reduced, one eliminated pose block and one
/// residual block per view). [`calibrate`] builds one and solves it; it is public for callers
/// that drive or time the solver themselves (the benchmarks do).
#[derive(Debug, Clone)]
pub struct CalibrationProblem<D> {
    /// Image size.
    pub image_size: ImageSize,
    /// Input index and name of each used view, in order.
    pub used_views: Vec<(usize, String)>,
    /// Views left out by `skip_bad_views`.
    pub skipped: Vec<SkippedView>,
    /// The used views' points, as the cost function reads them.
    pub views: Vec<ViewData>,
    /// Closed-form (or given) intrinsics.
    pub initial: Intrinsics,
    /// Initial distortion coefficients.
    pub initial_distortion: Vec<f64>,
    /// Closed-form pose of each used view.
    pub initial_poses: Vec<Pose>,
    /// `fx / fy` when the aspect ratio is fixed.
    pub aspect_ratio: Option<f64>,
    /// Fixed components of the camera block.
    pub fixed: Vec<usize>,
    /// The Levenberg-Marquardt problem.
    pub problem: Problem,
    /// The camera block.
    pub camera_block: ParameterBlockId,
    /// One pose block per used view.
    pub pose_blocks: Vec<ParameterBlockId>,
    /// Time spent on checks and homographies, and on the closed-form start.
    pub preparation_times: (Duration, Duration),
    _model: PhantomData<fn() -> D>,
}

impl<D: LensDistortion> CalibrationProblem<D> {
    /// Checks the observations and options, estimates the homographies, computes the closed-form
    /// start and builds the problem (steps 1 to 3 of [`calibrate_with_model`]).
    pub fn new(
        observations: &Observations,
        options: &CalibrationOptions,
    ) -> Result<Self, CalibrationError> {
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
        let Prepared {
            used,
            homographies,
            skipped,
        } = prepare_views(&observations.views, options)?;
        let homographies_done = Instant::now();

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
        let mut initial_poses = Vec::with_capacity(used.len());
        for (&(index, view), h) in used.iter().zip(&homographies) {
            let pose =
                initial_pose(h, &initial).ok_or_else(|| CalibrationError::Initialization {
                    reason: format!("view {index}: no pose from its homography"),
                })?;
            if let Some(point) = view
                .object_points
                .iter()
                .position(|x| pose.transform_point(x).z <= 0.0)
            {
                return Err(CalibrationError::PointBehindCamera { view: index, point });
            }
            initial_poses.push(pose);
        }

        let views: Vec<ViewData> = used
            .iter()
            .map(|(_, v)| ViewData {
                object: v.object_points.clone(),
                image: v.image_points.iter().map(|p| p.coords).collect(),
            })
            .collect();
        let fixed = fixed_camera_components::<D>(options, used.len());
        let mut builder = ProblemBuilder::new();
        let camera_block = builder.add_parameter_block(4 + D::NUM_PARAMS);
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
        let (residuals, free) = (problem.num_residuals(), problem.num_free_parameters());
        if residuals <= free {
            return Err(CalibrationError::TooFewObservations {
                residuals,
                parameters: free,
            });
        }
        Ok(Self {
            image_size,
            used_views: used.iter().map(|(i, v)| (*i, v.name.clone())).collect(),
            skipped,
            views,
            aspect_ratio: options.fix_aspect_ratio.then(|| initial.fx / initial.fy),
            initial,
            initial_distortion,
            initial_poses,
            fixed,
            problem,
            camera_block,
            pose_blocks,
            preparation_times: (homographies_done - start, homographies_done.elapsed()),
            _model: PhantomData,
        })
    }

    /// The cost function over the used views, with poses in parameterization `P`.
    pub fn cost<P: RotationParameterization>(&self) -> ReprojectionCost<'_, D, P> {
        ReprojectionCost::new(&self.views, self.aspect_ratio)
    }

    /// The closed-form start as the solver's flat parameter vector, poses in parameterization `P`.
    pub fn start<P: RotationParameterization>(&self) -> Vec<f64> {
        let mut x = vec![0.0; self.problem.num_parameters()];
        Camera::new(self.initial, D::from_params(&self.initial_distortion))
            .write_params(self.problem.block_mut(&mut x, self.camera_block));
        for (pose, &b) in self.initial_poses.iter().zip(&self.pose_blocks) {
            self.problem
                .block_mut(&mut x, b)
                .copy_from_slice(pose.to_params::<P>().as_slice());
        }
        x
    }

    /// Total number of points used.
    pub fn num_points(&self) -> usize {
        self.views.iter().map(|v| v.object.len()).sum()
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

fn solve<D: LensDistortion, P: RotationParameterization>(
    prepared: CalibrationProblem<D>,
    options: &CalibrationOptions,
    start: Instant,
) -> Result<Calibration<D>, CalibrationError> {
    let optimization_start = Instant::now();
    let cost = prepared.cost::<P>();
    let mut x = prepared.start::<P>();
    let num_points = prepared.num_points();
    let (camera_block, aspect_ratio) = (prepared.camera_block, prepared.aspect_ratio);

    let mut solver = Solver::new(prepared.problem.clone(), options.solver.clone())?;
    let report = solver.solve(&cost, &mut x)?;
    let optimization_done = Instant::now();
    let covariance = if options.compute_uncertainty {
        Some(solver.covariance(&cost, &x)?)
    } else {
        None
    };
    let problem = solver.problem();
    let std_of = |block: ParameterBlockId| match &covariance {
        Some(c) => c.standard_deviations(block),
        None => vec![0.0; problem.dim(block)],
    };

    let camera = cost.camera(problem.block(&x, camera_block));
    let camera_std = std_of(camera_block);
    let mut intrinsics_std = [camera_std[0], camera_std[1], camera_std[2], camera_std[3]];
    if let Some(r) = aspect_ratio {
        intrinsics_std[1] = intrinsics_std[0] / r;
    }
    let names = camera_param_names::<D>();
    let fixed_parameters = prepared
        .fixed
        .iter()
        .map(|&i| names[i].to_string())
        .collect();

    // Residuals per view for the RMS figures.
    let mut view_results = Vec::with_capacity(prepared.views.len());
    let (mut sum_sq, mut sum_x, mut sum_y, mut sum_xx, mut sum_yy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let mut buffer = Vec::new();
    for (k, ((index, name), &b)) in prepared
        .used_views
        .iter()
        .zip(&prepared.pose_blocks)
        .enumerate()
    {
        let n = prepared.views[k].object.len();
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
        view_results.push(ViewResult {
            index: *index,
            name: name.clone(),
            pose: Pose::from_params::<P>(&Vector6::from(params)),
            pose_params: params,
            pose_std: std_of(b).try_into().unwrap_or([0.0; 6]),
            rms: (view_sq / n as f64).sqrt(),
            num_points: n,
        });
    }
    let np = num_points as f64;
    let sample_std = |s: f64, ss: f64| ((ss - s * s / np) / (np - 1.0).max(1.0)).max(0.0).sqrt();
    let (homographies, initialization) = prepared.preparation_times;
    let calibration = Calibration {
        camera,
        intrinsics_std,
        distortion_std: camera_std[4..].to_vec(),
        fixed_parameters,
        image_size: prepared.image_size,
        rotation: if P::NAME == AxisAngle::NAME {
            RotationKind::AxisAngle
        } else {
            RotationKind::EulerXyz
        },
        views: view_results,
        skipped_views: prepared.skipped,
        rms: (sum_sq / np).sqrt(),
        residual_std: [sample_std(sum_x, sum_xx), sample_std(sum_y, sum_yy)],
        residual_variance: sum_sq
            / (problem.num_residuals() - problem.num_free_parameters()) as f64,
        num_points,
        initial_intrinsics: prepared.initial,
        // The cost is half the sum of squared residuals.
        initial_rms: (2.0 * report.initial_cost / np).sqrt(),
        solver: report,
        elapsed: start.elapsed(),
        stage_times: StageTimes {
            homographies,
            initialization,
            optimization: optimization_done - optimization_start,
            uncertainty: optimization_done.elapsed(),
        },
    };
    check_finite(&calibration)?;
    Ok(calibration)
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
