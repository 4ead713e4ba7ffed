//! The stereo pipeline, a thin front end over the engine (`calib_core`): checks, one
//! single-camera calibration per camera, the initial rig, the joint Levenberg-Marquardt over
//! `22 + 6M` parameters and the covariance. Walk-through: `docs/calib-stereo.md`.

use crate::error::{Side, StereoError};
use crate::observations::{StereoObservations, check_pair};
use crate::options::StereoOptions;
use crate::result::{PairResult, SkippedPair, StereoCalibration};
use calib_core::diagnostics::{duplicate_views, same_view};
use calib_core::init::StartMethod;
use calib_core::result::CameraEstimate;
use calib_core::rig::{candidate_rigs, initial_rig, rig_rotation_disagreements, start_cost};
use calib_core::single::camera_param_names;
use calib_core::warnings::{Warning, WarningCode};
use calib_core::{
    CalibrationError, CalibrationOptions, JointProblem, JointSolution, ObservationSpec,
    PreparedCamera, SolveOptions, View, prepare_camera,
};
use camera_model::{AnyCamera, Pose, skew};
use nalgebra::{Matrix3, Point2, Vector3};
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
    let (mut kept, mut skipped) = select_pairs(observations, options)?;
    let mut warnings = Vec::new();
    loop {
        match calibrate_pairs(observations, &kept, (left_size, right_size), options, false) {
            Ok(mut result) => {
                skipped.sort_by_key(|s| s.index);
                result.skipped_pairs = skipped;
                warnings.append(&mut result.warnings);
                result.warnings = warnings;
                result.elapsed = start.elapsed();
                return Ok(result);
            }
            Err(PairsFailure::Error(error)) => return Err(error),
            // Whole pairs that are wrong: with `skip_bad_pairs`, drop them and start again.
            Err(PairsFailure::BadPairs(error, bad)) => {
                let positions: Vec<usize> = bad.iter().map(|(k, _)| *k).collect();
                if !options.skip_bad_pairs || positions.len() >= kept.len() {
                    return Err(error);
                }
                let reason = error.to_string();
                for (k, own) in bad {
                    let index = kept[k];
                    skipped.push(SkippedPair {
                        index,
                        reason: without_pair(index, &own.unwrap_or_else(|| reason.clone())),
                    });
                }
                remove_positions(&mut kept, &positions);
            }
            Err(PairsFailure::Duplicates(copies)) => {
                let described: Vec<String> = copies
                    .iter()
                    .take(10)
                    .map(|&(copy, original)| {
                        format!("pair {} = pair {}", kept[copy], kept[original])
                    })
                    .collect();
                warnings.push(Warning::new(
                    WarningCode::DuplicateViews,
                    format!(
                        "{} {} an earlier pair (the board did not move, or files are listed twice) and {} left out: {}{}",
                        copies.len(),
                        if copies.len() > 1 { "pairs repeat" } else { "pair repeats" },
                        if copies.len() > 1 { "were" } else { "was" },
                        described.join(", "),
                        if copies.len() > 10 { ", ..." } else { "" }
                    ),
                ));
                let positions: Vec<usize> = copies.iter().map(|c| c.0).collect();
                remove_positions(&mut kept, &positions);
            }
        }
    }
}

/// `message` without its leading `pair {index}, ` or `pair {index}: `: the reason a skipped
/// pair's entry gives, which names the pair already.
fn without_pair(index: usize, message: &str) -> String {
    let pair = format!("pair {index}");
    message
        .strip_prefix(&pair)
        .and_then(|rest| rest.strip_prefix(", ").or_else(|| rest.strip_prefix(": ")))
        .unwrap_or(message)
        .to_string()
}

fn remove_positions(kept: &mut Vec<usize>, positions: &[usize]) {
    let mut k = 0;
    kept.retain(|_| {
        k += 1;
        !positions.contains(&(k - 1))
    });
}

/// Why [`calibrate_pairs`] stopped.
enum PairsFailure {
    /// A failure of the whole calibration.
    Error(StereoError),
    /// The pairs at these positions of `kept` are wrong (skippable), each with its own reason
    /// where the error does not describe it (`None`: the error's message).
    BadPairs(StereoError, Vec<(usize, Option<String>)>),
    /// Pairs (positions `(copy, original)`) repeating earlier ones: left out with a warning.
    Duplicates(Vec<(usize, usize)>),
}

impl From<StereoError> for PairsFailure {
    fn from(e: StereoError) -> Self {
        PairsFailure::Error(e)
    }
}

/// The pair-level reading of an engine error: a view that mostly misses the model makes its
/// pair bad (the observation index divided by the observations per pair is its position), and so
/// do the other views of its round that [`CalibrationError::views_to_skip`] leaves out with it.
fn engine_failure(
    error: CalibrationError,
    observations_per_pair: usize,
    num_pairs: usize,
    wrap: impl Fn(CalibrationError) -> StereoError,
) -> PairsFailure {
    let views = error.views_to_skip(num_pairs * observations_per_pair);
    match error {
        CalibrationError::MostlyOutliers {
            observation,
            ref also,
            ..
        } => {
            let mut bad = vec![(observation / observations_per_pair, None)];
            for view in also.iter().filter(|v| views.contains(&v.observation)) {
                let k = view.observation / observations_per_pair;
                if bad.iter().all(|(b, _)| *b != k) {
                    let own = wrap(CalibrationError::MostlyOutliers {
                        observation: view.observation,
                        location: view.location.clone(),
                        rejected: view.rejected,
                        points: view.points,
                        also: Vec::new(),
                    });
                    bad.push((k, Some(own.to_string())));
                }
            }
            PairsFailure::BadPairs(wrap(error), bad)
        }
        other => PairsFailure::Error(wrap(other)),
    }
}

/// Largest angle (degrees) between a pair's rig rotation and the others' before the pair is
/// called mismatched. Correct pairs agree within the single-camera pose errors: a fraction of a
/// degree on good captures, up to 11.5 degrees over the stereo convergence population (weak
/// tilts, 3 views, 1 px noise); reversed or rotated corner orders disagree by 90 to 180.
const MAX_RIG_DISAGREEMENT_DEG: f64 = 30.0;

/// A baseline shorter than this fraction of the median board distance gets a warning.
const SHORT_BASELINE: f64 = 0.01;

/// A bootstrap refit (`crate::bootstrap`): the stereo calibration of the pairs `kept` of
/// `observations` (a pair listed `m` times weighs `m`) as [`calibrate_stereo`] calibrates its
/// pairs, without the pair checks (repeated pairs are meant), the covariance and the cameras'
/// diagnostics.
pub(crate) fn refit_pairs(
    observations: &StereoObservations,
    kept: &[usize],
    options: &StereoOptions,
) -> Result<StereoCalibration, StereoError> {
    let sizes = observations.sizes()?;
    calibrate_pairs(observations, kept, sizes, options, true).map_err(|failure| match failure {
        PairsFailure::Error(e) | PairsFailure::BadPairs(e, _) => e,
        PairsFailure::Duplicates(_) => StereoError::Bootstrap("repeated pairs".into()),
    })
}

/// The stereo calibration of the pairs `kept`; a bootstrap refit (`refit`) skips the pair
/// checks, the covariance and the cameras' diagnostics.
fn calibrate_pairs(
    observations: &StereoObservations,
    kept: &[usize],
    (left_size, right_size): (calib_core::ImageSize, calib_core::ImageSize),
    options: &StereoOptions,
    refit: bool,
) -> Result<StereoCalibration, PairsFailure> {
    let prepare = |side: Side, camera_options: &CalibrationOptions, size| {
        let t = Instant::now();
        let mut camera_options = camera_options.clone();
        camera_options.skip_bad_views = false;
        camera_options.drop_duplicate_views = false;
        let views: Vec<(usize, &View)> = kept
            .iter()
            .map(|&i| (i, observations.pairs[i].view(side)))
            .collect();
        let prepared = prepare_camera(&views, Some(size), &camera_options).map_err(|source| {
            PairsFailure::Error(StereoError::Camera {
                camera: side,
                source,
            })
        })?;
        Ok::<_, PairsFailure>((prepared, t.elapsed()))
    };
    let (left_prepared, left_prepare_time) = prepare(Side::Left, &options.left, left_size)?;
    let (right_prepared, right_prepare_time) = prepare(Side::Right, &options.right, right_size)?;

    // Pair-level checks on the homographies: a pair whose two views are the same image, pairs
    // repeating earlier ones.
    let identical: Vec<usize> = (0..kept.len())
        .filter(|_| !refit)
        .filter(|&k| {
            let pair = &observations.pairs[kept[k]];
            same_view(
                &pair.left,
                &left_prepared.homographies[k],
                &pair.right,
                &right_prepared.homographies[k],
            )
        })
        .collect();
    if !identical.is_empty() {
        let pairs = identical.iter().map(|&k| kept[k]).collect();
        return Err(PairsFailure::BadPairs(
            StereoError::IdenticalViews { pairs },
            identical.into_iter().map(|k| (k, None)).collect(),
        ));
    }
    let duplicates = if refit {
        Vec::new()
    } else {
        let side_views = |side| -> Vec<&View> {
            kept.iter()
                .map(|&i| observations.pairs[i].view(side))
                .collect()
        };
        let left = duplicate_views(&side_views(Side::Left), &left_prepared.homographies);
        let right = duplicate_views(&side_views(Side::Right), &right_prepared.homographies);
        left.into_iter()
            .filter(|d| right.contains(d))
            .collect::<Vec<_>>()
    };
    if !duplicates.is_empty() {
        return Err(PairsFailure::Duplicates(duplicates));
    }

    // Single-camera calibrations on the kept pairs: the start of the joint optimization.
    let single = |side: Side, camera_options: &CalibrationOptions, prepared: PreparedCamera| {
        let t = Instant::now();
        let start_method = prepared.start_method;
        let mut solve = camera_options.solve_options();
        solve.rotation = options.rotation;
        solve.outliers = options.outliers;
        solve.solver.num_threads = options.solver.num_threads;
        solve.camera_warnings = !refit;
        let (spec, solution) = prepared
            .solve_for_start(&side.to_string(), &solve)
            .map_err(|e| {
                engine_failure(e, 1, kept.len(), |source| StereoError::Camera {
                    camera: side,
                    source,
                })
            })?;
        Ok::<_, PairsFailure>((spec, start_method, solution, t.elapsed()))
    };
    let (left_spec, left_method, left_single, left_time) =
        single(Side::Left, &options.left, left_prepared)?;
    let (right_spec, right_method, right_single, right_time) =
        single(Side::Right, &options.right, right_prepared)?;

    // Every pair must see the same rig: a pair whose right corners are numbered differently
    // from its left ones, or whose views are from different moments, disagrees.
    let mut disagreements = rig_rotation_disagreements(&left_single.frames, &right_single.frames);
    let mut mismatched: Vec<usize> = (0..disagreements.len())
        .filter(|&k| disagreements[k].to_degrees() > MAX_RIG_DISAGREEMENT_DEG)
        .collect();
    // Two pairs that disagree: the medoid is either one, so the wrong pair cannot be told (the
    // first would stand as the reference, at 0 degrees, and the second be blamed): name both,
    // each with the angle between them.
    if kept.len() == 2 && !mismatched.is_empty() {
        mismatched = vec![0, 1];
        let between = disagreements[0].max(disagreements[1]);
        disagreements = vec![between; 2];
    }
    if !mismatched.is_empty() && !refit {
        let pairs = mismatched
            .iter()
            .map(|&k| (kept[k], disagreements[k].to_degrees()))
            .collect();
        let own = |&(_, angle): &(usize, f64)| {
            format!(
                "its rotation from the left to the right camera differs from the other pairs' by {angle:.0} degrees (more than 30): are the right view's corners in the same order as the left's (not reversed or rotated), and are both views from the same moment?"
            )
        };
        let reasons = mismatched
            .iter()
            .zip(&pairs)
            .map(|(&k, p)| (k, Some(own(p))))
            .collect();
        return Err(PairsFailure::BadPairs(
            StereoError::MismatchedPairs { pairs },
            reasons,
        ));
    }

    // One pair cannot be checked against another: a right view whose corners are numbered the
    // other way round turns the rig 180 degrees without a trace.
    let mut unchecked = Vec::new();
    if let [only] = kept {
        unchecked.push(Warning::new(
            WarningCode::PoorlyDetermined,
            format!(
                "the rig rests on one pair (pair {only}): it cannot be checked against another pair (a right view whose corners are numbered the other way round from the left's would turn it 180 degrees without a trace) and both principal points are held at the image centres (or the guesses); add pairs with the board in other poses"
            ),
        ));
    }

    let rig0 = match options.rig_guess {
        Some(rig) => rig,
        None => initial_rig(options.rig_init, &left_single.frames, &right_single.frames)
            .ok_or_else(|| {
                StereoError::RigInitialization("no rotation from the per-pair poses".into())
            })?,
    };
    let joint_start = Instant::now();
    let mut problem = joint_problem(
        observations,
        kept,
        options,
        [left_spec, right_spec],
        [&left_single.cameras[0], &right_single.cameras[0]],
        &left_single.frames,
        rig0,
    );
    // Points the single-camera stages rejected start out rejected (and may come back).
    for (k, o) in problem.observations.iter_mut().enumerate() {
        let single = if k % 2 == 0 {
            &left_single
        } else {
            &right_single
        };
        let rejected = &single.rejected[k / 2];
        if !rejected.is_empty() {
            let mut suspected = vec![false; o.object.len()];
            for &i in rejected {
                suspected[i] = true;
            }
            o.suspected = Some(suspected);
        }
    }
    // On weak captures (boards nearly facing the cameras, few pairs) the single-camera poses
    // are loose, and the rig averaged from them can put board points behind the right camera
    // or beyond its lens model's range: then start from the candidate rig (the other method,
    // or one pair's own rig) with the lowest start error that every point can be evaluated at.
    if options.rig_guess.is_none() && start_cost(&problem).is_none() {
        let candidates = candidate_rigs(&left_single.frames, &right_single.frames);
        if let Some(best) = candidates
            .into_iter()
            .filter_map(|rig| {
                problem.rig[1] = rig;
                start_cost(&problem).map(|c| (c, rig))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
        {
            problem.rig[1] = best.1;
        } else {
            problem.rig[1] = rig0;
        }
    }
    let rig0 = problem.rig[1];
    let mut solve = SolveOptions::default();
    solve.rotation = options.rotation;
    solve.solver = options.solver.clone();
    // The joint stage starts at each camera's own minimum: a warm start.
    calib_core::single::joint_stage_solver(
        problem.cameras.iter().map(|c| c.model()),
        &mut solve.solver,
    );
    solve.loss = options.loss;
    solve.outliers = options.outliers;
    solve.compute_uncertainty = !refit;
    solve.camera_warnings = !refit;
    let solution = calib_core::solve(&problem, &solve)
        .map_err(|e| engine_failure(e, 2, kept.len(), joint_error))?;
    let joint_done = Instant::now();
    let mut result = assemble(
        observations,
        kept,
        &problem,
        solution,
        rig0,
        [
            left_prepare_time + left_time,
            right_prepare_time + right_time,
            joint_done - joint_start,
        ],
    )?;
    result.initial_methods = [left_method, right_method];
    result.warnings.append(&mut unchecked);
    // The distance to the board itself (its points' centroid), not to its origin, which may lie
    // anywhere in the board's plane.
    let centre = calib_core::problem::BoardNormalization::measure(
        problem.observations.iter().flat_map(|o| &o.object),
    )
    .map_or_else(Vector3::zeros, |n| n.centre);
    let mut distances: Vec<f64> = result
        .pairs
        .iter()
        .map(|p| (p.left_pose.rotation * centre + p.left_pose.translation).norm())
        .collect();
    distances.sort_by(f64::total_cmp);
    let distance = distances[distances.len() / 2];
    if result.baseline < SHORT_BASELINE * distance {
        result.warnings.push(Warning::new(
            WarningCode::ShortBaseline,
            format!(
                "the baseline |T| = {:.4} is {:.2}% of the median board distance {distance:.4}: depth from this rig is unreliable and F is ill-conditioned; are both files from the same camera?",
                result.baseline,
                100.0 * result.baseline / distance
            ),
        ));
    }
    Ok(result)
}

/// Maps an engine error of the joint stage to the stereo error (its messages already name the
/// cameras and pairs).
fn joint_error(error: CalibrationError) -> StereoError {
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
            for (camera, view, camera_options) in [
                (Side::Left, &pair.left, &options.left),
                (Side::Right, &pair.right, &options.right),
            ] {
                let object: Vec<Point2<f64>> = view
                    .object_points
                    .iter()
                    .map(|p| Point2::new(p.x, p.y))
                    .collect();
                if let Err(source) = homography::estimate_robust(
                    &object,
                    &view.image_points,
                    &camera_options.homography,
                    &camera_options.robust_homography,
                ) {
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
                reason: without_pair(index, &e.to_string()),
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

fn assemble(
    observations: &StereoObservations,
    kept: &[usize],
    problem: &JointProblem,
    solution: JointSolution,
    rig0: Pose,
    times: [std::time::Duration; 3],
) -> Result<StereoCalibration, StereoError> {
    let estimate = |c: usize, name: &str| {
        let std = &solution.camera_std[c];
        let mut sums = calib_core::ObservationErrors::default();
        for (o, e) in solution.errors.iter().enumerate() {
            if problem.observations[o].camera == c {
                sums.add(e);
            }
        }
        let spec = &problem.cameras[c];
        let names = camera_param_names(spec.model());
        CameraEstimate {
            name: name.into(),
            camera: solution.cameras[c].clone(),
            image_size: spec.image_size,
            intrinsics_std: [std[0], std[1], std[2], std[3]],
            distortion_std: std[4..].to_vec(),
            // With the focal length shared (`focal_from`), fx and fy are held in this camera's
            // block but estimated in the other's: not fixed.
            fixed_parameters: spec
                .fixed
                .iter()
                .filter(|&&i| !(spec.focal_from.is_some() && i < 2))
                .map(|&i| names[i].to_string())
                .collect(),
            rms: sums.rms(),
            num_points: sums.used,
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
                rms_left: solution.errors[2 * k].rms(),
                rms_right: solution.errors[2 * k + 1].rms(),
                num_points: solution.errors[2 * k].all,
                rejected_left: solution.rejected[2 * k].clone(),
                rejected_right: solution.rejected[2 * k + 1].clone(),
            }
        })
        .collect();
    let mut total = calib_core::ObservationErrors::default();
    for e in &solution.errors {
        total.add(e);
    }
    let joint = solution.optimization_time;
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
        rms: total.rms(),
        rms_all_points: total.rms_all(),
        num_rejected: solution.num_rejected(),
        pairs,
        skipped_pairs: Vec::new(),
        residual_variance: solution.residual_variance,
        initial_rig: rig0,
        initial_methods: [StartMethod::Given; 2],
        initial_rms: (2.0 * solution.initial_cost / total.used.max(1) as f64).sqrt(),
        warnings: solution.warnings,
        solver: solution.report,
        elapsed: std::time::Duration::ZERO,
        stage_times: [times[0], times[1], joint, times[2].saturating_sub(joint)],
        bootstrap: None,
    })
}
