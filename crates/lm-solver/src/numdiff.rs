//! Central finite differences, for checking analytic Jacobians.
//!
//! Every analytic Jacobian in the workspace is tested against [`central_difference`]. The step for
//! parameter `j` is `relative_step * max(|x_j|, 1)`; the truncation error of a central difference is
//! `O(h^2 f''')` and its rounding error about `eps |f| / h`, so a relative step near `1e-6` balances
//! the two for functions whose values and parameters are of order one to a thousand.
//!
//! ```
//! use lm_solver::numdiff::{central_difference, compare_jacobians};
//! // f(x) = (x0 * x1, sin(x0))
//! let f = |x: &[f64], out: &mut [f64]| {
//!     out[0] = x[0] * x[1];
//!     out[1] = x[0].sin();
//! };
//! let x = [0.3, 2.0];
//! let numeric = central_difference(f, &x, 2, 1e-6);
//! // analytic Jacobian, column-major (2 rows, 2 columns)
//! let analytic = [x[1], x[0].cos(), x[0], 0.0];
//! assert!(compare_jacobians(&analytic, &numeric, 2, 1e-8, 1e-10).is_ok());
//! ```

use crate::cost::{CostFunction, EvaluationError, GramBlocks, JacobianBlocks};
use crate::loss::{Loss, apply_correction};
use crate::normal_equations::grouped_loss;
use crate::problem::ResidualBlockId;

/// Central-difference Jacobian of `f: R^n -> R^m` at `x`.
///
/// `f(x, out)` writes the `m` function values into `out`. The result is column-major: entry
/// `(i, j)` (derivative of output `i` with respect to input `j`) is at index `i + j * m`.
/// Step for input `j`: `relative_step * max(|x_j|, 1)`.
///
/// Cost: `2n` evaluations of `f`. Allocates; meant for tests and diagnostics, not hot loops.
pub fn central_difference<F>(f: F, x: &[f64], m: usize, relative_step: f64) -> Vec<f64>
where
    F: FnMut(&[f64], &mut [f64]),
{
    let steps: Vec<f64> = x.iter().map(|v| relative_step * v.abs().max(1.0)).collect();
    central_difference_with_steps(f, x, m, &steps)
}

/// Central-difference Jacobian with an explicit step per input, for inputs whose natural scales
/// differ by orders of magnitude (such as the entries of a homography). Same layout and cost as
/// [`central_difference`].
pub fn central_difference_with_steps<F>(mut f: F, x: &[f64], m: usize, steps: &[f64]) -> Vec<f64>
where
    F: FnMut(&[f64], &mut [f64]),
{
    let n = x.len();
    let mut jac = vec![0.0; m * n];
    let mut xp = x.to_vec();
    let mut plus = vec![0.0; m];
    let mut minus = vec![0.0; m];
    for j in 0..n {
        let h = steps[j];
        xp[j] = x[j] + h;
        f(&xp, &mut plus);
        xp[j] = x[j] - h;
        f(&xp, &mut minus);
        xp[j] = x[j];
        // Use the actually representable step so that h's rounding does not bias the quotient.
        let two_h = (x[j] + h) - (x[j] - h);
        for i in 0..m {
            jac[i + j * m] = (plus[i] - minus[i]) / two_h;
        }
    }
    jac
}

/// The largest mismatch found by [`compare_jacobians`].
#[derive(Debug, Clone, PartialEq)]
pub struct JacobianMismatch {
    /// Row (output index) of the worst entry.
    pub row: usize,
    /// Column (input index) of the worst entry.
    pub col: usize,
    /// The analytic value.
    pub analytic: f64,
    /// The finite-difference value.
    pub numeric: f64,
    /// `|analytic - numeric| / (|numeric| + absolute_scale)`.
    pub relative_error: f64,
}

impl std::fmt::Display for JacobianMismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Jacobian entry ({}, {}): analytic {:e}, numeric {:e}, relative error {:e}",
            self.row, self.col, self.analytic, self.numeric, self.relative_error
        )
    }
}

/// Compares two column-major `m`-row Jacobians entry by entry.
///
/// An entry passes when `|a - n| <= relative_tolerance * (|n| + absolute_scale)`. The absolute scale
/// keeps entries that are zero (or cancel to nearly zero) from demanding an impossible relative
/// accuracy: pass the typical magnitude of the row's entries times the expected finite-difference
/// noise ratio, or simply a small number in the units of the Jacobian.
///
/// Returns the worst entry as an error if any entry fails, or if the lengths differ or any value
/// is not finite.
pub fn compare_jacobians(
    analytic: &[f64],
    numeric: &[f64],
    m: usize,
    relative_tolerance: f64,
    absolute_scale: f64,
) -> Result<(), JacobianMismatch> {
    let mut worst: Option<JacobianMismatch> = None;
    let mut failed = analytic.len() != numeric.len();
    for (k, (&a, &n)) in analytic.iter().zip(numeric).enumerate() {
        let rel = (a - n).abs() / (n.abs() + absolute_scale);
        let bad = !a.is_finite() || !n.is_finite() || rel > relative_tolerance;
        failed |= bad;
        let rel = if rel.is_finite() { rel } else { f64::INFINITY };
        if worst.as_ref().is_none_or(|w| rel > w.relative_error) {
            worst = Some(JacobianMismatch {
                row: k % m.max(1),
                col: k / m.max(1),
                analytic: a,
                numeric: n,
                relative_error: rel,
            });
        }
    }
    match (failed, worst) {
        (false, _) => Ok(()),
        (true, Some(w)) => Err(w),
        (true, None) => Err(JacobianMismatch {
            row: 0,
            col: 0,
            analytic: f64::NAN,
            numeric: f64::NAN,
            relative_error: f64::INFINITY,
        }),
    }
}

/// Why [`check_cost_function`] failed.
#[derive(Debug, Clone, PartialEq)]
pub enum CostCheckError {
    /// The cost function returned an error.
    Evaluation(EvaluationError),
    /// The residuals differ between the evaluation with Jacobians and the one without.
    ResidualsDiffer,
    /// A Jacobian entry differs from its finite difference (columns are numbered over the
    /// concatenated parameter blocks).
    Mismatch(JacobianMismatch),
    /// `evaluate_gram` returned `None`.
    NoFusedPath,
    /// An entry of the fused Gram matrix (`col` = `usize::MAX`: of the gradient; both: the squared
    /// residual norm) differs from the product formed from the Jacobian.
    GramMismatch {
        /// Row.
        row: usize,
        /// Column.
        col: usize,
        /// From `evaluate_gram`.
        fused: f64,
        /// From `evaluate`'s Jacobian.
        reference: f64,
    },
}

impl std::fmt::Display for CostCheckError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CostCheckError::Evaluation(e) => write!(f, "evaluation failed: {e}"),
            CostCheckError::ResidualsDiffer => {
                write!(f, "residuals differ with and without Jacobians")
            }
            CostCheckError::Mismatch(m) => m.fmt(f),
            CostCheckError::NoFusedPath => write!(f, "evaluate_gram is not implemented"),
            CostCheckError::GramMismatch {
                row,
                col,
                fused,
                reference,
            } => write!(
                f,
                "fused Gram entry ({row}, {col}): {fused:e} vs {reference:e}"
            ),
        }
    }
}

/// Checks a cost function's analytic Jacobian for one residual block against central
/// differences (like Ceres' gradient checker).
///
/// Evaluates residual block `block` (of dimension `rows`) at `params` with and without
/// Jacobians, requires identical residuals, then compares every Jacobian block with
/// [`central_difference`] (step `relative_step * max(|x|, 1)`) through [`compare_jacobians`].
pub fn check_cost_function<C: CostFunction>(
    cost: &C,
    block: ResidualBlockId,
    params: &[&[f64]],
    rows: usize,
    relative_step: f64,
    relative_tolerance: f64,
    absolute_scale: f64,
) -> Result<(), CostCheckError> {
    let mut layout = Vec::with_capacity(params.len());
    let mut cols = 0;
    for p in params {
        layout.push((cols, p.len()));
        cols += p.len();
    }
    let mut buffer = vec![f64::NAN; rows * cols];
    let mut residuals = vec![0.0; rows];
    let mut jacobians = JacobianBlocks {
        buffer: &mut buffer,
        rows,
        layout: &layout,
    };
    cost.evaluate(block, params, &mut residuals, Some(&mut jacobians))
        .map_err(CostCheckError::Evaluation)?;
    let mut plain = vec![0.0; rows];
    cost.evaluate(block, params, &mut plain, None)
        .map_err(CostCheckError::Evaluation)?;
    if plain != residuals {
        return Err(CostCheckError::ResidualsDiffer);
    }
    let x: Vec<f64> = params.iter().flat_map(|p| p.iter().copied()).collect();
    let mut failure = None;
    let numeric = central_difference(
        |v: &[f64], out: &mut [f64]| {
            let blocks: Vec<&[f64]> = layout.iter().map(|&(c, d)| &v[c..c + d]).collect();
            if let Err(e) = cost.evaluate(block, &blocks, out, None) {
                failure.get_or_insert(e);
                out.fill(f64::NAN);
            }
        },
        &x,
        rows,
        relative_step,
    );
    if let Some(e) = failure {
        return Err(CostCheckError::Evaluation(e));
    }
    compare_jacobians(&buffer, &numeric, rows, relative_tolerance, absolute_scale)
        .map_err(CostCheckError::Mismatch)
}

/// Checks a cost function's fused [`CostFunction::evaluate_gram`] against the products formed
/// from [`CostFunction::evaluate`]'s Jacobian for one residual block (of dimension `rows`).
///
/// Every Gram entry must agree to `relative_tolerance * sqrt(G_ii G_jj)`, every gradient entry to
/// `relative_tolerance * sqrt(G_ii |r|^2)` (the Cauchy-Schwarz bounds of the entries), and the
/// squared residual norm to `relative_tolerance` relative. Fails with
/// [`CostCheckError::NoFusedPath`] if `evaluate_gram` returns `None`.
pub fn check_gram<C: CostFunction>(
    cost: &C,
    block: ResidualBlockId,
    params: &[&[f64]],
    rows: usize,
    relative_tolerance: f64,
) -> Result<(), CostCheckError> {
    check_gram_with_loss(
        cost,
        block,
        params,
        rows,
        Loss::Trivial,
        rows,
        relative_tolerance,
    )
}

/// Like [`check_gram`] for a residual block with a robust `loss` applied to each group of
/// `group` residuals: the fused products must equal those of the corrected Jacobian and
/// residuals, and the returned value `sum_g rho(|r_g|^2)`.
pub fn check_gram_with_loss<C: CostFunction>(
    cost: &C,
    block: ResidualBlockId,
    params: &[&[f64]],
    rows: usize,
    loss: Loss,
    group: usize,
    relative_tolerance: f64,
) -> Result<(), CostCheckError> {
    let mut layout = Vec::with_capacity(params.len());
    let mut cols = 0;
    for p in params {
        layout.push((cols, p.len()));
        cols += p.len();
    }
    let mut jac = vec![0.0; rows * cols];
    let mut residuals = vec![0.0; rows];
    let mut jacobians = JacobianBlocks {
        buffer: &mut jac,
        rows,
        layout: &layout,
    };
    cost.evaluate(block, params, &mut residuals, Some(&mut jacobians))
        .map_err(CostCheckError::Evaluation)?;
    let s_ref = if loss.is_trivial() {
        residuals.iter().map(|v| v * v).sum()
    } else {
        let total = grouped_loss(loss, group, &residuals);
        for start in (0..rows).step_by(group) {
            let g = start..start + group;
            let s: f64 = residuals[g.clone()].iter().map(|v| v * v).sum();
            apply_correction(
                loss.evaluate(s),
                &mut residuals[g],
                Some((&mut jac, rows, start, cols)),
            );
        }
        total
    };
    let (mut gram, mut gradient) = (vec![f64::NAN; cols * cols], vec![f64::NAN; cols]);
    let mut blocks = GramBlocks {
        gram: &mut gram,
        gradient: &mut gradient,
        cols,
        layout: &layout,
        loss,
        group,
    };
    let s = cost
        .evaluate_gram(block, params, &mut blocks)
        .ok_or(CostCheckError::NoFusedPath)?
        .map_err(CostCheckError::Evaluation)?;
    let column = |c: usize| &jac[c * rows..(c + 1) * rows];
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let diag: Vec<f64> = (0..cols).map(|c| dot(column(c), column(c))).collect();
    let r_norm = dot(&residuals, &residuals);
    let mismatch = |row: usize, col: usize, fused: f64, reference: f64, scale: f64| {
        if (fused - reference).abs() <= relative_tolerance * scale && fused.is_finite() {
            Ok(())
        } else {
            Err(CostCheckError::GramMismatch {
                row,
                col,
                fused,
                reference,
            })
        }
    };
    mismatch(usize::MAX, usize::MAX, s, s_ref, s_ref.abs())?;
    for j in 0..cols {
        mismatch(
            j,
            usize::MAX,
            gradient[j],
            dot(column(j), &residuals),
            (diag[j] * r_norm).sqrt(),
        )?;
        for i in 0..cols {
            mismatch(
                i,
                j,
                gram[i + j * cols],
                dot(column(i), column(j)),
                (diag[i] * diag[j]).sqrt(),
            )?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn detects_a_wrong_derivative() {
        let f = |x: &[f64], out: &mut [f64]| out[0] = x[0] * x[0];
        let numeric = central_difference(f, &[3.0], 1, 1e-6);
        assert!(compare_jacobians(&[6.0], &numeric, 1, 1e-8, 1e-12).is_ok());
        let err = compare_jacobians(&[6.1], &numeric, 1, 1e-8, 1e-12).unwrap_err();
        assert_eq!((err.row, err.col), (0, 0));
        assert!(err.relative_error > 0.01);
    }

    #[test]
    fn rejects_non_finite_and_length_mismatch() {
        assert!(compare_jacobians(&[f64::NAN], &[1.0], 1, 1.0, 1.0).is_err());
        assert!(compare_jacobians(&[1.0, 2.0], &[1.0], 1, 1.0, 1.0).is_err());
    }
}
