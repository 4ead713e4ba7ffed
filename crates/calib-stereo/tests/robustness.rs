//! A stereo board in other units or with an offset origin is the same calibration (issue 11,
//! finding 2): same cameras, same RMS, `T` in the board's units.

use calib_stereo::synthetic::{SyntheticStereoConfig, generate_stereo};
use calib_stereo::{StereoObservations, StereoOptions, calibrate_stereo};
use nalgebra::{Point3, Vector3};

fn transform(obs: &StereoObservations, scale: f64, shift: Vector3<f64>) -> StereoObservations {
    let mut out = obs.clone();
    for pair in &mut out.pairs {
        for view in [&mut pair.left, &mut pair.right] {
            for p in &mut view.object_points {
                *p = Point3::from(p.coords * scale + shift);
            }
        }
    }
    out
}

#[test]
fn board_units_and_origin_do_not_matter() {
    let set = generate_stereo(&SyntheticStereoConfig::default()).unwrap();
    let reference = calibrate_stereo(&set.observations, &StereoOptions::default()).unwrap();
    for (what, scale, shift) in [
        ("micrometres", 1000.0, Vector3::zeros()),
        ("1e-8 units", 1e-8, Vector3::zeros()),
        ("origin 5 m off", 1.0, Vector3::new(-5000.0, 2500.0, 0.0)),
        ("origin 20 m off", 1.0, Vector3::new(20_000.0, 0.0, 0.0)),
    ] {
        let r = calibrate_stereo(
            &transform(&set.observations, scale, shift),
            &StereoOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{what}: {e}"));
        assert!(r.solver.termination.is_converged(), "{what}");
        // The baseline is judged against the distance to the board, not to its origin (a 10 m
        // origin made sourishg1's 94 mm baseline "0.94% of the board distance").
        assert!(
            !r.warnings
                .iter()
                .any(|w| w.code == calib_core::warnings::WarningCode::ShortBaseline),
            "{what}: {:?}",
            r.warnings
        );
        assert!(
            (r.rms - reference.rms).abs() < 1e-9 * reference.rms,
            "{what}: rms {} vs {}",
            r.rms,
            reference.rms
        );
        for (a, b) in [(&r.left, &reference.left), (&r.right, &reference.right)] {
            let (pa, pb) = (a.camera.params(), b.camera.params());
            for i in 0..pa.len() {
                let sigma = if i < 4 {
                    b.intrinsics_std[i]
                } else {
                    b.distortion_std[i - 4]
                };
                assert!(
                    (pa[i] - pb[i]).abs() <= 1e-3 * sigma,
                    "{what}: {} parameter {i}",
                    a.name
                );
            }
        }
        let t = r.rig.translation / scale;
        assert!(
            (t - reference.rig.translation).norm() <= 1e-6 * reference.baseline,
            "{what}: T {t} vs {}",
            reference.rig.translation
        );
    }
}
