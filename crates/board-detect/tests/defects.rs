//! Photographic defects on rendered boards (docs/board-detect.md, "Photographic defects"):
//! a shadow edge through a corner must not give a silently displaced corner.

use board_detect::synth::Scene;
use board_detect::{Board, DetectError, DetectOptions, GrayView, detect};

/// Multiplies the image by a shadow: the side of the line through `p` with direction angle
/// `angle` (radians) where the normal `(-sin, cos)` points is darkened by the fraction
/// `dark`, with a 0.6 px (logistic scale) penumbra. Photometric: the corners do not move.
fn shade(pixels: &mut [u8], width: usize, p: [f64; 2], angle: f64, dark: f64) {
    let (nx, ny) = (-angle.sin(), angle.cos());
    for (i, v) in pixels.iter_mut().enumerate() {
        let (x, y) = ((i % width) as f64, (i / width) as f64);
        let side = (x - p[0]) * nx + (y - p[1]) * ny;
        let s = 1.0 - dark / (1.0 + (-side / 0.6).clamp(-50.0, 50.0).exp());
        *v = (*v as f64 * s).round().clamp(0.0, 255.0) as u8;
    }
}

fn max_error(found: &[[f64; 2]], truth: &[[f64; 2]]) -> f64 {
    found
        .iter()
        .zip(truth)
        .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
        .fold(0.0, f64::max)
}

/// A shadow edge (50 % and 70 % darker) running exactly through one corner, at three angles
/// to the board's edges, for three interior corners of two poses: either the board is
/// refused (the corner is not a clean crossing) or every corner is within 0.5 px of the truth.
/// Before the symmetry check these 18 images gave corners up to 2 px off the truth with no
/// refusal (2.01 px for corner 20 of pose 0 at 0.35 rad: the saddle fit follows the shadow's
/// edge, and the grid's geometry check allows 0.15 of a square); now all are refused, 12 as
/// `DisturbedCorner`, the others as partial boards. 0.5 px: the refined corners of these scenes without a shadow
/// are within 0.15 px (`synthetic.rs`); a corner near, but not on, the shadow edge is pulled
/// by up to a few tenths of a pixel.
#[test]
fn shadow_edge_through_a_corner_is_refused_not_returned_displaced() {
    let poses = [
        ([0.2, -0.3, 0.1], [-3.5, -2.0, 14.0]),
        ([-0.4, 0.5, -0.3], [-4.0, -2.5, 17.0]),
    ];
    let board = Board::new(9, 6, 1.0).unwrap();
    let (mut refused, mut disturbed, mut found) = (0, 0, 0);
    for (k, (rotation, translation)) in poses.into_iter().enumerate() {
        let scene = Scene {
            rotation,
            translation,
            seed: 21 + k as u64,
            ..Scene::default()
        };
        let clean = scene.render();
        for corner in [20, 22, 31] {
            let p = clean.corners[corner];
            // The board's row direction at this corner, and angles across it.
            let q = clean.corners[corner + 1];
            let row = (q[1] - p[1]).atan2(q[0] - p[0]);
            for (da, dark) in [(0.35, 0.5), (0.8, 0.7), (-0.6, 0.5)] {
                let mut px = clean.pixels.clone();
                shade(&mut px, scene.width, p, row + da, dark);
                let view = GrayView::packed(&px, scene.width, scene.height).unwrap();
                match detect(&view, &board, &DetectOptions::default()) {
                    Ok(d) => {
                        let e = max_error(&d.corners, &clean.corners);
                        assert!(
                            e < 0.5,
                            "pose {k}, shadow through corner {corner} at {da} rad, {dark}: \
                             a corner {e:.2} px off the truth was returned"
                        );
                        found += 1;
                    }
                    Err(DetectError::DisturbedCorner { .. }) => disturbed += 1,
                    // The shadow can also cut the grid's growth (a partial board).
                    Err(_) => refused += 1,
                }
            }
        }
    }
    eprintln!("found {found}, refused as disturbed {disturbed}, otherwise {refused}");
    assert!(disturbed > 0, "found {found}, disturbed {disturbed}");
}

/// A 50 % shadow edge along the middle of a row of squares (half a square from every corner)
/// leaves every corner a clean crossing: the board is found, as accurate as without it.
/// Tolerance 0.15 px: the bound of `corners_within_005_px_at_moderate_blur` for these scenes.
#[test]
fn shadow_edge_between_corner_rows_keeps_the_board() {
    let scene = Scene {
        seed: 31,
        ..Scene::default()
    };
    let clean = scene.render();
    let cols = scene.cols;
    let mid = |c: usize| {
        let (a, b) = (clean.corners[2 * cols + c], clean.corners[3 * cols + c]);
        [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0]
    };
    let (p, q) = (mid(0), mid(cols - 1));
    let mut px = clean.pixels.clone();
    shade(
        &mut px,
        scene.width,
        p,
        (q[1] - p[1]).atan2(q[0] - p[0]),
        0.5,
    );
    let view = GrayView::packed(&px, scene.width, scene.height).unwrap();
    let board = Board::new(9, 6, 1.0).unwrap();
    let d = detect(&view, &board, &DetectOptions::default()).expect("board refused");
    let e = max_error(&d.corners, &clean.corners);
    assert!(e < 0.15, "max corner error {e:.3} px");
}

/// Low light: a board of 30 grey levels of contrast under noise of 20 (a dark scene brightened
/// by gain; the defects bench's `lowlight c30n20`). The saddle fit's corners there scatter by
/// about 0.5 px RMS, so some land more than 1 px off: the board must be refused (as too noisy,
/// or not found) rather than returned with such a corner. Without the noise check (its limit
/// set out of reach) 8 of these 12 images return a board with a corner 1.2-1.7 px off the
/// truth and no error; with it those 8 are `TooNoisy` (predicted 0.49-0.60 px, limit 0.25),
/// the others are not found whole. Every board returned must have all its corners within 1 px.
/// And the reason must not mislead: before the ring test's contrast followed the noise, 3 of
/// the 12 (seeds 3, 5, 7) were refused as `board size mismatch` (a 9x7 or 10x6 grid for this
/// 9x6 board: noise X-junctions beyond its edge extended the grid); now none is.
#[test]
fn low_light_noise_refuses_rather_than_returns_corners_a_pixel_off() {
    let board = Board::new(9, 6, 1.0).unwrap();
    let (mut noisy, mut wrong, mut mismatch) = (0, Vec::new(), 0);
    for seed in 1..=12u64 {
        let scene = Scene {
            dark: 40.0,
            light: 73.0,
            background: 56.0,
            noise: 20.0,
            seed,
            ..Scene::default()
        };
        let img = scene.render();
        let view = GrayView::packed(&img.pixels, scene.width, scene.height).unwrap();
        match detect(&view, &board, &DetectOptions::default()) {
            Ok(d) => {
                let e = max_error(&d.corners, &img.corners);
                eprintln!("seed {seed}: returned, max error {e:.2} px");
                if e > 1.0 {
                    wrong.push((seed, e));
                }
            }
            Err(e) => {
                eprintln!("seed {seed}: {e}");
                if matches!(e, DetectError::SizeMismatch { .. }) {
                    mismatch += 1;
                }
                if let DetectError::TooNoisy {
                    sigma_px,
                    limit_px,
                    noise,
                    ..
                } = e
                {
                    assert!(sigma_px > limit_px && sigma_px.is_finite());
                    // The measured noise is the rendered one (20, quantized and clipped).
                    assert!((noise - 20.0).abs() < 2.0, "noise estimate {noise}");
                    noisy += 1;
                }
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "boards returned with a corner over 1 px off: {wrong:?}"
    );
    assert!(noisy > 0, "no board refused as too noisy");
    assert_eq!(
        mismatch, 0,
        "a board of the right size refused as a size mismatch"
    );
}

/// Smears the image along the direction `angle` (radians) over `length` px: the mean of
/// bilinear samples at `length + 1` evenly spaced offsets from `-length / 2` to `length / 2`
/// (a centred, point-symmetric line kernel: the corners do not move).
fn motion_blur(pixels: &[u8], width: usize, height: usize, length: f64, angle: f64) -> Vec<u8> {
    let n = length.round() as usize + 1;
    let (dx, dy) = (angle.cos(), angle.sin());
    let at = |x: f64, y: f64| -> f64 {
        let x = x.clamp(0.0, (width - 1) as f64);
        let y = y.clamp(0.0, (height - 1) as f64);
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(width - 1), (y0 + 1).min(height - 1));
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let p = |xx: usize, yy: usize| pixels[yy * width + xx] as f64;
        let top = p(x0, y0) + fx * (p(x1, y0) - p(x0, y0));
        let bottom = p(x0, y1) + fx * (p(x1, y1) - p(x0, y1));
        top + fy * (bottom - top)
    };
    (0..width * height)
        .map(|i| {
            let (x, y) = ((i % width) as f64, (i / width) as f64);
            let s: f64 = (0..n)
                .map(|k| {
                    let t = -length / 2.0 + length * k as f64 / (n - 1) as f64;
                    at(x + t * dx, y + t * dy)
                })
                .sum();
            (s / n as f64).round() as u8
        })
        .collect()
}

/// Motion blur of 15 px (the defects bench's `motion 15px`) smears the corners into ramps
/// longer than the search's ring and blur at half and full resolution; the quarter-resolution
/// search level finds the board. Without that level (the first four default levels only) two
/// of these three images are refused (angles 1.1 and 2.0: no board, partial board 34 of 54);
/// with it every corner is within 0.3 px of the truth (0.06-0.20 px measured; the refinement
/// runs at full resolution whatever level found the grid).
#[test]
fn long_motion_blur_is_found_at_the_coarse_search_level() {
    let board = Board::new(9, 6, 1.0).unwrap();
    let mut without = DetectOptions::default();
    without.search_levels.truncate(4);
    let mut refused_without = 0;
    for (k, angle) in [0.3f64, 1.1, 2.0].into_iter().enumerate() {
        let scene = Scene {
            width: 1280,
            height: 960,
            fx: 1100.0,
            fy: 1100.0,
            cx: 639.5,
            cy: 479.5,
            seed: 31 + k as u64,
            ..Scene::default()
        };
        let img = scene.render();
        let px = motion_blur(&img.pixels, scene.width, scene.height, 15.0, angle);
        let view = GrayView::packed(&px, scene.width, scene.height).unwrap();
        let before = detect(&view, &board, &without);
        eprintln!(
            "angle {angle}: four levels: {:?}",
            before.as_ref().map(|_| ()).map_err(|e| e.to_string())
        );
        if before.is_err() {
            refused_without += 1;
        }
        let d = detect(&view, &board, &DetectOptions::default()).expect("board found");
        let e = max_error(&d.corners, &img.corners);
        eprintln!("angle {angle}: max error {e:.3} px");
        assert!(e < 0.3, "angle {angle}: max error {e} px");
    }
    assert!(
        refused_without >= 2,
        "the first four levels found {} of 3",
        3 - refused_without
    );
}
