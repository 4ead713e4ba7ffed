//! Pinhole intrinsics: focal lengths and principal point in pixels.

use nalgebra::{Matrix3, Vector2, Vector4};
use serde::{Deserialize, Serialize};

/// Pinhole intrinsics, in pixels.
///
/// A point `(x_n, y_n)` of the normalized image plane (`z = 1` in the camera frame, after lens
/// distortion) lands at pixel `(fx * x_n + cx, fy * y_n + cy)`.
///
/// Pixel convention (OpenCV's, used throughout the workspace): `(0, 0)` is the *centre* of the
/// top-left pixel, `x` grows to the right and `y` downwards. Tools that put the first pixel centre
/// at `(1, 1)` (MATLAB, Bouguet's toolbox) report `cx`, `cy` larger by exactly one.
///
/// In the calibration literature these are `alpha_x = f k_x`, `alpha_y = f k_y` (focal length times
/// pixels per unit length) and the principal point `(x_o, y_o)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Horizontal focal length `alpha_x`, pixels.
    pub fx: f64,
    /// Vertical focal length `alpha_y`, pixels.
    pub fy: f64,
    /// Principal point, horizontal coordinate `x_o`, pixels.
    pub cx: f64,
    /// Principal point, vertical coordinate `y_o`, pixels.
    pub cy: f64,
}

impl Intrinsics {
    /// Number of parameters, in the order `[fx, fy, cx, cy]`.
    pub const NUM_PARAMS: usize = 4;

    /// Parameter names in parameter order.
    pub const PARAM_NAMES: [&'static str; 4] = ["fx", "fy", "cx", "cy"];

    /// Intrinsics from focal lengths and principal point (pixels).
    pub const fn new(fx: f64, fy: f64, cx: f64, cy: f64) -> Self {
        Self { fx, fy, cx, cy }
    }

    /// The parameter vector `[fx, fy, cx, cy]`.
    pub fn to_vector(&self) -> Vector4<f64> {
        Vector4::new(self.fx, self.fy, self.cx, self.cy)
    }

    /// Intrinsics from the parameter vector `[fx, fy, cx, cy]`.
    pub fn from_slice(p: &[f64; 4]) -> Self {
        Self::new(p[0], p[1], p[2], p[3])
    }

    /// The camera matrix `K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`.
    pub fn matrix(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }

    /// Pixel of a (distorted) normalized image point.
    #[inline]
    pub fn to_pixel(&self, normalized: &Vector2<f64>) -> Vector2<f64> {
        Vector2::new(
            self.fx * normalized.x + self.cx,
            self.fy * normalized.y + self.cy,
        )
    }

    /// Normalized image point of a pixel (the inverse of [`Intrinsics::to_pixel`]).
    ///
    /// Requires non-zero focal lengths, which [`Intrinsics::is_valid`] checks.
    #[inline]
    pub fn to_normalized(&self, pixel: &Vector2<f64>) -> Vector2<f64> {
        Vector2::new((pixel.x - self.cx) / self.fx, (pixel.y - self.cy) / self.fy)
    }

    /// True when all four values are finite and both focal lengths are positive.
    pub fn is_valid(&self) -> bool {
        self.fx.is_finite()
            && self.fy.is_finite()
            && self.cx.is_finite()
            && self.cy.is_finite()
            && self.fx > 0.0
            && self.fy > 0.0
    }
}
