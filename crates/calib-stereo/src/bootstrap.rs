//! The pair bootstrap: standard deviations of both cameras and of the rig from refits of
//! resampled pairs, for lens models whose linearized sigmas are too small.
//!
//! The stereo counterpart of the single-camera view bootstrap (`calib_single::bootstrap`, whose
//! resampling, trimmed spread and warnings it uses): it draws as many of the calibration's used
//! pairs as it has, with replacement, calibrates the rig from them as the pairs were calibrated,
//! and takes each parameter's spread over the refits about the calibration's estimate. Worth it
//! for the rational models (`rational8`, `thin-prism12`), whose linearized principal-point
//! sigmas are several times too small (`docs/calib-stereo.md`, "Honest standard deviations").
//!
//! Opt-in (`calib stereo --bootstrap N`): a refit costs about what the stereo calibration
//! costs, so `N` resamples cost about `N` calibrations, spread over the threads.

use crate::calibrate::refit_pairs;
use crate::error::StereoError;
use crate::observations::{StereoObservations, StereoPair};
use crate::options::StereoOptions;
use crate::result::StereoCalibration;
use calib_core::View;
use calib_core::result::CameraEstimate;
use calib_core::single::camera_param_names;
use calib_core::warnings::Warning;
use calib_single::bootstrap::{
    BootstrapOptions, BootstrapStart, MIN_RESAMPLES, MIN_VIEWS, SpreadClause, draw, failed_warning,
    rough_warning, spread_about, spread_warning,
};
use camera_model::{AxisAngle, RotationKind, RotationParameterization};
use rayon::prelude::*;
use std::time::Instant;

/// Names of the rig's six parameters in warnings and summaries: the rotation's three (body-frame
/// increments for `so3`, else the parameterization's own) and `T`'s.
pub const RIG_PARAM_NAMES: [&str; 6] = ["rx", "ry", "rz", "Tx", "Ty", "Tz"];

/// The bootstrap standard deviations of one camera of the pair.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraSpread {
    /// `fx, fy, cx, cy`, pixels.
    pub intrinsics_std: [f64; 4],
    /// The distortion coefficients, in the model's (OpenCV's) order.
    pub distortion_std: Vec<f64>,
}

/// The spread of the stereo parameters over pair resamples (`bootstrap` in stereo result
/// files). Each standard deviation is `sqrt(s^2 + (m - estimate)^2)`, with `m` and `s` the
/// trimmed mean and standard deviation of the parameter's refits (`calib_single::bootstrap::
/// spread_about`): the refits' spread about the calibration's own estimate. A parameter held at
/// a guess gets zero; one held at its camera's single-camera estimate
/// (`fix_left_intrinsics` without a guess) gets that estimate's spread over the resamples.
#[derive(Debug, Clone, PartialEq)]
pub struct StereoBootstrap {
    /// Resamples drawn.
    pub resamples: usize,
    /// Resamples whose refit failed; the standard deviations are over the others.
    pub failed: usize,
    /// Seed of the resampling.
    pub seed: u64,
    /// The left camera's.
    pub left: CameraSpread,
    /// The right camera's.
    pub right: CameraSpread,
    /// The rig's six parameters in the order and units of `StereoCalibration::rig_std`
    /// (radians, board units): with the `so3` parameterization the rotation's are the body-frame
    /// increments `log(R^T R_refit)`, the convention of the linearized sigmas.
    pub rig_std: [f64; 6],
    /// The baseline `|T|`'s, board units.
    pub baseline_std: f64,
    /// Wall time of the bootstrap, seconds.
    pub elapsed_seconds: f64,
}

impl StereoBootstrap {
    /// The `bootstrap-spread` warning for `calibration` when a free parameter's bootstrap
    /// standard deviation exceeds `calib_single::bootstrap::SPREAD_WARNING_RATIO` times its
    /// linearized sigma, naming the camera ("left cx's bootstrap spread is 7x its linearized
    /// sigma") or the rig ("rig Tx's ..."); `None` when no parameter does.
    pub fn warning(&self, calibration: &StereoCalibration) -> Option<Warning> {
        let mut clauses = Vec::new();
        for (side, estimate, spread) in [
            ("left", &calibration.left, &self.left),
            ("right", &calibration.right, &self.right),
        ] {
            let names = camera_param_names(estimate.camera.model);
            let free: Vec<bool> = names
                .iter()
                .map(|n| !estimate.fixed_parameters.iter().any(|f| f == n))
                .collect();
            let linear = camera_values(&estimate.intrinsics_std, &estimate.distortion_std);
            let boot = camera_values(&spread.intrinsics_std, &spread.distortion_std);
            let prefix = format!("{side} ");
            let owner = format!("{side} camera's ");
            clauses.extend(
                SpreadClause {
                    prefix: &prefix,
                    coefficient_owner: &owner,
                    names: &names,
                    listed: 4,
                    free: &free,
                    linear: &linear,
                    spread: &boot,
                }
                .text(),
            );
        }
        clauses.extend(
            SpreadClause {
                prefix: "rig ",
                coefficient_owner: "",
                names: &RIG_PARAM_NAMES,
                listed: 6,
                free: &[true; 6],
                linear: &calibration.rig_std,
                spread: &self.rig_std,
            }
            .text(),
        );
        spread_warning(&clauses)
    }

    /// The summary lines: the bootstrap's +- 3 sigma next to the linearized ones.
    pub fn summary(&self, calibration: &StereoCalibration) -> String {
        let three = |v: &[f64]| {
            v.iter()
                .map(|s| format!("{:.5}", 3.0 * s))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let failed = if self.failed > 0 {
            format!(", {} failed", self.failed)
        } else {
            String::new()
        };
        let mut out = format!(
            "  pair bootstrap ({} resamples{failed}), +- 3 sigma (linearized in parentheses):\n",
            self.resamples
        );
        for (side, estimate, spread) in [
            ("left", &calibration.left, &self.left),
            ("right", &calibration.right, &self.right),
        ] {
            let (b, l) = (&spread.intrinsics_std, &estimate.intrinsics_std);
            out.push_str(&format!(
                "    {side}: fx, fy = {} ({})   cx, cy = {} ({})\n      distortion = {} ({})\n",
                three(&b[..2]),
                three(&l[..2]),
                three(&b[2..]),
                three(&l[2..]),
                three(&spread.distortion_std),
                three(&estimate.distortion_std),
            ));
        }
        let (b, l) = (&self.rig_std, &calibration.rig_std);
        out.push_str(&format!(
            "    rig: rotation = {} ({}) rad   T = {} ({})   baseline = {:.5}\n",
            three(&b[..3]),
            three(&l[..3]),
            three(&b[3..]),
            three(&l[3..]),
            3.0 * self.baseline_std,
        ));
        out
    }
}

fn camera_values(intrinsics: &[f64; 4], distortion: &[f64]) -> Vec<f64> {
    intrinsics.iter().chain(distortion).copied().collect()
}

fn camera_params(estimate: &CameraEstimate) -> Vec<f64> {
    let k = estimate.camera.intrinsics;
    let mut v = vec![k.fx, k.fy, k.cx, k.cy];
    v.extend_from_slice(&estimate.camera.distortion);
    v
}

/// The rig's six parameters of `refit` as deviations comparable with `calibration.rig_std`:
/// for `so3` the rotation's body-frame increment from the calibration's rotation and `T`; for
/// the other parameterizations the parameters themselves.
fn rig_values(calibration: &StereoCalibration, refit: &StereoCalibration) -> [f64; 6] {
    let t = refit.rig.translation;
    match calibration.rotation {
        RotationKind::So3 => {
            let d = AxisAngle::from_matrix(
                &(calibration.rig.rotation.transpose() * refit.rig.rotation),
            );
            [d.x, d.y, d.z, t.x, t.y, t.z]
        }
        _ => refit.rig_params,
    }
}

/// The pair bootstrap of `calibration`, the result of [`crate::calibrate_stereo`] on
/// `observations` with `options`: `settings.resamples` times, draws as many of the
/// calibration's used pairs as it has, with replacement (a pair drawn `m` times weighs `m`; a
/// resample with fewer than `calib_single::bootstrap::MIN_VIEWS` distinct pairs is drawn again),
/// and calibrates the rig from them as the pairs were calibrated: the same options and start
/// (each camera alone, the initial rig, the joint solve), without outlier rejection (the
/// calibration's rejected points left out), without the covariance, the pair checks and the
/// diagnostics. Returns each parameter's spread over the refits about the calibration's
/// estimate. A refit that fails is left out and counted. Deterministic for a seed, whatever the
/// thread count.
///
/// # Errors
///
/// [`StereoError::Bootstrap`] for fewer than `MIN_RESAMPLES` (10) resamples, fewer than
/// `MIN_VIEWS` (3) used pairs, `settings.start` other than [`BootstrapStart::Calibration`], a
/// calibration whose pairs or rejected points are not in `observations`, or fewer than
/// `MIN_RESAMPLES` refits that succeed.
pub fn bootstrap(
    observations: &StereoObservations,
    options: &StereoOptions,
    calibration: &StereoCalibration,
    settings: &BootstrapOptions,
) -> Result<StereoBootstrap, StereoError> {
    let start = Instant::now();
    let refuse = |reason: String| Err(StereoError::Bootstrap(reason));
    if settings.resamples < MIN_RESAMPLES {
        return refuse(format!(
            "{} resamples asked for, at least {MIN_RESAMPLES} are needed",
            settings.resamples
        ));
    }
    if settings.start != BootstrapStart::Calibration {
        return refuse(
            "the stereo bootstrap refits each resample from the start only (BootstrapStart::Calibration)"
                .into(),
        );
    }
    let n = calibration.pairs.len();
    if n < MIN_VIEWS {
        return refuse(format!(
            "the calibration used {n} pair{}; resampling needs at least {MIN_VIEWS}",
            if n == 1 { "" } else { "s" }
        ));
    }
    // The used pairs with the calibration's rejected points left out.
    let mut pairs = Vec::with_capacity(n);
    for p in &calibration.pairs {
        let Some(pair) = observations.pairs.get(p.index) else {
            return refuse(format!(
                "pair {} of the calibration is not in the observations",
                p.index
            ));
        };
        let keep = |view: &View, rejected: &[usize], side: &str| {
            let count = view.object_points.len();
            if view.image_points.len() != count || rejected.iter().any(|&r| r >= count) {
                return Err(StereoError::Bootstrap(format!(
                    "pair {}: the calibration's rejected {side} points are not in the observations",
                    p.index
                )));
            }
            let kept = (0..count).filter(|i| !rejected.contains(i));
            Ok(View {
                name: view.name.clone(),
                object_points: kept.clone().map(|i| view.object_points[i]).collect(),
                image_points: kept.map(|i| view.image_points[i]).collect(),
            })
        };
        pairs.push(StereoPair {
            left: keep(&pair.left, &p.rejected_left, "left")?,
            right: keep(&pair.right, &p.rejected_right, "right")?,
        });
    }
    let used = StereoObservations {
        image_size: observations.image_size,
        right_image_size: observations.right_image_size,
        pairs,
    };
    let mut refit_options = options.clone();
    refit_options.outliers = None;
    refit_options.skip_bad_pairs = false;
    refit_options.rotation = calibration.rotation;
    for camera in [&mut refit_options.left, &mut refit_options.right] {
        camera.outliers = None;
        camera.compute_uncertainty = false;
    }
    let refit = |b: usize| -> Option<Vec<f64>> {
        let counts = draw(n, settings.seed, b);
        let kept: Vec<usize> = counts
            .iter()
            .enumerate()
            .flat_map(|(k, &m)| std::iter::repeat_n(k, m))
            .collect();
        let r = refit_pairs(&used, &kept, &refit_options).ok()?;
        let mut params = camera_params(&r.left);
        params.extend(camera_params(&r.right));
        params.extend(rig_values(calibration, &r));
        params.push(r.baseline);
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
    let mut estimate = camera_params(&calibration.left);
    estimate.extend(camera_params(&calibration.right));
    estimate.extend(rig_values(calibration, calibration));
    estimate.push(calibration.baseline);
    let std: Vec<f64> = (0..estimate.len())
        .map(|j| spread_about(good.iter().map(|p| p[j]).collect(), estimate[j]))
        .collect();
    let nl = calibration.left.camera.model.num_params();
    let nr = calibration.right.camera.model.num_params();
    let camera = |s: &[f64]| CameraSpread {
        intrinsics_std: [s[0], s[1], s[2], s[3]],
        distortion_std: s[4..].to_vec(),
    };
    Ok(StereoBootstrap {
        resamples: settings.resamples,
        failed: settings.resamples - good.len(),
        seed: settings.seed,
        left: camera(&std[..nl]),
        right: camera(&std[nl..nl + nr]),
        rig_std: std::array::from_fn(|i| std[nl + nr + i]),
        baseline_std: std[nl + nr + 6],
        elapsed_seconds: start.elapsed().as_secs_f64(),
    })
}

/// [`bootstrap`], stored in `calibration.bootstrap` with its `bootstrap-spread` warning (if
/// any) added to `calibration.warnings`, and a `poorly-determined` warning that the bootstrap
/// is rough under `calib_single::bootstrap::ROUGH_BELOW_VIEWS` (10) used pairs.
///
/// # Errors
///
/// Those of [`bootstrap`]; `calibration` is then unchanged.
pub fn add_bootstrap(
    calibration: &mut StereoCalibration,
    observations: &StereoObservations,
    options: &StereoOptions,
    settings: &BootstrapOptions,
) -> Result<(), StereoError> {
    let result = bootstrap(observations, options, calibration, settings)?;
    calibration.warnings.extend(result.warning(calibration));
    calibration.warnings.extend(rough_warning(
        calibration.pairs.len(),
        "pair bootstrap",
        "pairs",
    ));
    calibration.warnings.extend(failed_warning(
        result.failed,
        result.resamples,
        "pair bootstrap",
    ));
    calibration.bootstrap = Some(result);
    Ok(())
}
