//! Stereo rectification as Bouguet's method (OpenCV's `stereoRectify` with
//! `CALIB_ZERO_DISPARITY`) computes it, for every lens model.
//!
//! Given the rig `X_right = R X_left + T`:
//!
//! 1. **Split the rotation.** `r = rodrigues(R)`; each camera turns by half of it towards the
//!    other: `R_half = rodrigues(-r / 2)`, so the left camera turns by `R_half^T` and the right
//!    by `R_half`; the baseline seen from the half-turned cameras is `t = R_half T`.
//! 2. **Align the baseline with x.** The axis `e` (x, or y for a vertical rig: the larger of
//!    `|t_x|`, `|t_y|`) with the sign of that component; `W` rotates `t` onto `e`
//!    (axis `t x e`, angle `acos(|t_e| / |t|)`). `R1 = W R_half^T`, `R2 = W R_half`: both
//!    rectified cameras look the same way and `R2 T = (t', 0, 0)`.
//! 3. **A common new camera matrix.** Focal length `f` = mean of the two `fy` (`fx` for a
//!    vertical rig); each camera's principal point centres the rectified images of its four image
//!    corners (of its four edge midpoints where a corner lies more than 90 degrees off the
//!    rectified axis, which a pinhole image cannot show: fisheyes wider than about 180 degrees
//!    across the diagonal); with zero disparity at infinity both take the mean of the two.
//! 4. **Scale (`alpha`).** As in [`crate::undistort::optimal_new_camera_matrix`], `s0` makes
//!    every rectified pixel of both images valid and `s1` keeps every source pixel;
//!    `f <- f (s0 (1 - alpha) + s1 alpha)`.
//! 5. `P1 = [f 0 cx 0; 0 f cy 0; 0 0 1 0]`, `P2` the same with `P2[0][3] = f t'`;
//!    `Q = [1 0 0 -cx; 0 1 0 -cy; 0 0 0 f; 0 0 -1/t' 0]` maps `(x, y, disparity, 1)` to a
//!    homogeneous 3-D point in the rectified left camera (disparity `x_left - x_right`).
//!
//! The image corners and the 9x9 grid of step 4 are undistorted with the camera model's exact
//! inverse, so pinhole and fisheye (Kannala-Brandt) cameras are handled alike: the rectified
//! images are ideal pinhole images. OpenCV keeps the corners in single precision and undistorts
//! them with 5 fixed-point iterations, so its `P1`, `P2`, `Q` differ from these by about 2e-8
//! relative without distortion and 6e-6 with it; a float64 transcription of OpenCV's code with
//! converged undistortion agrees with this one to 3e-15 (`benches/after/compare_opencv.py`).

use crate::calibration::StereoRig;
use crate::error::ExportError;
use crate::undistort::{LostPoints, Rect, clip_roi, pixel_ray, rectangles, undistort_rectangles};
use calib_core::{ImageSize, ResultFormatError};
use camera_model::{AxisAngle, RotationParameterization};
use nalgebra::{Matrix3, Matrix3x4, Matrix4, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// The result of rectifying a stereo rig. Matrices in pixels of the rectified images (OpenCV's
/// pixel convention) and board units for `P2`'s translation and `Q`.
#[derive(Debug, Clone, PartialEq)]
pub struct Rectification {
    /// Rotation from the left camera's frame to the rectified left frame.
    pub r1: Matrix3<f64>,
    /// Rotation from the right camera's frame to the rectified right frame.
    pub r2: Matrix3<f64>,
    /// Projection matrix of the rectified left camera (rectified left frame to pixels).
    pub p1: Matrix3x4<f64>,
    /// Projection matrix of the rectified right camera, in the rectified *left* frame:
    /// `P2 = [K' | K' (t', 0, 0)^T]`, `P2[0][3] = f t'`.
    pub p2: Matrix3x4<f64>,
    /// Disparity-to-depth matrix: `Q (x, y, d, 1)^T` is the homogeneous 3-D point in the
    /// rectified left frame, `d = x_left - x_right`.
    pub q: Matrix4<f64>,
    /// Image size of the rectified images (that of the input images).
    pub image_size: ImageSize,
    /// The free scaling parameter used (`None`: OpenCV's default scaling, `s = 1`).
    pub alpha: Option<f64>,
    /// Region of valid pixels in the rectified left image: `x, y, width, height`.
    pub roi1: [u32; 4],
    /// Region of valid pixels in the rectified right image.
    pub roi2: [u32; 4],
    /// True for a vertical rig (baseline mostly along y).
    pub vertical: bool,
}

/// The rectification of `rig`. `alpha` in `0..=1` (0: only valid pixels in both rectified
/// images, 1: every source pixel kept), or `None` for OpenCV's default (`alpha = -1`: no extra
/// scaling).
///
/// Errors: invalid cameras or rig, cameras of different image sizes, an image corner that cannot
/// be undistorted.
pub fn stereo_rectify(rig: &StereoRig, alpha: Option<f64>) -> Result<Rectification, ExportError> {
    rig.check()?;
    if let Some(a) = alpha {
        crate::undistort::check_alpha(a)?;
    }
    let size = rig.left.image_size;
    if rig.right.image_size != size {
        return Err(ExportError::invalid(
            "stereo rectification",
            format!(
                "the two cameras have different image sizes ({}x{} and {}x{}); rectification needs one size",
                size.width, size.height, rig.right.image_size.width, rig.right.image_size.height
            ),
        ));
    }
    let (nx, ny) = (size.width as f64, size.height as f64);

    // 1. Split the rotation.
    let r_vec = AxisAngle::from_matrix(&rig.rotation);
    let r_half = AxisAngle::matrix(&(-0.5 * r_vec));
    let t = r_half * rig.translation;
    // 2. Align the baseline with x (or y).
    let idx = if t.x.abs() > t.y.abs() { 0 } else { 1 };
    let c = t[idx];
    let mut axis = Vector3::zeros();
    axis[idx] = if c > 0.0 { 1.0 } else { -1.0 };
    let mut w = t.cross(&axis);
    let nw = w.norm();
    if nw > 0.0 {
        w *= (c.abs() / t.norm()).clamp(-1.0, 1.0).acos() / nw;
    }
    let w_r = AxisAngle::matrix(&w);
    let r1 = w_r * r_half.transpose();
    let r2 = w_r * r_half;
    let t_new = r2 * rig.translation;

    // 3. Common camera matrix.
    let other = idx ^ 1;
    let mut f = 0.5 * (rig.left.matrix()[(other, other)] + rig.right.matrix()[(other, other)]);
    let mut cc = [Vector2::zeros(); 2];
    for (k, (camera, r)) in [(&rig.left, &r1), (&rig.right, &r2)]
        .into_iter()
        .enumerate()
    {
        // The image corners; a lens that sees them beyond 90 degrees from the rectified axis (a
        // fisheye wider than about 180 degrees across the diagonal) has no pinhole image of them,
        // and the edge midpoints centre it instead.
        let corners = [
            (0.0, 0.0),
            (nx - 1.0, 0.0),
            (0.0, ny - 1.0),
            (nx - 1.0, ny - 1.0),
        ];
        let midpoints = [
            ((nx - 1.0) / 2.0, 0.0),
            (nx - 1.0, (ny - 1.0) / 2.0),
            ((nx - 1.0) / 2.0, ny - 1.0),
            (0.0, (ny - 1.0) / 2.0),
        ];
        let rectified = |points: &[(f64, f64); 4]| -> Result<Option<Vector2<f64>>, ExportError> {
            let mut sum = Vector2::zeros();
            for &(u, v) in points {
                let ray = pixel_ray(&camera.camera, &Vector2::new(u, v)).map_err(|e| {
                    ExportError::invalid(
                        format!("rectifying camera '{}'", camera.name),
                        format!(
                            "image point ({u}, {v}): {e} (a lens model that is not one-to-one out to the image corners cannot be rectified: see the calibration's model-invalid warning, and recalibrate this camera with a model valid over the image, e.g. as calib single --compare-models recommends)"
                        ),
                    )
                })?;
                let s = r * ray;
                if s.z.partial_cmp(&1e-9) != Some(std::cmp::Ordering::Greater) {
                    return Ok(None);
                }
                sum += Vector2::new(f * s.x / s.z, f * s.y / s.z);
            }
            Ok(Some(sum))
        };
        let sum = match rectified(&corners)? {
            Some(sum) => sum,
            None => rectified(&midpoints)?.ok_or_else(|| {
                ExportError::invalid(
                    format!("rectifying camera '{}'", camera.name),
                    "the middle of an image edge looks more than 90 degrees away from the rectified cameras' common axis: a rectified (pinhole) image cannot show it; the cameras are turned too far from each other, or the lens sees too wide, to share rectified images (undistort each camera alone: calib undistort)".to_string(),
                )
            })?,
        };
        let avg = sum / 4.0;
        cc[k] = Vector2::new((nx - 1.0) / 2.0 - avg.x, (ny - 1.0) / 2.0 - avg.y);
    }
    // Zero disparity at infinity: one principal point for both.
    let centre = 0.5 * (cc[0] + cc[1]);
    cc = [centre, centre];
    let projection = |f: f64, c: &Vector2<f64>, tx: f64| {
        let mut p = Matrix3x4::new(f, 0.0, c.x, 0.0, 0.0, f, c.y, 0.0, 0.0, 0.0, 1.0, 0.0);
        p[(idx, 3)] = tx;
        p
    };
    let t_idx = t_new[idx];
    let mut p1 = projection(f, &cc[0], 0.0);
    let mut p2 = projection(f, &cc[1], t_idx * f);

    // 4. Scale.
    let k3 = |p: &Matrix3x4<f64>| p.fixed_view::<3, 3>(0, 0).into_owned();
    // Keeping source pixels (alpha above 0) needs every grid point: one a fisheye sees more
    // than 90 degrees off the rectified axis has no place in a pinhole image, and leaving it out
    // gave a degenerate scale (f 0.3 px for a 200-degree pair). Alpha 0 crops to the rest.
    let policy = match alpha {
        Some(a) if a > 0.0 => LostPoints::RefusedInnerMayBeEmpty,
        _ => LostPoints::LeftOut,
    };
    let (inner1, outer1) = rectangles(&rig.left.camera, size, Some(&r1), Some(&k3(&p1)), policy)?;
    let (inner2, outer2) = rectangles(&rig.right.camera, size, Some(&r2), Some(&k3(&p2)), policy)?;
    let ratios = |r: &Rect, c: &Vector2<f64>| {
        [
            c.x / (c.x - r.x),
            c.y / (c.y - r.y),
            (nx - 1.0 - c.x) / (r.x + r.width - c.x),
            (ny - 1.0 - c.y) / (r.y + r.height - c.y),
        ]
    };
    let mut s = 1.0;
    if let Some(alpha) = alpha {
        let s1 = ratios(&outer1, &cc[0])
            .into_iter()
            .chain(ratios(&outer2, &cc[1]))
            .fold(f64::MAX, f64::min);
        s = s1;
        if alpha < 1.0 {
            // The all-valid scale needs each image's inner rectangle, which is empty when the
            // border rows and columns of a rectified image overlap (cameras rolled by about 40
            // degrees or more relative to each other; OpenCV then returns a scale from the
            // empty rectangle's edges, e.g. f = 13931 for a 35-degree roll).
            for (inner, camera) in [(&inner1, &rig.left), (&inner2, &rig.right)] {
                if !inner.is_nonempty() {
                    return Err(ExportError::invalid(
                        "stereo rectification",
                        format!(
                            "alpha {alpha}: the rectified image of camera '{}' has no rectangle of valid pixels to scale to (the cameras are rotated by {:.0} degrees relative to each other, and each rectified image is turned by half of that); use alpha 1 (every source pixel kept) or -1 (no scaling)",
                            camera.name,
                            r_vec.norm().to_degrees()
                        ),
                    ));
                }
            }
            let s0 = ratios(&inner1, &cc[0])
                .into_iter()
                .chain(ratios(&inner2, &cc[1]))
                .fold(f64::MIN, f64::max);
            s = s0 * (1.0 - alpha) + s1 * alpha;
        }
    }
    if !(s.is_finite() && s > 0.0) {
        return Err(ExportError::invalid(
            "stereo rectification",
            format!(
                "the scale for alpha {} is {s}: the rectified images would be empty (part of an image cannot be rectified into the common image plane: the cameras look too far apart)",
                alpha.unwrap_or(-1.0)
            ),
        ));
    }
    f *= s;
    p1 = projection(f, &cc[0], 0.0);
    p2 = projection(f, &cc[1], t_idx * f);
    let roi = |camera: &crate::CameraCalibration, r: &Matrix3<f64>, p: &Matrix3x4<f64>| {
        undistort_rectangles(&camera.camera, size, Some(r), Some(&k3(p)))
            .map(|(inner, _)| clip_roi(&inner, size))
    };
    let roi1 = roi(&rig.left, &r1, &p1)?;
    let roi2 = roi(&rig.right, &r2, &p2)?;

    // 5. Q.
    let (cx, cy) = (cc[0].x, cc[0].y);
    let last = if idx == 0 {
        cc[0].x - cc[1].x
    } else {
        cc[0].y - cc[1].y
    } / t_idx;
    let q = Matrix4::new(
        1.0,
        0.0,
        0.0,
        -cx, //
        0.0,
        1.0,
        0.0,
        -cy, //
        0.0,
        0.0,
        0.0,
        f, //
        0.0,
        0.0,
        -1.0 / t_idx,
        last,
    );
    Ok(Rectification {
        r1,
        r2,
        p1,
        p2,
        q,
        image_size: size,
        alpha,
        roi1,
        roi2,
        vertical: idx == 1,
    })
}

impl Rectification {
    /// The rectified camera matrix (the left 3x3 part of `P1`, equal to that of `P2`).
    pub fn camera_matrix(&self) -> Matrix3<f64> {
        self.p1.fixed_view::<3, 3>(0, 0).into_owned()
    }

    /// The JSON form: `R1`, `R2` (3x3), `P1`, `P2` (3x4), `Q` (4x4) as row-major nested lists,
    /// with `image_size`, `alpha` (`null` for OpenCV's default) and `roi1`, `roi2`
    /// (`[x, y, width, height]`). Schema in `docs/formats.md`.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(RectificationJson::from(self)).unwrap_or(serde_json::Value::Null)
    }

    /// Reads [`Rectification::to_json`]'s form.
    pub fn from_json(value: serde_json::Value) -> Result<Self, ResultFormatError> {
        let format = value.get("format").and_then(|f| f.as_str()).unwrap_or("");
        if format != RECTIFICATION_FORMAT {
            return Err(ResultFormatError::WrongKind {
                expected: "rectification file",
                found: format.to_string(),
            });
        }
        let j: RectificationJson = serde_json::from_value(value)?;
        let m3 = |r: &[[f64; 3]; 3]| Matrix3::from_fn(|i, k| r[i][k]);
        let m34 = |r: &[[f64; 4]; 3]| Matrix3x4::from_fn(|i, k| r[i][k]);
        Ok(Rectification {
            r1: m3(&j.r1),
            r2: m3(&j.r2),
            p1: m34(&j.p1),
            p2: m34(&j.p2),
            q: Matrix4::from_fn(|i, k| j.q[i][k]),
            image_size: j.image_size,
            alpha: j.alpha,
            roi1: j.roi1,
            roi2: j.roi2,
            vertical: j.vertical,
        })
    }
}

/// The `format` key of rectification files.
pub const RECTIFICATION_FORMAT: &str = "calib-rectification/1";

#[derive(Serialize, Deserialize)]
struct RectificationJson {
    format: String,
    convention: String,
    image_size: ImageSize,
    alpha: Option<f64>,
    #[serde(default)]
    vertical: bool,
    #[serde(rename = "R1")]
    r1: [[f64; 3]; 3],
    #[serde(rename = "R2")]
    r2: [[f64; 3]; 3],
    #[serde(rename = "P1")]
    p1: [[f64; 4]; 3],
    #[serde(rename = "P2")]
    p2: [[f64; 4]; 3],
    #[serde(rename = "Q")]
    q: [[f64; 4]; 4],
    roi1: [u32; 4],
    roi2: [u32; 4],
}

impl From<&Rectification> for RectificationJson {
    fn from(r: &Rectification) -> Self {
        RectificationJson {
            format: RECTIFICATION_FORMAT.into(),
            convention: "OpenCV stereoRectify (CALIB_ZERO_DISPARITY): x_rect1 ~ P1 R1 X_left, x_rect2 ~ P2 R1 X_left; Q (x, y, x_left - x_right, 1) = homogeneous point in the rectified left frame; pixels: (0,0) is the centre of the top-left pixel".into(),
            image_size: r.image_size,
            alpha: r.alpha,
            vertical: r.vertical,
            r1: std::array::from_fn(|i| std::array::from_fn(|k| r.r1[(i, k)])),
            r2: std::array::from_fn(|i| std::array::from_fn(|k| r.r2[(i, k)])),
            p1: std::array::from_fn(|i| std::array::from_fn(|k| r.p1[(i, k)])),
            p2: std::array::from_fn(|i| std::array::from_fn(|k| r.p2[(i, k)])),
            q: std::array::from_fn(|i| std::array::from_fn(|k| r.q[(i, k)])),
            roi1: r.roi1,
            roi2: r.roi2,
        }
    }
}
