//! Joint refinement of a view's corners through a low-order warp of the board.
//!
//! The board-to-image map of a pinhole camera with mild lens distortion is a homography
//! plus a smooth correction. Fitting `H(c, r) + P(c, r)`, with `P` a polynomial of degrees
//! `2..=degree` in the normalized board coordinates, to all corners of a view and replacing
//! every corner by the fitted map averages per-corner noise over the whole board, at the
//! price of a model error where the warp cannot follow the true distortion.

use homography::{RefineOptions, estimate};
use nalgebra::{DMatrix, DVector, Point2};

use crate::grid::P;

/// The homography fitted to the corners (object points `(c, r)`, unit squares) and its RMS
/// residual in pixels.
pub(crate) fn homography_fit(pts: &[P], cols: usize) -> Option<(nalgebra::Matrix3<f64>, f64)> {
    let obj: Vec<Point2<f64>> = (0..pts.len())
        .map(|i| Point2::new((i % cols) as f64, (i / cols) as f64))
        .collect();
    let img: Vec<Point2<f64>> = pts.iter().map(|p| Point2::new(p[0], p[1])).collect();
    let est = estimate(&obj, &img, &RefineOptions::default()).ok()?;
    Some((est.h, est.rms))
}

/// Replaces the corners by the fitted homography-plus-polynomial warp. `None` (corners
/// unchanged) when the fit is not possible.
pub(crate) fn smooth(pts: &[P], cols: usize, rows: usize, degree: usize) -> Option<Vec<P>> {
    let n = pts.len();
    let hc = (cols as f64 - 1.0) / 2.0;
    let hr = (rows as f64 - 1.0) / 2.0;
    let terms: Vec<(i32, i32)> = (2..=degree as i32)
        .flat_map(|d| (0..=d).map(move |i| (i, d - i)))
        .collect();
    if terms.len() + 1 > n {
        return None;
    }
    let mut a = DMatrix::<f64>::zeros(n, terms.len());
    for k in 0..n {
        let (c, r) = ((k % cols) as f64, (k / cols) as f64);
        let (u, v) = ((c - hc) / hc.max(1.0), (r - hr) / hr.max(1.0));
        for (j, &(i, e)) in terms.iter().enumerate() {
            a[(k, j)] = u.powi(i) * v.powi(e);
        }
    }
    let svd = a.clone().svd(true, true);
    // Alternate: homography to the corners minus the polynomial, polynomial to the rest.
    let mut poly = vec![[0.0, 0.0]; n];
    let mut base = vec![[0.0, 0.0]; n];
    for _ in 0..20 {
        let target: Vec<P> = pts
            .iter()
            .zip(&poly)
            .map(|(p, q)| [p[0] - q[0], p[1] - q[1]])
            .collect();
        let (h, _) = homography_fit(&target, cols)?;
        let mut bx = DVector::<f64>::zeros(n);
        let mut by = DVector::<f64>::zeros(n);
        for (k, p) in pts.iter().enumerate() {
            let q = h.transform_point(&Point2::new((k % cols) as f64, (k / cols) as f64));
            base[k] = [q.x, q.y];
            bx[k] = p[0] - q.x;
            by[k] = p[1] - q.y;
        }
        let fx = &a * svd.solve(&bx, 1e-10).ok()?;
        let fy = &a * svd.solve(&by, 1e-10).ok()?;
        for k in 0..n {
            poly[k] = [fx[k], fy[k]];
        }
    }
    Some(
        (0..n)
            .map(|k| [base[k][0] + poly[k][0], base[k][1] + poly[k][1]])
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::Scene;

    /// Without lens distortion the board-to-image map is a homography, which the warp
    /// contains, so exact corners come back unchanged (up to the solver's rounding).
    #[test]
    fn warp_is_exact_without_distortion() {
        let s = Scene {
            k1: 0.0,
            k2: 0.0,
            ..Scene::default()
        };
        let pts: Vec<P> = (0..54)
            .map(|i| s.project((i % 9) as f64, (i / 9) as f64).unwrap())
            .collect();
        for d in 2..=4 {
            let q = smooth(&pts, 9, 6, d).unwrap();
            for (a, b) in pts.iter().zip(&q) {
                assert!(
                    (a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6,
                    "degree {d}: {a:?} vs {b:?}"
                );
            }
        }
    }

    /// With distortion the warp has a model error: this is why it is not the default.
    #[test]
    fn warp_has_model_error_with_distortion() {
        let s = Scene {
            k1: -0.15,
            k2: 0.05,
            ..Scene::default()
        };
        let pts: Vec<P> = (0..54)
            .map(|i| s.project((i % 9) as f64, (i / 9) as f64).unwrap())
            .collect();
        let q = smooth(&pts, 9, 6, 2).unwrap();
        let e = (pts
            .iter()
            .zip(&q)
            .map(|(a, b)| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2))
            .sum::<f64>()
            / 54.0)
            .sqrt();
        assert!(e > 0.1, "degree 2 warp model error {e} px");
    }
}
