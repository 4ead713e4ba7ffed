"""OpenCV 5 on the images written by `lens_eval --save`: findChessboardCorners + cornerSubPix
(half window from the square size) and findChessboardCornersSB, against the truth; and the
same statistics for board-detect from results.jsonl.
usage: python opencv_lens_eval.py DIR [DIR...]  (with cv2 5 and numpy, e.g. the venv of
benches/detect/run.sh: benches/detect/.venv/bin/python; docs/board-detect.md, "Fisheye,
wide-angle and small squares")"""
import json, sys, time, os
import numpy as np, cv2

def match(found, truth, cols, rows):
    """(label_ok, errors). OpenCV's order may be the 180-degree rotation of ours: accept both."""
    f = np.asarray(found, float).reshape(-1, 2); t = np.asarray(truth, float)
    best = None
    for cand in (f, f[::-1]):
        d = np.linalg.norm(cand[:, None, :] - t[None, :, :], axis=2)
        ok = bool(np.all(np.argmin(d, axis=1) == np.arange(len(t))))
        e = np.linalg.norm(cand - t, axis=1)
        if ok and (best is None or e.max() < best[1].max()):
            best = (True, e)
    if best is None:
        return False, None
    return best

def stats(rows, key):
    n = len(rows); ok = [r for r in rows if r[key]['ok']]; wrong = [r for r in rows if r[key]['wrong']]
    e = np.concatenate([r[key]['err'] for r in ok]) if ok else np.array([np.nan])
    t = np.array([r[key]['ms'] for r in rows])
    return f"{len(ok)}/{n} wrong {len(wrong)} | err med {np.median(e):.3f} p95 {np.percentile(e,95):.3f} max {e.max():.3f} | ms med {np.median(t):.1f}"

out = {}
for d in sys.argv[1:]:
    for line in open(os.path.join(d, 'results.jsonl')):
        r = json.loads(line)
        path = os.path.join(d, r['name'] + '.png')
        if not os.path.exists(path):
            continue
        img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        cols, rows = r['cols'], r['rows']
        truth = r['truth']
        res = {}
        ours = {'ok': False, 'wrong': False, 'err': None, 'ms': r['ms'], 'status': r['status']}
        if r['status'] == 'ok':
            ok, e = match(r['corners'], truth, cols, rows)
            # ours must match in its own order (no 180-degree freedom)
            e2 = np.linalg.norm(np.asarray(r['corners']) - np.asarray(truth), axis=1)
            ours.update(ok=r['label_ok'], wrong=not r['label_ok'], err=e2)
        res['ours'] = ours
        sp = r['min_spacing']
        hw = int(max(2, min(5, round(0.4 * sp))))
        t0 = time.perf_counter()
        found, c = cv2.findChessboardCorners(img, (cols, rows), cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
        if found:
            c = cv2.cornerSubPix(img, c, (hw, hw), (-1, -1), (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01))
        ms = (time.perf_counter() - t0) * 1e3
        cv = {'ok': False, 'wrong': False, 'err': None, 'ms': ms}
        if found:
            ok, e = match(c, truth, cols, rows)
            cv.update(ok=ok, wrong=not ok, err=e)
        res['cv'] = cv
        t0 = time.perf_counter()
        found, c = cv2.findChessboardCornersSB(img, (cols, rows), cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY)
        ms = (time.perf_counter() - t0) * 1e3
        sb = {'ok': False, 'wrong': False, 'err': None, 'ms': ms}
        if found:
            ok, e = match(c, truth, cols, rows)
            sb.update(ok=ok, wrong=not ok, err=e)
        res['sb'] = sb
        res['name'] = r['name']
        out.setdefault(r['population'], []).append(res)
for pop, rows in out.items():
    for key, label in (('ours', 'board-detect'), ('cv', 'cv2 classic+subpix'), ('sb', 'cv2 SB')):
        print(f"{pop:12s} {label:20s} {stats(rows, key)}")
    for r in rows:
        if r['ours']['wrong']:
            print('  WRONG LABEL (ours):', r['name'])
        if not r['ours']['ok'] and not r['ours']['wrong']:
            print('  refused (ours):', r['name'], r['ours']['status'][:150], '| cv', r['cv']['ok'], 'sb', r['sb']['ok'])
