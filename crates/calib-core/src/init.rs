//! Closed-form initial guesses: intrinsics from the homographies, then one pose per view.
//!
//! Derivations: `docs/calib-single.md`, sections "Initial intrinsics" and "Initial poses".

use crate::data::ImageSize;
use crate::error::CalibrationError;
use camera_model::{Intrinsics, Pose, nearest_rotation};
use nalgebra::{Matrix3, Vector3};

/// How the common focal length is solved from the stacked orthogonality constraints `a x = b`
/// (`x = 1 / alpha^2`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FocalInit {
    /// Bouguet's choice: the `x` that makes the projection of `a x` on `b` equal to `b`,
    /// `x = <b, b> / <a, b>`.
    #[default]
    Bouguet,
    /// Ordinary least squares, `x = <a, b> / <a, a>`.
    LeastSquares,
}

/// Below this tilt measure in every view (about half the squared tilt angle in radians, so
/// ~0.8 degrees) the focal length is not observable: the constraints vanish for boards parallel
/// to the image plane.
pub const MIN_TILT_MEASURE: f64 = 1e-4;

/// Initial intrinsics from the views' homographies (board plane to pixels, any scale): the
/// principal point at the image centre (OpenCV convention), square pixels, and the focal length
/// from the orthogonality of the board's axes and diagonals.
///
/// For each homography `H`, with `H' = [[1, 0, -cx], [0, 1, -cy], [0, 0, 1]] H`, the images of the
/// board's directions `v1 = H' (1,0,0)`, `v2 = H' (0,1,0)`, `v3 = H' (1,1,0)`, `v4 = H' (1,-1,0)`
/// (each normalized) satisfy `(v1x v2x + v1y v2y) x = -v1z v2z` and the same for `v3, v4`, with
/// `x = 1 / alpha^2`, because the pairs are orthogonal on the board.
pub fn initial_intrinsics(
    homographies: &[Matrix3<f64>],
    image_size: ImageSize,
    method: FocalInit,
) -> Result<Intrinsics, CalibrationError> {
    let (cx, cy) = image_size.centre();
    let shift = Matrix3::new(1.0, 0.0, -cx, 0.0, 1.0, -cy, 0.0, 0.0, 1.0);
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    let mut constraints = Vec::with_capacity(2 * homographies.len());
    for h in homographies {
        let hs = shift * h;
        let c1: Vector3<f64> = hs.column(0).into_owned();
        let c2: Vector3<f64> = hs.column(1).into_owned();
        for (p, q) in [(c1, c2), (c1 + c2, c1 - c2)] {
            let (p, q) = (p.normalize(), q.normalize());
            let a = p.x * q.x + p.y * q.y;
            let b = -p.z * q.z;
            constraints.push(b);
            ab += a * b;
            aa += a * a;
            bb += b * b;
        }
    }
    let alpha2 = match method {
        FocalInit::Bouguet => ab / bb,
        FocalInit::LeastSquares => aa / ab,
    };
    let tilt = constraints.iter().fold(0.0f64, |m, b| m.max(b.abs()));
    // b is about (tilt^2 / 2) / alpha^2 once the v's are normalized, so b alpha^2 measures tilt.
    let tilt_measure = if alpha2.is_finite() && alpha2 > 0.0 {
        tilt * alpha2
    } else {
        0.0
    };
    if !(alpha2.is_finite() && alpha2 > 0.0) || tilt_measure < MIN_TILT_MEASURE {
        return Err(CalibrationError::FrontoParallel { tilt_measure });
    }
    let alpha = alpha2.sqrt();
    Ok(Intrinsics::new(alpha, alpha, cx, cy))
}

/// Initial pose of one view from its homography `H` (any scale) and intrinsics `K`:
/// `K^-1 H = lambda [r1 r2 t]`, with `lambda1 = |K^-1 h1|`, `lambda2 = |K^-1 h2|`,
/// `r1 = K^-1 h1 / lambda1`, `r2 = K^-1 h2 / lambda2`, `r3 = r1 x r2`,
/// `t = K^-1 h3 / ((lambda1 + lambda2) / 2)`, and `[r1 r2 r3]` replaced by the nearest rotation.
/// The sign is chosen so that the board origin is in front of the camera (`t_z > 0`).
pub fn initial_pose(h: &Matrix3<f64>, intrinsics: &Intrinsics) -> Option<Pose> {
    let k_inv = intrinsics.matrix().try_inverse()?;
    let m = k_inv * h;
    let (c1, c2, c3): (Vector3<f64>, Vector3<f64>, Vector3<f64>) = (
        m.column(0).into_owned(),
        m.column(1).into_owned(),
        m.column(2).into_owned(),
    );
    let (l1, l2) = (c1.norm(), c2.norm());
    if !(l1 > 0.0 && l2 > 0.0 && l1.is_finite() && l2.is_finite()) {
        return None;
    }
    let r1 = c1 / l1;
    let r2 = c2 / l2;
    let mut t = c3 / ((l1 + l2) / 2.0);
    let mut r = nearest_rotation(&Matrix3::from_columns(&[r1, r2, r1.cross(&r2)]))?;
    if t.z < 0.0 {
        // H had the opposite sign: -r1, -r2, -t is the same homography; r3 = r1 x r2 is unchanged.
        r.column_mut(0).neg_mut();
        r.column_mut(1).neg_mut();
        t = -t;
    }
    t.iter().all(|v| v.is_finite()).then_some(Pose::new(r, t))
}

#[cfg(test)]
mod tests {
    use super::*;
    use camera_model::{EulerXyz, RotationParameterization};

    fn homography(k: &Intrinsics, pose: &Pose) -> Matrix3<f64> {
        let r = pose.rotation;
        let m = Matrix3::from_columns(&[
            r.column(0).into_owned(),
            r.column(1).into_owned(),
            pose.translation,
        ]);
        k.matrix() * m
    }

    fn pose(angles: [f64; 3], t: [f64; 3]) -> Pose {
        Pose::new(EulerXyz::matrix(&Vector3::from(angles)), Vector3::from(t))
    }

    #[test]
    fn exact_homographies_give_the_exact_focal_length_and_poses() {
        let size = ImageSize::new(640, 480);
        let k = Intrinsics::new(800.0, 800.0, 319.5, 239.5);
        let poses = [
            pose([0.4, -0.2, 0.1], [-0.1, -0.05, 1.0]),
            pose([-0.3, 0.5, -0.7], [0.05, -0.1, 1.5]),
            pose([0.2, 0.3, 2.0], [0.0, 0.1, 0.8]),
        ];
        let hs: Vec<Matrix3<f64>> = poses.iter().map(|p| homography(&k, p) * -3.7).collect();
        for method in [FocalInit::Bouguet, FocalInit::LeastSquares] {
            let guess = initial_intrinsics(&hs, size, method).unwrap();
            assert!((guess.fx - 800.0).abs() < 1e-9 && guess.fy == guess.fx);
            assert_eq!((guess.cx, guess.cy), (319.5, 239.5));
        }
        for (p, h) in poses.iter().zip(&hs) {
            let estimate = initial_pose(h, &k).unwrap();
            assert!((estimate.rotation - p.rotation).norm() < 1e-12);
            assert!((estimate.translation - p.translation).norm() < 1e-12);
        }
    }

    #[test]
    fn fronto_parallel_views_are_rejected() {
        let size = ImageSize::new(640, 480);
        let k = Intrinsics::new(800.0, 800.0, 319.5, 239.5);
        let hs = vec![
            homography(&k, &pose([0.0, 0.0, 0.3], [0.0, 0.0, 1.0])),
            homography(&k, &pose([0.0, 0.0, -1.0], [0.1, 0.0, 2.0])),
        ];
        assert!(matches!(
            initial_intrinsics(&hs, size, FocalInit::Bouguet),
            Err(CalibrationError::FrontoParallel { .. })
        ));
        // A 0.3 degree tilt is still not enough; 3 degrees is.
        let tilted = |deg: f64| {
            vec![homography(
                &k,
                &pose([deg.to_radians(), 0.0, 0.3], [0.0, 0.0, 1.0]),
            )]
        };
        assert!(initial_intrinsics(&tilted(0.3), size, FocalInit::Bouguet).is_err());
        let guess = initial_intrinsics(&tilted(3.0), size, FocalInit::Bouguet).unwrap();
        assert!((guess.fx - 800.0).abs() < 1e-6);
    }
}
