//! Error type shared by every fallible function of the crate.

use std::fmt;

/// Which of the two input point sets a problem was found in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PointSet {
    /// The plane (calibration board) coordinates `(X, Y)`, in board units.
    Object,
    /// The measured pixel coordinates `(x, y)`.
    Image,
}

impl fmt::Display for PointSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PointSet::Object => f.write_str("object (plane) points"),
            PointSet::Image => f.write_str("image (pixel) points"),
        }
    }
}

/// Everything that can make a homography estimate impossible or meaningless.
///
/// The estimation functions validate their input and report one of these instead of
/// panicking or returning non-finite numbers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HomographyError {
    /// Fewer than the four correspondences that the eight degrees of freedom of a
    /// homography require.
    #[error("at least 4 point correspondences are needed, got {found}")]
    TooFewPoints {
        /// Number of correspondences that were passed.
        found: usize,
    },

    /// The object and image slices do not have the same length, so they cannot be paired.
    #[error("object and image point counts differ ({object} object points, {image} image points)")]
    LengthMismatch {
        /// Length of the object point slice.
        object: usize,
        /// Length of the image point slice.
        image: usize,
    },

    /// A coordinate is NaN or infinite.
    #[error("{set}: point {index} has a non-finite coordinate")]
    NonFinite {
        /// Index of the offending point within its slice.
        index: usize,
        /// The slice the point belongs to.
        set: PointSet,
    },

    /// All points of a set are (numerically) the same point, so they have no spread that
    /// the normalization could scale to a mean distance of `sqrt(2)`.
    #[error("{set}: all points coincide, the set has no spatial extent")]
    Coincident {
        /// The degenerate set.
        set: PointSet,
    },

    /// All points of a set lie on one straight line (see
    /// [`COLLINEARITY_THRESHOLD`](crate::COLLINEARITY_THRESHOLD)); such a set cannot
    /// determine a plane-to-plane mapping.
    #[error("{set}: all points lie on one line")]
    Collinear {
        /// The degenerate set.
        set: PointSet,
    },

    /// The linear DLT system has more than one independent solution, e.g. only three
    /// distinct points, or four points of which three are collinear (see
    /// [`RANK_THRESHOLD`](crate::RANK_THRESHOLD)).
    #[error("the DLT system is rank deficient (numerical rank {rank}, 8 needed)")]
    RankDeficient {
        /// Numerical rank of the normalized `2N x 9` DLT matrix (8 is needed).
        rank: usize,
    },

    /// Fewer than half the correspondences (or fewer than four) agree with any one homography:
    /// the points are shuffled, mismatched or mostly wrong.
    #[error(
        "only {inliers} of {points} points fit one homography: the image points do not match the board points (shuffled or mismatched correspondences?)"
    )]
    NoConsensus {
        /// The largest number of points that agree.
        inliers: usize,
        /// Number of correspondences.
        points: usize,
    },

    /// A homography was found or given, but it cannot be used: its `H33` entry is
    /// (numerically) zero, i.e. the plane origin maps to infinity and the `H33 = 1`
    /// scaling is impossible, or its entries are not finite, or a linear algebra routine
    /// failed to converge.
    #[error("degenerate homography: {reason}")]
    DegenerateSolution {
        /// Human readable description of the problem.
        reason: &'static str,
    },
}
