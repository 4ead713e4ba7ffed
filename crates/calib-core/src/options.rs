//! Options of a camera's calibration (each camera of a stereo pair or rig has its own).

use crate::init::FocalInit;
use crate::outliers::OutlierRejection;
use camera_model::{CameraModel, Intrinsics, RotationKind};
use homography::{RefineOptions, RobustOptions};
use lm_solver::{Loss, SolverOptions};

/// What to estimate and how. `CalibrationOptions::default()` estimates everything (fx, fy, cx, cy,
/// k1, k2, p1, p2 and the poses) from the closed-form start, like OpenCV's `calibrateCamera` with
/// `CALIB_FIX_K3`.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct CalibrationOptions {
    /// The lens model (default `brown-conrady4`: `k1, k2, p1, p2`).
    pub model: CameraModel,
    /// Hold the principal point at its initial value (the image centre, or the guess). With a
    /// single view it is always held (it is not observable from one view).
    pub fix_principal_point: bool,
    /// Hold `fx` and `fy` at their initial values (the closed-form guess or `intrinsic_guess`).
    pub fix_focal_length: bool,
    /// Hold `fx / fy` at its initial value (1 from the closed-form start): only `fx` is estimated
    /// and `fy = fx / ratio`.
    pub fix_aspect_ratio: bool,
    /// Hold the tangential distortion coefficients at zero.
    pub zero_tangential_distortion: bool,
    /// Indices of distortion coefficients (in the model's order, e.g. `[k1, k2, p1, p2]`) to hold
    /// at their initial value (zero unless a guess is given). See
    /// [`CalibrationOptions::fix_distortion_by_name`].
    pub fixed_distortion: Vec<usize>,
    /// Start from these intrinsics instead of the closed-form guess.
    pub intrinsic_guess: Option<Intrinsics>,
    /// Initial distortion coefficients (default: all zero).
    pub distortion_guess: Option<Vec<f64>>,
    /// Rotation parameterization of the poses during the optimization (Euler X-Y-Z by default).
    pub rotation: RotationKind,
    /// How the closed-form focal length is solved.
    pub focal_init: FocalInit,
    /// Skip views that fail the input checks or whose homography cannot be estimated, and list
    /// them in the result, instead of failing.
    pub skip_bad_views: bool,
    /// Leave out views that repeat an earlier view (same homography within
    /// [`crate::diagnostics::DUPLICATE_TOLERANCE_PX`]), with a warning (default `true`; the
    /// stereo and rig front ends check whole frames instead).
    pub drop_duplicate_views: bool,
    /// Compute the standard deviations (default `true`). Without them the result's sigmas are
    /// zero; a caller that only needs a starting point (the stereo pipeline's single-camera stage)
    /// saves the rank check and the inversion.
    pub compute_uncertainty: bool,
    /// Reject points far beyond the noise and solve again (default on: 5 robust sigmas, never
    /// below 1 px; see [`crate::outliers`]). `None` uses every point, like OpenCV.
    pub outliers: Option<OutlierRejection>,
    /// Robust loss on each point's reprojection error (default none: least squares). The loss
    /// applies to the squared error in px^2, its scale (`Loss::Huber(a)`, `Loss::Cauchy(a)`)
    /// is in pixels: Huber's `a` is the error beyond which a point counts as an outlier.
    pub loss: Loss,
    /// Homography refinement settings.
    pub homography: RefineOptions,
    /// Robust homography settings: views with stray corners start from the corners that agree.
    pub robust_homography: RobustOptions,
    /// Levenberg-Marquardt settings.
    pub solver: SolverOptions,
}

impl Default for CalibrationOptions {
    fn default() -> Self {
        Self {
            model: CameraModel::default(),
            fix_principal_point: false,
            fix_focal_length: false,
            fix_aspect_ratio: false,
            zero_tangential_distortion: false,
            fixed_distortion: Vec::new(),
            intrinsic_guess: None,
            distortion_guess: None,
            rotation: RotationKind::EulerXyz,
            focal_init: FocalInit::Bouguet,
            skip_bad_views: false,
            drop_duplicate_views: true,
            compute_uncertainty: true,
            outliers: Some(OutlierRejection::default()),
            loss: Loss::Trivial,
            robust_homography: RobustOptions::default(),
            homography: RefineOptions {
                cost_tolerance: 1e-10,
                step_tolerance: 1e-8,
                ..RefineOptions::default()
            },
            solver: default_solver_options(),
        }
    }
}

impl CalibrationOptions {
    /// The engine's solve settings for these options.
    pub fn solve_options(&self) -> crate::SolveOptions {
        crate::SolveOptions {
            rotation: self.rotation,
            solver: self.solver.clone(),
            loss: self.loss,
            compute_uncertainty: self.compute_uncertainty,
            outliers: self.outliers,
            camera_warnings: true,
            recheck_without_suspects: false,
        }
    }

    /// Holds the named distortion coefficients ("k2", "p1", ...) of the model, or says which names
    /// the model has.
    pub fn fix_distortion_by_name(&mut self, names: &[&str]) -> Result<(), String> {
        let known = self.model.distortion_names();
        for name in names {
            let index = known.iter().position(|n| n == name).ok_or_else(|| {
                format!(
                    "unknown coefficient '{name}' for model {} (expected one of {})",
                    self.model,
                    known.join(", ")
                )
            })?;
            self.fixed_distortion.push(index);
        }
        self.fixed_distortion.sort_unstable();
        self.fixed_distortion.dedup();
        Ok(())
    }

    /// These options for the lens model `model`: the held coefficients carried over by name
    /// ("p1" stays "p1", not the same position: `kannala-brandt4`'s third coefficient is `k3`,
    /// `brown-conrady4`'s is `p1`; a name `model` lacks is dropped, that term being zero in it by
    /// construction), the distortion guess kept only if the model is the same (a guess belongs to
    /// one model's coefficients).
    pub fn for_model(&self, model: CameraModel) -> CalibrationOptions {
        let mut options = self.clone();
        if model == self.model {
            return options;
        }
        let names = self.model.distortion_names();
        options.model = model;
        options.distortion_guess = None;
        options.fixed_distortion = self
            .fixed_distortion
            .iter()
            .filter_map(|&i| names.get(i))
            .filter_map(|name| model.distortion_names().iter().position(|n| n == name))
            .collect();
        options.fixed_distortion.sort_unstable();
        options.fixed_distortion.dedup();
        options
    }
}

/// The solver settings calibration uses by default: the library's tolerances, which converge to
/// the rounding level of the cost (relative change 1e-12); the hybrid damping policy (the text's
/// additive policy, then Marquardt's after 20 step attempts), which a convergence sweep over
/// weakly tilted captures chose (`docs/benchmarks-solver.md`); and at most 500 step attempts, a
/// safety net that ordinary problems never approach (they converge in 5 to 20).
pub fn default_solver_options() -> SolverOptions {
    let mut o = SolverOptions::default();
    o.max_iterations = 500;
    o.damping = lm_solver::DampingPolicy::hybrid();
    o
}
