//! The reprojection cost of a stereo rig.
//!
//! Parameter blocks: left camera (reduced), right camera (reduced), rig (reduced), and one left
//! pose per pair (eliminated). Residual block `2 j` holds pair `j`'s left reprojection errors
//! (`[left camera, pose_j]`), block `2 j + 1` its right ones (`[right camera, pose_j, rig]`, plus the
//! left camera when both cameras share the focal length). The right camera sees the board at
//! `rig * pose_j`; its Jacobians with respect to `pose_j` and the rig follow the chain rule of
//! `camera_model::pose::composition`.

use calib_single::cost::{accumulate_view_gram, compact_targets};
use camera_model::pose::composition::DifferentiableComposition;
use camera_model::{
    Camera, CameraPointJacobians, DifferentiablePose, LensDistortion, ParamJacobian, Pose,
    RotationParameterization,
};
use lm_solver::gram::CompactGram;
use lm_solver::{CostFunction, EvaluationError, GramBlocks, JacobianBlocks, ResidualBlockId};
use nalgebra::{Point3, Vector2, Vector6};
use std::marker::PhantomData;

/// The points of one pair.
#[derive(Debug, Clone)]
pub struct PairData {
    /// Board points (shared by both views).
    pub object: Vec<Point3<f64>>,
    /// Left measured pixels.
    pub left: Vec<Vector2<f64>>,
    /// Right measured pixels.
    pub right: Vec<Vector2<f64>>,
}

/// How the intrinsic blocks map to cameras.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CameraCoupling {
    /// Fixed `fx / fy` of the left camera (`fy = fx / r`).
    pub left_aspect: Option<f64>,
    /// Fixed `fx / fy` of the right camera.
    pub right_aspect: Option<f64>,
    /// The right camera uses the left camera's focal lengths.
    pub same_focal_length: bool,
}

/// Reprojection errors of all pairs of a stereo rig.
#[derive(Debug, Clone)]
pub struct StereoCost<'a, D, P> {
    pairs: &'a [PairData],
    coupling: CameraCoupling,
    _model: PhantomData<fn() -> (D, P)>,
}

fn behind(pair: usize, side: &str, point: usize) -> EvaluationError {
    EvaluationError::new(format!(
        "pair {pair}, {side} view, point {point} is not in front of the camera"
    ))
}

impl<'a, D: LensDistortion, P: RotationParameterization> StereoCost<'a, D, P> {
    /// The cost over `pairs`.
    pub fn new(pairs: &'a [PairData], coupling: CameraCoupling) -> Self {
        Self {
            pairs,
            coupling,
            _model: PhantomData,
        }
    }

    /// The left camera of a left camera block.
    pub fn left_camera(&self, left: &[f64]) -> Camera<D> {
        let mut camera = Camera::<D>::from_params(left);
        if let Some(r) = self.coupling.left_aspect {
            camera.intrinsics.fy = camera.intrinsics.fx / r;
        }
        camera
    }

    /// The right camera of the right (and, with a shared focal length, left) camera blocks.
    pub fn right_camera(&self, right: &[f64], left: &[f64]) -> Camera<D> {
        let mut camera = Camera::<D>::from_params(right);
        if self.coupling.same_focal_length {
            let l = self.left_camera(left);
            camera.intrinsics.fx = l.intrinsics.fx;
            camera.intrinsics.fy = l.intrinsics.fy;
        } else if let Some(r) = self.coupling.right_aspect {
            camera.intrinsics.fy = camera.intrinsics.fx / r;
        }
        camera
    }
}

/// Writes the camera-block Jacobian columns of one point (rows `rx`, `ry`) into `cam`, folding
/// `fy`'s column into `fx`'s for a fixed aspect ratio.
#[inline]
fn write_camera_columns<D: LensDistortion>(
    cam: &mut [f64],
    rows: usize,
    rx: usize,
    ry: usize,
    j: &CameraPointJacobians<D>,
    aspect: Option<f64>,
    skip_focal: bool,
) {
    let d_intrinsics = &j.d_intrinsics;
    for c in 0..4 {
        let zero = skip_focal && c < 2;
        cam[c * rows + rx] = if zero { 0.0 } else { d_intrinsics[(0, c)] };
        cam[c * rows + ry] = if zero { 0.0 } else { d_intrinsics[(1, c)] };
    }
    if let (Some(r), false) = (aspect, skip_focal) {
        cam[rx] += d_intrinsics[(0, 1)] / r;
        cam[ry] += d_intrinsics[(1, 1)] / r;
        cam[rows + rx] = 0.0;
        cam[rows + ry] = 0.0;
    }
    let dd = ParamJacobian::as_slice(&j.d_distortion);
    for c in 0..D::NUM_PARAMS {
        cam[(4 + c) * rows + rx] = dd[2 * c];
        cam[(4 + c) * rows + ry] = dd[2 * c + 1];
    }
}

impl<D: LensDistortion, P: RotationParameterization> CostFunction for StereoCost<'_, D, P> {
    fn evaluate(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        let pair_index = block.0 / 2;
        let pair = &self.pairs[pair_index];
        let rows = residuals.len();
        let pose_params = Vector6::from_column_slice(params[1]);
        let left_view = block.0.is_multiple_of(2);
        let (camera, measured, side) = if left_view {
            (self.left_camera(params[0]), &pair.left, "left")
        } else {
            let left_block: &[f64] = if self.coupling.same_focal_length {
                params[3]
            } else {
                params[0]
            };
            (
                self.right_camera(params[0], left_block),
                &pair.right,
                "right",
            )
        };
        let Some(jac) = jacobians else {
            // Cost only: the same arithmetic as below without the derivatives, so both paths give
            // identical residuals.
            let pose = Pose::from_params::<P>(&pose_params);
            let rig = (!left_view)
                .then(|| Pose::from_params::<P>(&Vector6::from_column_slice(params[2])));
            for (i, (x, m)) in pair.object.iter().zip(measured).enumerate() {
                let inner = pose.rotation * x.coords + pose.translation;
                let s = match &rig {
                    Some(rig) => rig.rotation * inner + rig.translation,
                    None => inner,
                };
                let p = camera
                    .project_camera_point(&s)
                    .map_err(|_| behind(pair_index, side, i))?;
                residuals[2 * i] = p.x - m.x;
                residuals[2 * i + 1] = p.y - m.y;
            }
            return Ok(());
        };
        if left_view {
            // [left camera, pose].
            let pose = DifferentiablePose::new::<P>(&pose_params);
            for (i, (x, m)) in pair.object.iter().zip(measured).enumerate() {
                let (s, ds_dm) = pose.transform_with_jacobian(x);
                let j = camera
                    .project_camera_point_with_jacobians(&s)
                    .map_err(|_| behind(pair_index, side, i))?;
                let (rx, ry) = (2 * i, 2 * i + 1);
                residuals[rx] = j.pixel.x - m.x;
                residuals[ry] = j.pixel.y - m.y;
                if let Some(cam) = jac.block_mut(0) {
                    write_camera_columns::<D>(
                        cam,
                        rows,
                        rx,
                        ry,
                        &j,
                        self.coupling.left_aspect,
                        false,
                    );
                }
                if let Some(p) = jac.block_mut(1) {
                    let d = j.d_camera_point * ds_dm;
                    for c in 0..6 {
                        p[c * rows + rx] = d[(0, c)];
                        p[c * rows + ry] = d[(1, c)];
                    }
                }
            }
            return Ok(());
        }
        // [right camera, pose, rig (, left camera)].
        let rig_params = Vector6::from_column_slice(params[2]);
        let composition = DifferentiableComposition::new::<P>(&rig_params, &pose_params);
        for (i, (x, m)) in pair.object.iter().zip(measured).enumerate() {
            let (s, ds_dpose, ds_drig) = composition.transform_with_jacobians(x);
            let j = camera
                .project_camera_point_with_jacobians(&s)
                .map_err(|_| behind(pair_index, side, i))?;
            let (rx, ry) = (2 * i, 2 * i + 1);
            residuals[rx] = j.pixel.x - m.x;
            residuals[ry] = j.pixel.y - m.y;
            if let Some(cam) = jac.block_mut(0) {
                write_camera_columns::<D>(
                    cam,
                    rows,
                    rx,
                    ry,
                    &j,
                    self.coupling.right_aspect,
                    self.coupling.same_focal_length,
                );
            }
            for (k, ds) in [(1usize, &ds_dpose), (2, &ds_drig)] {
                if let Some(p) = jac.block_mut(k) {
                    let d = j.d_camera_point * ds;
                    for c in 0..6 {
                        p[c * rows + rx] = d[(0, c)];
                        p[c * rows + ry] = d[(1, c)];
                    }
                }
            }
            if self.coupling.same_focal_length
                && let Some(left) = jac.block_mut(3)
            {
                // fx_R = fx_L and fy_R = fy_L (= fx_L / r_L with a fixed left aspect ratio); the
                // right residuals do not depend on the rest of the left block.
                for c in 0..left.len() / rows {
                    left[c * rows + rx] = 0.0;
                    left[c * rows + ry] = 0.0;
                }
                let di = &j.d_intrinsics;
                match self.coupling.left_aspect {
                    Some(r) => {
                        left[rx] = di[(0, 0)] + di[(0, 1)] / r;
                        left[ry] = di[(1, 0)] + di[(1, 1)] / r;
                    }
                    None => {
                        left[rx] = di[(0, 0)];
                        left[ry] = di[(1, 0)];
                        left[rows + rx] = di[(0, 1)];
                        left[rows + ry] = di[(1, 1)];
                    }
                }
            }
        }
        Ok(())
    }

    /// The fused path (see [`CostFunction::evaluate_gram`]): each pixel row has few structural
    /// non-zeros, accumulated as compact rows (`lm_solver::gram::CompactGram`). Left views are
    /// single-camera views ([`accumulate_view_gram`]); right views use 15-wide rows
    /// from which the twelve pose and rig derivatives follow by a fixed map per pair (see the
    /// comment in the body), the focal entry going to the left camera's columns when both
    /// cameras share the focal length. Implemented for models with four distortion coefficients.
    fn evaluate_gram(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        gram: &mut GramBlocks<'_>,
    ) -> Option<Result<f64, EvaluationError>> {
        if D::NUM_PARAMS != 4 {
            return None;
        }
        let pair_index = block.0 / 2;
        let pair = &self.pairs[pair_index];
        let pose_params = Vector6::from_column_slice(params[1]);
        let n = gram.cols();
        let mut squared = 0.0;
        if block.0.is_multiple_of(2) {
            let camera = self.left_camera(params[0]);
            let pose = DifferentiablePose::new::<P>(&pose_params);
            let squared = accumulate_view_gram(
                &camera,
                &pose,
                &pair.object,
                &pair.left,
                self.coupling.left_aspect,
                gram,
            );
            return Some(squared.map_err(|point| behind(pair_index, "left", point)));
        }
        let left_block: &[f64] = if self.coupling.same_focal_length {
            params[3]
        } else {
            params[0]
        };
        let camera = self.right_camera(params[0], left_block);
        let pose = DifferentiablePose::new::<P>(&pose_params);
        let rig = DifferentiablePose::new::<P>(&Vector6::from_column_slice(params[2]));
        let (omega_pose, omega_rig) = (pose.body_generators(), rig.body_generators());
        let r_left_t = pose.rotation.transpose();
        // With D = (dp/ds) R_s and the body-frame generators (dR/drho_k = R [omega_k]x), each row's
        // pose and rig derivatives are fixed linear maps of three 3-vectors per point:
        //   dp/dt_L = D_r,  dp/dt_s = R_s D_r,  dp/drho_s = Omega_s^T (q x D_r),
        //   dp/drho_L = Omega_L^T (X x R_L^T D_r),  q = R_L X + t_L,
        // so the compact row is [focal, principal point, k (4), D_r, q x D_r, X x R_L^T D_r].
        let (mut gx, mut gy) = (CompactGram::<15>::new(), CompactGram::<15>::new());
        for (i, (x, m)) in pair.object.iter().zip(&pair.right).enumerate() {
            let q = pose.rotation * x.coords + pose.translation;
            let s = rig.rotation * q + rig.translation;
            let j = match camera.project_camera_point_with_jacobians(&s) {
                Ok(j) => j,
                Err(_) => return Some(Err(behind(pair_index, "right", i))),
            };
            let d = j.d_camera_point * rig.rotation;
            let dd = ParamJacobian::as_slice(&j.d_distortion);
            let (rx, ry) = (j.pixel.x - m.x, j.pixel.y - m.y);
            squared += rx * rx + ry * ry;
            let row = |r: usize, focal: f64| {
                let dr = nalgebra::Vector3::new(d[(r, 0)], d[(r, 1)], d[(r, 2)]);
                let e = q.cross(&dr);
                let f = x.coords.cross(&(r_left_t * dr));
                [
                    focal,
                    1.0,
                    dd[r],
                    dd[2 + r],
                    dd[4 + r],
                    dd[6 + r],
                    dr.x,
                    dr.y,
                    dr.z,
                    e.x,
                    e.y,
                    e.z,
                    f.x,
                    f.y,
                    f.z,
                ]
            };
            gx.push(&row(0, j.d_intrinsics[(0, 0)]), rx);
            gy.push(&row(1, j.d_intrinsics[(1, 1)]), ry);
        }
        let right_cols = gram.block(0).map(|b| b.0);
        let pose_cols = gram.block(1).map(|b| b.0);
        let rig_cols = gram.block(2).map(|b| b.0);
        let left_cols = if self.coupling.same_focal_length {
            gram.block(3).map(|b| b.0)
        } else {
            None
        };
        let (g, gradient) = gram.parts_mut();
        g.fill(0.0);
        gradient.fill(0.0);
        // At most 6 camera + 3 + 9 pose + 18 rig entries: a fixed array, no allocation.
        let mut storage = [(0usize, 0usize, 0.0f64); 40];
        for (row_y, sums) in [(false, gx.finish()), (true, gy.finish())] {
            let mut count = 0;
            let mut push = |e: (usize, usize, f64)| {
                storage[count] = e;
                count += 1;
            };
            // Camera entries as in a single-camera row (no pose columns here).
            let single = compact_targets(row_y, right_cols, None, self.coupling.right_aspect);
            for (a, t) in single.iter().take(6).enumerate() {
                if let Some((c, f)) = *t
                    && !(a == 0 && self.coupling.same_focal_length)
                {
                    push((a, c, f));
                }
            }
            if self.coupling.same_focal_length {
                // The focal lengths are the left camera's (fy_L = fx_L / r with its fixed aspect).
                if let Some(c) = left_cols {
                    push(match (row_y, self.coupling.left_aspect) {
                        (false, _) => (0, c, 1.0),
                        (true, Some(r)) => (0, c, 1.0 / r),
                        (true, None) => (0, c + 1, 1.0),
                    });
                }
            }
            for k in 0..3 {
                if let Some(p) = pose_cols {
                    push((6 + k, p + 3 + k, 1.0));
                    for i in 0..3 {
                        push((12 + i, p + k, omega_pose[(i, k)]));
                    }
                }
                if let Some(c) = rig_cols {
                    for i in 0..3 {
                        push((6 + i, c + 3 + k, rig.rotation[(k, i)]));
                        push((9 + i, c + k, omega_rig[(i, k)]));
                    }
                }
            }
            sums.scatter_map(&storage[..count], g, gradient, n);
        }
        Some(Ok(squared))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use camera_model::{AxisAngle, BrownConrady, EulerXyz};
    use lm_solver::numdiff::{check_cost_function, check_gram};
    use nalgebra::Vector3;
    use proptest::prelude::*;

    fn pair() -> PairData {
        let object: Vec<Point3<f64>> = (0..12)
            .map(|k| Point3::new((k % 4) as f64 * 30.0, (k / 4) as f64 * 30.0, 0.0))
            .collect();
        let left = (0..12)
            .map(|k| Vector2::new(300.0 + k as f64, 200.0 - k as f64))
            .collect();
        let right = (0..12)
            .map(|k| Vector2::new(250.0 - k as f64, 210.0 + k as f64))
            .collect();
        PairData {
            object,
            left,
            right,
        }
    }

    fn check<P: RotationParameterization>(
        cameras: ([f64; 8], [f64; 8]),
        pose: [f64; 6],
        rig: [f64; 6],
        coupling: CameraCoupling,
    ) -> Result<(), String> {
        let pairs = [pair()];
        let cost = StereoCost::<BrownConrady, P>::new(&pairs, coupling);
        // Pixel Jacobians as in the single-camera test: rounding eps |f| / h <= 6e-7 px per unit
        // (translations here are hundreds of mm, so h is larger and the error smaller), truncation
        // below 2e-6 px; 1e-5 (|n| + 1) bounds both several times over.
        check_cost_function(
            &cost,
            ResidualBlockId(0),
            &[&cameras.0, &pose],
            24,
            1e-6,
            1e-5,
            1.0,
        )
        .map_err(|e| format!("left: {e}"))?;
        let right_params: Vec<&[f64]> = if coupling.same_focal_length {
            vec![&cameras.1, &pose, &rig, &cameras.0]
        } else {
            vec![&cameras.1, &pose, &rig]
        };
        check_cost_function(
            &cost,
            ResidualBlockId(1),
            &right_params,
            24,
            1e-6,
            1e-5,
            1.0,
        )
        .map_err(|e| format!("right: {e}"))?;
        // The fused Gram products equal those of the (checked) Jacobian.
        check_gram(&cost, ResidualBlockId(0), &[&cameras.0, &pose], 24, 1e-11)
            .map_err(|e| format!("left gram: {e}"))?;
        check_gram(&cost, ResidualBlockId(1), &right_params, 24, 1e-11)
            .map_err(|e| format!("right gram: {e}"))
    }

    proptest! {
        #[test]
        fn stereo_jacobians_match_finite_differences(
            fx in 300.0f64..1200.0, aspect in 0.9f64..1.2, k1 in -0.3f64..0.3, k2 in -0.2f64..0.2,
            ax in -0.5f64..0.5, ay in -0.5f64..0.5, az in -1.0f64..1.0, tz in 600.0f64..1500.0,
            rx in -0.05f64..0.05, ry in -0.05f64..0.05, rz in -0.05f64..0.05, baseline in -150.0f64..-50.0,
            left_aspect in prop::bool::ANY, right_aspect in prop::bool::ANY, same_focal in prop::bool::ANY,
            axis_angle in prop::bool::ANY,
        ) {
            let left = [fx, fx * aspect, 320.0, 240.0, k1, k2, 0.001, -0.002];
            let right = [fx * 1.02, fx * aspect * 0.99, 310.0, 250.0, k1 * 0.9, k2, -0.001, 0.001];
            let coupling = CameraCoupling {
                left_aspect: left_aspect.then_some(1.0 / aspect),
                right_aspect: right_aspect.then_some(1.02 / (0.99 * aspect)),
                same_focal_length: same_focal,
            };
            let r_pose = EulerXyz::matrix(&Vector3::new(ax + std::f64::consts::PI, ay, az));
            let r_rig = EulerXyz::matrix(&Vector3::new(rx, ry, rz));
            let t_pose = [-50.0, -30.0, tz];
            let t_rig = [baseline, 1.0, 2.0];
            let result = if axis_angle {
                let (a, b) = (AxisAngle::from_matrix(&r_pose), AxisAngle::from_matrix(&r_rig));
                check::<AxisAngle>((left, right), [a.x, a.y, a.z, t_pose[0], t_pose[1], t_pose[2]], [b.x, b.y, b.z, t_rig[0], t_rig[1], t_rig[2]], coupling)
            } else {
                let (a, b) = (EulerXyz::from_matrix(&r_pose), EulerXyz::from_matrix(&r_rig));
                check::<EulerXyz>((left, right), [a.x, a.y, a.z, t_pose[0], t_pose[1], t_pose[2]], [b.x, b.y, b.z, t_rig[0], t_rig[1], t_rig[2]], coupling)
            };
            prop_assert!(result.is_ok(), "{:?}", result);
        }
    }
}
