//! Input: pairs of views of the board, one by each camera, taken at the same time.
//!
//! JSON (`docs/formats.md`):
//!
//! ```json
//! { "image_size": [w, h], "right_image_size": [w, h],
//!   "pairs": [ { "left_image": "left1.jpg", "right_image": "right1.jpg",
//!                "object_points": [[X, Y, Z], ...],
//!                "left_points": [[x, y], ...], "right_points": [[x, y], ...] } ] }
//! ```
//!
//! `right_image_size` is optional (default: `image_size`). Instead of `object_points` a pair may
//! give `left_object_points` and `right_object_points`: each camera may then see a different part
//! of the board (a corner hidden in one view, a partial ChArUco board), as long as both lists use
//! the same board coordinates.

use crate::error::{Side, StereoError};
use calib_core::JsonFile;
use calib_single::{ImageSize, Observations, View};
use nalgebra::{Point2, Point3};
use serde::Deserialize;

/// One pair of simultaneous views.
#[derive(Debug, Clone, PartialEq)]
pub struct StereoPair {
    /// The left camera's view.
    pub left: View,
    /// The right camera's view (same board points, in the same order).
    pub right: View,
}

impl StereoPair {
    /// The view of camera `side`.
    pub fn view(&self, side: crate::Side) -> &View {
        match side {
            crate::Side::Left => &self.left,
            crate::Side::Right => &self.right,
        }
    }
}

/// All pairs.
#[derive(Debug, Clone, PartialEq)]
pub struct StereoObservations {
    /// Image size of the left camera (and of the right one unless `right_image_size` is set).
    pub image_size: Option<ImageSize>,
    /// Image size of the right camera, if it differs.
    pub right_image_size: Option<ImageSize>,
    /// The pairs.
    pub pairs: Vec<StereoPair>,
}

/// The serde form of one pair.
#[derive(Deserialize)]
pub struct PairFile {
    #[serde(default)]
    left_image: Option<String>,
    #[serde(default)]
    right_image: Option<String>,
    #[serde(default)]
    object_points: Option<Vec<[f64; 3]>>,
    #[serde(default)]
    left_object_points: Option<Vec<[f64; 3]>>,
    #[serde(default)]
    right_object_points: Option<Vec<[f64; 3]>>,
    left_points: Vec<[f64; 2]>,
    right_points: Vec<[f64; 2]>,
}

/// The serde form of a stereo observation file (see the module documentation).
#[derive(Deserialize)]
pub struct StereoFile {
    #[serde(default)]
    image_size: Option<[u32; 2]>,
    #[serde(default)]
    right_image_size: Option<[u32; 2]>,
    pairs: Vec<PairFile>,
}

fn points3(v: &[[f64; 3]]) -> Vec<Point3<f64>> {
    v.iter().map(|p| Point3::new(p[0], p[1], p[2])).collect()
}

fn points2(v: &[[f64; 2]]) -> Vec<Point2<f64>> {
    v.iter().map(|p| Point2::new(p[0], p[1])).collect()
}

impl JsonFile for StereoObservations {
    type File = StereoFile;
    const KIND: Option<calib_core::io::JsonKind> =
        Some(calib_core::io::JsonKind::StereoObservations);

    fn from_file(file: StereoFile) -> Self {
        let pairs = file
            .pairs
            .into_iter()
            .enumerate()
            .map(|(i, p)| {
                let shared = p.object_points.as_deref().map(points3);
                let left_object = p.left_object_points.as_deref().map(points3);
                let right_object = p.right_object_points.as_deref().map(points3);
                StereoPair {
                    left: View {
                        name: p.left_image.unwrap_or_else(|| format!("pair {i} left")),
                        object_points: left_object.or_else(|| shared.clone()).unwrap_or_default(),
                        image_points: points2(&p.left_points),
                    },
                    right: View {
                        name: p.right_image.unwrap_or_else(|| format!("pair {i} right")),
                        object_points: right_object.or(shared).unwrap_or_default(),
                        image_points: points2(&p.right_points),
                    },
                }
            })
            .collect();
        Self {
            image_size: file.image_size.map(|[w, h]| ImageSize::new(w, h)),
            right_image_size: file.right_image_size.map(|[w, h]| ImageSize::new(w, h)),
            pairs,
        }
    }
}

impl StereoObservations {
    /// `error`'s message with the view it is about named by its image (`pair 3, left view
    /// (left4.jpg): ...`), for printing.
    pub fn describe(&self, error: &crate::StereoError) -> String {
        let message = error.to_string();
        let Some((pair, side)) = error.view() else {
            return message;
        };
        let (Some(p), location) = (self.pairs.get(pair), format!("pair {pair}, {side} view"))
        else {
            return message;
        };
        let name = &p.view(side).name;
        match message.strip_prefix(&location) {
            Some(rest) if *name != format!("pair {pair} {side}") => {
                format!("{location} ({name}){rest}")
            }
            _ => message,
        }
    }

    /// The JSON form (the format [`StereoObservations::from_json`] reads): `object_points` when
    /// both views share their board points, `left_object_points` and `right_object_points`
    /// otherwise.
    pub fn to_json_value(&self) -> serde_json::Value {
        let points3 = |v: &View| {
            v.object_points
                .iter()
                .map(|x| [x.x, x.y, x.z])
                .collect::<Vec<_>>()
        };
        let pairs: Vec<serde_json::Value> = self
            .pairs
            .iter()
            .map(|p| {
                let mut pair = serde_json::json!({
                    "left_image": p.left.name,
                    "right_image": p.right.name,
                    "left_points": p.left.image_points.iter().map(|x| [x.x, x.y]).collect::<Vec<_>>(),
                    "right_points": p.right.image_points.iter().map(|x| [x.x, x.y]).collect::<Vec<_>>(),
                });
                if p.left.object_points == p.right.object_points {
                    pair["object_points"] = serde_json::json!(points3(&p.left));
                } else {
                    pair["left_object_points"] = serde_json::json!(points3(&p.left));
                    pair["right_object_points"] = serde_json::json!(points3(&p.right));
                }
                pair
            })
            .collect();
        let mut out = serde_json::json!({ "pairs": pairs });
        if let Some(s) = self.image_size {
            out["image_size"] = serde_json::json!([s.width, s.height]);
        }
        if let Some(s) = self.right_image_size {
            out["right_image_size"] = serde_json::json!([s.width, s.height]);
        }
        out
    }

    /// The image sizes of the two cameras, checked.
    pub fn sizes(&self) -> Result<(ImageSize, ImageSize), StereoError> {
        let left = self.image_size.ok_or(StereoError::ImageSizeMissing)?;
        let right = self.right_image_size.unwrap_or(left);
        for (camera, s) in [(Side::Left, left), (Side::Right, right)] {
            if s.width == 0 || s.height == 0 {
                return Err(StereoError::InvalidImageSize {
                    camera,
                    width: s.width,
                    height: s.height,
                });
            }
        }
        Ok((left, right))
    }

    /// The views of one camera as single-camera observations (view `i` is pair `i`).
    pub fn camera(&self, side: Side) -> Result<Observations, StereoError> {
        let (left, right) = self.sizes()?;
        Ok(Observations {
            image_size: Some(match side {
                Side::Left => left,
                Side::Right => right,
            }),
            views: self
                .pairs
                .iter()
                .map(|p| match side {
                    Side::Left => p.left.clone(),
                    Side::Right => p.right.clone(),
                })
                .collect(),
        })
    }
}

/// Checks one pair: each view passes the single-camera checks (counts, finiteness, planarity).
/// The two views may show different parts of the board.
pub fn check_pair(index: usize, pair: &StereoPair) -> Result<(), StereoError> {
    for (camera, view) in [(Side::Left, &pair.left), (Side::Right, &pair.right)] {
        calib_single::observations::check_view(index, view).map_err(|source| {
            StereoError::View {
                pair: index,
                camera,
                source,
            }
        })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const PAIR: &str = r#"{ "image_size": [640, 480], "right_image_size": [320, 240],
        "pairs": [ { "left_image": "l.png", "right_image": "r.png",
                     "object_points": [[0,0,0],[1,0,0],[0,1,0],[1,1,0]],
                     "left_points": [[1,2],[3,4],[5,6],[7,9]],
                     "right_points": [[2,2],[4,4],[6,6],[8,9]] } ] }"#;

    #[test]
    fn reads_pairs_and_sizes() {
        let obs = StereoObservations::from_json(PAIR).unwrap();
        assert_eq!(obs.pairs.len(), 1);
        assert_eq!(obs.pairs[0].right.name, "r.png");
        assert_eq!(
            obs.pairs[0].left.object_points,
            obs.pairs[0].right.object_points
        );
        assert_eq!(obs.sizes().unwrap().1, ImageSize::new(320, 240));
        assert!(check_pair(0, &obs.pairs[0]).is_ok());
        let again = StereoObservations::from_json(&obs.to_json_value().to_string()).unwrap();
        assert_eq!(again, obs);
    }

    #[test]
    fn pair_checks_name_the_pair() {
        let mut obs = StereoObservations::from_json(PAIR).unwrap();
        obs.pairs[0].left.image_points.pop();
        assert!(matches!(
            check_pair(2, &obs.pairs[0]),
            Err(StereoError::View {
                pair: 2,
                camera: Side::Left,
                ..
            })
        ));
        let mut obs = StereoObservations::from_json(PAIR).unwrap();
        obs.image_size = None;
        assert_eq!(obs.sizes(), Err(StereoError::ImageSizeMissing));
    }

    #[test]
    fn partial_views_are_accepted_and_written_back() {
        let text = PAIR.replace(
            r#""object_points": [[0,0,0],[1,0,0],[0,1,0],[1,1,0]],"#,
            r#""left_object_points": [[0,0,0],[1,0,0],[0,1,0],[1,1,0]], "right_object_points": [[0,0,0],[1,0,0],[0,1,0],[1,1,0],[2,0,0]],"#,
        )
        .replace(r#""right_points": [[2,2],[4,4],[6,6],[8,9]]"#, r#""right_points": [[2,2],[4,4],[6,6],[8,9],[9,9]]"#);
        let obs = StereoObservations::from_json(&text).unwrap();
        assert!(check_pair(0, &obs.pairs[0]).is_ok());
        assert_eq!(obs.pairs[0].right.object_points.len(), 5);
        let again = StereoObservations::from_json(&obs.to_json_value().to_string()).unwrap();
        assert_eq!(again, obs);
    }
}
