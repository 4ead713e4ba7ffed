//! The rig pipeline against synthetic truth.

use calib_rig::synthetic::{RigLayout, SyntheticRigConfig, generate_rig};
use calib_rig::{RigOptions, calibrate_rig};
use camera_model::CameraModel;

/// Angle between two rotations, radians (precise near zero, unlike the trace formula).
fn rotation_angle(a: &nalgebra::Matrix3<f64>, b: &nalgebra::Matrix3<f64>) -> f64 {
    let r = a * b.transpose();
    ((r - r.transpose()).norm() / 8f64.sqrt()).asin()
}

#[test]
fn noise_free_rigs_are_recovered_exactly() {
    for (layout, models) in [
        (RigLayout::Ring { arc_deg: 180.0 }, vec![]),
        (
            RigLayout::Line { spacing: 0.6 },
            vec![CameraModel::BrownConrady4, CameraModel::BrownConrady5],
        ),
    ] {
        let mut config = SyntheticRigConfig::default();
        config.base.noise_px = 0.0;
        config.layout = layout;
        config.models = models;
        let data = generate_rig(&config).unwrap();
        let rig = calibrate_rig(&data.observations, &RigOptions::default()).unwrap();
        assert!(rig.rms < 1e-8, "rms {}", rig.rms);
        for (c, (camera, truth)) in rig.cameras.iter().zip(&data.cameras).enumerate() {
            let k = camera.estimate.camera.intrinsics;
            let t = truth.intrinsics;
            for (a, b) in [(k.fx, t.fx), (k.fy, t.fy), (k.cx, t.cx), (k.cy, t.cy)] {
                assert!((a - b).abs() < 1e-6, "camera {c}: {a} vs {b}");
            }
            for (a, b) in camera
                .estimate
                .camera
                .distortion
                .iter()
                .zip(&truth.distortion)
            {
                assert!((a - b).abs() < 1e-8, "camera {c}: distortion {a} vs {b}");
            }
            let true_t = &data.transforms[c];
            assert!(rotation_angle(&camera.transform.rotation, &true_t.rotation) < 1e-9);
            assert!((camera.transform.translation - true_t.translation).norm() < 1e-6);
        }
    }
}
