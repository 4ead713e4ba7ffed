//! Point-symmetry check of the refined corners.
//!
//! Two straight edges crossing, blurred by any point-symmetric blur, give an image that is
//! point-symmetric about the crossing: `I(q + d) = I(q - d)`, under any perspective (the
//! edges stay straight) and to first order under lens distortion and smooth lighting. A
//! shadow edge, the rim of a glare or an occluder running through a corner breaks that
//! symmetry, and pulls every intensity-based corner estimate (the saddle fit's, OpenCV's
//! gradient orthogonality) off the crossing by up to several pixels while the grid's
//! geometry check still passes. Such a corner is found by its asymmetry being far above the
//! board's typical one (which noise, JPEG and lighting set, corner by corner alike).

use crate::gray::ImageF;
use crate::grid::P;

/// Asymmetry of a corner above which it is flagged, relative to the board's median
/// asymmetry. Measured (`benches/detect/corner_symmetry.py data`): on the 113 bundled
/// photographs the largest corner is at most 4.8 times its board's median. A shadow edge
/// through a corner is far above: 0.49 against 0.007 clean in the unit test below.
pub(crate) const RELATIVE_LIMIT: f64 = 8.0;

/// Smallest asymmetry flagged, whatever the board's median (a fraction of the corner's
/// contrast). Clean rendered corners measure 0.002-0.011 (`corner_symmetry.py` on a
/// `lens_eval pinhole 20 DIR --save` directory), the bundled photographs' corners up to 0.17
/// (below 4.8 times their board's median). Chosen on the defects sweep
/// (`benches/detect/defects.sh`): with it, the shadowed boards kept have no corner more
/// than 0.08 px off, and no other defect loses a board to the check.
pub(crate) const ABSOLUTE_LIMIT: f64 = 0.06;

/// Median corner spacing (px) below which the check is not made. Squares of 3 to 8 px leave the
/// refinement its smallest window (5 x 5 samples), where a clean corner's asymmetry is set by
/// pixelation more than by the scene: with the check, 3 of 40 clean boards of the `small-small`
/// population (`cargo run --release -p board-detect --example lens_eval -- small-small 40 DIR`)
/// and 1 of 40 of `small-large` were refused as disturbed (37 -> 34 and 35 -> 34 found). There the
/// grid's geometry check bounds a pulled corner to 0.15 of a square, under 1.5 px.
pub(crate) const MIN_SPACING: f64 = 10.0;

/// RMS of `I(q + d) - I(q - d)` over the offsets `d` of the `(2r + 1)^2` window (integer
/// offsets, bilinear samples of the blurred image `img`), divided by the window's contrast
/// (90th minus 10th percentile of its samples, at least 1 grey level). 0 for a perfect
/// X-junction; `None` when the window leaves the image.
/// `samples` is the caller's buffer for the window's samples (one allocation per board, not per
/// corner).
pub(crate) fn asymmetry(img: &ImageF, q: P, r: usize, samples: &mut Vec<f64>) -> Option<f64> {
    if !(q[0].is_finite() && q[1].is_finite()) {
        return None;
    }
    let (x0, y0) = (q[0].floor(), q[1].floor());
    let (fx, fy) = ((q[0] - x0) as f32, (q[1] - y0) as f32);
    let ri = r as isize;
    let (x0, y0) = (x0 as isize, y0 as isize);
    let (w, h) = (img.w as isize, img.h as isize);
    if x0 - ri < 0 || y0 - ri < 0 || x0 + ri + 1 >= w || y0 + ri + 1 >= h {
        return None;
    }
    // Offsets are whole pixels, so every sample shares q's bilinear weights.
    let at = |x: isize, y: isize| -> f32 {
        let i = (y * w + x) as usize;
        let (a, b) = (img.data[i], img.data[i + 1]);
        let (c, d) = (img.data[i + img.w], img.data[i + img.w + 1]);
        let top = a + fx * (b - a);
        top + fy * (c + fx * (d - c) - top)
    };
    samples.clear();
    let mut sum2 = 0.0f64;
    let mut n = 0usize;
    for dy in -ri..=ri {
        for dx in -ri..=ri {
            // Each pair once: the half plane (dy > 0) or (dy == 0, dx > 0).
            if dy < 0 || (dy == 0 && dx <= 0) {
                continue;
            }
            let a = at(x0 + dx, y0 + dy) as f64;
            let b = at(x0 - dx, y0 - dy) as f64;
            sum2 += (a - b) * (a - b);
            n += 1;
            samples.push(a);
            samples.push(b);
        }
    }
    // Percentiles by selection (linear time: a full sort cost 0.1 ms per 54-corner board).
    let rank = |f: f64| ((samples.len() - 1) as f64 * f).round() as usize;
    let (lo, hi) = (rank(0.1), rank(0.9));
    let p90 = *samples.select_nth_unstable_by(hi, f64::total_cmp).1;
    let p10 = *samples[..hi].select_nth_unstable_by(lo, f64::total_cmp).1;
    let contrast = (p90 - p10).max(1.0);
    Some((sum2 / n as f64).sqrt() / contrast)
}

/// The most asymmetric corner, when it is asymmetric enough to have been pulled off its
/// crossing: `(index, asymmetry, limit)`. `pts` are in `img`'s pixel coordinates; corners
/// whose window leaves the image are not judged.
pub(crate) fn worst_asymmetric(img: &ImageF, pts: &[P], r: usize) -> Option<(usize, f64, f64)> {
    let mut samples = Vec::with_capacity((2 * r + 1).pow(2));
    let a: Vec<Option<f64>> = pts
        .iter()
        .map(|&q| asymmetry(img, q, r, &mut samples))
        .collect();
    let mut known: Vec<f64> = a.iter().flatten().copied().collect();
    if known.is_empty() {
        return None;
    }
    known.sort_by(f64::total_cmp);
    let median = known[known.len() / 2];
    let limit = (RELATIVE_LIMIT * median).max(ABSOLUTE_LIMIT);
    a.iter()
        .enumerate()
        .filter_map(|(i, v)| v.map(|v| (i, v)))
        .filter(|&(_, v)| v > limit)
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .map(|(i, v)| (i, v, limit))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An ideal X-junction at `c`, integrated over each pixel (16x16 samples) and blurred, optionally with a shadow
    /// darkening the half plane `x > c.x + shadow_offset` by `dark`.
    fn junction(c: P, shadow: Option<(f64, f64)>) -> ImageF {
        let (w, h) = (41usize, 41usize);
        let mut data = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let mut v = 0.0;
                for sy in 0..16 {
                    for sx in 0..16 {
                        let px = x as f64 + (sx as f64 + 0.5) / 16.0 - 0.5 - c[0];
                        let py = y as f64 + (sy as f64 + 0.5) / 16.0 - 0.5 - c[1];
                        let mut i = if (px > 0.0) == (py > 0.0) {
                            40.0
                        } else {
                            210.0
                        };
                        if let Some((off, dark)) = shadow
                            && px > off
                        {
                            i *= 1.0 - dark;
                        }
                        v += i / 256.0;
                    }
                }
                data.push(v as f32);
            }
        }
        ImageF { w, h, data }.blurred(1.5)
    }

    /// A clean junction is symmetric about its crossing (asymmetry near 0); a 50 % shadow
    /// edge through it is not; a shadow edge 8 px away leaves the window untouched.
    #[test]
    fn shadow_edge_through_a_corner_breaks_its_symmetry() {
        let c = [20.3, 19.8];
        let clean = asymmetry(&junction(c, None), c, 3, &mut Vec::new()).unwrap();
        assert!(clean < 0.01, "clean {clean}");
        let through = asymmetry(&junction(c, Some((0.0, 0.5))), c, 3, &mut Vec::new()).unwrap();
        assert!(through > 0.2, "through {through}");
        let far = asymmetry(&junction(c, Some((8.0, 0.5))), c, 3, &mut Vec::new()).unwrap();
        assert!(far < 0.01, "far {far}");
        assert!(asymmetry(&junction(c, None), [1.0, 20.0], 3, &mut Vec::new()).is_none());
    }
}
