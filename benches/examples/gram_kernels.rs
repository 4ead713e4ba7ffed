//! Micro-benchmark of the Gram kernel that dominates calibration linearization
//! (`lm_solver::kernels::gram_and_gradient`, private, copied here) against variants, on the
//! calibration shape: 1000 view Jacobians of 800 rows x 14 columns (20x20 board, camera 8 + pose
//! 6), i.e. one linearization of the 1000 x 400 benchmark.
//!
//! ```text
//! cargo run --release -p calib-benches --example gram_kernels
//! # the file has no dependencies, so other code generation settings are quick to try:
//! rustc -C opt-level=3 -C target-cpu=native -o /tmp/gram_kernels benches/examples/gram_kernels.rs && /tmp/gram_kernels
//! ```
//!
//! Variants: `current` (the solver's kernel: one dot product per Gram entry, 4 accumulators),
//! `tiled128` (the same over 128-row panels), `dot16` (16 accumulators combined in a fixed order:
//! still independent of the thread count). Results in `docs/benchmarks-solver.md`, section 6.

use std::hint::black_box;
use std::time::Instant;

type Kernel = fn(&[f64], usize, usize, &[f64], &mut [f64], &mut [f64]);

/// The solver's `dot` (4 accumulators).
#[inline]
fn dot4(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 4];
    let mut ca = a.chunks_exact(4);
    let mut cb = b.chunks_exact(4);
    for (x, y) in (&mut ca).zip(&mut cb) {
        for l in 0..4 {
            acc[l] += x[l] * y[l];
        }
    }
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// 16 accumulators, combined in a fixed order. It must be inlined into the Gram loop: compiled
/// as a separate function (`#[inline(never)]`) the loop is shuffled across lanes and most of the
/// gain is lost (19.5 ms instead of 14.5 ms on the benchmark machine).
#[inline]
fn dot16(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 16];
    let mut ca = a.chunks_exact(16);
    let mut cb = b.chunks_exact(16);
    for (x, y) in (&mut ca).zip(&mut cb) {
        for l in 0..16 {
            acc[l] += x[l] * y[l];
        }
    }
    let mut tail = 0.0;
    for (x, y) in ca.remainder().iter().zip(cb.remainder()) {
        tail += x * y;
    }
    let mut s = [0.0; 4];
    for (l, v) in s.iter_mut().enumerate() {
        *v = (acc[l] + acc[l + 4]) + (acc[l + 8] + acc[l + 12]);
    }
    (s[0] + s[1]) + (s[2] + s[3]) + tail
}

#[inline(always)]
fn gram_with<F: Fn(&[f64], &[f64]) -> f64>(
    dot: F,
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
        jtr[j] = dot(cj, r);
    }
}

fn current(jac: &[f64], rows: usize, cols: usize, r: &[f64], gram: &mut [f64], jtr: &mut [f64]) {
    gram_with(dot4, jac, rows, cols, r, gram, jtr);
}

fn with_dot16(jac: &[f64], rows: usize, cols: usize, r: &[f64], gram: &mut [f64], jtr: &mut [f64]) {
    for j in 0..cols {
        let cj = &jac[j * rows..(j + 1) * rows];
        for i in 0..=j {
            let v = dot16(&jac[i * rows..(i + 1) * rows], cj);
            gram[i + j * cols] = v;
            gram[j + i * cols] = v;
        }
        jtr[j] = dot16(cj, r);
    }
}

fn tiled128(jac: &[f64], rows: usize, cols: usize, r: &[f64], gram: &mut [f64], jtr: &mut [f64]) {
    const PANEL: usize = 128;
    gram.fill(0.0);
    jtr.fill(0.0);
    let mut start = 0;
    while start < rows {
        let end = (start + PANEL).min(rows);
        for j in 0..cols {
            let cj = &jac[j * rows + start..j * rows + end];
            for i in 0..=j {
                gram[i + j * cols] += dot4(&jac[i * rows + start..i * rows + end], cj);
            }
            jtr[j] += dot4(cj, &r[start..end]);
        }
        start = end;
    }
    for j in 0..cols {
        for i in 0..j {
            gram[j + i * cols] = gram[i + j * cols];
        }
    }
}

fn main() {
    let (rows, cols, views) = (800, 14, 1000);
    let mut state = 1u64;
    let mut uniform = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let jac: Vec<f64> = (0..rows * cols).map(|_| uniform()).collect();
    let r: Vec<f64> = (0..rows).map(|_| uniform()).collect();
    let (mut reference, mut reference_jtr) = (vec![0.0; cols * cols], vec![0.0; cols]);
    current(&jac, rows, cols, &r, &mut reference, &mut reference_jtr);
    let kernels: [(&str, Kernel); 3] = [
        ("current (4 accumulators)", current),
        ("tiled128", tiled128),
        ("dot16 (16 accumulators)", with_dot16),
    ];
    let (mut gram, mut jtr) = (vec![0.0; cols * cols], vec![0.0; cols]);
    for (name, kernel) in kernels {
        kernel(&jac, rows, cols, &r, &mut gram, &mut jtr);
        let diff = gram
            .iter()
            .zip(&reference)
            .map(|(a, b)| ((a - b) / b).abs())
            .fold(0.0, f64::max);
        let mut best = f64::INFINITY;
        for _ in 0..7 {
            let t = Instant::now();
            for _ in 0..views {
                kernel(black_box(&jac), rows, cols, &r, &mut gram, &mut jtr);
                black_box(&gram);
            }
            best = best.min(t.elapsed().as_secs_f64());
        }
        println!(
            "{name:26} {:7.2} ms per {views} views of {rows}x{cols} (max relative difference to \
             current {diff:.1e})",
            best * 1e3
        );
    }
}
