//! Calibration from our own corners (crate `board-detect`) on the bundled photographs: every
//! board is found, and the RMS is at or below the one OpenCV 5 reaches from the bundled corner
//! files (OpenCV's detector with a per-corner window choice), read from the reference files.

use board_detect::{Board, DetectOptions, detect_files, observations_json};
use calib_core::JsonFile;
use calib_single::{CalibrationOptions, Observations, calibrate};
use std::path::PathBuf;

fn data(path: &str) -> PathBuf {
    PathBuf::from(format!("{}/../../data/{path}", env!("CARGO_MANIFEST_DIR")))
}

#[test]
fn our_corners_calibrate_at_or_below_opencvs_rms() {
    for set in ["sourishg1", "sourishg2"] {
        for camera in ["left", "right"] {
            let corners = Observations::read(data(&format!("{set}/{camera}.json"))).unwrap();
            let square = corners.views[0].object_points[1].x;
            let paths: Vec<PathBuf> = corners
                .views
                .iter()
                .map(|v| data(&format!("{set}/images/{}", v.name)))
                .collect();
            let board = Board::new(9, 6, square).unwrap();
            let results = detect_files(&paths, &board, &DetectOptions::default(), None);
            let found = results.iter().filter(|r| r.outcome.is_ok()).count();
            assert_eq!(found, paths.len(), "{set}/{camera}");
            let file = observations_json(&results, &board);
            let ours = Observations::from_file(serde_json::from_value(file).unwrap());
            let mut options = CalibrationOptions::default();
            options.outliers = None;
            let result = calibrate(&ours, &options).unwrap();
            let reference: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(data(&format!("{set}/reference/opencv5_{camera}.json")))
                    .unwrap(),
            )
            .unwrap();
            let opencv = reference["results"]["fix_k3"]["rms"].as_f64().unwrap();
            println!(
                "{set}/{camera}: {found} boards, rms {:.4} (OpenCV corners {opencv:.4})",
                result.rms
            );
            assert!(
                result.rms <= opencv,
                "{set}/{camera}: {} vs {opencv}",
                result.rms
            );
        }
    }
}
