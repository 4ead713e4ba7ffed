//! The rig pipeline (`docs/calib-rig.md`): each camera alone, the camera graph and its spanning
//! tree, transforms averaged over shared frames and chained along the tree, then one joint
//! Levenberg-Marquardt in the engine (`calib_core`), the same one stereo uses.

use crate::error::RigError;
use crate::graph::{SpanningTree, shared_frames, spanning_tree};
use crate::observations::{RigFrame, RigObservations};
use crate::options::RigOptions;
use crate::result::{FrameResult, FrameView, RigCalibration, RigCamera, params_of};
use calib_core::result::CameraEstimate;
use calib_core::rig::{candidate_rigs, least_squares_rig, rig_rotation_disagreements};
use calib_core::single::camera_param_names;
use calib_core::warnings::{Warning, WarningCode};
use calib_core::{
    CalibrationError, CameraSpec, JointProblem, JointSolution, ObservationErrors, ObservationSpec,
    SolveOptions, View, prepare_camera,
};
use camera_model::{AnyCamera, AxisAngle, CameraModel, Pose, RotationParameterization};
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// Largest angle (degrees) between one shared frame's transform and the others' for the frame
/// to count in the start transform (stereo's `MAX_RIG_DISAGREEMENT_DEG`: correct frames agree
/// within the per-camera pose errors, up to about 11 degrees on weak captures).
const MAX_TRANSFORM_DISAGREEMENT_DEG: f64 = 30.0;

/// One camera after its own calibration.
struct CameraStart {
    spec: CameraSpec,
    /// Board-to-camera pose per frame the camera saw.
    poses: BTreeMap<usize, Pose>,
    /// Points rejected by its own calibration, per frame.
    rejected: BTreeMap<usize, Vec<usize>>,
    method: String,
    /// Views (frame indices) its own checks left out with `skip_bad_views`.
    skipped: Vec<calib_core::SkippedView>,
}

/// Checks the file: cameras and frames present, observations naming existing cameras at most once
/// per frame, image sizes positive.
fn check(observations: &RigObservations, options: &RigOptions) -> Result<(), RigError> {
    let n = observations.cameras.len();
    if n == 0 {
        return Err(RigError::Empty("cameras"));
    }
    if observations.frames.is_empty() {
        return Err(RigError::Empty("frames"));
    }
    if options.reference >= n {
        return Err(RigError::InvalidOption(format!(
            "reference camera {} of {n}",
            options.reference
        )));
    }
    // Names are how results, warnings, exports and --model NAME=... refer to cameras.
    for (c, camera) in observations.cameras.iter().enumerate() {
        if let Some(first) = observations.cameras[..c]
            .iter()
            .position(|other| other.name == camera.name)
        {
            return Err(RigError::InvalidOption(format!(
                "cameras {first} and {c} are both named '{}': give every camera its own name",
                camera.name
            )));
        }
    }
    // A name held "in every camera whose model has it" that no camera has is a typo, not a
    // request to hold nothing.
    for name in &options.hold_fixed {
        if !(0..n).any(|c| {
            model_of(observations, options, c)
                .distortion_names()
                .contains(&name.as_str())
        }) {
            return Err(RigError::InvalidOption(format!(
                "hold_fixed: no camera's lens model has a coefficient named '{name}'"
            )));
        }
    }
    for c in &observations.cameras {
        if c.image_size.width == 0 || c.image_size.height == 0 {
            return Err(RigError::InvalidOption(format!(
                "camera '{}': image size {}x{}",
                c.name, c.image_size.width, c.image_size.height
            )));
        }
    }
    for (f, frame) in observations.frames.iter().enumerate() {
        let mut seen = vec![false; n];
        for o in &frame.observations {
            if o.camera >= n {
                return Err(RigError::BadFrame {
                    frame: f,
                    reason: format!("camera {} of {n}", o.camera),
                });
            }
            let (points, pixels) = (o.view.object_points.len(), o.view.image_points.len());
            if points != pixels {
                return Err(RigError::BadFrame {
                    frame: f,
                    reason: format!(
                        "camera '{}' has {pixels} image points for {points} board points",
                        observations.cameras[o.camera].name
                    ),
                });
            }
            if std::mem::replace(&mut seen[o.camera], true) {
                return Err(RigError::BadFrame {
                    frame: f,
                    reason: format!(
                        "camera '{}' observed twice",
                        observations.cameras[o.camera].name
                    ),
                });
            }
        }
        // Two cameras with the same corners saw one image: calibrated, they would stand at the
        // same place (a zero baseline) without any complaint.
        for (k, a) in frame.observations.iter().enumerate() {
            if let Some(b) = frame.observations[..k]
                .iter()
                .find(|b| same_capture(&a.view, &b.view))
            {
                return Err(RigError::BadFrame {
                    frame: f,
                    reason: format!(
                        "cameras '{}' and '{}' have the same corners (the same image given for both cameras?)",
                        observations.cameras[b.camera].name, observations.cameras[a.camera].name
                    ),
                });
            }
        }
    }
    Ok(())
}

/// True if two views are one capture: the same board points, every pixel within
/// [`SAME_CAPTURE_PX`] of the other's.
fn same_capture(a: &View, b: &View) -> bool {
    !a.object_points.is_empty()
        && a.object_points == b.object_points
        && a.image_points.len() == b.image_points.len()
        && a.image_points
            .iter()
            .zip(&b.image_points)
            .all(|(p, q)| (p - q).norm() <= SAME_CAPTURE_PX)
}

/// The lens model of camera `c`.
fn model_of(observations: &RigObservations, options: &RigOptions, c: usize) -> CameraModel {
    options
        .given
        .get(c)
        .and_then(|g| g.as_ref().map(|g| g.model))
        .or_else(|| options.models.get(c).copied().flatten())
        .or(observations.cameras[c].model)
        .unwrap_or(options.camera.model)
}

/// Camera `c` calibrated alone on its frames (or its given intrinsics held), for the start.
fn start_camera(
    observations: &RigObservations,
    options: &RigOptions,
    c: usize,
) -> Result<CameraStart, RigError> {
    let input = &observations.cameras[c];
    let views: Vec<(usize, &View)> = observations
        .frames
        .iter()
        .enumerate()
        .filter_map(|(f, frame)| {
            frame
                .observations
                .iter()
                .find(|o| o.camera == c)
                .map(|o| (f, &o.view))
        })
        .collect();
    let given = options.given.get(c).and_then(Option::as_ref);
    if given.is_none() && views.len() < options.min_views {
        return Err(RigError::TooFewViews {
            camera: input.name.clone(),
            views: views.len(),
            needed: options.min_views,
        });
    }
    // Held coefficients carry over to this camera's model by name; the guess only to cameras
    // of the options' own model.
    let mut camera_options = options.camera.for_model(model_of(observations, options, c));
    let own: Vec<&str> = options
        .hold_fixed
        .iter()
        .map(String::as_str)
        .filter(|n| camera_options.model.distortion_names().contains(n))
        .chain(
            options
                .hold_fixed_by_camera
                .get(c)
                .into_iter()
                .flatten()
                .map(String::as_str),
        )
        .collect();
    camera_options
        .fix_distortion_by_name(&own)
        .map_err(|e| RigError::Camera {
            camera: input.name.clone(),
            source: CalibrationError::InvalidOption(e),
        })?;
    // A view that fails the camera's own checks (points that fit no homography, pixels outside
    // the image) is left out of the rig with skip_bad_views, as calib single leaves it out.
    camera_options.skip_bad_views = options.camera.skip_bad_views;
    camera_options.drop_duplicate_views = false;
    if let Some(g) = given {
        camera_options.intrinsic_guess = Some(g.intrinsics);
        camera_options.distortion_guess = Some(g.distortion.clone());
        camera_options.fix_focal_length = true;
        camera_options.fix_principal_point = true;
        camera_options.fixed_distortion = (0..g.model.num_distortion_params()).collect();
    }
    let camera_error = |source| RigError::Camera {
        camera: input.name.clone(),
        source,
    };
    let mut solve = camera_options.solve_options();
    solve.rotation = options.rotation;
    solve.outliers = options.outliers;
    solve.solver.num_threads = options.solver.num_threads;
    // Views whose points mostly miss the camera's own model (a view of another lens, pixels
    // scrambled in part) are left out with skip_bad_views and the camera solved again, as calib
    // single does; they then leave the rig with the views its checks left out.
    let mut dropped: Vec<calib_core::SkippedView> = Vec::new();
    let (method, frames, skipped, mut spec, solution) = loop {
        let kept: Vec<(usize, &View)> = views
            .iter()
            .filter(|(f, _)| !dropped.iter().any(|d| d.index == *f))
            .copied()
            .collect();
        let prepared =
            prepare_camera(&kept, Some(input.image_size), &camera_options).map_err(camera_error)?;
        let method = if given.is_some() {
            "given".to_string()
        } else {
            prepared.start_method.name().to_string()
        };
        let frames: Vec<usize> = prepared.views.iter().map(|(f, _)| *f).collect();
        let names = prepared.views.clone();
        let mut skipped = prepared.skipped.clone();
        match prepared.solve_for_start(&input.name, &solve) {
            Ok((spec, solution)) => {
                skipped.extend(dropped);
                skipped.sort_by_key(|s| s.index);
                break (method, frames, skipped, spec, solution);
            }
            Err(e @ CalibrationError::MostlyOutliers { .. }) if camera_options.skip_bad_views => {
                dropped.extend(e.skipped_views(&names));
            }
            Err(CalibrationError::MostlyOutliers {
                observation,
                rejected,
                points,
                mut also,
                ..
            }) => {
                // Named in the rig's terms (frame and camera), not the camera stage's views.
                let at = |o: usize| format!("frame {}, camera '{}'", names[o].0, input.name);
                for v in &mut also {
                    v.location = at(v.observation);
                }
                return Err(camera_error(CalibrationError::MostlyOutliers {
                    observation,
                    location: at(observation),
                    rejected,
                    points,
                    also,
                }));
            }
            Err(e) => return Err(camera_error(e)),
        }
    };
    if given.is_some() {
        spec.fixed = (0..spec.model().num_params()).collect();
        spec.aspect_ratio = None;
    }
    Ok(CameraStart {
        spec,
        poses: frames
            .iter()
            .copied()
            .zip(solution.frames.clone())
            .collect(),
        rejected: frames
            .iter()
            .copied()
            .zip(solution.rejected.iter().cloned())
            .collect(),
        method,
        skipped,
    })
}

/// The camera graph's maximum spanning tree from the reference, or the connected groups.
fn camera_tree(
    observations: &RigObservations,
    options: &RigOptions,
) -> Result<SpanningTree, RigError> {
    let n = observations.cameras.len();
    let seen: Vec<Vec<usize>> = observations
        .frames
        .iter()
        .map(|f| f.observations.iter().map(|o| o.camera).collect())
        .collect();
    let shared = shared_frames(n, &seen);
    spanning_tree(&shared, options.reference).map_err(|groups| RigError::Disconnected {
        groups: groups
            .into_iter()
            .map(|g| {
                g.into_iter()
                    .map(|c| observations.cameras[c].name.clone())
                    .collect()
            })
            .collect(),
    })
}

/// Largest pixel difference (px) between two views of one camera that are the same capture.
const SAME_CAPTURE_PX: f64 = 0.5;

/// Frames that repeat an earlier one, as `(copy, original)`: the same cameras, each with the
/// same board points and every pixel within [`SAME_CAPTURE_PX`] of the earlier frame's.
fn duplicate_frames(observations: &RigObservations) -> Vec<(usize, usize)> {
    let same = |a: &RigFrame, b: &RigFrame| {
        a.observations.len() == b.observations.len()
            && !a.observations.is_empty()
            && a.observations.iter().all(|x| {
                b.observations
                    .iter()
                    .any(|y| x.camera == y.camera && same_capture(&x.view, &y.view))
            })
    };
    let frames = &observations.frames;
    let mut out = Vec::new();
    for j in 0..frames.len() {
        if let Some(i) = (0..j)
            .filter(|i| !out.iter().any(|&(copy, _)| copy == *i))
            .find(|&i| same(&frames[i], &frames[j]))
        {
            out.push((j, i));
        }
    }
    out
}

/// The board poses of the frames cameras `a` and `b` both saw, in `a`'s and in `b`'s frame.
fn shared_frame_poses(starts: &[CameraStart], a: usize, b: usize) -> (Vec<Pose>, Vec<Pose>) {
    starts[a]
        .poses
        .iter()
        .filter_map(|(f, pose)| starts[b].poses.get(f).map(|other| (*pose, *other)))
        .unzip()
}

/// Each camera's start transform from the reference: averaged over the frames it shares with
/// its parent in the tree ([`least_squares_rig`], the stereo start) and chained from the root.
fn initial_transforms(
    observations: &RigObservations,
    starts: &[CameraStart],
    tree: &SpanningTree,
) -> Result<Vec<Pose>, RigError> {
    let n = starts.len();
    let mut transforms = vec![Pose::identity(); n];
    for &c in &tree.order[1..] {
        let p = tree.parent[c].expect("every camera but the reference has a parent");
        let (mut from, mut to) = shared_frame_poses(starts, p, c);
        // Robust averaging: frames whose own transform disagrees with the others' by more
        // than stereo's mismatch limit (corners numbered differently in the two views, views
        // from different moments) are left out of the start; the joint stage then treats their
        // points as outliers.
        let disagreements = rig_rotation_disagreements(&from, &to);
        let agree: Vec<usize> = (0..from.len())
            .filter(|&k| disagreements[k].to_degrees() <= MAX_TRANSFORM_DISAGREEMENT_DEG)
            .collect();
        if !agree.is_empty() && agree.len() < from.len() {
            from = agree.iter().map(|&k| from[k]).collect();
            to = agree.iter().map(|&k| to[k]).collect();
        }
        let edge = least_squares_rig(&from, &to)
            .ok_or_else(|| RigError::Initialization(observations.cameras[c].name.clone()))?;
        transforms[c] = edge.compose(&transforms[p]);
    }
    Ok(transforms)
}

/// Board pose per frame in the reference camera's frame (`None` for frames no camera's start
/// placed), from the camera nearest the reference (in tree edges) that saw it.
fn frame_starts(
    observations: &RigObservations,
    starts: &[CameraStart],
    transforms: &[Pose],
    tree: &SpanningTree,
) -> Vec<Option<Pose>> {
    (0..observations.frames.len())
        .map(|f| {
            let via = observations.frames[f]
                .observations
                .iter()
                .filter(|o| starts[o.camera].poses.contains_key(&f))
                .min_by_key(|o| (tree.depth[o.camera], o.camera))?
                .camera;
            Some(transforms[via].inverse().compose(&starts[via].poses[&f]))
        })
        .collect()
}

/// Sum of squared start errors (px^2) of camera `c`'s observations with transform `transform`,
/// or `None` if a point cannot be projected (behind the camera, beyond its lens' range).
fn camera_start_cost(
    observations: &RigObservations,
    camera: &AnyCamera,
    c: usize,
    transform: &Pose,
    frames: &[Option<Pose>],
) -> Option<f64> {
    let mut cost = 0.0;
    for (frame, pose) in observations.frames.iter().zip(frames) {
        let (Some(o), Some(pose)) = (frame.observations.iter().find(|o| o.camera == c), pose)
        else {
            continue;
        };
        let camera_pose = transform.compose(pose);
        for (x, p) in o.view.object_points.iter().zip(&o.view.image_points) {
            let q = camera
                .project_camera_point(&camera_pose.transform_point(x))
                .ok()?;
            cost += (q - p.coords).norm_squared();
        }
    }
    cost.is_finite().then_some(cost)
}

/// On weak captures (boards nearly facing the cameras, few shared frames) the per-camera poses
/// are loose and an averaged transform can put board points behind a camera or beyond its lens
/// model's range, where the joint optimization cannot start. As stereo does, such a camera's
/// edge is replaced by the candidate (the other averaging method, or one shared frame's own
/// transform) with the lowest start error that every point can be evaluated at.
fn repair_transforms(
    observations: &RigObservations,
    starts: &[CameraStart],
    transforms: &mut [Pose],
    tree: &SpanningTree,
) {
    for &c in &tree.order[1..] {
        let frames = frame_starts(observations, starts, transforms, tree);
        let camera = &starts[c].spec.initial;
        if camera_start_cost(observations, camera, c, &transforms[c], &frames).is_some() {
            continue;
        }
        let p = tree.parent[c].expect("every camera but the reference has a parent");
        let (from, to) = shared_frame_poses(starts, p, c);
        let best = candidate_rigs(&from, &to)
            .into_iter()
            .filter_map(|edge| {
                let transform = edge.compose(&transforms[p]);
                camera_start_cost(observations, camera, c, &transform, &frames)
                    .map(|cost| (cost, transform))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0));
        if let Some((_, transform)) = best {
            transforms[c] = transform;
        }
    }
}

/// The joint problem: every frame with a start pose, every observation in it (points a camera's
/// own calibration rejected start out suspected). Returns it with the input index of each of its
/// frames.
fn build_problem(
    observations: &RigObservations,
    cameras: Vec<CameraSpec>,
    transforms: Vec<Pose>,
    frame_poses: &[Option<Pose>],
    reference: usize,
    rejected: &[&BTreeMap<usize, Vec<usize>>],
) -> (JointProblem, Vec<usize>) {
    let n = cameras.len();
    let mut frame_index = Vec::new();
    let mut frames = Vec::new();
    let mut specs = Vec::new();
    for (f, (frame, pose)) in observations.frames.iter().zip(frame_poses).enumerate() {
        let Some(pose) = pose else {
            continue;
        };
        let k = frames.len();
        frames.push(*pose);
        frame_index.push(f);
        for o in &frame.observations {
            let mut spec = ObservationSpec::new(
                o.camera,
                k,
                format!(
                    "frame {f}, camera '{}' ({})",
                    observations.cameras[o.camera].name, o.view.name
                ),
                o.view.object_points.clone(),
                o.view.image_points.iter().map(|p| p.coords).collect(),
            );
            let own = rejected.get(o.camera).and_then(|r| r.get(&f));
            if let Some(r) = own.filter(|r| !r.is_empty()) {
                let mut suspected = vec![false; o.view.object_points.len()];
                for &i in r {
                    suspected[i] = true;
                }
                spec.suspected = Some(suspected);
            }
            specs.push(spec);
        }
    }
    let problem = JointProblem {
        cameras,
        reference,
        rig: transforms,
        rig_fixed: (0..n).map(|c| c == reference).collect(),
        frame_names: frame_index.iter().map(|f| format!("frame {f}")).collect(),
        frames,
        observations: specs,
    };
    (problem, frame_index)
}

/// The joint problem of a rig data set at given parameters (cameras, transforms from camera
/// `reference` and board-to-reference poses per input frame), every camera parameter free: to
/// evaluate the cost at someone else's solution, or to start from the truth in tests. Camera
/// names come from the observations.
pub fn rig_problem(
    observations: &RigObservations,
    cameras: &[AnyCamera],
    transforms: &[Pose],
    frame_poses: &[Pose],
    reference: usize,
) -> JointProblem {
    let specs = cameras
        .iter()
        .zip(&observations.cameras)
        .map(|(camera, input)| CameraSpec::new(&input.name, input.image_size, camera.clone()))
        .collect();
    let poses: Vec<Option<Pose>> = frame_poses.iter().copied().map(Some).collect();
    build_problem(
        observations,
        specs,
        transforms.to_vec(),
        &poses,
        reference,
        &[],
    )
    .0
}

/// Largest distance between the board positions two views of one frame imply in the reference
/// camera (the start transforms applied to each camera's own board pose), as a fraction of the
/// board's distance from the cameras, for the views to count as one moment, where the joint
/// stage fails. Correct views agree within the per-camera depth errors: a few percent on good
/// captures, but up to 70% on weak ones (boards nearly facing the cameras), which is why a
/// displaced view is only named when the joint stage fails; a view from another moment (one camera's
/// images numbered one frame off) or with the board's points in the wrong unit or size (a view
/// of a board scaled by `s` is placed `s` times as far) lies beyond it, while turned by less than
/// [`MAX_TRANSFORM_DISAGREEMENT_DEG`] when the board moved little between the frames.
const MAX_POSITION_DISAGREEMENT: f64 = 0.1;

/// Views of one frame that contradict the rest of the rig: `cameras` disagree with the frame's
/// other views (with two views, both) by up to `angle_deg` in rotation and by up to `offset`
/// (board units, `fraction` of the board's distance) in position.
#[derive(Debug, Clone, PartialEq)]
struct Disagreement {
    frame: usize,
    cameras: Vec<usize>,
    angle_deg: f64,
    offset: f64,
    fraction: f64,
}

impl Disagreement {
    /// The finding in user terms: `frame 6: camera 'rot180' sees the board ... from where the
    /// rest of the rig puts it`.
    fn describe(&self, observations: &RigObservations) -> String {
        let names: Vec<String> = self
            .cameras
            .iter()
            .map(|&c| format!("'{}'", observations.cameras[c].name))
            .collect();
        let what = if self.angle_deg > MAX_TRANSFORM_DISAGREEMENT_DEG {
            format!("the board turned {:.1} degrees", self.angle_deg)
        } else {
            format!(
                "the board {:.1} board units ({:.0}% of its distance) away",
                self.offset,
                100.0 * self.fraction
            )
        };
        format!(
            "frame {}: camera{} {} {} {what} from where the rest of the rig puts it",
            self.frame,
            if self.cameras.len() > 1 { "s" } else { "" },
            names.join(" and "),
            if self.cameras.len() > 1 {
                "see"
            } else {
                "sees"
            },
        )
    }

    /// The warning for views left out (skip_bad_views).
    fn left_out(found: &[Disagreement], observations: &RigObservations) -> Warning {
        Warning::new(
            WarningCode::InconsistentView,
            format!(
                "views left out (corners numbered differently, views from different moments, or a board of another size): {}",
                found
                    .iter()
                    .map(|d| d.describe(observations))
                    .collect::<Vec<_>>()
                    .join("; ")
            ),
        )
    }

    /// `observations` without the views `found` names.
    fn without(found: &[Disagreement], observations: &RigObservations) -> RigObservations {
        let mut copy = observations.clone();
        for d in found {
            copy.frames[d.frame]
                .observations
                .retain(|o| !d.cameras.contains(&o.camera));
        }
        copy
    }
}

/// Views whose own board pose, carried to the reference camera by the start transforms,
/// disagrees with the frame's other views: turned more than [`MAX_TRANSFORM_DISAGREEMENT_DEG`]
/// (reversed corner numbering is a board turned half a turn), or placed more than
/// [`MAX_POSITION_DISAGREEMENT`] of its distance away (a view from another moment, a board of
/// the wrong size). Such a view is consistent on its own but not with the rig.
fn inconsistent_views(
    observations: &RigObservations,
    starts: &[CameraStart],
    transforms: &[Pose],
) -> Vec<Disagreement> {
    struct Implied {
        camera: usize,
        rotation: nalgebra::Matrix3<f64>,
        position: nalgebra::Vector3<f64>,
        distance: f64,
    }
    let mut found = Vec::new();
    for (f, frame) in observations.frames.iter().enumerate() {
        // One board point for every view (views may be partial): the mean of their points.
        let points: Vec<&nalgebra::Point3<f64>> = frame
            .observations
            .iter()
            .flat_map(|o| &o.view.object_points)
            .collect();
        if points.is_empty() {
            continue;
        }
        let centre = nalgebra::Point3::from(
            points
                .iter()
                .map(|p| p.coords)
                .sum::<nalgebra::Vector3<f64>>()
                / points.len() as f64,
        );
        let implied: Vec<Implied> = frame
            .observations
            .iter()
            .filter_map(|o| {
                let pose = starts[o.camera].poses.get(&f)?;
                let to_reference = transforms[o.camera].inverse();
                let in_camera = pose.transform_point(&centre);
                Some(Implied {
                    camera: o.camera,
                    rotation: to_reference.rotation * pose.rotation,
                    position: to_reference.rotation * in_camera + to_reference.translation,
                    distance: in_camera.norm(),
                })
            })
            .collect();
        if implied.len() < 2 {
            continue;
        }
        let angle = |a: &Implied, b: &Implied| {
            AxisAngle::from_matrix(&(a.rotation.transpose() * b.rotation))
                .norm()
                .to_degrees()
        };
        let offset = |a: &Implied, b: &Implied| (a.position - b.position).norm();
        let fraction = |a: &Implied, b: &Implied| {
            let distance = 0.5 * (a.distance + b.distance);
            if distance > 0.0 {
                offset(a, b) / distance
            } else {
                0.0
            }
        };
        // Disagreement in units of the limits: above 1 is inconsistent.
        let score = |a: &Implied, b: &Implied| {
            (angle(a, b) / MAX_TRANSFORM_DISAGREEMENT_DEG)
                .max(fraction(a, b) / MAX_POSITION_DISAGREEMENT)
        };
        // The view closest to all others; with two views, either.
        let medoid = (0..implied.len())
            .min_by(|&i, &j| {
                let si: f64 = implied.iter().map(|v| score(&implied[i], v)).sum();
                let sj: f64 = implied.iter().map(|v| score(&implied[j], v)).sum();
                si.total_cmp(&sj)
            })
            .expect("two views or more");
        let centre_view = &implied[medoid];
        let off: Vec<&Implied> = implied
            .iter()
            .filter(|v| score(centre_view, v) > 1.0)
            .collect();
        if off.is_empty() {
            continue;
        }
        let cameras = if implied.len() == 2 {
            implied.iter().map(|v| v.camera).collect()
        } else {
            off.iter().map(|v| v.camera).collect()
        };
        found.push(Disagreement {
            frame: f,
            cameras,
            angle_deg: off
                .iter()
                .map(|v| angle(centre_view, v))
                .fold(0.0, f64::max),
            offset: off
                .iter()
                .map(|v| offset(centre_view, v))
                .fold(0.0, f64::max),
            fraction: off
                .iter()
                .map(|v| fraction(centre_view, v))
                .fold(0.0, f64::max),
        });
    }
    found
}

/// Calibrates a rig: see the crate documentation and `docs/calib-rig.md`.
pub fn calibrate_rig(
    observations: &RigObservations,
    options: &RigOptions,
) -> Result<RigCalibration, RigError> {
    let start = Instant::now();
    check(observations, options)?;
    // Repeated frames (a file listed twice, the board not moved) would count their views twice
    // and shrink every sigma by sqrt(2): left out with a warning, as calib single does.
    let mut warnings = Vec::new();
    let deduplicated;
    let duplicates = if options.camera.drop_duplicate_views {
        duplicate_frames(observations)
    } else {
        Vec::new()
    };
    let observations = if duplicates.is_empty() {
        observations
    } else {
        warnings.push(calib_core::diagnostics::duplicates_warning(
            "frame",
            &duplicates,
        ));
        let mut copy = observations.clone();
        for (f, _) in &duplicates {
            copy.frames[*f].observations.clear();
        }
        deduplicated = copy;
        &deduplicated
    };
    let n = observations.cameras.len();
    // The graph first: a disconnected rig is refused before any camera is calibrated.
    let mut tree = camera_tree(observations, options)?;
    let starts: Vec<CameraStart> = (0..n)
        .map(|c| start_camera(observations, options, c))
        .collect::<Result<_, _>>()?;
    let per_camera = start.elapsed();
    // Views a camera's own checks left out (skip_bad_views) leave the rig too: in the joint
    // stage they would be views without a start, most of whose points miss.
    let skipped: Vec<(usize, usize, &str)> = starts
        .iter()
        .enumerate()
        .flat_map(|(c, s)| {
            s.skipped
                .iter()
                .map(move |v| (v.index, c, v.reason.as_str()))
        })
        .collect();
    let checked;
    let observations = if skipped.is_empty() {
        observations
    } else {
        let described: Vec<String> = skipped
            .iter()
            .map(|&(f, c, reason)| {
                format!(
                    "frame {f}, camera '{}': {reason}",
                    observations.cameras[c].name
                )
            })
            .collect();
        warnings.push(Warning::new(
            WarningCode::InconsistentView,
            format!(
                "views left out by their camera's own checks: {}",
                described.join("; ")
            ),
        ));
        let mut copy = observations.clone();
        for &(f, c, _) in &skipped {
            copy.frames[f].observations.retain(|o| o.camera != c);
        }
        checked = copy;
        // Without those views a camera may lose its ties to the rest.
        tree = camera_tree(&checked, options)?;
        &checked
    };
    let mut transforms = initial_transforms(observations, &starts, &tree)?;
    repair_transforms(observations, &starts, &mut transforms, &tree);

    // Views turned against the rig (corners numbered differently): refused, or left out with a
    // warning (skip_bad_views). Views that only place the board elsewhere wait for the joint
    // stage: on weak captures (boards nearly facing the cameras, few views) a camera's own
    // calibration places the board loosely in depth, and correct views lie up to 70% of their
    // distance off at the start (`docs/calib-rig.md`, step 5).
    let (turned, displaced): (Vec<Disagreement>, Vec<Disagreement>) =
        inconsistent_views(observations, &starts, &transforms)
            .into_iter()
            .partition(|d| d.angle_deg > MAX_TRANSFORM_DISAGREEMENT_DEG);
    let filtered;
    let observations = if turned.is_empty() {
        observations
    } else {
        if !options.camera.skip_bad_views {
            return Err(RigError::InconsistentViews(
                turned.iter().map(|d| d.describe(observations)).collect(),
            ));
        }
        warnings.push(Disagreement::left_out(&turned, observations));
        filtered = Disagreement::without(&turned, observations);
        &filtered
    };

    // A camera tied to the others by one frame only: its transform cannot be cross-checked.
    for (c, camera) in observations.cameras.iter().enumerate() {
        let shared: Vec<usize> = observations
            .frames
            .iter()
            .enumerate()
            .filter(|(_, f)| {
                f.observations.iter().any(|o| o.camera == c)
                    && f.observations.iter().any(|o| o.camera != c)
            })
            .map(|(f, _)| f)
            .collect();
        if let [frame] = shared[..] {
            warnings.push(Warning::new(
                WarningCode::PoorlyDetermined,
                format!(
                    "camera '{}' shares only frame {frame} with the other cameras: its place in the rig rests on that one view and cannot be checked against another (a board whose corners are numbered the other way round there would turn it 180 degrees without a trace); add frames it sees together with another camera",
                    camera.name
                ),
            ));
        }
    }

    let frames = frame_starts(observations, &starts, &transforms, &tree);
    let rejected: Vec<&BTreeMap<usize, Vec<usize>>> = starts.iter().map(|s| &s.rejected).collect();
    let (problem, frame_index) = build_problem(
        observations,
        starts.iter().map(|s| s.spec.clone()).collect(),
        transforms,
        &frames,
        options.reference,
        &rejected,
    );
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
    let joint_start = Instant::now();
    let mut solution = match calib_core::solve(&problem, &solve) {
        Ok(solution) => solution,
        // Views placing the board elsewhere than the rest of their frame (another moment, a
        // board of another size) where the joint stage fails: named, or left out and the rig
        // calibrated again. The engine's error would name whichever view its rounds reached
        // first, often a correct one of another camera.
        Err(_) if !displaced.is_empty() => {
            if !options.camera.skip_bad_views {
                return Err(RigError::InconsistentViews(
                    displaced.iter().map(|d| d.describe(observations)).collect(),
                ));
            }
            warnings.push(Disagreement::left_out(&displaced, observations));
            return calibrated_again(
                &Disagreement::without(&displaced, observations),
                options,
                warnings,
                start,
            );
        }
        // Views that mostly miss the rig's model, with skip_bad_views: their frames go (a view
        // that contradicts the others of its frame pulls the frame's pose, and then its
        // innocent neighbours miss: which of them is wrong the joint stage cannot tell) and the
        // rig is calibrated again without them, as calib stereo leaves out a pair.
        Err(e @ CalibrationError::MostlyOutliers { .. }) if options.camera.skip_bad_views => {
            let frames = frames_to_skip(&problem, &frame_index, &e);
            let mut copy = observations.clone();
            for &f in &frames {
                copy.frames[f].observations.clear();
            }
            let listed: Vec<String> = frames.iter().map(|f| format!("frame {f}")).collect();
            warnings.push(Warning::new(
                WarningCode::InconsistentView,
                format!(
                    "{} left out: {} views disagree with the rig's model ({e}); views of one frame that contradict each other (corners numbered a row off, a view from another moment) pull the frame's pose, so the whole frame goes",
                    listed.join(", "),
                    if frames.len() > 1 { "their" } else { "its" }
                ),
            ));
            return calibrated_again(&copy, options, warnings, start);
        }
        Err(e) => {
            return Err(frames_that_contradict(
                &problem,
                &frame_index,
                observations,
                e,
            ));
        }
    };
    warnings.append(&mut solution.warnings);
    solution.warnings = warnings;
    let joint = joint_start.elapsed();
    Ok(assemble(
        observations,
        options,
        &problem,
        solution,
        &starts,
        &frame_index,
        tree.parent,
        [per_camera, joint],
        start,
    ))
}

/// The rig calibrated again from `observations` (some views left out), with `warnings` (why
/// they went) first, then the new run's own; its time counted from `start`.
fn calibrated_again(
    observations: &RigObservations,
    options: &RigOptions,
    mut warnings: Vec<Warning>,
    start: Instant,
) -> Result<RigCalibration, RigError> {
    let mut result = calibrate_rig(observations, options)?;
    for w in std::mem::take(&mut result.warnings) {
        if !warnings.iter().any(|k| k.message == w.message) {
            warnings.push(w);
        }
    }
    result.warnings = warnings;
    result.elapsed = start.elapsed();
    Ok(result)
}

/// The input frames a rig that skips bad views leaves out after `error` (a
/// [`CalibrationError::MostlyOutliers`]): the frames where several views are past the limit
/// (views that contradict each other: the bad one pulled the frame's pose) when there are such
/// frames, else the frames of the views `views_to_skip` gives. A view that pulled its frame can
/// pull its camera too, so that a view of that camera in another frame is past the limit in the
/// same round; it is kept when the contradicting frame is known.
fn frames_to_skip(
    problem: &JointProblem,
    frame_index: &[usize],
    error: &CalibrationError,
) -> std::collections::BTreeSet<usize> {
    let contradicting: std::collections::BTreeSet<usize> =
        past_limit_by_frame(problem, frame_index, error)
            .into_iter()
            .filter(|(_, views)| views.len() >= 2)
            .map(|(f, _)| f)
            .collect();
    if !contradicting.is_empty() {
        return contradicting;
    }
    error
        .views_to_skip(problem.observations.len())
        .into_iter()
        .map(|o| frame_index[problem.observations[o].frame])
        .collect()
}

/// The views a [`CalibrationError::MostlyOutliers`] names (the first and the others of its
/// round), per input frame: `(camera, rejected points, points)`. Empty for other errors.
fn past_limit_by_frame(
    problem: &JointProblem,
    frame_index: &[usize],
    error: &CalibrationError,
) -> BTreeMap<usize, Vec<(usize, usize, usize)>> {
    let mut past: BTreeMap<usize, Vec<(usize, usize, usize)>> = BTreeMap::new();
    if let CalibrationError::MostlyOutliers {
        observation,
        rejected,
        points,
        also,
        ..
    } = error
    {
        for (o, rejected, points) in std::iter::once((*observation, *rejected, *points))
            .chain(also.iter().map(|v| (v.observation, v.rejected, v.points)))
        {
            let spec = &problem.observations[o];
            past.entry(frame_index[spec.frame])
                .or_default()
                .push((spec.camera, rejected, points));
        }
    }
    past
}

/// The rig's reading of a joint-stage error. Views past the outlier limit that share a frame
/// (every view of a frame where one of them, its corners numbered a row off,
/// pulled the frame's pose) are a frame whose views contradict each other, reported per frame as
/// [`RigError::InconsistentViews`]: the engine's error named the first of them in input order,
/// most likely a correct one.
fn frames_that_contradict(
    problem: &JointProblem,
    frame_index: &[usize],
    observations: &RigObservations,
    error: CalibrationError,
) -> RigError {
    let past = past_limit_by_frame(problem, frame_index, &error);
    if past.values().all(|views| views.len() < 2) {
        return RigError::Joint(error);
    }
    let name = |c: usize| format!("'{}'", observations.cameras[c].name);
    RigError::InconsistentViews(
        past.iter()
            .map(|(f, views)| {
                let listed: Vec<String> = views
                    .iter()
                    .map(|&(c, r, n)| format!("{} ({r} of {n} points)", name(c)))
                    .collect();
                if let [one] = &listed[..] {
                    format!("frame {f}: the view of camera {one} misses the rig's model")
                } else {
                    format!(
                        "frame {f}: the views of cameras {} miss the rig's model: one of them places the board differently from the others (corners numbered a row off?) and pulls the frame's pose",
                        listed.join(", ")
                    )
                }
            })
            .collect(),
    )
}

#[allow(clippy::too_many_arguments)]
fn assemble(
    observations: &RigObservations,
    options: &RigOptions,
    problem: &JointProblem,
    solution: JointSolution,
    starts: &[CameraStart],
    frame_index: &[usize],
    tree_parent: Vec<Option<usize>>,
    [per_camera, joint]: [Duration; 2],
    start: Instant,
) -> RigCalibration {
    let n = problem.cameras.len();
    let mut sums = vec![ObservationErrors::default(); n];
    let mut total = ObservationErrors::default();
    let mut views: Vec<Vec<FrameView>> = vec![Vec::new(); problem.frames.len()];
    for (o, e) in problem.observations.iter().zip(&solution.errors) {
        sums[o.camera].add(e);
        total.add(e);
    }
    for (i, o) in problem.observations.iter().enumerate() {
        let e = &solution.errors[i];
        views[o.frame].push(FrameView {
            camera: o.camera,
            rms: e.rms(),
            points: e.used,
            rejected_points: solution.rejected[i].clone(),
        });
    }
    let cameras = (0..n)
        .map(|c| {
            let spec = &problem.cameras[c];
            let std = &solution.camera_std[c];
            let names = camera_param_names(spec.model());
            RigCamera {
                estimate: CameraEstimate {
                    name: spec.name.clone(),
                    camera: solution.cameras[c].clone(),
                    image_size: spec.image_size,
                    intrinsics_std: [std[0], std[1], std[2], std[3]],
                    distortion_std: std[4..].to_vec(),
                    fixed_parameters: spec.fixed.iter().map(|&i| names[i].to_string()).collect(),
                    rms: sums[c].rms(),
                    num_points: sums[c].used,
                },
                transform: solution.rig[c],
                transform_params: if c == options.reference {
                    params_of(&solution.rig[c], solution.rotation)
                } else {
                    solution.rig_params[c]
                },
                transform_std: solution.rig_std[c],
                num_views: observations.views_of(c),
                initial_method: starts[c].method.clone(),
            }
        })
        .collect();
    let frames = frame_index
        .iter()
        .enumerate()
        .map(|(k, &index)| FrameResult {
            index,
            pose: solution.frames[k],
            pose_params: solution.frame_params[k],
            pose_std: solution.frame_std[k],
            views: std::mem::take(&mut views[k]),
        })
        .collect();
    let optimization = solution.optimization_time;
    RigCalibration {
        cameras,
        reference: options.reference,
        frames,
        rms: total.rms(),
        rms_all_points: total.rms_all(),
        num_rejected: solution.num_rejected(),
        residual_variance: solution.residual_variance,
        rotation: solution.rotation,
        tree_parent,
        initial_rms: (2.0 * solution.initial_cost / total.used.max(1) as f64).sqrt(),
        warnings: solution.warnings,
        solver: solution.report,
        elapsed: start.elapsed(),
        stage_times: [per_camera, optimization, joint.saturating_sub(optimization)],
    }
}

/// Maps an engine error from the joint stage (kept for callers matching on the source).
pub fn joint_source(error: &RigError) -> Option<&CalibrationError> {
    match error {
        RigError::Joint(e) | RigError::Camera { source: e, .. } => Some(e),
        _ => None,
    }
}
