//! One Levenberg-Marquardt solve of a [`JointProblem`] and its covariance.
//!
//! The problem becomes `lm_solver` blocks (cameras and rig transforms reduced, frame poses
//! eliminated by the Schur complement, one residual block per observation with the loss applied
//! per point), is solved from its start values, and the solution is read back with standard
//! deviations. Failures are reported in user terms: the camera, the view or frame, the
//! parameter names.

use crate::cost::{JointCost, residual_layouts};
use crate::error::{CalibrationError, OutlierView};
use crate::outliers::{self, OutlierRejection};
use crate::problem::{BoardNormalization, JointProblem};
use crate::warnings::{Warning, WarningCode};
use camera_model::{
    AnyCamera, AxisAngle, CameraModel, EulerXyz, Pose, RotationKind, RotationParameterization, So3,
};
use lm_solver::manifold::RotationVector;
use lm_solver::{
    CovarianceError, DampingPolicy, Loss, ParameterBlockId, ProblemBuilder, Solver, SolverError,
    SolverOptions, SolverReport,
};
use nalgebra::{DMatrix, Vector2, Vector3, Vector6};
use std::sync::Arc;
use std::time::Duration;

/// How to solve a [`JointProblem`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct SolveOptions {
    /// Rotation parameterization of frame poses and rig transforms.
    pub rotation: RotationKind,
    /// Levenberg-Marquardt settings.
    pub solver: SolverOptions,
    /// Robust loss applied to each point's squared reprojection error (px^2).
    pub loss: Loss,
    /// Compute the covariance (standard deviations) at the solution.
    pub compute_uncertainty: bool,
    /// Reject outliers and solve again until the rejected set is stable (`None`: use every
    /// point, and ignore the observations' suspects). See [`crate::outliers`].
    pub outliers: Option<OutlierRejection>,
    /// Check each camera at the solution and warn (principal point, lens model validity,
    /// poorly determined parameters; default `true`). Internal solves whose solution is only a
    /// start or a score (the focal searches, a many-term model's simpler stage) skip it: the
    /// validity walk alone costs about as much as a small solve.
    pub camera_warnings: bool,
    /// With outlier rejection and suspects (points the robust homography left out of the first
    /// solve), when the start values are themselves a fit of the same points (a many-term lens
    /// model started from a simpler model's solution): if that rejection fails or ends with
    /// rejected points, it runs once more with every point in the first solve. A rational
    /// model whose first solve leaves out suspected edge corners extrapolates freely there: it
    /// may reject good corners for good, or stop against a pole of its denominator. The second
    /// run replaces a failure; of two solutions, the one with the lower truncated cost (the sum
    /// over every point of `min(|e|^2, T^2)`, `T` the first solution's threshold of the
    /// point's camera) is kept. Costs nothing when the first run succeeds without rejecting a
    /// point. Default `false`; [`crate::single::PreparedCamera::solve_options`] sets it after a
    /// warm start.
    pub recheck_without_suspects: bool,
}

impl Default for SolveOptions {
    fn default() -> Self {
        let solver = crate::options::default_solver_options();
        Self {
            rotation: RotationKind::EulerXyz,
            solver,
            loss: Loss::Trivial,
            compute_uncertainty: true,
            outliers: Some(OutlierRejection::default()),
            camera_warnings: true,
            recheck_without_suspects: false,
        }
    }
}

/// The solution of a [`JointProblem`].
#[derive(Debug, Clone)]
pub struct JointSolution {
    /// Each camera as estimated (a fixed aspect ratio and shared focal lengths applied).
    pub cameras: Vec<AnyCamera>,
    /// Standard deviations of each camera's `[fx, fy, cx, cy, distortion...]` (zero for fixed
    /// components; those of the source camera for shared focal lengths; zeros without
    /// uncertainty).
    pub camera_std: Vec<Vec<f64>>,
    /// Covariance of each camera's block `[fx, fy, cx, cy, distortion...]` (pixels and
    /// coefficient units; rows and columns of fixed components zero), when computed.
    pub camera_covariance: Vec<Option<DMatrix<f64>>>,
    /// Each camera's transform from the reference camera, `X_cam = R X_ref + t`.
    pub rig: Vec<Pose>,
    /// Its parameters `[rho, t]` in the rotation parameterization (zeros for the reference).
    pub rig_params: Vec<[f64; 6]>,
    /// Their standard deviations (radians, board units; zero for the reference and fixed rigs).
    pub rig_std: Vec<[f64; 6]>,
    /// Each frame's board pose in the reference camera's frame.
    pub frames: Vec<Pose>,
    /// Its parameters `[rho, t]`.
    pub frame_params: Vec<[f64; 6]>,
    /// Their standard deviations.
    pub frame_std: Vec<[f64; 6]>,
    /// Per observation, its reprojection error statistics at the solution (per-point errors:
    /// [`reprojection_errors`] of [`JointProblem::with_solution`]).
    pub errors: Vec<ObservationErrors>,
    /// The Levenberg-Marquardt report.
    pub report: SolverReport,
    /// `sum w |e|^2 / (2 n_used - p)`, pixels^2: the variance that scales the covariance.
    pub residual_variance: f64,
    /// The rotation parameterization of the parameters above.
    pub rotation: RotationKind,
    /// Per observation, the points (indices into the observation) rejected as outliers.
    pub rejected: Vec<Vec<usize>>,
    /// Re-solves after rejecting outliers (0 when nothing was rejected).
    pub outlier_rounds: usize,
    /// Iterations over all solves (equal to `report.iterations.len()` without re-solves).
    pub total_iterations: usize,
    /// Levenberg-Marquardt time over all solves (`report.total_time` without re-solves): the
    /// results' `optimization` stage, which must not leave the solves before the last outlier
    /// round to the `uncertainty` stage.
    pub optimization_time: Duration,
    /// The cost (half the weighted sum of squared errors, px^2) at the start of the first
    /// solve.
    pub initial_cost: f64,
    /// What deserves attention: the solver's iteration limit, rejected outliers.
    pub warnings: Vec<Warning>,
    /// `(camera, component)` of the camera-block components (distortion terms) along directions
    /// the data does not determine; their standard deviations are lower bounds.
    pub undetermined: Vec<(usize, usize)>,
    /// Per camera, the error norms of an evenly strided sample of the user-weighted points
    /// (for the noise level; empty without outlier rejection).
    pub(crate) noise_sample: Vec<Vec<f64>>,
    /// `(observation, point, |e|)` of the user-weighted points whose error exceeds the outlier
    /// floor: the only points rejection can pick (empty without outlier rejection).
    pub(crate) outlier_candidates: Vec<(usize, usize, f64)>,
    /// `sum |e|^2` over the user-weighted points, rejected or not (with outlier rejection; the
    /// points rejection can pick from, and the base of [`truncated_cost`]).
    pub(crate) candidate_sum_sq: f64,
    /// Per camera, the radial errors of the used points in [`RADIAL_BANDS`] bands of distance
    /// from the principal point (band `b`: `b / RADIAL_BANDS` to `(b + 1) / RADIAL_BANDS` of
    /// the farthest image corner's distance): `(sum of e . u, count)` with `u` the unit vector
    /// from the principal point to the measured pixel. For the lack-of-fit check of
    /// [`crate::diagnostics::camera_warnings`].
    pub(crate) radial_bands: Vec<[(f64, usize); RADIAL_BANDS]>,
}

/// Bands of distance from the principal point in [`JointSolution::radial_bands`].
pub(crate) const RADIAL_BANDS: usize = 8;

/// Reprojection error statistics of one observation at a solution, pixels.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ObservationErrors {
    /// Points used by the solve (positive weight, not rejected).
    pub used: usize,
    /// `sum |e|^2` over the used points.
    pub sum_sq: f64,
    /// `sum e` over the used points (x and y).
    pub sum: Vector2<f64>,
    /// `sum e_x^2`, `sum e_y^2` over the used points.
    pub sum_sq_xy: Vector2<f64>,
    /// Every point of the observation.
    pub all: usize,
    /// `sum |e|^2` over every point.
    pub all_sum_sq: f64,
}

impl ObservationErrors {
    /// RMS over the used points (0 without any).
    pub fn rms(&self) -> f64 {
        (self.sum_sq / self.used.max(1) as f64).sqrt()
    }

    /// RMS over every point.
    pub fn rms_all(&self) -> f64 {
        (self.all_sum_sq / self.all.max(1) as f64).sqrt()
    }

    /// Adds `other`'s sums to these.
    pub fn add(&mut self, other: &ObservationErrors) {
        self.used += other.used;
        self.sum_sq += other.sum_sq;
        self.sum += other.sum;
        self.sum_sq_xy += other.sum_sq_xy;
        self.all += other.all;
        self.all_sum_sq += other.all_sum_sq;
    }
}

impl JointSolution {
    /// Number of points rejected as outliers.
    pub fn num_rejected(&self) -> usize {
        self.rejected.iter().map(Vec::len).sum()
    }
}

/// The solver's parameter blocks of a [`JointProblem`].
#[derive(Debug, Clone)]
pub(crate) struct Blocks {
    pub cameras: Vec<ParameterBlockId>,
    pub rigs: Vec<Option<ParameterBlockId>>,
    pub frames: Vec<ParameterBlockId>,
}

/// Solves `problem` from its start values; with `options.outliers`, rejects outliers (starting
/// with the observations' suspects) and solves again from the previous solution until the
/// rejected set no longer changes.
///
/// # Errors
///
/// Input errors in user terms, [`CalibrationError::MostlyOutliers`] for a view that loses more
/// than `max_view_fraction` of its points, solver failures, and parameters the data does not
/// determine ([`CalibrationError::NotDetermined`]).
pub fn solve(
    problem: &JointProblem,
    options: &SolveOptions,
) -> Result<JointSolution, CalibrationError> {
    problem
        .check()
        .map_err(|e| CalibrationError::InvalidOption(e.to_string()))?;
    let Some(rejection) = options.outliers else {
        let mut solution = solve_once(problem, options, problem, None)?;
        solution.total_iterations = solution.report.iterations.len();
        add_solver_warnings(&mut solution);
        if options.camera_warnings {
            let camera = crate::diagnostics::camera_warnings(problem, &solution);
            solution.warnings.extend(camera);
        }
        return Ok(solution);
    };
    let suspects: Vec<Vec<usize>> = problem
        .observations
        .iter()
        .map(|o| match &o.suspected {
            Some(s) => (0..s.len())
                .filter(|&i| s[i] && o.weights.as_ref().is_none_or(|w| w[i] > 0.0))
                .collect(),
            None => Vec::new(),
        })
        .collect();
    let recheck = options.recheck_without_suspects && suspects.iter().any(|s| !s.is_empty());
    let every_point = || {
        reject_and_solve(
            problem,
            options,
            &rejection,
            vec![Vec::new(); suspects.len()],
        )
    };
    let mut solution = match reject_and_solve(problem, options, &rejection, suspects.clone()) {
        Ok(solution) => solution,
        Err(error) if recheck => every_point().map_err(|_| error)?,
        Err(error) => return Err(error),
    };
    if recheck && solution.num_rejected() > 0 {
        // A failed second run keeps the first solution.
        if let Ok(second) = every_point() {
            let thresholds = outliers::thresholds(&solution, &rejection);
            let total_iterations = solution.total_iterations + second.total_iterations;
            let optimization_time = solution.optimization_time + second.optimization_time;
            if truncated_cost(problem, &second, &thresholds)
                < truncated_cost(problem, &solution, &thresholds)
            {
                solution = second;
            }
            solution.total_iterations = total_iterations;
            solution.optimization_time = optimization_time;
        }
    }
    add_solver_warnings(&mut solution);
    add_outlier_warning(problem, &mut solution, &rejection);
    if options.camera_warnings {
        let camera = crate::diagnostics::camera_warnings(problem, &solution);
        solution.warnings.extend(camera);
    }
    Ok(solution)
}

/// The rejection loop: solves with `rejected` left out, marks the outliers of the solution and
/// solves again from it until the marked set no longer changes (at most `max_rounds` re-solves).
fn reject_and_solve(
    problem: &JointProblem,
    options: &SolveOptions,
    rejection: &OutlierRejection,
    mut rejected: Vec<Vec<usize>>,
) -> Result<JointSolution, CalibrationError> {
    let floor = Some(rejection.min_threshold_px);
    let mut warm: Option<JointProblem> = None;
    let mut total_iterations = 0;
    let mut optimization_time = Duration::ZERO;
    let mut initial_cost = None;
    let mut rounds = 0;
    loop {
        let base = warm.as_ref().unwrap_or(problem);
        let mut solution = if rejected.iter().any(|r| !r.is_empty()) {
            let mut work = base.clone();
            outliers::apply(&mut work, &rejected);
            solve_once(&work, options, problem, floor)?
        } else {
            solve_once(base, options, problem, floor)?
        };
        total_iterations += solution.report.iterations.len();
        optimization_time += solution.report.total_time;
        let first_cost = *initial_cost.get_or_insert(solution.report.initial_cost);
        let all_marked = outliers::mark(problem, &solution, rejection);
        // A view past the limit gets its pose refitted robustly before the next round (not
        // after the last solve, whose marks are final).
        let refit = if rounds < rejection.max_rounds {
            refit_poses(problem, &solution, &all_marked, rejection, options)?
        } else {
            Refit::default()
        };
        optimization_time += refit.time;
        let marked = if refit.frames.is_empty() {
            at_most_view_fraction(
                problem,
                &solution.outlier_candidates,
                &all_marked,
                rejection,
            )
        } else {
            let (candidates, next) = refit.merge(&solution.outlier_candidates, &all_marked);
            at_most_view_fraction(problem, &candidates, &next, rejection)
        };
        if marked == rejected || rounds == rejection.max_rounds {
            // Judged on the final marks only: after a first solve that a view's own stray
            // corners pulled, more than half of its good points can exceed the threshold for a
            // round and come back in the next.
            check_view_fractions(problem, &all_marked, rejection)?;
            solution.rejected = rejected;
            solution.outlier_rounds = rounds;
            solution.total_iterations = total_iterations;
            solution.optimization_time = optimization_time;
            solution.initial_cost = first_cost;
            return Ok(solution);
        }
        rejected = marked;
        rounds += 1;
        if options.compute_uncertainty {
            check_frames_keep_points(problem, &rejected)?;
        }
        let mut next = problem.with_solution(&solution);
        for &(f, pose) in &refit.frames {
            next.frames[f] = pose;
        }
        warm = Some(next);
    }
}

/// What [`refit_poses`] found: the frames whose pose it replaces, and for their observations
/// the points marked and the candidates `(observation, point, |e|)` at the new pose.
#[derive(Default)]
struct Refit {
    frames: Vec<(usize, Pose)>,
    marked: Vec<(usize, Vec<usize>)>,
    candidates: Vec<Candidate>,
    time: Duration,
}

/// `(observation, point, |e|)` of a point whose error exceeds the outlier floor.
type Candidate = (usize, usize, f64);

/// One refit of one frame: its pose, its observations' marks and candidates there, and how
/// many points are marked.
struct FrameRefit {
    pose: Pose,
    marked: Vec<(usize, Vec<usize>)>,
    candidates: Vec<Candidate>,
    count: usize,
}

impl Refit {
    /// `candidates` and `marked` of a solution with the refitted frames' observations replaced
    /// by the refit's.
    fn merge(
        &self,
        candidates: &[Candidate],
        marked: &[Vec<usize>],
    ) -> (Vec<Candidate>, Vec<Vec<usize>>) {
        let mut next = marked.to_vec();
        let mut replaced = vec![false; marked.len()];
        for (o, m) in &self.marked {
            next[*o].clone_from(m);
            replaced[*o] = true;
        }
        let mut merged: Vec<Candidate> = candidates
            .iter()
            .filter(|(o, _, _)| !replaced[*o])
            .copied()
            .collect();
        merged.extend_from_slice(&self.candidates);
        (merged, next)
    }
}

/// For each frame with a view past `max_view_fraction` at `solution`: that frame's pose
/// refitted alone, with the cameras and the rig held, under a Cauchy loss at each camera's
/// threshold (`ln(1 + |e|^2 / T^2)`: a point far beyond the threshold barely pulls), from two
/// starts: the solution's pose and, for each view past the limit, the pose of a
/// least-median-of-squares consensus of its own points ([`consensus_pose`]). The refit with the
/// fewest points over the threshold (the rule of [`outliers::mark`]) replaces the solution's
/// pose and marks when it has fewer of them.
///
/// Why: stray corners that the homography did not flag pull their view's pose in the joint
/// least-squares solve so that most of its good points exceed the threshold, and the pulled
/// pose can have the board tilted the other way (of the two poses that a small, distant view of
/// a plane nearly allows). Neither the rounds (which keep the better half of such a view) nor a
/// refit from that pose leave it; a pose from the view's consensus does. A wrong view (another
/// lens, wrong correspondences) has no pose that fits most of its points and stays past the
/// limit. Frames with no view past the limit are not touched: where no view loses half of its
/// points, nothing changes.
fn refit_poses(
    problem: &JointProblem,
    solution: &JointSolution,
    marked: &[Vec<usize>],
    rejection: &OutlierRejection,
    options: &SolveOptions,
) -> Result<Refit, CalibrationError> {
    let mut refit = Refit::default();
    let past = |o: usize| {
        marked[o].len() as f64
            > rejection.max_view_fraction * problem.observations[o].num_used_points() as f64
    };
    let mut frames: Vec<usize> = (0..marked.len())
        .filter(|&o| past(o))
        .map(|o| problem.observations[o].frame)
        .collect();
    if frames.is_empty() {
        return Ok(refit);
    }
    frames.sort_unstable();
    frames.dedup();
    let thresholds = outliers::thresholds(solution, rejection);
    let cameras: Vec<crate::problem::CameraSpec> = problem
        .cameras
        .iter()
        .zip(&solution.cameras)
        .map(|(spec, camera)| crate::problem::CameraSpec {
            initial: camera.clone(),
            fixed: (0..spec.model().num_params()).collect(),
            aspect_ratio: None,
            focal_from: None,
            ..spec.clone()
        })
        .collect();
    let sub_options = SolveOptions {
        loss: Loss::Cauchy(1.0),
        compute_uncertainty: false,
        outliers: None,
        camera_warnings: false,
        recheck_without_suspects: false,
        ..options.clone()
    };
    for f in frames {
        let members: Vec<usize> = (0..problem.observations.len())
            .filter(|&o| problem.observations[o].frame == f)
            .collect();
        let sub = JointProblem {
            cameras: cameras.clone(),
            reference: problem.reference,
            rig: solution.rig.clone(),
            rig_fixed: vec![true; problem.cameras.len()],
            frames: vec![solution.frames[f]],
            frame_names: vec![problem.frame_names[f].clone()],
            observations: members
                .iter()
                .map(|&o| {
                    let obs = &problem.observations[o];
                    let t = thresholds[obs.camera].max(f64::MIN_POSITIVE.sqrt());
                    let mut spec = obs.clone();
                    spec.frame = 0;
                    spec.suspected = None;
                    spec.weights = Some(
                        (0..obs.object.len())
                            .map(|i| obs.weights.as_ref().map_or(1.0, |w| w[i]) / (t * t))
                            .collect(),
                    );
                    spec
                })
                .collect(),
        };
        let mut starts = vec![solution.frames[f]];
        for &o in members.iter().filter(|&&o| past(o)) {
            if let Some(pose) = consensus_pose(
                problem,
                solution,
                o,
                thresholds[problem.observations[o].camera],
            ) {
                starts.push(pose);
            }
        }
        let before: usize = members.iter().map(|&o| marked[o].len()).sum();
        let mut best: Option<FrameRefit> = None;
        for start in starts {
            let mut sub = sub.clone();
            sub.frames[0] = start;
            // A start whose refit fails is dropped.
            let Ok(fit) = solve(&sub, &sub_options) else {
                continue;
            };
            refit.time += fit.report.total_time;
            let Ok(errors) = reprojection_errors(&sub.with_solution(&fit)) else {
                continue;
            };
            let mut new_marked = Vec::new();
            let mut new_candidates = Vec::new();
            for (&o, e) in members.iter().zip(&errors) {
                let obs = &problem.observations[o];
                let t = thresholds[obs.camera];
                let mut m = Vec::new();
                for (i, e) in e.iter().enumerate() {
                    if obs.weights.as_ref().is_some_and(|w| w[i] <= 0.0) {
                        continue;
                    }
                    // As `solve_with` and `outliers::mark` take them (a NaN error is marked).
                    let norm = e.norm();
                    let below_floor = norm <= rejection.min_threshold_px;
                    if !below_floor {
                        new_candidates.push((o, i, norm));
                    }
                    let within = norm <= t;
                    if !within {
                        m.push(i);
                    }
                }
                new_marked.push((o, m));
            }
            let count: usize = new_marked.iter().map(|(_, m)| m.len()).sum();
            if count < best.as_ref().map_or(before, |b| b.count) {
                best = Some(FrameRefit {
                    pose: fit.frames[0],
                    marked: new_marked,
                    candidates: new_candidates,
                    count,
                });
            }
        }
        if let Some(best) = best {
            refit.frames.push((f, best.pose));
            refit.marked.extend(best.marked);
            refit.candidates.extend(best.candidates);
        }
    }
    Ok(refit)
}

/// `sum over the user-weighted points of min(|e|^2, T^2)`, `T` = `thresholds` of the point's
/// camera: a solution's cost with each point's influence capped at the rejection threshold,
/// comparable between solutions that reject different points.
fn truncated_cost(problem: &JointProblem, solution: &JointSolution, thresholds: &[f64]) -> f64 {
    let all = solution.candidate_sum_sq;
    let excess: f64 = solution
        .outlier_candidates
        .iter()
        .map(|&(o, _, norm)| {
            let t = thresholds[problem.observations[o].camera];
            (norm * norm - t * t).max(0.0)
        })
        .sum();
    all - excess
}

impl JointProblem {
    /// This problem with its start values replaced by `solution`'s cameras, rig and frames: to
    /// evaluate the solution ([`reprojection_errors`]) or to solve again from it.
    pub fn with_solution(&self, solution: &JointSolution) -> JointProblem {
        let mut p = self.clone();
        for (spec, camera) in p.cameras.iter_mut().zip(&solution.cameras) {
            spec.initial = camera.clone();
        }
        p.rig.clone_from(&solution.rig);
        p.frames.clone_from(&solution.frames);
        p
    }
}

/// Where observation `o` is, in user terms: its frame's name and, with several cameras, the
/// camera's.
fn locate(problem: &JointProblem, o: usize) -> String {
    let obs = &problem.observations[o];
    let frame = &problem.frame_names[obs.frame];
    if problem.cameras.len() > 1 {
        format!("{frame}, camera '{}'", problem.cameras[obs.camera].name)
    } else {
        frame.clone()
    }
}

/// A board pose seen by fewer points than this cannot be solved for (six parameters).
const MIN_POSE_POINTS: usize = 3;

/// Before a re-solve with uncertainties: a frame whose points the marking left fewer than
/// [`MIN_POSE_POINTS`] (every point of a view that fits no pose, as a sheared board's) has an
/// undetermined pose, and the solve's covariance would stop on it with
/// [`CalibrationError::NotDetermined`], which `skip_bad_views` cannot act on. Such a view is
/// wrong as a whole: [`CalibrationError::MostlyOutliers`]. (Without uncertainties the damped
/// solve goes on and the points may come back in the next round, as before.)
fn check_frames_keep_points(
    problem: &JointProblem,
    rejected: &[Vec<usize>],
) -> Result<(), CalibrationError> {
    let mut kept = vec![0usize; problem.frames.len()];
    for (o, r) in rejected.iter().enumerate() {
        let obs = &problem.observations[o];
        kept[obs.frame] += obs.num_used_points().saturating_sub(r.len());
    }
    let emptied = |(o, r): &(usize, &Vec<usize>)| {
        !r.is_empty() && kept[problem.observations[*o].frame] < MIN_POSE_POINTS
    };
    let worst = rejected
        .iter()
        .enumerate()
        .filter(emptied)
        .max_by_key(|&(o, r)| (r.len(), std::cmp::Reverse(o)));
    match worst {
        Some((o, _)) => {
            let also: Vec<usize> = rejected
                .iter()
                .enumerate()
                .filter(emptied)
                .map(|(other, _)| other)
                .filter(|&other| other != o)
                .collect();
            Err(mostly_outliers(problem, rejected, o, &also))
        }
        None => Ok(()),
    }
}

/// The frame pose that observation `o`'s points alone give with its camera and the rig held at
/// `solution`: the pixels undistorted to the projection plane (scaled by `fx`, about pixels),
/// a least-median-of-squares homography from the board plane to them (it tolerates up to half
/// of the points wrong; the ordinary fit when every point is within `threshold` of it), its
/// pose, and that pose taken to the reference camera. `None` for a board off the plane `Z = 0`,
/// or without a consensus.
fn consensus_pose(
    problem: &JointProblem,
    solution: &JointSolution,
    o: usize,
    threshold: f64,
) -> Option<Pose> {
    let obs = &problem.observations[o];
    let camera = &solution.cameras[obs.camera];
    let scale = camera.intrinsics.fx;
    let undistort = camera_model::UndistortOptions::default();
    let mut object = Vec::new();
    let mut image = Vec::new();
    let mut points = Vec::new();
    for (i, (x, m)) in obs.object.iter().zip(&obs.pixels).enumerate() {
        if obs.weights.as_ref().is_some_and(|w| w[i] <= 0.0) {
            continue;
        }
        if x.z != 0.0 {
            return None;
        }
        let Ok(ray) = camera.pixel_to_ray(m, &undistort) else {
            continue;
        };
        if ray.z <= 1e-3 {
            continue;
        }
        object.push(nalgebra::Point2::new(x.x, x.y));
        image.push(nalgebra::Point2::new(
            scale * ray.x / ray.z,
            scale * ray.y / ray.z,
        ));
        points.push(*x);
    }
    // Clean only when every point is within the threshold: a stray corner never passes.
    let robust = homography::RobustOptions {
        suspicious_factor: 0.0,
        min_threshold_px: threshold,
        ..homography::RobustOptions::default()
    };
    let h = homography::estimate_robust(
        &object,
        &image,
        &homography::RefineOptions::default(),
        &robust,
    )
    .ok()?;
    let k = camera_model::Intrinsics::new(scale, scale, 0.0, 0.0);
    let pose = crate::init::initial_pose(&h.estimate.h, &k, &points)?;
    Some(solution.rig[obs.camera].inverse().compose(&pose))
}

/// [`CalibrationError::MostlyOutliers`] naming observation `o`, with the views `also` past the
/// same limit.
fn mostly_outliers(
    problem: &JointProblem,
    rejected: &[Vec<usize>],
    o: usize,
    also: &[usize],
) -> CalibrationError {
    let view = |o: usize| OutlierView {
        observation: o,
        location: locate(problem, o),
        rejected: rejected[o].len(),
        points: problem.observations[o].num_used_points(),
    };
    let named = view(o);
    CalibrationError::MostlyOutliers {
        observation: o,
        location: named.location,
        rejected: named.rejected,
        points: named.points,
        also: also.iter().map(|&a| view(a)).collect(),
    }
}

/// `marked` with each observation's rejections cut to its `max_view_fraction` worst points
/// (largest errors first). A view's stray corners that the homography did not flag pull its
/// pose in the first solve so that most of its good points exceed the threshold; rejecting them
/// all left the pose to its few worst points, which could not bring it back (1000 views with 3
/// stray corners each: one good view refused as mostly outliers in 6 of 6 seeds). Keeping the
/// better half lets the next solve put the pose back (4 of those 6 seeds); where the pulled pose
/// has the board tilted the other way it does not return within the rounds, which
/// [`refit_poses`] mends. A view that is wrong as a whole is still judged on its uncut marks at
/// the end.
fn at_most_view_fraction(
    problem: &JointProblem,
    candidates: &[Candidate],
    marked: &[Vec<usize>],
    options: &OutlierRejection,
) -> Vec<Vec<usize>> {
    let limit = |o: usize| {
        (options.max_view_fraction * problem.observations[o].num_used_points() as f64) as usize
    };
    if marked.iter().enumerate().all(|(o, m)| m.len() <= limit(o)) {
        return marked.to_vec();
    }
    let mut errors: Vec<Vec<(usize, f64)>> = vec![Vec::new(); marked.len()];
    for &(o, point, norm) in candidates {
        if marked[o].len() > limit(o) && marked[o].binary_search(&point).is_ok() {
            errors[o].push((point, norm));
        }
    }
    marked
        .iter()
        .enumerate()
        .map(|(o, m)| {
            if m.len() <= limit(o) {
                return m.clone();
            }
            let mut worst = std::mem::take(&mut errors[o]);
            worst.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
            let mut kept: Vec<usize> = worst.iter().take(limit(o)).map(|&(p, _)| p).collect();
            kept.sort_unstable();
            kept
        })
        .collect()
}

fn check_view_fractions(
    problem: &JointProblem,
    rejected: &[Vec<usize>],
    options: &OutlierRejection,
) -> Result<(), CalibrationError> {
    let past: Vec<usize> = rejected
        .iter()
        .enumerate()
        .filter(|(o, r)| {
            r.len() as f64
                > options.max_view_fraction * problem.observations[*o].num_used_points() as f64
        })
        .map(|(o, _)| o)
        .collect();
    match past.split_first() {
        Some((&o, also)) => Err(mostly_outliers(problem, rejected, o, also)),
        None => Ok(()),
    }
}

fn add_solver_warnings(solution: &mut JointSolution) {
    if solution.report.termination == lm_solver::Termination::MaxIterations {
        let n = solution.report.iterations.len();
        solution.warnings.push(Warning::new(
            WarningCode::IterationLimit,
            format!(
                "the solver stopped at its iteration limit ({n} iterations) before converging: the result may not be the minimum; raise the limit or check the data"
            ),
        ));
    }
}

fn add_outlier_warning(
    problem: &JointProblem,
    solution: &mut JointSolution,
    options: &OutlierRejection,
) {
    let total = solution.num_rejected();
    if total == 0 {
        return;
    }
    let mut worst: Vec<(usize, usize)> = solution
        .rejected
        .iter()
        .enumerate()
        .filter(|(_, r)| !r.is_empty())
        .map(|(o, r)| (r.len(), o))
        .collect();
    worst.sort_by(|a, b| b.cmp(a));
    let listed: Vec<String> = worst
        .iter()
        .take(5)
        .map(|&(n, o)| format!("{} ({n})", locate(problem, o)))
        .collect();
    let more = if worst.len() > 5 { ", ..." } else { "" };
    solution.warnings.push(Warning::new(
        WarningCode::OutliersRejected,
        format!(
            "{total} points in {} view{} rejected as outliers (error above {} sigma and {} px): {}{more}; the result lists them per view. If they lie at the image's edges in many views, the lens model may be too simple for the lens (try a model with more terms)",
            worst.len(),
            if worst.len() == 1 { "" } else { "s" },
            options.threshold_sigmas,
            options.min_threshold_px,
            listed.join(", ")
        ),
    ));
}

/// One solve of `problem` as given (weights as they are). `user` is the problem with the user's
/// weights (rejected points not zeroed) and `floor` the outlier floor, for the error statistics
/// that outlier rejection reads.
fn solve_once(
    problem: &JointProblem,
    options: &SolveOptions,
    user: &JointProblem,
    floor: Option<f64>,
) -> Result<JointSolution, CalibrationError> {
    let normalization = problem.board_normalization();
    let normalized;
    let target = match &normalization {
        Some(n) => {
            normalized = problem.normalized(n);
            &normalized
        }
        None => problem,
    };
    match options.rotation {
        RotationKind::EulerXyz => {
            solve_with::<EulerXyz>(target, options, normalization, user, floor)
        }
        RotationKind::AxisAngle => {
            solve_with::<AxisAngle>(target, options, normalization, user, floor)
        }
        RotationKind::So3 => solve_with::<So3>(target, options, normalization, user, floor),
    }
}

/// Maps a frame's parameters and their covariance from normalized board coordinates back to the
/// user's: `t = s t' - R(rho) c`, so `dt/drho_k = -(dR/drho_k) c` and `dt/dt' = s I`; the rotation
/// parameters are unchanged.
fn denormalize_frame<R: RotationParameterization>(
    n: &BoardNormalization,
    params: [f64; 6],
    covariance: Option<&DMatrix<f64>>,
) -> ([f64; 6], [f64; 6]) {
    let rho = Vector3::new(params[0], params[1], params[2]);
    let (rotation, derivatives) = R::matrix_and_derivatives(&rho);
    let t = Vector3::new(params[3], params[4], params[5]) * n.scale - rotation * n.centre;
    let out = [params[0], params[1], params[2], t.x, t.y, t.z];
    let std = match covariance {
        Some(c) => {
            let mut j = DMatrix::<f64>::identity(6, 6);
            for k in 0..3 {
                let column = -(derivatives[k] * n.centre);
                for i in 0..3 {
                    j[(3 + i, k)] = column[i];
                }
                j[(3 + k, 3 + k)] = n.scale;
            }
            let mapped = &j * c * j.transpose();
            std::array::from_fn(|i| mapped[(i, i)].max(0.0).sqrt())
        }
        None => [0.0; 6],
    };
    (out, std)
}

/// The reprojection errors `projected - measured` (pixels) of every point of every observation
/// at the problem's start values (cameras, rig and frame poses as given), without optimizing:
/// to evaluate someone else's solution, or a start.
pub fn reprojection_errors(
    problem: &JointProblem,
) -> Result<Vec<Vec<Vector2<f64>>>, CalibrationError> {
    problem
        .check()
        .map_err(|e| CalibrationError::InvalidOption(e.to_string()))?;
    let (lm, blocks) = build(problem, &SolveOptions::default())?;
    let x = start::<EulerXyz>(problem, &lm, &blocks);
    let cost = JointCost::<EulerXyz>::new(problem);
    (0..problem.observations.len())
        .map(|i| {
            let params: Vec<&[f64]> = lm
                .residual_blocks_of(lm_solver::ResidualBlockId(i))
                .map(|b| lm.block(&x, b))
                .collect();
            cost.reprojection_errors(i, &params)
                .map_err(|e| CalibrationError::Initialization { reason: e.message })
        })
        .collect()
}

/// The `lm_solver` problem [`solve`] builds for `problem`, with the start vector (rotations in
/// parameterization `R`): for callers that drive or time the solver themselves (the benchmarks
/// do).
pub fn solver_problem<R: RotationParameterization>(
    problem: &JointProblem,
    options: &SolveOptions,
) -> Result<(lm_solver::Problem, Vec<f64>), CalibrationError> {
    problem
        .check()
        .map_err(|e| CalibrationError::InvalidOption(e.to_string()))?;
    let (lm, blocks) = build(problem, options)?;
    let x = start::<R>(problem, &lm, &blocks);
    Ok((lm, x))
}

/// The `lm_solver` problem of `problem`.
fn build(
    problem: &JointProblem,
    options: &SolveOptions,
) -> Result<(lm_solver::Problem, Blocks), CalibrationError> {
    let mut builder = ProblemBuilder::new();
    let manifold = options
        .rotation
        .needs_manifold()
        .then(|| Arc::new(RotationVector::pose()));
    let cameras: Vec<ParameterBlockId> = problem
        .cameras
        .iter()
        .map(|c| {
            let b = builder.add_parameter_block(c.model().num_params());
            builder.set_fixed_components(b, &c.fixed);
            b
        })
        .collect();
    let rigs: Vec<Option<ParameterBlockId>> = (0..problem.cameras.len())
        .map(|c| {
            problem.has_rig(c).then(|| {
                let b = builder.add_parameter_block(6);
                builder.set_constant(b, problem.rig_fixed[c]);
                if let Some(m) = &manifold {
                    builder.set_manifold(b, m.clone());
                }
                b
            })
        })
        .collect();
    let frames: Vec<ParameterBlockId> = problem
        .frames
        .iter()
        .map(|_| {
            let b = builder.add_parameter_block(6);
            builder.set_eliminated(b, true);
            if let Some(m) = &manifold {
                builder.set_manifold(b, m.clone());
            }
            b
        })
        .collect();
    for (o, layout) in problem.observations.iter().zip(residual_layouts(problem)) {
        let mut blocks = vec![cameras[o.camera], frames[o.frame]];
        if layout.rig.is_some() {
            blocks.push(rigs[o.camera].expect("non-reference camera has a rig block"));
        }
        if let Some(source) = problem.cameras[o.camera].focal_from {
            blocks.push(cameras[source]);
        }
        builder.add_residual_block_with_grouped_loss(2 * o.object.len(), &blocks, options.loss, 2);
    }
    let built = builder
        .build()
        .map_err(|e| CalibrationError::InvalidOption(e.to_string()))?;
    Ok((
        built,
        Blocks {
            cameras,
            rigs,
            frames,
        },
    ))
}

/// The start values as the solver's parameter vector.
fn start<R: RotationParameterization>(
    problem: &JointProblem,
    lm: &lm_solver::Problem,
    blocks: &Blocks,
) -> Vec<f64> {
    let mut x = vec![0.0; lm.num_parameters()];
    for (camera, &b) in problem.cameras.iter().zip(&blocks.cameras) {
        camera.initial.write_params(lm.block_mut(&mut x, b));
    }
    for (rig, b) in problem.rig.iter().zip(&blocks.rigs) {
        if let Some(b) = b {
            lm.block_mut(&mut x, *b)
                .copy_from_slice(rig.to_params::<R>().as_slice());
        }
    }
    for (pose, &b) in problem.frames.iter().zip(&blocks.frames) {
        lm.block_mut(&mut x, b)
            .copy_from_slice(pose.to_params::<R>().as_slice());
    }
    x
}

/// Describes parameter block `block` in user terms.
fn describe_block(problem: &JointProblem, blocks: &Blocks, block: ParameterBlockId) -> String {
    if let Some(c) = blocks.cameras.iter().position(|&b| b == block) {
        return format!("the intrinsics of camera '{}'", problem.cameras[c].name);
    }
    if let Some(c) = blocks.rigs.iter().position(|&b| b == Some(block)) {
        return format!(
            "the pose of camera '{}' in the rig",
            problem.cameras[c].name
        );
    }
    if let Some(f) = blocks.frames.iter().position(|&b| b == block) {
        return format!("the board pose of {}", problem.frame_names[f]);
    }
    format!("parameter block {}", block.0)
}

/// Names the component `component` of block `block` ("fx of camera 'left'").
fn describe_component(
    problem: &JointProblem,
    blocks: &Blocks,
    block: ParameterBlockId,
    component: usize,
) -> String {
    if let Some(c) = blocks.cameras.iter().position(|&b| b == block) {
        let names = problem.cameras[c].param_names();
        let name = names.get(component).copied().unwrap_or("?");
        return if problem.cameras.len() == 1 {
            name.to_string()
        } else {
            format!("{name} of camera '{}'", problem.cameras[c].name)
        };
    }
    let what = if component < 3 {
        "rotation"
    } else {
        "translation"
    };
    format!("{what} of {}", describe_block(problem, blocks, block))
}

/// A solver or covariance failure in user terms.
fn user_error(problem: &JointProblem, blocks: &Blocks, error: CovarianceError) -> CalibrationError {
    match error {
        CovarianceError::RankDeficient { weakest, .. } => {
            let mut names: Vec<String> = weakest
                .iter()
                .map(|&(b, c)| describe_component(problem, blocks, b, c))
                .collect();
            names.dedup();
            CalibrationError::NotDetermined {
                what: names.join(", "),
                hint: "add views with the board tilted and spread over the image, or fix these parameters".into(),
            }
        }
        CovarianceError::SingularEliminatedBlock { block } => {
            // A view of a full board determines its pose; a rational lens model whose
            // denominator nearly vanishes at some of its points (derivatives of 1e8 px and more)
            // makes the pose block numerically singular instead (`stopped_at_pole`: the other
            // damping policy was tried).
            let rational = blocks
                .frames
                .iter()
                .position(|&b| b == ParameterBlockId(block))
                .and_then(|f| {
                    problem
                        .observations
                        .iter()
                        .filter(|o| o.frame == f)
                        .map(|o| problem.cameras[o.camera].model())
                        .find(|m| matches!(m, CameraModel::Rational8 | CameraModel::ThinPrism12))
                });
            let hint = match rational {
                Some(model) => format!(
                    "the board must show at least 4 well-spread points that are not on one line, or the {model} lens model reached a state where its denominator nearly vanishes at this view's points (the optimization stopped against a pole of the model with both damping policies): try brown-conrady5"
                ),
                None => {
                    "the board must show at least 4 well-spread points that are not on one line"
                        .into()
                }
            };
            CalibrationError::NotDetermined {
                what: describe_block(problem, blocks, ParameterBlockId(block)),
                hint,
            }
        }
        CovarianceError::Singular { .. } => CalibrationError::NotDetermined {
            what: "some combination of the parameters".into(),
            hint: "add views with the board tilted and spread over the image, or fix parameters"
                .into(),
        },
        other => CalibrationError::Unobservable(other),
    }
}

fn solver_error(problem: &JointProblem, error: SolverError) -> CalibrationError {
    match error {
        SolverError::InitialEvaluation { residual, message } => {
            let name = problem
                .observations
                .get(residual)
                .map_or_else(|| format!("residual block {residual}"), |o| o.name.clone());
            CalibrationError::Initialization {
                reason: format!("{name}: the start values cannot be evaluated: {message}"),
            }
        }
        other => CalibrationError::Solver(other),
    }
}

/// A rational lens model's denominator below this (in absolute value) at an observed point
/// marks a pole wall: the point's derivatives are `1 / |denominator|`, a million times their
/// size elsewhere, and more.
pub const POLE_WALL: f64 = 1e-6;

/// Whether the solve stopped with a rational lens model's denominator at or below
/// [`POLE_WALL`] at an observed point.
///
/// Numerator and denominator of a rational model can share a root (the valley of nearly
/// equivalent coefficients: both multiplied by a common `(1 + a r^2)`). When that root reaches the
/// radius of an observed point, the point's projection is `0/0`: the cost is finite, but it
/// changes by the whole error of the point within `1e-10` of the parameters, and on one side of
/// that wall a Levenberg-Marquardt path can go on lowering the cost in ever shorter steps until
/// the step tolerance stops it. That point is not a minimum (the gradient is large, every
/// longer step is rejected), and its covariance is singular. The minimum lies past the wall,
/// which a path with longer steps can cross (both signs flip together, the projection stays
/// finite).
fn stopped_at_pole<R: RotationParameterization>(
    cost: &JointCost<'_, R>,
    lm: &lm_solver::Problem,
    x: &[f64],
) -> bool {
    let mut params: Vec<&[f64]> = Vec::with_capacity(4);
    (0..lm.num_residual_blocks()).any(|i| {
        params.clear();
        params.extend(
            lm.residual_blocks_of(lm_solver::ResidualBlockId(i))
                .map(|b| lm.block(x, b)),
        );
        cost.smallest_denominator(i, &params)
            .is_some_and(|q| q <= POLE_WALL)
    })
}

/// The damping policy to retry a solve with: Marquardt's for the additive and hybrid policies,
/// the hybrid one for Marquardt's.
fn other_damping(damping: DampingPolicy) -> Option<DampingPolicy> {
    match damping {
        DampingPolicy::Marquardt { .. } => Some(DampingPolicy::hybrid()),
        DampingPolicy::Additive { .. } | DampingPolicy::Hybrid { .. } => {
            Some(DampingPolicy::marquardt())
        }
        _ => None,
    }
}

fn solve_with<R: RotationParameterization>(
    problem: &JointProblem,
    options: &SolveOptions,
    normalization: Option<BoardNormalization>,
    user: &JointProblem,
    floor: Option<f64>,
) -> Result<JointSolution, CalibrationError> {
    let (lm, blocks) = build(problem, options)?;
    let used = problem.num_used_points();
    let free = lm.num_free_parameters();
    if 2 * used <= free {
        return Err(CalibrationError::TooFewObservations {
            residuals: 2 * used,
            parameters: free,
        });
    }
    let cost = JointCost::<R>::new(problem);
    let x_start = start::<R>(problem, &lm, &blocks);
    let mut x = x_start.clone();
    let mut solver =
        Solver::new(lm, options.solver.clone()).map_err(|e| solver_error(problem, e))?;
    let mut report = solver
        .solve(&cost, &mut x)
        .map_err(|e| solver_error(problem, e))?;
    // A rational lens model's path can end against one of its poles (see `stopped_at_pole`):
    // not a minimum. The other damping policy's path from the same start is tried once; its
    // result replaces the first only if it does not end at a pole as well.
    if let Some(damping) = other_damping(options.solver.damping)
        && stopped_at_pole(&cost, solver.problem(), &x)
    {
        let mut retry_options = options.solver.clone();
        retry_options.damping = damping;
        let mut retry = Solver::new(solver.problem().clone(), retry_options)
            .map_err(|e| solver_error(problem, e))?;
        let mut retry_x = x_start;
        let retry_report = retry
            .solve(&cost, &mut retry_x)
            .map_err(|e| solver_error(problem, e))?;
        if !stopped_at_pole(&cost, retry.problem(), &retry_x) {
            solver = retry;
            x = retry_x;
            report = report.followed_by(retry_report);
        }
    }
    // Zero-weight points count as residuals for the solver but carry no information: rescale
    // the variance to the points actually used.
    let all_rows = solver.problem().num_residuals();
    let used_rows = 2 * used;
    let dof_scale = (all_rows - free) as f64 / (used_rows - free) as f64;
    let mut undetermined = Vec::new();
    let covariance = if options.compute_uncertainty {
        let is_distortion =
            |&(b, c): &(ParameterBlockId, usize)| c >= 4 && blocks.cameras.contains(&b);
        match solver.covariance(&cost, &x) {
            Ok(c) => Some(c),
            // Distortion terms the data does not separate (a rational model on a narrow lens):
            // a result with those terms reported, not a refusal of the whole calibration.
            Err(CovarianceError::RankDeficient { weakest, .. })
                if !weakest.is_empty() && weakest.iter().all(is_distortion) =>
            {
                let c = solver
                    .covariance_floored(&cost, &x)
                    .map_err(|e| user_error(problem, &blocks, e))?;
                if !c.floored.iter().all(is_distortion) {
                    return Err(user_error(
                        problem,
                        &blocks,
                        CovarianceError::RankDeficient {
                            rank: 0,
                            dimension: 0,
                            weakest: c.floored.clone(),
                        },
                    ));
                }
                for &(b, component) in &c.floored {
                    if let Some(camera) = blocks.cameras.iter().position(|&x| x == b) {
                        undetermined.push((camera, component));
                    }
                }
                Some(c)
            }
            Err(e) => return Err(user_error(problem, &blocks, e)),
        }
    } else {
        None
    };
    let lm = solver.problem();
    let std_of = |b: ParameterBlockId| -> Vec<f64> {
        match &covariance {
            Some(c) => c
                .standard_deviations(b)
                .into_iter()
                .map(|s| s * dof_scale.sqrt())
                .collect(),
            None => vec![0.0; lm.tangent_dim(b)],
        }
    };
    let six = |v: Vec<f64>| -> [f64; 6] { v.try_into().unwrap_or([0.0; 6]) };

    // Cameras, with the effective focal lengths.
    let raw_params: Vec<&[f64]> = blocks.cameras.iter().map(|&b| lm.block(&x, b)).collect();
    let mut cameras = Vec::with_capacity(problem.cameras.len());
    let mut camera_std = Vec::with_capacity(problem.cameras.len());
    let mut camera_covariance = Vec::with_capacity(problem.cameras.len());
    for (c, spec) in problem.cameras.iter().enumerate() {
        let source = spec.focal_from.map(|s| raw_params[s]);
        let params = cost.camera_params(c, raw_params[c], source);
        cameras.push(
            AnyCamera::from_params(spec.model(), &params)
                .map_err(|e| CalibrationError::Diverged(e.to_string()))?,
        );
        let mut std = std_of(blocks.cameras[c]);
        if let Some(s) = spec.focal_from {
            let src = std_of(blocks.cameras[s]);
            let r = problem.cameras[s].aspect_ratio;
            std[0] = src[0];
            std[1] = r.map_or(src[1], |r| src[0] / r);
        } else if let Some(r) = spec.aspect_ratio {
            std[1] = std[0] / r;
        }
        camera_std.push(std);
        camera_covariance.push(
            covariance
                .as_ref()
                .and_then(|cov| cov.block(blocks.cameras[c]))
                .map(|m| m * dof_scale),
        );
    }
    let mut rig = Vec::with_capacity(problem.cameras.len());
    let mut rig_params = Vec::new();
    let mut rig_std = Vec::new();
    for b in &blocks.rigs {
        match b {
            Some(b) => {
                let mut p = six(lm.block(&x, *b).to_vec());
                let mut std = six(std_of(*b));
                if let Some(n) = &normalization {
                    for i in 3..6 {
                        p[i] *= n.scale;
                        std[i] *= n.scale;
                    }
                }
                rig.push(Pose::from_params::<R>(&Vector6::from(p)));
                rig_params.push(p);
                rig_std.push(std);
            }
            None => {
                rig.push(Pose::identity());
                rig_params.push([0.0; 6]);
                rig_std.push([0.0; 6]);
            }
        }
    }
    let mut frames = Vec::new();
    let mut frame_params = Vec::new();
    let mut frame_std = Vec::new();
    for &b in &blocks.frames {
        let mut p = six(lm.block(&x, b).to_vec());
        let mut std = six(std_of(b));
        if let Some(n) = &normalization {
            let covariance = covariance
                .as_ref()
                .and_then(|c| c.block(b))
                .map(|c| c * dof_scale);
            (p, std) = denormalize_frame::<R>(n, p, covariance.as_ref());
        }
        frames.push(Pose::from_params::<R>(&Vector6::from(p)));
        frame_params.push(p);
        frame_std.push(std);
    }
    // One streaming pass over the points (storing every error would cost more in fresh memory
    // than computing it): per-observation sums, and for outlier rejection a strided sample of
    // the error norms per camera and the points above the floor.
    let n_cam = problem.cameras.len();
    let mut per_camera = vec![0usize; n_cam];
    for o in &problem.observations {
        per_camera[o.camera] += o.object.len();
    }
    let strides: Vec<usize> = per_camera
        .iter()
        .map(|&n| n.div_ceil(outliers::MEDIAN_SAMPLE).max(1))
        .collect();
    let mut counters = vec![0usize; n_cam];
    let mut noise_sample = vec![Vec::new(); if floor.is_some() { n_cam } else { 0 }];
    let mut outlier_candidates = Vec::new();
    let mut candidate_sum_sq = 0.0;
    let floor_sq = floor.map(|f| f * f);
    let mut errors = Vec::with_capacity(problem.observations.len());
    let mut buffer = Vec::new();
    let mut weighted = 0.0;
    let mut radial_bands = vec![[(0.0, 0usize); RADIAL_BANDS]; n_cam];
    // Principal point and farthest image corner's distance from it, per camera.
    let centres: Vec<(Vector2<f64>, f64)> = problem
        .cameras
        .iter()
        .zip(&cameras)
        .map(|(spec, camera)| {
            let k = camera.intrinsics;
            let (w, h) = (
                f64::from(spec.image_size.width) - 0.5,
                f64::from(spec.image_size.height) - 0.5,
            );
            let far = (k.cx + 0.5).max(w - k.cx).hypot((k.cy + 0.5).max(h - k.cy));
            (Vector2::new(k.cx, k.cy), far)
        })
        .collect();
    for (i, o) in problem.observations.iter().enumerate() {
        let params: Vec<&[f64]> = lm
            .residual_blocks_of(lm_solver::ResidualBlockId(i))
            .map(|b| lm.block(&x, b))
            .collect();
        cost.reprojection_errors_into(i, &params, &mut buffer)
            .map_err(|e| CalibrationError::Diverged(e.message))?;
        let user_weights = user.observations[i].weights.as_deref();
        let mut s = ObservationErrors::default();
        for (k, e) in buffer.iter().enumerate() {
            let sq = e.norm_squared();
            s.all += 1;
            s.all_sum_sq += sq;
            let w = o.weights.as_ref().map_or(1.0, |w| w[k]);
            if w > 0.0 {
                s.used += 1;
                s.sum_sq += sq;
                s.sum += e;
                s.sum_sq_xy += e.component_mul(e);
                weighted += w * sq;
                let (centre, far) = centres[o.camera];
                let d = o.pixels[k] - centre;
                let r = d.norm();
                if r > 0.0 && far > 0.0 {
                    let band = ((r / far * RADIAL_BANDS as f64) as usize).min(RADIAL_BANDS - 1);
                    let entry = &mut radial_bands[o.camera][band];
                    entry.0 += e.dot(&d) / r;
                    entry.1 += 1;
                }
            }
            if let Some(floor_sq) = floor_sq
                && user_weights.is_none_or(|w| w[k] > 0.0)
            {
                let c = o.camera;
                if counters[c].is_multiple_of(strides[c]) {
                    noise_sample[c].push(sq.sqrt());
                }
                counters[c] += 1;
                candidate_sum_sq += sq;
                // Not `sq > floor_sq`: a NaN error is a candidate too.
                let below = sq <= floor_sq;
                if !below {
                    outlier_candidates.push((i, k, sq.sqrt()));
                }
            }
        }
        errors.push(s);
    }
    let initial_cost = report.initial_cost;
    let optimization_time = report.total_time;
    let solution = JointSolution {
        cameras,
        camera_std,
        camera_covariance,
        rig,
        rig_params,
        rig_std,
        frames,
        frame_params,
        frame_std,
        errors,
        report,
        residual_variance: weighted / (used_rows - free) as f64,
        rotation: options.rotation,
        rejected: vec![Vec::new(); problem.observations.len()],
        outlier_rounds: 0,
        total_iterations: 0,
        optimization_time,
        initial_cost,
        warnings: Vec::new(),
        noise_sample,
        candidate_sum_sq,
        outlier_candidates,
        undetermined,
        radial_bands,
    };
    check_finite(&solution)?;
    Ok(solution)
}

fn check_finite(s: &JointSolution) -> Result<(), CalibrationError> {
    let mut ok = s.residual_variance.is_finite();
    for (camera, std) in s.cameras.iter().zip(&s.camera_std) {
        ok &= camera.params().iter().chain(std).all(|v| v.is_finite());
    }
    for v in s
        .rig_params
        .iter()
        .chain(&s.rig_std)
        .chain(&s.frame_params)
        .chain(&s.frame_std)
    {
        ok &= v.iter().all(|v| v.is_finite());
    }
    if ok {
        Ok(())
    } else {
        Err(CalibrationError::Diverged(
            "a parameter or its uncertainty is not finite".into(),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::{CameraSpec, ObservationSpec};
    use crate::synthetic::{SyntheticConfig, add_noise, generate, project_inside};
    use camera_model::AxisAngle;
    use lm_solver::Rng;
    use nalgebra::Matrix3;

    /// Three cameras in a row, 30 mm apart, and 12 frames (camera 2 sees only the even ones),
    /// 0.2 px of noise; camera 1's view of frame 3 has three corners 42 px off. Returns the
    /// problem (started at the truth), the true frame poses, that view's index and its spoiled
    /// points.
    fn three_cameras() -> (JointProblem, Vec<Pose>, usize, Vec<usize>) {
        let config = SyntheticConfig {
            views: 12,
            seed: 3,
            ..Default::default()
        };
        let set = generate(&config).unwrap();
        let rig: Vec<Pose> = (0..3)
            .map(|c| {
                Pose::new(
                    Matrix3::identity(),
                    Vector3::new(-30.0 * c as f64, 0.0, 0.0),
                )
            })
            .collect();
        let mut rng = Rng::new(7);
        let mut observations = Vec::new();
        for (f, pose) in set.poses.iter().enumerate() {
            for (c, rig) in rig.iter().enumerate() {
                let board = &set.views[f].object_points;
                let seen =
                    project_inside(&set.camera, &rig.compose(pose), board, set.image_size, 5.0);
                let Some(pixels) = seen.filter(|_| c != 2 || f % 2 == 0) else {
                    continue;
                };
                let pixels = add_noise(pixels, 0.2, &mut rng);
                observations.push(ObservationSpec::new(
                    c,
                    f,
                    format!("frame {f}, camera {c}"),
                    board.clone(),
                    pixels.iter().map(|p| p.coords).collect(),
                ));
            }
        }
        let spoiled = observations
            .iter()
            .position(|o| o.frame == 3 && o.camera == 1)
            .unwrap();
        let moved = vec![4, 22, 40];
        for (&i, (dx, dy)) in moved
            .iter()
            .zip([(30.0, 30.0), (-30.0, 30.0), (30.0, -30.0)])
        {
            observations[spoiled].pixels[i] += Vector2::new(dx, dy);
        }
        let cameras = (0..3)
            .map(|c| CameraSpec::new(format!("cam{c}"), set.image_size, set.camera.clone()))
            .collect();
        let problem = JointProblem {
            cameras,
            reference: 0,
            rig,
            rig_fixed: vec![true, false, false],
            frames: set.poses.clone(),
            frame_names: (0..12).map(|f| format!("frame {f}")).collect(),
            observations,
        };
        (problem, set.poses, spoiled, moved)
    }

    /// A frame with a view past the limit at a pose tilted the wrong way is refitted alone,
    /// with the cameras and the rig held (camera 0's clean view of it counts too, camera 2 does
    /// not see it): the pose returns to the truth and only the stray corners stay marked.
    #[test]
    fn a_frame_past_the_limit_is_refitted_with_the_cameras_held() {
        let (problem, truth, spoiled, moved) = three_cameras();
        let members: Vec<usize> = (0..problem.observations.len())
            .filter(|&o| problem.observations[o].frame == 3)
            .collect();
        assert_eq!(members.len(), 2);
        let options = SolveOptions::default();
        let solution = solve(&problem, &options).unwrap();
        assert_eq!(solution.rejected[spoiled], moved);
        // The board of frame 3 tilted the other way about its centre: its normal mirrored
        // about the line of sight, the pose that a small, distant board nearly allows too.
        let mut pulled = solution.clone();
        let pose = solution.frames[3];
        let centre = pose.rotation * Vector3::new(100.0, 62.5, 0.0) + pose.translation;
        let sight = centre.normalize();
        let normal = pose.rotation.column(2).into_owned();
        let mirrored = 2.0 * normal.dot(&sight) * sight - normal;
        let axis = normal.cross(&mirrored);
        let turn = AxisAngle::matrix(&(axis.normalize() * normal.angle(&mirrored)));
        pulled.frames[3] = Pose::new(
            turn * pose.rotation,
            turn * (pose.translation - centre) + centre,
        );
        let mut marked = vec![Vec::new(); problem.observations.len()];
        marked[spoiled] = (0..54).collect();
        let rejection = OutlierRejection::default();
        let refit = refit_poses(&problem, &pulled, &marked, &rejection, &options).unwrap();
        assert_eq!(refit.frames.len(), 1);
        let (frame, pose) = refit.frames[0];
        assert_eq!(frame, 3);
        let angle = AxisAngle::from_matrix(&(truth[3].rotation.transpose() * pose.rotation)).norm();
        let shift = (truth[3].translation - pose.translation).norm();
        assert!(angle < 5e-3 && shift < 3.0, "{angle} rad, {shift} mm");
        for (o, m) in &refit.marked {
            let expected = if *o == spoiled {
                moved.clone()
            } else {
                Vec::new()
            };
            assert_eq!(*m, expected, "observation {o}");
        }
        // Nothing past the limit: nothing refitted.
        let none = refit_poses(
            &problem,
            &solution,
            &solution.rejected,
            &rejection,
            &options,
        );
        assert!(none.unwrap().frames.is_empty());
    }
}
