//! Linear solvers for the damped normal equations `(J^T J + diag(damping)) step = -g`.
//!
//! All solvers solve the same system and give the same step up to rounding; they differ in how
//! they exploit the structure:
//!
//! | solver | method | cost per solve |
//! |---|---|---|
//! | [`LinearSolverKind::DenseSchur`] | eliminate `V` block by block, dense reduced system | `O(E d^3 + E k^2 d + n_r^3)` |
//! | [`LinearSolverKind::SparseSchur`] | same, sparse reduced system (faer, symbolic analysis cached) | `O(E d^3 + E k^2 d + fill)` |
//! | [`LinearSolverKind::SparseCholesky`] | sparse Cholesky of the whole system (faer) | `O(fill)` |
//! | [`LinearSolverKind::DenseReference`] | dense Cholesky of the whole system (nalgebra) | `O(n^3)` |
//!
//! (`E` eliminated blocks of dimension `d`, each coupled to `k` reduced parameters, `n_r` reduced
//! parameters, `n` parameters.) A system that is not numerically positive definite is reported as
//! a failed solve, which the Levenberg-Marquardt loop treats as a rejected step.

use crate::kernels::{cholesky_in_place, cholesky_solve};
use crate::normal_equations::NormalEquations;
use crate::problem::Problem;
use crate::schur::{
    assemble_dense_schur, back_substitute_chunk, eliminate_chunk, for_each_chunk, prepare_chunks,
    scatter_eliminated_steps,
};
use crate::sparse::{BlockSparseCholesky, SymbolicFailure};

/// Which linear solver computes the Levenberg-Marquardt step.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LinearSolverKind {
    /// Dense Schur when the reduced system is small (at most 512 parameters), otherwise sparse
    /// Schur if blocks are eliminated, otherwise sparse Cholesky.
    #[default]
    Auto,
    /// Block-by-block elimination, dense reduced system. The calibration path.
    DenseSchur,
    /// Block-by-block elimination, sparse reduced system.
    SparseSchur,
    /// Sparse Cholesky factorization of the full normal equations (elimination marks ignored).
    SparseCholesky,
    /// Dense Cholesky of the full normal equations; a simple reference for tests.
    DenseReference,
}

impl LinearSolverKind {
    /// The concrete solver `Auto` picks for `problem` (other kinds are returned unchanged).
    pub fn resolve(self, problem: &Problem) -> LinearSolverKind {
        match self {
            LinearSolverKind::Auto if problem.reduced_dim <= 512 => LinearSolverKind::DenseSchur,
            LinearSolverKind::Auto if !problem.eliminated.is_empty() => {
                LinearSolverKind::SparseSchur
            }
            LinearSolverKind::Auto => LinearSolverKind::SparseCholesky,
            other => other,
        }
    }
}

/// The linear system could not be solved (not numerically positive definite).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct SolveFailed;

pub(crate) enum LinearSolver {
    DenseSchur {
        s: Vec<f64>,
        rhs: Vec<f64>,
    },
    SparseSchur {
        system: SparseSchurSystem,
        rhs: Vec<f64>,
    },
    SparseCholesky {
        matrix: BlockSparseCholesky,
        rhs: Vec<f64>,
        u_pairs: Vec<usize>,
        /// Per eliminated block: pair of its diagonal block, and (coupled index, pair) for W.
        v_pairs: Vec<usize>,
        w_pairs: Vec<Vec<(usize, usize)>>,
    },
    DenseReference {
        /// Dense index of each parameter block's first component (usize::MAX if constant).
        dense_offsets: Vec<usize>,
        n: usize,
    },
}

impl LinearSolver {
    pub fn new(
        kind: LinearSolverKind,
        problem: &Problem,
        ne: &mut NormalEquations,
    ) -> Result<Self, SymbolicFailure> {
        let n_r = problem.reduced_dim;
        let reduced_dims: Vec<usize> = problem
            .reduced_blocks
            .iter()
            .map(|&b| problem.dims[b])
            .collect();
        Ok(match kind.resolve(problem) {
            LinearSolverKind::Auto | LinearSolverKind::DenseSchur => {
                prepare_chunks(ne, Some(n_r));
                LinearSolver::DenseSchur {
                    s: vec![0.0; n_r * n_r],
                    rhs: vec![0.0; n_r],
                }
            }
            LinearSolverKind::SparseSchur => {
                prepare_chunks(ne, None);
                LinearSolver::SparseSchur {
                    system: SparseSchurSystem::new(problem)?,
                    rhs: vec![0.0; n_r],
                }
            }
            LinearSolverKind::SparseCholesky => {
                let mut dims = reduced_dims.clone();
                dims.extend(problem.eliminated.iter().map(|e| e.dim));
                let r = reduced_dims.len();
                let mut pairs: Vec<(usize, usize)> = problem
                    .u_pattern
                    .pairs
                    .iter()
                    .map(|&(a, b, _)| (a, b))
                    .collect();
                for (e, layout) in problem.eliminated.iter().enumerate() {
                    for &(a, _) in &layout.coupled {
                        pairs.push((a, r + e));
                    }
                }
                let matrix = BlockSparseCholesky::new(&dims, pairs)?;
                let u_pairs = problem
                    .u_pattern
                    .pairs
                    .iter()
                    .map(|&(a, b, _)| matrix.pair(a, b).unwrap_or(0))
                    .collect();
                let v_pairs = (0..problem.eliminated.len())
                    .map(|e| matrix.pair(r + e, r + e).unwrap_or(0))
                    .collect();
                let w_pairs = problem
                    .eliminated
                    .iter()
                    .enumerate()
                    .map(|(e, layout)| {
                        layout
                            .coupled
                            .iter()
                            .enumerate()
                            .map(|(i, &(a, _))| (i, matrix.pair(a, r + e).unwrap_or(0)))
                            .collect()
                    })
                    .collect();
                let n = matrix.dim();
                LinearSolver::SparseCholesky {
                    matrix,
                    rhs: vec![0.0; n],
                    u_pairs,
                    v_pairs,
                    w_pairs,
                }
            }
            LinearSolverKind::DenseReference => {
                let mut dense_offsets = vec![usize::MAX; problem.dims.len()];
                let mut n = 0;
                for &b in &problem.reduced_blocks {
                    dense_offsets[b] = n;
                    n += problem.dims[b];
                }
                for e in &problem.eliminated {
                    dense_offsets[e.block] = n;
                    n += e.dim;
                }
                LinearSolver::DenseReference { dense_offsets, n }
            }
        })
    }

    /// Sizes the per-chunk scratch of another set of normal equations for this solver (the
    /// second buffers of eager linearization).
    pub fn prepare(&self, problem: &Problem, ne: &mut NormalEquations) {
        match self {
            LinearSolver::DenseSchur { .. } => prepare_chunks(ne, Some(problem.reduced_dim)),
            LinearSolver::SparseSchur { .. } => prepare_chunks(ne, None),
            LinearSolver::SparseCholesky { .. } | LinearSolver::DenseReference { .. } => {}
        }
    }

    /// The concrete solver.
    pub fn kind(&self) -> LinearSolverKind {
        match self {
            LinearSolver::DenseSchur { .. } => LinearSolverKind::DenseSchur,
            LinearSolver::SparseSchur { .. } => LinearSolverKind::SparseSchur,
            LinearSolver::SparseCholesky { .. } => LinearSolverKind::SparseCholesky,
            LinearSolver::DenseReference { .. } => LinearSolverKind::DenseReference,
        }
    }

    /// Solves `(H + diag(damping)) step = -g` (flat parameter layout for `damping` and `step`;
    /// entries of constant blocks are ignored and their step is zero).
    pub fn solve(
        &mut self,
        problem: &Problem,
        ne: &mut NormalEquations,
        damping: &[f64],
        step: &mut [f64],
        pool: Option<&rayon::ThreadPool>,
    ) -> Result<(), SolveFailed> {
        step.fill(0.0);
        match self {
            LinearSolver::DenseSchur { s, rhs } => {
                let n = problem.reduced_dim;
                for_each_chunk(&mut ne.chunks, pool, |c| {
                    eliminate_chunk(problem, c, damping, true)
                });
                if ne.chunks.iter().any(|c| c.solve_failed) {
                    return Err(SolveFailed);
                }
                assemble_dense_schur(problem, ne, s);
                for (ra, &block) in problem.reduced_blocks.iter().enumerate() {
                    let g0 = problem.reduced_offsets[ra];
                    let o = problem.offsets[block];
                    for i in 0..problem.dims[block] {
                        s[(g0 + i) * (n + 1)] += damping[o + i];
                        rhs[g0 + i] = -ne.g[o + i];
                    }
                }
                for chunk in &ne.chunks {
                    for (a, b) in rhs.iter_mut().zip(&chunk.rhs_partial) {
                        *a += b;
                    }
                }
                cholesky_in_place(s, n).map_err(|_| SolveFailed)?;
                cholesky_solve(s, n, rhs);
                if !rhs.iter().all(|v| v.is_finite()) {
                    return Err(SolveFailed);
                }
                finish_schur_step(problem, ne, rhs, step, pool);
            }
            LinearSolver::SparseSchur { system, rhs } => {
                for_each_chunk(&mut ne.chunks, pool, |c| {
                    eliminate_chunk(problem, c, damping, false)
                });
                if ne.chunks.iter().any(|c| c.solve_failed) {
                    return Err(SolveFailed);
                }
                system.assemble(problem, ne, damping, Some(rhs));
                system
                    .matrix
                    .factorize_and_solve(rhs)
                    .map_err(|_| SolveFailed)?;
                finish_schur_step(problem, ne, rhs, step, pool);
            }
            LinearSolver::SparseCholesky {
                matrix,
                rhs,
                u_pairs,
                v_pairs,
                w_pairs,
            } => {
                matrix.clear();
                add_u_blocks(problem, ne, matrix, u_pairs);
                let r = problem.reduced_blocks.len();
                for (ra, &block) in problem.reduced_blocks.iter().enumerate() {
                    let o = problem.offsets[block];
                    let d = problem.dims[block];
                    matrix.add_diagonal(ra, &damping[o..o + d]);
                    let g0 = matrix.block_offset(ra);
                    for i in 0..d {
                        rhs[g0 + i] = -ne.g[o + i];
                    }
                }
                for chunk in &ne.chunks {
                    for (local, e) in chunk.elim.clone().enumerate() {
                        let layout = &problem.eliminated[e];
                        let (d, rows) = (layout.dim, layout.w_rows);
                        let (vo, wo) = (chunk.v_off[local], chunk.w_off[local]);
                        matrix.add_block(v_pairs[e], &chunk.v[vo..vo + d * d], d, 1.0);
                        for &(ci, p) in &w_pairs[e] {
                            let off = layout.coupled[ci].1;
                            matrix.add_block(p, &chunk.w[wo + off..wo + rows * d], rows, 1.0);
                        }
                        let o = problem.offsets[layout.block];
                        matrix.add_diagonal(r + e, &damping[o..o + d]);
                        let g0 = matrix.block_offset(r + e);
                        for i in 0..d {
                            rhs[g0 + i] = -ne.g[o + i];
                        }
                    }
                }
                matrix.factorize_and_solve(rhs).map_err(|_| SolveFailed)?;
                for (ra, &block) in problem.reduced_blocks.iter().enumerate() {
                    let g0 = matrix.block_offset(ra);
                    let o = problem.offsets[block];
                    let d = problem.dims[block];
                    step[o..o + d].copy_from_slice(&rhs[g0..g0 + d]);
                }
                for (e, layout) in problem.eliminated.iter().enumerate() {
                    let g0 = matrix.block_offset(r + e);
                    let o = problem.offsets[layout.block];
                    step[o..o + layout.dim].copy_from_slice(&rhs[g0..g0 + layout.dim]);
                }
            }
            LinearSolver::DenseReference { dense_offsets, n } => {
                let n = *n;
                let h = assemble_dense(problem, ne, dense_offsets, n, Some(damping));
                let mut rhs = nalgebra::DVector::zeros(n);
                for (b, &o) in dense_offsets.iter().enumerate() {
                    if o == usize::MAX {
                        continue;
                    }
                    for i in 0..problem.dims[b] {
                        rhs[o + i] = -ne.g[problem.offsets[b] + i];
                    }
                }
                let chol = nalgebra::Cholesky::new(h).ok_or(SolveFailed)?;
                let x = chol.solve(&rhs);
                if !x.iter().all(|v| v.is_finite()) {
                    return Err(SolveFailed);
                }
                for (b, &o) in dense_offsets.iter().enumerate() {
                    if o == usize::MAX {
                        continue;
                    }
                    let base = problem.offsets[b];
                    for i in 0..problem.dims[b] {
                        step[base + i] = x[o + i];
                    }
                }
            }
        }
        Ok(())
    }
}

/// The reduced system `S = U - sum_e Y_e Y_e^T` as a block-sparse matrix (pattern: the `U`
/// pairs and every pair of reduced blocks coupled to a common eliminated block), with its
/// symbolic factorization. Used by the sparse Schur solver and by the covariance of large
/// reduced systems.
pub(crate) struct SparseSchurSystem {
    pub matrix: BlockSparseCholesky,
    /// Pair index for each entry of the U pattern.
    u_pairs: Vec<usize>,
    /// Per eliminated block: (coupled i, coupled j, pair) for coupled pairs with i <= j.
    elim_pairs: Vec<Vec<(usize, usize, usize)>>,
    scratch: Vec<f64>,
}

impl SparseSchurSystem {
    pub fn new(problem: &Problem) -> Result<Self, SymbolicFailure> {
        let reduced_dims: Vec<usize> = problem
            .reduced_blocks
            .iter()
            .map(|&b| problem.dims[b])
            .collect();
        let mut pairs: Vec<(usize, usize)> = problem
            .u_pattern
            .pairs
            .iter()
            .map(|&(a, b, _)| (a, b))
            .collect();
        for e in &problem.eliminated {
            for &(a, _) in &e.coupled {
                for &(b, _) in &e.coupled {
                    if a < b {
                        pairs.push((a, b));
                    }
                }
            }
        }
        let matrix = BlockSparseCholesky::new(&reduced_dims, pairs)?;
        let u_pairs = problem
            .u_pattern
            .pairs
            .iter()
            .map(|&(a, b, _)| matrix.pair(a, b).unwrap_or(0))
            .collect();
        let elim_pairs = problem
            .eliminated
            .iter()
            .map(|e| {
                let mut list = Vec::new();
                for (i, &(a, _)) in e.coupled.iter().enumerate() {
                    for (j, &(b, _)) in e.coupled.iter().enumerate() {
                        if a <= b {
                            list.push((i, j, matrix.pair(a, b).unwrap_or(0)));
                        }
                    }
                }
                list
            })
            .collect();
        let max_dim = reduced_dims.iter().copied().max().unwrap_or(0);
        Ok(Self {
            matrix,
            u_pairs,
            elim_pairs,
            scratch: vec![0.0; max_dim * max_dim],
        })
    }

    /// Fills the matrix with `S + diag(damping)` from `U` and the chunks' `Y_e` (after
    /// [`eliminate_chunk`]), and, if given, `rhs` with `-g_r + sum_e Y_e z_e`.
    pub fn assemble(
        &mut self,
        problem: &Problem,
        ne: &NormalEquations,
        damping: &[f64],
        mut rhs: Option<&mut Vec<f64>>,
    ) {
        let Self {
            matrix,
            u_pairs,
            elim_pairs,
            scratch,
        } = self;
        matrix.clear();
        add_u_blocks(problem, ne, matrix, u_pairs);
        for (ra, &block) in problem.reduced_blocks.iter().enumerate() {
            let o = problem.offsets[block];
            let d = problem.dims[block];
            matrix.add_diagonal(ra, &damping[o..o + d]);
            if let Some(rhs) = rhs.as_deref_mut() {
                let g0 = problem.reduced_offsets[ra];
                for i in 0..d {
                    rhs[g0 + i] = -ne.g[o + i];
                }
            }
        }
        for chunk in &ne.chunks {
            for (local, e) in chunk.elim.clone().enumerate() {
                let layout = &problem.eliminated[e];
                let (d, rows) = (layout.dim, layout.w_rows);
                let wo = chunk.w_off[local];
                let go = chunk.g_off[local];
                let y = &chunk.y[wo..wo + rows * d];
                let z = &chunk.z[go..go + d];
                for &(ci, cj, p) in &elim_pairs[e] {
                    let (ra, oi) = layout.coupled[ci];
                    let (rb, oj) = layout.coupled[cj];
                    let di = problem.dims[problem.reduced_blocks[ra]];
                    let dj = problem.dims[problem.reduced_blocks[rb]];
                    for j in 0..dj {
                        for i in 0..di {
                            let mut acc = 0.0;
                            for k in 0..d {
                                acc += y[oi + i + k * rows] * y[oj + j + k * rows];
                            }
                            scratch[i + j * di] = acc;
                        }
                    }
                    matrix.add_block(p, scratch, di, -1.0);
                }
                if let Some(rhs) = rhs.as_deref_mut() {
                    for &(ra, oi) in &layout.coupled {
                        let di = problem.dims[problem.reduced_blocks[ra]];
                        let g0 = problem.reduced_offsets[ra];
                        for i in 0..di {
                            let mut acc = 0.0;
                            for k in 0..d {
                                acc += y[oi + i + k * rows] * z[k];
                            }
                            rhs[g0 + i] += acc;
                        }
                    }
                }
            }
        }
    }
}

/// Given the reduced step `dr`, recovers the eliminated steps by back substitution and writes
/// both into the flat `step`.
fn finish_schur_step(
    problem: &Problem,
    ne: &mut NormalEquations,
    dr: &[f64],
    step: &mut [f64],
    pool: Option<&rayon::ThreadPool>,
) {
    for_each_chunk(&mut ne.chunks, pool, |c| {
        back_substitute_chunk(problem, c, dr)
    });
    scatter_reduced(problem, dr, step);
    scatter_eliminated_steps(problem, &ne.chunks, step);
}

fn scatter_reduced(problem: &Problem, dr: &[f64], step: &mut [f64]) {
    for (ra, &block) in problem.reduced_blocks.iter().enumerate() {
        let g0 = problem.reduced_offsets[ra];
        let o = problem.offsets[block];
        let d = problem.dims[block];
        step[o..o + d].copy_from_slice(&dr[g0..g0 + d]);
    }
}

fn add_u_blocks(
    problem: &Problem,
    ne: &NormalEquations,
    matrix: &mut BlockSparseCholesky,
    u_pairs: &[usize],
) {
    for (&(ra, _, off), &p) in problem.u_pattern.pairs.iter().zip(u_pairs) {
        let da = problem.dims[problem.reduced_blocks[ra]];
        matrix.add_block(p, &ne.u[off..], da, 1.0);
    }
}

/// The full normal matrix `J^T J` (plus `damping` on the diagonal if given) as a dense matrix,
/// reduced blocks first, then eliminated blocks (`dense_offsets` gives each block's position).
pub(crate) fn assemble_dense(
    problem: &Problem,
    ne: &NormalEquations,
    dense_offsets: &[usize],
    n: usize,
    damping: Option<&[f64]>,
) -> nalgebra::DMatrix<f64> {
    let mut h = nalgebra::DMatrix::<f64>::zeros(n, n);
    for &(ra, rb, off) in &problem.u_pattern.pairs {
        let (ba, bb) = (problem.reduced_blocks[ra], problem.reduced_blocks[rb]);
        let (da, db) = (problem.dims[ba], problem.dims[bb]);
        let (oa, ob) = (dense_offsets[ba], dense_offsets[bb]);
        for j in 0..db {
            for i in 0..da {
                let v = ne.u[off + i + j * da];
                h[(oa + i, ob + j)] = v;
                h[(ob + j, oa + i)] = v;
            }
        }
    }
    for chunk in &ne.chunks {
        for (local, e) in chunk.elim.clone().enumerate() {
            let layout = &problem.eliminated[e];
            let (d, rows) = (layout.dim, layout.w_rows);
            let (vo, wo) = (chunk.v_off[local], chunk.w_off[local]);
            let oe = dense_offsets[layout.block];
            for j in 0..d {
                for i in 0..d {
                    h[(oe + i, oe + j)] = chunk.v[vo + i + j * d];
                }
            }
            for &(ra, row) in &layout.coupled {
                let ba = problem.reduced_blocks[ra];
                let oa = dense_offsets[ba];
                for j in 0..d {
                    for i in 0..problem.dims[ba] {
                        let v = chunk.w[wo + row + i + j * rows];
                        h[(oa + i, oe + j)] = v;
                        h[(oe + j, oa + i)] = v;
                    }
                }
            }
        }
    }
    if let Some(damping) = damping {
        for (b, &o) in dense_offsets.iter().enumerate() {
            if o == usize::MAX {
                continue;
            }
            for i in 0..problem.dims[b] {
                h[(o + i, o + i)] += damping[problem.offsets[b] + i];
            }
        }
    }
    h
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::cost::{CostFunction, EvaluationError, JacobianBlocks};
    use crate::problem::{ParameterBlockId, ProblemBuilder, ResidualBlockId};
    use crate::test_problems::Rng;
    use proptest::prelude::*;

    /// Linear residual blocks `r_b = sum_k A_bk x_k - c_b` with random dense `A`.
    pub(crate) struct RandomLinear {
        /// Per residual block: rows, and per parameter block the column-major A_bk.
        pub blocks: Vec<(usize, Vec<Vec<f64>>, Vec<f64>)>,
    }

    impl CostFunction for RandomLinear {
        fn evaluate(
            &self,
            block: ResidualBlockId,
            params: &[&[f64]],
            residuals: &mut [f64],
            jacobians: Option<&mut JacobianBlocks<'_>>,
        ) -> Result<(), EvaluationError> {
            let (rows, a, c) = &self.blocks[block.0];
            residuals.copy_from_slice(c);
            for (k, p) in params.iter().enumerate() {
                for (j, v) in p.iter().enumerate() {
                    for i in 0..*rows {
                        residuals[i] += a[k][i + j * rows] * v;
                    }
                }
            }
            if let Some(jac) = jacobians {
                for (k, a_k) in a.iter().enumerate() {
                    if let Some(out) = jac.block_mut(k) {
                        out.copy_from_slice(a_k);
                    }
                }
            }
            Ok(())
        }
    }

    /// A random block-sparse problem: reduced and eliminated blocks of random sizes, residual
    /// blocks coupling each eliminated block with random reduced blocks, free residual blocks,
    /// sometimes a constant block and fixed components.
    pub(crate) fn random_problem(seed: u64) -> (Problem, RandomLinear, Vec<f64>) {
        let mut rng = Rng::new(seed);
        let mut pick = |n: usize| (rng.uniform() * n as f64) as usize;
        let mut b = ProblemBuilder::new();
        let n_reduced = 1 + pick(4);
        let n_elim = pick(7);
        let reduced: Vec<ParameterBlockId> = (0..n_reduced)
            .map(|_| b.add_parameter_block(1 + pick(5)))
            .collect();
        let elim: Vec<ParameterBlockId> = (0..n_elim)
            .map(|_| {
                let id = b.add_parameter_block(1 + pick(4));
                b.set_eliminated(id, true);
                id
            })
            .collect();
        if n_reduced > 1 && pick(3) == 0 {
            b.set_constant(reduced[0], true);
        }
        if pick(2) == 0 {
            b.set_fixed_components(reduced[n_reduced - 1], &[0]);
        }
        if n_elim > 0 && pick(2) == 0 {
            b.set_fixed_components(elim[0], &[0]);
        }
        let mut structure: Vec<Vec<ParameterBlockId>> = Vec::new();
        for &e in &elim {
            for _ in 0..1 + pick(3) {
                let mut blocks = vec![e];
                for &r in &reduced {
                    if pick(2) == 0 {
                        blocks.push(r);
                    }
                }
                // Random order within the residual block.
                if blocks.len() > 1 && pick(2) == 0 {
                    blocks.swap(0, 1);
                }
                structure.push(blocks);
            }
        }
        for _ in 0..1 + pick(3) {
            let mut blocks: Vec<ParameterBlockId> =
                reduced.iter().copied().filter(|_| pick(2) == 0).collect();
            if blocks.is_empty() {
                blocks.push(reduced[pick(n_reduced)]);
            }
            structure.push(blocks);
        }
        let mut residuals = Vec::new();
        for blocks in &structure {
            let rows = 1 + pick(4);
            b.add_residual_block(rows, blocks);
            residuals.push((rows, blocks.clone()));
        }
        let problem = b.build().unwrap();
        let mut rng = Rng::new(seed ^ 0xABCD);
        let cost = RandomLinear {
            blocks: residuals
                .iter()
                .map(|(rows, blocks)| {
                    let a = blocks
                        .iter()
                        .map(|&p| (0..rows * problem.dim(p)).map(|_| rng.normal()).collect())
                        .collect();
                    let c = (0..*rows).map(|_| rng.normal()).collect();
                    (*rows, a, c)
                })
                .collect(),
        };
        let x: Vec<f64> = (0..problem.num_parameters())
            .map(|_| rng.normal())
            .collect();
        (problem, cost, x)
    }

    fn step_with(
        kind: LinearSolverKind,
        problem: &Problem,
        cost: &RandomLinear,
        x: &[f64],
        damping: &[f64],
        target_work: usize,
    ) -> Result<Vec<f64>, SolveFailed> {
        let mut ne =
            NormalEquations::new(problem, target_work, kind == LinearSolverKind::DenseSchur);
        ne.evaluate(problem, cost, x, true, None).unwrap();
        let mut solver = LinearSolver::new(kind, problem, &mut ne).unwrap();
        assert_eq!(solver.kind(), kind);
        let mut step = vec![0.0; problem.num_parameters()];
        solver.solve(problem, &mut ne, damping, &mut step, None)?;
        Ok(step)
    }

    proptest! {
        /// All four solvers give the same step (1e-9 relative) on random block-sparse problems,
        /// with one chunk or many.
        #[test]
        fn all_solvers_give_the_same_step(seed in 0u64..u64::MAX, target in prop::sample::select(vec![1usize, 20, 1_000_000])) {
            let (problem, cost, x) = random_problem(seed);
            let mut rng = Rng::new(seed.wrapping_add(1));
            let damping: Vec<f64> = (0..problem.num_parameters())
                .map(|i| if problem.is_fixed(i) { 1.0 } else { rng.range(0.1, 2.0) })
                .collect();
            let reference = step_with(LinearSolverKind::DenseReference, &problem, &cost, &x, &damping, target).unwrap();
            let scale = reference.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-300);
            for kind in [LinearSolverKind::DenseSchur, LinearSolverKind::SparseSchur, LinearSolverKind::SparseCholesky] {
                let step = step_with(kind, &problem, &cost, &x, &damping, target).unwrap();
                let diff = step.iter().zip(&reference).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
                prop_assert!(diff <= 1e-9 * scale, "{kind:?}: |diff| = {diff:e}, |step| = {scale:e}");
                for (i, s) in step.iter().enumerate() {
                    if problem.is_fixed(i) {
                        prop_assert_eq!(*s, 0.0);
                    }
                }
            }
        }
    }

    /// The same linear residuals, with the Gram products supplied through the fused path
    /// (`evaluate_gram`), formed naively from the A matrices.
    struct FusedRandomLinear(RandomLinear);

    impl CostFunction for FusedRandomLinear {
        fn evaluate(
            &self,
            block: ResidualBlockId,
            params: &[&[f64]],
            residuals: &mut [f64],
            jacobians: Option<&mut JacobianBlocks<'_>>,
        ) -> Result<(), EvaluationError> {
            self.0.evaluate(block, params, residuals, jacobians)
        }

        fn evaluate_gram(
            &self,
            block: ResidualBlockId,
            params: &[&[f64]],
            gram: &mut crate::cost::GramBlocks<'_>,
        ) -> Option<Result<f64, EvaluationError>> {
            let (rows, a, _) = &self.0.blocks[block.0];
            let mut r = vec![0.0; *rows];
            self.0.evaluate(block, params, &mut r, None).ok()?;
            // Column c of the block's Jacobian (over non-constant parameter blocks).
            let mut columns: Vec<Vec<f64>> = Vec::new();
            for (k, a_k) in a.iter().enumerate() {
                if gram.block(k).is_some() {
                    for c in 0..params[k].len() {
                        columns.push(a_k[c * rows..(c + 1) * rows].to_vec());
                    }
                }
            }
            let n = gram.cols();
            let (g, grad) = gram.parts_mut();
            for i in 0..n {
                for j in 0..n {
                    g[i + j * n] = columns[i].iter().zip(&columns[j]).map(|(x, y)| x * y).sum();
                }
                grad[i] = columns[i].iter().zip(&r).map(|(x, y)| x * y).sum();
            }
            Some(Ok(r.iter().map(|v| v * v).sum()))
        }
    }

    proptest! {
        /// The fused path gives the same normal equations (hence the same step) as the Jacobian
        /// path, fixed components and constant blocks included; `check_gram` accepts it.
        #[test]
        fn fused_gram_path_matches_the_jacobian_path(seed in 0u64..u64::MAX) {
            let (problem, cost, x) = random_problem(seed);
            let damping: Vec<f64> = (0..problem.num_parameters())
                .map(|i| if problem.is_fixed(i) { 1.0 } else { 0.5 })
                .collect();
            let generic = step_with(LinearSolverKind::DenseSchur, &problem, &cost, &x, &damping, 20).unwrap();
            let fused_cost = FusedRandomLinear(cost);
            let mut ne = NormalEquations::new(&problem, 20, true);
            ne.evaluate(&problem, &fused_cost, &x, true, None).unwrap();
            let mut solver = LinearSolver::new(LinearSolverKind::DenseSchur, &problem, &mut ne).unwrap();
            let mut fused = vec![0.0; problem.num_parameters()];
            solver.solve(&problem, &mut ne, &damping, &mut fused, None).unwrap();
            let scale = generic.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-300);
            let diff = fused.iter().zip(&generic).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
            prop_assert!(diff <= 1e-10 * scale, "{diff:e} vs {scale:e}");
            for r in 0..problem.num_residual_blocks() {
                let id = ResidualBlockId(r);
                let params: Vec<&[f64]> = problem.residual_blocks_of(id).map(|b| problem.block(&x, b)).collect();
                let check = crate::numdiff::check_gram(&fused_cost, id, &params, problem.residual_dim(id), 1e-12);
                prop_assert!(check.is_ok(), "{:?}", check);
            }
        }
    }

    /// A singular system is a failed solve for every solver, never a panic.
    #[test]
    fn singular_systems_fail_cleanly() {
        let mut b = ProblemBuilder::new();
        let a = b.add_parameter_block(2);
        let e = b.add_parameter_block(2);
        b.set_eliminated(e, true);
        b.add_residual_block(1, &[a, e]);
        let problem = b.build().unwrap();
        let cost = RandomLinear {
            blocks: vec![(1, vec![vec![1.0, 2.0], vec![0.5, -1.0]], vec![1.0])],
        };
        let x = vec![0.0; 4];
        let zero = vec![0.0; 4];
        for kind in [
            LinearSolverKind::DenseSchur,
            LinearSolverKind::SparseSchur,
            LinearSolverKind::SparseCholesky,
            LinearSolverKind::DenseReference,
        ] {
            assert_eq!(
                step_with(kind, &problem, &cost, &x, &zero, 1),
                Err(SolveFailed),
                "{kind:?}"
            );
        }
    }
}
