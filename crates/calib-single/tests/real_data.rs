//! Real observations (corners detected in real photographs): the calibration must reach the
//! minimum OpenCV 5 reaches on the same observations with k3 fixed to zero (the same model).
//! The reference numbers are read from the bundled data files, never written here.

use calib_core::JsonFile;
use calib_single::{CalibrationOptions, Observations, calibrate};
use serde_json::Value;

fn data(path: &str) -> String {
    format!("{}/../../data/{path}", env!("CARGO_MANIFEST_DIR"))
}

fn reference(set: &str, camera: &str) -> Value {
    let text =
        std::fs::read_to_string(data(&format!("{set}/reference/opencv5_{camera}.json"))).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn reaches_opencv_minimum_on_all_real_sets() {
    for set in ["sourishg1", "sourishg2"] {
        for camera in ["left", "right"] {
            let obs = Observations::read(data(&format!("{set}/{camera}.json"))).unwrap();
            let result = calibrate(&obs, &CalibrationOptions::default())
                .unwrap_or_else(|e| panic!("{set}/{camera}: {e}"));
            let r = &reference(set, camera)["results"]["fix_k3"];
            let k = &result.camera.intrinsics;
            let f = |key: &str| r[key].as_f64().unwrap();
            println!(
                "{set}/{camera}: rms {:.9} (OpenCV {:.9}), fx {:.5} ({:.5}), fy {:.5} ({:.5}), cx {:.5} ({:.5}), cy {:.5} ({:.5}), {} iterations, {:.2} ms",
                result.rms,
                f("rms"),
                k.fx,
                f("fx"),
                k.fy,
                f("fy"),
                k.cx,
                f("cx"),
                k.cy,
                f("cy"),
                result.solver.iterations.len(),
                result.elapsed.as_secs_f64() * 1e3
            );
            assert!(
                result.solver.termination.is_converged(),
                "{set}/{camera}: {}",
                result.solver.termination
            );
            assert!(
                (result.rms - f("rms")).abs() < 1e-5,
                "{set}/{camera}: rms {} vs {}",
                result.rms,
                f("rms")
            );
            for (ours, key) in [(k.fx, "fx"), (k.fy, "fy"), (k.cx, "cx"), (k.cy, "cy")] {
                assert!(
                    (ours - f(key)).abs() < 0.01,
                    "{set}/{camera}: {key} {ours} vs {}",
                    f(key)
                );
            }
            // Same minimum, so the distortion agrees too (to well within its uncertainty).
            let dist = result.distortion_coefficients();
            for (i, key) in ["k1", "k2", "p1", "p2"].iter().enumerate() {
                assert!(
                    (dist[i] - f(key)).abs() < 0.05 * result.distortion_std[i],
                    "{set}/{camera}: {key} {} vs {}",
                    dist[i],
                    f(key)
                );
            }
            // OpenCV scales (J^T J)^-1 by the same residual variance: the standard deviations of
            // the intrinsics agree to a few percent (OpenCV's Jacobian is numerically different
            // only in rounding, so differences come from its use of all 14 distortion slots).
            let std = &r["std_deviations_intrinsics"];
            for (i, key) in ["fx", "fy", "cx", "cy"].iter().enumerate() {
                let theirs = std[key].as_f64().unwrap();
                let ours = result.intrinsics_std[i];
                assert!(
                    (ours / theirs - 1.0).abs() < 0.05,
                    "{set}/{camera}: sigma {key} {ours} vs {theirs}"
                );
            }
            assert_eq!(result.num_points, r["n_points"].as_u64().unwrap() as usize);
        }
    }
}

#[test]
fn per_view_rms_and_bouguet_pixel_error_match_opencv() {
    let obs = Observations::read(data("sourishg1/left.json")).unwrap();
    let result = calibrate(&obs, &CalibrationOptions::default()).unwrap();
    let r = &reference("sourishg1", "left")["results"]["fix_k3"];
    let per_view: Vec<f64> = r["per_view_rms"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(per_view.len(), result.views.len());
    for (view, theirs) in result.views.iter().zip(&per_view) {
        assert!(
            (view.rms - theirs).abs() < 1e-4,
            "{}: {} vs {theirs}",
            view.name,
            view.rms
        );
    }
    let bouguet = r["bouguet_err_std_xy"].as_array().unwrap();
    for (ours, theirs) in result.residual_std.iter().zip(bouguet) {
        let theirs = theirs.as_f64().unwrap();
        assert!((ours - theirs).abs() < 1e-5, "{ours} vs {theirs}");
    }
}

/// brown-conrady5 (k3 free) reaches OpenCV 5's default minimum (`results.default` of the bundled
/// references): RMS within 1e-5 px, intrinsics within 0.01 px.
#[test]
fn brown_conrady5_reaches_opencvs_default_minimum() {
    for set in ["sourishg1", "sourishg2"] {
        for camera in ["left", "right"] {
            let obs = Observations::read(data(&format!("{set}/{camera}.json"))).unwrap();
            let mut options = CalibrationOptions::default();
            options.model = camera_model::CameraModel::BrownConrady5;
            options.outliers = None;
            let result = calibrate(&obs, &options).unwrap();
            let r = &reference(set, camera)["results"]["default"];
            let f = |key: &str| r[key].as_f64().unwrap();
            assert!(
                (result.rms - f("rms")).abs() < 1e-5,
                "{set}/{camera}: rms {} vs {}",
                result.rms,
                f("rms")
            );
            let k = &result.camera.intrinsics;
            for (ours, key) in [(k.fx, "fx"), (k.fy, "fy"), (k.cx, "cx"), (k.cy, "cy")] {
                assert!(
                    (ours - f(key)).abs() < 0.01,
                    "{set}/{camera}: {key} {ours} vs {}",
                    f(key)
                );
            }
        }
    }
}
