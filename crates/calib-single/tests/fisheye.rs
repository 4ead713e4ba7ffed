//! Fisheye lenses (kannala-brandt4 on the equidistant projection): the start searches the focal
//! length of an equidistant camera (`init::fisheye_search`) and converges on fields of view from
//! 60 to 190 degrees, boards spread out to the edge of the field, 3 to 25 views, noise up to
//! 1.5 px, tilts down to 8 degrees.

use calib_core::synthetic::fisheye_population;
use calib_single::synthetic::generate;
use calib_single::{CalibrationOptions, calibrate};
use camera_model::CameraModel;

#[test]
fn fisheye_lenses_converge_from_60_to_190_degrees() {
    let mut options = CalibrationOptions::default();
    options.model = CameraModel::KannalaBrandt4;
    let (mut at_minimum, mut widest) = (0, 0.0f64);
    let problems = 120;
    for seed in 0..problems {
        // Fields of view spread over 60 to 190 degrees, in an order unrelated to the seed.
        let fov = 60.0 + 130.0 * ((seed * 37) % problems) as f64 / (problems - 1) as f64;
        let config = fisheye_population(seed, fov);
        let set = generate(&config).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        // The widest angle off the axis that the boards reach.
        for (view, pose) in set.observations.views.iter().zip(&set.poses) {
            for x in &view.object_points {
                let s = pose.transform_point(x);
                widest = widest.max(s.xy().norm().atan2(s.z).to_degrees());
            }
        }
        let mut truth = options.clone();
        truth.intrinsic_guess = Some(set.camera.intrinsics);
        truth.distortion_guess = Some(set.camera.distortion.clone());
        let reference = calibrate(&set.observations, &truth).unwrap();
        let result = calibrate(&set.observations, &options)
            .unwrap_or_else(|e| panic!("seed {seed} (fov {fov:.0}): {e}"));
        assert!(
            result.solver.termination.is_converged(),
            "seed {seed} (fov {fov:.0}): {}",
            result.solver.termination
        );
        assert!(
            result.rms_all_points <= reference.rms_all_points + 1e-5,
            "seed {seed} (fov {fov:.0}): rms {} vs {} from the truth (start f {:.1}, true {:.1})",
            result.rms_all_points,
            reference.rms_all_points,
            result.initial_intrinsics.fx,
            config.intrinsics.fx
        );
        assert_eq!(result.initial_method.name(), "fisheye-focal-search");
        at_minimum += 1;
    }
    println!("{at_minimum}/{problems} at the minimum; boards reach {widest:.1} deg off the axis");
    assert!(widest > 75.0, "{widest}");
}

#[test]
fn noise_free_fisheye_data_recovers_the_camera() {
    let mut config = fisheye_population(3, 160.0);
    config.noise_px = 0.0;
    let set = generate(&config).unwrap();
    let mut options = CalibrationOptions::default();
    options.model = CameraModel::KannalaBrandt4;
    let result = calibrate(&set.observations, &options).unwrap();
    let (a, b) = (result.camera.params(), set.camera.params());
    for i in 0..8 {
        assert!(
            (a[i] - b[i]).abs() <= 1e-8 * b[i].abs().max(1.0),
            "parameter {i}: {} vs {}",
            a[i],
            b[i]
        );
    }
}

/// A fisheye lens fitted with a pinhole model too simple for it gets the `model-misfit` warning
/// (its radial errors change with the distance from the principal point far beyond the noise,
/// and its sigmas cover the noise only); fitted with kannala-brandt4 it does not, nor does the
/// noise-free fit.
#[test]
fn a_lens_model_too_simple_for_the_lens_is_called_a_misfit() {
    let mut config = fisheye_population(5, 150.0);
    config.views = 20;
    config.noise_px = 0.3;
    config.max_tilt_deg = 45.0;
    let set = generate(&config).unwrap();
    let misfit = |model: CameraModel, observations| {
        let mut options = CalibrationOptions::default();
        options.model = model;
        let result = calibrate(observations, &options).unwrap();
        result
            .warnings
            .iter()
            .any(|w| w.code == calib_core::WarningCode::ModelMisfit)
    };
    assert!(misfit(CameraModel::BrownConrady4, &set.observations));
    assert!(!misfit(CameraModel::KannalaBrandt4, &set.observations));
    config.noise_px = 0.0;
    let clean = generate(&config).unwrap();
    assert!(!misfit(CameraModel::KannalaBrandt4, &clean.observations));
}
