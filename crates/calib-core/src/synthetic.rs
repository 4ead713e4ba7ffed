//! Synthetic calibration data with known truth: a planar chessboard seen by a known camera (any
//! lens model) from random realistic poses, with Gaussian pixel noise. Seeded and
//! platform-independent (it uses [`lm_solver::Rng`]), so a seed names the same data set forever.

use crate::data::{ImageSize, View};
use camera_model::{
    AnyCamera, AxisAngle, Camera, CameraModel, Intrinsics, LensDistortion, Pose, Projection,
    RotationParameterization, dispatch_camera_model,
};
use lm_solver::Rng;
use nalgebra::{Point2, Point3, Vector2, Vector3};

/// What to generate.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticConfig {
    /// Image size in pixels.
    pub image_size: ImageSize,
    /// True lens model.
    pub model: CameraModel,
    /// True intrinsics.
    pub intrinsics: Intrinsics,
    /// True distortion coefficients (the model's, OpenCV's order).
    pub distortion: Vec<f64>,
    /// Inner corners per row.
    pub board_cols: usize,
    /// Inner corners per column.
    pub board_rows: usize,
    /// Square size (board units).
    pub square: f64,
    /// Number of views.
    pub views: usize,
    /// Standard deviation of the pixel noise, per coordinate.
    pub noise_px: f64,
    /// Largest angle between the board normal and the optical axis, degrees.
    pub max_tilt_deg: f64,
    /// Seed.
    pub seed: u64,
}

impl Default for SyntheticConfig {
    /// A 640x480 camera (fx = fy = 800, centred principal point, mild barrel distortion), a 9x6
    /// board of 25 mm squares, 20 views tilted up to 45 degrees, 0.2 px noise.
    fn default() -> Self {
        Self {
            image_size: ImageSize::new(640, 480),
            model: CameraModel::BrownConrady4,
            intrinsics: Intrinsics::new(800.0, 800.0, 319.5, 239.5),
            distortion: vec![-0.2, 0.05, 0.001, -0.0005],
            board_cols: 9,
            board_rows: 6,
            square: 25.0,
            views: 20,
            noise_px: 0.2,
            max_tilt_deg: 45.0,
            seed: 1,
        }
    }
}

/// A generated data set and the truth behind it.
#[derive(Debug, Clone)]
pub struct SyntheticSet {
    /// Image size.
    pub image_size: ImageSize,
    /// The noisy views.
    pub views: Vec<View>,
    /// The true camera.
    pub camera: AnyCamera,
    /// The true board-to-camera pose of each view.
    pub poses: Vec<Pose>,
}

/// Why generation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SyntheticError {
    /// No pose keeping the whole board inside the image was found.
    #[error(
        "could not place the board inside the image for view {view}: the board or tilt is too large for this camera"
    )]
    CannotPlaceBoard {
        /// The view.
        view: usize,
    },
    /// No board pose in front of both cameras of a stereo rig showed the whole board to both.
    #[error(
        "could not place the board so that both cameras see all of it for pair {view}: the board ({board_width:.1} wide) is small against the baseline ({baseline:.1}) at the distances that fill the image; use a larger board or square size, or a shorter baseline (--rig)"
    )]
    NotSeenByBoth {
        /// The pair.
        view: usize,
        /// The board's width, board units.
        board_width: f64,
        /// The rig's baseline, board units.
        baseline: f64,
    },
    /// A setting is out of range.
    #[error("invalid setting: {0}")]
    Invalid(String),
}

/// The board's inner corners, row-major: corner `(r, c)` at `(c * square, r * square, 0)`.
pub fn board_points(cols: usize, rows: usize, square: f64) -> Vec<Point3<f64>> {
    (0..rows)
        .flat_map(|r| {
            (0..cols).map(move |c| Point3::new(c as f64 * square, r as f64 * square, 0.0))
        })
        .collect()
}

/// Draws a board pose: tilted by up to `max_tilt_deg` about a random axis in the image plane,
/// turned up to 30 degrees in its plane, filling 35% to 80% of the image width, centred somewhere
/// in the middle 40% of the image.
pub fn random_pose(
    rng: &mut Rng,
    config: &SyntheticConfig,
    board_width: f64,
    board_centre: &Vector3<f64>,
) -> Pose {
    let k = &config.intrinsics;
    let tilt = rng.range(0.0, config.max_tilt_deg.to_radians());
    let axis_angle = rng.range(0.0, 2.0 * std::f64::consts::PI);
    let spin = rng.range(-30f64.to_radians(), 30f64.to_radians());
    let tilt_rotation =
        AxisAngle::matrix(&(Vector3::new(axis_angle.cos(), axis_angle.sin(), 0.0) * tilt));
    let rotation = tilt_rotation * AxisAngle::matrix(&Vector3::new(0.0, 0.0, spin));
    let fill = rng.range(0.35, 0.8);
    if config.model.is_fisheye() {
        // Spread the boards over the whole field, out to its edge: a direction up to 90% of the
        // angle at the image's half-diagonal (equidistant: pixels per radian = f), the board
        // facing the camera along it and subtending `fill` of the image width in angle.
        let edge = config.image_size.half_diagonal() / k.fx;
        let theta = rng.range(0.0, 0.9 * edge).min(0.97 * std::f64::consts::PI);
        let phi = rng.range(0.0, 2.0 * std::f64::consts::PI);
        let direction = Vector3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        );
        let towards = match Vector3::z().cross(&direction).try_normalize(1e-12) {
            Some(axis) => AxisAngle::matrix(&(axis * theta)),
            None => nalgebra::Matrix3::identity(),
        };
        let angle = (fill * config.image_size.width as f64 / k.fx).min(2.0);
        let depth = board_width / (2.0 * (angle / 2.0).tan());
        let rotation = towards * rotation;
        return Pose::new(rotation, direction * depth - rotation * board_centre);
    }
    let depth = k.fx * board_width / (fill * config.image_size.width as f64);
    let (w, h) = (
        config.image_size.width as f64,
        config.image_size.height as f64,
    );
    let (u, v) = (rng.range(0.3 * w, 0.7 * w), rng.range(0.3 * h, 0.7 * h));
    let centre = Vector3::new((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0) * depth;
    Pose::new(rotation, centre - rotation * board_centre)
}

/// Smallest determinant of the distortion map's Jacobian accepted along the ray to a point. Real
/// lenses only image the region where the distortion map is one-to-one (it folds back beyond it,
/// outside the image circle); a margin of 0.3 keeps points clearly inside that region.
pub const MIN_DISTORTION_JACOBIAN: f64 = 0.3;

fn typed_inside<D: LensDistortion, P: Projection>(camera: &AnyCamera, s: &Vector3<f64>) -> bool {
    let typed = Camera::<D, P>::from_parts(camera.intrinsics, D::from_params(&camera.distortion));
    let Ok(m) = P::project(s) else {
        return false;
    };
    (1..=16).all(|i| {
        let t = i as f64 / 16.0;
        let p = Vector2::new(t * m.x, t * m.y);
        typed.distortion.distort_with_jacobians(&p).1.determinant() >= MIN_DISTORTION_JACOBIAN
    })
}

/// True if the camera-frame point `s` is in the projection's range and the distortion map is
/// locally one-to-one, with margin, on the segment from the optical axis to its projection
/// (checked at 16 points).
pub fn inside_lens_field(camera: &AnyCamera, s: &Vector3<f64>) -> bool {
    dispatch_camera_model!(camera.model, D, P => typed_inside::<D, P>(camera, s))
}

/// Projects the board with `camera` from `pose`; `None` unless every point is in front of the
/// camera, inside the lens' one-to-one field and at least `margin` pixels inside the image.
pub fn project_inside(
    camera: &AnyCamera,
    pose: &Pose,
    board: &[Point3<f64>],
    size: ImageSize,
    margin: f64,
) -> Option<Vec<Point2<f64>>> {
    let (w, h) = (size.width as f64, size.height as f64);
    board
        .iter()
        .map(|x| {
            let s = pose.transform_point(x);
            if !(s.z > 0.0 && inside_lens_field(camera, &s)) {
                return None;
            }
            let p = camera.project_camera_point(&s).ok()?;
            let inside = p.x >= margin
                && p.x <= w - 1.0 - margin
                && p.y >= margin
                && p.y <= h - 1.0 - margin;
            inside.then_some(Point2::new(p.x, p.y))
        })
        .collect()
}

/// Checks the settings shared by the single and stereo generators.
pub fn check_config(config: &SyntheticConfig) -> Result<(), SyntheticError> {
    if config.board_cols < 2
        || config.board_rows < 2
        || !config.square.is_finite()
        || config.square <= 0.0
    {
        return Err(SyntheticError::Invalid(
            "the board needs at least 2x2 corners and a positive square size".into(),
        ));
    }
    if !config.noise_px.is_finite()
        || config.noise_px < 0.0
        || !(0.0..=80.0).contains(&config.max_tilt_deg)
    {
        return Err(SyntheticError::Invalid(
            "noise must be >= 0 and the tilt within 0..80 degrees".into(),
        ));
    }
    if config.image_size.width == 0
        || config.image_size.height == 0
        || !config.intrinsics.is_valid()
        || config.distortion.len() != config.model.num_distortion_params()
        || config.distortion.iter().any(|v| !v.is_finite())
    {
        return Err(SyntheticError::Invalid(format!(
            "invalid camera (the model {} has {} distortion coefficients)",
            config.model,
            config.model.num_distortion_params()
        )));
    }
    Ok(())
}

/// The true camera of a configuration.
pub fn true_camera(config: &SyntheticConfig) -> Result<AnyCamera, SyntheticError> {
    AnyCamera::new(config.model, config.intrinsics, config.distortion.clone())
        .map_err(|e| SyntheticError::Invalid(e.to_string()))
}

/// A fisheye problem of the population users produce, for convergence sweeps: a
/// `kannala-brandt4` camera with the diagonal field of view `fov_deg` (degrees; its focal length
/// `half-diagonal / (fov / 2)` in radians), a 1280x960 image, the principal point up to 20 px
/// off the centre, `fy/fx` within 1%, small coefficients (`k1` within 0.05), a 9x6 board of
/// 30-unit squares out to the edge of the field, 3 to 25 views, noise 0.1 to 1.5 px, the largest
/// tilt between 8 and 60 degrees.
pub fn fisheye_population(seed: u64, fov_deg: f64) -> SyntheticConfig {
    let mut rng = Rng::new(0xF15E_0000 + seed);
    let size = ImageSize::new(1280, 960);
    let f = size.half_diagonal() / (fov_deg.to_radians() / 2.0);
    let (cx, cy) = size.centre();
    SyntheticConfig {
        image_size: size,
        model: CameraModel::KannalaBrandt4,
        intrinsics: Intrinsics::new(
            f,
            f * rng.range(0.99, 1.01),
            cx + rng.range(-20.0, 20.0),
            cy + rng.range(-20.0, 20.0),
        ),
        distortion: fisheye_distortion(&mut rng),
        board_cols: 9,
        board_rows: 6,
        square: 30.0,
        views: 3 + (rng.uniform() * 23.0) as usize,
        noise_px: rng.range(0.1, 1.5),
        max_tilt_deg: rng.range(8.0, 60.0),
        seed: 9_000_000 + seed,
    }
}

/// Small random `kannala-brandt4` coefficients (`k1` within 0.05, `k2` 0.01, `k3` 0.003, `k4`
/// 0.0005), as [`fisheye_population`] draws them.
pub fn fisheye_distortion(rng: &mut Rng) -> Vec<f64> {
    vec![
        rng.range(-0.05, 0.05),
        rng.range(-0.01, 0.01),
        rng.range(-0.003, 0.003),
        rng.range(-0.0005, 0.0005),
    ]
}

/// A problem of the population users produce, for convergence sweeps: 3 to 40 views, the largest
/// board tilt drawn per problem between 5 and 60 degrees (each view's tilt uniform up to it, so
/// many views are nearly frontal), noise 0.05 to 1 px, a 7x5, 9x6 or 12x9 board, focal lengths
/// 400 to 1500 px with `fy/fx` within 2%, the principal point up to 15 px off the image centre,
/// barrel distortion around `k1 = -0.2`, a 640x480 or 1280x720 image.
pub fn population(seed: u64) -> SyntheticConfig {
    let mut rng = Rng::new(0x5EED_0000 + seed);
    let views = 3 + (rng.uniform() * 38.0) as usize;
    let max_tilt_deg = rng.range(5.0, 60.0);
    let noise_px = rng.range(0.05, 1.0);
    let (board_cols, board_rows) = [(7, 5), (9, 6), (12, 9)][(rng.uniform() * 3.0) as usize % 3];
    let image_size = if rng.uniform() < 0.5 {
        ImageSize::new(640, 480)
    } else {
        ImageSize::new(1280, 720)
    };
    let scale = image_size.width as f64 / 640.0;
    let f = rng.range(400.0, 1500.0) * scale;
    let (cx, cy) = image_size.centre();
    let intrinsics = Intrinsics::new(
        f,
        f * rng.range(0.98, 1.02),
        cx + rng.range(-15.0, 15.0),
        cy + rng.range(-15.0, 15.0),
    );
    SyntheticConfig {
        image_size,
        model: CameraModel::BrownConrady4,
        intrinsics,
        distortion: vec![
            rng.range(-0.25, -0.15),
            rng.range(-0.05, 0.1),
            rng.range(-0.002, 0.002),
            rng.range(-0.002, 0.002),
        ],
        board_cols,
        board_rows,
        square: rng.range(10.0, 40.0),
        views,
        noise_px,
        max_tilt_deg,
        seed: 7_000_000 + seed,
    }
}

/// A plausible true distortion of `model` for synthetic data: mild barrel distortion
/// `k1, k2, p1, p2 = -0.2, 0.05, 0.001, -0.0005`; `brown-conrady5` adds `k3 = 0.02`; `rational8`
/// adds `k3..k6 = 0.02, 0.1, 0.01, 0.002`; `thin-prism12` adds `s1..s4 = 0.001, -0.0005, 0.0008,
/// 0.0002`; `kannala-brandt4` is `0.05, -0.01, 0.003, -0.0005`.
pub fn default_distortion(model: CameraModel) -> Vec<f64> {
    let base = [-0.2, 0.05, 0.001, -0.0005];
    match model {
        CameraModel::BrownConrady4 => base.to_vec(),
        CameraModel::BrownConrady5 => [&base[..], &[0.02]].concat(),
        CameraModel::Rational8 => [&base[..], &[0.02, 0.1, 0.01, 0.002]].concat(),
        CameraModel::ThinPrism12 => [
            &base[..],
            &[0.02, 0.1, 0.01, 0.002],
            &[0.001, -0.0005, 0.0008, 0.0002],
        ]
        .concat(),
        CameraModel::KannalaBrandt4 => vec![0.05, -0.01, 0.003, -0.0005],
    }
}

/// The board of `config` (points, row-major), its width and its centre, board units.
pub fn board_geometry(config: &SyntheticConfig) -> (Vec<Point3<f64>>, f64, Vector3<f64>) {
    let board = board_points(config.board_cols, config.board_rows, config.square);
    let width = (config.board_cols - 1) as f64 * config.square;
    let height = (config.board_rows - 1) as f64 * config.square;
    (board, width, Vector3::new(width / 2.0, height / 2.0, 0.0))
}

/// The pixels with independent Gaussian noise of standard deviation `noise_px` on each
/// coordinate.
pub fn add_noise(pixels: Vec<Point2<f64>>, noise_px: f64, rng: &mut Rng) -> Vec<Point2<f64>> {
    pixels
        .into_iter()
        .map(|p| Point2::new(p.x + noise_px * rng.normal(), p.y + noise_px * rng.normal()))
        .collect()
}

/// Generates a single-camera data set.
pub fn generate(config: &SyntheticConfig) -> Result<SyntheticSet, SyntheticError> {
    check_config(config)?;
    let mut rng = Rng::new(config.seed);
    let camera = true_camera(config)?;
    let (board, board_width, centre) = board_geometry(config);
    let mut views = Vec::with_capacity(config.views);
    let mut poses = Vec::with_capacity(config.views);
    for view in 0..config.views {
        let (pose, pixels) = (0..1000)
            .find_map(|_| {
                let pose = random_pose(&mut rng, config, board_width, &centre);
                project_inside(&camera, &pose, &board, config.image_size, 5.0).map(|p| (pose, p))
            })
            .ok_or(SyntheticError::CannotPlaceBoard { view })?;
        let image_points = add_noise(pixels, config.noise_px, &mut rng);
        views.push(View {
            name: format!("synthetic{view}"),
            object_points: board.clone(),
            image_points,
        });
        poses.push(pose);
    }
    Ok(SyntheticSet {
        image_size: config.image_size,
        views,
        camera,
        poses,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_views_lie_inside_the_image_and_are_reproducible() {
        let config = SyntheticConfig {
            views: 30,
            max_tilt_deg: 60.0,
            ..Default::default()
        };
        let a = generate(&config).unwrap();
        let b = generate(&config).unwrap();
        assert_eq!(a.views, b.views);
        for (view, pose) in a.views.iter().zip(&a.poses) {
            assert_eq!(view.object_points.len(), 54);
            for p in &view.image_points {
                assert!(p.x > 0.0 && p.x < 639.0 && p.y > 0.0 && p.y < 479.0);
            }
            let normal = pose.rotation.column(2);
            assert!(normal.z.abs() >= 60f64.to_radians().cos() - 1e-12);
        }
        let other = generate(&SyntheticConfig { seed: 2, ..config }).unwrap();
        assert_ne!(other.views, a.views);
        // Strong barrel distortion on a wide lens: every point stays where the lens map is
        // one-to-one, even though the map folds back inside the image corners.
        let wide = SyntheticConfig {
            intrinsics: Intrinsics::new(400.0, 390.0, 300.0, 230.0),
            distortion: vec![-0.34, -0.1, 0.002, -0.003],
            views: 30,
            max_tilt_deg: 60.0,
            ..Default::default()
        };
        let set = generate(&wide).unwrap();
        for (view, pose) in set.views.iter().zip(&set.poses) {
            for x in &view.object_points {
                assert!(inside_lens_field(&set.camera, &pose.transform_point(x)));
            }
        }
    }

    #[test]
    fn noise_has_the_requested_level() {
        let config = SyntheticConfig {
            views: 50,
            noise_px: 0.5,
            ..Default::default()
        };
        let set = generate(&config).unwrap();
        let mut sum = 0.0;
        let mut n = 0;
        for (view, pose) in set.views.iter().zip(&set.poses) {
            for (x, m) in view.object_points.iter().zip(&view.image_points) {
                let p = set.camera.project(pose, x).unwrap();
                sum += (p.x - m.x).powi(2) + (p.y - m.y).powi(2);
                n += 2;
            }
        }
        let sigma = (sum / n as f64).sqrt();
        // 5400 samples: the standard error of sigma is about 0.5 / sqrt(2 * 5400) = 0.005.
        assert!((sigma - 0.5).abs() < 0.025, "{sigma}");
    }

    #[test]
    fn impossible_settings_are_errors() {
        let config = SyntheticConfig {
            square: -1.0,
            ..Default::default()
        };
        assert!(matches!(generate(&config), Err(SyntheticError::Invalid(_))));
        // A 10x10 image leaves no room inside the 5 px margin.
        let tiny_image = SyntheticConfig {
            image_size: ImageSize::new(10, 10),
            intrinsics: Intrinsics::new(10.0, 10.0, 4.5, 4.5),
            ..Default::default()
        };
        assert_eq!(
            generate(&tiny_image).unwrap_err(),
            SyntheticError::CannotPlaceBoard { view: 0 }
        );
    }
}
