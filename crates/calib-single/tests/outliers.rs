//! Stray corners and wrong views: the population of mistakes a corner detector makes.

use calib_core::WarningCode;
use calib_single::synthetic::{SyntheticConfig, generate};
use calib_single::{CalibrationError, CalibrationOptions, calibrate};
use homography::HomographyError;
use lm_solver::Rng;

fn params(c: &calib_single::Calibration) -> Vec<f64> {
    let mut v = vec![0.0; 8];
    c.camera.write_params(&mut v);
    v
}

/// Displaces 1 to 3 corners (by 3 to 60 px in random directions) in every third view and swaps
/// two neighbours in every sixth; returns the spoiled points per view (sorted).
fn inject_stray_corners(
    obs: &mut calib_single::Observations,
    seed: u64,
) -> Vec<(usize, Vec<usize>)> {
    let mut rng = Rng::new(seed * 77);
    let mut injected: Vec<(usize, Vec<usize>)> = Vec::new();
    for v in (0..obs.views.len()).step_by(3) {
        let n = obs.views[v].image_points.len();
        let mut bad = Vec::new();
        for _ in 0..1 + v % 3 {
            let i = (rng.next_u64() % n as u64) as usize;
            if bad.contains(&i) {
                continue;
            }
            let angle = rng.range(0.0, std::f64::consts::TAU);
            let size = rng.range(3.0, 60.0);
            let p = &mut obs.views[v].image_points[i];
            p.x += size * angle.cos();
            p.y += size * angle.sin();
            bad.push(i);
        }
        if v % 2 == 0 {
            // Two neighbours swapped (a detector's ordering slip): 25 mm apart on the board.
            let i = (0..n - 1)
                .find(|i| !bad.contains(i) && !bad.contains(&(i + 1)) && i % 9 != 8)
                .unwrap();
            obs.views[v].image_points.swap(i, i + 1);
            bad.extend([i, i + 1]);
        }
        bad.sort_unstable();
        injected.push((v, bad));
    }
    injected
}

/// Every view of `result` rejected exactly its `injected` points (none for views not listed).
fn assert_rejected_exactly(
    result: &calib_single::Calibration,
    injected: &[(usize, Vec<usize>)],
    seed: u64,
) {
    for view in &result.views {
        let expected = injected
            .iter()
            .find(|(v, _)| *v == view.index)
            .map_or(&[][..], |(_, b)| b.as_slice());
        assert_eq!(
            view.rejected_points, expected,
            "seed {seed}, view {}",
            view.index
        );
    }
}

/// The same mistakes under a wide-angle lens calibrated with `rational8`, whose outlier rejection
/// runs a second time with every point in the first solve when the first run rejects points
/// (`SolveOptions::recheck_without_suspects`): exactly the spoiled corners are rejected, and the
/// intrinsics stay within 4 sigma of the truth.
#[test]
fn stray_corners_are_rejected_under_a_rational_model() {
    for seed in 1..=3u64 {
        let (set, options) = wide_rational8(seed);
        let clean = calibrate(&set.observations, &options).unwrap();
        assert_eq!(clean.num_rejected, 0, "seed {seed}");
        let mut obs = set.observations.clone();
        let injected = inject_stray_corners(&mut obs, seed);
        let result = calibrate(&obs, &options).unwrap();
        assert_rejected_exactly(&result, &injected, seed);
        assert!(result.rms < 1.2 * clean.rms, "seed {seed}: {}", result.rms);
        let truth = set.camera.intrinsics;
        let e = result.camera.intrinsics;
        for (i, (d, s)) in [
            e.fx - truth.fx,
            e.fy - truth.fy,
            e.cx - truth.cx,
            e.cy - truth.cy,
        ]
        .iter()
        .zip(&result.intrinsics_std)
        .enumerate()
        {
            assert!(
                d.abs() < 4.0 * s,
                "seed {seed}, intrinsic {i}: {d} (sigma {s})"
            );
        }
    }
}

/// The `optimization` stage counts every solve of the outlier rounds and of the rational model's
/// second run, not only the kept solve's (whose time `solver.total_time` is): earlier solves
/// were counted as `uncertainty`, which then looked like the slowest stage.
#[test]
fn the_optimization_stage_counts_every_solve() {
    let (set, options) = wide_rational8(1);
    let mut obs = set.observations.clone();
    inject_stray_corners(&mut obs, 1);
    let result = calibrate(&obs, &options).unwrap();
    assert!(result.num_rejected > 0);
    // Two runs at least (with and without the homography's suspects), each taking some time.
    assert!(
        result.stage_times.optimization > result.solver.total_time,
        "{:?} vs {:?}",
        result.stage_times,
        result.solver.total_time
    );
}

/// Displaced corners (by 3 to 60 px in random directions) and swapped neighbours in a third of
/// the views: every one of them is found, nothing else is rejected, and the estimate is as close
/// to the truth as a clean calibration's (within 3 sigma).
#[test]
fn stray_corners_are_rejected_and_the_estimate_is_unharmed() {
    for seed in 1..=6u64 {
        let config = SyntheticConfig {
            seed,
            noise_px: 0.2,
            ..Default::default()
        };
        let set = generate(&config).unwrap();
        let clean = calibrate(&set.observations, &CalibrationOptions::default()).unwrap();
        assert_eq!(clean.num_rejected, 0, "seed {seed}");
        // The default boards stay in the middle 40% of the image: poor-coverage is due.
        assert!(
            clean
                .warnings
                .iter()
                .all(|w| w.code == WarningCode::PoorCoverage),
            "seed {seed}: {:?}",
            clean.warnings
        );

        let mut obs = set.observations.clone();
        let injected = inject_stray_corners(&mut obs, seed);
        let result = calibrate(&obs, &CalibrationOptions::default()).unwrap();
        assert_rejected_exactly(&result, &injected, seed);
        let total: usize = injected.iter().map(|(_, b)| b.len()).sum();
        assert_eq!(result.num_rejected, total);
        assert!(result.rms < 1.2 * clean.rms, "seed {seed}: {}", result.rms);
        assert!(result.rms_all_points > 2.0 * result.rms);
        assert!(
            result
                .warnings
                .iter()
                .any(|w| w.code == WarningCode::OutliersRejected && w.message.contains("view"))
        );
        let mut truth = vec![0.0; 8];
        set.camera.write_params(&mut truth);
        let std: Vec<f64> = result
            .intrinsics_std
            .iter()
            .chain(&result.distortion_std)
            .copied()
            .collect();
        for (i, ((e, t), s)) in params(&result).iter().zip(&truth).zip(&std).enumerate() {
            assert!(
                (e - t).abs() < 4.0 * s,
                "seed {seed}, parameter {i}: {e} vs {t} (sigma {s})"
            );
        }
        // Without rejection the same data pulls the estimate away.
        let mut off = CalibrationOptions::default();
        off.outliers = None;
        let plain = calibrate(&obs, &off).unwrap();
        assert_eq!(plain.num_rejected, 0);
        assert!(plain.rms > 3.0 * result.rms, "seed {seed}: {}", plain.rms);
    }
}

/// A view whose image points belong to another board layout (shuffled): its homography has no
/// consensus, the error names the view, and `skip_bad_views` leaves it out.
#[test]
fn a_shuffled_view_is_named_or_skipped() {
    let set = generate(&SyntheticConfig::default()).unwrap();
    let mut obs = set.observations.clone();
    let n = obs.views[4].image_points.len();
    let mut rng = Rng::new(3);
    for i in (1..n).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        obs.views[4].image_points.swap(i, j);
    }
    match calibrate(&obs, &CalibrationOptions::default()) {
        Err(CalibrationError::Homography {
            view: 4,
            source: HomographyError::NoConsensus { .. },
        }) => {}
        other => panic!("{other:?}"),
    }
    let mut skip = CalibrationOptions::default();
    skip.skip_bad_views = true;
    let result = calibrate(&obs, &skip).unwrap();
    assert_eq!(result.skipped_views.len(), 1);
    assert_eq!(result.skipped_views[0].index, 4);
    assert!(result.skipped_views[0].reason.contains("homography"));
    assert_eq!(result.views.len(), obs.views.len() - 1);
}

/// A view from another camera (pixels through a strongly different lens, as when files get
/// mixed up): its homography finds a consensus in the board's centre, but the calibrated camera
/// cannot fit most of its points. The calibration names the view, and `skip_bad_views` drops it
/// and calibrates the rest.
#[test]
fn a_view_from_another_lens_is_named_or_skipped() {
    let config = SyntheticConfig::default();
    let set = generate(&config).unwrap();
    let mut obs = set.observations.clone();
    let k = config.intrinsics;
    for p in obs.views[7].image_points.iter_mut() {
        let (x, y) = ((p.x - k.cx) / k.fx, (p.y - k.cy) / k.fy);
        let s = 1.0 - 0.4 * (x * x + y * y);
        p.x = k.cx + k.fx * x * s;
        p.y = k.cy + k.fy * y * s;
    }
    let result = view_7_is_named_or_skipped(&obs);
    let mut truth = vec![0.0; 8];
    set.camera.write_params(&mut truth);
    assert!((params(&result)[0] - truth[0]).abs() < 4.0 * result.intrinsics_std[0]);
}

/// A view detected with the wrong board size (an 8x6 board's points for the first 48 corners
/// of a 9x6 board): two thirds of its points fit a sheared board, a homography, so it passes the
/// homography stage, but no pose fits them and every point is marked. It is `MostlyOutliers`,
/// named, and skipped with `skip_bad_views`, not an undetermined pose that stops the calibration.
#[test]
fn a_view_with_the_wrong_board_size_is_named_or_skipped() {
    let config = SyntheticConfig::default();
    let set = generate(&config).unwrap();
    let mut obs = set.observations.clone();
    let view = &mut obs.views[7];
    wrong_board_size(view);
    view_7_is_named_or_skipped(&obs);
}

/// Strong barrel distortion: the homography of a board filling the image leaves tens of pixels
/// at its edges, and the robust homography may suspect them; the calibrated model fits them, so
/// none stays rejected.
#[test]
fn suspects_of_a_distorted_lens_are_readmitted() {
    let config = SyntheticConfig {
        distortion: vec![-0.45, 0.2, 0.0, 0.0],
        intrinsics: camera_model::Intrinsics::new(420.0, 420.0, 330.0, 235.0),
        seed: 9,
        ..Default::default()
    };
    let set = generate(&config).unwrap();
    let result = calibrate(&set.observations, &CalibrationOptions::default()).unwrap();
    assert_eq!(result.num_rejected, 0, "{:?}", result.warnings);
    assert!(result.rms < 0.35, "{}", result.rms);
}

/// Several views with the wrong board size among many: skipping bad views leaves them out
/// together (one calibration more, not one per bad view: 2000 views with 20 such views took 69 s
/// one at a time), each with its own count, and the result is the calibration of the others.
#[test]
fn several_bad_views_are_skipped_together() {
    let config = SyntheticConfig {
        views: 100,
        seed: 5,
        ..Default::default()
    };
    let set = generate(&config).unwrap();
    let bad = [3, 17, 40, 41, 66, 90];
    let mut obs = set.observations.clone();
    for &k in &bad {
        wrong_board_size(&mut obs.views[k]);
    }
    let mut skip = CalibrationOptions::default();
    skip.skip_bad_views = true;
    let result = calibrate(&obs, &skip).unwrap();
    let skipped: Vec<usize> = result.skipped_views.iter().map(|s| s.index).collect();
    assert_eq!(skipped, bad);
    // Each reason is the view's own count, without repeating the view the entry names.
    for s in &result.skipped_views {
        assert!(
            s.reason.contains(" of 48 points are outliers")
                && !s.reason.contains(&format!("view {}", s.index)),
            "{}",
            s.reason
        );
    }
    // The same calibration as without those views.
    let mut clean = set.observations.clone();
    let mut k = 0;
    clean.views.retain(|_| {
        k += 1;
        !bad.contains(&(k - 1))
    });
    let reference = calibrate(&clean, &CalibrationOptions::default()).unwrap();
    assert_eq!(result.rms, reference.rms);
    assert_eq!(result.camera, reference.camera);
}

/// `obs` is refused naming view 7 as mostly outliers, and calibrated without it (and nothing
/// else rejected) when bad views are skipped.
fn view_7_is_named_or_skipped(obs: &calib_single::Observations) -> calib_single::Calibration {
    match calibrate(obs, &CalibrationOptions::default()) {
        Err(e @ CalibrationError::MostlyOutliers { .. }) => {
            assert!(e.to_string().starts_with("view 7"), "{e}");
        }
        Ok(r) => panic!("accepted: rms {} rejected {}", r.rms, r.num_rejected),
        Err(e) => panic!("{e}"),
    }
    let mut skip = CalibrationOptions::default();
    skip.skip_bad_views = true;
    let result = calibrate(obs, &skip).unwrap();
    let skipped: Vec<usize> = result.skipped_views.iter().map(|s| s.index).collect();
    assert_eq!(skipped, vec![7]);
    assert_eq!(result.num_rejected, 0);
    result
}

/// A view of a 9x6 board detected as an 8x6 one: the first 48 corners with an 8x6 board's
/// points.
fn wrong_board_size(view: &mut calib_single::View) {
    view.image_points.truncate(48);
    view.object_points = (0..48)
        .map(|i| nalgebra::Point3::new(25.0 * (i % 8) as f64, 25.0 * (i / 8) as f64, 0.0))
        .collect();
}

/// Three stray corners 42 px off (30 px in x and y) in every view: where the homography does not
/// flag them, the first solve's pose of that view follows them and most of its good points
/// exceed the threshold; rejecting them all left the pose to its worst points and a good view
/// was refused as mostly outliers (6 of 6 seeds of 1000 views, from 60 views up). A round then
/// rejected at most half of a view (its worst points), but the pulled pose can have the board
/// tilted the other way, which those rounds do not leave: the last two cases (60 views) were
/// refused, views 19 and 23 with 45 and 49 of 54 points marked. Such a view's pose is now
/// refitted alone, robustly and from its own points' consensus, before the next round.
#[test]
fn stray_corners_in_every_view_do_not_refuse_a_good_view() {
    let mut failures = Vec::new();
    // (generator seed, views, seed of the moves)
    for (seed, views, moves) in [
        (40, 120, 1),
        (41, 120, 2),
        (42, 120, 3),
        (0, 60, 1),
        (43, 60, 44),
    ] {
        let config = SyntheticConfig {
            views,
            seed,
            ..Default::default()
        };
        let set = generate(&config).unwrap();
        let mut obs = set.observations.clone();
        let mut rng = Rng::new(moves);
        for view in &mut obs.views {
            let n = view.image_points.len();
            let mut moved = Vec::new();
            while moved.len() < 3 {
                let i = (rng.next_u64() % n as u64) as usize;
                if !moved.contains(&i) {
                    moved.push(i);
                }
            }
            for i in moved {
                let p = &mut view.image_points[i];
                let dx = if rng.uniform() < 0.5 { -30.0 } else { 30.0 };
                let dy = if rng.uniform() < 0.5 { -30.0 } else { 30.0 };
                p.x = (p.x + dx).clamp(0.0, 639.0);
                p.y = (p.y + dy).clamp(0.0, 479.0);
            }
        }
        match calibrate(&obs, &CalibrationOptions::default()) {
            Ok(r) => {
                assert!(r.skipped_views.is_empty());
                // The strays and hardly anything else.
                assert!(
                    (3 * views..=3 * views + 10).contains(&r.num_rejected),
                    "seed {seed}: {} rejected",
                    r.num_rejected
                );
                assert!((r.rms - 0.2 * 2f64.sqrt()).abs() < 0.03, "rms {}", r.rms);
            }
            Err(e) => failures.push(format!("seed {seed}, {views} views: {e}")),
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// 30 views of a wide rational8 lens (fx 330 on 640x480, the generator's default distortion),
/// 0.2 px of noise, and the options that calibrate it with that model.
fn wide_rational8(seed: u64) -> (calib_single::synthetic::SyntheticSet, CalibrationOptions) {
    use calib_core::synthetic::default_distortion;
    use camera_model::{CameraModel, Intrinsics};
    let config = SyntheticConfig {
        seed,
        noise_px: 0.2,
        model: CameraModel::Rational8,
        distortion: default_distortion(CameraModel::Rational8),
        intrinsics: Intrinsics::new(330.0, 330.0, 322.0, 236.0),
        views: 30,
        ..Default::default()
    };
    let mut options = CalibrationOptions::default();
    options.model = CameraModel::Rational8;
    (generate(&config).unwrap(), options)
}
