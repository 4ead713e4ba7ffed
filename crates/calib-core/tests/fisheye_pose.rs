//! The fisheye start's pose of a view (`init::fisheye_pose`) for boards far off the axis.

use calib_core::init::fisheye_pose;
use camera_model::{AnyCamera, AxisAngle, CameraModel, Intrinsics, Pose, RotationParameterization};
use nalgebra::{Point3, Vector2, Vector3};

/// A 9x6 board facing an equidistant camera (f = 357, 1280x1024) from `theta_deg` off its axis
/// towards the image's top-right corner, tilted a little; its true pose and pixels.
fn edge_view(theta_deg: f64) -> (Vec<Point3<f64>>, Vec<Vector2<f64>>, Pose) {
    let camera = AnyCamera::new(
        CameraModel::KannalaBrandt4,
        Intrinsics::new(357.0, 357.0, 639.5, 511.5),
        vec![0.0; 4],
    )
    .unwrap();
    let board: Vec<Point3<f64>> = (0..6)
        .flat_map(|r| (0..9).map(move |c| Point3::new(c as f64 * 30.0, r as f64 * 30.0, 0.0)))
        .collect();
    let centre = Vector3::new(120.0, 75.0, 0.0);
    let (theta, phi) = (theta_deg.to_radians(), -0.67f64);
    let direction = Vector3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    );
    let towards = AxisAngle::matrix(&(Vector3::z().cross(&direction).normalize() * theta));
    let rotation = towards * AxisAngle::matrix(&Vector3::new(0.2, -0.15, 0.1));
    let pose = Pose::new(rotation, direction * 700.0 - rotation * centre);
    let pixels = board
        .iter()
        .map(|x| {
            camera
                .project_camera_point(&pose.transform_point(x))
                .unwrap()
        })
        .collect();
    (board, pixels, pose)
}

/// A board entirely 80 to 100 degrees off the axis has no point within the 70 degrees the
/// axis-centred start maps to the pinhole plane. It had no fisheye pose (`None`), and its start
/// came from the pixel homography through a pinhole camera, which means nothing at the edge of a
/// fisheye: started from the true camera, such a view was refused as mostly outliers. Mapped to
/// the plane facing its own mean direction, its pose is the true one (no noise, no distortion).
#[test]
fn a_board_beyond_70_degrees_gets_its_pose_from_its_own_rays() {
    for theta in [85.0, 92.0, 100.0] {
        let (board, pixels, truth) = edge_view(theta);
        assert!(
            pixels
                .iter()
                .all(|p| (p - Vector2::new(639.5, 511.5)).norm() / 357.0 > 70f64.to_radians()),
            "{theta}: the view must lie beyond 70 degrees"
        );
        let pose = fisheye_pose(357.0, 639.5, 511.5, &board, &pixels)
            .unwrap_or_else(|| panic!("{theta}: no pose"));
        let angle = AxisAngle::from_matrix(&(pose.rotation * truth.rotation.transpose())).norm();
        let shift = (pose.translation - truth.translation).norm() / truth.translation.norm();
        assert!(
            angle < 1e-9 && shift < 1e-9,
            "{theta}: rotation off by {angle} rad, translation by {shift}"
        );
    }
}
