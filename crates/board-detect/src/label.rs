//! Labelling a full grid with board coordinates, and the geometric consistency check.

use crate::DetectError;
use crate::gray::ImageF;
use crate::grid::{Grid, P, cross};

/// Row-major corners (`index = r * cols + c`) for a grid that is exactly the board's size.
///
/// The grid axes are right-handed in the image. The labellings that keep them right-handed
/// and map the grid onto `cols x rows` are the candidates (two, or four for a square board);
/// the colour rule keeps those whose cell between corners `0, 1, cols, cols + 1` is dark,
/// then the geometric rule picks the one whose row direction points most to the image's
/// right, and fails with [`DetectError::AmbiguousOrientation`] when that is not clear.
pub(crate) fn label(
    g: &Grid,
    cols: usize,
    rows: usize,
    img: &ImageF,
    scale: f64,
) -> Result<Vec<P>, DetectError> {
    let (nu, nv) = (g.nu, g.nv);
    let mut pts: Vec<P> = Vec::with_capacity(nu * nv);
    for p in &g.pts {
        match p {
            Some(p) => pts.push(*p),
            None => return Err(DetectError::NoBoard),
        }
    }
    let at = |u: usize, v: usize| pts[v * nu + u];
    // Candidate labellings as maps (c, r) -> (u, v).
    type Map = Box<dyn Fn(usize, usize) -> (usize, usize)>;
    let mut cands: Vec<Map> = Vec::new();
    if nu == cols && nv == rows {
        cands.push(Box::new(|c, r| (c, r)));
        cands.push(Box::new(move |c, r| (nu - 1 - c, nv - 1 - r)));
    }
    if nu == rows && nv == cols {
        // c along +v, r along -u: still right-handed.
        cands.push(Box::new(move |c, r| (nu - 1 - r, c)));
        cands.push(Box::new(move |c, r| (r, nv - 1 - c)));
    }
    if cands.is_empty() {
        return Err(DetectError::NoBoard);
    }
    let labelled: Vec<Vec<P>> = cands
        .iter()
        .map(|m| {
            (0..rows)
                .flat_map(|r| (0..cols).map(move |c| (c, r)))
                .map(|(c, r)| {
                    let (u, v) = m(c, r);
                    at(u, v)
                })
                .collect()
        })
        .collect();
    let mut keep: Vec<usize> = (0..labelled.len()).collect();
    if (cols + rows) % 2 == 1 || (cols == rows && cols % 2 == 1) {
        // The colour of cell (0, 0) tells some candidates apart: vote over adjacent cell pairs.
        let mut dark = Vec::new();
        for l in &labelled {
            let (votes, agree, mean_diff) = colour_votes(l, cols, rows, img, scale);
            if votes == 0 || mean_diff.abs() < 4.0 || (agree as f64) < 0.8 * votes as f64 {
                return Err(DetectError::AmbiguousOrientation(format!(
                    "square colours too faint to tell (contrast {:.1} grey levels, {agree} of {votes} cell pairs agree)",
                    mean_diff.abs()
                )));
            }
            dark.push(mean_diff > 0.0);
        }
        keep.retain(|&i| dark[i]);
        if keep.is_empty() {
            return Err(DetectError::AmbiguousOrientation(
                "no labelling has a dark first cell".into(),
            ));
        }
    }
    if keep.len() > 1 {
        // Geometric rule: the row direction (corner 0 -> corner cols - 1) most to the right.
        let mut score: Vec<(f64, usize)> = keep
            .iter()
            .map(|&i| {
                let l = &labelled[i];
                let d = [l[cols - 1][0] - l[0][0], l[cols - 1][1] - l[0][1]];
                (d[0] / d[0].hypot(d[1]).max(1e-12), i)
            })
            .collect();
        score.sort_by(|a, b| b.0.total_cmp(&a.0));
        if score[0].0 - score[1].0 < 0.35 {
            return Err(DetectError::AmbiguousOrientation(
                "the board's square colours are symmetric and its rows are too close to vertical or diagonal".into(),
            ));
        }
        keep = vec![score[0].1];
    }
    let out = labelled[keep[0]].clone();
    debug_assert!(cross(sub(out[1], out[0]), sub(out[cols], out[0])) > 0.0 || nu * nv < 4);
    Ok(out)
}

fn sub(a: P, b: P) -> P {
    [a[0] - b[0], a[1] - b[1]]
}

/// Votes over horizontally and vertically adjacent cells `(a, b)` with `a` of even parity
/// (`(c + r) % 2 == 0`): returns (pairs, pairs where the even cell is darker, mean of
/// odd-minus-even intensity). Positive mean: even cells, hence cell (0, 0), are dark.
fn colour_votes(
    l: &[P],
    cols: usize,
    rows: usize,
    img: &ImageF,
    scale: f64,
) -> (usize, usize, f64) {
    let ncol = cols - 1;
    let nrow = rows - 1;
    let mut val = vec![0f32; ncol * nrow];
    for r in 0..nrow {
        for c in 0..ncol {
            let q = [
                l[r * cols + c],
                l[r * cols + c + 1],
                l[(r + 1) * cols + c],
                l[(r + 1) * cols + c + 1],
            ];
            let x = q.iter().map(|p| p[0]).sum::<f64>() / 4.0;
            let y = q.iter().map(|p| p[1]).sum::<f64>() / 4.0;
            val[r * ncol + c] = img.sample(x * scale, y * scale);
        }
    }
    let (mut votes, mut agree, mut sum) = (0usize, 0usize, 0.0f64);
    for r in 0..nrow {
        for c in 0..ncol {
            let me = val[r * ncol + c];
            for (dc, dr) in [(1, 0), (0, 1)] {
                let (c2, r2) = (c + dc, r + dr);
                if c2 >= ncol || r2 >= nrow {
                    continue;
                }
                let other = val[r2 * ncol + c2];
                let diff = if (c + r) % 2 == 0 {
                    other - me
                } else {
                    me - other
                } as f64;
                votes += 1;
                if diff > 0.0 {
                    agree += 1;
                }
                sum += diff;
            }
        }
    }
    let mean = if votes > 0 { sum / votes as f64 } else { 0.0 };
    // Agreement counted in the direction of the mean.
    let agree = if mean >= 0.0 { agree } else { votes - agree };
    (votes, agree, mean)
}

/// Intersection of the line through `a, b` with the line through `c, d`.
fn intersect(a: P, b: P, c: P, d: P) -> Option<P> {
    let r = sub(b, a);
    let s = sub(d, c);
    let den = cross(r, s);
    if den.abs() < 1e-12 {
        return None;
    }
    let t = cross(sub(c, a), s) / den;
    Some([a[0] + t * r[0], a[1] + t * r[1]])
}

/// Checks that every corner lies where the lines through its row and column neighbours
/// cross (lines stay lines under perspective; lens distortion bends them only slightly over
/// two squares). Limit: `rel` times the local corner spacing, at least `abs_px`.
pub(crate) fn check_consistency(
    pts: &[P],
    cols: usize,
    rows: usize,
    rel: f64,
    abs_px: f64,
) -> Result<(), DetectError> {
    let at = |c: usize, r: usize| pts[r * cols + c];
    let pair = |i: usize, n: usize| -> (usize, usize) {
        if i == 0 {
            (1, 2)
        } else if i + 1 == n {
            (n - 2, n - 3)
        } else {
            (i - 1, i + 1)
        }
    };
    let mut worst = (0.0f64, 0usize, 0.0f64);
    for r in 0..rows {
        for c in 0..cols {
            let (c1, c2) = pair(c, cols);
            let (r1, r2) = pair(r, rows);
            let p = at(c, r);
            let Some(q) = intersect(at(c1, r), at(c2, r), at(c, r1), at(c, r2)) else {
                return Err(DetectError::InconsistentGrid {
                    index: r * cols + c,
                    error_px: f64::INFINITY,
                    limit_px: abs_px,
                });
            };
            let spacing = {
                let a = at(c1, r);
                let b = at(c, r1);
                (a[0] - p[0])
                    .hypot(a[1] - p[1])
                    .min((b[0] - p[0]).hypot(b[1] - p[1]))
            };
            let e = (q[0] - p[0]).hypot(q[1] - p[1]);
            let lim = (rel * spacing).max(abs_px);
            if e - lim > worst.0 - worst.2 || worst.0 == 0.0 {
                worst = (e, r * cols + c, lim);
            }
        }
    }
    if worst.0 > worst.2 {
        return Err(DetectError::InconsistentGrid {
            index: worst.1,
            error_px: worst.0,
            limit_px: worst.2,
        });
    }
    Ok(())
}
