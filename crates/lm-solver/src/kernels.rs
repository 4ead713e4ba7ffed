//! Small dense kernels on column-major slices: Gram products, Cholesky factorization and
//! triangular solves.
//!
//! All loops have a fixed operation order, so results are bit-for-bit reproducible whatever thread
//! runs them. Matrices are column-major: entry `(i, j)` of an `n`-row matrix is at `i + j * n`.

/// Dot product with sixteen independent accumulators: enough to keep the additions pipelined
/// (eight SSE2 registers), few enough not to spill. The summation order is fixed, so results are
/// reproducible whatever thread runs them.
#[inline]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 16];
    let mut ca = a.chunks_exact(16);
    let mut cb = b.chunks_exact(16);
    for (x, y) in (&mut ca).zip(&mut cb) {
        for lane in 0..16 {
            acc[lane] += x[lane] * y[lane];
        }
    }
    let mut tail = 0.0;
    for (x, y) in ca.remainder().iter().zip(cb.remainder()) {
        tail += x * y;
    }
    let mut quarter = [0.0; 4];
    for (l, q) in quarter.iter_mut().enumerate() {
        *q = (acc[l] + acc[l + 4]) + (acc[l + 8] + acc[l + 12]);
    }
    (quarter[0] + quarter[1]) + (quarter[2] + quarter[3]) + tail
}

/// `gram = J^T J` (full symmetric `cols x cols`) and `jtr = J^T r` for a column-major
/// `rows x cols` matrix `jac`: one [`dot`] per entry of the upper triangle and of `J^T r`.
///
/// Cost: `rows * cols * (cols + 3) / 2` multiply-adds.
pub(crate) fn gram_and_gradient(
    jac: &[f64],
    rows: usize,
    cols: usize,
    r: &[f64],
    gram: &mut [f64],
    jtr: &mut [f64],
) {
    for j in 0..cols {
        let cj = &jac[j * rows..(j + 1) * rows];
        for i in 0..=j {
            let v = dot(&jac[i * rows..(i + 1) * rows], cj);
            gram[i + j * cols] = v;
            gram[j + i * cols] = v;
        }
        jtr[j] = dot(cj, &r[..rows]);
    }
}

/// In-place Cholesky factorization `A = L L^T` of the symmetric positive definite `n x n` matrix
/// in `a` (only the lower triangle is read; `L` overwrites it, the strict upper triangle is left
/// as is).
///
/// Returns `Err(k)` if the `k`-th pivot is not positive and finite (the matrix is not numerically
/// positive definite). Cost: `n^3 / 6` multiply-adds.
pub(crate) fn cholesky_in_place(a: &mut [f64], n: usize) -> Result<(), usize> {
    for j in 0..n {
        let mut d = a[j + j * n];
        for k in 0..j {
            let l = a[j + k * n];
            d -= l * l;
        }
        if !(d > 0.0 && d.is_finite()) {
            return Err(j);
        }
        let d = d.sqrt();
        a[j + j * n] = d;
        let inv = 1.0 / d;
        for i in j + 1..n {
            let mut s = a[i + j * n];
            for k in 0..j {
                s -= a[i + k * n] * a[j + k * n];
            }
            a[i + j * n] = s * inv;
        }
    }
    Ok(())
}

/// Solves `L y = b` in place (`L` lower triangular from [`cholesky_in_place`]).
#[inline]
pub(crate) fn forward_substitute(l: &[f64], n: usize, b: &mut [f64]) {
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i + k * n] * b[k];
        }
        b[i] = s / l[i + i * n];
    }
}

/// Solves `L^T x = y` in place.
#[inline]
pub(crate) fn backward_substitute_transpose(l: &[f64], n: usize, b: &mut [f64]) {
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k + i * n] * b[k];
        }
        b[i] = s / l[i + i * n];
    }
}

/// Solves `L L^T x = b` in place.
#[inline]
pub(crate) fn cholesky_solve(l: &[f64], n: usize, b: &mut [f64]) {
    forward_substitute(l, n, b);
    backward_substitute_transpose(l, n, b);
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    #[test]
    fn cholesky_solves_a_spd_system() {
        let m = DMatrix::from_fn(5, 5, |i, j| ((i * 7 + j * 3) % 5) as f64 - 2.0);
        let a = &m * m.transpose() + DMatrix::identity(5, 5);
        let mut l = a.as_slice().to_vec();
        cholesky_in_place(&mut l, 5).unwrap();
        let b: Vec<f64> = (0..5).map(|i| i as f64 + 1.0).collect();
        let mut x = b.clone();
        cholesky_solve(&l, 5, &mut x);
        let ax = &a * nalgebra::DVector::from_vec(x);
        for i in 0..5 {
            assert!((ax[i] - b[i]).abs() < 1e-12);
        }
    }

    #[test]
    fn cholesky_reports_the_failing_pivot() {
        // Positive definite leading 1x1 block, singular 2x2.
        let mut a = vec![1.0, 2.0, 2.0, 4.0];
        assert_eq!(cholesky_in_place(&mut a, 2), Err(1));
        let mut nan = vec![f64::NAN];
        assert_eq!(cholesky_in_place(&mut nan, 1), Err(0));
    }

    #[test]
    fn gram_matches_matrix_product() {
        // Sizes around the 4-column and 4-row blocking.
        for (rows, cols) in [(7, 3), (1, 1), (8, 4), (13, 9), (802, 14)] {
            let j = DMatrix::from_fn(rows, cols, |i, k| {
                ((i * 31 + k * 17) % 13) as f64 - 6.0 + 0.1 * k as f64
            });
            let r: Vec<f64> = (0..rows).map(|i| i as f64 * 0.1 - 1.0).collect();
            let mut gram = vec![0.0; cols * cols];
            let mut jtr = vec![0.0; cols];
            gram_and_gradient(j.as_slice(), rows, cols, &r, &mut gram, &mut jtr);
            let expected = j.transpose() * &j;
            let expected_g = j.transpose() * nalgebra::DVector::from_vec(r);
            for (a, b) in gram.iter().zip(expected.iter()) {
                assert!(
                    (a - b).abs() <= 1e-12 * b.abs().max(1.0),
                    "{rows}x{cols}: {a} vs {b}"
                );
            }
            for (a, b) in jtr.iter().zip(expected_g.iter()) {
                assert!(
                    (a - b).abs() <= 1e-12 * b.abs().max(1.0),
                    "{rows}x{cols}: {a} vs {b}"
                );
            }
        }
    }
}
