//! The uncertainty of a calibration from its observations, at a stored solution: the covariance
//! of the intrinsics, and how far a point seen at a pixel may project from where the solution
//! puts it (mrcal's projection uncertainty).
//!
//! The result files keep standard deviations, not the full covariance the projection-uncertainty
//! map needs, so the report recomputes it from the observations: with `theta` the free
//! intrinsics `[fx, fy, cx, cy, distortion...]` and one pose `m_i` (rotation vector, translation)
//! per view, the Gauss-Newton normal matrix `N = [[U, W], [W^T, V]]` of the reprojection errors
//! is reduced to `theta` by the Schur complement, `S = U - sum_i W_i V_i^-1 W_i^T`, and
//! `Cov(theta) = sigma^2 S^-1` with `sigma^2 = |r|^2 / (2 N - p)`, the same estimate the
//! calibration reports. The projection uncertainty of a function `q(theta, m_1..m_n)` with
//! Jacobians `J_theta`, `J_i` is `J N^-1 J^T sigma^2`, which the blocks give without forming
//! `N^-1`: `sigma^2 (A S^-1 A^T + sum_i J_i V_i^-1 J_i^T)` with `A = J_theta - sum_i J_i V_i^-1
//! W_i^T`. Jacobians are central differences (relative step 1e-6: truncation and rounding
//! errors near 1e-10 relative, far below what a plot shows). Points rejected as outliers are
//! left out. For a stereo camera each camera is treated alone (its views' poses free), which
//! ignores what the rig's constraint adds and so slightly overstates the uncertainty.

use crate::error::ExportError;
use camera_model::{AnyCamera, AxisAngle, Pose, RotationParameterization, UndistortOptions};
use nalgebra::{DMatrix, DVector, Point3, Vector2, Vector3};

/// One view of the board: its pose and the points used.
#[derive(Debug, Clone)]
pub struct CovarianceView {
    /// Board-to-camera pose.
    pub pose: Pose,
    /// Board points.
    pub object: Vec<Point3<f64>>,
    /// Measured pixels.
    pub pixels: Vec<Vector2<f64>>,
}

/// The linearized calibration at its solution: the Gauss-Newton normal matrix reduced to the
/// free intrinsics (Schur complement) and each view's pose blocks, enough for the covariance of
/// the intrinsics and for [`Uncertainty::projection`], the projection uncertainty including the
/// poses (mrcal's diagnostic).
#[derive(Debug, Clone)]
pub struct Uncertainty {
    camera: AnyCamera,
    /// Indices of the free intrinsics in `[fx, fy, cx, cy, distortion...]`.
    free: Vec<usize>,
    /// `sigma^2 S^-1` over the free intrinsics.
    s_inv: DMatrix<f64>,
    /// `sigma^2`, pixels^2 per coordinate.
    sigma2: f64,
    /// Per view: pose (rotation vector, translation), `V_i^-1` (6x6) and `W_i` (p x 6).
    views: Vec<ViewBlocks>,
}

#[derive(Debug, Clone)]
struct ViewBlocks {
    rotation: nalgebra::Matrix3<f64>,
    rvec: Vector3<f64>,
    translation: Vector3<f64>,
    v_inv: DMatrix<f64>,
    w: DMatrix<f64>,
}

impl Uncertainty {
    /// Linearizes the calibration of `camera` from `views` (the points used, outliers left out)
    /// with the intrinsics of indices `fixed` held.
    pub fn new(
        camera: &AnyCamera,
        views: &[CovarianceView],
        fixed: &[usize],
    ) -> Result<Self, ExportError> {
        let n_all = camera.model.num_params();
        let free: Vec<usize> = (0..n_all).filter(|i| !fixed.contains(i)).collect();
        let p = free.len();
        let base = camera.params();
        let mut u = DMatrix::<f64>::zeros(p, p);
        let mut sum_sq = 0.0;
        let mut rows = 0usize;
        let mut blocks = Vec::with_capacity(views.len());
        let fail = |e: camera_model::CameraModelError| ExportError::Camera {
            what: "covariance of the intrinsics".into(),
            source: e,
        };
        for view in views {
            let rvec = AxisAngle::from_matrix(&view.pose.rotation);
            let pose6 = [
                rvec.x,
                rvec.y,
                rvec.z,
                view.pose.translation.x,
                view.pose.translation.y,
                view.pose.translation.z,
            ];
            let residuals =
                |params: &[f64], pose: &[f64; 6]| -> Result<DVector<f64>, ExportError> {
                    let cam = AnyCamera::from_params(camera.model, params).map_err(fail)?;
                    let r = AxisAngle::matrix(&Vector3::new(pose[0], pose[1], pose[2]));
                    let t = Vector3::new(pose[3], pose[4], pose[5]);
                    let mut out = DVector::zeros(2 * view.object.len());
                    for (k, (x, m)) in view.object.iter().zip(&view.pixels).enumerate() {
                        let q = cam
                            .project_camera_point(&(r * x.coords + t))
                            .map_err(fail)?;
                        out[2 * k] = q.x - m.x;
                        out[2 * k + 1] = q.y - m.y;
                    }
                    Ok(out)
                };
            let r0 = residuals(&base, &pose6)?;
            sum_sq += r0.norm_squared();
            rows += r0.len();
            let m = r0.len();
            let mut j_theta = DMatrix::<f64>::zeros(m, p);
            for (c, &i) in free.iter().enumerate() {
                let h = 1e-6 * base[i].abs().max(1e-3);
                let (mut plus, mut minus) = (base.clone(), base.clone());
                plus[i] += h;
                minus[i] -= h;
                let d = (residuals(&plus, &pose6)? - residuals(&minus, &pose6)?) / (2.0 * h);
                j_theta.set_column(c, &d);
            }
            let mut j_pose = DMatrix::<f64>::zeros(m, 6);
            for i in 0..6 {
                let h = pose_step(&pose6, i);
                let (mut plus, mut minus) = (pose6, pose6);
                plus[i] += h;
                minus[i] -= h;
                let d = (residuals(&base, &plus)? - residuals(&base, &minus)?) / (2.0 * h);
                j_pose.set_column(i, &d);
            }
            let v = j_pose.transpose() * &j_pose;
            let w = j_theta.transpose() * &j_pose;
            let v_inv = v.try_inverse().ok_or_else(|| {
                ExportError::invalid(
                    "covariance of the intrinsics",
                    "a view's pose is not determined by its points",
                )
            })?;
            u += j_theta.transpose() * &j_theta - &w * &v_inv * w.transpose();
            blocks.push(ViewBlocks {
                rotation: AxisAngle::matrix(&rvec),
                rvec,
                translation: view.pose.translation,
                v_inv,
                w,
            });
        }
        let dof = rows as i64 - (p + 6 * views.len()) as i64;
        if dof <= 0 {
            return Err(ExportError::invalid(
                "covariance of the intrinsics",
                "not more residuals than parameters",
            ));
        }
        let sigma2 = sum_sq / dof as f64;
        let s_inv = u.try_inverse().ok_or_else(|| {
            ExportError::invalid(
                "covariance of the intrinsics",
                "the intrinsics are not determined by the views",
            )
        })? * sigma2;
        Ok(Self {
            camera: camera.clone(),
            free,
            s_inv,
            sigma2,
            views: blocks,
        })
    }

    /// The estimated pixel noise `sigma` (per coordinate), pixels.
    pub fn sigma(&self) -> f64 {
        self.sigma2.sqrt()
    }

    /// Covariance of `[fx, fy, cx, cy, distortion...]` (rows and columns of fixed components
    /// zero).
    pub fn intrinsics_covariance(&self) -> DMatrix<f64> {
        let n_all = self.camera.model.num_params();
        let mut full = DMatrix::<f64>::zeros(n_all, n_all);
        for (a, &i) in self.free.iter().enumerate() {
            for (b, &k) in self.free.iter().enumerate() {
                full[(i, k)] = self.s_inv[(a, b)];
            }
        }
        full
    }

    /// The 2x2 covariance (pixels^2) of where a point seen at `pixel`, `distance` away from the
    /// camera (board units along the ray; `None`: at infinity), projects, as mrcal computes it:
    /// the point is fixed relative to the boards, not to the camera. With the solution's poses
    /// `T_i`, the point in each board's frame is `x_i = T_i^-1 p`; a perturbed solution (`theta`,
    /// `T_i'`) sees it at `p' = mean_i T_i' x_i` and projects it with `theta`, so the pose
    /// uncertainty (where the camera is relative to the boards) adds to the intrinsics'. At
    /// infinity only the rotations act. `None` if the pixel cannot be unprojected.
    pub fn projection(
        &self,
        pixel: &Vector2<f64>,
        distance: Option<f64>,
    ) -> Option<nalgebra::Matrix2<f64>> {
        let ray = self
            .camera
            .pixel_to_ray(pixel, &UndistortOptions::default())
            .ok()?
            .into_inner();
        let point = match distance {
            Some(d) if d.is_finite() && d > 0.0 => ray * d,
            _ => ray,
        };
        let at_infinity = !matches!(distance, Some(d) if d.is_finite() && d > 0.0);
        let base = self.camera.params();
        let model = self.camera.model;
        let project = |params: &[f64], s: &Vector3<f64>| -> Option<Vector2<f64>> {
            AnyCamera::from_params(model, params)
                .ok()?
                .project_camera_point(s)
                .ok()
        };
        // d q / d theta (free intrinsics), at the point.
        let p = self.free.len();
        let mut j_theta = DMatrix::<f64>::zeros(2, p);
        for (c, &i) in self.free.iter().enumerate() {
            let h = 1e-6 * base[i].abs().max(1e-3);
            let (mut plus, mut minus) = (base.clone(), base.clone());
            plus[i] += h;
            minus[i] -= h;
            let d = (project(&plus, &point)? - project(&minus, &point)?) / (2.0 * h);
            j_theta[(0, c)] = d.x;
            j_theta[(1, c)] = d.y;
        }
        // d q / d p (2x3), the projection's derivative in the camera frame.
        let scale = point.norm().max(1e-12);
        let mut dq_dp = nalgebra::Matrix2x3::<f64>::zeros();
        for k in 0..3 {
            let h = 1e-6 * scale;
            let (mut plus, mut minus) = (point, point);
            plus[k] += h;
            minus[k] -= h;
            let d = (project(&base, &plus)? - project(&base, &minus)?) / (2.0 * h);
            dq_dp.set_column(k, &d);
        }
        // Each pose's share of the mean: d p' / d m_i = (1/n) [d (R(r) x_i) / d r | I].
        let n = self.views.len() as f64;
        let mut a = j_theta;
        let mut cov = nalgebra::Matrix2::<f64>::zeros();
        for v in &self.views {
            let x = if at_infinity {
                v.rotation.transpose() * point
            } else {
                v.rotation.transpose() * (point - v.translation)
            };
            let mut j = DMatrix::<f64>::zeros(2, 6);
            for k in 0..3 {
                let h = 1e-7;
                let (mut plus, mut minus) = (v.rvec, v.rvec);
                plus[k] += h;
                minus[k] -= h;
                let d = (AxisAngle::matrix(&plus) * x - AxisAngle::matrix(&minus) * x) / (2.0 * h);
                let dq = dq_dp * d / n;
                j[(0, k)] = dq.x;
                j[(1, k)] = dq.y;
            }
            if !at_infinity {
                let dq = dq_dp / n;
                for k in 0..3 {
                    j[(0, 3 + k)] = dq[(0, k)];
                    j[(1, 3 + k)] = dq[(1, k)];
                }
            }
            let jv = &j * &v.v_inv;
            a -= &jv * v.w.transpose();
            let c = &jv * j.transpose() * self.sigma2;
            cov += nalgebra::Matrix2::new(c[(0, 0)], c[(0, 1)], c[(1, 0)], c[(1, 1)]);
        }
        let c = &a * &self.s_inv * a.transpose();
        cov += nalgebra::Matrix2::new(c[(0, 0)], c[(0, 1)], c[(1, 0)], c[(1, 1)]);
        Some(cov)
    }
}

/// Finite-difference step of pose component `i` (rotation vector, then translation).
fn pose_step(pose6: &[f64; 6], i: usize) -> f64 {
    if i < 3 {
        1e-7
    } else {
        1e-6 * pose6[i].abs().max(1e-3)
    }
}

/// Covariance of the intrinsic parameter vector `[fx, fy, cx, cy, distortion...]` (rows and
/// columns of the `fixed` components zero), from the views at the solution `camera`.
pub fn intrinsics_covariance(
    camera: &AnyCamera,
    views: &[CovarianceView],
    fixed: &[usize],
) -> Result<DMatrix<f64>, ExportError> {
    Ok(Uncertainty::new(camera, views, fixed)?.intrinsics_covariance())
}

/// The 2x2 covariance (pixels^2) of where the ray `ray` projects, from the intrinsics'
/// covariance (camera frame held fixed, so the point's distance along the ray drops out).
pub fn projection_covariance(
    camera: &AnyCamera,
    covariance: &DMatrix<f64>,
    ray: &Vector3<f64>,
) -> Option<nalgebra::Matrix2<f64>> {
    let base = camera.params();
    let n = base.len();
    let mut j = DMatrix::<f64>::zeros(2, n);
    for i in 0..n {
        if covariance[(i, i)] == 0.0 {
            continue;
        }
        let h = 1e-6 * base[i].abs().max(1e-3);
        let (mut plus, mut minus) = (base.clone(), base.clone());
        plus[i] += h;
        minus[i] -= h;
        let a = AnyCamera::from_params(camera.model, &plus)
            .ok()?
            .project_camera_point(ray)
            .ok()?;
        let b = AnyCamera::from_params(camera.model, &minus)
            .ok()?
            .project_camera_point(ray)
            .ok()?;
        let d = (a - b) / (2.0 * h);
        j[(0, i)] = d.x;
        j[(1, i)] = d.y;
    }
    let c = &j * covariance * j.transpose();
    Some(nalgebra::Matrix2::new(
        c[(0, 0)],
        c[(0, 1)],
        c[(1, 0)],
        c[(1, 1)],
    ))
}

/// The standard deviation in the worst direction, `sqrt(largest eigenvalue)`, of a 2x2
/// covariance.
pub fn worst_std(c: &nalgebra::Matrix2<f64>) -> f64 {
    let mean = 0.5 * (c[(0, 0)] + c[(1, 1)]);
    let d = (0.25 * (c[(0, 0)] - c[(1, 1)]).powi(2) + c[(0, 1)] * c[(1, 0)])
        .max(0.0)
        .sqrt();
    (mean + d).max(0.0).sqrt()
}
