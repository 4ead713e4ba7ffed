//! Synthetic rigs with known truth: N cameras on a ring or in a line, all looking at a shared
//! volume, a board moved through it. Each frame the board faces one camera or a pair of
//! neighbours (in turn) and is seen by every camera that sees all of it from the front:
//! neighbours overlap, distant cameras do not.

use crate::observations::{RigCameraInput, RigFrame, RigObservation, RigObservations};
use calib_core::data::View;
use calib_core::synthetic::{
    SyntheticConfig, SyntheticError, add_noise, board_geometry, check_config, default_distortion,
    project_inside,
};
use camera_model::{AnyCamera, AxisAngle, CameraModel, Intrinsics, Pose, RotationParameterization};
use lm_solver::Rng;
use nalgebra::{Matrix3, Vector3};

/// Where the cameras stand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RigLayout {
    /// On a horizontal circle around the volume, spread over `arc_deg` degrees (360: a full
    /// ring), each looking at its centre.
    Ring {
        /// Arc the cameras cover, degrees.
        arc_deg: f64,
    },
    /// On a horizontal line, `spacing` board widths apart, each turned towards the volume's
    /// centre.
    Line {
        /// Distance between neighbours, board widths.
        spacing: f64,
    },
}

/// What to generate.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticRigConfig {
    /// Number of cameras.
    pub cameras: usize,
    /// Where they stand.
    pub layout: RigLayout,
    /// Number of frames.
    pub frames: usize,
    /// Board (size, square), noise, largest tilt, seed, and the first camera's image size,
    /// intrinsics and lens model; the other cameras' focal lengths differ by up to 15%, their
    /// principal points by up to 15 px. `views` is ignored (see `frames`).
    pub base: SyntheticConfig,
    /// Lens model per camera, repeated cyclically (empty: `base.model` for all).
    pub models: Vec<CameraModel>,
}

impl Default for SyntheticRigConfig {
    /// Four cameras on a 180-degree arc, 40 frames, the single-camera defaults for the board
    /// and the first camera (0.2 px noise).
    fn default() -> Self {
        Self {
            cameras: 4,
            layout: RigLayout::Ring { arc_deg: 180.0 },
            frames: 40,
            base: SyntheticConfig::default(),
            models: Vec::new(),
        }
    }
}

/// A generated rig data set and its truth.
#[derive(Debug, Clone)]
pub struct SyntheticRigSet {
    /// The noisy observations.
    pub observations: RigObservations,
    /// True cameras.
    pub cameras: Vec<AnyCamera>,
    /// True camera transforms from camera 0 (`X_cam = R X_0 + T`; the identity for camera 0).
    pub transforms: Vec<Pose>,
    /// True board-to-camera-0 pose of each frame.
    pub frame_poses: Vec<Pose>,
}

/// Degrees between neighbouring cameras on a ring over `arc_deg` (a closed ring from 359
/// degrees: `n` gaps; an open arc: `n - 1`).
fn ring_step(arc_deg: f64, n: usize) -> f64 {
    if arc_deg >= 359.0 {
        arc_deg / n as f64
    } else {
        arc_deg / (n.max(2) - 1) as f64
    }
}

/// Rotation of a camera at `position` looking at `target`, image y axis as close to world +y
/// (down) as the viewing direction allows.
fn look_at(position: &Vector3<f64>, target: &Vector3<f64>) -> Matrix3<f64> {
    let z = (target - position).normalize();
    let x = Vector3::y().cross(&z).normalize();
    let y = z.cross(&x);
    Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()])
}

/// Generates a rig: cameras placed by the layout around a volume at the distance where the board
/// fills about 55% of the first camera's image width; per frame, a board facing in turn one
/// camera (even frames) or the point between two neighbours (odd frames), tilted as for a single
/// camera, kept when those cameras see all of it, and observed by every camera that sees all of
/// it from the front (within 70 degrees of the board's normal). Neighbours always share frames.
pub fn generate_rig(config: &SyntheticRigConfig) -> Result<SyntheticRigSet, SyntheticError> {
    let base = &config.base;
    check_config(base)?;
    if !(1..=64).contains(&config.cameras) || config.frames == 0 {
        return Err(SyntheticError::Invalid(
            "a rig needs 1 to 64 cameras and at least one frame".into(),
        ));
    }
    let n = config.cameras;
    // A board seen by two neighbours faces each within 70 degrees (below): neighbours more than
    // 140 degrees apart around the ring share a frame only where the board's offset from the
    // centre turns their views towards each other, and from 170 degrees (two cameras on the
    // default 180-degree arc face each other) the 2000 draws below find none.
    if let RigLayout::Ring { arc_deg } = config.layout {
        let step = ring_step(arc_deg, n);
        if n > 1 && step > 170.0 {
            return Err(SyntheticError::Invalid(format!(
                "{n} cameras on a {arc_deg}-degree arc stand {step:.0} degrees apart: a board seen by two neighbours must face both within 70 degrees, so they should stand at most about 140 degrees apart; use a smaller arc (at most {:.0} degrees for {n} cameras) or more cameras",
                140.0 * (n - 1) as f64
            )));
        }
    }
    let mut rng = Rng::new(base.seed);
    let (board, board_width, board_centre) = board_geometry(base);
    let k0 = base.intrinsics;
    let distance = k0.fx * board_width / (0.55 * base.image_size.width as f64);

    // Cameras in a world frame with the volume's centre at the origin, y down.
    let target = Vector3::zeros();
    let mut world_to_camera = Vec::with_capacity(n);
    let mut cameras = Vec::with_capacity(n);
    for c in 0..n {
        let position = match config.layout {
            RigLayout::Ring { arc_deg } => {
                let step = ring_step(arc_deg, n);
                let a = (c as f64 * step - arc_deg / 2.0).to_radians();
                Vector3::new(distance * a.sin(), 0.0, -distance * a.cos())
            }
            RigLayout::Line { spacing } => Vector3::new(
                (c as f64 - (n - 1) as f64 / 2.0) * spacing * board_width,
                0.0,
                -distance,
            ),
        };
        let jitter = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * 0.02;
        let rotation = AxisAngle::matrix(&jitter) * look_at(&position, &target);
        world_to_camera.push(Pose::new(rotation, -(rotation * position)));
        let model = if config.models.is_empty() {
            base.model
        } else {
            config.models[c % config.models.len()]
        };
        let (cx, cy) = base.image_size.centre();
        let intrinsics = if c == 0 {
            k0
        } else {
            let f = k0.fx * rng.range(0.85, 1.15);
            Intrinsics::new(
                f,
                f * rng.range(0.98, 1.02),
                cx + rng.range(-15.0, 15.0),
                cy + rng.range(-15.0, 15.0),
            )
        };
        let distortion = if c == 0 && model == base.model {
            base.distortion.clone()
        } else {
            let scale = rng.range(0.7, 1.3);
            default_distortion(model)
                .into_iter()
                .map(|d| d * scale)
                .collect()
        };
        cameras.push(
            AnyCamera::new(model, intrinsics, distortion)
                .map_err(|e| SyntheticError::Invalid(format!("camera {c}: {e}")))?,
        );
    }
    let to_reference = world_to_camera[0].inverse();
    let mut transforms: Vec<Pose> = world_to_camera
        .iter()
        .map(|p| p.compose(&to_reference))
        .collect();
    transforms[0] = Pose::identity();

    let facing_limit = 70f64.to_radians().cos();
    let closed = matches!(config.layout, RigLayout::Ring { arc_deg } if arc_deg >= 359.0);
    let neighbours = if closed { n } else { n - 1 };
    let centres: Vec<Vector3<f64>> = world_to_camera
        .iter()
        .map(|p| -(p.rotation.transpose() * p.translation))
        .collect();
    let mut frames = Vec::with_capacity(config.frames);
    let mut frame_poses = Vec::with_capacity(config.frames);
    for f in 0..config.frames {
        // Even frames face one camera, odd frames the point between two neighbours (both must
        // see them): every neighbour pair shares frames, so the rig is connected.
        let k = (f / 2) % n;
        let (facing, required): (Matrix3<f64>, Vec<usize>) = if f % 2 == 1 && neighbours > 0 {
            let k = (f / 2) % neighbours;
            let j = (k + 1) % n;
            let between = (centres[k] + centres[j]) / 2.0;
            (look_at(&between, &target), vec![k, j])
        } else {
            (world_to_camera[k].rotation, vec![k])
        };
        let found = (0..2000).find_map(|_| {
            // Tilted about an axis in the facing image plane and spun in its plane, as
            // single-camera views are, then moved around the volume's centre.
            let tilt = rng.range(0.0, base.max_tilt_deg.to_radians());
            let axis = rng.range(0.0, 2.0 * std::f64::consts::PI);
            let spin = rng.range(-30f64.to_radians(), 30f64.to_radians());
            let in_camera = AxisAngle::matrix(&(Vector3::new(axis.cos(), axis.sin(), 0.0) * tilt))
                * AxisAngle::matrix(&Vector3::new(0.0, 0.0, spin));
            let rotation = facing.transpose() * in_camera;
            let centre = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * 0.12 * distance;
            let board_to_world = Pose::new(rotation, centre - rotation * board_centre);
            let normal = rotation * Vector3::z();
            let mut observations = Vec::new();
            for c in 0..n {
                let front = normal.dot(&(centre - centres[c]).normalize()) > facing_limit;
                let pose = world_to_camera[c].compose(&board_to_world);
                let pixels = if front {
                    project_inside(&cameras[c], &pose, &board, base.image_size, 5.0)
                } else {
                    None
                };
                match pixels {
                    Some(pixels) => observations.push(RigObservation {
                        camera: c,
                        view: View {
                            name: format!("frame {f}, camera {c}"),
                            object_points: board.clone(),
                            image_points: add_noise(pixels, base.noise_px, &mut rng),
                        },
                    }),
                    None if required.contains(&c) => return None,
                    None => {}
                }
            }
            Some((observations, world_to_camera[0].compose(&board_to_world)))
        });
        let (observations, pose) = found.ok_or(SyntheticError::CannotPlaceBoard { view: f })?;
        frames.push(RigFrame { observations });
        frame_poses.push(pose);
    }
    Ok(SyntheticRigSet {
        observations: RigObservations {
            cameras: (0..n)
                .map(|c| RigCameraInput {
                    name: format!("cam{c}"),
                    image_size: base.image_size,
                    model: Some(cameras[c].model),
                })
                .collect(),
            frames,
        },
        cameras,
        transforms,
        frame_poses,
    })
}

/// A random rig of the population users build, for convergence sweeps: 3 to 8 cameras on a ring
/// (90 to 360 degrees) or in a line, 6 to 15 frames per camera, the board, noise (0.05 to 1 px),
/// tilt (10 to 60 degrees), focal length and principal point of
/// [`calib_core::synthetic::population`].
pub fn population(seed: u64) -> SyntheticRigConfig {
    let mut base = calib_core::synthetic::population(seed);
    let mut rng = Rng::new(0x816_0000 + seed);
    let cameras = 3 + (rng.uniform() * 6.0) as usize % 6;
    let layout = if rng.uniform() < 0.6 {
        RigLayout::Ring {
            arc_deg: rng.range(90.0, 360.0),
        }
    } else {
        RigLayout::Line {
            spacing: rng.range(0.3, 1.0),
        }
    };
    base.max_tilt_deg = base.max_tilt_deg.max(10.0);
    let frames = cameras * (6 + (rng.uniform() * 10.0) as usize % 10);
    SyntheticRigConfig {
        cameras,
        layout,
        frames,
        base,
        models: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cameras_look_at_the_volume_and_neighbours_overlap() {
        let data = generate_rig(&SyntheticRigConfig::default()).unwrap();
        assert_eq!(data.transforms[0], Pose::identity());
        let n = data.cameras.len();
        let mut shared = vec![vec![0; n]; n];
        for frame in &data.observations.frames {
            for a in &frame.observations {
                for b in &frame.observations {
                    shared[a.camera][b.camera] += 1;
                }
            }
        }
        for (c, row) in shared.iter().enumerate() {
            assert!(row[c] >= 10, "camera {c} saw {} frames", row[c]);
        }
        for c in 1..n {
            assert!(
                shared[c - 1][c] > 0,
                "cameras {} and {c} share no frame",
                c - 1
            );
        }
        // The two ends of a 180-degree arc see the board from opposite sides.
        assert_eq!(shared[0][n - 1], 0);
    }

    /// Two cameras on the default 180-degree arc face each other: no board faces both. The
    /// generator said it could not place the board "for this camera" (too large a board or
    /// tilt); it now names the arc and what to use.
    #[test]
    fn neighbours_too_far_apart_on_the_ring_are_refused_naming_the_arc() {
        let mut config = SyntheticRigConfig {
            cameras: 2,
            ..Default::default()
        };
        let message = generate_rig(&config).unwrap_err().to_string();
        assert!(
            message.contains("180 degrees apart") && message.contains("at most 140 degrees"),
            "{message}"
        );
        config.layout = RigLayout::Ring { arc_deg: 90.0 };
        assert!(generate_rig(&config).is_ok());
    }

    #[test]
    fn frames_reproject_to_their_observations_through_the_transforms() {
        let mut config = SyntheticRigConfig::default();
        config.base.noise_px = 0.0;
        config.layout = RigLayout::Line { spacing: 0.5 };
        let data = generate_rig(&config).unwrap();
        for (frame, pose) in data.observations.frames.iter().zip(&data.frame_poses) {
            for o in &frame.observations {
                let camera_pose = data.transforms[o.camera].compose(pose);
                for (x, p) in o.view.object_points.iter().zip(&o.view.image_points) {
                    let s = camera_pose.transform_point(x);
                    let q = data.cameras[o.camera].project_camera_point(&s).unwrap();
                    assert!((q - p.coords).norm() < 1e-9);
                }
            }
        }
    }
}
