//! What the engine calibrates from: views of a planar board, each a list of board points matched
//! to measured pixels, and the image size of each camera.

use nalgebra::{Point2, Point3};
use serde::{Deserialize, Serialize};

/// Image size in pixels. In files: `[width, height]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(from = "[u32; 2]", into = "[u32; 2]")]
pub struct ImageSize {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl From<[u32; 2]> for ImageSize {
    fn from([width, height]: [u32; 2]) -> Self {
        Self { width, height }
    }
}

impl From<ImageSize> for [u32; 2] {
    fn from(s: ImageSize) -> Self {
        [s.width, s.height]
    }
}

impl ImageSize {
    /// A size.
    pub const fn new(width: u32, height: u32) -> Self {
        Self { width, height }
    }

    /// The image centre in OpenCV's pixel convention: `((w - 1) / 2, (h - 1) / 2)` (the first
    /// pixel's centre is `(0, 0)`).
    pub fn centre(&self) -> (f64, f64) {
        (
            (self.width as f64 - 1.0) / 2.0,
            (self.height as f64 - 1.0) / 2.0,
        )
    }

    /// The distance from the image centre to its farthest corner, pixels.
    pub fn half_diagonal(&self) -> f64 {
        let (cx, cy) = self.centre();
        cx.hypot(cy)
    }

    /// True if the pixel is inside the image extended by `margin` pixels on every side.
    pub fn contains(&self, x: f64, y: f64, margin: f64) -> bool {
        x >= -0.5 - margin
            && y >= -0.5 - margin
            && x <= self.width as f64 - 0.5 + margin
            && y <= self.height as f64 - 0.5 + margin
    }
}

/// One view of the board by one camera.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// A name for messages and reports (the image file name, or "view N").
    pub name: String,
    /// Board points, in board units; the planar method needs `Z = 0`.
    pub object_points: Vec<Point3<f64>>,
    /// Measured pixels (OpenCV convention), in the same order.
    pub image_points: Vec<Point2<f64>>,
}
