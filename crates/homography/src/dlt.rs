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

use nalgebra::{Matrix3, Point2, SMatrix, SymmetricEigen};

use crate::error::HomographyError;
use crate::normalization::{apply, inverse};
use crate::validate::{check_configuration, scale_to_unit_h33};

/// Relative threshold on the singular values of the normalized DLT matrix `L'` that defines
/// its numerical rank: `sigma_i` counts when `sigma_i > RANK_THRESHOLD * sigma_1`.
///
/// A homography needs rank 8 (a one-dimensional null space). The singular values are the square
/// roots of the eigenvalues of the 9x9 normal matrix `L'^T L'`, whose rounding errors are about
/// `eps * sigma_1^2`; an exactly degenerate configuration (repeated points, three collinear
/// points out of four) therefore shows `sigma_8` at about `sqrt(eps) * sigma_1 ~ 1.5e-8 sigma_1`.
/// Configurations in general position give ratios that reflect the geometry: about `0.25` for
/// full chessboard views. `1e-6` sits two orders of magnitude above the rounding level and five
/// below real views.
pub const RANK_THRESHOLD: f64 = 1e-6;

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
///   [`H33_THRESHOLD`](crate::H33_THRESHOLD)) or the system has non-finite entries.
pub fn dlt(object: &[Point2<f64>], image: &[Point2<f64>]) -> Result<Matrix3<f64>, HomographyError> {
    let (t_object, t_image) = check_configuration(object, image)?;

    // M = L'^T L', accumulated point by point: each point adds the two rows
    // [p.x, p.y, 1, 0, 0, 0, -q.x p.x, -q.x p.y, -q.x] and [0, 0, 0, p.x, p.y, 1, -q.y p.x, ...],
    // whose six non-zeros each give 21 products. The null vector of L' is the eigenvector of M
    // with the smallest eigenvalue; Hartley's normalization keeps L' well conditioned, so the
    // squared condition number of M costs no accuracy that matters here, and M is 9x9 whatever
    // the number of points.
    let mut m = SMatrix::<f64, 9, 9>::zeros();
    for (m_obj, m_img) in object.iter().zip(image) {
        let p = apply(&t_object, m_obj);
        let q = apply(&t_image, m_img);
        for (offset, target) in [(0usize, q.x), (3, q.y)] {
            let values = [p.x, p.y, 1.0, -target * p.x, -target * p.y, -target];
            let columns = [offset, offset + 1, offset + 2, 6, 7, 8];
            for (a, &ca) in columns.iter().enumerate() {
                for (b, &cb) in columns.iter().enumerate().skip(a) {
                    m[(ca, cb)] += values[a] * values[b];
                }
            }
        }
    }
    let m = SMatrix::<f64, 9, 9>::from_fn(|i, j| if i <= j { m[(i, j)] } else { m[(j, i)] });
    if !m.iter().all(|v| v.is_finite()) {
        return Err(HomographyError::DegenerateSolution {
            reason: "the DLT system has non-finite entries",
        });
    }
    let eigen = SymmetricEigen::new(m);
    let lambda = &eigen.eigenvalues;
    let largest = lambda.max();
    let sigma_threshold = RANK_THRESHOLD * largest.max(0.0).sqrt();
    let rank = lambda
        .iter()
        .filter(|&&l| l.max(0.0).sqrt() > sigma_threshold)
        .count();
    if rank < 8 {
        return Err(HomographyError::RankDeficient { rank });
    }
    let smallest = (0..9)
        .min_by(|&a, &b| lambda[a].total_cmp(&lambda[b]))
        .unwrap_or(0);
    let x = eigen.eigenvectors.column(smallest);

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
