//! The stereo pipeline: checks, one single-camera calibration per camera, the initial rig, the
//! joint Levenberg-Marquardt over `22 + 6M` parameters and the covariance. Walk-through:
//! `docs/calib-stereo.md`.

use crate::cost::{CameraCoupling, PairData, StereoCost};
use crate::error::{Side, StereoError};
use crate::observations::{StereoObservations, check_pair};
use crate::options::StereoOptions;
use crate::result::{CameraEstimate, PairResult, SkippedPair, StereoCalibration};
use crate::rig::initial_rig;
use calib_single::calibrate::{camera_param_names, fixed_camera_components};
use calib_single::{
    CalibrationError, CalibrationOptions, ImageSize, Observations, calibrate_with_model,
};
use camera_model::{
    AxisAngle, BrownConrady, Camera, EulerXyz, LensDistortion, Pose, RotationKind,
    RotationParameterization, skew,
};
use lm_solver::{CostFunction, ParameterBlockId, ProblemBuilder, ResidualBlockId, Solver};
use nalgebra::{Matrix3, Point2, Vector6};
use std::time::Instant;

/// Calibrates a stereo rig with the Brown-Conrady `k1, k2, p1, p2` model on both cameras.
pub fn calibrate_stereo(
    observations: &StereoObservations,
    options: &StereoOptions,
) -> Result<StereoCalibration<BrownConrady>, StereoError> {
    calibrate_stereo_with_model::<BrownConrady>(observations, options)
}

/// Calibrates a stereo rig with distortion model `D`:
///
/// 1. checks every pair (each view as in single-camera calibration, equal point counts and
///    board points in both views),
/// 2. calibrates each camera alone on its views,
/// 3. computes the initial rig from the per-pair poses (`crate::rig`),
/// 4. optimizes both cameras, the left pose of every pair and the rig together (poses eliminated
///    by the Schur complement; the reduced system has the 22 shared parameters), then computes the
///    covariance.
pub fn calibrate_stereo_with_model<D: LensDistortion>(
    observations: &StereoObservations,
    options: &StereoOptions,
) -> Result<StereoCalibration<D>, StereoError> {
    let start = Instant::now();
    let (left_size, right_size) = observations.sizes()?;
    if observations.pairs.is_empty() {
        return Err(StereoError::NoPairs { skipped: 0 });
    }
    let (kept, skipped) = select_pairs(observations, options)?;

    // Single-camera calibrations on the kept pairs.
    let single = |side: Side, camera_options: &CalibrationOptions, size: ImageSize| {
        let mut camera_options = camera_options.clone();
        camera_options.skip_bad_views = false;
        camera_options.solver.num_threads = options.solver.num_threads;
        // This stage only provides the start of the joint optimization, which refines every
        // parameter to the full tolerance: stop at a relative cost change of 1e-6 (the last
        // iterations of a full convergence move the parameters by far less than the joint
        // stage's first step) and skip the uncertainties.
        camera_options.solver.function_tolerance =
            camera_options.solver.function_tolerance.max(1e-6);
        camera_options.compute_uncertainty = false;
        let obs = Observations {
            image_size: Some(size),
            views: kept
                .iter()
                .map(|&i| match side {
                    Side::Left => observations.pairs[i].left.clone(),
                    Side::Right => observations.pairs[i].right.clone(),
                })
                .collect(),
        };
        calibrate_with_model::<D>(&obs, &camera_options).map_err(|source| StereoError::Camera {
            camera: side,
            source: remap_view(source, &kept),
        })
    };
    let left_single = single(Side::Left, &options.left, left_size)?;
    let right_single = single(Side::Right, &options.right, right_size)?;
    let single_times = [left_single.elapsed, right_single.elapsed];

    let left_poses: Vec<Pose> = left_single.views.iter().map(|v| v.pose).collect();
    let right_poses: Vec<Pose> = right_single.views.iter().map(|v| v.pose).collect();
    let rig0 = match options.rig_guess {
        Some(rig) => rig,
        None => initial_rig(options.rig_init, &left_poses, &right_poses).ok_or_else(|| {
            StereoError::RigInitialization("no rotation from the per-pair poses".into())
        })?,
    };

    let setup = Setup {
        observations,
        kept,
        skipped,
        sizes: (left_size, right_size),
        cameras: (left_single.camera, right_single.camera),
        left_poses,
        rig0,
        start,
        single_times,
    };
    match options.rotation {
        RotationKind::EulerXyz => optimize::<D, EulerXyz>(setup, options),
        RotationKind::AxisAngle => optimize::<D, AxisAngle>(setup, options),
        _ => Err(StereoError::RigInitialization(
            "rotation kind not supported".into(),
        )),
    }
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

/// Renames a single-camera error's view index (an index into the kept pairs) to the pair index.
fn remap_view(error: CalibrationError, kept: &[usize]) -> CalibrationError {
    let pair = |view: usize| kept.get(view).copied().unwrap_or(view);
    match error {
        CalibrationError::Homography { view, source } => CalibrationError::Homography {
            view: pair(view),
            source,
        },
        CalibrationError::PointBehindCamera { view, point } => {
            CalibrationError::PointBehindCamera {
                view: pair(view),
                point,
            }
        }
        other => other,
    }
}

struct Setup<'a, D> {
    observations: &'a StereoObservations,
    kept: Vec<usize>,
    skipped: Vec<SkippedPair>,
    sizes: (ImageSize, ImageSize),
    cameras: (Camera<D>, Camera<D>),
    left_poses: Vec<Pose>,
    rig0: Pose,
    start: Instant,
    single_times: [std::time::Duration; 2],
}

/// Fixed components of one camera block in the joint optimization.
fn joint_fixed<D: LensDistortion>(
    camera_options: &CalibrationOptions,
    fix_all: bool,
    pairs: usize,
) -> Vec<usize> {
    if fix_all {
        return (0..4 + D::NUM_PARAMS).collect();
    }
    fixed_camera_components::<D>(camera_options, pairs)
}

fn optimize<D: LensDistortion, P: RotationParameterization>(
    setup: Setup<'_, D>,
    options: &StereoOptions,
) -> Result<StereoCalibration<D>, StereoError> {
    let Setup {
        observations,
        kept,
        skipped,
        sizes,
        cameras,
        left_poses,
        rig0,
        start,
        single_times,
    } = setup;
    let joint_start = Instant::now();
    let n_cam = 4 + D::NUM_PARAMS;
    let pairs: Vec<PairData> = kept
        .iter()
        .map(|&i| {
            let p = &observations.pairs[i];
            PairData {
                object: p.left.object_points.clone(),
                left: p.left.image_points.iter().map(|x| x.coords).collect(),
                right: p.right.image_points.iter().map(|x| x.coords).collect(),
            }
        })
        .collect();
    let ratio = |c: &Camera<D>| c.intrinsics.fx / c.intrinsics.fy;
    let coupling = CameraCoupling {
        left_aspect: options.left.fix_aspect_ratio.then(|| ratio(&cameras.0)),
        right_aspect: options.right.fix_aspect_ratio.then(|| ratio(&cameras.1)),
        same_focal_length: options.same_focal_length,
    };
    let cost = StereoCost::<D, P>::new(&pairs, coupling);

    let left_fixed = joint_fixed::<D>(&options.left, options.fix_left_intrinsics, pairs.len());
    let mut right_fixed =
        joint_fixed::<D>(&options.right, options.fix_right_intrinsics, pairs.len());
    if options.same_focal_length {
        right_fixed.extend([0, 1]);
        right_fixed.sort_unstable();
        right_fixed.dedup();
    }
    let mut builder = ProblemBuilder::new();
    let left_block = builder.add_parameter_block(n_cam);
    let right_block = builder.add_parameter_block(n_cam);
    let rig_block = builder.add_parameter_block(6);
    builder.set_fixed_components(left_block, &left_fixed);
    builder.set_fixed_components(right_block, &right_fixed);
    let pose_blocks: Vec<ParameterBlockId> = pairs
        .iter()
        .map(|p| {
            let b = builder.add_parameter_block(6);
            builder.set_eliminated(b, true);
            builder.add_residual_block(2 * p.object.len(), &[left_block, b]);
            if options.same_focal_length {
                builder.add_residual_block(
                    2 * p.object.len(),
                    &[right_block, b, rig_block, left_block],
                );
            } else {
                builder.add_residual_block(2 * p.object.len(), &[right_block, b, rig_block]);
            }
            b
        })
        .collect();
    let problem = builder
        .build()
        .map_err(|e| StereoError::RigInitialization(e.to_string()))?;
    let (residuals, free) = (problem.num_residuals(), problem.num_free_parameters());
    if residuals <= free {
        return Err(StereoError::TooFewObservations {
            residuals,
            parameters: free,
        });
    }
    let mut x = vec![0.0; problem.num_parameters()];
    cameras
        .0
        .write_params(problem.block_mut(&mut x, left_block));
    cameras
        .1
        .write_params(problem.block_mut(&mut x, right_block));
    problem
        .block_mut(&mut x, rig_block)
        .copy_from_slice(rig0.to_params::<P>().as_slice());
    for (pose, &b) in left_poses.iter().zip(&pose_blocks) {
        problem
            .block_mut(&mut x, b)
            .copy_from_slice(pose.to_params::<P>().as_slice());
    }
    let points_per_camera: usize = pairs.iter().map(|p| p.object.len()).sum();
    let total_points = 2 * points_per_camera;

    let mut solver = Solver::new(problem, options.solver.clone())?;
    let initial_cost = residual_costs(&cost, solver.problem(), &x)?;
    let initial_rms = (initial_cost.iter().sum::<f64>() / total_points as f64).sqrt();
    let report = solver.solve(&cost, &mut x)?;
    let joint_done = Instant::now();
    let covariance = solver.covariance(&cost, &x)?;
    let problem = solver.problem();

    let left_params = problem.block(&x, left_block);
    let left_camera = cost.left_camera(left_params);
    let right_camera = cost.right_camera(problem.block(&x, right_block), left_params);
    let costs = residual_costs(&cost, problem, &x)?;
    let names = camera_param_names::<D>();
    let estimate = |camera: Camera<D>,
                    block: ParameterBlockId,
                    fixed: &[usize],
                    aspect: Option<f64>,
                    size: ImageSize,
                    offset: usize| {
        let std = covariance.standard_deviations(block);
        let mut intrinsics_std = [std[0], std[1], std[2], std[3]];
        if let Some(r) = aspect {
            intrinsics_std[1] = intrinsics_std[0] / r;
        }
        let sum: f64 = costs.iter().skip(offset).step_by(2).sum();
        CameraEstimate {
            camera,
            intrinsics_std,
            distortion_std: std[4..].to_vec(),
            fixed_parameters: fixed.iter().map(|&i| names[i].to_string()).collect(),
            image_size: size,
            rms: (sum / points_per_camera as f64).sqrt(),
        }
    };
    let left = estimate(
        left_camera,
        left_block,
        &left_fixed,
        coupling.left_aspect,
        sizes.0,
        0,
    );
    let mut right = estimate(
        right_camera,
        right_block,
        &right_fixed,
        coupling.right_aspect,
        sizes.1,
        1,
    );
    if options.same_focal_length {
        right.intrinsics_std[0] = left.intrinsics_std[0];
        right.intrinsics_std[1] = left.intrinsics_std[1];
    }

    let rig_params: [f64; 6] = problem.block(&x, rig_block).try_into().unwrap_or([0.0; 6]);
    let rig = Pose::from_params::<P>(&Vector6::from(rig_params));
    let rig_std: [f64; 6] = covariance
        .standard_deviations(rig_block)
        .try_into()
        .unwrap_or([0.0; 6]);
    let essential = skew(&rig.translation) * rig.rotation;
    let fundamental = fundamental_matrix(&left.camera, &right.camera, &essential);

    let pair_results = kept
        .iter()
        .zip(&pairs)
        .zip(&pose_blocks)
        .enumerate()
        .map(|(k, ((&index, data), &b))| {
            let params: [f64; 6] = problem.block(&x, b).try_into().unwrap_or([0.0; 6]);
            let n = data.object.len() as f64;
            let p = &observations.pairs[index];
            PairResult {
                index,
                names: (p.left.name.clone(), p.right.name.clone()),
                left_pose: Pose::from_params::<P>(&Vector6::from(params)),
                pose_params: params,
                pose_std: covariance
                    .standard_deviations(b)
                    .try_into()
                    .unwrap_or([0.0; 6]),
                rms_left: (costs[2 * k] / n).sqrt(),
                rms_right: (costs[2 * k + 1] / n).sqrt(),
                num_points: data.object.len(),
            }
        })
        .collect();
    let result = StereoCalibration {
        left,
        right,
        rig,
        rig_params,
        rig_std,
        rotation: if P::NAME == AxisAngle::NAME {
            RotationKind::AxisAngle
        } else {
            RotationKind::EulerXyz
        },
        essential,
        fundamental,
        baseline: rig.translation.norm(),
        rms: (costs.iter().sum::<f64>() / total_points as f64).sqrt(),
        pairs: pair_results,
        skipped_pairs: skipped,
        residual_variance: covariance.residual_variance,
        initial_rig: rig0,
        initial_rms,
        solver: report,
        elapsed: start.elapsed(),
        stage_times: [
            single_times[0],
            single_times[1],
            joint_done - joint_start,
            joint_done.elapsed(),
        ],
    };
    check_finite(&result)?;
    Ok(result)
}

/// `F = K_R^-T E K_L^-1`, scaled so that `F[2][2] = 1` (OpenCV's normalization) unless that entry
/// is (nearly) zero.
fn fundamental_matrix<D: LensDistortion>(
    left: &Camera<D>,
    right: &Camera<D>,
    essential: &Matrix3<f64>,
) -> Matrix3<f64> {
    let kl = left
        .intrinsics
        .matrix()
        .try_inverse()
        .unwrap_or_else(Matrix3::zeros);
    let kr = right
        .intrinsics
        .matrix()
        .try_inverse()
        .unwrap_or_else(Matrix3::zeros);
    let f = kr.transpose() * essential * kl;
    let scale = f[(2, 2)];
    if scale.abs() > 1e-12 * f.norm() {
        f / scale
    } else {
        f
    }
}

/// Squared residual norm of every residual block.
fn residual_costs<C: CostFunction>(
    cost: &C,
    problem: &lm_solver::Problem,
    x: &[f64],
) -> Result<Vec<f64>, StereoError> {
    let mut buffer = Vec::new();
    (0..problem.num_residual_blocks())
        .map(|r| {
            let id = ResidualBlockId(r);
            buffer.resize(problem.residual_dim(id), 0.0);
            let params: Vec<&[f64]> = problem
                .residual_blocks_of(id)
                .map(|b| problem.block(x, b))
                .collect();
            cost.evaluate(id, &params, &mut buffer, None)
                .map_err(|e| StereoError::Diverged(e.message))?;
            Ok(buffer.iter().map(|v| v * v).sum())
        })
        .collect()
}

fn check_finite<D: LensDistortion>(r: &StereoCalibration<D>) -> Result<(), StereoError> {
    let mut values = vec![r.rms, r.baseline, r.residual_variance];
    for c in [&r.left, &r.right] {
        let k = &c.camera.intrinsics;
        values.extend([k.fx, k.fy, k.cx, k.cy]);
        values.extend(c.intrinsics_std);
        values.extend(&c.distortion_std);
    }
    values.extend(r.rig_params);
    values.extend(r.rig_std);
    values.extend(r.fundamental.iter());
    for p in &r.pairs {
        values.extend(p.pose_params);
        values.extend(p.pose_std);
    }
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(StereoError::Diverged(
            "a parameter or its uncertainty is not finite".into(),
        ))
    }
}
