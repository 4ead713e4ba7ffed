//! Where a lens model is physically valid: one-to-one (its distortion map keeps a positive
//! Jacobian determinant, so it neither folds over nor tears) and, for rational models, with a
//! positive denominator.
//!
//! A calibration constrains the model only where the board was seen. Polynomial and rational
//! models fitted there can fold back or blow up just outside (OpenCV issues 15992 and 15577): the
//! RMS looks fine, yet pixels near the image corners have no, or two, undistorted directions.
//! [`AnyCamera::validity`] walks 64 rays from the principal point, in the projection's normalized
//! coordinates (`x / z` for pinhole models, `theta` along the direction for the equidistant
//! projection), checks the determinant and the denominator at 512 steps along each, and reports
//! the pixel radius where the first check fails, per ray and overall, against the distance to the
//! image border along the same ray. Cost: about 33 000 distortion evaluations, well under a
//! millisecond.

use crate::dispatch_camera_model;
use crate::{AnyCamera, Camera, LensDistortion, Projection};
use nalgebra::Vector2;

/// Rays walked from the principal point.
pub const VALIDITY_RAYS: usize = 64;
const RAYS: usize = VALIDITY_RAYS;
/// Steps along each ray.
const STEPS: usize = 512;
/// Largest pinhole normalized radius walked (`tan 87 degrees`): beyond, the pinhole projection
/// itself is meaningless for a camera.
const MAX_PINHOLE_RADIUS: f64 = 19.08;

/// The validity of a lens model over an image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Validity {
    /// Pixel distance from the principal point at which the model first stops being one-to-one
    /// (or a rational denominator stops being positive), smallest over the rays; infinite if it
    /// stays valid as far as it was walked.
    pub valid_radius_px: f64,
    /// Distance from the principal point to the farthest image corner, pixels.
    pub image_radius_px: f64,
    /// Smallest ratio, over the rays, of the valid distance to the image border's distance along
    /// the same ray: at least 1 when the model is valid over the whole image.
    pub coverage: f64,
    /// Where each of the [`VALIDITY_RAYS`] rays (ray `i` leaves the principal point at angle
    /// `2 pi i / VALIDITY_RAYS` in normalized coordinates, from +x towards +y) stops being valid:
    /// the pixel (OpenCV's convention, first pixel centre at 0,0) of its last valid point, `None`
    /// when the ray stays valid as far as it was walked. Joined in order they trace the fold,
    /// which is an ellipse rather than a circle in pixels when `fx != fy`.
    pub limit_px: [Option<Vector2<f64>>; VALIDITY_RAYS],
}

impl Validity {
    /// True when the model is valid over the whole image with `margin` (a fraction: 0.05 asks for
    /// 5% beyond the border).
    pub fn covers_image(&self, margin: f64) -> bool {
        self.coverage >= 1.0 + margin
    }
}

/// Distance from `(cx, cy)` to the border of a `width x height` image along direction `u`
/// (pixel centres from 0 to `width - 1`; infinite if the point is outside or `u` is zero).
fn border_distance(cx: f64, cy: f64, width: f64, height: f64, u: Vector2<f64>) -> f64 {
    let along = |c: f64, size: f64, d: f64| {
        if d > 0.0 {
            (size - 1.0 - c) / d
        } else if d < 0.0 {
            -c / d
        } else {
            f64::INFINITY
        }
    };
    along(cx, width, u.x).min(along(cy, height, u.y)).max(0.0)
}

fn typed_validity<D: LensDistortion, P: Projection>(
    camera: &AnyCamera,
    width: f64,
    height: f64,
) -> Validity {
    let typed = Camera::<D, P>::from_parts(camera.intrinsics, D::from_params(&camera.distortion));
    let k = camera.intrinsics;
    let corners = [
        (0.0, 0.0),
        (width - 1.0, 0.0),
        (0.0, height - 1.0),
        (width - 1.0, height - 1.0),
    ];
    let image_radius_px = corners
        .iter()
        .map(|&(x, y)| (x - k.cx).hypot(y - k.cy))
        .fold(0.0, f64::max);
    // The equidistant projection's normalized radius is the angle off the axis, up to pi.
    let max_radius = if P::NAME == "equidistant" {
        std::f64::consts::PI * 0.999
    } else {
        MAX_PINHOLE_RADIUS
    };
    // A denominator root found exactly: sampling alone can step over a thin negative band.
    let pole = typed.distortion.pole_radius().unwrap_or(f64::INFINITY);
    let (mut valid_radius_px, mut coverage) = (f64::INFINITY, f64::INFINITY);
    let mut limit_px = [None; RAYS];
    for (ray, limit_pixel) in limit_px.iter_mut().enumerate() {
        let phi = 2.0 * std::f64::consts::PI * ray as f64 / RAYS as f64;
        let direction = Vector2::new(phi.cos(), phi.sin());
        // The pixel of the point `rho` along the ray, if the model is valid there.
        let valid_at = |rho: f64| -> Option<Vector2<f64>> {
            let n = direction * rho;
            let (d, jacobian, _) = typed.distortion.distort_with_jacobians(&n);
            let positive = typed.distortion.denominator(&n).is_none_or(|q| q > 0.0);
            (jacobian.determinant() > 0.0 && positive && d.iter().all(|v| v.is_finite()))
                .then(|| k.to_pixel(&d))
        };
        let from_centre = |pixel: Vector2<f64>| (pixel.x - k.cx).hypot(pixel.y - k.cy);
        let mut reached = 0.0f64;
        let mut last_valid = Vector2::new(k.cx, k.cy);
        let mut failed = false;
        let mut last = 0.0;
        for step in 1..=STEPS {
            let rho = max_radius * step as f64 / STEPS as f64;
            if rho >= pole {
                // The ray ends just before the pole: between close roots of numerator and
                // denominator the band of directions near it maps onto every radius.
                if let Some(pixel) = valid_at(pole * (1.0 - 1e-4)) {
                    reached = reached.max(from_centre(pixel));
                    last_valid = pixel;
                }
                failed = true;
                break;
            }
            match valid_at(rho) {
                Some(pixel) => {
                    reached = reached.max(from_centre(pixel));
                    last_valid = pixel;
                }
                None => {
                    // Locate the limit between the last valid step and this one.
                    let (mut lo, mut hi) = (last, rho);
                    for _ in 0..40 {
                        let mid = 0.5 * (lo + hi);
                        match valid_at(mid) {
                            Some(pixel) => {
                                reached = reached.max(from_centre(pixel));
                                last_valid = pixel;
                                lo = mid;
                            }
                            None => hi = mid,
                        }
                    }
                    failed = true;
                    break;
                }
            }
            last = rho;
            if reached > 4.0 * image_radius_px {
                break;
            }
        }
        let limit = if failed { reached } else { f64::INFINITY };
        *limit_pixel = failed.then_some(last_valid);
        valid_radius_px = valid_radius_px.min(limit);
        // The border along the ray in pixels: the distorted ray bends, so use the direction in
        // which it leaves the principal point.
        let border = border_distance(k.cx, k.cy, width, height, direction);
        coverage = coverage.min(limit / border.max(1e-9));
    }
    Validity {
        valid_radius_px,
        image_radius_px,
        coverage,
        limit_px,
    }
}

impl AnyCamera {
    /// Where this camera's lens model is one-to-one with a positive denominator, against a
    /// `width x height` image (see the module documentation).
    pub fn validity(&self, width: u32, height: u32) -> Validity {
        let (w, h) = (f64::from(width), f64::from(height));
        dispatch_camera_model!(self.model, D, P => typed_validity::<D, P>(self, w, h))
    }
}

#[cfg(test)]
mod tests {
    use crate::{AnyCamera, CameraModel, Intrinsics};

    fn camera(model: CameraModel, distortion: Vec<f64>) -> AnyCamera {
        AnyCamera::new(
            model,
            Intrinsics::new(500.0, 500.0, 319.5, 239.5),
            distortion,
        )
        .unwrap()
    }

    #[test]
    fn mild_distortion_is_valid_over_the_image() {
        let v =
            camera(CameraModel::BrownConrady4, vec![-0.2, 0.05, 0.001, -0.001]).validity(640, 480);
        assert!(v.covers_image(0.05), "{v:?}");
        assert!((v.image_radius_px - 319.5f64.hypot(239.5)).abs() < 1e-9);
        let fisheye = camera(
            CameraModel::KannalaBrandt4,
            vec![0.05, -0.01, 0.003, -0.0005],
        );
        assert!(fisheye.validity(640, 480).covers_image(0.05));
    }

    /// Barrel distortion `1 + k1 r^2` with `k1 = -0.5` folds back at `r^2 = 1 / (3 |k1|)`:
    /// `d(r (1 + k1 r^2))/dr = 1 + 3 k1 r^2 = 0`, at normalized radius 0.816, where the distorted
    /// radius is `0.816 (1 - 0.5 * 0.667) = 0.544`, 272 px at f = 500: inside a 640x480 image
    /// (corner at 400 px) but outside a 320x240 crop around the centre (corner at 200 px).
    #[test]
    fn folding_barrel_distortion_is_found_where_theory_puts_it() {
        let c = camera(CameraModel::BrownConrady4, vec![-0.5, 0.0, 0.0, 0.0]);
        let v = c.validity(640, 480);
        let fold = 500.0 * (1.0 / 1.5f64).sqrt() * (1.0 - 0.5 / 1.5);
        assert!((v.valid_radius_px - fold).abs() < 2.0, "{v:?} vs {fold}");
        assert!(!v.covers_image(0.0));
        let small = AnyCamera::new(
            CameraModel::BrownConrady4,
            Intrinsics::new(500.0, 500.0, 159.5, 119.5),
            vec![-0.5, 0.0, 0.0, 0.0],
        )
        .unwrap();
        assert!(small.validity(320, 240).covers_image(0.05));
    }

    /// The same fold with `fy = 2 fx`: in pixels it is an ellipse with semi-axes `fx d` and
    /// `fy d` (d = 0.544, the distorted normalized radius of the fold), and every ray's limit lies
    /// on it; the smallest radius is the one along x.
    #[test]
    fn the_fold_is_traced_per_ray_as_an_ellipse_when_fx_differs_from_fy() {
        let (fx, fy) = (300.0, 600.0);
        let c = AnyCamera::new(
            CameraModel::BrownConrady4,
            Intrinsics::new(fx, fy, 639.5, 479.5),
            vec![-0.5, 0.0, 0.0, 0.0],
        )
        .unwrap();
        let v = c.validity(1280, 960);
        let d = (1.0 / 1.5f64).sqrt() * (1.0 - 0.5 / 1.5);
        assert!((v.valid_radius_px - fx * d).abs() < 1.0, "{v:?}");
        for (ray, limit) in v.limit_px.iter().enumerate() {
            let p = limit.unwrap_or_else(|| panic!("ray {ray} found no fold"));
            let (x, y) = ((p.x - 639.5) / fx, (p.y - 479.5) / fy);
            assert!((x.hypot(y) - d).abs() < 1e-3, "ray {ray}: {p:?}");
            let phi = std::f64::consts::TAU * ray as f64 / v.limit_px.len() as f64;
            assert!((y.atan2(x) - phi).sin().abs() < 1e-9, "ray {ray} direction");
        }
        let never = camera(CameraModel::BrownConrady4, vec![0.2, 0.0, 0.0, 0.0]);
        assert!(
            never
                .validity(640, 480)
                .limit_px
                .iter()
                .all(Option::is_none)
        );
    }

    /// A rational model `r (1 - 3 r^2) / (1 - r^2)` (k1 = -3, k4 = -1): the numerator turns the
    /// distorted radius back at r = 0.3626, distorted radius 0.2528, 126.4 px at f = 500, well
    /// before the denominator's pole at r = 1.
    #[test]
    fn a_folding_rational_model_is_found() {
        let c = camera(
            CameraModel::Rational8,
            vec![-3.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0],
        );
        let v = c.validity(640, 480);
        assert!(!v.covers_image(0.0), "{v:?}");
        assert!((v.valid_radius_px - 126.4).abs() < 1.0, "{v:?}");
    }

    /// Numerator and denominator with nearly shared roots (`t = r^2` at 0.0795 and 1e-7 to
    /// 3e-7 beyond, the shape of a rational8 fit seen in a rig calibration): the projection is
    /// within 1.5% of the identity except within 2e-4 of the pole; in a band 2e-7 wide in `t` the
    /// denominator is negative and the band's directions map onto every radius. A walk sampling
    /// every 0.037 in `r` steps over it; the exact root puts the limit just before the pole,
    /// about `500 sqrt(0.0795)` = 141 px (143 px there, where the ratio is 1.0125).
    #[test]
    fn a_thin_band_of_negative_denominator_is_found() {
        let t1 = 0.0795;
        let (t2, n1, n2) = (t1 + 2e-7, t1 + 1e-7, t1 + 3e-7);
        let c = camera(
            CameraModel::Rational8,
            vec![
                -(1.0 / n1 + 1.0 / n2),
                1.0 / (n1 * n2),
                0.0,
                0.0,
                0.0,
                -(1.0 / t1 + 1.0 / t2),
                1.0 / (t1 * t2),
                0.0,
            ],
        );
        let v = c.validity(640, 480);
        assert!(!v.covers_image(0.0), "{v:?}");
        let pole_px = 500.0 * t1.sqrt();
        assert!(
            (v.valid_radius_px - 1.0125 * pole_px).abs() < 0.5,
            "{v:?} vs {pole_px}"
        );
    }

    #[test]
    fn cubic_roots() {
        use crate::distortion::smallest_positive_cubic_root as root;
        // (1 - t/2)(1 - t/3)(1 - t/5) = 1 - (31/30) t + (1/3) t^2 - (1/30) t^3.
        let r = root(-31.0 / 30.0, 1.0 / 3.0, -1.0 / 30.0).unwrap();
        assert!((r - 2.0).abs() < 1e-12, "{r}");
        // (1 + t)(1 + t^2): no positive root; (1 - t/2)^2: a double root at 2.
        assert_eq!(root(1.0, 1.0, 1.0), None);
        let r = root(-1.0, 0.25, 0.0).unwrap();
        assert!((r - 2.0).abs() < 1e-6, "{r}");
        // Linear and constant.
        assert!((root(-0.5, 0.0, 0.0).unwrap() - 2.0).abs() < 1e-12);
        assert_eq!(root(0.0, 0.0, 0.0), None);
        assert_eq!(root(0.3, 0.0, 0.0), None);
    }
}
