//! Central projections: from a camera-frame point to the projection plane, before distortion.
//!
//! A [`Projection`] maps a point `s` of the camera frame to a 2-D point `m` on which the lens
//! distortion then acts; intrinsics turn the distorted point into pixels (see [`crate::Camera`]).
//! Two projections are implemented:
//!
//! | projection | `m` | valid for |
//! |---|---|---|
//! | [`Pinhole`] | `(x/z, y/z)` | points in front of the camera, `z > 0` |
//! | [`Equidistant`] | `theta (x, y) / r`, `r = |(x, y)|`, `theta = atan2(r, z)` | every direction except straight back (`theta < pi`) |
//!
//! The equidistant projection is the base of fisheye models (Kannala-Brandt, OpenCV's
//! `cv2.fisheye`): the length of `m` is the angle `theta` between the ray and the optical axis, so
//! fields of view of 180 degrees and more are representable, where `x/z` is not. Computing
//! `theta` from the 3-D direction with `atan2` (not `atan(r/z)`) keeps points at and beyond 90
//! degrees off-axis valid.
//!
//! Derivations of the Jacobians: `docs/camera-model.md`, section "Projections".

use crate::error::CameraModelError;
use nalgebra::{Matrix2x3, Unit, Vector2, Vector3};

/// A central projection from the camera frame to the projection plane (no parameters).
pub trait Projection: Copy + Clone + Send + Sync + std::fmt::Debug + PartialEq + 'static {
    /// A short name for reports and files ("pinhole", "equidistant").
    const NAME: &'static str;

    /// The projection-plane point of camera-frame point `s`, or why `s` has none (behind a
    /// pinhole camera, on the negative optical axis of a fisheye, not finite).
    fn project(s: &Vector3<f64>) -> Result<Vector2<f64>, CameraModelError>;

    /// `project(s)` and its Jacobian `dm/ds` (2x3). Must give the same `m` bits as `project`.
    fn project_with_jacobian(
        s: &Vector3<f64>,
    ) -> Result<(Vector2<f64>, Matrix2x3<f64>), CameraModelError>;

    /// The unit ray (camera frame) whose projection is `m`, or `None` if `m` is the image of no
    /// direction (beyond the projection's range).
    fn unproject(m: &Vector2<f64>) -> Option<Unit<Vector3<f64>>>;
}

#[inline]
fn check_finite(s: &Vector3<f64>) -> Result<(), CameraModelError> {
    if s.x.is_finite() && s.y.is_finite() && s.z.is_finite() {
        Ok(())
    } else {
        Err(CameraModelError::NonFinite {
            what: "camera-frame point",
        })
    }
}

/// The pinhole projection `m = (x/z, y/z)` of the calibration text, defined for `z > 0`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Pinhole;

impl Projection for Pinhole {
    const NAME: &'static str = "pinhole";

    #[inline]
    fn project(s: &Vector3<f64>) -> Result<Vector2<f64>, CameraModelError> {
        check_finite(s)?;
        // `!(z > 0)` also rejects NaN.
        if s.z <= 0.0 {
            return Err(CameraModelError::PointBehindCamera { depth: s.z });
        }
        let inv_z = 1.0 / s.z;
        Ok(Vector2::new(s.x * inv_z, s.y * inv_z))
    }

    #[inline]
    fn project_with_jacobian(
        s: &Vector3<f64>,
    ) -> Result<(Vector2<f64>, Matrix2x3<f64>), CameraModelError> {
        check_finite(s)?;
        if s.z <= 0.0 {
            return Err(CameraModelError::PointBehindCamera { depth: s.z });
        }
        let inv_z = 1.0 / s.z;
        let n = Vector2::new(s.x * inv_z, s.y * inv_z);
        let jac = Matrix2x3::new(inv_z, 0.0, -n.x * inv_z, 0.0, inv_z, -n.y * inv_z);
        Ok((n, jac))
    }

    fn unproject(m: &Vector2<f64>) -> Option<Unit<Vector3<f64>>> {
        (m.x.is_finite() && m.y.is_finite())
            .then(|| Unit::new_normalize(Vector3::new(m.x, m.y, 1.0)))
    }
}

/// The equidistant projection `m = theta (x, y) / r` with `r = sqrt(x^2 + y^2)` and
/// `theta = atan2(r, z)`: `|m|` is the angle (radians) between the ray and the optical axis.
/// Defined for every direction except the negative optical axis (`theta = pi`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Equidistant;

/// Below this `r^2 / z^2` the equidistant factors use their Taylor series (see
/// `Equidistant::factors`).
const EQUIDISTANT_SERIES: f64 = 1e-6;

impl Equidistant {
    /// `a = theta / r` and `b = (da/dr) / r`, finite at the optical axis (series for
    /// `r / z < 1e-3`, where the closed forms are 0/0: `a = 1/z - r^2/(3 z^3) + r^4/(5 z^5)`,
    /// `b = -2/(3 z^3) + 4 r^2/(5 z^5)`, truncation below 1e-12 relative).
    #[inline]
    fn factors(s: &Vector3<f64>) -> Result<(f64, f64, f64), CameraModelError> {
        check_finite(s)?;
        let r2 = s.x * s.x + s.y * s.y;
        let z = s.z;
        let rho2 = r2 + z * z;
        if z > 0.0 && r2 < EQUIDISTANT_SERIES * z * z {
            let iz = 1.0 / z;
            let iz3 = iz * iz * iz;
            let a = iz - r2 * iz3 / 3.0 + r2 * r2 * iz3 * iz * iz / 5.0;
            let b = -2.0 * iz3 / 3.0 + 4.0 * r2 * iz3 * iz * iz / 5.0;
            return Ok((a, b, rho2));
        }
        if r2 == 0.0 {
            // On the optical axis behind the camera (or at the centre): no direction.
            return Err(CameraModelError::PointBehindCamera { depth: z });
        }
        let r = r2.sqrt();
        let theta = r.atan2(z);
        let a = theta / r;
        let b = (z * r / rho2 - theta) / (r * r2);
        Ok((a, b, rho2))
    }
}

impl Projection for Equidistant {
    const NAME: &'static str = "equidistant";

    #[inline]
    fn project(s: &Vector3<f64>) -> Result<Vector2<f64>, CameraModelError> {
        let (a, _, _) = Self::factors(s)?;
        Ok(Vector2::new(a * s.x, a * s.y))
    }

    #[inline]
    fn project_with_jacobian(
        s: &Vector3<f64>,
    ) -> Result<(Vector2<f64>, Matrix2x3<f64>), CameraModelError> {
        let (a, b, rho2) = Self::factors(s)?;
        let (x, y) = (s.x, s.y);
        let bxy = b * x * y;
        let jac = Matrix2x3::new(a + b * x * x, bxy, -x / rho2, bxy, a + b * y * y, -y / rho2);
        Ok((Vector2::new(a * x, a * y), jac))
    }

    fn unproject(m: &Vector2<f64>) -> Option<Unit<Vector3<f64>>> {
        let theta = m.norm();
        if !theta.is_finite() || theta >= std::f64::consts::PI {
            return None;
        }
        if theta == 0.0 {
            return Some(Vector3::z_axis());
        }
        let (s, c) = theta.sin_cos();
        Some(Unit::new_normalize(Vector3::new(
            m.x / theta * s,
            m.y / theta * s,
            c,
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lm_solver::numdiff::{central_difference, compare_jacobians};
    use proptest::prelude::*;

    fn check<P: Projection>(s: Vector3<f64>) -> Result<(), TestCaseError> {
        let (m, jac) = P::project_with_jacobian(&s).unwrap();
        prop_assert_eq!(m, P::project(&s).unwrap());
        let numeric = central_difference(
            |v: &[f64], out: &mut [f64]| {
                out.copy_from_slice(
                    P::project(&Vector3::new(v[0], v[1], v[2]))
                        .unwrap()
                        .as_slice(),
                )
            },
            s.as_slice(),
            2,
            1e-6,
        );
        // |m| <= pi and the second derivatives are O(1 / |s|^2) for |s| >= 0.5, so with
        // h = 1e-6 max(|s_i|, 1) the rounding (eps |m| / h <= 7e-10) and truncation
        // (h^2 / 6 |f'''| < 1e-11) errors stay below 1e-6 (|J| + 1e-3) >= 1e-9.
        let r = compare_jacobians(jac.as_slice(), &numeric, 2, 1e-6, 1e-3);
        prop_assert!(r.is_ok(), "{:?} at {s}", r);
        // Unprojection returns the direction of s.
        let ray = P::unproject(&m).unwrap();
        prop_assert!((ray.into_inner() - s.normalize()).norm() < 1e-12);
        Ok(())
    }

    proptest! {
        #[test]
        fn pinhole_jacobian_matches_finite_differences(
            x in -2.0f64..2.0, y in -2.0f64..2.0, z in 0.5f64..3.0
        ) {
            check::<Pinhole>(Vector3::new(x, y, z))?;
        }

        /// Directions from the optical axis to 170 degrees off-axis (beyond 90: behind the
        /// image plane), at distances 0.5 to 3.
        #[test]
        fn equidistant_jacobian_matches_finite_differences(
            theta in 0.0f64..170f64.to_radians(), phi in -3.2f64..3.2, dist in 0.5f64..3.0
        ) {
            let s = dist * Vector3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            check::<Equidistant>(s)?;
            let m = Equidistant::project(&s).unwrap();
            prop_assert!((m.norm() - theta).abs() < 1e-12);
        }
    }

    #[test]
    fn equidistant_is_smooth_across_the_series_boundary() {
        // Just inside and outside r/z = 1e-3 the two forms agree to rounding.
        for r in [0.999e-3, 1.001e-3, 0.0, 1e-9] {
            let s = Vector3::new(r, 0.3 * r, 1.0);
            let (m, j) = Equidistant::project_with_jacobian(&s).unwrap();
            let theta = (s.x.hypot(s.y)).atan2(s.z);
            assert!((m.norm() - theta).abs() < 1e-18 + 1e-15 * theta);
            assert!((j[(0, 0)] - 1.0).abs() < 1e-5 && j[(0, 2)].abs() < 2e-3);
        }
    }

    #[test]
    fn invalid_points_are_errors() {
        assert!(matches!(
            Pinhole::project(&Vector3::new(0.1, 0.2, 0.0)),
            Err(CameraModelError::PointBehindCamera { .. })
        ));
        assert!(Equidistant::project(&Vector3::new(0.1, 0.2, -1.0)).is_ok());
        assert!(matches!(
            Equidistant::project(&Vector3::new(0.0, 0.0, -1.0)),
            Err(CameraModelError::PointBehindCamera { .. })
        ));
        assert!(matches!(
            Equidistant::project(&Vector3::new(f64::NAN, 0.0, 1.0)),
            Err(CameraModelError::NonFinite { .. })
        ));
        assert!(Equidistant::unproject(&Vector2::new(3.2, 0.0)).is_none());
    }
}
