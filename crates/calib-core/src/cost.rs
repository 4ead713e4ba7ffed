//! The reprojection cost of a [`JointProblem`], as an `lm_solver` cost function: one
//! implementation for one camera, a stereo pair and N cameras, every lens model.
//!
//! Parameter blocks, in order: one camera block `[fx, fy, cx, cy, distortion...]` per camera
//! (reduced), one rig block `[rho, t]` per camera other than the reference (reduced), one pose
//! block `[rho, t]` per frame (eliminated). Residual block `i` is observation `i`: its `2 n`
//! residuals `sqrt(w) (projected - measured)`, ordered `x_0, y_0, x_1, y_1, ...`, and it depends
//! on `[camera, frame pose]`, then `rig` for a non-reference camera, then the focal-source
//! camera when the focal lengths are shared.
//!
//! The camera model is dispatched once per residual block (per view) with
//! [`camera_model::dispatch_camera_model!`], so the per-point loops are monomorphized.

use crate::kernel::{FocalTargets, KernelWidth, ViewInput, handles_loss};
use crate::problem::{CameraSpec, JointProblem, ObservationSpec};
use camera_model::{
    Camera, DifferentiablePose, LensDistortion, ParamJacobian, Pose, Projection,
    RotationParameterization, dispatch_camera_model, pose::composition::DifferentiableComposition,
};
use lm_solver::{CostFunction, EvaluationError, GramBlocks, JacobianBlocks, ResidualBlockId};
use nalgebra::{Vector3, Vector6};
use std::marker::PhantomData;

/// Where a residual block's optional parameter blocks are in its list.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ResidualLayout {
    /// Index of the rig block in the residual's parameter list.
    pub rig: Option<usize>,
    /// Index of the focal-source camera block.
    pub focal: Option<usize>,
}

/// The residual layouts of a problem's observations (the parameter lists of
/// [`crate::solve()`]'s residual blocks).
pub(crate) fn residual_layouts(problem: &JointProblem) -> Vec<ResidualLayout> {
    problem
        .observations
        .iter()
        .map(|o| {
            let rig = problem.has_rig(o.camera).then_some(2);
            let focal = problem.cameras[o.camera]
                .focal_from
                .map(|_| if rig.is_some() { 3 } else { 2 });
            ResidualLayout { rig, focal }
        })
        .collect()
}

/// Reprojection errors of every observation of a [`JointProblem`], with poses and rig in
/// rotation parameterization `R`.
#[derive(Debug, Clone)]
pub struct JointCost<'a, R> {
    problem: &'a JointProblem,
    layouts: Vec<ResidualLayout>,
    _rotation: PhantomData<fn() -> R>,
}

/// `R_c (R_f X + t_f) + t_c` (or `R_f X + t_f` for the reference camera), in the same
/// operation order as the Jacobian path (`DifferentiableComposition`), so both give the same
/// bits.
#[inline]
fn transform(pose: &Pose, rig: Option<&Pose>, x: &nalgebra::Point3<f64>) -> Vector3<f64> {
    let q = pose.rotation * x.coords + pose.translation;
    match rig {
        Some(r) => r.rotation * q + r.translation,
        None => q,
    }
}

fn not_visible(obs: &ObservationSpec, point: usize) -> EvaluationError {
    EvaluationError::new(format!(
        "{}, point {}: the camera cannot see the point (behind it, or outside the lens model's range)",
        obs.name,
        obs.point_id(point)
    ))
}

impl<'a, R: RotationParameterization> JointCost<'a, R> {
    /// The cost of `problem` (checked by the caller).
    pub fn new(problem: &'a JointProblem) -> Self {
        Self {
            problem,
            layouts: residual_layouts(problem),
            _rotation: PhantomData,
        }
    }

    /// The camera of observation `obs` from its residual block's parameters: its own block, with
    /// `fy = fx / r` for a fixed aspect ratio and the focal lengths of the source camera when
    /// they are shared.
    fn typed_camera<D: LensDistortion, P: Projection>(
        &self,
        spec: &CameraSpec,
        params: &[&[f64]],
        layout: ResidualLayout,
    ) -> Camera<D, P> {
        let mut camera = Camera::<D, P>::from_params(params[0]);
        let (fx, fy) = self.focal_lengths(spec, params, layout);
        camera.intrinsics.fx = fx;
        camera.intrinsics.fy = fy;
        camera
    }

    /// `(fx, fy)` of a camera given its residual block's parameters.
    fn focal_lengths(
        &self,
        spec: &CameraSpec,
        params: &[&[f64]],
        layout: ResidualLayout,
    ) -> (f64, f64) {
        match (spec.focal_from, layout.focal) {
            (Some(source), Some(k)) => {
                let src = &self.problem.cameras[source];
                let fx = params[k][0];
                (fx, src.aspect_ratio.map_or(params[k][1], |r| fx / r))
            }
            _ => {
                let fx = params[0][0];
                (fx, spec.aspect_ratio.map_or(params[0][1], |r| fx / r))
            }
        }
    }

    /// The camera described by camera block `params` of camera `c` (aspect ratio applied; shared
    /// focal lengths taken from `source_params`, the source camera's block).
    pub fn camera_params(
        &self,
        c: usize,
        params: &[f64],
        source_params: Option<&[f64]>,
    ) -> Vec<f64> {
        let spec = &self.problem.cameras[c];
        let mut out = params.to_vec();
        match (spec.focal_from, source_params) {
            (Some(source), Some(src)) => {
                let r = self.problem.cameras[source].aspect_ratio;
                out[0] = src[0];
                out[1] = r.map_or(src[1], |r| src[0] / r);
            }
            _ => {
                if let Some(r) = spec.aspect_ratio {
                    out[1] = out[0] / r;
                }
            }
        }
        out
    }

    /// The frame pose and, for a non-reference camera, the rig transform of a residual block.
    fn poses(&self, params: &[&[f64]], layout: ResidualLayout) -> (Pose, Option<Pose>) {
        let pose = Pose::from_params::<R>(&Vector6::from_column_slice(params[1]));
        let rig = layout
            .rig
            .map(|k| Pose::from_params::<R>(&Vector6::from_column_slice(params[k])));
        (pose, rig)
    }

    /// The unweighted reprojection errors `projected - measured` (pixels) of every point of
    /// observation `block` at its residual block's parameters `params`.
    pub fn reprojection_errors(
        &self,
        block: usize,
        params: &[&[f64]],
    ) -> Result<Vec<nalgebra::Vector2<f64>>, EvaluationError> {
        let mut errors = Vec::new();
        self.reprojection_errors_into(block, params, &mut errors)?;
        Ok(errors)
    }

    /// [`JointCost::reprojection_errors`] into `errors` (cleared first; reuse it across calls).
    pub fn reprojection_errors_into(
        &self,
        block: usize,
        params: &[&[f64]],
        errors: &mut Vec<nalgebra::Vector2<f64>>,
    ) -> Result<(), EvaluationError> {
        let obs = &self.problem.observations[block];
        let spec = &self.problem.cameras[obs.camera];
        let layout = self.layouts[block];
        let (pose, rig) = self.poses(params, layout);
        errors.clear();
        dispatch_camera_model!(spec.model(), D, P => {
            let camera = self.typed_camera::<D, P>(spec, params, layout);
            for (i, (x, m)) in obs.object.iter().zip(&obs.pixels).enumerate() {
                let p = camera
                    .project_camera_point(&transform(&pose, rig.as_ref(), x))
                    .map_err(|_| not_visible(obs, i))?;
                errors.push(p - m);
            }
            Ok(())
        })
    }

    /// The smallest `|denominator|` of the lens model's rational term over the used points
    /// (positive weight) of observation `block` at its residual block's parameters `params`;
    /// `None` for models without a denominator, for observations without used points, and
    /// when a point cannot be projected.
    pub fn smallest_denominator(&self, block: usize, params: &[&[f64]]) -> Option<f64> {
        let obs = &self.problem.observations[block];
        let spec = &self.problem.cameras[obs.camera];
        let layout = self.layouts[block];
        let (pose, rig) = self.poses(params, layout);
        dispatch_camera_model!(spec.model(), D, P => {
            let camera = self.typed_camera::<D, P>(spec, params, layout);
            let mut smallest: Option<f64> = None;
            for (i, x) in obs.object.iter().enumerate() {
                if obs.weights.as_ref().is_some_and(|w| w[i] <= 0.0) {
                    continue;
                }
                let n = P::project(&transform(&pose, rig.as_ref(), x)).ok()?;
                let q = camera.distortion.denominator(&n)?.abs();
                smallest = Some(smallest.map_or(q, |s| s.min(q)));
            }
            smallest
        })
    }

    fn evaluate_model<D: LensDistortion, P: Projection>(
        &self,
        block: usize,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        let obs = &self.problem.observations[block];
        let spec = &self.problem.cameras[obs.camera];
        let layout = self.layouts[block];
        let camera = self.typed_camera::<D, P>(spec, params, layout);
        let pose_params = Vector6::from_column_slice(params[1]);
        let weight = |i: usize| obs.weights.as_ref().map_or(1.0, |w| w[i].sqrt());
        let Some(jac) = jacobians else {
            let (pose, rig) = self.poses(params, layout);
            for (i, (x, m)) in obs.object.iter().zip(&obs.pixels).enumerate() {
                let s = transform(&pose, rig.as_ref(), x);
                let p = camera
                    .project_camera_point(&s)
                    .map_err(|_| not_visible(obs, i))?;
                let w = weight(i);
                residuals[2 * i] = w * (p.x - m.x);
                residuals[2 * i + 1] = w * (p.y - m.y);
            }
            return Ok(());
        };
        let rows = residuals.len();
        let pose = DifferentiablePose::new::<R>(&pose_params);
        let composition = layout.rig.map(|k| {
            DifferentiableComposition::new::<R>(
                &Vector6::from_column_slice(params[k]),
                &pose_params,
            )
        });
        let n_dist = D::NUM_PARAMS;
        for (i, (x, m)) in obs.object.iter().zip(&obs.pixels).enumerate() {
            let (s, ds_dpose, ds_drig) = match &composition {
                Some(c) => {
                    let (s, d_inner, d_outer) = c.transform_with_jacobians(x);
                    (s, d_inner, Some(d_outer))
                }
                None => {
                    let (s, d) = pose.transform_with_jacobian(x);
                    (s, d, None)
                }
            };
            let j = camera
                .project_camera_point_with_jacobians(&s)
                .map_err(|_| not_visible(obs, i))?;
            let w = weight(i);
            let (rx, ry) = (2 * i, 2 * i + 1);
            residuals[rx] = w * (j.pixel.x - m.x);
            residuals[ry] = w * (j.pixel.y - m.y);
            let (dfx, dfy) = (j.d_intrinsics[(0, 0)] * w, j.d_intrinsics[(1, 1)] * w);
            if let Some(cam) = jac.block_mut(0) {
                for c in 0..4 {
                    cam[c * rows + rx] = 0.0;
                    cam[c * rows + ry] = 0.0;
                }
                if spec.focal_from.is_none() {
                    cam[rx] = dfx;
                    match spec.aspect_ratio {
                        // fy = fx / r: fy's column folds into fx's.
                        Some(r) => cam[ry] = dfy / r,
                        None => cam[rows + ry] = dfy,
                    }
                }
                cam[2 * rows + rx] = w;
                cam[3 * rows + ry] = w;
                let dd = ParamJacobian::as_slice(&j.d_distortion);
                for c in 0..n_dist {
                    cam[(4 + c) * rows + rx] = dd[2 * c] * w;
                    cam[(4 + c) * rows + ry] = dd[2 * c + 1] * w;
                }
            }
            if let Some(p) = jac.block_mut(1) {
                let d = j.d_camera_point * ds_dpose;
                for c in 0..6 {
                    p[c * rows + rx] = d[(0, c)] * w;
                    p[c * rows + ry] = d[(1, c)] * w;
                }
            }
            if let (Some(k), Some(ds)) = (layout.rig, ds_drig)
                && let Some(p) = jac.block_mut(k)
            {
                let d = j.d_camera_point * ds;
                for c in 0..6 {
                    p[c * rows + rx] = d[(0, c)] * w;
                    p[c * rows + ry] = d[(1, c)] * w;
                }
            }
            if let (Some(k), Some(source)) = (layout.focal, spec.focal_from)
                && let Some(src) = jac.block_mut(k)
            {
                // fx = fx_src and fy = fy_src (= fx_src / r_src with a fixed source aspect);
                // nothing else of the source camera enters.
                for c in 0..src.len() / rows {
                    src[c * rows + rx] = 0.0;
                    src[c * rows + ry] = 0.0;
                }
                src[rx] = dfx;
                match self.problem.cameras[source].aspect_ratio {
                    Some(r) => src[ry] = dfy / r,
                    None => src[rows + ry] = dfy,
                }
            }
        }
        Ok(())
    }

    fn evaluate_gram_model<D, P>(
        &self,
        block: usize,
        params: &[&[f64]],
        gram: &mut GramBlocks<'_>,
    ) -> Result<f64, EvaluationError>
    where
        D: LensDistortion,
        D::ParamJacobian: KernelWidth,
        P: Projection,
    {
        let obs = &self.problem.observations[block];
        let spec = &self.problem.cameras[obs.camera];
        let layout = self.layouts[block];
        let camera = self.typed_camera::<D, P>(spec, params, layout);
        let pose = DifferentiablePose::new::<R>(&Vector6::from_column_slice(params[1]));
        let camera_col = gram.block(0).map(|(c, _)| c);
        let focal = match (spec.focal_from, layout.focal) {
            (Some(source), Some(k)) => {
                let col = gram.block(k).map(|(c, _)| c);
                focal_targets(col, self.problem.cameras[source].aspect_ratio)
            }
            _ => focal_targets(camera_col, spec.aspect_ratio),
        };
        let view = ViewInput {
            observation: obs,
            focal,
            camera_col,
            pose_col: gram.block(1).map(|(c, _)| c),
            rig_col: layout.rig.and_then(|k| gram.block(k)).map(|(c, _)| c),
        };
        let outcome = match layout.rig {
            Some(k) => {
                let rig = DifferentiablePose::new::<R>(&Vector6::from_column_slice(params[k]));
                <D::ParamJacobian as KernelWidth>::rig(&camera, &pose, &rig, &view, gram)
            }
            None => <D::ParamJacobian as KernelWidth>::reference(&camera, &pose, &view, gram),
        };
        outcome.map_err(|point| not_visible(obs, point))
    }
}

/// Focal targets for a camera block starting at `col`: `fx` for the x row; `fy` (or `fx` with
/// factor `1 / r` for a fixed aspect ratio `r`) for the y row.
fn focal_targets(col: Option<usize>, aspect_ratio: Option<f64>) -> FocalTargets {
    FocalTargets {
        x: col.map(|c| (c, 1.0)),
        y: col.map(|c| match aspect_ratio {
            Some(r) => (c, 1.0 / r),
            None => (c + 1, 1.0),
        }),
    }
}

impl<R: RotationParameterization> CostFunction for JointCost<'_, R> {
    fn evaluate(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        let model = self.problem.cameras[self.problem.observations[block.0].camera].model();
        dispatch_camera_model!(model, D, P => self.evaluate_model::<D, P>(block.0, params, residuals, jacobians))
    }

    /// The fused path of the `kernel` module, for every lens model and for the trivial, Huber and
    /// Cauchy losses (others take the generic path).
    fn evaluate_gram(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        gram: &mut GramBlocks<'_>,
    ) -> Option<Result<f64, EvaluationError>> {
        if !handles_loss(gram.loss()) || gram.loss_group() != 2 && !gram.loss().is_trivial() {
            return None;
        }
        let model = self.problem.cameras[self.problem.observations[block.0].camera].model();
        Some(
            dispatch_camera_model!(model, D, P => self.evaluate_gram_model::<D, P>(block.0, params, gram)),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::ImageSize;
    use crate::problem::{CameraSpec, JointProblem, ObservationSpec};
    use camera_model::{AnyCamera, AxisAngle, CameraModel, EulerXyz, Intrinsics, So3};
    use lm_solver::manifold::{Manifold, RotationVector};
    use lm_solver::numdiff::{
        central_difference, check_cost_function, check_gram_with_loss, compare_jacobians,
    };
    use lm_solver::{Loss, Rng};
    use nalgebra::{Point3, Vector2};
    use proptest::prelude::*;

    /// Realistic distortion coefficients for each model (small enough that the maps stay
    /// one-to-one over the test points).
    fn distortion(model: CameraModel, rng: &mut Rng) -> Vec<f64> {
        let n = model.num_distortion_params();
        (0..n)
            .map(|i| {
                let scale = match (model, i) {
                    (CameraModel::KannalaBrandt4, i) => 0.05 / (1 + i) as f64,
                    (_, 2 | 3) => 0.003,
                    (_, 0) => 0.2,
                    (_, 8..) => 0.002,
                    _ => 0.05,
                };
                rng.range(-scale, scale)
            })
            .collect()
    }

    /// Two cameras (any models), one frame, both observing a 4x3 board; camera 1 is in the rig.
    fn problem(seed: u64, aspect: bool, shared_focal: bool) -> JointProblem {
        let mut rng = Rng::new(seed);
        let models = CameraModel::ALL;
        let mut cameras = Vec::new();
        for c in 0..2 {
            let model = models[(rng.uniform() * models.len() as f64) as usize % models.len()];
            let f = rng.range(300.0, 900.0);
            let k = Intrinsics::new(
                f,
                f * rng.range(0.9, 1.1),
                rng.range(300.0, 340.0),
                rng.range(220.0, 260.0),
            );
            let camera = AnyCamera::new(model, k, distortion(model, &mut rng)).unwrap();
            let mut spec = CameraSpec::new(format!("cam{c}"), ImageSize::new(640, 480), camera);
            if aspect && c == 0 {
                spec.aspect_ratio = Some(1.05);
                spec.fixed = vec![1];
            }
            if shared_focal && c == 1 {
                spec.focal_from = Some(0);
                spec.fixed = vec![0, 1];
            }
            cameras.push(spec);
        }
        let object: Vec<Point3<f64>> = (0..12)
            .map(|k| Point3::new((k % 4) as f64 * 40.0, (k / 4) as f64 * 40.0, 0.0))
            .collect();
        let pixels: Vec<Vector2<f64>> = (0..12)
            .map(|k| Vector2::new(300.0 + 3.0 * k as f64, 200.0 - 2.0 * k as f64))
            .collect();
        let mut o0 = ObservationSpec::new(0, 0, "view 0", object.clone(), pixels.clone());
        o0.weights = Some(
            (0..12)
                .map(|i| if i == 5 { 0.0 } else { 0.5 + 0.1 * i as f64 })
                .collect(),
        );
        let o1 = ObservationSpec::new(1, 0, "view 1", object, pixels);
        let frame = Pose::new(
            EulerXyz::matrix(&Vector3::new(
                std::f64::consts::PI + rng.range(-0.5, 0.5),
                rng.range(-0.5, 0.5),
                rng.range(-1.0, 1.0),
            )),
            Vector3::new(
                rng.range(-80.0, 0.0),
                rng.range(-60.0, 0.0),
                rng.range(600.0, 1200.0),
            ),
        );
        let rig = Pose::new(
            EulerXyz::matrix(&Vector3::new(
                rng.range(-0.1, 0.1),
                rng.range(-0.1, 0.1),
                rng.range(-0.1, 0.1),
            )),
            Vector3::new(
                rng.range(-120.0, -60.0),
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
            ),
        );
        let p = JointProblem {
            cameras,
            reference: 0,
            rig: vec![Pose::identity(), rig],
            rig_fixed: vec![false, false],
            frames: vec![frame],
            frame_names: vec!["frame 0".into()],
            observations: vec![o0, o1],
        };
        p.check().unwrap();
        p
    }

    fn params<R: RotationParameterization>(p: &JointProblem, obs: usize) -> Vec<Vec<f64>> {
        let o = &p.observations[obs];
        let mut out = vec![
            p.cameras[o.camera].initial.params(),
            p.frames[o.frame].to_params::<R>().as_slice().to_vec(),
        ];
        if p.has_rig(o.camera) {
            out.push(p.rig[o.camera].to_params::<R>().as_slice().to_vec());
        }
        if let Some(s) = p.cameras[o.camera].focal_from {
            out.push(p.cameras[s].initial.params());
        }
        out
    }

    fn check_all<R: RotationParameterization>(p: &JointProblem) -> Result<(), String> {
        let cost = JointCost::<R>::new(p);
        for obs in 0..2 {
            let owned = params::<R>(p, obs);
            let refs: Vec<&[f64]> = owned.iter().map(|v| v.as_slice()).collect();
            // Pixel Jacobians: values below 5e3 px and parameters of order one to a thousand, so
            // with relative steps of 1e-6 the central-difference error is below ~1e-6 px per
            // unit; 1e-5 (|n| + 1) is several times that and far below any wrong term.
            check_cost_function(&cost, ResidualBlockId(obs), &refs, 24, 1e-6, 1e-5, 1.0).map_err(
                |e| {
                    format!(
                        "observation {obs} ({}): {e}",
                        p.cameras[p.observations[obs].camera].model()
                    )
                },
            )?;
            for loss in [Loss::Trivial, Loss::Huber(2.0), Loss::Cauchy(3.0)] {
                check_gram_with_loss(&cost, ResidualBlockId(obs), &refs, 24, loss, 2, 1e-10)
                    .map_err(|e| format!("observation {obs} fused, {loss:?}: {e}"))?;
            }
        }
        Ok(())
    }

    /// `smallest_denominator` is the smallest `|1 + k4 r^2 + k5 r^4 + k6 r^6|` over the used
    /// points, computed here independently from the camera-frame points; `None` for polynomial
    /// models.
    #[test]
    fn smallest_denominator_is_over_the_used_points() {
        let mut p = problem(3, false, false);
        let k = Intrinsics::new(500.0, 500.0, 320.0, 240.0);
        let point_r2 = |p: &JointProblem, i: usize| {
            let s = p.frames[0].transform_point(&p.observations[0].object[i]);
            (s.x / s.z).powi(2) + (s.y / s.z).powi(2)
        };
        // A denominator with a root exactly at point 7's radius: 1 - r^2 / r7^2.
        let r7 = point_r2(&p, 7);
        let mut d = vec![0.0; 8];
        d[5] = -1.0 / r7;
        p.cameras[0].initial = AnyCamera::new(CameraModel::Rational8, k, d.clone()).unwrap();
        let expected = |p: &JointProblem, d: &[f64]| {
            (0..12)
                .filter(|&i| {
                    p.observations[0]
                        .weights
                        .as_ref()
                        .is_none_or(|w| w[i] > 0.0)
                })
                .map(|i| (1.0 + d[5] * point_r2(p, i)).abs())
                .fold(f64::INFINITY, f64::min)
        };
        let smallest = |p: &JointProblem| {
            let cost = JointCost::<EulerXyz>::new(p);
            let owned = params::<EulerXyz>(p, 0);
            let refs: Vec<&[f64]> = owned.iter().map(|v| v.as_slice()).collect();
            cost.smallest_denominator(0, &refs)
        };
        let q = smallest(&p).unwrap();
        assert!(q < 1e-12, "{q}");
        assert!((q - expected(&p, &d)).abs() < 1e-12);
        // Point 5 has weight zero: a root at its radius is not seen.
        let r5 = point_r2(&p, 5);
        d[5] = -1.0 / r5;
        p.cameras[0].initial = AnyCamera::new(CameraModel::Rational8, k, d.clone()).unwrap();
        let q = smallest(&p).unwrap();
        assert!(q > 1e-6 || (r5 - r7).abs() < 1e-9, "{q}");
        assert!(
            (q - expected(&p, &d)).abs() < 1e-12,
            "{q} vs {}",
            expected(&p, &d)
        );
        p.cameras[0].initial =
            AnyCamera::new(CameraModel::BrownConrady5, k, vec![0.1, 0.0, 0.0, 0.0, 0.0]).unwrap();
        assert_eq!(smallest(&p), None);
    }

    proptest! {
        /// The analytic Jacobian of every residual block against central differences, and the
        /// fused normal equations against the Jacobian's, for random models, poses, rigs, weights
        /// (or none: the kernels' unscaled path), losses, aspect ratios and shared focal lengths.
        #[test]
        fn jacobians_and_fused_path_are_correct(
            seed in 0u64..u64::MAX, aspect in prop::bool::ANY, shared in prop::bool::ANY, axis in prop::bool::ANY,
            unweighted in prop::bool::ANY
        ) {
            let mut p = problem(seed, aspect, shared);
            if unweighted {
                p.observations[0].weights = None;
            }
            let r = if axis { check_all::<AxisAngle>(&p) } else { check_all::<EulerXyz>(&p) };
            prop_assert!(r.is_ok(), "{:?}", r);
        }

        /// With SO(3) updates the pose and rig columns are derivatives along the manifold:
        /// `d r(x ⊞ delta) / d delta` at zero.
        #[test]
        fn so3_jacobians_are_tangent_derivatives(seed in 0u64..u64::MAX, tilt in -0.4f64..0.4) {
            let mut p = problem(seed, false, false);
            // Rotation vectors are ill-conditioned within a few degrees of pi (log and exp lose
            // digits there), which would swamp the finite differences; keep the board turned by
            // about 2.4 rad about its x axis instead of pi.
            p.frames[0].rotation = EulerXyz::matrix(&Vector3::new(2.4 + tilt, 0.2, -0.3));
            let cost = JointCost::<So3>::new(&p);
            let owned = params::<So3>(&p, 1);
            let refs: Vec<&[f64]> = owned.iter().map(|v| v.as_slice()).collect();
            let layout = [(0usize, 4 + p.cameras[1].model().num_distortion_params()), (100, 6), (106, 6)];
            let cols = 112;
            let mut buffer = vec![0.0; 24 * cols];
            let layout_fixed: Vec<(usize, usize)> = layout.to_vec();
            let mut res = vec![0.0; 24];
            {
                let mut jac = JacobianBlocks::new(&mut buffer, 24, &layout_fixed);
                cost.evaluate(ResidualBlockId(1), &refs, &mut res, Some(&mut jac)).unwrap();
            }
            let manifold = RotationVector::pose();
            for (k, &(col, _)) in layout.iter().enumerate().skip(1) {
                let numeric = central_difference(
                    |d: &[f64], out: &mut [f64]| {
                        let mut moved = owned.clone();
                        manifold.plus(&owned[k], d, &mut moved[k]);
                        let r: Vec<&[f64]> = moved.iter().map(|v| v.as_slice()).collect();
                        cost.evaluate(ResidualBlockId(1), &r, out, None).unwrap();
                    },
                    &[0.0; 6],
                    24,
                    1e-6,
                );
                let analytic = &buffer[col * 24..(col + 6) * 24];
                let r = compare_jacobians(analytic, &numeric, 24, 1e-5, 1.0);
                prop_assert!(r.is_ok(), "block {k}: {:?}", r);
            }
        }
    }
}
