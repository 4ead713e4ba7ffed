//! The initial rig transform (left camera to right camera) from per-pair poses.
//!
//! For each pair `j`, the left and right single-camera calibrations give `(R_L,j, t_L,j)` and
//! `(R_R,j, t_R,j)`, and an exact rig satisfies `R_R,j = R_s R_L,j` and
//! `t_R,j = R_s t_L,j + t_s`.

use camera_model::{AxisAngle, Pose, RotationParameterization, nearest_rotation};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

/// How the initial rig is computed from the per-pair poses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RigInit {
    /// Least squares over all pairs (the specification's stacked linear system for `R_s`, made a
    /// rotation by SVD; `t_s` the mean of `t_R - R_s t_L`). The default: more accurate than the
    /// median under Gaussian noise (see the test `least_squares_beats_the_median_on_noisy_poses`).
    #[default]
    LeastSquares,
    /// The pair whose rig rotation `R_R R_L^T` is closest to all others (medoid), and the
    /// component-wise median of `t_R - R_s t_L`. Robust to a few bad pairs.
    Median,
}

/// The least-squares rig.
///
/// Writing `vec(R)` for the rotation's entries column by column, each pair contributes the 9x9
/// block `A_j = R_L,j^T (x) I_3` (`A_j vec(R_s) = vec(R_R,j)`, one row per entry of `R_R,j`); the
/// stacked system `A vec(R_s) = b` is solved by least squares and the result projected onto the
/// rotations. Then `t_s` minimizes `sum_j |t_R,j - R_s t_L,j - t_s|^2`: the mean.
pub fn least_squares_rig(left: &[Pose], right: &[Pose]) -> Option<Pose> {
    let m = left.len();
    if m == 0 || right.len() != m {
        return None;
    }
    let mut a = DMatrix::<f64>::zeros(9 * m, 9);
    let mut b = DVector::<f64>::zeros(9 * m);
    for (j, (l, r)) in left.iter().zip(right).enumerate() {
        for col in 0..3 {
            for k in 0..3 {
                for i in 0..3 {
                    a[(9 * j + 3 * col + i, 3 * k + i)] = l.rotation[(k, col)];
                }
            }
            for i in 0..3 {
                b[9 * j + 3 * col + i] = r.rotation[(i, col)];
            }
        }
    }
    let normal = a.transpose() * &a;
    let rhs = a.transpose() * b;
    let solution = normal.cholesky()?.solve(&rhs);
    let rotation = nearest_rotation(&Matrix3::from_column_slice(solution.as_slice()))?;
    let mut translation = Vector3::zeros();
    for (l, r) in left.iter().zip(right) {
        translation += r.translation - rotation * l.translation;
    }
    translation /= m as f64;
    Some(Pose::new(rotation, translation))
}

/// The median-of-pairs rig (see [`RigInit::Median`]).
pub fn median_rig(left: &[Pose], right: &[Pose]) -> Option<Pose> {
    let m = left.len();
    if m == 0 || right.len() != m {
        return None;
    }
    let rotations: Vec<Matrix3<f64>> = left
        .iter()
        .zip(right)
        .map(|(l, r)| r.rotation * l.rotation.transpose())
        .collect();
    let angle =
        |a: &Matrix3<f64>, b: &Matrix3<f64>| AxisAngle::from_matrix(&(a.transpose() * b)).norm();
    let medoid = (0..m).min_by(|&i, &j| {
        let si: f64 = rotations.iter().map(|r| angle(&rotations[i], r)).sum();
        let sj: f64 = rotations.iter().map(|r| angle(&rotations[j], r)).sum();
        si.total_cmp(&sj)
    })?;
    let rotation = rotations[medoid];
    let mut translation = Vector3::zeros();
    for axis in 0..3 {
        let mut values: Vec<f64> = left
            .iter()
            .zip(right)
            .map(|(l, r)| (r.translation - rotation * l.translation)[axis])
            .collect();
        values.sort_by(f64::total_cmp);
        translation[axis] = if m % 2 == 1 {
            values[m / 2]
        } else {
            0.5 * (values[m / 2 - 1] + values[m / 2])
        };
    }
    Some(Pose::new(rotation, translation))
}

/// For each frame, the angle (radians) between its rig rotation `R_R R_L^T` and the medoid of
/// all frames' rig rotations. On a rigid rig with correct correspondences every angle is within
/// the pose noise (a fraction of a degree); a frame whose right points are numbered the other
/// way round, or whose views belong to different moments, stands out by tens of degrees.
pub fn rig_rotation_disagreements(left: &[Pose], right: &[Pose]) -> Vec<f64> {
    let rotations: Vec<Matrix3<f64>> = left
        .iter()
        .zip(right)
        .map(|(l, r)| r.rotation * l.rotation.transpose())
        .collect();
    let angle =
        |a: &Matrix3<f64>, b: &Matrix3<f64>| AxisAngle::from_matrix(&(a.transpose() * b)).norm();
    // The medoid of at most 64 evenly spread frames: O(m) for large rigs.
    let step = rotations.len().div_ceil(64).max(1);
    let sample: Vec<usize> = (0..rotations.len()).step_by(step).collect();
    let Some(&medoid) = sample.iter().min_by(|&&i, &&j| {
        let si: f64 = sample
            .iter()
            .map(|&k| angle(&rotations[i], &rotations[k]))
            .sum();
        let sj: f64 = sample
            .iter()
            .map(|&k| angle(&rotations[j], &rotations[k]))
            .sum();
        si.total_cmp(&sj)
    }) else {
        return Vec::new();
    };
    rotations
        .iter()
        .map(|r| angle(&rotations[medoid], r))
        .collect()
}

/// The initial rig by the chosen method.
pub fn initial_rig(method: RigInit, left: &[Pose], right: &[Pose]) -> Option<Pose> {
    match method {
        RigInit::LeastSquares => least_squares_rig(left, right),
        RigInit::Median => median_rig(left, right),
    }
}

/// Sum of squared start errors of `problem` (px^2), or `None` if some point cannot be projected.
pub fn start_cost(problem: &crate::JointProblem) -> Option<f64> {
    let errors = crate::solve::reprojection_errors(problem).ok()?;
    let cost: f64 = errors.iter().flatten().map(|e| e.norm_squared()).sum();
    cost.is_finite().then_some(cost)
}

/// Rigs (left camera to right camera) to try when the default start cannot be evaluated: both initial methods and the own
/// rig of up to 32 evenly spread pairs.
pub fn candidate_rigs(left: &[Pose], right: &[Pose]) -> Vec<Pose> {
    let mut rigs: Vec<Pose> = [RigInit::LeastSquares, RigInit::Median]
        .into_iter()
        .filter_map(|m| initial_rig(m, left, right))
        .collect();
    let step = left.len().div_ceil(32).max(1);
    for k in (0..left.len()).step_by(step) {
        let rotation = right[k].rotation * left[k].rotation.transpose();
        rigs.push(Pose::new(
            rotation,
            right[k].translation - rotation * left[k].translation,
        ));
    }
    rigs
}

#[cfg(test)]
mod tests {
    use super::*;
    use camera_model::EulerXyz;
    use lm_solver::Rng;

    fn random_pose(rng: &mut Rng) -> Pose {
        Pose::new(
            EulerXyz::matrix(&Vector3::new(
                rng.range(-0.6, 0.6) + std::f64::consts::PI,
                rng.range(-0.6, 0.6),
                rng.range(-1.0, 1.0),
            )),
            Vector3::new(
                rng.range(-200.0, 200.0),
                rng.range(-150.0, 150.0),
                rng.range(500.0, 1500.0),
            ),
        )
    }

    fn perturb(p: &Pose, rng: &mut Rng, angle: f64, shift: f64) -> Pose {
        let w = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * angle;
        let t = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * shift;
        Pose::new(AxisAngle::matrix(&w) * p.rotation, p.translation + t)
    }

    fn rig() -> Pose {
        Pose::new(
            EulerXyz::matrix(&Vector3::new(0.01, -0.03, 0.005)),
            Vector3::new(-100.0, 1.0, 2.5),
        )
    }

    #[test]
    fn exact_poses_give_the_exact_rig_with_both_methods() {
        let mut rng = Rng::new(1);
        let left: Vec<Pose> = (0..7).map(|_| random_pose(&mut rng)).collect();
        let right: Vec<Pose> = left.iter().map(|l| rig().compose(l)).collect();
        for method in [RigInit::LeastSquares, RigInit::Median] {
            let r = initial_rig(method, &left, &right).unwrap();
            assert!((r.rotation - rig().rotation).norm() < 1e-12, "{method:?}");
            assert!(
                (r.translation - rig().translation).norm() < 1e-9,
                "{method:?}"
            );
        }
        assert!(initial_rig(RigInit::LeastSquares, &[], &[]).is_none());
    }

    /// Poses from single-camera calibrations carry independent errors (here Gaussian, 0.5 degree
    /// and 1 mm); the least-squares rig averages them and is more accurate than the median-of-pairs
    /// rig, so it is the default.
    #[test]
    fn least_squares_beats_the_median_on_noisy_poses() {
        let (mut ls_error, mut median_error) = (0.0, 0.0);
        for seed in 0..200 {
            let mut rng = Rng::new(seed);
            let left: Vec<Pose> = (0..12).map(|_| random_pose(&mut rng)).collect();
            let right: Vec<Pose> = left.iter().map(|l| rig().compose(l)).collect();
            let noisy_left: Vec<Pose> = left
                .iter()
                .map(|p| perturb(p, &mut rng, 0.5f64.to_radians(), 1.0))
                .collect();
            let noisy_right: Vec<Pose> = right
                .iter()
                .map(|p| perturb(p, &mut rng, 0.5f64.to_radians(), 1.0))
                .collect();
            let truth = rig();
            let error = |p: Pose| {
                AxisAngle::from_matrix(&(p.rotation.transpose() * truth.rotation)).norm() * 1000.0
                    + (p.translation - truth.translation).norm()
            };
            ls_error += error(least_squares_rig(&noisy_left, &noisy_right).unwrap());
            median_error += error(median_rig(&noisy_left, &noisy_right).unwrap());
        }
        assert!(
            ls_error < median_error,
            "least squares {ls_error}, median {median_error}"
        );
        assert_eq!(RigInit::default(), RigInit::LeastSquares);
    }
}
