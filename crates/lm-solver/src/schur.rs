//! Schur complement elimination of the block-diagonal part `V` of the normal equations.
//!
//! With the damped system written as
//!
//! ```text
//! [ U   W ] [dr]   [-g_r]
//! [ W^T V ] [de] = [-g_e]
//! ```
//!
//! and `V = diag(V_e)`, each `V_e = L_e L_e^T` is factorized on its own (a small dense Cholesky),
//! `Y_e = W_e L_e^-T` and `z_e = L_e^-1 g_e` are formed, and the reduced system is
//!
//! ```text
//! S dr = rhs,   S = U - sum_e Y_e Y_e^T,   rhs = -g_r + sum_e Y_e z_e,
//! ```
//!
//! after which each eliminated step follows from `de = -L_e^-T (z_e + Y_e^T dr)`. All per-block
//! work is independent and runs in parallel over the evaluation chunks.
//!
//! Cost per eliminated block of dimension `d` coupled to `k` reduced parameters: `d^3/6` for the
//! factorization, `k d^2 / 2` for `Y_e`, `k^2 d / 2` for the Schur update.

use crate::kernels::{backward_substitute_transpose, cholesky_in_place, forward_substitute};
use crate::normal_equations::{Chunk, NormalEquations};
use crate::problem::Problem;
use rayon::prelude::*;

/// Sizes the per-chunk scratch the elimination needs (done once).
pub(crate) fn prepare_chunks(ne: &mut NormalEquations, dense_reduced_dim: Option<usize>) {
    for chunk in &mut ne.chunks {
        chunk.factor = vec![0.0; chunk.v.len()];
        chunk.y = vec![0.0; chunk.w.len()];
        chunk.z = vec![0.0; chunk.ge.len()];
        if let Some(n) = dense_reduced_dim {
            chunk.s_partial = vec![0.0; n * n];
            chunk.rhs_partial = vec![0.0; n];
        }
    }
}

/// Factorizes the damped `V_e` of every eliminated block of a chunk and forms `Y_e`, `z_e`.
/// With `dense_partial`, also accumulates `-Y_e Y_e^T` (upper triangle) and `Y_e z_e` into the
/// chunk's dense partial Schur complement and right-hand side (reduced layout, `n x n`).
///
/// Sets `chunk.solve_failed` (and `chunk.failed_eliminated` to the first such block) if some
/// damped `V_e` is not positive definite.
pub(crate) fn eliminate_chunk(
    problem: &Problem,
    chunk: &mut Chunk,
    damping: &[f64],
    dense_partial: bool,
) {
    chunk.solve_failed = false;
    chunk.failed_eliminated = None;
    if dense_partial {
        chunk.s_partial.fill(0.0);
        chunk.rhs_partial.fill(0.0);
    }
    for (local, e) in chunk.elim.clone().enumerate() {
        let d = problem.eliminated[e].dim;
        // A constant `d` lets the compiler unroll the small loops (the same operations in the
        // same order): calibration's board poses are 6-dimensional.
        let factorized = match d {
            6 => eliminate_block(problem, chunk, damping, dense_partial, local, e, 6),
            3 => eliminate_block(problem, chunk, damping, dense_partial, local, e, 3),
            _ => eliminate_block(problem, chunk, damping, dense_partial, local, e, d),
        };
        if !factorized {
            chunk.solve_failed = true;
            chunk.failed_eliminated = Some(e);
            return;
        }
    }
}

/// One eliminated block of [`eliminate_chunk`]: `false` if its damped `V_e` is not positive
/// definite.
#[inline(always)]
fn eliminate_block(
    problem: &Problem,
    chunk: &mut Chunk,
    damping: &[f64],
    dense_partial: bool,
    local: usize,
    e: usize,
    d: usize,
) -> bool {
    let n = problem.reduced_dim;
    let layout = &problem.eliminated[e];
    let rows = layout.w_rows;
    let base = problem.offsets[layout.block];
    let (vo, wo, go) = (chunk.v_off[local], chunk.w_off[local], chunk.g_off[local]);

    let factor = &mut chunk.factor[vo..vo + d * d];
    factor.copy_from_slice(&chunk.v[vo..vo + d * d]);
    for i in 0..d {
        factor[i + i * d] += damping[base + i];
    }
    if cholesky_in_place(factor, d).is_err() {
        return false;
    }
    // Y^T = L^-1 W^T: every row of W through the forward substitution at once, column by
    // column of Y (stored like W: rows x d, column-major), so that the inner loops run over
    // contiguous rows; each entry sees the operations of `forward_substitute` in its order.
    let w = &chunk.w[wo..wo + rows * d];
    let y = &mut chunk.y[wo..wo + rows * d];
    for i in 0..d {
        let (done, rest) = y.split_at_mut(i * rows);
        let yi = &mut rest[..rows];
        yi.copy_from_slice(&w[i * rows..(i + 1) * rows]);
        for k in 0..i {
            let l = factor[i + k * d];
            for (a, b) in yi.iter_mut().zip(&done[k * rows..(k + 1) * rows]) {
                *a -= l * b;
            }
        }
        let diagonal = factor[i + i * d];
        for a in yi.iter_mut() {
            *a /= diagonal;
        }
    }
    let y = &*y;
    let z = &mut chunk.z[go..go + d];
    z.copy_from_slice(&chunk.ge[go..go + d]);
    forward_substitute(factor, d, z);

    if dense_partial {
        // Global reduced row of each local row of W_e.
        for &(ra_j, off_j) in &layout.coupled {
            let dj = problem.dims[problem.reduced_blocks[ra_j]];
            let gj = problem.reduced_offsets[ra_j];
            for cj in 0..dj {
                let col = gj + cj;
                let lj = off_j + cj;
                // rhs += Y z
                let mut acc = 0.0;
                for k in 0..d {
                    acc += y[lj + k * rows] * z[k];
                }
                chunk.rhs_partial[col] += acc;
                // S -= Y Y^T, upper triangle only (`assemble_dense_schur` mirrors it); the
                // sums over k run for a column of S at once, each in the order k = 0..d.
                for &(ra_i, off_i) in &layout.coupled {
                    let di = problem.dims[problem.reduced_blocks[ra_i]];
                    let gi = problem.reduced_offsets[ra_i];
                    let count = di.min((col + 1).saturating_sub(gi));
                    if count == 0 {
                        continue;
                    }
                    let column = &mut chunk.s_partial[gi + col * n..][..count];
                    subtract_products(y, rows, d, off_i, lj, column);
                }
            }
        }
    }
    true
}

/// `out[r] -= sum_k y[off + r + k rows] y[lj + k rows]` for `r < out.len()`, each sum formed
/// from zero in the order `k = 0..d` (the same bits on every path): one column of the update
/// `S -= Y Y^T`. `y` holds `d` columns of `rows` values.
#[inline]
fn subtract_products(y: &[f64], rows: usize, d: usize, off: usize, lj: usize, out: &mut [f64]) {
    assert!(
        off + out.len() + (d.max(1) - 1) * rows <= y.len() && lj + (d.max(1) - 1) * rows < y.len()
    );
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above; the bounds were asserted.
            unsafe { subtract_products_avx2(y, rows, d, off, lj, out) };
            return;
        }
    }
    for (r, o) in out.iter_mut().enumerate() {
        let mut acc = 0.0;
        for k in 0..d {
            acc += y[off + r + k * rows] * y[lj + k * rows];
        }
        *o -= acc;
    }
}

/// [`subtract_products`] four rows per AVX2 register: the same multiplications and additions
/// in the same order (no fused multiply-add), with the sums in registers. The scalar loops it
/// replaces kept them in a stack buffer and were 12% of a thin-prism12 calibration in `perf`.
///
/// # Safety
/// The CPU must support AVX2, and `off + out.len() + (d - 1) rows <= y.len()`,
/// `lj + (d - 1) rows < y.len()` (for `d >= 1`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn subtract_products_avx2(
    y: &[f64],
    rows: usize,
    d: usize,
    off: usize,
    lj: usize,
    out: &mut [f64],
) {
    use std::arch::x86_64::{
        _mm256_add_pd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_setzero_pd,
        _mm256_storeu_pd, _mm256_sub_pd,
    };
    let count = out.len();
    let mut r = 0;
    // SAFETY (every load and store below): r + 4 <= count and the caller's bounds.
    unsafe {
        while r + 4 <= count {
            let mut sum = _mm256_setzero_pd();
            for k in 0..d {
                let b = _mm256_loadu_pd(y.as_ptr().add(off + r + k * rows));
                let yj = _mm256_set1_pd(*y.get_unchecked(lj + k * rows));
                sum = _mm256_add_pd(sum, _mm256_mul_pd(b, yj));
            }
            let s = _mm256_loadu_pd(out.as_ptr().add(r));
            _mm256_storeu_pd(out.as_mut_ptr().add(r), _mm256_sub_pd(s, sum));
            r += 4;
        }
    }
    for (i, o) in out.iter_mut().enumerate().skip(r) {
        let mut acc = 0.0;
        for k in 0..d {
            acc += y[off + i + k * rows] * y[lj + k * rows];
        }
        *o -= acc;
    }
}

/// Back-substitution for a chunk: `de = -L^-T (z + Y^T dr)` for every eliminated block, written
/// into `chunk.z`. `dr` is the reduced step (reduced layout).
pub(crate) fn back_substitute_chunk(problem: &Problem, chunk: &mut Chunk, dr: &[f64]) {
    for (local, e) in chunk.elim.clone().enumerate() {
        let layout = &problem.eliminated[e];
        let d = layout.dim;
        let rows = layout.w_rows;
        let (vo, wo, go) = (chunk.v_off[local], chunk.w_off[local], chunk.g_off[local]);
        let y = &chunk.y[wo..wo + rows * d];
        let z = &mut chunk.z[go..go + d];
        for (k, zk) in z.iter_mut().enumerate() {
            let mut acc = *zk;
            for &(ra, off) in &layout.coupled {
                let da = problem.dims[problem.reduced_blocks[ra]];
                let g = problem.reduced_offsets[ra];
                for i in 0..da {
                    acc += y[off + i + k * rows] * dr[g + i];
                }
            }
            *zk = -acc;
        }
        backward_substitute_transpose(&chunk.factor[vo..vo + d * d], d, z);
    }
}

/// Runs `f` on every chunk, in parallel when a pool is given.
pub(crate) fn for_each_chunk<F>(chunks: &mut [Chunk], pool: Option<&rayon::ThreadPool>, f: F)
where
    F: Fn(&mut Chunk) + Sync + Send,
{
    match pool {
        Some(pool) => pool.install(|| chunks.par_iter_mut().for_each(f)),
        None => chunks.iter_mut().for_each(f),
    }
}

/// Copies the eliminated steps (in `chunk.z` after [`back_substitute_chunk`]) into the flat step.
pub(crate) fn scatter_eliminated_steps(problem: &Problem, chunks: &[Chunk], step: &mut [f64]) {
    for chunk in chunks {
        for (local, e) in chunk.elim.clone().enumerate() {
            let layout = &problem.eliminated[e];
            let go = chunk.g_off[local];
            let base = problem.offsets[layout.block];
            step[base..base + layout.dim].copy_from_slice(&chunk.z[go..go + layout.dim]);
        }
    }
}

/// Writes the dense reduced matrix `S = U - sum_e Y_e Y_e^T` (both triangles, column-major,
/// `n x n` with `n = problem.reduced_dim`) into `s`, from `U` and the chunks' partial Schur
/// complements (filled by [`eliminate_chunk`] with a dense reduced block). Any damping of the
/// reduced parameters is the caller's to add. Cost `O(n^2)` per chunk.
pub(crate) fn assemble_dense_schur(problem: &Problem, ne: &NormalEquations, s: &mut [f64]) {
    let n = problem.reduced_dim;
    debug_assert_eq!(s.len(), n * n);
    s.fill(0.0);
    for &(ra, rb, off) in &problem.u_pattern.pairs {
        let (da, db) = (
            problem.dims[problem.reduced_blocks[ra]],
            problem.dims[problem.reduced_blocks[rb]],
        );
        let (ga, gb) = (problem.reduced_offsets[ra], problem.reduced_offsets[rb]);
        for j in 0..db {
            for i in 0..da {
                let v = ne.u[off + i + j * da];
                s[(ga + i) + (gb + j) * n] = v;
                s[(gb + j) + (ga + i) * n] = v;
            }
        }
    }
    for chunk in &ne.chunks {
        for (a, b) in s.iter_mut().zip(&chunk.s_partial) {
            *a += b;
        }
    }
    // The partial complements hold the upper triangle: mirror it (the same sums either way).
    for j in 0..n {
        for i in j + 1..n {
            s[i + j * n] = s[j + i * n];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dispatched kernel (AVX2 where the CPU has it) against the documented order, bit for
    /// bit, for every remainder of four rows, offsets into the middle of `Y` and several `d`.
    #[test]
    fn subtract_products_follows_the_documented_order() {
        let mut state = 7u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for d in [1, 3, 6, 7] {
            let rows = 23;
            let y: Vec<f64> = (0..rows * d).map(|_| next() * 1e3).collect();
            for off in [0, 2, 5] {
                for count in 0..=rows - off {
                    for lj in [0, 4, rows - 1] {
                        let start: Vec<f64> = (0..count).map(|_| next()).collect();
                        let mut out = start.clone();
                        subtract_products(&y, rows, d, off, lj, &mut out);
                        for (r, (o, s)) in out.iter().zip(&start).enumerate() {
                            let mut acc = 0.0;
                            for k in 0..d {
                                acc += y[off + r + k * rows] * y[lj + k * rows];
                            }
                            assert_eq!(
                                o.to_bits(),
                                (s - acc).to_bits(),
                                "d {d} row {r} of {count}"
                            );
                        }
                    }
                }
            }
        }
    }
}
