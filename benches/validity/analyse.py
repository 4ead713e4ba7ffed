"""Brute-force audit of the lens-model validity check (benches/validity/run.sh).

    python analyse.py PROBE RESULT.json [RESULT.json ...]

For each calibration result (`calib single -o`), samples the fitted distortion map from
normalized coordinates to pixels densely in 2-D (a tensor grid over the projection plane, not
rays), independently of the Rust code: the determinant of the discrete map's Jacobian (central
differences between grid points: positive, and at most 100, the check's bound on the area
magnification), the rational denominator (positive, and inside its first root in r^2 from
numpy.roots, since a negative band can be thinner than the grid), and finiteness. The valid set is
the connected region around the principal point where all hold (cv2.connectedComponents); its
border cells next to a failing cell are the folds (those of the fine grid when it has any: the
coarse one only adds folds beyond it). From them:

  bf_radius   the smallest pixel distance of a fold from the principal point (inf: no fold in
              the sampled domain), against the result's `validity.valid_radius_px`;
  bf_cover    the smallest ratio, over the folds, of a fold's position to the image border in the
              same direction (the rectangle norm about the principal point), against the 5% margin
              of `covers_image`; a valid region that ends at the projection's range (pinhole
              87 degrees, equidistant 180) inside the image counts as a fold there.

Then it undistorts a grid of pixels over the image plus 5% with the Rust API (PROBE, the
`validity_probe` example, which also times `AnyCamera::validity`) and checks, for every pixel
closer to the principal point than the reported valid radius, that the undistortion succeeded,
maps back to the pixel, and lies on the valid branch (the segment from the axis to it crosses
no fold). Prints one table row per result (markdown) and a line per disagreement.
"""
import json
import math
import subprocess
import sys

import cv2
import numpy as np

MARGIN = 1.05  # covers_image: valid 5% beyond the border
MAX_AREA_MAGNIFICATION = 100.0  # the check's bound on the Jacobian determinant (validity.rs)
PINHOLE_MAX = math.tan(math.radians(87.0))
EQUIDISTANT_MAX = math.pi * 0.999


def coefficients(cam):
    """The model, the intrinsics and the twelve rational/thin-prism coefficients (or four KB)."""
    d = cam['dist_coeffs']
    if cam['model'] == 'kannala-brandt4':
        return d
    k = np.zeros(12)
    k[:len(d)] = d
    return k


def distort(model, k, x, y):
    """Distorted normalized point and the rational denominator (1 for polynomial models)."""
    r2 = x * x + y * y
    if model == 'kannala-brandt4':
        f = 1 + r2 * (k[0] + r2 * (k[1] + r2 * (k[2] + r2 * k[3])))
        return x * f, y * f, np.ones_like(x)
    r4, r6 = r2 * r2, r2 * r2 * r2
    num = 1 + k[0] * r2 + k[1] * r4 + k[4] * r6
    den = 1 + k[5] * r2 + k[6] * r4 + k[7] * r6
    with np.errstate(all='ignore'):
        c = num / den
    p1, p2 = k[2], k[3]
    xd = x * c + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) + k[8] * r2 + k[9] * r4
    yd = y * c + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y + k[10] * r2 + k[11] * r4
    return xd, yd, den


def pole_t(model, k):
    """The rational denominator's smallest positive root in t = r^2 (numpy.roots), or inf: a band
    where it is negative can be far narrower than any grid step."""
    if model == 'kannala-brandt4' or not any(k[5:8]):
        return math.inf
    roots = np.roots([k[7], k[6], k[5], 1.0][next(i for i, v in enumerate([k[7], k[6], k[5]]) if v != 0):])
    real = [r.real for r in roots if abs(r.imag) <= 1e-9 * max(1.0, abs(r)) and r.real > 0]
    return min(real, default=math.inf)


def radial_first_failure(model, k, f):
    """For a disagreement: the radial map r -> r c(r) alone (tangential terms left out), evaluated
    at 3e6 radii up to 3 (pinhole) or pi (fisheye), which resolves bands far thinner than the 2-D
    grid: the pixel radius (at focal length f) where it first stops increasing, its denominator
    vanishes or its area magnification passes the bound; inf if nowhere."""
    r = np.linspace(1e-6, math.pi * 0.999 if model == 'kannala-brandt4' else 3.0, 3_000_001)
    radial = k if model == 'kannala-brandt4' else np.concatenate([k[:2], [0, 0], k[4:8], [0, 0, 0, 0]])
    xd, _, den = distort(model, radial, r, np.zeros_like(r))
    slope = np.gradient(xd, r)
    bad = (den <= 0) | (slope <= 0) | (xd / r * slope > MAX_AREA_MAGNIFICATION) | ~np.isfinite(xd)
    if not bad.any():
        return math.inf
    i = max(int(np.argmax(bad)) - 1, 0)
    return f * xd[i]


def rect_norm(px, py, cx, cy, w, h):
    """max over axes of the offset from the principal point over the border's offset that way:
    1 on the image border (pixel centres 0..w-1), 1.05 on the checked margin."""
    bx = np.where(px >= cx, (w - 1 - cx), cx)
    by = np.where(py >= cy, (h - 1 - cy), cy)
    with np.errstate(all='ignore'):
        return np.maximum(np.abs(px - cx) / np.maximum(bx, 1e-9), np.abs(py - cy) / np.maximum(by, 1e-9))


def grid_axis(limit, n, beta):
    """n points on [-limit, limit], dense near 0 (sinh spacing) when beta > 0."""
    u = np.linspace(-1, 1, n)
    if beta <= 0:
        return limit * u
    return limit * np.sinh(beta * u) / math.sinh(beta)


def sample(model, k, intr, size, limit, n, beta):
    """The map on an n x n tensor grid over [-limit, limit]^2 in normalized coordinates."""
    fx, fy, cx, cy = intr
    w, h = size
    a = grid_axis(limit, n, beta)
    x, y = np.meshgrid(a, a)
    domain = EQUIDISTANT_MAX if model == 'kannala-brandt4' else PINHOLE_MAX
    inside = np.hypot(x, y) <= domain
    xd, yd, den = distort(model, k, x, y)
    px, py = fx * xd + cx, fy * yd + cy
    # Jacobian by central differences along the grid (np.gradient uses the true spacing).
    dxdx = np.gradient(xd, a, axis=1)
    dxdy = np.gradient(xd, a, axis=0)
    dydx = np.gradient(yd, a, axis=1)
    dydy = np.gradient(yd, a, axis=0)
    det = dxdx * dydy - dxdy * dydx
    ok = (np.isfinite(px) & np.isfinite(py) & np.isfinite(det) & (det > 0) & (den > 0)
          & (det <= MAX_AREA_MAGNIFICATION) & (x * x + y * y < pole_t(model, k)))
    good = (ok & inside).astype(np.uint8)
    _, labels = cv2.connectedComponents(good, connectivity=4)
    centre = labels[n // 2, n // 2]
    comp = (labels == centre) & (centre != 0)
    # Folds: component cells with a 4-neighbour that fails a check inside the domain.
    bad = ~ok & inside
    nb = np.zeros_like(comp)
    nb[1:, :] |= bad[:-1, :]
    nb[:-1, :] |= bad[1:, :]
    nb[:, 1:] |= bad[:, :-1]
    nb[:, :-1] |= bad[:, 1:]
    fold = comp & nb
    # The end of the projection's range (not a fold, but no pixel beyond is reached).
    out = ~inside
    ob = np.zeros_like(comp)
    ob[1:, :] |= out[:-1, :]
    ob[:-1, :] |= out[1:, :]
    ob[:, 1:] |= out[:, :-1]
    ob[:, :-1] |= out[:, 1:]
    edge_of_range = comp & ob & ~fold
    # The grid's own edge (the sampled box ends): neither.
    box = np.zeros_like(comp)
    box[0, :] = box[-1, :] = box[:, 0] = box[:, -1] = True
    box_edge = comp & box & ~fold & ~edge_of_range
    rn = rect_norm(px, py, cx, cy, w, h)
    dist = np.hypot(px - cx, py - cy)
    return dict(a=a, x=x, y=y, comp=comp, fold=fold, range_end=edge_of_range, box_edge=box_edge,
                rn=rn, dist=dist, spacing=np.diff(a))


def on_valid_branch(model, k, nx, ny):
    """True if the segment from the axis to (nx, ny) crosses no fold (det and denominator > 0),
    checked at 4000 points with a central-difference Jacobian."""
    t = np.linspace(0, 1, 4001)[1:]
    x, y = t * nx, t * ny
    h = 1e-7 * max(1.0, math.hypot(nx, ny))
    if nx * nx + ny * ny >= pole_t(model, k):
        return False
    xa, ya, den = distort(model, k, x + h, y)
    xb, yb, _ = distort(model, k, x - h, y)
    xc, yc, _ = distort(model, k, x, y + h)
    xe, ye, _ = distort(model, k, x, y - h)
    det = ((xa - xb) * (yc - ye) - (xc - xe) * (ya - yb)) / (4 * h * h)
    return bool(np.all(det > 0) & np.all(den > 0))


def analyse(probe, path):
    res = json.load(open(path))
    cam = res['camera']
    model = cam['model']
    k = coefficients(cam)
    intr = (cam['fx'], cam['fy'], cam['cx'], cam['cy'])
    fx, fy, cx, cy = intr
    w, h = res['image_size']
    domain = EQUIDISTANT_MAX if model == 'kannala-brandt4' else PINHOLE_MAX
    # Coarse pass over the whole projection range (dense near the axis), then a fine uniform
    # grid over the part whose pixels lie within 1.5 times the image (where folds matter).
    coarse = sample(model, k, intr, (w, h), domain * 1.001, 2001, 4.0 if model != 'kannala-brandt4' else 0.0)
    near = coarse['comp'] & (coarse['rn'] <= 1.5)
    reach = np.hypot(coarse['x'], coarse['y'])
    limit = min(domain * 1.001, 1.1 * reach[near].max() + 4 * coarse['spacing'].max()) if near.any() else domain
    fine = sample(model, k, intr, (w, h), limit, 2401, 0.0)
    found = []
    for s in (fine, coarse):
        ends = s['fold']
        if ends.any():
            found.append((s['dist'][ends].min(), s['rn'][ends].min()))
    # The fine grid resolves the region that matters; the coarse one only what lies beyond it.
    if fine['fold'].any():
        found = found[:1]
    bf_radius = min((f[0] for f in found), default=math.inf)
    bf_cover = min((f[1] for f in found), default=math.inf)
    # A region ending at the projection's range inside the image: pixels there are never reached.
    range_cover = min(fine['rn'][fine['range_end']].min() if fine['range_end'].any() else math.inf,
                      coarse['rn'][coarse['range_end']].min() if coarse['range_end'].any() else math.inf)
    bf_valid = min(bf_cover, range_cover) >= MARGIN
    # The grid's resolution in pixels near the fold: the allowance for comparing radii.
    step_px = limit * 2 / 2400 * max(fx, fy) * 2

    # The Rust side: the check's answer, its time, and undistorted pixels.
    gx = np.linspace(-0.05 * (w - 1), 1.05 * (w - 1), 49)
    gy = np.linspace(-0.05 * (h - 1), 1.05 * (h - 1), 37)
    pix = [(float(x), float(y)) for y in gy for x in gx]
    text = f"{model} {w} {h} {fx!r} {fy!r} {cx!r} {cy!r} " + ' '.join(repr(float(v)) for v in k[:len(cam['dist_coeffs'])]) + '\n'
    text += ''.join(f'{x!r} {y!r}\n' for x, y in pix)
    out = subprocess.run([probe], input=text, capture_output=True, text=True, check=True).stdout.splitlines()
    v = out[0].split()
    rust_radius, rust_cover, rust_covers, micros = float(v[1]), float(v[3]), v[4] == 'true', float(v[5])
    reported = cam['validity']
    rep_radius = reported['valid_radius_px'] if reported['valid_radius_px'] is not None else math.inf
    warned = any(wn['code'] == 'model-invalid' for wn in res['warnings'])
    undist_fail = wrong_branch = bad_roundtrip = tested = 0
    for line in out[1:]:
        f = line.split()
        x, y = float(f[0]), float(f[1])
        if math.hypot(x - cx, y - cy) >= 0.999 * rep_radius:
            continue
        tested += 1
        if f[2] == 'error':
            undist_fail += 1
            continue
        nx, ny = float(f[2]), float(f[3])
        xd, yd, _ = distort(model, k, np.array([nx]), np.array([ny]))
        if math.hypot(fx * xd[0] + cx - x, fy * yd[0] + cy - y) > 1e-6:
            bad_roundtrip += 1
        elif not on_valid_branch(model, k, nx, ny):
            wrong_branch += 1
    problems = []
    if bf_valid != reported['covers_image']:
        borderline = abs(min(bf_cover, range_cover) - MARGIN) < 0.02
        problems.append(('borderline ' if borderline else '') +
                        ('false negative' if reported['covers_image'] else 'false positive'))
    if warned == reported['covers_image']:
        problems.append('warning disagrees with covers_image')
    if math.isfinite(bf_radius) != math.isfinite(rep_radius):
        # A fold the brute force sees may lie beyond the 4 image radii the check walks.
        if not (math.isfinite(bf_radius) and bf_radius > 3.9 * reported['image_radius_px']):
            problems.append('radius found by one side only')
    elif math.isfinite(bf_radius) and abs(bf_radius - rep_radius) > max(0.01 * bf_radius, step_px):
        problems.append('radius off')
    if undist_fail or wrong_branch or bad_roundtrip:
        problems.append('undistortion')
    if any(p.startswith(('false', 'radius found')) for p in problems):
        problems.append(f"1-D radial map: first failure {radial_first_failure(model, k, min(fx, fy)):.0f} px")
    return dict(name=path.split('/')[-1].removesuffix('.result.json'), model=model, size=f'{w}x{h}',
                rep_radius=rep_radius, bf_radius=bf_radius, image_radius=reported['image_radius_px'],
                rust_cover=rust_cover, bf_cover=min(bf_cover, range_cover), covers=reported['covers_image'],
                bf_valid=bf_valid, warned=warned, tested=tested, undist_fail=undist_fail,
                wrong_branch=wrong_branch, bad_roundtrip=bad_roundtrip, micros=micros,
                step_px=step_px, problems=problems, rms=res['rms'])


def fmt(v, d=0):
    return '-' if not math.isfinite(v) else f'{v:.{d}f}'


def main():
    probe, paths = sys.argv[1], sys.argv[2:]
    print('| case | fit | image | RMS px | reported radius px | brute-force radius px | corner px | coverage (check / brute) | covers / brute | warned | undistorted in radius (fail / wrong branch) | check us | disagreement |')
    print('|---|---|---|---|---|---|---|---|---|---|---|---|---|')
    rows = []
    for p in paths:
        r = analyse(probe, p)
        rows.append(r)
        print(f"| {r['name']} | {r['model']} | {r['size']} | {r['rms']:.3f} | {fmt(r['rep_radius'])} | {fmt(r['bf_radius'])} "
              f"| {r['image_radius']:.0f} | {fmt(r['rust_cover'], 2)} / {fmt(r['bf_cover'], 2)} "
              f"| {'yes' if r['covers'] else 'no'} / {'yes' if r['bf_valid'] else 'no'} | {'yes' if r['warned'] else 'no'} "
              f"| {r['tested']} ({r['undist_fail']} / {r['wrong_branch'] + r['bad_roundtrip']}) | {r['micros']:.0f} "
              f"| {', '.join(r['problems']) or '-'} |", flush=True)
    bad = [r for r in rows if r['problems']]
    print(f"\n{len(rows)} results, {len(bad)} with a disagreement; check time median "
          f"{np.median([r['micros'] for r in rows]):.0f} us, max {max(r['micros'] for r in rows):.0f} us")


if __name__ == '__main__':
    main()
