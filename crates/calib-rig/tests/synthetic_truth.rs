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

/// Boards in other units or with their origin far off the board are the same rig: the same RMS
/// and intrinsics, translations in the board's units (the engine normalizes the board).
#[test]
fn board_units_and_origin_do_not_matter() {
    let config = SyntheticRigConfig {
        cameras: 3,
        frames: 30,
        ..Default::default()
    };
    let data = generate_rig(&config).unwrap();
    let reference = calibrate_rig(&data.observations, &RigOptions::default()).unwrap();
    for (scale, offset) in [
        (1000.0, [0.0, 0.0]),
        (1e-3, [0.0, 0.0]),
        (1.0, [-5000.0, 2500.0]),
    ] {
        let mut moved = data.observations.clone();
        for frame in &mut moved.frames {
            for o in &mut frame.observations {
                for p in &mut o.view.object_points {
                    *p = nalgebra::Point3::new(
                        p.x * scale + offset[0],
                        p.y * scale + offset[1],
                        0.0,
                    );
                }
            }
        }
        let rig = calibrate_rig(&moved, &RigOptions::default()).unwrap();
        assert!(
            (rig.rms - reference.rms).abs() < 1e-7,
            "scale {scale}: {} vs {}",
            rig.rms,
            reference.rms
        );
        for (a, b) in rig.cameras.iter().zip(&reference.cameras) {
            let (ka, kb) = (a.estimate.camera.intrinsics, b.estimate.camera.intrinsics);
            assert!(
                (ka.fx - kb.fx).abs() < 1e-5 && (ka.cy - kb.cy).abs() < 1e-5,
                "scale {scale}"
            );
            let t = a.transform.translation / scale - b.transform.translation;
            assert!(
                t.norm() < 1e-5 * b.transform.translation.norm().max(1.0),
                "scale {scale}: {t}"
            );
        }
    }
}
