//! The exact homography through four correspondences: the sample fit of
//! [`estimate_robust`](crate::estimate_robust).
//!
//! Four points `p_0 .. p_3` of the plane, no three collinear, form a projective basis: the
//! matrix `A = [l_0 p_0, l_1 p_1, l_2 p_2]` (homogeneous columns) with `(l_0, l_1, l_2)` solving
//! `[p_0 p_1 p_2] l = p_3` maps `e_1, e_2, e_3` and `(1, 1, 1)` to `p_0 .. p_3` up to scale. By
//! Cramer's rule `l_i` is a ratio of the determinants `D(i, j, k) = det [p_i p_j p_k]`, which
//! are twice the signed areas of the triangles of the points; dropping the common denominator,
//!
//! ```text
//! A = [ D(3,1,2) p_0,  D(0,3,2) p_1,  D(0,1,3) p_2 ]
//! ```
//!
//! With `B` built the same way from the image points, `H = B A^-1 ~ B adj(A)` maps every
//! `p_i` to its `q_i`: the unique homography of the four correspondences, which the DLT finds
//! as the null vector of its `8 x 9` system. This takes about a hundred flops instead of the
//! DLT's 9x9 symmetric eigen-decomposition; LMedS fits up to 300 samples per contaminated view,
//! where the eigen-decomposition was over half of the whole calibration's run time.
//!
//! The points are passed in normalized coordinates (the Hartley normalization of the whole
//! view, computed once per view), so every coordinate is of order one and the determinants
//! keep their digits whatever the pixel offsets and board units.

use nalgebra::{Matrix3, Point2};

use crate::PointSet;
use crate::error::HomographyError;
use crate::normalization::{apply, inverse, normalization_matrix_for};
use crate::validate::scale_to_unit_h33;

/// Smallest accepted `|D(i, j, k)| / d^2` of a sample, where `D(i, j, k)` is twice the area of
/// a triangle of three of its four points and `d` the largest distance between two of them:
/// below it the sample has three (nearly) collinear points in the plane or in the image, and
/// no usable homography.
///
/// The ratio is the height of the triangle over the sample's extent (at most one), independent
/// of units and of the normalization. Exactly collinear points give rounding noise of order
/// `1e-16`; at `1e-6` the determinants still carry ten significant digits. This is the same
/// margin as the DLT's [`RANK_THRESHOLD`](crate::RANK_THRESHOLD), whose `sigma_8 / sigma_1` for
/// four points shrinks in proportion to that height.
pub(crate) const SAMPLE_DEGENERACY_THRESHOLD: f64 = 1e-6;

/// `det [a b c]` of the homogeneous points `(x, y, 1)`: twice the signed area of the triangle.
#[inline]
fn area2(a: &Point2<f64>, b: &Point2<f64>, c: &Point2<f64>) -> f64 {
    (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)
}

/// The matrix mapping `e_1, e_2, e_3, (1, 1, 1)` to `p_0 .. p_3` up to scale, or `None` when
/// three of the points are collinear (see [`SAMPLE_DEGENERACY_THRESHOLD`]).
#[inline]
fn projective_basis(p: &[Point2<f64>; 4]) -> Option<Matrix3<f64>> {
    let d012 = area2(&p[0], &p[1], &p[2]);
    let l0 = area2(&p[3], &p[1], &p[2]);
    let l1 = area2(&p[0], &p[3], &p[2]);
    let l2 = area2(&p[0], &p[1], &p[3]);
    let mut extent2 = 0.0_f64;
    for i in 0..4 {
        for j in i + 1..4 {
            extent2 = extent2.max((p[i] - p[j]).norm_squared());
        }
    }
    let limit = SAMPLE_DEGENERACY_THRESHOLD * extent2;
    // A single repeated point gives limit 0 and determinants 0: refused too.
    if limit.is_nan()
        || [d012, l0, l1, l2]
            .iter()
            .any(|d| d.is_nan() || d.abs() <= limit)
    {
        return None;
    }
    Some(Matrix3::new(
        l0 * p[0].x,
        l1 * p[1].x,
        l2 * p[2].x,
        l0 * p[0].y,
        l1 * p[1].y,
        l2 * p[2].y,
        l0,
        l1,
        l2,
    ))
}

/// The adjugate (transposed cofactor matrix): `A^-1` times `det A`, without the division.
#[inline]
fn adjugate(m: &Matrix3<f64>) -> Matrix3<f64> {
    let c = |i: usize, j: usize| m[(i, j)];
    Matrix3::new(
        c(1, 1) * c(2, 2) - c(1, 2) * c(2, 1),
        c(0, 2) * c(2, 1) - c(0, 1) * c(2, 2),
        c(0, 1) * c(1, 2) - c(0, 2) * c(1, 1),
        c(1, 2) * c(2, 0) - c(1, 0) * c(2, 2),
        c(0, 0) * c(2, 2) - c(0, 2) * c(2, 0),
        c(0, 2) * c(1, 0) - c(0, 0) * c(1, 2),
        c(1, 0) * c(2, 1) - c(1, 1) * c(2, 0),
        c(0, 1) * c(2, 0) - c(0, 0) * c(2, 1),
        c(0, 0) * c(1, 1) - c(0, 1) * c(1, 0),
    )
}

/// The homography (arbitrary scale) with `H p_i ~ q_i` for the four correspondences, or `None`
/// when three points of either set are collinear: such a sample determines no homography
/// (only a singular matrix, or a one-parameter family).
#[inline]
pub(crate) fn four_point(p: &[Point2<f64>; 4], q: &[Point2<f64>; 4]) -> Option<Matrix3<f64>> {
    let a = projective_basis(p)?;
    let b = projective_basis(q)?;
    Some(b * adjugate(&a))
}

/// The four-point fits of one view: its points in the view's normalized coordinates, computed
/// once, so that each sample costs a gather, [`four_point`] and two 3x3 products.
pub(crate) struct SampleSolver {
    object: Vec<Point2<f64>>,
    image: Vec<Point2<f64>>,
    t_object: Matrix3<f64>,
    t_image_inverse: Matrix3<f64>,
}

impl SampleSolver {
    /// Normalizes the view's points (same errors as
    /// [`normalization_matrix`](crate::normalization_matrix), for either set).
    pub(crate) fn new(
        object: &[Point2<f64>],
        image: &[Point2<f64>],
    ) -> Result<Self, HomographyError> {
        let t_object = normalization_matrix_for(object, PointSet::Object)?;
        let t_image = normalization_matrix_for(image, PointSet::Image)?;
        Ok(Self {
            object: object.iter().map(|p| apply(&t_object, p)).collect(),
            image: image.iter().map(|p| apply(&t_image, p)).collect(),
            t_object,
            t_image_inverse: inverse(&t_image),
        })
    }

    /// The homography in the caller's units of the points `idx` (`H33 = 1`), or `None` for a
    /// degenerate sample: three collinear points (see [`SAMPLE_DEGENERACY_THRESHOLD`]) or, as
    /// for [`dlt`](fn@crate::dlt), a board origin mapped to infinity. `object` is the slice given to
    /// [`SampleSolver::new`].
    #[inline]
    pub(crate) fn solve(&self, object: &[Point2<f64>], idx: &[usize; 4]) -> Option<Matrix3<f64>> {
        let h = four_point(&idx.map(|i| self.object[i]), &idx.map(|i| self.image[i]))?;
        let h = self.t_image_inverse * h * self.t_object;
        scale_to_unit_h33(&h, &idx.map(|i| object[i])).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dlt::dlt;
    use proptest::prelude::*;

    fn relative_difference(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
        (a - b).norm() / b.norm()
    }

    /// `H = K [r1 r2 t]` for a board tilted by `tilt` (radians) about an in-plane axis at
    /// `axis` and spun by `spin`, its origin at depth `z` (board units).
    fn pose_homography(tilt: f64, axis: f64, spin: f64, z: f64) -> Matrix3<f64> {
        use nalgebra::{Rotation3, Unit, Vector3};
        let k = Matrix3::new(800.0, 0.0, 320.0, 0.0, 790.0, 240.0, 0.0, 0.0, 1.0);
        let r = Rotation3::from_axis_angle(
            &Unit::new_normalize(Vector3::new(axis.cos(), axis.sin(), 0.0)),
            tilt,
        ) * Rotation3::from_axis_angle(&Vector3::z_axis(), spin);
        let rm = r.matrix();
        let mut rt = Matrix3::zeros();
        rt.set_column(0, &rm.column(0));
        rt.set_column(1, &rm.column(1));
        rt.set_column(2, &Vector3::new(-100.0, -60.0, z));
        k * rt
    }

    /// Smallest `|D(i, j, k)| / d^2` over the four triangles of a sample.
    fn min_triangle_ratio(p: &[Point2<f64>; 4]) -> f64 {
        let mut extent2 = 0.0_f64;
        for i in 0..4 {
            for j in i + 1..4 {
                extent2 = extent2.max((p[i] - p[j]).norm_squared());
            }
        }
        [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]
            .iter()
            .map(|t| area2(&p[t[0]], &p[t[1]], &p[t[2]]).abs() / extent2)
            .fold(f64::INFINITY, f64::min)
    }

    /// The sample fit as [`estimate_robust`](crate::estimate_robust) runs it, with the
    /// normalization of a larger view.
    fn solve_in_view(
        view_object: &[Point2<f64>],
        view_image: &[Point2<f64>],
        idx: [usize; 4],
    ) -> Option<Matrix3<f64>> {
        SampleSolver::new(view_object, view_image)
            .unwrap()
            .solve(view_object, &idx)
    }

    #[test]
    fn reproduces_the_dlt_on_a_board_view() {
        let h_true = pose_homography(0.6, 0.4, 0.3, 600.0);
        let object: Vec<_> = (0..54)
            .map(|i| Point2::new(25.0 * (i % 9) as f64, 25.0 * (i / 9) as f64))
            .collect();
        let image: Vec<_> = object.iter().map(|p| h_true.transform_point(p)).collect();
        // Corners of the board, a compact sample and a skewed one; none has three collinear.
        for idx in [[0, 8, 53, 45], [10, 12, 30, 19], [1, 17, 46, 33]] {
            let h = solve_in_view(&object, &image, idx).expect("general position");
            let o: Vec<_> = idx.iter().map(|&i| object[i]).collect();
            let m: Vec<_> = idx.iter().map(|&i| image[i]).collect();
            let reference = dlt(&o, &m).unwrap();
            assert!(relative_difference(&h, &reference) < 1e-12, "{idx:?}");
            assert!(relative_difference(&h, &(h_true / h_true[(2, 2)])) < 1e-12);
            assert_eq!(h[(2, 2)], 1.0);
        }
    }

    #[test]
    fn refuses_three_collinear_points_in_either_set() {
        let h_true = pose_homography(0.5, 1.0, -0.2, 500.0);
        let object: Vec<_> = (0..54)
            .map(|i| Point2::new(25.0 * (i % 9) as f64, 25.0 * (i / 9) as f64))
            .collect();
        let image: Vec<_> = object.iter().map(|p| h_true.transform_point(p)).collect();
        // Three corners of one row, of one column, of a diagonal; and all four on a row.
        for idx in [
            [0, 3, 7, 30],
            [2, 11, 47, 40],
            [0, 10, 20, 5],
            [9, 10, 12, 17],
        ] {
            assert_eq!(solve_in_view(&object, &image, idx), None, "{idx:?}");
        }
        // Collinear in the plane only (the image points noisy): no homography maps a line
        // off a line; the DLT returns a singular matrix here, the four-point fit nothing.
        let mut noisy = image.clone();
        noisy[3].y += 0.3;
        assert_eq!(solve_in_view(&object, &noisy, [0, 3, 7, 30]), None);
        // Collinear in the image only.
        let mut object2 = object.clone();
        object2[3].y += 0.5;
        assert_eq!(solve_in_view(&object2, &image, [0, 3, 7, 30]), None);
        // A repeated point.
        let mut repeated = image.clone();
        repeated[30] = repeated[0];
        assert_eq!(solve_in_view(&object, &repeated, [0, 3, 30, 40]), None);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        /// Random camera poses and random well-spread samples: the four-point fit is the DLT's
        /// homography to rounding.
        #[test]
        fn agrees_with_the_dlt(
            tilt in 0.0..1.0_f64,
            axis in 0.0..std::f64::consts::TAU,
            spin in -3.2..3.2_f64,
            z in 300.0..3000.0_f64,
            coords in proptest::array::uniform8(0.0..200.0_f64),
        ) {
            let h_true = pose_homography(tilt, axis, spin, z);
            let o = [0, 2, 4, 6].map(|k| Point2::new(coords[k], coords[k + 1]));
            let m = o.map(|p| h_true.transform_point(&p));
            prop_assume!(min_triangle_ratio(&o) > 0.05 && min_triangle_ratio(&m) > 0.05);
            let h = solve_in_view(&o, &m, [0, 1, 2, 3]).unwrap();
            let reference = dlt(&o, &m).unwrap();
            prop_assert!(relative_difference(&h, &reference) < 1e-9,
                "{} {h} {reference}", relative_difference(&h, &reference));
            for (p, q) in o.iter().zip(&m) {
                prop_assert!((h.transform_point(p) - q).norm() < 1e-9 * q.coords.norm());
            }
        }
    }
}
