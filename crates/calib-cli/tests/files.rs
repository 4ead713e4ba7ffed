//! Files as users give them: the wrong kind of file, a byte order mark, pipes, links,
//! read-only results, and drawings into the images' own folder.

use std::process::Command;

fn calib() -> Command {
    Command::new(env!("CARGO_BIN_EXE_calib"))
}

fn data(path: &str) -> String {
    format!("{}/../../data/{path}", env!("CARGO_MANIFEST_DIR"))
}

/// A fresh scratch folder `name` for one test.
fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("calib-cli-files")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `command`, expecting failure with one line on stderr; returns that line.
fn fails(command: &mut Command) -> String {
    let run = command.output().unwrap();
    let err = String::from_utf8(run.stderr).unwrap();
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}

/// Runs `command`, expecting failure after the calibration's warnings (with `-q`, each on one
/// line of stderr: the bundled sets get `poor-coverage`); returns the error line, the last.
fn fails_after_warnings(command: &mut Command) -> String {
    let run = command.output().unwrap();
    let err = String::from_utf8(run.stderr).unwrap();
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let lines: Vec<&str> = err.lines().collect();
    let (last, warnings) = lines.split_last().expect("no error message");
    assert!(
        warnings.iter().all(|l| l.starts_with("calib: warning [")),
        "{err}"
    );
    last.to_string()
}

/// Runs `calib ARGS... -q -o OUTPUT` and checks that it succeeded.
fn writes(args: &[&str], output: &std::path::Path) {
    let run = calib()
        .args(args)
        .args(["-q", "-o"])
        .arg(output)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

/// A stereo file given to `calib single`, a single camera's to `calib rig`, a result given
/// where observations are read: the message says what the file is and which command reads it,
/// not serde's "missing field `views` at line 11472".
#[test]
fn a_file_of_another_kind_is_named() {
    let err = fails(calib().args(["single", &data("sourishg1/stereo.json")]));
    assert!(
        err.contains("this is a stereo observation file")
            && err.contains("calib stereo reads it")
            && !err.contains("missing field"),
        "{err}"
    );
    let err = fails(calib().args(["rig", &data("sourishg1/left.json")]));
    assert!(
        err.contains("this is a single camera's observation file")
            && err.contains("not a rig observation file"),
        "{err}"
    );
    let dir = scratch("kind");
    let result = dir.join("result.json");
    writes(&["single", &data("sourishg1/left.json")], &result);
    let err = fails(calib().arg("stereo").arg(&result));
    assert!(
        err.contains("this is a result of calib single")
            && err.contains("give the observation file it was calibrated from"),
        "{err}"
    );
    let empty = dir.join("empty.json");
    std::fs::write(&empty, "").unwrap();
    let err = fails(calib().arg("single").arg(&empty));
    assert!(err.ends_with("empty.json: the file is empty\n"), "{err}");
}

/// A file saved with a UTF-8 byte order mark (Notepad, PowerShell) is read like any other.
#[test]
fn a_byte_order_mark_is_skipped() {
    let dir = scratch("bom");
    let file = dir.join("left.json");
    let text = std::fs::read_to_string(data("sourishg1/left.json")).unwrap();
    std::fs::write(&file, format!("\u{feff}{}", text.replace('\n', "\r\n"))).unwrap();
    let run = calib().arg("single").arg(&file).arg("-q").output().unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

/// `-o` through a link writes the file it names (the link stays); into a named pipe (`mkfifo`,
/// `-o >(jq .)`) writes through it instead of replacing it by a file (the same path as root
/// would replace `/dev/null` or `/dev/stdout`); a read-only previous result is refused and kept.
#[cfg(unix)]
#[test]
fn links_pipes_and_read_only_results() {
    use std::os::unix::fs::PermissionsExt;
    let dir = scratch("paths");
    let real = dir.join("real.json");
    let link = dir.join("link.json");
    std::fs::write(&real, "{}").unwrap();
    std::os::unix::fs::symlink("real.json", &link).unwrap();
    let obs = data("sourishg1/left.json");
    writes(&["single", &obs], &link);
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(std::fs::read_to_string(&real).unwrap().contains("\"rms\""));

    let fifo = dir.join("fifo");
    if Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success())
    {
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
        };
        let run = calib()
            .args(["single", &obs, "-q", "-o"])
            .arg(&fifo)
            .output()
            .unwrap();
        assert!(run.status.success());
        assert!(reader.join().unwrap().contains("\"rms\""));
        let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
        assert!(!kind.is_file(), "the pipe was replaced by a file");
    }

    std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o444)).unwrap();
    let before = std::fs::read(&real).unwrap();
    let err = fails_after_warnings(calib().args(["single", &obs, "-q", "-o"]).arg(&real));
    assert!(err.contains("read-only"), "{err}");
    assert_eq!(std::fs::read(&real).unwrap(), before);
}

/// `--draw DIR` into the folder of PNG photographs: the drawing of `left1.png` would be
/// `DIR/left1.png`, the photograph itself; it is refused before anything is written.
#[test]
fn drawings_never_replace_an_input_image() {
    let dir = scratch("draw");
    let photo = dir.join("left1.png");
    board_detect::image::open(data("sourishg1/images/left1.jpg"))
        .unwrap()
        .save(&photo)
        .unwrap();
    let before = std::fs::read(&photo).unwrap();
    let obs = dir.join("obs.json");
    let err = fails(
        calib()
            .args(["detect", "--board", "9x6", "-q", "-o"])
            .arg(&obs)
            .arg("--draw")
            .arg(&dir)
            .arg(&photo),
    );
    assert!(err.contains("--draw") && err.contains("left1.png"), "{err}");
    assert_eq!(std::fs::read(&photo).unwrap(), before);
    assert!(!obs.exists());
}

/// An output folder (`undistort -o`, `rectify --out`, `--report`, `report -o`) given as an
/// existing file is named as such, before anything is written; a refused `calib undistort`
/// leaves no empty folder behind.
#[test]
fn an_output_folder_that_is_a_file_is_named() {
    let dir = scratch("folders");
    let obs = data("sourishg1/left.json");
    let result = dir.join("result.json");
    let old = dir.join("old.json");
    std::fs::write(&old, "{}").unwrap();
    let err = fails(
        calib()
            .args(["single", &obs, "-q", "-o"])
            .arg(&result)
            .arg("--report")
            .arg(&old),
    );
    assert!(
        err.contains("--report") && err.contains("that is a file, not a folder"),
        "{err}"
    );
    assert!(
        !result.exists(),
        "the result was written before the refusal"
    );
    writes(&["single", &obs], &result);
    let err = fails(calib().arg("report").arg(&result).arg("-o").arg(&old));
    assert!(
        err.starts_with("calib: -o ") && err.contains("not a folder"),
        "{err}"
    );
    let image = data("sourishg1/images/left1.jpg");
    let err = fails(
        calib()
            .arg("undistort")
            .arg(&result)
            .arg("-o")
            .arg(&old)
            .arg(&image),
    );
    assert!(err.contains("not a folder"), "{err}");
    assert_eq!(std::fs::read(&old).unwrap(), b"{}");
    // A bad image: refused, and no folder made.
    let text = dir.join("text.jpg");
    std::fs::write(&text, "hello").unwrap();
    let out = dir.join("undistorted");
    fails(
        calib()
            .arg("undistort")
            .arg(&result)
            .arg("-o")
            .arg(&out)
            .arg(&text),
    );
    assert!(!out.exists());
}

/// A stereo result whose lens model folds inside the image (sourishg2 with thin-prism12 or
/// rational8: the model-invalid warning) cannot be rectified, but its calibration is valid:
/// the OpenCV file holds M1 ... F without R1 ... Q, with a comment saying why and a warning on
/// stderr (before, the export failed, and `calib stereo --export` with it wrote nothing). ROS
/// camera_info of a stereo pair is its rectification: refused, naming the OpenCV export.
#[test]
fn a_stereo_rig_that_cannot_be_rectified_is_exported_without_rectification() {
    let dir = scratch("unrectifiable");
    let obs = data("sourishg2/stereo.json");
    let (result, yaml) = (dir.join("tp.json"), dir.join("tp.yaml"));
    let run = calib()
        .args(["stereo", &obs, "--model", "thin-prism12", "-q", "-o"])
        .arg(&result)
        .arg("--export")
        .arg(format!("opencv={}", yaml.display()))
        .output()
        .unwrap();
    let err = String::from_utf8(run.stderr).unwrap();
    assert!(run.status.success(), "{err}");
    assert!(err.contains("warning [model-invalid]"), "{err}");
    assert!(
        err.contains("calib: warning: --export opencv=")
            && err.contains("written without the rectification (R1, R2, P1, P2, Q)"),
        "{err}"
    );
    assert!(result.exists());
    let check = |text: &str| {
        for key in ["M1", "D1", "M2", "D2", "R", "T", "E", "F"] {
            assert!(
                text.contains(&format!("\n{key}: !!opencv-matrix\n")),
                "{key}"
            );
        }
        for key in ["R1", "R2", "P1", "P2", "Q"] {
            assert!(!text.contains(&format!("\n{key}: ")), "{key}: {text}");
        }
        let comment: Vec<&str> = text.lines().filter_map(|l| l.strip_prefix("# ")).collect();
        let comment = comment.join(" ");
        assert!(
            comment.starts_with(
                "R1, R2, P1, P2, Q (the rectification) are left out: they cannot be computed"
            ) && comment.contains("lens model that is valid over the whole image")
                && comment.contains("--alpha"),
            "{text}"
        );
        // Comment lines wrapped for people reading the file.
        assert!(
            text.lines()
                .filter(|l| l.starts_with('#'))
                .all(|l| l.len() <= 110),
            "{text}"
        );
    };
    check(&std::fs::read_to_string(&yaml).unwrap());

    // calib export: the same file, the warning naming it.
    let again = dir.join("again.yaml");
    let run = calib()
        .arg("export")
        .arg(&result)
        .args(["--format", "opencv", "-o"])
        .arg(&again)
        .output()
        .unwrap();
    let err = String::from_utf8(run.stderr).unwrap();
    assert!(run.status.success(), "{err}");
    assert!(
        err.starts_with(&format!(
            "calib: warning: {}: written without",
            again.display()
        )),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(&again).unwrap(),
        std::fs::read_to_string(&yaml).unwrap()
    );
    // An exported file exported again (to standard output): the same, the warning on stderr.
    let run = calib()
        .arg("export")
        .arg(&again)
        .args(["--format", "opencv", "-q", "-o", "-"])
        .output()
        .unwrap();
    assert!(run.status.success());
    assert!(
        String::from_utf8(run.stderr)
            .unwrap()
            .contains("written without")
    );
    check(&String::from_utf8(run.stdout).unwrap());

    // ROS: refused, nothing written.
    let r8 = dir.join("r8.json");
    writes(&["stereo", &obs, "--model", "rational8"], &r8);
    let ros = dir.join("ros.yaml");
    let err = fails(
        calib()
            .arg("export")
            .arg(&r8)
            .args(["--format", "ros", "-o"])
            .arg(&ros),
    );
    assert!(
        err.contains("ROS camera_info files of a stereo pair need its rectification")
            && err.contains("--format opencv writes this calibration without the rectification"),
        "{err}"
    );
    assert!(!dir.join("ros-left.yaml").exists() && !dir.join("ros-right.yaml").exists());
}

/// `calib rectify -o RECT.json --out DIR`: the JSON is written after the rectified images, so
/// a run whose images fail (here the right image's output path is a folder) leaves no JSON
/// claiming a finished run (before, the JSON was written first and stayed).
#[test]
fn rectify_writes_its_json_after_the_images() {
    let dir = scratch("rectify-order");
    let rig = dir.join("rig.json");
    writes(&["stereo", &data("sourishg1/stereo.json")], &rig);
    let (rect, out) = (dir.join("rect.json"), dir.join("rectified"));
    std::fs::create_dir_all(out.join("right/right3.jpg")).unwrap();
    let rectify = |rect: &std::path::Path| {
        let mut c = calib();
        c.arg("rectify")
            .arg(&rig)
            .arg("-o")
            .arg(rect)
            .args(["--images", &data("sourishg1/images/left3.jpg")])
            .args(["--right", &data("sourishg1/images/right3.jpg")])
            .arg("--out")
            .arg(&out);
        c
    };
    let err = fails(&mut rectify(&rect));
    assert!(err.contains("right3.jpg"), "{err}");
    assert!(
        !rect.exists(),
        "the JSON was written before the images failed"
    );
    // Once the images can be written, the JSON follows them.
    std::fs::remove_dir(out.join("right/right3.jpg")).unwrap();
    let run = rectify(&rect).output().unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(rect.exists() && out.join("right/right3.jpg").is_file());
    let (json, image) = (
        std::fs::metadata(&rect).unwrap().modified().unwrap(),
        std::fs::metadata(out.join("right/right3.jpg"))
            .unwrap()
            .modified()
            .unwrap(),
    );
    assert!(json >= image);
}

/// Ctrl-C (SIGINT) or SIGTERM while a big file is written: the run exits with 128 + the signal
/// (130, 143), removes its temporary `.NAME.tmp-PID` file and leaves the previous file as it was
/// (before, the signal ended the process and the temporary file stayed beside the output).
/// The signal is sent as soon as the temporary file appears; a run that finished first is
/// repeated with a bigger file.
#[cfg(unix)]
#[test]
fn an_interrupted_write_leaves_no_temporary_file_and_the_old_result() {
    use std::os::unix::process::ExitStatusExt;
    let dir = scratch("interrupted");
    let out = dir.join("big.json");
    let temporary = |dir: &std::path::Path| -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(".big.json.tmp-"))
            .collect()
    };
    for (signal, code) in [(libc::SIGINT, 130), (libc::SIGTERM, 143)] {
        let mut caught = false;
        for views in [4000, 8000, 16000, 32000] {
            std::fs::write(&out, "the previous result").unwrap();
            let mut child = calib()
                .args(["synth", "single", "--views", &views.to_string(), "-o"])
                .arg(&out)
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap();
            let mut sent = false;
            let status = loop {
                if let Some(status) = child.try_wait().unwrap() {
                    break status;
                }
                if !sent && !temporary(&dir).is_empty() {
                    // SAFETY: kill(2) on the child's process id.
                    assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
                    sent = true;
                }
                std::thread::sleep(std::time::Duration::from_micros(200));
            };
            let mut err = String::new();
            std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
            assert!(temporary(&dir).is_empty(), "{:?} left", temporary(&dir));
            if !sent || status.success() {
                // The write finished before the signal: try a bigger one.
                assert!(status.success(), "{status:?} {err}");
                continue;
            }
            assert_eq!(
                (status.code(), status.signal()),
                (Some(code), None),
                "signal {signal}: {err}"
            );
            assert_eq!(err, "", "signal {signal}");
            // The previous file, or (a signal just after the rename) the new one whole.
            let text = std::fs::read_to_string(&out).unwrap();
            if text != "the previous result" {
                let json: serde_json::Value = serde_json::from_str(&text).unwrap();
                assert_eq!(json["views"].as_array().unwrap().len(), views);
                continue;
            }
            eprintln!("signal {signal}: interrupted the write of {views} views");
            caught = true;
            break;
        }
        assert!(
            caught,
            "signal {signal}: no write was slow enough to interrupt"
        );
    }
    // A Ctrl-C the run was started to ignore (a shell script's background job, `trap '' INT`)
    // stays ignored: the run finishes.
    let mut child = Command::new("sh")
        .args(["-c", "trap '' INT; exec \"$0\" \"$@\""])
        .arg(env!("CARGO_BIN_EXE_calib"))
        .args(["synth", "single", "--views", "4000", "-o"])
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if !temporary(&dir).is_empty() {
            // SAFETY: kill(2) on the child's process id.
            unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
        }
        std::thread::sleep(std::time::Duration::from_micros(200));
    };
    assert!(status.success(), "{status:?}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(json["views"].as_array().unwrap().len(), 4000);
}

/// A JPEG cut short (a copy that did not finish) is named as such: listed in
/// `rejected_images` with that reason like any unreadable image, and an error naming the file
/// where an image is undistorted. Before, it decoded with its missing half grey, and the
/// detector ran on that.
#[test]
fn a_jpeg_cut_short_is_named() {
    let dir = scratch("cut-short");
    for i in [1, 2] {
        let name = format!("left{i}.jpg");
        std::fs::copy(data(&format!("sourishg1/images/{name}")), dir.join(&name)).unwrap();
    }
    let whole = std::fs::read(data("sourishg1/images/left3.jpg")).unwrap();
    let cut = dir.join("left3.jpg");
    std::fs::write(&cut, &whole[..whole.len() / 2]).unwrap();
    let obs = dir.join("obs.json");
    let (left1, left2) = (dir.join("left1.jpg"), dir.join("left2.jpg"));
    let images = [&left1, &left2, &cut].map(|p| p.to_string_lossy().into_owned());
    writes(
        &[
            "detect", "--board", "9x6", &images[0], &images[1], &images[2],
        ],
        &obs,
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&obs).unwrap()).unwrap();
    assert_eq!(json["views"].as_array().unwrap().len(), 2);
    let rejected = &json["rejected_images"];
    assert_eq!(rejected.as_array().unwrap().len(), 1, "{rejected}");
    assert_eq!(rejected[0]["image"], "left3.jpg");
    let reason = rejected[0]["reason"].as_str().unwrap();
    assert!(
        reason.starts_with("the file is cut short (truncated JPEG"),
        "{reason}"
    );
    // The image alone: the error names it and why.
    let err = fails(
        calib()
            .args(["detect", "--board", "9x6", "-q", "-o"])
            .arg(dir.join("alone.json"))
            .arg(&cut),
    );
    assert!(
        err.contains("left3.jpg: the file is cut short (truncated JPEG"),
        "{err}"
    );
    // Undistorting it.
    let result = dir.join("left.json");
    writes(&["single", &data("sourishg1/left.json")], &result);
    let err = fails(
        calib()
            .arg("undistort")
            .arg(&result)
            .arg("-o")
            .arg(dir.join("undistorted"))
            .arg(&cut),
    );
    assert!(
        err.contains("left3.jpg: the file is cut short (truncated JPEG"),
        "{err}"
    );
}
