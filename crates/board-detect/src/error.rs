//! Typed reasons why an image gives no board.

use std::path::PathBuf;

/// Why [`detect`](fn@crate::detect) (or one of its variants) returned no board for an image.
///
/// Every failure on user data is one of these values; nothing in the crate panics on bad
/// input. The `Display` text is short and suitable for the `reason` field of the
/// observation files.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DetectError {
    /// The board description itself is unusable (fewer than 3 inner corners along a side,
    /// a non-positive or non-finite square size).
    #[error("invalid board: {0}")]
    InvalidBoard(String),

    /// The pixel buffer does not match the declared width, height and stride, or a side is 0.
    #[error("invalid image buffer: {0}")]
    InvalidImage(String),

    /// The image is smaller than any board could be (fewer than 16 pixels on a side).
    #[error("image too small ({width}x{height} pixels)")]
    ImageTooSmall {
        /// Width in pixels.
        width: u64,
        /// Height in pixels.
        height: u64,
    },

    /// The image has more pixels than [`DetectOptions::max_pixels`](crate::DetectOptions::max_pixels)
    /// allows; it was refused before any pixel buffer of that size was allocated.
    #[error("image too large ({width}x{height} pixels, limit {limit} pixels)")]
    ImageTooLarge {
        /// Width in pixels.
        width: u64,
        /// Height in pixels.
        height: u64,
        /// The pixel budget in force.
        limit: u64,
    },

    /// The file could not be read (missing, permission denied, ...).
    #[error("cannot read {path}: {message}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's message.
        message: String,
    },

    /// The file is not an image in a supported format (JPEG, PNG).
    #[error("unsupported image format: {0}")]
    UnsupportedFormat(String),

    /// The file looks like a supported image but its data is corrupt or truncated.
    #[error("cannot decode image: {0}")]
    Decode(String),

    /// A JPEG file that ends before its end-of-image marker: cut short, as a copy or download
    /// that did not finish leaves it. Decoders fill the missing part with grey; it is refused
    /// instead, so no detection runs on a partly grey image.
    #[error(
        "the file is cut short (truncated JPEG: it ends before its end-of-image marker, as a copy or download that did not finish leaves it)"
    )]
    Truncated,

    /// No chessboard-like corner grid was found, or only one with fewer than half of the
    /// board's corners (or fewer than 12, or fewer than 4 on a side): what textures and noise
    /// can give.
    #[error("no board found")]
    NoBoard,

    /// A corner grid was found but not all of the board's corners: part of the board is
    /// hidden, out of the image or too blurred.
    #[error("partial board: {found} of {expected} corners found")]
    PartialBoard {
        /// Corners found (in the largest grid).
        found: usize,
        /// Corners of the board (`cols * rows`).
        expected: usize,
    },

    /// The corner grid found is larger than the board in some direction, so it is a
    /// different board (or two boards side by side) and cannot be labelled. The found size is
    /// written in the order of `--board COLSxROWS` (the longer side first when
    /// `cols >= rows`).
    #[error(
        "board size mismatch: found a {found_cols}x{found_rows} corner grid, expected {cols}x{rows}"
    )]
    SizeMismatch {
        /// Grid size found along the first grid direction.
        found_cols: usize,
        /// Grid size found along the second grid direction.
        found_rows: usize,
        /// Expected inner corners per row.
        cols: usize,
        /// Expected inner corners per column.
        rows: usize,
    },

    /// Two (or more) complete boards of the expected size are in the image: which one the
    /// corners belong to would be a guess, so the image is refused. (A smaller or partial
    /// second board does not count: the largest grid is labelled.)
    #[error(
        "{count} complete {cols}x{rows} boards in the image: show one board per image (or cover the others)"
    )]
    SeveralBoards {
        /// Complete boards found (at least 2).
        count: usize,
        /// Inner corners per row.
        cols: usize,
        /// Inner corners per column.
        rows: usize,
    },

    /// The board was found but its orientation cannot be decided: the colour rule does not
    /// apply (both `cols + rows` even, or a square board) and the board's row direction is
    /// too close to the image diagonal or vertical for the geometric rule, or the square
    /// colours are too faint to tell.
    #[error("ambiguous orientation: {0}")]
    AmbiguousOrientation(String),

    /// A full grid was found, but one corner is not a clean crossing of two edges: the image
    /// around it is far from point-symmetric (its asymmetry, the RMS difference between the
    /// pixels at `+d` and `-d` from it over its refinement window divided by the window's
    /// contrast, is above `limit`: 8 times the board's median corner, and at least 0.06). A
    /// shadow edge, the rim of a glare patch or an occluder runs through it, and pulls the
    /// refined corner off the true crossing (by 1-4 px on rendered shadows) where the grid's
    /// geometry alone does not show it; the image is refused rather than give that corner.
    #[error(
        "corner {index} is not a clean crossing (asymmetry {asymmetry:.2}, limit {limit:.2}): a shadow edge, glare or an occluder runs through it"
    )]
    DisturbedCorner {
        /// Row-major index of the most asymmetric corner.
        index: usize,
        /// Its asymmetry (a fraction of its window's contrast; 0 for a perfect crossing).
        asymmetry: f64,
        /// The limit it exceeded.
        limit: f64,
    },

    /// A full grid was found, but the image is too noisy for the board's contrast to place
    /// its corners accurately: the saddle refinement's predicted uncertainty of some corner
    /// (one standard deviation, in pixels, from the image noise measured around the board and
    /// the corner's sharpness, after the refinement window grew as far as the squares allow)
    /// is above `limit_px`, so corners more than a pixel off would be likely. Low light (a dark
    /// image brightened by gain) gives it; more light, a longer exposure or less gain help. A
    /// corner covered (a finger) or washed out, whose contrast is low whatever the light, can
    /// give it too.
    #[error(
        "too noisy for accurate corners: corner {index} is uncertain by {sigma_px:.2} px (one standard deviation, limit {limit_px:.2} px) with image noise {noise:.1} grey levels: too little contrast there for the noise (low light: more light or less gain; or the corner is covered or washed out)"
    )]
    TooNoisy {
        /// Row-major index of the least certain corner.
        index: usize,
        /// Its predicted standard deviation in pixels (along its least certain direction).
        sigma_px: f64,
        /// The limit in pixels.
        limit_px: f64,
        /// Measured image noise, standard deviation in grey levels (0-255).
        noise: f64,
    },

    /// A full grid was found, but its geometry is not that of a planar board seen by a
    /// camera: a corner deviates from the position its neighbours predict.
    #[error(
        "inconsistent grid: corner {index} is {error_px:.2} px from where its neighbours put it (limit {limit_px:.2} px)"
    )]
    InconsistentGrid {
        /// Row-major index of the worst corner.
        index: usize,
        /// Its deviation in pixels.
        error_px: f64,
        /// The limit in pixels.
        limit_px: f64,
    },
}
