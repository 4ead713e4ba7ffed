//! The stereo pipeline, a thin front end over the engine (`calib_core`): checks, one
//! single-camera calibration per camera, the initial rig, the joint Levenberg-Marquardt over
//! `22 + 6M` parameters and the covariance. Walk-through: `docs/calib-stereo.md`.

use crate::error::{Side, StereoError};
use crate::observations::{StereoObservations, check_pair};
use crate::options::StereoOptions;
use crate::result::{PairResult, SkippedPair, StereoCalibration};
use calib_core::init::StartMethod;
use calib_core::result::CameraEstimate;
use calib_core::rig::initial_rig;
use calib_core::single::camera_param_names;
use calib_core::{
    CalibrationError, CalibrationOptions, JointProblem, JointSolution, ObservationSpec,
    SolveOptions, View, prepare_camera,
};
use camera_model::{AnyCamera, Pose, skew};
use nalgebra::{Matrix3, Point2};
use std::time::Instant;

/// Calibrates a stereo rig (lens models `options.left.model` and `options.right.model`,
/// Brown-Conrady `k1, k2, p1, p2` by default):
///
/// 1. checks every pair (each view as in single-camera calibration),
/// 2. calibrates each camera alone on its views,
/// 3. computes the initial rig from the per-pair poses (`calib_core::rig`),
/// 4. optimizes both cameras, the left pose of every pair and the rig together (poses eliminated
///    by the Schur complement; the reduced system has the shared parameters), then computes the
///    covariance.
pub fn calibrate_stereo(
    observations: &StereoObservations,
    options: &StereoOptions,
) -> Result<StereoCalibration, StereoError> {
    let start = Instant::now();
    let (left_size, right_size) = observations.sizes()?;
    if observations.pairs.is_empty() {
        return Err(StereoError::NoPairs { skipped: 0 });
    }
    let (kept, skipped) = select_pairs(observations, options)?;

    // Single-camera calibrations on the kept pairs.
    let single = |side: Side, camera_options: &CalibrationOptions, size| {
        let t = Instant::now();
        let mut camera_options = camera_options.clone();
        camera_options.skip_bad_views = false;
        let views: Vec<(usize, &View)> = kept
            .iter()
            .map(|&i| {
                let pair = &observations.pairs[i];
                (
                    i,
                    match side {
                        Side::Left => &pair.left,
                        Side::Right => &pair.right,
                    },
                )
            })
            .collect();
        let camera_error = |source| StereoError::Camera {
            camera: side,
            source,
        };
        let prepared = prepare_camera(&views, Some(size), &camera_options).map_err(camera_error)?;
        let spec = prepared.camera_spec(&side.to_string());
        let start_method = prepared.start_method;
        // This stage only provides the start of the joint optimization, which refines every
        // parameter to the full tolerance: stop at a relative cost change of 1e-6 (the last
        // iterations of a full convergence move the parameters by far less than the joint
        // stage's first step) and skip the uncertainties.
        let mut solve = SolveOptions::default();
        solve.rotation = options.rotation;
        solve.solver = camera_options.solver.clone();
        solve.solver.num_threads = options.solver.num_threads;
        solve.solver.function_tolerance = solve.solver.function_tolerance.max(1e-6);
        solve.compute_uncertainty = false;
        let solution = calib_core::solve(&prepared.into_problem(&side.to_string()), &solve)
            .map_err(camera_error)?;
        Ok::<_, StereoError>((spec, start_method, solution, t.elapsed()))
    };
    let (left_prepared, left_method, left_single, left_time) =
        single(Side::Left, &options.left, left_size)?;
    let (right_prepared, right_method, right_single, right_time) =
        single(Side::Right, &options.right, right_size)?;

    let rig0 = match options.rig_guess {
        Some(rig) => rig,
        None => initial_rig(options.rig_init, &left_single.frames, &right_single.frames)
            .ok_or_else(|| {
                StereoError::RigInitialization("no rotation from the per-pair poses".into())
            })?,
    };
    let joint_start = Instant::now();
    let problem = joint_problem(
        observations,
        &kept,
        options,
        [left_prepared, right_prepared],
        [&left_single.cameras[0], &right_single.cameras[0]],
        &left_single.frames,
        rig0,
    );
    let mut solve = SolveOptions::default();
    solve.rotation = options.rotation;
    solve.solver = options.solver.clone();
    let solution = calib_core::solve(&problem, &solve).map_err(|e| joint_error(e, &kept))?;
    let joint_done = Instant::now();
    let mut result = assemble(
        observations,
        &kept,
        skipped,
        &problem,
        solution,
        rig0,
        [left_time, right_time, joint_done - joint_start],
        start,
    )?;
    result.initial_methods = [left_method, right_method];
    Ok(result)
}

/// Maps an engine error of the joint stage to the stereo error (its messages already name the
/// cameras and pairs).
fn joint_error(error: CalibrationError, _kept: &[usize]) -> StereoError {
    match error {
        CalibrationError::TooFewObservations {
            residuals,
            parameters,
        } => StereoError::TooFewObservations {
            residuals,
            parameters,
        },
        CalibrationError::Solver(e) => StereoError::Solver(e),
        other => StereoError::Joint(other),
    }
}

/// The joint problem of the kept pairs: camera 0 left (reference), camera 1 right, one frame per
/// pair with the left camera's board pose, each camera starting from its single-camera estimate
/// (or held at it).
fn joint_problem(
    observations: &StereoObservations,
    kept: &[usize],
    options: &StereoOptions,
    specs: [calib_core::CameraSpec; 2],
    cameras: [&AnyCamera; 2],
    left_poses: &[Pose],
    rig0: Pose,
) -> JointProblem {
    let mut specs = specs.to_vec();
    for (c, (camera_options, fix_all)) in [
        (&options.left, options.fix_left_intrinsics),
        (&options.right, options.fix_right_intrinsics),
    ]
    .into_iter()
    .enumerate()
    {
        let spec = &mut specs[c];
        spec.initial = cameras[c].clone();
        let k = cameras[c].intrinsics;
        spec.aspect_ratio = camera_options.fix_aspect_ratio.then(|| k.fx / k.fy);
        if fix_all {
            spec.fixed = (0..spec.model().num_params()).collect();
        }
    }
    if options.same_focal_length {
        let right = &mut specs[1];
        right.focal_from = Some(0);
        right.fixed.extend([0, 1]);
        right.fixed.sort_unstable();
        right.fixed.dedup();
    }
    let mut obs = Vec::with_capacity(2 * kept.len());
    for (frame, &i) in kept.iter().enumerate() {
        let pair = &observations.pairs[i];
        for (camera, view) in [(0, &pair.left), (1, &pair.right)] {
            obs.push(ObservationSpec::new(
                camera,
                frame,
                format!(
                    "pair {i} {} view ({})",
                    if camera == 0 { "left" } else { "right" },
                    view.name
                ),
                view.object_points.clone(),
                view.image_points.iter().map(|p| p.coords).collect(),
            ));
        }
    }
    JointProblem {
        cameras: specs,
        reference: 0,
        rig: vec![Pose::identity(), rig0],
        rig_fixed: vec![true, false],
        frames: left_poses.to_vec(),
        frame_names: kept.iter().map(|i| format!("pair {i}")).collect(),
        observations: obs,
    }
}

/// The joint problem of a stereo data set at given parameters (every pair; cameras, left poses
/// and rig as given), for evaluating the cost at someone else's solution.
pub fn stereo_problem(
    observations: &StereoObservations,
    cameras: [&AnyCamera; 2],
    left_poses: &[Pose],
    rig: Pose,
) -> Result<JointProblem, StereoError> {
    let (left_size, right_size) = observations.sizes()?;
    let mut specs = Vec::new();
    for (name, size, camera) in [
        ("left", left_size, cameras[0]),
        ("right", right_size, cameras[1]),
    ] {
        specs.push(calib_core::CameraSpec::new(name, size, camera.clone()));
    }
    let mut obs = Vec::new();
    for (i, pair) in observations.pairs.iter().enumerate() {
        for (camera, view) in [(0, &pair.left), (1, &pair.right)] {
            obs.push(ObservationSpec::new(
                camera,
                i,
                format!("pair {i}"),
                view.object_points.clone(),
                view.image_points.iter().map(|p| p.coords).collect(),
            ));
        }
    }
    Ok(JointProblem {
        cameras: specs,
        reference: 0,
        rig: vec![Pose::identity(), rig],
        rig_fixed: vec![true, false],
        frames: left_poses.to_vec(),
        frame_names: (0..observations.pairs.len())
            .map(|i| format!("pair {i}"))
            .collect(),
        observations: obs,
    })
}

/// Checks the pairs; with `skip_bad_pairs`, pairs failing the checks or whose homography cannot
/// be estimated in either view are left out.
fn select_pairs(
    observations: &StereoObservations,
    options: &StereoOptions,
) -> Result<(Vec<usize>, Vec<SkippedPair>), StereoError> {
    let mut kept = Vec::new();
    let mut skipped = Vec::new();
    for (index, pair) in observations.pairs.iter().enumerate() {
        let mut result = check_pair(index, pair);
        if result.is_ok() && options.skip_bad_pairs {
            // The single-camera calibrations would stop on a bad homography; find it here.
            for (camera, view, homography_options) in [
                (Side::Left, &pair.left, &options.left.homography),
                (Side::Right, &pair.right, &options.right.homography),
            ] {
                let object: Vec<Point2<f64>> = view
                    .object_points
                    .iter()
                    .map(|p| Point2::new(p.x, p.y))
                    .collect();
                if let Err(source) =
                    homography::estimate(&object, &view.image_points, homography_options)
                {
                    result = Err(StereoError::View {
                        pair: index,
                        camera,
                        source: CalibrationError::Homography {
                            view: index,
                            source,
                        },
                    });
                    break;
                }
            }
        }
        match result {
            Ok(()) => kept.push(index),
            Err(e) if options.skip_bad_pairs => skipped.push(SkippedPair {
                index,
                reason: e.to_string(),
            }),
            Err(e) => return Err(e),
        }
    }
    if kept.is_empty() {
        return Err(StereoError::NoPairs {
            skipped: skipped.len(),
        });
    }
    Ok((kept, skipped))
}

/// `F = K_R^-T E K_L^-1`, scaled so that `F[2][2] = 1` (OpenCV's normalization) unless that entry
/// is (nearly) zero.
fn fundamental_matrix(
    left: &AnyCamera,
    right: &AnyCamera,
    essential: &Matrix3<f64>,
) -> Matrix3<f64> {
    let kl = left.matrix().try_inverse().unwrap_or_else(Matrix3::zeros);
    let kr = right.matrix().try_inverse().unwrap_or_else(Matrix3::zeros);
    let f = kr.transpose() * essential * kl;
    let scale = f[(2, 2)];
    if scale.abs() > 1e-12 * f.norm() {
        f / scale
    } else {
        f
    }
}

#[allow(clippy::too_many_arguments)]
fn assemble(
    observations: &StereoObservations,
    kept: &[usize],
    skipped: Vec<SkippedPair>,
    problem: &JointProblem,
    solution: JointSolution,
    rig0: Pose,
    times: [std::time::Duration; 3],
    start: Instant,
) -> Result<StereoCalibration, StereoError> {
    let squared: Vec<f64> = solution
        .residuals
        .iter()
        .map(|e| e.iter().map(|v| v.norm_squared()).sum())
        .collect();
    let points: Vec<usize> = solution.residuals.iter().map(Vec::len).collect();
    let estimate = |c: usize, name: &str| {
        let std = &solution.camera_std[c];
        let (sum, n) = (0..squared.len())
            .filter(|&o| problem.observations[o].camera == c)
            .fold((0.0, 0), |(s, n), o| (s + squared[o], n + points[o]));
        let spec = &problem.cameras[c];
        let names = camera_param_names(spec.model());
        CameraEstimate {
            name: name.into(),
            camera: solution.cameras[c].clone(),
            image_size: spec.image_size,
            intrinsics_std: [std[0], std[1], std[2], std[3]],
            distortion_std: std[4..].to_vec(),
            fixed_parameters: spec.fixed.iter().map(|&i| names[i].to_string()).collect(),
            rms: (sum / n.max(1) as f64).sqrt(),
            num_points: n,
        }
    };
    let (left, right) = (estimate(0, "left"), estimate(1, "right"));
    let rig = solution.rig[1];
    let essential = skew(&rig.translation) * rig.rotation;
    let fundamental = fundamental_matrix(&left.camera, &right.camera, &essential);
    let pairs = kept
        .iter()
        .enumerate()
        .map(|(k, &index)| {
            let p = &observations.pairs[index];
            PairResult {
                index,
                names: (p.left.name.clone(), p.right.name.clone()),
                left_pose: solution.frames[k],
                pose_params: solution.frame_params[k],
                pose_std: solution.frame_std[k],
                rms_left: (squared[2 * k] / points[2 * k] as f64).sqrt(),
                rms_right: (squared[2 * k + 1] / points[2 * k + 1] as f64).sqrt(),
                num_points: points[2 * k],
            }
        })
        .collect();
    let total_points: usize = points.iter().sum();
    let total_squared: f64 = squared.iter().sum();
    let joint = solution.report.total_time;
    Ok(StereoCalibration {
        left,
        right,
        rig,
        rig_params: solution.rig_params[1],
        rig_std: solution.rig_std[1],
        rotation: solution.rotation,
        essential,
        fundamental,
        baseline: rig.translation.norm(),
        rms: (total_squared / total_points as f64).sqrt(),
        pairs,
        skipped_pairs: skipped,
        residual_variance: solution.residual_variance,
        initial_rig: rig0,
        initial_methods: [StartMethod::Given; 2],
        initial_rms: (2.0 * solution.report.initial_cost / total_points as f64).sqrt(),
        solver: solution.report,
        elapsed: start.elapsed(),
        stage_times: [times[0], times[1], joint, times[2].saturating_sub(joint)],
    })
}
