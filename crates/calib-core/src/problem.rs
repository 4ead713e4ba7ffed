//! A calibration problem described as data: cameras, frames, observations and rig transforms.
//!
//! One description serves a single camera (one camera, one frame per view), a stereo pair (two
//! cameras, one frame per pair) and a rig of N cameras:
//!
//! * a **camera** has a lens model, an image size, start values for its intrinsics and
//!   distortion, and masks (fixed components, a fixed aspect ratio, focal lengths shared with
//!   another camera);
//! * a **frame** is one moment at which the board stood still: its pose maps board coordinates to
//!   the *reference* camera's frame (`X_ref = R_f X_board + t_f`), whether or not the reference
//!   camera saw it;
//! * the **rig** gives each camera's pose relative to the reference, `X_cam = R_c X_ref + t_c`
//!   (the identity for the reference camera, which has no rig parameters);
//! * an **observation** is one camera's view of the board in one frame: board points with their
//!   ids in the user's input, measured pixels, and optional per-point weights (zero drops a
//!   point, e.g. a rejected outlier).
//!
//! The solver sees one reduced block per camera and per non-reference rig transform, one
//! eliminated block per frame pose, and one residual block per observation (`2 n` rows, the
//! loss applied per point). See `docs/architecture.md`.

use crate::data::ImageSize;
use camera_model::{AnyCamera, CameraModel, Pose};
use nalgebra::{Point3, Vector2, Vector3};

/// One camera of a calibration problem.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraSpec {
    /// A name for messages and results ("left", "cam2").
    pub name: String,
    /// Image size, pixels.
    pub image_size: ImageSize,
    /// Lens model and start values of `[fx, fy, cx, cy, distortion...]` (held values for fixed
    /// components).
    pub initial: AnyCamera,
    /// Components of `[fx, fy, cx, cy, distortion...]` held at their start values (sorted).
    pub fixed: Vec<usize>,
    /// `Some(r)`: `fy = fx / r` (component 1 must be fixed; its value is ignored).
    pub aspect_ratio: Option<f64>,
    /// `Some(k)`: `fx` and `fy` are those of camera `k` (an earlier camera; components 0 and 1
    /// must be fixed), like OpenCV's `CALIB_SAME_FOCAL_LENGTH`.
    pub focal_from: Option<usize>,
}

impl CameraSpec {
    /// A free camera: every parameter estimated from the start values in `initial`.
    pub fn new(name: impl Into<String>, image_size: ImageSize, initial: AnyCamera) -> Self {
        Self {
            name: name.into(),
            image_size,
            initial,
            fixed: Vec::new(),
            aspect_ratio: None,
            focal_from: None,
        }
    }

    /// The lens model.
    pub fn model(&self) -> CameraModel {
        self.initial.model
    }

    /// Names of the camera block's components: `fx, fy, cx, cy` and the distortion's.
    pub fn param_names(&self) -> Vec<&'static str> {
        let mut names = vec!["fx", "fy", "cx", "cy"];
        names.extend_from_slice(self.model().distortion_names());
        names
    }
}

/// One camera's view of the board in one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ObservationSpec {
    /// The camera (index into [`JointProblem::cameras`]).
    pub camera: usize,
    /// The frame (index into [`JointProblem::frames`]).
    pub frame: usize,
    /// A name for messages and results (the image file, "view 3").
    pub name: String,
    /// Board points (board frame, board units).
    pub object: Vec<Point3<f64>>,
    /// Measured pixels (OpenCV convention), in the same order.
    pub pixels: Vec<Vector2<f64>>,
    /// Index of each point in the user's input (for reports of outliers), same length; `None`:
    /// the points are the input's, in order (`0..n`).
    pub point_ids: Option<Vec<usize>>,
    /// Per-point weights (`None`: all one). A point's squared residual is multiplied by its
    /// weight before the loss; zero removes it from the fit.
    pub weights: Option<Vec<f64>>,
    /// Points suspected to be outliers before the solve (e.g. by the robust homography), same
    /// length: with outlier rejection on they start out rejected and are readmitted if the
    /// calibrated model fits them; with it off they are used like every other point.
    pub suspected: Option<Vec<bool>>,
}

impl ObservationSpec {
    /// An observation of all of `object` (ids `0..n`) with unit weights.
    pub fn new(
        camera: usize,
        frame: usize,
        name: impl Into<String>,
        object: Vec<Point3<f64>>,
        pixels: Vec<Vector2<f64>>,
    ) -> Self {
        Self {
            camera,
            frame,
            name: name.into(),
            object,
            pixels,
            point_ids: None,
            weights: None,
            suspected: None,
        }
    }

    /// The input index of point `i` of this observation.
    pub fn point_id(&self, i: usize) -> usize {
        self.point_ids.as_ref().map_or(i, |ids| ids[i])
    }

    /// Number of points with a non-zero weight.
    pub fn num_used_points(&self) -> usize {
        match &self.weights {
            None => self.object.len(),
            Some(w) => w.iter().filter(|&&w| w > 0.0).count(),
        }
    }
}

/// A complete calibration problem with start values.
#[derive(Debug, Clone, PartialEq)]
pub struct JointProblem {
    /// The cameras.
    pub cameras: Vec<CameraSpec>,
    /// The reference camera (its rig transform is the identity and not estimated).
    pub reference: usize,
    /// Start value of each camera's transform from the reference camera, `X_cam = R X_ref + t`
    /// (ignored for the reference camera).
    pub rig: Vec<Pose>,
    /// Cameras whose rig transform is held at its start value.
    pub rig_fixed: Vec<bool>,
    /// Start value of each frame's board pose in the reference camera's frame.
    pub frames: Vec<Pose>,
    /// A name per frame for messages ("view 3", "pair 5", "frame 2").
    pub frame_names: Vec<String>,
    /// The observations.
    pub observations: Vec<ObservationSpec>,
}

/// Why a problem description is inconsistent (a programming error of a front end, or a file
/// whose indices do not match).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ProblemError {
    /// An index points nowhere.
    #[error("{0}")]
    Index(String),
    /// A camera's settings contradict each other.
    #[error("camera '{camera}': {reason}")]
    Camera {
        /// The camera's name.
        camera: String,
        /// What is wrong.
        reason: String,
    },
    /// An observation's lists have different lengths.
    #[error("observation '{name}': {reason}")]
    Observation {
        /// The observation's name.
        name: String,
        /// What is wrong.
        reason: String,
    },
}

/// A similarity of the board coordinates, `X' = (X - centre) / scale`, that centres them and
/// gives them unit size. Boards in micrometres or 1e-8 units, or with their origin far outside
/// the board, then give the solver the same well-scaled problem as boards in millimetres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardNormalization {
    /// Centroid of all board points, board units.
    pub centre: Vector3<f64>,
    /// RMS distance of the board points from the centroid, board units.
    pub scale: f64,
}

impl BoardNormalization {
    /// The centroid and RMS spread of `points` (one pass), whether or not they need normalizing;
    /// `None` without points or with non-finite ones.
    pub fn measure<'a>(points: impl IntoIterator<Item = &'a Point3<f64>>) -> Option<Self> {
        let (mut n, mut sum, mut sum_sq) = (0usize, Vector3::zeros(), 0.0);
        for p in points {
            n += 1;
            sum += p.coords;
            sum_sq += p.coords.norm_squared();
        }
        if n == 0 {
            return None;
        }
        let centre = sum / n as f64;
        let scale = (sum_sq / n as f64 - centre.norm_squared()).max(0.0).sqrt();
        (centre.iter().all(|v| v.is_finite()) && scale.is_finite())
            .then_some(BoardNormalization { centre, scale })
    }

    /// The board's origin lies more than three RMS sizes from its points' centroid.
    pub fn origin_is_far(&self) -> bool {
        self.centre.norm() > 3.0 * self.scale
    }

    /// A frame pose (board to reference camera) of the original problem in the normalized one:
    /// `t' = (R c + t) / s`.
    pub fn normalize_frame(&self, pose: &Pose) -> Pose {
        Pose::new(
            pose.rotation,
            (pose.rotation * self.centre + pose.translation) / self.scale,
        )
    }

    /// The inverse of [`BoardNormalization::normalize_frame`]: `t = s t' - R c`.
    pub fn denormalize_frame(&self, pose: &Pose) -> Pose {
        Pose::new(
            pose.rotation,
            pose.translation * self.scale - pose.rotation * self.centre,
        )
    }
}

impl JointProblem {
    /// The normalization of the board coordinates, if the problem needs one: when the board
    /// points' RMS size is outside `[0.01, 1e4]` board units or their centroid lies more than
    /// three sizes from the board origin. Ordinary boards (millimetres or metres, origin on the
    /// board) are solved as given, so their numbers do not change at all.
    pub fn board_normalization(&self) -> Option<BoardNormalization> {
        BoardNormalization::measure(self.observations.iter().flat_map(|o| o.object.iter()))
            .filter(|n| (!(0.01..=1e4).contains(&n.scale) || n.origin_is_far()) && n.scale > 0.0)
    }

    /// The problem in normalized board coordinates: board points `(X - c) / s`, frame
    /// translations `(R c + t) / s`, rig translations `t / s` (a change of units and origin that
    /// leaves every projection unchanged).
    pub fn normalized(&self, n: &BoardNormalization) -> JointProblem {
        let mut out = self.clone();
        for o in &mut out.observations {
            for p in &mut o.object {
                *p = Point3::from((p.coords - n.centre) / n.scale);
            }
        }
        for f in &mut out.frames {
            *f = n.normalize_frame(f);
        }
        for r in &mut out.rig {
            r.translation /= n.scale;
        }
        out
    }

    /// Checks indices, lengths and camera settings.
    pub fn check(&self) -> Result<(), ProblemError> {
        let n_cam = self.cameras.len();
        if self.reference >= n_cam {
            return Err(ProblemError::Index(format!(
                "reference camera {} of {n_cam}",
                self.reference
            )));
        }
        if self.rig.len() != n_cam || self.rig_fixed.len() != n_cam {
            return Err(ProblemError::Index(format!(
                "{} rig transforms and {} rig flags for {n_cam} cameras",
                self.rig.len(),
                self.rig_fixed.len()
            )));
        }
        if self.frame_names.len() != self.frames.len() {
            return Err(ProblemError::Index(format!(
                "{} frame names for {} frames",
                self.frame_names.len(),
                self.frames.len()
            )));
        }
        for (c, camera) in self.cameras.iter().enumerate() {
            let fail = |reason: String| ProblemError::Camera {
                camera: camera.name.clone(),
                reason,
            };
            let n = camera.model().num_params();
            if camera.initial.distortion.len() != camera.model().num_distortion_params() {
                return Err(fail("wrong number of distortion coefficients".into()));
            }
            if let Some(&i) = camera.fixed.iter().find(|&&i| i >= n) {
                return Err(fail(format!("fixed component {i} of {n}")));
            }
            if camera.aspect_ratio.is_some() && !camera.fixed.contains(&1) {
                return Err(fail(
                    "a fixed aspect ratio needs fy (component 1) fixed".into(),
                ));
            }
            if let Some(r) = camera.aspect_ratio
                && !(r.is_finite() && r > 0.0)
            {
                return Err(fail(format!("aspect ratio {r} is not positive")));
            }
            if let Some(k) = camera.focal_from {
                if k >= c {
                    return Err(fail(format!(
                        "focal lengths shared with camera {k}, which is not an earlier camera"
                    )));
                }
                if !(camera.fixed.contains(&0) && camera.fixed.contains(&1)) {
                    return Err(fail("shared focal lengths need fx and fy fixed".into()));
                }
                if self.cameras[k].focal_from.is_some() {
                    return Err(fail(
                        "focal lengths shared with a camera that shares them".into(),
                    ));
                }
            }
        }
        for o in &self.observations {
            if o.camera >= n_cam || o.frame >= self.frames.len() {
                return Err(ProblemError::Index(format!(
                    "observation '{}' refers to camera {} of {n_cam} and frame {} of {}",
                    o.name,
                    o.camera,
                    o.frame,
                    self.frames.len()
                )));
            }
            let n = o.object.len();
            let weights_ok = o.weights.as_ref().is_none_or(|w| w.len() == n);
            let ids_ok = o.point_ids.as_ref().is_none_or(|ids| ids.len() == n);
            let suspected_ok = o.suspected.as_ref().is_none_or(|s| s.len() == n);
            if o.pixels.len() != n || !ids_ok || !weights_ok || !suspected_ok {
                return Err(ProblemError::Observation {
                    name: o.name.clone(),
                    reason: "points, pixels, ids, weights and suspects differ in length".into(),
                });
            }
            if n == 0 {
                return Err(ProblemError::Observation {
                    name: o.name.clone(),
                    reason: "no points".into(),
                });
            }
        }
        Ok(())
    }

    /// Number of used points (non-zero weight) over all observations.
    pub fn num_used_points(&self) -> usize {
        self.observations
            .iter()
            .map(ObservationSpec::num_used_points)
            .sum()
    }

    /// True if camera `c` has rig parameters (every camera but the reference).
    pub fn has_rig(&self, c: usize) -> bool {
        c != self.reference
    }
}
