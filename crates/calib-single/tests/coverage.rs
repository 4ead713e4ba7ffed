//! The `poor-coverage` warning: parts of the image where no board corner was seen are named,
//! with the distance to the nearest corner used, and captures reaching every image corner and
//! edge get none.

use calib_core::WarningCode;
use calib_single::nalgebra::{Matrix3, Vector3};
use calib_single::synthetic::{
    SyntheticConfig, add_noise, board_geometry, project_inside, true_camera,
};
use calib_single::{CalibrationOptions, Observations, View, calibrate};
use camera_model::RotationParameterization;

/// The image's corners and edge midpoints, as the warning names them (640x480).
const PLACES: [(&str, f64, f64); 8] = [
    ("top-left corner", 0.0, 0.0),
    ("top edge", 319.5, 0.0),
    ("top-right corner", 639.0, 0.0),
    ("right edge", 639.0, 239.5),
    ("bottom-right corner", 639.0, 479.0),
    ("bottom edge", 319.5, 479.0),
    ("bottom-left corner", 0.0, 479.0),
    ("left edge", 0.0, 239.5),
];

/// A view of the default 9x6 board with its centre at pixel `(u, v)`, spanning about `fill` of
/// the image width, tilted by `tilt` degrees about a random in-plane axis, 0.2 px noise; `None`
/// when some corner would fall outside the image.
fn board_at(u: f64, v: f64, fill: f64, tilt: f64, rng: &mut lm_solver::Rng) -> Option<View> {
    board_seen_by(&SyntheticConfig::default(), u, v, fill, tilt, rng)
}

/// [`board_at`] for the camera of `config` (its board, intrinsics and lens).
fn board_seen_by(
    config: &SyntheticConfig,
    u: f64,
    v: f64,
    fill: f64,
    tilt: f64,
    rng: &mut lm_solver::Rng,
) -> Option<View> {
    let camera = true_camera(config).unwrap();
    let (board, width, centre) = board_geometry(config);
    let k = config.intrinsics;
    let axis = rng.range(0.0, std::f64::consts::TAU);
    let rotation: Matrix3<f64> = camera_model::AxisAngle::matrix(
        &(Vector3::new(axis.cos(), axis.sin(), 0.0) * tilt.to_radians()),
    );
    let depth = k.fx * width / (fill * 640.0);
    let at = Vector3::new((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0) * depth;
    let pose = camera_model::Pose::new(rotation, at - rotation * centre);
    let pixels = project_inside(&camera, &pose, &board, config.image_size, 1.0)?;
    Some(View {
        name: String::new(),
        object_points: board,
        image_points: add_noise(pixels, 0.2, rng),
    })
}

/// 15 views whose boards stay in the middle of the image (centres within 10% of the width and
/// height from the centre, 35% to 45% of the width wide).
fn middle_views(rng: &mut lm_solver::Rng) -> Vec<View> {
    (0..15)
        .map(|_| {
            loop {
                let (u, v) = (rng.range(256.0, 384.0), rng.range(192.0, 288.0));
                if let Some(view) =
                    board_at(u, v, rng.range(0.35, 0.45), rng.range(15.0, 40.0), rng)
                {
                    break view;
                }
            }
        })
        .collect()
}

fn observations(views: Vec<View>) -> Observations {
    let views = views
        .into_iter()
        .enumerate()
        .map(|(i, v)| View {
            name: format!("view {i}"),
            ..v
        })
        .collect();
    Observations {
        image_size: Some(SyntheticConfig::default().image_size),
        views,
    }
}

fn coverage_message(result: &calib_single::Calibration) -> Option<&str> {
    result
        .warnings
        .iter()
        .find(|w| w.code == WarningCode::PoorCoverage)
        .map(|w| w.message.as_str())
}

/// The distance from `(x, y)` to the nearest of the views' points, pixels.
fn nearest(views: &[View], x: f64, y: f64) -> f64 {
    views
        .iter()
        .flat_map(|v| &v.image_points)
        .map(|p| (p.x - x).hypot(p.y - y))
        .fold(f64::INFINITY, f64::min)
}

/// Boards in the middle only: every image corner and edge midpoint is named, with its distance
/// to the nearest corner (computed here independently), and the summary shows the warning.
#[test]
fn boards_in_the_middle_leave_every_border_named() {
    let mut rng = lm_solver::Rng::new(3);
    let views = middle_views(&mut rng);
    let result = calibrate(&observations(views.clone()), &CalibrationOptions::default()).unwrap();
    let message = coverage_message(&result).unwrap_or_else(|| panic!("{:?}", result.warnings));
    for (name, x, y) in PLACES {
        let gap = nearest(&views, x, y);
        assert!(gap > 100.0, "{name}: {gap}");
        assert!(
            message.contains(&format!("{gap:.0} px from the {name}")),
            "{name} {gap:.0}: {message}"
        );
    }
    // 25% of the half-diagonal of 640x480 (399.7 px).
    assert!(message.contains("this warning from 100 px"), "{message}");
    assert!(result.summary().contains("poor-coverage"));
}

/// The same middle boards plus one view reaching towards each image corner and edge midpoint:
/// no warning; leaving out the top-left view brings the warning back naming only that corner.
#[test]
fn boards_reaching_every_border_get_no_warning() {
    let mut rng = lm_solver::Rng::new(4);
    let mut views = middle_views(&mut rng);
    let (cx, cy) = (319.5, 239.5);
    for (name, x, y) in PLACES {
        // The board's centre a third of the way in from the place; a smaller board when it
        // does not fit.
        let view = (0..200)
            .find_map(|i| {
                let fill = 0.45 - 0.001 * f64::from(i);
                board_at(x + (cx - x) * 0.4, y + (cy - y) * 0.4, fill, 10.0, &mut rng)
            })
            .unwrap_or_else(|| panic!("no board fits at the {name}"));
        views.push(view);
    }
    for (name, x, y) in PLACES {
        assert!(nearest(&views, x, y) < 100.0, "{name}");
    }
    let result = calibrate(&observations(views.clone()), &CalibrationOptions::default()).unwrap();
    assert_eq!(coverage_message(&result), None, "{:?}", result.warnings);

    let without: Vec<View> = views
        .iter()
        .enumerate()
        .filter(|&(i, _)| i != 15)
        .map(|(_, v)| v.clone())
        .collect();
    let gap = nearest(&without, 0.0, 0.0);
    let result = calibrate(&observations(without), &CalibrationOptions::default()).unwrap();
    let message = coverage_message(&result).unwrap_or_else(|| panic!("{:?}", result.warnings));
    assert!(
        message.contains(&format!(
            "the nearest is {gap:.0} px from the top-left corner ("
        )),
        "{message}"
    );
}

/// A stray point at the image's top-left corner in every middle-only view is rejected as an
/// outlier and does not count as coverage there.
#[test]
fn rejected_points_do_not_count_as_coverage() {
    let mut rng = lm_solver::Rng::new(5);
    let mut views = middle_views(&mut rng);
    for view in &mut views {
        view.image_points[0].x = 2.0;
        view.image_points[0].y = 2.0;
    }
    let result = calibrate(&observations(views.clone()), &CalibrationOptions::default()).unwrap();
    assert!(
        result
            .warnings
            .iter()
            .any(|w| w.code == WarningCode::OutliersRejected)
    );
    let message = coverage_message(&result).unwrap_or_else(|| panic!("{:?}", result.warnings));
    let clean: Vec<View> = views
        .into_iter()
        .map(|mut v| {
            v.image_points.remove(0);
            v
        })
        .collect();
    let gap = nearest(&clean, 0.0, 0.0);
    assert!(
        message.contains(&format!(
            "the nearest is {gap:.0} px from the top-left corner"
        )),
        "{message}"
    );
}

/// A circular fisheye (kannala-brandt4, fx 140 on 640x480: a 190-degree lens's image circle
/// ends about 230 px from the centre; by the true lens the side edges' midpoints lie about 118
/// degrees from the optical axis, the corners 140) whose boards reach out to 215 px: no
/// `poor-coverage` warning, since every place far from the corners used lies more than 90
/// degrees from the axis by the fit (black in such an image); a pinhole model's image would
/// get the warning for the same places.
#[test]
fn a_circular_fisheye_is_not_told_to_cover_its_black_corners() {
    let config = SyntheticConfig {
        model: camera_model::CameraModel::KannalaBrandt4,
        intrinsics: camera_model::Intrinsics::new(140.0, 140.0, 319.5, 239.5),
        distortion: calib_core::synthetic::default_distortion(
            camera_model::CameraModel::KannalaBrandt4,
        ),
        ..Default::default()
    };
    let mut rng = lm_solver::Rng::new(6);
    let views: Vec<View> = (0..20)
        .map(|_| {
            loop {
                let angle = rng.range(0.0, std::f64::consts::TAU);
                let radius = rng.range(0.0, 160.0);
                let (u, v) = (319.5 + radius * angle.cos(), 239.5 + radius * angle.sin());
                let fill = rng.range(0.2, 0.3);
                let tilt = rng.range(15.0, 40.0);
                if let Some(view) = board_seen_by(&config, u, v, fill, tilt, &mut rng)
                    && view
                        .image_points
                        .iter()
                        .all(|p| (p.x - 319.5).hypot(p.y - 239.5) < 215.0)
                {
                    break view;
                }
            }
        })
        .collect();
    let mut views = views;
    // Boards up to the image circle above and below the centre, where the top and bottom edges
    // lie inside it.
    for v in [60.0, 419.0] {
        let view = (0..500)
            .find_map(|_| {
                let fill = rng.range(0.15, 0.25);
                board_seen_by(&config, 319.5, v, fill, rng.range(0.0, 30.0), &mut rng).filter(
                    |view| {
                        view.image_points
                            .iter()
                            .all(|p| (p.x - 319.5).hypot(p.y - 239.5) < 235.0)
                    },
                )
            })
            .unwrap();
        views.push(view);
    }
    let mut options = CalibrationOptions::default();
    options.model = camera_model::CameraModel::KannalaBrandt4;
    let result = calibrate(&observations(views.clone()), &options).unwrap();
    assert_eq!(coverage_message(&result), None, "{:?}", result.warnings);
    let mut far = 0;
    for (name, x, y) in PLACES {
        if nearest(&views, x, y) > 100.0 {
            far += 1;
            let ray = result
                .camera
                .pixel_to_ray(
                    &calib_single::nalgebra::Vector2::new(x, y),
                    &camera_model::UndistortOptions::default(),
                )
                .unwrap();
            assert!(ray.z < 0.0, "{name}: ray z {}", ray.z);
        }
    }
    assert!(far >= 4, "the test needs far places: {far}");
}
