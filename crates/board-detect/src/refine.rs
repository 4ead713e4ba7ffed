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
        let mut q = p;
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
        Some(q)
    }
}
