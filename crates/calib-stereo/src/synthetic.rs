//! Synthetic stereo data with known truth: a board seen by both cameras of a known rig.

use crate::observations::{StereoObservations, StereoPair};
use calib_single::synthetic::{
    SyntheticConfig, SyntheticError, add_noise, board_geometry, check_config, project_inside,
    random_pose, true_camera,
};
use calib_single::{ImageSize, View};
use camera_model::{AnyCamera, CameraModel, EulerXyz, Intrinsics, Pose, RotationParameterization};
use lm_solver::Rng;
use nalgebra::Vector3;

/// What to generate. Board, noise, tilt, view count, seed and the left camera come from `left`.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticStereoConfig {
    /// Left camera, board, number of pairs, noise, tilt and seed.
    pub left: SyntheticConfig,
    /// Right camera lens model.
    pub right_model: CameraModel,
    /// Right camera intrinsics.
    pub right_intrinsics: Intrinsics,
    /// Right camera distortion (the model's coefficients).
    pub right_distortion: Vec<f64>,
    /// Right image size.
    pub right_image_size: ImageSize,
    /// Left camera to right camera (`X_R = R X_L + T`).
    pub rig: Pose,
}

impl Default for SyntheticStereoConfig {
    /// The single-camera defaults for the left camera, a slightly different right camera, and a
    /// 100 mm baseline with a rotation of about 1.3 degrees.
    fn default() -> Self {
        Self {
            left: SyntheticConfig::default(),
            right_model: CameraModel::BrownConrady4,
            right_intrinsics: Intrinsics::new(810.0, 805.0, 325.0, 235.0),
            right_distortion: vec![-0.18, 0.04, -0.0005, 0.0008],
            right_image_size: ImageSize::new(640, 480),
            rig: Pose::new(
                EulerXyz::matrix(&Vector3::new(0.01, -0.02, 0.005)),
                Vector3::new(-100.0, 1.0, 2.0),
            ),
        }
    }
}

/// A generated stereo data set and its truth.
#[derive(Debug, Clone)]
pub struct SyntheticStereoSet {
    /// The noisy observations.
    pub observations: StereoObservations,
    /// True left camera.
    pub left: AnyCamera,
    /// True right camera.
    pub right: AnyCamera,
    /// True rig.
    pub rig: Pose,
    /// True board-to-left-camera pose of each pair.
    pub left_poses: Vec<Pose>,
}

/// Generates a stereo data set: board poses drawn as for a single camera, kept only when the
/// whole board is inside both images (and both lenses' one-to-one fields).
pub fn generate_stereo(
    config: &SyntheticStereoConfig,
) -> Result<SyntheticStereoSet, SyntheticError> {
    let base = &config.left;
    check_config(base)?;
    let mut rng = Rng::new(base.seed);
    let left = true_camera(base)?;
    let right = AnyCamera::new(
        config.right_model,
        config.right_intrinsics,
        config.right_distortion.clone(),
    )
    .map_err(|e| SyntheticError::Invalid(format!("right camera: {e}")))?;
    let (board, width, centre) = board_geometry(base);
    let mut pairs = Vec::with_capacity(base.views);
    let mut poses = Vec::with_capacity(base.views);
    for view in 0..base.views {
        let (pose, l, r) = (0..2000)
            .find_map(|_| {
                let pose = random_pose(&mut rng, base, width, &centre);
                let l = project_inside(&left, &pose, &board, base.image_size, 5.0)?;
                let r = project_inside(
                    &right,
                    &config.rig.compose(&pose),
                    &board,
                    config.right_image_size,
                    5.0,
                )?;
                Some((pose, l, r))
            })
            .ok_or(SyntheticError::NotSeenByBoth {
                view,
                board_width: width,
                baseline: config.rig.translation.norm(),
            })?;
        pairs.push(StereoPair {
            left: View {
                name: format!("left{view}"),
                object_points: board.clone(),
                image_points: add_noise(l, base.noise_px, &mut rng),
            },
            right: View {
                name: format!("right{view}"),
                object_points: board.clone(),
                image_points: add_noise(r, base.noise_px, &mut rng),
            },
        });
        poses.push(pose);
    }
    Ok(SyntheticStereoSet {
        observations: StereoObservations {
            image_size: Some(base.image_size),
            right_image_size: Some(config.right_image_size),
            pairs,
        },
        left,
        right,
        rig: config.rig,
        left_poses: poses,
    })
}

/// A random stereo problem of the population users produce (issue 11): the left camera, board,
/// views, tilt (5 to 60 degrees), noise and off-centre principal point of
/// [`calib_core::synthetic::population`]; a right camera within 10% of the left's focal length,
/// its own off-centre principal point and distortion; a rig rotated up to 5 degrees about each
/// axis with a mostly horizontal baseline of 0.2 to 0.8 board widths.
pub fn population(seed: u64) -> SyntheticStereoConfig {
    let left = calib_core::synthetic::population(seed);
    let mut rng = Rng::new(0x57E2_E000 + seed);
    let k = left.intrinsics;
    let (cx, cy) = left.image_size.centre();
    let f = k.fx * rng.range(0.9, 1.1);
    let right_intrinsics = Intrinsics::new(
        f,
        f * rng.range(0.98, 1.02),
        cx + rng.range(-15.0, 15.0),
        cy + rng.range(-15.0, 15.0),
    );
    let right_distortion = vec![
        rng.range(-0.25, -0.15),
        rng.range(-0.05, 0.1),
        rng.range(-0.002, 0.002),
        rng.range(-0.002, 0.002),
    ];
    let width = (left.board_cols - 1) as f64 * left.square;
    let baseline = rng.range(0.2, 0.8) * width;
    let angle = 5f64.to_radians();
    let rig = Pose::new(
        EulerXyz::matrix(&Vector3::new(
            rng.range(-angle, angle),
            rng.range(-angle, angle),
            rng.range(-angle, angle),
        )),
        Vector3::new(
            -baseline,
            rng.range(-0.05, 0.05) * baseline,
            rng.range(-0.05, 0.05) * baseline,
        ),
    );
    SyntheticStereoConfig {
        right_model: left.model,
        right_image_size: left.image_size,
        left,
        right_intrinsics,
        right_distortion,
        rig,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_views_are_consistent_with_the_rig() {
        let config = SyntheticStereoConfig {
            left: SyntheticConfig {
                views: 10,
                noise_px: 0.0,
                ..Default::default()
            },
            ..Default::default()
        };
        let set = generate_stereo(&config).unwrap();
        for (pair, pose) in set.observations.pairs.iter().zip(&set.left_poses) {
            for (x, m) in pair
                .right
                .object_points
                .iter()
                .zip(&pair.right.image_points)
            {
                let p = set.right.project(&set.rig.compose(pose), x).unwrap();
                assert!((p - m.coords).norm() < 1e-9);
            }
        }
        assert_eq!(
            generate_stereo(&config).unwrap().observations,
            set.observations
        );
    }
}
