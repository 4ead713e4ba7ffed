//! Data that cannot determine the answer is refused or carries a warning, never a silent number
//! (issue 11, finding 4).

use calib_core::WarningCode;
use calib_single::synthetic::{SyntheticConfig, generate};
use calib_single::{CalibrationError, CalibrationOptions, ImageSize, calibrate};

fn has(result: &calib_single::Calibration, code: WarningCode) -> bool {
    result.warnings.iter().any(|w| w.code == code)
}

/// 29 copies of one view: the copies are dropped with a warning, and what remains (one view)
/// cannot pretend to be a calibration: the focal length comes with a warning, not a confident
/// wrong number.
#[test]
fn copies_of_one_view_are_dropped_and_reported() {
    let set = generate(&SyntheticConfig::default()).unwrap();
    let mut obs = set.observations.clone();
    obs.views = vec![obs.views[3].clone(); 29];
    match calibrate(&obs, &CalibrationOptions::default()) {
        Ok(result) => {
            assert_eq!(result.views.len(), 1);
            assert!(has(&result, WarningCode::DuplicateViews));
            assert!(
                has(&result, WarningCode::PoorlyDetermined),
                "{:?}",
                result.warnings
            );
        }
        // Or refused as undetermined: also acceptable, as long as it is not silent.
        Err(e) => assert!(matches!(e, CalibrationError::NotDetermined { .. }), "{e}"),
    }
    // Copies among good views: dropped, the rest calibrates normally.
    let mut obs = set.observations.clone();
    obs.views.push(obs.views[0].clone());
    obs.views.push(obs.views[5].clone());
    let result = calibrate(&obs, &CalibrationOptions::default()).unwrap();
    assert_eq!(result.views.len(), set.observations.views.len());
    let w = result
        .warnings
        .iter()
        .find(|w| w.code == WarningCode::DuplicateViews)
        .unwrap();
    assert!(w.message.contains("view 20 = view 0"), "{}", w.message);
    assert!(w.message.contains("view 21 = view 5"), "{}", w.message);
}

/// Points outside the stated image: refused, naming the view and point.
#[test]
fn points_outside_the_image_are_refused() {
    let set = generate(&SyntheticConfig::default()).unwrap();
    let mut obs = set.observations.clone();
    obs.image_size = Some(ImageSize::new(1, 1));
    let err = calibrate(&obs, &CalibrationOptions::default()).unwrap_err();
    assert!(
        matches!(err, CalibrationError::PointOutsideImage { view: 0, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("image size"), "{err}");
}

/// One view's pixels scaled x100 (a unit slip): refused with the view named, or dropped with
/// `skip_bad_views`.
#[test]
fn a_scaled_view_is_named() {
    let set = generate(&SyntheticConfig::default()).unwrap();
    let mut obs = set.observations.clone();
    for p in obs.views[6].image_points.iter_mut() {
        p.x *= 100.0;
        p.y *= 100.0;
    }
    let err = calibrate(&obs, &CalibrationOptions::default()).unwrap_err();
    assert!(
        matches!(err, CalibrationError::PointOutsideImage { view: 6, .. }),
        "{err}"
    );
    let mut skip = CalibrationOptions::default();
    skip.skip_bad_views = true;
    let result = calibrate(&obs, &skip).unwrap();
    assert_eq!(result.skipped_views[0].index, 6);
}

/// A wrong image size that still contains the points (points in the top-left corner of a much
/// larger stated image): the principal point ends far from the stated centre, with a warning.
#[test]
fn a_wrong_image_size_puts_a_warning_on_the_principal_point() {
    let set = generate(&SyntheticConfig::default()).unwrap();
    let mut obs = set.observations.clone();
    obs.image_size = Some(ImageSize::new(1920, 1440));
    let result = calibrate(&obs, &CalibrationOptions::default()).unwrap();
    assert!(
        has(&result, WarningCode::PrincipalPointOffCentre),
        "{:?}",
        result.warnings
    );
    let clean = calibrate(&set.observations, &CalibrationOptions::default()).unwrap();
    assert!(clean.warnings.is_empty(), "{:?}", clean.warnings);
}

/// A view whose error is far above the others' (points from a different lens, kept because
/// outlier rejection is off) gets a warning naming it.
#[test]
fn an_inconsistent_view_is_named_in_a_warning() {
    let config = SyntheticConfig::default();
    let set = generate(&config).unwrap();
    let mut obs = set.observations.clone();
    let k = config.intrinsics;
    for p in obs.views[9].image_points.iter_mut() {
        let (x, y) = ((p.x - k.cx) / k.fx, (p.y - k.cy) / k.fy);
        let s = 1.0 + 0.6 * (x * x + y * y);
        p.x = k.cx + k.fx * x * s;
        p.y = k.cy + k.fy * y * s;
    }
    let mut off = CalibrationOptions::default();
    off.outliers = None;
    let result = calibrate(&obs, &off).unwrap();
    let w = result
        .warnings
        .iter()
        .find(|w| w.code == WarningCode::InconsistentView)
        .unwrap_or_else(|| panic!("{:?}", result.warnings));
    assert!(w.message.contains("view 9"), "{}", w.message);
    assert!(result.summary().contains("inconsistent-view"));
}
