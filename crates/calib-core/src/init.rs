//! Closed-form initial guesses: intrinsics from the homographies, then one pose per view.
//!
//! Derivations: `docs/calib-single.md`, sections "Initial intrinsics" and "Initial poses".

use crate::data::ImageSize;
use crate::error::CalibrationError;
use crate::problem::{CameraSpec, JointProblem, ObservationSpec};
use crate::solve::SolveOptions;
use camera_model::{AnyCamera, CameraModel, Intrinsics, Pose, nearest_rotation};
use nalgebra::{Matrix3, Point2, Point3, Vector2, Vector3};

/// How the common focal length is solved from the stacked orthogonality constraints `a x = b`
/// (`x = 1 / alpha^2`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FocalInit {
    /// Bouguet's choice: the `x` that makes the projection of `a x` on `b` equal to `b`,
    /// `x = <b, b> / <a, b>`.
    #[default]
    Bouguet,
    /// Ordinary least squares, `x = <a, b> / <a, a>`.
    LeastSquares,
}

/// Below this tilt measure in every view (about half the squared tilt angle in radians, so
/// ~0.8 degrees) the closed form's constraints are too weak to use; the start then comes from
/// the focal search.
pub const MIN_TILT_MEASURE: f64 = 1e-4;

/// Below this perspective measure in every view ([`perspective_measure`]: the relative depth
/// variation across the board, `1e-4` is a 0.01 degree tilt of a board spanning half its
/// distance) the boards are parallel to the image plane to rounding and the focal length is not
/// observable at all: the calibration is refused. Everything above is attempted; whether the data
/// then determine the focal length is for the covariance to say (an error if it is singular, a
/// warning if the focal length's uncertainty is large). The convergence sweep
/// (`calib-single/tests/convergence_population.rs`) draws the largest tilt per problem down to 5
/// degrees.
pub const MIN_PERSPECTIVE: f64 = 1e-4;

/// Initial intrinsics from the views' homographies (board plane to pixels, any scale): the
/// principal point at the image centre (OpenCV convention), square pixels, and the focal length
/// from the orthogonality of the board's axes and diagonals.
///
/// For each homography `H`, with `H' = [[1, 0, -cx], [0, 1, -cy], [0, 0, 1]] H`, the images of the
/// board's directions `v1 = H' (1,0,0)`, `v2 = H' (0,1,0)`, `v3 = H' (1,1,0)`, `v4 = H' (1,-1,0)`
/// (each normalized) satisfy `(v1x v2x + v1y v2y) x = -v1z v2z` and the same for `v3, v4`, with
/// `x = 1 / alpha^2`, because the pairs are orthogonal on the board.
pub fn initial_intrinsics(
    homographies: &[Matrix3<f64>],
    image_size: ImageSize,
    method: FocalInit,
) -> Result<Intrinsics, CalibrationError> {
    let (cx, cy) = image_size.centre();
    let centred = centred_homographies(homographies, image_size, 1.0);
    let alpha = square_focal(&centred, method)?;
    Ok(Intrinsics::new(alpha, alpha, cx, cy))
}

/// The homographies with the principal point moved to the origin, then `y` scaled by
/// `y_scale` (`diag(1, y_scale, 1) [[1, 0, -cx], [0, 1, -cy], [0, 0, 1]] H`).
fn centred_homographies(
    homographies: &[Matrix3<f64>],
    image_size: ImageSize,
    y_scale: f64,
) -> Vec<Matrix3<f64>> {
    let (cx, cy) = image_size.centre();
    let shift = Matrix3::new(1.0, 0.0, -cx, 0.0, y_scale, -cy * y_scale, 0.0, 0.0, 1.0);
    homographies.iter().map(|h| shift * h).collect()
}

/// The orthogonality constraints of centred homographies: per view, the board's axes and its
/// diagonals, each pair `(p, q)` normalized, as `(p.x q.x, p.y q.y, -p.z q.z)`: with square
/// pixels `(a_x + a_y) / alpha^2 = b`, with `fx != fy` `a_x / fx^2 + a_y / fy^2 = b`.
fn orthogonality_constraints(centred: &[Matrix3<f64>]) -> Vec<[f64; 3]> {
    let mut constraints = Vec::with_capacity(2 * centred.len());
    for hs in centred {
        let c1: Vector3<f64> = hs.column(0).into_owned();
        let c2: Vector3<f64> = hs.column(1).into_owned();
        for (p, q) in [(c1, c2), (c1 + c2, c1 - c2)] {
            let (p, q) = (p.normalize(), q.normalize());
            constraints.push([p.x * q.x, p.y * q.y, -p.z * q.z]);
        }
    }
    constraints
}

/// The square-pixel focal length of centred homographies (see [`initial_intrinsics`]).
fn square_focal(centred: &[Matrix3<f64>], method: FocalInit) -> Result<f64, CalibrationError> {
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    let mut tilt = 0.0f64;
    for [ax, ay, b] in orthogonality_constraints(centred) {
        let a = ax + ay;
        ab += a * b;
        aa += a * a;
        bb += b * b;
        tilt = tilt.max(b.abs());
    }
    let alpha2 = match method {
        FocalInit::Bouguet => ab / bb,
        FocalInit::LeastSquares => aa / ab,
    };
    // b is about (tilt^2 / 2) / alpha^2 once the v's are normalized, so b alpha^2 measures tilt.
    let tilt_measure = if alpha2.is_finite() && alpha2 > 0.0 {
        tilt * alpha2
    } else {
        0.0
    };
    if !(alpha2.is_finite() && alpha2 > 0.0) || tilt_measure < MIN_TILT_MEASURE {
        return Err(CalibrationError::FrontoParallel { tilt_measure });
    }
    Ok(alpha2.sqrt())
}

/// Largest relative difference of `fx` and `fy` that the start treats as square pixels.
const SQUARE_PIXELS: f64 = 0.02;

/// Initial intrinsics with `fx != fy`, for cameras whose pixels are not square (an image
/// resampled to another aspect ratio: the square-pixel closed forms then disagree). The
/// constraints `a_x u + a_y v = b` (`u = 1/fx^2`, `v = 1/fy^2`) are solved by least squares for
/// the ratio `s = fx / fy = sqrt(v / u)`; the image is rescaled by `s` in `y`, where the pixels
/// are square, and the two square-pixel forms must agree there within
/// [`CLOSED_FORM_AGREEMENT`], as they must for any camera. `None` if the pixels look square,
/// or the forms still disagree.
fn aspect_closed_form(
    homographies: &[Matrix3<f64>],
    image_size: ImageSize,
    method: FocalInit,
) -> Option<Intrinsics> {
    let constraints =
        orthogonality_constraints(&centred_homographies(homographies, image_size, 1.0));
    let (mut xx, mut xy, mut yy, mut xb, mut yb) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for [ax, ay, b] in constraints {
        xx += ax * ax;
        xy += ax * ay;
        yy += ay * ay;
        xb += ax * b;
        yb += ay * b;
    }
    let det = xx * yy - xy * xy;
    let (u, v) = ((xb * yy - yb * xy) / det, (yb * xx - xb * xy) / det);
    if !(u > 0.0 && v > 0.0 && u.is_finite() && v.is_finite()) {
        return None;
    }
    let s = (v / u).sqrt();
    if (s - 1.0).abs() <= SQUARE_PIXELS || !(0.5..=2.0).contains(&s) {
        return None;
    }
    let centred = centred_homographies(homographies, image_size, s);
    let a = square_focal(&centred, method).ok()?;
    let b = square_focal(&centred, other_method(method)).ok()?;
    if (a / b - 1.0).abs() > CLOSED_FORM_AGREEMENT {
        return None;
    }
    let (cx, cy) = image_size.centre();
    Some(Intrinsics::new(a, a / s, cx, cy))
}

fn other_method(method: FocalInit) -> FocalInit {
    match method {
        FocalInit::Bouguet => FocalInit::LeastSquares,
        FocalInit::LeastSquares => FocalInit::Bouguet,
    }
}

/// Initial pose of one view from its homography `H` (any scale) and intrinsics `K`:
/// `K^-1 H = lambda [r1 r2 t]`, with `lambda1 = |K^-1 h1|`, `lambda2 = |K^-1 h2|`,
/// `r1 = K^-1 h1 / lambda1`, `r2 = K^-1 h2 / lambda2`, `r3 = r1 x r2`,
/// `t = K^-1 h3 / ((lambda1 + lambda2) / 2)`, and `[r1 r2 r3]` replaced by the nearest rotation.
/// `H` and `-H` are the same homography; the sign is chosen so that the observed board points
/// (`points`, on `Z = 0`) are in front of the camera: their centroid has positive depth. (The
/// board origin need not be on the board, so its own depth would not do.)
pub fn initial_pose(
    h: &Matrix3<f64>,
    intrinsics: &Intrinsics,
    points: &[nalgebra::Point3<f64>],
) -> Option<Pose> {
    let k_inv = intrinsics.matrix().try_inverse()?;
    let m = k_inv * h;
    let (c1, c2, c3): (Vector3<f64>, Vector3<f64>, Vector3<f64>) = (
        m.column(0).into_owned(),
        m.column(1).into_owned(),
        m.column(2).into_owned(),
    );
    let (l1, l2) = (c1.norm(), c2.norm());
    if !(l1 > 0.0 && l2 > 0.0 && l1.is_finite() && l2.is_finite()) {
        return None;
    }
    let r1 = c1 / l1;
    let r2 = c2 / l2;
    let mut t = c3 / ((l1 + l2) / 2.0);
    let mut r = nearest_rotation(&Matrix3::from_columns(&[r1, r2, r1.cross(&r2)]))?;
    let centroid = if points.is_empty() {
        Vector3::zeros()
    } else {
        points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / points.len() as f64
    };
    if (r * centroid + t).z < 0.0 {
        // H had the opposite sign: -r1, -r2, -t is the same homography; r3 = r1 x r2 is unchanged.
        r.column_mut(0).neg_mut();
        r.column_mut(1).neg_mut();
        t = -t;
    }
    t.iter().all(|v| v.is_finite()).then_some(Pose::new(r, t))
}

/// Where the initial intrinsics came from (`initial.method` in results).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum StartMethod {
    /// Given by the caller (`intrinsic_guess`).
    Given,
    /// The closed form from the homographies (the seed's method).
    ClosedForm(FocalInit),
    /// The closed form with `fx != fy` (pixels that are not square): see
    /// [`start_intrinsics`].
    ClosedFormAspect(FocalInit),
    /// The closed form was unusable or not at the minimum of the start's reprojection error: a
    /// one-dimensional search over the focal length found the start.
    FocalSearch,
    /// A fisheye lens: a one-dimensional search over the focal length of an equidistant camera,
    /// poses from the points mapped to the pinhole plane ([`fisheye_search`]).
    FisheyeSearch,
}

impl std::str::FromStr for StartMethod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        [
            StartMethod::Given,
            StartMethod::ClosedForm(FocalInit::Bouguet),
            StartMethod::ClosedForm(FocalInit::LeastSquares),
            StartMethod::ClosedFormAspect(FocalInit::Bouguet),
            StartMethod::ClosedFormAspect(FocalInit::LeastSquares),
            StartMethod::FocalSearch,
            StartMethod::FisheyeSearch,
        ]
        .into_iter()
        .find(|m| m.name() == s)
        .ok_or_else(|| format!("unknown start method '{s}'"))
    }
}

impl StartMethod {
    /// The name in result files: `given`, `closed-form-bouguet`, `closed-form-least-squares`,
    /// `closed-form-bouguet-aspect`, `closed-form-least-squares-aspect`, `focal-search`,
    /// `fisheye-focal-search`.
    pub fn name(self) -> &'static str {
        match self {
            StartMethod::Given => "given",
            StartMethod::ClosedForm(FocalInit::Bouguet) => "closed-form-bouguet",
            StartMethod::ClosedForm(FocalInit::LeastSquares) => "closed-form-least-squares",
            StartMethod::ClosedFormAspect(FocalInit::Bouguet) => "closed-form-bouguet-aspect",
            StartMethod::ClosedFormAspect(FocalInit::LeastSquares) => {
                "closed-form-least-squares-aspect"
            }
            StartMethod::FocalSearch => "focal-search",
            StartMethod::FisheyeSearch => "fisheye-focal-search",
        }
    }
}

/// A view's board points and their pixels, in the same order.
pub type ViewPoints<'a> = (&'a [Point3<f64>], &'a [Point2<f64>]);

/// A view reduced to what scoring a focal length needs: its homography and a spread subset of
/// its points.
#[derive(Debug, Clone)]
pub struct ScoringView {
    /// The homography (board plane to pixels).
    pub h: Matrix3<f64>,
    /// Board points (subset).
    pub object: Vec<Point3<f64>>,
    /// Their pixels.
    pub image: Vec<Vector2<f64>>,
}

/// Most views and points per view used to score focal lengths: a weakly tilted capture
/// determines the focal length only through all its views together, so the search uses as many
/// as it can afford (a score is one small calibration, about 1 ms at this size). The pinhole
/// search only runs on weak captures and keeps up to 100 points per view (with 30, one weak
/// stereo capture of the convergence population started outside the right camera's range);
/// the fisheye search runs on every fisheye calibration and scores fewer, smaller views
/// ([`FISHEYE_SCORING_VIEWS`]).
pub const SCORING_VIEWS: usize = 40;
/// See [`SCORING_VIEWS`].
pub const SCORING_POINTS: usize = 100;
/// Points per view scoring a fisheye focal length (see [`FISHEYE_SCORING_VIEWS`]).
pub const FISHEYE_SCORING_POINTS: usize = 12;
/// Views scoring a fisheye focal length. The search only has to land in the minimum's basin
/// along the focal length, which the equidistant poses of 8 views of 12 spread points fix as
/// well as 20 of 30 did: the fisheye sweep (`calib-single/tests/fisheye.rs`, fields of view
/// 60 to 190 degrees, 3 to 25 views, noise to 1.5 px, tilts from 8 degrees) and a 400-problem
/// run of it reach the same minima, and the search costs about half (it dominated a fisheye
/// calibration: `docs/benchmarks-models.md`).
pub const FISHEYE_SCORING_VIEWS: usize = 8;

/// The relative depth range of a view's points, from its homography alone (independent of the
/// intrinsics): with `w(X) = h31 X + h32 Y + h33` proportional to the depth of board point `X`,
/// `(max w - min w) / mean w`. It is about `tan(tilt) x board extent / distance`; zero for a
/// board parallel to the image plane, where the view says nothing about the focal length.
pub fn perspective_measure(h: &Matrix3<f64>, points: &[Point3<f64>]) -> f64 {
    let (mut sum, mut lo, mut hi) = (0.0, f64::INFINITY, f64::NEG_INFINITY);
    for p in points {
        let w = h[(2, 0)] * p.x + h[(2, 1)] * p.y + h[(2, 2)];
        sum += w;
        lo = lo.min(w);
        hi = hi.max(w);
    }
    let mean = sum / points.len().max(1) as f64;
    if mean.abs() > 0.0 && hi >= lo {
        (hi - lo) / mean.abs()
    } else {
        0.0
    }
}

/// The views that score focal lengths: the [`SCORING_VIEWS`] with the strongest perspective,
/// each with at most `max_points` points spread over the view.
pub fn scoring_views(
    homographies: &[Matrix3<f64>],
    views: &[ViewPoints<'_>],
    max_points: usize,
) -> Vec<ScoringView> {
    let mut order: Vec<(f64, usize)> = homographies
        .iter()
        .zip(views)
        .enumerate()
        .map(|(i, (h, (object, _)))| (perspective_measure(h, object), i))
        .collect();
    order.sort_by(|a, b| b.0.total_cmp(&a.0));
    order
        .into_iter()
        .take(SCORING_VIEWS)
        .map(|(_, i)| {
            let (object, image) = views[i];
            let step = object.len().div_ceil(max_points.max(1)).max(1);
            ScoringView {
                h: homographies[i],
                object: object.iter().step_by(step).copied().collect(),
                image: image.iter().step_by(step).map(|p| p.coords).collect(),
            }
        })
        .collect()
}

/// How the calibration's camera block is held, for scoring focal lengths with the same model.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoringCamera {
    /// The lens model.
    pub model: CameraModel,
    /// Components of `[fx, fy, cx, cy, distortion...]` the calibration holds (besides the focal
    /// lengths, which the score holds at each candidate).
    pub fixed: Vec<usize>,
}

/// How hard a focal length's score is computed: the coarse grid only ranks focal lengths a
/// factor 1.5 apart, so its small calibrations stop early; the golden-section refinement
/// compares close focal lengths and needs the converged profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScoreEffort {
    /// Most Levenberg-Marquardt iterations of a score's calibration.
    pub max_iterations: usize,
    /// Its relative cost-change tolerance.
    pub function_tolerance: f64,
}

impl ScoreEffort {
    /// For the grid.
    pub const COARSE: ScoreEffort = ScoreEffort {
        max_iterations: 15,
        function_tolerance: 1e-3,
    };
    /// For the refinement and comparisons.
    pub const FINE: ScoreEffort = ScoreEffort {
        max_iterations: 50,
        function_tolerance: 1e-6,
    };
}

/// The start's reprojection RMS (pixels) at focal length `f`: square pixels, principal point
/// starting at `(cx, cy)`, every scoring view's pose from its homography, then everything but
/// the focal lengths optimized as the calibration would (principal point, distortion, poses):
/// the profile of the calibration's cost along the focal length, on the scoring subset.
/// Infinite if some view has no pose or the solve fails.
pub fn focal_score(f: f64, cx: f64, cy: f64, camera: &ScoringCamera, views: &[ScoringView]) -> f64 {
    focal_score_with(f, cx, cy, camera, views, ScoreEffort::FINE)
}

/// [`focal_score`] computed with `effort`.
pub fn focal_score_with(
    f: f64,
    cx: f64,
    cy: f64,
    camera: &ScoringCamera,
    views: &[ScoringView],
    effort: ScoreEffort,
) -> f64 {
    let k = Intrinsics::new(f, f, cx, cy);
    let frames: Option<Vec<Pose>> = views
        .iter()
        .map(|v| initial_pose(&v.h, &k, &v.object))
        .collect();
    match frames {
        Some(frames) => score_from_poses(k, camera, views, frames, effort),
        None => f64::INFINITY,
    }
}

/// Largest angle off the optical axis (radians, 70 degrees) of the points a fisheye start maps to
/// the pinhole plane: `tan(theta)` stretches points beyond it too much to fit a homography well.
pub const FISHEYE_START_MAX_ANGLE: f64 = 70.0 * std::f64::consts::PI / 180.0;

/// Fewest points [`fisheye_pose`] fits a pose to (a homography from 4 would follow their noise).
pub const FISHEYE_POSE_MIN_POINTS: usize = 6;

/// The board pose of a view seen through an equidistant camera with focal length `f` and
/// principal point `(cx, cy)` (no distortion): each pixel at radius `r` from the principal point
/// is the direction at `theta = r / f` off the axis; the points with `theta` below
/// [`FISHEYE_START_MAX_ANGLE`] are mapped to the pinhole plane (`tan(theta)` along their
/// direction), a homography from the board to that plane is fitted (at least
/// [`FISHEYE_POSE_MIN_POINTS`] points), and the pose follows from it with `K = I`.
///
/// A view with fewer such points (a board at the edge of a wide fisheye, all of it 70 to 100+
/// degrees off the axis) is mapped to the plane facing the mean of its directions instead: the
/// directions are turned so that their mean becomes the axis, the same fit gives the pose in that
/// frame, and the turn is undone. Before, such a view had no fisheye pose, its start came from the
/// pixel homography through a pinhole camera, and every focal length that put it beyond 70
/// degrees scored infinite in the focal search. `None` if too few points qualify or the fit
/// fails.
pub fn fisheye_pose(
    f: f64,
    cx: f64,
    cy: f64,
    object: &[Point3<f64>],
    image: &[Vector2<f64>],
) -> Option<Pose> {
    let (mut board, mut plane) = (Vec::new(), Vec::new());
    for (x, m) in object.iter().zip(image) {
        let (d, r, theta) = equidistant_polar(f, cx, cy, m);
        if theta < FISHEYE_START_MAX_ANGLE {
            let scale = if r > 0.0 { theta.tan() / r } else { 1.0 / f };
            board.push(Point2::new(x.x, x.y));
            plane.push(Point2::from(d * scale));
        }
    }
    if board.len() < FISHEYE_POSE_MIN_POINTS {
        return fisheye_pose_off_axis(f, cx, cy, object, image);
    }
    plane_pose(&board, &plane)
}

/// Pixel `m`'s offset from the principal point `(cx, cy)`, its length `r` and the angle off the
/// axis an equidistant lens of focal length `f` sees it at, `theta = r / f` (radians).
fn equidistant_polar(f: f64, cx: f64, cy: f64, m: &Vector2<f64>) -> (Vector2<f64>, f64, f64) {
    let d = Vector2::new(m.x - cx, m.y - cy);
    let r = d.norm();
    (d, r, r / f)
}

/// The pose of a board whose points `board` (on its plane) are seen at `plane` on the camera's
/// plane `z = 1` (normalized coordinates, `K = I`): from their homography.
fn plane_pose(board: &[Point2<f64>], plane: &[Point2<f64>]) -> Option<Pose> {
    let h = homography::dlt(board, plane).ok()?;
    let kept: Vec<Point3<f64>> = board.iter().map(|p| Point3::new(p.x, p.y, 0.0)).collect();
    initial_pose(&h, &Intrinsics::new(1.0, 1.0, 0.0, 0.0), &kept)
}

/// [`fisheye_pose`] of a view with too few points within [`FISHEYE_START_MAX_ANGLE`] of the
/// axis: the equidistant directions (`theta = r / f`, below 180 degrees) turned by the rotation
/// `Q` that takes their mean to the axis, those within the same angle of it mapped to the plane
/// `z = 1`, and the pose `(R', t')` fitted there returned as `(Q^T R', Q^T t')`.
fn fisheye_pose_off_axis(
    f: f64,
    cx: f64,
    cy: f64,
    object: &[Point3<f64>],
    image: &[Vector2<f64>],
) -> Option<Pose> {
    let rays: Vec<(Point3<f64>, Vector3<f64>)> = object
        .iter()
        .zip(image)
        .filter_map(|(x, m)| {
            let (d, r, theta) = equidistant_polar(f, cx, cy, m);
            (r > 0.0 && theta < std::f64::consts::PI).then(|| {
                let u = d / r;
                (
                    *x,
                    Vector3::new(theta.sin() * u.x, theta.sin() * u.y, theta.cos()),
                )
            })
        })
        .collect();
    let mean = rays
        .iter()
        .fold(Vector3::zeros(), |a, (_, ray)| a + ray)
        .try_normalize(1e-9)?;
    let turn = nalgebra::Rotation3::rotation_between(&mean, &Vector3::z())?;
    let (mut board, mut plane) = (Vec::new(), Vec::new());
    for (x, ray) in &rays {
        let v = turn * ray;
        if v.xy().norm().atan2(v.z) < FISHEYE_START_MAX_ANGLE {
            board.push(Point2::new(x.x, x.y));
            plane.push(Point2::new(v.x / v.z, v.y / v.z));
        }
    }
    if board.len() < FISHEYE_POSE_MIN_POINTS {
        return None;
    }
    let pose = plane_pose(&board, &plane)?;
    let back = turn.inverse();
    Some(Pose::new(
        back.matrix() * pose.rotation,
        back * pose.translation,
    ))
}

/// [`focal_score`] for a fisheye lens: the poses come from [`fisheye_pose`] at each candidate
/// focal length instead of the pixel homographies.
pub fn fisheye_score(
    f: f64,
    cx: f64,
    cy: f64,
    camera: &ScoringCamera,
    views: &[ScoringView],
) -> f64 {
    fisheye_score_with(f, cx, cy, camera, views, ScoreEffort::FINE)
}

/// [`fisheye_score`] computed with `effort`.
pub fn fisheye_score_with(
    f: f64,
    cx: f64,
    cy: f64,
    camera: &ScoringCamera,
    views: &[ScoringView],
    effort: ScoreEffort,
) -> f64 {
    let frames: Option<Vec<Pose>> = views
        .iter()
        .map(|v| fisheye_pose(f, cx, cy, &v.object, &v.image))
        .collect();
    match frames {
        Some(frames) => {
            score_from_poses(Intrinsics::new(f, f, cx, cy), camera, views, frames, effort)
        }
        None => f64::INFINITY,
    }
}

/// The focal length of a fisheye lens that minimizes [`fisheye_score`], searched like
/// [`focal_search`]. `None` if no focal length gives a finite score.
pub fn fisheye_search(
    image_size: ImageSize,
    camera: &ScoringCamera,
    views: &[ScoringView],
) -> Option<f64> {
    let (cx, cy) = image_size.centre();
    // Equidistant: f = r / theta. At the image's half-diagonal d, theta runs from 0.2 rad (a
    // 23 degree lens) to pi (a 360 degree one): f from d / pi to 5 d.
    minimize_over_focal(image_size, (0.25, 5.0), |f, effort| {
        fisheye_score_with(f, cx, cy, camera, views, effort)
    })
}

/// The calibration's cost profile at intrinsics `k` (focal lengths held) from the given start
/// poses of the scoring views.
fn score_from_poses(
    k: Intrinsics,
    camera: &ScoringCamera,
    views: &[ScoringView],
    frames: Vec<Pose>,
    effort: ScoreEffort,
) -> f64 {
    let model = camera.model;
    let held = camera;
    let mut camera = CameraSpec::new(
        "scoring",
        ImageSize::new(1, 1),
        AnyCamera::undistorted(model, k),
    );
    camera.fixed = [0, 1].iter().chain(&held.fixed).copied().collect();
    camera.fixed.sort_unstable();
    camera.fixed.dedup();
    let problem = JointProblem {
        cameras: vec![camera],
        reference: 0,
        rig: vec![Pose::identity()],
        rig_fixed: vec![true],
        frame_names: (0..views.len())
            .map(|i| format!("scoring view {i}"))
            .collect(),
        frames,
        observations: views
            .iter()
            .enumerate()
            .map(|(i, v)| ObservationSpec::new(0, i, "scoring", v.object.clone(), v.image.clone()))
            .collect(),
    };
    let mut options = SolveOptions {
        compute_uncertainty: false,
        outliers: None,
        camera_warnings: false,
        ..SolveOptions::default()
    };
    options.solver.max_iterations = effort.max_iterations;
    options.solver.damping = lm_solver::DampingPolicy::marquardt();
    options.solver.num_threads = 1;
    options.solver.function_tolerance = effort.function_tolerance;
    match crate::solve::solve(&problem, &options) {
        Ok(solution) => {
            let (sum, n) = solution
                .errors
                .iter()
                .fold((0.0, 0usize), |(s, n), e| (s + e.all_sum_sq, n + e.all));
            (sum / n.max(1) as f64).sqrt()
        }
        Err(_) => f64::INFINITY,
    }
}

/// The focal length (pixels) that minimizes [`focal_score`]: a log-spaced grid from 0.05 to 20
/// times the image's half-diagonal (6 points per decade), then a golden-section search between
/// the best grid point's neighbours. `None` if no focal length gives a finite score.
pub fn focal_search(
    image_size: ImageSize,
    camera: &ScoringCamera,
    views: &[ScoringView],
) -> Option<f64> {
    let (cx, cy) = image_size.centre();
    minimize_over_focal(image_size, (0.05, 20.0), |f, effort| {
        focal_score_with(f, cx, cy, camera, views, effort)
    })
}

/// Minimizes `score(f)` over focal lengths: a log-spaced grid between `low` and `high` image
/// half-diagonals (6 points per decade, [`ScoreEffort::COARSE`]), then the vertex of the
/// parabola through the best grid point and its neighbours (in `log f`, kept inside them). The
/// grid step is a factor 1.47; the vertex is within a few percent of the profile's minimum,
/// well inside what the calibration converges from. (A golden-section refinement with converged
/// scores cost ten times as much and changed no result of the convergence sweeps.)
fn minimize_over_focal(
    image_size: ImageSize,
    (low, high): (f64, f64),
    score: impl Fn(f64, ScoreEffort) -> f64,
) -> Option<f64> {
    let d = image_size.half_diagonal().max(1.0);
    let (lo, hi) = ((low * d).ln(), (high * d).ln());
    let steps = ((hi - lo) / std::f64::consts::LN_10 * 6.0).ceil() as usize;
    let grid: Vec<(f64, f64)> = (0..=steps)
        .map(|i| {
            let x = lo + (hi - lo) * i as f64 / steps as f64;
            (x, score(x.exp(), ScoreEffort::COARSE))
        })
        .collect();
    let (best, &(x1, s1)) = grid
        .iter()
        .enumerate()
        .filter(|(_, (_, s))| s.is_finite())
        .min_by(|a, b| a.1.1.total_cmp(&b.1.1))?;
    if best == 0 || best == steps {
        return Some(x1.exp());
    }
    let ((x0, s0), (x2, s2)) = (grid[best - 1], grid[best + 1]);
    if !(s0.is_finite() && s2.is_finite()) {
        return Some(x1.exp());
    }
    // Equal spacing h: vertex at x1 + h (s0 - s2) / (2 (s0 - 2 s1 + s2)).
    let h = x1 - x0;
    let curvature = s0 - 2.0 * s1 + s2;
    let x = if curvature > 0.0 {
        (x1 + h * (s0 - s2) / (2.0 * curvature)).clamp(x0, x2)
    } else {
        x1
    };
    Some(x.exp())
}

/// Relative disagreement of the two closed forms above which neither is trusted as the start.
pub const CLOSED_FORM_AGREEMENT: f64 = 0.15;

/// The start of the intrinsics (square pixels, principal point at the image centre).
///
/// The closed form `method` is kept when both closed forms (Bouguet's and least squares) are
/// valid, agree within [`CLOSED_FORM_AGREEMENT`] and give a focal length within 0.05 to 20 image
/// half-diagonals: well-tilted boards make both accurate. Otherwise (a `1/alpha^2` that is not
/// positive, as nearly frontal boards with noise give, or two estimates that disagree, which
/// shows that noise dominates the constraints) the focal length comes from [`focal_search`], the
/// minimum of the calibration cost's profile along the focal length, or from a closed form if it
/// scores lower.
pub fn start_intrinsics(
    homographies: &[Matrix3<f64>],
    views: &[ViewPoints<'_>],
    image_size: ImageSize,
    camera: &ScoringCamera,
    method: FocalInit,
) -> Result<(Intrinsics, StartMethod), CalibrationError> {
    let (cx, cy) = image_size.centre();
    let d = image_size.half_diagonal().max(1.0);
    let perspective = homographies
        .iter()
        .zip(views)
        .map(|(h, (object, _))| perspective_measure(h, object))
        .fold(0.0, f64::max);
    if perspective.is_nan() || perspective < MIN_PERSPECTIVE {
        return Err(CalibrationError::FrontoParallel {
            tilt_measure: perspective,
        });
    }
    let other = other_method(method);
    let preferred = initial_intrinsics(homographies, image_size, method);
    let second = initial_intrinsics(homographies, image_size, other);
    if let (Ok(a), Ok(b)) = (&preferred, &second)
        && (a.fx / b.fx - 1.0).abs() <= CLOSED_FORM_AGREEMENT
        && (0.05 * d..=20.0 * d).contains(&a.fx)
    {
        return Ok((*a, StartMethod::ClosedForm(method)));
    }
    // Square-pixel forms that disagree because the pixels are not square (and the calibration
    // estimates fx and fy separately).
    if !camera.fixed.contains(&1)
        && let Some(k) = aspect_closed_form(homographies, image_size, method)
        && (0.05 * d..=20.0 * d).contains(&k.fx)
    {
        return Ok((k, StartMethod::ClosedFormAspect(method)));
    }
    let scoring = scoring_views(homographies, views, SCORING_POINTS);
    let mut candidates: Vec<(f64, StartMethod)> = Vec::new();
    if let Some(f) = focal_search(image_size, camera, &scoring) {
        candidates.push((f, StartMethod::FocalSearch));
    }
    for (closed, m) in [(preferred, method), (second, other)] {
        if let Ok(k) = closed {
            candidates.push((k.fx, StartMethod::ClosedForm(m)));
        }
    }
    let best = candidates
        .into_iter()
        .map(|(f, m)| (focal_score(f, cx, cy, camera, &scoring), f, m))
        .filter(|(s, _, _)| s.is_finite())
        .min_by(|a, b| a.0.total_cmp(&b.0));
    match best {
        Some((_, f, m)) => Ok((Intrinsics::new(f, f, cx, cy), m)),
        None => Err(CalibrationError::FrontoParallel {
            tilt_measure: perspective,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use camera_model::{EulerXyz, RotationParameterization};

    fn homography(k: &Intrinsics, pose: &Pose) -> Matrix3<f64> {
        let r = pose.rotation;
        let m = Matrix3::from_columns(&[
            r.column(0).into_owned(),
            r.column(1).into_owned(),
            pose.translation,
        ]);
        k.matrix() * m
    }

    fn pose(angles: [f64; 3], t: [f64; 3]) -> Pose {
        Pose::new(EulerXyz::matrix(&Vector3::from(angles)), Vector3::from(t))
    }

    #[test]
    fn exact_homographies_give_the_exact_focal_length_and_poses() {
        let size = ImageSize::new(640, 480);
        let k = Intrinsics::new(800.0, 800.0, 319.5, 239.5);
        let poses = [
            pose([0.4, -0.2, 0.1], [-0.1, -0.05, 1.0]),
            pose([-0.3, 0.5, -0.7], [0.05, -0.1, 1.5]),
            pose([0.2, 0.3, 2.0], [0.0, 0.1, 0.8]),
        ];
        let hs: Vec<Matrix3<f64>> = poses.iter().map(|p| homography(&k, p) * -3.7).collect();
        for method in [FocalInit::Bouguet, FocalInit::LeastSquares] {
            let guess = initial_intrinsics(&hs, size, method).unwrap();
            assert!((guess.fx - 800.0).abs() < 1e-9 && guess.fy == guess.fx);
            assert_eq!((guess.cx, guess.cy), (319.5, 239.5));
        }
        for (p, h) in poses.iter().zip(&hs) {
            let estimate = initial_pose(h, &k, &[]).unwrap();
            assert!((estimate.rotation - p.rotation).norm() < 1e-12);
            assert!((estimate.translation - p.translation).norm() < 1e-12);
        }
    }

    #[test]
    fn fronto_parallel_views_are_rejected() {
        let size = ImageSize::new(640, 480);
        let k = Intrinsics::new(800.0, 800.0, 319.5, 239.5);
        let hs = vec![
            homography(&k, &pose([0.0, 0.0, 0.3], [0.0, 0.0, 1.0])),
            homography(&k, &pose([0.0, 0.0, -1.0], [0.1, 0.0, 2.0])),
        ];
        assert!(matches!(
            initial_intrinsics(&hs, size, FocalInit::Bouguet),
            Err(CalibrationError::FrontoParallel { .. })
        ));
        // A 0.3 degree tilt is still not enough; 3 degrees is.
        let tilted = |deg: f64| {
            vec![homography(
                &k,
                &pose([deg.to_radians(), 0.0, 0.3], [0.0, 0.0, 1.0]),
            )]
        };
        assert!(initial_intrinsics(&tilted(0.3), size, FocalInit::Bouguet).is_err());
        let guess = initial_intrinsics(&tilted(3.0), size, FocalInit::Bouguet).unwrap();
        assert!((guess.fx - 800.0).abs() < 1e-6);
    }
}
