//! The projection model `x = h1.M / h3.M`, `y = h2.M / h3.M` and its analytic Jacobian with
//! respect to the eight free entries of `H`.

use nalgebra::{Matrix3, Point2, SMatrix, Vector2};

/// A `2 x 8` matrix: derivatives of one projected pixel `(x, y)` with respect to the eight
/// free entries of `H`, in the order `h11, h21, h31, h12, h22, h32, h13, h23`.
pub type Matrix2x8 = SMatrix<f64, 2, 8>;

/// Projects one plane point through `h` and returns the pixel with its Jacobian.
///
/// With `M = (X, Y, 1)` and the rows `h1, h2, h3` of `h`, the homogeneous image point is
/// `(u', v', w') = (h1.M, h2.M, h3.M)` and the pixel is `(x, y) = (u'/w', v'/w')`, in the
/// same convention as the pixels `h` was estimated from.
///
/// The Jacobian holds `d(x, y) / d(h11, h21, h31, h12, h22, h32, h13, h23)`, i.e. the entries
/// of `h` in column-major order without `h33`, which is treated as a constant (it is `1`
/// for the homographies of this crate, but any value works):
///
/// ```text
/// dx/dh1 = M / w'      dx/dh2 = 0          dx/dh3 = -x M / w'
/// dy/dh1 = 0           dy/dh2 = M / w'     dy/dh3 = -y M / w'
/// ```
///
/// (restricted to the free entries). No check is made: if the point lies on the vanishing
/// line (`w' = 0`) the results are infinite or NaN.
pub fn project_with_jacobian(h: &Matrix3<f64>, point: &Point2<f64>) -> (Vector2<f64>, Matrix2x8) {
    let (big_x, big_y) = (point.x, point.y);
    let u = h[(0, 0)] * big_x + h[(0, 1)] * big_y + h[(0, 2)];
    let v = h[(1, 0)] * big_x + h[(1, 1)] * big_y + h[(1, 2)];
    let w = h[(2, 0)] * big_x + h[(2, 1)] * big_y + h[(2, 2)];
    let inv_w = 1.0 / w;
    let x = u * inv_w;
    let y = v * inv_w;

    let (ax, ay) = (big_x * inv_w, big_y * inv_w);
    #[rustfmt::skip]
    let jacobian = Matrix2x8::from_row_slice(&[
        // h11  h21  h31      h12  h22  h32      h13    h23
        ax,  0.0, -x * ax,  ay,  0.0, -x * ay,  inv_w, 0.0,
        0.0, ax,  -y * ax,  0.0, ay,  -y * ay,  0.0,   inv_w,
    ]);
    (Vector2::new(x, y), jacobian)
}

/// Projects one plane point through `h` (no Jacobian).
#[inline]
pub(crate) fn project(h: &Matrix3<f64>, p: &Point2<f64>) -> Vector2<f64> {
    let u = h[(0, 0)] * p.x + h[(0, 1)] * p.y + h[(0, 2)];
    let v = h[(1, 0)] * p.x + h[(1, 1)] * p.y + h[(1, 2)];
    let w = h[(2, 0)] * p.x + h[(2, 1)] * p.y + h[(2, 2)];
    // The same arithmetic as the refinement's linearization, so both give identical costs.
    let inv_w = 1.0 / w;
    Vector2::new(u * inv_w, v * inv_w)
}

/// Sum over points of the squared pixel distance between the projection and the
/// measurement; `f64::INFINITY` if any projection is not finite.
pub(crate) fn sum_squared_residuals(
    h: &Matrix3<f64>,
    object: &[Point2<f64>],
    image: &[Point2<f64>],
) -> f64 {
    let mut sum = 0.0;
    for (m_obj, m_img) in object.iter().zip(image) {
        let r = project(h, m_obj) - m_img.coords;
        let d2 = r.norm_squared();
        if !d2.is_finite() {
            return f64::INFINITY;
        }
        sum += d2;
    }
    sum
}

/// Root-mean-square reprojection error of `h`, in pixels:
/// `sqrt(1/N * sum_i |project(h, object_i) - image_i|^2)`.
///
/// Points are paired by index; if the slices differ in length, the extra points of the
/// longer one are ignored. Returns `0.0` for empty input and `f64::INFINITY` when a point
/// projects to infinity (or the error is otherwise not finite), never NaN.
pub fn reprojection_rms(h: &Matrix3<f64>, object: &[Point2<f64>], image: &[Point2<f64>]) -> f64 {
    let n = object.len().min(image.len());
    if n == 0 {
        return 0.0;
    }
    (sum_squared_residuals(h, object, image) / n as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobian_columns_follow_column_major_order() {
        let h = Matrix3::new(2.0, 0.5, 3.0, -0.25, 1.5, 4.0, 0.1, 0.2, 1.0);
        let p = Point2::new(1.0, 2.0);
        let (px, j) = project_with_jacobian(&h, &p);
        let w = 0.1 + 0.4 + 1.0;
        let x = (2.0 + 1.0 + 3.0) / w;
        let y = (-0.25 + 3.0 + 4.0) / w;
        assert!((px - Vector2::new(x, y)).norm() < 1e-15);
        // Perturb h31 (index 2 of the column-major storage): only the denominator changes.
        assert!((j[(0, 2)] + x * 1.0 / w).abs() < 1e-15);
        assert!((j[(1, 5)] + y * 2.0 / w).abs() < 1e-15);
        assert!((j[(0, 6)] - 1.0 / w).abs() < 1e-15);
        assert_eq!(j[(1, 6)], 0.0);
        assert!((j[(1, 7)] - 1.0 / w).abs() < 1e-15);
    }

    #[test]
    fn rms_handles_empty_and_infinite() {
        let h = Matrix3::identity();
        assert_eq!(reprojection_rms(&h, &[], &[]), 0.0);
        let at_infinity = Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0);
        let rms = reprojection_rms(&at_infinity, &[Point2::new(0.0, 1.0)], &[Point2::origin()]);
        assert_eq!(rms, f64::INFINITY);
    }
}
