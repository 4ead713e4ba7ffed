//! Errors of a calibration. Every variant about the input names the view (index in the input,
//! from 0) and, where it applies, the point; front ends with several cameras wrap them with the
//! camera and pair.

use homography::HomographyError;
use lm_solver::{CovarianceError, SolverError};

/// Which coordinate of a point is at fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointKind {
    /// A board (object) point.
    Object,
    /// A measured image point.
    Image,
}

impl std::fmt::Display for PointKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            PointKind::Object => "object",
            PointKind::Image => "image",
        })
    }
}

/// What can go wrong in a calibration. Every variant about the input names the view (index in the
/// input, starting at 0) and, where it applies, the point.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CalibrationError {
    /// No views were given (or none is left after skipping bad ones).
    #[error("no usable views{}", if *.skipped > 0 { format!(" ({} skipped as bad)", .skipped) } else { String::new() })]
    NoViews {
        /// How many views were skipped.
        skipped: usize,
    },
    /// The image size is missing.
    #[error(
        "image size is missing: the principal point starts at the image centre, so it is required"
    )]
    ImageSizeMissing,
    /// The image size has a zero dimension.
    #[error("invalid image size {width}x{height}: both dimensions must be positive")]
    InvalidImageSize {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// A view has different numbers of object and image points.
    #[error("view {view}: {object} object points but {image} image points")]
    PointCountMismatch {
        /// View index.
        view: usize,
        /// Number of object points.
        object: usize,
        /// Number of image points.
        image: usize,
    },
    /// An image point lies outside the image (by more than a small margin).
    #[error(
        "view {view}, point {point}: pixel ({}, {}) lies outside the {width}x{height} image: is the image size right?",
        coordinate(*.x),
        coordinate(*.y)
    )]
    PointOutsideImage {
        /// View index.
        view: usize,
        /// Point index.
        point: usize,
        /// The pixel's x.
        x: f64,
        /// The pixel's y.
        y: f64,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
    },
    /// A view has fewer than 4 points (a homography needs 4).
    #[error("view {view}: {found} points, at least 4 are needed")]
    TooFewPoints {
        /// View index.
        view: usize,
        /// Number of points.
        found: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("view {view}, point {point}: non-finite {kind} coordinate")]
    NonFinite {
        /// View index.
        view: usize,
        /// Point index.
        point: usize,
        /// Object or image point.
        kind: PointKind,
    },
    /// An object point is off the plane `Z = 0`.
    #[error(
        "view {view}, point {point}: object point has Z = {z}; the planar method needs every board point on Z = 0"
    )]
    NotPlanar {
        /// View index.
        view: usize,
        /// Point index.
        point: usize,
        /// The offending Z.
        z: f64,
    },
    /// A view's board points span a million times more than the median view's, or lie that far
    /// from the other views' board: a corrupt coordinate or a view in other units. (Left in, its
    /// numbers overflowed the board's centring and the error named another view.)
    #[error(
        "view {view}: its board points span {extent:.3e} board units and lie {distance:.3e} from the centre of the other views' board, which spans {typical:.3e}: a corrupt coordinate or a view in other units; fix or remove it, or skip bad views"
    )]
    BoardOutOfScale {
        /// View index.
        view: usize,
        /// Largest coordinate range of the view's board points (x, y or z), board units.
        extent: f64,
        /// Distance of the view's board centroid from the median of the views' centroids (the
        /// largest coordinate difference), board units.
        distance: f64,
        /// The median view's extent.
        typical: f64,
    },
    /// The homography of a view could not be estimated (collinear or coincident points, rank
    /// deficiency, degenerate solution).
    #[error("view {view}: {source}")]
    Homography {
        /// View index.
        view: usize,
        /// The homography error.
        source: HomographyError,
    },
    /// Not enough measurements for the parameters to be estimated.
    #[error(
        "{residuals} residuals (2 per point) for {parameters} free parameters: add views or points, or fix parameters"
    )]
    TooFewObservations {
        /// Number of scalar residuals.
        residuals: usize,
        /// Number of free parameters.
        parameters: usize,
    },
    /// Every view is (nearly) fronto-parallel: the focal length cannot be observed.
    #[error(
        "every view shows the board parallel to the image plane (the largest depth variation across a board is {tilt_measure:.1e} of its distance): the focal length is not observable; tilt the board in some views"
    )]
    FrontoParallel {
        /// The largest perspective measure over the views: the relative depth variation across
        /// the board (`init::perspective_measure`), about `tan(tilt) x extent / distance`.
        tilt_measure: f64,
    },
    /// The closed-form initialization failed for another reason.
    #[error("initialization failed: {reason}")]
    Initialization {
        /// Why.
        reason: String,
    },
    /// The initial pose of a view puts a board point behind the camera.
    #[error("view {view}: the initial pose puts point {point} behind the camera")]
    PointBehindCamera {
        /// View index.
        view: usize,
        /// Point index.
        point: usize,
    },
    /// An invalid option value.
    #[error("invalid option: {0}")]
    InvalidOption(String),
    /// The view bootstrap (`calib_single::bootstrap`) cannot estimate a spread: too few
    /// resamples asked for, too few views, or too few refits that succeeded (the reason says
    /// which).
    #[error("bootstrap: {0}")]
    Bootstrap(String),
    /// The solver could not be set up or started.
    #[error("solver: {0}")]
    Solver(#[from] SolverError),
    /// The parameters are not all determined by the data (singular normal matrix at the minimum).
    #[error("the calibration is not unique: {0}")]
    Unobservable(#[from] CovarianceError),
    /// Some parameters are not determined by the data, named in user terms.
    #[error(
        "the calibration is not unique: {what} {verb} not determined by the data; {hint}",
        verb = if .what.contains(", ") || .what.contains(" and ") { "are" } else { "is" }
    )]
    NotDetermined {
        /// The parameters, e.g. "fx, fy, cx" or "the pose of view 3".
        what: String,
        /// What the user can do.
        hint: String,
    },
    /// More than half of a view's points are far from the calibrated model: the view's points do
    /// not match the board (wrong board size or orientation, mixed-up files), not a few bad
    /// corners.
    #[error(
        "{location}: {rejected} of {points} points are outliers: the view does not match the board (wrong correspondences?); remove it or skip bad views"
    )]
    MostlyOutliers {
        /// Index of the observation in the problem.
        observation: usize,
        /// The view in user terms ("view 3 (img03.png)", "pair 2, camera 'left'").
        location: String,
        /// Number of rejected points.
        rejected: usize,
        /// Number of used points.
        points: usize,
        /// The other views past the same limit in the same round, for
        /// [`CalibrationError::views_to_skip`].
        also: Vec<OutlierView>,
    },
    /// The optimization produced a non-finite value.
    #[error("the optimization diverged ({0})")]
    Diverged(String),
}

/// A pixel coordinate for messages: one decimal, or scientific notation beyond a million (a
/// coordinate of 1e300 printed in full is 300 digits).
fn coordinate(v: f64) -> String {
    if v.abs() < 1e6 {
        format!("{v:.1}")
    } else {
        format!("{v:.3e}")
    }
}

/// A view most of whose points are outliers, besides the one a
/// [`CalibrationError::MostlyOutliers`] names. Displayed as that error is.
#[derive(Debug, Clone, PartialEq)]
pub struct OutlierView {
    /// Index of the observation in the problem.
    pub observation: usize,
    /// The view in user terms.
    pub location: String,
    /// Number of rejected points.
    pub rejected: usize,
    /// Number of used points.
    pub points: usize,
}

impl OutlierView {
    /// The message without the view's location: for a list that names the view already.
    pub fn detail(&self) -> String {
        format!(
            "{} of {} points are outliers: the view does not match the board (wrong correspondences?)",
            self.rejected, self.points
        )
    }
}

impl std::fmt::Display for OutlierView {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} of {} points are outliers: the view does not match the board (wrong correspondences?); remove it or skip bad views",
            self.location, self.rejected, self.points
        )
    }
}

/// A view in user terms: `view 3 (img03.png)`, or `view 3` when the view has no name of its own
/// (its name is empty or is that same text).
pub fn view_location(index: usize, name: &str) -> String {
    let plain = format!("view {index}");
    if name.is_empty() || name == plain {
        plain
    } else {
        format!("{plain} ({name})")
    }
}

impl CalibrationError {
    /// The input view (index from 0) an error about one view's input names as `view N`: the
    /// point checks, the homography and the initial pose. `None` for the others
    /// ([`CalibrationError::MostlyOutliers`] carries its view's `location` already).
    pub fn view(&self) -> Option<usize> {
        match self {
            CalibrationError::PointCountMismatch { view, .. }
            | CalibrationError::PointOutsideImage { view, .. }
            | CalibrationError::TooFewPoints { view, .. }
            | CalibrationError::NonFinite { view, .. }
            | CalibrationError::NotPlanar { view, .. }
            | CalibrationError::BoardOutOfScale { view, .. }
            | CalibrationError::Homography { view, .. }
            | CalibrationError::PointBehindCamera { view, .. } => Some(*view),
            _ => None,
        }
    }

    /// The message with its `view N` replaced by `location` (e.g. `"view 3 (img03.png)"` from
    /// [`view_location`], `"pair 3, left view"`); the plain message for errors about no one
    /// view.
    pub fn message_at(&self, location: &str) -> String {
        let message = self.to_string();
        match self.view() {
            Some(v) => match message.strip_prefix(&format!("view {v}")) {
                Some(rest) => format!("{location}{rest}"),
                None => message,
            },
            None => message,
        }
    }

    /// The message without its leading `view N: ` (a point keeps its `point K, `; a
    /// [`CalibrationError::MostlyOutliers`] loses its location and the advice to skip): for a
    /// list that names the view already, such as the skipped views.
    pub fn detail(&self) -> String {
        if let CalibrationError::MostlyOutliers {
            rejected, points, ..
        } = self
        {
            return OutlierView {
                observation: 0,
                location: String::new(),
                rejected: *rejected,
                points: *points,
            }
            .detail();
        }
        let message = self.to_string();
        let Some(v) = self.view() else {
            return message;
        };
        match message.strip_prefix(&format!("view {v}")) {
            Some(rest) => rest
                .strip_prefix(": ")
                .or_else(|| rest.strip_prefix(", "))
                .unwrap_or(rest)
                .to_string(),
            None => message,
        }
    }

    /// [`CalibrationError::views_to_skip`] as skipped views, for a caller whose observation
    /// `o` is the input view `views[o]` (`(index, name)`), each with its own reason.
    pub fn skipped_views(&self, views: &[(usize, String)]) -> Vec<crate::SkippedView> {
        let also: &[OutlierView] = match self {
            CalibrationError::MostlyOutliers { also, .. } => also,
            _ => &[],
        };
        self.views_to_skip(views.len())
            .into_iter()
            .map(|o| {
                let (index, name) = views[o].clone();
                let reason = also
                    .iter()
                    .find(|v| v.observation == o)
                    .map_or_else(|| self.detail(), OutlierView::detail);
                crate::SkippedView {
                    index,
                    name,
                    reason,
                }
            })
            .collect()
    }

    /// The observations a caller that skips bad views leaves out after this error (empty for
    /// every error but [`CalibrationError::MostlyOutliers`]): the one it names and, when the
    /// views past the limit are few (at most a tenth of the `num_observations`), every other one
    /// of the same round. A few such views are wrong on their own; one bad view pulling the
    /// shared camera would put many good views past the limit, and then only the worst is left
    /// out before solving again. Leaving them out together saves a calibration per bad view
    /// (2000 views with 20 mismatched ones took 69 s one at a time).
    pub fn views_to_skip(&self, num_observations: usize) -> Vec<usize> {
        match self {
            CalibrationError::MostlyOutliers {
                observation, also, ..
            } => {
                let mut views = vec![*observation];
                if (1 + also.len()) * 10 <= num_observations {
                    views.extend(also.iter().map(|v| v.observation));
                }
                views
            }
            _ => Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn error(also: usize) -> CalibrationError {
        let view = |o: usize| OutlierView {
            observation: o,
            location: format!("view {o}"),
            rejected: 50,
            points: 54,
        };
        CalibrationError::MostlyOutliers {
            observation: 7,
            location: "view 7".into(),
            rejected: 54,
            points: 54,
            also: (100..100 + also).map(view).collect(),
        }
    }

    /// Every error about one view's input starts with `view N`, so that front ends can put the
    /// image's name there; `detail` drops it where the view is named already.
    #[test]
    fn view_errors_can_be_located_by_name() {
        let errors = [
            CalibrationError::PointCountMismatch {
                view: 3,
                object: 10,
                image: 54,
            },
            CalibrationError::PointOutsideImage {
                view: 3,
                point: 7,
                x: 700.0,
                y: 1.0,
                width: 640,
                height: 480,
            },
            CalibrationError::TooFewPoints { view: 3, found: 2 },
            CalibrationError::NonFinite {
                view: 3,
                point: 7,
                kind: PointKind::Image,
            },
            CalibrationError::NotPlanar {
                view: 3,
                point: 7,
                z: 1.0,
            },
            CalibrationError::BoardOutOfScale {
                view: 3,
                extent: 1e9,
                distance: 1e9,
                typical: 200.0,
            },
            CalibrationError::Homography {
                view: 3,
                source: HomographyError::TooFewPoints { found: 3 },
            },
            CalibrationError::PointBehindCamera { view: 3, point: 7 },
        ];
        for e in errors {
            assert_eq!(e.view(), Some(3), "{e}");
            let located = e.message_at(&view_location(3, "left4.jpg"));
            assert!(located.starts_with("view 3 (left4.jpg)"), "{located}");
            assert_eq!(located.matches("view 3").count(), 1, "{located}");
            let detail = e.detail();
            assert!(!detail.contains("view 3"), "{detail}");
            assert!(e.to_string().ends_with(&detail), "{e} / {detail}");
        }
        assert_eq!(view_location(3, "view 3"), "view 3");
        assert_eq!(view_location(3, ""), "view 3");
        let other = CalibrationError::Diverged("x".into());
        assert_eq!(other.view(), None);
        assert_eq!(other.message_at("view 1 (a.png)"), other.to_string());
        assert_eq!(other.detail(), other.to_string());
    }

    /// The others of the round go with the named view only while the views past the limit are at
    /// most a tenth of all: more suggests one bad view pulling the camera, so one at a time.
    #[test]
    fn views_to_skip_takes_the_round_only_when_it_is_a_small_part() {
        assert_eq!(error(0).views_to_skip(5), vec![7]);
        assert_eq!(error(2).views_to_skip(30), vec![7, 100, 101]);
        assert_eq!(error(2).views_to_skip(29), vec![7]);
        assert_eq!(
            error(19).views_to_skip(2000),
            (7..8).chain(100..119).collect::<Vec<_>>()
        );
        assert!(
            CalibrationError::Diverged("x".into())
                .views_to_skip(100)
                .is_empty()
        );
        assert_eq!(
            error(1)
                .to_string()
                .replace("view 7", "view 100")
                .replace("54 of", "50 of"),
            match error(1) {
                CalibrationError::MostlyOutliers { also, .. } => also[0].to_string(),
                _ => unreachable!(),
            }
        );
    }
}
