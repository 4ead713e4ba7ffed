//! The solver on non-camera problems whose answers are known independently.

use lm_solver::manifold::{Manifold, RotationVector, UnitQuaternion};
use lm_solver::numdiff::central_difference;
use lm_solver::test_problems::{BearingAdjustment, PoseGraph, Rng};
use lm_solver::{
    CostFunction, CovarianceError, DampingPolicy, EvaluationError, IterationRecord, JacobianBlocks,
    LinearSolverKind, Loss, ObserverAction, ProblemBuilder, ResidualBlockId, Solver, SolverError,
    SolverOptions, SolverReport, Termination,
};
use nalgebra::{DMatrix, DVector, Matrix3, Quaternion, Rotation3, UnitQuaternion as Quat, Vector3};
use std::sync::Arc;

/// Residuals of a whole problem as one vector (for finite-difference Jacobians).
fn stacked_residuals<C: CostFunction>(
    cost: &C,
    problem: &lm_solver::Problem,
    x: &[f64],
    out: &mut [f64],
) {
    let mut row = 0;
    for r in 0..problem.num_residual_blocks() {
        let id = ResidualBlockId(r);
        let params: Vec<&[f64]> = problem
            .residual_blocks_of(id)
            .map(|b| problem.block(x, b))
            .collect();
        let dim = problem.residual_dim(id);
        cost.evaluate(id, &params, &mut out[row..row + dim], None)
            .unwrap();
        row += dim;
    }
}

/// Polynomial fit: a linear least-squares problem, so the minimizer is the ordinary
/// least-squares solution, computed here independently by SVD. The covariance must equal
/// sigma^2 (A^T A)^-1.
struct Polynomial {
    t: Vec<f64>,
    y: Vec<f64>,
    degree: usize,
}

impl CostFunction for Polynomial {
    fn evaluate(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        let t = self.t[block.0];
        let mut value = 0.0;
        let mut power = 1.0;
        for c in &params[0][..=self.degree] {
            value += c * power;
            power *= t;
        }
        residuals[0] = value - self.y[block.0];
        if let Some(j) = jacobians
            && let Some(jac) = j.block_mut(0)
        {
            let mut power = 1.0;
            for v in jac.iter_mut() {
                *v = power;
                power *= t;
            }
        }
        Ok(())
    }
}

/// The reference covariance of the free parameters at `x`: `sigma^2 (J^T J)^-1` from a
/// central-difference Jacobian of all residuals (independent of the solver), with the free
/// parameters' indices. Finite differences (h = 1e-7, smooth O(1) residuals) limit the Jacobian
/// to ~1e-8 relative, so entries are good to ~1e-6 of their natural scale `sqrt(C_aa C_bb)`.
fn dense_reference_covariance<C: CostFunction>(
    cost: &C,
    problem: &lm_solver::Problem,
    x: &[f64],
) -> (DMatrix<f64>, Vec<usize>, f64) {
    let m = problem.num_residuals();
    let jac = central_difference(
        |v, out| stacked_residuals(cost, problem, v, out),
        x,
        m,
        1e-7,
    );
    let free: Vec<usize> = (0..problem.num_parameters())
        .filter(|&i| !problem.is_fixed(i))
        .collect();
    let j = DMatrix::from_fn(m, free.len(), |i, k| jac[i + free[k] * m]);
    let mut r = vec![0.0; m];
    stacked_residuals(cost, problem, x, &mut r);
    let sigma2 = r.iter().map(|v| v * v).sum::<f64>() / (m - free.len()) as f64;
    let dense = (j.transpose() * &j).try_inverse().unwrap() * sigma2;
    (dense, free, sigma2)
}

/// Checks a covariance block against the reference: entries to 1e-5 of `sqrt(C_aa C_bb)`, fixed
/// components exactly zero.
fn assert_block_matches(
    c: &DMatrix<f64>,
    offset: usize,
    dense: &DMatrix<f64>,
    free: &[usize],
    what: &str,
) {
    let position = |i: usize| free.iter().position(|&f| f == i);
    for a in 0..c.nrows() {
        for b in 0..c.ncols() {
            match (position(offset + a), position(offset + b)) {
                (Some(pa), Some(pb)) => {
                    let scale = (dense[(pa, pa)] * dense[(pb, pb)]).sqrt();
                    assert!(
                        (c[(a, b)] - dense[(pa, pb)]).abs() <= 1e-5 * scale,
                        "{what} ({a},{b}): {} vs {}",
                        c[(a, b)],
                        dense[(pa, pb)]
                    );
                }
                _ => assert_eq!(c[(a, b)], 0.0),
            }
        }
    }
}

#[test]
fn polynomial_fit_matches_the_svd_solution_and_its_covariance() {
    let mut rng = Rng::new(3);
    let degree = 3;
    let t: Vec<f64> = (0..40).map(|i| -1.0 + i as f64 / 20.0).collect();
    let y: Vec<f64> = t
        .iter()
        .map(|t| 0.5 - 1.0 * t + 0.3 * t * t + 2.0 * t * t * t + 0.05 * rng.normal())
        .collect();
    let mut builder = ProblemBuilder::new();
    let c = builder.add_parameter_block(degree + 1);
    for _ in &t {
        builder.add_residual_block(1, &[c]);
    }
    let cost = Polynomial {
        t: t.clone(),
        y: y.clone(),
        degree,
    };
    let mut solver = Solver::new(builder.build().unwrap(), SolverOptions::default()).unwrap();
    let mut x = vec![0.0; degree + 1];
    let report = solver.solve(&cost, &mut x).unwrap();
    assert!(
        report.termination.is_converged(),
        "{:?}",
        report.termination
    );

    let a = DMatrix::from_fn(t.len(), degree + 1, |i, k| t[i].powi(k as i32));
    let b = DVector::from_vec(y);
    let expected = a.clone().svd(true, true).solve(&b, 1e-14).unwrap();
    let residual = &a * &expected - &b;
    let sigma2 = residual.norm_squared() / (t.len() - degree - 1) as f64;
    let expected_cov = (a.transpose() * &a).try_inverse().unwrap() * sigma2;
    // The solver stops when the cost cannot drop by more than 1e-12 of itself, which pins the
    // coefficients down to a tiny fraction of their uncertainty: a millionth of a sigma.
    for k in 0..=degree {
        let sigma = expected_cov[(k, k)].sqrt();
        assert!(
            (x[k] - expected[k]).abs() < 1e-6 * sigma,
            "{k}: {} vs {} (sigma {sigma})",
            x[k],
            expected[k]
        );
    }
    let cov = solver.covariance(&cost, &x).unwrap();
    assert!((cov.residual_variance - sigma2).abs() < 1e-12 * sigma2);
    let block = cov.block(c).unwrap();
    assert!((block - &expected_cov).norm() < 1e-9 * expected_cov.norm());
}

/// `y = a exp(b t)`: from a start far away, both damping policies reach the exact parameters of
/// noise-free data.
struct Exponential {
    t: Vec<f64>,
    y: Vec<f64>,
}

impl CostFunction for Exponential {
    fn evaluate(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        let (a, b) = (params[0][0], params[0][1]);
        let t = self.t[block.0];
        let e = (b * t).exp();
        residuals[0] = a * e - self.y[block.0];
        if let Some(j) = jacobians
            && let Some(jac) = j.block_mut(0)
        {
            jac[0] = e;
            jac[1] = a * t * e;
        }
        Ok(())
    }
}

#[test]
fn exponential_fit_recovers_the_truth_with_both_damping_policies() {
    let t: Vec<f64> = (0..30).map(|i| i as f64 * 0.2).collect();
    let y: Vec<f64> = t.iter().map(|t| 3.0 * (-0.7 * t).exp()).collect();
    let cost = Exponential { t, y };
    for damping in [DampingPolicy::additive(), DampingPolicy::marquardt()] {
        let mut builder = ProblemBuilder::new();
        let ab = builder.add_parameter_block(2);
        for _ in 0..cost.t.len() {
            builder.add_residual_block(1, &[ab]);
        }
        let options = {
            let mut o = SolverOptions::default();
            o.damping = damping;
            o
        };
        let mut solver = Solver::new(builder.build().unwrap(), options).unwrap();
        let mut x = vec![10.0, 0.5];
        let report = solver.solve(&cost, &mut x).unwrap();
        assert!(
            report.termination.is_converged(),
            "{damping:?}: {:?}",
            report.termination
        );
        assert!(
            (x[0] - 3.0).abs() < 1e-9 && (x[1] + 0.7).abs() < 1e-9,
            "{damping:?}: {x:?}"
        );
        assert!(report.final_cost < 1e-20);
    }
}

/// A line through points with 20% gross outliers: robust losses land near the truth, the plain
/// squared loss does not.
struct Line {
    t: Vec<f64>,
    y: Vec<f64>,
}

impl CostFunction for Line {
    fn evaluate(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        let t = self.t[block.0];
        residuals[0] = params[0][0] + params[0][1] * t - self.y[block.0];
        if let Some(j) = jacobians
            && let Some(jac) = j.block_mut(0)
        {
            jac[0] = 1.0;
            jac[1] = t;
        }
        Ok(())
    }
}

#[test]
fn robust_losses_reject_outliers() {
    let mut rng = Rng::new(11);
    let t: Vec<f64> = (0..100).map(|i| i as f64 / 10.0).collect();
    let y: Vec<f64> = t
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let clean = 1.0 + 2.0 * t + 0.1 * rng.normal();
            if i % 5 == 0 {
                clean + 30.0 + 10.0 * rng.uniform()
            } else {
                clean
            }
        })
        .collect();
    let cost = Line { t, y };
    let fit = |loss: Loss| {
        let mut builder = ProblemBuilder::new();
        let p = builder.add_parameter_block(2);
        for _ in 0..cost.t.len() {
            builder.add_residual_block_with_loss(1, &[p], loss);
        }
        let mut solver = Solver::new(builder.build().unwrap(), SolverOptions::default()).unwrap();
        let mut x = vec![0.0, 0.0];
        let report = solver.solve(&cost, &mut x).unwrap();
        assert!(
            report.termination.is_converged(),
            "{loss:?}: {:?}",
            report.termination
        );
        x
    };
    let plain = fit(Loss::Trivial);
    // Outliers add ~7 on average to the intercept.
    assert!((plain[0] - 1.0).abs() > 3.0, "{plain:?}");
    for loss in [Loss::Huber(0.3), Loss::Cauchy(0.3)] {
        let x = fit(loss);
        // 80 inliers with sigma 0.1: the robust intercept is within a few hundredths of 1 (Huber
        // keeps a small bias from the outliers' bounded influence).
        assert!(
            (x[0] - 1.0).abs() < 0.3 && (x[1] - 2.0).abs() < 0.05,
            "{loss:?}: {x:?}"
        );
    }
}

/// Dennis and Schnabel's large-residual example: `r = (x + 1, l x^2 + x - 1)` with `l = -2`. The
/// minimizer is `x = 0`, but Gauss-Newton's local contraction factor there is `|l| = 2`: plain
/// Gauss-Newton is not locally convergent (its iterates are pushed away from the minimizer and
/// wander around it forever), while Levenberg-Marquardt converges.
struct LargeResidual {
    lambda: f64,
}

impl CostFunction for LargeResidual {
    fn evaluate(
        &self,
        _block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        let x = params[0][0];
        residuals[0] = x + 1.0;
        residuals[1] = self.lambda * x * x + x - 1.0;
        if let Some(j) = jacobians
            && let Some(jac) = j.block_mut(0)
        {
            jac[0] = 1.0;
            jac[1] = 2.0 * self.lambda * x + 1.0;
        }
        Ok(())
    }
}

#[test]
fn levenberg_marquardt_converges_where_gauss_newton_diverges() {
    let cost = LargeResidual { lambda: -2.0 };
    // Plain Gauss-Newton from 0.05: after 200 iterations it is still far from the minimizer.
    let mut x = 0.05f64;
    let mut late_max = 0.0f64;
    for k in 0..200 {
        let (r0, r1) = (x + 1.0, -2.0 * x * x + x - 1.0);
        let (j0, j1) = (1.0, -4.0 * x + 1.0);
        x -= (j0 * r0 + j1 * r1) / (j0 * j0 + j1 * j1);
        if k >= 190 {
            late_max = late_max.max(x.abs());
        }
    }
    assert!(
        late_max > 0.1,
        "Gauss-Newton should not converge, last iterates within {late_max}"
    );

    let mut builder = ProblemBuilder::new();
    let p = builder.add_parameter_block(1);
    builder.add_residual_block(2, &[p]);
    for damping in [DampingPolicy::additive(), DampingPolicy::marquardt()] {
        let options = {
            let mut o = SolverOptions::default();
            o.damping = damping;
            o
        };
        let mut solver = Solver::new(builder.clone().build().unwrap(), options).unwrap();
        let mut x = vec![0.05];
        let report = solver.solve(&cost, &mut x).unwrap();
        assert!(
            report.termination.is_converged(),
            "{:?}",
            report.termination
        );
        assert!(x[0].abs() < 1e-6, "{damping:?}: {x:?}");
        assert!(
            report.iterations.iter().any(|r| !r.accepted),
            "damping never engaged"
        );
    }
}

fn all_kinds() -> [LinearSolverKind; 4] {
    [
        LinearSolverKind::DenseSchur,
        LinearSolverKind::SparseSchur,
        LinearSolverKind::SparseCholesky,
        LinearSolverKind::DenseReference,
    ]
}

#[test]
fn bearing_adjustment_recovers_noise_free_truth_with_every_solver() {
    let ba = BearingAdjustment::generate(8, 25, 0.0, 5);
    let truth = ba.truth();
    for kind in all_kinds() {
        let built = ba.build(true);
        let options = {
            let mut o = SolverOptions::default();
            o.linear_solver = kind;
            o.chunk_work = 40;
            o
        };
        let mut solver = Solver::new(built.problem, options).unwrap();
        assert_eq!(solver.linear_solver(), kind);
        let mut x = ba.perturbed(0.3, 9);
        let report = solver.solve(&ba, &mut x).unwrap();
        assert!(
            report.termination.is_converged(),
            "{kind:?}: {:?}",
            report.termination
        );
        let err = max_abs_difference(&x, &truth);
        assert!(err < 1e-8, "{kind:?}: max error {err}");
    }
}

#[test]
fn noisy_bearing_adjustment_covariance_matches_the_dense_inverse() {
    let ba = BearingAdjustment::generate(6, 12, 1e-3, 21);
    let built = ba.build(true);
    let problem = built.problem.clone();
    let mut solver = Solver::new(built.problem, SolverOptions::default()).unwrap();
    let mut x = ba.perturbed(0.1, 2);
    let report = solver.solve(&ba, &mut x).unwrap();
    assert!(report.termination.is_converged());
    let cov = solver.covariance(&ba, &x).unwrap();

    // Independent check: finite-difference Jacobian of all residuals, free columns only.
    let (dense, free, sigma2) = dense_reference_covariance(&ba, &problem, &x);
    assert!((cov.residual_variance - sigma2).abs() < 1e-9 * sigma2);
    for &block in &built.blocks {
        let Some(c) = cov.block(block) else { continue };
        assert_block_matches(
            &c,
            problem.offset(block),
            &dense,
            &free,
            &format!("{block:?}"),
        );
    }
    // The standard deviations of a landmark are positive, those of the fixed gauge zero.
    assert!(
        cov.standard_deviations(built.blocks[10])
            .iter()
            .all(|&s| s > 0.0)
    );
    assert_eq!(cov.standard_deviations(built.blocks[0]), vec![0.0; 3]);
    assert_eq!(cov.standard_deviations(built.blocks[1])[0], 0.0);
}

#[test]
fn unfixed_gauge_is_reported_as_rank_deficient() {
    let ba = BearingAdjustment::generate(5, 10, 1e-3, 4);
    let mut builder = ProblemBuilder::new();
    let cams: Vec<_> = ba
        .cameras
        .iter()
        .map(|_| builder.add_parameter_block(3))
        .collect();
    let lms: Vec<_> = ba
        .landmarks
        .iter()
        .map(|_| {
            let id = builder.add_parameter_block(2);
            builder.set_eliminated(id, true);
            id
        })
        .collect();
    for &(c, l, _) in &ba.observations {
        builder.add_residual_block(1, &[cams[c], lms[l]]);
    }
    let mut solver = Solver::new(builder.build().unwrap(), SolverOptions::default()).unwrap();
    let x = ba.truth();
    match solver.covariance(&ba, &x) {
        // Translation (2), rotation (1) and scale (1) are unobservable: rank = 15 - 4.
        Err(CovarianceError::RankDeficient {
            rank,
            dimension,
            weakest,
        }) => {
            assert_eq!(dimension, 15);
            assert_eq!(rank, 11);
            // The weakest direction is a gauge motion: it moves cameras.
            assert!(!weakest.is_empty());
            assert!(weakest.iter().all(|(b, _)| b.0 < cams.len()));
        }
        other => panic!("expected a rank deficiency, got {other:?}"),
    }
}

/// An undetermined eliminated block that is not the first of its chunk is named itself: the
/// message of a calibration names this view, not the first view of its chunk of ~100.
#[test]
fn a_singular_eliminated_block_is_named_itself() {
    let ba = BearingAdjustment::generate(5, 10, 1e-3, 4);
    let unseen = 6;
    let mut builder = ProblemBuilder::new();
    let mut blocks: Vec<_> = ba
        .cameras
        .iter()
        .map(|_| builder.add_parameter_block(3))
        .collect();
    for _ in &ba.landmarks {
        let id = builder.add_parameter_block(2);
        builder.set_eliminated(id, true);
        blocks.push(id);
    }
    builder.set_constant(blocks[0], true);
    builder.set_fixed_components(blocks[1], &[0]);
    let nc = ba.cameras.len();
    // Landmark `unseen` is observed by one camera only: one bearing does not locate it.
    for &(c, l, _) in &ba.observations {
        if l != unseen || c == 2 {
            builder.add_residual_block(1, &[blocks[c], blocks[nc + l]]);
        }
    }
    let problem = builder.build().unwrap();
    let mut solver = Solver::new(problem, SolverOptions::default()).unwrap();
    assert_eq!(solver.num_chunks(), 1, "all landmarks in one chunk");
    match solver.covariance(&ba, &ba.truth()) {
        Err(CovarianceError::SingularEliminatedBlock { block }) => {
            assert_eq!(block, blocks[nc + unseen].0);
        }
        other => panic!("expected a singular eliminated block, got {other:?}"),
    }
}

#[test]
fn pose_graph_recovers_truth_and_solves_noisy_graphs() {
    let graph = PoseGraph::generate(30, 10, 0.0, 8);
    for kind in [
        LinearSolverKind::SparseCholesky,
        LinearSolverKind::DenseSchur,
    ] {
        let built = graph.build();
        let options = {
            let mut o = SolverOptions::default();
            o.linear_solver = kind;
            o
        };
        let mut solver = Solver::new(built.problem, options).unwrap();
        let mut rng = Rng::new(1);
        let truth = graph.truth();
        let mut x: Vec<f64> = truth
            .iter()
            .enumerate()
            .map(|(i, v)| if i < 3 { *v } else { v + rng.range(-0.2, 0.2) })
            .collect();
        let report = solver.solve(&graph, &mut x).unwrap();
        assert!(
            report.termination.is_converged(),
            "{:?}",
            report.termination
        );
        let err = max_abs_difference(&x, &truth);
        assert!(err < 1e-8, "{kind:?}: {err}");
    }
    let noisy = PoseGraph::generate(50, 15, 0.01, 3);
    let built = noisy.build();
    let mut solver = Solver::new(built.problem, SolverOptions::default()).unwrap();
    let mut x = noisy.truth();
    let report = solver.solve(&noisy, &mut x).unwrap();
    assert!(report.termination.is_converged());
    assert!(report.final_cost < report.initial_cost);
    // At the minimum of a noisy graph the cost is about half the residual count times sigma^2.
    let expected = 0.5 * (3 * noisy.edges.len() - 3 * 49) as f64 * 1e-4;
    assert!(report.final_cost > 0.3 * expected && report.final_cost < 2.0 * expected);
}

#[test]
fn results_are_identical_for_any_thread_count() {
    let ba = BearingAdjustment::generate(20, 200, 1e-3, 13);
    let run = |threads: usize| {
        let built = ba.build(true);
        let options = {
            let mut o = SolverOptions::default();
            o.num_threads = threads;
            o.chunk_work = 100;
            o
        };
        let mut solver = Solver::new(built.problem, options).unwrap();
        assert!(solver.num_chunks() > 4);
        let mut x = ba.perturbed(0.2, 3);
        let report = solver.solve(&ba, &mut x).unwrap();
        (x, report.final_cost, report.iterations.len())
    };
    let (x1, c1, n1) = run(1);
    for threads in [2, 3] {
        let (x, c, n) = run(threads);
        assert_eq!(n, n1);
        assert_eq!(c.to_bits(), c1.to_bits());
        assert!(x.iter().zip(&x1).all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}

/// A cost that fails (like a point behind a camera) beyond `x = 3`. Its residual `tanh(x - 2)`
/// makes the Gauss-Newton step from `x = 0.5` overshoot to about 5.5.
struct Guarded;

impl CostFunction for Guarded {
    fn evaluate(
        &self,
        _block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        let x = params[0][0];
        if x > 3.0 {
            return Err(EvaluationError::new("x beyond 3"));
        }
        let t = (x - 2.0).tanh();
        residuals[0] = t;
        if let Some(j) = jacobians
            && let Some(jac) = j.block_mut(0)
        {
            jac[0] = 1.0 - t * t;
        }
        Ok(())
    }
}

#[test]
fn evaluation_failures_error_at_the_start_and_reject_trial_steps() {
    let mut builder = ProblemBuilder::new();
    let p = builder.add_parameter_block(1);
    builder.add_residual_block(1, &[p]);
    let problem = builder.build().unwrap();
    let mut solver = Solver::new(problem, SolverOptions::default()).unwrap();
    let err = solver.solve(&Guarded, &mut [3.5]).unwrap_err();
    assert!(
        matches!(err, SolverError::InitialEvaluation { residual: 0, .. }),
        "{err:?}"
    );
    let mut x = [0.5];
    let report = solver.solve(&Guarded, &mut x).unwrap();
    assert!(
        report.termination.is_converged(),
        "{:?}",
        report.termination
    );
    assert!((x[0] - 2.0).abs() < 1e-8);
    assert!(
        report
            .iterations
            .iter()
            .any(|r| !r.accepted && r.trial_cost.is_infinite())
    );
    assert!(solver.solve(&Guarded, &mut [f64::NAN]).is_err());
    assert!(matches!(
        solver.solve(&Guarded, &mut [1.0, 2.0]),
        Err(SolverError::ParameterLength {
            expected: 1,
            found: 2
        })
    ));
}

/// Robust losses without a finite, positive scale and solver options out of range are typed
/// errors naming the residual block or option (`Huber(0.0)` "converged" at the start, and a
/// NaN scale was blamed on the cost function as a non-finite residual).
#[test]
fn invalid_losses_and_options_are_refused() {
    for loss in [Loss::Huber(0.0), Loss::Huber(-1.0), Loss::Cauchy(f64::NAN)] {
        let mut builder = ProblemBuilder::new();
        let p = builder.add_parameter_block(1);
        builder.add_residual_block(1, &[p]);
        builder.add_residual_block_with_loss(1, &[p], loss);
        let err = builder.build().unwrap_err();
        assert!(err.to_string().starts_with("residual block 1: "), "{err}");
    }
    let problem = || {
        let mut builder = ProblemBuilder::new();
        let p = builder.add_parameter_block(1);
        builder.add_residual_block_with_loss(1, &[p], Loss::Huber(1.0));
        builder.build().unwrap()
    };
    for (what, change) in [
        (
            "gradient_tolerance",
            (|o: &mut SolverOptions| o.gradient_tolerance = f64::NAN) as fn(&mut SolverOptions),
        ),
        ("function_tolerance", |o| o.function_tolerance = -1.0),
        ("min_lambda", |o| o.min_lambda = 1e17),
        ("min_lambda", |o| o.min_lambda = 0.0),
    ] {
        let mut options = SolverOptions::default();
        change(&mut options);
        match Solver::new(problem(), options) {
            Err(SolverError::InvalidOption(message)) => {
                assert!(message.contains(what), "{message}")
            }
            other => panic!("{what}: {:?}", other.map(|_| ())),
        }
    }
    assert!(Solver::new(problem(), SolverOptions::default()).is_ok());
}

#[test]
fn termination_reasons_are_reported() {
    let ba = BearingAdjustment::generate(5, 10, 1e-3, 4);
    let built = ba.build(true);
    let options = {
        let mut o = SolverOptions::default();
        o.max_iterations = 1;
        o
    };
    let mut solver = Solver::new(built.problem, options).unwrap();
    let mut x = ba.perturbed(0.3, 1);
    let report = solver.solve(&ba, &mut x).unwrap();
    assert_eq!(report.termination, Termination::MaxIterations);
    assert_eq!(report.iterations.len(), 1);
    assert!(!report.termination.is_converged());

    // Noise-free data at the truth: the gradient is zero.
    let exact = BearingAdjustment::generate(5, 10, 0.0, 4);
    let built = exact.build(true);
    let mut solver = Solver::new(built.problem, SolverOptions::default()).unwrap();
    let mut x = exact.truth();
    let report = solver.solve(&exact, &mut x).unwrap();
    assert_eq!(report.termination, Termination::GradientTolerance);
    assert!(report.iterations.is_empty());

    // The observer sees every attempt; evaluation counts follow the linearization mode.
    for eager in [true, false] {
        let built = ba.build(true);
        let options = {
            let mut o = SolverOptions::default();
            o.eager_linearization = eager;
            o
        };
        let mut solver = Solver::new(built.problem, options).unwrap();
        let mut x = ba.perturbed(0.3, 1);
        let mut seen = 0;
        let report = solver
            .solve_with_observer(&ba, &mut x, |_: &IterationRecord| {
                seen += 1;
                ObserverAction::Continue
            })
            .unwrap();
        assert_eq!(seen, report.iterations.len());
        assert!(report.termination.is_converged());
        let trials = report
            .iterations
            .iter()
            .filter(|r| r.trial_cost.is_finite())
            .count();
        if eager {
            assert_eq!(report.jacobian_evaluations, 1 + trials);
            assert_eq!(report.residual_evaluations, 0);
        } else {
            assert_eq!(report.jacobian_evaluations, 1 + report.accepted_steps);
            assert_eq!(report.residual_evaluations, trials);
        }
    }
}

/// The step attempts of `report` whose trial point was evaluated, after checking that each was
/// evaluated once, with or without its Jacobian (an accepted trial evaluated without one is
/// linearized afterwards, and the start is linearized too).
fn evaluated_trials(report: &SolverReport) -> usize {
    let trials = report
        .iterations
        .iter()
        .filter(|r| r.trial_cost.is_finite())
        .count();
    assert!(report.jacobian_evaluations + report.residual_evaluations > trials);
    trials
}

/// Two solves took the same steps: as many iterations, the same final cost and parameters, to
/// the bit.
fn assert_same_steps(a: (&[f64], &SolverReport), b: (&[f64], &SolverReport), what: &str) {
    assert_eq!(a.1.iterations.len(), b.1.iterations.len(), "{what}");
    assert_eq!(a.1.final_cost.to_bits(), b.1.final_cost.to_bits(), "{what}");
    assert!(
        a.0.iter().zip(b.0).all(|(x, y)| x.to_bits() == y.to_bits()),
        "{what}"
    );
}

/// Eager and lazy linearization take the same steps: the same minimum, the same iterations.
#[test]
fn eager_and_lazy_linearization_agree() {
    let ba = BearingAdjustment::generate(10, 60, 1e-3, 17);
    let run = |eager: bool| {
        let built = ba.build(true);
        let options = {
            let mut o = SolverOptions::default();
            o.eager_linearization = eager;
            o
        };
        let mut solver = Solver::new(built.problem, options).unwrap();
        let mut x = ba.perturbed(0.4, 5);
        let report = solver.solve(&ba, &mut x).unwrap();
        let cov = solver.covariance(&ba, &x).unwrap();
        (x, report, cov.standard_deviations(built.blocks[12]))
    };
    let (x_eager, eager, std_eager) = run(true);
    let (x_lazy, lazy, std_lazy) = run(false);
    assert_same_steps((&x_eager, &eager), (&x_lazy, &lazy), "eager and lazy");
    // The covariance reuses the solver's last linearization; it equals a fresh one.
    assert_eq!(std_eager, std_lazy);
}

/// The largest component-wise distance between two parameter vectors.
fn max_abs_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}

/// A robust loss applied per group inside one residual block is the same problem as one residual
/// block per group with that loss: the same minimum.
#[test]
fn grouped_losses_equal_one_block_per_group() {
    let mut rng = Rng::new(12);
    let t: Vec<f64> = (0..60).map(|i| i as f64 / 6.0).collect();
    let y: Vec<f64> = t
        .iter()
        .enumerate()
        .map(|(i, t)| 1.0 + 2.0 * t + 0.1 * rng.normal() + if i % 7 == 0 { 20.0 } else { 0.0 })
        .collect();
    struct Stacked(Line);
    impl CostFunction for Stacked {
        fn evaluate(
            &self,
            _block: ResidualBlockId,
            params: &[&[f64]],
            residuals: &mut [f64],
            jacobians: Option<&mut JacobianBlocks<'_>>,
        ) -> Result<(), EvaluationError> {
            let (a, b) = (params[0][0], params[0][1]);
            let n = self.0.t.len();
            for (i, (t, y)) in self.0.t.iter().zip(&self.0.y).enumerate() {
                residuals[i] = a + b * t - y;
            }
            if let Some(j) = jacobians
                && let Some(jac) = j.block_mut(0)
            {
                for (i, t) in self.0.t.iter().enumerate() {
                    jac[i] = 1.0;
                    jac[n + i] = *t;
                }
            }
            Ok(())
        }
    }
    let line = Line {
        t: t.clone(),
        y: y.clone(),
    };
    for loss in [Loss::Huber(0.3), Loss::Cauchy(0.3)] {
        let mut separate = ProblemBuilder::new();
        let p = separate.add_parameter_block(2);
        for _ in 0..t.len() {
            separate.add_residual_block_with_loss(1, &[p], loss);
        }
        let mut solver = Solver::new(separate.build().unwrap(), SolverOptions::default()).unwrap();
        let mut a = vec![0.0, 0.0];
        let ra = solver.solve(&line, &mut a).unwrap();
        let mut grouped = ProblemBuilder::new();
        let p = grouped.add_parameter_block(2);
        grouped.add_residual_block_with_grouped_loss(t.len(), &[p], loss, 1);
        let mut solver = Solver::new(grouped.build().unwrap(), SolverOptions::default()).unwrap();
        let mut b = vec![0.0, 0.0];
        let stacked = Stacked(Line {
            t: t.clone(),
            y: y.clone(),
        });
        let rb = solver.solve(&stacked, &mut b).unwrap();
        assert!(ra.termination.is_converged() && rb.termination.is_converged());
        assert!((ra.final_cost - rb.final_cost).abs() <= 1e-10 * ra.final_cost);
        assert!(
            max_abs_difference(&a, &b) < 1e-7,
            "{loss:?}: {a:?} vs {b:?}"
        );
        assert!(
            (b[0] - 1.0).abs() < 0.1 && (b[1] - 2.0).abs() < 0.02,
            "{b:?}"
        );
    }
    // A group size that does not divide the block is refused.
    let mut bad = ProblemBuilder::new();
    let p = bad.add_parameter_block(2);
    bad.add_residual_block_with_grouped_loss(5, &[p], Loss::Huber(1.0), 2);
    assert!(matches!(
        bad.build(),
        Err(lm_solver::ProblemError::LossGroup { group: 2, .. })
    ));
}

/// An observer can end the solve; the report says so and `x` holds the last accepted point.
#[test]
fn an_observer_can_stop_the_solve() {
    let ba = BearingAdjustment::generate(5, 10, 1e-3, 4);
    let built = ba.build(true);
    let mut solver = Solver::new(built.problem, SolverOptions::default()).unwrap();
    let mut x = ba.perturbed(0.3, 1);
    let start = x.clone();
    let report = solver
        .solve_with_observer(&ba, &mut x, |r: &IterationRecord| {
            if r.iteration >= 2 {
                ObserverAction::Stop
            } else {
                ObserverAction::Continue
            }
        })
        .unwrap();
    assert_eq!(report.termination, Termination::StoppedByObserver);
    assert_eq!(report.iterations.len(), 2);
    assert!(!report.termination.is_converged());
    assert!(report.final_cost < report.initial_cost);
    assert_ne!(x, start);
}

/// Rotation fit: find `R` with `R a_i ~ b_i`. The answer is known in closed form (the orthogonal
/// Procrustes solution, `R = U diag(1, 1, det) V^T` of `sum b a^T`). Solved on the rotation
/// manifold, stored as a rotation vector or a unit quaternion; the Jacobian is taken in the
/// tangent space, `d (R exp(d) a) / d d = -R [a]x`.
struct RotationFit {
    a: Vec<Vector3<f64>>,
    b: Vec<Vector3<f64>>,
    quaternion: bool,
}

impl RotationFit {
    fn rotation(&self, p: &[f64]) -> Matrix3<f64> {
        if self.quaternion {
            *Quat::from_quaternion(Quaternion::new(p[0], p[1], p[2], p[3]))
                .to_rotation_matrix()
                .matrix()
        } else {
            *Rotation3::from_scaled_axis(Vector3::new(p[0], p[1], p[2])).matrix()
        }
    }
}

impl CostFunction for RotationFit {
    fn evaluate(
        &self,
        block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        let r = self.rotation(params[0]);
        let (a, b) = (self.a[block.0], self.b[block.0]);
        let e = r * a - b;
        residuals.copy_from_slice(e.as_slice());
        if let Some(j) = jacobians
            && let Some(jac) = j.block_mut(0)
        {
            let d = -r * a.cross_matrix();
            jac.copy_from_slice(d.as_slice());
        }
        Ok(())
    }
}

#[test]
fn rotations_are_solved_on_the_manifold() {
    let mut rng = Rng::new(31);
    // Rotations of up to pi, including one within 1e-3 rad of pi, where an additive update of a
    // rotation vector is singular.
    let truths = [
        Vector3::new(0.3, -0.2, 0.5),
        Vector3::new(-1.9, 1.1, 0.4),
        Vector3::new(0.0, 0.0, std::f64::consts::PI - 1e-3),
    ];
    for (k, w) in truths.iter().enumerate() {
        let truth = Rotation3::from_scaled_axis(*w);
        let a: Vec<Vector3<f64>> = (0..30)
            .map(|_| Vector3::new(rng.normal(), rng.normal(), rng.normal()))
            .collect();
        let b: Vec<Vector3<f64>> = a
            .iter()
            .map(|v| truth * v + 0.01 * Vector3::new(rng.normal(), rng.normal(), rng.normal()))
            .collect();
        // Closed form.
        let m: Matrix3<f64> = a.iter().zip(&b).map(|(a, b)| b * a.transpose()).sum();
        let svd = m.svd(true, true);
        let (u, vt) = (svd.u.unwrap(), svd.v_t.unwrap());
        let det = (u * vt).determinant().signum();
        let procrustes = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, det)) * vt;
        for quaternion in [false, true] {
            let fit = RotationFit {
                a: a.clone(),
                b: b.clone(),
                quaternion,
            };
            let manifold: Arc<dyn Manifold> = if quaternion {
                Arc::new(UnitQuaternion)
            } else {
                Arc::new(RotationVector::rotation())
            };
            let mut builder = ProblemBuilder::new();
            let p = builder.add_parameter_block(manifold.ambient_dim());
            builder.set_manifold(p, manifold.clone());
            for _ in 0..a.len() {
                builder.add_residual_block(3, &[p]);
            }
            let problem = builder.build().unwrap();
            assert_eq!(problem.num_tangent_parameters(), 3);
            // Tangent Jacobian against finite differences through the manifold.
            let start = if quaternion {
                vec![1.0, 0.0, 0.0, 0.0]
            } else {
                vec![0.1, 0.2, -0.1]
            };
            let mut jac = vec![0.0; 9];
            let mut res = vec![0.0; 3];
            let numeric = central_difference(
                |d, out| {
                    let mut moved = vec![0.0; start.len()];
                    manifold.plus(&start, d, &mut moved);
                    fit.evaluate(ResidualBlockId(0), &[&moved], out, None)
                        .unwrap();
                },
                &[0.0; 3],
                3,
                1e-6,
            );
            {
                let mut blocks = jacobian_blocks(&mut jac, 3);
                fit.evaluate(ResidualBlockId(0), &[&start], &mut res, Some(&mut blocks))
                    .unwrap();
            }
            assert!(
                max_abs_difference(&jac, &numeric) < 1e-8,
                "{jac:?} vs {numeric:?}"
            );

            let mut solver = Solver::new(problem, SolverOptions::default()).unwrap();
            let mut x = start.clone();
            let report = solver.solve(&fit, &mut x).unwrap();
            assert!(
                report.termination.is_converged(),
                "{k}: {}",
                report.termination
            );
            let found = fit.rotation(&x);
            assert!(
                (found - procrustes).norm() < 1e-8,
                "truth {k}, quaternion {quaternion}: {}",
                (found - procrustes).norm()
            );
            if quaternion {
                let norm = x.iter().map(|v| v * v).sum::<f64>().sqrt();
                assert!((norm - 1.0).abs() < 1e-12);
            }
            // The covariance lives in the tangent space: 3 x 3.
            let cov = solver.covariance(&fit, &x).unwrap();
            assert_eq!(cov.block(p).unwrap().shape(), (3, 3));
        }
    }
}

fn jacobian_blocks(buffer: &mut [f64], rows: usize) -> JacobianBlocks<'_> {
    JacobianBlocks::new(buffer, rows, &[(0, 3)])
}

/// Beyond the dense limit, the covariance of a few blocks comes from a sparse factorization of
/// the reduced system and a few solves; it equals the inverse of the full `J^T J`.
#[test]
fn selected_covariance_of_a_large_sparse_problem_matches_the_dense_inverse() {
    // 200 cameras x 3 = 600 reduced parameters (beyond the dense limit of 512).
    let ba = BearingAdjustment::generate(200, 8, 1e-3, 5);
    let built = ba.build(true);
    let problem = built.problem.clone();
    assert!(problem.reduced_dim() > lm_solver::covariance::DENSE_COVARIANCE_LIMIT);
    let options = {
        let mut o = SolverOptions::default();
        o.linear_solver = LinearSolverKind::SparseSchur;
        o
    };
    let mut solver = Solver::new(built.problem, options).unwrap();
    let mut x = ba.perturbed(0.05, 3);
    let report = solver.solve(&ba, &mut x).unwrap();
    assert!(report.termination.is_converged(), "{}", report.termination);
    let wanted = [
        built.blocks[1],
        built.blocks[57],
        built.blocks[199],
        built.blocks[203],
    ];
    // Blocks that were not requested (nor needed) are not computed.
    let cameras_only = solver.covariance_of(&ba, &x, &wanted[..3]).unwrap();
    assert!(cameras_only.block(built.blocks[100]).is_none());
    assert!(cameras_only.block(built.blocks[57]).is_some());
    let cov = solver.covariance_of(&ba, &x, &wanted).unwrap();

    let (dense, free, _) = dense_reference_covariance(&ba, &problem, &x);
    let position = |i: usize| free.iter().position(|&f| f == i);
    for &block in &wanted {
        let c = cov.block(block).unwrap();
        assert_block_matches(
            &c,
            problem.offset(block),
            &dense,
            &free,
            &format!("{block:?}"),
        );
    }
    // Cross-covariance of two requested cameras.
    let cross = cov.cross(built.blocks[57], built.blocks[199]).unwrap();
    let (pa, pb) = (
        position(problem.offset(built.blocks[57])).unwrap(),
        position(problem.offset(built.blocks[199])).unwrap(),
    );
    let scale = (dense[(pa, pa)] * dense[(pb, pb)]).sqrt();
    assert!((cross[(0, 0)] - dense[(pa, pb)]).abs() <= 1e-5 * scale);
}

/// A trial whose rejection is predicted (its `lambda` at or below the last rejected one, or,
/// under Marquardt's policy, right after a rejection) is evaluated for its cost alone even in
/// eager mode; the iterates are those of the lazy mode, bit for bit, and fewer Jacobians are
/// evaluated than trials.
#[test]
fn predicted_rejections_skip_the_linearization() {
    // Starts this far from the truth make every policy reject steps.
    let (ba, scale) = (BearingAdjustment::generate(8, 40, 1e-3, 23), 3.0);
    let mut predicted_somewhere = [false; 3];
    for (p, damping) in [
        DampingPolicy::additive(),
        DampingPolicy::marquardt(),
        DampingPolicy::hybrid(),
    ]
    .into_iter()
    .enumerate()
    {
        for seed in 0..6 {
            let run = |eager: bool| {
                let built = ba.build(true);
                let mut o = SolverOptions::default();
                o.eager_linearization = eager;
                o.damping = damping;
                let mut solver = Solver::new(built.problem, o).unwrap();
                let mut x = ba.perturbed(scale, seed);
                let report = solver.solve(&ba, &mut x).unwrap();
                (x, report)
            };
            let (x_eager, eager) = run(true);
            let (x_lazy, lazy) = run(false);
            assert_same_steps(
                (&x_eager, &eager),
                (&x_lazy, &lazy),
                &format!("{damping:?}"),
            );
            let trials = evaluated_trials(&eager);
            assert!(eager.jacobian_evaluations <= 1 + trials);
            let rejected = trials - eager.accepted_steps;
            if eager.residual_evaluations > 0 {
                predicted_somewhere[p] = true;
                assert!(rejected > 0, "a prediction without any rejection");
                assert!(eager.jacobian_evaluations < 1 + trials);
            }
        }
    }
    assert_eq!(predicted_somewhere, [true; 3], "no prediction exercised");
}

/// The damping search (`SolverOptions::damping_search`) reaches the same minimum as Marquardt's
/// policy alone, with fewer linearizations when the damping starts far too high (each
/// well-predicted step then lowers `lambda` by only 3x), and records each of its trials as a
/// step attempt evaluated for its cost alone.
#[test]
fn damping_search_reaches_the_same_minimum_with_fewer_linearizations() {
    let ba = BearingAdjustment::generate(8, 40, 1e-3, 5);
    let mut fewer = 0;
    for seed in 0..4 {
        let run = |search: usize| {
            let built = ba.build(true);
            let mut o = SolverOptions::default();
            o.damping = DampingPolicy::Marquardt {
                initial: 1e2,
                min_diagonal: 1e-6,
                max_diagonal: 1e32,
                min_gain_ratio: 1e-3,
            };
            o.damping_search = search;
            let mut solver = Solver::new(built.problem, o).unwrap();
            let mut x = ba.perturbed(0.3, seed);
            let report = solver.solve(&ba, &mut x).unwrap();
            (x, report)
        };
        let (x_plain, plain) = run(0);
        let (x_search, search) = run(3);
        assert!(plain.termination.is_converged() && search.termination.is_converged());
        let relative = (search.final_cost - plain.final_cost).abs() / plain.final_cost;
        assert!(relative < 1e-10, "seed {seed}: cost {relative:e} apart");
        assert!(
            max_abs_difference(&x_plain, &x_search) < 1e-6,
            "seed {seed}"
        );
        if search.jacobian_evaluations < plain.jacobian_evaluations {
            fewer += 1;
        }
        assert!(
            search.jacobian_evaluations <= plain.jacobian_evaluations,
            "seed {seed}: {} vs {}",
            search.jacobian_evaluations,
            plain.jacobian_evaluations
        );
        // Every step attempt is recorded, search trials included.
        evaluated_trials(&search);
        assert_eq!(search.linear_solves, search.iterations.len());
    }
    assert!(
        fewer >= 3,
        "the search saved linearizations on {fewer} of 4"
    );
}

/// `r = x`: the cost `x^2 / 2` has its minimum at 0.
struct Identity;

impl CostFunction for Identity {
    fn evaluate(
        &self,
        _block: ResidualBlockId,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut JacobianBlocks<'_>>,
    ) -> Result<(), EvaluationError> {
        residuals[0] = params[0][0];
        if let Some(j) = jacobians
            && let Some(jac) = j.block_mut(0)
        {
            jac[0] = 1.0;
        }
        Ok(())
    }
}

/// A crawl: with the additive damping held at `lambda = 1e6` (factor 1), every step shrinks `x`
/// by the factor `1e6 / (1 + 1e6)`, lowering the cost by 2e-6 relative: far above the per-step
/// function tolerance, so the solve runs to its iteration limit. The stagnation rule with a
/// window of 10 steps and a tolerance of 1e-4 (10 steps lower it by 2e-5) ends it converged
/// after exactly 11 steps: the first at which 10 earlier accepted steps exist.
#[test]
fn the_stagnation_rule_ends_a_crawl() {
    let run = |window: usize| {
        let mut builder = ProblemBuilder::new();
        let p = builder.add_parameter_block(1);
        builder.add_residual_block(1, &[p]);
        let mut o = SolverOptions::default();
        o.damping = DampingPolicy::Additive {
            initial: 1e6,
            factor: 1.0,
        };
        o.stagnation_window = window;
        o.stagnation_tolerance = 1e-4;
        let mut solver = Solver::new(builder.build().unwrap(), o).unwrap();
        let mut x = [1.0];
        let report = solver.solve(&Identity, &mut x).unwrap();
        (x[0], report)
    };
    let (_, crawl) = run(0);
    assert_eq!(crawl.termination, Termination::MaxIterations);
    let (x, stopped) = run(10);
    assert_eq!(stopped.termination, Termination::FunctionTolerance);
    assert_eq!(stopped.iterations.len(), 11);
    let expected = (1e6f64 / (1.0 + 1e6)).powi(11);
    assert!((x - expected).abs() < 1e-12, "{x} vs {expected}");
}
