//! Choosing a lens model (`compare_models`): the recommendation on data of a known lens, and
//! coefficients held fixed by name in every model.

use calib_core::synthetic::{SyntheticConfig, default_distortion};
use calib_single::compare::{self, MODELS};
use calib_single::synthetic::generate;
use calib_single::{CalibrationOptions, ModelComparison, Observations, compare_models};
use camera_model::{CameraModel, Intrinsics};

/// 20 views of a lens of `model` with its default distortion and 0.2 px of noise.
fn views_of(model: CameraModel, intrinsics: Intrinsics) -> Observations {
    let config = SyntheticConfig {
        model,
        distortion: default_distortion(model),
        intrinsics,
        views: 20,
        noise_px: 0.2,
        seed: 3,
        ..Default::default()
    };
    generate(&config).unwrap().observations
}

fn row(comparison: &ModelComparison, model: CameraModel) -> &calib_single::ModelRow {
    comparison.rows.iter().find(|r| r.model == model).unwrap()
}

#[test]
fn the_simplest_adequate_model_is_recommended() {
    // A brown-conrady4 lens: the richer pinhole models fit its noise a little better, and no
    // better on the held-out views; brown-conrady4 has the fewest parameters.
    let pinhole = views_of(
        CameraModel::BrownConrady4,
        Intrinsics::new(800.0, 800.0, 319.5, 239.5),
    );
    let c = compare_models(&pinhole, &CalibrationOptions::default(), &MODELS, &[]);
    assert_eq!(
        c.recommended,
        Some(CameraModel::BrownConrady4),
        "{}",
        c.table()
    );
    let simple = row(&c, CameraModel::BrownConrady4);
    let rational = row(&c, CameraModel::Rational8);
    // More terms: a lower RMS on the fitted views, not a lower cross-validated one.
    assert!(
        rational.rms.unwrap() <= simple.rms.unwrap(),
        "{}",
        c.table()
    );
    assert!(
        simple.cross_validated_rms.unwrap() <= rational.cross_validated_rms.unwrap() * 1.02,
        "{}",
        c.table()
    );
    assert_eq!(simple.parameters, 8);
    assert!(c.held_fixed.is_empty());
    assert!(c.gap_to_best_fit.unwrap() <= 0.02, "{}", c.table());

    // A 150-degree fisheye: the pinhole models cannot follow it, kannala-brandt4 can.
    let f = 400.0 / 75f64.to_radians();
    let fisheye = views_of(
        CameraModel::KannalaBrandt4,
        Intrinsics::new(f, f, 322.0, 236.0),
    );
    let c = compare_models(&fisheye, &CalibrationOptions::default(), &MODELS, &[]);
    assert_eq!(
        c.recommended,
        Some(CameraModel::KannalaBrandt4),
        "{}",
        c.table()
    );
    let kb = row(&c, CameraModel::KannalaBrandt4);
    // Its held-out error is the noise's order (0.2 px per coordinate).
    assert!(kb.cross_validated_rms.unwrap() < 0.4, "{}", c.table());
}

/// A wide lens with strong rational and prism terms (one-to-one over its image) whose views do
/// not reach the image corners: every model that fits it folds inside the image, and the valid
/// ones fit clearly worse. The comparison recommends the best valid one but says that it is not
/// adequate, instead of calling it "within 2% of the best" (a helper audit's finding: 13% to 57%
/// above the best fit, presented as adequate).
#[test]
fn a_recommendation_that_fits_worse_than_a_folding_model_says_so() {
    let config = SyntheticConfig {
        model: CameraModel::ThinPrism12,
        distortion: vec![
            1.5, 0.3, 0.001, -0.0005, 0.01, 1.8, 0.6, 0.05, 0.01, -0.004, 0.008, 0.002,
        ],
        intrinsics: Intrinsics::new(300.0, 300.0, 319.5, 239.5),
        views: 25,
        noise_px: 0.2,
        seed: 2,
        ..Default::default()
    };
    let obs = generate(&config).unwrap().observations;
    let c = compare_models(&obs, &CalibrationOptions::default(), &MODELS, &[]);
    let table = c.table();
    let recommended = c.recommended.expect("a valid model");
    let best = c.best_fit.expect("a fitted model");
    let gap = c.gap_to_best_fit.unwrap();
    let score = |m| {
        let r = row(&c, m);
        r.cross_validated_rms.unwrap()
    };
    assert!(
        (gap - (score(recommended) / score(best) - 1.0)).abs() < 1e-12,
        "{table}"
    );
    assert!(gap > 0.02, "{table}");
    assert!(!row(&c, best).valid_over_image, "{table}");
    assert!(table.contains("no model both fits this lens"), "{table}");
    assert!(!table.contains("within 2% of the best"), "{table}");
}

#[test]
fn held_coefficients_are_matched_by_name_in_every_model() {
    let obs = views_of(
        CameraModel::BrownConrady4,
        Intrinsics::new(800.0, 800.0, 319.5, 239.5),
    );
    let models = [
        CameraModel::BrownConrady4,
        CameraModel::BrownConrady5,
        CameraModel::KannalaBrandt4,
    ];
    let plain = compare_models(&obs, &CalibrationOptions::default(), &models, &[]);
    // p1, p2 exist in the pinhole models only: kannala-brandt4's third and fourth coefficients
    // are k3, k4, and must not be held in their place (it has no tangential terms: its fit is
    // the plain one).
    let c = compare_models(&obs, &CalibrationOptions::default(), &models, &["p1", "p2"]);
    assert_eq!(c.held_fixed, ["p1", "p2"]);
    assert!(
        c.table()
            .contains("held at zero in every model that has them: p1, p2")
    );
    assert_eq!(row(&c, CameraModel::BrownConrady4).parameters, 6);
    assert_eq!(row(&c, CameraModel::BrownConrady5).parameters, 7);
    assert_eq!(row(&c, CameraModel::KannalaBrandt4).parameters, 8);
    assert_eq!(
        row(&c, CameraModel::KannalaBrandt4).rms,
        row(&plain, CameraModel::KannalaBrandt4).rms
    );
    // Holding the tangential terms costs the pinhole fits something (the lens has p1, p2).
    let bc4 = row(&c, CameraModel::BrownConrady4).rms.unwrap();
    assert!(bc4 > row(&plain, CameraModel::BrownConrady4).rms.unwrap() + 1e-6);

    // The options' own held coefficients (indices in the options' model) carry over by name:
    // brown-conrady5's k3 is held as kannala-brandt4's k3, brown-conrady4 has none, and
    // brown-conrady5 with k3 held is brown-conrady4.
    let mut options = CalibrationOptions::default();
    options.model = CameraModel::BrownConrady5;
    options.fix_distortion_by_name(&["k3"]).unwrap();
    let c = compare_models(&obs, &options, &models, &[]);
    assert_eq!(c.held_fixed, ["k3"]);
    assert_eq!(row(&c, CameraModel::KannalaBrandt4).parameters, 7);
    assert_ne!(
        row(&c, CameraModel::KannalaBrandt4).rms,
        row(&plain, CameraModel::KannalaBrandt4).rms
    );
    let (bc4, bc5) = (
        row(&c, CameraModel::BrownConrady4).rms.unwrap(),
        row(&c, CameraModel::BrownConrady5).rms.unwrap(),
    );
    assert!((bc4 - bc5).abs() < 1e-9, "{}", c.table());
    assert_eq!(bc4, row(&plain, CameraModel::BrownConrady4).rms.unwrap());
}

#[test]
fn options_carry_held_coefficients_to_another_model_by_name() {
    let mut options = CalibrationOptions::default();
    options.fix_distortion_by_name(&["k2", "p1"]).unwrap();
    options.distortion_guess = Some(vec![0.1, 0.0, 0.0, 0.0]);
    let rational = options.for_model(CameraModel::Rational8);
    assert_eq!(rational.fixed_distortion, [1, 2]);
    // A guess is one model's coefficients.
    assert_eq!(rational.distortion_guess, None);
    // kannala-brandt4 has k2 (index 1) and no p1.
    assert_eq!(
        options
            .for_model(CameraModel::KannalaBrandt4)
            .fixed_distortion,
        [1]
    );
    assert_eq!(options.for_model(CameraModel::BrownConrady4), options);
}

/// Without cross-validation (3 views) nothing is recommended: on the fitted views the model with
/// the most terms always has the lowest RMS, and ranking by it recommended thin-prism12 on one
/// view of a brown-conrady4 lens.
#[test]
fn too_few_views_to_cross_validate_give_no_recommendation() {
    let mut three = views_of(
        CameraModel::BrownConrady4,
        Intrinsics::new(800.0, 800.0, 319.5, 239.5),
    );
    three.views.truncate(3);
    let c = compare_models(&three, &CalibrationOptions::default(), &MODELS, &[]);
    assert!(c.rows.iter().any(|r| r.rms.is_some()), "{}", c.table());
    assert!(c.rows.iter().all(|r| r.cross_validated_rms.is_none()));
    assert_eq!(c.recommended, None, "{}", c.table());
    assert!(
        c.table()
            .contains("no recommendation: no model could be cross-validated"),
        "{}",
        c.table()
    );
}

/// The parameter counts are the free ones: a held principal point, focal length or aspect
/// ratio and tangential terms held at zero are not counted (they counted before, so a table
/// made with `--fix-principal-point` gave brown-conrady4 8 parameters where 6 were fitted).
#[test]
fn held_intrinsics_are_not_counted_as_parameters() {
    use CameraModel::{BrownConrady4, BrownConrady5, KannalaBrandt4};
    let views = views_of(BrownConrady4, Intrinsics::new(800.0, 800.0, 319.5, 239.5));
    let mut pp = CalibrationOptions::default();
    pp.fix_principal_point = true;
    // And fy following fx, p1 and p2 held at zero: fx, k1, k2 (and k3) are left.
    let mut more = pp.clone();
    more.fix_aspect_ratio = true;
    more.zero_tangential_distortion = true;
    for (options, expected) in [
        (pp, [(BrownConrady4, 6), (KannalaBrandt4, 6)]),
        (more, [(BrownConrady4, 3), (BrownConrady5, 4)]),
    ] {
        let models = expected.map(|(m, _)| m);
        let c = compare_models(&views, &options, &models, &[]);
        for (model, parameters) in expected {
            assert_eq!(row(&c, model).parameters, parameters, "{}", c.table());
        }
    }
}

/// A 190-degree fisheye (kannala-brandt4, 30 views, 1 px of noise): the kannala-brandt4 fit is
/// one-to-one over the image but folds at 105% of the corner distance, inside the 5% margin of
/// `valid_over_image`. Before, the recommendation fell to the only model valid with the margin,
/// brown-conrady4, whose cross-validated RMS is five times the noise (a pinhole model cannot
/// follow a field beyond 180 degrees: errors of millions of pixels at the corners in
/// benches/compare_models); the fisheye model that fits is recommended now, and the table says
/// where it folds.
#[test]
fn a_fit_that_folds_just_beyond_the_border_is_preferred_to_one_that_misfits() {
    let f = 241.0;
    let config = SyntheticConfig {
        model: CameraModel::KannalaBrandt4,
        distortion: default_distortion(CameraModel::KannalaBrandt4),
        intrinsics: Intrinsics::new(f, f, 319.5, 239.5),
        views: 30,
        noise_px: 1.0,
        seed: 1,
        ..Default::default()
    };
    let obs = generate(&config).unwrap().observations;
    let c = compare_models(&obs, &CalibrationOptions::default(), &MODELS, &[]);
    let table = c.table();
    let kb = row(&c, CameraModel::KannalaBrandt4);
    // The case this test is about: folding within the margin, not inside the image.
    assert!(!kb.valid_over_image, "{table}");
    assert_eq!(c.recommended, Some(CameraModel::KannalaBrandt4), "{table}");
    // Its held-out error is the noise's (1 px per coordinate: 1.41 px), the pinhole model's
    // several times that.
    let cv = kb.cross_validated_rms.unwrap();
    assert!(cv < 1.6, "{table}");
    assert!(
        row(&c, CameraModel::BrownConrady4)
            .cross_validated_rms
            .unwrap()
            > 3.0 * cv,
        "{table}"
    );
    assert!(c.gap_to_best_fit.unwrap() <= 0.02, "{table}");
    assert!(
        table.contains("its fold lies within 5% beyond the border"),
        "{table}"
    );
}

/// Five views at 1 px of noise and 10 degrees of tilt: the valid models' fits on half of the
/// views fail, and the table says so instead of "no model is valid over the image" (they are).
#[test]
fn valid_models_that_cannot_be_cross_validated_are_not_called_invalid() {
    let config = SyntheticConfig {
        model: CameraModel::BrownConrady4,
        distortion: default_distortion(CameraModel::BrownConrady4),
        intrinsics: Intrinsics::new(800.0, 800.0, 319.5, 239.5),
        views: 5,
        noise_px: 1.0,
        max_tilt_deg: 10.0,
        seed: 1,
        ..Default::default()
    };
    let obs = generate(&config).unwrap().observations;
    let c = compare_models(&obs, &CalibrationOptions::default(), &MODELS, &[]);
    let table = c.table();
    let bc4 = row(&c, CameraModel::BrownConrady4);
    assert!(
        bc4.valid_over_image && bc4.cross_validated_rms.is_none(),
        "{table}"
    );
    assert_eq!(c.recommended, None, "{table}");
    assert!(
        !table.contains("no model is valid over the image"),
        "{table}"
    );
    assert!(
        table.contains("the models valid over the image could not be cross-validated"),
        "{table}"
    );
}

/// A brown-conrady5 lens whose k3 matters only at the image corners, seen by boards in the
/// middle of the image (`calib synth` places them in its middle 40%): brown-conrady4 is
/// recommended on most seeds, and is tens of pixels wrong at the image corners. The comparison
/// reports how far the models that fit as well disagree there, and that disagreement is of the
/// order of the recommended fit's true error at the place it names (within a factor of 2,
/// measured: ratios 0.84 to 1.6; the other model is no truth either). On seed 1 the paired
/// test finds brown-conrady4 systematically worse (2.3 standard errors) and recommends
/// brown-conrady5, the true model, which no other model one-to-one over the image fits as well:
/// nothing to report there, and the test checks that instead (it asserted a disagreement on
/// every seed before the paired test).
#[test]
fn equally_fitting_models_disagreeing_where_no_corner_was_seen_are_reported() {
    let mut reported = 0;
    for seed in 1..=6 {
        let config = SyntheticConfig {
            model: CameraModel::BrownConrady5,
            distortion: vec![-0.32, 0.1, 0.001, -0.0005, -0.012],
            intrinsics: Intrinsics::new(400.0, 400.0, 319.5, 239.5),
            views: 20,
            noise_px: 0.2,
            seed,
            ..Default::default()
        };
        let set = generate(&config).unwrap();
        let c = compare_models(
            &set.observations,
            &CalibrationOptions::default(),
            &MODELS,
            &[],
        );
        let recommended = c.recommended.unwrap();
        let Some(d) = c.uncovered_disagreement.clone() else {
            // Only when no other model valid over the image is as good.
            let reference = row(&c, c.reference.unwrap());
            assert!(
                c.rows.iter().all(|r| r.model == recommended
                    || !r.valid_over_image
                    || !compare::as_good_as(r, reference)),
                "seed {seed}: {}",
                c.table()
            );
            continue;
        };
        reported += 1;
        assert!(
            c.table().contains("where no board corner was seen"),
            "{}",
            c.table()
        );
        let (w, h) = (639.0, 479.0);
        let place = match d.place.as_str() {
            "top-left corner" => (0.0, 0.0),
            "top-right corner" => (w, 0.0),
            "bottom-right corner" => (w, h),
            "bottom-left corner" => (0.0, h),
            other => panic!("{other}: {}", c.table()),
        };
        let pixel = calib_single::nalgebra::Vector2::new(place.0, place.1);
        let mut options = CalibrationOptions::default().for_model(recommended);
        options.distortion_guess = None;
        let fit = calib_single::calibrate(&set.observations, &options).unwrap();
        let ray = fit
            .camera
            .pixel_to_ray(&pixel, &camera_model::UndistortOptions::default())
            .unwrap();
        let truth = set.camera.project_camera_point(&ray).unwrap();
        let error = (truth - pixel).norm();
        assert!(error > 3.0, "the test needs an error to find: {error}");
        assert!(
            d.pixels > error / 2.0 && d.pixels < 2.0 * error,
            "seed {seed}: disagreement {} px against the recommended fit's true error {error} px: {}",
            d.pixels,
            c.table()
        );
    }
    assert!(
        reported >= 4,
        "{reported} of 6 seeds reported a disagreement"
    )
}

/// A strong rational barrel lens (benches/compare_models' `rational-barrel`), 30 views at 0.3 px:
/// kannala-brandt4's cross-validated RMS is within 2% of rational8's, and the 2% rule
/// recommended it, with 15 px of error over the image against rational8's 0.54 px. The paired
/// test sees that the excess is systematic: a misfit of `delta` px^2 per point adds `n delta` to
/// each held-out view's squared error (n = 54 points, about `n 2 sigma^2` of noise), a log ratio
/// of `delta / (2 sigma^2)`, while the noise moves it by about `sqrt(delta / n) / sigma` per
/// view (the cross term of misfit and noise; the noise itself is the same for both models).
/// Over V = 30 views that is `sqrt(V n delta) / (2 sigma)` standard errors: 5 for the 3.5% seen
/// here (delta = 0.0063 px^2, sigma = 0.3 px), against a threshold of t(29) = 2.05 (measured:
/// 3.4, the views' spread larger than the noise alone).
#[test]
fn a_simpler_model_within_two_percent_but_systematically_worse_is_not_chosen() {
    let config = SyntheticConfig {
        model: CameraModel::Rational8,
        distortion: vec![1.0, 0.2, 0.001, -0.0005, 0.0, 1.5, 0.5, 0.0],
        intrinsics: Intrinsics::new(320.0, 320.0, 319.5, 239.5),
        views: 30,
        noise_px: 0.3,
        seed: 1,
        ..Default::default()
    };
    let obs = generate(&config).unwrap().observations;
    let c = compare_models(&obs, &CalibrationOptions::default(), &MODELS, &[]);
    let table = c.table();
    let kb = row(&c, CameraModel::KannalaBrandt4);
    let rational = row(&c, CameraModel::Rational8);
    // The case: the 2% rule would have taken kannala-brandt4 (valid, fewer parameters).
    assert!(kb.valid_over_image && rational.valid_over_image, "{table}");
    assert!(
        kb.cross_validated_rms.unwrap() <= 1.02 * rational.cross_validated_rms.unwrap(),
        "{table}"
    );
    assert_eq!(c.recommended, Some(CameraModel::Rational8), "{table}");
    assert_eq!(c.reference, Some(CameraModel::Rational8), "{table}");
    let (excess, se, views) = compare::paired_excess(kb, rational).unwrap();
    assert_eq!(views, 30);
    assert!(excess > compare::as_good_factor(views) * se, "{table}");
    // The row carries the same test, and the table says why.
    assert_eq!(kb.excess_over_reference, Some(excess));
    assert_eq!(kb.excess_std_error, Some(se));
    assert!(table.contains(": worse"), "{table}");
    // Every view was held out once; the per-view errors add up to the cross-validated RMS.
    assert_eq!(rational.held_out.len(), 30);
    let (sum, n) = rational
        .held_out
        .iter()
        .fold((0.0, 0), |(s, n), v| (s + v.squared_error, n + v.points));
    let cv = rational.cross_validated_rms.unwrap();
    assert!(((sum / n as f64).sqrt() - cv).abs() < 1e-9 * cv, "{table}");
}

/// A brown-conrady4 lens (104 degrees diagonal), 15 views at 0.1 px: brown-conrady5 reaches a
/// cross-validated RMS 1.1% below the true model's. brown-conrady5 contains brown-conrady4, so
/// its k3 only adds what it learned from the other half's noise: the true model's excess over
/// it has an expected value of zero or less, and the paired test's statistic is then within
/// t(14) = 2.14 standard errors in 97.5% of such cases (measured here: 1.0). The richer model
/// is not preferred; the fewest parameters win.
#[test]
fn a_richer_model_better_by_chance_is_not_chosen() {
    let config = SyntheticConfig {
        model: CameraModel::BrownConrady4,
        distortion: vec![-0.3, 0.09, 0.001, -0.0005],
        intrinsics: Intrinsics::new(420.0, 420.0, 319.5, 239.5),
        views: 15,
        noise_px: 0.1,
        seed: 1,
        ..Default::default()
    };
    let obs = generate(&config).unwrap().observations;
    let c = compare_models(&obs, &CalibrationOptions::default(), &MODELS, &[]);
    let table = c.table();
    let simple = row(&c, CameraModel::BrownConrady4);
    let best = row(&c, c.reference.expect("a reference"));
    // The case: a richer valid model with a lower cross-validated RMS.
    assert!(best.parameters > simple.parameters, "{table}");
    assert!(
        simple.cross_validated_rms.unwrap() > best.cross_validated_rms.unwrap(),
        "{table}"
    );
    let (excess, se, views) = compare::paired_excess(simple, best).unwrap();
    assert_eq!(views, 15);
    assert!(excess <= compare::as_good_factor(views) * se, "{table}");
    assert_eq!(c.recommended, Some(CameraModel::BrownConrady4), "{table}");
    assert!(
        table.contains("brown-conrady4") && table.contains(": as good"),
        "{table}"
    );
}
