//! Block-sparse symmetric matrices with a cached sparse Cholesky factorization (faer).
//!
//! The sparsity pattern is a set of upper-triangular block pairs `(a, b)`, `a <= b`. It is turned
//! once into a scalar compressed-sparse-column structure (upper triangle, sorted rows), analysed
//! once (fill-reducing ordering and symbolic factorization), and from then on every solve only
//! refills the values, factorizes numerically and solves, in preallocated memory.

use dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side, Spec};
use std::collections::HashMap;

/// A symmetric matrix made of dense blocks, stored as its upper triangle in CSC form.
pub(crate) struct BlockSparseCholesky {
    n: usize,
    block_offsets: Vec<usize>,
    block_dims: Vec<usize>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    /// For pair `p` and local column `j` of block `b`: position in `values` of the entry in the
    /// first row of block `a`. The rows of block `a` follow contiguously.
    pair_positions: Vec<usize>,
    pair_starts: Vec<usize>,
    pairs: Vec<(usize, usize)>,
    lookup: HashMap<(usize, usize), usize>,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    memory: MemBuffer,
}

impl std::fmt::Debug for BlockSparseCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BlockSparseCholesky")
            .field("n", &self.n)
            .field("blocks", &self.block_dims.len())
            .field("nnz", &self.values.len())
            .field("factor_nnz", &self.l_values.len())
            .finish()
    }
}

/// The symbolic analysis failed (faer's message).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct SymbolicFailure(pub String);

/// The matrix is not numerically positive definite.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct NotPositiveDefinite;

impl BlockSparseCholesky {
    /// Builds the structure for blocks of the given dimensions and the given block pairs
    /// (`a <= b`; duplicates are ignored; every diagonal block is always present).
    ///
    /// Cost: the symbolic analysis (AMD ordering and elimination tree), done once.
    /// Errors only if faer cannot represent the structure (index overflow or out of memory).
    pub fn new(
        block_dims: &[usize],
        pairs: impl IntoIterator<Item = (usize, usize)>,
    ) -> Result<Self, SymbolicFailure> {
        let nb = block_dims.len();
        let mut block_offsets = Vec::with_capacity(nb);
        let mut n = 0;
        for &d in block_dims {
            block_offsets.push(n);
            n += d;
        }
        // Pairs per column block, sorted by row block.
        let mut by_col: Vec<Vec<usize>> = vec![Vec::new(); nb];
        for (b, rows) in by_col.iter_mut().enumerate() {
            rows.push(b);
        }
        for (a, b) in pairs {
            let (a, b) = if a <= b { (a, b) } else { (b, a) };
            by_col[b].push(a);
        }
        for rows in &mut by_col {
            rows.sort_unstable();
            rows.dedup();
        }
        let mut sorted_pairs = Vec::new();
        for (b, rows) in by_col.iter().enumerate() {
            for &a in rows {
                sorted_pairs.push((a, b));
            }
        }
        let lookup: HashMap<(usize, usize), usize> = sorted_pairs
            .iter()
            .enumerate()
            .map(|(p, &ab)| (ab, p))
            .collect();

        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        let mut pair_positions = Vec::new();
        let mut pair_starts = vec![0; sorted_pairs.len()];
        col_ptr.push(0);
        // First, the start of each pair's column table.
        let mut next = 0;
        for (p, &(_, b)) in sorted_pairs.iter().enumerate() {
            pair_starts[p] = next;
            next += block_dims[b];
        }
        pair_positions.resize(next, 0);
        for (b, rows) in by_col.iter().enumerate() {
            for j in 0..block_dims[b] {
                for &a in rows {
                    let p = lookup[&(a, b)];
                    pair_positions[pair_starts[p] + j] = row_idx.len();
                    let count = if a == b { j + 1 } else { block_dims[a] };
                    for i in 0..count {
                        row_idx.push(block_offsets[a] + i);
                    }
                }
                col_ptr.push(row_idx.len());
            }
        }
        let values = vec![0.0; row_idx.len()];
        let structure = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_cholesky(
            structure,
            Side::Upper,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| SymbolicFailure(format!("{e:?}")))?;
        let l_values = vec![0.0; symbolic.len_val()];
        let req = StackReq::or(
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Spec::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        );
        let memory =
            MemBuffer::try_new(req).map_err(|_| SymbolicFailure("out of memory".into()))?;
        Ok(Self {
            n,
            block_offsets,
            block_dims: block_dims.to_vec(),
            col_ptr,
            row_idx,
            values,
            pair_positions,
            pair_starts,
            pairs: sorted_pairs,
            lookup,
            symbolic,
            l_values,
            memory,
        })
    }

    /// Scalar dimension.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Scalar offset of a block.
    pub fn block_offset(&self, block: usize) -> usize {
        self.block_offsets[block]
    }

    /// Index of the pair `(a, b)` (`a <= b`), if it is in the pattern.
    pub fn pair(&self, a: usize, b: usize) -> Option<usize> {
        self.lookup.get(&(a, b)).copied()
    }

    /// Sets all values to zero.
    pub fn clear(&mut self) {
        self.values.fill(0.0);
    }

    /// Adds `alpha * block` to pair `p`; `block` is column-major `d_a x d_b` with leading
    /// dimension `ld` (rows of the enclosing storage). For a diagonal pair only the upper triangle
    /// is read.
    #[inline]
    pub fn add_block(&mut self, p: usize, block: &[f64], ld: usize, alpha: f64) {
        let (a, b) = self.pairs[p];
        let da = self.block_dims[a];
        for j in 0..self.block_dims[b] {
            let pos = self.pair_positions[self.pair_starts[p] + j];
            let count = if a == b { j + 1 } else { da };
            let src = &block[j * ld..][..count];
            for (v, s) in self.values[pos..pos + count].iter_mut().zip(src) {
                *v += alpha * s;
            }
        }
    }

    /// Adds `diag` to the diagonal of block `a`.
    pub fn add_diagonal(&mut self, a: usize, diag: &[f64]) {
        let p = self.lookup[&(a, a)];
        for (j, d) in diag.iter().enumerate() {
            let pos = self.pair_positions[self.pair_starts[p] + j] + j;
            self.values[pos] += d;
        }
    }

    /// Factorizes the current values and solves `A x = rhs` in place.
    pub fn factorize_and_solve(&mut self, rhs: &mut [f64]) -> Result<(), NotPositiveDefinite> {
        if !self.values.iter().all(|v| v.is_finite()) {
            return Err(NotPositiveDefinite);
        }
        let structure = SymbolicSparseColMatRef::new_checked(
            self.n,
            self.n,
            &self.col_ptr,
            None,
            &self.row_idx,
        );
        let matrix = SparseColMatRef::new(structure, &self.values);
        let stack = MemStack::new(&mut self.memory);
        let llt = self
            .symbolic
            .factorize_numeric_llt(
                &mut self.l_values,
                matrix,
                Side::Upper,
                LltRegularization::default(),
                Par::Seq,
                stack,
                Spec::default(),
            )
            .map_err(|_| NotPositiveDefinite)?;
        let stack = MemStack::new(&mut self.memory);
        let rhs_mat = MatMut::from_column_major_slice_mut(rhs, self.n, 1);
        llt.solve_in_place_with_conj(Conj::No, rhs_mat, Par::Seq, stack);
        if rhs.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(NotPositiveDefinite)
        }
    }

    /// The scalar diagonal of the current values.
    pub fn diagonal(&self) -> Vec<f64> {
        (0..self.n)
            .map(|c| {
                // Rows are sorted within each column, so the diagonal entry is the last one.
                let end = self.col_ptr[c + 1];
                if end > self.col_ptr[c] && self.row_idx[end - 1] == c {
                    self.values[end - 1]
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// Factorizes the current values and solves `A X = B` in place for the `cols` columns of
    /// `rhs` (column-major `n x cols`). Allocates the scratch of a multi-column solve: meant for
    /// one-off uses such as selected columns of an inverse, not for iterations.
    pub fn factorize_and_solve_columns(
        &mut self,
        rhs: &mut [f64],
        cols: usize,
    ) -> Result<(), NotPositiveDefinite> {
        if cols == 0 {
            return Ok(());
        }
        // The first column through the preallocated path factorizes.
        let (first, rest) = rhs.split_at_mut(self.n);
        self.factorize_and_solve(first)?;
        if cols == 1 {
            return Ok(());
        }
        let llt = faer::sparse::linalg::cholesky::LltRef::new(&self.symbolic, &self.l_values);
        let scratch = self
            .symbolic
            .solve_in_place_scratch::<f64>(cols - 1, Par::Seq);
        let mut memory = MemBuffer::try_new(scratch).map_err(|_| NotPositiveDefinite)?;
        let stack = MemStack::new(&mut memory);
        let rhs_mat = MatMut::from_column_major_slice_mut(rest, self.n, cols - 1);
        llt.solve_in_place_with_conj(Conj::No, rhs_mat, Par::Seq, stack);
        if rest.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(NotPositiveDefinite)
        }
    }

    /// The dense symmetric matrix (for tests): `n x n`, column-major.
    #[cfg(test)]
    pub fn to_dense(&self) -> Vec<f64> {
        let mut dense = vec![0.0; self.n * self.n];
        for c in 0..self.n {
            for k in self.col_ptr[c]..self.col_ptr[c + 1] {
                let r = self.row_idx[k];
                dense[r + c * self.n] = self.values[k];
                dense[c + r * self.n] = self.values[k];
            }
        }
        dense
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    #[test]
    fn solves_a_block_tridiagonal_system() {
        let dims = [2, 3, 1, 2];
        let mut m = BlockSparseCholesky::new(&dims, [(0, 1), (1, 2), (2, 3)]).unwrap();
        let n = m.dim();
        // Build a random SPD matrix with this pattern: A = B + n I with B's blocks random.
        let mut dense = DMatrix::<f64>::zeros(n, n);
        let mut seed = 1u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 33) as f64 / (1u64 << 31) as f64) - 0.5
        };
        for &(a, b) in &[(0, 0), (0, 1), (1, 1), (1, 2), (2, 2), (2, 3), (3, 3)] {
            let (da, db) = (dims[a], dims[b]);
            let block: Vec<f64> = (0..da * db).map(|_| next()).collect();
            let p = m.pair(a, b).unwrap();
            m.add_block(p, &block, da, 1.0);
            for j in 0..db {
                for i in 0..da {
                    let (r, c) = (m.block_offset(a) + i, m.block_offset(b) + j);
                    if a == b && i > j {
                        continue;
                    }
                    dense[(r, c)] = block[i + j * da];
                    dense[(c, r)] = block[i + j * da];
                }
            }
        }
        for (a, &d) in dims.iter().enumerate() {
            m.add_diagonal(a, &vec![n as f64; d]);
        }
        dense += DMatrix::identity(n, n) * n as f64;
        assert_eq!(DMatrix::from_column_slice(n, n, &m.to_dense()), dense);
        let b: Vec<f64> = (0..n).map(|i| i as f64 - 3.0).collect();
        let mut x = b.clone();
        m.factorize_and_solve(&mut x).unwrap();
        let residual = &dense * DVector::from_vec(x) - DVector::from_vec(b);
        assert!(residual.norm() < 1e-12);
    }

    #[test]
    fn indefinite_matrix_is_reported() {
        let mut m = BlockSparseCholesky::new(&[2], []).unwrap();
        m.add_block(0, &[1.0, 0.0, 0.0, -1.0], 2, 1.0);
        let mut x = vec![1.0, 1.0];
        assert_eq!(m.factorize_and_solve(&mut x), Err(NotPositiveDefinite));
    }
}
