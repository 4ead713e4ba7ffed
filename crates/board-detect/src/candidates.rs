//! Corner candidates: saddle points of the blurred image that look like X-junctions.

use crate::gray::ImageF;

/// A candidate corner in search-image pixels.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Candidate {
    pub x: f64,
    pub y: f64,
    /// Saddle strength `Ixy^2 - Ixx Iyy` of the blurred image.
    pub response: f32,
}

/// Least contrast (grey levels, brightest minus darkest ring sample) of an X-junction in
/// [`ring_test`] on a clean image.
pub(crate) const MIN_CONTRAST: f64 = 8.0;

/// Saddle candidates of `img` at blur `sigma`.
///
/// Response `R = Ixy^2 - Ixx Iyy` (minus the Hessian determinant) of the image blurred with
/// `sigma`: positive at saddle points, which chessboard X-junctions are. Kept: strict 5x5 local
/// maxima above 1% of the strongest response that pass the ring test: on a circle of radius
/// `ring` around the point, the blurred intensity crosses its mean exactly four times with
/// enough contrast (two bright and two dark sectors, as at a chessboard corner, not at an
/// edge end or a blob), the brightest and darkest ring samples at least `min_contrast` grey
/// levels apart. At most `max_count` candidates, strongest first.
pub(crate) fn find(
    blur: &ImageF,
    ring: f64,
    min_contrast: f64,
    max_count: usize,
) -> Vec<Candidate> {
    let (w, h) = (blur.w, blur.h);
    if w < 8 || h < 8 {
        return Vec::new();
    }
    let mut resp = vec![0f32; w * h];
    let d = &blur.data;
    // Row by row over shifted slices, branch-free, so that the loop vectorizes.
    for y in 1..h - 1 {
        let (up, mid, dn) = (
            &d[(y - 1) * w..y * w],
            &d[y * w..(y + 1) * w],
            &d[(y + 1) * w..(y + 2) * w],
        );
        let out = &mut resp[y * w + 1..(y + 1) * w - 1];
        for (x, o) in out.iter_mut().enumerate() {
            let c = mid[x + 1];
            let ixx = mid[x + 2] - 2.0 * c + mid[x];
            let iyy = dn[x + 1] - 2.0 * c + up[x + 1];
            let ixy = 0.25 * (dn[x + 2] - dn[x] - up[x + 2] + up[x]);
            *o = (ixy * ixy - ixx * iyy).max(0.0);
        }
    }
    let rmax = resp.iter().fold(0f32, |m, &r| m.max(r));
    if rmax <= 0.0 {
        return Vec::new();
    }
    let thr = 0.01 * rmax;
    let circle = unit_circle();
    let border = (ring.ceil() as usize + 2).max(3);
    let mut out = Vec::new();
    if w <= 2 * border || h <= 2 * border {
        return out;
    }
    for y in border..h - border {
        let row = &resp[y * w..(y + 1) * w];
        for x in border..w - border {
            let r = row[x];
            if r <= thr || r < row[x - 1] || r < row[x + 1] {
                continue;
            }
            // Strict maximum in the 5x5 neighbourhood (ties broken by position).
            let mut is_max = true;
            'nms: for dy in -2isize..=2 {
                let yy = (y as isize + dy) as usize;
                for dx in -2isize..=2 {
                    if dx == 0 && dy == 0 {
                        continue;
                    }
                    let xx = (x as isize + dx) as usize;
                    let o = resp[yy * w + xx];
                    if o > r || (o == r && (dy < 0 || (dy == 0 && dx < 0))) {
                        is_max = false;
                        break 'nms;
                    }
                }
            }
            if !is_max {
                continue;
            }
            // Sub-pixel saddle position from the local quadratic model of the blurred image.
            let i = y * w + x;
            let c = d[i];
            let gx = 0.5 * (d[i + 1] - d[i - 1]) as f64;
            let gy = 0.5 * (d[i + w] - d[i - w]) as f64;
            let ixx = (d[i + 1] - 2.0 * c + d[i - 1]) as f64;
            let iyy = (d[i + w] - 2.0 * c + d[i - w]) as f64;
            let ixy = 0.25 * (d[i + w + 1] - d[i + w - 1] - d[i - w + 1] + d[i - w - 1]) as f64;
            let det = ixx * iyy - ixy * ixy;
            let (mut ox, mut oy) = (0.0, 0.0);
            if det.abs() > 1e-12 {
                ox = -(iyy * gx - ixy * gy) / det;
                oy = -(-ixy * gx + ixx * gy) / det;
                if ox.abs() > 1.0 || oy.abs() > 1.0 {
                    ox = 0.0;
                    oy = 0.0;
                }
            }
            let (px, py) = (x as f64 + ox, y as f64 + oy);
            if ring_test_with(blur, px, py, ring, min_contrast, &circle) {
                out.push(Candidate {
                    x: px,
                    y: py,
                    response: r,
                });
            }
        }
    }
    out.sort_by(|a, b| b.response.total_cmp(&a.response));
    out.truncate(max_count);
    out
}

/// Number of samples on the ring of [`ring_test`].
const RING_SAMPLES: usize = 24;

/// True when the ring of radius `r` around `(x, y)` has two bright and two dark sectors,
/// alternating, each sector at least two samples long, with the bright-dark contrast at least
/// `min_contrast` grey levels ([`MIN_CONTRAST`] on a clean image, more on a noisy one). Also
/// requires that opposite sectors have the same colour.
pub(crate) fn ring_test(img: &ImageF, x: f64, y: f64, r: f64, min_contrast: f64) -> bool {
    ring_test_with(img, x, y, r, min_contrast, &unit_circle())
}

fn unit_circle() -> [[f64; 2]; RING_SAMPLES] {
    let mut c = [[0.0; 2]; RING_SAMPLES];
    for (k, p) in c.iter_mut().enumerate() {
        let a = k as f64 * std::f64::consts::TAU / RING_SAMPLES as f64;
        *p = [a.cos(), a.sin()];
    }
    c
}

fn ring_test_with(
    img: &ImageF,
    x: f64,
    y: f64,
    r: f64,
    min_contrast: f64,
    circle: &[[f64; 2]; RING_SAMPLES],
) -> bool {
    let mut v = [0f32; RING_SAMPLES];
    for (s, c) in v.iter_mut().zip(circle) {
        *s = img.sample(x + r * c[0], y + r * c[1]);
    }
    let (mut lo, mut hi) = (f32::MAX, f32::MIN);
    for &s in &v {
        lo = lo.min(s);
        hi = hi.max(s);
    }
    if f64::from(hi - lo) < min_contrast {
        return false;
    }
    let mid = 0.5 * (lo + hi);
    let signs: Vec<bool> = v.iter().map(|&s| s > mid).collect();
    // Count sign changes around the ring and the run lengths.
    let mut changes = 0;
    let mut start = None;
    for k in 0..RING_SAMPLES {
        if signs[k] != signs[(k + 1) % RING_SAMPLES] {
            changes += 1;
            if start.is_none() {
                start = Some((k + 1) % RING_SAMPLES);
            }
        }
    }
    if changes != 4 {
        return false;
    }
    // Run lengths, starting at a change so that every run is whole.
    let s0 = start.unwrap_or(0);
    let mut runs = [0usize; 4];
    let mut ri = 0;
    for k in 0..RING_SAMPLES {
        let i = (s0 + k) % RING_SAMPLES;
        if k > 0 && signs[i] != signs[(i + RING_SAMPLES - 1) % RING_SAMPLES] {
            ri += 1;
        }
        if ri < 4 {
            runs[ri] += 1;
        }
    }
    if runs.iter().any(|&n| n < 2) {
        return false;
    }
    // Opposite sectors: the sample diametrically opposite the middle of a run has the same sign.
    let mut pos = s0;
    for &n in &runs {
        let mid_i = (pos + n / 2) % RING_SAMPLES;
        let opp = (mid_i + RING_SAMPLES / 2) % RING_SAMPLES;
        if signs[mid_i] != signs[opp] {
            return false;
        }
        pos += n;
    }
    true
}
