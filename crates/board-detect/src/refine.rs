//! Sub-pixel corner refinement.
//!
//! Two per-corner estimators, both iterated to a fixed point:
//!
//! * [`gradient`]: gradient orthogonality. Every pixel `x_i` near a corner `q` is either in a
//!   flat region (gradient `g_i ~ 0`) or on one of the edges through `q` (gradient orthogonal
//!   to `q - x_i`), so `q` minimises `sum_i w_i (g_i . (q - x_i))^2`, a 2x2 linear system.
//!   The weights are a Gaussian around the current estimate.
//! * [`SaddleFit`]: the blurred image is fitted with a quadratic surface by weighted least
//!   squares on a grid of samples centred at the current estimate; the surface's saddle point
//!   is the next estimate. A blurred X-junction is point-symmetric about the corner, so the
//!   fit's linear terms vanish exactly there.

use crate::gray::ImageF;
use crate::grid::P;

/// Gradient-orthogonality refinement of `p` with half-window `hw` pixels (window
/// `(2 hw + 1)^2`) and Gaussian weight of standard deviation `sigma_w` pixels. Returns
/// `None` when the estimate leaves the window or the system is singular.
pub(crate) fn gradient(img: &ImageF, p: P, hw: usize, sigma_w: f64) -> Option<P> {
    let hw_i = hw as isize;
    let (w, h) = (img.w as isize, img.h as isize);
    let mut q = p;
    let inv2s2 = 1.0 / (2.0 * sigma_w * sigma_w);
    for _ in 0..40 {
        let cx = q[0].round() as isize;
        let cy = q[1].round() as isize;
        if cx - hw_i < 1 || cy - hw_i < 1 || cx + hw_i > w - 2 || cy + hw_i > h - 2 {
            return None;
        }
        let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0f64, 0.0, 0.0, 0.0, 0.0);
        for dy in -hw_i..=hw_i {
            let y = cy + dy;
            let row = (y * w) as usize;
            let up = ((y - 1) * w) as usize;
            let dn = ((y + 1) * w) as usize;
            let ry = y as f64 - q[1];
            for dx in -hw_i..=hw_i {
                let x = (cx + dx) as usize;
                let gx = 0.5 * (img.data[row + x + 1] - img.data[row + x - 1]) as f64;
                let gy = 0.5 * (img.data[dn + x] - img.data[up + x]) as f64;
                let rx = x as f64 - q[0];
                let wt = (-(rx * rx + ry * ry) * inv2s2).exp();
                let (gxx, gxy, gyy) = (wt * gx * gx, wt * gx * gy, wt * gy * gy);
                a11 += gxx;
                a12 += gxy;
                a22 += gyy;
                // b = sum w g g^T x_i, with x_i relative to the current estimate.
                b1 += gxx * rx + gxy * ry;
                b2 += gxy * rx + gyy * ry;
            }
        }
        let det = a11 * a22 - a12 * a12;
        if det.is_nan() || det <= 1e-9 * (a11 + a22).powi(2) {
            return None;
        }
        let sx = (a22 * b1 - a12 * b2) / det;
        let sy = (a11 * b2 - a12 * b1) / det;
        q = [q[0] + sx, q[1] + sy];
        if (q[0] - p[0]).abs() > hw as f64 || (q[1] - p[1]).abs() > hw as f64 {
            return None;
        }
        if sx * sx + sy * sy < 1e-6 {
            break;
        }
    }
    Some(q)
}

/// Precomputed weighted least-squares solver for the saddle refinement's quadratic fit
/// ([`SaddleFit::refine`]).
pub(crate) struct SaddleFit {
    r: isize,
    /// 6 x N matrix mapping the samples to the coefficients `[a, b, c, d, e, f]` of
    /// `a x^2 + b x y + c y^2 + d x + e y + f`.
    m: Vec<[f64; 6]>,
}

impl SaddleFit {
    /// Fit over the `(2r + 1)^2` samples at integer offsets, Gaussian weights of standard
    /// deviation `sigma_w` pixels.
    pub fn new(r: usize, sigma_w: f64) -> Self {
        let r = r as isize;
        let mut rows = Vec::new();
        let mut wts = Vec::new();
        for j in -r..=r {
            for i in -r..=r {
                let (x, y) = (i as f64, j as f64);
                rows.push([x * x, x * y, y * y, x, y, 1.0]);
                wts.push((-(x * x + y * y) / (2.0 * sigma_w * sigma_w)).exp());
            }
        }
        let mut ata = nalgebra::Matrix6::<f64>::zeros();
        for (row, &wt) in rows.iter().zip(&wts) {
            let v = nalgebra::Vector6::from_row_slice(row);
            ata += wt * v * v.transpose();
        }
        let inv = ata.try_inverse().unwrap_or_else(nalgebra::Matrix6::zeros);
        let m = rows
            .iter()
            .zip(&wts)
            .map(|(row, &wt)| {
                let v = inv * nalgebra::Vector6::from_row_slice(row) * wt;
                [v[0], v[1], v[2], v[3], v[4], v[5]]
            })
            .collect();
        Self { r, m }
    }

    /// Saddle-point refinement of `p` on the blurred image. `None` when the fit is not a
    /// saddle or the estimate moves more than the fit radius.
    pub fn refine(&self, blur: &ImageF, p: P) -> Option<P> {
        self.refine_curvature(blur, p).map(|(q, _)| q)
    }

    /// How pixel noise reaches the fit's linear coefficients `d` and `e`: their variance per
    /// unit variance of independent noise on the image's pixels, for a fit on that image
    /// blurred with a Gaussian of standard deviation `sigma` px (as [`ImageF::blurred`]).
    /// The samples are taken at whole-pixel offsets (bilinear interpolation, which averages
    /// a little more, is left out, so this errs on the high side). By the window's symmetry
    /// `d` and `e` have the same variance and are uncorrelated.
    pub fn linear_noise_gain(&self, sigma: f64) -> f64 {
        let r = self.r;
        let kr = if sigma > 0.0 {
            (3.0 * sigma).ceil() as isize
        } else {
            0
        };
        let g: Vec<f64> = (-kr..=kr)
            .map(|i| {
                if sigma > 0.0 {
                    (-((i * i) as f64) / (2.0 * sigma * sigma)).exp()
                } else {
                    1.0
                }
            })
            .collect();
        let gs: f64 = g.iter().sum();
        let g: Vec<f64> = g.iter().map(|v| v / gs).collect();
        // The coefficient `d` as a kernel on the raw pixels: the fit's row for `d` (on the
        // sample grid) convolved with the blur; its sum of squares is the variance gain.
        let n = 2 * r + 1;
        let big = n + 2 * kr;
        let mut k = vec![0.0f64; (big * big) as usize];
        for (idx, row) in self.m.iter().enumerate() {
            let (si, sj) = ((idx as isize) % n, (idx as isize) / n);
            for (a, ga) in g.iter().enumerate() {
                for (b, gb) in g.iter().enumerate() {
                    let (x, y) = (si + a as isize, sj + b as isize);
                    k[(y * big + x) as usize] += row[3] * ga * gb;
                }
            }
        }
        k.iter().map(|v| v * v).sum()
    }

    /// [`SaddleFit::refine`], also returning the quadratic's curvature coefficients
    /// `[a, b, c]` (of `a x^2 + b x y + c y^2`) at the final estimate.
    pub fn refine_curvature(&self, blur: &ImageF, p: P) -> Option<(P, [f64; 3])> {
        let mut q = p;
        let mut curv = [0.0; 3];
        let r = self.r;
        let rf = r as f64;
        for _ in 0..30 {
            if q[0] < rf + 1.0
                || q[1] < rf + 1.0
                || q[0] > (blur.w as f64) - rf - 2.0
                || q[1] > (blur.h as f64) - rf - 2.0
            {
                return None;
            }
            let mut c = [0.0f64; 6];
            let mut k = 0;
            // Bilinear sampling at q + (i, j): the weights of the four neighbours are the same
            // for all samples, so interpolate once per sample with shared fractions.
            let x0 = q[0].floor();
            let y0 = q[1].floor();
            let fx = (q[0] - x0) as f32;
            let fy = (q[1] - y0) as f32;
            let (x0, y0) = (x0 as isize, y0 as isize);
            let w = blur.w as isize;
            for j in -r..=r {
                let base = ((y0 + j) * w) as usize;
                let base2 = base + blur.w;
                for i in -r..=r {
                    let x = (x0 + i) as usize;
                    let a =
                        blur.data[base + x] + fx * (blur.data[base + x + 1] - blur.data[base + x]);
                    let b = blur.data[base2 + x]
                        + fx * (blur.data[base2 + x + 1] - blur.data[base2 + x]);
                    let s = (a + fy * (b - a)) as f64;
                    let mk = &self.m[k];
                    for t in 0..6 {
                        c[t] += mk[t] * s;
                    }
                    k += 1;
                }
            }
            let [a, b, cc, d, e, _] = c;
            curv = [a, b, cc];
            let det = 4.0 * a * cc - b * b;
            if det.is_nan() || det >= 0.0 {
                return None;
            }
            let sx = -(2.0 * cc * d - b * e) / det;
            let sy = -(2.0 * a * e - b * d) / det;
            let step = sx.hypot(sy);
            let lim = 0.5 * rf;
            let (sx, sy) = if step > lim {
                (sx * lim / step, sy * lim / step)
            } else {
                (sx, sy)
            };
            q = [q[0] + sx, q[1] + sy];
            if (q[0] - p[0]).abs() > rf || (q[1] - p[1]).abs() > rf {
                return None;
            }
            if step < 1e-3 {
                break;
            }
        }
        Some((q, curv))
    }

    /// Standard deviation (px) along the least certain direction of a corner refined to the
    /// saddle of a fit with curvature `[a, b, c]` ([`SaddleFit::refine_curvature`]), when the
    /// fit's linear coefficients have variance `var_linear` (image noise variance times
    /// [`SaddleFit::linear_noise_gain`]). The saddle is `-H^-1 (d, e)` with
    /// `H = [[2a, b], [b, 2c]]`, so its covariance is `var_linear H^-2` and the largest
    /// deviation `sqrt(var_linear) / min |eigenvalue of H|`. Infinite for a flat fit.
    pub fn position_sigma(curv: [f64; 3], var_linear: f64) -> f64 {
        let [a, b, c] = curv;
        let half = ((a - c) * (a - c) + b * b).sqrt();
        let l = ((a + c).abs() - half).abs().min((a + c).abs() + half);
        if l.is_nan() || l <= 0.0 || !var_linear.is_finite() {
            return f64::INFINITY;
        }
        var_linear.max(0.0).sqrt() / l
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::SplitMix;

    /// A smooth X-junction (point-symmetric about `c`), 30 grey levels of contrast, plus
    /// Gaussian noise of `noise` grey levels.
    fn x_junction(c: P, noise: f64, rng: &mut SplitMix) -> ImageF {
        let (w, h) = (48, 48);
        let data = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64 - c[0], (i / w) as f64 - c[1]);
                (55.0 + 15.0 * x.tanh() * y.tanh() + noise * rng.normal()) as f32
            })
            .collect();
        ImageF { w, h, data }
    }

    /// The predicted scatter of a refined corner (`position_sigma` from the noise and
    /// `linear_noise_gain`) matches the scatter over 400 noisy images of one corner, at two
    /// window sizes: within 15 % (the estimate of a standard deviation from 400 samples is
    /// good to about 4 %; the prediction leaves out the bilinear interpolation's averaging and
    /// linearizes the fit, which the measured ratios, 0.98 at r = 4 and 0.92 at r = 8, show to matter little).
    #[test]
    fn predicted_corner_scatter_matches_the_noise() {
        let c = [23.3, 24.6];
        let noise = 10.0;
        for (r, sigma) in [(4usize, 1.0f64), (8, 3.0)] {
            let fit = SaddleFit::new(r, r as f64 * 0.6);
            let var_linear = noise * noise * fit.linear_noise_gain(sigma);
            let mut rng = SplitMix(7 + r as u64);
            let (mut sx, mut sy, mut predicted) = (0.0, 0.0, Vec::new());
            let n = 400;
            for _ in 0..n {
                let img = x_junction(c, noise, &mut rng).blurred(sigma);
                let (q, curv) = fit.refine_curvature(&img, c).expect("a saddle");
                sx += (q[0] - c[0]).powi(2);
                sy += (q[1] - c[1]).powi(2);
                predicted.push(SaddleFit::position_sigma(curv, var_linear));
            }
            // The junction's axes are the pixel axes and symmetric: the scatter is the same
            // along x and y, and the least certain direction is either.
            let measured = ((sx + sy) / (2 * n) as f64).sqrt();
            predicted.sort_by(f64::total_cmp);
            let ratio = predicted[n / 2] / measured;
            assert!(
                (0.85..1.15).contains(&ratio),
                "r {r}: predicted / measured {ratio}"
            );
        }
    }

    #[test]
    fn position_sigma_of_a_flat_fit_is_infinite() {
        assert_eq!(
            SaddleFit::position_sigma([0.0, 0.0, 0.0], 1.0),
            f64::INFINITY
        );
        // A saddle with eigenvalues +-2 of H: sqrt(4) / 2.
        assert!((SaddleFit::position_sigma([1.0, 0.0, -1.0], 4.0) - 1.0).abs() < 1e-12);
    }
}
