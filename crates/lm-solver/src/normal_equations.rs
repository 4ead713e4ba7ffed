//! Evaluation of the cost and accumulation of the block-structured normal equations.
//!
//! The Jacobian is never stored whole. Each residual block's Jacobian is evaluated into a small
//! scratch buffer, multiplied into its Gram matrix `J_b^T J_b` and gradient `J_b^T r_b`, and
//! scattered into
//!
//! ```text
//!          reduced   eliminated
//!        [   U          W     ]   U: block-sparse (pattern fixed at build time)
//!  H  =  [                    ]   W: one dense column block W_e per eliminated block e
//!        [   W^T        V     ]   V: block diagonal, one dense V_e per eliminated block
//! ```
//!
//! and the gradient `g`. Work is split into chunks of consecutive eliminated blocks (with their
//! residual blocks) followed by the residual blocks that touch no eliminated block. Chunks are
//! fixed when the solver is built, independently of the number of threads, and the partial sums of
//! the shared parts (`U`, the reduced gradient, the cost) are added in chunk order, so the result
//! is bit-for-bit the same with one thread or many.

use crate::cost::{CostFunction, EvaluationError, GramBlocks, JacobianBlocks};
use crate::kernels::gram_and_gradient;
use crate::loss::apply_correction;
use crate::problem::{BlockRole, MAX_BLOCKS_PER_RESIDUAL, Problem, ResidualBlockId};
use rayon::prelude::*;
use std::ops::Range;

/// Why an evaluation failed.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum EvaluationFailure {
    /// The cost function returned an error.
    Error {
        residual: usize,
        error: EvaluationError,
    },
    /// A residual or Jacobian entry was NaN or infinite.
    NonFinite { residual: usize },
}

/// Per-chunk storage: owned eliminated blocks, partial sums, scratch.
#[derive(Debug, Clone)]
pub(crate) struct Chunk {
    /// Eliminated blocks owned by this chunk (indices into `Problem::eliminated`).
    pub elim: Range<usize>,
    /// Range into `Problem::free_residuals`.
    pub free: Range<usize>,
    /// Offsets (per owned eliminated block) into `v`, `w` and `ge`.
    pub v_off: Vec<usize>,
    pub w_off: Vec<usize>,
    pub g_off: Vec<usize>,
    /// `V_e` (column-major `d x d`), `W_e` (column-major `w_rows x d`), `g_e`.
    pub v: Vec<f64>,
    pub w: Vec<f64>,
    pub ge: Vec<f64>,
    /// Partial sums of the `U` values, the reduced gradient and the cost.
    pub u: Vec<f64>,
    pub gr: Vec<f64>,
    pub cost: f64,
    pub status: Result<(), EvaluationFailure>,
    // Evaluation scratch.
    jac: Vec<f64>,
    res: Vec<f64>,
    gram: Vec<f64>,
    jtr: Vec<f64>,
    // Linear-solver scratch (sized by the solver; empty until then).
    /// Cholesky factors of the damped `V_e`, same layout as `v`.
    pub factor: Vec<f64>,
    /// `Y_e = W_e L_e^-T`, same layout as `w`.
    pub y: Vec<f64>,
    /// `z_e = L_e^-1 g_e`, then the eliminated step, same layout as `ge`.
    pub z: Vec<f64>,
    /// Dense partial Schur complement and right-hand side (dense Schur solver only).
    pub s_partial: Vec<f64>,
    pub rhs_partial: Vec<f64>,
    /// Set by the linear solver when a damped `V_e` is not positive definite.
    pub solve_failed: bool,
    /// The eliminated block (index into `Problem::eliminated`) whose damped `V_e` was not
    /// positive definite, when `solve_failed` is set.
    pub failed_eliminated: Option<usize>,
}

/// The linearized problem at one point: cost, gradient and normal-equation blocks.
#[derive(Debug, Clone)]
pub(crate) struct NormalEquations {
    pub chunks: Vec<Chunk>,
    /// `U` values (layout `Problem::u_pattern`).
    pub u: Vec<f64>,
    /// Gradient `J^T r` in the tangent layout (zero for constant and fixed components).
    pub g: Vec<f64>,
    /// `0.5 * sum rho(|r_b|^2)`.
    pub cost: f64,
}

/// Splits the work into chunks of roughly equal size. The split depends only on the problem.
fn plan_chunks(
    problem: &Problem,
    target_work: usize,
    dense_reduced: bool,
) -> Vec<(Range<usize>, Range<usize>)> {
    let work_of = |r: usize| {
        let l = &problem.residuals[r];
        (l.dim * (l.cols + 1)).max(1)
    };
    let elim_work: Vec<usize> = problem
        .eliminated
        .iter()
        .map(|e| e.residuals.iter().map(|&r| work_of(r)).sum::<usize>() + 1)
        .collect();
    let free_work: Vec<usize> = problem.free_residuals.iter().map(|&r| work_of(r)).collect();
    let total: usize = elim_work.iter().sum::<usize>() + free_work.iter().sum::<usize>();
    // Enough chunks to feed a few threads, few enough that the per-chunk copies of the shared
    // partial sums (U, the reduced gradient and, for the dense Schur solver only, a dense
    // partial Schur complement) stay small.
    let dense = if dense_reduced {
        problem.reduced_dim * (problem.reduced_dim + 1)
    } else {
        problem.reduced_dim
    };
    let shared = problem.u_pattern.len + dense;
    let memory_cap = (4_000_000 / shared.max(1)).max(1);
    let count = (total / target_work.max(1)).clamp(1, 128).min(memory_cap);
    let target = total.div_ceil(count).max(1);

    let mut chunks = Vec::new();
    let (mut e0, mut f0, mut acc) = (0, 0, 0);
    let mut e = 0;
    while e < elim_work.len() {
        acc += elim_work[e];
        e += 1;
        if acc >= target {
            chunks.push((e0..e, 0..0));
            e0 = e;
            acc = 0;
        }
    }
    let mut f = 0;
    while f < free_work.len() {
        acc += free_work[f];
        f += 1;
        if acc >= target {
            chunks.push((e0..elim_work.len(), f0..f));
            e0 = elim_work.len();
            f0 = f;
            acc = 0;
        }
    }
    if e0 < elim_work.len() || f0 < free_work.len() || chunks.is_empty() {
        chunks.push((e0..elim_work.len(), f0..free_work.len()));
    }
    chunks
}

impl NormalEquations {
    /// Allocates all storage for `problem`, in chunks of about `target_work` units (residual rows
    /// times Jacobian columns). `dense_reduced` says whether each chunk will hold a dense partial
    /// Schur complement (the dense Schur solver), which bounds how many chunks are worth making.
    pub fn new(problem: &Problem, target_work: usize, dense_reduced: bool) -> Self {
        let chunks = plan_chunks(problem, target_work, dense_reduced)
            .into_iter()
            .map(|(elim, free)| {
                let (mut v_off, mut w_off, mut g_off) = (Vec::new(), Vec::new(), Vec::new());
                let (mut nv, mut nw, mut ng) = (0, 0, 0);
                for e in elim.clone() {
                    let l = &problem.eliminated[e];
                    v_off.push(nv);
                    w_off.push(nw);
                    g_off.push(ng);
                    nv += l.dim * l.dim;
                    nw += l.w_rows * l.dim;
                    ng += l.dim;
                }
                Chunk {
                    elim,
                    free,
                    v_off,
                    w_off,
                    g_off,
                    v: vec![0.0; nv],
                    w: vec![0.0; nw],
                    ge: vec![0.0; ng],
                    u: vec![0.0; problem.u_pattern.len],
                    gr: vec![0.0; problem.reduced_dim],
                    cost: 0.0,
                    status: Ok(()),
                    jac: vec![0.0; problem.max_jacobian_len],
                    res: vec![0.0; problem.max_residual_dim],
                    gram: vec![0.0; problem.max_cols * problem.max_cols],
                    jtr: vec![0.0; problem.max_cols],
                    factor: Vec::new(),
                    y: Vec::new(),
                    z: Vec::new(),
                    s_partial: Vec::new(),
                    rhs_partial: Vec::new(),
                    solve_failed: false,
                    failed_eliminated: None,
                }
            })
            .collect();
        Self {
            chunks,
            u: vec![0.0; problem.u_pattern.len],
            g: vec![0.0; problem.num_tangent],
            cost: 0.0,
        }
    }

    /// Evaluates the cost at `x` and returns it; with `linearize` also forms the normal equations
    /// and stores the cost in `self.cost` (without, the stored linearization is left untouched).
    ///
    /// On failure the first failing residual block (in chunk order) is reported.
    pub fn evaluate<C: CostFunction>(
        &mut self,
        problem: &Problem,
        cost_fn: &C,
        x: &[f64],
        linearize: bool,
        pool: Option<&rayon::ThreadPool>,
    ) -> Result<f64, EvaluationFailure> {
        let work = |chunk: &mut Chunk| {
            chunk.status = evaluate_chunk(problem, cost_fn, x, chunk, linearize);
        };
        match pool {
            Some(pool) => pool.install(|| self.chunks.par_iter_mut().for_each(work)),
            None => self.chunks.iter_mut().for_each(work),
        }
        let mut cost = 0.0;
        for chunk in &self.chunks {
            chunk.status.clone()?;
            cost += chunk.cost;
        }
        if !linearize {
            return Ok(cost);
        }
        self.cost = cost;
        self.u.fill(0.0);
        self.g.fill(0.0);
        for chunk in &self.chunks {
            for (a, b) in self.u.iter_mut().zip(&chunk.u) {
                *a += b;
            }
            for (ra, &block) in problem.reduced_blocks.iter().enumerate() {
                let src = &chunk.gr[problem.reduced_offsets[ra]..][..problem.dims[block]];
                let dst = &mut self.g[problem.offsets[block]..][..problem.dims[block]];
                for (a, b) in dst.iter_mut().zip(src) {
                    *a += b;
                }
            }
            for (local, e) in chunk.elim.clone().enumerate() {
                let l = &problem.eliminated[e];
                let src = &chunk.ge[chunk.g_off[local]..][..l.dim];
                self.g[problem.offsets[l.block]..][..l.dim].copy_from_slice(src);
            }
        }
        Ok(cost)
    }

    /// Maximum absolute gradient entry over the free parameters.
    pub fn gradient_max_norm(&self) -> f64 {
        self.g.iter().fold(0.0f64, |m, v| m.max(v.abs()))
    }

    /// Writes the diagonal of `J^T J` into `out` (flat parameter layout; zero for constant
    /// blocks and fixed components).
    pub fn hessian_diagonal(&self, problem: &Problem, out: &mut [f64]) {
        out.fill(0.0);
        for &(ra, rb, off) in &problem.u_pattern.pairs {
            if ra != rb {
                continue;
            }
            let block = problem.reduced_blocks[ra];
            let d = problem.dims[block];
            for i in 0..d {
                out[problem.offsets[block] + i] = self.u[off + i + i * d];
            }
        }
        for chunk in &self.chunks {
            for (local, e) in chunk.elim.clone().enumerate() {
                let l = &problem.eliminated[e];
                for i in 0..l.dim {
                    out[problem.offsets[l.block] + i] = chunk.v[chunk.v_off[local] + i + i * l.dim];
                }
            }
        }
    }
}

/// `sum_g rho(|r_g|^2)` over the groups of `group` consecutive residuals.
pub(crate) fn grouped_loss(loss: crate::loss::Loss, group: usize, res: &[f64]) -> f64 {
    res.chunks(group)
        .map(|g| loss.evaluate(g.iter().map(|v| v * v).sum())[0])
        .sum()
}

fn evaluate_chunk<C: CostFunction>(
    problem: &Problem,
    cost_fn: &C,
    x: &[f64],
    chunk: &mut Chunk,
    linearize: bool,
) -> Result<(), EvaluationFailure> {
    chunk.cost = 0.0;
    if linearize {
        chunk.v.fill(0.0);
        chunk.w.fill(0.0);
        chunk.ge.fill(0.0);
        chunk.u.fill(0.0);
        chunk.gr.fill(0.0);
    }
    for (local, e) in chunk.elim.clone().enumerate() {
        for &r in &problem.eliminated[e].residuals {
            evaluate_residual(problem, cost_fn, x, chunk, r, Some(local), linearize)?;
        }
    }
    for i in chunk.free.clone() {
        let r = problem.free_residuals[i];
        evaluate_residual(problem, cost_fn, x, chunk, r, None, linearize)?;
    }
    Ok(())
}

#[inline]
fn evaluate_residual<C: CostFunction>(
    problem: &Problem,
    cost_fn: &C,
    x: &[f64],
    chunk: &mut Chunk,
    r: usize,
    local_elim: Option<usize>,
    linearize: bool,
) -> Result<(), EvaluationFailure> {
    let layout = &problem.residuals[r];
    let (rows, cols) = (layout.dim, layout.cols);
    let mut refs: [&[f64]; MAX_BLOCKS_PER_RESIDUAL] = [&[]; MAX_BLOCKS_PER_RESIDUAL];
    for (k, p) in layout.params.iter().enumerate() {
        refs[k] = &x[problem.ambient_offsets[p.block]..][..problem.ambient_dims[p.block]];
    }
    let params = &refs[..layout.params.len()];
    let id = ResidualBlockId(r);
    let gram = &mut chunk.gram[..cols * cols];
    let jtr = &mut chunk.jtr[..cols];
    let fused = if linearize {
        let mut blocks = GramBlocks {
            gram: &mut *gram,
            gradient: &mut *jtr,
            cols,
            layout: &layout.jac_layout,
            loss: layout.loss,
            group: layout.group,
        };
        cost_fn.evaluate_gram(id, params, &mut blocks)
    } else {
        None
    };
    if let Some(outcome) = fused {
        let s = outcome.map_err(|error| EvaluationFailure::Error { residual: r, error })?;
        if !s.is_finite() {
            return Err(EvaluationFailure::NonFinite { residual: r });
        }
        chunk.cost += 0.5 * s;
        // Fixed components: zero rows and columns, as zero Jacobian columns would give.
        for p in &layout.params {
            if p.role == BlockRole::Constant {
                continue;
            }
            let base = problem.offsets[p.block];
            for c in 0..problem.dims[p.block] {
                if problem.fixed_mask[base + c] {
                    let col = p.col + c;
                    gram[col * cols..(col + 1) * cols].fill(0.0);
                    for k in 0..cols {
                        gram[col + k * cols] = 0.0;
                    }
                    jtr[col] = 0.0;
                }
            }
        }
    } else {
        let res = &mut chunk.res[..rows];
        let outcome = if linearize {
            let mut jacobians = JacobianBlocks {
                buffer: &mut chunk.jac[..rows * cols],
                rows,
                layout: &layout.jac_layout,
            };
            cost_fn.evaluate(id, params, res, Some(&mut jacobians))
        } else {
            cost_fn.evaluate(id, params, res, None)
        };
        outcome.map_err(|error| EvaluationFailure::Error { residual: r, error })?;
        // Summed group by group, as a fused path sums its points: the same cost to the bit
        // whichever path evaluates a point (lazy and eager solves take the same steps).
        let s: f64 = res
            .chunks(layout.group)
            .map(|g| g.iter().map(|v| v * v).sum::<f64>())
            .sum();
        if !s.is_finite() {
            return Err(EvaluationFailure::NonFinite { residual: r });
        }
        if layout.loss.is_trivial() {
            chunk.cost += 0.5 * s;
        } else {
            chunk.cost += 0.5 * grouped_loss(layout.loss, layout.group, res);
        }
        if !linearize {
            return Ok(());
        }
        let jac = &mut chunk.jac[..rows * cols];
        if !layout.loss.is_trivial() {
            for start in (0..rows).step_by(layout.group) {
                let group = start..start + layout.group;
                let s: f64 = res[group.clone()].iter().map(|v| v * v).sum();
                apply_correction(
                    layout.loss.evaluate(s),
                    &mut res[group],
                    Some((&mut *jac, rows, start, cols)),
                );
            }
        }
        // Fixed components: their columns do not take part.
        for p in &layout.params {
            if p.role == BlockRole::Constant {
                continue;
            }
            let base = problem.offsets[p.block];
            for c in 0..problem.dims[p.block] {
                if problem.fixed_mask[base + c] {
                    jac[(p.col + c) * rows..(p.col + c + 1) * rows].fill(0.0);
                }
            }
        }
        gram_and_gradient(jac, rows, cols, res, gram, jtr);
    }
    // A NaN anywhere in J or r shows up in the Gram matrix or the gradient.
    if !gram.iter().chain(jtr.iter()).all(|v| v.is_finite()) {
        return Err(EvaluationFailure::NonFinite { residual: r });
    }

    // Gradient.
    for p in &layout.params {
        let d = problem.dims[p.block];
        match p.role {
            BlockRole::Constant => {}
            BlockRole::Reduced(ra) => {
                let dst = &mut chunk.gr[problem.reduced_offsets[ra]..][..d];
                for (a, b) in dst.iter_mut().zip(&jtr[p.col..p.col + d]) {
                    *a += b;
                }
            }
            BlockRole::Eliminated(_) => {
                let local = local_elim.unwrap_or(0);
                let dst = &mut chunk.ge[chunk.g_off[local]..][..d];
                for (a, b) in dst.iter_mut().zip(&jtr[p.col..p.col + d]) {
                    *a += b;
                }
            }
        }
    }
    // U blocks.
    for &(ka, kb, off) in &layout.u_targets {
        let (pa, pb) = (&layout.params[ka], &layout.params[kb]);
        let (da, db) = (problem.dims[pa.block], problem.dims[pb.block]);
        for j in 0..db {
            let src = &gram[pa.col + (pb.col + j) * cols..][..da];
            let dst = &mut chunk.u[off + j * da..][..da];
            for (a, b) in dst.iter_mut().zip(src) {
                *a += b;
            }
        }
    }
    // V and W blocks.
    if let (Some((e, ke)), Some(local)) = (layout.eliminated, local_elim) {
        let pe = &layout.params[ke];
        let le = &problem.eliminated[e];
        let de = le.dim;
        let v = &mut chunk.v[chunk.v_off[local]..][..de * de];
        for j in 0..de {
            let src = &gram[pe.col + (pe.col + j) * cols..][..de];
            for (a, b) in v[j * de..][..de].iter_mut().zip(src) {
                *a += b;
            }
        }
        let w = &mut chunk.w[chunk.w_off[local]..][..le.w_rows * de];
        for &(ka, row) in &layout.w_targets {
            let pa = &layout.params[ka];
            let da = problem.dims[pa.block];
            for j in 0..de {
                let src = &gram[pa.col + (pe.col + j) * cols..][..da];
                for (a, b) in w[row + j * le.w_rows..][..da].iter_mut().zip(src) {
                    *a += b;
                }
            }
        }
    }
    Ok(())
}
