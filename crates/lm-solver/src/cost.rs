//! The evaluation callback: how users supply residuals and analytic Jacobians.

use crate::loss::Loss;
use crate::problem::ResidualBlockId;

/// A failure reported by a cost function, for example a point that moved behind a camera.
///
/// At the initial parameters this aborts the solve with an error; at a trial point of the
/// Levenberg-Marquardt iteration it only rejects the step.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct EvaluationError {
    /// What went wrong, in words.
    pub message: String,
}

impl EvaluationError {
    /// An error with a message.
    pub fn new(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
        }
    }
}

/// The Jacobian blocks of one residual block, to be filled by [`CostFunction::evaluate`].
///
/// Block `k` (the `k`-th parameter block the residual depends on, in the order given to
/// [`ProblemBuilder::add_residual_block`](crate::ProblemBuilder::add_residual_block)) is a
/// column-major `rows x dim_k` matrix: entry `(i, j)`, the derivative of residual `i` with respect
/// to component `j` of the block, is at index `i + j * rows`.
///
/// The buffer is reused between residual blocks and is not cleared: every entry of every block
/// for which [`JacobianBlocks::block_mut`] returns `Some` must be written, zeros included.
pub struct JacobianBlocks<'a> {
    pub(crate) buffer: &'a mut [f64],
    pub(crate) rows: usize,
    /// (first column, dim) per parameter block; `usize::MAX` column for constant blocks.
    pub(crate) layout: &'a [(usize, usize)],
}

impl<'a> JacobianBlocks<'a> {
    /// Jacobian blocks over `buffer` (column-major, `rows` rows), parameter block `k` occupying
    /// columns `layout[k].0 .. layout[k].0 + layout[k].1` (`usize::MAX` as first column: a
    /// constant block with no columns). The solver builds these itself; this is for testing a
    /// cost function directly.
    pub fn new(buffer: &'a mut [f64], rows: usize, layout: &'a [(usize, usize)]) -> Self {
        Self {
            buffer,
            rows,
            layout,
        }
    }

    /// Number of residuals (rows of every block).
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The block for the `k`-th parameter block, or `None` if that block is constant (its
    /// Jacobian is not needed).
    #[inline]
    pub fn block_mut(&mut self, k: usize) -> Option<&mut [f64]> {
        let (col, dim) = self.layout[k];
        if col == usize::MAX {
            return None;
        }
        Some(&mut self.buffer[col * self.rows..(col + dim) * self.rows])
    }

    /// True if the `k`-th parameter block's Jacobian is wanted.
    #[inline]
    pub fn wants(&self, k: usize) -> bool {
        self.layout[k].0 != usize::MAX
    }
}

/// The Gram matrix `J^T J` and gradient `J^T r` of one residual block, to be filled by
/// [`CostFunction::evaluate_gram`].
///
/// The columns are those of the block's Jacobian: parameter block `k` (in the order given to
/// [`ProblemBuilder::add_residual_block`](crate::ProblemBuilder::add_residual_block)) occupies
/// columns `block(k)`; constant blocks have no columns. The Gram matrix is column-major
/// `cols x cols` and every entry must be written (both triangles); the buffers are reused
/// between residual blocks and are not cleared.
pub struct GramBlocks<'a> {
    pub(crate) gram: &'a mut [f64],
    pub(crate) gradient: &'a mut [f64],
    pub(crate) cols: usize,
    pub(crate) layout: &'a [(usize, usize)],
    pub(crate) loss: Loss,
    pub(crate) group: usize,
}

impl GramBlocks<'_> {
    /// Number of columns (and rows) of the Gram matrix.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// First column and dimension of the `k`-th parameter block, or `None` if it is constant.
    #[inline]
    pub fn block(&self, k: usize) -> Option<(usize, usize)> {
        let (col, dim) = self.layout[k];
        (col != usize::MAX).then_some((col, dim))
    }

    /// The Gram matrix (`cols x cols`, column-major) and the gradient (`cols`).
    #[inline]
    pub fn parts_mut(&mut self) -> (&mut [f64], &mut [f64]) {
        (self.gram, self.gradient)
    }

    /// The residual block's loss, applied to each group of [`GramBlocks::loss_group`] residuals.
    #[inline]
    pub fn loss(&self) -> Loss {
        self.loss
    }

    /// Rows per loss group (the block's dimension when the loss applies to the whole block).
    #[inline]
    pub fn loss_group(&self) -> usize {
        self.group
    }
}

/// Residuals and analytic Jacobians of every residual block of a problem.
///
/// The solver calls `evaluate` for each residual block, possibly from several threads at once
/// (hence `Sync`), always with the values of the blocks that residual depends on.
pub trait CostFunction: Sync {
    /// Evaluates residual block `block`.
    ///
    /// * `params[k]` holds the current values of the `k`-th parameter block of this residual.
    /// * `residuals` (length = the block's dimension) receives the residuals.
    /// * `jacobians`, when present, receives the Jacobian blocks (see [`JacobianBlocks`]). It is
    ///   absent when only the cost is needed (trial points).
    ///
    /// Returning an error marks the parameters as invalid (for example a point behind a camera).
    /// Non-finite residuals or Jacobians are treated the same way.
    fn evaluate(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError>;

    /// Optional fast path: evaluate residual block `block` and write its Gram matrix `J^T J` and
    /// gradient `J^T r` directly (see [`GramBlocks`]), returning `sum_g rho(|r_g|^2)` over the
    /// block's loss groups (the squared residual norm `|r|^2` for the trivial loss).
    ///
    /// A cost function that knows the structure of its Jacobian (zeros, repeated factors) can
    /// accumulate these products point by point, fused with the evaluation, without writing the
    /// Jacobian out. The default returns `None`, and the solver forms the products from
    /// [`CostFunction::evaluate`]'s Jacobian. With a non-trivial loss ([`GramBlocks::loss`]) the
    /// products must be those of the corrected residuals and Jacobian (`crate::loss`), group by
    /// group; a cost function that does not handle a loss returns `None` for it. The solver
    /// zeroes the rows and columns of fixed components itself. Results must agree with
    /// `evaluate` (`lm_solver::numdiff::check_gram` tests that). Summing the returned value group
    /// by group in residual order, from residuals equal to `evaluate`'s, gives the cost-only
    /// pass's value to the bit, so that a trial point's cost does not depend on how it was
    /// evaluated (`SolverOptions::eager_linearization`).
    fn evaluate_gram(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        gram: &mut GramBlocks<'_>,
    ) -> Option<Result<f64, EvaluationError>> {
        let _ = (block, params, gram);
        None
    }
}
