//! One camera from its views: input checks, homographies, the closed-form start and the
//! single-camera [`JointProblem`]. The single-camera front end solves it as the calibration; the
//! stereo and rig front ends solve it per camera to start their joint problem.
//!
//! Walk-through with formulas: `docs/calib-single.md`.

use crate::data::{ImageSize, View};
use crate::diagnostics::{check_inside_image, duplicate_views};
use crate::error::{CalibrationError, PointKind};
use crate::init::{
    FISHEYE_POSE_MIN_POINTS, FISHEYE_SCORING_POINTS, FISHEYE_SCORING_VIEWS, ScoringCamera,
    StartMethod, fisheye_pose, fisheye_search, initial_pose, scoring_views, start_intrinsics,
};
use crate::options::CalibrationOptions;
use crate::problem::{BoardNormalization, CameraSpec, JointProblem, ObservationSpec};
use crate::result::SkippedView;
use crate::solve::JointSolution;
use crate::warnings::Warning;
use camera_model::{AnyCamera, CameraModel, Intrinsics, Pose};
use lm_solver::DampingPolicy;
use nalgebra::{Matrix3, Point2, Point3, Vector2, Vector3};
use std::time::{Duration, Instant};

/// Relative tolerance on `|Z|` for "on the plane": rounding of board coordinates (written in
/// decimal, e.g. 24.23 mm squares) is far below it, a real out-of-plane point far above.
pub const PLANARITY_TOLERANCE: f64 = 1e-9;

/// Checks one view's points: counts, finiteness and planarity. `index` is the view's index in
/// the user's input (for messages).
pub fn check_view(index: usize, view: &View) -> Result<(), CalibrationError> {
    let (n_obj, n_img) = (view.object_points.len(), view.image_points.len());
    if n_obj != n_img {
        return Err(CalibrationError::PointCountMismatch {
            view: index,
            object: n_obj,
            image: n_img,
        });
    }
    if n_obj < 4 {
        return Err(CalibrationError::TooFewPoints {
            view: index,
            found: n_obj,
        });
    }
    let mut extent = 0.0f64;
    for (point, (o, m)) in view
        .object_points
        .iter()
        .zip(&view.image_points)
        .enumerate()
    {
        if !(o.x.is_finite() && o.y.is_finite() && o.z.is_finite()) {
            return Err(CalibrationError::NonFinite {
                view: index,
                point,
                kind: PointKind::Object,
            });
        }
        if !(m.x.is_finite() && m.y.is_finite()) {
            return Err(CalibrationError::NonFinite {
                view: index,
                point,
                kind: PointKind::Image,
            });
        }
        extent = extent.max(o.x.abs()).max(o.y.abs());
    }
    let tolerance = PLANARITY_TOLERANCE * extent.max(f64::MIN_POSITIVE);
    if let Some((point, o)) = view
        .object_points
        .iter()
        .enumerate()
        .find(|(_, o)| o.z.abs() > tolerance)
    {
        return Err(CalibrationError::NotPlanar {
            view: index,
            point,
            z: o.z,
        });
    }
    Ok(())
}

/// A view's board points and pixels.
type PointLists = (Vec<Point3<f64>>, Vec<Point2<f64>>);

/// One camera ready to be solved: its usable views, their homographies and the start.
#[derive(Debug, Clone)]
pub struct PreparedCamera {
    /// Image size.
    pub image_size: ImageSize,
    /// Index in the input and name of each used view, in order.
    pub views: Vec<(usize, String)>,
    /// The used views as observations of camera 0, frame `k` for the `k`-th used view.
    pub observations: Vec<ObservationSpec>,
    /// Views left out by `skip_bad_views`.
    pub skipped: Vec<SkippedView>,
    /// The homography (board plane to pixels) of each used view.
    pub homographies: Vec<Matrix3<f64>>,
    /// Closed-form (or given) intrinsics with the initial distortion.
    pub initial: AnyCamera,
    /// Where the initial intrinsics came from.
    pub start_method: StartMethod,
    /// Closed-form board-to-camera pose of each used view.
    pub initial_poses: Vec<Pose>,
    /// Fixed components of the camera block `[fx, fy, cx, cy, distortion...]`.
    pub fixed: Vec<usize>,
    /// `fx / fy` when the aspect ratio is fixed.
    pub aspect_ratio: Option<f64>,
    /// Time spent on checks and homographies, and on the closed-form start.
    pub times: (Duration, Duration),
    /// What the preparation noticed (duplicate views left out).
    pub warnings: Vec<Warning>,
    /// True when the start is the minimum of a simpler nested model (a rational model started
    /// from the `brown-conrady5` solution): a warm start, see [`PreparedCamera::solve_options`].
    pub warm_start: bool,
}

/// Indices of the camera block `[fx, fy, cx, cy, distortion...]` held fixed by `options` for a
/// calibration with `num_views` views (sorted, unique).
pub fn fixed_camera_components(options: &CalibrationOptions, num_views: usize) -> Vec<usize> {
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
        fixed.extend(options.model.tangential_params().iter().map(|i| 4 + i));
    }
    fixed.extend(options.fixed_distortion.iter().map(|i| 4 + i));
    fixed.sort_unstable();
    fixed.dedup();
    fixed
}

/// Names of the camera block's components for `model`: `fx, fy, cx, cy` and the distortion's.
pub fn camera_param_names(model: CameraModel) -> Vec<&'static str> {
    let mut names = vec!["fx", "fy", "cx", "cy"];
    names.extend_from_slice(model.distortion_names());
    names
}

fn check_options(options: &CalibrationOptions) -> Result<(), CalibrationError> {
    let n = options.model.num_distortion_params();
    if let Some(&i) = options.fixed_distortion.iter().find(|&&i| i >= n) {
        return Err(CalibrationError::InvalidOption(format!(
            "distortion index {i} out of range: the model {} has {n} coefficients",
            options.model
        )));
    }
    if let Some(d) = &options.distortion_guess
        && (d.len() != n || d.iter().any(|v| !v.is_finite()))
    {
        return Err(CalibrationError::InvalidOption(format!(
            "distortion guess must have {n} finite coefficients for the model {}",
            options.model
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

/// Checks the views, estimates their homographies and computes the closed-form start: the
/// principal point at the image centre, square pixels and the focal length from the
/// orthogonality of the board's axes (unless `options.intrinsic_guess`), distortion zero (or
/// `options.distortion_guess`), and one pose per view from `K^-1 H`.
///
/// `views` pairs each view with its index in the user's input, which errors and skipped views
/// name. With `options.skip_bad_views`, views that fail the checks or whose homography cannot be
/// estimated are listed in [`PreparedCamera::skipped`] instead of failing.
pub fn prepare_camera(
    views: &[(usize, &View)],
    image_size: Option<ImageSize>,
    options: &CalibrationOptions,
) -> Result<PreparedCamera, CalibrationError> {
    let start = Instant::now();
    let image_size = image_size.ok_or(CalibrationError::ImageSizeMissing)?;
    if image_size.width == 0 || image_size.height == 0 {
        return Err(CalibrationError::InvalidImageSize {
            width: image_size.width,
            height: image_size.height,
        });
    }
    check_options(options)?;
    // The start (homographies, closed form, poses) sees a board whose origin lies far outside
    // it re-centred, as the solver does (`JointProblem::board_normalization`): 20 m away from a
    // 0.2 m board, the homography's last column dwarfs the others and the closed form lost the
    // focal length.
    let out_of_scale = boards_out_of_scale(views);
    let in_scale: Vec<(usize, &View)> = views
        .iter()
        .enumerate()
        .filter(|(k, _)| out_of_scale[*k].is_none())
        .map(|(_, v)| *v)
        .collect();
    let offset = board_offset(&in_scale);
    let centred: Vec<View> = match offset {
        Some(c) => views
            .iter()
            .map(|(_, v)| View {
                name: v.name.clone(),
                object_points: v.object_points.iter().map(|p| p - c.coords).collect(),
                image_points: v.image_points.clone(),
            })
            .collect(),
        None => Vec::new(),
    };
    let mut used = Vec::new();
    let mut homographies = Vec::new();
    let mut inliers = Vec::new();
    let mut skipped = Vec::new();
    for (k, &(index, original)) in views.iter().enumerate() {
        let view = centred.get(k).unwrap_or(original);
        let result = check_view(index, original)
            .and_then(|()| out_of_scale[k].clone().map_or(Ok(()), Err))
            .and_then(|()| check_inside_image(index, original, image_size))
            .and_then(|()| {
                let object: Vec<Point2<f64>> = view
                    .object_points
                    .iter()
                    .map(|p| Point2::new(p.x, p.y))
                    .collect();
                // Through a fisheye lens a board is far from a homography of its pixels: the
                // robust fit would call its edge corners outliers. Its start does not use the
                // pixel homography's inliers; the model's outlier rejection still applies.
                let estimate = if options.model.is_fisheye() {
                    homography::estimate(&object, &view.image_points, &options.homography).map(
                        |e| homography::RobustEstimate {
                            estimate: e,
                            inliers: vec![true; object.len()],
                            num_inliers: object.len(),
                        },
                    )
                } else {
                    homography::estimate_robust(
                        &object,
                        &view.image_points,
                        &options.homography,
                        &options.robust_homography,
                    )
                };
                estimate.map_err(|source| CalibrationError::Homography {
                    view: index,
                    source,
                })
            });
        match result {
            Ok(r) => {
                used.push((index, view));
                homographies.push(r.estimate.h);
                inliers.push((r.num_inliers < r.inliers.len()).then_some(r.inliers));
            }
            Err(e) if options.skip_bad_views => skipped.push(SkippedView {
                index,
                name: view.name.clone(),
                reason: e.detail(),
            }),
            Err(e) => return Err(e),
        }
    }
    if used.is_empty() {
        return Err(CalibrationError::NoViews {
            skipped: skipped.len(),
        });
    }
    let mut warnings = Vec::new();
    let duplicates = if !options.drop_duplicate_views {
        Vec::new()
    } else {
        let views: Vec<&View> = used.iter().map(|(_, v)| *v).collect();
        duplicate_views(&views, &homographies)
    };
    if !duplicates.is_empty() {
        let numbered: Vec<(usize, usize)> = duplicates
            .iter()
            .map(|&(copy, original)| (used[copy].0, used[original].0))
            .collect();
        warnings.push(crate::diagnostics::duplicates_warning("view", &numbered));
        let mut drop = vec![false; used.len()];
        for &(copy, _) in &duplicates {
            drop[copy] = true;
        }
        let mut k = 0;
        used.retain(|_| {
            k += 1;
            !drop[k - 1]
        });
        let mut k = 0;
        homographies.retain(|_| {
            k += 1;
            !drop[k - 1]
        });
        let mut k = 0;
        inliers.retain(|_| {
            k += 1;
            !drop[k - 1]
        });
    }
    // The start uses the points that agree with their view's homography.
    let start_points: Vec<PointLists> = used
        .iter()
        .zip(&inliers)
        .filter_map(|((_, v), keep)| {
            keep.as_ref().map(|keep| {
                let pick = |i: &usize| keep[*i];
                (
                    (0..keep.len())
                        .filter(pick)
                        .map(|i| v.object_points[i])
                        .collect(),
                    (0..keep.len())
                        .filter(pick)
                        .map(|i| v.image_points[i])
                        .collect(),
                )
            })
        })
        .collect();
    let mut filtered = start_points.iter();
    let start_views: Vec<crate::init::ViewPoints<'_>> = used
        .iter()
        .zip(&inliers)
        .map(|((_, v), keep)| match keep {
            Some(_) => {
                let (o, m) = filtered.next().expect("one filtered view per suspect mask");
                (o.as_slice(), m.as_slice())
            }
            None => (v.object_points.as_slice(), v.image_points.as_slice()),
        })
        .collect();
    let homographies_done = Instant::now();

    let fisheye = options.model.is_fisheye();
    let (intrinsics, start_method) = match options.intrinsic_guess {
        Some(guess) => (guess, StartMethod::Given),
        // A fisheye lens is far from a pinhole: search the focal length of an equidistant camera.
        None if fisheye => {
            let scoring = ScoringCamera {
                model: options.model,
                fixed: fixed_camera_components(options, used.len()),
            };
            // Views with too few points for a fisheye pose would make every focal length's
            // score infinite; they get their start pose from the homography below.
            let (scoring_h, scoring_points): (Vec<_>, Vec<_>) = homographies
                .iter()
                .zip(&start_views)
                .filter(|(_, (object, _))| object.len() >= FISHEYE_POSE_MIN_POINTS)
                .map(|(h, v)| (*h, *v))
                .unzip();
            let mut views = scoring_views(&scoring_h, &scoring_points, FISHEYE_SCORING_POINTS);
            views.truncate(FISHEYE_SCORING_VIEWS);
            if views.is_empty() {
                return Err(CalibrationError::Initialization {
                    reason: format!(
                        "the fisheye start needs views with at least {FISHEYE_POSE_MIN_POINTS} points, and no view has that many"
                    ),
                });
            }
            let f = fisheye_search(image_size, &scoring, &views).ok_or_else(|| {
                CalibrationError::Initialization {
                    reason: "no focal length of an equidistant (fisheye) camera explains the views: are the points and the image size right?".into(),
                }
            })?;
            let (cx, cy) = image_size.centre();
            (Intrinsics::new(f, f, cx, cy), StartMethod::FisheyeSearch)
        }
        None => {
            let scoring = ScoringCamera {
                model: options.model,
                fixed: fixed_camera_components(options, used.len()),
            };
            start_intrinsics(
                &homographies,
                &start_views,
                image_size,
                &scoring,
                options.focal_init,
            )?
        }
    };
    let mut distortion = options
        .distortion_guess
        .clone()
        .unwrap_or_else(|| vec![0.0; options.model.num_distortion_params()]);
    if options.zero_tangential_distortion {
        for &i in options.model.tangential_params() {
            distortion[i] = 0.0;
        }
    }
    let initial = AnyCamera::new(options.model, intrinsics, distortion)
        .map_err(|e| CalibrationError::InvalidOption(e.to_string()))?;
    let mut initial_poses = Vec::with_capacity(used.len());
    for ((&(index, view), h), (object, image)) in used.iter().zip(&homographies).zip(&start_views) {
        let fisheye_start = fisheye
            .then(|| {
                let pixels: Vec<Vector2<f64>> = image.iter().map(|p| p.coords).collect();
                let k = &intrinsics;
                fisheye_pose(k.fx, k.cx, k.cy, object, &pixels)
            })
            .flatten();
        let pose = fisheye_start
            .or_else(|| initial_pose(h, &intrinsics, object))
            .ok_or_else(|| CalibrationError::Initialization {
                reason: format!("view {index}: no pose from its homography"),
            })?;
        // A fisheye lens sees points beside and behind its optical centre's plane.
        if let Some(point) = view
            .object_points
            .iter()
            .position(|x| pose.transform_point(x).z <= 0.0)
            .filter(|_| object.len() == view.object_points.len() && !fisheye)
        {
            return Err(CalibrationError::PointBehindCamera { view: index, point });
        }
        // Back to the user's board origin: X_cam = R (X - c) + t' = R X + (t' - R c).
        initial_poses.push(match offset {
            Some(c) => Pose::new(pose.rotation, pose.translation - pose.rotation * c.coords),
            None => pose,
        });
    }
    // The problem keeps the user's board points (the solver re-centres on its own).
    let original = |index: usize| {
        views.iter().find(|(i, _)| *i == index).map_or_else(
            || unreachable!("a used view comes from `views`"),
            |(_, v)| *v,
        )
    };
    let fixed = fixed_camera_components(options, used.len());
    let mut prepared = PreparedCamera {
        image_size,
        aspect_ratio: options
            .fix_aspect_ratio
            .then(|| intrinsics.fx / intrinsics.fy),
        observations: used
            .iter()
            .zip(inliers)
            .enumerate()
            .map(|(k, ((index, view), keep))| {
                let mut o = ObservationSpec::new(
                    0,
                    k,
                    view.name.clone(),
                    original(*index).object_points.clone(),
                    view.image_points.iter().map(|p| p.coords).collect(),
                );
                o.suspected = keep.map(|keep| keep.iter().map(|k| !k).collect());
                o
            })
            .collect(),
        views: used.iter().map(|(i, v)| (*i, v.name.clone())).collect(),
        skipped,
        homographies,
        initial,
        start_method,
        initial_poses,
        fixed,
        times: (homographies_done - start, homographies_done.elapsed()),
        warnings,
        warm_start: false,
    };
    if options.distortion_guess.is_none() {
        prepared.start_from_simpler_model()?;
    }
    Ok(prepared)
}

/// The point the start re-centres the board on, if its origin lies far outside it: the
/// centroid of every view's board points when it is more than three RMS board sizes from the
/// origin (the rule of `JointProblem::board_normalization`); `None` for ordinary boards, whose
/// start is computed exactly as given.
/// Views may differ in extent by this factor (partial boards, another board) before one is
/// called out of scale.
const BOARD_SCALE_LIMIT: f64 = 1e6;

/// [`CalibrationError::BoardOutOfScale`] for each view whose board points span more than
/// [`BOARD_SCALE_LIMIT`] times the median view's extent, or whose centroid lies that far from
/// the median of the centroids (per coordinate; the distance is the largest coordinate
/// difference); `None` for the others, and for every view when
/// there are fewer than three or the median extent is zero. Non-finite points are left to
/// `check_view`. Cost `O(points + views log views)`.
fn boards_out_of_scale(views: &[(usize, &View)]) -> Vec<Option<CalibrationError>> {
    let stats: Vec<Option<(Vector3<f64>, f64)>> = views
        .iter()
        .map(|(_, v)| {
            let points: Vec<&Point3<f64>> = v
                .object_points
                .iter()
                .filter(|p| p.coords.iter().all(|c| c.is_finite()))
                .collect();
            if points.is_empty() {
                return None;
            }
            let (mut lo, mut hi) = (points[0].coords, points[0].coords);
            let mut sum = Vector3::zeros();
            for p in &points {
                lo = lo.inf(&p.coords);
                hi = hi.sup(&p.coords);
                sum += p.coords / points.len() as f64;
            }
            Some((sum, (hi - lo).max()))
        })
        .collect();
    let mut none = vec![None; views.len()];
    let known: Vec<&(Vector3<f64>, f64)> = stats.iter().flatten().collect();
    if known.len() < 3 {
        return none;
    }
    let median = |mut values: Vec<f64>| {
        values.sort_by(f64::total_cmp);
        values[values.len() / 2]
    };
    let typical = median(known.iter().map(|s| s.1).collect());
    let centre = Vector3::from_fn(|i, _| median(known.iter().map(|s| s.0[i]).collect()));
    if !(typical > 0.0 && typical.is_finite()) {
        return none;
    }
    for (k, s) in stats.iter().enumerate() {
        let Some((centroid, extent)) = s else {
            continue;
        };
        // The largest coordinate difference (a Euclidean norm would square 1e308 into
        // infinity); an overflowing difference is out of scale too.
        let distance = (centroid - centre).amax();
        if *extent > BOARD_SCALE_LIMIT * typical || distance > BOARD_SCALE_LIMIT * typical {
            none[k] = Some(CalibrationError::BoardOutOfScale {
                view: views[k].0,
                extent: *extent,
                distance,
                typical,
            });
        }
    }
    none
}

fn board_offset(views: &[(usize, &View)]) -> Option<Point3<f64>> {
    BoardNormalization::measure(views.iter().flat_map(|(_, v)| &v.object_points))
        .filter(BoardNormalization::origin_is_far)
        // Only in the board's plane: Z stays 0 for the planar start.
        .map(|n| Point3::new(n.centre.x, n.centre.y, 0.0))
}

/// The model a many-term model starts from: its terms in OpenCV's order begin with those of
/// `brown-conrady5`, so that model's solution is a point of the richer model's space.
fn simpler_model(model: CameraModel) -> Option<CameraModel> {
    match model {
        CameraModel::Rational8 | CameraModel::ThinPrism12 => Some(CameraModel::BrownConrady5),
        _ => None,
    }
}

/// The rational models' stagnation rule: 20 accepted steps that together lower the cost by at
/// most 1e-5 relative end the solve (`SolverOptions::stagnation_window`). Runaways along the
/// rational valley: such steps change the RMS by 5e-6 relative, far below the cost's own
/// sampling noise (sqrt(2 / residuals), 2.6% for 1500 points). 20 rather than 50: on the
/// 90-problem population of `calib-single/tests/models.rs` as many problems at the truth
/// start's minimum (rational8 84, thin-prism12 76 instead of 75, none at the iteration limit
/// instead of 2) in 19% and 30% fewer iterations; 10 lost 3 rational8 problems
/// (docs/benchmarks-models.md).
fn stop_stagnating(solver: &mut lm_solver::SolverOptions) {
    solver.stagnation_window = 20;
    solver.stagnation_tolerance = 1e-5;
}

/// Adapts `solver` to the joint stage of a stereo pair or rig whose cameras have the lens
/// `models` (started from each camera's own minimum): with a rational model (`rational8`,
/// `thin-prism12`) and the default damping ([`DampingPolicy::hybrid`]; a damping chosen by the
/// user is kept) the joint solve gets the stagnation rule of the single-camera solve
/// ([`PreparedCamera::solve_options`]); otherwise nothing changes.
///
/// Without it the joint stage crawled along the rational valley to the iteration limit (500
/// iterations and an `iteration-limit` warning) in 36 of 195 stereo pairs of narrow rational8
/// cameras and 14 of 196 rigs mixing `rational8` with polynomial cameras; with it in 4 and 0
/// (thin-prism12 pairs: 37 of 100 before, 9 with it).
/// Where it ends a crawl the RMS stays higher than at the crawl's end, by a median of 1e-8 px
/// (pairs) and 1e-9 px (rigs), 95th percentile 4e-4 and 8e-5 px, at most 1.1e-3 and 5.1e-3 px
/// (docs/calib-stereo.md and docs/calib-rig.md, `tests/models_population.rs` of both crates).
/// The single-camera stage's warm damping ([`DampingPolicy::marquardt_warm`]) was tried here
/// as well: it ended 102 of 195 pairs in a higher minimum than the default damping and 28 in a
/// lower one.
pub fn joint_stage_solver(
    models: impl IntoIterator<Item = CameraModel>,
    solver: &mut lm_solver::SolverOptions,
) {
    let rational = models
        .into_iter()
        .any(|m| matches!(m, CameraModel::Rational8 | CameraModel::ThinPrism12));
    if rational && solver.damping == DampingPolicy::hybrid() {
        stop_stagnating(solver);
    }
}

impl PreparedCamera {
    /// For a many-term model (rational, thin prism), replaces the start by the solution of the
    /// same views with `brown-conrady5` (the extra terms zero): from the closed form, the extra
    /// terms' freedom lets the first iterations wander into another minimum (seen on 1 problem
    /// in 60 of the convergence population); from the simpler model's minimum they only refine
    /// it. Keeps the start as it is if that solve fails, except when the simpler model's
    /// intrinsics or a pose are not determined by the views: then the richer model's are not
    /// either, and that refusal ([`CalibrationError::NotDetermined`]) is returned.
    fn start_from_simpler_model(&mut self) -> Result<(), CalibrationError> {
        let model = self.initial.model;
        let Some(simple) = simpler_model(model) else {
            return Ok(());
        };
        let n = simple.num_params();
        let mut staged = self.clone();
        let Ok(camera) = AnyCamera::new(
            simple,
            self.initial.intrinsics,
            self.initial.distortion[..simple.num_distortion_params()].to_vec(),
        ) else {
            return Ok(());
        };
        staged.initial = camera;
        staged.fixed.retain(|&i| i < n);
        // With the uncertainty: data that do not determine the simpler model's intrinsics do
        // not determine the richer model's either (its Jacobian at this start holds the simpler
        // one's columns). From four near-frontal views, where brown-conrady5 is refused for its
        // focal length, rational8 went on to a degenerate fx of 8.7 px (truth 800) with a sigma
        // of 1.2 px.
        let options = crate::SolveOptions {
            outliers: None,
            camera_warnings: false,
            ..crate::SolveOptions::default()
        };
        let solution = match crate::solve(&staged.into_problem("start"), &options) {
            Ok(solution) => solution,
            Err(e @ CalibrationError::NotDetermined { .. }) => return Err(e),
            Err(_) => return Ok(()),
        };
        let solved = &solution.cameras[0];
        let mut distortion = self.initial.distortion.clone();
        distortion[..solved.distortion.len()].copy_from_slice(&solved.distortion);
        if let Ok(camera) = AnyCamera::new(model, solved.intrinsics, distortion) {
            self.initial = camera;
            self.initial_poses = solution.frames;
            self.warm_start = true;
        }
        Ok(())
    }

    /// The options to solve this camera with: `options`, except that the default damping
    /// ([`DampingPolicy::hybrid`]) becomes a warm-start policy after a warm start
    /// (`warm_start`): from the simpler model's minimum, the hybrid policy's additive phase and
    /// Marquardt's descent from `lambda = 1e-4` cost a third of a rational model's iterations.
    /// rational8 gets [`DampingPolicy::marquardt_warm`] (Marquardt's steps from `lambda = 1e-8`
    /// at once); thin-prism12, whose prism terms are nearly interchangeable with the principal
    /// point and the tangential terms, [`DampingPolicy::hybrid_warm`] (12 short additive steps
    /// first: Marquardt's at once ends it in a higher minimum on sourishg1/left) with a damping
    /// search of 3 trials (`SolverOptions::damping_search`: 4% to 12% faster on three of the
    /// bundled cameras, 2% slower on the fourth; on the population 73 of 90 problems at the truth
    /// start's minimum instead of 71; for rational8 it changed nothing on the bundled cameras
    /// and cost one population problem). Measured on the
    /// bundled cameras and the 90-problem population of `tests/models.rs`
    /// (`docs/benchmarks-models.md`). Both rational models also get the stagnation rule (20
    /// accepted steps that together lower the cost by at most 1e-5 relative end the solve,
    /// `SolverOptions::stagnation_window`; the joint stage of a pair or rig gets it too,
    /// [`joint_stage_solver`]). A damping chosen by the user is kept. After a warm start
    /// the outlier rejection also runs with every point in the first solve when the run with
    /// the suspects left out fails or rejects points
    /// ([`crate::SolveOptions::recheck_without_suspects`]).
    pub fn solve_options(&self, options: &crate::SolveOptions) -> crate::SolveOptions {
        let mut options = options.clone();
        options.recheck_without_suspects |= self.warm_start;
        if self.warm_start && options.solver.damping == DampingPolicy::hybrid() {
            options.solver.damping = match self.initial.model {
                CameraModel::Rational8 => DampingPolicy::marquardt_warm(),
                _ => DampingPolicy::hybrid_warm(),
            };
            if self.initial.model == CameraModel::ThinPrism12 {
                options.solver.damping_search = 3;
            }
            stop_stagnating(&mut options.solver);
        }
        options
    }

    /// The camera as a [`CameraSpec`] named `name`.
    pub fn camera_spec(&self, name: &str) -> CameraSpec {
        let mut spec = CameraSpec::new(name, self.image_size, self.initial.clone());
        spec.fixed = self.fixed.clone();
        spec.aspect_ratio = self.aspect_ratio;
        spec
    }

    /// The single-camera problem: one camera, one frame per used view (named "view N" after
    /// the view's input index). Clones the observations; see [`PreparedCamera::into_problem`].
    pub fn problem(&self, name: &str) -> JointProblem {
        self.clone().into_problem(name)
    }

    /// [`PreparedCamera::problem`], moving the observations instead of copying them.
    pub fn into_problem(mut self, name: &str) -> JointProblem {
        self.take_problem(name)
    }

    /// [`PreparedCamera::problem`], moving the observations and initial poses out (they are
    /// left empty) and keeping the rest of the preparation for the result.
    pub fn take_problem(&mut self, name: &str) -> JointProblem {
        JointProblem {
            cameras: vec![self.camera_spec(name)],
            reference: 0,
            rig: vec![Pose::identity()],
            rig_fixed: vec![true],
            frame_names: self
                .views
                .iter()
                .map(|(i, name)| crate::error::view_location(*i, name))
                .collect(),
            frames: std::mem::take(&mut self.initial_poses),
            observations: std::mem::take(&mut self.observations),
        }
    }

    /// The start stage of a multi-camera calibration (stereo, rig): this camera solved alone,
    /// returning its spec (start at the solution; aspect ratio re-read from it) and the solution
    /// (board pose per used view, rejected points). This stage only provides the start of the
    /// joint optimization, which refines every parameter to the full tolerance: it stops at a
    /// relative cost change of 1e-6 and skips the uncertainties.
    pub fn solve_for_start(
        self,
        name: &str,
        options: &crate::SolveOptions,
    ) -> Result<(CameraSpec, JointSolution), CalibrationError> {
        let mut spec = self.camera_spec(name);
        let mut solve = self.solve_options(options);
        solve.solver.function_tolerance = solve.solver.function_tolerance.max(1e-6);
        solve.compute_uncertainty = false;
        let solution = crate::solve(&self.into_problem(name), &solve)?;
        spec.initial = solution.cameras[0].clone();
        if let Some(r) = spec.aspect_ratio.as_mut() {
            *r = spec.initial.intrinsics.fx / spec.initial.intrinsics.fy;
        }
        Ok((spec, solution))
    }

    /// Total number of points used.
    pub fn num_points(&self) -> usize {
        self.observations.iter().map(|o| o.object.len()).sum()
    }
}
