"""Photographic defects on rendered chessboards: board-detect (`calib detect`) against OpenCV 5,
both compared with the exact corners. See docs/board-detect.md, "Photographic defects".

usage: python defects.py BASEDIR OUTDIR --calib CALIB [--only REGEX] [--no-opencv]
                         [--opencv-from JSONL]

BASEDIR holds boards rendered with their truth by
`cargo run --release -p board-detect --example lens_eval -- pinhole N BASEDIR --save`
(results.jsonl and <name>.png: 1280x960, 9x6 and 8x6 boards, pinhole lens with mild radial
distortion, blur 0.5-1.2 px, noise 1-3 grey levels, lighting gradients). Every defect below is
applied to every base image at three strengths; all of them are photometric or point-symmetric
blurs, so the true corner positions do not move:

  shadow-line     a straight shadow edge (1 px penumbra) across the board, 30/50/70 % darker
  shadow-curve    the edge of a circular shadow (radius 1.5-3 boards) across the board
  glare           a saturated blob (odd images) or streak (even images, 6 x 1 radii) centred
                  on a corner, clipped core radius 0.6/1.2/2 squares, with a halo
  motion          a centred line kernel (point-symmetric) 3/7/15 px long, any direction,
                  then noise 2
  defocus-gauss   Gaussian blur sigma 2/3.5/5 px, then noise 2
  defocus-disc    uniform disc of radius 2/3.5/5 px, then noise 2
  jpeg            JPEG quality 50/30/15 (the image is written as .jpg)
  lowlight        black-to-white contrast 60/45/30 grey levels, noise 8/14/20
  overexpose      gain 1.6/2.5/4 (white clipped, black squares grey)
  occluder        a finger (skin-grey capsule, soft edge, shading) entering from a board side,
                  its tip 1/2/3 squares inside the outer corners
  clutter         outside the board: text / 3 checker patches (other square sizes, rotated) /
                  a second smaller board (5x4 corners, 0.7 of the squares)

Each image is detected by `CALIB detect --board CxR --threads 1` (one run per group and board
size, with a clean copy of a base image first so that the run always writes its file), by cv2.findChessboardCorners (ADAPTIVE_THRESH | NORMALIZE_IMAGE) + cornerSubPix (half
window 0.4 of the shortest corner spacing, clamped to 2..5 px) and by
cv2.findChessboardCornersSB (EXHAUSTIVE | ACCURACY). Outcome per image: found (every corner
within 1 px of its truth and labelled right), refused (with board-detect's reason), or WRONG (a
board returned with some corner more than 1 px from its truth or mislabelled). OpenCV's labels
are accepted up to the 180-degree ambiguity of its ordering; board-detect's must match exactly.
The images are deterministic (seeded by base name, defect and strength): --opencv-from takes
OpenCV's results from an earlier run's defects.jsonl on the same base boards instead of running
it again (for a change to board-detect alone). Writes OUTDIR/defects.jsonl (one line per image and detector) and prints a Markdown table:
per group, found / refused / WRONG for each detector, corner error RMS and max over the found
boards (px) and the median detection time (ms; board-detect's from detection_seconds_per_image,
single thread; OpenCV's measured around its calls, decoding excluded for both).
"""
import argparse, json, os, re, shutil, subprocess, sys, time, zlib
from collections import Counter, defaultdict

import cv2
import numpy as np

LEVELS = {
    'shadow-line': ['30%', '50%', '70%'],
    'shadow-curve': ['30%', '50%', '70%'],
    'glare': ['r0.6', 'r1.2', 'r2'],
    'motion': ['3px', '7px', '15px'],
    'defocus-gauss': ['s2', 's3.5', 's5'],
    'defocus-disc': ['r2', 'r3.5', 'r5'],
    'jpeg': ['q50', 'q30', 'q15'],
    'lowlight': ['c60n8', 'c45n14', 'c30n20'],
    'overexpose': ['g1.6', 'g2.5', 'g4'],
    'occluder': ['1sq', '2sq', '3sq'],
    'clutter': ['text', 'checkers', 'board2'],
}


def grid(truth, cols, rows):
    return np.asarray(truth, float).reshape(rows, cols, 2)


def board_outline(g, grow):
    """Polygon around the board: the outer corners pushed out by `grow` squares (linear
    extrapolation along the rows and columns), as int32 points for cv2.fillPoly."""
    rows, cols = g.shape[:2]
    ring = []
    for c in range(cols):
        ring.append(g[0, c] + grow * (g[0, c] - g[1, c]))
    for r in range(rows):
        ring.append(g[r, cols - 1] + grow * (g[r, cols - 1] - g[r, cols - 2]))
    for c in range(cols - 1, -1, -1):
        ring.append(g[rows - 1, c] + grow * (g[rows - 1, c] - g[rows - 2, c]))
    for r in range(rows - 1, -1, -1):
        ring.append(g[r, 0] + grow * (g[r, 0] - g[r, 1]))
    # Corners of the outline: push the four outer corners diagonally too.
    out = []
    for p in ring:
        out.append(p)
    hull = cv2.convexHull(np.asarray(out, np.float32))
    return hull.reshape(-1, 2)


def spacing(g):
    d1 = np.linalg.norm(np.diff(g, axis=1), axis=2)
    d2 = np.linalg.norm(np.diff(g, axis=0), axis=2)
    return float(min(d1.min(), d2.min())), float(np.median(np.concatenate([d1.ravel(), d2.ravel()])))


def noise(img, sigma, rng):
    return np.clip(img + rng.normal(0, sigma, img.shape), 0, 255)


def line_kernel(length, angle):
    """Point-symmetric motion kernel: samples at t in [-L/2, L/2] (symmetric), bilinear."""
    n = int(np.ceil(length / 2)) + 2
    k = np.zeros((2 * n + 1, 2 * n + 1))
    ts = np.linspace(-length / 2, length / 2, int(length * 8) + 1)
    for t in ts:
        x, y = n + t * np.cos(angle), n + t * np.sin(angle)
        x0, y0 = int(np.floor(x)), int(np.floor(y))
        fx, fy = x - x0, y - y0
        k[y0, x0] += (1 - fx) * (1 - fy)
        k[y0, x0 + 1] += fx * (1 - fy)
        k[y0 + 1, x0] += (1 - fx) * fy
        k[y0 + 1, x0 + 1] += fx * fy
    k = 0.5 * (k + k[::-1, ::-1])  # exactly point-symmetric
    return k / k.sum()


def disc_kernel(radius):
    n = int(np.ceil(radius)) + 1
    s = 8
    ax = (np.arange((2 * n + 1) * s) + 0.5) / s - (n + 0.5)
    xx, yy = np.meshgrid(ax, ax)
    inside = (xx * xx + yy * yy <= radius * radius).astype(float)
    k = inside.reshape(2 * n + 1, s, 2 * n + 1, s).mean(axis=(1, 3))
    return k / k.sum()


def soft_mask(shape, draw, soft):
    m = np.zeros(shape, np.float32)
    draw(m)
    if soft > 0:
        m = cv2.GaussianBlur(m, (0, 0), soft)
    return m


def apply(defect, level, img, g, rng, name):
    """The defective image (float 0..255) and the file extension."""
    h, w = img.shape
    rows, cols = g.shape[:2]
    li = LEVELS[defect].index(level)
    _, sq = spacing(g)
    centre = g.reshape(-1, 2).mean(axis=0)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    if defect in ('shadow-line', 'shadow-curve'):
        dark = [0.3, 0.5, 0.7][li]
        # A point near the board's centre the edge passes through (within a square), any angle.
        p = centre + rng.uniform(-1, 1, 2) * sq
        a = rng.uniform(0, np.pi)
        nrm = np.array([np.cos(a), np.sin(a)])
        if defect == 'shadow-line':
            side = (xx - p[0]) * nrm[0] + (yy - p[1]) * nrm[1]
        else:
            extent = np.linalg.norm(g[0, 0] - g[-1, -1])
            rad = rng.uniform(1.5, 3.0) * extent
            c = p + nrm * rad
            side = rad - np.hypot(xx - c[0], yy - c[1])
        # Penumbra: a 1 px (sigma) smooth step.
        shade = 1.0 - dark / (1.0 + np.exp(np.clip(-side / 0.6, -50, 50)))
        return img * shade, 'png'
    if defect == 'glare':
        r = [0.6, 1.2, 2.0][li] * sq
        k = rng.integers(0, rows * cols)
        p = g.reshape(-1, 2)[k]
        if name_index(name) % 2 == 1:
            d2 = ((xx - p[0]) ** 2 + (yy - p[1]) ** 2) / (r * r)
        else:
            a = rng.uniform(0, np.pi)
            u = (xx - p[0]) * np.cos(a) + (yy - p[1]) * np.sin(a)
            v = -(xx - p[0]) * np.sin(a) + (yy - p[1]) * np.cos(a)
            d2 = (u / (3 * r)) ** 2 + (v / (0.5 * r)) ** 2
        # Saturated inside d2 < 1, a halo falling off outside it.
        add = 400.0 * np.exp(-np.maximum(d2 - 1.0, 0.0) * 1.5) * np.where(d2 < 1, 1.0, 0.6)
        return np.clip(img + add, 0, 255), 'png'
    if defect == 'motion':
        ln = [3, 7, 15][li]
        k = line_kernel(ln, rng.uniform(0, np.pi))
        return noise(cv2.filter2D(img, -1, k, borderType=cv2.BORDER_REFLECT), 2, rng), 'png'
    if defect == 'defocus-gauss':
        s = [2.0, 3.5, 5.0][li]
        return noise(cv2.GaussianBlur(img, (0, 0), s), 2, rng), 'png'
    if defect == 'defocus-disc':
        r = [2.0, 3.5, 5.0][li]
        return noise(cv2.filter2D(img, -1, disc_kernel(r), borderType=cv2.BORDER_REFLECT), 2, rng), 'png'
    if defect == 'jpeg':
        return img, 'jpg'
    if defect == 'lowlight':
        c, n = [(60, 8), (45, 14), (30, 20)][li]
        lo, hi = np.percentile(img, 2), np.percentile(img, 98)
        out = 20 + (img - lo) / (hi - lo) * c
        return noise(out, n, rng), 'png'
    if defect == 'overexpose':
        gain = [1.6, 2.5, 4.0][li]
        return np.clip(img * gain, 0, 255), 'png'
    if defect == 'occluder':
        depth = [1.0, 2.0, 3.0][li]
        # Enter from one side: a corner on the border row/column, tip `depth` squares inside.
        side = rng.integers(0, 4)
        if side == 0:
            e, inward = g[0, rng.integers(1, cols - 1)], g[1, 0] - g[0, 0]
        elif side == 1:
            e, inward = g[-1, rng.integers(1, cols - 1)], g[-2, 0] - g[-1, 0]
        elif side == 2:
            e, inward = g[rng.integers(1, rows - 1), 0], g[0, 1] - g[0, 0]
        else:
            e, inward = g[rng.integers(1, rows - 1), -1], g[0, -2] - g[0, -1]
        u = inward / np.linalg.norm(inward)
        u = u + rng.uniform(-0.3, 0.3) * np.array([-u[1], u[0]])
        u /= np.linalg.norm(u)
        tip = e + u * sq * (depth - 1.0 + 0.3)
        start = tip - u * (max(w, h))
        width = rng.uniform(0.8, 1.4) * sq
        tone = rng.uniform(130, 200)

        def draw(m):
            cv2.line(m, tuple(int(round(v)) for v in start * 16), tuple(int(round(v)) for v in tip * 16),
                     1.0, int(round(width)), lineType=cv2.LINE_AA, shift=4)

        m = soft_mask((h, w), draw, 1.2)
        # Shading across the finger: darker at its sides.
        perp = np.abs((xx - tip[0]) * (-u[1]) + (yy - tip[1]) * u[0]) / (width / 2)
        skin = tone * (1.0 - 0.35 * np.clip(perp, 0, 1) ** 2) + rng.normal(0, 3, (h, w))
        return img * (1 - m) + skin * m, 'png'
    if defect == 'clutter':
        out = img.copy()
        occupied = np.zeros((h, w), np.uint8)
        cv2.fillPoly(occupied, [board_outline(g, 2.5).astype(np.int32)], 1)
        placed = 0

        def place(patch, tries=300):
            nonlocal placed
            ph, pw = patch.shape
            if ph >= h or pw >= w:
                return False
            for _ in range(tries):
                x0, y0 = rng.integers(0, w - pw), rng.integers(0, h - ph)
                if occupied[y0:y0 + ph, x0:x0 + pw].any():
                    continue
                mask = patch >= 0
                region = out[y0:y0 + ph, x0:x0 + pw]
                region[mask] = patch[mask]
                occupied[max(0, y0 - 4):y0 + ph + 4, max(0, x0 - 4):x0 + pw + 4] = 1
                placed += 1
                return True
            return False

        if level == 'text':
            for _ in range(6):
                txt = ''.join(rng.choice(list('ABCDEFGHJKLMNPQRSTUVWXYZ0123456789 #+')) for _ in range(rng.integers(4, 10)))
                scale = rng.uniform(0.8, 2.0)
                (tw, th), base = cv2.getTextSize(txt, cv2.FONT_HERSHEY_SIMPLEX, scale, 2)
                ink = np.zeros((th + base + 6, tw + 6), np.uint8)
                cv2.putText(ink, txt, (3, th + 3), cv2.FONT_HERSHEY_SIMPLEX, scale, 255, 2, cv2.LINE_AA)
                # Dark text on a white label (blended by the ink's coverage).
                a = ink.astype(np.float32) / 255.0
                place(a * float(rng.uniform(0, 50)) + (1 - a) * 230.0)
        else:
            for _ in range(3 if level == 'checkers' else 1):
                if level == 'checkers':
                    n_sq = int(rng.integers(3, 7)), int(rng.integers(3, 7))
                    s = sq * rng.uniform(0.4, 1.5)
                    border = 0.0
                else:
                    n_sq = (6, 5)  # squares: 5x4 inner corners
                    s = sq * 0.7
                    border = 0.6
                pw, ph = int(np.ceil((n_sq[0] + 2 * border) * s)), int(np.ceil((n_sq[1] + 2 * border) * s))
                ss = 4
                yy2, xx2 = np.mgrid[0:ph * ss, 0:pw * ss].astype(np.float32)
                cx, cy = ((xx2 + 0.5) / ss - border * s) / s, ((yy2 + 0.5) / ss - border * s) / s
                inside = (cx >= 0) & (cx < n_sq[0]) & (cy >= 0) & (cy < n_sq[1])
                val = np.where(inside & ((np.floor(cx) + np.floor(cy)) % 2 == 0), 30.0, 215.0)
                val = val.reshape(ph, ss, pw, ss).mean(axis=(1, 3)).astype(np.float32)
                # Rotate by a random angle about the patch centre, with a white background.
                ang = rng.uniform(0, 360) if level == 'checkers' else rng.uniform(-30, 30)
                diag = int(np.ceil(np.hypot(pw, ph))) + 2
                canvas = np.full((diag, diag), -1.0, np.float32)
                oy, ox = (diag - ph) // 2, (diag - pw) // 2
                canvas[oy:oy + ph, ox:ox + pw] = val
                mm = cv2.getRotationMatrix2D((diag / 2, diag / 2), ang, 1.0)
                rot = cv2.warpAffine(canvas, mm, (diag, diag), flags=cv2.INTER_LINEAR, borderValue=-1.0)
                valid = cv2.warpAffine((canvas >= 0).astype(np.float32), mm, (diag, diag), flags=cv2.INTER_NEAREST)
                rot[valid < 0.5] = -1.0
                place(rot)
        return noise(out, 1.0, rng), 'png'
    raise ValueError(defect)


def name_index(name):
    return int(name.rsplit('-', 1)[1])


def match_any_order(found, truth):
    """OpenCV: errors in its order or the 180-degree reversed order, whichever labels right."""
    f = np.asarray(found, float).reshape(-1, 2)
    t = np.asarray(truth, float)
    best = None
    for cand in (f, f[::-1]):
        e = np.linalg.norm(cand - t, axis=1)
        if best is None or e.max() < best.max():
            best = e
    return best


def outcome(errors):
    if errors is None:
        return 'refused'
    return 'found' if errors.max() <= 1.0 else 'WRONG'


def reason_key(reason):
    """The reason without its numbers: 'partial board', 'not a clean crossing', ..."""
    r = re.sub(r'^corner \d+ is ', '', reason)
    r = r.split(':')[0].split('(')[0].strip()
    return r[:40]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('basedir')
    ap.add_argument('outdir')
    ap.add_argument('--calib', required=True)
    ap.add_argument('--only', default='')
    ap.add_argument('--no-opencv', action='store_true')
    ap.add_argument('--opencv-from', help="an earlier run's defects.jsonl (same base boards)")
    a = ap.parse_args()
    cv2.setNumThreads(1)
    base = [json.loads(l) for l in open(os.path.join(a.basedir, 'results.jsonl'))]
    os.makedirs(a.outdir, exist_ok=True)
    earlier = {}
    if a.opencv_from:
        for line in open(a.opencv_from):
            r = json.loads(line)
            if 'cv' in r:
                earlier[(r['group'], r['name'])] = r
    res_path = os.path.join(a.outdir, 'defects.jsonl')
    res_file = open(res_path, 'w')
    table = []
    for defect, levels in LEVELS.items():
        for level in levels:
            group = f'{defect} {level}'
            if a.only and not re.search(a.only, group):
                continue
            gdir = os.path.join(a.outdir, 'imgs', f'{defect}-{level}')
            os.makedirs(gdir, exist_ok=True)
            items = []
            for b in base:
                img = cv2.imread(os.path.join(a.basedir, b['name'] + '.png'), cv2.IMREAD_GRAYSCALE).astype(np.float32)
                g = grid(b['truth'], b['cols'], b['rows'])
                seed = zlib.crc32(f"{b['name']} {defect} {level}".encode())
                rng = np.random.default_rng(seed)
                out, ext = apply(defect, level, img, g, rng, b['name'])
                u8 = np.clip(np.round(out), 0, 255).astype(np.uint8)
                path = os.path.join(gdir, f"{b['name']}.{ext}")
                if ext == 'jpg':
                    q = int(level[1:])
                    cv2.imwrite(path, u8, [cv2.IMWRITE_JPEG_QUALITY, q])
                else:
                    cv2.imwrite(path, u8)
                items.append((b, path))
            # board-detect through the CLI, one run per board size.
            ours = {}
            times = []
            for size in sorted({(b['cols'], b['rows']) for b, _ in items}):
                paths = [p for b, p in items if (b['cols'], b['rows']) == size]
                # A clean image of the board first, so that the run writes its file (and every
                # other image's reason) even when no defective image has a board.
                sentinel = os.path.join(gdir, f'sentinel-{size[0]}x{size[1]}.png')
                first = next(b for b, _ in items if (b['cols'], b['rows']) == size)
                shutil.copyfile(os.path.join(a.basedir, first['name'] + '.png'), sentinel)
                paths = [sentinel] + paths
                obs = os.path.join(gdir, f'obs-{size[0]}x{size[1]}.json')
                r = subprocess.run([a.calib, 'detect', '--board', f'{size[0]}x{size[1]}', '--square', '1',
                                    '--threads', '1', '-o', obs] + paths, capture_output=True, text=True)
                if r.returncode != 0:
                    sys.exit(f'calib detect failed: {r.stderr}')
                d = json.load(open(obs))
                times.append((d.get('detection_seconds_per_image') or 0.0) * 1e3)
                for v in d['views']:
                    ours[v['image']] = ('ok', np.asarray(v['image_points'], float), None)
                for rj in d.get('rejected_images', []):
                    ours[rj['image']] = ('refused', None, rj['reason'])
            rows = []
            for b, path in items:
                truth = np.asarray(b['truth'], float)
                fname = os.path.basename(path)
                st, pts, reason = ours.get(fname, ('refused', None, 'missing from the output'))
                e = None if pts is None else np.linalg.norm(pts - truth, axis=1)
                rec = {'group': group, 'defect': defect, 'level': level, 'name': b['name'], 'image': path,
                       'ours': {'outcome': outcome(e), 'reason': reason,
                                'err': None if e is None else e.tolist(),
                                'corners': None if pts is None else pts.tolist()}}
                if (group, b['name']) in earlier:
                    rec['cv'] = earlier[(group, b['name'])]['cv']
                    rec['sb'] = earlier[(group, b['name'])]['sb']
                elif not a.no_opencv:
                    img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
                    size = (b['cols'], b['rows'])
                    hw = int(max(2, min(5, round(0.4 * b['min_spacing']))))
                    t0 = time.perf_counter()
                    ok, c = cv2.findChessboardCorners(img, size, cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
                    if ok:
                        c = cv2.cornerSubPix(img, c, (hw, hw), (-1, -1),
                                             (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01))
                    ms = (time.perf_counter() - t0) * 1e3
                    e = match_any_order(c, truth) if ok else None
                    rec['cv'] = {'outcome': outcome(e), 'ms': ms, 'err': None if e is None else e.tolist()}
                    t0 = time.perf_counter()
                    ok, c = cv2.findChessboardCornersSB(img, size, cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY)
                    ms = (time.perf_counter() - t0) * 1e3
                    e = match_any_order(c, truth) if ok else None
                    rec['sb'] = {'outcome': outcome(e), 'ms': ms, 'err': None if e is None else e.tolist()}
                res_file.write(json.dumps(rec) + '\n')
                res_file.flush()
                rows.append(rec)
            table.append((group, rows, float(np.median(times)) if times else float('nan')))
            print(summary_line(group, rows, table[-1][2]), flush=True)
    print()
    print('| defect | strength | board-detect found / refused / WRONG | RMS / max (px) | ms | reasons | '
          'OpenCV classic found / WRONG | RMS / max | ms | OpenCV SB found / WRONG | RMS / max | ms |')
    print('|---|---|---|---|---|---|---|---|---|---|---|---|')
    for group, rows, ms in table:
        print(summary_line(group, rows, ms, markdown=True))
    print(f'\nper-image results: {res_path}')


def stats(rows, key):
    n = len(rows)
    oc = Counter(r[key]['outcome'] for r in rows)
    errs = [np.asarray(r[key]['err']) for r in rows if r[key]['outcome'] == 'found']
    if errs:
        e = np.concatenate(errs)
        acc = f'{np.sqrt(np.mean(e * e)):.3f} / {e.max():.2f}'
    else:
        acc = '-'
    return n, oc, acc


def summary_line(group, rows, ms_ours, markdown=False):
    defect, level = group.split(' ')
    n, oc, acc = stats(rows, 'ours')
    reasons = Counter(reason_key(r['ours']['reason']) for r in rows if r['ours']['outcome'] == 'refused')
    rs = ', '.join(f'{k} {v}' for k, v in reasons.most_common())
    wrong = f"**{oc['WRONG']}**" if oc['WRONG'] and markdown else str(oc['WRONG'])
    cells = [defect, level, f"{oc['found']}/{n} / {oc['refused']} / {wrong}", acc, f'{ms_ours:.1f}', rs or '-']
    for key in ('cv', 'sb'):
        if key in rows[0]:
            _, o2, acc2 = stats(rows, key)
            ms = float(np.median([r[key]['ms'] for r in rows]))
            w2 = f"**{o2['WRONG']}**" if o2['WRONG'] and markdown else str(o2['WRONG'])
            cells += [f"{o2['found']}/{n} / {w2}", acc2, f'{ms:.0f}']
    if markdown:
        return '| ' + ' | '.join(cells) + ' |'
    return '  '.join(cells)


if __name__ == '__main__':
    main()
