//! Robust loss functions applied to the squared norm of a residual block.
//!
//! The cost of a residual block `r` is `rho(|r|^2) / 2`. To keep the Gauss-Newton machinery, the
//! solver rescales the residual and the Jacobian so that the plain least-squares model of the
//! rescaled block has the robust cost's gradient and, where possible, its curvature (Triggs et al.,
//! "Bundle Adjustment: A Modern Synthesis", section 4.3):
//!
//! ```text
//! s = |r|^2,   alpha = 1 - sqrt(1 + 2 s rho''/rho')
//! r~ = sqrt(rho') / (1 - alpha) r
//! J~ = sqrt(rho') (I - alpha r r^T / s) J
//! ```
//!
//! so that `J~^T r~ = rho' J^T r` (the exact gradient) and
//! `J~^T J~ = rho' J^T J + 2 rho'' J^T r r^T J` (the exact Gauss-Newton curvature of `rho`).
//!
//! The curvature term is applied only where the loss is convex (`rho'' > 0`). Where it is concave
//! the square root's argument can reach zero (for Huber's outlier branch it is exactly zero), which
//! makes `1 - alpha` vanish and the rescaled residual infinite; there only the first-order scaling
//! by `sqrt(rho')` is kept, as Ceres does. Huber and Cauchy are concave everywhere, so for them the
//! correction is the `sqrt(rho')` reweighting; [`Loss::Custom`] losses that are convex somewhere
//! get the full correction there.

/// A user-supplied loss: given `s = |r|^2`, returns `[rho(s), rho'(s), rho''(s)]`. `rho` must be
/// increasing (`rho' > 0`) with `rho(0) = 0`.
#[derive(Debug, Clone, Copy)]
pub struct CustomLoss(pub fn(f64) -> [f64; 3]);

impl PartialEq for CustomLoss {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::fn_addr_eq(self.0, other.0)
    }
}

/// A robust loss `rho(s)` of the squared residual norm `s`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Loss {
    /// `rho(s) = s`: ordinary least squares.
    #[default]
    Trivial,
    /// Huber loss with threshold `a` (in residual units): `rho(s) = s` for `s <= a^2`,
    /// `2 a sqrt(s) - a^2` beyond. Quadratic near zero, linear in `|r|` for outliers.
    Huber(f64),
    /// Cauchy loss with scale `a`: `rho(s) = a^2 ln(1 + s / a^2)`. Outliers' influence decays
    /// like `1/|r|`.
    Cauchy(f64),
    /// A loss given by a function returning `[rho, rho', rho'']`.
    Custom(CustomLoss),
}

impl Loss {
    /// Errors unless the loss's scale is finite and positive (Huber's threshold, Cauchy's
    /// scale): a zero scale makes every residual an outlier with zero weight, a negative or NaN
    /// one makes the cost non-finite.
    pub fn check(&self) -> Result<(), String> {
        match *self {
            Loss::Huber(a) | Loss::Cauchy(a) if !(a.is_finite() && a > 0.0) => {
                Err(format!("the loss {self:?} needs a finite, positive scale"))
            }
            _ => Ok(()),
        }
    }

    /// `[rho(s), rho'(s), rho''(s)]`.
    #[inline]
    pub fn evaluate(&self, s: f64) -> [f64; 3] {
        match *self {
            Loss::Trivial => [s, 1.0, 0.0],
            Loss::Huber(a) => {
                let b = a * a;
                if s > b {
                    let r = s.sqrt();
                    [2.0 * a * r - b, a / r, -a / (2.0 * s * r)]
                } else {
                    [s, 1.0, 0.0]
                }
            }
            Loss::Cauchy(a) => {
                let b = a * a;
                let c = 1.0 / b;
                let sum = 1.0 + s * c;
                let inv = 1.0 / sum;
                [b * sum.ln(), inv, -c * inv * inv]
            }
            Loss::Custom(f) => (f.0)(s),
        }
    }

    /// True for the trivial loss (no correction needed).
    #[inline]
    pub fn is_trivial(&self) -> bool {
        matches!(self, Loss::Trivial)
    }
}

/// Applies the correction in place to a group of residuals `r` and the matching rows of a
/// column-major Jacobian, given `rho = Loss::evaluate(|r|^2)`. The Jacobian is given as
/// `(jac, rows, first_row, cols)`: a `rows x cols` matrix whose rows `first_row..first_row +
/// r.len()` belong to `r` (a whole residual block is `first_row = 0`, `rows = r.len()`).
///
/// The Jacobian must be corrected before the residual (it uses the uncorrected residual), which
/// this function takes care of.
pub(crate) fn apply_correction(
    rho: [f64; 3],
    r: &mut [f64],
    jac: Option<(&mut [f64], usize, usize, usize)>,
) {
    let s: f64 = r.iter().map(|v| v * v).sum();
    let sqrt_rho1 = rho[1].sqrt();
    let (residual_scale, alpha_over_s) = if s == 0.0 || rho[2] <= 0.0 {
        (sqrt_rho1, 0.0)
    } else {
        // rho'' > 0: the argument exceeds one, so alpha < 0 and 1 - alpha > 1.
        let alpha = 1.0 - (1.0 + 2.0 * s * rho[2] / rho[1]).sqrt();
        (sqrt_rho1 / (1.0 - alpha), alpha / s)
    };
    if let Some((jac, rows, first, cols)) = jac {
        for c in 0..cols {
            let col = &mut jac[c * rows + first..c * rows + first + r.len()];
            if alpha_over_s != 0.0 {
                let dot: f64 = col.iter().zip(r.iter()).map(|(a, b)| a * b).sum();
                let k = alpha_over_s * dot;
                for (j, ri) in col.iter_mut().zip(r.iter()) {
                    *j = sqrt_rho1 * (*j - k * ri);
                }
            } else {
                for j in col.iter_mut() {
                    *j *= sqrt_rho1;
                }
            }
        }
    }
    for v in r.iter_mut() {
        *v *= residual_scale;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numdiff::{central_difference, compare_jacobians};

    #[test]
    fn derivatives_match_finite_differences() {
        for loss in [Loss::Trivial, Loss::Huber(1.3), Loss::Cauchy(0.7)] {
            for s in [0.1, 0.5, 1.0, 2.0, 9.0] {
                if matches!(loss, Loss::Huber(_)) && (s - 1.69f64).abs() < 0.05 {
                    continue; // kink of Huber's second derivative
                }
                let first = central_difference(|x, o| o[0] = loss.evaluate(x[0])[0], &[s], 1, 1e-6);
                let second =
                    central_difference(|x, o| o[0] = loss.evaluate(x[0])[1], &[s], 1, 1e-6);
                let rho = loss.evaluate(s);
                assert!(
                    compare_jacobians(&[rho[1]], &first, 1, 1e-7, 1e-9).is_ok(),
                    "{loss:?} {s}"
                );
                assert!(
                    compare_jacobians(&[rho[2]], &second, 1, 1e-6, 1e-9).is_ok(),
                    "{loss:?} {s}"
                );
            }
        }
    }

    /// For a loss that is convex in `s`, the corrected block reproduces the exact Gauss-Newton
    /// curvature `rho' J^T J + 2 rho'' J^T r r^T J` as well as the gradient.
    #[test]
    fn convex_custom_loss_gets_the_full_curvature_correction() {
        let loss = Loss::Custom(CustomLoss(|s| [s + 0.25 * s * s, 1.0 + 0.5 * s, 0.5]));
        let r0 = [0.8, -1.7, 0.4];
        let j0 = [1.0, 0.5, -0.2, 0.3, -1.1, 0.9];
        let s: f64 = r0.iter().map(|v| v * v).sum();
        let rho = loss.evaluate(s);
        let (mut r, mut j) = (r0, j0);
        apply_correction(rho, &mut r, Some((&mut j, 3, 0, 2)));
        let jtr0: Vec<f64> = (0..2)
            .map(|c| (0..3).map(|i| j0[c * 3 + i] * r0[i]).sum())
            .collect();
        for a in 0..2 {
            let grad: f64 = (0..3).map(|i| j[a * 3 + i] * r[i]).sum();
            assert!((grad - rho[1] * jtr0[a]).abs() < 1e-12);
            for b in 0..2 {
                let corrected: f64 = (0..3).map(|i| j[a * 3 + i] * j[b * 3 + i]).sum();
                let plain: f64 = (0..3).map(|i| j0[a * 3 + i] * j0[b * 3 + i]).sum();
                let exact = rho[1] * plain + 2.0 * rho[2] * jtr0[a] * jtr0[b];
                assert!((corrected - exact).abs() < 1e-12, "{corrected} vs {exact}");
            }
        }
    }

    /// The corrected residual's squared norm has the same gradient as the robust cost:
    /// `J~^T r~ = rho' J^T r`.
    #[test]
    fn corrected_gradient_equals_robust_gradient() {
        let r0 = [0.8, -1.7, 0.4];
        let j0 = [1.0, 0.5, -0.2, 0.3, -1.1, 0.9]; // 3x2 column-major
        for loss in [Loss::Huber(0.5), Loss::Cauchy(0.6), Loss::Trivial] {
            let s: f64 = r0.iter().map(|v| v * v).sum();
            let rho = loss.evaluate(s);
            let mut r = r0;
            let mut j = j0;
            apply_correction(rho, &mut r, Some((&mut j, 3, 0, 2)));
            for c in 0..2 {
                let corrected: f64 = (0..3).map(|i| j[c * 3 + i] * r[i]).sum();
                let robust: f64 = rho[1] * (0..3).map(|i| j0[c * 3 + i] * r0[i]).sum::<f64>();
                assert!((corrected - robust).abs() < 1e-12, "{loss:?}");
            }
        }
    }
}
