//! Inverse projection: from distorted pixels back to normalized coordinates and viewing rays.
//!
//! Distortion models have no closed-form inverse, so [`undistort_normalized`] solves
//! `distortion(n) = target` by Newton's method with the model's analytic 2x2 Jacobian, halving
//! the step whenever a full step would not reduce the error. Newton converges quadratically near
//! the solution, so a handful of iterations reach the rounding level, far below the fixed-point
//! iteration OpenCV uses by default.

use crate::camera::Camera;
use crate::distortion::LensDistortion;
use crate::error::CameraModelError;
use crate::projection::Projection;
use nalgebra::{Matrix2, Unit, Vector2, Vector3};

/// Settings of the iterative undistortion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UndistortOptions {
    /// Maximum number of Newton iterations (default 50).
    pub max_iterations: usize,
    /// Stop when `|distortion(n) - target| <= tolerance * max(1, |target|)`, normalized units
    /// (default `1e-14`: about 2e-11 px for a 2000 px focal length). Where no step reduces the
    /// error any more (the rounding floor of the map), an error up to `1e-10 * max(1, |target|)`
    /// (1e-7 px at a 1000 px focal length) is accepted.
    pub tolerance: f64,
}

impl Default for UndistortOptions {
    fn default() -> Self {
        Self {
            max_iterations: 50,
            tolerance: 1e-14,
        }
    }
}

/// Largest error (normalized units, relative to `max(1, |target|)`) accepted when no Newton step
/// reduces it any more, whatever the tolerance: the map cannot be evaluated more exactly there.
/// A rational fit whose numerator and denominator nearly share a root inside the image (both
/// about 4e-5 at `r^2 = 0.153` in `undistortion_crosses_a_near_cancelling_root_pair`) evaluates
/// its radial factor with relative rounding errors near 1e-16 / 4e-5, so Newton stalls at
/// residuals of 1e-13 to 1e-12 there; 1e-10 is 1e-7 px at a 1000 px focal length, far below any
/// corner's noise, and far below the error left by a target beyond a fold (which has no
/// preimage).
const ROUNDING_FLOOR: f64 = 1e-10;

/// Points checked between the principal point and a solution by [`on_valid_branch`].
const BRANCH_SAMPLES: usize = 16;
/// Steps of the continuation from the principal point (`target` scaled by `i / STAGES`) tried
/// when Newton's method from the target itself ends off the valid branch.
const CONTINUATION_STAGES: usize = 16;

/// True when `n` lies on the branch of the distortion map that starts at the principal point:
/// inside the rational denominator's first root, with a positive Jacobian determinant and
/// denominator at `n` and at [`BRANCH_SAMPLES`] points on the way to it.
fn on_valid_branch<D: LensDistortion>(distortion: &D, n: &Vector2<f64>) -> bool {
    if distortion
        .pole_radius()
        .is_some_and(|pole| n.norm() >= pole)
    {
        return false;
    }
    (1..=BRANCH_SAMPLES).all(|i| {
        let m = n * (i as f64 / BRANCH_SAMPLES as f64);
        let (_, jacobian, _) = distortion.distort_with_jacobians(&m);
        jacobian.determinant() > 0.0 && distortion.denominator(&m).is_none_or(|q| q > 0.0)
    })
}

/// The ideal normalized point `n` with `distortion.distort(n) == target`, on the branch of the
/// distortion map that starts at the principal point (where the model is valid,
/// `crate::validity`).
///
/// Newton's method starts at `target`. Near a fold or a pole of a fitted model it can converge to
/// a second preimage beyond it (a direction the lens does not image there); such a solution is
/// refused, and the branch is then followed from the principal point (`target` scaled up in
/// [`CONTINUATION_STAGES`] steps, each solved from the last).
///
/// Errors: a non-finite target; a singular distortion Jacobian on the way or no convergence within
/// `options.max_iterations` (typical when `target` lies beyond the radius where the model folds
/// back, e.g. far outside the calibrated image area); or
/// [`CameraModelError::UndistortBeyondValidRegion`] when every solution found lies beyond a fold
/// or pole.
pub fn undistort_normalized<D: LensDistortion>(
    distortion: &D,
    target: &Vector2<f64>,
    options: &UndistortOptions,
) -> Result<Vector2<f64>, CameraModelError> {
    if !(target.x.is_finite() && target.y.is_finite()) {
        return Err(CameraModelError::NonFinite {
            what: "point to undistort",
        });
    }
    let direct = newton(distortion, target, *target, options, |_, _| true);
    if let Ok(n) = direct
        && on_valid_branch(distortion, &n)
    {
        return Ok(n);
    }
    // Each stage's steps stay on the branch: next to a pole the map crowds the outer pixels into
    // a thin band of directions, and a full step would leave it for the far side of the pole.
    let pole = distortion.pole_radius().unwrap_or(f64::INFINITY);
    let on_branch = |m: &Vector2<f64>, jacobian: &Matrix2<f64>| {
        m.norm() < pole
            && jacobian.determinant() > 0.0
            && distortion.denominator(m).is_none_or(|q| q > 0.0)
    };
    let mut n = Vector2::zeros();
    for stage in 1..=CONTINUATION_STAGES {
        let scaled = target * (stage as f64 / CONTINUATION_STAGES as f64);
        n = match newton(distortion, &scaled, n, options, on_branch) {
            Ok(n) => n,
            // Newton from the target found a solution, off the branch: say so.
            Err(_) if direct.is_ok() => return Err(CameraModelError::UndistortBeyondValidRegion),
            Err(e) => return Err(e),
        };
    }
    if on_valid_branch(distortion, &n) {
        Ok(n)
    } else {
        Err(CameraModelError::UndistortBeyondValidRegion)
    }
}

/// Newton's method for `distortion(n) = target` from `start`, halving steps that do not reduce
/// the error or land where `admissible(point, jacobian)` is false.
fn newton<D: LensDistortion>(
    distortion: &D,
    target: &Vector2<f64>,
    start: Vector2<f64>,
    options: &UndistortOptions,
    admissible: impl Fn(&Vector2<f64>, &Matrix2<f64>) -> bool,
) -> Result<Vector2<f64>, CameraModelError> {
    let tolerance = options.tolerance * target.norm().max(1.0);
    let mut n = start;
    let (d, mut jac, _) = distortion.distort_with_jacobians(&n);
    let mut error = d - target;
    let mut error_norm = error.norm();
    for iteration in 0..options.max_iterations {
        if error_norm <= tolerance {
            return Ok(n);
        }
        let det = jac.determinant();
        if !det.is_finite() || det.abs() <= 1e-12 * jac.norm_squared() {
            return Err(CameraModelError::UndistortSingular);
        }
        // 2x2 inverse by the adjugate.
        let step = -Vector2::new(
            jac[(1, 1)] * error.x - jac[(0, 1)] * error.y,
            -jac[(1, 0)] * error.x + jac[(0, 0)] * error.y,
        ) / det;
        let mut scale = 1.0;
        let mut improved = false;
        for _ in 0..30 {
            let candidate = n + scale * step;
            let (cd, cjac, _) = distortion.distort_with_jacobians(&candidate);
            let candidate_error = cd - target;
            let candidate_norm = candidate_error.norm();
            if candidate_norm < error_norm && admissible(&candidate, &cjac) {
                n = candidate;
                jac = cjac;
                error = candidate_error;
                error_norm = candidate_norm;
                improved = true;
                break;
            }
            scale *= 0.5;
        }
        if !improved {
            // No step reduces the error: at the rounding floor if we are close, stuck otherwise.
            if error_norm <= (16.0 * tolerance).max(ROUNDING_FLOOR * target.norm().max(1.0)) {
                return Ok(n);
            }
            return Err(CameraModelError::UndistortNotConverged {
                iterations: iteration + 1,
                residual: error_norm,
            });
        }
    }
    if error_norm <= tolerance {
        Ok(n)
    } else {
        Err(CameraModelError::UndistortNotConverged {
            iterations: options.max_iterations,
            residual: error_norm,
        })
    }
}

impl<D: LensDistortion, P: Projection> Camera<D, P> {
    /// The undistorted projection-plane point seen at `pixel`: `(x/z, y/z)` for a pinhole
    /// camera, `theta (x, y) / r` for an equidistant (fisheye) one.
    pub fn undistort_pixel(
        &self,
        pixel: &Vector2<f64>,
        options: &UndistortOptions,
    ) -> Result<Vector2<f64>, CameraModelError> {
        if !self.intrinsics.is_valid() {
            return Err(CameraModelError::InvalidIntrinsics {
                fx: self.intrinsics.fx,
                fy: self.intrinsics.fy,
            });
        }
        if !(pixel.x.is_finite() && pixel.y.is_finite()) {
            return Err(CameraModelError::NonFinite { what: "pixel" });
        }
        let distorted = self.intrinsics.to_normalized(pixel);
        undistort_normalized(&self.distortion, &distorted, options)
    }

    /// The unit-length viewing ray (camera frame) through `pixel`: `z > 0` for a pinhole camera;
    /// a fisheye ray can point sideways or backwards.
    pub fn pixel_to_ray(
        &self,
        pixel: &Vector2<f64>,
        options: &UndistortOptions,
    ) -> Result<Unit<Vector3<f64>>, CameraModelError> {
        let n = self.undistort_pixel(pixel, options)?;
        P::unproject(&n).ok_or(CameraModelError::OutsideProjection)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distortion::BrownConrady;
    use crate::intrinsics::Intrinsics;
    use proptest::prelude::*;

    /// Largest distorted normalized radius inside a `width x height` image.
    fn max_image_radius(c: &Intrinsics, width: f64, height: f64) -> f64 {
        let corners = [
            (0.0, 0.0),
            (width - 1.0, 0.0),
            (0.0, height - 1.0),
            (width - 1.0, height - 1.0),
        ];
        corners
            .iter()
            .map(|&(u, v)| c.to_normalized(&Vector2::new(u, v)).norm())
            .fold(0.0, f64::max)
    }

    /// True when every distorted radius up to `r_distorted_max` has a preimage on the branch of
    /// `f(r) = r (1 + k1 r^2 + k2 r^4)` that starts at the centre and is still clearly increasing
    /// (`f' > 0.2`), with 5% to spare: the region where a real lens model is invertible. Beyond it
    /// (for strong barrel distortion the image corners can lie there) undistortion must fail.
    fn invertible_over(d: &BrownConrady, r_distorted_max: f64) -> bool {
        let mut r = 0.0;
        while r < 3.0 {
            let r2 = r * r;
            if 1.0 + 3.0 * d.k1 * r2 + 5.0 * d.k2 * r2 * r2 <= 0.2 {
                return false;
            }
            if r * (1.0 + d.k1 * r2 + d.k2 * r2 * r2) >= 1.05 * r_distorted_max {
                return true;
            }
            r += 1e-3;
        }
        false
    }

    proptest! {
        // Some sampled lenses fold back inside the image and are skipped; allow for that.
        #![proptest_config(ProptestConfig { max_global_rejects: 1_000_000, ..ProptestConfig::default() })]

        /// Project an undistorted point, undistort the pixel, project again: the two pixels agree
        /// to 1e-9 px everywhere in the image for realistic distortion. Focal lengths of 600 px and
        /// more on a 1280 px wide image cover fields of view up to ~95 degrees, the range of the
        /// Brown-Conrady model (wider lenses need a fisheye model).
        #[test]
        fn undistort_round_trips_over_the_image(
            fx in 600.0f64..1500.0, aspect in 0.9f64..1.1,
            k1 in -0.4f64..0.4, k2 in -0.3f64..0.3, p1 in -0.005f64..0.005, p2 in -0.005f64..0.005,
            u in 0.0f64..1.0, v in 0.0f64..1.0,
        ) {
            let (w, h) = (1280.0, 960.0);
            let intrinsics = Intrinsics::new(fx, fx * aspect, (w - 1.0) / 2.0, (h - 1.0) / 2.0);
            let distortion = BrownConrady::new(k1, k2, p1, p2);
            prop_assume!(invertible_over(&distortion, max_image_radius(&intrinsics, w, h)));
            let camera = Camera::new(intrinsics, distortion);
            let pixel = Vector2::new(u * (w - 1.0), v * (h - 1.0));
            let n = camera.undistort_pixel(&pixel, &UndistortOptions::default()).unwrap();
            let again = camera.project_camera_point(&Vector3::new(n.x, n.y, 1.0)).unwrap();
            prop_assert!((again - pixel).norm() < 1e-9, "{again} vs {pixel}");
            let ray = camera.pixel_to_ray(&pixel, &UndistortOptions::default()).unwrap();
            prop_assert!((ray.norm() - 1.0).abs() < 1e-15 && ray.z > 0.0);
            let through = camera.project_camera_point(&(ray.into_inner() * 3.0)).unwrap();
            prop_assert!((through - pixel).norm() < 1e-9);
        }
    }

    #[test]
    fn non_invertible_region_is_an_error_not_a_wrong_answer() {
        // Strong barrel distortion folds back at r ~ 1.3: a distorted radius beyond the fold's
        // maximum has no preimage.
        let d = BrownConrady::new(-0.2, 0.0, 0.0, 0.0);
        let err = undistort_normalized(&d, &Vector2::new(2.0, 0.0), &UndistortOptions::default());
        assert!(
            matches!(
                err,
                Err(CameraModelError::UndistortNotConverged { .. }
                    | CameraModelError::UndistortSingular
                    | CameraModelError::UndistortBeyondValidRegion)
            ),
            "{err:?}"
        );
    }

    /// Two fits from `benches/validity/run.sh` (a brown-conrady5 fit of a strong barrel lens,
    /// fx 280, folding 237 px from the principal point, and a kannala-brandt4 fit of a 4000x3000
    /// fisheye folding 2447 px out) and pixels inside their valid radius (216 and 2420 px), for
    /// which Newton's method from the pixel itself converged to the preimage beyond the fold
    /// (normalized radius 2.31; angle 2.24 rad against a fold at about 1.7): a direction the lens
    /// does not image there, returned without complaint. The answer must be the preimage on the
    /// branch from the principal point: the segment to it keeps a positive Jacobian determinant
    /// (checked at 1000 points, finer than the solver's own 16) and it maps back to the pixel.
    /// Pixels beyond the fold have no such preimage and are an error.
    #[test]
    fn undistortion_stays_on_the_branch_that_starts_at_the_principal_point() {
        use crate::distortion::{BrownConrady5, KannalaBrandt4};
        use crate::projection::Equidistant;
        let barrel = Camera::new(
            Intrinsics::new(
                280.55019901732516,
                280.60316313602993,
                319.89143715955197,
                240.01324637972672,
            ),
            BrownConrady5::new([
                -0.4511378763334498,
                0.12171886617066863,
                -1.2586340172812175e-05,
                -0.00023553245603699592,
                -0.011352107501354205,
            ]),
        );
        let fisheye = Camera::<KannalaBrandt4, Equidistant>::from_parts(
            Intrinsics::new(
                1099.5923514138656,
                1099.5313261078015,
                1999.9197849705856,
                1499.3578699493182,
            ),
            KannalaBrandt4::new([
                0.0515607421200564,
                -0.012090225420239005,
                0.0043360862872601985,
                -0.0008178283931956366,
            ]),
        );
        let options = UndistortOptions::default();
        fn check<D: LensDistortion, P: Projection>(camera: &Camera<D, P>, pixel: Vector2<f64>) {
            let n = camera
                .undistort_pixel(&pixel, &UndistortOptions::default())
                .unwrap();
            let back = camera.intrinsics.to_pixel(&camera.distortion.distort(&n));
            assert!((back - pixel).norm() < 1e-9, "{pixel:?}: {back:?}");
            let on_branch = (1..=1000).all(|i| {
                let m = n * (i as f64 / 1000.0);
                camera.distortion.distort_with_jacobians(&m).1.determinant() > 0.0
            });
            assert!(on_branch, "{pixel:?}: {n:?} lies beyond the fold");
        }
        check(&barrel, Vector2::new(216.99375000000003, 429.7694444444445));
        check(&barrel, Vector2::new(422.0062500000001, 429.7694444444445));
        check(&fisheye, Vector2::new(74.98124999999996, 33.32222222222222));
        check(&fisheye, Vector2::new(3924.01875, 33.32222222222222));
        // 300 px from the principal point, beyond the barrel fit's fold (237 px): an error.
        let beyond = Vector2::new(319.89 + 300.0, 240.01);
        assert!(barrel.undistort_pixel(&beyond, &options).is_err());
    }

    /// A thin-prism12 fit of a brown-conrady4 lens (`benches/validity/run.sh`: `calib synth
    /// single --image 640x480 --views 20 --noise 0.3 --seed 2`, `calib single --model
    /// thin-prism12`), valid to 680 px from the principal point: its numerator and denominator
    /// nearly share a root at `r^2 = 0.153` (both about 4e-5 there, the denominator positive), so
    /// the radial factor `num / den` turns sharply within a ring 305 px out, on the image's left
    /// edge. The map is one-to-one there, and every pixel of the image plus 5% must undistort
    /// and map back.
    #[test]
    fn undistortion_crosses_a_near_cancelling_root_pair() {
        use crate::distortion::ThinPrism12;
        let camera = Camera::new(
            Intrinsics::new(
                801.7189716558472,
                801.2069704200289,
                305.04530053934883,
                215.54001888668023,
            ),
            ThinPrism12::new([
                -13.25707451864063,
                45.16480465811841,
                -0.00777172074228936,
                -0.0057101540136518135,
                -8.066492821795663,
                -13.069994756012726,
                42.7205119136975,
                -0.08214008925653875,
                0.008842792020218987,
                -0.008160046912839168,
                0.015704931966650296,
                -0.001193331699084394,
            ]),
        );
        let options = UndistortOptions::default();
        let (w, h) = (640.0, 480.0);
        let mut failed = Vec::new();
        for i in 0..=200 {
            for j in 0..=150 {
                let pixel = Vector2::new(
                    -0.05 * w + 1.1 * w * i as f64 / 200.0,
                    -0.05 * h + 1.1 * h * j as f64 / 150.0,
                );
                match camera.undistort_pixel(&pixel, &options) {
                    Ok(n) => {
                        // The map's rounding floor there: about 1e-12 normalized, 1e-9 px.
                        let back = camera.intrinsics.to_pixel(&camera.distortion.distort(&n));
                        assert!((back - pixel).norm() < 1e-8, "{pixel:?}: {back:?}");
                    }
                    Err(e) => failed.push((pixel, e)),
                }
            }
        }
        assert!(
            failed.is_empty(),
            "{} failed: {:?}",
            failed.len(),
            &failed[..failed.len().min(5)]
        );
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let camera = Camera::new(
            Intrinsics::new(0.0, 500.0, 320.0, 240.0),
            BrownConrady::default(),
        );
        assert!(matches!(
            camera.undistort_pixel(&Vector2::new(1.0, 2.0), &UndistortOptions::default()),
            Err(CameraModelError::InvalidIntrinsics { .. })
        ));
        let camera = Camera::new(
            Intrinsics::new(500.0, 500.0, 320.0, 240.0),
            BrownConrady::default(),
        );
        assert!(matches!(
            camera.undistort_pixel(&Vector2::new(f64::NAN, 2.0), &UndistortOptions::default()),
            Err(CameraModelError::NonFinite { .. })
        ));
        let options = UndistortOptions {
            max_iterations: 0,
            ..Default::default()
        };
        let d = BrownConrady::new(0.3, 0.0, 0.0, 0.0);
        assert!(matches!(
            undistort_normalized(&d, &Vector2::new(0.5, 0.5), &options),
            Err(CameraModelError::UndistortNotConverged { iterations: 0, .. })
        ));
    }
}
