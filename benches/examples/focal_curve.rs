//! Debug: prints the start's focal score curve of one population problem.
use calib_core::init::{focal_score, scoring_views};
use calib_single::synthetic::generate;

fn main() {
    let seed: u64 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(134);
    let config = calib_core::synthetic::population(seed);
    let set = generate(&config).unwrap();
    let size = set.observations.image_size.unwrap();
    let views: Vec<_> = set.observations.views.iter().enumerate().collect();
    let prepared = calib_core::prepare_camera(&views, Some(size), &Default::default()).unwrap();
    let pts: Vec<_> = set
        .observations
        .views
        .iter()
        .map(|v| (v.object_points.as_slice(), v.image_points.as_slice()))
        .collect();
    let scoring = scoring_views(
        &prepared.homographies,
        &pts,
        calib_core::init::SCORING_POINTS,
    );
    let (cx, cy) = size.centre();
    println!(
        "true f {:.1} k {:?} noise {:.2} start {:?} {:?}",
        config.intrinsics.fx,
        config.distortion,
        config.noise_px,
        prepared.initial.intrinsics.fx,
        prepared.start_method
    );
    let b = calib_core::init::initial_intrinsics(
        &prepared.homographies,
        size,
        calib_core::FocalInit::Bouguet,
    )
    .map(|k| k.fx);
    let l = calib_core::init::initial_intrinsics(
        &prepared.homographies,
        size,
        calib_core::FocalInit::LeastSquares,
    )
    .map(|k| k.fx);
    println!("bouguet {b:?} ls {l:?}");
    if std::env::args().nth(2).is_some() {
        return;
    }
    for i in 0..60 {
        let f = 20.0 * (1.1f64).powi(i);
        let mut o = calib_single::CalibrationOptions::default();
        o.fix_focal_length = true;
        o.intrinsic_guess = Some(calib_core::camera_model::Intrinsics::new(f, f, cx, cy));
        o.compute_uncertainty = false;
        let full = calib_single::calibrate(&set.observations, &o)
            .map(|r| r.rms)
            .unwrap_or(f64::NAN);
        println!(
            "{f:8.1} {:10.4} {:10.4}",
            focal_score(
                f,
                cx,
                cy,
                &calib_core::init::ScoringCamera {
                    model: config.model,
                    fixed: vec![]
                },
                &scoring
            ),
            full
        );
    }
}
