//! Input: views of a planar board, each a list of board points matched to measured pixels.
//!
//! The JSON format (`docs/formats.md`) is the one of `data/README.md`:
//!
//! ```json
//! { "image_size": [width, height],
//!   "views": [ { "image": "left1.jpg",
//!                "object_points": [[X, Y, Z], ...],
//!                "image_points":  [[x, y], ...] } ] }
//! ```
//!
//! Unknown keys are ignored.

use calib_core::JsonFile;
pub use calib_core::data::{ImageSize, View};
pub use calib_core::single::{PLANARITY_TOLERANCE, check_view};
use nalgebra::{Point2, Point3};
use serde::Deserialize;

/// All views of one camera.
#[derive(Debug, Clone, PartialEq)]
pub struct Observations {
    /// Image size; required by the calibration (the principal point starts at the centre).
    pub image_size: Option<ImageSize>,
    /// The views.
    pub views: Vec<View>,
}

pub use calib_core::io::ReadError;

/// The serde form of one view.
#[derive(Deserialize)]
pub struct ViewFile {
    #[serde(default)]
    image: Option<String>,
    object_points: Vec<[f64; 3]>,
    image_points: Vec<[f64; 2]>,
}

/// The serde form of a single-camera observation file (see the module documentation).
#[derive(Deserialize)]
pub struct ObservationFile {
    #[serde(default)]
    image_size: Option<[u32; 2]>,
    views: Vec<ViewFile>,
}

impl JsonFile for Observations {
    type File = ObservationFile;
    const KIND: Option<calib_core::io::JsonKind> =
        Some(calib_core::io::JsonKind::SingleObservations);

    fn from_file(file: ObservationFile) -> Self {
        Self {
            image_size: file.image_size.map(|[w, h]| ImageSize::new(w, h)),
            views: file
                .views
                .into_iter()
                .enumerate()
                .map(|(i, v)| View {
                    name: v.image.unwrap_or_else(|| format!("view {i}")),
                    object_points: v
                        .object_points
                        .iter()
                        .map(|p| Point3::new(p[0], p[1], p[2]))
                        .collect(),
                    image_points: v
                        .image_points
                        .iter()
                        .map(|p| Point2::new(p[0], p[1]))
                        .collect(),
                })
                .collect(),
        }
    }
}

impl Observations {
    /// `error`'s message with the view it is about named by its image (`view 3 (left4.jpg): ...`
    /// instead of `view 3: ...`), for printing: the view numbers count the views given, which
    /// differ from the images given once detection drops some.
    pub fn describe(&self, error: &calib_core::CalibrationError) -> String {
        match error
            .view()
            .and_then(|v| self.views.get(v).map(|view| (v, view)))
        {
            Some((v, view)) => error.message_at(&calib_core::view_location(v, &view.name)),
            None => error.to_string(),
        }
    }

    /// Total number of points over all views.
    pub fn num_points(&self) -> usize {
        self.views.iter().map(|v| v.object_points.len()).sum()
    }

    /// The JSON text of these observations (the format [`Observations::from_json`] reads).
    pub fn to_json_value(&self) -> serde_json::Value {
        let views: Vec<serde_json::Value> = self
            .views
            .iter()
            .map(|v| {
                serde_json::json!({
                    "image": v.name,
                    "object_points": v.object_points.iter().map(|p| [p.x, p.y, p.z]).collect::<Vec<_>>(),
                    "image_points": v.image_points.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>(),
                })
            })
            .collect();
        let mut out = serde_json::json!({ "views": views });
        if let Some(size) = self.image_size {
            out["image_size"] = serde_json::json!([size.width, size.height]);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use calib_core::{CalibrationError, PointKind};

    #[test]
    fn reads_the_documented_format_and_ignores_unknown_keys() {
        let text = r#"{ "name": "x", "image_size": [640, 480],
            "views": [ { "image": "a.png", "extra": 1,
                         "object_points": [[0,0,0],[1,0,0],[0,1,0],[1,1,0]],
                         "image_points": [[1,2],[3,4],[5,6],[7,8]] },
                       { "object_points": [], "image_points": [] } ] }"#;
        let obs = Observations::from_json(text).unwrap();
        assert_eq!(obs.image_size, Some(ImageSize::new(640, 480)));
        assert_eq!(obs.views[0].name, "a.png");
        assert_eq!(obs.views[1].name, "view 1");
        assert_eq!(obs.views[0].image_points[3], Point2::new(7.0, 8.0));
        let again = Observations::from_json(&obs.to_json_value().to_string()).unwrap();
        assert_eq!(again, obs);
    }

    #[test]
    fn malformed_files_are_errors_with_positions() {
        let err = Observations::from_json(r#"{ "views": [ { "object_points": [[0, 0]] } ] }"#)
            .unwrap_err();
        assert!(err.to_string().contains("line"), "{err}");
        assert!(Observations::read("/nonexistent/file.json").is_err());
    }

    #[test]
    fn view_checks_name_the_fault() {
        let square = |z: f64| View {
            name: "v".into(),
            object_points: vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, z),
                Point3::new(1.0, 1.0, 0.0),
            ],
            image_points: vec![Point2::new(0.0, 0.0); 4],
        };
        assert!(check_view(0, &square(0.0)).is_ok());
        assert_eq!(
            check_view(3, &square(0.5)),
            Err(CalibrationError::NotPlanar {
                view: 3,
                point: 2,
                z: 0.5
            })
        );
        let mut v = square(0.0);
        v.image_points.pop();
        assert!(matches!(
            check_view(1, &v),
            Err(CalibrationError::PointCountMismatch {
                view: 1,
                object: 4,
                image: 3
            })
        ));
        v.object_points.pop();
        assert!(matches!(
            check_view(1, &v),
            Err(CalibrationError::TooFewPoints { view: 1, found: 3 })
        ));
        let mut v = square(0.0);
        v.image_points[1].y = f64::NAN;
        assert!(matches!(
            check_view(2, &v),
            Err(CalibrationError::NonFinite {
                view: 2,
                point: 1,
                kind: PointKind::Image
            })
        ));
        let mut v = square(0.0);
        v.object_points[0].x = f64::INFINITY;
        assert!(matches!(
            check_view(2, &v),
            Err(CalibrationError::NonFinite {
                view: 2,
                point: 0,
                kind: PointKind::Object
            })
        ));
    }
}
