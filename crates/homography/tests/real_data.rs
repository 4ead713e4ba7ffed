//! Real detections: 29 views of a 9 x 6 chessboard (24.23 mm squares) from a 640 x 360
//! webcam (data/sourishg1/left.json, OpenCV pixel convention). The lens distortion is not
//! modelled by a homography, so the residuals are small but not zero.

mod common;

use homography::{RefineOptions, RefineTermination, dlt, estimate, reprojection_rms};

const LEFT: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../data/sourishg1/left.json"
);

#[test]
fn every_real_view_fits_within_two_pixels() {
    let views = common::read_views(LEFT);
    assert_eq!(views.len(), 29);
    println!("view  N   DLT rms   refined rms  iterations  termination");
    for (i, v) in views.iter().enumerate() {
        assert_eq!(v.object.len(), 54);
        let est = estimate(&v.object, &v.image, &RefineOptions::default())
            .unwrap_or_else(|e| panic!("view {}: {e}", i + 1));
        println!(
            "{:>4} {:>3} {:>9.4} {:>12.4} {:>11} {:?}",
            i + 1,
            v.object.len(),
            est.dlt_rms,
            est.rms,
            est.iterations,
            est.termination
        );
        assert!(est.rms < 2.0, "view {}: rms {} px", i + 1, est.rms);
        assert!(est.rms <= est.dlt_rms);
        assert!(
            matches!(
                est.termination,
                RefineTermination::StepTolerance | RefineTermination::CostTolerance
            ),
            "view {}: {:?}",
            i + 1,
            est.termination
        );
        let h_dlt = dlt(&v.object, &v.image).unwrap();
        assert_eq!(reprojection_rms(&h_dlt, &v.object, &v.image), est.dlt_rms);
    }
}
