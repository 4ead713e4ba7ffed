//! Undistortion of points and the choice of a new camera matrix (OpenCV's
//! `undistortPoints` and `getOptimalNewCameraMatrix`), for every lens model.
//!
//! A pixel of the calibrated camera is mapped to its viewing ray with the camera model's exact
//! inverse ([`AnyCamera::pixel_to_ray`]: Newton's method to 1e-14, pinhole and fisheye models
//! alike). The undistorted, "ideal pinhole" image of that ray after an optional rotation `R` is
//! `(x/z, y/z)` (normalized coordinates), or `P (x/z, y/z, 1)` in the pixels of a new camera
//! matrix `P`. Rays at or behind the ideal image plane (`z <= 0`, only possible for fisheye
//! lenses or large `R`) have no such image and are reported as errors.
//!
//! Pixel convention: OpenCV's, `(0, 0)` is the centre of the top-left pixel.

use crate::error::ExportError;
use calib_core::ImageSize;
use camera_model::{AnyCamera, UndistortOptions};
use nalgebra::{Matrix3, Vector2, Vector3};

/// An axis-aligned rectangle, pixels (or normalized units): top-left corner and size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    /// Left edge.
    pub x: f64,
    /// Top edge.
    pub y: f64,
    /// Width.
    pub width: f64,
    /// Height.
    pub height: f64,
}

impl Rect {
    /// True for a finite rectangle of positive width and height. The inner rectangle of
    /// [`undistort_rectangles`] is empty (negative width or height) when the border rows or
    /// columns of the undistorted image overlap, e.g. for a camera rolled far by the
    /// rectification.
    pub fn is_nonempty(&self) -> bool {
        [self.x, self.y, self.width, self.height]
            .iter()
            .all(|v| v.is_finite())
            && self.width > 0.0
            && self.height > 0.0
    }
}

/// The unit viewing ray (camera frame) through `pixel`.
pub fn pixel_ray(camera: &AnyCamera, pixel: &Vector2<f64>) -> Result<Vector3<f64>, ExportError> {
    camera
        .pixel_to_ray(pixel, &UndistortOptions::default())
        .map(|r| r.into_inner())
        .map_err(|source| ExportError::Camera {
            what: format!("undistorting pixel ({}, {})", pixel.x, pixel.y),
            source,
        })
}

/// The ideal pinhole image of ray `ray` after rotation `rotation`: `(x/z, y/z)`; an error for
/// rays with `z <= 1e-9 |ray|` (at or behind the image plane).
pub fn pinhole_image(
    rotation: &Matrix3<f64>,
    ray: &Vector3<f64>,
) -> Result<Vector2<f64>, ExportError> {
    let r = rotation * ray;
    if r.z.partial_cmp(&(1e-9 * r.norm())) != Some(std::cmp::Ordering::Greater) {
        return Err(ExportError::invalid(
            "undistortion",
            format!(
                "the ray ({:.4}, {:.4}, {:.4}) points at or behind the ideal image plane (a field of view of 180 degrees or more cannot be undistorted to one pinhole image)",
                r.x, r.y, r.z
            ),
        ));
    }
    Ok(Vector2::new(r.x / r.z, r.y / r.z))
}

/// OpenCV's `undistortPoints(src, K, D, R, P)` for one pixel: the undistorted point after the
/// rotation `rectification` (identity if `None`), in normalized coordinates, or in the pixels of
/// `new_matrix` (its 3x3 part, as OpenCV uses for a 3x4 projection matrix) when given.
pub fn undistort_point(
    camera: &AnyCamera,
    pixel: &Vector2<f64>,
    rectification: Option<&Matrix3<f64>>,
    new_matrix: Option<&Matrix3<f64>>,
) -> Result<Vector2<f64>, ExportError> {
    let ray = pixel_ray(camera, pixel)?;
    let n = pinhole_image(rectification.unwrap_or(&Matrix3::identity()), &ray)?;
    Ok(match new_matrix {
        Some(p) => {
            let h = p * Vector3::new(n.x, n.y, 1.0);
            Vector2::new(h.x / h.z, h.y / h.z)
        }
        None => n,
    })
}

/// [`undistort_point`] for many pixels; each keeps its own error.
pub fn undistort_points(
    camera: &AnyCamera,
    pixels: &[Vector2<f64>],
    rectification: Option<&Matrix3<f64>>,
    new_matrix: Option<&Matrix3<f64>>,
) -> Vec<Result<Vector2<f64>, ExportError>> {
    pixels
        .iter()
        .map(|p| undistort_point(camera, p, rectification, new_matrix))
        .collect()
}

/// Number of grid points per side of [`undistort_rectangles`] (OpenCV's 9).
pub const GRID: usize = 9;

/// The inscribed (`inner`: every pixel valid) and circumscribed (`outer`: every source pixel)
/// rectangles of the undistorted image, as OpenCV's `getUndistortRectangles` computes them: a
/// 9x9 grid of pixels `(i (w - 1) / 8, j (h - 1) / 8)` is undistorted ([`undistort_point`]
/// with `rectification` and `new_matrix`); `outer` is their bounding box, `inner` is bounded by
/// the innermost point of each border row and column, and may be empty
/// ([`Rect::is_nonempty`]). Grid points that cannot be undistorted (beyond the lens model's
/// range or behind the image plane) are left out.
pub fn undistort_rectangles(
    camera: &AnyCamera,
    image_size: ImageSize,
    rectification: Option<&Matrix3<f64>>,
    new_matrix: Option<&Matrix3<f64>>,
) -> Result<(Rect, Rect), ExportError> {
    rectangles(
        camera,
        image_size,
        rectification,
        new_matrix,
        LostPoints::LeftOut,
    )
}

/// What [`rectangles`] does with a grid point that cannot be undistorted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum LostPoints {
    /// Leave it out.
    LeftOut,
    /// Refuse (an error naming the first one); an empty inner rectangle is refused too.
    Refused,
    /// Refuse, but leave an empty inner rectangle to the caller (stereo rectification keeping
    /// every source pixel, whose rolled cameras have none).
    RefusedInnerMayBeEmpty,
    /// Leave it out if its ray points at or behind the ideal image plane (its undistorted image
    /// lies at infinity in its own direction, so it bounds no inner rectangle), refuse if the
    /// model cannot invert it; an empty inner rectangle is refused.
    BehindPlaneLeftOut,
}

/// [`undistort_rectangles`], with `policy` saying what a grid point that cannot be undistorted
/// does.
pub(crate) fn rectangles(
    camera: &AnyCamera,
    image_size: ImageSize,
    rectification: Option<&Matrix3<f64>>,
    new_matrix: Option<&Matrix3<f64>>,
    policy: LostPoints,
) -> Result<(Rect, Rect), ExportError> {
    let every_point = policy != LostPoints::LeftOut;
    let (w, h) = (image_size.width as f64, image_size.height as f64);
    let n = (GRID - 1) as f64;
    let (mut ix0, mut ix1, mut iy0, mut iy1) = (f64::MIN, f64::MAX, f64::MIN, f64::MAX);
    let (mut ox0, mut ox1, mut oy0, mut oy1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    let mut count = 0;
    let mut first_lost = None;
    let mut lost_behind_plane = false;
    for j in 0..GRID {
        for i in 0..GRID {
            let pixel = Vector2::new(i as f64 * (w - 1.0) / n, j as f64 * (h - 1.0) / n);
            let p = match undistort_point(camera, &pixel, rectification, new_matrix) {
                Ok(p) => p,
                Err(e) => {
                    let behind = !matches!(e, ExportError::Camera { .. });
                    lost_behind_plane |= behind;
                    if !(behind && policy == LostPoints::BehindPlaneLeftOut) {
                        first_lost.get_or_insert((pixel, e));
                    }
                    continue;
                }
            };
            count += 1;
            ox0 = ox0.min(p.x);
            ox1 = ox1.max(p.x);
            oy0 = oy0.min(p.y);
            oy1 = oy1.max(p.y);
            if i == 0 {
                ix0 = ix0.max(p.x);
            }
            if i == GRID - 1 {
                ix1 = ix1.min(p.x);
            }
            if j == 0 {
                iy0 = iy0.max(p.y);
            }
            if j == GRID - 1 {
                iy1 = iy1.min(p.y);
            }
        }
    }
    let inner = Rect {
        x: ix0,
        y: iy0,
        width: ix1 - ix0,
        height: iy1 - iy0,
    };
    let outer = Rect {
        x: ox0,
        y: oy0,
        width: ox1 - ox0,
        height: oy1 - oy0,
    };
    let lost = GRID * GRID - count;
    if let Some((first, error)) = first_lost.filter(|_| every_point) {
        let why = if let ExportError::Camera { source, .. } = &error {
            // The camera model's inverse failed: the distortion is not one-to-one there.
            format!(
                "{source}: the lens model is not one-to-one out to the image corners (see the calibration's model-invalid warning), so no new camera matrix covers this image; recalibrate with a model valid over the image, e.g. as calib single --compare-models recommends"
            )
        } else {
            // A fisheye seeing more than 90 degrees off its axis there: without those points
            // the rectangles lose their border, and the camera matrix came out degenerate
            // (fx 1.3 against fy 2.6 for a 200-degree lens) instead of failing.
            "it has no direction in front of the camera's image plane: the lens sees more than 90 degrees off its axis there, which an undistorted (pinhole) image cannot show, so no new camera matrix covers this image; alpha 0 (only valid pixels) keeps the part of the image within 90 degrees of the axis".to_string()
        };
        return Err(ExportError::invalid(
            "undistortion",
            format!(
                "{lost} of {} grid points over the {}x{} image cannot be undistorted; the first, pixel ({}, {}): {why}",
                GRID * GRID,
                image_size.width,
                image_size.height,
                first.x,
                first.y
            ),
        ));
    }
    if policy == LostPoints::BehindPlaneLeftOut && lost_behind_plane && !inner.is_nonempty() {
        return Err(ExportError::invalid(
            "undistortion",
            format!(
                "{lost} of {} grid points over the {}x{} image look more than 90 degrees off the lens axis, so many that no rectangle of valid undistorted pixels is bounded (a whole border row or column of the image lies beyond 90 degrees): this lens has no undistorted (pinhole) image",
                GRID * GRID,
                image_size.width,
                image_size.height
            ),
        ));
    }
    let needs_inner = matches!(policy, LostPoints::Refused | LostPoints::BehindPlaneLeftOut);
    if count < 4 || !outer.is_nonempty() || (needs_inner && !inner.is_nonempty()) {
        return Err(ExportError::invalid(
            "undistortion",
            format!(
                "only {count} of {} grid points over the {}x{} image can be undistorted: the lens model does not cover the image",
                GRID * GRID,
                image_size.width,
                image_size.height
            ),
        ));
    }
    Ok((inner, outer))
}

/// Checks a free scaling parameter: `0..=1`.
pub(crate) fn check_alpha(alpha: f64) -> Result<(), ExportError> {
    if (0.0..=1.0).contains(&alpha) {
        Ok(())
    } else {
        Err(ExportError::invalid(
            "alpha",
            format!("expected a number from 0 to 1, got {alpha}"),
        ))
    }
}

/// A new camera matrix for undistorted images of size `image_size`, chosen like OpenCV's
/// `getOptimalNewCameraMatrix(K, D, size, alpha)` (principal point not forced to the centre):
/// with `alpha = 0` the undistorted image shows only valid pixels (the inner rectangle of
/// [`undistort_rectangles`] fills the image), with `alpha = 1` every source pixel is kept (the
/// outer rectangle fills it); values between interpolate the focal lengths and principal point
/// linearly. Also returns the valid-pixel region of the new image (OpenCV's `validPixROI`, as
/// integers `x, y, width, height`, clipped to the image).
pub fn optimal_new_camera_matrix(
    camera: &AnyCamera,
    image_size: ImageSize,
    alpha: f64,
) -> Result<(Matrix3<f64>, [u32; 4]), ExportError> {
    check_alpha(alpha)?;
    let (w, h) = (image_size.width as f64, image_size.height as f64);
    // With alpha 0 only the inner rectangle counts, which points beyond 90 degrees off the
    // axis of a wide fisheye do not bound: the undistorted image then crops to the rest.
    let policy = if alpha == 0.0 {
        LostPoints::BehindPlaneLeftOut
    } else {
        LostPoints::Refused
    };
    let (inner, mut outer) = rectangles(camera, image_size, None, None, policy)?;
    if alpha == 0.0 {
        outer = inner;
    }
    let fx0 = (w - 1.0) / inner.width;
    let fy0 = (h - 1.0) / inner.height;
    let cx0 = -fx0 * inner.x;
    let cy0 = -fy0 * inner.y;
    let fx1 = (w - 1.0) / outer.width;
    let fy1 = (h - 1.0) / outer.height;
    let cx1 = -fx1 * outer.x;
    let cy1 = -fy1 * outer.y;
    let fx = fx0 * (1.0 - alpha) + fx1 * alpha;
    let fy = fy0 * (1.0 - alpha) + fy1 * alpha;
    let cx = cx0 * (1.0 - alpha) + cx1 * alpha;
    let cy = cy0 * (1.0 - alpha) + cy1 * alpha;
    let k = Matrix3::new(fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0);
    let (roi_inner, _) = undistort_rectangles(camera, image_size, None, Some(&k))?;
    Ok((k, clip_roi(&roi_inner, image_size)))
}

/// OpenCV's integer valid region of a rectangle: `ceil` of the corner, `floor` of the size,
/// intersected with the image (with 1e-9 px of slack, so rounding noise around an integer does
/// not move the region by a pixel).
pub(crate) fn clip_roi(r: &Rect, size: ImageSize) -> [u32; 4] {
    const SLACK: f64 = 1e-9;
    let (cx, cy) = ((r.x - SLACK).ceil(), (r.y - SLACK).ceil());
    let x0 = cx.max(0.0);
    let y0 = cy.max(0.0);
    let x1 = (cx + (r.width + SLACK).floor()).min(size.width as f64);
    let y1 = (cy + (r.height + SLACK).floor()).min(size.height as f64);
    if x1 <= x0 || y1 <= y0 {
        return [0, 0, 0, 0];
    }
    [x0 as u32, y0 as u32, (x1 - x0) as u32, (y1 - y0) as u32]
}

#[cfg(test)]
mod tests {
    use super::*;
    use camera_model::{CameraModel, Intrinsics};

    /// An equidistant lens with f = 200 px sees 91.5 degrees at the middle of the 640x480
    /// image's left and right edges and 114 degrees at its corners: no pinhole image holds that,
    /// and the new camera matrix is refused instead of coming out degenerate (with alpha 0 too:
    /// the whole left and right border columns lie beyond 90 degrees, so no rectangle of valid
    /// pixels is bounded). At f = 230 only the corners do (99.6 degrees; 79.7 at the side
    /// edges): alpha 1 is refused, alpha 0 crops to the part within 90 degrees (every corner of
    /// the new image sees a pixel of the source image). At f = 400 (46 and 57 degrees) both are
    /// computed.
    #[test]
    fn a_fisheye_beyond_90_degrees_has_only_a_cropped_undistorted_camera() {
        let fisheye = |f: f64| {
            AnyCamera::new(
                CameraModel::KannalaBrandt4,
                Intrinsics::new(f, f, 319.5, 239.5),
                vec![0.0; 4],
            )
            .unwrap()
        };
        let size = ImageSize {
            width: 640,
            height: 480,
        };
        for alpha in [0.0, 1.0] {
            let err = optimal_new_camera_matrix(&fisheye(200.0), size, alpha).unwrap_err();
            assert!(err.to_string().contains("90 degrees"), "{alpha}: {err}");
        }
        let err = optimal_new_camera_matrix(&fisheye(230.0), size, 1.0).unwrap_err();
        assert!(err.to_string().contains("more than 90 degrees"), "{err}");
        assert!(err.to_string().contains("alpha 0"), "{err}");
        let wide = fisheye(230.0);
        let (k0, _) = optimal_new_camera_matrix(&wide, size, 0.0).unwrap();
        let k0_inv = k0.try_inverse().unwrap();
        for (u, v) in [
            (0.0, 0.0),
            (639.0, 0.0),
            (0.0, 479.0),
            (639.0, 479.0),
            (0.0, 239.5),
        ] {
            let src = wide
                .project_camera_point(&(k0_inv * Vector3::new(u, v, 1.0)))
                .unwrap();
            assert!(
                src.x > -1.0 && src.x < 640.0 && src.y > -1.0 && src.y < 480.0,
                "corner ({u}, {v}) sees {src}"
            );
        }
        for alpha in [0.0, 1.0] {
            let (k, _) = optimal_new_camera_matrix(&fisheye(400.0), size, alpha).unwrap();
            assert!(
                k[(0, 0)] > 50.0 && (k[(0, 0)] / k[(1, 1)] - 1.0).abs() < 0.5,
                "{k}"
            );
        }
    }

    /// A lens model that folds inside the image (k1 = -0.6 at f = 500: the radial map
    /// `r (1 + k1 r^2)` turns back at r = 0.745, the corners are at r = 0.8) is refused for the
    /// fold, not for a field of view beyond 90 degrees, which this narrow lens does not have.
    #[test]
    fn a_model_folding_inside_the_image_is_refused_for_the_fold() {
        let cam = AnyCamera::new(
            CameraModel::BrownConrady4,
            Intrinsics::new(500.0, 500.0, 319.5, 239.5),
            vec![-0.6, 0.0, 0.0, 0.0],
        )
        .unwrap();
        let err = optimal_new_camera_matrix(&cam, ImageSize::new(640, 480), 0.0)
            .unwrap_err()
            .to_string();
        assert!(err.contains("not one-to-one"), "{err}");
        assert!(!err.contains("90 degrees"), "{err}");
    }

    fn camera(model: CameraModel, k1: f64) -> AnyCamera {
        let mut d = vec![0.0; model.num_distortion_params()];
        d[0] = k1;
        AnyCamera::new(model, Intrinsics::new(500.0, 480.0, 330.0, 230.0), d).unwrap()
    }

    /// Ground truth by construction: project known rays, undistort the pixels, compare with the
    /// rays' pinhole images.
    #[test]
    fn undistorted_points_are_the_rays_pinhole_images_for_every_model() {
        for model in CameraModel::ALL {
            let mut cam = camera(model, -0.2);
            for (i, d) in cam.distortion.iter_mut().enumerate().skip(1) {
                *d = 0.01 * ((i * 7919) % 13) as f64 / 13.0 - 0.004;
            }
            let k_new = Matrix3::new(400.0, 0.0, 320.0, 0.0, 400.0, 240.0, 0.0, 0.0, 1.0);
            let r = <camera_model::AxisAngle as camera_model::RotationParameterization>::matrix(
                &Vector3::new(0.02, -0.03, 0.01),
            );
            for ray in [
                Vector3::new(0.1, -0.2, 1.0),
                Vector3::new(-0.4, 0.3, 1.0),
                Vector3::new(0.0, 0.0, 1.0),
            ] {
                let pixel = cam.project_camera_point(&ray).unwrap();
                let n = undistort_point(&cam, &pixel, None, None).unwrap();
                assert!(
                    (n - ray.xy() / ray.z).norm() < 1e-12,
                    "{model}: {n} vs {ray}"
                );
                let q = undistort_point(&cam, &pixel, Some(&r), Some(&k_new)).unwrap();
                let s = r * ray;
                let expected = Vector2::new(400.0 * s.x / s.z + 320.0, 400.0 * s.y / s.z + 240.0);
                assert!((q - expected).norm() < 1e-9, "{model}: {q} vs {expected}");
            }
        }
    }

    /// Without distortion the undistorted image is the image itself: alpha 0 and 1 both give
    /// back K (inner = outer = the image), to rounding.
    #[test]
    fn optimal_matrix_of_an_undistorted_camera_is_its_own() {
        for model in CameraModel::ALL {
            if model.is_fisheye() {
                continue;
            }
            let cam = camera(model, 0.0);
            let size = ImageSize::new(640, 480);
            for alpha in [0.0, 0.5, 1.0] {
                let (k, roi) = optimal_new_camera_matrix(&cam, size, alpha).unwrap();
                assert!((k - cam.matrix()).amax() < 1e-9, "{model} {alpha}: {k}");
                // The inner rectangle spans pixel centres 0..w-1, so its floor'ed width is w - 1
                // (OpenCV reports the same).
                assert_eq!(roi, [0, 0, 639, 479]);
            }
        }
    }

    /// Barrel distortion (k1 < 0) pulls the image corners in: the undistorted corners spread
    /// beyond the image, so alpha 1 (all source pixels) needs a shorter focal length than alpha 0
    /// (only valid pixels); every source corner lands inside the alpha-1 image, and the alpha-0
    /// image's corners all see valid source pixels.
    #[test]
    fn alpha_zero_keeps_only_valid_pixels_and_alpha_one_keeps_all() {
        for model in [
            CameraModel::BrownConrady4,
            CameraModel::Rational8,
            CameraModel::KannalaBrandt4,
        ] {
            let cam = camera(model, -0.15);
            let size = ImageSize::new(640, 480);
            let (k0, _) = optimal_new_camera_matrix(&cam, size, 0.0).unwrap();
            let (k1, _) = optimal_new_camera_matrix(&cam, size, 1.0).unwrap();
            assert!(k1[(0, 0)] < k0[(0, 0)], "{model}: {k1} vs {k0}");
            for (u, v) in [
                (0.0, 0.0),
                (639.0, 0.0),
                (0.0, 479.0),
                (639.0, 479.0),
                (319.5, 0.0),
            ] {
                let q = undistort_point(&cam, &Vector2::new(u, v), None, Some(&k1)).unwrap();
                assert!(
                    q.x > -0.5 - 1e-6
                        && q.x < 639.5 + 1e-6
                        && q.y > -0.5 - 1e-6
                        && q.y < 479.5 + 1e-6,
                    "{model}: corner ({u}, {v}) -> {q}"
                );
                // The alpha-0 image's corner pixel seen by the source camera lies in the image.
                let k0_inv = k0.try_inverse().unwrap();
                let ray = k0_inv * Vector3::new(u, v, 1.0);
                let src = cam.project_camera_point(&ray).unwrap();
                assert!(
                    src.x > -1.0 && src.x < 640.0 && src.y > -1.0 && src.y < 480.0,
                    "{model}: {src}"
                );
            }
        }
        assert!(
            optimal_new_camera_matrix(
                &camera(CameraModel::BrownConrady4, 0.0),
                ImageSize::new(64, 48),
                1.5
            )
            .is_err()
        );
    }
}
