//! The fused per-view kernels: one observation's contribution to the normal equations, point by
//! point, without writing its Jacobian out.
//!
//! Per point, the x and y rows of the Jacobian have few structural non-zeros: the x row does not
//! depend on `fy, cy`, the y row not on `fx, cx`. Each row is accumulated as a compact row
//! ([`PartitionedGram`]: a fixed part and the `N` distortion derivatives of the lens model) and
//! scattered onto the residual block's columns once per view:
//!
//! * reference camera (no rig): fixed part `[d focal, 1, d/dpose (6)]`, width 8;
//! * other cameras: fixed part `[d focal, 1, D, q x D, X x R_f^T D]`, width 11, where
//!   `D = (dp/ds) R_c` is the pixel row's derivative in the reference frame, `q = R_f X + t_f`,
//!   and the pose and rig columns follow by fixed linear maps per view through the body-frame
//!   generators of the rotation parameterization (`dR/drho_k = R [omega_k]x`):
//!   `dp/dt_f = D`, `dp/drho_f = Omega_f^T (X x R_f^T D)`, `dp/dt_c = R_c D`,
//!   `dp/drho_c = Omega_c^T (q x D)`.
//!
//! The model part has the lens model's width `N` as a const generic, taken from its parameter
//! Jacobian type `SMatrix<f64, 2, N>` ([`KernelWidth`]), so every model has the fast path. Per
//! point the rows and residual are scaled by `sqrt(w rho'(w s))` (weight `w`, robust loss `rho`
//! applied to the weighted squared residual `w s`), the first-order correction that is exact for
//! the Huber and Cauchy losses (concave in `s`, see `lm_solver::loss`).

use crate::problem::ObservationSpec;
use camera_model::{Camera, DifferentiablePose, LensDistortion, ParamJacobian, Projection};
use lm_solver::gram::PartitionedGram;
use lm_solver::{GramBlocks, Loss};
use nalgebra::{Matrix3, SMatrix, Vector3};

/// Where the focal-length entries of the x and y rows go: `(column, factor)` each, or `None`
/// for a constant block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FocalTargets {
    pub x: Option<(usize, f64)>,
    pub y: Option<(usize, f64)>,
}

/// Everything a kernel needs about one observation besides the camera and poses.
pub(crate) struct ViewInput<'a> {
    pub observation: &'a ObservationSpec,
    pub focal: FocalTargets,
    /// First column of the camera block (intrinsics and distortion), `None` if constant.
    pub camera_col: Option<usize>,
    /// First column of the frame-pose block.
    pub pose_col: Option<usize>,
    /// First column of the rig block (cameras other than the reference).
    pub rig_col: Option<usize>,
}

/// The loss's value and the row scale `sqrt(w rho'(w s))` for one point with weight `w` and
/// squared residual `s`. `None` for losses the kernels do not handle (custom losses that may be
/// convex, which need the full correction).
#[inline]
pub(crate) fn point_scale(loss: Loss, w: f64, s: f64) -> (f64, f64) {
    let ws = w * s;
    match loss {
        Loss::Trivial => (ws, w.sqrt()),
        _ => {
            let rho = loss.evaluate(ws);
            (rho[0], (w * rho[1]).sqrt())
        }
    }
}

/// True if the kernels can apply `loss` (first-order correction exact).
pub(crate) fn handles_loss(loss: Loss) -> bool {
    matches!(loss, Loss::Trivial | Loss::Huber(_) | Loss::Cauchy(_))
}

/// Dispatch to the kernels of a model with `N` coefficients, `N` read from the model's
/// parameter Jacobian type.
pub(crate) trait KernelWidth {
    /// See [`reference_view`].
    fn reference<D, P>(
        camera: &Camera<D, P>,
        pose: &DifferentiablePose,
        view: &ViewInput<'_>,
        gram: &mut GramBlocks<'_>,
    ) -> Result<f64, usize>
    where
        D: LensDistortion<ParamJacobian = Self>,
        P: Projection;

    /// See [`rig_view`].
    fn rig<D, P>(
        camera: &Camera<D, P>,
        pose: &DifferentiablePose,
        rig: &DifferentiablePose,
        view: &ViewInput<'_>,
        gram: &mut GramBlocks<'_>,
    ) -> Result<f64, usize>
    where
        D: LensDistortion<ParamJacobian = Self>,
        P: Projection;
}

impl<const N: usize> KernelWidth for SMatrix<f64, 2, N> {
    #[inline]
    fn reference<D, P>(
        camera: &Camera<D, P>,
        pose: &DifferentiablePose,
        view: &ViewInput<'_>,
        gram: &mut GramBlocks<'_>,
    ) -> Result<f64, usize>
    where
        D: LensDistortion<ParamJacobian = Self>,
        P: Projection,
    {
        if view.observation.weights.is_none() && gram.loss().is_trivial() {
            reference_view::<D, P, N, false>(camera, pose, view, gram)
        } else {
            reference_view::<D, P, N, true>(camera, pose, view, gram)
        }
    }

    #[inline]
    fn rig<D, P>(
        camera: &Camera<D, P>,
        pose: &DifferentiablePose,
        rig: &DifferentiablePose,
        view: &ViewInput<'_>,
        gram: &mut GramBlocks<'_>,
    ) -> Result<f64, usize>
    where
        D: LensDistortion<ParamJacobian = Self>,
        P: Projection,
    {
        if view.observation.weights.is_none() && gram.loss().is_trivial() {
            rig_view::<D, P, N, false>(camera, pose, rig, view, gram)
        } else {
            rig_view::<D, P, N, true>(camera, pose, rig, view, gram)
        }
    }
}

/// The distortion derivatives of one pixel row (`row` 0: x, 1: y), `N` of them.
#[inline(always)]
fn distortion_row<J: ParamJacobian, const N: usize>(dd: &J, row: usize, scale: f64) -> [f64; N] {
    let s = dd.as_slice();
    std::array::from_fn(|k| s[2 * k + row] * scale)
}

/// Fills `gram` with the normal-equation blocks of an observation by the reference camera
/// (residual block `[camera, frame pose (, focal source)]`). Returns the sum over points of
/// `rho(w s)` (`s` the squared residual in px^2), or the index (in the observation) of the
/// first point the camera cannot see. Cost `O(n)`, no allocation. `SCALED = false` is the
/// unweighted least-squares case (all weights one, trivial loss), compiled without the
/// per-point scaling.
pub(crate) fn reference_view<D, P, const N: usize, const SCALED: bool>(
    camera: &Camera<D, P>,
    pose: &DifferentiablePose,
    view: &ViewInput<'_>,
    gram: &mut GramBlocks<'_>,
) -> Result<f64, usize>
where
    D: LensDistortion<ParamJacobian = SMatrix<f64, 2, N>>,
    P: Projection,
{
    let loss = gram.loss();
    let obs = view.observation;
    let (mut gx, mut gy) = (
        PartitionedGram::<8, N>::new(),
        PartitionedGram::<8, N>::new(),
    );
    let mut total = 0.0;
    for (i, (x, m)) in obs.object.iter().zip(&obs.pixels).enumerate() {
        let (s, ds_dm) = pose.transform_with_jacobian(x);
        let j = camera
            .project_camera_point_with_jacobians(&s)
            .map_err(|_| i)?;
        let d_pose = j.d_camera_point * ds_dm;
        let (rx, ry) = (j.pixel.x - m.x, j.pixel.y - m.y);
        // Unweighted least squares (the common case) compiles without the scaling.
        let (rho, c) = if SCALED {
            let w = obs.weights.as_ref().map_or(1.0, |w| w[i]);
            point_scale(loss, w, rx * rx + ry * ry)
        } else {
            (rx * rx + ry * ry, 1.0)
        };
        total += rho;
        let fixed = |r: usize, focal: f64| {
            [
                focal * c,
                c,
                d_pose[(r, 0)] * c,
                d_pose[(r, 1)] * c,
                d_pose[(r, 2)] * c,
                d_pose[(r, 3)] * c,
                d_pose[(r, 4)] * c,
                d_pose[(r, 5)] * c,
            ]
        };
        gx.push(
            &fixed(0, j.d_intrinsics[(0, 0)]),
            &distortion_row::<_, N>(&j.d_distortion, 0, c),
            rx * c,
        );
        gy.push(
            &fixed(1, j.d_intrinsics[(1, 1)]),
            &distortion_row::<_, N>(&j.d_distortion, 1, c),
            ry * c,
        );
    }
    let n = gram.cols();
    let (g, gradient) = gram.parts_mut();
    g.fill(0.0);
    gradient.fill(0.0);
    // At most 8 + 12 targets: a fixed array, no allocation.
    let mut targets = [None; 8 + 16];
    for (row_y, sums) in [(false, gx.finish()), (true, gy.finish())] {
        let t = &mut targets[..8 + N];
        t.fill(None);
        t[0] = if row_y { view.focal.y } else { view.focal.x };
        if let Some(c) = view.camera_col {
            t[1] = Some((c + if row_y { 3 } else { 2 }, 1.0));
            for k in 0..N {
                t[8 + k] = Some((c + 4 + k, 1.0));
            }
        }
        if let Some(p) = view.pose_col {
            for k in 0..6 {
                t[2 + k] = Some((p + k, 1.0));
            }
        }
        sums.scatter(t, g, gradient, n);
    }
    Ok(total)
}

/// Fills `gram` with the normal-equation blocks of an observation by a camera other than the
/// reference (residual block `[camera, frame pose, rig (, focal source)]`); see the module
/// documentation for the compact rows. Returns as [`reference_view`].
pub(crate) fn rig_view<D, P, const N: usize, const SCALED: bool>(
    camera: &Camera<D, P>,
    pose: &DifferentiablePose,
    rig: &DifferentiablePose,
    view: &ViewInput<'_>,
    gram: &mut GramBlocks<'_>,
) -> Result<f64, usize>
where
    D: LensDistortion<ParamJacobian = SMatrix<f64, 2, N>>,
    P: Projection,
{
    let loss = gram.loss();
    let obs = view.observation;
    let (omega_pose, omega_rig) = (pose.body_generators(), rig.body_generators());
    let r_pose_t: Matrix3<f64> = pose.rotation.transpose();
    let (mut gx, mut gy) = (
        PartitionedGram::<11, N>::new(),
        PartitionedGram::<11, N>::new(),
    );
    let mut total = 0.0;
    for (i, (x, m)) in obs.object.iter().zip(&obs.pixels).enumerate() {
        let q = pose.rotation * x.coords + pose.translation;
        let s = rig.rotation * q + rig.translation;
        let j = camera
            .project_camera_point_with_jacobians(&s)
            .map_err(|_| i)?;
        let d = j.d_camera_point * rig.rotation;
        let (rx, ry) = (j.pixel.x - m.x, j.pixel.y - m.y);
        // Unweighted least squares (the common case) compiles without the scaling.
        let (rho, c) = if SCALED {
            let w = obs.weights.as_ref().map_or(1.0, |w| w[i]);
            point_scale(loss, w, rx * rx + ry * ry)
        } else {
            (rx * rx + ry * ry, 1.0)
        };
        total += rho;
        let fixed = |r: usize, focal: f64| {
            let dr = Vector3::new(d[(r, 0)], d[(r, 1)], d[(r, 2)]);
            let e = q.cross(&dr);
            let f = x.coords.cross(&(r_pose_t * dr));
            [
                focal * c,
                c,
                dr.x * c,
                dr.y * c,
                dr.z * c,
                e.x * c,
                e.y * c,
                e.z * c,
                f.x * c,
                f.y * c,
                f.z * c,
            ]
        };
        gx.push(
            &fixed(0, j.d_intrinsics[(0, 0)]),
            &distortion_row::<_, N>(&j.d_distortion, 0, c),
            rx * c,
        );
        gy.push(
            &fixed(1, j.d_intrinsics[(1, 1)]),
            &distortion_row::<_, N>(&j.d_distortion, 1, c),
            ry * c,
        );
    }
    let n = gram.cols();
    let (g, gradient) = gram.parts_mut();
    g.fill(0.0);
    gradient.fill(0.0);
    // At most 1 + 1 + 16 camera + 3 + 9 pose + 3 + 9 rig... entries: a fixed array.
    let mut storage = [(0usize, 0usize, 0.0f64); 64];
    for (row_y, sums) in [(false, gx.finish()), (true, gy.finish())] {
        let mut count = 0;
        let mut push = |e: (usize, usize, f64)| {
            storage[count] = e;
            count += 1;
        };
        if let Some((col, factor)) = if row_y { view.focal.y } else { view.focal.x } {
            push((0, col, factor));
        }
        if let Some(c) = view.camera_col {
            push((1, c + if row_y { 3 } else { 2 }, 1.0));
            for k in 0..N {
                push((11 + k, c + 4 + k, 1.0));
            }
        }
        for k in 0..3 {
            if let Some(p) = view.pose_col {
                push((2 + k, p + 3 + k, 1.0));
                for i in 0..3 {
                    push((8 + i, p + k, omega_pose[(i, k)]));
                }
            }
            if let Some(c) = view.rig_col {
                for i in 0..3 {
                    push((2 + i, c + 3 + k, rig.rotation[(k, i)]));
                    push((5 + i, c + k, omega_rig[(i, k)]));
                }
            }
        }
        sums.scatter_map(&storage[..count], g, gradient, n);
    }
    Ok(total)
}
