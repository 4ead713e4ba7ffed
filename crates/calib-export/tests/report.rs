//! The report: every image the page references exists and is well-formed SVG; the covariance
//! behind the uncertainty map agrees with the calibration's own standard deviations.

use calib_core::JsonFile;
use calib_export::covariance::{CovarianceView, intrinsics_covariance};
use calib_export::{ReportInput, write_report};

fn data(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data/sourishg1")
        .join(name)
}

/// A minimal XML well-formedness check: tags nest and close, attributes are quoted, the root is
/// `<svg>`. (Headless Chromium rendering: docs/after-calibration.md, `benches/after/render.sh`.)
fn well_formed_svg(text: &str) -> Result<(), String> {
    let body = text.trim_start();
    let body = match body.strip_prefix("<?xml") {
        Some(rest) => &rest[rest.find("?>").ok_or("unterminated declaration")? + 2..],
        None => body,
    };
    let mut stack: Vec<String> = Vec::new();
    let mut rest = body;
    let mut saw_root = false;
    while let Some(start) = rest.find('<') {
        let end = rest[start..].find('>').ok_or("unterminated tag")? + start;
        let tag = &rest[start + 1..end];
        if tag.starts_with("!--") || tag.starts_with('?') || tag.starts_with('!') {
        } else if let Some(name) = tag.strip_prefix('/') {
            let open = stack
                .pop()
                .ok_or(format!("</{name}> without opening tag"))?;
            if open != name.trim() {
                return Err(format!("<{open}> closed by </{name}>"));
            }
        } else {
            let name = tag
                .split_whitespace()
                .next()
                .unwrap_or("")
                .trim_end_matches('/')
                .to_string();
            if !saw_root {
                if name != "svg" {
                    return Err(format!("root element <{name}>"));
                }
                saw_root = true;
            }
            if tag.matches('"').count() % 2 != 0 {
                return Err(format!("unbalanced quotes in <{tag}>"));
            }
            if !tag.ends_with('/') {
                stack.push(name);
            }
        }
        rest = &rest[end + 1..];
    }
    if !saw_root || !stack.is_empty() {
        return Err(format!("unclosed elements {stack:?}"));
    }
    Ok(())
}

fn check_report(dir: &std::path::Path, expected_images: usize) {
    let page = std::fs::read_to_string(dir.join("index.html")).unwrap();
    let sources: Vec<&str> = page
        .split("<img src=\"")
        .skip(1)
        .map(|s| &s[..s.find('"').unwrap()])
        .collect();
    assert_eq!(sources.len(), expected_images, "{sources:?}");
    for src in sources {
        let text = std::fs::read_to_string(dir.join(src)).unwrap_or_else(|e| panic!("{src}: {e}"));
        well_formed_svg(&text).unwrap_or_else(|e| panic!("{src}: {e}"));
        assert!(
            !text.contains("NaN") && !text.contains("inf\""),
            "{src} has non-finite coordinates"
        );
    }
}

#[test]
fn single_and_stereo_reports_reference_existing_well_formed_svgs() {
    let dir = std::env::temp_dir().join(format!("calib-export-report-{}", std::process::id()));
    let obs = calib_single::Observations::read(data("left.json")).unwrap();
    let result =
        calib_single::calibrate(&obs, &calib_single::CalibrationOptions::default()).unwrap();
    write_report(
        &ReportInput::single(&result, Some(&obs)).unwrap(),
        &dir.join("single"),
    )
    .unwrap();
    check_report(&dir.join("single"), 7);
    // Without observations: the four plots that need none.
    write_report(
        &ReportInput::single(&result, None).unwrap(),
        &dir.join("bare"),
    )
    .unwrap();
    check_report(&dir.join("bare"), 3);
    let stereo = calib_stereo::StereoObservations::read(data("stereo.json")).unwrap();
    let rig =
        calib_stereo::calibrate_stereo(&stereo, &calib_stereo::StereoOptions::default()).unwrap();
    write_report(
        &ReportInput::stereo(&rig, Some(&stereo)).unwrap(),
        &dir.join("stereo"),
    )
    .unwrap();
    check_report(&dir.join("stereo"), 14);
    // A result with the wrong observation file is refused.
    assert!(
        ReportInput::stereo(
            &rig,
            Some(&calib_stereo::StereoObservations {
                image_size: None,
                right_image_size: None,
                pairs: Vec::new()
            })
        )
        .is_err()
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The report's covariance (numerical Jacobians, Schur complement) against the calibration's own
/// (analytic Jacobians, lm-solver's covariance): the standard deviations of fx, fy, cx, cy and
/// the distortion agree to 1% (differences: finite differences ~1e-6, the parameterization of
/// the poses, which does not change the marginal covariance of the intrinsics).
#[test]
fn covariance_matches_the_calibrations_standard_deviations() {
    let obs = calib_single::Observations::read(data("left.json")).unwrap();
    let result =
        calib_single::calibrate(&obs, &calib_single::CalibrationOptions::default()).unwrap();
    let views: Vec<CovarianceView> = result
        .views
        .iter()
        .map(|v| {
            let view = &obs.views[v.index];
            let keep: Vec<usize> = (0..view.object_points.len())
                .filter(|i| !v.rejected_points.contains(i))
                .collect();
            CovarianceView {
                pose: v.pose,
                object: keep.iter().map(|&i| view.object_points[i]).collect(),
                pixels: keep.iter().map(|&i| view.image_points[i].coords).collect(),
            }
        })
        .collect();
    let c = intrinsics_covariance(&result.camera, &views, &[]).unwrap();
    let reported: Vec<f64> = result
        .intrinsics_std
        .iter()
        .chain(&result.distortion_std)
        .copied()
        .collect();
    for (i, s) in reported.iter().enumerate() {
        let ours = c[(i, i)].sqrt();
        assert!((ours - s).abs() < 0.01 * s, "parameter {i}: {ours} vs {s}");
    }
}
