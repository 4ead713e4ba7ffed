//! Gauss-Newton refinement of the geometric (pixel) reprojection error, and the combined
//! DLT + refinement entry point.
//!
//! `H33` is fixed to one and the eight remaining entries
//! `p = (h11, h21, h31, h12, h22, h32, h13, h23)` are optimized. With the residuals
//! `r_i = project(H(p), M_i) - m_i` and their `2 x 8` Jacobians `J_i` (see
//! [`project_with_jacobian`](crate::projection::project_with_jacobian)), each iteration solves the normal equations
//!
//! ```text
//! (sum_i J_i^T J_i) dp = -sum_i J_i^T r_i
//! ```
//!
//! accumulated point by point into fixed-size `8 x 8` and `8 x 1` arrays. The columns are
//! scaled to unit norm before the Cholesky factorization: the entries have very different
//! units (`h13` moves pixels directly, `h31` through a product of pixels and board units),
//! and the scaling removes that spread from the condition number.

use nalgebra::{Cholesky, Matrix3, Point2, SMatrix, SVector};

use crate::dlt::dlt;
use crate::error::HomographyError;

use crate::validate::{check_configuration, scale_to_unit_h33};

/// Stopping rules of the Gauss-Newton refinement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineOptions {
    /// Maximum number of accepted Gauss-Newton steps. Default `20`; the DLT start is usually
    /// so close that 2 to 5 steps suffice. `0` returns the (rescaled) initial homography.
    pub max_iterations: usize,
    /// Stop when the relative step `|D dp| / |D p|` falls below this value, where `D` holds
    /// the column norms of the Jacobian, so each entry is measured by its effect in pixels
    /// (independent of the board units). Default `1e-12`.
    pub step_tolerance: f64,
    /// Stop when the relative decrease of the sum of squared residuals,
    /// `(C_old - C_new) / C_old`, falls below this value. Default `1e-14`.
    pub cost_tolerance: f64,
}

impl Default for RefineOptions {
    fn default() -> Self {
        Self {
            max_iterations: 20,
            step_tolerance: 1e-12,
            cost_tolerance: 1e-14,
        }
    }
}

/// Why the refinement stopped. All variants come with a usable homography: the best one
/// seen, which is never worse than the initial estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RefineTermination {
    /// The relative step fell below [`RefineOptions::step_tolerance`].
    StepTolerance,
    /// The relative cost decrease fell below [`RefineOptions::cost_tolerance`]. This
    /// includes an initial cost of exactly zero, and a final step that was rejected
    /// because rounding made the cost rise, when the linearized model predicted a decrease
    /// below the tolerance or below the rounding error of the cost evaluation (the usual
    /// end on noisy data).
    CostTolerance,
    /// [`RefineOptions::max_iterations`] steps were taken.
    MaxIterations,
    /// The next Gauss-Newton step would have increased the cost although the linearized
    /// model predicted a decrease clearly above the tolerance and the rounding error (the
    /// linearization is poor, e.g. a bad starting point); the step was rejected and the
    /// previous homography kept.
    NoImprovement,
    /// The normal equations were not positive definite, so no step could be computed; the
    /// current homography is kept.
    SingularSystem,
}

/// A refined homography with its diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct HomographyEstimate {
    /// Maps plane points `(X, Y, 1)` (board units) to homogeneous pixels, scaled so that
    /// `h[(2, 2)] == 1`.
    pub h: Matrix3<f64>,
    /// RMS reprojection error in pixels, `sqrt(mean_i(dx_i^2 + dy_i^2))`, of the starting
    /// homography: the linear DLT estimate when produced by [`estimate`], the caller's
    /// `h0` when produced by [`refine`].
    pub dlt_rms: f64,
    /// RMS reprojection error in pixels of [`h`](Self::h), after refinement.
    pub rms: f64,
    /// Number of accepted Gauss-Newton steps.
    pub iterations: usize,
    /// Why the iteration stopped.
    pub termination: RefineTermination,
}

/// Refines an initial homography by Gauss-Newton on the pixel reprojection error.
///
/// `h0` may have any scale (it is divided by its `H33` first). `object` holds plane
/// coordinates in board units and `image` the measured pixels, in the convention of `h0`.
/// A step is accepted only if it does not increase the sum of squared residuals, so
/// `rms <= dlt_rms` always holds in the result.
///
/// # Errors
///
/// The input checks of [`dlt`](crate::dlt()) (count, lengths, finiteness, coincident or
/// collinear sets) and [`HomographyError::DegenerateSolution`] if `h0` is not finite, has
/// `H33 ~ 0` (see [`H33_THRESHOLD`](crate::H33_THRESHOLD)) or maps a data point to infinity.
pub fn refine(
    h0: &Matrix3<f64>,
    object: &[Point2<f64>],
    image: &[Point2<f64>],
    options: &RefineOptions,
) -> Result<HomographyEstimate, HomographyError> {
    check_configuration(object, image)?;
    refine_checked(h0, object, image, options)
}

/// [`refine`] for correspondences whose configuration has been checked (by [`dlt`]).
fn refine_checked(
    h0: &Matrix3<f64>,
    object: &[Point2<f64>],
    image: &[Point2<f64>],
    options: &RefineOptions,
) -> Result<HomographyEstimate, HomographyError> {
    let mut h = scale_to_unit_h33(h0, object)?;
    let n = object.len() as f64;

    // One pass per iteration: the candidate's cost and normal equations are formed together,
    // so an accepted step needs no second pass over the points.
    let mut current = linearize(&h, object, image);
    if !current.cost.is_finite() {
        return Err(HomographyError::DegenerateSolution {
            reason: "the initial homography maps a data point to infinity",
        });
    }
    let initial_cost = current.cost;
    let mut iterations = 0;

    let termination = loop {
        let cost = current.cost;
        if cost == 0.0 {
            break RefineTermination::CostTolerance;
        }
        if iterations >= options.max_iterations {
            break RefineTermination::MaxIterations;
        }
        let Some(step) = solve_scaled(&current.jtj, &current.jtr) else {
            break RefineTermination::SingularSystem;
        };
        let parameter_norm = h
            .iter()
            .take(8)
            .zip(step.scale.iter())
            .map(|(p, d)| (p * d).powi(2))
            .sum::<f64>()
            .sqrt();
        let relative_step = step.scaled_norm / parameter_norm;

        let mut candidate = h;
        for (k, d) in step.delta.iter().enumerate() {
            // Column-major storage: the first eight entries are exactly the parameters.
            candidate[k] += d;
        }
        let next = linearize(&candidate, object, image);
        let new_cost = next.cost;
        // An infinite cost is larger than the (finite) current one; NaN is rejected too.
        if new_cost.is_nan() || new_cost > cost {
            // Residuals of tenths of a pixel are differences of coordinates in the hundreds,
            // so the cost is only known to ~1e-13 relative. A step that was predicted to
            // gain less than that (or less than the tolerance) can be rejected by rounding
            // alone: that is convergence, not a failed step.
            break if relative_step < options.step_tolerance {
                RefineTermination::StepTolerance
            } else if step.predicted_decrease
                <= (options.cost_tolerance * cost).max(current.cost_rounding)
            {
                RefineTermination::CostTolerance
            } else {
                RefineTermination::NoImprovement
            };
        }

        let relative_decrease = (cost - new_cost) / cost;
        h = candidate;
        current = next;
        iterations += 1;

        if relative_step < options.step_tolerance {
            break RefineTermination::StepTolerance;
        }
        if relative_decrease < options.cost_tolerance {
            break RefineTermination::CostTolerance;
        }
    };

    Ok(HomographyEstimate {
        h,
        dlt_rms: (initial_cost / n).sqrt(),
        rms: (current.cost / n).sqrt(),
        iterations,
        termination,
    })
}

/// The cost and normal equations of the refinement at one homography.
struct Linearization {
    /// Sum of squared residuals (infinite if a point maps to infinity).
    cost: f64,
    jtj: SMatrix<f64, 8, 8>,
    jtr: SVector<f64, 8>,
    /// First-order bound on the rounding error of `cost`.
    cost_rounding: f64,
}

/// Sum of squared residuals, `J^T J` and `J^T r` in one pass. Each row of a point's 2x8 Jacobian
/// has five non-zeros (`x` does not depend on `h21, h22, h23`, `y` not on `h11, h12, h13`), so
/// only those products are accumulated.
fn linearize(h: &Matrix3<f64>, object: &[Point2<f64>], image: &[Point2<f64>]) -> Linearization {
    let mut jtj = SMatrix::<f64, 8, 8>::zeros();
    let mut jtr = SVector::<f64, 8>::zeros();
    let (mut cost, mut cost_rounding) = (0.0, 0.0);
    for (m_obj, m_img) in object.iter().zip(image) {
        let (big_x, big_y) = (m_obj.x, m_obj.y);
        let u = h[(0, 0)] * big_x + h[(0, 1)] * big_y + h[(0, 2)];
        let v = h[(1, 0)] * big_x + h[(1, 1)] * big_y + h[(1, 2)];
        let w = h[(2, 0)] * big_x + h[(2, 1)] * big_y + h[(2, 2)];
        let inv_w = 1.0 / w;
        let (x, y) = (u * inv_w, v * inv_w);
        let (rx, ry) = (x - m_img.x, y - m_img.y);
        let (ax, ay) = (big_x * inv_w, big_y * inv_w);
        // Columns h11 h21 h31 h12 h22 h32 h13 h23 = 0..8 (see `project_with_jacobian`).
        let rows = [
            ([0usize, 2, 3, 5, 6], [ax, -x * ax, ay, -x * ay, inv_w], rx),
            ([1, 2, 4, 5, 7], [ax, -y * ax, ay, -y * ay, inv_w], ry),
        ];
        for (columns, values, r) in rows {
            for a in 0..5 {
                jtr[columns[a]] += values[a] * r;
                for b in a..5 {
                    jtj[(columns[a], columns[b])] += values[a] * values[b];
                }
            }
        }
        cost += rx * rx + ry * ry;
        // Each residual component is off by at most ~2 eps |x_projected|, which moves r^2 by
        // 2 |r| * 2 eps |x_projected|.
        cost_rounding += rx.abs() * x.abs() + ry.abs() * y.abs();
    }
    // The upper triangle was accumulated (columns are increasing within each row pattern).
    for j in 0..8 {
        for i in j + 1..8 {
            jtj[(i, j)] = jtj[(j, i)];
        }
    }
    if !cost.is_finite() {
        cost = f64::INFINITY;
    }
    Linearization {
        cost,
        jtj,
        jtr,
        cost_rounding: 4.0 * f64::EPSILON * cost_rounding,
    }
}

/// A Gauss-Newton step with the quantities the stopping rules need.
struct Step {
    /// The update of the eight free entries.
    delta: SVector<f64, 8>,
    /// `|D delta|`, the step measured by its effect on the residuals column by column.
    scaled_norm: f64,
    /// `D = sqrt(diag(J^T J))`, the column norms of the stacked Jacobian.
    scale: SVector<f64, 8>,
    /// Cost decrease predicted by the linearized model, `|J delta|^2`.
    predicted_decrease: f64,
}

/// Solves `A delta = -b` (`A = J^T J`, `b = J^T r`) with Jacobi (column) scaling and
/// Cholesky. Returns `None` when the system is singular or the result is not finite.
fn solve_scaled(a: &SMatrix<f64, 8, 8>, b: &SVector<f64, 8>) -> Option<Step> {
    let d = a.diagonal().map(f64::sqrt);
    if !d.iter().all(|v| v.is_finite() && *v > 0.0) {
        return None;
    }
    let inv_d = d.map(|v| 1.0 / v);
    let scaled = SMatrix::<f64, 8, 8>::from_fn(|i, j| a[(i, j)] * inv_d[i] * inv_d[j]);
    let rhs = -b.component_mul(&inv_d);
    let y = Cholesky::new(scaled)?.solve(&rhs);
    let delta = y.component_mul(&inv_d);
    if !delta.iter().all(|v| v.is_finite()) {
        return None;
    }
    // For the Gauss-Newton step, |r|^2 - |r + J delta|^2 = delta^T J^T J delta = -b.delta.
    let predicted_decrease = -b.dot(&delta);
    Some(Step {
        delta,
        scaled_norm: y.norm(),
        scale: d,
        predicted_decrease,
    })
}

/// Estimates a homography: normalized DLT followed by Gauss-Newton refinement.
///
/// This is the normal entry point. `object` holds plane coordinates `(X, Y)` in board
/// units, `image` the matching pixels (in practice OpenCV's convention: `(0, 0)` is the
/// centre of the top-left pixel). The returned [`HomographyEstimate::h`] maps `(X, Y, 1)`
/// to homogeneous pixels with `H33 = 1`; `dlt_rms` and `rms` are the RMS reprojection
/// errors in pixels before and after refinement.
///
/// # Errors
///
/// Everything [`dlt`](crate::dlt()) reports; see [`HomographyError`].
pub fn estimate(
    object: &[Point2<f64>],
    image: &[Point2<f64>],
    options: &RefineOptions,
) -> Result<HomographyEstimate, HomographyError> {
    // `dlt` checks the configuration (the same checks and errors as `refine`'s).
    let h0 = dlt(object, image)?;
    refine_checked(&h0, object, image, options)
}
