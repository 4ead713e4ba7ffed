//! Helpers shared by the integration tests: the workspace's deterministic PRNG, synthetic
//! camera views of a planar board, and a minimal reader for the real data file.
#![allow(dead_code)] // each test binary uses a different subset

use nalgebra::{Matrix3, Point2, Rotation3, Unit, Vector3};

pub use lm_solver::Rng;

/// Intrinsic matrix with zero skew.
pub fn intrinsics(fx: f64, fy: f64, cx: f64, cy: f64) -> Matrix3<f64> {
    Matrix3::new(fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0)
}

/// Rotation that spins the board about its normal by `spin`, then tilts it by `tilt`
/// about an in-plane axis at angle `axis_angle`.
pub fn board_rotation(spin: f64, tilt: f64, axis_angle: f64) -> Rotation3<f64> {
    let axis = Unit::new_normalize(Vector3::new(axis_angle.cos(), axis_angle.sin(), 0.0));
    Rotation3::from_axis_angle(&axis, tilt) * Rotation3::from_axis_angle(&Vector3::z_axis(), spin)
}

/// `H = K [r1 r2 t]` for a board rotated by `r` whose point `centre` (plane coordinates)
/// is placed at `centre_cam` in the camera frame.
pub fn homography_from_pose(
    k: &Matrix3<f64>,
    r: &Rotation3<f64>,
    centre: Point2<f64>,
    centre_cam: Vector3<f64>,
) -> Matrix3<f64> {
    let rm = r.matrix();
    let t = centre_cam - rm * Vector3::new(centre.x, centre.y, 0.0);
    let mut rt = Matrix3::zeros();
    rt.set_column(0, &rm.column(0));
    rt.set_column(1, &rm.column(1));
    rt.set_column(2, &t);
    k * rt
}

/// Inner corners of a `cols x rows` chessboard, row-major, `(col * square, row * square)`.
pub fn board_points(cols: usize, rows: usize, square: f64) -> Vec<Point2<f64>> {
    (0..rows)
        .flat_map(|r| (0..cols).map(move |c| Point2::new(c as f64 * square, r as f64 * square)))
        .collect()
}

pub fn map_points(h: &Matrix3<f64>, pts: &[Point2<f64>]) -> Vec<Point2<f64>> {
    pts.iter().map(|p| h.transform_point(p)).collect()
}

/// `|A/A33 - B/B33|_F / |B/B33|_F`.
pub fn relative_difference(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let a = a / a[(2, 2)];
    let b = b / b[(2, 2)];
    (a - b).norm() / b.norm()
}

/// A random view of the 9 x 6 board (square 0.03) by the camera fx = fy = 800, cx = 320,
/// cy = 240: tilt up to 45 degrees, board centre 0.3 .. 0.6 in front, shifted so that all
/// corners stay inside a 640 x 480 image. Returns `(H, object, image)`.
pub fn random_view(rng: &mut Rng) -> (Matrix3<f64>, Vec<Point2<f64>>, Vec<Point2<f64>>) {
    let k = intrinsics(800.0, 800.0, 320.0, 240.0);
    let object = board_points(9, 6, 0.03);
    let centre = Point2::new(4.0 * 0.03, 2.5 * 0.03);
    loop {
        let r = board_rotation(
            rng.range(-0.3, 0.3),
            rng.range(0.0, 45f64.to_radians()),
            rng.range(0.0, std::f64::consts::TAU),
        );
        let z = rng.range(0.3, 0.6);
        let c = Vector3::new(rng.range(-0.1, 0.1) * z, rng.range(-0.08, 0.08) * z, z);
        let h = homography_from_pose(&k, &r, centre, c);
        let image = map_points(&h, &object);
        if image
            .iter()
            .all(|p| (0.0..640.0).contains(&p.x) && (0.0..480.0).contains(&p.y))
        {
            return (h, object, image);
        }
    }
}

/// One view of the real data set.
pub struct View {
    pub object: Vec<Point2<f64>>,
    pub image: Vec<Point2<f64>>,
}

/// Reads the `views` of a calibration data file without a JSON library: every
/// `"object_points"` array (triples `X, Y, Z`) is paired with the next `"image_points"`
/// array (pairs `x, y`).
pub fn read_views(path: &str) -> Vec<View> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {path}: {e}"));
    let objects = arrays_after_key(&text, "\"object_points\":");
    let images = arrays_after_key(&text, "\"image_points\":");
    assert_eq!(
        objects.len(),
        images.len(),
        "unpaired point arrays in {path}"
    );
    objects
        .into_iter()
        .zip(images)
        .map(|(o, i)| {
            assert_eq!(o.len() % 3, 0);
            assert_eq!(i.len() % 2, 0);
            let object: Vec<_> = o
                .chunks(3)
                .map(|c| {
                    assert_eq!(c[2], 0.0, "board points must have Z = 0");
                    Point2::new(c[0], c[1])
                })
                .collect();
            let image: Vec<_> = i.chunks(2).map(|c| Point2::new(c[0], c[1])).collect();
            assert_eq!(object.len(), image.len());
            View { object, image }
        })
        .collect()
}

/// For every occurrence of `key`, all numbers of the (possibly nested) array that follows.
fn arrays_after_key(text: &str, key: &str) -> Vec<Vec<f64>> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(pos) = rest.find(key) {
        rest = &rest[pos + key.len()..];
        let start = rest.find('[').expect("array after key");
        let mut depth = 0usize;
        let mut numbers = Vec::new();
        let mut token = String::new();
        let mut end = rest.len();
        for (i, ch) in rest[start..].char_indices() {
            match ch {
                '0'..='9' | '-' | '+' | '.' | 'e' | 'E' => {
                    token.push(ch);
                    continue;
                }
                _ => {}
            }
            if !token.is_empty() {
                numbers.push(token.parse::<f64>().expect("number"));
                token.clear();
            }
            match ch {
                '[' => depth += 1,
                ']' => {
                    depth -= 1;
                    if depth == 0 {
                        end = start + i + 1;
                        break;
                    }
                }
                _ => {}
            }
        }
        out.push(numbers);
        rest = &rest[end..];
    }
    out
}
