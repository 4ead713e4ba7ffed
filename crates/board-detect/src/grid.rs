//! Growing a corner grid from candidates: a 3x3 seed, then whole rows and columns at a time.
//!
//! The grid has `nu` corners along its first axis and `nv` along its second; position
//! `(u, v)` is stored at `v * nu + u`. The axes are right-handed in the image (`u` to `v`
//! turns clockwise on the screen, as `x` to `y` does), which the seed guarantees and every
//! transform below preserves or restores.

use crate::candidates::Candidate;
use crate::gray::ImageF;

pub(crate) type P = [f64; 2];

#[inline]
fn sub(a: P, b: P) -> P {
    [a[0] - b[0], a[1] - b[1]]
}
#[inline]
fn add(a: P, b: P) -> P {
    [a[0] + b[0], a[1] + b[1]]
}
#[inline]
fn norm(a: P) -> f64 {
    a[0].hypot(a[1])
}
#[inline]
pub(crate) fn cross(a: P, b: P) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}
#[inline]
fn dot(a: P, b: P) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// A partially filled grid of corner positions (search-image pixels).
#[derive(Debug, Clone)]
pub(crate) struct Grid {
    pub nu: usize,
    pub nv: usize,
    pub pts: Vec<Option<P>>,
    /// Candidate index of every filled position (`usize::MAX` for filled-in corners).
    pub ids: Vec<usize>,
}

impl Grid {
    #[inline]
    pub fn get(&self, u: usize, v: usize) -> Option<P> {
        self.pts[v * self.nu + u]
    }

    pub fn count(&self) -> usize {
        self.pts.iter().filter(|p| p.is_some()).count()
    }

    fn flip_u(&mut self) {
        for v in 0..self.nv {
            self.pts[v * self.nu..(v + 1) * self.nu].reverse();
            self.ids[v * self.nu..(v + 1) * self.nu].reverse();
        }
    }

    fn transpose(&mut self) {
        let mut pts = vec![None; self.pts.len()];
        let mut ids = vec![usize::MAX; self.pts.len()];
        for v in 0..self.nv {
            for u in 0..self.nu {
                pts[u * self.nv + v] = self.pts[v * self.nu + u];
                ids[u * self.nv + v] = self.ids[v * self.nu + u];
            }
        }
        self.pts = pts;
        self.ids = ids;
        std::mem::swap(&mut self.nu, &mut self.nv);
    }

    /// Rotation by 90 degrees of the labels (keeps the axes right-handed): `transpose`
    /// followed by a flip of the new first axis.
    fn apply(&mut self, side: Side, forward: bool) {
        match (side, forward) {
            (Side::PlusU, _) => {}
            (Side::MinusU, _) => self.flip_u(),
            (Side::PlusV, _) => self.transpose(),
            (Side::MinusV, true) => {
                self.transpose();
                self.flip_u();
            }
            (Side::MinusV, false) => {
                self.flip_u();
                self.transpose();
            }
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum Side {
    PlusU,
    MinusU,
    PlusV,
    MinusV,
}

/// Bucketed spatial index over the candidates.
pub(crate) struct Index {
    cell: f64,
    gw: usize,
    gh: usize,
    buckets: Vec<Vec<u32>>,
}

impl Index {
    pub fn new(c: &[Candidate], w: usize, h: usize, cell: f64) -> Self {
        let gw = (w as f64 / cell).ceil() as usize + 1;
        let gh = (h as f64 / cell).ceil() as usize + 1;
        let mut buckets = vec![Vec::new(); gw * gh];
        for (i, p) in c.iter().enumerate() {
            let bx = ((p.x / cell).max(0.0) as usize).min(gw - 1);
            let by = ((p.y / cell).max(0.0) as usize).min(gh - 1);
            buckets[by * gw + bx].push(i as u32);
        }
        Self {
            cell,
            gw,
            gh,
            buckets,
        }
    }

    /// Calls `f(index, squared distance)` for every candidate within `r` of `p`.
    fn within(&self, c: &[Candidate], p: P, r: f64, mut f: impl FnMut(usize, f64)) {
        let x0 = (((p[0] - r) / self.cell).floor().max(0.0) as usize).min(self.gw - 1);
        let x1 = (((p[0] + r) / self.cell).floor().max(0.0) as usize).min(self.gw - 1);
        let y0 = (((p[1] - r) / self.cell).floor().max(0.0) as usize).min(self.gh - 1);
        let y1 = (((p[1] + r) / self.cell).floor().max(0.0) as usize).min(self.gh - 1);
        let r2 = r * r;
        for by in y0..=y1 {
            for bx in x0..=x1 {
                for &i in &self.buckets[by * self.gw + bx] {
                    let q = &c[i as usize];
                    let d2 = (q.x - p[0]).powi(2) + (q.y - p[1]).powi(2);
                    if d2 <= r2 {
                        f(i as usize, d2);
                    }
                }
            }
        }
    }

    /// The nearest candidate to `p` within `r`, not marked in `used`.
    fn nearest(&self, c: &[Candidate], used: &[bool], p: P, r: f64) -> Option<usize> {
        let mut best = None;
        let mut bd = f64::MAX;
        self.within(c, p, r, |i, d2| {
            if !used[i] && d2 < bd {
                bd = d2;
                best = Some(i);
            }
        });
        best
    }
}

/// Search parameters for the grid growth.
pub(crate) struct GrowParams {
    /// Largest distance from a prediction to the accepted candidate, as a fraction of the
    /// local corner spacing.
    pub tol: f64,
    /// How many seeds to try at most.
    pub max_seeds: usize,
    /// Largest grid side that can still be a sub-grid of the board.
    pub max_side: usize,
    /// Stop as soon as a grid has this many corners.
    pub target: usize,
}

/// Cell centre intensity: the blurred image at the mean of the four corners.
fn cell_value(img: &ImageF, a: P, b: P, c: P, d: P) -> f32 {
    img.sample(
        0.25 * (a[0] + b[0] + c[0] + d[0]),
        0.25 * (a[1] + b[1] + c[1] + d[1]),
    )
}

/// The grids found, largest first (at most a few). Seeding goes on after a complete grid
/// (`params.target` corners) until a second one or the seed limit.
pub(crate) fn find_grids(cands: &[Candidate], img: &ImageF, params: &GrowParams) -> Vec<Grid> {
    let n = cands.len();
    if n < 9 {
        return Vec::new();
    }
    let index = Index::new(cands, img.w, img.h, 16.0);
    let mut claimed = vec![false; n];
    let mut grids: Vec<Grid> = Vec::new();
    let search_r = (img.w.max(img.h) as f64 / 5.0).max(20.0);
    let mut tried = 0;
    let mut complete_grids = 0;
    let mut first_box: Option<[f64; 4]> = None;
    for s in 0..n {
        if tried >= params.max_seeds {
            break;
        }
        if claimed[s] || inside(&first_box, &cands[s]) {
            continue;
        }
        tried += 1;
        let Some(mut g) = seed(cands, &index, img, s, search_r, params.tol) else {
            continue;
        };
        let mut used = vec![false; n];
        for &id in &g.ids {
            if id != usize::MAX {
                used[id] = true;
            }
        }
        grow(&mut g, cands, &index, &mut used, img, params);
        for &id in &g.ids {
            if id != usize::MAX {
                claimed[id] = true;
            }
        }
        let complete = g.count() >= params.target;
        if complete {
            complete_grids += 1;
            // A second complete board is looked for among the seeds left, outside the first
            // board, so that an image with two boards is refused rather than one of them
            // picked by corner strength; not when too few candidates are left for one.
            first_box = Some(bounding_box(&g));
            let left = (0..n)
                .filter(|&i| !claimed[i] && !inside(&first_box, &cands[i]))
                .count();
            if complete_grids > 1 || 2 * left < params.target {
                grids.push(g);
                break;
            }
        }
        grids.push(g);
    }
    grids.sort_by_key(|g| std::cmp::Reverse(g.count()));
    grids.truncate(3);
    grids
}

/// The grid's bounding box `[x0, y0, x1, y1]`, grown by its largest step between neighbours.
fn bounding_box(g: &Grid) -> [f64; 4] {
    let pts: Vec<P> = g.pts.iter().flatten().copied().collect();
    let mut b = [f64::MAX, f64::MAX, f64::MIN, f64::MIN];
    for p in &pts {
        b = [
            b[0].min(p[0]),
            b[1].min(p[1]),
            b[2].max(p[0]),
            b[3].max(p[1]),
        ];
    }
    let mut step: f64 = 0.0;
    for v in 0..g.nv {
        for u in 0..g.nu {
            if let Some(p) = g.get(u, v) {
                for q in [
                    (u + 1 < g.nu).then(|| g.get(u + 1, v)).flatten(),
                    (v + 1 < g.nv).then(|| g.get(u, v + 1)).flatten(),
                ]
                .into_iter()
                .flatten()
                {
                    step = step.max(norm(sub(q, p)));
                }
            }
        }
    }
    [b[0] - step, b[1] - step, b[2] + step, b[3] + step]
}

fn inside(b: &Option<[f64; 4]>, c: &Candidate) -> bool {
    b.is_some_and(|b| c.x >= b[0] && c.x <= b[2] && c.y >= b[1] && c.y <= b[3])
}

/// A 3x3 seed around candidate `s`: two pairs of opposite neighbours and the four diagonal
/// corners, with the four cells around `s` alternating in colour.
fn seed(
    c: &[Candidate],
    index: &Index,
    img: &ImageF,
    s: usize,
    search_r: f64,
    tol: f64,
) -> Option<Grid> {
    let p = [c[s].x, c[s].y];
    let mut nb: Vec<(f64, usize)> = Vec::new();
    index.within(c, p, search_r, |i, d2| {
        if i != s {
            nb.push((d2, i));
        }
    });
    nb.sort_by(|a, b| a.0.total_cmp(&b.0));
    nb.truncate(8);
    let none = vec![false; c.len()];
    for ia in 0..nb.len() {
        for ic in ia + 1..nb.len() {
            let a = [c[nb[ia].1].x, c[nb[ia].1].y];
            let cc = [c[nb[ic].1].x, c[nb[ic].1].y];
            let mut u = sub(a, p);
            let mut v = sub(cc, p);
            let (lu, lv) = (norm(u), norm(v));
            if lu < 3.0 || lv < 3.0 || lu > 2.0 * lv || lv > 2.0 * lu {
                continue;
            }
            let sin = cross(u, v) / (lu * lv);
            if sin.abs() < 0.55 {
                continue;
            }
            let (mut ia_id, mut ic_id) = (nb[ia].1, nb[ic].1);
            if sin < 0.0 {
                std::mem::swap(&mut u, &mut v);
                std::mem::swap(&mut ia_id, &mut ic_id);
            }
            let r = tol * lu.min(lv);
            let find = |q: P| index.nearest(c, &none, q, r);
            let Some(b) = find(sub(p, u)) else { continue };
            let Some(e) = find(sub(p, v)) else { continue };
            let pb = [c[b].x, c[b].y];
            let pe = [c[e].x, c[e].y];
            let pa = add(p, u);
            let pc = add(p, v);
            let diag = [
                find(add(pa, v)),
                find(add(pa, sub(pe, p))),
                find(add(pb, v)),
                find(add(pb, sub(pe, p))),
            ];
            let [Some(d_pp), Some(d_pm), Some(d_mp), Some(d_mm)] = diag else {
                continue;
            };
            // Layout (u right, v down): row v=0: mm, e, pm; v=1: b, s, a; v=2: mp, c, pp.
            let ids = [d_mm, e, d_pm, b, s, ia_id, d_mp, ic_id, d_pp];
            let mut uniq = ids.to_vec();
            uniq.sort_unstable();
            uniq.dedup();
            if uniq.len() != 9 {
                continue;
            }
            let pts: Vec<Option<P>> = ids.iter().map(|&i| Some([c[i].x, c[i].y])).collect();
            let g = Grid {
                nu: 3,
                nv: 3,
                pts,
                ids: ids.to_vec(),
            };
            let q = |u: usize, v: usize| g.get(u, v).unwrap_or(p);
            let cell = |u: usize, v: usize| {
                cell_value(img, q(u, v), q(u + 1, v), q(u, v + 1), q(u + 1, v + 1))
            };
            let (c00, c10, c01, c11) = (cell(0, 0), cell(1, 0), cell(0, 1), cell(1, 1));
            let margin = 6.0;
            let ok =
                (c00.max(c11) + margin < c10.min(c01)) || (c10.max(c01) + margin < c00.min(c11));
            let _ = (pc, e);
            if ok {
                return Some(g);
            }
        }
    }
    None
}

/// Projective extrapolation of the next point of a row of equally spaced board corners.
pub(crate) fn extrapolate(p0: Option<P>, p1: P, p2: P) -> P {
    let d1 = sub(p2, p1);
    let Some(p0) = p0 else { return add(p2, d1) };
    let d0 = sub(p1, p0);
    let (l0, l1) = (norm(d0), norm(d1));
    if l0 < 1e-9 || l1 < 1e-9 {
        return add(p2, d1);
    }
    let rho = l1 / l0;
    // Image of equally spaced points under a 1D projective map x(t) = (a t + b) / (c t + 1):
    // successive steps have ratios (c + 1) / (2c + 1), then (2c + 1) / (3c + 1).
    let mut ratio = rho;
    if (2.0 * rho - 1.0).abs() > 1e-6 {
        let cc = (1.0 - rho) / (2.0 * rho - 1.0);
        let r2 = (2.0 * cc + 1.0) / (3.0 * cc + 1.0);
        if r2.is_finite() && (0.3..3.0).contains(&r2) {
            ratio = r2;
        }
    }
    let ang = cross(d0, d1).atan2(dot(d0, d1));
    let (s, co) = ang.sin_cos();
    let d2 = [
        (co * d1[0] - s * d1[1]) * ratio,
        (s * d1[0] + co * d1[1]) * ratio,
    ];
    add(p2, d2)
}

fn grow(
    g: &mut Grid,
    c: &[Candidate],
    index: &Index,
    used: &mut [bool],
    img: &ImageF,
    params: &GrowParams,
) {
    let sides = [Side::PlusU, Side::MinusU, Side::PlusV, Side::MinusV];
    let mut stalled = 0;
    let mut k = 0;
    while stalled < 4 {
        let side = sides[k % 4];
        k += 1;
        g.apply(side, true);
        let grown = g.nu < params.max_side && grow_plus_u(g, c, index, used, img, params.tol);
        g.apply(side, false);
        if grown {
            stalled = 0;
        } else {
            stalled += 1;
        }
    }
}

/// Tries to add a column at `u = nu`. Returns whether it did.
fn grow_plus_u(
    g: &mut Grid,
    c: &[Candidate],
    index: &Index,
    used: &mut [bool],
    img: &ImageF,
    tol: f64,
) -> bool {
    let (nu, nv) = (g.nu, g.nv);
    let mut newcol: Vec<Option<(P, usize)>> = vec![None; nv];
    let mut predicted = 0;
    let mut found = 0;
    for (v, slot) in newcol.iter_mut().enumerate() {
        let (Some(p2), Some(p1)) = (g.get(nu - 1, v), g.get(nu - 2, v)) else {
            continue;
        };
        let p0 = if nu >= 3 { g.get(nu - 3, v) } else { None };
        let pred = extrapolate(p0, p1, p2);
        predicted += 1;
        let step = norm(sub(p2, p1));
        if let Some(i) = index.nearest(c, used, pred, tol * step) {
            *slot = Some(([c[i].x, c[i].y], i));
            found += 1;
        }
    }
    if found < 2 || 2 * found < predicted {
        return false;
    }
    // Colour check: each new cell is opposite in colour to its neighbour in the last column,
    // and (where there is one) the same as the cell two columns back.
    let mut checked = 0;
    for v in 0..nv.saturating_sub(1) {
        let (Some((n0, _)), Some((n1, _))) = (newcol[v], newcol[v + 1]) else {
            continue;
        };
        let (Some(a0), Some(a1), Some(b0), Some(b1)) = (
            g.get(nu - 1, v),
            g.get(nu - 1, v + 1),
            g.get(nu - 2, v),
            g.get(nu - 2, v + 1),
        ) else {
            continue;
        };
        let new = cell_value(img, a0, a1, n0, n1);
        let prev = cell_value(img, b0, b1, a0, a1);
        let contrast = (new - prev).abs();
        if contrast < 5.0 {
            return false;
        }
        if nu >= 3
            && let (Some(z0), Some(z1)) = (g.get(nu - 3, v), g.get(nu - 3, v + 1))
        {
            let prev2 = cell_value(img, z0, z1, b0, b1);
            if (new - prev2).abs() > contrast || (prev2 - prev).signum() != (new - prev).signum() {
                return false;
            }
        }
        checked += 1;
    }
    if checked == 0 {
        return false;
    }
    let mut pts = Vec::with_capacity((nu + 1) * nv);
    let mut ids = Vec::with_capacity((nu + 1) * nv);
    for (v, slot) in newcol.iter().enumerate() {
        pts.extend_from_slice(&g.pts[v * nu..(v + 1) * nu]);
        ids.extend_from_slice(&g.ids[v * nu..(v + 1) * nu]);
        match slot {
            Some((p, i)) => {
                pts.push(Some(*p));
                ids.push(*i);
                used[*i] = true;
            }
            None => {
                pts.push(None);
                ids.push(usize::MAX);
            }
        }
    }
    g.nu += 1;
    g.pts = pts;
    g.ids = ids;
    true
}

/// Fills the missing positions of a grid by prediction from their row or column neighbours.
/// Returns false when some position has no neighbours to predict it from.
pub(crate) fn predict_missing(g: &mut Grid) -> bool {
    for _ in 0..4 {
        let mut missing = false;
        for v in 0..g.nv {
            for u in 0..g.nu {
                if g.get(u, v).is_some() {
                    continue;
                }
                let mut preds: Vec<P> = Vec::new();
                // Between two neighbours of a row or column: the midpoint.
                if u > 0
                    && u + 1 < g.nu
                    && let (Some(a), Some(b)) = (g.get(u - 1, v), g.get(u + 1, v))
                {
                    preds.push([0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])]);
                }
                if v > 0
                    && v + 1 < g.nv
                    && let (Some(a), Some(b)) = (g.get(u, v - 1), g.get(u, v + 1))
                {
                    preds.push([0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])]);
                }
                // Extrapolated from two on one side.
                if preds.is_empty() {
                    if u >= 2
                        && let (Some(a), Some(b)) = (g.get(u - 2, v), g.get(u - 1, v))
                    {
                        preds.push(extrapolate(None, a, b));
                    }
                    if u + 2 < g.nu
                        && let (Some(a), Some(b)) = (g.get(u + 2, v), g.get(u + 1, v))
                    {
                        preds.push(extrapolate(None, a, b));
                    }
                    if v >= 2
                        && let (Some(a), Some(b)) = (g.get(u, v - 2), g.get(u, v - 1))
                    {
                        preds.push(extrapolate(None, a, b));
                    }
                    if v + 2 < g.nv
                        && let (Some(a), Some(b)) = (g.get(u, v + 2), g.get(u, v + 1))
                    {
                        preds.push(extrapolate(None, a, b));
                    }
                }
                if !preds.is_empty() {
                    let n = preds.len() as f64;
                    let sx = preds.iter().map(|p| p[0]).sum::<f64>() / n;
                    let sy = preds.iter().map(|p| p[1]).sum::<f64>() / n;
                    g.pts[v * g.nu + u] = Some([sx, sy]);
                } else {
                    missing = true;
                }
            }
        }
        if !missing {
            return true;
        }
    }
    false
}
