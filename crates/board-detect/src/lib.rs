//! Chessboard corner detection for camera calibration.
//!
//! Image in, labelled sub-pixel chessboard corners out, or a typed [`DetectError`] saying why
//! not. No dependency on the calibration solvers. The method and its measured accuracy and
//! speed are in `docs/board-detect.md`.
//!
//! # Conventions
//!
//! * A board is given by its inner corners, `cols x rows` (a 9x6 board has 10x7 squares).
//! * Corner `(c, r)` has object point `(c * square, r * square, 0)` and index `r * cols + c`
//!   (row-major), the order of OpenCV's `findChessboardCorners` in the workspace's data files.
//! * Pixels follow OpenCV: the centre of the top-left pixel is `(0, 0)`, `x` right, `y` down.
//! * Orientation: the labels are right-handed in the image (from the row direction to the
//!   column direction is clockwise on the screen, as the board is seen from its printed side).
//!   When `cols + rows` is odd (9x6), a 180-degree rotation swaps the square colours, and the
//!   labels are chosen so that the **cell between corners `0`, `1`, `cols` and `cols + 1` is
//!   dark**: the same physical corner is corner 0 in every image, so the two cameras of a
//!   stereo pair agree whatever the board's rotation. When `cols + rows` is even (8x6, 7x5)
//!   the board with its colours is symmetric under 180 degrees and no image can tell; the
//!   labels are then chosen so that the row direction points to the image's right, and a
//!   board whose rows are within about 10 degrees of vertical is refused as
//!   [`DetectError::AmbiguousOrientation`] rather than guessed. Square boards (`cols == rows`)
//!   follow the same two rules over their four rotations.
//!
//! # Pipeline
//!
//! 1. Search (on a copy downscaled to a pixel budget, coarse level first): saddle points of
//!    the blurred image (`Ixy^2 - Ixx Iyy`), kept when a ring around them shows two bright
//!    and two dark opposite sectors.
//! 2. Grid: a 3x3 seed of candidates with alternating cell colours, grown a row or column at
//!    a time by projective extrapolation; corners the search missed are predicted and must
//!    pass the ring test.
//! 3. Labels by the rules above; checks that the grid is the board's size.
//! 4. Refinement at full resolution (default: saddle point of a quadratic fitted to the
//!    lightly blurred image, see [`Refinement`]).
//! 5. Verification: every corner must lie where the lines through its row and column
//!    neighbours cross.
//!
//! # Example
//!
//! ```
//! use board_detect::synth::Scene;
//! use board_detect::{Board, DetectOptions, GrayView, detect};
//!
//! // A rendered 9x6 board with known corners (any 8-bit grey buffer works the same way).
//! let scene = Scene::default();
//! let rendered = scene.render();
//! let view = GrayView::packed(&rendered.pixels, scene.width, scene.height)?;
//! let board = Board::new(9, 6, 1.0)?;
//! let found = detect(&view, &board, &DetectOptions::default())?;
//! let worst = found
//!     .corners
//!     .iter()
//!     .zip(&rendered.corners)
//!     .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
//!     .fold(0.0, f64::max);
//! assert!(worst < 0.2);
//! # Ok::<(), board_detect::DetectError>(())
//! ```
//!
//! Files: [`detect_file`] and [`detect_files`] (parallel over images, per-image results and
//! detection times), [`observations_json`], [`stereo_observations_json`] and [`rig_observations_json`] (the workspace's
//! observation format), [`write_overlay_png`] (a picture of what was found).
#![deny(missing_docs)]

mod candidates;
mod detect;
mod draw;
mod error;
mod gray;
mod grid;
mod label;
mod refine;
mod symmetry;
mod warp;

pub use draw::{draw_detection, write_overlay_png};
pub use error::DetectError;
pub use gray::GrayView;
/// The `image` crate whose types this crate's API takes and returns.
pub use image;

/// A chessboard, described by its inner corners: `cols` corners per row, `rows` per column
/// (a 9x6 board has 10x7 squares). Corner `(c, r)` has object point `(c * square, r * square, 0)`
/// and index `r * cols + c` (row-major).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Board {
    /// Inner corners per row (along the board's X axis), at least 3.
    pub cols: usize,
    /// Inner corners per column (along the board's Y axis), at least 3.
    pub rows: usize,
    /// Side of a square, in the user's unit (mm, m, or 1.0 for "squares").
    pub square: f64,
}

impl Board {
    /// A board of `cols x rows` inner corners with squares of side `square`.
    pub fn new(cols: usize, rows: usize, square: f64) -> Result<Self, DetectError> {
        let b = Self { cols, rows, square };
        b.validate()?;
        Ok(b)
    }

    pub(crate) fn validate(&self) -> Result<(), DetectError> {
        if self.cols < 3 || self.rows < 3 {
            return Err(DetectError::InvalidBoard(format!(
                "{}x{} inner corners: at least 3 per side are needed",
                self.cols, self.rows
            )));
        }
        if self.cols > 1000 || self.rows > 1000 {
            return Err(DetectError::InvalidBoard(format!(
                "{}x{} inner corners is too many",
                self.cols, self.rows
            )));
        }
        if !(self.square.is_finite() && self.square > 0.0) {
            return Err(DetectError::InvalidBoard(format!(
                "square size {} is not positive",
                self.square
            )));
        }
        Ok(())
    }

    /// Object points `(c * square, r * square, 0)`, row-major.
    pub fn object_points(&self) -> Vec<[f64; 3]> {
        (0..self.rows)
            .flat_map(|r| {
                (0..self.cols).map(move |c| [c as f64 * self.square, r as f64 * self.square, 0.0])
            })
            .collect()
    }
}

/// How corners are refined to sub-pixel accuracy after the grid is found.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Refinement {
    /// No refinement: the saddle positions of the search (about 0.1-0.3 px accuracy).
    None,
    /// Gradient orthogonality (the principle of OpenCV's `cornerSubPix`) with a half-window of
    /// `window` times the corner's distance to its nearest grid neighbour, rounded, clamped to
    /// `2..=max_half_window` pixels.
    Gradient {
        /// Half-window as a fraction of the local corner spacing.
        window: f64,
        /// Largest half-window in pixels.
        max_half_window: usize,
    },
    /// Saddle point of a quadratic fitted to the image blurred with standard deviation
    /// `blur` times the median corner spacing (clamped to `0.7..=max_blur` pixels), over a
    /// window of half-size `window` times the median spacing (clamped to `2..=max_window`
    /// pixels).
    Saddle {
        /// Blur as a fraction of the median spacing.
        blur: f64,
        /// Fit half-window as a fraction of the median spacing.
        window: f64,
        /// Largest blur in pixels.
        max_blur: f64,
        /// Largest fit half-window in pixels.
        max_window: usize,
    },
}

/// Options of [`detect()`]. `Default` gives the measured best choices.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectOptions {
    /// Largest image accepted, in pixels (`width * height`); larger ones fail with
    /// [`DetectError::ImageTooLarge`] before their pixels are decoded. Default 100 million.
    pub max_pixels: u64,
    /// The grid search runs on a copy downscaled by the smallest integer factor that brings
    /// it to at most this many pixels (refinement always uses full resolution). Default 2
    /// million, so search time is bounded whatever the image size. When that downscale was
    /// needed and no level found the board, one more search runs on a copy of at most four
    /// times this many pixels (blur 1 px), for boards whose squares the first copy shrinks
    /// below about 4 px.
    pub search_max_pixels: u64,
    /// Search attempts, tried in turn until one finds the board. Coarse levels first: they
    /// are cheap and find boards with large squares; finer ones find small squares. The
    /// default ends with a quarter-resolution level (images of at least 480 px a side), tried
    /// only when the others found no whole board: it finds boards smeared by long motion blur
    /// (15 px) or over-exposure, whose corners the finer levels see as ramps.
    pub search_levels: Vec<SearchLevel>,
    /// Sub-pixel refinement.
    pub refinement: Refinement,
    /// Joint pass after the per-corner refinement: `Some(d)` replaces every corner by a
    /// homography-plus-polynomial (degrees 2 to `d`) warp of the board fitted to all corners
    /// of the view. Default `None` (see `docs/board-detect.md` for the measurements).
    pub joint_warp_degree: Option<usize>,
    /// Verification: largest distance of a corner from the crossing of the lines through its
    /// row and column neighbours, as a fraction of its spacing (but at least 1 px).
    pub max_grid_deviation: f64,
}

impl Default for DetectOptions {
    fn default() -> Self {
        Self {
            max_pixels: 100_000_000,
            search_max_pixels: 2_000_000,
            search_levels: vec![
                SearchLevel {
                    downscale: 2,
                    blur: 1.0,
                    min_side: 120,
                },
                SearchLevel {
                    downscale: 1,
                    blur: 1.5,
                    min_side: 0,
                },
                SearchLevel {
                    downscale: 1,
                    blur: 1.0,
                    min_side: 0,
                },
                SearchLevel {
                    downscale: 1,
                    blur: 2.5,
                    min_side: 0,
                },
                SearchLevel {
                    downscale: 4,
                    blur: 1.0,
                    min_side: 120,
                },
            ],
            refinement: Refinement::Saddle {
                blur: 0.1,
                window: 0.2,
                max_blur: 1.5,
                max_window: 4,
            },
            max_grid_deviation: 0.15,
            joint_warp_degree: None,
        }
    }
}

/// One attempt of the corner search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchLevel {
    /// Extra integer downscale on top of the one that enforces
    /// [`DetectOptions::search_max_pixels`] (1: none).
    pub downscale: usize,
    /// Gaussian blur before the saddle search, standard deviation in pixels of the
    /// downscaled image.
    pub blur: f64,
    /// Skip this level when the downscaled image's smaller side is below this many pixels.
    pub min_side: usize,
}

/// A detected board.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    /// Corner pixel positions, row-major (`index = r * cols + c`), OpenCV convention: the
    /// centre of the top-left pixel is `(0, 0)`, `x` right, `y` down.
    pub corners: Vec<[f64; 2]>,
    /// Image `[width, height]` in pixels.
    pub image_size: [usize; 2],
    /// RMS residual in pixels of a homography fitted to the corners: a measure of how planar
    /// and undistorted the view is (lens distortion alone gives a few tenths of a pixel to
    /// several pixels); `f64::NAN` if the fit failed.
    pub homography_rms: f64,
}

/// Detects `board` in a grayscale image buffer.
pub fn detect(
    image: &GrayView<'_>,
    board: &Board,
    options: &DetectOptions,
) -> Result<Detection, DetectError> {
    detect::run(image, board, options)
}

mod io;
pub use io::{
    ImageResult, decode_gray, detect_file, detect_files, detect_image, file_name, image_names,
    load_gray, load_upright, observations_json, rig_observations_json,
    rig_observations_json_matched, stereo_observations_json, upright_dimensions,
};
pub mod synth;
