//! Normalized direct linear transform (DLT): the linear estimate of `H`.
//!
//! For a correspondence `M = (X, Y, 1)` (plane) and `(x, y)` (pixel), the projection
//! `x = h1.M / h3.M`, `y = h2.M / h3.M` (with `hk` the rows of `H`) becomes linear in the
//! nine entries of `H` after multiplying out the denominators:
//!
//! ```text
//! h1.M - x h3.M = 0
//! h2.M - y h3.M = 0
//! ```
//!
//! Stacking both equations for all points gives `L h = 0` with `L` of size `2N x 9` and `h`
//! the rows of `H` concatenated. The least-squares solution with `|h| = 1` is the right
//! singular vector of the smallest singular value. The system is built from normalized
//! points (see [`normalization`](crate::normalization_matrix)), and the normalization is
//! undone afterwards: `H = T_m^-1 H' T_M`.

use nalgebra::{DMatrix, Matrix3, Point2, SVD};

use crate::error::HomographyError;
use crate::normalization::{apply, inverse};
use crate::validate::{check_configuration, scale_to_unit_h33};

/// Relative threshold on the singular values of the normalized DLT matrix `L'` that defines
/// its numerical rank: `sigma_i` counts when `sigma_i > RANK_THRESHOLD * sigma_1`.
///
/// A homography needs rank 8 (a one-dimensional null space). Exact degeneracies, such as
/// repeated points or three collinear points out of four, leave the second smallest
/// singular value at rounding level (below `1e-15 * sigma_1` for the order-one entries of
/// the normalized system). Configurations in general position give ratios that reflect the
/// geometry: about `0.25` for full chessboard views, and still around the relative size of
/// the offset when a point is moved slightly off a degenerate position. `1e-10` leaves
/// margins of several orders of magnitude on both sides.
pub const RANK_THRESHOLD: f64 = 1e-10;

/// Upper bound on the total number of implicit-shift SVD iterations (a 9-column problem
/// converges in a few dozen).
const SVD_MAX_ITERATIONS: usize = 10_000;

/// Estimates the homography with the normalized DLT, without nonlinear refinement.
///
/// `object` holds plane coordinates `(X, Y)` in board units, `image` the matching pixel
/// coordinates `(x, y)` in the caller's convention (in practice OpenCV's: `(0, 0)` is the
/// centre of the top-left pixel, `x` right, `y` down). The result maps `(X, Y, 1)` to
/// homogeneous pixels and is scaled so that `H[(2, 2)] == 1`.
///
/// The DLT minimizes an algebraic error, not the pixel distance; use
/// [`estimate`](crate::estimate) to follow it with the geometric refinement.
///
/// # Errors
///
/// * [`HomographyError::LengthMismatch`], [`HomographyError::TooFewPoints`] (fewer than 4),
///   [`HomographyError::NonFinite`]: malformed input;
/// * [`HomographyError::Coincident`], [`HomographyError::Collinear`]: a point set does not
///   span the plane;
/// * [`HomographyError::RankDeficient`]: the points do not determine a unique homography
///   (see [`RANK_THRESHOLD`]);
/// * [`HomographyError::DegenerateSolution`]: the solution has `H33 ~ 0` (see
///   [`H33_THRESHOLD`](crate::H33_THRESHOLD)) or the SVD failed.
pub fn dlt(object: &[Point2<f64>], image: &[Point2<f64>]) -> Result<Matrix3<f64>, HomographyError> {
    let (t_object, t_image) = check_configuration(object, image)?;

    // With exactly four points L' has 8 rows; the thin SVD of an 8 x 9 matrix would only
    // return 8 right singular vectors and miss the null vector. A zero row changes neither
    // the solution nor the singular values but makes V^T square.
    let rows = (2 * object.len()).max(9);
    let mut l = DMatrix::<f64>::zeros(rows, 9);
    for (i, (m_obj, m_img)) in object.iter().zip(image).enumerate() {
        let p = apply(&t_object, m_obj);
        let q = apply(&t_image, m_img);
        let r = 2 * i;
        l[(r, 0)] = p.x;
        l[(r, 1)] = p.y;
        l[(r, 2)] = 1.0;
        l[(r, 6)] = -q.x * p.x;
        l[(r, 7)] = -q.x * p.y;
        l[(r, 8)] = -q.x;
        l[(r + 1, 3)] = p.x;
        l[(r + 1, 4)] = p.y;
        l[(r + 1, 5)] = 1.0;
        l[(r + 1, 6)] = -q.y * p.x;
        l[(r + 1, 7)] = -q.y * p.y;
        l[(r + 1, 8)] = -q.y;
    }

    let svd = SVD::try_new_unordered(l, false, true, f64::EPSILON, SVD_MAX_ITERATIONS).ok_or(
        HomographyError::DegenerateSolution {
            reason: "the SVD of the DLT system did not converge",
        },
    )?;
    let v_t = svd
        .v_t
        .as_ref()
        .ok_or(HomographyError::DegenerateSolution {
            reason: "the SVD did not return right singular vectors",
        })?;
    let sigma = &svd.singular_values;
    if !sigma.iter().all(|s| s.is_finite()) {
        return Err(HomographyError::DegenerateSolution {
            reason: "the SVD of the DLT system produced non-finite values",
        });
    }

    let largest = sigma.max();
    let rank = sigma
        .iter()
        .filter(|&&s| s > RANK_THRESHOLD * largest)
        .count();
    if rank < 8 {
        return Err(HomographyError::RankDeficient { rank });
    }
    let smallest = (0..sigma.len())
        .min_by(|&a, &b| sigma[a].total_cmp(&sigma[b]))
        .unwrap_or(0);
    let x = v_t.row(smallest);

    // Entries of x are the rows of H' one after the other; Matrix3::new is row-major.
    let h_normalized = Matrix3::new(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8]);
    let h = inverse(&t_image) * h_normalized * t_object;
    scale_to_unit_h33(&h, object)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(h: &Matrix3<f64>, p: &Point2<f64>) -> Point2<f64> {
        h.transform_point(p)
    }

    #[test]
    fn four_points_give_the_exact_homography() {
        // The minimal case exercises the zero-row padding of the 8 x 9 system.
        let h_true = Matrix3::new(812.0, -35.0, 310.0, 20.0, 790.0, 250.0, 0.05, -0.02, 1.0);
        let object = [
            Point2::new(0.0, 0.0),
            Point2::new(0.24, 0.0),
            Point2::new(0.24, 0.15),
            Point2::new(0.0, 0.15),
        ];
        let image: Vec<_> = object.iter().map(|p| map(&h_true, p)).collect();
        let h = dlt(&object, &image).unwrap();
        assert!((h - h_true).norm() / h_true.norm() < 1e-12, "{h}");
        assert_eq!(h[(2, 2)], 1.0);
    }
}
