//! The view bootstrap: standard deviations of the camera parameters from refits of resampled
//! views, for lens models whose linearized sigmas are too small.
//!
//! A calibration's standard deviations are the linearization's (`sigma^2 (J^T J)^-1` at the
//! minimum). For the polynomial models (`brown-conrady4`, `brown-conrady5`, `kannala-brandt4`)
//! they match the spread of the estimates over repeated captures. For the rational models
//! (`rational8`, `thin-prism12`) the cost has a curved valley (numerator and denominator can
//! share a factor `1 + a r^2`), and the principal point and the board poses, which trade off
//! with it, vary several times more than their linearized sigmas say. The bootstrap measures the
//! spread instead: it draws as many views as were used, with replacement, calibrates the camera
//! from them as the views were calibrated, and takes each parameter's spread over the refits
//! about the calibration's estimate (`docs/camera-model.md`, "Terms the data does not
//! determine").
//!
//! Opt-in (`calib single --bootstrap N`): a refit costs about what the calibration's own solve
//! costs, so `N` resamples cost about `N` calibrations, spread over the threads.

use crate::observations::Observations;
use crate::result::Calibration;
use calib_core::problem::{CameraSpec, JointProblem, ObservationSpec};
use calib_core::single::{camera_param_names, fixed_camera_components};
use calib_core::solve::JointSolution;
use calib_core::warnings::{Warning, WarningCode};
use calib_core::{CalibrationError, CalibrationOptions, View, prepare_camera};
use camera_model::Pose;
use lm_solver::Rng;
use nalgebra::Vector2;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// The fewest resamples [`bootstrap`] accepts: below 10 the standard deviation of a parameter is
/// itself uncertain by more than 25% (relative standard error `1 / sqrt(2 (N - 1))`).
pub const MIN_RESAMPLES: usize = 10;

/// The fewest used views [`bootstrap`] accepts. A resample must show at least this many distinct
/// views (resamples with fewer are drawn again): fewer do not determine the principal point.
pub const MIN_VIEWS: usize = 3;

/// A bootstrap standard deviation more than this many times the linearized sigma gets the
/// `bootstrap-spread` warning. On polynomial models (where the linearized sigmas hold) the ratio
/// scatters around 1 (`benches/bootstrap/run.sh`); the rational models' principal point reaches
/// 3 to 30.
pub const SPREAD_WARNING_RATIO: f64 = 3.0;

/// Settings of [`bootstrap`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BootstrapOptions {
    /// Number of resamples (at least [`MIN_RESAMPLES`]; 100 gives each sigma to about 7%,
    /// `1 / sqrt(2 (N - 1))`).
    pub resamples: usize,
    /// Seed of the resampling: the same seed, observations and calibration give the same result
    /// on every platform and with any number of threads.
    pub seed: u64,
    /// Where each refit starts (default [`BootstrapStart::Calibration`]).
    pub start: BootstrapStart,
}

impl Default for BootstrapOptions {
    fn default() -> Self {
        Self {
            resamples: 100,
            seed: 1,
            start: BootstrapStart::Calibration,
        }
    }
}

/// Where [`bootstrap`]'s refits start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BootstrapStart {
    /// Each resample is calibrated as the views were: the same options and start (closed form,
    /// and for the rational models the `brown-conrady5` stage), without outlier rejection (the
    /// calibration's rejected points left out) and without the covariance and diagnostics. The
    /// spread is then that of the estimator itself, including the minima of the rational valley
    /// it may end in.
    #[default]
    Calibration,
    /// Each refit starts at the calibration's solution (camera and the drawn views' poses). No
    /// faster on the measured cases, and on the rational models the refits stay near the
    /// calibration's minimum, so the spread comes out too small:
    /// over 50 rational8 cameras the RMS of z for cx, cy was 2.1 and 2.9
    /// (`benches/bootstrap/run.sh --warm --only views20.rational8`). Kept for that comparison.
    Solution,
}

/// The spread of the camera parameters over view resamples (`bootstrap` in result files).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Bootstrap {
    /// Resamples drawn.
    pub resamples: usize,
    /// Resamples whose refit failed (solver error); the standard deviations are over the others.
    pub failed: usize,
    /// Seed of the resampling.
    pub seed: u64,
    /// The bootstrap sigmas of `fx, fy, cx, cy`, pixels (zero for parameters held fixed): for
    /// each parameter `sqrt(s^2 + (m - estimate)^2)`, with `m` and `s` the trimmed mean and
    /// standard deviation of its refits (5% dropped at each end, `s` scaled to estimate a normal
    /// standard deviation): the refits' spread about the calibration's own estimate.
    pub intrinsics_std: [f64; 4],
    /// The bootstrap sigmas of the distortion coefficients (the same definition), in the model's
    /// (OpenCV's) order (zero for coefficients held fixed).
    pub distortion_std: Vec<f64>,
    /// Wall time of the bootstrap, seconds.
    pub elapsed_seconds: f64,
}

impl Bootstrap {
    /// The `bootstrap-spread` warning for `calibration` when a free parameter's bootstrap
    /// standard deviation exceeds [`SPREAD_WARNING_RATIO`] times its linearized sigma: the
    /// intrinsics with their ratios (worst first), then the distortion coefficients by name;
    /// `None` when no parameter does.
    pub fn warning(&self, calibration: &Calibration) -> Option<Warning> {
        let names = camera_param_names(calibration.camera.model);
        let free: Vec<bool> = names
            .iter()
            .map(|name| !calibration.fixed_parameters.iter().any(|f| f == name))
            .collect();
        let linear: Vec<f64> = calibration
            .intrinsics_std
            .iter()
            .chain(&calibration.distortion_std)
            .copied()
            .collect();
        let spread: Vec<f64> = self
            .intrinsics_std
            .iter()
            .chain(&self.distortion_std)
            .copied()
            .collect();
        let clause = SpreadClause {
            prefix: "",
            coefficient_owner: "",
            names: &names,
            listed: 4,
            free: &free,
            linear: &linear,
            spread: &spread,
        };
        spread_warning(&[clause.text()?])
    }

    /// The summary lines: the bootstrap's +- 3 sigma next to the linearized ones.
    pub fn summary(&self, calibration: &Calibration) -> String {
        let three = |v: &[f64]| {
            v.iter()
                .map(|s| format!("{:.5}", 3.0 * s))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let (b, l) = (&self.intrinsics_std, &calibration.intrinsics_std);
        let failed = if self.failed > 0 {
            format!(", {} failed", self.failed)
        } else {
            String::new()
        };
        format!(
            "  view bootstrap ({} resamples{failed}), +- 3 sigma (linearized in parentheses):\n    fx, fy = {} ({})   cx, cy = {} ({})\n    distortion = {} ({})\n",
            self.resamples,
            three(&b[..2]),
            three(&l[..2]),
            three(&b[2..]),
            three(&l[2..]),
            three(&self.distortion_std),
            three(&calibration.distortion_std),
        )
    }
}

/// One part of a `bootstrap-spread` warning: the parameters of one camera (or of a rig) whose
/// bootstrap standard deviation exceeds [`SPREAD_WARNING_RATIO`] times the linearized one.
/// Shared by the single-camera and the stereo bootstrap (`calib_stereo::bootstrap`).
#[derive(Debug, Clone, Copy)]
pub struct SpreadClause<'a> {
    /// Put before each parameter's name: `""` for a single camera, `"left "` for a stereo
    /// pair's camera.
    pub prefix: &'a str,
    /// Put before "distortion coefficient(s)": `""`, or `"left camera's "`.
    pub coefficient_owner: &'a str,
    /// The parameters' names (`fx, fy, cx, cy` and the coefficients, or a rig's six).
    pub names: &'a [&'a str],
    /// How many leading parameters are named with their ratio (4 for a camera: the intrinsics;
    /// the rest are distortion coefficients, named without it).
    pub listed: usize,
    /// Whether each parameter is estimated (held parameters never warn).
    pub free: &'a [bool],
    /// Linearized standard deviations, in `names`' order.
    pub linear: &'a [f64],
    /// Bootstrap standard deviations, in `names`' order.
    pub spread: &'a [f64],
}

impl SpreadClause<'_> {
    /// The clause, e.g. "cx's bootstrap spread is 7x its linearized sigma, cy's 5x (and the
    /// distortion coefficients k4, k5 beyond 3x)", worst ratio first; `None` when no free
    /// parameter exceeds [`SPREAD_WARNING_RATIO`]. A zero linearized sigma of a free parameter
    /// (no covariance) counts as exceeded.
    pub fn text(&self) -> Option<String> {
        let over: Vec<(usize, &str, f64)> = self
            .names
            .iter()
            .zip(self.linear.iter().zip(self.spread))
            .enumerate()
            .filter(|(i, _)| self.free.get(*i).copied().unwrap_or(false))
            .filter(|(_, (_, (l, b)))| **b > SPREAD_WARNING_RATIO * **l && **b > 0.0)
            .map(|(i, (name, (l, b)))| (i, *name, b / l))
            .collect();
        if over.is_empty() {
            return None;
        }
        let mut listed: Vec<&(usize, &str, f64)> =
            over.iter().filter(|p| p.0 < self.listed).collect();
        listed.sort_by(|a, b| b.2.total_cmp(&a.2));
        let ratio = |r: f64| {
            if r.is_finite() && r < 1e4 {
                format!("{r:.0}x")
            } else {
                "far beyond".into()
            }
        };
        let prefix = self.prefix;
        let text: Vec<String> = listed
            .iter()
            .enumerate()
            .map(|(k, (_, name, r))| match k {
                0 => format!(
                    "{prefix}{name}'s bootstrap spread is {} its linearized sigma",
                    ratio(*r)
                ),
                _ => format!("{prefix}{name}'s {}", ratio(*r)),
            })
            .collect();
        let coefficients: Vec<&str> = over
            .iter()
            .filter(|p| p.0 >= self.listed)
            .map(|p| p.1)
            .collect();
        let limit = SPREAD_WARNING_RATIO;
        let owner = self.coefficient_owner;
        let mut message = text.join(", ");
        match (coefficients.len(), text.is_empty()) {
            (0, _) => {}
            (1, true) => {
                message = format!(
                    "the {owner}distortion coefficient {}'s bootstrap spread exceeds {limit:.0}x its linearized sigma",
                    coefficients[0]
                )
            }
            (_, true) => {
                message = format!(
                    "the bootstrap spreads of the {owner}distortion coefficients {} exceed {limit:.0}x their linearized sigmas",
                    coefficients.join(", ")
                )
            }
            (_, false) => message.push_str(&format!(
                " (and the {owner}distortion coefficients {} beyond {limit:.0}x)",
                coefficients.join(", ")
            )),
        }
        Some(message)
    }
}

/// The `bootstrap-spread` warning made of `clauses` (joined by "; "), with the advice; `None`
/// for no clause.
pub fn spread_warning(clauses: &[String]) -> Option<Warning> {
    if clauses.is_empty() {
        return None;
    }
    Some(Warning::new(
        WarningCode::BootstrapSpread,
        format!(
            "{}: the linearized sigmas of this fit are not honest; quote the bootstrap's standard deviations (`bootstrap` in the result), or use a model with fewer terms",
            clauses.join("; ")
        ),
    ))
}

/// The `poorly-determined` warning that a bootstrap (`what`: "view bootstrap", "pair
/// bootstrap") over `n` resampled `items` ("views", "pairs") is rough, when `n` is below
/// [`ROUGH_BELOW_VIEWS`].
pub fn rough_warning(n: usize, what: &str, items: &str) -> Option<Warning> {
    (n < ROUGH_BELOW_VIEWS).then(|| {
        Warning::new(
            WarningCode::PoorlyDetermined,
            format!(
                "the {what} over {n} {items} is rough: a resample of {n} {items} holds about {:.0} distinct ones, so its standard deviations are themselves uncertain well beyond the 7% of 100 resamples; add {items} (at least {ROUGH_BELOW_VIEWS})",
                distinct_views(n)
            ),
        )
    })
}

/// Above this fraction of failed refits [`failed_warning`] warns.
pub const FAILED_WARNING_FRACTION: f64 = 0.1;

/// The `poorly-determined` warning that `failed` of a bootstrap's `resamples` refits failed
/// (`what`: "view bootstrap", "pair bootstrap"), when more than [`FAILED_WARNING_FRACTION`] did:
/// the standard deviations are over the others, and resamples whose refit fails (a pole of a
/// rational model, a pose left free) are likely the far ones, so the spread may be understated.
/// (Not seen in the benches: none of the 6000 refits of `benches/bootstrap/run.sh --stereo
/// --seeds 30` failed.)
pub fn failed_warning(failed: usize, resamples: usize, what: &str) -> Option<Warning> {
    (failed as f64 > FAILED_WARNING_FRACTION * resamples as f64).then(|| {
        Warning::new(
            WarningCode::PoorlyDetermined,
            format!(
                "{failed} of the {what}'s {resamples} refits failed: its standard deviations are over the other {}, and the failed resamples may be the far ones, so they may understate the spread; add views covering the image or use a model with fewer terms",
                resamples - failed
            ),
        )
    })
}

/// The view bootstrap of `calibration`, the result of [`crate::calibrate`] on `observations`
/// with `options`: `settings.resamples` times, draws as many of the calibration's used views as
/// it has, with replacement (a view drawn `m` times weighs `m`; a resample with fewer than
/// [`MIN_VIEWS`] distinct views is drawn again), refits the camera and the drawn views' poses
/// as the views were calibrated (see [`BootstrapStart`]; its rejected points left out, no outlier
/// rejection, no covariance, no diagnostics; the parameters `options` holds stay held), and
/// returns each parameter's spread over the refits about the calibration's estimate
/// ([`Bootstrap::intrinsics_std`]). A refit that fails is left out and counted.
///
/// # Errors
///
/// [`CalibrationError::Bootstrap`] for fewer than [`MIN_RESAMPLES`] resamples, fewer than
/// [`MIN_VIEWS`] used views, a calibration whose views are not in `observations`, or fewer than
/// [`MIN_RESAMPLES`] refits that succeed.
pub fn bootstrap(
    observations: &Observations,
    options: &CalibrationOptions,
    calibration: &Calibration,
    settings: &BootstrapOptions,
) -> Result<Bootstrap, CalibrationError> {
    let start = Instant::now();
    let refuse = |reason: String| Err(CalibrationError::Bootstrap(reason));
    if settings.resamples < MIN_RESAMPLES {
        return refuse(format!(
            "{} resamples asked for, at least {MIN_RESAMPLES} are needed",
            settings.resamples
        ));
    }
    let n = calibration.views.len();
    if n < MIN_VIEWS {
        return refuse(format!(
            "the calibration used {n} view{}; resampling needs at least {MIN_VIEWS}",
            if n == 1 { "" } else { "s" }
        ));
    }
    // Each used view's points, with weight zero for the points the calibration rejected.
    let mut views = Vec::with_capacity(n);
    for v in &calibration.views {
        let Some(view) = observations
            .views
            .get(v.index)
            .filter(|view| view.object_points.len() == view.image_points.len())
        else {
            return refuse(format!(
                "view {} of the calibration is not in the observations",
                v.index
            ));
        };
        let mut weights = vec![1.0; view.object_points.len()];
        for &r in &v.rejected_points {
            match weights.get_mut(r) {
                Some(w) => *w = 0.0,
                None => {
                    return refuse(format!(
                        "view {}: rejected point {r} is not in the observations",
                        v.index
                    ));
                }
            }
        }
        views.push((v, view, weights));
    }
    let model = calibration.camera.model;
    let mut spec = CameraSpec::new("camera", calibration.image_size, calibration.camera.clone());
    spec.fixed = fixed_camera_components(options, n);
    spec.aspect_ratio = options
        .fix_aspect_ratio
        .then(|| calibration.camera.intrinsics.fx / calibration.camera.intrinsics.fy);
    let mut solve_options = options.solve_options();
    solve_options.rotation = calibration.rotation;
    solve_options.compute_uncertainty = false;
    solve_options.outliers = None;
    solve_options.camera_warnings = false;
    solve_options.recheck_without_suspects = false;
    let warm = |counts: &[usize]| -> Option<JointSolution> {
        let mut problem = JointProblem {
            cameras: vec![spec.clone()],
            reference: 0,
            rig: vec![Pose::identity()],
            rig_fixed: vec![true],
            frame_names: Vec::new(),
            frames: Vec::new(),
            observations: Vec::new(),
        };
        for ((v, view, weights), &m) in views.iter().zip(counts) {
            if m == 0 {
                continue;
            }
            let frame = problem.frames.len();
            problem
                .frame_names
                .push(calib_core::view_location(v.index, &v.name));
            problem.frames.push(v.pose);
            let mut o = ObservationSpec::new(
                0,
                frame,
                v.name.clone(),
                view.object_points.clone(),
                view.image_points
                    .iter()
                    .map(|p| Vector2::new(p.x, p.y))
                    .collect(),
            );
            o.weights = Some(weights.iter().map(|w| w * m as f64).collect());
            problem.observations.push(o);
        }
        calib_core::solve(&problem, &solve_options).ok()
    };
    // The views with the calibration's rejected points left out, for refits from the start.
    let kept: Vec<View> = views
        .iter()
        .map(|(v, view, weights)| {
            let keep = |i: &usize| weights[*i] > 0.0;
            let n = weights.len();
            View {
                name: v.name.clone(),
                object_points: (0..n).filter(keep).map(|i| view.object_points[i]).collect(),
                image_points: (0..n).filter(keep).map(|i| view.image_points[i]).collect(),
            }
        })
        .collect();
    let mut refit_options = options.clone();
    refit_options.outliers = None;
    refit_options.compute_uncertainty = false;
    refit_options.drop_duplicate_views = false;
    refit_options.skip_bad_views = false;
    let mut cold_solve = refit_options.solve_options();
    cold_solve.camera_warnings = false;
    let cold = |counts: &[usize]| -> Option<JointSolution> {
        let picked: Vec<(usize, &View)> = counts
            .iter()
            .zip(views.iter().zip(&kept))
            .flat_map(|(&m, ((v, _, _), view))| std::iter::repeat_n((v.index, view), m))
            .collect();
        let mut prepared =
            prepare_camera(&picked, Some(calibration.image_size), &refit_options).ok()?;
        let problem = prepared.take_problem("camera");
        calib_core::solve(&problem, &prepared.solve_options(&cold_solve)).ok()
    };
    let refit = |b: usize| -> Option<Vec<f64>> {
        let counts = draw(n, settings.seed, b);
        let solution = match settings.start {
            BootstrapStart::Calibration => cold(&counts)?,
            BootstrapStart::Solution => warm(&counts)?,
        };
        let camera = &solution.cameras[0];
        let k = &camera.intrinsics;
        let mut params = vec![k.fx, k.fy, k.cx, k.cy];
        params.extend_from_slice(&camera.distortion);
        params.iter().all(|p| p.is_finite()).then_some(params)
    };
    let refits: Vec<Option<Vec<f64>>> =
        (0..settings.resamples).into_par_iter().map(refit).collect();
    let good: Vec<&Vec<f64>> = refits.iter().flatten().collect();
    if good.len() < MIN_RESAMPLES {
        return refuse(format!(
            "only {} of {} refits succeeded, at least {MIN_RESAMPLES} are needed",
            good.len(),
            settings.resamples
        ));
    }
    let k = calibration.camera.intrinsics;
    let estimate: Vec<f64> = [k.fx, k.fy, k.cx, k.cy]
        .into_iter()
        .chain(calibration.camera.distortion.iter().copied())
        .collect();
    let std: Vec<f64> = (0..model.num_params())
        .map(|j| spread_about(good.iter().map(|p| p[j]).collect(), estimate[j]))
        .collect();
    Ok(Bootstrap {
        resamples: settings.resamples,
        failed: settings.resamples - good.len(),
        seed: settings.seed,
        intrinsics_std: [std[0], std[1], std[2], std[3]],
        distortion_std: std[4..].to_vec(),
        elapsed_seconds: start.elapsed().as_secs_f64(),
    })
}

/// [`bootstrap`], stored in `calibration.bootstrap` with its `bootstrap-spread` warning (if
/// any) added to `calibration.warnings`.
///
/// # Errors
///
/// Those of [`bootstrap`]; `calibration` is then unchanged.
pub fn add_bootstrap(
    calibration: &mut Calibration,
    observations: &Observations,
    options: &CalibrationOptions,
    settings: &BootstrapOptions,
) -> Result<(), CalibrationError> {
    let result = bootstrap(observations, options, calibration, settings)?;
    calibration.warnings.extend(result.warning(calibration));
    calibration.warnings.extend(rough_warning(
        calibration.views.len(),
        "view bootstrap",
        "views",
    ));
    calibration.warnings.extend(failed_warning(
        result.failed,
        result.resamples,
        "view bootstrap",
    ));
    calibration.bootstrap = Some(result);
    Ok(())
}

/// Below this many used views [`add_bootstrap`] warns (`poorly-determined`) that the bootstrap
/// is rough: a resample of `n` views holds about `n (1 - (1 - 1/n)^n)` distinct ones (6.5 of
/// 10, 3.9 of 6), and the resamples of few views lie close to [`MIN_VIEWS`], where the principal
/// point is barely determined. Measured down to 12 views (`benches/bootstrap/run.sh`: z 0.79 to
/// 0.87 for rational8); below 10 it is not measured.
pub const ROUGH_BELOW_VIEWS: usize = 10;

/// Expected number of distinct views in a resample of `n` views drawn with replacement.
fn distinct_views(n: usize) -> f64 {
    let n = n as f64;
    n * (1.0 - (1.0 - 1.0 / n).powf(n))
}

/// The bootstrap standard deviation of one parameter from its refits `values` (at least 3)
/// about the calibration's `estimate`: `sqrt(s^2 + (m - estimate)^2)`, with `m` and `s` the
/// trimmed mean and standard deviation of the values ([`TRIM_FRACTION`] dropped at each end, `s`
/// scaled to estimate a normal standard deviation). In the values' units.
pub fn spread_about(values: Vec<f64>, estimate: f64) -> f64 {
    let (mean, spread) = trimmed_spread(values);
    spread.hypot(mean - estimate)
}

/// Fraction of the refits left out at each end before the spread is taken.
pub const TRIM_FRACTION: f64 = 0.05;

/// The trimmed mean and standard deviation of `values` (at least 3): those of the values left
/// after dropping the `round(TRIM_FRACTION n)` smallest and as many largest, the standard
/// deviation (sample, `n - 1`) divided by that of a unit normal truncated to the same central
/// fraction (0.789 for 5% at each end), so that it estimates the standard deviation of normally
/// distributed values. A refit that ends in a far minimum of a rational model's valley (fx 100
/// px off where the others scatter by 3) would otherwise dominate the plain standard deviation:
/// for thin-prism12 it inflated fx's sigma well beyond the errors, where the trimmed one (with
/// the offset of [`Bootstrap::intrinsics_std`]) gives an RMS of z of 0.62 to 0.71 over 50 seeds
/// (`benches/bootstrap/run.sh`).
fn trimmed_spread(mut values: Vec<f64>) -> (f64, f64) {
    let n = values.len();
    values.sort_by(f64::total_cmp);
    let drop = ((TRIM_FRACTION * n as f64).round() as usize).min((n - 3) / 2);
    let kept = &values[drop..n - drop];
    let count = kept.len() as f64;
    let mean = kept.iter().sum::<f64>() / count;
    let ss = kept.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
    (
        mean,
        (ss / (count - 1.0)).sqrt() / truncated_normal_std(drop as f64 / n as f64),
    )
}

/// Standard deviation of a unit normal truncated to its central `1 - 2 p` (`p` below 1/2): with
/// `z` its upper `p` quantile, `sqrt(1 - 2 z phi(z) / (1 - 2 p))`; 1 for `p = 0`.
fn truncated_normal_std(p: f64) -> f64 {
    if p <= 0.0 {
        return 1.0;
    }
    // The quantile by bisection on the upper tail Q(z) = erfc(z / sqrt 2) / 2, decreasing in z.
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if upper_tail(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let z = 0.5 * (lo + hi);
    let density = (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
    (1.0 - 2.0 * z * density / (1.0 - 2.0 * p)).sqrt()
}

/// The upper tail of the unit normal, `Q(z) = erfc(z / sqrt 2) / 2`, for `z >= 0`: Abramowitz
/// and Stegun 7.1.26 (absolute error below 1.5e-7 in `erfc`).
fn upper_tail(z: f64) -> f64 {
    let x = z / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    0.5 * poly * (-x * x).exp()
}

/// How many times each of `n` views (or stereo pairs) is drawn in resample `b` of `seed`: `n`
/// draws with replacement, again until at least [`MIN_VIEWS`] distinct ones are drawn (`n >=
/// MIN_VIEWS`). The same on every platform and whatever the thread count.
pub fn draw(n: usize, seed: u64, b: usize) -> Vec<usize> {
    let mut rng = Rng::new(seed.wrapping_mul(0x0001_0000_0001).wrapping_add(b as u64));
    loop {
        let mut counts = vec![0usize; n];
        for _ in 0..n {
            // Uniform in 0..n (n is far below 2^53).
            let k = ((rng.uniform() * n as f64) as usize).min(n - 1);
            counts[k] += 1;
        }
        if counts.iter().filter(|&&m| m > 0).count() >= MIN_VIEWS.min(n) {
            return counts;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_are_deterministic_and_sum_to_the_view_count() {
        for n in [3, 4, 20] {
            for b in 0..50 {
                let counts = draw(n, 7, b);
                assert_eq!(counts, draw(n, 7, b));
                assert_eq!(counts.iter().sum::<usize>(), n);
                assert!(counts.iter().filter(|&&m| m > 0).count() >= MIN_VIEWS);
            }
        }
        assert_ne!(draw(20, 7, 0), draw(20, 8, 0));
    }

    #[test]
    fn many_failed_refits_are_warned() {
        assert!(failed_warning(0, 100, "view bootstrap").is_none());
        assert!(failed_warning(10, 100, "view bootstrap").is_none());
        let w = failed_warning(11, 100, "pair bootstrap").unwrap();
        assert_eq!(w.code, WarningCode::PoorlyDetermined);
        assert!(
            w.message
                .starts_with("11 of the pair bootstrap's 100 refits failed")
                && w.message.contains("other 89"),
            "{}",
            w.message
        );
    }

    #[test]
    fn truncated_normal_factor_matches_the_closed_form() {
        assert_eq!(truncated_normal_std(0.0), 1.0);
        // 5% at each end: z = 1.6449, sqrt(1 - 2 z phi(z) / 0.9) = 0.7892.
        assert!((truncated_normal_std(0.05) - 0.7892).abs() < 1e-3);
        // 10%: z = 1.2816, 0.6616.
        assert!((truncated_normal_std(0.10) - 0.6616).abs() < 1e-3);
    }

    #[test]
    fn trimmed_spread_estimates_a_normal_spread_and_ignores_far_values() {
        // 2000 unit normals: the estimate lies within 5 standard errors (about 2% each).
        let mut rng = Rng::new(3);
        let values: Vec<f64> = (0..2000).map(|_| 2.0 * rng.normal()).collect();
        let (mean, s) = trimmed_spread(values.clone());
        assert!((s - 2.0).abs() < 5.0 * 2.0 * 0.02, "{s}");
        assert!(mean.abs() < 5.0 * 2.0 / 2000f64.sqrt(), "{mean}");
        // Four values of 100 in 100 (far minima) barely move it, where the plain std is 20.
        let mut mixed: Vec<f64> = values[..96].to_vec();
        mixed.extend([100.0; 4]);
        let (_, s) = trimmed_spread(mixed);
        assert!((1.4..2.8).contains(&s), "{s}");
    }
}
