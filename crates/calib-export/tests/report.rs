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
    check_report(&dir.join("single"), 8);
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
    // Eight plots per camera and the rig's layout.
    check_report(&dir.join("stereo"), 17);
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

#[test]
fn rig_reports_show_every_camera_and_the_layout_and_refuse_other_observations() {
    let dir = std::env::temp_dir().join(format!("calib-export-rig-report-{}", std::process::id()));
    let config = calib_rig::synthetic::SyntheticRigConfig {
        cameras: 3,
        frames: 24,
        ..Default::default()
    };
    let data = calib_rig::synthetic::generate_rig(&config).unwrap();
    let result =
        calib_rig::calibrate_rig(&data.observations, &calib_rig::RigOptions::default()).unwrap();
    let input = ReportInput::rig(&result, Some(&data.observations)).unwrap();
    // Each camera's views are its frames, at its pose (the frame's pose through the rig).
    for (c, camera) in input.cameras.iter().enumerate() {
        let seen = data
            .observations
            .frames
            .iter()
            .filter(|f| f.observations.iter().any(|o| o.camera == c))
            .count();
        assert_eq!(camera.views.len(), seen, "camera {c}");
        assert!(camera.views.iter().all(|v| v.points.is_some()));
    }
    write_report(&input, &dir.join("rig")).unwrap();
    check_report(&dir.join("rig"), 1 + 8 * 3);
    let page = std::fs::read_to_string(dir.join("rig").join("index.html")).unwrap();
    assert!(page.contains("layout.svg") && page.contains("Rig calibration (3 cameras)"));
    // Frames out of order: the stored RMS no longer matches, the report refuses the file.
    let mut shuffled = data.observations.clone();
    shuffled.frames.rotate_left(1);
    let err = ReportInput::rig(&result, Some(&shuffled))
        .unwrap_err()
        .to_string();
    assert!(err.contains("does not match"), "{err}");
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

/// The projection uncertainty against Monte Carlo: the same synthetic views with fresh pixel
/// noise, calibrated again and again; where each solution projects a point fixed relative to
/// the boards (mrcal's mean over the boards' frames) spreads as `Uncertainty::projection`
/// predicts, at the boards' distance and at infinity, at the centre and near a corner.
#[test]
fn projection_uncertainty_matches_monte_carlo() {
    use calib_core::lm_solver::Rng;
    use calib_export::covariance::Uncertainty;
    use camera_model::UndistortOptions;
    use nalgebra::{Matrix2, Vector2, Vector3};
    let noise = 0.3;
    let config = calib_single::synthetic::SyntheticConfig {
        views: 8,
        noise_px: 0.0,
        seed: 7,
        ..Default::default()
    };
    let truth = calib_single::synthetic::generate(&config).unwrap();
    let options = calib_single::CalibrationOptions::default();
    let trials = 60;
    let pixels = [Vector2::new(319.5, 239.5), Vector2::new(40.0, 40.0)];
    // The boards' median distance.
    let mut distances: Vec<f64> = truth.poses.iter().map(|p| p.translation.norm()).collect();
    distances.sort_by(f64::total_cmp);
    let d = distances[distances.len() / 2];
    let distances = [Some(d), None];
    let points: Vec<Vec<Vector3<f64>>> = pixels
        .iter()
        .map(|q| {
            let ray = truth
                .camera
                .pixel_to_ray(q, &UndistortOptions::default())
                .unwrap()
                .into_inner();
            distances
                .iter()
                .map(|d| d.map_or(ray, |d| ray * d))
                .collect()
        })
        .collect();
    let mut samples = vec![vec![Vec::new(); distances.len()]; pixels.len()];
    let mut predicted = None;
    let mut rng = Rng::new(11);
    for trial in 0..trials {
        let mut obs = truth.observations.clone();
        for view in &mut obs.views {
            view.image_points = calib_core::synthetic::add_noise(
                std::mem::take(&mut view.image_points),
                noise,
                &mut rng,
            );
        }
        let result = calib_single::calibrate(&obs, &options).unwrap();
        assert_eq!(result.views.len(), truth.poses.len());
        if trial == 0 {
            let views: Vec<CovarianceView> = result
                .views
                .iter()
                .map(|v| CovarianceView {
                    pose: v.pose,
                    object: obs.views[v.index].object_points.clone(),
                    pixels: obs.views[v.index]
                        .image_points
                        .iter()
                        .map(|p| p.coords)
                        .collect(),
                })
                .collect();
            predicted = Some(Uncertainty::new(&result.camera, &views, &[]).unwrap());
        }
        for (a, per_pixel) in points.iter().enumerate() {
            for (b, p) in per_pixel.iter().enumerate() {
                // mean_i T_i' T_i^-1 p, projected by the solution's camera.
                let mut mean = Vector3::zeros();
                for v in &result.views {
                    let t = &truth.poses[v.index];
                    let x = match distances[b] {
                        Some(_) => t.rotation.transpose() * (p - t.translation),
                        None => t.rotation.transpose() * p,
                    };
                    mean += match distances[b] {
                        Some(_) => v.pose.rotation * x + v.pose.translation,
                        None => v.pose.rotation * x,
                    };
                }
                mean /= result.views.len() as f64;
                samples[a][b].push(result.camera.project_camera_point(&mean).unwrap());
            }
        }
    }
    let predicted = predicted.unwrap();
    // The prediction used trial 0's noise estimate; scale it to the true noise.
    let scale = (noise / predicted.sigma()).powi(2);
    for (a, q) in pixels.iter().enumerate() {
        for (b, d) in distances.iter().enumerate() {
            let s = &samples[a][b];
            let mean: Vector2<f64> = s.iter().sum::<Vector2<f64>>() / s.len() as f64;
            let empirical = s
                .iter()
                .map(|x| (x - mean) * (x - mean).transpose())
                .sum::<Matrix2<f64>>()
                / (s.len() - 1) as f64;
            let c = predicted.projection(q, *d).unwrap() * scale;
            let ratio = (empirical.trace() / c.trace()).sqrt();
            println!(
                "pixel {q:?} distance {d:?}: predicted {:.4} px, Monte Carlo {:.4} px (ratio {ratio:.3})",
                c.trace().sqrt(),
                empirical.trace().sqrt()
            );
            assert!((0.75..1.33).contains(&ratio), "ratio {ratio}");
        }
    }
}

/// The distortion field shows the validity radius of camera_model's check: a lens model that
/// folds over inside the image gets a red circle and a caption naming the radius; a valid one
/// says it is one-to-one over the image.
/// A report of one 640x480 camera named "camera" with `views`, nothing held, no warnings.
fn one_camera_input(
    title: &str,
    camera: camera_model::AnyCamera,
    views: Vec<calib_export::report::ReportView>,
) -> ReportInput {
    ReportInput {
        title: title.into(),
        summary: String::new(),
        warnings: Vec::new(),
        cameras: vec![calib_export::report::ReportCamera {
            name: "camera".into(),
            camera,
            image_size: calib_core::ImageSize::new(640, 480),
            fixed: Vec::new(),
            views,
        }],
        layout: None,
    }
}

#[test]
fn distortion_plot_shows_the_validity_radius() {
    use calib_export::report::ReportView;
    use camera_model::{AnyCamera, CameraModel, Intrinsics, Pose};
    let dir = std::env::temp_dir().join(format!("calib-export-validity-{}", std::process::id()));
    let report = |k1: f64, name: &str| {
        let camera = AnyCamera::new(
            CameraModel::BrownConrady4,
            Intrinsics::new(500.0, 500.0, 319.5, 239.5),
            vec![k1, 0.0, 0.0, 0.0],
        )
        .unwrap();
        let validity = camera.validity(640, 480);
        let input = one_camera_input(
            "validity",
            camera,
            vec![ReportView {
                name: "view".into(),
                pose: Pose::new(
                    nalgebra::Matrix3::identity(),
                    nalgebra::Vector3::new(0.0, 0.0, 500.0),
                ),
                rms: 0.1,
                points: None,
                rejected: Vec::new(),
            }],
        );
        write_report(&input, &dir.join(name)).unwrap();
        let page = std::fs::read_to_string(dir.join(name).join("index.html")).unwrap();
        let svg = std::fs::read_to_string(dir.join(name).join("distortion-camera.svg")).unwrap();
        well_formed_svg(&svg).unwrap();
        (validity, page, svg)
    };
    // 1 + 3 k1 r^2 = 0 at r = 0.745 (373 px): the corners (400 px) are beyond the fold.
    let (validity, page, svg) = report(-0.6, "folding");
    assert!(!validity.covers_image(0.0), "{validity:?}");
    let radius = format!(
        "{:.0} px from the principal point",
        validity.valid_radius_px
    );
    assert!(
        page.contains("stops being one-to-one") && page.contains(&radius),
        "{page}"
    );
    assert!(svg.contains("#FF0000"), "no red circle");
    let (validity, page, svg) = report(-0.2, "valid");
    assert!(validity.covers_image(0.0), "{validity:?}");
    assert!(page.contains("one-to-one over the whole image"));
    // 1 + 3 k1 r^2 > 0 out to 645 px: the circle lies beyond the corners (400 px).
    assert!(validity.valid_radius_px > validity.image_radius_px);
    assert!(page.contains("(outside the image)"), "{page}");
    assert!(!svg.contains("#FF0000"));
    // Pincushion k1 > 0 never folds: no radius to print (it printed "coverage inf").
    let (validity, page, _) = report(0.2, "never-folds");
    assert!(validity.valid_radius_px.is_infinite(), "{validity:?}");
    assert!(page.contains("no fold was found"), "{page}");
    assert!(!page.contains("inf)") && !page.contains(" inf"), "{page}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A report rewritten in the same folder never mixes two reports: cameras whose names differ only
/// in characters a file name cannot hold (`左カメラ`, `右カメラ`) get their own plots; plots the
/// new report does not have are removed (and only those: a foreign page's images stay); a write
/// that fails leaves the previous report whole;
/// warnings come first, in their own box.
#[test]
fn reports_in_one_folder_never_mix() {
    let dir = std::env::temp_dir().join(format!("calib-export-report-mix-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let obs = calib_single::Observations::read(data("left.json")).unwrap();
    let result =
        calib_single::calibrate(&obs, &calib_single::CalibrationOptions::default()).unwrap();
    let single = ReportInput::single(&result, Some(&obs)).unwrap();
    let mut rig = single.clone();
    rig.cameras.push(rig.cameras[0].clone());
    rig.cameras[0].name = "左カメラ".into();
    rig.cameras[1].name = "右カメラ".into();
    rig.cameras[1].views.truncate(3);
    // A folder holding someone else's page: its images are not the report's to remove.
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("index.html"), "<img src=\"logo.svg\">").unwrap();
    std::fs::write(dir.join("logo.svg"), "<svg></svg>").unwrap();
    write_report(&rig, &dir).unwrap();
    assert!(dir.join("logo.svg").exists());
    std::fs::remove_file(dir.join("logo.svg")).unwrap();
    check_report(&dir, 16);
    let page = std::fs::read_to_string(dir.join("index.html")).unwrap();
    let rms: Vec<&str> = page
        .split("<img src=\"")
        .skip(1)
        .map(|s| &s[..s.find('"').unwrap()])
        .filter(|s| s.starts_with("rms-"))
        .collect();
    assert_eq!(rms.len(), 2);
    assert_ne!(rms[0], rms[1], "two cameras share one plot file");
    // The second camera's chart has its own three views, the first its 29.
    let bars = |file: &str| {
        std::fs::read_to_string(dir.join(file))
            .unwrap()
            .matches(".jpg\n")
            .count()
    };
    assert_eq!((bars(rms[0]), bars(rms[1])), (29, 3));

    // Rewritten without observations and for one camera: the other plots go.
    let mut bare = ReportInput::single(&result, None).unwrap();
    bare.warnings = vec!["warning [poorly-determined]: k2 is not determined".into()];
    write_report(&bare, &dir).unwrap();
    check_report(&dir, 3);
    let svgs = std::fs::read_dir(&dir)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .ends_with(".svg")
        })
        .count();
    assert_eq!(svgs, 3, "plots of the previous report were left behind");
    let page = std::fs::read_to_string(dir.join("index.html")).unwrap();
    let warning = page.find("class=\"warnings\"").expect("no warnings box");
    assert!(
        warning < page.find("<pre>").unwrap(),
        "warnings after the summary"
    );
    assert!(page.contains("1 warning: read before using this calibration"));
    assert!(page.contains("drawn as a square at its origin"), "{page}");

    // 87 views: the poses plot draws one board in two and says so.
    let mut many = single.clone();
    let views = many.cameras[0].views.clone();
    many.cameras[0]
        .views
        .extend(views.iter().cloned().chain(views.iter().cloned()));
    let crowded = dir.join("crowded");
    write_report(&many, &crowded).unwrap();
    let page = std::fs::read_to_string(crowded.join("index.html")).unwrap();
    assert!(
        page.contains("every view (one view in 2 of the 87)"),
        "{page}"
    );
    std::fs::remove_dir_all(&crowded).unwrap();

    // A folder where a plot should go: refused, the previous report untouched, no temporaries.
    std::fs::remove_file(dir.join("distortion-camera.svg")).unwrap();
    std::fs::create_dir(dir.join("distortion-camera.svg")).unwrap();
    let before = std::fs::read(dir.join("index.html")).unwrap();
    let err = write_report(&single, &dir).unwrap_err().to_string();
    assert!(err.contains("distortion-camera.svg"), "{err}");
    assert_eq!(std::fs::read(dir.join("index.html")).unwrap(), before);
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(!names.iter().any(|n| n.starts_with('.')), "{names:?}");
    assert!(
        !names.iter().any(|n| n.starts_with("residuals")),
        "{names:?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Many corners: the per-corner plots (arrows, scatter) draw at most 20000 of them, every k-th,
/// and say so; 1000 views of 400 points made a 75 MB residual plot that no browser shows.
#[test]
fn per_corner_plots_are_thinned_for_many_corners() {
    use calib_export::report::ReportView;
    use camera_model::{AnyCamera, CameraModel, Intrinsics, Pose};
    let dir = std::env::temp_dir().join(format!("calib-export-thinned-{}", std::process::id()));
    let camera = AnyCamera::new(
        CameraModel::BrownConrady4,
        Intrinsics::new(500.0, 500.0, 319.5, 239.5),
        vec![-0.1, 0.0, 0.0, 0.0],
    )
    .unwrap();
    let pose = Pose::new(
        nalgebra::Matrix3::identity(),
        nalgebra::Vector3::new(-100.0, -75.0, 300.0),
    );
    // 60 views of a 20x20 board (24000 corners), each pixel 0.1 px off its projection.
    let board: Vec<nalgebra::Point3<f64>> = (0..400)
        .map(|i| nalgebra::Point3::new(10.0 * (i % 20) as f64, 8.0 * (i / 20) as f64, 0.0))
        .collect();
    let pixels: Vec<nalgebra::Vector2<f64>> = board
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let s = pose.transform_point(p);
            let px = camera.project_camera_point(&s).unwrap();
            let angle = i as f64;
            nalgebra::Vector2::new(px.x + 0.1 * angle.cos(), px.y + 0.1 * angle.sin())
        })
        .collect();
    let views = (0..60)
        .map(|k| ReportView {
            name: format!("view{k}"),
            pose,
            rms: 0.1,
            points: Some((board.clone(), pixels.clone())),
            rejected: Vec::new(),
        })
        .collect();
    let input = one_camera_input("many corners", camera, views);
    write_report(&input, &dir).unwrap();
    let page = std::fs::read_to_string(dir.join("index.html")).unwrap();
    assert!(
        page.contains("every 2nd corner of the 24000 used ones is drawn (12000)"),
        "{page}"
    );
    for plot in ["residuals-camera.svg", "scatter-camera.svg"] {
        let svg = std::fs::read_to_string(dir.join(plot)).unwrap();
        well_formed_svg(&svg).unwrap();
        let circles = svg.matches("<circle").count();
        assert!(
            (12000..12100).contains(&circles),
            "{plot}: {circles} circles"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The coverage plot marks the `poor-coverage` warning's places: boards only in the middle of
/// the image get a red arc around every image corner and edge midpoint, named in the caption;
/// boards reaching every one of them get none.
#[test]
fn coverage_plot_marks_the_places_no_corner_reached() {
    use calib_export::report::ReportView;
    use camera_model::{AnyCamera, CameraModel, Intrinsics, Pose};
    let dir = std::env::temp_dir().join(format!("calib-export-coverage-{}", std::process::id()));
    let camera = AnyCamera::new(
        CameraModel::BrownConrady4,
        Intrinsics::new(500.0, 500.0, 319.5, 239.5),
        vec![-0.1, 0.0, 0.0, 0.0],
    )
    .unwrap();
    // A 9x6 board of 10-unit squares facing the camera 500 units away, its centre at pixel
    // (u, v): about 80 x 50 px.
    let board: Vec<nalgebra::Point3<f64>> = (0..54)
        .map(|i| nalgebra::Point3::new(10.0 * (i % 9) as f64, 10.0 * (i / 9) as f64, 0.0))
        .collect();
    let view_at = |u: f64, v: f64| {
        // f = 500 at 500 units: a unit is a pixel at the board.
        let (x, y) = (u - 319.5, v - 239.5);
        let pose = Pose::new(
            nalgebra::Matrix3::identity(),
            nalgebra::Vector3::new(x - 40.0, y - 25.0, 500.0),
        );
        let pixels = board
            .iter()
            .map(|p| {
                camera
                    .project_camera_point(&pose.transform_point(p))
                    .unwrap()
            })
            .collect();
        ReportView {
            name: format!("view at {u},{v}"),
            pose,
            rms: 0.1,
            points: Some((board.clone(), pixels)),
            rejected: Vec::new(),
        }
    };
    let report = |views: Vec<ReportView>, name: &str| {
        let input = one_camera_input("coverage", camera.clone(), views);
        write_report(&input, &dir.join(name)).unwrap();
        let page = std::fs::read_to_string(dir.join(name).join("index.html")).unwrap();
        let svg = std::fs::read_to_string(dir.join(name).join("coverage-camera.svg")).unwrap();
        well_formed_svg(&svg).unwrap();
        (page, svg)
    };
    let middle: Vec<ReportView> = [(300.0, 220.0), (340.0, 260.0), (320.0, 240.0)]
        .into_iter()
        .map(|(u, v)| view_at(u, v))
        .collect();
    let (page, svg) = report(middle.clone(), "middle");
    assert!(svg.contains("#FF0000"), "no red arc");
    assert!(
        page.contains("(top-left corner, top edge, top-right corner, right edge, bottom-right corner, bottom edge, bottom-left corner, left edge)")
            && page.contains("within 100 px"),
        "{page}"
    );
    // Boards whose centres sit 45 px in from each image corner and edge midpoint.
    let mut everywhere = middle;
    for (u, v) in [
        (45.0, 30.0),
        (319.5, 30.0),
        (594.0, 30.0),
        (594.0, 239.5),
        (594.0, 449.0),
        (319.5, 449.0),
        (45.0, 449.0),
        (45.0, 239.5),
    ] {
        everywhere.push(view_at(u, v));
    }
    let (page, svg) = report(everywhere, "everywhere");
    assert!(!svg.contains("#FF0000"), "a red arc");
    assert!(
        !page.contains("the reach of the poor-coverage warning"),
        "{page}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
