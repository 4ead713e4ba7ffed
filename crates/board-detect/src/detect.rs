//! The detection pipeline: search for a grid, label it, refine, verify.

use crate::candidates;
use crate::gray::{GrayView, ImageF};
use crate::grid::{self, GrowParams, P};
use crate::label;
use crate::refine::{self, SaddleFit};
use crate::symmetry;
use crate::{Board, DetectError, DetectOptions, Detection, Refinement};

/// Smallest side, in pixels, of an image that can be searched.
pub(crate) const MIN_SIDE: usize = 16;

pub(crate) fn check_size(width: u64, height: u64, opts: &DetectOptions) -> Result<(), DetectError> {
    if width.saturating_mul(height) > opts.max_pixels {
        return Err(DetectError::ImageTooLarge {
            width,
            height,
            limit: opts.max_pixels,
        });
    }
    if width < MIN_SIDE as u64 || height < MIN_SIDE as u64 {
        return Err(DetectError::ImageTooSmall { width, height });
    }
    Ok(())
}

pub(crate) fn run(
    view: &GrayView<'_>,
    board: &Board,
    opts: &DetectOptions,
) -> Result<Detection, DetectError> {
    board.validate()?;
    let (w, h) = (view.width(), view.height());
    check_size(w as u64, h as u64, opts)?;
    // Search on an image of at most `search_max_pixels` (integer box downscale).
    let mut f = 1usize;
    while ((w / f) as u64) * ((h / f) as u64) > opts.search_max_pixels.max(1024) {
        f += 1;
    }
    let (cols, rows) = (board.cols, board.rows);
    let n = cols * rows;
    let params = GrowParams {
        tol: 0.3,
        max_seeds: 40,
        max_side: cols.max(rows) + 1,
        target: n,
    };
    let mut best_err = DetectError::NoBoard;
    let mut best_count = 0usize;
    let mut levels: Vec<(usize, ImageF, f64)> = Vec::new();
    // Attempts: (total downscale, blur). The configured levels, then, when the image was
    // downscaled for the search, one more at a finer scale (a pixel budget four times
    // larger, at most 4x the time of a full search level): squares of 3-8 px, which the
    // downscaled search image shrinks below its reach, are found there.
    let mut attempts: Vec<(usize, f64)> = opts
        .search_levels
        .iter()
        .map(|level| (f * level.downscale.max(1), level.blur, level.min_side))
        .filter(|&(ff, _, min_side)| (w / ff).min(h / ff) >= min_side.max(MIN_SIDE))
        .map(|(ff, blur, _)| (ff, blur))
        .collect();
    if f > 1 {
        let mut fine = 1usize;
        while ((w / fine) as u64) * ((h / fine) as u64) > 4 * opts.search_max_pixels.max(1024) {
            fine += 1;
        }
        if fine < f {
            attempts.push((fine, 1.0));
        }
    }
    for (ff, sigma) in attempts {
        // Search images are made once per scale and only when a level needs them.
        let idx = match levels.iter().position(|(k, _, _)| *k == ff) {
            Some(i) => i,
            None => {
                let im = if ff == 1 {
                    ImageF::from_view(view)
                } else {
                    ImageF::from_view_downscaled(view, ff)
                };
                // Its noise (grey levels), for the ring test's contrast limit below.
                let noise = im.noise_sigma(NOISE_SAMPLE_STEP);
                levels.push((ff, im, noise));
                levels.len() - 1
            }
        };
        let blur = levels[idx].1.blurred(sigma);
        let ring = (1.6 * sigma).max(2.5);
        // The ring test's contrast must stand above the noise left after the blur (white
        // noise of standard deviation `s` becomes `s / (2 sqrt(pi) sigma)`), or noise alone
        // forms X-junctions beyond the board and the grid outgrows it.
        let blurred_noise = levels[idx].2 / (2.0 * std::f64::consts::PI.sqrt() * sigma);
        let min_contrast = (RING_NOISE_CONTRAST * blurred_noise).max(candidates::MIN_CONTRAST);
        let cands = candidates::find(&blur, ring, min_contrast, 4000);
        let grids = grid::find_grids(&cands, &blur, &params);
        let complete = grids
            .iter()
            .filter(|g| g.count() >= n && is_full(g.nu, g.nv, board))
            .count();
        if complete > 1 {
            return Err(DetectError::SeveralBoards {
                count: complete,
                cols,
                rows,
            });
        }
        for g in grids {
            match complete_grid(g, &blur, ring, min_contrast, board).map_err(|(e, count)| {
                // The growth stops one corner past the board's longer side: grow again,
                // without the limit, to report the size of the grid that is there.
                if matches!(e, DetectError::SizeMismatch { .. }) {
                    let unlimited = GrowParams {
                        max_side: MAX_REPORTED_SIDE,
                        ..params
                    };
                    let largest = grid::find_grids(&cands, &blur, &unlimited)
                        .into_iter()
                        .next()
                        .filter(|g| !fits(g.nu, g.nv, board));
                    if let Some(g) = largest {
                        return (size_mismatch(g.nu, g.nv, board), count);
                    }
                }
                (e, count)
            }) {
                Ok(pts) => {
                    let scale = ff as f64;
                    let off = (scale - 1.0) / 2.0;
                    let pts: Vec<P> = pts
                        .iter()
                        .map(|p| [p[0] * scale + off, p[1] * scale + off])
                        .collect();
                    return finish(view, pts, board, opts);
                }
                Err((e, count)) => {
                    // Keep the most informative failure: the one with the most corners.
                    if count > best_count || matches!(best_err, DetectError::NoBoard) {
                        best_count = count;
                        best_err = e;
                    }
                }
            }
        }
    }
    Err(best_err)
}

/// Pixel step (in both directions) of the noise estimates ([`ImageF::noise_sigma`]): a
/// 640x360 image gives about 14 000 samples, enough for the median to a few percent.
const NOISE_SAMPLE_STEP: usize = 4;

/// The ring test's least contrast, in standard deviations of the search image's noise after
/// its blur (at least [`candidates::MIN_CONTRAST`]). On the defects bench's low light c30n20
/// (noise 20, contrast 30) noise candidates beyond the board's edge extended 6 of 20 grids to
/// `board size mismatch` (e.g. 9x7 for a 9x6 board); with 5 one is left (3: 6, 4: 6, 6: 0 but
/// 9 partial boards) and 16 of 20 are reported as too noisy. Images with noise under about 6
/// grey levels keep the fixed limit, so clean images are searched as before.
const RING_NOISE_CONTRAST: f64 = 5.0;

/// Largest grid side grown to report a [`DetectError::SizeMismatch`] (the largest board).
const MAX_REPORTED_SIDE: usize = 1001;

/// Whether an `a x b` grid fits inside the board (either way round).
fn fits(a: usize, b: usize, board: &Board) -> bool {
    (a <= board.cols && b <= board.rows) || (a <= board.rows && b <= board.cols)
}

/// Whether an `a x b` grid is the board's size (either way round).
fn is_full(a: usize, b: usize, board: &Board) -> bool {
    (a == board.cols && b == board.rows) || (a == board.rows && b == board.cols)
}

/// The mismatch of an `a x b` grid, its sides written in the board's order (`COLSxROWS`,
/// the longer side first when `cols >= rows`), as `--board` would take it.
fn size_mismatch(a: usize, b: usize, board: &Board) -> DetectError {
    let (long, short) = (a.max(b), a.min(b));
    let (found_cols, found_rows) = if board.cols >= board.rows {
        (long, short)
    } else {
        (short, long)
    };
    DetectError::SizeMismatch {
        found_cols,
        found_rows,
        cols: board.cols,
        rows: board.rows,
    }
}

/// Whether a grid smaller than the board is reported as a [`DetectError::PartialBoard`]
/// rather than [`DetectError::NoBoard`]: at least half of the board's corners, at least 12,
/// and at least 3 corners on each side (a seed's size). Smaller grids (a 3x3 seed grown by up
/// to a third of a 9x6 board) are what textures and noise give; three full rows of a 9x6
/// board are half of it.
fn is_partial_board(g: &grid::Grid, board: &Board) -> bool {
    let count = g.count();
    count >= (board.cols * board.rows).div_ceil(2).max(12) && g.nu.min(g.nv) >= 3
}

/// Checks the grid size, fills and verifies missing corners, labels. On failure returns the
/// reason and the number of corners the grid had.
fn complete_grid(
    mut g: grid::Grid,
    blur: &ImageF,
    ring: f64,
    min_contrast: f64,
    board: &Board,
) -> Result<Vec<P>, (DetectError, usize)> {
    let (cols, rows) = (board.cols, board.rows);
    let count = g.count();
    if !fits(g.nu, g.nv, board) {
        return Err((size_mismatch(g.nu, g.nv, board), count));
    }
    let partial = |g: &grid::Grid| DetectError::PartialBoard {
        found: g.count(),
        expected: cols * rows,
    };
    if !is_full(g.nu, g.nv, board) {
        if !is_partial_board(&g, board) {
            return Err((DetectError::NoBoard, 0));
        }
        return Err((partial(&g), count));
    }
    if count < g.nu * g.nv {
        // Corners the candidate search missed: predict, refine, and demand an X-junction.
        let missing: Vec<usize> = (0..g.pts.len()).filter(|&i| g.pts[i].is_none()).collect();
        if !grid::predict_missing(&mut g) {
            return Err((partial(&g), count));
        }
        let fit = SaddleFit::new(2, 1.5);
        for i in missing {
            let p = g.pts[i].unwrap_or([0.0, 0.0]);
            match fit.refine(blur, p) {
                Some(q) if candidates::ring_test(blur, q[0], q[1], ring, min_contrast) => {
                    g.pts[i] = Some(q)
                }
                _ => {
                    return Err((
                        DetectError::PartialBoard {
                            found: count,
                            expected: cols * rows,
                        },
                        count,
                    ));
                }
            }
        }
    }
    label::label(&g, cols, rows, blur, 1.0).map_err(|e| (e, count))
}

/// Predicted corner uncertainty (px, one standard deviation along the least certain
/// direction: [`SaddleFit::position_sigma`] from the image's measured noise) above which the
/// saddle refinement is redone with a larger window and blur ([`NOISE_WINDOW_SPACING`],
/// [`NOISE_MAX_WINDOW`], [`NOISE_BLUR_WINDOW`]) to average the noise down. Clean images stay
/// far below it, so their corners do not change: at most 0.019 px on the 57 bundled
/// photographs of sourishg1 and sourishg2 (left), about 0.01 on rendered boards with noise 1-3;
/// the defects bench's low light (noise 8-20 grey levels on a contrast of 60-30) gives 0.1-0.6.
const NOISE_GROW_SIGMA: f64 = 0.05;

/// Half-window of the noisy image's refinement, as a fraction of the board's shorter corner
/// spacings (their 10th percentile): the window stays inside the four squares around the
/// corner.
const NOISE_WINDOW_SPACING: f64 = 0.4;

/// Largest half-window of the noisy image's refinement, in pixels. The quadratic fit's
/// precision stops improving beyond about 8-10 px (a blurred X-junction is not a quadratic
/// there, and the fit weighs the flat squares as much as the edges): on the defects bench's
/// low light c45n14 the predicted uncertainty of the worst corner falls from 0.29 px at 4 px
/// to 0.22 at 8 and 0.21 at 12.
const NOISE_MAX_WINDOW: usize = 12;

/// Blur of the noisy image's refinement, as a fraction of its half-window (at least the
/// configured blur): on the defects bench's low light it lowers the corner RMS from 0.325 to
/// 0.309 px at c45n14 and from 0.67 to 0.64 px at c30n20 (boards returned with no limit).
const NOISE_BLUR_WINDOW: f64 = 0.4;

/// Predicted corner uncertainty (px, one standard deviation along the least certain direction)
/// above which the board is refused as [`DetectError::TooNoisy`]. A corner of standard deviation
/// `s` lands more than 1 px off with probability about `exp(-1 / (2 s^2))`: 3e-4 at 0.25 px, so
/// the board's few least certain corners stay within 1 px. On the defects bench the worst
/// corner's error was at most 3.4 times its predicted deviation (low light c45n14 and c60n8).
const MAX_POSITION_SIGMA: f64 = 0.25;

/// Per-corner spacing: distance to the nearest row or column neighbour.
fn spacings(pts: &[P], cols: usize, rows: usize) -> Vec<f64> {
    let d = |a: P, b: P| (a[0] - b[0]).hypot(a[1] - b[1]);
    (0..rows * cols)
        .map(|i| {
            let (c, r) = (i % cols, i / cols);
            let mut m = f64::MAX;
            if c > 0 {
                m = m.min(d(pts[i], pts[i - 1]));
            }
            if c + 1 < cols {
                m = m.min(d(pts[i], pts[i + 1]));
            }
            if r > 0 {
                m = m.min(d(pts[i], pts[i - cols]));
            }
            if r + 1 < rows {
                m = m.min(d(pts[i], pts[i + cols]));
            }
            m
        })
        .collect()
}

/// The view's pixels in the board's bounding box grown by `margin` pixels, and the box origin.
fn board_region(view: &GrayView<'_>, pts: &[P], margin: f64) -> (ImageF, f64, f64) {
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for p in pts {
        x0 = x0.min(p[0]);
        y0 = y0.min(p[1]);
        x1 = x1.max(p[0]);
        y1 = y1.max(p[1]);
    }
    let cx0 = (x0 - margin).max(0.0) as usize;
    let cy0 = (y0 - margin).max(0.0) as usize;
    let cx1 = (x1 + margin).max(0.0) as usize + 1;
    let cy1 = (y1 + margin).max(0.0) as usize + 1;
    let img = ImageF::from_view_region(view, cx0, cy0, cx1, cy1);
    (img, cx0 as f64, cy0 as f64)
}

/// Refines at full resolution (only the board's region is converted), verifies, and builds
/// the detection.
fn finish(
    view: &GrayView<'_>,
    mut pts: Vec<P>,
    board: &Board,
    opts: &DetectOptions,
) -> Result<Detection, DetectError> {
    let (cols, rows) = (board.cols, board.rows);
    let sp = spacings(&pts, cols, rows);
    let mut sorted = sp.clone();
    sorted.sort_by(f64::total_cmp);
    let med = sorted[sorted.len() / 2];
    // The blurred board region the symmetry check reads: the saddle refinement's own (its
    // blur and window), or one made with the default refinement's parameters.
    let mut blurred: Option<(ImageF, f64, f64, usize)> = None;
    match opts.refinement {
        Refinement::None => {}
        Refinement::Gradient {
            window,
            max_half_window,
        } => {
            let max_hw = max_half_window.max(2);
            let (img, ox, oy) = board_region(view, &pts, max_hw as f64 + 3.0);
            for (p, &s) in pts.iter_mut().zip(&sp) {
                let hw = ((window * s).round() as usize).clamp(2, max_hw);
                if let Some(q) = refine::gradient(&img, [p[0] - ox, p[1] - oy], hw, hw as f64 * 0.7)
                {
                    *p = [q[0] + ox, q[1] + oy];
                }
            }
        }
        Refinement::Saddle {
            blur,
            window,
            max_blur,
            max_window,
        } => {
            let sigma = (blur * med).clamp(0.7, max_blur.max(0.7));
            let r0 = ((window * med).round() as usize).clamp(2, max_window.max(2));
            // The window (and blur) a noisy image gets: up to a fraction of the shorter
            // spacings, never below the configured ones.
            let r_noisy = ((NOISE_WINDOW_SPACING * sorted[sorted.len() / 10]).floor() as usize)
                .clamp(r0, NOISE_MAX_WINDOW.max(r0));
            let sigma_noisy = sigma.max(NOISE_BLUR_WINDOW * r_noisy as f64);
            // Blur only the board's bounding box (with room for the fit and the kernel).
            let margin = (r_noisy as f64 + 3.0 * sigma_noisy + 4.0).ceil();
            let (region, ox, oy) = board_region(view, &pts, margin);
            let noise = region.noise_sigma(NOISE_SAMPLE_STEP);
            // The search's positions: a corner whose fit fails keeps its own.
            let start = pts.clone();
            // Refines every corner from the search's position; returns the least certain
            // corner (index, predicted standard deviation in px).
            let refine_all = |pts: &mut [P], img: &ImageF, r: usize, sig: f64| {
                let fit = SaddleFit::new(r, r as f64 * 0.6);
                let var_linear = noise * noise * fit.linear_noise_gain(sig);
                let mut worst: Option<(usize, f64)> = None;
                for (i, (p, s)) in pts.iter_mut().zip(&start).enumerate() {
                    *p = *s;
                    if let Some((q, curv)) = fit.refine_curvature(img, [s[0] - ox, s[1] - oy]) {
                        *p = [q[0] + ox, q[1] + oy];
                        let sd = SaddleFit::position_sigma(curv, var_linear);
                        if worst.is_none_or(|(_, w)| sd > w) {
                            worst = Some((i, sd));
                        }
                    }
                }
                worst
            };
            let mut img = region.blurred(sigma);
            let mut r = r0;
            let mut worst = refine_all(&mut pts, &img, r, sigma);
            // Grow by half at a time, and stop as soon as the corners are certain enough: a
            // window larger than needed costs accuracy on strongly blurred boards (defocus
            // sigma 5 px: max error 0.47 px when going straight to the largest window, 0.18
            // this way).
            while r < r_noisy && worst.is_some_and(|(_, w)| w > NOISE_GROW_SIGMA) {
                r = (r + r.div_ceil(2)).min(r_noisy);
                let sig = sigma.max(NOISE_BLUR_WINDOW * r as f64);
                img = region.blurred(sig);
                worst = refine_all(&mut pts, &img, r, sig);
            }
            if let Some((index, sigma_px)) = worst
                && sigma_px > MAX_POSITION_SIGMA
            {
                return Err(DetectError::TooNoisy {
                    index,
                    sigma_px,
                    limit_px: MAX_POSITION_SIGMA,
                    noise,
                });
            }
            blurred = Some((img, ox, oy, r));
        }
    }
    label::check_consistency(&pts, cols, rows, opts.max_grid_deviation, 1.0)?;
    let (img, ox, oy, r) = blurred.unwrap_or_else(|| {
        let sigma = (0.1 * med).clamp(0.7, 1.5);
        let r = ((0.2 * med).round() as usize).clamp(2, 4);
        let margin = (r as f64 + 3.0 * sigma + 4.0).ceil();
        let (region, ox, oy) = board_region(view, &pts, margin);
        (region.blurred(sigma), ox, oy, r)
    });
    let local: Vec<P> = pts.iter().map(|p| [p[0] - ox, p[1] - oy]).collect();
    if med >= symmetry::MIN_SPACING
        && let Some((index, asymmetry, limit)) = symmetry::worst_asymmetric(&img, &local, r)
    {
        return Err(DetectError::DisturbedCorner {
            index,
            asymmetry,
            limit,
        });
    }
    if let Some(d) = opts.joint_warp_degree
        && let Some(q) = crate::warp::smooth(&pts, cols, rows, d)
    {
        pts = q;
    }
    let homography_rms = crate::warp::homography_fit(&pts, cols).map_or(f64::NAN, |(_, rms)| rms);
    Ok(Detection {
        corners: pts,
        image_size: [view.width(), view.height()],
        homography_rms,
    })
}
