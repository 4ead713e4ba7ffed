//! Input: a rig of cameras and the frames in which some of them saw the board.
//!
//! ```json
//! { "cameras": [ { "name": "cam0", "image_size": [1280, 960], "model": "brown-conrady4" }, ... ],
//!   "frames": [ { "object_points": [[X, Y, Z], ...],
//!                 "observations": [ { "camera": 0, "image_points": [[x, y], ...] }, ... ] } ] }
//! ```
//!
//! A frame is one moment: the board is still and every listed camera saw it. `image_points`
//! follow the frame's `object_points` in order and count, unless the observation carries its own
//! `object_points` (a partial view). `model` is optional (default `brown-conrady4`). Unknown keys
//! are ignored. The format is documented in `docs/formats.md`.

use calib_core::JsonFile;
use calib_core::data::{ImageSize, View};
use camera_model::CameraModel;
use nalgebra::{Point2, Point3};
use serde::Deserialize;

/// One camera of the rig as described in the input.
#[derive(Debug, Clone, PartialEq)]
pub struct RigCameraInput {
    /// Name for messages and results.
    pub name: String,
    /// Image size.
    pub image_size: ImageSize,
    /// Lens model, if the file sets one (the options decide otherwise).
    pub model: Option<CameraModel>,
}

/// One camera's view of the board in one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct RigObservation {
    /// The camera (index into the cameras).
    pub camera: usize,
    /// The view: board points and pixels.
    pub view: View,
}

/// One frame: the board at rest, seen by some cameras.
#[derive(Debug, Clone, PartialEq)]
pub struct RigFrame {
    /// The observations, at most one per camera.
    pub observations: Vec<RigObservation>,
}

/// All frames of a rig.
#[derive(Debug, Clone, PartialEq)]
pub struct RigObservations {
    /// The cameras.
    pub cameras: Vec<RigCameraInput>,
    /// The frames.
    pub frames: Vec<RigFrame>,
}

#[derive(Deserialize)]
#[doc(hidden)]
pub struct CameraFile {
    #[serde(default)]
    name: Option<String>,
    image_size: [u32; 2],
    #[serde(default)]
    model: Option<CameraModel>,
}

#[derive(Deserialize)]
#[doc(hidden)]
pub struct ObservationFile {
    camera: usize,
    image_points: Vec<[f64; 2]>,
    #[serde(default)]
    object_points: Option<Vec<[f64; 3]>>,
    #[serde(default)]
    image: Option<String>,
}

#[derive(Deserialize)]
#[doc(hidden)]
pub struct FrameFile {
    #[serde(default)]
    object_points: Vec<[f64; 3]>,
    observations: Vec<ObservationFile>,
}

/// The serde form of a rig observation file (see the module documentation).
#[derive(Deserialize)]
pub struct RigFile {
    cameras: Vec<CameraFile>,
    frames: Vec<FrameFile>,
}

fn points3(v: &[[f64; 3]]) -> Vec<Point3<f64>> {
    v.iter().map(|p| Point3::new(p[0], p[1], p[2])).collect()
}

impl JsonFile for RigObservations {
    type File = RigFile;
    const KIND: Option<calib_core::io::JsonKind> = Some(calib_core::io::JsonKind::RigObservations);

    fn from_file(file: RigFile) -> Self {
        let cameras: Vec<RigCameraInput> = file
            .cameras
            .into_iter()
            .enumerate()
            .map(|(i, c)| RigCameraInput {
                name: c.name.unwrap_or_else(|| format!("cam{i}")),
                image_size: ImageSize::new(c.image_size[0], c.image_size[1]),
                model: c.model,
            })
            .collect();
        let frames = file
            .frames
            .into_iter()
            .enumerate()
            .map(|(f, frame)| {
                let shared = points3(&frame.object_points);
                RigFrame {
                    observations: frame
                        .observations
                        .into_iter()
                        .map(|o| RigObservation {
                            camera: o.camera,
                            view: View {
                                name: o
                                    .image
                                    .unwrap_or_else(|| format!("frame {f}, camera {}", o.camera)),
                                object_points: o
                                    .object_points
                                    .as_deref()
                                    .map(points3)
                                    .unwrap_or_else(|| shared.clone()),
                                image_points: o
                                    .image_points
                                    .iter()
                                    .map(|p| Point2::new(p[0], p[1]))
                                    .collect(),
                            },
                        })
                        .collect(),
                }
            })
            .collect();
        Self { cameras, frames }
    }
}

impl RigObservations {
    /// The JSON form (what [`JsonFile::from_json`] reads): per-observation `object_points` only
    /// where they differ from the frame's (the first observation's).
    pub fn to_json_value(&self) -> serde_json::Value {
        use serde_json::json;
        let cameras: Vec<serde_json::Value> = self
            .cameras
            .iter()
            .map(|c| {
                let mut v = json!({"name": c.name, "image_size": [c.image_size.width, c.image_size.height]});
                if let Some(m) = c.model {
                    v["model"] = json!(m.name());
                }
                v
            })
            .collect();
        let p3 = |v: &View| -> Vec<[f64; 3]> {
            v.object_points.iter().map(|p| [p.x, p.y, p.z]).collect()
        };
        let frames: Vec<serde_json::Value> = self
            .frames
            .iter()
            .map(|f| {
                let shared = f.observations.first().map(|o| p3(&o.view)).unwrap_or_default();
                let observations: Vec<serde_json::Value> = f
                    .observations
                    .iter()
                    .map(|o| {
                        let mut v = json!({
                            "camera": o.camera,
                            "image": o.view.name,
                            "image_points": o.view.image_points.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>(),
                        });
                        let own = p3(&o.view);
                        if own != shared {
                            v["object_points"] = json!(own);
                        }
                        v
                    })
                    .collect();
                json!({"object_points": shared, "observations": observations})
            })
            .collect();
        json!({"cameras": cameras, "frames": frames})
    }

    /// Number of observations of camera `c`.
    pub fn views_of(&self, c: usize) -> usize {
        self.frames
            .iter()
            .filter(|f| f.observations.iter().any(|o| o.camera == c))
            .count()
    }
}
