"""Photographs-to-calibration check on a set rendered by the board-detect example render_set:
`calib detect` and `calib single --board` on its images, against its truth.json (z = (estimate -
truth) / reported sigma; "exp_rms" is the detector's corner error against the exact corners times
sqrt((2N - p) / 2N)); with --opencv also findChessboardCorners + cornerSubPix and
cv2.fisheye.calibrate / cv2.calibrateCamera on the same images. One JSON line per set.
Usage (repository root, after cargo build --release -p calib-cli and
cargo run --release -p board-detect --example render_set -- kb DIR --seed S):
    [CALIB=path/to/calib] python benches/detect/render_set_compare.py DIR [--opencv]
(--opencv needs cv2 5 and numpy, e.g. the venv of benches/detect/run.sh)."""
import json, subprocess, sys, math, os
import numpy as np
CALIB = os.environ.get("CALIB", "target/release/calib")
d = sys.argv[1]
truth = json.load(open(f'{d}/truth.json'))
cam = truth['camera']
model = cam['model']
imgs = [f"{d}/{v['image']}" for v in truth['views']]
subprocess.run([CALIB, 'detect', '--board', '9x6', *imgs, '-o', f'{d}/obs.json', '-q'], check=True)
obs = json.load(open(f'{d}/obs.json'))
tv = {v['image']: v for v in truth['views']}
errs = []
radial = []
for v in obs['views']:
    t = np.array(tv[v['image']]['corners']); p = np.array(v['image_points'])
    e = p - t; errs.append(e)
    r = t - [cam['cx'], cam['cy']]; rn = r / np.linalg.norm(r, axis=1, keepdims=True)
    radial.append((e * rn).sum(1))
errs = np.concatenate(errs); radial = np.concatenate(radial)
det_rms = math.sqrt((errs ** 2).sum(1).mean())
p = subprocess.run([CALIB, 'single', '--board', '9x6', '--square', '1', '--model', model, *imgs, '-o', f'{d}/out.json'], capture_output=True, text=True)
if p.returncode != 0:
    print(d, 'FAILED', p.stderr[-2000:]); sys.exit(1)
out = json.load(open(f'{d}/out.json'))
c = out['camera']; s = c['std']
names = ['fx', 'fy', 'cx', 'cy']
z = {n: (c[n] - cam[n]) / s[n] for n in names}
kn = ['k1', 'k2', 'k3', 'k4'] if model == 'kannala-brandt4' else ['k1', 'k2', 'p1', 'p2', 'k3']
for i, n in enumerate(kn):
    z[n] = (c['dist_coeffs'][i] - cam['dist_coeffs'][i]) / s['dist_coeffs'][i] if s['dist_coeffs'][i] > 0 else float('nan')
N = out['num_points']; P = len(names) + len(kn) + 6 * out['num_views']
exp_rms = det_rms * math.sqrt((2 * N - P) / (2 * N))
warn = [w['code'] for w in out['warnings']]
rej = [(r['image'], r['reason']) for r in out.get('rejected_images', [])]
row = dict(dir=d, fov=cam.get('field_of_view_deg'), fx=cam['fx'], found=len(obs['views']), rejected=len(rej),
           rms=out['rms'], det_rms=det_rms, exp_rms=exp_rms, radial_bias=float(radial.mean()),
           z={k: round(v, 2) for k, v in z.items()}, maxz=max(abs(v) for v in z.values() if v == v),
           warnings=warn, rejections=rej, dfx=c['fx'] - cam['fx'], sfx=s['fx'])
if '--opencv' in sys.argv:
    import cv2
    objp = np.zeros((54, 3)); objp[:, :2] = np.mgrid[0:9, 0:6].T.reshape(-1, 2)
    O, I, used = [], [], 0
    for v in truth['views']:
        g = cv2.imread(f"{d}/{v['image']}", 0)
        ok, cr = cv2.findChessboardCorners(g, (9, 6), flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
        if not ok: continue
        cr = cv2.cornerSubPix(g, cr, (5, 5), (-1, -1), (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3))
        O.append(objp.reshape(1, -1, 3).astype(np.float64)); I.append(cr.reshape(1, -1, 2).astype(np.float64))
    K = np.eye(3); D = np.zeros((4, 1))
    try:
        if model == 'kannala-brandt4':
            fl = cv2.CALIB_RECOMPUTE_EXTRINSIC | cv2.CALIB_FIX_SKEW
            crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
            try:
                rms, K, D, _, _ = cv2.fisheye.calibrate(O, I, (1280, 960), np.eye(3), np.zeros((4, 1)), flags=fl, criteria=crit)
                row['opencv_start'] = 'default'
            except cv2.error:
                # OpenCV 5's own start fails (InitExtrinsics norm_u1 assertion): a generic
                # equidistant guess, f = width / pi, centre of the image.
                K0 = np.array([[1280 / np.pi, 0, 639.5], [0, 1280 / np.pi, 479.5], [0, 0, 1]])
                rms, K, D, _, _ = cv2.fisheye.calibrate(O, I, (1280, 960), K0, np.zeros((4, 1)), flags=fl | cv2.CALIB_USE_INTRINSIC_GUESS, criteria=crit)
                row['opencv_start'] = 'guess f=w/pi'
        else:
            rms, K, D, _, _ = cv2.calibrateCamera([o.reshape(-1, 3).astype(np.float32) for o in O], [i.reshape(-1, 2).astype(np.float32) for i in I], (1280, 960), None, None)
        row['opencv'] = dict(found=len(O), rms=rms, fx=K[0, 0], dfx=K[0, 0] - cam['fx'], dcx=K[0, 2] - cam['cx'], dcy=K[1, 2] - cam['cy'], D=np.ravel(D).round(5).tolist())
    except cv2.error as e:
        row['opencv'] = dict(found=len(O), error=str(e)[:200])
print(json.dumps(row))
