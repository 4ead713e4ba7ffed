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

/// A camera that shares a single frame with the others is calibrated, with a warning that its
/// place in the rig rests on that one view (a helper audit: with that view's corners numbered
/// the other way round, the camera came out 180 degrees wrong, exit 0, no warning). Cameras
/// sharing many frames get no such warning.
#[test]
fn a_camera_tied_to_the_rig_by_one_frame_is_flagged() {
    let data = generate_rig(&SyntheticRigConfig::default()).unwrap();
    let last = data.observations.cameras.len() - 1;
    let mut weak = data.observations.clone();
    let mut kept = None;
    for (f, frame) in weak.frames.iter_mut().enumerate() {
        let sees = frame.observations.iter().any(|o| o.camera == last);
        let others = frame.observations.iter().any(|o| o.camera != last);
        if sees && others {
            if kept.is_none() {
                kept = Some(f);
            } else {
                // Only the last camera sees the board in the other frames it was in.
                frame.observations.retain(|o| o.camera == last);
            }
        }
    }
    let kept = kept.expect("a shared frame");
    let flagged = |r: &calib_rig::RigCalibration| {
        r.warnings
            .iter()
            .any(|w| w.message.contains("shares only frame"))
    };
    let strong = calibrate_rig(&data.observations, &RigOptions::default()).unwrap();
    assert!(!flagged(&strong), "{:?}", strong.warnings);
    let r = calibrate_rig(&weak, &RigOptions::default()).unwrap();
    let name = &weak.cameras[last].name;
    assert!(
        r.warnings.iter().any(|w| w
            .message
            .contains(&format!("camera '{name}' shares only frame {kept} "))),
        "{:?}",
        r.warnings
    );
}

/// Every frame listed twice is the same rig with the copies left out and a warning: counted
/// twice, each view would have shrunk every sigma by sqrt(2) (a helper audit: cam0's fx sigma
/// 0.744 -> 0.524, no warning), as calib single's duplicate-views check prevents for one camera.
#[test]
fn repeated_frames_are_left_out_with_a_warning() {
    let config = SyntheticRigConfig {
        cameras: 3,
        frames: 12,
        ..Default::default()
    };
    let data = generate_rig(&config).unwrap();
    let once = calibrate_rig(&data.observations, &RigOptions::default()).unwrap();
    let mut twice = data.observations.clone();
    twice.frames.extend(data.observations.frames.clone());
    let r = calibrate_rig(&twice, &RigOptions::default()).unwrap();
    assert!(
        r.warnings.iter().any(
            |w| w.code == calib_core::warnings::WarningCode::DuplicateViews
                && w.message.contains("frame 12 = frame 0")
        ),
        "{:?}",
        r.warnings
    );
    assert_eq!(r.frames.len(), once.frames.len());
    assert!(r.frames.iter().all(|f| f.index < 12));
    for (a, b) in r.cameras.iter().zip(&once.cameras) {
        assert_eq!(a.estimate.intrinsics_std, b.estimate.intrinsics_std);
        assert_eq!(a.estimate.camera, b.estimate.camera);
    }
    // Asked to keep them, the copies count (and the sigmas shrink by about sqrt(2)).
    let mut keep = RigOptions::default();
    keep.camera.drop_duplicate_views = false;
    let kept = calibrate_rig(&twice, &keep).unwrap();
    let ratio =
        kept.cameras[0].estimate.intrinsics_std[0] / once.cameras[0].estimate.intrinsics_std[0];
    assert!((ratio - 0.5f64.sqrt()).abs() < 0.05, "{ratio}");
}
