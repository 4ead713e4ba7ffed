//! Sigma honesty: over many seeds, the errors of the estimates divided by their reported
//! standard deviations have unit variance (the covariance is right, neither optimistic nor
//! pessimistic).

use calib_rig::synthetic::{RigLayout, SyntheticRigConfig, generate_rig};
use calib_rig::{RigOptions, calibrate_rig};

#[test]
fn reported_sigmas_match_the_spread_of_the_errors() {
    let seeds = 60;
    // z-scores per kind of parameter, over every non-reference camera of every seed.
    let mut intrinsics = Vec::new();
    let mut distortion = Vec::new();
    let mut translation = Vec::new();
    for seed in 0..seeds {
        let mut config = SyntheticRigConfig {
            cameras: 3,
            frames: 24,
            layout: RigLayout::Line { spacing: 0.5 },
            ..Default::default()
        };
        config.base.noise_px = 0.5;
        config.base.seed = 100 + seed;
        let data = generate_rig(&config).unwrap();
        let mut options = RigOptions::default();
        options.outliers = None;
        let rig = calibrate_rig(&data.observations, &options).unwrap();
        for (c, camera) in rig.cameras.iter().enumerate().skip(1) {
            let e = &camera.estimate;
            let (k, t) = (e.camera.intrinsics, data.cameras[c].intrinsics);
            for (i, (x, y)) in [(k.fx, t.fx), (k.fy, t.fy), (k.cx, t.cx), (k.cy, t.cy)]
                .into_iter()
                .enumerate()
            {
                intrinsics.push((x - y) / e.intrinsics_std[i]);
            }
            for (i, (x, y)) in e
                .camera
                .distortion
                .iter()
                .zip(&data.cameras[c].distortion)
                .enumerate()
            {
                distortion.push((x - y) / e.distortion_std[i]);
            }
            let d = camera.transform.translation - data.transforms[c].translation;
            for i in 0..3 {
                translation.push(d[i] / camera.transform_std[3 + i]);
            }
        }
    }
    for (what, z) in [
        ("intrinsics", &intrinsics),
        ("distortion", &distortion),
        ("translation", &translation),
    ] {
        let n = z.len() as f64;
        let mean_square = z.iter().map(|v| v * v).sum::<f64>() / n;
        // Errors of one camera's parameters are correlated, so the effective sample is smaller
        // than n: at least the 60 seeds. Chi-square over 60 degrees of freedom divided by 60 lies
        // within 0.55..1.6 with probability above 99.8%.
        println!("{what}: {} z-scores, mean square {mean_square:.3}", z.len());
        assert!(
            (0.55..1.6).contains(&mean_square),
            "{what}: mean square z {mean_square}"
        );
    }
}
