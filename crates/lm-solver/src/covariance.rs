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
//! Small reduced systems (up to 512 parameters: calibration has 8 to a few hundred) are inverted
//! densely (`O(n_r^2)` memory, `O(n_r^3)` time) after an eigenvalue rank check that names the
//! weakest parameter combination. Larger ones (bundle adjustment) go through the sparse Cholesky
//! factorization of `S`, and only the columns of `S^-1` that the requested blocks need are
//! solved for ([`Solver::covariance_of`]): `O(n_r k)` memory for `k` such columns. Fixed
//! components and constant blocks have zero covariance. For blocks with a manifold everything is
//! in tangent coordinates.

use crate::cost::CostFunction;
use crate::kernels::backward_substitute_transpose;
use crate::levenberg_marquardt::{Solver, describe};
use crate::linear_solver::SparseSchurSystem;
use crate::problem::{BlockRole, ParameterBlockId, Problem};
use crate::schur::{assemble_dense_schur, eliminate_chunk, for_each_chunk};
use nalgebra::DMatrix;

/// Largest reduced system whose covariance is formed densely.
pub const DENSE_COVARIANCE_LIMIT: usize = 512;

/// Why a covariance could not be computed.
#[non_exhaustive]
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
        /// The components that carry the weakest direction (largest entries of its eigenvector
        /// of the Jacobi-scaled matrix, all within a factor 3 of the largest): `(parameter
        /// block, tangent component)`. A caller can name them ("view 3 pose", "fx").
        weakest: Vec<(ParameterBlockId, usize)>,
    },
    /// The sparse factorization of the reduced normal matrix failed, or a requested variance is
    /// unbounded: some parameter combination is not observable.
    #[error(
        "the reduced normal matrix ({dimension} free parameters) is singular: some parameter combination is not observable"
    )]
    Singular {
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

/// `S^-1` (scaled by the residual variance): whole, or some of its columns.
#[derive(Debug, Clone)]
enum ReducedInverse {
    Dense(DMatrix<f64>),
    /// `columns` is `n x k`; `index[i]` is the column holding reduced component `i`, or
    /// `usize::MAX` if it was not computed.
    Columns {
        index: Vec<usize>,
        columns: DMatrix<f64>,
    },
}

impl ReducedInverse {
    fn entry(&self, i: usize, j: usize) -> Option<f64> {
        match self {
            ReducedInverse::Dense(m) => Some(m[(i, j)]),
            ReducedInverse::Columns { index, columns } => match index[j] {
                usize::MAX => match index[i] {
                    usize::MAX => None,
                    c => Some(columns[(j, c)]),
                },
                c => Some(columns[(i, c)]),
            },
        }
    }
}

/// Covariance of the parameters at a solution, scaled by the residual variance.
#[derive(Debug, Clone)]
pub struct Covariance {
    /// `sigma^2 = 2 cost / (m - p)`: the variance of one residual, estimated from the fit.
    pub residual_variance: f64,
    /// `m - p`.
    pub degrees_of_freedom: usize,
    /// Reduced components along directions the data did not determine, when the covariance was
    /// computed with [`Solver::covariance_floored`] (empty otherwise): their variances are
    /// lower bounds.
    pub floored: Vec<(ParameterBlockId, usize)>,
    reduced: ReducedInverse,
    eliminated: Vec<Option<DMatrix<f64>>>,
    roles: Vec<BlockRole>,
    dims: Vec<usize>,
    reduced_offsets: Vec<usize>,
}

impl Covariance {
    /// The covariance block of one parameter block (`tangent_dim x tangent_dim`), or `None` for a
    /// constant block or a block that was not requested from [`Solver::covariance_of`].
    pub fn block(&self, block: ParameterBlockId) -> Option<DMatrix<f64>> {
        match self.roles[block.0] {
            BlockRole::Constant => None,
            BlockRole::Reduced(_) => self.cross(block, block),
            BlockRole::Eliminated(e) => self.eliminated[e].clone(),
        }
    }

    /// The cross-covariance of two non-eliminated blocks (`dim_a x dim_b`), or `None` if either
    /// is constant or eliminated, or if neither was requested.
    pub fn cross(&self, a: ParameterBlockId, b: ParameterBlockId) -> Option<DMatrix<f64>> {
        match (self.roles[a.0], self.roles[b.0]) {
            (BlockRole::Reduced(ra), BlockRole::Reduced(rb)) => {
                let (oa, ob) = (self.reduced_offsets[ra], self.reduced_offsets[rb]);
                let (da, db) = (self.dims[a.0], self.dims[b.0]);
                let mut out = DMatrix::zeros(da, db);
                for j in 0..db {
                    for i in 0..da {
                        out[(i, j)] = self.reduced.entry(oa + i, ob + j)?;
                    }
                }
                Some(out)
            }
            _ => None,
        }
    }

    /// Standard deviations of a block's components (zeros for constant blocks and fixed
    /// components, and for blocks that were not requested).
    pub fn standard_deviations(&self, block: ParameterBlockId) -> Vec<f64> {
        match self.block(block) {
            Some(c) => (0..c.nrows()).map(|i| c[(i, i)].max(0.0).sqrt()).collect(),
            None => vec![0.0; self.dims[block.0]],
        }
    }
}

/// The free reduced components (reduced scalar indices), in order.
fn free_reduced(problem: &Problem) -> Vec<usize> {
    let mut free = Vec::new();
    for (ra, &block) in problem.reduced_blocks.iter().enumerate() {
        for i in 0..problem.dims[block] {
            if !problem.fixed_mask[problem.offsets[block] + i] {
                free.push(problem.reduced_offsets[ra] + i);
            }
        }
    }
    free
}

/// `(parameter block, component)` of reduced scalar index `i`.
fn reduced_component(problem: &Problem, i: usize) -> (ParameterBlockId, usize) {
    let ra = problem.reduced_offsets.partition_point(|&o| o <= i) - 1;
    (
        ParameterBlockId(problem.reduced_blocks[ra]),
        i - problem.reduced_offsets[ra],
    )
}

impl Solver {
    /// Covariance of all parameters at `x` (normally the solution of [`Solver::solve`]); see
    /// [`Solver::covariance_of`].
    pub fn covariance<C: CostFunction>(
        &mut self,
        cost_fn: &C,
        x: &[f64],
    ) -> Result<Covariance, CovarianceError> {
        let all: Vec<ParameterBlockId> = (0..self.problem.num_parameter_blocks())
            .map(ParameterBlockId)
            .collect();
        self.covariance_of(cost_fn, x, &all)
    }

    /// Covariance of the requested parameter blocks at `x` (their blocks and, for non-eliminated
    /// ones, their cross-covariances).
    ///
    /// Linearizes at `x` (unless the last solve ended there, whose linearization is reused) and
    /// forms the undamped Schur complement `S` of the reduced blocks. Up to
    /// [`DENSE_COVARIANCE_LIMIT`] reduced parameters `S` is checked for numerical rank
    /// (eigenvalues of the Jacobi-scaled matrix against [`RANK_TOLERANCE`]) and inverted densely.
    /// Beyond, `S` is factorized sparsely and only the columns of `S^-1` that the requested
    /// blocks need are solved for (the requested reduced blocks, and the reduced blocks coupled to
    /// each requested eliminated block), so asking for a few blocks of a large problem costs a
    /// factorization and a few solves, not a dense inverse.
    pub fn covariance_of<C: CostFunction>(
        &mut self,
        cost_fn: &C,
        x: &[f64],
        blocks: &[ParameterBlockId],
    ) -> Result<Covariance, CovarianceError> {
        self.covariance_impl(cost_fn, x, blocks, false)
    }

    /// [`Solver::covariance`], but directions of the reduced system below the rank tolerance are
    /// kept with their eigenvalue raised to the tolerance (standard deviations a million times
    /// the best-determined one's, per unit of the scaled parameters) instead of failing, and
    /// their main components listed in [`Covariance::floored`]: for models whose extra terms the
    /// data may not separate, where the caller reports them rather than refusing the whole
    /// result. Only the dense path (up to [`DENSE_COVARIANCE_LIMIT`] reduced parameters) floors;
    /// beyond it, this is [`Solver::covariance`].
    pub fn covariance_floored<C: CostFunction>(
        &mut self,
        cost_fn: &C,
        x: &[f64],
    ) -> Result<Covariance, CovarianceError> {
        let all: Vec<ParameterBlockId> = (0..self.problem.num_parameter_blocks())
            .map(ParameterBlockId)
            .collect();
        self.covariance_impl(cost_fn, x, &all, true)
    }

    fn covariance_impl<C: CostFunction>(
        &mut self,
        cost_fn: &C,
        x: &[f64],
        blocks: &[ParameterBlockId],
        floor: bool,
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
        let dense = n <= DENSE_COVARIANCE_LIMIT;

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
            if dense && chunk.s_partial.len() != n * n {
                chunk.s_partial = vec![0.0; n * n];
                chunk.rhs_partial = vec![0.0; n];
            }
        }
        for_each_chunk(&mut self.ne.chunks, pool, |c| {
            eliminate_chunk(problem, c, &damping, dense)
        });
        for chunk in &self.ne.chunks {
            if chunk.solve_failed {
                // The failing block itself, not the chunk's first: chunks hold many views.
                let block = chunk
                    .failed_eliminated
                    .or_else(|| chunk.elim.clone().next())
                    .map_or(0, |e| problem.eliminated[e].block);
                return Err(CovarianceError::SingularEliminatedBlock { block });
            }
            // A positive but tiny pivot also means an undetermined block. Each squared pivot is
            // compared with its own diagonal entry (`L_ii^2 / V_ii`, the fraction of the
            // component's information not explained by the components before it): independent of
            // the units, where comparing with the largest diagonal would call a pose 2 m away
            // singular because its rotation and translation entries differ by 1e12 in mm.
            for (local, e) in chunk.elim.clone().enumerate() {
                let layout = &problem.eliminated[e];
                let d = layout.dim;
                let vo = chunk.v_off[local];
                let min_ratio = (0..d)
                    .map(|i| {
                        let diag = chunk.v[vo + i * (d + 1)];
                        let pivot = chunk.factor[vo + i * (d + 1)].powi(2);
                        if diag > 0.0 { pivot / diag } else { 0.0 }
                    })
                    .fold(f64::INFINITY, f64::min);
                if min_ratio <= RANK_TOLERANCE {
                    return Err(CovarianceError::SingularEliminatedBlock {
                        block: layout.block,
                    });
                }
            }
        }
        let mut wanted_eliminated = vec![false; problem.eliminated.len()];
        let mut wanted_reduced = vec![false; problem.reduced_blocks.len()];
        for b in blocks {
            match problem.roles[b.0] {
                BlockRole::Constant => {}
                BlockRole::Reduced(ra) => wanted_reduced[ra] = true,
                BlockRole::Eliminated(e) => {
                    wanted_eliminated[e] = true;
                    for &(ra, _) in &problem.eliminated[e].coupled {
                        wanted_reduced[ra] = true;
                    }
                }
            }
        }
        let mut floored = Vec::new();
        let reduced = if dense {
            self.dense_reduced_inverse(floor.then_some(&mut floored))?
        } else {
            self.sparse_reduced_inverse(&damping, &wanted_reduced)?
        };
        let problem = &self.problem;
        // Eliminated blocks.
        let mut eliminated = vec![None; problem.eliminated.len()];
        for chunk in &self.ne.chunks {
            for (local, e) in chunk.elim.clone().enumerate() {
                if !wanted_eliminated[e] {
                    continue;
                }
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
                let c_sub = DMatrix::from_fn(rows, rows, |i, j| {
                    reduced.entry(index[i], index[j]).unwrap_or(0.0)
                });
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
                eliminated[e] = Some(cov * sigma2);
            }
        }
        let reduced = match reduced {
            ReducedInverse::Dense(m) => ReducedInverse::Dense(m * sigma2),
            ReducedInverse::Columns { index, columns } => ReducedInverse::Columns {
                index,
                columns: columns * sigma2,
            },
        };
        Ok(Covariance {
            residual_variance: sigma2,
            degrees_of_freedom: m - p,
            floored,
            reduced,
            eliminated,
            roles: problem.roles.clone(),
            dims: problem.dims.clone(),
            reduced_offsets: problem.reduced_offsets.clone(),
        })
    }

    /// `S^-1` (unscaled) from the dense partial Schur complements, after a rank check.
    fn dense_reduced_inverse(
        &self,
        floored: Option<&mut Vec<(ParameterBlockId, usize)>>,
    ) -> Result<ReducedInverse, CovarianceError> {
        let problem = &self.problem;
        let n = problem.reduced_dim;
        let mut s = DMatrix::<f64>::zeros(n, n);
        assemble_dense_schur(problem, &self.ne, s.as_mut_slice());
        let free = free_reduced(problem);
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
            let mut eigenvalues = eigen.eigenvalues.clone();
            if let Some(floored) = floored
                && max_ev.is_finite()
                && max_ev > 0.0
                && rank < k
            {
                let floor = RANK_TOLERANCE * max_ev;
                for (j, v) in eigenvalues.iter_mut().enumerate() {
                    if *v <= floor {
                        *v = floor;
                        let vector = eigen.eigenvectors.column(j);
                        let largest = vector.amax();
                        floored.extend(
                            (0..k)
                                .filter(|&i| vector[i].abs() * 3.0 >= largest)
                                .map(|i| reduced_component(problem, free[i])),
                        );
                    }
                }
                floored.sort_unstable_by_key(|&(b, c)| (b.0, c));
                floored.dedup();
            } else if rank < k || !max_ev.is_finite() {
                let weakest_index = eigen.eigenvalues.imin();
                let vector = eigen.eigenvectors.column(weakest_index);
                let largest = vector.amax();
                let weakest = (0..k)
                    .filter(|&i| vector[i].abs() * 3.0 >= largest)
                    .map(|i| reduced_component(problem, free[i]))
                    .collect();
                return Err(CovarianceError::RankDeficient {
                    rank,
                    dimension: k,
                    weakest,
                });
            }
            let inv_ev = DMatrix::from_diagonal(&eigenvalues.map(|v| 1.0 / v));
            let inv_scaled = &eigen.eigenvectors * inv_ev * eigen.eigenvectors.transpose();
            for i in 0..k {
                for j in 0..k {
                    inverse[(free[i], free[j])] = inv_scaled[(i, j)] * scale[i] * scale[j];
                }
            }
        }
        Ok(ReducedInverse::Dense(inverse))
    }

    /// The columns of `S^-1` (unscaled) for the components of the wanted reduced blocks, from a
    /// sparse factorization of `S` (fixed components: unit diagonal, zeroed afterwards).
    fn sparse_reduced_inverse(
        &self,
        damping: &[f64],
        wanted_reduced: &[bool],
    ) -> Result<ReducedInverse, CovarianceError> {
        let problem = &self.problem;
        let n = problem.reduced_dim;
        let free = free_reduced(problem);
        let mut system =
            SparseSchurSystem::new(problem).map_err(|_| CovarianceError::Singular {
                dimension: free.len(),
            })?;
        system.assemble(problem, &self.ne, damping, None);
        let diagonal = system.matrix.diagonal();
        let mut index = vec![usize::MAX; n];
        let mut wanted = Vec::new();
        for (ra, &block) in problem.reduced_blocks.iter().enumerate() {
            if !wanted_reduced[ra] {
                continue;
            }
            for i in 0..problem.dims[block] {
                index[problem.reduced_offsets[ra] + i] = wanted.len();
                wanted.push(problem.reduced_offsets[ra] + i);
            }
        }
        let k = wanted.len();
        let mut columns = DMatrix::<f64>::zeros(n, k);
        for (c, &i) in wanted.iter().enumerate() {
            columns[(i, c)] = 1.0;
        }
        if k > 0 {
            system
                .matrix
                .factorize_and_solve_columns(columns.as_mut_slice(), k)
                .map_err(|_| CovarianceError::Singular {
                    dimension: free.len(),
                })?;
        }
        let is_free = {
            let mut mask = vec![false; n];
            for &i in &free {
                mask[i] = true;
            }
            mask
        };
        for (c, &i) in wanted.iter().enumerate() {
            if !is_free[i] {
                columns.column_mut(c).fill(0.0);
                continue;
            }
            // A variance beyond 1 / RANK_TOLERANCE in Jacobi-scaled units: unobservable.
            let scaled_variance = columns[(i, c)] * diagonal[i];
            if scaled_variance.is_nan() || scaled_variance > 1.0 / RANK_TOLERANCE {
                return Err(CovarianceError::Singular {
                    dimension: free.len(),
                });
            }
            for r in 0..n {
                if !is_free[r] {
                    columns[(r, c)] = 0.0;
                }
            }
        }
        Ok(ReducedInverse::Columns { index, columns })
    }
}
