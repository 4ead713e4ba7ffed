//! The fused per-view kernels: one observation's contribution to the normal equations, point by
//! point, without writing its Jacobian out.
//!
//! Per point, the x and y rows of the Jacobian have few structural non-zeros: the x row does not
//! depend on `fy, cy`, the y row not on `fx, cx`. Each row is accumulated as a compact row
//! ([`CompactGram`]: a fixed part and the `N` distortion derivatives of the lens model) and
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
//! The model part has the lens model's width as a const generic, taken from its parameter
//! Jacobian type ([`KernelWidth`]), so every model has the fast path: `N` for a plain
//! `SMatrix<f64, 2, N>`, and for a [`RowSparseJacobian`] the `M` parameters each pixel row
//! depends on (thin prism: 10 of 12), each row's derivatives scattered to its own columns. Per
//! point the rows and residual are scaled by `sqrt(w rho'(w s))` (weight `w`, robust loss `rho`
//! applied to the weighted squared residual `w s`), the first-order correction that is exact for
//! the Huber and Cauchy losses (concave in `s`, see `lm_solver::loss`).

use crate::problem::ObservationSpec;
use camera_model::{
    Camera, DifferentiablePose, LensDistortion, ParamJacobian, Projection, RowSparseJacobian,
    RowSupport,
};
use lm_solver::gram::CompactGram;
use lm_solver::{GramBlocks, Loss};
use nalgebra::{Matrix2x3, Matrix3, Matrix3x6, Point3, SMatrix, Vector3};

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
    /// An observation by the reference camera (residual block `[camera, frame pose (, focal
    /// source)]`), see [`accumulate`].
    fn reference<D, P>(
        camera: &Camera<D, P>,
        pose: &DifferentiablePose,
        view: &ViewInput<'_>,
        gram: &mut GramBlocks<'_>,
    ) -> Result<f64, usize>
    where
        D: LensDistortion<ParamJacobian = Self>,
        P: Projection;

    /// An observation by another camera (residual block `[camera, frame pose, rig (, focal
    /// source)]`), see [`accumulate`].
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

/// The one implementation of [`KernelWidth`] for a Jacobian type whose rows carry the
/// coefficients `$support` names, `$m` of them.
macro_rules! kernel_width {
    ([$($generics:tt)*] $jacobian:ty, $support:ty, $m:tt) => {
        impl<$($generics)*> KernelWidth for $jacobian {
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
                let geometry = ReferenceGeometry { pose };
                geometry_rows::<D, P, _, $support, 8, $m>(camera, &geometry, view, gram)
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
                let geometry = RigGeometry::new(pose, rig);
                geometry_rows::<D, P, _, $support, 11, $m>(camera, &geometry, view, gram)
            }
        }
    };
}

kernel_width!([const N: usize] SMatrix<f64, 2, N>, AllParams<N>, N);
kernel_width!(
    [S: RowSupport<M>, const N: usize, const M: usize] RowSparseJacobian<S, N, M>,
    S,
    M
);

/// Every parameter in both rows: the support of a plain `SMatrix<f64, 2, N>` Jacobian.
#[derive(Debug, Clone, Copy, PartialEq)]
struct AllParams<const N: usize>;

impl<const N: usize> RowSupport<N> for AllParams<N> {
    const ROWS: [[usize; N]; 2] = [first_indices::<N>(), first_indices::<N>()];
}

/// `[0, 1, ..., N - 1]`.
const fn first_indices<const N: usize>() -> [usize; N] {
    let mut indices = [0; N];
    let mut i = 0;
    while i < N {
        indices[i] = i;
        i += 1;
    }
    indices
}

/// One observation through `geometry` with rows of the `M` parameters `L` names per pixel row:
/// the unweighted least-squares case compiled without the per-point scaling.
#[inline]
fn geometry_rows<D, P, G, L, const F: usize, const M: usize>(
    camera: &Camera<D, P>,
    geometry: &G,
    view: &ViewInput<'_>,
    gram: &mut GramBlocks<'_>,
) -> Result<f64, usize>
where
    D: LensDistortion,
    P: Projection,
    G: ViewGeometry<F>,
    L: RowSupport<M>,
{
    if view.observation.weights.is_none() && gram.loss().is_trivial() {
        accumulate::<D, P, G, L, F, M, false>(camera, geometry, view, gram)
    } else {
        accumulate::<D, P, G, L, F, M, true>(camera, geometry, view, gram)
    }
}

/// `(rho(w s), sqrt(w rho'(w s)))` of point `i` (weight `w`, squared residual `s`); without
/// `SCALED` (all weights one, trivial loss) simply `(s, 1)`, so that the common case compiles
/// without the scaling.
#[inline(always)]
fn scale<const SCALED: bool>(
    obs: &ObservationSpec,
    i: usize,
    loss: Loss,
    rx: f64,
    ry: f64,
) -> (f64, f64) {
    if SCALED {
        let w = obs.weights.as_ref().map_or(1.0, |w| w[i]);
        point_scale(loss, w, rx * rx + ry * ry)
    } else {
        (rx * rx + ry * ry, 1.0)
    }
}

/// Pushes a point's x and y rows (fixed parts `fixed`, the distortion derivatives from `dd` that
/// `L` names for each row, residuals `r`), all scaled by `c`.
#[inline(always)]
fn push_rows<J: ParamJacobian, L: RowSupport<M>, const F: usize, const M: usize>(
    grams: [&mut CompactGram<F, M>; 2],
    fixed: [[f64; F]; 2],
    dd: &J,
    r: [f64; 2],
    c: f64,
) {
    for (row, (gram, fixed)) in grams.into_iter().zip(fixed).enumerate() {
        gram.push(&fixed, &distortion_row::<_, L, M>(dd, row, c), r[row] * c);
    }
}

/// The residual block's Gram matrix and gradient, zeroed, with the column count.
#[inline]
fn cleared<'g>(gram: &'g mut GramBlocks<'_>) -> (usize, &'g mut [f64], &'g mut [f64]) {
    let n = gram.cols();
    let (g, gradient) = gram.parts_mut();
    g.fill(0.0);
    gradient.fill(0.0);
    (n, g, gradient)
}

/// The distortion derivatives of one pixel row (`row` 0: x, 1: y) that `L` names, `M` of them.
#[inline(always)]
fn distortion_row<J: ParamJacobian, L: RowSupport<M>, const M: usize>(
    dd: &J,
    row: usize,
    scale: f64,
) -> [f64; M] {
    let s = dd.as_slice();
    std::array::from_fn(|k| s[2 * L::ROWS[row][k] + row] * scale)
}

/// How a view's board points reach the camera, and what the fixed part of a compact row holds:
/// the reference camera's pose, or a frame pose composed with a rig transform. `F` is the width
/// of the fixed part.
trait ViewGeometry<const F: usize> {
    /// What a point's rows need besides the projection's Jacobian.
    type Point;

    /// The camera-frame point of board point `x`, and its per-point data.
    fn transform(&self, x: &Point3<f64>) -> (Vector3<f64>, Self::Point);

    /// The fixed part of pixel row `row` (0: x, 1: y): `[d focal, 1, geometry entries]`, all
    /// scaled by `c`; `ds` is `dp/ds` of the projection (2x3).
    fn fixed_row(
        &self,
        point: &Self::Point,
        x: &Point3<f64>,
        ds: &Matrix2x3<f64>,
        row: usize,
        focal: f64,
        c: f64,
    ) -> [f64; F];

    /// Adds the sums of the x and y rows onto the residual block's Gram matrix and gradient;
    /// entry `k` of row `r`'s model part is distortion parameter `support[r][k]`.
    fn scatter<const M: usize>(
        &self,
        sums: [&CompactGram<F, M>; 2],
        view: &ViewInput<'_>,
        support: &[[usize; M]; 2],
        gram: &mut [f64],
        gradient: &mut [f64],
        n: usize,
    );
}

/// The reference camera: `s = R_f X + t_f`; fixed part `[d focal, 1, d/dpose (6)]`.
struct ReferenceGeometry<'a> {
    pose: &'a DifferentiablePose,
}

impl ViewGeometry<8> for ReferenceGeometry<'_> {
    type Point = Matrix3x6<f64>;

    #[inline(always)]
    fn transform(&self, x: &Point3<f64>) -> (Vector3<f64>, Matrix3x6<f64>) {
        self.pose.transform_with_jacobian(x)
    }

    #[inline(always)]
    fn fixed_row(
        &self,
        ds_dm: &Matrix3x6<f64>,
        _x: &Point3<f64>,
        ds: &Matrix2x3<f64>,
        row: usize,
        focal: f64,
        c: f64,
    ) -> [f64; 8] {
        let d = ds.row(row) * ds_dm;
        [
            focal * c,
            c,
            d[0] * c,
            d[1] * c,
            d[2] * c,
            d[3] * c,
            d[4] * c,
            d[5] * c,
        ]
    }

    fn scatter<const M: usize>(
        &self,
        sums: [&CompactGram<8, M>; 2],
        view: &ViewInput<'_>,
        support: &[[usize; M]; 2],
        gram: &mut [f64],
        gradient: &mut [f64],
        n: usize,
    ) {
        // At most 8 + 16 targets: a fixed array, no allocation.
        let mut targets = [None; 8 + 16];
        for (row, sums) in sums.into_iter().enumerate() {
            let t = &mut targets[..8 + M];
            t.fill(None);
            t[0] = [view.focal.x, view.focal.y][row];
            if let Some(c) = view.camera_col {
                t[1] = Some((c + 2 + row, 1.0));
                for (k, parameter) in support[row].iter().enumerate() {
                    t[8 + k] = Some((c + 4 + parameter, 1.0));
                }
            }
            if let Some(p) = view.pose_col {
                for k in 0..6 {
                    t[2 + k] = Some((p + k, 1.0));
                }
            }
            sums.scatter(t, gram, gradient, n);
        }
    }
}

/// Another camera: `q = R_f X + t_f`, `s = R_c q + t_c`; fixed part
/// `[d focal, 1, D, q x D, X x R_f^T D]` with `D = (dp/ds) R_c` (see the module documentation).
struct RigGeometry<'a> {
    pose: &'a DifferentiablePose,
    rig: &'a DifferentiablePose,
    omega_pose: Matrix3<f64>,
    omega_rig: Matrix3<f64>,
    pose_rotation_t: Matrix3<f64>,
}

impl<'a> RigGeometry<'a> {
    fn new(pose: &'a DifferentiablePose, rig: &'a DifferentiablePose) -> Self {
        Self {
            pose,
            rig,
            omega_pose: pose.body_generators(),
            omega_rig: rig.body_generators(),
            pose_rotation_t: pose.rotation.transpose(),
        }
    }
}

impl ViewGeometry<11> for RigGeometry<'_> {
    type Point = Vector3<f64>;

    #[inline(always)]
    fn transform(&self, x: &Point3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let q = self.pose.rotation * x.coords + self.pose.translation;
        (self.rig.rotation * q + self.rig.translation, q)
    }

    #[inline(always)]
    fn fixed_row(
        &self,
        q: &Vector3<f64>,
        x: &Point3<f64>,
        ds: &Matrix2x3<f64>,
        row: usize,
        focal: f64,
        c: f64,
    ) -> [f64; 11] {
        let dr: Vector3<f64> = (ds.row(row) * self.rig.rotation).transpose();
        let e = q.cross(&dr);
        let f = x.coords.cross(&(self.pose_rotation_t * dr));
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
    }

    fn scatter<const M: usize>(
        &self,
        sums: [&CompactGram<11, M>; 2],
        view: &ViewInput<'_>,
        support: &[[usize; M]; 2],
        gram: &mut [f64],
        gradient: &mut [f64],
        n: usize,
    ) {
        // At most 1 + 1 + 16 camera + 3 + 9 pose + 18 rig entries: a fixed array.
        let mut storage = [(0usize, 0usize, 0.0f64); 64];
        for (row, sums) in sums.into_iter().enumerate() {
            let mut count = 0;
            let mut push = |e: (usize, usize, f64)| {
                storage[count] = e;
                count += 1;
            };
            if let Some((col, factor)) = [view.focal.x, view.focal.y][row] {
                push((0, col, factor));
            }
            if let Some(c) = view.camera_col {
                push((1, c + 2 + row, 1.0));
                for (k, parameter) in support[row].iter().enumerate() {
                    push((11 + k, c + 4 + parameter, 1.0));
                }
            }
            for k in 0..3 {
                if let Some(p) = view.pose_col {
                    push((2 + k, p + 3 + k, 1.0));
                    for i in 0..3 {
                        push((8 + i, p + k, self.omega_pose[(i, k)]));
                    }
                }
                if let Some(c) = view.rig_col {
                    for i in 0..3 {
                        push((2 + i, c + 3 + k, self.rig.rotation[(k, i)]));
                        push((5 + i, c + k, self.omega_rig[(i, k)]));
                    }
                }
            }
            sums.scatter_map(&storage[..count], gram, gradient, n);
        }
    }
}

/// Fills `gram` with the normal-equation blocks of one observation, point by point. Returns the
/// sum over points of `rho(w s)` (`s` the squared residual in px^2), or the index (in the
/// observation) of the first point the camera cannot see. Cost `O(n)`, no allocation.
/// `SCALED = false` is the unweighted least-squares case (all weights one, trivial loss),
/// compiled without the per-point scaling.
fn accumulate<D, P, G, L, const F: usize, const M: usize, const SCALED: bool>(
    camera: &Camera<D, P>,
    geometry: &G,
    view: &ViewInput<'_>,
    gram: &mut GramBlocks<'_>,
) -> Result<f64, usize>
where
    D: LensDistortion,
    P: Projection,
    G: ViewGeometry<F>,
    L: RowSupport<M>,
{
    let loss = gram.loss();
    let obs = view.observation;
    let mut gx = CompactGram::<F, M>::new();
    let mut gy = CompactGram::<F, M>::new();
    let mut total = 0.0;
    for (i, (x, m)) in obs.object.iter().zip(&obs.pixels).enumerate() {
        let (s, point) = geometry.transform(x);
        let j = camera
            .project_camera_point_with_jacobians(&s)
            .map_err(|_| i)?;
        let (rx, ry) = (j.pixel.x - m.x, j.pixel.y - m.y);
        let (rho, c) = scale::<SCALED>(obs, i, loss, rx, ry);
        total += rho;
        let ds = &j.d_camera_point;
        push_rows::<_, L, F, M>(
            [&mut gx, &mut gy],
            [
                geometry.fixed_row(&point, x, ds, 0, j.d_intrinsics[(0, 0)], c),
                geometry.fixed_row(&point, x, ds, 1, j.d_intrinsics[(1, 1)], c),
            ],
            &j.d_distortion,
            [rx, ry],
            c,
        );
    }
    let (n, g, gradient) = cleared(gram);
    let (gx, gy) = (gx.finish(), gy.finish());
    geometry.scatter([gx, gy], view, &L::ROWS, g, gradient, n);
    Ok(total)
}
