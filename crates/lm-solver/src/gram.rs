//! Helpers for cost functions that implement the fused path
//! [`CostFunction::evaluate_gram`](crate::CostFunction::evaluate_gram).
//!
//! A residual row often has only a few structural non-zeros among the Jacobian's columns (a
//! pixel's x coordinate does not depend on the focal length of y, say). [`CompactGram`] accumulates
//! `sum u u^T` and `sum r u` over such compact rows `u` of fixed width `W`, then scatters the result
//! onto the real columns. Rows are buffered (32 at a time) and each entry is reduced over
//! all buffered rows in registers, which avoids reading and writing the `W x W` accumulators once
//! per row.
//!
//! ```
//! use lm_solver::gram::CompactGram;
//! // Two rows of a 3-column Jacobian whose rows only touch columns (0, 2) and (1, 2).
//! let mut first = CompactGram::<2>::new();
//! let mut second = CompactGram::<2>::new();
//! first.push(&[1.0, 2.0], &[], 0.5);
//! second.push(&[3.0, 4.0], &[], -1.0);
//! let (mut gram, mut gradient) = (vec![0.0; 9], vec![0.0; 3]);
//! first.finish().scatter(&[Some((0, 1.0)), Some((2, 1.0))], &mut gram, &mut gradient, 3);
//! second.finish().scatter(&[Some((1, 1.0)), Some((2, 1.0))], &mut gram, &mut gradient, 3);
//! assert_eq!(gram[2 + 2 * 3], 2.0 * 2.0 + 4.0 * 4.0); // column 2 with itself
//! assert_eq!(gradient[2], 2.0 * 0.5 + 4.0 * -1.0);
//! ```

/// Rows reduced together into the lane sums: the unit of the summation order.
pub const BATCH: usize = 8;

/// Rows buffered before the lane sums are read and written back: [`BATCH`] rows at a time are
/// added in the same order as one batch per flush, but the sums stay in registers over
/// `ROWS / BATCH` batches, a quarter of the accumulator loads and stores.
const ROWS: usize = 4 * BATCH;

/// Lanes of the partial sums: each entry keeps four running sums, reduced once in `finish`.
const LANES: usize = 4;

/// Accumulates `sum u u^T` and `sum r u` over compact rows `u = [fixed, model]` made of a part of
/// fixed width `F` and a part of width `N` (entries `0..F` and `F..F + N` of the combined row;
/// `N` defaults to 0).
///
/// The split lets a cost function generic over a model with `N` parameters size its accumulator
/// without arithmetic on const generics (`[f64; F + N]` is not expressible in generic code):
/// calibration's rows are `F` pose and intrinsic entries plus the `N` distortion derivatives of
/// the lens model. Each entry is reduced over a batch of [`BATCH`] rows in four lanes, the same
/// operations in the same order whatever the instruction set, so results are reproducible.
#[derive(Debug, Clone)]
pub struct CompactGram<const F: usize, const N: usize = 0> {
    rows_f: [[f64; ROWS]; F],
    rows_n: [[f64; ROWS]; N],
    residuals: [f64; ROWS],
    filled: usize,
    lanes_ff: [[[f64; LANES]; F]; F],
    lanes_fn: [[[f64; LANES]; N]; F],
    lanes_nn: [[[f64; LANES]; N]; N],
    gradient_f: [[f64; LANES]; F],
    gradient_n: [[f64; LANES]; N],
    sums_ff: [[f64; F]; F],
    sums_fn: [[f64; N]; F],
    sums_nn: [[f64; N]; N],
    sum_gradient_f: [f64; F],
    sum_gradient_n: [f64; N],
}

impl<const F: usize, const N: usize> Default for CompactGram<F, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const F: usize, const N: usize> CompactGram<F, N> {
    /// Width of a combined row.
    pub const WIDTH: usize = F + N;

    /// An empty accumulator.
    #[inline(always)]
    pub fn new() -> Self {
        // SAFETY: every field is an array of `f64` or a `usize`, for which all-zero bits are
        // the value zero. Written this way the compiler zeroes the caller's slot in place; the
        // field-by-field literal was built once and copied (two 11 KB copies per view of a
        // rational8 calibration, 3% of its time).
        unsafe { std::mem::zeroed() }
    }

    /// Adds one row `[fixed, model]` with residual `r`.
    #[inline]
    pub fn push(&mut self, fixed: &[f64; F], model: &[f64; N], r: f64) {
        let p = self.filled;
        for (column, value) in self.rows_f.iter_mut().zip(fixed) {
            column[p] = *value;
        }
        for (column, value) in self.rows_n.iter_mut().zip(model) {
            column[p] = *value;
        }
        self.residuals[p] = r;
        self.filled += 1;
        if self.filled == ROWS {
            self.flush();
        }
    }

    #[inline]
    fn flush(&mut self) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2, checked just above.
                unsafe { self.flush_avx2() };
                self.filled = 0;
                return;
            }
        }
        self.flush_lanes();
        self.filled = 0;
    }

    /// The reduction in explicit AVX2 vectors (a lane sum is one register), the same
    /// multiplications and additions in the same order as [`CompactGram::flush_lanes`], so the
    /// same bits (no fused multiply-add). Written out because the auto-vectorizer split some
    /// widths' loops across entries with shuffles (rational8 rows: twice the time).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn flush_avx2(&mut self) {
        let batches = self.filled.div_ceil(BATCH);
        for a in 0..F {
            let ua = load_avx2(&self.rows_f[a]);
            for c in a..F {
                accumulate_avx2(&mut self.lanes_ff[a][c], &ua, &self.rows_f[c], batches);
            }
            for c in 0..N {
                accumulate_avx2(&mut self.lanes_fn[a][c], &ua, &self.rows_n[c], batches);
            }
            accumulate_avx2(&mut self.gradient_f[a], &ua, &self.residuals, batches);
        }
        for a in 0..N {
            let ua = load_avx2(&self.rows_n[a]);
            for c in a..N {
                accumulate_avx2(&mut self.lanes_nn[a][c], &ua, &self.rows_n[c], batches);
            }
            accumulate_avx2(&mut self.gradient_n[a], &ua, &self.residuals, batches);
        }
    }

    /// Reduces the buffered rows (`filled` of them, the rest of the last batch zero) into the
    /// lane sums: per lane `l` and batch, `sum[l] += a[l] b[l] + a[l + 4] b[l + 4]`, batch
    /// after batch.
    fn flush_lanes(&mut self) {
        let batches = self.filled.div_ceil(BATCH);
        let accumulate = |acc: &mut [f64; LANES], a: &[f64; ROWS], b: &[f64; ROWS]| {
            for batch in 0..batches {
                let (a, b) = (&a[batch * BATCH..], &b[batch * BATCH..]);
                for l in 0..LANES {
                    acc[l] += a[l] * b[l] + a[l + LANES] * b[l + LANES];
                }
            }
        };
        for a in 0..F {
            let ua = self.rows_f[a];
            for c in a..F {
                accumulate(&mut self.lanes_ff[a][c], &ua, &self.rows_f[c]);
            }
            for c in 0..N {
                accumulate(&mut self.lanes_fn[a][c], &ua, &self.rows_n[c]);
            }
            accumulate(&mut self.gradient_f[a], &ua, &self.residuals);
        }
        for a in 0..N {
            let ua = self.rows_n[a];
            for c in a..N {
                accumulate(&mut self.lanes_nn[a][c], &ua, &self.rows_n[c]);
            }
            accumulate(&mut self.gradient_n[a], &ua, &self.residuals);
        }
    }

    /// Reduces the rows still buffered and the lane sums, and returns the sums.
    pub fn finish(&mut self) -> &Self {
        if self.filled > 0 {
            let (filled, end) = (self.filled, self.filled.div_ceil(BATCH) * BATCH);
            for column in self.rows_f.iter_mut().chain(self.rows_n.iter_mut()) {
                column[filled..end].fill(0.0);
            }
            self.residuals[filled..end].fill(0.0);
            self.flush();
        }
        let reduce = |v: &[f64; LANES]| (v[0] + v[1]) + (v[2] + v[3]);
        for a in 0..F {
            for c in a..F {
                self.sums_ff[a][c] = reduce(&self.lanes_ff[a][c]);
            }
            for c in 0..N {
                self.sums_fn[a][c] = reduce(&self.lanes_fn[a][c]);
            }
            self.sum_gradient_f[a] = reduce(&self.gradient_f[a]);
        }
        for a in 0..N {
            for c in a..N {
                self.sums_nn[a][c] = reduce(&self.lanes_nn[a][c]);
            }
            self.sum_gradient_n[a] = reduce(&self.gradient_n[a]);
        }
        self
    }

    /// Entry `(a, b)` of `sum u u^T` over combined rows (call [`CompactGram::finish`]
    /// first).
    #[inline]
    pub fn entry(&self, a: usize, b: usize) -> f64 {
        let (a, b) = if a <= b { (a, b) } else { (b, a) };
        match (a < F, b < F) {
            (true, true) => self.sums_ff[a][b],
            (true, false) => self.sums_fn[a][b - F],
            _ => self.sums_nn[a - F][b - F],
        }
    }

    /// Entry `a` of `sum r u` (call [`CompactGram::finish`] first).
    #[inline]
    pub fn gradient(&self, a: usize) -> f64 {
        if a < F {
            self.sum_gradient_f[a]
        } else {
            self.sum_gradient_n[a - F]
        }
    }

    /// Adds the sums onto a column-major `n x n` Gram matrix and gradient: combined entry `a`
    /// goes to column `targets[a].0` multiplied by `targets[a].1`, or nowhere for `None` (a
    /// constant parameter block). Several entries may share a column. `targets` has length
    /// `F + N`.
    pub fn scatter(
        &self,
        targets: &[Option<(usize, f64)>],
        gram: &mut [f64],
        gradient: &mut [f64],
        n: usize,
    ) {
        debug_assert_eq!(targets.len(), F + N);
        let (fixed, model) = targets.split_at(F);
        // Each pair once from the upper triangle of the sums, added at both (a, c) and (c, a)
        // (the same product either way, so the result equals the plain double loop's).
        let mut add = |(ca, fa): (usize, f64), (cc, fc): (usize, f64), diagonal: bool, v: f64| {
            let value = fa * fc * v;
            gram[ca + cc * n] += value;
            if !diagonal {
                gram[cc + ca * n] += value;
            }
        };
        upper_triangle(fixed, |a, c| self.sums_ff[a][c], &mut add);
        upper_triangle(model, |a, c| self.sums_nn[a][c], &mut add);
        for (a, ta) in fixed.iter().enumerate() {
            let Some(ta) = *ta else { continue };
            gradient[ta.0] += ta.1 * self.sum_gradient_f[a];
            for (c, tc) in model.iter().enumerate() {
                if let Some(tc) = *tc {
                    add(ta, tc, false, self.sums_fn[a][c]);
                }
            }
        }
        for (tc, g) in model.iter().zip(&self.sum_gradient_n) {
            if let Some((cc, fc)) = *tc {
                gradient[cc] += fc * g;
            }
        }
    }

    /// Adds `T S T^T` and `T g` onto a column-major `n x n` Gram matrix and gradient, for a
    /// general linear map `T` from combined entries to columns given as a list of
    /// `(entry, column, factor)`: column `c` of the real Jacobian row is `sum factor * u[entry]`
    /// over the list's entries for `c`. Use this when an entry feeds several columns;
    /// [`CompactGram::scatter`] is the one-to-one special case. Cost: `entries^2` multiply-adds.
    pub fn scatter_map(
        &self,
        entries: &[(usize, usize, f64)],
        gram: &mut [f64],
        gradient: &mut [f64],
        n: usize,
    ) {
        for &(a, ca, fa) in entries {
            gradient[ca] += fa * self.gradient(a);
            for &(b, cb, fb) in entries {
                gram[ca + cb * n] += fa * fb * self.entry(a, b);
            }
        }
    }
}

/// One buffered column as registers, two per batch (rows 0..4 and 4..8).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn load_avx2(column: &[f64; ROWS]) -> [std::arch::x86_64::__m256d; 2 * ROWS / BATCH] {
    // SAFETY: k < 2 ROWS / BATCH, so k * LANES + LANES <= ROWS.
    std::array::from_fn(|k| unsafe {
        std::arch::x86_64::_mm256_loadu_pd(column.as_ptr().add(k * LANES))
    })
}

/// `acc += a * b` over `batches` batches of the buffered rows, `a` already in registers (two per
/// batch), in the order of [`CompactGram::flush_lanes`]: per batch the products of rows 0..4 and
/// 4..8 are added together first, then onto the sum.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn accumulate_avx2(
    acc: &mut [f64; LANES],
    a: &[std::arch::x86_64::__m256d; 2 * ROWS / BATCH],
    b: &[f64; ROWS],
    batches: usize,
) {
    use std::arch::x86_64::{_mm256_add_pd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_storeu_pd};
    // SAFETY: `acc` holds LANES values; batch k reads b[8k..8k + 8] with k < batches <= ROWS / 8.
    unsafe {
        let mut sum = _mm256_loadu_pd(acc.as_ptr());
        for k in 0..batches.min(ROWS / BATCH) {
            let low = _mm256_mul_pd(a[2 * k], _mm256_loadu_pd(b.as_ptr().add(k * BATCH)));
            let high = _mm256_mul_pd(
                a[2 * k + 1],
                _mm256_loadu_pd(b.as_ptr().add(k * BATCH + LANES)),
            );
            sum = _mm256_add_pd(sum, _mm256_add_pd(low, high));
        }
        _mm256_storeu_pd(acc.as_mut_ptr(), sum);
    }
}

/// Calls `add(target a, target c, a == c, sums(a, c))` for every pair `a <= c` of present
/// targets: one diagonal block of [`CompactGram::scatter`].
#[inline(always)]
fn upper_triangle(
    targets: &[Option<(usize, f64)>],
    sums: impl Fn(usize, usize) -> f64,
    add: &mut impl FnMut((usize, f64), (usize, f64), bool, f64),
) {
    for (a, ta) in targets.iter().enumerate() {
        let Some(ta) = *ta else { continue };
        for (c, tc) in targets.iter().enumerate().skip(a) {
            if let Some(tc) = *tc {
                add(ta, tc, c == a, sums(a, c));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Entry `(i, j)` of `sum u u^T` (`j = None`: of `sum r u`) in the documented order: per
    /// batch of 8 rows (the last padded with zeros) and lane `l`, `lane[l] += u_l u_l' + u_{l+4}
    /// u_{l+4}'`, then `(lane0 + lane1) + (lane2 + lane3)`.
    fn in_documented_order(rows: &[(Vec<f64>, f64)], i: usize, j: Option<usize>) -> f64 {
        let value = |k: usize, column: Option<usize>| {
            rows.get(k)
                .map_or(0.0, |(u, r)| column.map_or(*r, |c| u[c]))
        };
        let mut lanes = [0.0; LANES];
        for batch in 0..rows.len().div_ceil(BATCH) {
            for (l, lane) in lanes.iter_mut().enumerate() {
                let (k, m) = (batch * BATCH + l, batch * BATCH + l + LANES);
                *lane += value(k, Some(i)) * value(k, j) + value(m, Some(i)) * value(m, j);
            }
        }
        (lanes[0] + lanes[1]) + (lanes[2] + lanes[3])
    }

    /// `count` random rows through the dispatched flush (AVX2 where available) and through the
    /// plain loop alone, both compared bit for bit with the documented order.
    fn check_flush_order<const F: usize, const N: usize>(count: usize, seed: u64) {
        let mut dispatched = CompactGram::<F, N>::new();
        let mut plain = CompactGram::<F, N>::new();
        let mut state = seed;
        let mut rows = Vec::new();
        for i in 0..count {
            let u: Vec<f64> = (0..F + N)
                .map(|_| {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
                })
                .collect();
            let r = i as f64 * 0.01 - 0.2;
            let (fixed, model) = u.split_at(F);
            dispatched.push(&fixed.try_into().unwrap(), &model.try_into().unwrap(), r);
            // The same rows through the plain loop only.
            let p = plain.filled;
            for (column, value) in plain.rows_f.iter_mut().zip(fixed) {
                column[p] = *value;
            }
            for (column, value) in plain.rows_n.iter_mut().zip(model) {
                column[p] = *value;
            }
            plain.residuals[p] = r;
            plain.filled += 1;
            if plain.filled == ROWS {
                plain.flush_lanes();
                plain.filled = 0;
            }
            rows.push((u, r));
        }
        if plain.filled > 0 {
            let filled = plain.filled;
            for column in plain.rows_f.iter_mut().chain(plain.rows_n.iter_mut()) {
                column[filled..].fill(0.0);
            }
            plain.residuals[filled..].fill(0.0);
            plain.flush_lanes();
            plain.filled = 0;
        }
        let (a, b) = (dispatched.finish().clone(), plain.finish().clone());
        for i in 0..F + N {
            let expected = in_documented_order(&rows, i, None).to_bits();
            assert_eq!(
                a.gradient(i).to_bits(),
                expected,
                "gradient {i} of {count} rows"
            );
            assert_eq!(
                b.gradient(i).to_bits(),
                expected,
                "gradient {i} of {count} rows"
            );
            for j in 0..F + N {
                let expected = in_documented_order(&rows, i.min(j), Some(i.max(j))).to_bits();
                assert_eq!(
                    a.entry(i, j).to_bits(),
                    expected,
                    "({i}, {j}) of {count} rows"
                );
                assert_eq!(
                    b.entry(i, j).to_bits(),
                    expected,
                    "({i}, {j}) of {count} rows"
                );
            }
        }
    }

    /// The dispatched flush (AVX2 where available) and the plain one give the bits of the
    /// documented summation order, whatever the number of rows buffered per flush: full and
    /// partial buffers, partial batches, the widths of calibration's rows.
    #[test]
    fn vector_width_and_buffering_do_not_change_the_result() {
        for count in [1, 7, 8, 31, 32, 37, 54, 64, 70] {
            check_flush_order::<5, 0>(count, 7 + count as u64);
            check_flush_order::<8, 12>(count, 11 + count as u64);
            check_flush_order::<11, 16>(count, 13 + count as u64);
        }
    }

    #[test]
    fn mapped_scatter_equals_the_product_of_the_expanded_rows() {
        // Real rows of 3 columns built from compact rows of 2: c0 = u0, c1 = 2 u0 - u1, c2 = u1.
        let compact = [[1.0, 2.0], [0.5, -1.0], [3.0, 0.25]];
        let residuals = [0.1, -0.2, 0.3];
        let mut g = CompactGram::<2>::new();
        for (u, r) in compact.iter().zip(&residuals) {
            g.push(u, &[], *r);
        }
        let entries = [(0, 0, 1.0), (0, 1, 2.0), (1, 1, -1.0), (1, 2, 1.0)];
        let (mut gram, mut gradient) = (vec![0.0; 9], vec![0.0; 3]);
        g.finish()
            .scatter_map(&entries, &mut gram, &mut gradient, 3);
        let rows: Vec<[f64; 3]> = compact
            .iter()
            .map(|u| [u[0], 2.0 * u[0] - u[1], u[1]])
            .collect();
        for i in 0..3 {
            for j in 0..3 {
                let direct: f64 = rows.iter().map(|r| r[i] * r[j]).sum();
                assert!((gram[i + 3 * j] - direct).abs() < 1e-12);
            }
            let direct: f64 = rows.iter().zip(&residuals).map(|(r, e)| r[i] * e).sum();
            assert!((gradient[i] - direct).abs() < 1e-12);
        }
    }

    #[test]
    fn sums_match_direct_products_for_partial_batches() {
        for count in [1usize, 7, 8, 9, 23] {
            let rows: Vec<[f64; 3]> = (0..count)
                .map(|i| [i as f64, 1.0, (i * i) as f64 * 0.1])
                .collect();
            let residuals: Vec<f64> = (0..count).map(|i| 0.5 - i as f64).collect();
            let mut g = CompactGram::<3>::new();
            for (u, r) in rows.iter().zip(&residuals) {
                g.push(u, &[], *r);
            }
            let g = g.finish();
            for a in 0..3 {
                for b in 0..3 {
                    let direct: f64 = rows.iter().map(|u| u[a] * u[b]).sum();
                    assert!((g.entry(a, b) - direct).abs() <= 1e-12 * direct.abs().max(1.0));
                }
                let direct: f64 = rows.iter().zip(&residuals).map(|(u, r)| u[a] * r).sum();
                assert!((g.gradient(a) - direct).abs() <= 1e-12 * direct.abs().max(1.0));
            }
        }
    }

    /// The partitioned accumulator gives the same bits as the plain one on the combined rows.
    #[test]
    fn partitioned_equals_plain() {
        let mut plain = CompactGram::<7>::new();
        let mut split = CompactGram::<4, 3>::new();
        let mut state = 3u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for _ in 0..21 {
            let u: [f64; 7] = std::array::from_fn(|_| next());
            let r = next();
            plain.push(&u, &[], r);
            split.push(&[u[0], u[1], u[2], u[3]], &[u[4], u[5], u[6]], r);
        }
        let (a, b) = (plain.finish().clone(), split.finish().clone());
        for i in 0..7 {
            assert_eq!(a.gradient(i).to_bits(), b.gradient(i).to_bits());
            for j in 0..7 {
                assert_eq!(a.entry(i, j).to_bits(), b.entry(i, j).to_bits());
            }
        }
        let targets: Vec<Option<(usize, f64)>> =
            (0..7).map(|i| (i != 2).then_some((6 - i, 1.5))).collect();
        let fixed: [Option<(usize, f64)>; 7] = std::array::from_fn(|i| targets[i]);
        let (mut g1, mut r1) = (vec![0.0; 49], vec![0.0; 7]);
        let (mut g2, mut r2) = (vec![0.0; 49], vec![0.0; 7]);
        a.scatter(&fixed, &mut g1, &mut r1, 7);
        b.scatter(&targets, &mut g2, &mut r2, 7);
        assert_eq!(g1, g2);
        assert_eq!(r1, r2);
    }
}
