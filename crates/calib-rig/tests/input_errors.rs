//! Bad rigs give typed errors naming cameras and frames; options that change the problem work.

use calib_core::JsonFile;
use calib_rig::synthetic::{RigLayout, SyntheticRigConfig, generate_rig};
use calib_rig::{RigError, RigObservations, RigOptions, calibrate_rig};
use camera_model::{AxisAngle, CameraModel, RotationParameterization};

fn rig(cameras: usize, frames: usize) -> calib_rig::synthetic::SyntheticRigSet {
    let config = SyntheticRigConfig {
        cameras,
        frames,
        layout: RigLayout::Line { spacing: 0.5 },
        ..Default::default()
    };
    generate_rig(&config).unwrap()
}

#[test]
fn cameras_without_shared_frames_are_named_with_their_groups() {
    let mut data = rig(4, 40);
    // Split every frame shared between {cam0, cam1} and {cam2, cam3}: each group keeps its
    // views in every other such frame.
    for (f, frame) in data.observations.frames.iter_mut().enumerate() {
        let low = frame.observations.iter().any(|o| o.camera < 2);
        let high = frame.observations.iter().any(|o| o.camera >= 2);
        if low && high {
            frame
                .observations
                .retain(|o| (o.camera < 2) == (f % 2 == 0));
        }
    }
    let error = calibrate_rig(&data.observations, &RigOptions::default()).unwrap_err();
    match &error {
        RigError::Disconnected { groups } => {
            assert_eq!(groups, &vec![vec!["cam0", "cam1"], vec!["cam2", "cam3"]]);
        }
        other => panic!("expected Disconnected, got {other}"),
    }
    let message = error.to_string();
    assert!(
        message.contains("[cam2, cam3]") && message.contains("[cam0, cam1]"),
        "{message}"
    );
}

#[test]
fn a_camera_with_too_few_frames_is_told_to_bring_its_intrinsics() {
    let mut data = rig(3, 30);
    // cam2 keeps two frames, both shared with another camera.
    let mut kept = 0;
    for frame in &mut data.observations.frames {
        let shared = frame.observations.len() > 1;
        let keep = shared && kept < 2 && frame.observations.iter().any(|o| o.camera == 2);
        kept += usize::from(keep);
        frame.observations.retain(|o| o.camera != 2 || keep);
    }
    assert_eq!(kept, 2);
    let error = calibrate_rig(&data.observations, &RigOptions::default()).unwrap_err();
    assert!(
        matches!(error, RigError::TooFewViews { views: 2, .. }),
        "{error}"
    );
    // Both front ends' ways of giving them: the command's option and the Python argument.
    let text = error.to_string();
    assert!(
        text.contains("--intrinsics cam2=RESULT.json; Python: known={'cam2': (K, dist)}"),
        "{text}"
    );

    // Given (fixed) intrinsics make the same rig solvable.
    let mut options = RigOptions::default();
    options.given = vec![None, None, Some(data.cameras[2].clone())];
    let result = calibrate_rig(&data.observations, &options).unwrap();
    assert!(result.solver.termination.is_converged());
    assert_eq!(result.cameras[2].initial_method, "given");
    assert_eq!(result.cameras[2].estimate.camera, data.cameras[2]);
    assert!(
        result.cameras[2]
            .estimate
            .intrinsics_std
            .iter()
            .all(|&s| s == 0.0)
    );
}

#[test]
fn malformed_frames_are_refused_with_their_index() {
    let data = rig(2, 12);
    let mut json = data.observations.to_json_value();
    json["frames"][3]["observations"][0]["camera"] = 5.into();
    let bad = RigObservations::from_json(&json.to_string()).unwrap();
    let error = calibrate_rig(&bad, &RigOptions::default()).unwrap_err();
    assert_eq!(error.to_string(), "frame 3: camera 5 of 2");

    let mut json = data.observations.to_json_value();
    let first = json["frames"][4]["observations"][0].clone();
    json["frames"][4]["observations"]
        .as_array_mut()
        .unwrap()
        .push(first);
    let bad = RigObservations::from_json(&json.to_string()).unwrap();
    let error = calibrate_rig(&bad, &RigOptions::default()).unwrap_err();
    assert!(
        error.to_string().contains("frame 4: camera 'cam"),
        "{error}"
    );

    let mut json = data.observations.to_json_value();
    json["frames"][5]["observations"][0]["image_points"]
        .as_array_mut()
        .unwrap()
        .pop();
    let bad = RigObservations::from_json(&json.to_string()).unwrap();
    let error = calibrate_rig(&bad, &RigOptions::default()).unwrap_err();
    assert!(error.to_string().contains("frame 5"), "{error}");

    // One image given for both cameras of a frame: refused (it calibrated to a zero baseline).
    let f = (0..data.observations.frames.len())
        .find(|&f| data.observations.frames[f].observations.len() == 2)
        .unwrap();
    let mut bad = data.observations.clone();
    let first = bad.frames[f].observations[0].view.clone();
    bad.frames[f].observations[1].view = first;
    let error = calibrate_rig(&bad, &RigOptions::default()).unwrap_err();
    assert!(
        error
            .to_string()
            .starts_with(&format!("frame {f}: cameras '"))
            && error.to_string().contains("have the same corners"),
        "{error}"
    );

    let empty = RigObservations {
        cameras: data.observations.cameras.clone(),
        frames: Vec::new(),
    };
    assert_eq!(
        calibrate_rig(&empty, &RigOptions::default()).unwrap_err(),
        RigError::Empty("frames")
    );
    let mut options = RigOptions::default();
    options.reference = 7;
    assert!(matches!(
        calibrate_rig(&data.observations, &options).unwrap_err(),
        RigError::InvalidOption(_)
    ));
}

#[test]
fn the_reference_camera_sets_the_frame_of_the_transforms() {
    let data = rig(3, 30);
    let base = calibrate_rig(&data.observations, &RigOptions::default()).unwrap();
    let mut options = RigOptions::default();
    options.reference = 1;
    let moved = calibrate_rig(&data.observations, &options).unwrap();
    assert!((moved.rms - base.rms).abs() < 1e-7);
    assert_eq!(moved.cameras[1].transform, camera_model::Pose::identity());
    // X_2 = R_21 X_1 + T_21 = (T_2 T_1^-1) X_1 from the first calibration.
    let expected = base.cameras[2]
        .transform
        .compose(&base.cameras[1].transform.inverse());
    let got = moved.cameras[2].transform;
    assert!((got.translation - expected.translation).norm() < 1e-4);
    assert!((got.rotation - expected.rotation).norm() < 1e-7);
}

#[test]
fn pinhole_and_fisheye_cameras_calibrate_together() {
    let config = SyntheticRigConfig {
        cameras: 3,
        frames: 36,
        models: vec![CameraModel::BrownConrady4, CameraModel::KannalaBrandt4],
        ..Default::default()
    };
    let data = generate_rig(&config).unwrap();
    let result = calibrate_rig(&data.observations, &RigOptions::default()).unwrap();
    assert!(result.solver.termination.is_converged());
    assert_eq!(
        result.cameras[1].estimate.camera.model,
        CameraModel::KannalaBrandt4
    );
    for (c, camera) in result.cameras.iter().enumerate() {
        let (k, t) = (
            camera.estimate.camera.intrinsics,
            data.cameras[c].intrinsics,
        );
        assert!(
            (k.fx - t.fx).abs() < 6.0 * camera.estimate.intrinsics_std[0] + 1e-6,
            "camera {c}: fx {} vs {}",
            k.fx,
            t.fx
        );
        let d = camera.transform.translation - data.transforms[c].translation;
        assert!(
            d.norm() < 0.01 * data.transforms[c].translation.norm().max(1.0),
            "camera {c}: T off by {d}"
        );
    }
}

#[test]
fn a_view_with_reversed_corners_is_named() {
    let mut data = rig(3, 30);
    // Frame 7, camera 1: the corners listed the other way round (a detector that started at
    // the opposite corner). Alone that view is a valid board pose; with the rig it is not.
    let frame = data
        .observations
        .frames
        .iter_mut()
        .enumerate()
        .skip(7)
        .find(|(_, f)| f.observations.len() > 1 && f.observations.iter().any(|o| o.camera == 1))
        .unwrap();
    let index = frame.0;
    let view = &mut frame
        .1
        .observations
        .iter_mut()
        .find(|o| o.camera == 1)
        .unwrap()
        .view;
    view.image_points.reverse();
    let error = calibrate_rig(&data.observations, &RigOptions::default()).unwrap_err();
    assert!(matches!(error, RigError::InconsistentViews(_)), "{error}");
    let message = error.to_string();
    assert!(
        message.contains(&format!("frame {index}: camera")) && message.contains("'cam1'"),
        "{message}"
    );
    assert_eq!(message.matches("frame ").count(), 1, "{message}");
    assert!(
        message.contains("(--skip-bad-views; Python: skip_bad_views=True)"),
        "{message}"
    );

    // Left out with a warning on request; the rest calibrates as before.
    let mut options = RigOptions::default();
    options.camera.skip_bad_views = true;
    let result = calibrate_rig(&data.observations, &options).unwrap();
    assert!(result.solver.termination.is_converged());
    assert!(
        result
            .warnings
            .iter()
            .any(|w| w.message.contains(&format!("frame {index}: camera"))),
        "{:?}",
        result.warnings
    );
    assert!(result.rms < 0.35, "{}", result.rms);
    let frame = result.frames.iter().find(|f| f.index == index).unwrap();
    assert!(frame.views.iter().all(|v| v.camera != 1));
}

#[test]
fn two_cameras_with_one_name_are_refused() {
    let mut data = rig(3, 20);
    data.observations.cameras[2].name = "cam0".into();
    let error = calibrate_rig(&data.observations, &RigOptions::default()).unwrap_err();
    let message = error.to_string();
    assert!(
        message.contains("cameras 0 and 2 are both named 'cam0'"),
        "{message}"
    );
}

/// A name to hold that no camera's model has (a typo: "k7") is refused, not ignored; a name
/// some camera has is held there.
#[test]
fn holding_a_coefficient_no_camera_has_is_refused() {
    let data = rig(3, 20);
    let mut options = RigOptions::default();
    options.hold_fixed = vec!["k7".into()];
    let message = calibrate_rig(&data.observations, &options)
        .unwrap_err()
        .to_string();
    assert!(message.contains("'k7'"), "{message}");
    options.hold_fixed = vec!["k2".into()];
    let result = calibrate_rig(&data.observations, &options).unwrap();
    for camera in &result.cameras {
        assert!(
            camera.estimate.fixed_parameters.contains(&"k2".to_string()),
            "{:?}",
            camera.estimate.fixed_parameters
        );
    }
}

/// The frame and camera of the first view of `camera` in a frame where at least two other
/// cameras saw the board too.
fn view_with_two_others(data: &calib_rig::synthetic::SyntheticRigSet, camera: usize) -> usize {
    data.observations
        .frames
        .iter()
        .position(|f| {
            f.observations.len() >= 3 && f.observations.iter().any(|o| o.camera == camera)
        })
        .unwrap()
}

fn view_mut(
    data: &mut calib_rig::synthetic::SyntheticRigSet,
    frame: usize,
    camera: usize,
) -> &mut calib_core::View {
    &mut data.observations.frames[frame]
        .observations
        .iter_mut()
        .find(|o| o.camera == camera)
        .unwrap()
        .view
}

/// The rig calibrated with `skip_bad_views`, at the noise level (RMS below 0.3 px).
fn calibrated_skipping_bad_views(observations: &RigObservations) -> calib_rig::RigCalibration {
    let mut options = RigOptions::default();
    options.camera.skip_bad_views = true;
    let result = calibrate_rig(observations, &options).unwrap();
    assert!(result.rms < 0.3, "{}", result.rms);
    result
}

/// Asserts that `result` kept no view of `camera` in `frame`.
fn view_left_out(result: &calib_rig::RigCalibration, frame: usize, camera: usize) {
    let kept = result.frames.iter().find(|f| f.index == frame).unwrap();
    assert!(kept.views.iter().all(|v| v.camera != camera));
}

/// Asserts that `data` is refused naming only `camera` in `frame` by its position, and that
/// `--skip-bad-views` leaves that view out and calibrates the rest.
fn only_that_view_is_named(
    data: &calib_rig::synthetic::SyntheticRigSet,
    frame: usize,
    camera: usize,
) {
    let name = &data.observations.cameras[camera].name;
    let error = calibrate_rig(&data.observations, &RigOptions::default()).unwrap_err();
    assert!(matches!(error, RigError::InconsistentViews(_)), "{error}");
    let message = error.to_string();
    assert!(
        message.contains(&format!("frame {frame}: camera '{name}' sees the board "))
            && message.contains("of its distance) away"),
        "{message}"
    );
    assert_eq!(message.matches("camera '").count(), 1, "{message}");
    let result = calibrated_skipping_bad_views(&data.observations);
    assert_eq!(result.num_rejected, 0);
    view_left_out(&result, frame, camera);
}

/// A view whose board points are in another size (a board of 20 mm squares given as 25 mm) is
/// a valid view alone: the camera's own calibration places the board nearer. Only its position
/// in the rig betrays it. It was left to the joint stage, whose outlier rounds blamed another
/// camera of the frame (52 of 54 points of a correct view) and which --skip-bad-views did not
/// act on.
#[test]
fn a_view_of_a_board_of_another_size_is_named() {
    let mut data = rig(4, 40);
    let frame = view_with_two_others(&data, 2);
    for p in &mut view_mut(&mut data, frame, 2).object_points {
        p.coords *= 0.8;
    }
    only_that_view_is_named(&data, frame, 2);
}

/// One camera's images of two frames swapped (its file names numbered one frame off): each view
/// is a correct view of the board, turned by less than the rotation check's 30 degrees from the
/// frame's other views when the board turned little between the two frames, but elsewhere.
#[test]
fn a_view_from_another_frame_is_named() {
    let mut data = rig(4, 40);
    let camera = 1;
    let frames: Vec<usize> = (0..data.observations.frames.len())
        .filter(|&f| {
            let f = &data.observations.frames[f];
            f.observations.len() >= 3 && f.observations.iter().any(|o| o.camera == camera)
        })
        .collect();
    // Two such frames whose boards are turned less than 20 degrees from each other and lie
    // more than a quarter of their distance apart.
    let (a, b) = frames
        .iter()
        .flat_map(|&a| frames.iter().map(move |&b| (a, b)))
        .find(|&(a, b)| {
            let (p, q) = (&data.frame_poses[a], &data.frame_poses[b]);
            let angle = AxisAngle::from_matrix(&(p.rotation.transpose() * q.rotation))
                .norm()
                .to_degrees();
            a < b
                && angle < 20.0
                && (p.translation - q.translation).norm() > 0.25 * p.translation.norm()
        })
        .expect("two frames with similar board rotations");
    let pixels = view_mut(&mut data, a, camera).image_points.clone();
    let other = std::mem::replace(&mut view_mut(&mut data, b, camera).image_points, pixels);
    view_mut(&mut data, a, camera).image_points = other;
    // Both views are named; with one of them restored, the other alone.
    let error = calibrate_rig(&data.observations, &RigOptions::default()).unwrap_err();
    let message = error.to_string();
    assert!(
        message.contains(&format!("frame {a}: camera 'cam1' sees the board "))
            && message.contains(&format!("frame {b}: camera 'cam1' sees the board ")),
        "{message}"
    );
    let result = calibrated_skipping_bad_views(&data.observations);
    for f in [a, b] {
        view_left_out(&result, f, camera);
    }
}

/// A view that fails its camera's own checks (its pixels scrambled against its board points: no
/// homography fits) is refused naming the camera, and --skip-bad-views leaves it out
/// as calib single does. The rig set its cameras' skip_bad_views to false, so the option did
/// nothing there and the calibration stopped all the same.
#[test]
fn a_view_failing_its_cameras_checks_is_skipped_on_request() {
    let mut data = rig(4, 40);
    let frame = view_with_two_others(&data, 1);
    let view = view_mut(&mut data, frame, 1);
    // The pixels scrambled: point i gets the pixel of point 17 i (mod 54).
    let pixels = view.image_points.clone();
    let n = pixels.len();
    view.image_points = (0..n).map(|i| pixels[i * 17 % n]).collect();
    let error = calibrate_rig(&data.observations, &RigOptions::default()).unwrap_err();
    assert!(
        matches!(&error, RigError::Camera { camera, .. } if camera == "cam1"),
        "{error}"
    );
    // Named by frame and camera (the camera's own stage numbers its views by frame).
    assert!(
        error
            .to_string()
            .starts_with(&format!("frame {frame}, camera 'cam1': only ")),
        "{error}"
    );
    let result = calibrated_skipping_bad_views(&data.observations);
    assert!(
        result.warnings.iter().any(|w| w
            .message
            .contains(&format!("frame {frame}, camera 'cam1': only "))),
        "{:?}",
        result.warnings
    );
    view_left_out(&result, frame, 1);
}

/// A view whose corners are numbered two rows off (the corner list starts at the third row): a
/// valid view of a board shifted by two squares, which neither its camera's own checks nor the
/// rig's rotation and position checks catch. In the joint stage it pulls its frame's pose and
/// the frame's correct views miss: the error names a view of that frame, and with
/// `skip_bad_views` the frame is left out and the rest calibrated (the joint stage had no such
/// retry, and the option did nothing there).
#[test]
fn a_frame_whose_views_contradict_each_other_is_left_out_on_request() {
    let mut data = rig(4, 40);
    let frame = view_with_two_others(&data, 1);
    let view = view_mut(&mut data, frame, 1);
    let first_y = view.object_points[0].y;
    let row = view
        .object_points
        .iter()
        .take_while(|p| p.y == first_y)
        .count();
    let n = view.object_points.len();
    view.image_points.drain(..2 * row);
    view.object_points.truncate(n - 2 * row);
    // Named as the frame whose views contradict each other (the engine named the first view
    // past the limit, a correct one of another camera).
    match calibrate_rig(&data.observations, &RigOptions::default()) {
        Err(e @ RigError::InconsistentViews(_)) => assert!(
            e.to_string()
                .contains(&format!("frame {frame}: the views of cameras ")),
            "{e}"
        ),
        Err(e) => panic!("{e}"),
        Ok(r) => panic!("accepted: rms {}", r.rms),
    }
    let result = calibrated_skipping_bad_views(&data.observations);
    // The frame goes, alone: camera 1's view of another frame, past the limit in the same
    // round after the bad view pulled that camera, stays.
    assert!(
        result
            .warnings
            .iter()
            .any(|w| w.message.starts_with(&format!("frame {frame} left out: "))),
        "{:?}",
        result.warnings
    );
    assert_eq!(result.frames.len() + 1, data.observations.frames.len());
    assert!(result.frames.iter().all(|f| f.index != frame));
}

/// A view alone in its frame whose pixels come through another lens (pulled towards the centre
/// by a strong barrel distortion: a homography fits them loosely, so its camera's
/// own checks pass) misses its camera's model in the camera's own calibration. With
/// `skip_bad_views` it is left out and the rest calibrated, as calib single does; the option did
/// nothing at that stage and the rig stopped with "46 of 54 points are outliers ... skip bad
/// views", the advice the user had followed.
#[test]
fn a_view_missing_its_cameras_own_model_is_skipped_on_request() {
    let mut data = rig(4, 40);
    let frame = view_with_two_others(&data, 0);
    data.observations.frames[frame]
        .observations
        .retain(|o| o.camera == 0);
    let size = data.observations.cameras[0].image_size;
    let centre = nalgebra::Point2::new(size.width as f64 / 2.0, size.height as f64 / 2.0);
    let diagonal2 = centre.coords.norm_squared();
    let view = view_mut(&mut data, frame, 0);
    for p in &mut view.image_points {
        let d = *p - centre;
        *p = centre + d * (1.0 - 0.5 * d.norm_squared() / diagonal2);
    }
    assert!(view.image_points.iter().all(|p| p.x >= 0.0
        && p.y >= 0.0
        && p.x <= size.width as f64
        && p.y <= size.height as f64));
    let error = calibrate_rig(&data.observations, &RigOptions::default()).unwrap_err();
    assert!(
        matches!(&error, RigError::Camera { camera, source: calib_core::CalibrationError::MostlyOutliers { .. } } if camera == "cam0"),
        "{error}"
    );
    assert!(
        error
            .to_string()
            .starts_with(&format!("frame {frame}, camera 'cam0': 5"))
            && error.to_string().contains(" of 54 points are outliers"),
        "{error}"
    );
    let result = calibrated_skipping_bad_views(&data.observations);
    // The frame goes (it had no other view), alone.
    assert_eq!(result.frames.len() + 1, data.observations.frames.len());
    assert!(result.frames.iter().all(|f| f.index != frame));
    assert!(
        result.warnings.iter().any(|w| w
            .message
            .contains(&format!("frame {frame}, camera 'cam0': "))
            && w.message.contains(" points are outliers")),
        "{:?}",
        result.warnings
    );
}
