//! Every format round-trips every model it can hold, bit for bit; the models a format cannot
//! hold give a typed error; bad files give errors that name the file and the key.

use calib_core::ImageSize;
use calib_export::{
    Calibrated, CameraCalibration, ExportError, ExportOptions, Format, StereoRig, export,
    export_texts, parse_calibration, read_calibration,
};
use camera_model::{AnyCamera, AxisAngle, CameraModel, Intrinsics, RotationParameterization};
use nalgebra::Vector3;

/// A camera of `model` with distinct, awkward coefficients (not short decimals, mixed signs and
/// magnitudes down to 1e-7), so exact round trips are a real test.
fn camera(model: CameraModel, name: &str, seed: f64) -> CameraCalibration {
    let d: Vec<f64> = (0..model.num_distortion_params())
        .map(|i| ((i as f64 + 1.0) * 0.731 + seed).sin() * 10f64.powi(-(i as i32 % 7)) / 3.0)
        .collect();
    CameraCalibration::new(
        name,
        AnyCamera::new(
            model,
            Intrinsics::new(
                463.0270001 + seed,
                462.9 + seed / 7.0,
                314.45512,
                187.3021 - seed,
            ),
            d,
        )
        .unwrap(),
        ImageSize::new(640, 360),
    )
    .unwrap()
}

fn rig(left: CameraModel, right: CameraModel) -> StereoRig {
    StereoRig {
        left: camera(left, "left", 0.1),
        right: camera(right, "right", 0.37),
        rotation: AxisAngle::matrix(&Vector3::new(0.011, -0.0234, 0.0051)),
        translation: Vector3::new(-93.8412, -0.9213, 2.8511),
    }
}

/// Whether `format` can hold `camera` (the exporters' documented model tables).
fn supported(format: Format, camera: &CameraCalibration) -> bool {
    match (format, camera.camera.model) {
        (Format::Kalibr, CameraModel::Rational8 | CameraModel::ThinPrism12) => false,
        (Format::Kalibr, CameraModel::BrownConrady5) => camera.camera.distortion[4] == 0.0,
        (Format::Ros, CameraModel::ThinPrism12) => false,
        _ => true,
    }
}

fn same_camera(a: &CameraCalibration, b: &CameraCalibration, what: &str) {
    assert_eq!(a.camera.model, b.camera.model, "{what}");
    assert_eq!(a.image_size, b.image_size, "{what}");
    let (pa, pb) = (a.camera.params(), b.camera.params());
    assert_eq!(pa.len(), pb.len(), "{what}");
    for (x, y) in pa.iter().zip(&pb) {
        assert_eq!(x.to_bits(), y.to_bits(), "{what}: {pa:?} vs {pb:?}");
    }
}

fn read_back(format: Format, original: &Calibrated, texts: &[String]) -> Calibrated {
    match (format, original) {
        (Format::Ros, Calibrated::Stereo(s)) => {
            let cams: Vec<CameraCalibration> = texts
                .iter()
                .map(|t| match parse_calibration(t, "ros.yaml").unwrap() {
                    Calibrated::Single(c) => c,
                    other => panic!("{other:?}"),
                })
                .collect();
            assert_eq!(cams[0].name, "left");
            assert_eq!(cams[1].name, "right");
            Calibrated::Stereo(StereoRig {
                left: cams[0].clone(),
                right: cams[1].clone(),
                rotation: s.rotation,
                translation: s.translation,
            })
        }
        _ => {
            assert_eq!(texts.len(), 1);
            parse_calibration(&texts[0], "file.yaml").unwrap()
        }
    }
}

#[test]
fn single_cameras_round_trip_in_every_format_that_holds_their_model() {
    for format in Format::ALL {
        for model in CameraModel::ALL {
            let c = camera(model, "camera", 0.2);
            let original = Calibrated::Single(c.clone());
            let result = export_texts(&original, format, &ExportOptions::default());
            if !supported(format, &c) {
                assert!(
                    matches!(result, Err(ExportError::UnsupportedModel { model: m, .. }) if m == model),
                    "{format} {model}: {result:?}"
                );
                continue;
            }
            let texts = result.unwrap_or_else(|e| panic!("{format} {model}: {e}"));
            match read_back(format, &original, &texts) {
                Calibrated::Single(back) => same_camera(&c, &back, &format!("{format} {model}")),
                other => panic!("{other:?}"),
            }
        }
    }
}

#[test]
fn stereo_rigs_round_trip_in_every_format_that_holds_their_models() {
    for format in Format::ALL {
        for model in CameraModel::ALL {
            let original = rig(
                model,
                if model == CameraModel::ThinPrism12 {
                    model
                } else {
                    CameraModel::BrownConrady4
                },
            );
            let calibrated = Calibrated::Stereo(original.clone());
            let result = export_texts(&calibrated, format, &ExportOptions::default());
            if !supported(format, &original.left) {
                assert!(
                    matches!(result, Err(ExportError::UnsupportedModel { .. })),
                    "{format} {model}: {result:?}"
                );
                continue;
            }
            let texts = result.unwrap_or_else(|e| panic!("{format} {model}: {e}"));
            let Calibrated::Stereo(back) = read_back(format, &calibrated, &texts) else {
                panic!()
            };
            same_camera(
                &original.left,
                &back.left,
                &format!("{format} {model} left"),
            );
            same_camera(
                &original.right,
                &back.right,
                &format!("{format} {model} right"),
            );
            for (a, b) in original
                .rotation
                .iter()
                .chain(original.translation.iter())
                .zip(back.rotation.iter().chain(back.translation.iter()))
            {
                assert_eq!(a.to_bits(), b.to_bits(), "{format} {model} rig");
            }
        }
    }
}

#[test]
fn opencv_stereo_file_has_the_rectification_and_epipolar_matrices() {
    let r = rig(CameraModel::BrownConrady5, CameraModel::BrownConrady5);
    let text = &export_texts(
        &Calibrated::Stereo(r.clone()),
        Format::OpenCv,
        &ExportOptions::default(),
    )
    .unwrap()[0];
    assert!(text.starts_with("%YAML:1.0\n---\n"));
    for key in [
        "M1", "D1", "M2", "D2", "R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q",
    ] {
        assert!(
            text.contains(&format!("\n{key}: !!opencv-matrix\n")),
            "{key}"
        );
    }
    // The essential matrix in the file satisfies the epipolar constraint of the rig.
    let v: serde_norway::Value =
        serde_norway::from_str(text.strip_prefix("%YAML:1.0\n").unwrap()).unwrap();
    let e: Vec<f64> = v["E"]["data"]
        .as_sequence()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let e = nalgebra::Matrix3::from_row_slice(&e);
    let x_left = Vector3::new(0.3, -0.2, 4.0);
    let x_right = r.rotation * x_left + r.translation;
    let constraint = (x_right / x_right.z).dot(&(e * (x_left / x_left.z)));
    assert!(constraint.abs() < 1e-12 * e.norm(), "{constraint}");
}

/// The YAML comment lines of `text`, joined into one line.
fn comment(text: &str) -> String {
    text.lines()
        .filter_map(|l| l.strip_prefix("# "))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Cameras of different image sizes (a rig pair, `--right-image`): the OpenCV file holds both
/// sizes and the calibration, without the rectification (OpenCV rectifies one size), and reads
/// back; before, the export was refused.
#[test]
fn opencv_stereo_file_of_two_image_sizes_has_both_sizes_and_no_rectification() {
    let mut r = rig(CameraModel::BrownConrady5, CameraModel::KannalaBrandt4);
    r.right.image_size = ImageSize::new(800, 600);
    let original = Calibrated::Stereo(r.clone());
    let texts = export_texts(&original, Format::OpenCv, &ExportOptions::default()).unwrap();
    let text = &texts[0];
    assert!(
        text.contains("\nimage_width_2: 800\nimage_height_2: 600\n"),
        "{text}"
    );
    for key in ["M1", "D1", "M2", "D2", "R", "T", "E", "F"] {
        assert!(
            text.contains(&format!("\n{key}: !!opencv-matrix\n")),
            "{key}"
        );
    }
    for key in ["R1", "R2", "P1", "P2", "Q"] {
        assert!(!text.contains(&format!("\n{key}: ")), "{key}");
    }
    assert!(
        comment(text).starts_with("R1, R2, P1, P2, Q (the rectification) are left out: the two cameras have different image sizes (640x360 and 800x600)"),
        "{text}"
    );
    match read_back(Format::OpenCv, &original, &texts) {
        Calibrated::Stereo(back) => {
            same_camera(&back.left, &r.left, "left");
            same_camera(&back.right, &r.right, "right");
            assert_eq!(back.rotation, r.rotation);
            assert_eq!(back.translation, r.translation);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn translation_scale_converts_units_for_kalibr_and_ros() {
    let r = rig(CameraModel::BrownConrady4, CameraModel::BrownConrady4);
    let options = ExportOptions::new(Some(0.0), 0.001).unwrap();
    let text = &export_texts(&Calibrated::Stereo(r.clone()), Format::Kalibr, &options).unwrap()[0];
    let Calibrated::Stereo(back) = parse_calibration(text, "camchain.yaml").unwrap() else {
        panic!()
    };
    assert!((back.translation - r.translation * 0.001).norm() < 1e-15);
    let ros = export_texts(&Calibrated::Stereo(r.clone()), Format::Ros, &options).unwrap();
    let v: serde_norway::Value = serde_norway::from_str(&ros[1]).unwrap();
    let p: Vec<f64> = v["projection_matrix"]["data"]
        .as_sequence()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    // ROS's baseline: -P[0][3] / P[0][0], in metres here.
    let baseline = -p[3] / p[0];
    assert!(
        (baseline - r.translation.norm() * 0.001).abs() < 1e-12,
        "{baseline}"
    );
    assert!(ExportOptions::new(Some(0.0), 0.0).is_err());
    assert!(ExportOptions::new(Some(1.5), 1.0).is_err());
}

/// OpenCV's FileStorage YAML reader refuses a block sequence written at its key's indentation
/// ("Incorrect indentation"), which plain YAML allows: every sequence item of an export is
/// indented deeper than its key, so `cv2.FileStorage` reads the Kalibr camchain too.
#[test]
fn sequence_items_are_indented_below_their_key_for_opencv_filestorage() {
    let r = rig(CameraModel::BrownConrady4, CameraModel::KannalaBrandt4);
    for format in [Format::OpenCv, Format::Ros, Format::Kalibr] {
        for text in export_texts(
            &Calibrated::Stereo(r.clone()),
            format,
            &ExportOptions::default(),
        )
        .unwrap()
        {
            let indent = |line: &str| line.len() - line.trim_start().len();
            let mut key_indent = 0;
            for line in text.lines() {
                if line.trim_start().starts_with("- ") {
                    assert!(indent(line) > key_indent, "{format:?}: {line:?}\n{text}");
                } else if line.trim_end().ends_with(':') {
                    key_indent = indent(line);
                }
            }
        }
    }
}

#[test]
fn ros_stereo_writes_one_file_per_camera_and_files_are_replaced_atomically() {
    let dir = std::env::temp_dir().join(format!("calib-export-formats-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let r = Calibrated::Stereo(rig(
        CameraModel::KannalaBrandt4,
        CameraModel::KannalaBrandt4,
    ));
    let written = export(
        &r,
        Format::Ros,
        &dir.join("rig.yaml"),
        &ExportOptions::default(),
    )
    .unwrap();
    assert_eq!(
        written,
        vec![dir.join("rig-left.yaml"), dir.join("rig-right.yaml")]
    );
    for path in &written {
        let Calibrated::Single(c) = read_calibration(path).unwrap() else {
            panic!()
        };
        assert_eq!(c.camera.model, CameraModel::KannalaBrandt4);
    }
    // A failing export (unsupported model) leaves the previous file untouched.
    let before = std::fs::read_to_string(&written[0]).unwrap();
    let bad = Calibrated::Stereo(rig(CameraModel::ThinPrism12, CameraModel::ThinPrism12));
    assert!(
        export(
            &bad,
            Format::Ros,
            &dir.join("rig.yaml"),
            &ExportOptions::default()
        )
        .is_err()
    );
    assert_eq!(std::fs::read_to_string(&written[0]).unwrap(), before);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_files_are_typed_errors_naming_file_and_key() {
    let good = export_texts(
        &Calibrated::Single(camera(CameraModel::BrownConrady5, "c", 0.0)),
        Format::OpenCv,
        &ExportOptions::default(),
    )
    .unwrap()
    .remove(0);
    let cases: Vec<(String, &str)> = vec![
        (
            good.replace("rows: 3\n   cols: 3", "rows: 2\n   cols: 3"),
            "camera_matrix",
        ),
        (
            good.replace("image_width: 640", "image_width: -640"),
            "image_width",
        ),
        (
            good.replace("\"brown-conrady5\"", "\"pinhole-radial9\""),
            "distortion_model",
        ),
        (
            good.replace("cols: 5", "cols: 6"),
            "distortion_coefficients",
        ),
        (
            "%YAML:1.0\n---\ncamera_matrix: [1, 2\n".to_string(),
            "bad.yaml",
        ),
        (
            "{\"format\": \"something-else/1\"}".to_string(),
            "not a calibration file",
        ),
        (
            "cam0:\n  camera_model: pinhole\n  intrinsics: [1, 2, 3]\n".to_string(),
            "cam0.intrinsics",
        ),
        ("a: 1\n".to_string(), "not a calibration file"),
    ];
    for (text, expected) in cases {
        let err = parse_calibration(&text, "bad.yaml").unwrap_err();
        let message = err.to_string();
        assert!(
            message.contains("bad.yaml") && message.contains(expected),
            "{message} (expected '{expected}')"
        );
    }
    // A zero focal length and a non-finite coefficient are refused on export.
    let mut c = camera(CameraModel::BrownConrady4, "c", 0.0);
    c.camera.intrinsics.fx = 0.0;
    assert!(matches!(
        export_texts(
            &Calibrated::Single(c),
            Format::OpenCv,
            &ExportOptions::default()
        ),
        Err(ExportError::Invalid { .. })
    ));
    let mut c = camera(CameraModel::BrownConrady4, "c", 0.0);
    c.camera.distortion[1] = f64::NAN;
    assert!(
        export_texts(
            &Calibrated::Single(c),
            Format::Kalibr,
            &ExportOptions::default()
        )
        .is_err()
    );
}

#[test]
fn result_json_files_are_read_like_exports() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/sourishg1/left.json");
    let obs = <calib_single::Observations as calib_core::JsonFile>::read(&path).unwrap();
    let result =
        calib_single::calibrate(&obs, &calib_single::CalibrationOptions::default()).unwrap();
    let text = serde_json::to_string(&result.to_json()).unwrap();
    let Calibrated::Single(c) = parse_calibration(&text, "left-result.json").unwrap() else {
        panic!()
    };
    assert_eq!(c.camera, result.camera);
    assert_eq!(c.image_size, result.image_size);
}

/// A rig of four cameras (models mixed, the reference not first, names a file system would
/// mangle) with transforms far from the identity.
fn four_camera_rig(models: [CameraModel; 4]) -> calib_export::CameraRig {
    let names = ["front left", "front/right", "back", "top"];
    let cameras = models
        .iter()
        .zip(names)
        .enumerate()
        .map(|(i, (&m, n))| camera(m, n, 0.1 + 0.27 * i as f64))
        .collect();
    let reference = 1;
    let transforms = (0..4)
        .map(|i| {
            if i == reference {
                camera_model::Pose::identity()
            } else {
                let a = i as f64;
                camera_model::Pose::new(
                    AxisAngle::matrix(&Vector3::new(0.3 * a - 0.1, 1.2 - 0.7 * a, 0.05 * a)),
                    Vector3::new(-93.8412 * a, 11.9213 - a, 42.8511 * a - 70.0),
                )
            }
        })
        .collect();
    calib_export::CameraRig::new(cameras, transforms, reference).unwrap()
}

/// `a` and `b` describe the same rig: cameras bit for bit, and every camera's transform
/// relative to every other within `tolerance` (rotation entries; translations relative to the
/// rig's size): Kalibr's chain composes transforms, which rounds.
fn same_rig(a: &calib_export::CameraRig, b: &calib_export::CameraRig, tolerance: f64, what: &str) {
    assert_eq!(a.cameras.len(), b.cameras.len(), "{what}");
    for (x, y) in a.cameras.iter().zip(&b.cameras) {
        same_camera(x, y, what);
    }
    let size = a
        .transforms
        .iter()
        .map(|t| t.translation.norm())
        .fold(1.0, f64::max);
    for i in 0..a.cameras.len() {
        for j in 0..a.cameras.len() {
            let (p, q) = (a.relative(i, j), b.relative(i, j));
            let dr = (p.rotation - q.rotation).amax();
            let dt = (p.translation - q.translation).amax() / size;
            assert!(
                dr <= tolerance && dt <= tolerance,
                "{what}: camera {i} to {j}: rotation {dr:e}, translation {dt:e}"
            );
        }
    }
}

#[test]
fn rigs_round_trip_through_opencv_and_kalibr_and_give_one_ros_file_per_camera() {
    let options = ExportOptions::default();
    let bc4 = [CameraModel::BrownConrady4; 4];
    let mixed = [
        CameraModel::BrownConrady4,
        CameraModel::KannalaBrandt4,
        CameraModel::BrownConrady4,
        CameraModel::KannalaBrandt4,
    ];
    let all = [
        CameraModel::ThinPrism12,
        CameraModel::Rational8,
        CameraModel::BrownConrady5,
        CameraModel::KannalaBrandt4,
    ];
    // OpenCV holds every model, and the rig as written (same reference, same transforms).
    for models in [bc4, mixed, all] {
        let rig = four_camera_rig(models);
        let calibrated = Calibrated::Rig(rig.clone());
        let text = &export_texts(&calibrated, Format::OpenCv, &options).unwrap()[0];
        assert!(text.starts_with("%YAML:1.0\n---\nrig_cameras: 4\nreference_camera: 1\n"));
        let Calibrated::Rig(back) = parse_calibration(text, "rig.yaml").unwrap() else {
            panic!("not read back as a rig")
        };
        assert_eq!(back, rig, "opencv {models:?}");
    }
    // Kalibr: a chain from cam0 (its reference), radtan and equidistant only.
    let rig = four_camera_rig(mixed);
    let calibrated = Calibrated::Rig(rig.clone());
    let text = &export_texts(&calibrated, Format::Kalibr, &options).unwrap()[0];
    for k in 0..4 {
        assert!(text.contains(&format!("\ncam{k}:\n")) || text.starts_with("cam0:\n"));
    }
    assert_eq!(text.matches("T_cn_cnm1").count(), 3);
    let Calibrated::Rig(back) = parse_calibration(text, "camchain.yaml").unwrap() else {
        panic!("not read back as a rig")
    };
    assert_eq!(back.reference, 0);
    for (c, original) in back.cameras.iter().zip(&rig.cameras) {
        let renamed = CameraCalibration {
            name: c.name.clone(),
            ..original.clone()
        };
        same_camera(&renamed, c, "kalibr");
    }
    // Names travel in the topics (`/back/image_raw`); one that cannot be a topic segment
    // ("front left", "front/right") is written and read back as its key.
    assert!(
        text.contains("rostopic: /back/image_raw") && text.contains("rostopic: /cam0/image_raw")
    );
    let names: Vec<&str> = back.cameras.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["cam0", "cam1", "back", "top"]);
    let mut renamed = rig.clone();
    for (c, n) in renamed.cameras.iter_mut().zip(&names) {
        c.name = n.to_string();
    }
    same_rig(&renamed, &back, 1e-14, "kalibr");
    // A model Kalibr cannot hold names the camera.
    let err = export_texts(
        &Calibrated::Rig(four_camera_rig(all)),
        Format::Kalibr,
        &options,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("front left") && err.contains("cam0"), "{err}");
    // ROS: one camera_info per camera, file names from the camera names.
    let rig = four_camera_rig(bc4);
    let calibrated = Calibrated::Rig(rig.clone());
    let paths =
        calib_export::export_paths(&calibrated, Format::Ros, std::path::Path::new("d/ros.yaml"));
    let files: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    assert_eq!(
        files,
        [
            "d/ros-front_left.yaml",
            "d/ros-front_right.yaml",
            "d/ros-back.yaml",
            "d/ros-top.yaml"
        ]
    );
    // A name that cannot be a file name falls back for that camera only, never to another
    // camera's name (an audit found "cam2" written to ros-cam0.yaml when one name was hidden).
    let mut awkward = rig.clone();
    for (c, name) in awkward
        .cameras
        .iter_mut()
        .zip(["cam2", "left/front", ".hidden", "cam0"])
    {
        c.name = name.into();
    }
    let paths = calib_export::export_paths(
        &Calibrated::Rig(awkward),
        Format::Ros,
        std::path::Path::new("d/ros.yaml"),
    );
    let files: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    assert_eq!(
        files,
        [
            "d/ros-cam2.yaml",
            "d/ros-left_front.yaml",
            "d/ros-cam2_.yaml",
            "d/ros-cam0.yaml"
        ]
    );
    let texts = export_texts(&calibrated, Format::Ros, &options).unwrap();
    assert_eq!(texts.len(), 4);
    for (text, original) in texts.iter().zip(&rig.cameras) {
        let Calibrated::Single(c) = parse_calibration(text, "ros.yaml").unwrap() else {
            panic!("a ROS file is one camera")
        };
        assert_eq!(&c, original);
    }
}

#[test]
fn a_pair_of_a_rig_is_the_stereo_rig_between_the_two_cameras() {
    let rig = four_camera_rig([CameraModel::BrownConrady5; 4]);
    for (l, r) in [(0, 2), (2, 0), (1, 3), (3, 1)] {
        let pair = rig.pair(l, r).unwrap();
        assert_eq!(pair.left, rig.cameras[l]);
        assert_eq!(pair.right, rig.cameras[r]);
        // X_r = R X_l + T for a point given in the reference frame.
        let x_ref = Vector3::new(12.5, -40.0, 900.0);
        let x_l = rig.transforms[l].rotation * x_ref + rig.transforms[l].translation;
        let x_r = rig.transforms[r].rotation * x_ref + rig.transforms[r].translation;
        let via_pair = pair.rotation * x_l + pair.translation;
        assert!((via_pair - x_r).norm() < 1e-9 * x_r.norm(), "{l} {r}");
    }
    assert!(rig.pair(1, 1).is_err());
    assert!(rig.pair(0, 4).is_err());
    assert!(
        rig.camera_index("nobody")
            .unwrap_err()
            .to_string()
            .contains("front left, front/right, back, top")
    );
}

#[test]
fn bad_rigs_and_rig_files_are_refused_by_name() {
    let good = four_camera_rig([CameraModel::BrownConrady4; 4]);
    let mut twice = good.clone();
    twice.cameras[3].name = "back".into();
    assert!(
        twice
            .check()
            .unwrap_err()
            .to_string()
            .contains("'back' is used twice")
    );
    let mut moved = good.clone();
    moved.transforms[1].translation.x = 1.0;
    assert!(moved.check().unwrap_err().to_string().contains("identity"));
    let mut sheared = good.clone();
    sheared.transforms[2].rotation[(0, 1)] += 0.01;
    assert!(
        sheared
            .check()
            .unwrap_err()
            .to_string()
            .contains("camera 'back'")
    );
    // A camchain with a gap in its numbering.
    let text = &export_texts(
        &Calibrated::Rig(good.clone()),
        Format::Kalibr,
        &ExportOptions::default(),
    )
    .unwrap()[0];
    let gap = text.replace("cam2:", "cam5:");
    let err = parse_calibration(&gap, "gap.yaml").unwrap_err().to_string();
    assert!(
        err.contains("gap.yaml") && err.contains("cam2 is missing"),
        "{err}"
    );
    // An OpenCV rig file missing a camera's key.
    let text = &export_texts(
        &Calibrated::Rig(good),
        Format::OpenCv,
        &ExportOptions::default(),
    )
    .unwrap()[0];
    let cut = text.replace("   R: !!opencv-matrix", "   Rot: !!opencv-matrix");
    let err = parse_calibration(&cut, "cut.yaml").unwrap_err().to_string();
    assert!(
        err.contains("cut.yaml") && err.contains("camera_0.R"),
        "{err}"
    );
}

/// A Kalibr camchain holds no camera names: they travel in the topics. A stereo rig written as a
/// chain reads back as 'left' and 'right' (it read back as 'cam0' and 'cam1'); two cameras on
/// one topic cannot be told apart by it and keep their keys.
#[test]
fn kalibr_camera_names_travel_in_the_topics() {
    let calibrated =
        Calibrated::Stereo(rig(CameraModel::BrownConrady4, CameraModel::BrownConrady4));
    let text = &export_texts(&calibrated, Format::Kalibr, &ExportOptions::default()).unwrap()[0];
    let Calibrated::Stereo(back) = parse_calibration(text, "camchain.yaml").unwrap() else {
        panic!("not read back as a stereo rig")
    };
    assert_eq!(
        (back.left.name.as_str(), back.right.name.as_str()),
        ("left", "right")
    );
    let same = text.replace("/right/image_raw", "/left/image_raw");
    let Calibrated::Stereo(back) = parse_calibration(&same, "camchain.yaml").unwrap() else {
        panic!("not read back as a stereo rig")
    };
    assert_eq!(
        (back.left.name.as_str(), back.right.name.as_str()),
        ("cam0", "cam1")
    );
}

/// A rig whose lens folds inside the image (k1 = -2: r (1 + k1 r^2) turns back at r = 0.41,
/// the image corners are at 0.79) cannot be rectified; its calibration is valid: the OpenCV
/// file holds M1 ... F, a comment instead of R1 ... Q, reads back exactly, and the export names
/// the omission. ROS camera_info, which is the rectification, is refused.
#[test]
fn a_rig_that_cannot_be_rectified_is_written_without_rectification_for_opencv_only() {
    let mut r = rig(CameraModel::BrownConrady4, CameraModel::BrownConrady4);
    r.left.camera.distortion = vec![-2.0, 0.5, 0.0, 0.0];
    assert!(calib_export::stereo_rectify(&r, Some(0.0)).is_err());
    let original = Calibrated::Stereo(r.clone());
    let rendered =
        calib_export::render_export(&original, Format::OpenCv, &ExportOptions::default()).unwrap();
    let text = &rendered.texts[0];
    for key in ["R1", "R2", "P1", "P2", "Q"] {
        assert!(!text.contains(&format!("\n{key}: ")), "{key}");
    }
    assert!(
        comment(text).starts_with("R1, R2, P1, P2, Q (the rectification) are left out: they cannot be computed for this calibration (rectifying camera 'left'"),
        "{text}"
    );
    assert_eq!(rendered.omissions.len(), 1);
    assert!(
        rendered.omissions[0].starts_with("written without the rectification"),
        "{:?}",
        rendered.omissions
    );
    match read_back(Format::OpenCv, &original, &rendered.texts) {
        Calibrated::Stereo(back) => {
            same_camera(&back.left, &r.left, "left");
            same_camera(&back.right, &r.right, "right");
            assert_eq!(back.rotation, r.rotation);
        }
        other => panic!("{other:?}"),
    }
    // A bad alpha stays an error, not an omission.
    let mut options = ExportOptions::default();
    options.alpha = Some(2.0);
    assert!(export_texts(&original, Format::OpenCv, &options).is_err());
    let err = export_texts(&original, Format::Ros, &ExportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("ROS camera_info files of a stereo pair need its rectification")
            && err.contains("--format opencv"),
        "{err}"
    );
    // A rig that rectifies has no omission.
    let good = Calibrated::Stereo(rig(CameraModel::BrownConrady4, CameraModel::BrownConrady4));
    let rendered =
        calib_export::render_export(&good, Format::OpenCv, &ExportOptions::default()).unwrap();
    assert!(rendered.omissions.is_empty() && rendered.texts[0].contains("\nQ: "));
}
