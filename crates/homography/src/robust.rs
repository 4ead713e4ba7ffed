//! Homographies that a few wrong correspondences cannot spoil: least median of squares (LMedS)
//! when the ordinary fit shows outliers.
//!
//! [`estimate_robust`] first fits all points ([`estimate`]). If no residual stands out from the
//! others (the largest is within `suspicious_factor` robust standard deviations of the residuals,
//! or below `min_threshold_px`) and the median residual is below `min_threshold_px`, that fit is
//! returned: clean views, the common case, cost nothing
//! extra. Otherwise LMedS draws four-point samples (deterministic, seeded from the data), keeps
//! the exact homography of the sample (in closed form, `minimal.rs`; samples with three collinear
//! points are skipped) whose median squared residual over all points is smallest,
//! marks as inliers the points within `inlier_factor` robust standard deviations of it (Rousseeuw's
//! scale estimate, `1.4826 (1 + 5 / (n - 4)) sqrt(median)`), and refits the inliers. LMedS
//! tolerates up to half the points being wrong; when fewer than half fit one homography the view
//! is reported as [`HomographyError::NoConsensus`] (shuffled or mismatched correspondences).
//!
//! The threshold for "standing out" must allow for lens distortion, which a homography does not
//! model: its residual field is smooth and at most a few times its median, while a stray corner
//! is tens of robust standard deviations away.

use crate::error::HomographyError;
use crate::minimal::SampleSolver;
use crate::refine::{HomographyEstimate, RefineOptions, estimate};
use nalgebra::{Matrix3, Point2};

/// Settings of [`estimate_robust`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustOptions {
    /// A view is suspicious when its largest residual exceeds this many robust standard
    /// deviations of its residuals (default 10).
    pub suspicious_factor: f64,
    /// ... and this many pixels (default 3).
    pub min_threshold_px: f64,
    /// Inliers of the LMedS fit lie within this many robust standard deviations (default 3).
    pub inlier_factor: f64,
    /// No consensus when the LMedS scale exceeds this fraction of the image points' spread (RMS
    /// distance from their centroid; default 0.15): the distortion of a wide-angle lens leaves
    /// residuals of up to about 10% of the spread, mismatched points 30% and more.
    pub max_scale_fraction: f64,
    /// Number of four-point samples (default 300: with half the points wrong, the chance that
    /// no sample is outlier-free is `(1 - 1/16)^300 < 1e-8`).
    pub samples: usize,
}

impl Default for RobustOptions {
    fn default() -> Self {
        Self {
            suspicious_factor: 10.0,
            min_threshold_px: 3.0,
            inlier_factor: 3.0,
            max_scale_fraction: 0.15,
            samples: 300,
        }
    }
}

/// A robust homography and which points agree with it.
#[derive(Debug, Clone, PartialEq)]
pub struct RobustEstimate {
    /// The estimate from the inliers.
    pub estimate: HomographyEstimate,
    /// `inliers[i]`: point `i` agrees with the homography.
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub num_inliers: usize,
}

/// Residual norms (pixels) of every point under `h`.
fn residuals(h: &Matrix3<f64>, object: &[Point2<f64>], image: &[Point2<f64>]) -> Vec<f64> {
    object
        .iter()
        .zip(image)
        .map(|(x, m)| residual(h, x, m))
        .collect()
}

/// Residual norm (pixels) of one point under `h`; infinite when it maps to infinity.
#[inline]
fn residual(h: &Matrix3<f64>, x: &Point2<f64>, m: &Point2<f64>) -> f64 {
    let w = h[(2, 0)] * x.x + h[(2, 1)] * x.y + h[(2, 2)];
    let u = (h[(0, 0)] * x.x + h[(0, 1)] * x.y + h[(0, 2)]) / w;
    let v = (h[(1, 0)] * x.x + h[(1, 1)] * x.y + h[(1, 2)]) / w;
    let d = ((u - m.x).powi(2) + (v - m.y).powi(2)).sqrt();
    if d.is_finite() { d } else { f64::INFINITY }
}

fn median(values: &mut [f64]) -> f64 {
    let mid = values.len() / 2;
    values.select_nth_unstable_by(mid, f64::total_cmp);
    values[mid]
}

/// A small deterministic generator (splitmix64) for the samples: the same data always gives
/// the same result.
struct Sampler(u64);

impl Sampler {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) % n as u64) as usize
    }
}

/// A homography robust to wrong correspondences; see the module documentation.
///
/// # Errors
///
/// What [`estimate`] reports for the whole set (degenerate input) or for the inliers, and [`HomographyError::NoConsensus`] when fewer than half the points (or fewer than
/// four) fit one homography.
pub fn estimate_robust(
    object: &[Point2<f64>],
    image: &[Point2<f64>],
    refine_options: &RefineOptions,
    options: &RobustOptions,
) -> Result<RobustEstimate, HomographyError> {
    let n = object.len();
    // Degenerate input (too few points, collinear board) is reported as such.
    let all = estimate(object, image, refine_options)?;
    {
        let e = &all;
        let mut r = residuals(&e.h, object, image);
        let max = r.iter().copied().fold(0.0, f64::max);
        // Every residual under the pixel threshold: clean, no median needed.
        let med = if max <= options.min_threshold_px {
            0.0
        } else {
            median(&mut r)
        };
        // A typical point off by more than the pixel threshold means the homography does not
        // describe the view at all (mismatched points), however uniform the residuals are.
        let clean = med <= options.min_threshold_px
            && max <= (options.suspicious_factor * 1.4826 * med).max(options.min_threshold_px);
        if clean {
            return Ok(RobustEstimate {
                estimate: e.clone(),
                inliers: vec![true; n],
                num_inliers: n,
            });
        }
    }
    if n < 5 {
        // Nothing to vote with: four points always fit exactly.
        return Ok(RobustEstimate {
            estimate: all,
            inliers: vec![true; n],
            num_inliers: n,
        });
    }
    let seed = object.iter().chain(image).fold(n as u64, |a, p| {
        a.rotate_left(7) ^ p.x.to_bits() ^ p.y.to_bits().rotate_left(29)
    });
    let mut sampler = Sampler(seed);
    // The whole view passed `estimate`, so its normalization exists.
    let solver = SampleSolver::new(object, image)?;
    let mut best: Option<(f64, Matrix3<f64>)> = None;
    let mut scratch = Vec::with_capacity(n);
    for _ in 0..options.samples {
        let mut idx = [0usize; 4];
        for k in 0..4 {
            loop {
                let i = sampler.below(n);
                if !idx[..k].contains(&i) {
                    idx[k] = i;
                    break;
                }
            }
        }
        // The exact homography of the sample in closed form (a 9x9 eigen-decomposition per
        // sample was most of the run on contaminated views); degenerate samples are skipped.
        let Some(h) = solver.solve(object, &idx) else {
            continue;
        };
        scratch.clear();
        scratch.extend(object.iter().zip(image).map(|(x, m)| {
            let d = residual(&h, x, m);
            d * d
        }));
        let med = median(&mut scratch);
        if med.is_finite() && best.is_none_or(|(b, _)| med < b) {
            best = Some((med, h));
        }
    }
    let Some((med, h)) = best else {
        return Err(HomographyError::NoConsensus {
            inliers: 0,
            points: n,
        });
    };
    let sigma = 1.4826 * (1.0 + 5.0 / (n as f64 - 4.0)) * med.sqrt();
    let centroid = image
        .iter()
        .fold(nalgebra::Vector2::zeros(), |a, p| a + p.coords)
        / n as f64;
    let spread = (image
        .iter()
        .map(|p| (p.coords - centroid).norm_squared())
        .sum::<f64>()
        / n as f64)
        .sqrt();
    let max_sigma = options.max_scale_fraction * spread;
    let threshold = (options.inlier_factor * sigma.min(max_sigma)).max(options.min_threshold_px);
    let r = residuals(&h, object, image);
    let inliers: Vec<bool> = r.iter().map(|&d| d <= threshold).collect();
    let num_inliers = inliers.iter().filter(|&&b| b).count();
    if sigma > max_sigma || num_inliers < 4 || 2 * num_inliers < n {
        return Err(HomographyError::NoConsensus {
            inliers: num_inliers,
            points: n,
        });
    }
    let (o, m): (Vec<Point2<f64>>, Vec<Point2<f64>>) = object
        .iter()
        .zip(image)
        .zip(&inliers)
        .filter(|(_, keep)| **keep)
        .map(|((o, m), _)| (*o, *m))
        .unzip();
    let estimate = estimate(&o, &m, refine_options)?;
    Ok(RobustEstimate {
        estimate,
        inliers,
        num_inliers,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> (Matrix3<f64>, Vec<Point2<f64>>, Vec<Point2<f64>>) {
        let h = Matrix3::new(2.1, 0.15, 180.0, -0.1, 2.0, 95.0, 2e-4, -1e-4, 1.0);
        let object: Vec<Point2<f64>> = (0..54)
            .map(|i| Point2::new(25.0 * (i % 9) as f64, 25.0 * (i / 9) as f64))
            .collect();
        let mut state = 5u64;
        let image = object
            .iter()
            .map(|p| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let noise = ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.4;
                let q = h.transform_point(p);
                Point2::new(q.x + noise, q.y - noise)
            })
            .collect();
        (h, object, image)
    }

    #[test]
    fn clean_views_take_the_ordinary_fit() {
        let (_, object, image) = grid();
        let r = estimate_robust(
            &object,
            &image,
            &RefineOptions::default(),
            &RobustOptions::default(),
        )
        .unwrap();
        assert_eq!(r.num_inliers, 54);
        let plain = estimate(&object, &image, &RefineOptions::default()).unwrap();
        assert_eq!(r.estimate.h, plain.h);
    }

    #[test]
    fn stray_corners_are_found_and_left_out() {
        let (h, object, mut image) = grid();
        // One corner 800 px off, four more swapped or shifted.
        image[7].x += 800.0;
        image.swap(20, 21);
        image[33].y -= 40.0;
        image[50].x += 15.0;
        let r = estimate_robust(
            &object,
            &image,
            &RefineOptions::default(),
            &RobustOptions::default(),
        )
        .unwrap();
        for i in [7, 20, 21, 33, 50] {
            assert!(!r.inliers[i], "point {i}");
        }
        assert_eq!(r.num_inliers, 49);
        // The refit is as good as without the outliers: within noise of the truth.
        for p in &object {
            let (a, b) = (h.transform_point(p), r.estimate.h.transform_point(p));
            assert!((a - b).norm() < 0.5, "{a} vs {b}");
        }
    }

    #[test]
    fn shuffled_correspondences_have_no_consensus() {
        let (_, object, mut image) = grid();
        let n = image.len();
        for i in 0..n / 2 + 5 {
            image.swap(i, (i * 7 + 3) % n);
        }
        let err = estimate_robust(
            &object,
            &image,
            &RefineOptions::default(),
            &RobustOptions::default(),
        )
        .unwrap_err();
        assert!(matches!(err, HomographyError::NoConsensus { .. }), "{err}");
    }

    #[test]
    fn strong_lens_distortion_is_not_mistaken_for_mismatch() {
        // A board filling most of a 1280x960 image through a barrel lens (k1 = -0.35 at
        // f = 800 px): edge corners move by tens of pixels, smoothly.
        let h = Matrix3::new(1.0, 0.02, -100.0, -0.01, 1.0, -80.0, 1e-4, 5e-5, 1.0);
        let object: Vec<Point2<f64>> = (0..12 * 9)
            .map(|i| Point2::new(18.0 * (i % 12) as f64, 18.0 * (i / 12) as f64))
            .collect();
        let image: Vec<Point2<f64>> = object
            .iter()
            .map(|p| {
                let q = h.transform_point(p);
                let (x, y) = (q.x / 800.0 * 4.0, q.y / 800.0 * 4.0);
                let s = 1.0 - 0.35 * (x * x + y * y);
                Point2::new(640.0 + 800.0 * x * s, 480.0 + 800.0 * y * s)
            })
            .collect();
        let r = estimate_robust(
            &object,
            &image,
            &RefineOptions::default(),
            &RobustOptions::default(),
        )
        .unwrap();
        assert!(
            r.num_inliers * 2 > object.len(),
            "{} inliers",
            r.num_inliers
        );
    }
}
