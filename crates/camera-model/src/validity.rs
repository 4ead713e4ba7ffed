//! Where a lens model is physically valid: one-to-one (its distortion map keeps a positive
//! Jacobian determinant, so it neither folds over nor tears) and, for rational models, with a
//! positive denominator.
//!
//! A calibration constrains the model only where the board was seen. Polynomial and rational
//! models fitted there can fold back or blow up just outside (OpenCV issues 15992 and 15577): the
//! RMS looks fine, yet pixels near the image corners have no, or two, undistorted directions.
//! [`AnyCamera::validity`] walks 64 rays from the principal point and one towards each image
//! corner, in the projection's normalized coordinates (`x / z` for pinhole models, `theta` along
//! the direction for the equidistant projection), checks the determinant (positive, and at most
//! [`MAX_AREA_MAGNIFICATION`]) and the denominator at
//! 512 steps along each, and reports the pixel radius where the first check fails, per ray and
//! overall, against the distance to the image border along the same ray. Two limits are found
//! exactly rather than by sampling, because a fitted model can break within a band far narrower
//! than a step: the rational denominator's first root ([`LensDistortion::pole_radius`]) and the
//! radial map's first fold ([`LensDistortion::radial_factor`]: the smallest root of
//! `d(r N / D)/dr`, from its numerator polynomial's companion matrix). Each ray ends at the
//! nearer of the two. Cost: about 35 000 distortion evaluations, well under a millisecond.

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
/// Largest area magnification of the distortion map (its Jacobian determinant, 1 at the principal
/// point) accepted as valid. No lens magnifies its image locally ten times in each direction
/// against the centre; a fitted rational model does so only next to a pole of its radial factor,
/// where every pixel beyond some radius is crowded into a thin band of directions just inside the
/// pole (a fit's denominator root paired with a numerator root 2e-4 beyond it in `r^2` put the
/// pixels from 2100 to 3950 px into a band 1e-4 wide in `r`, and their undistortion found the
/// branch beyond the pole instead). The walk ends where the magnification passes this bound, not
/// at the pole itself.
pub const MAX_AREA_MAGNIFICATION: f64 = 100.0;

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
    // A denominator root found exactly: sampling alone can step over a thin negative band. The
    // ray ends just before it: between close roots of numerator and denominator the band of
    // directions near it maps onto every radius.
    let pole = typed
        .distortion
        .pole_radius()
        .map_or(f64::INFINITY, |r| r * (1.0 - 1e-4));
    // The radial map's fold found exactly too: between a near-cancelling pair of numerator and
    // denominator roots it can fold back within 6e-4 in `r`, far less than a step.
    let fold = typed
        .distortion
        .radial_factor()
        .and_then(|(n, d)| radial_fold(&n, &d, max_radius * max_radius))
        .unwrap_or(f64::INFINITY);
    let magnified = typed
        .distortion
        .radial_factor()
        .and_then(|(n, d)| radial_magnification_limit(&n, &d, max_radius * max_radius))
        .unwrap_or(f64::INFINITY);
    let end = pole.min(fold).min(magnified);
    let (mut valid_radius_px, mut coverage) = (f64::INFINITY, f64::INFINITY);
    let mut limit_px = [None; RAYS];
    // The 64 evenly spread rays, then one towards each image corner (the farthest points, which
    // the spread rays pass a few degrees off).
    let to_ray = |pixel: (f64, f64)| {
        let u = Vector2::new((pixel.0 - k.cx) / k.fx, (pixel.1 - k.cy) / k.fy);
        let norm = u.norm();
        (norm > 0.0).then(|| u / norm)
    };
    let directions = (0..RAYS)
        .map(|ray| {
            let phi = 2.0 * std::f64::consts::PI * ray as f64 / RAYS as f64;
            Some(Vector2::new(phi.cos(), phi.sin()))
        })
        .chain(corners.iter().map(|&c| to_ray(c)));
    for (ray, direction) in directions.enumerate() {
        let Some(direction) = direction else {
            continue;
        };
        // The pixel of the point `rho` along the ray, if the model is valid there.
        let valid_at = |rho: f64| -> Option<Vector2<f64>> {
            let n = direction * rho;
            let (d, jacobian, _) = typed.distortion.distort_with_jacobians(&n);
            let positive = typed.distortion.denominator(&n).is_none_or(|q| q > 0.0);
            let det = jacobian.determinant();
            (det > 0.0
                && det <= MAX_AREA_MAGNIFICATION
                && positive
                && d.iter().all(|v| v.is_finite()))
            .then(|| k.to_pixel(&d))
        };
        let from_centre = |pixel: Vector2<f64>| (pixel.x - k.cx).hypot(pixel.y - k.cy);
        let mut reached = 0.0f64;
        let mut last_valid = Vector2::new(k.cx, k.cy);
        let mut failed = false;
        let mut last = 0.0;
        for step in 1..=STEPS {
            let rho = (max_radius * step as f64 / STEPS as f64).min(end);
            match valid_at(rho) {
                Some(pixel) => {
                    reached = reached.max(from_centre(pixel));
                    last_valid = pixel;
                    if rho >= end {
                        failed = true;
                        break;
                    }
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
        if let Some(slot) = limit_px.get_mut(ray) {
            *slot = failed.then_some(last_valid);
        }
        valid_radius_px = valid_radius_px.min(limit);
        // The border along the ray in pixels: the distorted ray bends, so use the direction in
        // which it leaves the principal point (in pixels: scaled by fx, fy).
        let border = border_distance(
            k.cx,
            k.cy,
            width,
            height,
            Vector2::new(k.fx * direction.x, k.fy * direction.y).normalize(),
        );
        coverage = coverage.min(limit / border.max(1e-9));
    }
    Validity {
        valid_radius_px,
        image_radius_px,
        coverage,
        limit_px,
    }
}

/// `a * b` for polynomials given from the constant term up.
fn poly_mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

/// The derivative of a polynomial given from the constant term up.
fn poly_derivative(a: &[f64]) -> Vec<f64> {
    a.iter()
        .enumerate()
        .skip(1)
        .map(|(i, x)| i as f64 * x)
        .collect()
}

fn poly_eval(a: &[f64], t: f64) -> f64 {
    a.iter().rev().fold(0.0, |acc, x| acc * t + x)
}

/// The smallest normalized radius `r` at which the radial map `r -> r N(r^2) / D(r^2)` stops
/// increasing (or `None` if it increases as far as `max_t` in `t = r^2`), found from the roots of
/// its derivative's numerator `P(t) = N D + 2 t (N' D - N D')` (`d(r c)/dr = P / D^2` with
/// `c = N / D`): the eigenvalues of `P`'s companion matrix are the candidates, with the midpoints
/// between them (a negative band between two close real roots may come out as a complex pair
/// whose real part lies inside it), and the first candidate where `P <= 0` is bracketed from the
/// last positive one and bisected. Degree at most 8, so a few microseconds.
pub(crate) fn radial_fold(numerator: &[f64], denominator: &[f64], max_t: f64) -> Option<f64> {
    first_nonpositive(radial_slope_numerator(numerator, denominator), max_t).map(f64::sqrt)
}

/// `P(t) = N D + 2 t (N' D - N D')`, the numerator of `d(r N / D)/dr = P / D^2`.
fn radial_slope_numerator(numerator: &[f64], denominator: &[f64]) -> Vec<f64> {
    let n_d = poly_mul(numerator, denominator);
    let n1_d = poly_mul(&poly_derivative(numerator), denominator);
    let n_d1 = poly_mul(numerator, &poly_derivative(denominator));
    let mut p = n_d;
    for i in 0..n1_d.len().max(n_d1.len()) {
        let term = n1_d.get(i).unwrap_or(&0.0) - n_d1.get(i).unwrap_or(&0.0);
        // 2 t (N' D - N D'): shifted up one degree.
        if p.len() <= i + 1 {
            p.resize(i + 2, 0.0);
        }
        p[i + 1] += 2.0 * term;
    }
    p
}

/// The smallest normalized radius at which the radial map's area magnification
/// `c d(r c)/dr = N P / D^3` passes [`MAX_AREA_MAGNIFICATION`] (`None` if it does not as far as
/// `max_t` in `t = r^2`): the first `t` where `MAX_AREA_MAGNIFICATION D^3 - N P` turns non-positive,
/// found as [`radial_fold`] finds its fold. Exact, since a band of high magnification can be far
/// narrower than the walk's step (next to a pole, or a hump of the slope).
pub(crate) fn radial_magnification_limit(
    numerator: &[f64],
    denominator: &[f64],
    max_t: f64,
) -> Option<f64> {
    let p = radial_slope_numerator(numerator, denominator);
    let cube = poly_mul(&poly_mul(denominator, denominator), denominator);
    let np = poly_mul(numerator, &p);
    let q: Vec<f64> = (0..cube.len().max(np.len()))
        .map(|i| MAX_AREA_MAGNIFICATION * cube.get(i).unwrap_or(&0.0) - np.get(i).unwrap_or(&0.0))
        .collect();
    first_nonpositive(q, max_t).map(f64::sqrt)
}

/// The smallest `t` in `(0, max_t]` where the polynomial `p` (constant term first, `p(0) > 0`)
/// is non-positive: the real parts of its companion matrix's eigenvalues and the midpoints
/// between them are the candidates, and the first candidate where `p <= 0` is bracketed from the
/// last positive one and bisected.
fn first_nonpositive(mut p: Vec<f64>, max_t: f64) -> Option<f64> {
    while p.len() > 1 && p.last() == Some(&0.0) {
        p.pop();
    }
    if p.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let degree = p.len() - 1;
    let mut candidates: Vec<f64> = Vec::new();
    if degree >= 1 {
        let lead = p[degree];
        let companion = nalgebra::DMatrix::from_fn(degree, degree, |i, j| {
            if j == degree - 1 {
                -p[i] / lead
            } else if i == j + 1 {
                1.0
            } else {
                0.0
            }
        });
        // Bounded iterations: nalgebra's `complex_eigenvalues` iterates without limit. Should
        // the QR iteration not converge, a dense grid in `t` gives the candidates instead.
        match nalgebra::linalg::Schur::try_new(companion, f64::EPSILON, 10_000) {
            Some(schur) => candidates.extend(
                schur
                    .complex_eigenvalues()
                    .iter()
                    .map(|z| z.re)
                    .filter(|&t| t > 0.0 && t.is_finite()),
            ),
            None => candidates.extend((1..4096).map(|i| max_t * i as f64 / 4096.0)),
        }
    }
    candidates.push(max_t);
    candidates.sort_by(f64::total_cmp);
    candidates.retain(|&t| t <= max_t);
    let midpoints: Vec<f64> = candidates.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
    candidates.extend(midpoints);
    candidates.sort_by(f64::total_cmp);
    let mut positive = 0.0;
    for t in candidates {
        if poly_eval(&p, t) > 0.0 {
            positive = t;
            continue;
        }
        let (mut lo, mut hi) = (positive, t);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if poly_eval(&p, mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        return Some(lo);
    }
    None
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
    /// about `500 sqrt(0.0795)` = 141 px: where the area magnification passes 100, just inside
    /// the pole, where the map is still within 1.5% of the identity (the walk used to end at
    /// `0.9999 r`, 143 px).
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
            (v.valid_radius_px - pole_px).abs() < 0.015 * pole_px,
            "{v:?} vs {pole_px}"
        );
    }

    /// A near-identity rational model with a pole pair: `c = (1 - t / t_n) / (1 - t / t_d)`,
    /// denominator root `t_d = 0.4` (r = 0.632, 316 px at f = 500, inside the 640x480 image whose
    /// corners lie 400 px out) and a numerator root 8e-5 beyond it (the shape of a thin-prism12 fit
    /// of a 4000x3000 camera in `benches/validity/run.sh`). Just inside the pole the map crowds
    /// every radius into a thin band: at `0.9999 r_d`, where the walk used to end, the distorted
    /// radius is already 632 px, and the model was called valid over the image. Where the area
    /// magnification passes 100 the radius is 345.9 px (a dense evaluation of
    /// `c (c + 2 t dc/dt)` at 2e6 points), 9% beyond the pole's 316 px: the fold is inside the
    /// image. The tolerance, 1 px, covers the bisection (far finer) and the pixel rounding of
    /// the reported point.
    #[test]
    fn a_pole_paired_with_a_numerator_root_is_not_valid_out_to_infinity() {
        let (td, tn) = (0.4, 0.4 + 8e-5);
        let c = camera(
            CameraModel::Rational8,
            vec![-1.0 / tn, 0.0, 0.0, 0.0, 0.0, -1.0 / td, 0.0, 0.0],
        );
        let v = c.validity(640, 480);
        assert!(!v.covers_image(0.05), "{v:?}");
        assert!((v.valid_radius_px - 345.9).abs() < 1.0, "{v:?}");
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

    /// The radial fold from the polynomials: `r (1 + k1 r^2)` turns at `1 + 3 k1 t = 0`, and
    /// `theta (1 + k1 theta^2)` (kannala-brandt4) likewise; no fold for `k1 > 0`.
    #[test]
    fn radial_fold_is_exact_for_a_barrel_lens() {
        let fold = super::radial_fold(&[1.0, -0.5, 0.0], &[1.0], 400.0).unwrap();
        assert!((fold - (2.0f64 / 3.0).sqrt()).abs() < 1e-12, "{fold}");
        let fold = super::radial_fold(&[1.0, -0.5, 0.0, 0.0, 0.0], &[1.0], 10.0).unwrap();
        assert!((fold - (2.0f64 / 3.0).sqrt()).abs() < 1e-12, "{fold}");
        assert_eq!(super::radial_fold(&[1.0, 0.3, 0.0], &[1.0], 400.0), None);
        // Beyond the range asked: none.
        assert_eq!(super::radial_fold(&[1.0, -0.5], &[1.0], 0.5), None);
    }

    /// Two fits the sampled walk passed as one-to-one over the image (a helper audit checked
    /// them with `cv2.projectPoints`): a synthetic rational8 whose numerator and denominator share
    /// a nearly cancelling complex root pair (the radius backs up by 1 px, 214 px from the
    /// principal point, within 6e-4 in `r`), and thin-prism12 on sourishg2/right, whose radial
    /// factor turns negative before its denominator's root. Both are found now; the fold is a
    /// true maximum of the radial map (checked by evaluating it on either side).
    #[test]
    fn folds_narrower_than_a_step_are_found() {
        let cases = [
            (
                CameraModel::Rational8,
                Intrinsics::new(
                    799.7072136789193,
                    799.5432023156792,
                    319.3202338493843,
                    241.05927375321798,
                ),
                vec![
                    -26.397184399241173,
                    175.2504791865067,
                    0.0007396271877745448,
                    -0.00039868543798629325,
                    -13.802402191363587,
                    -26.098405067157213,
                    167.38886410280165,
                    37.91230761339404,
                ],
                (640, 480),
            ),
            (
                CameraModel::ThinPrism12,
                Intrinsics::new(
                    197.32287531555636,
                    232.97617963381757,
                    123.4850191540375,
                    86.5791231282901,
                ),
                vec![
                    30.680274328807247,
                    71.74330727191025,
                    -0.007069539446938335,
                    -0.041594147259118315,
                    -609.3197365791902,
                    30.88639323597743,
                    65.09622919069028,
                    -587.2815256368327,
                    0.028646586965143953,
                    0.03946396322004034,
                    -0.0010473627150003174,
                    0.025596542596674918,
                ],
                (270, 180),
            ),
        ];
        for (model, k, distortion, (w, h)) in cases {
            let d = distortion.clone();
            let c = AnyCamera::new(model, k, distortion).unwrap();
            let v = c.validity(w, h);
            assert!(!v.covers_image(0.0), "{model}: {v:?}");
            let (num, den) = (vec![1.0, d[0], d[1], d[4]], vec![1.0, d[5], d[6], d[7]]);
            let fold = super::radial_fold(&num, &den, 400.0).unwrap();
            let radial = |r: f64| {
                let t = r * r;
                r * super::poly_eval(&num, t) / super::poly_eval(&den, t)
            };
            assert!(radial(fold * (1.0 - 1e-7)) < radial(fold), "{model}");
            assert!(radial(fold * (1.0 + 1e-5)) < radial(fold), "{model}");
        }
    }

    /// A fisheye fit whose fold lies 2.6% beyond the farthest image corner: the evenly spread
    /// rays pass the corners a few degrees off, where the border is nearer, and measured a
    /// coverage above the 5% margin; the ray towards each corner measures it there.
    #[test]
    fn the_margin_is_checked_towards_the_image_corners() {
        let c = AnyCamera::new(
            CameraModel::KannalaBrandt4,
            Intrinsics::new(
                219.78555178992522,
                219.8178366782861,
                319.58357489326664,
                239.62160967465502,
            ),
            vec![
                0.05325022522163423,
                -0.01652092327203875,
                0.009259910505109206,
                -0.002563180729972618,
            ],
        )
        .unwrap();
        let v = c.validity(640, 480);
        let ratio = v.valid_radius_px / v.image_radius_px;
        assert!((1.0..1.05).contains(&ratio), "{v:?}");
        assert!(!v.covers_image(0.05) && v.covers_image(0.0), "{v:?}");
        assert!((v.coverage - ratio).abs() < 0.01, "{v:?}");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
        /// Against a dense walk: for random radial rational8 models (no tangential terms, so
        /// along +x the map is `r -> r c(r)`), the fold the validity reports along ray 0 is the
        /// first place where the distorted radius stops increasing or the area magnification
        /// `c (r c)'` passes [`super::MAX_AREA_MAGNIFICATION`] (closed form), found by stepping
        /// `r` by 2e-5 up to 2: the same distorted radius within what that step can resolve (the
        /// radius moves by the slope times the step there), and never a fold the dense walk does
        /// not see. Coefficients up to 50, as the rational valleys give (k1 = -26, k2 = 175 in a
        /// fit a helper audit found).
        #[test]
        fn the_reported_fold_is_the_first_one_a_dense_walk_finds(
            k in proptest::collection::vec(-50.0f64..50.0, 6),
        ) {
            let distortion = vec![k[0], k[1], 0.0, 0.0, k[2], k[3], k[4], k[5]];
            let c = AnyCamera::new(
                CameraModel::Rational8,
                Intrinsics::new(500.0, 500.0, 1999.5, 1999.5),
                distortion,
            )
            .unwrap();
            let v = c.validity(4000, 4000);
            let num = |t: f64| 1.0 + k[0] * t + k[1] * t * t + k[2] * t * t * t;
            let den = |t: f64| 1.0 + k[3] * t + k[4] * t * t + k[5] * t * t * t;
            // The dense walk: the first r where the denominator stops being positive or the
            // distorted radius decreases.
            let step = 2e-5;
            let (mut previous, mut fold, mut slope) = (0.0f64, None, 0.0f64);
            let mut r = step;
            while r <= 2.0 {
                let t = r * r;
                if den(t) <= 0.0 {
                    fold = Some((r, f64::NAN));
                    break;
                }
                let radius = r * num(t) / den(t);
                if radius < previous {
                    fold = Some((r, previous));
                    break;
                }
                // d(r c)/dr = c + 2 t dc/dt, dc/dt = (N' D - N D') / D^2.
                let dnum = k[0] + 2.0 * k[1] * t + 3.0 * k[2] * t * t;
                let dden = k[3] + 2.0 * k[4] * t + 3.0 * k[5] * t * t;
                let factor = num(t) / den(t);
                slope = factor + 2.0 * t * (dnum * den(t) - num(t) * dden) / (den(t) * den(t));
                if factor * slope > super::MAX_AREA_MAGNIFICATION {
                    fold = Some((r, previous));
                    break;
                }
                previous = radius;
                r += step;
            }
            let reported = v.limit_px[0].map(|p| (p.x - 1999.5) / 500.0);
            // The walk ends without failure once the distorted radius passes four image radii.
            let cap = 4.0 * v.image_radius_px / 500.0;
            if previous > cap {
                return Ok(());
            }
            match (fold, reported) {
                // A fold (not a pole) within r <= 2: the same distorted radius.
                (Some((_, dense)), Some(walk)) if dense.is_finite() => {
                    proptest::prop_assert!(
                        (walk - dense).abs() <= (1e-3 * dense.abs().max(1.0)).max(2.0 * slope.abs() * step),
                        "walk {} dense {} for {:?}", walk, dense, k
                    );
                }
                (Some((_, dense)), None) if dense.is_finite() => {
                    proptest::prop_assert!(false, "fold at distorted radius {} missed for {:?}", dense, k);
                }
                // No failure up to r = 2: the walk may only stop beyond it (or at a distorted
                // radius beyond what r = 2 reaches).
                (None, Some(walk)) => {
                    proptest::prop_assert!(walk >= previous * (1.0 - 1e-3), "walk {} stops before r = 2 ({}) for {:?}", walk, previous, k);
                }
                _ => {}
            }
        }
    }
}
