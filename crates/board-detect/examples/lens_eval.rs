//! Development harness: rendered chessboard photographs through wide-angle and fisheye lenses
//! and with small squares, detected, compared with the exact corners. Not a test.
//!
//! `cargo run --release -p board-detect --example lens_eval -- POPULATION COUNT OUTDIR [--seed S] [--save]`
//!
//! Populations (boards alternate 9x6 and 8x6; poses random, tilts up to 60 degrees from facing
//! the camera, blur 0.5-1.2 px, noise 1-3 grey levels, lighting gradients and vignetting):
//! * `kb`: 1280x960 Kannala-Brandt fisheye, fx 200-400, image circle of 120-190 degrees
//!   (black outside), boards anywhere inside the circle;
//! * `kb-border`: the same with the board's centre in the outer 35 % of the field's angle;
//! * `barrel`: 1280x960 pinhole, strong brown-conrady5 barrel, 90-120 degrees horizontally;
//! * `rational`: the same with a rational8-type radial model;
//! * `small-large`: 2592x1944 pinhole, squares of 3-8 px (board far away);
//! * `small-small`: 320x240 pinhole, squares of 3-8 px;
//! * `small-kb`: 1280x960 fisheye, squares of 3-8 px.
//!
//! Writes `OUTDIR/results.jsonl` (one line per image: lens, truth, our corners, outcome, time)
//! and, with `--save`, the images as `OUTDIR/<population>-<i>.png` (for the OpenCV
//! comparison, `benches/detect/opencv_lens_eval.py OUTDIR`). Prints a summary per population.
mod support;

use board_detect::synth::{Lens, Scene};
use board_detect::{Board, DetectOptions, GrayView, detect};
use nalgebra::{Rotation3, Unit, Vector3};
use std::io::Write;
use support::{Rng, kb_radius};

/// Largest angle imaged (radians) for the fisheye image circle, or `None`.
struct Setup {
    scene: Scene,
    circle: Option<f64>,
    label: String,
}

fn lens_setup(pop: &str, rng: &mut Rng) -> Setup {
    let mut scene = Scene {
        blur: rng.range(0.5, 1.2),
        noise: rng.range(1.0, 3.0),
        gain_left: rng.range(0.6, 1.0),
        gain_right: rng.range(0.8, 1.2),
        gain_vertical: rng.range(-0.2, 0.2),
        vignetting: rng.range(0.0, 0.5),
        background: rng.range(60.0, 160.0),
        dark: rng.range(20.0, 50.0),
        light: rng.range(190.0, 235.0),
        ..Scene::default()
    };
    let (w, h) = match pop {
        "small-large" => (2592, 1944),
        "small-small" => (320, 240),
        _ => (1280, 960),
    };
    scene.width = w;
    scene.height = h;
    scene.cx = (w as f64 - 1.0) / 2.0 + rng.range(-10.0, 10.0) * w as f64 / 1280.0;
    scene.cy = (h as f64 - 1.0) / 2.0 + rng.range(-10.0, 10.0) * w as f64 / 1280.0;
    let mut circle = None;
    let label;
    match pop {
        "kb" | "kb-border" | "small-kb" => {
            let k = [rng.range(-0.05, 0.05), rng.range(-0.01, 0.01), 0.0, 0.0];
            let f = rng.range(200.0, 400.0);
            let fov = rng.range(120.0, 190.0).to_radians();
            scene.lens = Lens::KannalaBrandt(k);
            scene.fx = f;
            scene.fy = f * rng.range(0.99, 1.01);
            circle = Some(fov / 2.0);
            label = format!("kb f={f:.0} fov={:.0} k={k:.3?}", fov.to_degrees());
        }
        "barrel" | "rational" => loop {
            let hfov = rng.range(90.0, 120.0).to_radians();
            let k = if pop == "barrel" {
                [
                    rng.range(-0.45, -0.2),
                    rng.range(0.05, 0.2),
                    rng.range(-0.04, 0.0),
                    0.0,
                    0.0,
                    0.0,
                ]
            } else {
                let k1 = rng.range(0.0, 1.5);
                [
                    k1,
                    rng.range(0.0, 0.3),
                    0.0,
                    k1 + rng.range(0.3, 0.8),
                    rng.range(0.0, 0.5),
                    0.0,
                ]
            };
            let t = Scene {
                lens: Lens::Rational(k),
                fx: 1.0,
                fy: 1.0,
                cx: 0.0,
                cy: 0.0,
                rotation: [0.0; 3],
                translation: [0.0, 0.0, 0.0],
                ..scene.clone()
            };
            // Normalized radius of the image's half width, and of its corner.
            let u = (hfov / 2.0).tan();
            let Some(rd) = project_ray(&t, u, 0.0) else {
                continue;
            };
            let f = (w as f64 / 2.0) / rd[0];
            let corner = (w as f64).hypot(h as f64) / 2.0 / f;
            // The radial map must not fold inside the image (else no real lens).
            let mut ok = false;
            let mut r = 0.0;
            let mut last = 0.0;
            while r < 20.0 {
                r += 0.01;
                let Some(p) = project_ray(&t, r, 0.0) else {
                    break;
                };
                if p[0] <= last {
                    break;
                }
                last = p[0];
                if last > corner * 1.05 {
                    ok = true;
                    break;
                }
            }
            if !ok || rd[0] / u > 0.9 {
                continue;
            }
            scene.lens = Lens::Rational(k);
            scene.fx = f;
            scene.fy = f;
            label = format!(
                "{pop} hfov={:.0} f={f:.0} barrel={:.2} k={k:.3?}",
                hfov.to_degrees(),
                rd[0] / u
            );
            break;
        },
        _ => {
            // Pinhole, mild distortion, horizontal field 50-70 degrees.
            let hfov = rng.range(50.0, 70.0).to_radians();
            scene.lens = Lens::Rational([rng.range(-0.2, 0.05), 0.0, 0.0, 0.0, 0.0, 0.0]);
            scene.fx = (w as f64 / 2.0) / (hfov / 2.0).tan();
            scene.fy = scene.fx;
            label = format!("pinhole hfov={:.0}", hfov.to_degrees());
        }
    }
    Setup {
        scene,
        circle,
        label,
    }
}

/// Projection of the camera-frame point `(x, y, 1)` with the scene's lens, normalized units.
fn project_ray(scene: &Scene, x: f64, y: f64) -> Option<[f64; 2]> {
    let s = Scene {
        rotation: [0.0; 3],
        translation: [x, y, 1.0],
        fx: 1.0,
        fy: 1.0,
        cx: 0.0,
        cy: 0.0,
        ..scene.clone()
    };
    s.project(0.0, 0.0)
}

/// Random pose: the board's centre in a random direction (angle from the axis below
/// `max_angle`, above `min_angle`), facing the camera then tilted by up to 60 degrees and
/// rolled. Returns whether every corner and the outer squares are inside the image (and the
/// image circle) and the smallest corner spacing is within `spacing`.
fn place(
    scene: &mut Scene,
    rng: &mut Rng,
    angle: (f64, f64),
    size_deg: (f64, f64),
    roll: f64,
    circle: Option<f64>,
    spacing: (f64, f64),
) -> Option<f64> {
    let (cols, rows) = (scene.cols as f64, scene.rows as f64);
    let theta = rng.range(angle.0, angle.1);
    let phi = rng.range(0.0, std::f64::consts::TAU);
    let dir = Vector3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    );
    let diag = (cols + 1.0).hypot(rows + 1.0);
    let ang = rng.range(size_deg.0, size_deg.1).to_radians();
    let dist = diag / 2.0 / (ang / 2.0).tan();
    // Board frame facing the camera: z axis along the ray (board normal points away), x
    // roughly along the image's x.
    let z = dir;
    let x0 = Vector3::new(1.0, 0.0, 0.0);
    let x = (x0 - z * z.dot(&x0)).normalize();
    let y = z.cross(&x);
    let facing = Rotation3::from_basis_unchecked(&[x, y, z]);
    let roll = Rotation3::from_axis_angle(&Unit::new_normalize(z), rng.range(-roll, roll));
    let tilt_axis_angle = rng.range(0.0, std::f64::consts::TAU);
    let axis = x * tilt_axis_angle.cos() + y * tilt_axis_angle.sin();
    let tilt = Rotation3::from_axis_angle(
        &Unit::new_normalize(axis),
        rng.range(0.0, 60f64.to_radians()),
    );
    let r = tilt * roll * facing;
    let centre = Vector3::new((cols - 1.0) / 2.0, (rows - 1.0) / 2.0, 0.0);
    let t = dir * dist - r * centre;
    scene.rotation = r.scaled_axis().into();
    scene.translation = t.into();
    // Visibility of the outer squares and the corners; spacing.
    let (w, h) = (scene.width as f64, scene.height as f64);
    let inside = |p: [f64; 2]| {
        p[0] > 2.0 && p[1] > 2.0 && p[0] < w - 3.0 && p[1] < h - 3.0 && {
            circle.is_none_or(|c| {
                let (a, b) = ((p[0] - scene.cx) / scene.fx, (p[1] - scene.cy) / scene.fy);
                a.hypot(b) < kb_radius(scene, c) * 0.98
            })
        }
    };
    let mut steps = 40;
    for i in 0..=steps {
        let s = i as f64 / steps as f64;
        for (bx, by) in [
            (-1.0 + s * (cols + 1.0), -1.0),
            (-1.0 + s * (cols + 1.0), rows),
            (-1.0, -1.0 + s * (rows + 1.0)),
            (cols, -1.0 + s * (rows + 1.0)),
        ] {
            if !scene.project(bx, by).is_some_and(inside) {
                return None;
            }
        }
    }
    steps = 0;
    let _ = steps;
    let mut min_sp = f64::MAX;
    for rr in 0..scene.rows {
        for c in 0..scene.cols {
            let p = scene.project(c as f64, rr as f64)?;
            for (dc, dr) in [(1.0, 0.0), (0.0, 1.0)] {
                let q = scene.project(c as f64 + dc, rr as f64 + dr)?;
                if (c + 1 < scene.cols || dc == 0.0) && (rr + 1 < scene.rows || dr == 0.0) {
                    min_sp = min_sp.min((p[0] - q[0]).hypot(p[1] - q[1]));
                }
            }
        }
    }
    (min_sp >= spacing.0 && min_sp <= spacing.1).then_some(min_sp)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        eprintln!("usage: lens_eval POPULATION COUNT OUTDIR [--seed S] [--save]");
        std::process::exit(2);
    }
    let pop = args[0].as_str();
    let count: usize = args[1].parse().unwrap();
    let outdir = std::path::PathBuf::from(&args[2]);
    let mut seed = 1u64;
    let mut save = false;
    let mut i = 3;
    while i < args.len() {
        match args[i].as_str() {
            "--seed" => {
                seed = args[i + 1].parse().unwrap();
                i += 1;
            }
            "--save" => save = true,
            a => panic!("unknown argument {a}"),
        }
        i += 1;
    }
    std::fs::create_dir_all(&outdir).unwrap();
    let mut out = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(outdir.join("results.jsonl"))
        .unwrap();
    let mut rng = Rng(seed.wrapping_mul(0x1234_5678_9ABC_DEF1) ^ pop.len() as u64);
    let small = pop.starts_with("small");
    let (mut found, mut wrong, mut errs) = (0, 0, Vec::new());
    let mut reasons: std::collections::BTreeMap<String, usize> = Default::default();
    let mut times = Vec::new();
    for n in 0..count {
        let (cols, rows) = if n % 2 == 0 { (9, 6) } else { (8, 6) };
        let mut setup;
        let mut min_sp;
        let mut tries = 0;
        loop {
            tries += 1;
            assert!(tries < 100_000, "no pose found");
            setup = lens_setup(pop, &mut rng);
            setup.scene.cols = cols;
            setup.scene.rows = rows;
            setup.scene.seed = seed * 1000 + n as u64;
            let (max_angle, angle_lo) = match setup.circle {
                Some(c) => (c * 0.98, if pop == "kb-border" { 0.65 * c } else { 0.0 }),
                None => {
                    let s = &setup.scene;
                    let corner = (s.width as f64).hypot(s.height as f64) / 2.0 / s.fx;
                    (corner.atan().min(1.5), 0.0)
                }
            };
            let roll = if (cols + rows) % 2 == 1 { 180f64 } else { 35.0 }.to_radians();
            let (size, spacing) = if small {
                // Board angular size from the wanted square size.
                let sq = rng.range(3.0, 8.0);
                let deg = (sq * ((cols + 1) as f64).hypot((rows + 1) as f64) / setup.scene.fx)
                    .to_degrees();
                ((deg * 0.9, deg * 1.1), (2.8, 8.5))
            } else {
                let deg = if setup.circle.is_some() {
                    (25.0, 120.0)
                } else {
                    (20.0, 80.0)
                };
                (deg, (8.0, f64::MAX))
            };
            let sc = &mut setup.scene;
            min_sp = place(
                sc,
                &mut rng,
                (angle_lo, max_angle),
                size,
                roll,
                setup.circle,
                spacing,
            );
            if min_sp.is_some() {
                break;
            }
        }
        let min_sp = min_sp.unwrap();
        let scene = &setup.scene;
        let mut r = scene.render();
        if let Some(c) = setup.circle {
            // Black outside the image circle (angle c).
            let rc = kb_radius(scene, c);
            for y in 0..scene.height {
                for x in 0..scene.width {
                    let (a, b) = (
                        (x as f64 - scene.cx) / scene.fx,
                        (y as f64 - scene.cy) / scene.fy,
                    );
                    if a.hypot(b) > rc {
                        r.pixels[y * scene.width + x] = 0;
                    }
                }
            }
        }
        let name = format!("{pop}-{seed}-{n:03}");
        if save {
            image::save_buffer(
                outdir.join(format!("{name}.png")),
                &r.pixels,
                scene.width as u32,
                scene.height as u32,
                image::ExtendedColorType::L8,
            )
            .unwrap();
        }
        let board = Board::new(cols, rows, 1.0).unwrap();
        let view = GrayView::packed(&r.pixels, scene.width, scene.height).unwrap();
        let t0 = std::time::Instant::now();
        let res = detect(&view, &board, &DetectOptions::default());
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        times.push(ms);
        let centre = scene
            .project((cols as f64 - 1.0) / 2.0, (rows as f64 - 1.0) / 2.0)
            .unwrap();
        let centre_r = (centre[0] - scene.cx).hypot(centre[1] - scene.cy);
        let (status, corners, max_err, label_ok) = match &res {
            Ok(d) => {
                // Wrong label: the nearest true corner of some detected corner is another one.
                let mut ok = true;
                let mut max_e: f64 = 0.0;
                for (i, p) in d.corners.iter().enumerate() {
                    let (mut best, mut bd) = (0, f64::MAX);
                    for (j, q) in r.corners.iter().enumerate() {
                        let dd = (p[0] - q[0]).hypot(p[1] - q[1]);
                        if dd < bd {
                            bd = dd;
                            best = j;
                        }
                    }
                    if best != i {
                        ok = false;
                    }
                    let e = (p[0] - r.corners[i][0]).hypot(p[1] - r.corners[i][1]);
                    max_e = max_e.max(e);
                    if ok {
                        errs.push(e);
                    }
                }
                if ok {
                    found += 1;
                } else {
                    wrong += 1;
                }
                ("ok".to_string(), d.corners.clone(), max_e, ok)
            }
            Err(e) => {
                let key = format!("{e:?}");
                let key = key.split(['(', ' ', '{']).next().unwrap_or("").to_string();
                *reasons.entry(key).or_default() += 1;
                (e.to_string(), Vec::new(), f64::NAN, false)
            }
        };
        let line = serde_json::json!({
            "name": name, "population": pop, "lens": setup.label, "cols": cols, "rows": rows,
            "width": scene.width, "height": scene.height, "min_spacing": min_sp,
            "centre_radius": centre_r, "blur": scene.blur, "noise": scene.noise,
            "truth": r.corners, "status": status, "corners": corners, "max_err": max_err,
            "label_ok": label_ok, "ms": ms, "fx": scene.fx, "fy": scene.fy, "cx": scene.cx,
            "cy": scene.cy, "rotation": scene.rotation, "translation": scene.translation,
            "lens_model": format!("{:?}", scene.lens), "vignetting": scene.vignetting,
        });
        writeln!(out, "{line}").unwrap();
    }
    errs.sort_by(f64::total_cmp);
    times.sort_by(f64::total_cmp);
    let q = |v: &[f64], f: f64| {
        if v.is_empty() {
            f64::NAN
        } else {
            v[((v.len() - 1) as f64 * f).round() as usize]
        }
    };
    println!(
        "{pop}: found {found}/{count} wrong {wrong} | err median {:.3} p95 {:.3} max {:.3} px | ms median {:.1} max {:.1} | {reasons:?}",
        q(&errs, 0.5),
        q(&errs, 0.95),
        q(&errs, 1.0),
        q(&times, 0.5),
        q(&times, 1.0)
    );
}
