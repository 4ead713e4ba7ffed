//! Synthetic single-camera data with known truth (the generator of
//! [`calib_core::synthetic`], as [`Observations`]).

use crate::observations::Observations;
pub use calib_core::synthetic::{
    MIN_DISTORTION_JACOBIAN, SyntheticConfig, SyntheticError, add_noise, board_geometry,
    board_points, check_config, inside_lens_field, project_inside, random_pose, true_camera,
};
use camera_model::{AnyCamera, Pose};

/// A generated data set and the truth behind it.
#[derive(Debug, Clone)]
pub struct SyntheticSet {
    /// The noisy observations.
    pub observations: Observations,
    /// The true camera.
    pub camera: AnyCamera,
    /// The true board-to-camera pose of each view.
    pub poses: Vec<Pose>,
}

/// Generates a single-camera data set (see [`calib_core::synthetic::generate`]).
pub fn generate(config: &SyntheticConfig) -> Result<SyntheticSet, SyntheticError> {
    let set = calib_core::synthetic::generate(config)?;
    Ok(SyntheticSet {
        observations: Observations {
            image_size: Some(set.image_size),
            views: set.views,
        },
        camera: set.camera,
        poses: set.poses,
    })
}
