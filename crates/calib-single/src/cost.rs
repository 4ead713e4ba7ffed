//! The reprojection cost of a single camera, as an `lm_solver` cost function.
//!
//! Parameter blocks: the camera `[fx, fy, cx, cy, distortion...]` (kept in the reduced system) and
//! one pose `[rho (3), t (3)]` per view (eliminated). Residual block `i` holds the `2 N_i`
//! reprojection errors `projected - measured` of view `i`, ordered `x_0, y_0, x_1, y_1, ...`.

use camera_model::{
    Camera, DifferentiablePose, LensDistortion, ParamJacobian, RotationParameterization,
};
use lm_solver::gram::CompactGram;
use lm_solver::{CostFunction, EvaluationError, GramBlocks, JacobianBlocks, ResidualBlockId};
use nalgebra::{Point3, Vector2, Vector3, Vector6};
use std::marker::PhantomData;

/// The points of one view, ready for the cost function.
#[derive(Debug, Clone)]
pub struct ViewData {
    /// Board points.
    pub object: Vec<Point3<f64>>,
    /// Measured pixels.
    pub image: Vec<Vector2<f64>>,
}

/// Reprojection errors of all views of one camera.
///
/// With `aspect_ratio = Some(r)` the vertical focal length is not a free parameter: it is
/// `fy = fx / r`, the camera block's `fy` entry is ignored (the calibration holds it fixed), and the
/// `fx` column of the Jacobian carries both contributions, `dp/dfx + dp/dfy / r`.
#[derive(Debug, Clone)]
pub struct ReprojectionCost<'a, D, P> {
    views: &'a [ViewData],
    aspect_ratio: Option<f64>,
    _model: PhantomData<fn() -> (D, P)>,
}

impl<'a, D: LensDistortion, P: RotationParameterization> ReprojectionCost<'a, D, P> {
    /// The cost over `views`; see the type documentation for `aspect_ratio`.
    pub fn new(views: &'a [ViewData], aspect_ratio: Option<f64>) -> Self {
        Self {
            views,
            aspect_ratio,
            _model: PhantomData,
        }
    }

    /// The fixed `fx / fy` ratio, if any.
    pub fn aspect_ratio(&self) -> Option<f64> {
        self.aspect_ratio
    }

    /// The camera described by a camera parameter block, with `fy` derived from `fx` when the
    /// aspect ratio is fixed.
    pub fn camera(&self, params: &[f64]) -> Camera<D> {
        let mut camera = Camera::<D>::from_params(params);
        if let Some(r) = self.aspect_ratio {
            camera.intrinsics.fy = camera.intrinsics.fx / r;
        }
        camera
    }
}

fn behind(view: usize, point: usize) -> EvaluationError {
    EvaluationError::new(format!(
        "view {view}, point {point} is not in front of the camera"
    ))
}

impl<D: LensDistortion, P: RotationParameterization> CostFunction for ReprojectionCost<'_, D, P> {
    fn evaluate(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        let view = &self.views[block.0];
        let camera = self.camera(params[0]);
        let pose_params = Vector6::from_column_slice(params[1]);
        let Some(jac) = jacobians else {
            let pose = camera_model::Pose::from_params::<P>(&pose_params);
            for (i, (x, m)) in view.object.iter().zip(&view.image).enumerate() {
                let s: Vector3<f64> = pose.transform_point(x);
                let p = camera
                    .project_camera_point(&s)
                    .map_err(|_| behind(block.0, i))?;
                residuals[2 * i] = p.x - m.x;
                residuals[2 * i + 1] = p.y - m.y;
            }
            return Ok(());
        };
        let rows = residuals.len();
        let pose = DifferentiablePose::new::<P>(&pose_params);
        let n_dist = D::NUM_PARAMS;
        let aspect = self.aspect_ratio;
        for (i, (x, m)) in view.object.iter().zip(&view.image).enumerate() {
            let j = camera
                .project_with_jacobians(&pose, x)
                .map_err(|_| behind(block.0, i))?;
            let (rx, ry) = (2 * i, 2 * i + 1);
            residuals[rx] = j.pixel.x - m.x;
            residuals[ry] = j.pixel.y - m.y;
            if let Some(cam) = jac.block_mut(0) {
                let di = &j.d_intrinsics;
                for c in 0..4 {
                    cam[c * rows + rx] = di[(0, c)];
                    cam[c * rows + ry] = di[(1, c)];
                }
                if let Some(r) = aspect {
                    // fy = fx / r: fold fy's column into fx's.
                    cam[rx] += di[(0, 1)] / r;
                    cam[ry] += di[(1, 1)] / r;
                    cam[rows + rx] = 0.0;
                    cam[rows + ry] = 0.0;
                }
                let dd = ParamJacobian::as_slice(&j.d_distortion);
                for c in 0..n_dist {
                    cam[(4 + c) * rows + rx] = dd[2 * c];
                    cam[(4 + c) * rows + ry] = dd[2 * c + 1];
                }
            }
            if let Some(p) = jac.block_mut(1) {
                for c in 0..6 {
                    p[c * rows + rx] = j.d_pose[(0, c)];
                    p[c * rows + ry] = j.d_pose[(1, c)];
                }
            }
        }
        Ok(())
    }

    /// The fused path (see [`CostFunction::evaluate_gram`] and [`accumulate_view_gram`]),
    /// implemented for models with four distortion coefficients (the others take the generic path).
    fn evaluate_gram(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        gram: &mut GramBlocks<'_>,
    ) -> Option<Result<f64, EvaluationError>> {
        if D::NUM_PARAMS != 4 {
            return None;
        }
        let camera = self.camera(params[0]);
        let pose = DifferentiablePose::new::<P>(&Vector6::from_column_slice(params[1]));
        let view = &self.views[block.0];
        let squared = accumulate_view_gram(
            &camera,
            &pose,
            &view.object,
            &view.image,
            self.aspect_ratio,
            gram,
        );
        Some(squared.map_err(|point| behind(block.0, point)))
    }
}

/// Fills `gram` with the normal-equation blocks of one view (board points `object`, measured
/// pixels `image`) seen by one camera, the fused
/// counterpart of [`ReprojectionCost::evaluate`] shared with the stereo cost's left views.
///
/// The residual block's parameter block 0 is the camera `[fx, fy, cx, cy, k (4)]` and block 1 the
/// pose; per point, the x and y rows of the Jacobian each have twelve structural non-zeros (the x
/// row does not depend on `fy, cy`, the y row not on `fx, cx`), accumulated as compact rows
/// `[d(fx or fy), d(cx or cy), d/dk (4), d/dpose (6)]` and scattered onto the block's columns once
/// per view (see [`compact_targets`]). Requires a model with four distortion coefficients.
///
/// Returns the sum of squared residuals in px², or the index of the first point behind the camera.
/// Cost `O(N)` in the number of points, no allocation.
pub fn accumulate_view_gram<D: LensDistortion>(
    camera: &Camera<D>,
    pose: &DifferentiablePose,
    object: &[Point3<f64>],
    image: &[Vector2<f64>],
    aspect_ratio: Option<f64>,
    gram: &mut GramBlocks<'_>,
) -> Result<f64, usize> {
    debug_assert_eq!(D::NUM_PARAMS, 4);
    let (mut gx, mut gy) = (CompactGram::<12>::new(), CompactGram::<12>::new());
    let mut squared = 0.0;
    for (i, (x, m)) in object.iter().zip(image).enumerate() {
        let (s, ds_dm) = pose.transform_with_jacobian(x);
        let j = camera
            .project_camera_point_with_jacobians(&s)
            .map_err(|_| i)?;
        let d_pose = j.d_camera_point * ds_dm;
        let dd = ParamJacobian::as_slice(&j.d_distortion);
        let (rx, ry) = (j.pixel.x - m.x, j.pixel.y - m.y);
        squared += rx * rx + ry * ry;
        let row = |r: usize, d: f64| {
            [
                d,
                1.0,
                dd[r],
                dd[2 + r],
                dd[4 + r],
                dd[6 + r],
                d_pose[(r, 0)],
                d_pose[(r, 1)],
                d_pose[(r, 2)],
                d_pose[(r, 3)],
                d_pose[(r, 4)],
                d_pose[(r, 5)],
            ]
        };
        gx.push(&row(0, j.d_intrinsics[(0, 0)]), rx);
        gy.push(&row(1, j.d_intrinsics[(1, 1)]), ry);
    }
    let n = gram.cols();
    let camera_cols = gram.block(0).map(|(c, _)| c);
    let pose_cols = gram.block(1).map(|(c, _)| c);
    let (g, gradient) = gram.parts_mut();
    g.fill(0.0);
    gradient.fill(0.0);
    for (row_y, sums) in [(false, gx.finish()), (true, gy.finish())] {
        let targets = compact_targets(row_y, camera_cols, pose_cols, aspect_ratio);
        sums.scatter(&targets, g, gradient, n);
    }
    Ok(squared)
}

/// Where the compact entries of an x row (`row_y = false`) or y row go in a residual block whose
/// camera block starts at column `camera` and pose block at `pose` (`None`: constant block), with
/// the fixed aspect ratio folding the y row's focal-length derivative onto `fx`.
pub fn compact_targets(
    row_y: bool,
    camera: Option<usize>,
    pose: Option<usize>,
    aspect_ratio: Option<f64>,
) -> [Option<(usize, f64)>; 12] {
    let mut t = [None; 12];
    if let Some(c) = camera {
        t[0] = Some(match (row_y, aspect_ratio) {
            (false, _) => (c, 1.0),
            // fy = fx / r: d/dfx gets d/dfy / r.
            (true, Some(r)) => (c, 1.0 / r),
            (true, None) => (c + 1, 1.0),
        });
        t[1] = Some((c + if row_y { 3 } else { 2 }, 1.0));
        for k in 0..4 {
            t[2 + k] = Some((c + 4 + k, 1.0));
        }
    }
    if let Some(p) = pose {
        for k in 0..6 {
            t[6 + k] = Some((p + k, 1.0));
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use camera_model::{AxisAngle, BrownConrady, EulerXyz};
    use lm_solver::numdiff::check_cost_function;
    use proptest::prelude::*;

    fn view() -> ViewData {
        let object: Vec<Point3<f64>> = (0..12)
            .map(|k| Point3::new((k % 4) as f64 * 0.03, (k / 4) as f64 * 0.03, 0.0))
            .collect();
        let image = (0..12)
            .map(|k| Vector2::new(300.0 + k as f64, 200.0 - k as f64))
            .collect();
        ViewData { object, image }
    }

    fn check<P: RotationParameterization>(
        camera: [f64; 8],
        pose: [f64; 6],
        aspect: Option<f64>,
    ) -> Result<(), String> {
        let views = [view()];
        let cost = ReprojectionCost::<BrownConrady, P>::new(&views, aspect);
        // Same budget as camera-model's projection test: rounding eps |f| / h <= 6e-7 px per unit
        // for pixels below 5e3, truncation below 2e-6 px; 1e-5 (|n| + 1) is several times that.
        // With a fixed aspect ratio the cost ignores the fy entry, so its finite-difference column
        // is zero and must match the zero analytic column, while fx's column carries both terms.
        check_cost_function(
            &cost,
            ResidualBlockId(0),
            &[&camera, &pose],
            24,
            1e-6,
            1e-5,
            1.0,
        )
        .map_err(|e| e.to_string())
    }

    proptest! {
        #[test]
        fn view_jacobian_matches_finite_differences(
            fx in 300.0f64..1500.0, aspect in 0.8f64..1.25, cx in 200.0f64..400.0, cy in 150.0f64..300.0,
            k1 in -0.4f64..0.4, k2 in -0.3f64..0.3, p1 in -0.01f64..0.01, p2 in -0.01f64..0.01,
            ax in -0.6f64..0.6, ay in -0.6f64..0.6, az in -3.0f64..3.0,
            tx in -0.1f64..0.1, ty in -0.1f64..0.1, tz in 0.3f64..2.0,
            fixed_aspect in prop::bool::ANY, axis_angle in prop::bool::ANY,
        ) {
            let camera = [fx, fx * aspect, cx, cy, k1, k2, p1, p2];
            let r = EulerXyz::matrix(&Vector3::new(ax, ay, az));
            let ratio = fixed_aspect.then_some(1.0 / aspect);
            let result = if axis_angle {
                let w = AxisAngle::from_matrix(&r);
                check::<AxisAngle>(camera, [w.x, w.y, w.z, tx, ty, tz], ratio)
            } else {
                check::<EulerXyz>(camera, [ax, ay, az, tx, ty, tz], ratio)
            };
            prop_assert!(result.is_ok(), "{:?}", result);
        }
    }

    proptest! {
        /// The fused Gram products equal those formed from the Jacobian.
        #[test]
        fn fused_gram_matches_the_jacobian(
            fx in 300.0f64..1500.0, aspect in 0.8f64..1.25, k1 in -0.4f64..0.4, k2 in -0.3f64..0.3,
            ax in -0.6f64..0.6, ay in -0.6f64..0.6, az in -3.0f64..3.0, tz in 0.3f64..2.0,
            fixed_aspect in prop::bool::ANY,
        ) {
            let views = [view()];
            let ratio = fixed_aspect.then_some(1.0 / aspect);
            let cost = ReprojectionCost::<BrownConrady, EulerXyz>::new(&views, ratio);
            let camera = [fx, fx * aspect, 320.0, 240.0, k1, k2, 0.002, -0.001];
            let pose = [ax, ay, az, 0.01, -0.02, tz];
            let r = lm_solver::numdiff::check_gram(&cost, ResidualBlockId(0), &[&camera, &pose], 24, 1e-11);
            prop_assert!(r.is_ok(), "{:?}", r);
        }
    }

    #[test]
    fn points_behind_the_camera_are_evaluation_errors() {
        let views = [view()];
        let cost = ReprojectionCost::<BrownConrady, EulerXyz>::new(&views, None);
        let camera = [800.0, 800.0, 320.0, 240.0, 0.0, 0.0, 0.0, 0.0];
        let pose = [0.0, 0.0, 0.0, 0.0, 0.0, -1.0];
        let mut res = vec![0.0; 24];
        let err = cost
            .evaluate(ResidualBlockId(0), &[&camera, &pose], &mut res, None)
            .unwrap_err();
        assert!(err.message.contains("view 0, point 0"), "{err}");
    }
}
