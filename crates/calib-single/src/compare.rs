//! Choosing a lens model: fit each candidate, check its validity, and cross-validate it.
//!
//! A model with more terms always reaches a lower RMS on the views it was fitted to; whether the
//! terms describe the lens or the noise shows on views it was not fitted to. Like mrcal, each
//! model is fitted on half of the views (the even-numbered ones, then the odd-numbered ones) and
//! evaluated on the other half: the camera is held at the fitted values and only the held-out
//! views' poses are estimated; the cross-validated RMS is over both halves' held-out points.
//!
//! A model fits *as well as* another ([`as_good_as`]) when two things hold. Its cross-validated
//! RMS is within [`CV_TOLERANCE`] (2%) of the other's: a difference this small does not matter.
//! And it is not systematically worse by a paired test on the held-out views
//! ([`paired_excess`]): both models are evaluated on the same views, so their per-view held-out
//! squared errors are paired, and the mean of their log ratios has a standard error estimated
//! from its spread over the views; the excess must be within [`as_good_factor`] (Student's t,
//! 97.5% one-sided) standard errors. The 2% alone let a model through that is consistently
//! worse on every view: on a rational lens at 30 views and 0.3 px, kannala-brandt4 1.8% above
//! rational8 (3.4 standard errors) was recommended with 15 px of error over the image against
//! 0.54 px (benches/compare_models). The test alone, without the 2%, was measured and
//! rejected: with few views (4 per half) it calls nearly every model as good and the simplest
//! wins, misfitting where the lowest cross-validated RMS was right (replayed on the sweep's
//! rows among the valid models: 81 of 308 recommendations worse than the true model's fit,
//! against 59 for the 2% alone). With both, 50 of 308 against 53 (docs/camera-model.md,
//! "Choosing a model").
//!
//! The recommendation is the model with the fewest parameters (the earlier row on a tie), valid
//! (one-to-one) over the image, that is as good as the best valid one; when the
//! best valid one is not as good as the best fit but a model whose fold lies within the
//! validity margin beyond the image border is, the same rule among those; when a model that
//! folds inside the image fits clearly better, the comparison says so
//! ([`ModelComparison::gap_to_best_fit`], [`ModelComparison::reference`]).

use crate::calibrate::calibrate;
use crate::observations::Observations;
use calib_core::warnings::Warning;
use calib_core::{CalibrationError, CalibrationOptions};
use camera_model::{AnyCamera, CameraModel, UndistortOptions};
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};
use std::fmt::Write;

/// A model's cross-validated RMS within this fraction of another's can count as as good
/// ([`as_good_as`]; the paired test decides within it). Alone, it decides for rows without
/// per-view held-out errors (a comparison file written before they were recorded).
pub const CV_TOLERANCE: f64 = 0.02;

/// Fewest paired held-out views for the paired test; with fewer (a view skipped in one model's
/// evaluation and not the other's), [`CV_TOLERANCE`] alone decides.
pub const MIN_PAIRED_VIEWS: usize = 3;

/// How many standard errors of the paired log ratio a model's excess held-out error may reach
/// and still count as as good as the reference: the one-sided 97.5% quantile of Student's t with
/// `views - 1` degrees of freedom (`views` paired held-out views; 1.96 beyond 30). A model is
/// then called worse than the best by chance in about 2.5% of cases where it is as good, before
/// two effects that make it more often: the best is the lowest of several noisy scores, and the
/// views of one half share the error of the camera fitted on the other half, which the spread
/// over views does not see (benches/compare_models measures the result).
pub fn as_good_factor(views: usize) -> f64 {
    // t_{0.975} for 1..=30 degrees of freedom.
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match views.saturating_sub(1) {
        0 => f64::INFINITY,
        dof if dof <= T.len() => T[dof - 1],
        _ => 1.96,
    }
}

/// The models compared by default, simplest first.
pub const MODELS: [CameraModel; 5] = [
    CameraModel::BrownConrady4,
    CameraModel::BrownConrady5,
    CameraModel::KannalaBrandt4,
    CameraModel::Rational8,
    CameraModel::ThinPrism12,
];

/// One model's row of the comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelRow {
    /// The lens model.
    pub model: CameraModel,
    /// Number of camera parameters (`fx, fy, cx, cy` and the distortion) the calibration
    /// estimates: those held fixed (coefficients by name, the principal point, focal length or
    /// aspect ratio, tangential terms held at zero) are not counted.
    pub parameters: usize,
    /// RMS on all views (pixels), or `None` if the calibration failed.
    pub rms: Option<f64>,
    /// Cross-validated RMS (pixels): fitted on one half of the views, evaluated on the other.
    pub cross_validated_rms: Option<f64>,
    /// The model is one-to-one over the whole image.
    pub valid_over_image: bool,
    /// The full calibration's warnings.
    pub warnings: Vec<Warning>,
    /// Why the calibration failed, if it did.
    pub error: Option<String>,
    /// The held-out error of each view (fitted on the other half of the views), in input order;
    /// empty without cross-validation. Its sums give `cross_validated_rms`; paired with another
    /// row's, the paired test ([`paired_excess`]).
    #[serde(default)]
    pub held_out: Vec<HeldOutView>,
    /// How far this model's held-out errors lie above the reference model's
    /// ([`ModelComparison::reference`]): the mean over the views both evaluated of the log ratio
    /// of the views' held-out squared errors ([`paired_excess`]; 0.036: 3.7% larger, negative:
    /// smaller). `None` without a reference or a paired test.
    #[serde(default)]
    pub excess_over_reference: Option<f64>,
    /// Standard error of `excess_over_reference` from the spread of the per-view log ratios
    /// (same unit). The row is as good as the reference when the excess is at
    /// most [`as_good_factor`] of the paired views times this.
    #[serde(default)]
    pub excess_std_error: Option<f64>,
}

/// One view's held-out error: the camera fitted on the other half of the views, only this
/// view's pose estimated.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HeldOutView {
    /// Index of the view in the input.
    pub view: usize,
    /// Sum of the squared reprojection errors of its points, pixels squared.
    pub squared_error: f64,
    /// Number of its points.
    pub points: usize,
}

/// The paired test of two rows: the mean over the views both evaluated of the log ratio of
/// `a`'s held-out squared error to `b`'s (`ln(e_a / e_b)`; 0.036: `a`'s errors 3.7% larger,
/// geometrically averaged), its standard error `s / sqrt(V)` (`s` the sample standard deviation
/// of the log ratios over the `V` views), and `V`. The ratio, not the difference in pixels
/// squared: a model that misfits the lens misfits the views near the border far more than the
/// others, and the spread of the differences then hid a 27-fold excess (1.7 standard errors on a
/// 150-degree fisheye), while its log ratio is large on every view. Both models see the same
/// noise on a view, so the ratio of two adequate models' errors is close to 1 on every view.
/// `None` with fewer than [`MIN_PAIRED_VIEWS`] views in common or a view without error (no
/// noise: the ratio is undefined).
pub fn paired_excess(a: &ModelRow, b: &ModelRow) -> Option<(f64, f64, usize)> {
    let ratios: Vec<f64> = a
        .held_out
        .iter()
        .filter_map(|x| {
            let y = b.held_out.iter().find(|y| y.view == x.view)?;
            Some((x.squared_error / y.squared_error).ln())
        })
        .collect();
    let v = ratios.len();
    if v < MIN_PAIRED_VIEWS || !ratios.iter().all(|r| r.is_finite()) {
        return None;
    }
    let mean = ratios.iter().sum::<f64>() / v as f64;
    let var = ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (v - 1) as f64;
    let se = (var / v as f64).sqrt();
    se.is_finite().then_some((mean, se, v))
}

/// `a` fits as well as `b`: its cross-validated RMS is within [`CV_TOLERANCE`] of `b`'s, and its
/// excess held-out error over `b`'s is within [`as_good_factor`] standard errors
/// ([`paired_excess`]; without a paired test, the first alone). False when either was not
/// cross-validated; true for a row against itself.
pub fn as_good_as(a: &ModelRow, b: &ModelRow) -> bool {
    let (Some(sa), Some(sb)) = (a.cross_validated_rms, b.cross_validated_rms) else {
        return false;
    };
    if a.model == b.model {
        return true;
    }
    sa <= sb * (1.0 + CV_TOLERANCE)
        && paired_excess(a, b).is_none_or(|(excess, se, v)| excess <= as_good_factor(v) * se)
}

/// The comparison of lens models on one camera's views. Serialized as the file
/// `calib single --compare-models -o FILE` writes (docs/formats.md), and read back from it with
/// `serde_json::from_str`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelComparison {
    /// One row per model, in the order given.
    pub rows: Vec<ModelRow>,
    /// The recommended model: the fewest parameters among the models valid over the image
    /// (`valid_over_image`) that fit as well as the best of them ([`as_good_as`]: cross-validated
    /// RMS within [`CV_TOLERANCE`] and not systematically worse by the paired test of their
    /// held-out errors), the earlier row on a tie. When the best of them does not fit as well as `best_fit`
    /// but a model one-to-one over the image itself (its fold within the validity margin beyond
    /// the border, so not `valid_over_image`) does, the same rule among those and the valid
    /// ones. `None` when no model
    /// valid over the image could be cross-validated (fewer than [`MIN_CROSS_VALIDATION_VIEWS`]
    /// views, or its fits on half of the views failed) or calibrated.
    pub recommended: Option<CameraModel>,
    /// The model with the lowest cross-validated RMS among all fitted ones, valid or not.
    pub best_fit: Option<CameraModel>,
    /// How far the recommended model's cross-validated RMS lies above `best_fit`'s, as a
    /// fraction (0.57: 57% higher). When `reference` does not fit as well as `best_fit`
    /// ([`as_good_as`]), no model valid over the image fits the lens as well as one that folds
    /// inside it: the recommendation is the best valid one, not an adequate one, and the table
    /// says so.
    pub gap_to_best_fit: Option<f64>,
    /// Names of the distortion coefficients held fixed in every model (empty: none).
    pub held_fixed: Vec<String>,
    /// The model the recommendation was measured against: the lowest cross-validated RMS among
    /// the models it was chosen from (the valid ones, or with them those one-to-one over the
    /// image itself). The rows' `excess_over_reference` are against it. `None` without a
    /// recommendation.
    #[serde(default)]
    pub reference: Option<CameraModel>,
    /// Where no board corner was seen (the image corners and edge midpoints of the
    /// `poor-coverage` warning, [`calib_core::diagnostics::uncovered_places`]), the largest
    /// distance between the pixel where the recommended model sees a ray and the pixel where
    /// another model that fits as well (one-to-one over the image itself, as good as
    /// `reference` by [`as_good_as`]) sees it. The cross-validation judges the models only
    /// where corners were seen; this says how much they differ where none were (an order of
    /// magnitude of the extrapolation's error, not a bound: docs/camera-model.md, "Choosing a
    /// model"). `None` when corners reached every image corner and edge, or no other model fits
    /// as well.
    #[serde(default)]
    pub uncovered_disagreement: Option<Disagreement>,
}

/// Two fits of the same corners disagreeing at a place of the image no board corner reached.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Disagreement {
    /// The distance, pixels, between where the recommended model and `model` see the ray that
    /// the recommended model sees at `place`.
    pub pixels: f64,
    /// The other model.
    pub model: CameraModel,
    /// The place: "top-left corner", "left edge" (its midpoint), ...
    pub place: String,
}

/// Views `keep(i)` of `observations`.
fn subset(observations: &Observations, keep: impl Fn(usize) -> bool) -> Observations {
    Observations {
        image_size: observations.image_size,
        views: observations
            .views
            .iter()
            .enumerate()
            .filter(|(i, _)| keep(*i))
            .map(|(_, v)| v.clone())
            .collect(),
    }
}

/// Sum of squared errors and point count of `test` with the camera of `options` fitted on
/// `train` held fixed, and each view's ([`HeldOutView`]; `index(i)` is the input index of
/// `test`'s view `i`).
fn held_out(
    train: &Observations,
    test: &Observations,
    index: impl Fn(usize) -> usize,
    options: &CalibrationOptions,
) -> Result<(f64, usize, Vec<HeldOutView>), CalibrationError> {
    let fitted = calibrate(train, options)?;
    let mut fixed = options.clone();
    fixed.intrinsic_guess = Some(fitted.camera.intrinsics);
    fixed.distortion_guess = Some(fitted.camera.distortion.clone());
    fixed.fix_focal_length = true;
    fixed.fix_principal_point = true;
    fixed.fix_aspect_ratio = false;
    fixed.fixed_distortion = (0..options.model.num_distortion_params()).collect();
    fixed.compute_uncertainty = false;
    // The raw held-out error: rejecting points would flatter a model that misfits them.
    fixed.outliers = None;
    let evaluated = calibrate(test, &fixed)?;
    let views = evaluated
        .views
        .iter()
        .map(|v| HeldOutView {
            view: index(v.index),
            squared_error: v.rms * v.rms * v.num_points as f64,
            points: v.num_points,
        })
        .collect();
    Ok((
        evaluated.rms * evaluated.rms * evaluated.num_points as f64,
        evaluated.num_points,
        views,
    ))
}

impl ModelRow {
    /// The row of a model that could not be fitted, and why.
    fn not_fitted(model: CameraModel, error: String) -> ModelRow {
        ModelRow {
            model,
            parameters: model.num_params(),
            rms: None,
            cross_validated_rms: None,
            valid_over_image: false,
            warnings: Vec::new(),
            error: Some(error),
            held_out: Vec::new(),
            excess_over_reference: None,
            excess_std_error: None,
        }
    }
}

/// Fewest views for the cross-validation (two per half).
pub const MIN_CROSS_VALIDATION_VIEWS: usize = 4;

/// Compares `models` on `observations` with `options` (its `model` is replaced by each
/// candidate; coefficients it holds are carried over by name, [`CalibrationOptions::for_model`],
/// its distortion guess is dropped) and `hold_fixed`, names of distortion coefficients held at
/// zero in every model that has them ("k3", "p1"; a model without the term has it at zero by
/// construction). Needs at least [`MIN_CROSS_VALIDATION_VIEWS`] views for the cross-validation;
/// fewer give rows without it and no recommendation (models are ranked by their
/// cross-validated RMS only).
pub fn compare_models(
    observations: &Observations,
    options: &CalibrationOptions,
    models: &[CameraModel],
    hold_fixed: &[&str],
) -> ModelComparison {
    let even = subset(observations, |i| i % 2 == 0);
    let odd = subset(observations, |i| i % 2 == 1);
    // Per row: the model's fit is one-to-one over the image itself (its fold, if any, lies beyond
    // the border but may lie within the validity margin).
    let mut inside_image = Vec::with_capacity(models.len());
    // Per fitted row: its camera and the board corners it used (rejected outliers left out).
    let mut fitted: Vec<(CameraModel, AnyCamera, Vec<Vector2<f64>>)> = Vec::new();
    let rows: Vec<ModelRow> = models
        .iter()
        .map(|&model| {
            let mut o = options.for_model(model);
            let own: Vec<&str> = hold_fixed
                .iter()
                .copied()
                .filter(|n| model.distortion_names().contains(n))
                .collect();
            if let Err(e) = o.fix_distortion_by_name(&own) {
                return ModelRow::not_fitted(model, e);
            }
            o.distortion_guess = None;
            let held =
                calib_core::single::fixed_camera_components(&o, observations.views.len()).len();
            let full = calibrate(observations, &o);
            let cross_validated = (observations.views.len() >= MIN_CROSS_VALIDATION_VIEWS)
                .then(|| {
                    let a = held_out(&even, &odd, |i| 2 * i + 1, &o).ok()?;
                    let b = held_out(&odd, &even, |i| 2 * i, &o).ok()?;
                    let mut views = [a.2, b.2].concat();
                    views.sort_by_key(|v| v.view);
                    Some((((a.0 + b.0) / (a.1 + b.1).max(1) as f64).sqrt(), views))
                })
                .flatten();
            let (cross_validated_rms, held_out) = match cross_validated {
                Some((cv, views)) => (Some(cv), views),
                None => (None, Vec::new()),
            };
            match full {
                Ok(r) => {
                    let size = r.image_size;
                    let validity = r.camera.validity(size.width, size.height);
                    inside_image.push((model, validity.covers_image(0.0)));
                    let used = r
                        .views
                        .iter()
                        .flat_map(|v| {
                            observations.views[v.index]
                                .image_points
                                .iter()
                                .enumerate()
                                .filter(|(j, _)| !v.rejected_points.contains(j))
                                .map(|(_, p)| Vector2::new(p.x, p.y))
                        })
                        .collect();
                    fitted.push((model, r.camera.clone(), used));
                    ModelRow {
                        model,
                        parameters: model.num_params() - held,
                        rms: Some(r.rms),
                        cross_validated_rms,
                        valid_over_image: validity
                            .covers_image(calib_core::diagnostics::VALIDITY_MARGIN),
                        warnings: r.warnings,
                        error: None,
                        held_out,
                        excess_over_reference: None,
                        excess_std_error: None,
                    }
                }
                Err(e) => ModelRow {
                    cross_validated_rms,
                    held_out,
                    ..ModelRow::not_fitted(model, e.to_string())
                },
            }
        })
        .collect();
    // Only the cross-validated error ranks models: on the views it was fitted to, a model with
    // more terms always wins (on one view the old fallback to the RMS recommended thin-prism12).
    let score = |r: &ModelRow| r.cross_validated_rms;
    let lowest = |eligible: &dyn Fn(&ModelRow) -> bool| {
        rows.iter()
            .enumerate()
            .filter_map(|(i, r)| score(r).filter(|_| eligible(r)).map(|s| (i, s)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    };
    // Among the rows `eligible` admits: the fewest parameters among those as good as the best of
    // them ([`as_good_as`]), and that best (row indices).
    let simplest_as_good = |eligible: &dyn Fn(&ModelRow) -> bool| {
        let best = lowest(eligible)?;
        rows.iter()
            .enumerate()
            .filter(|(_, r)| eligible(r) && as_good_as(r, &rows[best]))
            .min_by_key(|(_, r)| r.parameters)
            .map(|(i, _)| (i, best))
    };
    // Models whose fit folds inside the image still show what the lens needs.
    let best_fit = lowest(&|_| true);
    let adequate = |best: usize| best_fit.is_none_or(|b| as_good_as(&rows[best], &rows[b]));
    let valid = simplest_as_good(&|r: &ModelRow| r.valid_over_image);
    // When no model valid with the margin fits as well as the best fit, one whose fold lies
    // just beyond the border (within the margin) and which does fit is the one to use: on a
    // 190-degree fisheye with 1 px of noise, kannala-brandt4 folding at 105% of the corner
    // distance lost to brown-conrady4 with a cross-validated RMS five times higher (projection
    // errors of millions of pixels at the image corners, benches/compare_models).
    let in_image = |r: &ModelRow| {
        r.valid_over_image
            || inside_image
                .iter()
                .any(|&(m, inside)| m == r.model && inside)
    };
    let chosen = match valid {
        Some((_, best)) if adequate(best) => valid,
        _ => match simplest_as_good(&in_image) {
            Some((m, best)) if adequate(best) => Some((m, best)),
            _ => valid,
        },
    };
    let recommended = chosen.map(|(m, _)| rows[m].model);
    let reference = chosen.map(|(_, best)| rows[best].model);
    let uncovered_disagreement = chosen.and_then(|(m, best)| {
        let size = observations.image_size?;
        let m = rows[m].model;
        let (_, camera, used) = fitted.iter().find(|f| f.0 == m)?;
        let places = calib_core::diagnostics::uncovered_places(size, used);
        let as_good: Vec<&AnyCamera> = rows
            .iter()
            .filter(|r| r.model != m && in_image(r) && as_good_as(r, &rows[best]))
            .filter_map(|r| fitted.iter().find(|f| f.0 == r.model).map(|f| &f.1))
            .collect();
        disagreement(camera, &as_good, &places)
    });
    let gap_to_best_fit = recommended.zip(best_fit).and_then(|(m, best)| {
        let chosen = rows.iter().find(|r| r.model == m).and_then(score)?;
        Some((chosen / score(&rows[best])? - 1.0).max(0.0))
    });
    let best_fit = best_fit.map(|b| rows[b].model);
    // Each row's paired test against the reference, for the table and the file.
    let mut rows = rows;
    if let Some(reference) = chosen.map(|(_, best)| rows[best].clone()) {
        for r in &mut rows {
            if let Some((excess, se, _)) = paired_excess(r, &reference) {
                r.excess_over_reference = Some(excess);
                r.excess_std_error = Some(se);
            }
        }
    }
    let names = options.model.distortion_names();
    let mut held_fixed: Vec<String> = options
        .fixed_distortion
        .iter()
        .filter_map(|&i| names.get(i).map(|n| n.to_string()))
        .chain(hold_fixed.iter().map(|n| n.to_string()))
        .collect();
    held_fixed.sort_unstable();
    held_fixed.dedup();
    ModelComparison {
        rows,
        recommended,
        best_fit,
        gap_to_best_fit,
        reference,
        held_fixed,
        uncovered_disagreement,
    }
}

/// The largest distance over `places` between where `camera` sees a pixel's ray and where each
/// of `others` sees that ray. Rays `camera` cannot find (beyond a fold) or that another model
/// cannot project are skipped.
fn disagreement(
    camera: &AnyCamera,
    others: &[&AnyCamera],
    places: &[calib_core::diagnostics::UncoveredPlace],
) -> Option<Disagreement> {
    let options = UndistortOptions::default();
    let mut worst: Option<Disagreement> = None;
    for place in places {
        let Ok(ray) = camera.pixel_to_ray(&place.pixel, &options) else {
            continue;
        };
        for other in others {
            let Ok(pixel) = other.project_camera_point(&ray) else {
                continue;
            };
            let pixels = (pixel - place.pixel).norm();
            if pixels.is_finite() && worst.as_ref().is_none_or(|w| pixels > w.pixels) {
                worst = Some(Disagreement {
                    pixels,
                    model: other.model,
                    place: place.name.to_string(),
                });
            }
        }
    }
    worst
}

impl ModelComparison {
    /// The row of `model`.
    fn row(&self, model: CameraModel) -> Option<&ModelRow> {
        self.rows.iter().find(|r| r.model == model)
    }

    /// `best_fit` fits clearly better than `reference` (the models the recommendation was
    /// chosen from): [`as_good_as`] fails; for a file without `reference`, `gap_to_best_fit`
    /// above [`CV_TOLERANCE`].
    pub fn best_fit_clearly_better(&self) -> bool {
        let reference = self.reference.and_then(|m| self.row(m));
        match (reference, self.best_fit.and_then(|m| self.row(m))) {
            (Some(reference), Some(best)) => !as_good_as(reference, best),
            _ => self.gap_to_best_fit.is_some_and(|g| g > CV_TOLERANCE),
        }
    }

    /// The comparison as a table.
    pub fn table(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{:<16} {:>6} {:>10} {:>14} {:>8} {:>9}  held-out error vs reference",
            "model", "params", "RMS px", "cross-val px", "valid", "warnings"
        );
        let px = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.5}"));
        let reference = self.reference.and_then(|m| self.row(m));
        let versus = |r: &ModelRow| -> String {
            let Some(reference) = reference else {
                return String::new();
            };
            if r.model == reference.model {
                return "reference".to_string();
            }
            let (Some(e), Some(se)) = (r.excess_over_reference, r.excess_std_error) else {
                return String::new();
            };
            // "better": the reference is not as good as this row (a model left out of the
            // choice, one that folds inside the image).
            let verdict = if !as_good_as(reference, r) {
                "better"
            } else if as_good_as(r, reference) {
                "as good"
            } else {
                "worse"
            };
            format!(
                "{:+.1}% ({:+.1} se): {verdict}",
                100.0 * e.exp_m1(),
                if se > 0.0 { e / se } else { 0.0 }
            )
        };
        for r in &self.rows {
            let _ = writeln!(
                out,
                "{:<16} {:>6} {:>10} {:>14} {:>8} {:>9}  {}{}",
                r.model.name(),
                r.parameters,
                px(r.rms),
                px(r.cross_validated_rms),
                if r.valid_over_image { "yes" } else { "no" },
                r.warnings.len(),
                versus(r),
                r.error
                    .as_ref()
                    .map_or(String::new(), |e| format!("  not fitted: {e}"))
            );
        }
        if reference.is_some() {
            let _ = writeln!(
                out,
                "(held-out error vs reference: how much larger the squared errors are on the same views, geometric mean of the per-view ratios, and that in standard errors of their spread over the views; as good: cross-validated RMS within {:.0}% and at most Student's t (97.5%) standard errors)",
                100.0 * CV_TOLERANCE
            );
        }
        if !self.held_fixed.is_empty() {
            let _ = writeln!(
                out,
                "held at zero in every model that has them: {} (params counts the free ones)",
                self.held_fixed.join(", ")
            );
        }
        let folds_beyond_border = self
            .recommended
            .and_then(|m| self.rows.iter().find(|r| r.model == m))
            .is_some_and(|r| !r.valid_over_image);
        match self.recommended {
            Some(m) if folds_beyond_border => {
                let _ = writeln!(
                    out,
                    "recommended: {m}: no model one-to-one with the {:.0}% margin beyond the image border fits as well (cross-validated RMS within {:.0}% of the best and not systematically worse on the held-out views), and {m} does and stays one-to-one over the image itself: its fold lies within {:.0}% beyond the border (see its model-invalid warning); pixels at the very border are close to it",
                    100.0 * calib_core::diagnostics::VALIDITY_MARGIN,
                    100.0 * CV_TOLERANCE,
                    100.0 * calib_core::diagnostics::VALIDITY_MARGIN,
                );
            }
            Some(m) => match (self.best_fit, self.gap_to_best_fit) {
                (Some(best), Some(gap)) if self.best_fit_clearly_better() => {
                    let _ = writeln!(
                        out,
                        "recommended: {m}, the best of the models valid over the image, but its cross-validated RMS is {} above {best}'s, which folds inside the image: no model both fits this lens and stays one-to-one over the image. Add views with the board near the image corners (they constrain the richer model where it folds), and until then trust {m} only as far as its cross-validated error",
                        gap_percent(gap)
                    );
                }
                _ => {
                    let _ = writeln!(
                        out,
                        "recommended: {m} (the fewest parameters among the valid models whose cross-validated RMS is within {:.0}% of the best and not systematically worse on the held-out views)",
                        100.0 * CV_TOLERANCE
                    );
                }
            },
            None if self.rows.iter().all(|r| r.cross_validated_rms.is_none()) => {
                let _ = writeln!(
                    out,
                    "no recommendation: no model could be cross-validated (it needs at least {MIN_CROSS_VALIDATION_VIEWS} views, fitted on one half and evaluated on the other), and by the RMS on the fitted views the model with the most terms always wins"
                );
            }
            None if self
                .rows
                .iter()
                .any(|r| r.valid_over_image && r.cross_validated_rms.is_none()) =>
            {
                let _ = writeln!(
                    out,
                    "no recommendation: the models valid over the image could not be cross-validated (their fits on half of the views failed: too few views, or views too alike, in each half); add views with the board tilted and spread over the image"
                );
            }
            None => {
                let _ = writeln!(out, "no model is valid over the image");
            }
        }
        if let (Some(m), Some(d)) = (self.recommended, &self.uncovered_disagreement) {
            let shown = self.row(m).and_then(|r| r.cross_validated_rms);
            let advice = if shown.is_none_or(|cv| d.pixels > cv) {
                ": the cross-validation judges the models only where corners were seen; add views with the board near the image corners and edges (the poor-coverage warning names them) before trusting any of them there"
            } else {
                ""
            };
            let _ = writeln!(
                out,
                "where no board corner was seen, models that fit as well disagree: the ray {m} sees at the image's {}, {} (one-to-one over the image, as good by the same rule) sees {:.2} px away{advice}",
                d.place, d.model, d.pixels
            );
        }
        out
    }
}

/// A gap above [`CV_TOLERANCE`] as a percentage that never reads as within it: whole percents
/// from 10%, else one decimal, rounded up (a gap of 2.004% printed as "2%" read as inside the
/// 2% tolerance).
fn gap_percent(gap: f64) -> String {
    let percent = 100.0 * gap;
    if percent >= 10.0 {
        format!("{percent:.0}%")
    } else {
        // The 1e-9 keeps a gap that is a tenth of a percent up to rounding (3.4000000000000004)
        // at that tenth.
        format!("{:.1}%", (percent * 10.0 - 1e-9).ceil() / 10.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A gap just above the tolerance must not print as the tolerance itself.
    #[test]
    fn a_gap_above_the_tolerance_never_prints_as_within_it() {
        assert_eq!(gap_percent(CV_TOLERANCE + 4e-5), "2.1%");
        assert_eq!(gap_percent(0.034), "3.4%");
        assert_eq!(gap_percent(0.057), "5.7%");
        assert_eq!(gap_percent(0.25), "25%");
    }
}
