//! Choosing a lens model: fit each candidate, check its validity, and cross-validate it.
//!
//! A model with more terms always reaches a lower RMS on the views it was fitted to; whether the
//! terms describe the lens or the noise shows on views it was not fitted to. Like mrcal, each
//! model is fitted on half of the views (the even-numbered ones, then the odd-numbered ones) and
//! evaluated on the other half: the camera is held at the fitted values and only the held-out
//! views' poses are estimated; the cross-validated RMS is over both halves' held-out points. The
//! recommendation is the model with the fewest parameters whose cross-validated RMS is within
//! [`CV_TOLERANCE`] of the best valid one and which is valid (one-to-one) over the image; when
//! no such model fits within [`CV_TOLERANCE`] of the best fit but one whose fold lies within the
//! validity margin beyond the image border does, that one; when a model that folds inside the
//! image fits clearly better, the comparison says so ([`ModelComparison::gap_to_best_fit`]).

use crate::calibrate::calibrate;
use crate::observations::Observations;
use calib_core::warnings::Warning;
use calib_core::{CalibrationError, CalibrationOptions};
use camera_model::{AnyCamera, CameraModel, UndistortOptions};
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};
use std::fmt::Write;

/// A model's cross-validated RMS within this fraction of the best counts as equally good (the
/// held-out RMS of two fits of the same adequate model differ by about this much on 10 to 30
/// views).
pub const CV_TOLERANCE: f64 = 0.02;

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
}

/// The comparison of lens models on one camera's views. Serialized as the file
/// `calib single --compare-models -o FILE` writes (docs/formats.md), and read back from it with
/// `serde_json::from_str`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelComparison {
    /// One row per model, in the order given.
    pub rows: Vec<ModelRow>,
    /// The recommended model: the fewest parameters among the models valid over the image
    /// (`valid_over_image`) whose cross-validated RMS is within [`CV_TOLERANCE`] of the best of
    /// them. When none of them is within [`CV_TOLERANCE`] of `best_fit` but a model one-to-one
    /// over the image itself (its fold within the validity margin beyond the border, so not
    /// `valid_over_image`) is, the same rule among those and the valid ones. `None` when no model
    /// valid over the image could be cross-validated (fewer than [`MIN_CROSS_VALIDATION_VIEWS`]
    /// views, or its fits on half of the views failed) or calibrated.
    pub recommended: Option<CameraModel>,
    /// The model with the lowest cross-validated RMS among all fitted ones, valid or not.
    pub best_fit: Option<CameraModel>,
    /// How far the recommended model's cross-validated RMS lies above `best_fit`'s, as a
    /// fraction (0.57: 57% higher). Above [`CV_TOLERANCE`], no model valid over the image fits
    /// the lens as well as one that folds inside it: the recommendation is the best valid one,
    /// not an adequate one.
    pub gap_to_best_fit: Option<f64>,
    /// Names of the distortion coefficients held fixed in every model (empty: none).
    pub held_fixed: Vec<String>,
    /// Where no board corner was seen (the image corners and edge midpoints of the
    /// `poor-coverage` warning, [`calib_core::diagnostics::uncovered_places`]), the largest
    /// distance between the pixel where the recommended model sees a ray and the pixel where
    /// another model that fits as well (one-to-one over the image itself, cross-validated RMS
    /// within [`CV_TOLERANCE`] of the best among the models the recommendation chose from) sees
    /// it. The cross-validation judges the models only where corners were seen; this says how
    /// much they differ where none were (an order of magnitude of the extrapolation's error,
    /// not a bound: docs/camera-model.md, "Choosing a model"). `None` when corners reached
    /// every image corner and edge, or no other model fits as well.
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

/// Sum of squared errors and point count of `test` with the camera of `options` held fixed.
fn held_out(
    train: &Observations,
    test: &Observations,
    options: &CalibrationOptions,
) -> Result<(f64, usize), CalibrationError> {
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
    Ok((
        evaluated.rms * evaluated.rms * evaluated.num_points as f64,
        evaluated.num_points,
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
            let cross_validated_rms = (observations.views.len() >= MIN_CROSS_VALIDATION_VIEWS)
                .then(|| {
                    let a = held_out(&even, &odd, &o).ok()?;
                    let b = held_out(&odd, &even, &o).ok()?;
                    Some(((a.0 + b.0) / (a.1 + b.1).max(1) as f64).sqrt())
                })
                .flatten();
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
                    }
                }
                Err(e) => ModelRow {
                    cross_validated_rms,
                    ..ModelRow::not_fitted(model, e.to_string())
                },
            }
        })
        .collect();
    // Only the cross-validated error ranks models: on the views it was fitted to, a model with
    // more terms always wins (on one view the old fallback to the RMS recommended thin-prism12).
    let score = |r: &ModelRow| r.cross_validated_rms;
    // The fewest parameters among the rows `eligible` admits whose score is within the tolerance
    // of the best of them.
    let simplest_within = |eligible: &dyn Fn(&ModelRow) -> bool| {
        let best = rows
            .iter()
            .filter(|r| eligible(r))
            .filter_map(score)
            .fold(f64::INFINITY, f64::min);
        rows.iter()
            .filter(|r| eligible(r) && score(r).is_some_and(|s| s <= best * (1.0 + CV_TOLERANCE)))
            .min_by_key(|r| r.parameters)
            .map(|r| (r.model, best))
    };
    // Models whose fit folds inside the image still show what the lens needs.
    let best_fit = rows
        .iter()
        .filter_map(|r| score(r).map(|s| (r.model, s)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let adequate = |best: f64| best_fit.is_none_or(|(_, b)| best <= b * (1.0 + CV_TOLERANCE));
    let valid = simplest_within(&|r: &ModelRow| r.valid_over_image);
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
        _ => match simplest_within(&in_image) {
            Some((m, best)) if adequate(best) => Some((m, best)),
            _ => valid,
        },
    };
    let recommended = chosen.map(|(m, _)| m);
    let uncovered_disagreement = chosen.and_then(|(m, best)| {
        let size = observations.image_size?;
        let (_, camera, used) = fitted.iter().find(|f| f.0 == m)?;
        let places = calib_core::diagnostics::uncovered_places(size, used);
        let as_good: Vec<&AnyCamera> = rows
            .iter()
            .filter(|r| {
                r.model != m
                    && in_image(r)
                    && score(r).is_some_and(|s| s <= best * (1.0 + CV_TOLERANCE))
            })
            .filter_map(|r| fitted.iter().find(|f| f.0 == r.model).map(|f| &f.1))
            .collect();
        disagreement(camera, &as_good, &places)
    });
    let gap_to_best_fit = recommended.zip(best_fit).and_then(|(m, (_, best))| {
        let chosen = rows.iter().find(|r| r.model == m).and_then(score)?;
        Some((chosen / best - 1.0).max(0.0))
    });
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
        best_fit: best_fit.map(|b| b.0),
        gap_to_best_fit,
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
    /// The comparison as a table.
    pub fn table(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{:<16} {:>6} {:>10} {:>14} {:>8} {:>9}",
            "model", "params", "RMS px", "cross-val px", "valid", "warnings"
        );
        let px = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.5}"));
        for r in &self.rows {
            let _ = writeln!(
                out,
                "{:<16} {:>6} {:>10} {:>14} {:>8} {:>9}{}",
                r.model.name(),
                r.parameters,
                px(r.rms),
                px(r.cross_validated_rms),
                if r.valid_over_image { "yes" } else { "no" },
                r.warnings.len(),
                r.error
                    .as_ref()
                    .map_or(String::new(), |e| format!("  not fitted: {e}"))
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
                    "recommended: {m}: no model one-to-one with the {:.0}% margin beyond the image border fits as well (cross-validated RMS within {:.0}% of the best), and {m} does and stays one-to-one over the image itself: its fold lies within {:.0}% beyond the border (see its model-invalid warning); pixels at the very border are close to it",
                    100.0 * calib_core::diagnostics::VALIDITY_MARGIN,
                    100.0 * CV_TOLERANCE,
                    100.0 * calib_core::diagnostics::VALIDITY_MARGIN,
                );
            }
            Some(m) => match (self.best_fit, self.gap_to_best_fit) {
                (Some(best), Some(gap)) if gap > CV_TOLERANCE => {
                    let _ = writeln!(
                        out,
                        "recommended: {m}, the best of the models valid over the image, but its cross-validated RMS is {} above {best}'s, which folds inside the image: no model both fits this lens and stays one-to-one over the image. Add views with the board near the image corners (they constrain the richer model where it folds), and until then trust {m} only as far as its cross-validated error",
                        gap_percent(gap)
                    );
                }
                _ => {
                    let _ = writeln!(
                        out,
                        "recommended: {m} (the fewest parameters among the valid models whose cross-validated RMS is within {:.0}% of the best)",
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
            let shown = self
                .rows
                .iter()
                .find(|r| r.model == m)
                .and_then(|r| r.cross_validated_rms);
            let advice = if shown.is_none_or(|cv| d.pixels > cv) {
                ": the cross-validation judges the models only where corners were seen; add views with the board near the image corners and edges (the poor-coverage warning names them) before trusting any of them there"
            } else {
                ""
            };
            let _ = writeln!(
                out,
                "where no board corner was seen, models that fit as well disagree: the ray {m} sees at the image's {}, {} (one-to-one over the image, cross-validated RMS within {:.0}% of the best) sees {:.2} px away{advice}",
                d.place,
                d.model,
                100.0 * CV_TOLERANCE,
                d.pixels
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
