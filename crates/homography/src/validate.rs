//! Input validation shared by [`dlt`](fn@crate::dlt) and [`refine`](fn@crate::refine), and the
//! `H33 = 1` scaling with its degeneracy test.

use nalgebra::{Matrix3, Point2};

use crate::error::{HomographyError, PointSet};
use crate::normalization::checked_normalization;

/// Threshold on `|H33| / max_i |w'_i|` below which `H33` is treated as zero.
///
/// `H33` is the homogeneous scale `w'` of the plane origin, and `w'_i = h3 . (X_i, Y_i, 1)`
/// is the same quantity at the data points, so the ratio is independent of the overall
/// scale of `H` and of the unit of the plane coordinates. When it is tiny the origin sits
/// (numerically) on the vanishing line of the plane: dividing by `H33` would multiply the
/// rounding noise of the linear solution (about `1e-15` relative) by more than `1e9`,
/// and the `H33 = 1` parametrization of the refinement would be meaningless.
pub const H33_THRESHOLD: f64 = 1e-9;

/// Checks the pairing, the count and the finiteness of the correspondences.
pub(crate) fn check_correspondences(
    object: &[Point2<f64>],
    image: &[Point2<f64>],
) -> Result<(), HomographyError> {
    if object.len() != image.len() {
        return Err(HomographyError::LengthMismatch {
            object: object.len(),
            image: image.len(),
        });
    }
    if object.len() < 4 {
        return Err(HomographyError::TooFewPoints {
            found: object.len(),
        });
    }
    for (points, set) in [(object, PointSet::Object), (image, PointSet::Image)] {
        if let Some(index) = points
            .iter()
            .position(|p| !(p.x.is_finite() && p.y.is_finite()))
        {
            return Err(HomographyError::NonFinite { index, set });
        }
    }
    Ok(())
}

/// Full validation of a correspondence set: pairing, count, finiteness, and that both sets
/// span the plane. Returns the normalization matrices `(T_M, T_m)` of the object and the
/// image points.
pub(crate) fn check_configuration(
    object: &[Point2<f64>],
    image: &[Point2<f64>],
) -> Result<(Matrix3<f64>, Matrix3<f64>), HomographyError> {
    check_correspondences(object, image)?;
    let t_object = checked_normalization(object, PointSet::Object)?;
    let t_image = checked_normalization(image, PointSet::Image)?;
    Ok((t_object, t_image))
}

/// Divides `h` by its `H33` entry after checking that this is possible (see
/// [`H33_THRESHOLD`]) and that the result is finite.
pub(crate) fn scale_to_unit_h33(
    h: &Matrix3<f64>,
    object: &[Point2<f64>],
) -> Result<Matrix3<f64>, HomographyError> {
    if !h.iter().all(|v| v.is_finite()) {
        return Err(HomographyError::DegenerateSolution {
            reason: "the homography has non-finite entries",
        });
    }
    let largest_w = object.iter().fold(0.0_f64, |m, p| {
        m.max((h[(2, 0)] * p.x + h[(2, 1)] * p.y + h[(2, 2)]).abs())
    });
    let h33 = h[(2, 2)];
    let limit = H33_THRESHOLD * largest_w;
    if limit.is_nan() || h33.abs() <= limit {
        return Err(HomographyError::DegenerateSolution {
            reason: "H33 is numerically zero: the plane origin maps to infinity",
        });
    }
    let scaled = h / h33;
    if !scaled.iter().all(|v| v.is_finite()) {
        return Err(HomographyError::DegenerateSolution {
            reason: "the homography overflows when scaled to H33 = 1",
        });
    }
    Ok(scaled)
}
