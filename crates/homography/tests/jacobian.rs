//! Property test: the analytic Jacobian of `project_with_jacobian` against central finite
//! differences, over random realistic homographies `H = K [r1 r2 t]`.

mod common;

use common::{board_rotation, homography_from_pose, intrinsics};
use homography::project_with_jacobian;
use lm_solver::numdiff::{central_difference_with_steps, compare_jacobians};
use nalgebra::{Matrix3, Point2, Vector3};
use proptest::prelude::*;

/// A camera and board pose: fx in 300..2000 (fy within 10 %), principal point anywhere in a
/// plausible sensor, the unit board tilted by up to 60 degrees and spun freely, its centre
/// 0.5..5 board sizes in front of the camera and shifted sideways by up to 0.3 of that.
fn view_strategy() -> impl Strategy<Value = (Matrix3<f64>, f64)> {
    (
        (
            300.0..2000.0f64,
            0.9..1.1f64,
            100.0..1000.0f64,
            100.0..800.0f64,
        ),
        (
            -std::f64::consts::PI..std::f64::consts::PI,
            0.0..60f64.to_radians(),
            0.0..std::f64::consts::TAU,
        ),
        (-0.3..0.3f64, -0.3..0.3f64, 0.5..5.0f64),
    )
        .prop_map(|((fx, aspect, cx, cy), (spin, tilt, axis), (sx, sy, tz))| {
            let k = intrinsics(fx, fx * aspect, cx, cy);
            let r = board_rotation(spin, tilt, axis);
            let h = homography_from_pose(
                &k,
                &r,
                Point2::new(0.5, 0.5),
                Vector3::new(sx * tz, sy * tz, tz),
            );
            // Smallest depth over the board corners (the third row of K is (0, 0, 1), so
            // w' equals the depth of the corner).
            let min_depth = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .iter()
                .map(|&(x, y)| h[(2, 0)] * x + h[(2, 1)] * y + h[(2, 2)])
                .fold(f64::INFINITY, f64::min);
            (h / h[(2, 2)], min_depth)
        })
}

proptest! {
    // No regression file: proptest cannot locate one for an integration test binary, and
    // the strategy is cheap enough to run 512 fresh cases every time.
    #![proptest_config(ProptestConfig {
        cases: 512,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn jacobian_matches_central_differences(
        (h, min_depth) in view_strategy(),
        x in 0.0..1.0f64,
        y in 0.0..1.0f64,
    ) {
        // Only views with the whole board in front of the camera are valid.
        prop_assume!(min_depth > 0.05);
        let p = Point2::new(x, y);
        let (pixel, jac) = project_with_jacobian(&h, &p);

        // Step: cbrt(eps) times the magnitude of the row of H the entry belongs to, the
        // textbook optimum for central differences when f''' and f have similar scale (the
        // entries of H differ by orders of magnitude, so one relative step would not do).
        // Error budget of (f(h+d) - f(h-d)) / 2d:
        //  * truncation d^2/6 |f'''|: zero for the numerator rows (x is linear in h1, h2);
        //    for the denominator row, relative to the derivative it is about
        //    (d M_k / w')^2 <= (6e-6 * 10)^2 ~ 4e-9 for these views;
        //  * rounding ~ eps |f| / d, at most ~1e-15 |f| / d.
        // compare_jacobians accepts |analytic - fd| <= 1e-6 (|fd| + floor); with
        // floor = 1e-4 (1 + |pixel|) / d_min the absolute part is 1e-10 (1 + |f|) / d_min, a
        // margin of >100x over rounding, while a wrong formula (sign, missing factor, swapped
        // column) would be off by O(1).
        let params: Vec<f64> = h.iter().take(8).copied().collect();
        let steps: Vec<f64> = (0..8)
            .map(|j| f64::EPSILON.cbrt() * h.row(j % 3).norm())
            .collect();
        let numeric = central_difference_with_steps(
            |q: &[f64], out: &mut [f64]| {
                let mut hq = h;
                for (k, v) in q.iter().enumerate() {
                    hq[k] = *v;
                }
                out.copy_from_slice(project_with_jacobian(&hq, &p).0.as_slice());
            },
            &params,
            2,
            &steps,
        );
        let min_step = steps.iter().copied().fold(f64::INFINITY, f64::min);
        let floor = 1e-4 * (1.0 + pixel.abs().max()) / min_step;
        let r = compare_jacobians(jac.as_slice(), &numeric, 2, 1e-6, floor);
        prop_assert!(r.is_ok(), "{:?}", r);
    }
}
