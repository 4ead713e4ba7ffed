//! Stereo rectification against ground truth (synthetic rigs: a 3-D point's two rectified
//! images lie on one row, and Q turns their disparity back into the point) and on real images
//! (the bundled sourishg1 pairs, rectified and detected again).

use calib_core::{ImageSize, JsonFile};
use calib_export::undistort::undistort_point;
use calib_export::{CameraCalibration, PixelMap, StereoRig, remap_image, stereo_rectify};
use camera_model::{AnyCamera, AxisAngle, CameraModel, Intrinsics, RotationParameterization};
use nalgebra::{Matrix3, Vector2, Vector3, Vector4};

fn camera(model: CameraModel, name: &str, k: Intrinsics, k1: f64) -> CameraCalibration {
    let mut d = vec![0.0; model.num_distortion_params()];
    d[0] = k1;
    if d.len() > 2 {
        d[1] = 0.03;
        d[2] = if model.is_fisheye() { -0.004 } else { 0.0012 };
    }
    CameraCalibration::new(
        name,
        AnyCamera::new(model, k, d).unwrap(),
        ImageSize::new(640, 480),
    )
    .unwrap()
}

fn rig(model: CameraModel, translation: Vector3<f64>) -> StereoRig {
    StereoRig {
        left: camera(
            model,
            "left",
            Intrinsics::new(520.0, 515.0, 322.0, 236.0),
            -0.18,
        ),
        right: camera(
            model,
            "right",
            Intrinsics::new(505.0, 507.0, 315.0, 245.0),
            -0.12,
        ),
        rotation: AxisAngle::matrix(&Vector3::new(0.02, -0.05, 0.015)),
        translation,
    }
}

/// Ground truth by construction: points in front of both cameras are projected through each
/// (distorted) camera; their rectified images must share a row (exactly, up to undistortion's
/// 1e-14 and rounding: 1e-8 px), the rectified left point must be `P1 R1 X`, and `Q` applied to
/// `(x, y, x_left - x_right)` must give back `R1 X` (relative 1e-9).
#[test]
fn rectified_points_share_rows_and_q_recovers_depth_for_every_model_and_orientation() {
    let baselines = [
        Vector3::new(-0.12, 0.004, 0.003),
        Vector3::new(0.12, -0.003, 0.002),
        Vector3::new(0.005, -0.11, 0.004),
    ];
    for model in CameraModel::ALL {
        for t in baselines {
            let rig = rig(model, t);
            for alpha in [Some(0.0), Some(0.6), Some(1.0), None] {
                let rect = stereo_rectify(&rig, alpha).unwrap();
                let what = format!("{model} T={t:?} alpha={alpha:?}");
                for r in [&rect.r1, &rect.r2] {
                    assert!(
                        (r.transpose() * r - Matrix3::identity()).amax() < 1e-14,
                        "{what}"
                    );
                    assert!((r.determinant() - 1.0).abs() < 1e-14, "{what}");
                }
                // The rectified right camera is the left one moved along one axis only.
                let t_rect = rect.r2 * rig.translation;
                let axis = if rect.vertical { 1 } else { 0 };
                for i in 0..3 {
                    if i != axis {
                        assert!(t_rect[i].abs() < 1e-14, "{what}: {t_rect}");
                    }
                }
                assert_eq!(rect.vertical, t.y.abs() > t.x.abs(), "{what}");
                let k1 = rect.p1.fixed_view::<3, 3>(0, 0).into_owned();
                let k2 = rect.p2.fixed_view::<3, 3>(0, 0).into_owned();
                for (x, y, z) in [
                    (0.1, 0.05, 1.5),
                    (-0.4, 0.3, 2.0),
                    (0.3, -0.25, 4.0),
                    (0.0, 0.0, 10.0),
                ] {
                    let x_left = Vector3::new(x, y, z);
                    let x_right = rig.rotation * x_left + rig.translation;
                    let pl = rig.left.camera.project_camera_point(&x_left).unwrap();
                    let pr = rig.right.camera.project_camera_point(&x_right).unwrap();
                    let ql =
                        undistort_point(&rig.left.camera, &pl, Some(&rect.r1), Some(&k1)).unwrap();
                    let qr =
                        undistort_point(&rig.right.camera, &pr, Some(&rect.r2), Some(&k2)).unwrap();
                    // Same row (column for a vertical rig).
                    let across = 1 - axis;
                    assert!(
                        (ql[across] - qr[across]).abs() < 1e-8,
                        "{what}: {ql} vs {qr}"
                    );
                    // P1 R1 X.
                    let h = k1 * (rect.r1 * x_left);
                    let expected = Vector2::new(h.x / h.z, h.y / h.z);
                    assert!((ql - expected).norm() < 1e-8, "{what}: {ql} vs {expected}");
                    if !rect.vertical {
                        let d = ql.x - qr.x;
                        let h = rect.q * Vector4::new(ql.x, ql.y, d, 1.0);
                        let point = h.xyz() / h.w;
                        let truth = rect.r1 * x_left;
                        assert!(
                            (point - truth).norm() < 1e-9 * truth.norm(),
                            "{what}: {point} vs {truth}"
                        );
                    }
                }
            }
        }
    }
}

/// alpha 0: every pixel of both rectified images sees the source image (the border pixels of
/// the valid region map inside it); alpha 1: every source pixel is kept (the source corners map
/// inside the rectified images). Checked on the rectified images' border and the source corners.
#[test]
fn alpha_zero_keeps_only_valid_pixels_and_alpha_one_keeps_every_source_pixel() {
    for model in [CameraModel::BrownConrady5, CameraModel::KannalaBrandt4] {
        let rig = rig(model, Vector3::new(-0.12, 0.004, 0.003));
        let rect0 = stereo_rectify(&rig, Some(0.0)).unwrap();
        let rect1 = stereo_rectify(&rig, Some(1.0)).unwrap();
        assert!(rect1.p1[(0, 0)] < rect0.p1[(0, 0)], "{model}");
        for (camera, r, p0, p1) in [
            (&rig.left, rect0.r1, rect0.p1, rect1.p1),
            (&rig.right, rect0.r2, rect0.p2, rect1.p2),
        ] {
            let k0 = p0.fixed_view::<3, 3>(0, 0).into_owned();
            let map = PixelMap::new(camera, &r, &k0, camera.image_size).unwrap();
            let (w, h) = (640usize, 480usize);
            for (u, v) in (0..w)
                .map(|u| (u, 0))
                .chain((0..w).map(|u| (u, h - 1)))
                .chain((0..h).map(|v| (0, v)))
                .chain((0..h).map(|v| (w - 1, v)))
            {
                let [x, y] = map.source[v * w + u];
                // OpenCV's inner rectangle comes from a 9x9 grid, so between grid points the
                // border may reach a fraction of a pixel outside.
                assert!(
                    x > -1.5 && y > -1.5 && x < w as f32 + 0.5 && y < h as f32 + 0.5,
                    "{model}: ({u}, {v}) -> ({x}, {y})"
                );
            }
            let k1 = p1.fixed_view::<3, 3>(0, 0).into_owned();
            for (u, v) in [(0.0, 0.0), (639.0, 0.0), (0.0, 479.0), (639.0, 479.0)] {
                let q = undistort_point(&camera.camera, &Vector2::new(u, v), Some(&r), Some(&k1))
                    .unwrap();
                assert!(
                    q.x > -1e-6 && q.y > -1e-6 && q.x < 639.0 + 1e-6 && q.y < 479.0 + 1e-6,
                    "{model}: ({u}, {v}) -> {q}"
                );
            }
        }
    }
}

#[test]
fn bad_rigs_and_alphas_are_typed_errors() {
    let mut r = rig(CameraModel::BrownConrady4, Vector3::new(-0.1, 0.0, 0.0));
    assert!(stereo_rectify(&r, Some(-0.5)).is_err());
    r.translation = Vector3::zeros();
    assert!(
        stereo_rectify(&r, Some(0.0))
            .unwrap_err()
            .to_string()
            .contains("baseline")
    );
    let mut r = rig(CameraModel::BrownConrady4, Vector3::new(-0.1, 0.0, 0.0));
    r.rotation[(0, 0)] = 2.0;
    assert!(
        stereo_rectify(&r, Some(0.0))
            .unwrap_err()
            .to_string()
            .contains("rotation")
    );
    let mut r = rig(CameraModel::BrownConrady4, Vector3::new(-0.1, 0.0, 0.0));
    r.right.image_size = ImageSize::new(320, 240);
    assert!(
        stereo_rectify(&r, Some(0.0))
            .unwrap_err()
            .to_string()
            .contains("image sizes")
    );
}

/// A right camera rolled about its axis by 45, 90 or 180 degrees (mounted sideways or upside
/// down): alpha 1 and OpenCV's default scaling rectify it (points on one row, the source
/// corners inside the alpha-1 images), while alpha 0, whose inner rectangle of valid pixels is
/// empty there, is refused with a message naming the camera and the way out. (The all-valid
/// rectangle used to make every alpha fail: "only 81 of 81 grid points ... can be undistorted".)
#[test]
fn rolled_cameras_rectify_with_alpha_one_or_default_and_refuse_alpha_zero() {
    for degrees in [45.0f64, 90.0, 180.0] {
        let mut r = rig(
            CameraModel::BrownConrady5,
            Vector3::new(-0.12, 0.002, 0.003),
        );
        r.rotation = AxisAngle::matrix(&Vector3::new(0.0, 0.0, degrees.to_radians()));
        for alpha in [Some(1.0), None] {
            let rect = stereo_rectify(&r, alpha).unwrap();
            let what = format!("{degrees} degrees, alpha {alpha:?}");
            let k1 = rect.p1.fixed_view::<3, 3>(0, 0).into_owned();
            let k2 = rect.p2.fixed_view::<3, 3>(0, 0).into_owned();
            let across = if rect.vertical { 0 } else { 1 };
            for x_left in [Vector3::new(0.1, 0.05, 1.5), Vector3::new(-0.2, 0.1, 3.0)] {
                let x_right = r.rotation * x_left + r.translation;
                let pl = r.left.camera.project_camera_point(&x_left).unwrap();
                let pr = r.right.camera.project_camera_point(&x_right).unwrap();
                let ql = undistort_point(&r.left.camera, &pl, Some(&rect.r1), Some(&k1)).unwrap();
                let qr = undistort_point(&r.right.camera, &pr, Some(&rect.r2), Some(&k2)).unwrap();
                assert!(
                    (ql[across] - qr[across]).abs() < 1e-8,
                    "{what}: {ql} vs {qr}"
                );
            }
            if alpha == Some(1.0) {
                for (camera, rot, k) in [(&r.left, &rect.r1, &k1), (&r.right, &rect.r2, &k2)] {
                    for (u, v) in [(0.0, 0.0), (639.0, 0.0), (0.0, 479.0), (639.0, 479.0)] {
                        let q = undistort_point(
                            &camera.camera,
                            &Vector2::new(u, v),
                            Some(rot),
                            Some(k),
                        )
                        .unwrap();
                        assert!(
                            (-1.0..=640.0).contains(&q.x) && (-1.0..=480.0).contains(&q.y),
                            "{what}: corner ({u}, {v}) -> {q}"
                        );
                    }
                }
            }
        }
        let err = stereo_rectify(&r, Some(0.0)).unwrap_err().to_string();
        assert!(
            err.contains("no rectangle of valid pixels") && err.contains("use alpha 1"),
            "{degrees}: {err}"
        );
    }
}

/// Real images: calibrate the bundled sourishg1 rig from its corner file, rectify every pair's
/// photographs, detect the board in the rectified images and compare the rows of the same
/// corner. A good calibration leaves residual row differences of the order of the corner
/// detector's noise (~0.1 px) plus the calibration's reprojection error (0.24 px RMS here);
/// 0.5 px mean and 2 px worst are bounds a wrong R1/R2, a swapped rig or a wrong pixel
/// convention (0.5 px shift) would all exceed.
#[test]
fn rectified_sourishg1_pairs_have_corners_on_the_same_rows() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/sourishg1");
    let observations = calib_stereo::StereoObservations::read(data.join("stereo.json")).unwrap();
    let result =
        calib_stereo::calibrate_stereo(&observations, &calib_stereo::StereoOptions::default())
            .unwrap();
    let rig = StereoRig::from(&result);
    let rect = stereo_rectify(&rig, Some(0.0)).unwrap();
    let k = rect.camera_matrix();
    let left_map = PixelMap::new(&rig.left, &rect.r1, &k, rig.left.image_size).unwrap();
    let right_map = PixelMap::new(&rig.right, &rect.r2, &k, rig.right.image_size).unwrap();
    let board = board_detect::Board::new(9, 6, 24.23).unwrap();
    let options = board_detect::DetectOptions::default();
    let mut dys = Vec::new();
    let mut pairs = 0;
    for pair in &observations.pairs {
        let load = |name: &str| {
            image::open(data.join("images").join(name))
                .unwrap()
                .to_luma8()
        };
        let left = remap_image(
            &image::DynamicImage::ImageLuma8(load(&pair.left.name)),
            &left_map,
        )
        .to_luma8();
        let right = remap_image(
            &image::DynamicImage::ImageLuma8(load(&pair.right.name)),
            &right_map,
        )
        .to_luma8();
        let (Ok(l), Ok(r)) = (
            board_detect::detect_image(&left, &board, &options),
            board_detect::detect_image(&right, &board, &options),
        ) else {
            continue;
        };
        pairs += 1;
        for (a, b) in l.corners.iter().zip(&r.corners) {
            dys.push((a[1] - b[1]).abs());
        }
    }
    let mean = dys.iter().sum::<f64>() / dys.len() as f64;
    let max = dys.iter().cloned().fold(0.0, f64::max);
    println!(
        "sourishg1 rectified: {pairs} of {} pairs detected, {} corners, |dy| mean {mean:.3} px, max {max:.3} px",
        observations.pairs.len(),
        dys.len()
    );
    assert!(pairs >= 25, "{pairs} pairs detected after rectification");
    assert!(mean < 0.5, "mean |dy| {mean}");
    assert!(max < 2.0, "max |dy| {max}");
}

/// A fisheye pair seeing about 200 degrees across the diagonal (f 230 px on 640x480: the image
/// corners lie 100 degrees off the axis). No pinhole image shows the corners, and rectification
/// refused every alpha ("image corner (0, 0) looks behind the rectified image plane"), while
/// alpha 1 fell through to a degenerate scale (f 0.3 px) once the corners were not needed. Now
/// the edge midpoints centre each camera, alpha 0 and the default rectify (points on one row),
/// and alpha above 0, which would keep the corners, is refused pointing to alpha 0.
#[test]
fn a_fisheye_pair_seeing_beyond_90_degrees_rectifies_within_90_degrees() {
    let wide = |name, cx, cy| {
        CameraCalibration::new(
            name,
            AnyCamera::new(
                CameraModel::KannalaBrandt4,
                Intrinsics::new(230.0, 230.0, cx, cy),
                vec![0.0; 4],
            )
            .unwrap(),
            ImageSize::new(640, 480),
        )
        .unwrap()
    };
    let rig = StereoRig {
        left: wide("left", 319.5, 239.5),
        right: wide("right", 321.0, 238.0),
        rotation: AxisAngle::matrix(&Vector3::new(0.01, -0.02, 0.005)),
        translation: Vector3::new(-0.1, 0.002, 0.001),
    };
    for alpha in [Some(0.0), None] {
        let rect = stereo_rectify(&rig, alpha).unwrap_or_else(|e| panic!("{alpha:?}: {e}"));
        let k1 = rect.p1.fixed_view::<3, 3>(0, 0).into_owned();
        let k2 = rect.p2.fixed_view::<3, 3>(0, 0).into_owned();
        assert!(
            k1[(0, 0)] > 100.0 && k1[(0, 0)].is_finite(),
            "{alpha:?}: {k1}"
        );
        for x_left in [Vector3::new(0.5, 0.2, 1.0), Vector3::new(-0.8, -0.4, 1.2)] {
            let x_right = rig.rotation * x_left + rig.translation;
            let pl = rig.left.camera.project_camera_point(&x_left).unwrap();
            let pr = rig.right.camera.project_camera_point(&x_right).unwrap();
            let ql = undistort_point(&rig.left.camera, &pl, Some(&rect.r1), Some(&k1)).unwrap();
            let qr = undistort_point(&rig.right.camera, &pr, Some(&rect.r2), Some(&k2)).unwrap();
            assert!((ql.y - qr.y).abs() < 1e-8, "{alpha:?}: {ql} vs {qr}");
        }
    }
    for alpha in [0.5, 1.0] {
        let message = stereo_rectify(&rig, Some(alpha)).unwrap_err().to_string();
        assert!(
            message.contains("more than 90 degrees") && message.contains("alpha 0"),
            "{alpha}: {message}"
        );
    }
}
