//! The covariance of a camera's intrinsics from its observations, at a stored solution.
//!
//! The result files keep standard deviations, not the full covariance the projection-uncertainty
//! map needs, so the report recomputes it from the observations: with `theta` the free
//! intrinsics `[fx, fy, cx, cy, distortion...]` and one pose `m_i` (rotation vector, translation)
//! per view, the Gauss-Newton normal matrix of the reprojection errors is reduced to `theta` by
//! the Schur complement, `S = U - sum_i W_i V_i^-1 W_i^T`, and `Cov(theta) = sigma^2 S^-1` with
//! `sigma^2 = |r|^2 / (2 N - p)`, the same estimate the calibration reports. Jacobians are
//! central differences (relative step 1e-6: truncation and rounding errors near 1e-10 relative,
//! far below what a plot shows). Points rejected as outliers are left out. For a stereo camera
//! each camera is treated alone (its views' poses free), which ignores what the rig's constraint
//! adds and so slightly overstates the uncertainty.

use crate::error::ExportError;
use camera_model::{AnyCamera, AxisAngle, Pose, RotationParameterization};
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

/// Covariance of the intrinsic parameter vector `[fx, fy, cx, cy, distortion...]` (rows and
/// columns of the `fixed` components zero), from the views at the solution `camera`.
pub fn intrinsics_covariance(
    camera: &AnyCamera,
    views: &[CovarianceView],
    fixed: &[usize],
) -> Result<DMatrix<f64>, ExportError> {
    let n_all = camera.model.num_params();
    let free: Vec<usize> = (0..n_all).filter(|i| !fixed.contains(i)).collect();
    let p = free.len();
    let base = camera.params();
    let mut u = DMatrix::<f64>::zeros(p, p);
    let mut sum_sq = 0.0;
    let mut rows = 0usize;
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
        let residuals = |params: &[f64], pose: &[f64; 6]| -> Result<DVector<f64>, ExportError> {
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
            let h = if i < 3 {
                1e-7
            } else {
                1e-6 * pose6[i].abs().max(1e-3)
            };
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
        u += j_theta.transpose() * &j_theta - &w * v_inv * w.transpose();
    }
    let dof = rows as i64 - (p + 6 * views.len()) as i64;
    if dof <= 0 {
        return Err(ExportError::invalid(
            "covariance of the intrinsics",
            "not more residuals than parameters",
        ));
    }
    let sigma2 = sum_sq / dof as f64;
    let inverse = u.try_inverse().ok_or_else(|| {
        ExportError::invalid(
            "covariance of the intrinsics",
            "the intrinsics are not determined by the views",
        )
    })?;
    let mut full = DMatrix::<f64>::zeros(n_all, n_all);
    for (a, &i) in free.iter().enumerate() {
        for (b, &k) in free.iter().enumerate() {
            full[(i, k)] = sigma2 * inverse[(a, b)];
        }
    }
    Ok(full)
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
