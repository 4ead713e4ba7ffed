//! `calib rig` and `calib synth rig` as a user runs them.

use serde_json::Value;
use std::process::Command;

fn calib() -> Command {
    Command::new(env!("CARGO_BIN_EXE_calib"))
}

/// `name` in this test binary's scratch directory, `target/tmp/calib-cli-rig` (kept after
/// the run to look at, emptied once when the next run first asks for it, so a test never sees
/// a file of an earlier run).
fn temp(name: &str) -> std::path::PathBuf {
    static EMPTIED: std::sync::Once = std::sync::Once::new();
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("calib-cli-rig");
    EMPTIED.call_once(|| {
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
    });
    dir.join(name)
}

fn run_ok(command: &mut Command) -> std::process::Output {
    let run = command.output().unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    run
}

/// `calib synth rig ARGS... -o NAME` in the scratch directory; the file's path.
fn synthetic_rig(args: &[&str], name: &str) -> std::path::PathBuf {
    let file = temp(name);
    run_ok(
        calib()
            .args(["synth", "rig"])
            .args(args)
            .arg("-o")
            .arg(&file),
    );
    file
}

/// `calib rig INPUT ARGS... -q -o NAME` in the scratch directory, and its result.
fn calibrated_rig(input: &std::path::Path, args: &[&str], name: &str) -> Value {
    let out = temp(name);
    run_ok(
        calib()
            .arg("rig")
            .arg(input)
            .args(args)
            .args(["-q", "-o"])
            .arg(&out),
    );
    read(&out)
}

fn read(path: &std::path::Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn synthetic_rig_is_calibrated_with_the_documented_keys() {
    let input = temp("rig.json");
    let out = temp("rig-result.json");
    run_ok(
        calib()
            .args(["synth", "rig", "--cameras", "4", "--views", "40", "-o"])
            .arg(&input),
    );
    let run = run_ok(calib().arg("rig").arg(&input).arg("-o").arg(&out));
    let summary = String::from_utf8(run.stdout).unwrap();
    assert!(
        summary.contains("Rig calibration (4 cameras, 40 frames)")
            && summary.contains("camera 'cam3'")
            && summary.contains("from 'cam0'"),
        "{summary}"
    );
    let truth = read(&input)["truth"].clone();
    let result = read(&out);
    assert_eq!(result["format"], "calib-rig-result/1");
    for key in [
        "rms",
        "elapsed_seconds",
        "warnings",
        "cameras",
        "frames",
        "solver",
    ] {
        assert!(result.get(key).is_some(), "missing {key}");
    }
    let cameras = result["cameras"].as_array().unwrap();
    assert_eq!(cameras.len(), 4);
    for (c, camera) in cameras.iter().enumerate() {
        for key in [
            "name",
            "model",
            "camera_matrix",
            "dist_coeffs",
            "R",
            "T",
            "std",
        ] {
            assert!(camera.get(key).is_some(), "camera {c}: missing {key}");
        }
        assert_eq!(camera["name"], format!("cam{c}"));
        // Within 1% of the distance from the reference (noise 0.2 px).
        let t: Vec<f64> = serde_json::from_value(camera["T"].clone()).unwrap();
        let true_t: Vec<f64> = serde_json::from_value(truth["cameras"][c]["T"].clone()).unwrap();
        let error = (0..3)
            .map(|i| (t[i] - true_t[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        let distance = true_t.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!(
            error <= 0.01 * distance + 1e-9,
            "camera {c}: T off by {error}"
        );
    }
    assert_eq!(result["frames"].as_array().unwrap().len(), 40);
}

#[test]
fn reference_and_errors_name_cameras() {
    let input = synthetic_rig(
        &["--cameras", "3", "--views", "30", "--layout", "line"],
        "rig3.json",
    );
    let result = calibrated_rig(&input, &["--reference", "cam1"], "rig3-result.json");
    assert_eq!(result["reference"], 1);
    assert_eq!(
        result["cameras"][1]["T"],
        serde_json::json!([0.0, 0.0, 0.0])
    );

    let run = calib()
        .arg("rig")
        .arg(&input)
        .args(["--reference", "left"])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let err = String::from_utf8(run.stderr).unwrap();
    assert!(
        err.contains("no camera named 'left'") && err.contains("cam0, cam1, cam2"),
        "{err}"
    );

    // Two groups of cameras that never saw the board together.
    let mut file = read(&input);
    for frame in file["frames"].as_array_mut().unwrap() {
        let observations = frame["observations"].as_array_mut().unwrap();
        observations.retain(|o| o["camera"] != 2);
    }
    file["frames"][0]["observations"] = serde_json::json!([{
        "camera": 2,
        "image_points": file["frames"][0]["observations"][0]["image_points"].clone(),
    }]);
    let cut = temp("cut.json");
    std::fs::write(&cut, file.to_string()).unwrap();
    let run = calib().arg("rig").arg(&cut).output().unwrap();
    assert_eq!(run.status.code(), Some(1));
    let err = String::from_utf8(run.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("[cam2]") && err.contains("[cam0, cam1]"),
        "{err}"
    );
}

#[test]
fn per_camera_models_and_given_intrinsics() {
    let input = temp("rig-given.json");
    run_ok(
        calib()
            .args([
                "synth",
                "rig",
                "--cameras",
                "3",
                "--views",
                "36",
                "--layout",
                "line",
                "-o",
            ])
            .arg(&input),
    );
    // cam2 calibrated alone from its own views, as a user would first.
    let file = read(&input);
    let views: Vec<Value> = file["frames"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|f| {
            let o = f["observations"]
                .as_array()
                .unwrap()
                .iter()
                .find(|o| o["camera"] == 2)?;
            Some(serde_json::json!({
                "object_points": f["object_points"].clone(),
                "image_points": o["image_points"].clone(),
            }))
        })
        .collect();
    let single = temp("cam2-views.json");
    std::fs::write(
        &single,
        serde_json::json!({"image_size": file["cameras"][2]["image_size"].clone(), "views": views})
            .to_string(),
    )
    .unwrap();
    let cam2 = temp("cam2-result.json");
    run_ok(
        calib()
            .arg("single")
            .arg(&single)
            .arg("-q")
            .arg("-o")
            .arg(&cam2),
    );

    let out = temp("rig-given-result.json");
    run_ok(
        calib()
            .arg("rig")
            .arg(&input)
            .args(["--model", "cam1=brown-conrady5", "--intrinsics"])
            .arg(format!("cam2={}", cam2.display()))
            .args(["-q", "-o"])
            .arg(&out),
    );
    let result = read(&out);
    assert_eq!(result["cameras"][0]["model"], "brown-conrady4");
    assert_eq!(result["cameras"][1]["model"], "brown-conrady5");
    assert_eq!(result["cameras"][2]["initial_method"], "given");
    assert_eq!(
        result["cameras"][2]["camera_matrix"],
        read(&cam2)["camera"]["camera_matrix"]
    );

    for (args, expected) in [
        (
            vec!["--model", "cam7=brown-conrady5"],
            "no camera named 'cam7'",
        ),
        (vec!["--model", "cam1=pinhole9"], "--model cam1=pinhole9"),
        (
            vec!["--intrinsics", "result.json"],
            "--intrinsics NAME=result.json",
        ),
        // Without a given camera it held nothing, silently.
        (
            vec!["--fix-intrinsics"],
            "--fix-intrinsics: give the intrinsics",
        ),
    ] {
        let run = calib().arg("rig").arg(&input).args(&args).output().unwrap();
        assert_eq!(run.status.code(), Some(1));
        let err = String::from_utf8(run.stderr).unwrap();
        assert!(err.contains(expected), "{args:?}: {err}");
    }
    // A per-camera value is refused where it has no meaning.
    let run = calib()
        .arg("single")
        .arg(&single)
        .args(["--model", "cam1=brown-conrady5"])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(String::from_utf8(run.stderr).unwrap().contains("calib rig"));
}

/// After `calib rig`: `--export` in every format and `--report` on the calibration itself, the
/// same files from `calib export` / `calib report` on the result, a pair's stereo file and
/// rectification (`--pair`), one camera of the rig file as known intrinsics or for undistortion.
#[test]
fn rig_results_are_exported_reported_and_read_back() {
    let input = temp("after-obs.json");
    run_ok(
        calib()
            .args(["synth", "rig", "--cameras", "4", "--views", "24", "-o"])
            .arg(&input),
    );
    let result = temp("after-result.json");
    let report = temp("after-report");
    let run = run_ok(
        calib()
            .arg("rig")
            .arg(&input)
            .arg("-o")
            .arg(&result)
            .arg("--export")
            .arg(format!("opencv={}", temp("after-rig.yaml").display()))
            .arg("--export")
            .arg(format!("kalibr={}", temp("after-chain.yaml").display()))
            .arg("--export")
            .arg(format!("ros={}", temp("after-ros.yaml").display()))
            .arg("--report")
            .arg(&report),
    );
    let stdout = String::from_utf8(run.stdout).unwrap();
    assert!(stdout.contains("after-ros-cam2.yaml (ros)"), "{stdout}");
    for camera in ["cam0", "cam1", "cam2", "cam3"] {
        assert!(temp(&format!("after-ros-{camera}.yaml")).exists());
        assert!(report.join(format!("residuals-{camera}.svg")).exists());
    }
    let page = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert!(page.contains("layout.svg"));
    // calib export on the result writes the same bytes as --export.
    for (format, file) in [("opencv", "after-rig.yaml"), ("kalibr", "after-chain.yaml")] {
        let again = temp(&format!("again-{file}"));
        run_ok(
            calib()
                .arg("export")
                .arg(&result)
                .args(["--format", format, "-q", "-o"])
                .arg(&again),
        );
        assert_eq!(
            std::fs::read(&again).unwrap(),
            std::fs::read(temp(file)).unwrap(),
            "{format}"
        );
    }
    // The rig file's camera 'cam1' as known intrinsics: held at exactly those values.
    let given = temp("after-given.json");
    run_ok(
        calib()
            .arg("rig")
            .arg(&input)
            .arg("--intrinsics")
            .arg(format!("cam1={}", temp("after-rig.yaml").display()))
            .arg("-q")
            .arg("-o")
            .arg(&given),
    );
    let (first, second) = (read(&result), read(&given));
    assert_eq!(
        first["cameras"][1]["intrinsics"], second["cameras"][1]["intrinsics"],
        "cam1 held at the file's values"
    );
    assert_eq!(second["cameras"][1]["initial_method"], "given");
    // A pair: OpenCV's stereo keys, and a rectification.
    let pair = temp("after-pair.yaml");
    run_ok(
        calib()
            .arg("export")
            .arg(&result)
            .args(["--pair", "cam2,cam1", "--format", "opencv", "-q", "-o"])
            .arg(&pair),
    );
    let text = std::fs::read_to_string(&pair).unwrap();
    for key in [
        "M1:", "D2:", "\nR:", "\nT:", "\nE:", "\nF:", "R1:", "P2:", "\nQ:",
    ] {
        assert!(text.contains(key), "{key} missing");
    }
    let rect = temp("after-rect.json");
    run_ok(
        calib()
            .arg("rectify")
            .arg(temp("after-chain.yaml"))
            .args(["--pair", "cam0,cam1", "-q", "-o"])
            .arg(&rect),
    );
    assert!(read(&rect).get("P2").is_some());
    // What needs a pair or a camera name says so, with the names.
    for args in [
        vec![
            "rectify".to_string(),
            result.display().to_string(),
            "-o".into(),
            temp("x.json").display().to_string(),
        ],
        vec![
            "undistort".to_string(),
            result.display().to_string(),
            "-o".into(),
            temp("und").display().to_string(),
            input.display().to_string(),
        ],
        vec![
            "rectify".to_string(),
            result.display().to_string(),
            "--pair".into(),
            "cam0,cam9".into(),
            "-o".into(),
            temp("x.json").display().to_string(),
        ],
    ] {
        let run = calib().args(&args).output().unwrap();
        assert_eq!(run.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(
            err.contains("cam0, cam1, cam2, cam3") || err.contains("--camera NAME"),
            "{args:?}: {err}"
        );
    }
    // calib report on the result with its observations.
    let again = temp("after-report-again");
    run_ok(
        calib()
            .arg("report")
            .arg(&result)
            .arg("--observations")
            .arg(&input)
            .arg("-q")
            .arg("-o")
            .arg(&again),
    );
    assert!(again.join("layout.svg").exists() && again.join("uncertainty-cam2.svg").exists());
}

/// `--fix` names are held in every camera whose model has them, by name; a name no camera has
/// is refused.
#[test]
fn fix_names_are_held_per_camera_model() {
    let file = synthetic_rig(
        &[
            "--cameras",
            "3",
            "--models",
            "brown-conrady4,kannala-brandt4",
            "--seed",
            "5",
        ],
        "fix-rig.json",
    );
    let result = calibrated_rig(
        &file,
        &["--fix", "k4", "--fix", "cam0=k1"],
        "fix-rig-result.json",
    );
    let held: Vec<(String, Value)> = result["cameras"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            (
                c["model"].as_str().unwrap().to_string(),
                c["fixed_parameters"].clone(),
            )
        })
        .collect();
    for (c, (model, fixed)) in held.iter().enumerate() {
        let expected = if model == "kannala-brandt4" {
            serde_json::json!(["k4"])
        } else if c == 0 {
            serde_json::json!(["k1"])
        } else {
            serde_json::json!([])
        };
        assert_eq!(fixed, &expected, "{held:?}");
    }
    let run = calib()
        .arg("rig")
        .arg(&file)
        .args(["--fix", "s1"])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&run.stderr).contains("no camera's model has a coefficient 's1'")
    );

    // A format that cannot hold a camera's model: refused before calibrating with --export, and
    // named by camera by calib export.

    let run = calib()
        .arg("rig")
        .arg(&file)
        .args(["-q", "--model", "cam0=thin-prism12", "--export"])
        .arg(format!("ros={}", temp("fix-rig.yaml").display()))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&run.stderr).contains("thin-prism12"));
    calibrated_rig(
        &file,
        &["--model", "cam0=thin-prism12"],
        "fix-rig-prism.json",
    );
    let run = calib()
        .arg("export")
        .arg(temp("fix-rig-prism.json"))
        .args(["--format", "ros", "-o"])
        .arg(temp("fix-rig-ros.yaml"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("camera 'cam0'"), "{err}");
}

/// A bundled image, `data/NAME` at the workspace root.
fn bundled(name: &str) -> String {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data");
    root.join(name).to_string_lossy().into_owned()
}

fn images(camera: &str, frames: std::ops::RangeInclusive<usize>) -> Vec<String> {
    frames
        .map(|i| bundled(&format!("sourishg1/images/{camera}{i}.jpg")))
        .collect()
}

fn json(path: &std::path::Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// `calib rig` from photographs: --board, --square and --camera NAME IMAGE... per camera. On the
/// bundled pair it is `calib stereo` from the same photographs (the rig engine reaches the
/// stereo minimum); a frame whose image of one camera has no usable board keeps the other
/// camera's view and lists the image in `rejected_images`; unequal image counts are refused.
#[test]
fn a_rig_is_calibrated_from_photographs() {
    let (left, right) = (images("left", 1..=29), images("right", 1..=29));
    let stereo = temp("photos-stereo.json");
    run_ok(
        calib()
            .args(["stereo", "-q", "--board", "9x6", "--square", "24.23"])
            .args(&left)
            .arg("--right")
            .args(&right)
            .arg("-o")
            .arg(&stereo),
    );
    // `calib COMMAND --board 9x6 --square 24.23 --camera left ... --camera right ... -o OUT`.
    let from_photos = |command: &str, right: &[String], out: &std::path::Path| {
        let mut c = calib();
        c.args([
            command, "--board", "9x6", "--square", "24.23", "--camera", "left",
        ])
        .args(&left)
        .args(["--camera", "right"])
        .args(right)
        .arg("-o")
        .arg(out);
        c
    };
    let rig = temp("photos-rig.json");
    run_ok(from_photos("rig", &right, &rig).arg("-q"));
    let (s, r) = (json(&stereo), json(&rig));
    let rms = |v: &Value| v["rms"].as_f64().unwrap();
    assert!(
        (rms(&s) - rms(&r)).abs() < 1e-9 * rms(&s),
        "{} {}",
        rms(&s),
        rms(&r)
    );
    assert_eq!(r["cameras"][1]["name"], "right");
    assert_eq!(r["frames"].as_array().unwrap().len(), 29);

    // Frame 3's right image cut short: that frame keeps its left view only.
    let cut = temp("right4.jpg");
    let bytes = std::fs::read(&right[3]).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let mut damaged = right.clone();
    damaged[3] = cut.to_string_lossy().into_owned();
    let out = temp("photos-rig-damaged.json");
    let run = run_ok(&mut from_photos("rig", &damaged, &out));
    let summary = String::from_utf8_lossy(&run.stdout).into_owned();
    assert!(
        summary.contains("detected the board in 57 of 58 images"),
        "{summary}"
    );
    let result = json(&out);
    let rejected = result["rejected_images"].as_array().unwrap();
    assert_eq!(rejected.len(), 1, "{rejected:?}");
    assert_eq!(rejected[0]["camera"], "right");
    assert_eq!(rejected[0]["image"], "right4.jpg");
    let frame3 = result["frames"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["index"] == 3)
        .unwrap();
    assert_eq!(frame3["views"].as_array().unwrap().len(), 1, "{frame3}");
    assert!(
        result["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w["code"] == "images-skipped"),
        "{:?}",
        result["warnings"]
    );

    // calib detect --camera writes the rig observation file, which calib rig reads to the same
    // result.
    let corners = temp("photos-rig-corners.json");
    run_ok(from_photos("detect", &right, &corners).arg("-q"));
    let from_file = temp("photos-rig-from-file.json");
    run_ok(
        calib()
            .args(["rig", "-q"])
            .arg(&corners)
            .arg("-o")
            .arg(&from_file),
    );
    assert_eq!(rms(&json(&from_file)), rms(&r));

    // Frames are matched in order: unequal counts are refused, naming both cameras.
    let run = calib()
        .args(["rig", "--board", "9x6", "--camera", "left"])
        .args(&left)
        .args(["--camera", "right"])
        .args(&right[..28])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let message = String::from_utf8_lossy(&run.stderr);
    assert!(
        message.contains("camera 'right' has 28 images but camera 'left' has 29"),
        "{message}"
    );
    // Two right images in the wrong order (frame 3 would pair left4.jpg with right5.jpg): their
    // file numbers show it, while the other frames' numbers agree; calib stereo checks its pairs
    // alike.
    let mut swapped = right.clone();
    swapped.swap(3, 4);
    let out = temp("photos-rig-swapped.json");
    let run = from_photos("rig", &swapped, &out).output().unwrap();
    assert_eq!(run.status.code(), Some(1));
    let message = String::from_utf8_lossy(&run.stderr);
    assert!(
        message.contains("frame 3 matches left ")
            && message.contains("right5.jpg by their order, but their file numbers differ"),
        "{message}"
    );
    let run = calib()
        .args(["stereo", "--board", "9x6"])
        .args(&left)
        .arg("--right")
        .args(&swapped)
        .output()
        .unwrap();
    assert!(
        String::from_utf8_lossy(&run.stderr).contains("pair 3 matches left "),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );

    // --camera without --board, and a file with --camera, are explained.
    let run = calib()
        .args(["rig", "--camera", "left"])
        .args(&left[..3])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&run.stderr).contains("give the board too"));
    let run = calib()
        .args(["rig", "x.json", "--camera", "left"])
        .args(&left[..3])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
}

/// `--frames-by-number`: the cameras' images are matched by the numbers in their file names, so
/// a camera may lack some frames and the lists may come in any order. Shuffled lists give the
/// same rig observation file as the lists in order; with images missing from either camera the
/// frames keep the numbers (a frame a camera has no image of holds the other camera alone,
/// nothing is rejected) and the rig calibrates; stereo pairs only the numbers both have and
/// lists the others; images without a number, numbers given twice, one camera and observation
/// files are refused.
#[test]
fn frames_are_matched_by_file_number() {
    let (left, right) = (images("left", 1..=29), images("right", 1..=29));
    let detect = |left: &[String], right: &[String], by_number: bool, out: &std::path::Path| {
        let mut c = calib();
        c.args(["detect", "-q", "--board", "9x6", "--square", "24.23"])
            .arg("--camera")
            .arg("left")
            .args(left)
            .arg("--camera")
            .arg("right")
            .args(right)
            .arg("-o")
            .arg(out);
        if by_number {
            c.arg("--frames-by-number");
        }
        c
    };
    let in_order = temp("by-number-in-order.json");
    run_ok(&mut detect(&left, &right, false, &in_order));
    // Every third image first, the right list reversed: the numbers restore the frames.
    let mut shuffled_left: Vec<String> = left.iter().step_by(3).cloned().collect();
    shuffled_left.extend(
        left.iter()
            .enumerate()
            .filter(|(i, _)| i % 3 != 0)
            .map(|(_, p)| p.clone()),
    );
    let reversed_right: Vec<String> = right.iter().rev().cloned().collect();
    let by_number = temp("by-number-shuffled.json");
    run_ok(&mut detect(
        &shuffled_left,
        &reversed_right,
        true,
        &by_number,
    ));
    assert_eq!(json(&by_number)["frames"], json(&in_order)["frames"]);

    // Right images 4 and 9 and left image 20 missing.
    let right_some: Vec<String> = right
        .iter()
        .enumerate()
        .filter(|(i, _)| ![3, 8].contains(i))
        .map(|(_, p)| p.clone())
        .collect();
    let left_some: Vec<String> = left
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != 19)
        .map(|(_, p)| p.clone())
        .collect();
    let rig = temp("by-number-rig.json");
    run_ok(
        calib()
            .args([
                "rig",
                "-q",
                "--board",
                "9x6",
                "--square",
                "24.23",
                "--frames-by-number",
            ])
            .arg("--camera")
            .arg("left")
            .args(&left_some)
            .arg("--camera")
            .arg("right")
            .args(&right_some)
            .arg("-o")
            .arg(&rig),
    );
    let result = json(&rig);
    let frames = result["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 29);
    // The cameras (0 left, 1 right) in frame `index` (the frames in increasing number order).
    let cameras = |index: usize| -> Vec<u64> {
        let frame = frames.iter().find(|f| f["index"] == index).unwrap();
        frame["views"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v["camera"].as_u64().unwrap())
            .collect()
    };
    assert_eq!(cameras(3), [0]);
    assert_eq!(cameras(8), [0]);
    assert_eq!(cameras(19), [1]);
    assert_eq!(cameras(20), [0, 1]);
    assert_eq!(result["rejected_images"].as_array().map_or(0, Vec::len), 0);
    // Views matched wrongly would fail the rig's checks or leave pixels of error.
    let rms = result["rms"].as_f64().unwrap();
    assert!(rms < 0.3, "RMS {rms}");

    // Stereo from the same lists: 26 pairs, the three unmatched images listed.
    let pairs_by_number = |command: &str, out: &std::path::Path| {
        run_ok(
            calib()
                .args([command, "-q", "--board", "9x6", "--square", "24.23"])
                .arg("--frames-by-number")
                .args(&left_some)
                .arg("--right")
                .args(&right_some)
                .arg("-o")
                .arg(out),
        );
        json(out)
    };
    let file = pairs_by_number("detect", &temp("by-number-stereo.json"));
    assert_eq!(file["pairs"].as_array().unwrap().len(), 26);
    let reasons: Vec<&str> = file["rejected_pairs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["reason"].as_str().unwrap())
        .collect();
    assert_eq!(
        reasons,
        [
            "no right image numbered 4",
            "no right image numbered 9",
            "no left image numbered 20"
        ]
    );

    // calib stereo calibrates those pairs and names the images left without a partner.
    let warnings =
        pairs_by_number("stereo", &temp("by-number-stereo-result.json"))["warnings"].clone();
    let skipped = warnings
        .as_array()
        .unwrap()
        .iter()
        .find(|w| w["code"] == "images-skipped")
        .unwrap_or_else(|| panic!("{warnings}"));
    assert!(
        skipped["message"].as_str().unwrap().starts_with(
            "3 of 29 image pairs left out, no image of the other camera with the same number: left4.jpg / -, left9.jpg / -, - / right20.jpg"
        ),
        "{skipped}"
    );

    // Refusals, each naming what is wrong.
    let refused = |command: &mut Command, expected: &str| {
        let run = command.output().unwrap();
        let message = String::from_utf8_lossy(&run.stderr);
        assert!(
            !run.status.success() && message.contains(expected),
            "{message}"
        );
    };
    let unnumbered = temp("left-extra.jpg");
    std::fs::copy(&left[0], &unnumbered).unwrap();
    let mut with_unnumbered = left.clone();
    with_unnumbered.push(unnumbered.to_string_lossy().into_owned());
    refused(
        &mut detect(&with_unnumbered, &right, true, &temp("x.json")),
        "left-extra.jpg (camera 'left') has no number in its file name",
    );
    let twice = temp("left01.jpg");
    std::fs::copy(&left[0], &twice).unwrap();
    let mut with_twice = left.clone();
    with_twice.push(twice.to_string_lossy().into_owned());
    refused(
        &mut detect(&with_twice, &right, true, &temp("x.json")),
        "(camera 'left') have the same number 1",
    );
    refused(
        calib()
            .args(["single", "--board", "9x6", "--frames-by-number"])
            .args(&left),
        "calib single has one camera",
    );
    refused(
        calib().args(["rig", "--frames-by-number"]).arg(&in_order),
        "is an observation file, whose frames are already matched",
    );
    // Unequal counts in order point to the option.
    refused(
        &mut detect(&left, &right_some, false, &temp("x.json")),
        "--frames-by-number",
    );
}
