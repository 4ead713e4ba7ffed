//! Hartley normalization of a point set (similarity transform `T`) and the checks that
//! only make sense on normalized points (coincidence and collinearity).
//!
//! The DLT system mixes products of pixel coordinates (hundreds to thousands) with plane
//! coordinates (often millimetres or metres) and constants equal to one. Without
//! conditioning its smallest singular vector is very sensitive to rounding. Moving each
//! set's centroid to the origin and scaling it to a mean distance of `sqrt(2)` makes every
//! column of the system of order one, whatever the units of the caller.

use nalgebra::{Matrix3, Point2};

use crate::error::{HomographyError, PointSet};

/// Relative spread below which a point set is treated as a single repeated point.
///
/// The mean distance to the centroid is compared with the largest absolute coordinate of
/// the set. Computing the centroid of identical points leaves a rounding error of a few
/// `f64::EPSILON` times the coordinates, so truly coincident points give a ratio around
/// `1e-16 .. 1e-14`. A set whose extent is below `1e-12` of its offset from the origin keeps
/// almost no significant digits of shape after centring and cannot be normalized
/// meaningfully.
pub const COINCIDENCE_THRESHOLD: f64 = 1e-12;

/// Eigenvalue ratio `lambda_min / lambda_max` of the normalized `2 x 2` scatter matrix below
/// which a point set is reported as collinear.
///
/// The ratio is the squared aspect ratio (minor over major spread) of the point cloud. For
/// exactly collinear input the computed ratio is rounding noise of order `1e-16`. A value of
/// `1e-12` means the points deviate from a line by less than a millionth of their extent,
/// e.g. under a thousandth of a pixel along a 1000 px line: far below any corner detector's
/// precision, so the set carries no usable two-dimensional information.
pub const COLLINEARITY_THRESHOLD: f64 = 1e-12;

/// Computes the normalization matrix `T` of a point set.
///
/// `T` is the similarity
///
/// ```text
///     [ s  0  -s*cx ]
/// T = [ 0  s  -s*cy ]      s = sqrt(2) * N / sum_i |p_i - c|
///     [ 0  0    1   ]
/// ```
///
/// where `c = (cx, cy)` is the centroid. Applied to homogeneous points `(x, y, 1)` it moves
/// the centroid to the origin and makes the mean distance from the origin `sqrt(2)`. The
/// points may be in any unit (pixels, millimetres, metres); `T` carries the inverse unit.
///
/// # Errors
///
/// * [`HomographyError::TooFewPoints`] for an empty slice,
/// * [`HomographyError::NonFinite`] if a coordinate is NaN or infinite,
/// * [`HomographyError::Coincident`] if all points are the same (see
///   [`COINCIDENCE_THRESHOLD`]),
/// * [`HomographyError::DegenerateSolution`] if the coordinates are so large that the
///   centroid or the scale overflows.
///
/// This standalone function does not know which role the points play, so errors that name
/// a point set report [`PointSet::Object`].
pub fn normalization_matrix(points: &[Point2<f64>]) -> Result<Matrix3<f64>, HomographyError> {
    normalization_matrix_for(points, PointSet::Object)
}

/// [`normalization_matrix`] with the point set named in the errors.
pub(crate) fn normalization_matrix_for(
    points: &[Point2<f64>],
    set: PointSet,
) -> Result<Matrix3<f64>, HomographyError> {
    if points.is_empty() {
        return Err(HomographyError::TooFewPoints { found: 0 });
    }
    if let Some(index) = points
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite()))
    {
        return Err(HomographyError::NonFinite { index, set });
    }

    let n = points.len() as f64;
    let (sum_x, sum_y) = points
        .iter()
        .fold((0.0, 0.0), |(sx, sy), p| (sx + p.x, sy + p.y));
    let (cx, cy) = (sum_x / n, sum_y / n);
    let mean_distance = points
        .iter()
        .map(|p| ((p.x - cx).powi(2) + (p.y - cy).powi(2)).sqrt())
        .sum::<f64>()
        / n;
    let largest_coordinate = points
        .iter()
        .fold(0.0_f64, |m, p| m.max(p.x.abs()).max(p.y.abs()));

    if !(cx.is_finite() && cy.is_finite() && mean_distance.is_finite()) {
        return Err(HomographyError::DegenerateSolution {
            reason: "point coordinates too large: normalization overflowed",
        });
    }
    if mean_distance <= COINCIDENCE_THRESHOLD * largest_coordinate {
        return Err(HomographyError::Coincident { set });
    }
    let s = std::f64::consts::SQRT_2 / mean_distance;
    if !s.is_finite() {
        return Err(HomographyError::DegenerateSolution {
            reason: "point spread too small to normalize (scale overflowed)",
        });
    }
    Ok(Matrix3::new(
        s,
        0.0,
        -s * cx,
        0.0,
        s,
        -s * cy,
        0.0,
        0.0,
        1.0,
    ))
}

/// Applies a normalization matrix (a similarity with last row `0 0 1`) to a point.
#[inline]
pub(crate) fn apply(t: &Matrix3<f64>, p: &Point2<f64>) -> Point2<f64> {
    Point2::new(
        t[(0, 0)] * p.x + t[(0, 1)] * p.y + t[(0, 2)],
        t[(1, 0)] * p.x + t[(1, 1)] * p.y + t[(1, 2)],
    )
}

/// Inverse of a normalization matrix `[s 0 -s cx; 0 s -s cy; 0 0 1]`, in closed form.
pub(crate) fn inverse(t: &Matrix3<f64>) -> Matrix3<f64> {
    let s = t[(0, 0)];
    let cx = -t[(0, 2)] / s;
    let cy = -t[(1, 2)] / s;
    Matrix3::new(1.0 / s, 0.0, cx, 0.0, 1.0 / s, cy, 0.0, 0.0, 1.0)
}

/// Ratio `lambda_min / lambda_max` of the `2 x 2` scatter matrix of the normalized points
/// `T p_i` (second moments about the origin, which is their centroid). Zero for collinear
/// points, one for an isotropic cloud.
pub(crate) fn scatter_eigen_ratio(points: &[Point2<f64>], t: &Matrix3<f64>) -> f64 {
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for p in points {
        let q = apply(t, p);
        a += q.x * q.x;
        b += q.x * q.y;
        c += q.y * q.y;
    }
    // Eigenvalues of [a b; b c]; the smaller one via det / lambda_max avoids the
    // cancellation of (trace - sqrt(disc)) / 2. The common 1/N factor cancels in the ratio.
    let lambda_max = 0.5 * (a + c) + (0.5 * (a - c)).hypot(b);
    if lambda_max <= 0.0 {
        return 0.0;
    }
    let det = (a * c - b * b).max(0.0);
    det / lambda_max / lambda_max
}

/// Normalizes a point set and checks that it spans the plane.
pub(crate) fn checked_normalization(
    points: &[Point2<f64>],
    set: PointSet,
) -> Result<Matrix3<f64>, HomographyError> {
    let t = normalization_matrix_for(points, set)?;
    let ratio = scatter_eigen_ratio(points, &t);
    if ratio.is_nan() || ratio < COLLINEARITY_THRESHOLD {
        return Err(HomographyError::Collinear { set });
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn normalized_points_have_zero_centroid_and_mean_distance_sqrt2() {
        let pts = [
            Point2::new(100.0, 200.0),
            Point2::new(640.0, 10.0),
            Point2::new(300.0, 470.0),
            Point2::new(5.0, 5.0),
            Point2::new(123.4, 321.0),
        ];
        let t = normalization_matrix(&pts).unwrap();
        let q: Vec<_> = pts.iter().map(|p| apply(&t, p)).collect();
        let n = q.len() as f64;
        let cx = q.iter().map(|p| p.x).sum::<f64>() / n;
        let cy = q.iter().map(|p| p.y).sum::<f64>() / n;
        let md = q.iter().map(|p| p.coords.norm()).sum::<f64>() / n;
        assert!(cx.abs() < 1e-14 && cy.abs() < 1e-14);
        assert_relative_eq!(md, std::f64::consts::SQRT_2, epsilon = 1e-14);
        assert_relative_eq!(inverse(&t) * t, Matrix3::identity(), epsilon = 1e-14);
    }

    #[test]
    fn scatter_ratio_of_square_is_one_and_of_line_is_zero() {
        let square = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 0.0),
            Point2::new(1.0, 1.0),
            Point2::new(0.0, 1.0),
        ];
        let t = normalization_matrix(&square).unwrap();
        assert_relative_eq!(scatter_eigen_ratio(&square, &t), 1.0, epsilon = 1e-14);
        let line: Vec<_> = (0..10)
            .map(|i| Point2::new(0.1 * i as f64, 3.0 + 0.3 * i as f64))
            .collect();
        let t = normalization_matrix(&line).unwrap();
        assert!(scatter_eigen_ratio(&line, &t) < 1e-15);
    }

    #[test]
    fn standalone_errors() {
        assert_eq!(
            normalization_matrix(&[]),
            Err(HomographyError::TooFewPoints { found: 0 })
        );
        assert_eq!(
            normalization_matrix(&[Point2::new(0.1, 0.7); 3]),
            Err(HomographyError::Coincident {
                set: PointSet::Object
            })
        );
        assert_eq!(
            normalization_matrix(&[Point2::new(0.0, 0.0), Point2::new(f64::INFINITY, 1.0)]),
            Err(HomographyError::NonFinite {
                index: 1,
                set: PointSet::Object
            })
        );
        assert!(matches!(
            normalization_matrix(&[Point2::new(1e308, 0.0), Point2::new(1e308, 1.0)]),
            Err(HomographyError::DegenerateSolution { .. })
        ));
    }
}
