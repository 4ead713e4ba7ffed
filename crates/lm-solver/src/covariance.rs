//! Covariance of the solution from the normal equations at the minimum.
//!
//! The covariance of the free parameters is `sigma^2 (J^T J)^-1` with the residual variance
//! `sigma^2 = 2 cost / (m - p)` (`m` residuals, `p` free parameters; for the trivial loss
//! `2 cost = |r|^2`). It is computed block-wise through the Schur complement, never forming the
//! whole inverse:
//!
//! ```text
//! C_rr = S^-1                              S = U - W V^-1 W^T (undamped)
//! C_ee = V_e^-1 + V_e^-1 W_e^T S^-1 W_e V_e^-1
//!      = L_e^-T (I + Y_e^T S^-1 Y_e) L_e^-1   with V_e = L_e L_e^T, Y_e = W_e L_e^-T
//! ```
//!
//! The reduced matrix `S` is formed and inverted densely (`O(n_r^2)` memory, `O(n_r^3)` time),
//! which suits calibration (`n_r` = 8 to 22). Fixed components and constant blocks have zero
//! covariance.

use crate::cost::CostFunction;
use crate::kernels::backward_substitute_transpose;
use crate::levenberg_marquardt::{Solver, describe};
use crate::problem::{BlockRole, ParameterBlockId};
use crate::schur::{assemble_dense_schur, eliminate_chunk, for_each_chunk};
use nalgebra::DMatrix;

/// Why a covariance could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CovarianceError {
    /// The parameter vector has the wrong length or non-finite entries.
    #[error("invalid parameter vector: {0}")]
    InvalidParameters(String),
    /// The cost function failed at the given parameters.
    #[error("residual block {residual} cannot be evaluated: {message}")]
    Evaluation {
        /// The failing residual block.
        residual: usize,
        /// What went wrong.
        message: String,
    },
    /// `J^T J` restricted to the free reduced parameters is singular: some combination of them is
    /// not determined by the data.
    #[error(
        "the reduced normal matrix has numerical rank {rank} but {dimension} free parameters: some parameter combination is not observable"
    )]
    RankDeficient {
        /// Numerical rank found.
        rank: usize,
        /// Number of free reduced parameters.
        dimension: usize,
    },
    /// The normal matrix block of an eliminated parameter block is singular.
    #[error("parameter block {block} is not determined by its residuals (singular normal block)")]
    SingularEliminatedBlock {
        /// The parameter block.
        block: usize,
    },
    /// Not more residuals than free parameters: the residual variance is undefined.
    #[error("{residuals} residuals for {parameters} free parameters: no degrees of freedom left")]
    NoDegreesOfFreedom {
        /// Number of residuals.
        residuals: usize,
        /// Number of free parameters.
        parameters: usize,
    },
}

/// Relative eigenvalue below which a direction of the Jacobi-scaled reduced matrix counts as
/// unobservable. Rounding in `J^T J` perturbs eigenvalues by about `n eps` relative to the largest;
/// `1e-12` leaves three orders of margin above that for systems of up to ~100 parameters while
/// flagging directions whose standard deviation would be a million times the best-determined one
/// (per unit of the scaled parameters).
pub const RANK_TOLERANCE: f64 = 1e-12;

/// Covariance of the parameters at a solution, scaled by the residual variance.
#[derive(Debug, Clone)]
pub struct Covariance {
    /// `sigma^2 = 2 cost / (m - p)`: the variance of one residual, estimated from the fit.
    pub residual_variance: f64,
    /// `m - p`.
    pub degrees_of_freedom: usize,
    reduced: DMatrix<f64>,
    eliminated: Vec<DMatrix<f64>>,
    roles: Vec<BlockRole>,
    dims: Vec<usize>,
    reduced_offsets: Vec<usize>,
}

impl Covariance {
    /// The covariance block of one parameter block (`dim x dim`), or `None` for a constant block.
    pub fn block(&self, block: ParameterBlockId) -> Option<DMatrix<f64>> {
        let d = self.dims[block.0];
        match self.roles[block.0] {
            BlockRole::Constant => None,
            BlockRole::Reduced(r) => {
                let o = self.reduced_offsets[r];
                Some(self.reduced.view((o, o), (d, d)).into_owned())
            }
            BlockRole::Eliminated(e) => Some(self.eliminated[e].clone()),
        }
    }

    /// The cross-covariance of two non-eliminated blocks (`dim_a x dim_b`), or `None` if either
    /// is constant or eliminated.
    pub fn cross(&self, a: ParameterBlockId, b: ParameterBlockId) -> Option<DMatrix<f64>> {
        match (self.roles[a.0], self.roles[b.0]) {
            (BlockRole::Reduced(ra), BlockRole::Reduced(rb)) => {
                let (oa, ob) = (self.reduced_offsets[ra], self.reduced_offsets[rb]);
                Some(
                    self.reduced
                        .view((oa, ob), (self.dims[a.0], self.dims[b.0]))
                        .into_owned(),
                )
            }
            _ => None,
        }
    }

    /// Standard deviations of a block's components (zeros for constant blocks and fixed
    /// components).
    pub fn standard_deviations(&self, block: ParameterBlockId) -> Vec<f64> {
        match self.block(block) {
            Some(c) => (0..c.nrows()).map(|i| c[(i, i)].max(0.0).sqrt()).collect(),
            None => vec![0.0; self.dims[block.0]],
        }
    }
}

impl Solver {
    /// Covariance of the parameters `x` (normally the solution of [`Solver::solve`]).
    ///
    /// Linearizes at `x` (unless the last solve ended there, whose linearization is reused), forms
    /// the undamped Schur complement of the reduced blocks, checks its
    /// numerical rank (eigenvalues of the Jacobi-scaled matrix against [`RANK_TOLERANCE`]) and
    /// inverts it.
    pub fn covariance<C: CostFunction>(
        &mut self,
        cost_fn: &C,
        x: &[f64],
    ) -> Result<Covariance, CovarianceError> {
        let problem = &self.problem;
        if x.len() != problem.num_parameters || x.iter().any(|v| !v.is_finite()) {
            return Err(CovarianceError::InvalidParameters(format!(
                "expected {} finite values, got {}",
                problem.num_parameters,
                x.len()
            )));
        }
        let p = problem.num_free;
        let m = problem.num_residuals;
        if m <= p {
            return Err(CovarianceError::NoDegreesOfFreedom {
                residuals: m,
                parameters: p,
            });
        }
        let pool = self.pool.as_ref();
        // Right after a solve the normal equations already belong to `x`.
        if self.linearized_at.as_deref() != Some(x) {
            self.linearized_at = None;
            self.ne
                .evaluate(problem, cost_fn, x, true, pool)
                .map_err(|f| {
                    let (residual, message) = describe(&f);
                    CovarianceError::Evaluation { residual, message }
                })?;
            self.linearized_at = Some(x.to_vec());
        }
        let sigma2 = 2.0 * self.ne.cost / (m - p) as f64;
        let n = problem.reduced_dim;

        // Undamped elimination; fixed components get a unit diagonal so that the blocks stay
        // invertible (their rows and columns are otherwise zero).
        let damping: Vec<f64> = problem
            .fixed_mask
            .iter()
            .map(|&f| if f { 1.0 } else { 0.0 })
            .collect();
        for chunk in &mut self.ne.chunks {
            if chunk.factor.len() != chunk.v.len() {
                chunk.factor = vec![0.0; chunk.v.len()];
                chunk.y = vec![0.0; chunk.w.len()];
                chunk.z = vec![0.0; chunk.ge.len()];
            }
            if chunk.s_partial.len() != n * n {
                chunk.s_partial = vec![0.0; n * n];
                chunk.rhs_partial = vec![0.0; n];
            }
        }
        for_each_chunk(&mut self.ne.chunks, pool, |c| {
            eliminate_chunk(problem, c, &damping, true)
        });
        for chunk in &self.ne.chunks {
            if chunk.solve_failed {
                // Find the failing block for the message.
                let block = chunk
                    .elim
                    .clone()
                    .map(|e| problem.eliminated[e].block)
                    .next()
                    .unwrap_or(0);
                return Err(CovarianceError::SingularEliminatedBlock { block });
            }
            // A positive but tiny pivot also means an undetermined block.
            for (local, e) in chunk.elim.clone().enumerate() {
                let layout = &problem.eliminated[e];
                let d = layout.dim;
                let vo = chunk.v_off[local];
                let max_diag = (0..d)
                    .map(|i| chunk.v[vo + i * (d + 1)])
                    .fold(0.0f64, f64::max);
                let min_pivot = (0..d)
                    .map(|i| chunk.factor[vo + i * (d + 1)].powi(2))
                    .fold(f64::INFINITY, f64::min);
                if min_pivot <= RANK_TOLERANCE * max_diag {
                    return Err(CovarianceError::SingularEliminatedBlock {
                        block: layout.block,
                    });
                }
            }
        }
        let mut s = DMatrix::<f64>::zeros(n, n);
        assemble_dense_schur(problem, &self.ne, s.as_mut_slice());
        // Free reduced components.
        let mut free = Vec::new();
        for (ra, &block) in problem.reduced_blocks.iter().enumerate() {
            for i in 0..problem.dims[block] {
                if !problem.fixed_mask[problem.offsets[block] + i] {
                    free.push(problem.reduced_offsets[ra] + i);
                }
            }
        }
        let k = free.len();
        let mut inverse = DMatrix::<f64>::zeros(n, n);
        if k > 0 {
            let sub = DMatrix::from_fn(k, k, |i, j| s[(free[i], free[j])]);
            let scale: Vec<f64> = (0..k)
                .map(|i| 1.0 / sub[(i, i)].max(f64::MIN_POSITIVE).sqrt())
                .collect();
            let scaled = DMatrix::from_fn(k, k, |i, j| sub[(i, j)] * scale[i] * scale[j]);
            let eigen = nalgebra::SymmetricEigen::new(scaled);
            let max_ev = eigen.eigenvalues.iter().fold(0.0f64, |a, &b| a.max(b));
            let rank = eigen
                .eigenvalues
                .iter()
                .filter(|&&v| v > RANK_TOLERANCE * max_ev)
                .count();
            if rank < k || !max_ev.is_finite() {
                return Err(CovarianceError::RankDeficient { rank, dimension: k });
            }
            let inv_ev = DMatrix::from_diagonal(&eigen.eigenvalues.map(|v| 1.0 / v));
            let inv_scaled = &eigen.eigenvectors * inv_ev * eigen.eigenvectors.transpose();
            for i in 0..k {
                for j in 0..k {
                    inverse[(free[i], free[j])] = inv_scaled[(i, j)] * scale[i] * scale[j];
                }
            }
        }
        // Eliminated blocks.
        let mut eliminated = vec![DMatrix::zeros(0, 0); problem.eliminated.len()];
        for chunk in &self.ne.chunks {
            for (local, e) in chunk.elim.clone().enumerate() {
                let layout = &problem.eliminated[e];
                let (d, rows) = (layout.dim, layout.w_rows);
                let (vo, wo) = (chunk.v_off[local], chunk.w_off[local]);
                let l = &chunk.factor[vo..vo + d * d];
                let y = DMatrix::from_column_slice(rows, d, &chunk.y[wo..wo + rows * d]);
                // Reduced index of each row of W_e / Y_e.
                let mut index = Vec::with_capacity(rows);
                for &(ra, _) in &layout.coupled {
                    let g = problem.reduced_offsets[ra];
                    for i in 0..problem.dims[problem.reduced_blocks[ra]] {
                        index.push(g + i);
                    }
                }
                let c_sub = DMatrix::from_fn(rows, rows, |i, j| inverse[(index[i], index[j])]);
                let mut middle = y.transpose() * c_sub * &y;
                for i in 0..d {
                    middle[(i, i)] += 1.0;
                }
                // L^-T M L^-1 = L^-T (L^-T M)^T, because M is symmetric: apply L^-T to the
                // columns twice with a transpose in between.
                let mut cov = middle;
                for j in 0..d {
                    let mut col: Vec<f64> = cov.column(j).iter().copied().collect();
                    backward_substitute_transpose(l, d, &mut col);
                    cov.column_mut(j).copy_from_slice(&col);
                }
                let mut cov = cov.transpose();
                for j in 0..d {
                    let mut col: Vec<f64> = cov.column(j).iter().copied().collect();
                    backward_substitute_transpose(l, d, &mut col);
                    cov.column_mut(j).copy_from_slice(&col);
                }
                let base = problem.offsets[layout.block];
                for i in 0..d {
                    if problem.fixed_mask[base + i] {
                        for j in 0..d {
                            cov[(i, j)] = 0.0;
                            cov[(j, i)] = 0.0;
                        }
                    }
                }
                eliminated[e] = cov * sigma2;
            }
        }
        Ok(Covariance {
            residual_variance: sigma2,
            degrees_of_freedom: m - p,
            reduced: inverse * sigma2,
            eliminated,
            roles: problem.roles.clone(),
            dims: problem.dims.clone(),
            reduced_offsets: problem.reduced_offsets.clone(),
        })
    }
}
