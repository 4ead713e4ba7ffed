//! The `calib` binary as a user runs it.

use std::process::Command;

fn calib() -> Command {
    Command::new(env!("CARGO_BIN_EXE_calib"))
}

fn data(path: &str) -> String {
    format!("{}/../../data/{path}", env!("CARGO_MANIFEST_DIR"))
}

/// Runs the command and checks that it succeeded, showing its stderr otherwise.
fn run_ok(command: &mut Command) -> std::process::Output {
    let run = command.output().unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    run
}

/// `name` in this test binary's scratch directory, `target/tmp/calib-cli-cli` (kept after
/// the run to look at, emptied once when the next run first asks for it, so a test never sees
/// a file of an earlier run).
fn temp(name: &str) -> std::path::PathBuf {
    static EMPTIED: std::sync::Once = std::sync::Once::new();
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("calib-cli-cli");
    EMPTIED.call_once(|| {
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
    });
    dir.join(name)
}

#[test]
fn single_on_real_data_prints_a_summary_and_writes_json() {
    let out = temp("left.json");
    let run = run_ok(
        calib()
            .args(["single", &data("sourishg1/left.json"), "-o"])
            .arg(&out),
    );
    let summary = String::from_utf8(run.stdout).unwrap();
    assert!(
        summary.contains("focal length")
            && summary.contains("+-")
            && summary.contains("worst views"),
        "{summary}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let rms = json["rms"].as_f64().unwrap();
    assert!(rms > 0.1 && rms < 0.2, "{rms}");
    assert_eq!(json["views"].as_array().unwrap().len(), 29);
    assert!(json["elapsed_seconds"].as_f64().unwrap() > 0.0);
}

#[test]
fn bad_input_exits_non_zero_with_one_line() {
    let run = calib()
        .args(["single", "/nonexistent/obs.json"])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let err = String::from_utf8(run.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("calib: "), "{err}");

    // A view with three points.
    let bad = temp("bad.json");
    std::fs::write(
        &bad,
        r#"{"image_size":[640,480],"views":[{"image":"a","object_points":[[0,0,0],[1,0,0],[0,1,0]],"image_points":[[1,1],[2,1],[1,2]]}]}"#,
    )
    .unwrap();
    let run = calib().arg("single").arg(&bad).output().unwrap();
    assert_eq!(run.status.code(), Some(1));
    let err = String::from_utf8(run.stderr).unwrap();
    // The view is named by its image (view numbers count the views given, not the files).
    assert!(err.contains("view 0 (a): 3 points, at least 4"), "{err}");

    let run = calib()
        .args(["single", &data("sourishg1/left.json"), "--fix", "k7"])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let run = calib().args(["single"]).output().unwrap();
    assert_eq!(
        run.status.code(),
        Some(2),
        "usage errors come from the argument parser"
    );
}

#[test]
fn synth_then_calibrate_recovers_the_truth() {
    let file = temp("synth.json");
    run_ok(
        calib()
            .args([
                "synth", "single", "--views", "15", "--noise", "0.1", "--seed", "4", "-o",
            ])
            .arg(&file),
    );
    let result = calib()
        .arg("single")
        .arg(&file)
        .args(["--quiet", "--threads", "1", "-o", "-"])
        .output()
        .unwrap();
    assert!(result.status.success());
    assert!(
        result.stdout.starts_with(b"{"),
        "quiet mode prints only the JSON"
    );
    let json: serde_json::Value = serde_json::from_slice(&result.stdout).unwrap();
    let input: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let (fx, truth) = (
        json["camera"]["fx"].as_f64().unwrap(),
        input["truth"]["fx"].as_f64().unwrap(),
    );
    let sigma = json["camera"]["std"]["fx"].as_f64().unwrap();
    assert!(
        (fx - truth).abs() < 4.0 * sigma,
        "{fx} vs {truth} (sigma {sigma})"
    );
}

#[test]
fn options_reach_the_library() {
    let run = calib()
        .args([
            "single",
            &data("sourishg1/left.json"),
            "--fix-principal-point",
            "--zero-tangential",
            "--quiet",
            "-o",
            "-",
        ])
        .output()
        .unwrap();
    assert!(run.status.success());
    let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(json["camera"]["cx"].as_f64().unwrap(), 319.5);
    assert_eq!(json["camera"]["distortion"]["p1"].as_f64().unwrap(), 0.0);
    let fixed: Vec<&str> = json["camera"]["fixed_parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(fixed, ["cx", "cy", "p1", "p2"]);
}

#[test]
fn stereo_on_real_data_and_synthetic_rigs() {
    let out = temp("stereo.json");
    let run = run_ok(
        calib()
            .args(["stereo", &data("sourishg1/stereo.json"), "-o"])
            .arg(&out),
    );
    let summary = String::from_utf8(run.stdout).unwrap();
    assert!(
        summary.contains("baseline") && summary.contains("right camera"),
        "{summary}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    for key in [
        "R",
        "T",
        "E",
        "F",
        "rotation_vector",
        "euler_xyz",
        "baseline",
        "rig_std",
        "left",
        "right",
        "pairs",
    ] {
        assert!(json.get(key).is_some(), "missing {key}");
    }
    assert_eq!(json["pairs"].as_array().unwrap().len(), 29);

    let file = temp("synth-stereo.json");
    run_ok(
        calib()
            .args([
                "synth",
                "stereo",
                "--views",
                "8",
                "--noise",
                "0",
                "--rig",
                "0,0.05,0,-120,0,0",
                "-o",
            ])
            .arg(&file),
    );
    let run = run_ok(calib().arg("stereo").arg(&file).args([
        "--quiet",
        "--same-focal-length",
        "--fix-right-intrinsics",
        "-o",
        "-",
    ]));
    let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    // Every right parameter held but fx, fy: shared with the left camera, estimated there.
    assert_eq!(
        json["right"]["fixed_parameters"],
        serde_json::json!(["cx", "cy", "k1", "k2", "p1", "p2"])
    );
    assert_eq!(json["left"]["fx"], json["right"]["fx"]);

    let run = calib()
        .arg("stereo")
        .arg(&file)
        .args(["--quiet", "-o", "-"])
        .output()
        .unwrap();
    let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert!((json["baseline"].as_f64().unwrap() - 120.0).abs() < 1e-6);
    assert!(json["rms"].as_f64().unwrap() < 1e-6);

    // A pair whose right view has a point less than its left view.
    let mut bad: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    bad["pairs"][2]["right_points"]
        .as_array_mut()
        .unwrap()
        .pop();
    let bad_file = temp("bad-stereo.json");
    std::fs::write(&bad_file, bad.to_string()).unwrap();
    let run = calib().arg("stereo").arg(&bad_file).output().unwrap();
    assert_eq!(run.status.code(), Some(1));
    let err = String::from_utf8(run.stderr).unwrap();
    assert!(err.contains("pair 2"), "{err}");
}

/// A result never replaces its input, a failed run leaves a previous result intact, and a
/// closed pipe is an error, not a panic.
#[test]
fn outputs_are_safe() {
    let input = temp("input.json");
    std::fs::copy(data("sourishg1/left.json"), &input).unwrap();
    let before = std::fs::read(&input).unwrap();
    // The same file, spelled differently.
    let dir = input.parent().unwrap();
    let alias = dir.join(".").join("input.json");
    let run = calib()
        .args(["single", "-q"])
        .arg(&input)
        .arg("-o")
        .arg(&alias)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let err = String::from_utf8(run.stderr).unwrap();
    assert!(err.contains("input file"), "{err}");
    assert_eq!(std::fs::read(&input).unwrap(), before);

    // A previous result survives a failing calibration.
    let out = temp("previous.json");
    std::fs::write(&out, "previous").unwrap();
    let bad = temp("bad.json");
    std::fs::write(&bad, r#"{"image_size": [640, 480], "views": []}"#).unwrap();
    let run = calib()
        .args(["single", "-q"])
        .arg(&bad)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "previous");

    // Writing the summary into a closed pipe.
    let mut child = calib()
        .args(["single", &data("sourishg1/left.json")])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let run = child.wait_with_output().unwrap();
    let err = String::from_utf8(run.stderr).unwrap();
    assert!(!err.contains("panicked"), "{err}");
    assert_ne!(run.status.code(), Some(101), "{err}");

    // Oversized input and absurd repeat counts are refused.
    let run = calib()
        .args([
            "single",
            &data("sourishg1/left.json"),
            "--max-input-mb",
            "0",
        ])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let run = calib()
        .args([
            "single",
            &data("sourishg1/left.json"),
            "--repeat",
            "99999999",
        ])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
}

/// Outlier rejection and the robust loss are reachable from the command line, and warnings
/// reach stderr when the summary is off.
#[test]
fn outlier_options_and_warnings() {
    let synth = temp("stray.json");
    run_ok(
        calib()
            .args(["synth", "single", "--seed", "4", "-o"])
            .arg(&synth),
    );
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&synth).unwrap()).unwrap();
    json["views"][2]["image_points"][10][0] =
        serde_json::json!(json["views"][2]["image_points"][10][0].as_f64().unwrap() + 30.0);
    std::fs::write(&synth, json.to_string()).unwrap();
    let out = temp("stray-result.json");
    let run = run_ok(
        calib()
            .args(["single", "-q"])
            .arg(&synth)
            .arg("-o")
            .arg(&out),
    );
    let err = String::from_utf8(run.stderr).unwrap();
    assert!(err.contains("outliers-rejected"), "{err}");
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(result["num_rejected"], 1);
    assert_eq!(result["views"][2]["rejected_points"][0], 10);
    assert_eq!(result["warnings"][0]["code"], "outliers-rejected");

    for extra in [
        &["--no-outlier-rejection"][..],
        &[
            "--no-outlier-rejection",
            "--loss",
            "cauchy",
            "--loss-scale",
            "0.5",
        ][..],
    ] {
        run_ok(
            calib()
                .args(["single", "-q"])
                .arg(&synth)
                .args(extra)
                .arg("-o")
                .arg(&out),
        );
        let result: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        assert_eq!(result["num_rejected"], 0, "{extra:?}");
    }
    let run = calib()
        .args(["single", "-q"])
        .arg(&synth)
        .args(["--outlier-threshold", "0.5"])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
}

/// From photographs to a calibration in one command, and the corners alone with overlays: every
/// bundled board is found, and the calibration from our corners reaches the RMS the issue asks
/// for (at or below 0.170 px on sourishg1 left, where OpenCV's best corners give 0.172).
#[test]
fn photographs_to_calibration() {
    let images: Vec<String> = (1..=29)
        .map(|i| data(&format!("sourishg1/images/left{i}.jpg")))
        .collect();
    let out = temp("from-images.json");
    run_ok(
        calib()
            .args(["single", "-q", "--board", "9x6", "--square", "24.23"])
            .args(&images)
            .arg("-o")
            .arg(&out),
    );
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(result["num_views"], 29);
    let rms = result["rms"].as_f64().unwrap();
    assert!(rms <= 0.170, "{rms}");

    // Corners only, with overlays, plus an image without a board.
    let blank = temp("blank.png");
    board_detect::image::GrayImage::from_pixel(64, 48, board_detect::image::Luma([128]))
        .save(&blank)
        .unwrap();
    let corners = temp("corners.json");
    let draw = temp("drawn");
    let run = run_ok(
        calib()
            .args(["detect", "--board", "9x6", "--square", "24.23"])
            .args(&images[..3])
            .arg(&blank)
            .arg("-o")
            .arg(&corners)
            .arg("--draw")
            .arg(&draw),
    );
    let summary = String::from_utf8(run.stderr).unwrap();
    assert!(summary.contains("3 of 4 images"), "{summary}");
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&corners).unwrap()).unwrap();
    assert_eq!(file["views"].as_array().unwrap().len(), 3);
    assert_eq!(file["views"][0]["image"], "left1.jpg");
    assert_eq!(file["rejected_images"][0]["image"], "blank.png");
    assert!(file["detection_seconds_per_image"].as_f64().unwrap() > 0.0);
    for name in ["left1.png", "left2.png", "left3.png", "blank.png"] {
        assert!(draw.join(name).exists(), "{name}");
    }
    // `calib detect` needs the board: its usage line says so, and clap refuses without it.
    let help =
        String::from_utf8(calib().args(["detect", "--help"]).output().unwrap().stdout).unwrap();
    // (IMAGE is optional in the usage line: --camera NAME IMAGE... may give the images instead.)
    assert!(help.contains("--board <COLSxROWS> [IMAGE]..."), "{help}");
    let run = calib()
        .arg("detect")
        .arg(&images[0])
        .args(["-o", "-"])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
    assert!(
        String::from_utf8(run.stderr)
            .unwrap()
            .contains("--board <COLSxROWS>")
    );

    // Stereo from photographs.
    let right: Vec<String> = (1..=29)
        .map(|i| data(&format!("sourishg1/images/right{i}.jpg")))
        .collect();
    let out = temp("stereo-from-images.json");
    run_ok(
        calib()
            .args(["stereo", "-q", "--board", "9x6", "--square", "24.23"])
            .args(&images)
            .arg("--right")
            .args(&right)
            .arg("-o")
            .arg(&out),
    );
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(result["num_pairs"], 29);
    let reference: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(data("sourishg1/reference/opencv5_stereo.json")).unwrap(),
    )
    .unwrap();
    let opencv = reference["results"]["joint_fix_k3"]["rms"]
        .as_f64()
        .unwrap();
    assert!(
        result["rms_all_points"].as_f64().unwrap() < opencv,
        "{} vs OpenCV's {opencv} from its own corners",
        result["rms_all_points"]
    );

    // Images without --board, and unequal pair counts, are explained.
    let run = calib().args(["single", &images[0]]).output().unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(String::from_utf8(run.stderr).unwrap().contains("--board"));
    let run = calib()
        .args([
            "stereo", "--board", "9x6", &images[0], &images[1], "--right", &right[0],
        ])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(
        String::from_utf8(run.stderr)
            .unwrap()
            .contains("counts must be equal")
    );
}

#[test]
fn after_calibration_exports_read_back_undistort_and_rectify() {
    let rig = temp("after-rig.json");
    let yaml = temp("after-rig.yaml");
    let ros = temp("after-ros.yaml");
    run_ok(
        calib()
            .args(["stereo", &data("sourishg1/stereo.json"), "-q", "-o"])
            .arg(&rig)
            .arg(format!("--export=opencv={}", yaml.display()))
            .arg(format!("--export=ros={}", ros.display())),
    );
    assert!(temp("after-ros-left.yaml").exists() && temp("after-ros-right.yaml").exists());
    // Each exported file starts a calibration with its camera held fixed: the fixed
    // intrinsics are reported with zero uncertainty and the same values.
    let fixed = temp("after-fixed.json");
    run_ok(
        calib()
            .args([
                "single",
                &data("sourishg1/left.json"),
                "-q",
                "--fix-intrinsics",
                "--intrinsics",
            ])
            .arg(temp("after-ros-left.yaml"))
            .arg("-o")
            .arg(&fixed),
    );
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&fixed).unwrap()).unwrap();
    let original: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&rig).unwrap()).unwrap();
    assert_eq!(result["camera"]["fx"], original["left"]["fx"]);
    assert_eq!(result["camera"]["std"]["fx"], 0.0);
    run_ok(
        calib()
            .args([
                "stereo",
                &data("sourishg1/stereo.json"),
                "-q",
                "--fix-intrinsics",
                "--intrinsics",
            ])
            .arg(&yaml),
    );
    // Export from the result, in every format; kalibr refuses rational8 with a message.
    for format in ["opencv", "ros", "kalibr"] {
        run_ok(
            calib()
                .args(["export"])
                .arg(&rig)
                .args(["--format", format, "-q", "-o"])
                .arg(temp(&format!("after-{format}.yaml"))),
        );
    }
    let rational = temp("after-rational.json");
    run_ok(
        calib()
            .args([
                "single",
                &data("sourishg1/left.json"),
                "-q",
                "--model",
                "rational8",
                "-o",
            ])
            .arg(&rational),
    );
    let run = calib()
        .arg("export")
        .arg(&rational)
        .args(["--format", "kalibr", "-o"])
        .arg(temp("after-bad.yaml"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&run.stderr).contains("no equivalent of the rational8"));
    // Rectification JSON and images; undistorted images keep their names.
    let rect = temp("after-rect.json");
    let out = temp("after-rectified");
    run_ok(
        calib()
            .arg("rectify")
            .arg(&rig)
            .args(["-q", "-o"])
            .arg(&rect)
            .args([
                "--images",
                &data("sourishg1/images/left3.jpg"),
                "--right",
                &data("sourishg1/images/right3.jpg"),
                "--out",
            ])
            .arg(&out),
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&rect).unwrap()).unwrap();
    assert_eq!(r["P2"].as_array().unwrap().len(), 3);
    assert_eq!(r["Q"][3].as_array().unwrap().len(), 4);
    assert!(out.join("left/left3.jpg").exists() && out.join("right/right3.jpg").exists());
    // The usual layout of a rig's captures, one folder per camera with the same file names:
    // the rectified images go to left/ and right/ (it was refused as two inputs of one name).
    let (cam0, cam1) = (temp("after-cam0"), temp("after-cam1"));
    for (dir, name) in [(&cam0, "left3.jpg"), (&cam1, "right3.jpg")] {
        std::fs::create_dir_all(dir).unwrap();
        std::fs::copy(
            data(&format!("sourishg1/images/{name}")),
            dir.join("0001.jpg"),
        )
        .unwrap();
    }
    let out2 = temp("after-rectified-same-names");
    run_ok(
        calib()
            .arg("rectify")
            .arg(&rig)
            .arg("-q")
            .arg("--images")
            .arg(cam0.join("0001.jpg"))
            .arg("--right")
            .arg(cam1.join("0001.jpg"))
            .arg("--out")
            .arg(&out2),
    );
    assert_eq!(
        std::fs::read(out2.join("left/0001.jpg")).unwrap(),
        std::fs::read(out.join("left/left3.jpg")).unwrap()
    );
    assert_eq!(
        std::fs::read(out2.join("right/0001.jpg")).unwrap(),
        std::fs::read(out.join("right/right3.jpg")).unwrap()
    );
    let und = temp("after-undistorted");
    run_ok(
        calib()
            .arg("undistort")
            .arg(temp("after-ros-left.yaml"))
            .arg(data("sourishg1/images/left3.jpg"))
            .arg("-q")
            .arg("-o")
            .arg(&und),
    );
    // The opencv file of a rig is not a single camera.
    let run = calib()
        .arg("undistort")
        .arg(&yaml)
        .arg(data("sourishg1/images/left3.jpg"))
        .arg("-o")
        .arg(&und)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let single = temp("after-left.json");
    run_ok(
        calib()
            .args(["single", &data("sourishg1/left.json"), "-q", "-o"])
            .arg(&single),
    );
    run_ok(
        calib()
            .arg("undistort")
            .arg(&single)
            .arg(data("sourishg1/images/left3.jpg"))
            .args(["-q", "--alpha", "1", "-o"])
            .arg(&und),
    );
    assert!(und.join("left3.jpg").exists() && und.join("undistortion.json").exists());
    // Writing over the input image is refused.
    let images = std::path::Path::new(&data("sourishg1/images")).to_path_buf();
    let run = calib()
        .arg("undistort")
        .arg(&single)
        .arg(data("sourishg1/images/left3.jpg"))
        .arg("-o")
        .arg(&images)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&run.stderr).contains("replace the input"));

    // An image of another size is refused before anything is written: the alpha-1 image and
    // the sidecar of the run above stay as they were (the first image used to be replaced
    // before the second failed).
    let small = temp("after-small.png");
    board_detect::image::GrayImage::from_pixel(320, 180, board_detect::image::Luma([9]))
        .save(&small)
        .unwrap();
    let before = (
        std::fs::read(und.join("left3.jpg")).unwrap(),
        std::fs::read(und.join("undistortion.json")).unwrap(),
    );
    let run = calib()
        .arg("undistort")
        .arg(&single)
        .arg(data("sourishg1/images/left3.jpg"))
        .arg(&small)
        .args(["--alpha", "0", "-o"])
        .arg(&und)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let err = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(err.contains("after-small.png: 320x180 pixels"), "{err}");
    let after = (
        std::fs::read(und.join("left3.jpg")).unwrap(),
        std::fs::read(und.join("undistortion.json")).unwrap(),
    );
    assert!(before == after, "the output folder changed");
    // Rectification checks its images before writing the JSON, and wants pairs.
    let rect2 = temp("after-rect2.json");
    let run = calib()
        .arg("rectify")
        .arg(&rig)
        .arg("-o")
        .arg(&rect2)
        .args(["--images", &data("sourishg1/images/left3.jpg")])
        .arg(&small)
        .args([
            "--right",
            &data("sourishg1/images/right3.jpg"),
            &data("sourishg1/images/right4.jpg"),
            "--out",
        ])
        .arg(temp("after-rectified2"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&run.stderr).contains("after-small.png"));
    assert!(!rect2.exists() && !temp("after-rectified2").join("left/left3.jpg").exists());
    let run = calib()
        .arg("rectify")
        .arg(&rig)
        .args([
            "--images",
            &data("sourishg1/images/left3.jpg"),
            &data("sourishg1/images/left4.jpg"),
        ])
        .args(["--right", &data("sourishg1/images/right3.jpg"), "--out"])
        .arg(temp("after-rectified3"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&run.stderr).contains("2 left and 1 right images"));
    // `-o -`: the JSON (or the one exported file) alone on standard output.
    let run = run_ok(calib().arg("rectify").arg(&rig).args(["-o", "-"]));
    let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert!(json["P1"].is_array());
    assert!(String::from_utf8_lossy(&run.stderr).contains("rectified: f ="));
    let run = run_ok(
        calib()
            .arg("export")
            .arg(&single)
            .args(["--format", "opencv", "-o", "-"]),
    );
    assert!(String::from_utf8_lossy(&run.stdout).starts_with("%YAML:1.0"));
    let err = refused(&[
        "export",
        &rig.to_string_lossy(),
        "--format",
        "ros",
        "-o",
        "-",
    ]);
    assert!(err.contains("2 files"), "{err}");
    // `--export FORMAT=-` would write files named '-', '--left', '--right': refused.
    let err = refused(&[
        "single",
        &data("sourishg1/left.json"),
        "-q",
        "--export",
        "ros=-",
    ]);
    assert!(err.contains("give a file name"), "{err}");
    // The pair the other way round: the inverse transform.
    let reversed = temp("after-rect-reversed.json");
    run_ok(
        calib()
            .arg("rectify")
            .arg(&rig)
            .args(["--pair", "right,left", "-q", "--alpha", "-1", "-o"])
            .arg(&reversed),
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&reversed).unwrap()).unwrap();
    // The right camera is now the reference: the baseline points the other way (P2's x
    // translation changes sign).
    let forward: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&rect).unwrap()).unwrap();
    let tx = |v: &serde_json::Value| v["P2"][0][3].as_f64().unwrap();
    assert!(
        tx(&r) * tx(&forward) < 0.0,
        "{} vs {}",
        tx(&r),
        tx(&forward)
    );
    // Thread counts beyond the limit and alphas out of range get a message, not minutes of
    // thread creation or clap's "unexpected argument '-1'".
    let (single_path, und_path) = (single.to_string_lossy(), und.to_string_lossy());
    let left3 = data("sourishg1/images/left3.jpg");
    let undistort = |option: &str, value: &str, code: i32| {
        refused_with(
            code,
            &[
                "undistort",
                &single_path,
                &left3,
                "-o",
                &und_path,
                option,
                value,
            ],
        )
    };
    let err = undistort("--threads", "100000", 2);
    assert!(err.contains("0 (every core) to 1024"), "{err}");
    let err = undistort("--alpha", "-1", 1);
    assert!(err.contains("--alpha -1: expected 0"), "{err}");
}

/// Runs `calib ARGS...`, expects exit code `code` and returns stderr.
fn refused_with(code: i32, args: &[&str]) -> String {
    let run = calib().args(args).output().unwrap();
    let err = String::from_utf8(run.stderr).unwrap();
    assert_eq!(run.status.code(), Some(code), "{args:?}: {err}");
    err
}

/// `--intrinsics FILE` reads a calib result and every exported format (OpenCV, ROS, Kalibr): held
/// fixed, the camera comes back with exactly the file's numbers; as a start, it reaches the same
/// minimum as the closed-form start. calib stereo takes rigs (OpenCV, Kalibr, result) with
/// --intrinsics and single cameras (ROS's two files) with --left/--right-intrinsics.
#[test]
fn intrinsics_accepts_every_exported_format() {
    let json = |path: &std::path::Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    };
    let single = temp("intr-single.json");
    let mut command = calib();
    command
        .args(["single", &data("sourishg1/left.json"), "-q", "-o"])
        .arg(&single);
    for format in ["opencv", "ros", "kalibr"] {
        command.arg(format!(
            "--export={format}={}",
            temp(&format!("intr-single-{format}.yaml")).display()
        ));
    }
    run_ok(&mut command);
    let original = json(&single);
    let files = [
        single.clone(),
        temp("intr-single-opencv.yaml"),
        temp("intr-single-ros.yaml"),
        temp("intr-single-kalibr.yaml"),
    ];
    for file in &files {
        let out = temp("intr-fixed.json");
        run_ok(
            calib()
                .args(["single", &data("sourishg1/left.json"), "-q", "--intrinsics"])
                .arg(file)
                .arg("--fix-intrinsics")
                .arg("-o")
                .arg(&out),
        );
        let r = json(&out);
        for key in ["fx", "fy", "cx", "cy", "distortion"] {
            assert_eq!(r["camera"][key], original["camera"][key], "{file:?} {key}");
        }
        assert_eq!(r["camera"]["model"], original["camera"]["model"]);
    }
    // As a start: the same minimum.
    let out = temp("intr-start.json");
    run_ok(
        calib()
            .args(["single", &data("sourishg1/left.json"), "-q", "--intrinsics"])
            .arg(temp("intr-single-kalibr.yaml"))
            .arg("-o")
            .arg(&out),
    );
    let rms = json(&out)["rms"].as_f64().unwrap();
    assert!(
        (rms - original["rms"].as_f64().unwrap()).abs() < 1e-6,
        "{rms}"
    );
    // A wider --model starts from the file's camera padded with zeros.
    run_ok(
        calib()
            .args(["single", &data("sourishg1/left.json"), "-q", "--intrinsics"])
            .arg(temp("intr-single-ros.yaml"))
            .args(["--model", "brown-conrady5", "-o"])
            .arg(&out),
    );
    assert_eq!(json(&out)["camera"]["model"], "brown-conrady5");
    // Stereo: rigs with --intrinsics, single cameras with --left/--right-intrinsics.
    let rig = temp("intr-rig.json");
    let mut command = calib();
    command
        .args(["stereo", &data("sourishg1/stereo.json"), "-q", "-o"])
        .arg(&rig);
    for format in ["opencv", "ros", "kalibr"] {
        command.arg(format!(
            "--export={format}={}",
            temp(&format!("intr-rig-{format}.yaml")).display()
        ));
    }
    run_ok(&mut command);
    let original = json(&rig);
    let check = |args: &[std::path::PathBuf], flags: &[&str]| {
        let out = temp("intr-rig-fixed.json");
        let mut command = calib();
        command.args([
            "stereo",
            &data("sourishg1/stereo.json"),
            "-q",
            "--fix-intrinsics",
        ]);
        for (flag, file) in flags.iter().zip(args) {
            command.arg(flag).arg(file);
        }
        run_ok(command.arg("-o").arg(&out));
        let r = json(&out);
        for side in ["left", "right"] {
            for key in ["fx", "fy", "cx", "cy", "distortion"] {
                assert_eq!(r[side][key], original[side][key], "{args:?} {side} {key}");
            }
        }
    };
    check(std::slice::from_ref(&rig), &["--intrinsics"]);
    check(&[temp("intr-rig-opencv.yaml")], &["--intrinsics"]);
    check(&[temp("intr-rig-kalibr.yaml")], &["--intrinsics"]);
    check(
        &[
            temp("intr-rig-ros-left.yaml"),
            temp("intr-rig-ros-right.yaml"),
        ],
        &["--left-intrinsics", "--right-intrinsics"],
    );
    // --right-model names the right camera's model when its start comes from a file.
    let out = temp("intr-rig-model.json");
    run_ok(
        calib()
            .args([
                "stereo",
                &data("sourishg1/stereo.json"),
                "-q",
                "--right-intrinsics",
            ])
            .arg(temp("intr-rig-ros-right.yaml"))
            .args(["--right-model", "brown-conrady5", "-o"])
            .arg(&out),
    );
    let r = json(&out);
    assert_eq!(r["left"]["model"], "brown-conrady4");
    assert_eq!(r["right"]["model"], "brown-conrady5");
    // A ROS file is one camera: not a rig.
    let run = calib()
        .args(["stereo", &data("sourishg1/stereo.json"), "--intrinsics"])
        .arg(temp("intr-rig-ros-left.yaml"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&run.stderr).contains("--left-intrinsics"));
}

/// `calib report` from a result (with and without its observations) and `--report DIR` on the
/// calibrate commands write index.html and every SVG it references.
#[test]
fn reports_from_results_and_calibrate_commands() {
    let check = |dir: &std::path::Path, images: usize| {
        let page = std::fs::read_to_string(dir.join("index.html")).unwrap();
        let sources: Vec<&str> = page
            .split("<img src=\"")
            .skip(1)
            .map(|s| &s[..s.find('"').unwrap()])
            .collect();
        assert_eq!(sources.len(), images, "{sources:?}");
        for src in sources {
            let text = std::fs::read_to_string(dir.join(src)).unwrap();
            assert!(
                text.contains("<svg") && text.trim_end().ends_with("</svg>"),
                "{src}"
            );
        }
        page
    };
    let single = temp("rep-single.json");
    let dir = temp("rep-single");
    let run = run_ok(
        calib()
            .args(["single", &data("sourishg1/left.json"), "-o"])
            .arg(&single)
            .arg("--report")
            .arg(&dir),
    );
    assert!(String::from_utf8_lossy(&run.stdout).contains("index.html"));
    let page = check(&dir, 8);
    assert!(page.contains("one-to-one over the whole image") && page.contains("mrcal"));
    let dir = temp("rep-stereo");
    run_ok(
        calib()
            .args(["stereo", &data("sourishg1/stereo.json"), "-q", "--report"])
            .arg(&dir),
    );
    check(&dir, 17); // eight per camera and the rig layout
    let dir = temp("rep-cmd");
    run_ok(
        calib()
            .arg("report")
            .arg(&single)
            .args(["--observations", &data("sourishg1/left.json"), "-q", "-o"])
            .arg(&dir),
    );
    check(&dir, 8);
    let dir = temp("rep-bare");
    run_ok(
        calib()
            .arg("report")
            .arg(&single)
            .args(["-q", "-o"])
            .arg(&dir),
    );
    let page = check(&dir, 3);
    assert!(page.contains("--observations"));
    // The wrong observation file is refused; so is a report with --compare-models.
    let run = calib()
        .arg("report")
        .arg(&single)
        .args(["--observations", &data("sourishg2/left.json"), "-o"])
        .arg(temp("rep-wrong"))
        .output()
        .unwrap();
    assert_eq!(
        run.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let run = calib()
        .args([
            "single",
            &data("sourishg1/left.json"),
            "--compare-models",
            "--report",
        ])
        .arg(temp("rep-compare"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
}

/// Runs `calib ARGS...`, expects exit code 1 and returns stderr.
fn refused(args: &[&str]) -> String {
    refused_with(1, args)
}

/// Options that would be silently ignored, or applied to the wrong coefficient, are refused with
/// a message; a failing export leaves the previous result file as it was.
#[test]
fn conflicting_options_are_refused_and_failed_exports_write_nothing() {
    let left = data("sourishg1/left.json");
    for (extra, expected) in [
        (&["--model", "rational8"][..], "--model picks one"),
        (&["--distortion-guess=0.1,0,0,0"], "--distortion-guess"),
        (&["--fix", "q9"], "no compared model has a coefficient 'q9'"),
    ] {
        let mut args = vec!["single", left.as_str(), "--compare-models"];
        args.extend_from_slice(extra);
        let err = refused(&args);
        assert!(err.contains(expected), "{err}");
    }
    let err = refused(&[
        "single",
        &left,
        "--model",
        "kannala-brandt4",
        "--zero-tangential",
    ]);
    assert!(err.contains("no tangential coefficients"), "{err}");
    let err = refused(&["single", &left, "--guess", "400,nan,320,180"]);
    assert!(err.contains("value 2 of 4, 'nan'"), "{err}");

    // A start from a file and a guess: one of them would be ignored.
    let start = temp("conflict-start.json");
    run_ok(calib().args(["single", "-q", &left, "-o"]).arg(&start));
    let err = refused(&[
        "single",
        &left,
        "--intrinsics",
        start.to_str().unwrap(),
        "--guess",
        "400,400,320,180",
    ]);
    assert!(err.contains("give one or the other"), "{err}");

    // An export that cannot be written, found before or after the calibration: the previous
    // result stays.
    let out = temp("conflict-previous.json");
    std::fs::write(&out, "previous").unwrap();
    let missing_dir = temp("no-such-dir").join("x.yaml");
    let export = format!("opencv={}", missing_dir.display());
    let out_arg = out.to_str().unwrap();
    let err = refused(&["single", "-q", &left, "-o", out_arg, "--export", &export]);
    assert!(err.contains("does not exist"), "{err}");
    let kalibr = format!("kalibr={}", temp("conflict.yaml").display());
    // A model the format can never hold is refused before calibrating.
    let err = refused(&[
        "single",
        "-q",
        &left,
        "--model",
        "rational8",
        "--export",
        &kalibr,
    ]);
    assert!(err.contains("rational8"), "{err}");
    let err = refused(&[
        "single",
        "-q",
        &left,
        "--model",
        "brown-conrady5",
        "-o",
        out_arg,
        "--export",
        &kalibr,
    ]);
    assert!(err.contains("kalibr"), "{err}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "previous");
}

/// calib stereo: `--fix` holds a name in the camera whose model has it; `--fix-left-intrinsics`
/// with `--left-intrinsics FILE` holds the file's camera.
#[test]
fn stereo_holds_fixed_terms_per_camera_and_the_given_camera() {
    let stereo = data("sourishg1/stereo.json");
    let run = run_ok(calib().args([
        "stereo",
        &stereo,
        "-q",
        "--right-model",
        "kannala-brandt4",
        "--fix",
        "k4",
        "-o",
        "-",
    ]));
    let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(json["left"]["fixed_parameters"], serde_json::json!([]));
    assert_eq!(json["right"]["fixed_parameters"], serde_json::json!(["k4"]));
    // A name both models have, held in one camera only (names in OpenCV's upper case too); a
    // camera or name that does not exist.
    let run = run_ok(calib().args([
        "stereo",
        &stereo,
        "-q",
        "--model",
        "brown-conrady5",
        "--right-model",
        "kannala-brandt4",
        "--fix",
        "right=K3,k4",
        "-o",
        "-",
    ]));
    let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(json["left"]["fixed_parameters"], serde_json::json!([]));
    assert_eq!(
        json["right"]["fixed_parameters"],
        serde_json::json!(["k3", "k4"])
    );
    let err = refused(&["stereo", &stereo, "--fix", "middle=k1"]);
    assert!(err.contains("left and right"), "{err}");
    let err = refused(&["stereo", &stereo, "--fix", "left=k4"]);
    assert!(err.contains("--fix left="), "{err}");
    let err = refused(&["single", &data("sourishg1/left.json"), "--fix", "left=k1"]);
    assert!(err.contains("a value per camera"), "{err}");

    let left = temp("held-left.json");
    run_ok(
        calib()
            .args(["single", "-q", &data("sourishg1/left.json"), "-o"])
            .arg(&left),
    );
    let run = run_ok(
        calib()
            .args([
                "stereo",
                &stereo,
                "-q",
                "--fix-left-intrinsics",
                "--left-intrinsics",
            ])
            .arg(&left)
            .args(["-o", "-"]),
    );
    let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    let given: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&left).unwrap()).unwrap();
    for key in ["fx", "fy", "cx", "cy", "dist_coeffs"] {
        assert_eq!(json["left"][key], given["camera"][key], "{key}");
    }
}

/// Photographs as they come: two cameras of different resolutions, the JSON on standard
/// output, folders without a board, repeated file names, and images left out of a
/// calibration.
#[test]
fn photographs_of_mixed_cameras_names_and_failures() {
    use board_detect::image::{self, imageops};
    let left: Vec<String> = (1..=6)
        .map(|i| data(&format!("sourishg1/images/left{i}.jpg")))
        .collect();
    // The right camera at 1280x720 (the bundled right images, enlarged, as PNG).
    let big = temp("big");
    std::fs::create_dir_all(&big).unwrap();
    let right: Vec<String> = (1..=6)
        .map(|i| {
            let img = image::open(data(&format!("sourishg1/images/right{i}.jpg"))).unwrap();
            let path = big.join(format!("right{i}.png"));
            imageops::resize(&img.to_luma8(), 1280, 720, imageops::FilterType::Triangle)
                .save(&path)
                .unwrap();
            path.to_string_lossy().into_owned()
        })
        .collect();

    // Stereo with `-o -`: standard output is the JSON alone, the summary is on stderr.
    let run = run_ok(
        calib()
            .args(["stereo", "--board", "9x6", "--square", "24.23"])
            .args(&left)
            .arg("--right")
            .args(&right)
            .args(["-o", "-"]),
    );
    let result: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not JSON ({e}): {}",
            String::from_utf8_lossy(&run.stdout)
        )
    });
    assert_eq!(result["num_pairs"], 6);
    assert_eq!(result["left"]["image_size"], serde_json::json!([640, 360]));
    assert_eq!(
        result["right"]["image_size"],
        serde_json::json!([1280, 720])
    );
    let fx = |cam: &str| result[cam]["fx"].as_f64().unwrap();
    assert!(
        (fx("right") / fx("left") - 2.0).abs() < 0.1,
        "{} {}",
        fx("left"),
        fx("right")
    );
    assert!(String::from_utf8_lossy(&run.stderr).contains("6 of 6 pairs usable"));
    let obs = temp("mixed-stereo.json");
    run_ok(
        calib()
            .args(["detect", "-q", "--board", "9x6"])
            .args(&left)
            .arg("--right")
            .args(&right)
            .arg("-o")
            .arg(&obs),
    );
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&obs).unwrap()).unwrap();
    assert_eq!(file["pairs"].as_array().unwrap().len(), 6);
    assert_eq!(file["right_image_size"], serde_json::json!([1280, 720]));

    // Single camera with `-o -` and an export: the JSON alone on stdout.
    let yaml = temp("mixed-left.yaml");
    let run = run_ok(
        calib()
            .args(["single", "--board", "9x6"])
            .args(&left)
            .args(["-o", "-", "--export"])
            .arg(format!("opencv={}", yaml.display())),
    );
    let result: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(result["num_views"], 6);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("focal length") && stderr.contains("wrote"),
        "{stderr}"
    );

    // No board anywhere: exit 1 with the count and the reasons, and an existing output kept.
    let blank = temp("mixed-blank.png");
    image::GrayImage::from_pixel(64, 48, image::Luma([128]))
        .save(&blank)
        .unwrap();
    let missing = temp("no-such-image.jpg");
    let kept = temp("kept.json");
    std::fs::write(&kept, "{\"kept\": true}\n").unwrap();
    let run = calib()
        .args(["detect", "--board", "9x6"])
        .arg(&blank)
        .arg(&missing)
        .arg("-o")
        .arg(&kept)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let message = String::from_utf8_lossy(&run.stderr);
    for part in [
        "no board found in any of the 2 images",
        "mixed-blank.png: no board found",
        "no-such-image.jpg: cannot read",
    ] {
        assert!(message.contains(part), "{message}");
    }
    assert_eq!(
        std::fs::read_to_string(&kept).unwrap(),
        "{\"kept\": true}\n"
    );
    let run = calib()
        .args(["single", "--board", "9x6"])
        .arg(&missing)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let message = String::from_utf8_lossy(&run.stderr);
    assert!(
        message.contains("no board found in the image (")
            && message.contains("cannot read")
            && !message.contains("principal point"),
        "{message}"
    );

    // Images of one name from two folders (and x.jpg beside x.png): an overlay each, and
    // names in the observation file that tell them apart.
    let (cam0, cam1) = (temp("cam0"), temp("cam1"));
    std::fs::create_dir_all(&cam0).unwrap();
    std::fs::create_dir_all(&cam1).unwrap();
    let mut same_left = Vec::new();
    let mut same_right = Vec::new();
    for i in 1..=2 {
        let (l, r) = (cam0.join(format!("{i}.jpg")), cam1.join(format!("{i}.jpg")));
        std::fs::copy(&left[i - 1], &l).unwrap();
        std::fs::copy(data(&format!("sourishg1/images/right{i}.jpg")), &r).unwrap();
        same_left.push(l);
        same_right.push(r);
    }
    let draw = temp("mixed-drawn");
    run_ok(
        calib()
            .args(["detect", "-q", "--board", "9x6"])
            .args(&same_left)
            .arg("--right")
            .args(&same_right)
            .arg("-o")
            .arg(temp("same-names.json"))
            .arg("--draw")
            .arg(&draw),
    );
    for name in ["left/1.png", "left/2.png", "right/1.png", "right/2.png"] {
        assert!(draw.join(name).exists(), "{name}");
    }
    let x_png = temp("x.png");
    image::open(&left[0]).unwrap().save(&x_png).unwrap();
    let x_jpg = temp("x.jpg");
    std::fs::copy(&left[1], &x_jpg).unwrap();
    let single_draw = temp("mixed-drawn-single");
    run_ok(
        calib()
            .args(["detect", "-q", "--board", "9x6"])
            .arg(&x_jpg)
            .arg(&x_png)
            .arg(&same_left[0])
            .arg(cam1.join("1.jpg"))
            .arg("-o")
            .arg(temp("x.json"))
            .arg("--draw")
            .arg(&single_draw),
    );
    for name in ["x.png", "x-2.png", "1.png", "1-2.png"] {
        assert!(single_draw.join(name).exists(), "{name}");
    }
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(temp("x.json")).unwrap()).unwrap();
    let names: Vec<&str> = file["views"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["image"].as_str().unwrap())
        .collect();
    assert_eq!(names[..2], ["x.jpg", "x.png"]);
    assert!(
        names[2].ends_with("cam0/1.jpg") && names[3].ends_with("cam1/1.jpg"),
        "{names:?}"
    );

    // Images left out of a calibration are in the result and warned about, also with -q.
    let out = temp("mixed-skipped.json");
    let run = run_ok(
        calib()
            .args(["single", "-q", "--board", "9x6"])
            .args(&left)
            .arg(&blank)
            .arg("-o")
            .arg(&out),
    );
    assert!(
        String::from_utf8_lossy(&run.stderr).contains("[images-skipped]: 1 of 7 images"),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!(
        result["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w["code"] == "images-skipped")
    );
    assert_eq!(result["rejected_images"][0]["image"], "mixed-blank.png");
    assert_eq!(result["rejected_images"][0]["reason"], "no board found");
    let out = temp("mixed-skipped-stereo.json");
    let mut right_blank = right.clone();
    right_blank[5] = blank.to_string_lossy().into_owned();
    run_ok(
        calib()
            .args(["stereo", "-q", "--board", "9x6"])
            .args(&left)
            .arg("--right")
            .args(&right_blank)
            .arg("-o")
            .arg(&out),
    );
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(result["num_pairs"], 5);
    assert!(
        result["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w["code"] == "images-skipped")
    );
    assert_eq!(result["rejected_pairs"][0]["left_image"], "left6.jpg");
}

/// Lists of numbers that start with a minus sign are values, not options: `--distortion-guess
/// -0.1,0,0,0` (a telephoto lens' pincushion or a barrel lens' k1) was refused with "unexpected
/// argument '-0' found" and only `--distortion-guess=-0.1,...` worked.
#[test]
fn negative_lists_of_numbers_are_values() {
    let left = data("sourishg1/left.json");
    let out = run_ok(calib().args([
        "single",
        "-q",
        &left,
        "--guess",
        "463,463,314,187",
        "--distortion-guess",
        "-0.1,0,0,0",
        "-o",
        "-",
    ]));
    let result: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(result["initial"]["method"], "given");
    let synth = temp("negative-lists.json");
    run_ok(
        calib()
            .args(["synth", "stereo", "--distortion", "-0.1,0,0,0"])
            .args(["--right-distortion", "-0.1,0,0,0", "--views", "4"])
            .args(["--rig", "-0.01,0,0,-100,0,0", "-o"])
            .arg(&synth),
    );
    // A missing value is still reported, naming the option and what it took.
    let err = refused(&["single", &left, "--guess", "--fix-aspect-ratio"]);
    assert!(
        err.contains("--guess: expected 4 comma-separated numbers, got 1 in '--fix-aspect-ratio'"),
        "{err}"
    );
}

/// `calib stereo --bootstrap N [--bootstrap-seed S]`: the `bootstrap` object in the JSON (both
/// cameras and the rig), the summary's lines, another seed another spread; N below 10, or
/// --bootstrap-seed alone, refused.
#[test]
fn stereo_bootstrap_is_opt_in_and_checked() {
    let obs = temp("stereo-bootstrap-obs.json");
    run_ok(
        calib()
            .args(["synth", "stereo", "--views", "8", "-o"])
            .arg(&obs),
    );
    let out = temp("stereo-bootstrap-result.json");
    let read = |path: &std::path::Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    };
    let run = run_ok(
        calib()
            .args(["stereo", "--bootstrap", "10"])
            .arg(&obs)
            .arg("-o")
            .arg(&out),
    );
    let summary = String::from_utf8(run.stdout).unwrap();
    assert!(
        summary.contains("pair bootstrap (10 resamples)"),
        "{summary}"
    );
    let json = read(&out);
    assert_eq!(json["bootstrap"]["resamples"], 10);
    assert_eq!(json["bootstrap"]["seed"], 1);
    let cx = json["bootstrap"]["left"]["std"]["cx"].as_f64().unwrap();
    assert!(cx > 0.0);
    assert!(json["bootstrap"]["right"]["std"]["fy"].as_f64().unwrap() > 0.0);
    assert!(json["bootstrap"]["rig_std"][3].as_f64().unwrap() > 0.0);
    assert!(json["bootstrap"]["baseline_std"].as_f64().unwrap() > 0.0);
    // Eight pairs: the bootstrap is warned rough.
    let warnings = json["warnings"].to_string();
    assert!(
        warnings.contains("pair bootstrap over 8 pairs"),
        "{warnings}"
    );
    run_ok(
        calib()
            .args(["stereo", "--bootstrap", "10", "--bootstrap-seed", "7", "-q"])
            .arg(&obs)
            .arg("-o")
            .arg(&out),
    );
    let json = read(&out);
    assert_eq!(json["bootstrap"]["seed"], 7);
    assert_ne!(json["bootstrap"]["left"]["std"]["cx"].as_f64().unwrap(), cx);
    // Without the option the result has no bootstrap.
    run_ok(
        calib()
            .arg("stereo")
            .arg(&obs)
            .arg("-q")
            .arg("-o")
            .arg(&out),
    );
    assert!(read(&out).get("bootstrap").is_none());
    for args in [&["--bootstrap", "9"][..], &["--bootstrap-seed", "3"][..]] {
        let run = calib().arg("stereo").arg(&obs).args(args).output().unwrap();
        assert!(!run.status.success(), "{args:?}");
    }
}

/// `--bootstrap N`: the `bootstrap` object in the JSON and the summary's lines next to the
/// linearized sigmas; --bootstrap-seed draws other resamples; N below 10, --bootstrap-warm or
/// --bootstrap-seed alone, or --bootstrap with --compare-models, refused.
#[test]
fn bootstrap_is_opt_in_and_checked() {
    let obs = temp("bootstrap-obs.json");
    run_ok(
        calib()
            .args(["synth", "single", "--views", "8", "-o"])
            .arg(&obs),
    );
    let out = temp("bootstrap-result.json");
    let run = run_ok(
        calib()
            .args(["single", "--bootstrap", "10"])
            .arg(&obs)
            .arg("-o")
            .arg(&out),
    );
    let summary = String::from_utf8(run.stdout).unwrap();
    assert!(
        summary.contains("view bootstrap (10 resamples)"),
        "{summary}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(json["bootstrap"]["resamples"], 10);
    assert_eq!(json["bootstrap"]["seed"], 1);
    let fx = json["bootstrap"]["std"]["fx"].as_f64().unwrap();
    assert!(fx > 0.0);
    // Another seed draws other resamples.
    run_ok(
        calib()
            .args(["single", "--bootstrap", "10", "--bootstrap-seed", "7", "-q"])
            .arg(&obs)
            .arg("-o")
            .arg(&out),
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(json["bootstrap"]["seed"], 7);
    assert_ne!(json["bootstrap"]["std"]["fx"].as_f64().unwrap(), fx);
    // Without the option the result has no bootstrap.
    run_ok(
        calib()
            .arg("single")
            .arg(&obs)
            .arg("-q")
            .arg("-o")
            .arg(&out),
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!(json.get("bootstrap").is_none());
    for args in [
        &["--bootstrap", "9"][..],
        &["--bootstrap-warm"][..],
        &["--bootstrap-seed", "3"][..],
        &["--bootstrap", "10", "--compare-models"][..],
    ] {
        let run = calib().arg("single").arg(&obs).args(args).output().unwrap();
        assert!(!run.status.success(), "{args:?}");
    }
}
