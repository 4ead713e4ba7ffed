//! Pixel maps and bilinear resampling: OpenCV's `initUndistortRectifyMap` + `remap`.
//!
//! A [`PixelMap`] holds, for every pixel of the output image, the source pixel it shows
//! (computed once per camera); [`remap_image`] resamples any number of images with it. Output
//! pixel `(u, v)` looks along the ray `R^T K'^-1 (u, v, 1)` of the source camera (`K'` the new
//! camera matrix, `R` the rectification rotation, identity for plain undistortion), which the
//! camera model projects to the source pixel (any lens model; fisheye rays may point sideways).
//! Rays the model cannot project (behind a pinhole camera) map to nothing and give black pixels.

use crate::calibration::CameraCalibration;
use crate::error::ExportError;
use calib_core::ImageSize;
use image::{DynamicImage, ImageBuffer, Pixel};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

/// For every pixel of an output image, the source pixel it shows (OpenCV's pixel convention),
/// or NaN where no source pixel exists.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelMap {
    /// Output size.
    pub size: ImageSize,
    /// Source `(x, y)` per output pixel, row-major (`v * width + u`).
    pub source: Vec<[f32; 2]>,
}

impl PixelMap {
    /// The map of `camera` to the ideal pinhole camera `new_matrix` turned by `rotation`
    /// (OpenCV's `initUndistortRectifyMap(K, D, R, P, size)`), for an output of `size`.
    pub fn new(
        camera: &CameraCalibration,
        rotation: &Matrix3<f64>,
        new_matrix: &Matrix3<f64>,
        size: ImageSize,
    ) -> Result<Self, ExportError> {
        camera.check()?;
        let inverse = (new_matrix * rotation).try_inverse().ok_or_else(|| {
            ExportError::invalid(
                "pixel map",
                "the new camera matrix times the rotation is singular",
            )
        })?;
        if size.width == 0 || size.height == 0 {
            return Err(ExportError::invalid(
                "pixel map",
                "the output image is empty",
            ));
        }
        let w = size.width as usize;
        let mut source = vec![[f32::NAN; 2]; w * size.height as usize];
        source.par_chunks_mut(w).enumerate().for_each(|(v, row)| {
            for (u, out) in row.iter_mut().enumerate() {
                let ray = inverse * Vector3::new(u as f64, v as f64, 1.0);
                if let Ok(p) = camera.camera.project_camera_point(&ray)
                    && p.x.is_finite()
                    && p.y.is_finite()
                {
                    *out = [p.x as f32, p.y as f32];
                }
            }
        });
        Ok(Self { size, source })
    }

    /// The undistortion map of `camera` to `new_matrix` (no rotation), same image size.
    pub fn undistort(
        camera: &CameraCalibration,
        new_matrix: &Matrix3<f64>,
    ) -> Result<Self, ExportError> {
        Self::new(camera, &Matrix3::identity(), new_matrix, camera.image_size)
    }
}

/// A channel type [`remap_image`] resamples in place: 8 or 16 bits.
trait Channel: image::Primitive + Into<f32> + Send + Sync {
    /// The channel value nearest to `v`, clamped to the type's range.
    fn from_f32(v: f32) -> Self;
}

impl Channel for u8 {
    fn from_f32(v: f32) -> Self {
        v.round().clamp(0.0, 255.0) as u8
    }
}

impl Channel for u16 {
    fn from_f32(v: f32) -> Self {
        v.round().clamp(0.0, 65535.0) as u16
    }
}

/// Bilinear sample of channel values at `(x, y)`; pixels outside the image count as zero
/// (OpenCV's `BORDER_CONSTANT`), and a point with no neighbour inside is `None`.
fn sample<S: Channel, P: Pixel<Subpixel = S>>(
    image: &ImageBuffer<P, Vec<S>>,
    x: f32,
    y: f32,
) -> Option<[f32; 4]> {
    if !(x.is_finite() && y.is_finite()) {
        return None;
    }
    let (w, h) = (image.width() as i64, image.height() as i64);
    let x0 = x.floor() as i64;
    let y0 = y.floor() as i64;
    if x0 < -1 || y0 < -1 || x0 >= w || y0 >= h {
        return None;
    }
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let mut acc = [0.0f32; 4];
    for (dx, dy, weight) in [
        (0, 0, (1.0 - fx) * (1.0 - fy)),
        (1, 0, fx * (1.0 - fy)),
        (0, 1, (1.0 - fx) * fy),
        (1, 1, fx * fy),
    ] {
        let (px, py) = (x0 + dx, y0 + dy);
        if px < 0 || py < 0 || px >= w || py >= h || weight == 0.0 {
            continue;
        }
        let p = image.get_pixel(px as u32, py as u32);
        for (a, c) in acc.iter_mut().zip(p.channels()) {
            *a += weight * (*c).into();
        }
    }
    Some(acc)
}

fn remap_buffer<S: Channel, P: Pixel<Subpixel = S> + Sync>(
    image: &ImageBuffer<P, Vec<S>>,
    map: &PixelMap,
) -> ImageBuffer<P, Vec<S>> {
    let channels = P::CHANNEL_COUNT as usize;
    let w = map.size.width as usize;
    let mut data = vec![S::DEFAULT_MIN_VALUE; w * map.size.height as usize * channels];
    data.par_chunks_mut(w * channels)
        .enumerate()
        .for_each(|(v, row)| {
            for u in 0..w {
                let [x, y] = map.source[v * w + u];
                if let Some(acc) = sample(image, x, y) {
                    for c in 0..channels {
                        row[u * channels + c] = S::from_f32(acc[c]);
                    }
                }
            }
        });
    ImageBuffer::from_raw(map.size.width, map.size.height, data)
        .expect("buffer of width x height x channels")
}

/// Resamples `image` through `map` (bilinear, black where the map has no source). Grey, grey
/// with alpha, RGB and RGBA images of 8 or 16 bits keep their type (as `cv2.remap` keeps the
/// depth); other types (32-bit float) are converted to 8-bit RGB.
pub fn remap_image(image: &DynamicImage, map: &PixelMap) -> DynamicImage {
    match image {
        DynamicImage::ImageLuma8(b) => DynamicImage::ImageLuma8(remap_buffer(b, map)),
        DynamicImage::ImageRgb8(b) => DynamicImage::ImageRgb8(remap_buffer(b, map)),
        DynamicImage::ImageRgba8(b) => DynamicImage::ImageRgba8(remap_buffer(b, map)),
        DynamicImage::ImageLumaA8(b) => DynamicImage::ImageLumaA8(remap_buffer(b, map)),
        DynamicImage::ImageLuma16(b) => DynamicImage::ImageLuma16(remap_buffer(b, map)),
        DynamicImage::ImageRgb16(b) => DynamicImage::ImageRgb16(remap_buffer(b, map)),
        DynamicImage::ImageRgba16(b) => DynamicImage::ImageRgba16(remap_buffer(b, map)),
        DynamicImage::ImageLumaA16(b) => DynamicImage::ImageLumaA16(remap_buffer(b, map)),
        other => DynamicImage::ImageRgb8(remap_buffer(&other.to_rgb8(), map)),
    }
}

/// Reads an image file (JPEG or PNG) as the detector and `cv2.imread` read it: upright (EXIF
/// orientation applied), its channels and depth kept ([`board_detect::load_upright`]).
pub fn read_image(path: &std::path::Path) -> Result<DynamicImage, ExportError> {
    board_detect::load_upright(path, &board_detect::DetectOptions::default()).map_err(|e| {
        ExportError::Image {
            path: path.display().to_string(),
            reason: e.to_string(),
        }
    })
}

/// Encodes `image` by the extension of `path` (`.png`, or `.jpg`/`.jpeg` at quality 95) and
/// writes it atomically (a failure leaves any previous file in place).
pub fn write_image(image: &DynamicImage, path: &std::path::Path) -> Result<(), ExportError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let mut bytes = Vec::new();
    let fail = |reason: String| ExportError::Image {
        path: path.display().to_string(),
        reason,
    };
    match ext.as_str() {
        "png" => image
            .write_to(
                &mut std::io::Cursor::new(&mut bytes),
                image::ImageFormat::Png,
            )
            .map_err(|e| fail(e.to_string()))?,
        "jpg" | "jpeg" => {
            let rgb = match image {
                DynamicImage::ImageLuma8(_) | DynamicImage::ImageRgb8(_) => image.clone(),
                other => DynamicImage::ImageRgb8(other.to_rgb8()),
            };
            let encoder = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, 95);
            rgb.write_with_encoder(encoder)
                .map_err(|e| fail(e.to_string()))?;
        }
        other => {
            return Err(fail(format!(
                "cannot write '.{other}' images (use .png, .jpg or .jpeg)"
            )));
        }
    }
    calib_core::write_atomically(path, &bytes).map_err(|source| ExportError::Write {
        path: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use camera_model::{AnyCamera, CameraModel, Intrinsics};

    /// Undistorting a rendered image equals rendering the undistorted image: a smooth intensity
    /// pattern defined on the ideal (undistorted) image plane is drawn through the distorted
    /// camera, remapped, and compared with the pattern drawn directly with the new camera
    /// matrix. Bilinear interpolation of the smooth pattern (period 40 px, amplitude 100) errs
    /// by at most amplitude * (2 pi / 40)^2 / 8 ~ 0.3 levels, plus 0.5 of rounding each way.
    #[test]
    fn remapped_image_equals_the_ideal_rendering() {
        let camera = CameraCalibration::new(
            "c",
            AnyCamera::new(
                CameraModel::BrownConrady5,
                Intrinsics::new(300.0, 310.0, 161.0, 118.0),
                vec![-0.25, 0.08, 0.001, -0.002, -0.01],
            )
            .unwrap(),
            ImageSize::new(320, 240),
        )
        .unwrap();
        let k_new = Matrix3::new(250.0, 0.0, 160.0, 0.0, 250.0, 120.0, 0.0, 0.0, 1.0);
        let pattern = |x: f64, y: f64| {
            128.0
                + 50.0 * (x * std::f64::consts::TAU / 40.0).sin()
                + 50.0 * (y * std::f64::consts::TAU / 40.0).cos()
        };
        // The scene: the pattern on the plane z = 1 in the new camera's pixels.
        let source = image::GrayImage::from_fn(320, 240, |u, v| {
            let n = camera
                .camera
                .undistort_pixel(
                    &nalgebra::Vector2::new(u as f64, v as f64),
                    &Default::default(),
                )
                .unwrap();
            let q = k_new * Vector3::new(n.x, n.y, 1.0);
            image::Luma([pattern(q.x, q.y).round() as u8])
        });
        let map = PixelMap::undistort(&camera, &k_new).unwrap();
        // The same scene in 16 bits (256 times the levels) keeps its depth through the remap,
        // as cv2.remap does (it was converted to 8-bit RGB).
        let deep = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(320, 240, |u, v| {
            image::Luma([source.get_pixel(u, v)[0] as u16 * 256])
        });
        let out8 = remap_image(&DynamicImage::ImageLuma8(source), &map);
        let out16 = remap_image(&DynamicImage::ImageLuma16(deep), &map);
        let DynamicImage::ImageLuma16(out16) = out16 else {
            panic!("16-bit grey came out as {:?}", out16.color());
        };
        let out8 = out8.to_luma8();
        let (mut worst, mut worst16): (f64, f64) = (0.0, 0.0);
        for v in 20..220 {
            for u in 20..300 {
                let [x, y] = map.source[v * 320 + u];
                if x < 1.0 || y < 1.0 || x > 318.0 || y > 238.0 {
                    continue;
                }
                let expected = pattern(u as f64, v as f64);
                let (u, v) = (u as u32, v as u32);
                worst = worst.max((out8.get_pixel(u, v)[0] as f64 - expected).abs());
                worst16 = worst16.max((out16.get_pixel(u, v)[0] as f64 / 256.0 - expected).abs());
            }
        }
        assert!(worst <= 1.5, "worst difference {worst} levels");
        assert!(
            worst16 <= 1.5,
            "16 bits: worst difference {worst16} levels of 8 bits"
        );
    }
}
