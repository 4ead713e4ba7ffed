//! Renders a calibration set: about 20 photographs of one 9x6 chessboard through ONE fixed
//! lens, with the truth, so that `calib single --board` (or `calib stereo --board`) can be
//! checked end to end, from photographs to a calibrated camera. Not a test.
//!
//! `cargo run --release -p board-detect --example render_set -- LENS OUTDIR [--seed S] [--views N] [--stereo]`
//!
//! Lenses (1280x960):
//! * `kb`: Kannala-Brandt fisheye (`kannala-brandt4`), fx 250-350, field of view 150-190
//!   degrees (black outside the image circle), k1 in +-0.05, k2 in +-0.01, k3, k4 in +-0.002;
//! * `barrel`: pinhole with a strong brown-conrady5 barrel (k1 -0.45..-0.2, k2 0.05..0.2,
//!   k3 -0.04..0, no tangential terms), 90-120 degrees horizontally.
//!
//! Poses: the board's centre is placed in a direction stratified over the field (a quarter of
//! the views near the axis, the rest on rings at 35 %, 65 % and 90 % of the image circle's angle,
//! or of the way to the image border for `barrel`, so the border is covered; a ring that no
//! pose reaches moves slowly inwards), tilted up to 50 degrees, rolled up
//! to 30 degrees; blur 0.5-1.0 px, noise 1-2 grey levels, lighting gradients. The square is 1
//! board unit (`--square 1`).
//!
//! Writes `OUTDIR/view-NN.png` and `OUTDIR/truth.json`: `fx, fy, cx, cy`, `dist_coeffs` in
//! OpenCV's order for the model (`k1 k2 k3 k4`, or `k1 k2 p1 p2 k3`), `noise`, and per view
//! the pose (`X_cam = R X_board + t`, rotation vector) and the true corners (row-major, OpenCV
//! pixel convention). With `--stereo`, a second camera with its own lens of the same kind sees
//! the same poses from a known relative pose (`X_right = R X_left + T`, baseline about 8 squares):
//! `OUTDIR/right-NN.png`, and `right` and `R`, `T` in `truth.json`; only poses where the whole
//! board is in both images are kept.
mod support;

use board_detect::synth::{Lens, Scene};
use nalgebra::{Rotation3, Unit, Vector3};
use support::{Rng, kb_radius};

/// A camera: the scene's intrinsics and lens, plus the fisheye image circle (largest angle).
#[derive(Clone)]
struct Camera {
    scene: Scene,
    circle: Option<f64>,
    /// OpenCV-order coefficients for the truth file.
    coeffs: Vec<f64>,
}

fn camera(kind: &str, rng: &mut Rng) -> Camera {
    let mut scene = Scene {
        width: 1280,
        height: 960,
        cols: 9,
        rows: 6,
        square: 1.0,
        ..Scene::default()
    };
    scene.cx = 639.5 + rng.range(-10.0, 10.0);
    scene.cy = 479.5 + rng.range(-10.0, 10.0);
    match kind {
        "kb" => {
            let k = [
                rng.range(-0.05, 0.05),
                rng.range(-0.01, 0.01),
                rng.range(-0.002, 0.002),
                rng.range(-0.002, 0.002),
            ];
            let f = rng.range(250.0, 350.0);
            let fov = rng.range(150.0, 190.0).to_radians();
            scene.lens = Lens::KannalaBrandt(k);
            scene.fx = f;
            scene.fy = f * rng.range(0.995, 1.005);
            Camera {
                scene,
                circle: Some(fov / 2.0),
                coeffs: k.to_vec(),
            }
        }
        "barrel" => loop {
            let hfov = rng.range(90.0, 120.0).to_radians();
            let k = [
                rng.range(-0.45, -0.2),
                rng.range(0.05, 0.2),
                rng.range(-0.04, 0.0),
            ];
            let lens = Lens::Rational([k[0], k[1], k[2], 0.0, 0.0, 0.0]);
            // Normalized pinhole radius u of the half width; distorted radius g(u).
            let g = |u: f64| {
                let t = u * u;
                u * (1.0 + t * (k[0] + t * (k[1] + t * k[2])))
            };
            let u = (hfov / 2.0).tan();
            let f = 640.0 / g(u);
            let corner = 800.0 / f;
            // The radial map must be increasing up to 5 % beyond the image corner.
            let mut ok = false;
            let (mut r, mut last) = (0.0, 0.0);
            while r < 20.0 {
                r += 0.005;
                let d = g(r);
                if d <= last {
                    break;
                }
                last = d;
                if d > corner * 1.05 {
                    ok = true;
                    break;
                }
            }
            if !ok {
                continue;
            }
            scene.lens = lens;
            scene.fx = f;
            scene.fy = f;
            break Camera {
                scene,
                circle: None,
                coeffs: vec![k[0], k[1], 0.0, 0.0, k[2]],
            };
        },
        _ => panic!("unknown lens {kind} (kb or barrel)"),
    }
}

/// Whether the board's outer squares and all corners are inside the image (and its circle).
fn visible(cam: &Camera, rot: &Rotation3<f64>, t: &Vector3<f64>) -> bool {
    let s = Scene {
        rotation: rot.scaled_axis().into(),
        translation: (*t).into(),
        ..cam.scene.clone()
    };
    let (w, h) = (s.width as f64, s.height as f64);
    let (cols, rows) = (s.cols as f64, s.rows as f64);
    let inside = |p: [f64; 2]| {
        p[0] > 3.0
            && p[1] > 3.0
            && p[0] < w - 4.0
            && p[1] < h - 4.0
            && cam.circle.is_none_or(|c| {
                let (a, b) = ((p[0] - s.cx) / s.fx, (p[1] - s.cy) / s.fy);
                a.hypot(b) < kb_radius(&s, c) * 0.98
            })
    };
    let steps = 40;
    (0..=steps).all(|i| {
        let f = i as f64 / steps as f64;
        [
            (-1.0 + f * (cols + 1.0), -1.0),
            (-1.0 + f * (cols + 1.0), rows),
            (-1.0, -1.0 + f * (rows + 1.0)),
            (cols, -1.0 + f * (rows + 1.0)),
        ]
        .iter()
        .all(|&(x, y)| s.project(x, y).is_some_and(inside))
    })
}

/// A pose with the board's centre at angle `theta` from the axis (azimuth `phi`), angular
/// size `size` radians, tilted by up to 50 degrees and rolled.
fn pose(
    rng: &mut Rng,
    theta: f64,
    phi: f64,
    size: f64,
    cols: f64,
    rows: f64,
) -> (Rotation3<f64>, Vector3<f64>) {
    let dir = Vector3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    );
    let diag = (cols + 1.0).hypot(rows + 1.0);
    let dist = diag / 2.0 / (size / 2.0).tan();
    let z = dir;
    let x0 = Vector3::new(1.0, 0.0, 0.0);
    let x = (x0 - z * z.dot(&x0)).normalize();
    let y = z.cross(&x);
    let facing = Rotation3::from_basis_unchecked(&[x, y, z]);
    let roll = Rotation3::from_axis_angle(
        &Unit::new_normalize(z),
        rng.range(-30.0, 30.0f64).to_radians(),
    );
    let a = rng.range(0.0, std::f64::consts::TAU);
    let axis = x * a.cos() + y * a.sin();
    let tilt = Rotation3::from_axis_angle(
        &Unit::new_normalize(axis),
        rng.range(0.0, 50.0f64).to_radians(),
    );
    let r = tilt * roll * facing;
    let centre = Vector3::new((cols - 1.0) / 2.0, (rows - 1.0) / 2.0, 0.0);
    (r, dir * dist - r * centre)
}

/// Renders the view and blacks out what lies outside the fisheye's image circle.
fn render(
    cam: &Camera,
    rot: &Rotation3<f64>,
    t: &Vector3<f64>,
    rng: &mut Rng,
    seed: u64,
) -> (Vec<u8>, Vec<[f64; 2]>, f64) {
    let scene = Scene {
        rotation: rot.scaled_axis().into(),
        translation: (*t).into(),
        blur: rng.range(0.5, 1.0),
        noise: rng.range(1.0, 2.0),
        gain_left: rng.range(0.7, 1.0),
        gain_right: rng.range(0.85, 1.15),
        gain_vertical: rng.range(-0.15, 0.15),
        vignetting: rng.range(0.0, 0.4),
        background: rng.range(70.0, 150.0),
        seed,
        ..cam.scene.clone()
    };
    let mut r = scene.render();
    if let Some(c) = cam.circle {
        let rc = kb_radius(&scene, c);
        for y in 0..scene.height {
            for x in 0..scene.width {
                let a = (x as f64 - scene.cx) / scene.fx;
                let b = (y as f64 - scene.cy) / scene.fy;
                if a.hypot(b) > rc {
                    r.pixels[y * scene.width + x] = 0;
                }
            }
        }
    }
    (r.pixels, r.corners, scene.noise)
}

fn camera_json(cam: &Camera, kind: &str) -> serde_json::Value {
    let s = &cam.scene;
    serde_json::json!({
        "lens": kind, "model": if kind == "kb" { "kannala-brandt4" } else { "brown-conrady5" },
        "width": s.width, "height": s.height, "fx": s.fx, "fy": s.fy, "cx": s.cx, "cy": s.cy,
        "dist_coeffs": cam.coeffs,
        "field_of_view_deg": cam.circle.map(|c| 2.0 * c.to_degrees()),
    })
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        eprintln!("usage: render_set kb|barrel OUTDIR [--seed S] [--views N] [--stereo]");
        std::process::exit(2);
    }
    let kind = args[0].as_str();
    let outdir = std::path::PathBuf::from(&args[1]);
    let save = |name: &str, pix: &[u8]| {
        image::save_buffer(
            outdir.join(name),
            pix,
            1280,
            960,
            image::ExtendedColorType::L8,
        )
        .unwrap();
    };
    let (mut seed, mut views, mut stereo) = (1u64, 20usize, false);
    let mut i = 2;
    while i < args.len() {
        match args[i].as_str() {
            "--seed" => {
                seed = args[i + 1].parse().expect("--seed N");
                i += 1;
            }
            "--views" => {
                views = args[i + 1].parse().expect("--views N");
                i += 1;
            }
            "--stereo" => stereo = true,
            a => panic!("unknown argument {a}"),
        }
        i += 1;
    }
    std::fs::create_dir_all(&outdir).unwrap();
    let mut rng = Rng(seed.wrapping_mul(0x1234_5678_9ABC_DEF1) ^ kind.len() as u64);
    let left = camera(kind, &mut rng);
    let right = stereo.then(|| camera(kind, &mut rng));
    // Right camera: about 8 squares to the right, turned by a few degrees.
    let rel_r = Rotation3::from_scaled_axis(Vector3::new(
        rng.range(-0.05, 0.05),
        rng.range(-0.15, 0.15),
        rng.range(-0.05, 0.05),
    ));
    let rel_t = Vector3::new(-8.0, rng.range(-0.5, 0.5), rng.range(-0.5, 0.5));
    let (cols, rows) = (9.0, 6.0);
    // Largest angle of the board's centre for the fisheye: the image circle.
    let max_angle = left.circle.unwrap_or(0.0);
    let rings = [0.0, 0.35, 0.65, 0.9];
    let mut out_views = Vec::new();
    let mut n = 0;
    let (mut tries, mut view_tries) = (0, 0);
    while n < views {
        tries += 1;
        view_tries += 1;
        assert!(view_tries < 200_000, "no pose found for view {n}");
        // When a ring is hard to reach (a stereo pair's outer rings), move inwards slowly.
        let ring = rings[(n * 4 / views).min(3)] * (1.0 - (view_tries as f64 / 40_000.0).min(0.5));
        let frac = (ring + rng.range(-0.1, 0.1)).clamp(0.0, 0.97);
        let phi = n as f64 * 2.4 + rng.range(-0.3, 0.3);
        let theta = match left.circle {
            Some(_) => frac * max_angle,
            None => {
                // Pinhole: the fraction of the way to the image border along `phi`, in pixels,
                // undistorted (bisection on the increasing radial map) to an angle.
                let edge = (640.0 / phi.cos().abs()).min(480.0 / phi.sin().abs());
                let rd = frac * edge / left.scene.fx;
                let k = &left.coeffs;
                let g = |u: f64| u * (1.0 + u * u * (k[0] + u * u * (k[1] + u * u * k[4])));
                let (mut lo, mut hi) = (0.0, 10.0 * rd + 1e-9);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if g(mid) < rd { lo = mid } else { hi = mid }
                }
                lo.atan()
            }
        };
        let size = rng
            .range(30.0, if left.circle.is_some() { 90.0 } else { 60.0 })
            .to_radians();
        let (rot, t) = pose(&mut rng, theta, phi, size, cols, rows);
        if !visible(&left, &rot, &t) {
            continue;
        }
        let right_pose = right.as_ref().map(|_| (rel_r * rot, rel_r * t + rel_t));
        if let (Some(rc), Some((rr, rt))) = (&right, &right_pose)
            && !visible(rc, rr, rt)
        {
            continue;
        }
        let (pix, corners, noise) = render(&left, &rot, &t, &mut rng, seed * 1000 + n as u64);
        let name = format!("view-{n:02}.png");
        save(&name, &pix);
        let mut v = serde_json::json!({
            "image": name, "rotation_vector": Vector3::from(rot.scaled_axis()).as_slice(),
            "translation": t.as_slice(), "corners": corners, "noise": noise,
            "centre_angle_deg": theta.to_degrees(),
        });
        if let (Some(rc), Some((rr, rt))) = (&right, &right_pose) {
            let (pix, corners, noise) = render(rc, rr, rt, &mut rng, seed * 1000 + 500 + n as u64);
            let name = format!("right-{n:02}.png");
            save(&name, &pix);
            v["right"] = serde_json::json!({ "image": name, "corners": corners, "noise": noise });
        }
        out_views.push(v);
        n += 1;
        view_tries = 0;
    }
    let mut truth = serde_json::json!({
        "seed": seed, "board": "9x6", "square": 1.0, "camera": camera_json(&left, kind),
        "views": out_views,
    });
    if let Some(rc) = &right {
        truth["right"] = camera_json(rc, kind);
        let m = rel_r.matrix();
        truth["R"] = serde_json::json!([
            [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
            [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
            [m[(2, 0)], m[(2, 1)], m[(2, 2)]]
        ]);
        truth["T"] = serde_json::json!(rel_t.as_slice());
    }
    std::fs::write(
        outdir.join("truth.json"),
        serde_json::to_string_pretty(&truth).unwrap(),
    )
    .unwrap();
    println!(
        "{}: {} views ({} pose tries), {}",
        outdir.display(),
        views,
        tries,
        camera_json(&left, kind)
    );
}
