//! Checks that catch data which cannot determine the answer, and warnings about results that
//! deserve a second look. Errors stop a calibration (they name the view and point); warnings are
//! attached to the result. Every one is listed in `docs/calib-single.md`.
//!
//! * Before solving: points outside the image (an error: the image size or the points are
//!   wrong), duplicate views (the copies are dropped with a warning: they add no geometry, and
//!   29 copies of one view make a confident-looking but meaningless result).
//! * After solving: a principal point far from the image centre, parameters with a large
//!   uncertainty, a lens model that folds or misfits, image corners and edges no board corner
//!   reached, a view whose error is far above the others'.

use crate::data::{ImageSize, View};
use crate::error::CalibrationError;
use crate::problem::JointProblem;
use crate::solve::JointSolution;
use crate::warnings::{Warning, WarningCode};
use camera_model::{CameraModel, UndistortOptions, Validity};
use nalgebra::{Matrix3, Point2, Vector2};

/// Two views are duplicates when their homographies map the board's extent to pixels less than
/// this far apart: the board did not move (or the file was listed twice).
pub const DUPLICATE_TOLERANCE_PX: f64 = 0.5;

/// How far outside the image a point may lie, as a fraction of the image's dimension (plus half
/// a pixel): corner detectors never report points outside the image, so anything beyond this
/// means the image size or the points are wrong.
pub const OUTSIDE_MARGIN: f64 = 0.01;

/// A principal point farther than this fraction of the image's dimension from the centre gets a
/// warning (real lenses are within a few percent; a wrong image size puts it far off).
pub const PRINCIPAL_POINT_OFFSET: f64 = 0.2;

/// A focal length whose 3-sigma uncertainty exceeds this fraction of its value, or a principal
/// point whose 3-sigma uncertainty exceeds this fraction of the image, gets a warning.
pub const POOR_RELATIVE_UNCERTAINTY: f64 = 0.1;

/// Parameters whose correlation exceeds this in magnitude are reported as not separately
/// determined by the data.
pub const MAX_CORRELATION: f64 = 0.999;

/// A distortion coefficient whose 3-sigma uncertainty exceeds this is not determined: no real
/// lens needs a coefficient known only to within +-1.
pub const MAX_DISTORTION_UNCERTAINTY: f64 = 1.0;

/// The lens model must be one-to-one this far beyond the image border (a fraction of the
/// border's distance from the principal point).
pub const VALIDITY_MARGIN: f64 = 0.05;

/// A view whose RMS exceeds this multiple of the camera's median view RMS (and
/// [`INCONSISTENT_VIEW_FLOOR_PX`]) gets a warning. Views of one camera agree far better than
/// this: the largest over the median is 1.3 to 1.8 on the four bundled sets.
pub const INCONSISTENT_VIEW_FACTOR: f64 = 5.0;

/// The `inconsistent-view` warning needs a view's RMS above this too, pixels: views far below
/// a tenth of a pixel do not matter to anyone whatever their ratio. It was 1 px, which kept
/// silent a low-light photograph at 0.53 px among views at 0.02 px that pulled fx by 3.7
/// sigmas (`benches/detect/defects_set.py`; docs/board-detect.md, "Photographic defects").
pub const INCONSISTENT_VIEW_FLOOR_PX: f64 = 0.1;

/// An image corner or edge midpoint farther than this fraction of the image's half-diagonal
/// from every corner used gets a `poor-coverage` warning: the distortion there is extrapolated.
/// Measured on the bundled webcam sets, whose corners stay 0.57 to 0.64 of the half-diagonal
/// away from one image corner: models fitting them equally well (brown-conrady4, rational8,
/// both by calib) differ by 4.5 to 51 px at the image corners, by under 0.3 px at the centre
/// (`docs/calib-single.md`, section 8; `benches/coverage/run.sh`).
pub const COVERAGE_GAP: f64 = 0.25;

/// Fails if a pixel of `view` lies outside the image by more than the margin.
pub fn check_inside_image(
    index: usize,
    view: &View,
    size: ImageSize,
) -> Result<(), CalibrationError> {
    let (w, h) = (f64::from(size.width), f64::from(size.height));
    let (mx, my) = (0.5 + OUTSIDE_MARGIN * w, 0.5 + OUTSIDE_MARGIN * h);
    match view
        .image_points
        .iter()
        .position(|p| p.x < -mx || p.y < -my || p.x > w - 1.0 + mx || p.y > h - 1.0 + my)
    {
        Some(point) => Err(CalibrationError::PointOutsideImage {
            view: index,
            point,
            x: view.image_points[point].x,
            y: view.image_points[point].y,
            width: size.width,
            height: size.height,
        }),
        None => Ok(()),
    }
}

fn apply(h: &Matrix3<f64>, p: &Point2<f64>) -> Vector2<f64> {
    let w = h[(2, 0)] * p.x + h[(2, 1)] * p.y + h[(2, 2)];
    Vector2::new(
        (h[(0, 0)] * p.x + h[(0, 1)] * p.y + h[(0, 2)]) / w,
        (h[(1, 0)] * p.x + h[(1, 1)] * p.y + h[(1, 2)]) / w,
    )
}

/// The corners of the bounding box of a view's board points (board plane).
fn extent_of(view: &View) -> [Point2<f64>; 4] {
    let (mut lo, mut hi) = (Vector2::repeat(f64::MAX), Vector2::repeat(f64::MIN));
    for p in &view.object_points {
        lo = lo.inf(&p.xy().coords);
        hi = hi.sup(&p.xy().coords);
    }
    [
        Point2::new(lo.x, lo.y),
        Point2::new(hi.x, lo.y),
        Point2::new(hi.x, hi.y),
        Point2::new(lo.x, hi.y),
    ]
}

/// True if views `a` and `b` (with homographies `ha`, `hb`) show the board at the same place:
/// each one's board extent lands within [`DUPLICATE_TOLERANCE_PX`] under both homographies.
pub fn same_view(a: &View, ha: &Matrix3<f64>, b: &View, hb: &Matrix3<f64>) -> bool {
    let (ea, eb) = (extent_of(a), extent_of(b));
    (0..4).all(|k| {
        (apply(ha, &ea[k]) - apply(hb, &ea[k])).norm() < DUPLICATE_TOLERANCE_PX
            && (apply(ha, &eb[k]) - apply(hb, &eb[k])).norm() < DUPLICATE_TOLERANCE_PX
    })
}

/// The duplicates among views with board points `views[i]` and homographies `homographies[i]`:
/// pairs `(copy, original)` of positions, `original < copy`, each copy listed once. Cost:
/// `O(n log n)` plus the comparisons of views whose board centres land within the tolerance.
pub fn duplicate_views(views: &[&View], homographies: &[Matrix3<f64>]) -> Vec<(usize, usize)> {
    // The corners of each view's board extent, and where its homography puts them.
    let extents: Vec<[Point2<f64>; 4]> = views.iter().map(|v| extent_of(v)).collect();
    let images: Vec<[Vector2<f64>; 4]> = extents
        .iter()
        .zip(homographies)
        .map(|(e, h)| std::array::from_fn(|k| apply(h, &e[k])))
        .collect();
    let key = |i: usize| images[i].iter().map(|p| p.x).sum::<f64>() / 4.0;
    let mut order: Vec<usize> = (0..views.len()).filter(|&i| key(i).is_finite()).collect();
    order.sort_by(|&a, &b| key(a).total_cmp(&key(b)));
    let mut position = vec![usize::MAX; views.len()];
    for (p, &i) in order.iter().enumerate() {
        position[i] = p;
    }
    let same = |i: usize, j: usize| {
        // Both extents under both homographies: views of different board parts differ.
        (0..4).all(|k| {
            (apply(&homographies[j], &extents[i][k]) - images[i][k]).norm() < DUPLICATE_TOLERANCE_PX
                && (apply(&homographies[i], &extents[j][k]) - images[j][k]).norm()
                    < DUPLICATE_TOLERANCE_PX
        })
    };

    let mut is_copy = vec![false; views.len()];
    let mut pairs = Vec::new();
    // In input order, so that the first occurrence is the one kept.
    for i in 0..views.len() {
        if is_copy[i] || position[i] == usize::MAX {
            continue;
        }
        let p = position[i];
        let near = order[..p]
            .iter()
            .rev()
            .take_while(|&&j| key(i) - key(j) <= DUPLICATE_TOLERANCE_PX)
            .chain(
                order[p + 1..]
                    .iter()
                    .take_while(|&&j| key(j) - key(i) <= DUPLICATE_TOLERANCE_PX),
            );
        for &j in near {
            if j > i && !is_copy[j] && same(i, j) {
                is_copy[j] = true;
                pairs.push((j, i));
            }
        }
    }
    pairs.sort_unstable();
    pairs
}

/// The `duplicate-views` warning for repeated captures: `pairs` are `(copy, original)` in the
/// user's numbering of `kind`s ("view", "frame"); the first ten are listed.
pub fn duplicates_warning(kind: &str, pairs: &[(usize, usize)]) -> Warning {
    let n = pairs.len();
    let listed: Vec<String> = pairs
        .iter()
        .take(10)
        .map(|(copy, original)| format!("{kind} {copy} = {kind} {original}"))
        .collect();
    Warning::new(
        WarningCode::DuplicateViews,
        format!(
            "{n} {kind}{} repeat{} an earlier {kind} (the board did not move, or a {} is listed twice) and {} left out: {}{}",
            if n > 1 { "s" } else { "" },
            if n > 1 { "" } else { "s" },
            if kind == "view" { "file" } else { kind },
            if n > 1 { "were" } else { "was" },
            listed.join(", "),
            if n > 10 { ", ..." } else { "" }
        ),
    )
}

/// The `model-invalid` warning for `model` with `validity` (not covering the image with
/// [`VALIDITY_MARGIN`]): whether the fold is inside the image or within the margin beyond it,
/// and what to do.
fn model_invalid_message(
    model: CameraModel,
    validity: &Validity,
    free: &[&str],
    camera: Option<&str>,
) -> String {
    // `coverage` compares each ray's fold with the border along the same ray; the nearest fold
    // and the farthest corner may lie in different directions.
    let (place, consequence) = if validity.coverage < 1.0 {
        ("inside the image", "pixels beyond have no unique direction")
    } else {
        (
            "just outside the image",
            "pixels near the border are close to the fold, where the model is unreliable",
        )
    };
    // The fisheye has no simpler model of its kind: hold its highest free coefficients.
    let remedy = match (model, free) {
        (CameraModel::KannalaBrandt4, [.., a, b]) => format!(
            "hold the higher coefficients fixed ({}) or add views with the board near the image corners",
            hold_advice(&[&[b], &[a, b]], camera)
        ),
        (CameraModel::KannalaBrandt4, [b]) => format!(
            "hold the higher coefficients fixed ({}) or add views with the board near the image corners",
            hold_advice(&[&[b]], camera)
        ),
        _ => "use a model with fewer terms or add views with the board near the image corners"
            .to_string(),
    };
    // A rational fit that folds sits at one of the valley's sharply curved minima, where the
    // local sigmas are small and meaningless: measured over 200 synthetic wide-angle
    // calibrations each (fx 330, 30 views, 0.3 px), k1 lay beyond 3 of its sigmas from the
    // truth in 45 of the 60 rational8 fits with this warning (7 of the 140 without) and in 51
    // of 64 thin-prism12 ones (6 of 136), most of them without a poorly-determined warning.
    let sigmas = if model_is_linear_in_distortion(model) {
        ""
    } else {
        "; the distortion coefficients' sigmas of such a fit are not to be trusted (on simulated wide-angle lenses 3 in 4 of them missed the true k1 by more than 3 sigmas)"
    };
    format!(
        "the {model} lens model stops being one-to-one {place}: along its worst direction at {:.0}% of the distance from the principal point to the image border ({:.0}% is checked; the nearest fold is {:.0} px from the principal point): {consequence}{sigmas}; {remedy}",
        100.0 * validity.coverage,
        100.0 * (1.0 + VALIDITY_MARGIN),
        validity.valid_radius_px
    )
}

/// For a fisheye whose fold lies beyond every observed corner: the sentence saying that a
/// circular fisheye (an image circle inside the sensor, black beyond) whose circle ends before
/// the fold is not concerned. Its true lens may fold just outside the circle, and the fit
/// reproduces that, while the check walks out to the black image corners (measured on rendered
/// photographs, docs/board-detect.md, "Photographs to a fisheye calibration"). Empty otherwise.
fn circular_fisheye_note(model: CameraModel, validity: &Validity, observed_radius: f64) -> String {
    if !model.is_fisheye()
        || !validity.valid_radius_px.is_finite()
        || validity.valid_radius_px <= observed_radius
    {
        return String::new();
    }
    format!(
        " (the farthest corner seen is {observed_radius:.0} px from the principal point, inside the fold: for a circular fisheye whose image circle ends within {:.0} px of the principal point, black beyond, the fold lies outside the picture and nothing needs doing)",
        validity.valid_radius_px
    )
}

/// For a pinhole model whose nearest fold lies within the farthest observed corner: the sentence
/// saying that views near the image corners cannot be the remedy there, and what is. A pinhole
/// model fitted to a fisheye or a strong barrel lens folds inside the area the board already
/// covers (a 190-degree fisheye fitted with brown-conrady5: fold 270 px out, corners seen to 345
/// px; `benches/validity/run.sh`). Empty otherwise.
fn covered_fold_note(model: CameraModel, validity: &Validity, observed_radius: f64) -> String {
    if model.is_fisheye()
        || !validity.valid_radius_px.is_finite()
        || validity.valid_radius_px >= observed_radius
    {
        return String::new();
    }
    format!(
        " (the fold, {:.0} px from the principal point, lies within the farthest corner seen, {observed_radius:.0} px out: more views there cannot undo it; the lens may be wider than this model follows: compare the models (calib single --compare-models) or try --model kannala-brandt4)",
        validity.valid_radius_px
    )
}

/// An image corner or edge midpoint that no board corner reached: farther than
/// [`COVERAGE_GAP`] of the image's half-diagonal from every corner used.
#[derive(Debug, Clone, PartialEq)]
pub struct UncoveredPlace {
    /// "top-left corner", "top edge" (its midpoint), ... clockwise from the top-left corner.
    pub name: &'static str,
    /// Where it is, pixels (OpenCV: the first pixel's centre at (0, 0)).
    pub pixel: Vector2<f64>,
    /// Distance to the nearest corner used, pixels.
    pub gap: f64,
}

/// The image corners and edge midpoints of an image of `size` farther than [`COVERAGE_GAP`] of
/// its half-diagonal from every one of `pixels` (the board corners used), clockwise from the
/// top-left corner. Cost: 8 distances per pixel.
pub fn uncovered_places<'a>(
    size: ImageSize,
    pixels: impl IntoIterator<Item = &'a Vector2<f64>>,
) -> Vec<UncoveredPlace> {
    let (w, h) = (f64::from(size.width) - 1.0, f64::from(size.height) - 1.0);
    let places = [
        ("top-left corner", 0.0, 0.0),
        ("top edge", w / 2.0, 0.0),
        ("top-right corner", w, 0.0),
        ("right edge", w, h / 2.0),
        ("bottom-right corner", w, h),
        ("bottom edge", w / 2.0, h),
        ("bottom-left corner", 0.0, h),
        ("left edge", 0.0, h / 2.0),
    ];
    // Squared distances: a million corners cost milliseconds, not the tens `hypot` would.
    let mut nearest = [f64::INFINITY; 8];
    for p in pixels {
        for (n, &(_, x, y)) in nearest.iter_mut().zip(&places) {
            let (dx, dy) = (p.x - x, p.y - y);
            *n = n.min(dx * dx + dy * dy);
        }
    }
    let limit = COVERAGE_GAP * size.half_diagonal();
    places
        .iter()
        .zip(nearest.map(f64::sqrt))
        .filter(|&(_, gap)| gap > limit)
        .map(|(&(name, x, y), gap)| UncoveredPlace {
            name,
            pixel: Vector2::new(x, y),
            gap,
        })
        .collect()
}

/// The `poor-coverage` warning of camera `c`: [`uncovered_places`] of the corners used
/// (rejected outliers and zero-weight points do not count), named with their distances. Places
/// beyond the nearest fold of the model are left out (the `model-invalid` warning speaks for
/// them), and for a fisheye model those more than 90 degrees from the optical axis. Cost: 8
/// distances per point.
fn coverage_warning(
    problem: &JointProblem,
    solution: &JointSolution,
    c: usize,
    who: &str,
    validity: &Validity,
) -> Option<Warning> {
    let size = problem.cameras[c].image_size;
    let camera = &solution.cameras[c];
    let k = camera.intrinsics;
    let used = problem
        .observations
        .iter()
        .enumerate()
        .filter(|(_, o)| o.camera == c)
        .flat_map(|(i, o)| {
            let rejected = solution.rejected.get(i).map_or(&[][..], Vec::as_slice);
            o.pixels.iter().enumerate().filter_map(move |(j, p)| {
                let unused =
                    o.weights.as_ref().is_some_and(|wt| wt[j] <= 0.0) || rejected.contains(&j);
                (!unused).then_some(p)
            })
        });
    let gaps: Vec<String> = uncovered_places(size, used)
        .into_iter()
        .filter(|place| {
            let inside_fold = !validity.valid_radius_px.is_finite()
                || (place.pixel.x - k.cx).hypot(place.pixel.y - k.cy) <= validity.valid_radius_px;
            // A fisheye's image border beyond 90 degrees from the axis is, for the circular
            // fisheyes that reach so far, black: outside the image circle (the rendered
            // `render_set kb --seed 1` set, fx 273 on 1280x960, a 161-degree circle as the
            // command prints: the warning named its black corners and side edges before this
            // rule). Full-frame fisheyes reach about 90 degrees at their corners.
            let in_front = !camera.model.is_fisheye()
                || camera
                    .pixel_to_ray(&place.pixel, &UndistortOptions::default())
                    .is_ok_and(|ray| ray.z >= 0.0);
            inside_fold && in_front
        })
        .map(|place| format!("{:.0} px from the {}", place.gap, place.name))
        .collect();
    if gaps.is_empty() {
        return None;
    }
    let scale = size.half_diagonal();
    let circle = if camera.model.is_fisheye() {
        " (for a circular fisheye whose image circle does not reach them, nothing needs doing; places more than 90 degrees from the optical axis are not named)"
    } else {
        ""
    };
    Some(Warning::new(
        WarningCode::PoorCoverage,
        format!(
            "{who}the board corners used leave parts of the image uncovered: the nearest is {} (this warning from {:.0} px, {:.0}% of the half-diagonal); the lens model is extrapolated there, and models fitting the corners seen equally well can differ there by pixels; add views with the board close to {}{circle} (the report's coverage plot shows where corners were seen)",
            gaps.join(", "),
            COVERAGE_GAP * scale,
            100.0 * COVERAGE_GAP,
            if gaps.len() > 1 {
                "those places"
            } else {
                "that place"
            },
        ),
    ))
}

/// How to hold coefficients fixed, in both front ends: each of `choices` (alternatives, each a
/// set of names) as the command line's `--fix` and as the Python functions' `fix=`, e.g.
/// "--fix k4 or --fix k3,k4; Python: fix=['k4'] or fix=['k3', 'k4']". The messages are shared by
/// `calib` and the Python package. In a stereo rig or rig (`camera` given) the command line
/// holds a coefficient in one camera as `--fix NAME=k4` (a plain `--fix k4` holds it in every
/// camera); Python's `fix=` holds it in every camera whose model has it, which the advice says.
fn hold_advice(choices: &[&[&str]], camera: Option<&str>) -> String {
    let prefix = camera.map_or_else(String::new, |name| format!("{name}="));
    let cli: Vec<String> = choices
        .iter()
        .map(|names| format!("--fix {prefix}{}", names.join(",")))
        .collect();
    let python: Vec<String> = choices
        .iter()
        .map(|names| {
            let quoted: Vec<String> = names.iter().map(|n| format!("'{n}'")).collect();
            format!("fix=[{}]", quoted.join(", "))
        })
        .collect();
    let every = if camera.is_some() {
        " (in every camera whose model has them)"
    } else {
        ""
    };
    format!(
        "{}; Python: {}{every}",
        cli.join(" or "),
        python.join(" or ")
    )
}

/// What to do about distortion coefficients the data does not determine, for `model`: a model
/// with fewer terms of the same kind where there is one, else holding the undetermined
/// coefficients `loose` fixed (those the run did not hold already, in the model's order).
fn fewer_terms_advice(model: CameraModel, loose: &[&str], camera: Option<&str>) -> String {
    match model {
        CameraModel::ThinPrism12 => {
            "use a model with fewer terms (rational8, brown-conrady5 or brown-conrady4) or add views covering the image".into()
        }
        CameraModel::Rational8 => {
            "use a model with fewer terms (brown-conrady5 or brown-conrady4) or add views covering the image".into()
        }
        CameraModel::BrownConrady5 => "use brown-conrady4 (no k3) or add views covering the image".into(),
        CameraModel::BrownConrady4 | CameraModel::KannalaBrandt4 => {
            // The highest loose coefficient first, then the two highest.
            let hold = match loose {
                [] => format!("e.g. {}", hold_advice(&[&["k2"]], camera)),
                [one] => hold_advice(&[&[one]], camera),
                [.., a, b] => hold_advice(&[&[b], &[a, b]], camera),
            };
            let reach = if model.is_fisheye() { ", out to its corners" } else { "" };
            format!("hold the undetermined coefficients fixed ({hold}) or add views covering the image{reach}")
        }
    }
}

/// Chi-square (over the bands with at least [`MIN_BAND_POINTS`] points) of the mean radial
/// errors of camera `c` against their noise, its number of bands, and the largest band mean
/// (pixels, signed).
pub(crate) fn radial_statistic(solution: &JointSolution, c: usize) -> (f64, usize, f64) {
    let variance = solution.residual_variance;
    let mut chi2 = 0.0;
    let mut bands = 0;
    let mut largest: f64 = 0.0;
    for &(sum, n) in &solution.radial_bands[c] {
        if n >= MIN_BAND_POINTS && variance > 0.0 {
            let mean = sum / n as f64;
            chi2 += mean * mean * n as f64 / variance;
            bands += 1;
            if mean.abs() > largest.abs() {
                largest = mean;
            }
        }
    }
    (chi2, bands, largest)
}

/// Fewest points in a band of distance for it to count in [`radial_statistic`].
const MIN_BAND_POINTS: usize = 20;

/// Chi-square of the band means above which the radial pattern is a misfit. With 8 bands,
/// noise alone exceeds it with probability 3e-6; measured on correct models (brown-conrady4,
/// rational8, kannala-brandt4 on their own synthetic data, 60 seeds each) the largest value
/// was 10, on the bundled cameras 19.
const MISFIT_CHI2: f64 = 40.0;

/// Smallest band mean, relative to the noise's standard deviation, that the misfit warning
/// reports: with many points a pattern far below the noise is significant but harmless.
const MISFIT_RELATIVE: f64 = 0.1;

/// Smallest band mean (pixels) the misfit warning reports, whatever the noise: noise-free data
/// has a chi-square of rounding errors.
const MISFIT_FLOOR_PX: f64 = 0.005;

/// The `model-misfit` warning for camera `c` when the mean radial error of its used points,
/// in bands of distance from the principal point, is far beyond what the noise gives
/// ([`MISFIT_CHI2`], [`MISFIT_RELATIVE`]): a lens model too simple for the lens (a fisheye
/// fitted with brown-conrady4). The standard deviations cover the noise only, so they are then
/// too small (measured on such a fit: fx off by 2.3 sigma in RMS, 22% of seeds beyond 3 sigma).
fn radial_misfit(
    solution: &JointSolution,
    c: usize,
    who: &str,
    model: CameraModel,
) -> Option<Warning> {
    let (chi2, bands, largest) = radial_statistic(solution, c);
    let sigma = solution.residual_variance.sqrt();
    let pattern = largest.abs() > MISFIT_RELATIVE * sigma && largest.abs() > MISFIT_FLOOR_PX;
    (chi2 > MISFIT_CHI2 && pattern).then(|| {
        Warning::new(
            WarningCode::ModelMisfit,
            format!(
                "{who}{model}: the errors change with the distance from the principal point (mean radial error up to {largest:+.3} px in a band of distance, against {sigma:.3} px of noise; chi-square {chi2:.0} over {bands} bands, where noise alone gives about {bands}): the lens model does not fit this lens, and the standard deviations cover the noise only, not this misfit; compare lens models (calib single --compare-models; Python: calib.compare_models)"
            ),
        )
    })
}

/// True if a pixel depends linearly on the model's distortion coefficients for fixed
/// intrinsics and poses (polynomial models), false for the rational ones (their denominator):
/// only then is the cost quadratic along the coefficients' trade-off.
fn model_is_linear_in_distortion(model: CameraModel) -> bool {
    !matches!(model, CameraModel::Rational8 | CameraModel::ThinPrism12)
}

/// The advice for focal lengths that the data does not separate (`fx` and `fy` correlated
/// above [`MAX_CORRELATION`]) while their ratio held fixed would leave `fx` determined (3 sigma
/// within [`POOR_RELATIVE_UNCERTAINTY`] of it): boards tilted about one image axis only, or by
/// the same angle either way, constrain one combination of `fx` and `fy`, and a camera with
/// square pixels needs no more. `None` when the ratio is held already or holding it would not
/// help (boards facing the camera: the focal length itself is undetermined).
fn aspect_ratio_advice(
    cov: &nalgebra::DMatrix<f64>,
    k: &camera_model::Intrinsics,
    fixed: &[usize],
) -> Option<String> {
    if fixed.contains(&0) || fixed.contains(&1) {
        return None;
    }
    let (xx, xy, yy) = (cov[(0, 0)], cov[(0, 1)], cov[(1, 1)]);
    if !(xx > 0.0 && yy > 0.0) || (xy / (xx * yy).sqrt()).abs() <= MAX_CORRELATION {
        return None;
    }
    // With fy = fx / r held (r the estimated ratio), the variance of fx is the inverse of the
    // information about (fx, fy), inv(C), along u = (1, 1/r): det C / (u^T adj(C) u).
    let u = (1.0, k.fy / k.fx);
    let along = yy * u.0 * u.0 - 2.0 * xy * u.0 * u.1 + xx * u.1 * u.1;
    let sigma = ((xx * yy - xy * xy).max(0.0) / along).sqrt();
    (along > 0.0 && 3.0 * sigma <= POOR_RELATIVE_UNCERTAINTY * k.fx.abs()).then(|| {
        format!(
            "the views do not separate fx from fy: if the pixels are square, hold their ratio (--fix-aspect-ratio; Python: fix=['aspect_ratio']), with which fx is determined to about +- {:.1} (3 sigma)",
            3.0 * sigma
        )
    })
}

/// Warnings about each camera of a solved problem: principal point far off-centre, poorly
/// determined intrinsics, views far less consistent than the others.
pub fn camera_warnings(problem: &JointProblem, solution: &JointSolution) -> Vec<Warning> {
    let mut warnings = Vec::new();
    let several = problem.cameras.len() > 1;
    for (c, spec) in problem.cameras.iter().enumerate() {
        let who = if several {
            format!("camera '{}': ", spec.name)
        } else {
            String::new()
        };
        let camera = &solution.cameras[c];
        let k = camera.intrinsics;
        let (w, h) = (
            f64::from(spec.image_size.width),
            f64::from(spec.image_size.height),
        );
        let pp_free = !(spec.fixed.contains(&2) && spec.fixed.contains(&3));
        let (dx, dy) = (k.cx - (w - 1.0) / 2.0, k.cy - (h - 1.0) / 2.0);
        if pp_free
            && (dx.abs() > PRINCIPAL_POINT_OFFSET * w || dy.abs() > PRINCIPAL_POINT_OFFSET * h)
        {
            warnings.push(Warning::new(
                WarningCode::PrincipalPointOffCentre,
                format!(
                    "{who}the principal point ({:.1}, {:.1}) is {:.0}% of the width and {:.0}% of the height from the centre of the {}x{} image: check the image size, or hold the principal point fixed",
                    k.cx,
                    k.cy,
                    100.0 * dx.abs() / w,
                    100.0 * dy.abs() / h,
                    spec.image_size.width,
                    spec.image_size.height
                ),
            ));
        }
        let validity = camera.validity(spec.image_size.width, spec.image_size.height);
        if !validity.covers_image(VALIDITY_MARGIN) {
            let observed_radius = problem
                .observations
                .iter()
                .filter(|o| o.camera == c)
                .flat_map(|o| &o.pixels)
                .map(|p| (p.x - k.cx).hypot(p.y - k.cy))
                .fold(0.0, f64::max);
            warnings.push(Warning::new(
                WarningCode::ModelInvalid,
                format!(
                    "{who}{}{}",
                    model_invalid_message(
                        camera.model,
                        &validity,
                        &spec
                            .param_names()
                            .into_iter()
                            .enumerate()
                            .skip(4)
                            .filter(|(i, _)| !spec.fixed.contains(i))
                            .map(|(_, name)| name)
                            .collect::<Vec<_>>(),
                        several.then_some(spec.name.as_str()),
                    ),
                    circular_fisheye_note(camera.model, &validity, observed_radius)
                        + &covered_fold_note(camera.model, &validity, observed_radius)
                ),
            ));
        }
        let std = &solution.camera_std[c];
        // The principal point is free and poorly determined (the warning below): a long lens
        // (narrow field of view), whose views cannot fix it.
        let pp_poor = pp_free
            && std.len() >= 4
            && (3.0 * std[2] > POOR_RELATIVE_UNCERTAINTY * w
                || 3.0 * std[3] > POOR_RELATIVE_UNCERTAINTY * h);
        if let Some(cov) = &solution.camera_covariance[c] {
            let names = spec.param_names();
            let free: Vec<usize> = (0..names.len())
                .filter(|i| !spec.fixed.contains(i))
                .collect();
            let mut loose: Vec<&str> = Vec::new();
            for (a, &i) in free.iter().enumerate() {
                for &j in &free[a + 1..] {
                    let r = cov[(i, j)] / (cov[(i, i)] * cov[(j, j)]).sqrt();
                    if r.abs() > MAX_CORRELATION {
                        loose.extend([names[i], names[j]]);
                    }
                }
                if i >= 4 && 3.0 * cov[(i, i)].max(0.0).sqrt() > MAX_DISTORTION_UNCERTAINTY {
                    loose.push(names[i]);
                }
            }
            loose.extend(
                solution
                    .undetermined
                    .iter()
                    .filter(|(camera, _)| *camera == c)
                    .map(|&(_, i)| names[i]),
            );
            loose.sort_by_key(|n| names.iter().position(|m| m == n));
            loose.dedup();
            if !loose.is_empty() {
                let views = problem
                    .observations
                    .iter()
                    .filter(|o| o.camera == c)
                    .count();
                let distortion_loose = loose.iter().any(|n| names[4..].contains(n));
                // Along the undetermined direction the cost is curved, not quadratic: the
                // linearized sigmas of the parameters that trade off with it are too small.
                // In a rig the transforms trade off with that direction too (measured: a
                // thin-prism12 camera's stereo R off by 12 sigma, T by 9).
                let simpler = fewer_terms_advice(
                    camera.model,
                    &loose
                        .iter()
                        .copied()
                        .filter(|n| names[4..].contains(n))
                        .collect::<Vec<_>>(),
                    several.then_some(spec.name.as_str()),
                );
                let (them, their) = if loose.len() > 1 {
                    (
                        "them",
                        "their values mean little, as their large sigmas say",
                    )
                } else {
                    ("it", "its value means little, as its large sigma says")
                };
                let understate = format!(
                    "the sigmas of this camera's other parameters{} may understate their uncertainty",
                    if several {
                        " and of the rig's transforms"
                    } else {
                        ""
                    },
                );
                let advice = if loose.iter().any(|n| names[..4].contains(n)) {
                    // The focal lengths or the principal point trade off with something: the
                    // views' geometry is at fault (boards parallel to each other or to the
                    // image, tilted about one axis only), which no distortion setting mends,
                    // and the linearized sigmas are not exact along such a valley (measured:
                    // boards facing the camera within 3 degrees, fx's z RMS 2.7 over 22 runs).
                    let tilt = "add views with the board tilted in different directions and covering the image";
                    let mut advice = match aspect_ratio_advice(cov, &k, &spec.fixed) {
                        Some(square) => format!("{square}, or {tilt}"),
                        None => tilt.to_string(),
                    };
                    let distortion: Vec<&str> = loose
                        .iter()
                        .copied()
                        .filter(|n| names[4..].contains(n))
                        .collect();
                    if !distortion.is_empty() {
                        advice += &format!("; for {}: {simpler}", distortion.join(", "));
                        if !model_is_linear_in_distortion(camera.model) {
                            advice += &format!("; {understate}");
                        }
                    }
                    advice
                } else if distortion_loose && !model_is_linear_in_distortion(camera.model) {
                    format!("{understate}; {simpler}")
                } else if distortion_loose && pp_poor {
                    // The pixel is linear in the coefficients but not in the principal point,
                    // which moves the centre of the distortion: with both loose the cost is
                    // curved along their trade-off (measured on long lenses, fields of view of
                    // 2 to 15 degrees, brown-conrady4 with k2 loose: cx, cy and k1 spread 1.2 to
                    // 1.6 times their sigmas; holding the principal point or k2 brings them
                    // within 0.9 to 1.2; `docs/calib-single.md`, section 6).
                    // In a rig, holding the principal point at the image centre is no remedy:
                    // the transforms absorb its offset (see the principal point's warning).
                    let hold = if several {
                        ""
                    } else {
                        "hold the principal point (--fix-principal-point; Python: fix=['principal_point']), or "
                    };
                    format!(
                        "with the principal point poorly determined too, {understate} (cx, cy and the distortion); {hold}{simpler}"
                    )
                } else {
                    // The pixel is linear in these coefficients: along their trade-off the cost
                    // is exactly quadratic and the linearized sigmas hold (measured: every
                    // sigma of brown-conrady5 and kannala-brandt4 fits within 0.93 to 1.07 of
                    // the spread over 200 seeds while this warning was given).
                    format!(
                        "the data constrains {them} only in combination with other parameters: alone {their} (the other parameters' sigmas account for it); {simpler}"
                    )
                };
                warnings.push(Warning::new(
                    WarningCode::PoorlyDetermined,
                    format!(
                        "{who}{}: {} {} not determined by {views} view{} (correlation above {MAX_CORRELATION} or 3 sigma above {MAX_DISTORTION_UNCERTAINTY}); {advice}",
                        camera.model,
                        loose.join(", "),
                        if loose.len() > 1 { "are" } else { "is" },
                        if views == 1 { "" } else { "s" }
                    ),
                ));
            }
        }
        if std.iter().any(|&s| s > 0.0) {
            let mut poor = Vec::new();
            for (i, (name, value, scale)) in [
                ("fx", k.fx, k.fx),
                ("fy", k.fy, k.fy),
                ("cx", k.cx, w),
                ("cy", k.cy, h),
            ]
            .into_iter()
            .enumerate()
            {
                if 3.0 * std[i] > POOR_RELATIVE_UNCERTAINTY * scale.abs() {
                    poor.push(format!("{name} = {value:.1} +- {:.1}", 3.0 * std[i]));
                }
            }
            if !poor.is_empty() {
                // A loose principal point: with a long lens no capture determines it (the
                // board's perspective is too weak), and the pose absorbs a shift of it; holding
                // it at the image centre leaves the focal lengths' and the distortion's sigmas
                // honest (measured: fields of view of 2 to 15 degrees, principal point up to 5%
                // of the width off-centre, z RMS of fx, fy, k1 0.92 to 1.2).
                let hold = if pp_poor && several {
                    // Measured: a converging telephoto pair (fx 20000, principal points 25 px
                    // off-centre) held at the centres had the rig's rotation 220 sigmas off.
                    " (holding it at the image centre is no remedy here: the rig's rotation would absorb its offset, offset / fx radians, unseen by the sigmas)".to_string()
                } else if pp_poor {
                    let lens = if camera.model.is_fisheye() {
                        "a long lens".to_string()
                    } else {
                        format!(
                            "a long lens: the horizontal field of view here is {:.1} degrees",
                            2.0 * (w / (2.0 * k.fx.abs())).atan().to_degrees()
                        )
                    };
                    format!(
                        ", or, when no capture can determine it ({lens}), hold it at the image centre (--fix-principal-point; Python: fix=['principal_point']; the board poses then absorb its offset)"
                    )
                } else {
                    String::new()
                };
                warnings.push(Warning::new(
                    WarningCode::PoorlyDetermined,
                    format!(
                        "{who}{} (3 sigma) {} poorly determined: add views with the board tilted in different directions and covering the whole image{hold}",
                        poor.join(", "),
                        if poor.len() > 1 { "are" } else { "is" }
                    ),
                ));
            }
        }
        if let Some(w) = radial_misfit(solution, c, &who, camera.model) {
            warnings.push(w);
        }
        if let Some(w) = coverage_warning(problem, solution, c, &who, &validity) {
            warnings.push(w);
        }
        // Per-view RMS over the used points.
        let rms: Vec<(usize, f64)> = problem
            .observations
            .iter()
            .enumerate()
            .filter(|(_, o)| o.camera == c)
            .map(|(i, _)| (i, solution.errors[i].rms()))
            .collect();
        if rms.len() >= 3 {
            let mut sorted: Vec<f64> = rms.iter().map(|r| r.1).collect();
            sorted.sort_by(f64::total_cmp);
            let median = sorted[sorted.len() / 2];
            let limit = (INCONSISTENT_VIEW_FACTOR * median).max(INCONSISTENT_VIEW_FLOOR_PX);
            let bad: Vec<String> = rms
                .iter()
                .filter(|r| r.1 > limit)
                .map(|&(i, r)| {
                    format!(
                        "{} ({r:.2} px)",
                        problem.frame_names[problem.observations[i].frame]
                    )
                })
                .collect();
            if !bad.is_empty() {
                warnings.push(Warning::new(
                    WarningCode::InconsistentView,
                    format!(
                        "{who}{} {} an error far above the others' (median {median:.3} px): wrong points, a blurred, noisy or dark photograph, or a different camera or lens setting? Such a view pulls the whole calibration; check or remove {}",
                        bad.join(", "),
                        if bad.len() > 1 { "have" } else { "has" },
                        if bad.len() > 1 { "them" } else { "it" }
                    ),
                ));
            }
        }
    }
    warnings
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_model_invalid_message_places_the_fold() {
        use super::{CameraModel, Validity, model_invalid_message};
        let validity = |coverage: f64| Validity {
            valid_radius_px: 376.0,
            image_radius_px: 372.0,
            coverage,
            limit_px: [None; camera_model::validity::VALIDITY_RAYS],
        };
        // In a stereo rig or rig, the camera's name goes into --fix.
        let folded = model_invalid_message(
            CameraModel::KannalaBrandt4,
            &validity(0.95),
            &["k1", "k2", "k3", "k4"],
            Some("right"),
        );
        assert!(
            folded.contains("--fix right=k4 or --fix right=k3,k4"),
            "{folded}"
        );
        let inside = model_invalid_message(CameraModel::Rational8, &validity(0.67), &[], None);
        assert!(
            inside.contains("inside the image") && inside.contains("at 67% of the distance"),
            "{inside}"
        );
        let outside = model_invalid_message(CameraModel::ThinPrism12, &validity(1.03), &[], None);
        assert!(
            outside.contains("just outside the image") && outside.contains("105% is checked"),
            "{outside}"
        );
        // A folding rational fit's coefficient sigmas are not to be trusted; a polynomial
        // model's are (the cost is quadratic along its coefficients).
        for text in [&inside, &outside] {
            assert!(
                text.contains("sigmas of such a fit are not to be trusted"),
                "{text}"
            );
        }
        let all = ["k1", "k2", "k3", "k4"];
        let fisheye =
            model_invalid_message(CameraModel::KannalaBrandt4, &validity(0.95), &all, None);
        assert!(
            fisheye.contains("(--fix k4 or --fix k3,k4; Python: fix=['k4'] or fix=['k3', 'k4'])")
                && !fisheye.contains("not to be trusted"),
            "{fisheye}"
        );
        // With k4 held already, the advice goes on from the highest free one.
        let held = model_invalid_message(
            CameraModel::KannalaBrandt4,
            &validity(0.95),
            &all[..3],
            None,
        );
        assert!(
            held.contains("(--fix k3 or --fix k2,k3; Python: fix=['k3'] or fix=['k2', 'k3'])"),
            "{held}"
        );
    }

    #[test]
    fn undetermined_terms_are_answered_with_a_simpler_model_of_the_same_kind() {
        use super::{CameraModel, fewer_terms_advice};
        for model in [
            CameraModel::BrownConrady4,
            CameraModel::BrownConrady5,
            CameraModel::Rational8,
            CameraModel::ThinPrism12,
            CameraModel::KannalaBrandt4,
        ] {
            let advice = fewer_terms_advice(model, &["k3", "k4"], None);
            // Never the model itself, never a model with more terms, never a pinhole model for
            // the fisheye.
            for other in [
                CameraModel::BrownConrady4,
                CameraModel::BrownConrady5,
                CameraModel::Rational8,
                CameraModel::ThinPrism12,
                CameraModel::KannalaBrandt4,
            ] {
                if advice.contains(other.name()) {
                    assert!(
                        other.num_params() < model.num_params()
                            && other.is_fisheye() == model.is_fisheye(),
                        "{model}: {advice}"
                    );
                }
            }
        }
        // Holding names what is loose and not held yet (with --fix k4 given, k3 alone is left).
        assert!(
            fewer_terms_advice(CameraModel::KannalaBrandt4, &["k3", "k4"], None)
                .contains("(--fix k4 or --fix k3,k4; Python: fix=['k4'] or fix=['k3', 'k4'])")
        );
        assert!(
            fewer_terms_advice(CameraModel::KannalaBrandt4, &["k3"], None)
                .contains("(--fix k3; Python: fix=['k3'])")
        );
        assert!(
            fewer_terms_advice(CameraModel::BrownConrady4, &["k2"], None)
                .contains("--fix k2; Python: fix=['k2']")
        );
        // In a stereo rig or rig the command line holds it in the one camera (a plain --fix
        // would hold it in every camera).
        let in_rig = fewer_terms_advice(CameraModel::KannalaBrandt4, &["k3", "k4"], Some("fish"));
        assert!(
            in_rig.contains(
                "(--fix fish=k4 or --fix fish=k3,k4; Python: fix=['k4'] or fix=['k3', 'k4'] (in every camera whose model has them))"
            ),
            "{in_rig}"
        );
    }

    use super::*;
    use nalgebra::Point3;

    fn view(shift: f64) -> View {
        let object: Vec<Point3<f64>> = (0..20)
            .map(|i| Point3::new((i % 5) as f64, (i / 5) as f64, 0.0))
            .collect();
        View {
            name: "v".into(),
            image_points: object
                .iter()
                .map(|p| Point2::new(100.0 + 30.0 * p.x + shift, 80.0 + 30.0 * p.y))
                .collect(),
            object_points: object,
        }
    }

    /// A Kannala-Brandt lens `theta (1 + k1 theta^2)` with `k1 = -0.1` folds where
    /// `1 + 3 k1 theta^2 = 0`, theta = 1.826 rad, at `300 * 1.826 * (1 - 1/3)` = 365 px at fx 300:
    /// inside a 1280x960 image (corners 800 px out). Corners seen out to 300 px (a circular
    /// fisheye's circle) get the note; corners seen beyond the fold, or a pinhole model, do not.
    #[test]
    fn a_fold_beyond_every_corner_seen_is_explained_for_circular_fisheyes() {
        use camera_model::{AnyCamera, Intrinsics};
        let fisheye = AnyCamera::new(
            CameraModel::KannalaBrandt4,
            Intrinsics::new(300.0, 300.0, 639.5, 479.5),
            vec![-0.1, 0.0, 0.0, 0.0],
        )
        .unwrap();
        let v = fisheye.validity(1280, 960);
        let fold = 300.0 * (1.0f64 / 0.3).sqrt() * (2.0 / 3.0);
        assert!((v.valid_radius_px - fold).abs() < 3.0, "{v:?} vs {fold}");
        assert!(!v.covers_image(VALIDITY_MARGIN));
        let note = circular_fisheye_note(CameraModel::KannalaBrandt4, &v, 300.0);
        assert!(
            note.contains("300 px") && note.contains("nothing needs doing"),
            "{note}"
        );
        assert!(
            note.contains(&format!("{:.0} px", v.valid_radius_px)),
            "{note}"
        );
        assert_eq!(
            circular_fisheye_note(CameraModel::KannalaBrandt4, &v, 400.0),
            ""
        );
        let pinhole = AnyCamera::new(
            CameraModel::BrownConrady4,
            Intrinsics::new(500.0, 500.0, 319.5, 239.5),
            vec![-0.5, 0.0, 0.0, 0.0],
        )
        .unwrap()
        .validity(640, 480);
        assert_eq!(
            circular_fisheye_note(CameraModel::BrownConrady4, &pinhole, 100.0),
            ""
        );
    }

    /// A pinhole fit folding inside the corners seen gets advice other than more views; a fold
    /// beyond them, or a fisheye model, does not.
    #[test]
    fn a_fold_inside_the_corners_seen_points_to_other_models() {
        use camera_model::{AnyCamera, Intrinsics};
        let pinhole = AnyCamera::new(
            CameraModel::BrownConrady4,
            Intrinsics::new(500.0, 500.0, 319.5, 239.5),
            vec![-0.5, 0.0, 0.0, 0.0],
        )
        .unwrap()
        .validity(640, 480);
        assert!(pinhole.valid_radius_px < 400.0, "{pinhole:?}");
        let note = covered_fold_note(CameraModel::BrownConrady4, &pinhole, 400.0);
        assert!(
            note.contains("400 px out")
                && note.contains("calib single --compare-models")
                && note.contains("kannala-brandt4"),
            "{note}"
        );
        assert_eq!(
            covered_fold_note(
                CameraModel::BrownConrady4,
                &pinhole,
                pinhole.valid_radius_px - 1.0
            ),
            ""
        );
        assert_eq!(
            covered_fold_note(CameraModel::KannalaBrandt4, &pinhole, 400.0),
            ""
        );
    }

    #[test]
    fn duplicates_are_paired_with_their_first_occurrence() {
        let views = [view(0.0), view(5.0), view(0.1), view(0.2), view(5.0)];
        let hs: Vec<Matrix3<f64>> = [0.0, 5.0, 0.1, 0.2, 5.0]
            .iter()
            .map(|s| Matrix3::new(30.0, 0.0, 100.0 + s, 0.0, 30.0, 80.0, 0.0, 0.0, 1.0))
            .collect();
        let refs: Vec<&View> = views.iter().collect();
        assert_eq!(duplicate_views(&refs, &hs), vec![(2, 0), (3, 0), (4, 1)]);
    }

    #[test]
    fn points_outside_the_image_are_refused_with_their_place() {
        let v = view(0.0);
        assert!(check_inside_image(0, &v, ImageSize::new(640, 480)).is_ok());
        let err = check_inside_image(3, &v, ImageSize::new(1, 1)).unwrap_err();
        assert!(
            matches!(
                err,
                CalibrationError::PointOutsideImage {
                    view: 3,
                    point: 0,
                    ..
                }
            ),
            "{err}"
        );
        assert!(err.to_string().contains("1x1"), "{err}");
        // A wild coordinate is printed short, not as 300 digits.
        let mut wild = view(0.0);
        wild.image_points[2].x = 1e300;
        let err = check_inside_image(5, &wild, ImageSize::new(640, 480)).unwrap_err();
        assert!(
            err.to_string().contains("point 2: pixel (1.000e300, "),
            "{err}"
        );
    }
}
