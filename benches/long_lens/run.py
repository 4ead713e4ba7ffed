"""Run a population of long-lens captures (gen.py) through `calib single` and OpenCV.

    python run.py NAME SEEDS 'json-of-gen.gen-args' [--cv] [--nf] [--extra="calib options"]

--cv compares with cv2.calibrateCamera on the same corners, --nf adds a noise-free twin of each
file; TRUTHSTART=1 also solves from the true camera. Writes $OUT/res/NAME.jsonl (OUT defaults
to ./long_lens_out), one record per seed, and prints a summary line: refusals, warnings, z RMS
of fx, fy, cx, cy, k1, noise-free recovery, and the minimum against OpenCV's.
CALIB names the binary (default target/release/calib).
"""
import json, math, os, subprocess, sys, argparse
import numpy as np
from multiprocessing import Pool
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gen import gen

CALIB = os.environ.get('CALIB', 'target/release/calib')
OUT = os.environ.get('OUT', 'long_lens_out')
W = f'{OUT}/tmp'
EXTRA = []
os.makedirs(W, exist_ok=True)
os.makedirs(f'{OUT}/res', exist_ok=True)


def run_calib(path, out, extra):
    p = subprocess.run([CALIB, 'single', path, '-o', out, '-q', '--threads', '1'] + extra,
                       capture_output=True, text=True)
    if p.returncode != 0:
        return None, p.stderr.strip()
    return json.load(open(out)), p.stderr.strip()


def opencv(d, model):
    import cv2
    Wd, Hd = d['image_size']
    obj = [np.array(v['object_points'], np.float32) for v in d['views']]
    img = [np.array(v['image_points'], np.float32).reshape(-1, 1, 2) for v in d['views']]
    flags = cv2.CALIB_FIX_K3 if model == 'brown-conrady4' else 0
    if '--fix-principal-point' in EXTRA:
        flags |= cv2.CALIB_FIX_PRINCIPAL_POINT
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 1000, 1e-16)
    try:
        ret = cv2.calibrateCameraExtended(obj, img, (Wd, Hd), None, None, flags=flags, criteria=crit)
    except cv2.error as e:
        return {'error': str(e)[:200]}
    rms32, K, dist, rv, tv, sdi, sde, pve = ret
    se = 0.0
    n = 0
    for v, r, t in zip(d['views'], rv, tv):
        o = np.array(v['object_points'], np.float64)
        m = np.array(v['image_points'], np.float64)
        p, _ = cv2.projectPoints(o, r.astype(np.float64), t.astype(np.float64), K, dist)
        se += np.sum((p.reshape(-1, 2) - m) ** 2)
        n += len(m)
    return {'rms': math.sqrt(se / n), 'fx': K[0, 0], 'fy': K[1, 1], 'cx': K[0, 2], 'cy': K[1, 2],
            'k1': float(dist.ravel()[0]), 'sd': sdi.ravel()[:5].tolist()}


def one(job):
    name, seed, gargs, extra, do_cv, noise_free = job
    g = dict(gargs)
    d = gen(seed=seed, **g)
    tr = d['truth']
    path = f'{W}/{name}_{seed}.json'
    json.dump(d, open(path, 'w'))
    rec = {'seed': seed, 'truth': {k: tr[k] for k in ('fx', 'fy', 'cx', 'cy')}, 'k1': tr['distortion'][0]}
    res, err = run_calib(path, path + '.out', extra)
    if res is None:
        rec['refused'] = err
    else:
        cam = res['camera']
        sd = cam['std']
        z = {}
        for k in ('fx', 'fy', 'cx', 'cy'):
            z[k] = (cam[k] - tr[k]) / sd[k] if sd[k] > 0 else 0.0
        if 'k1' in cam['distortion'] and sd['distortion'].get('k1', 0) > 0:
            z['k1'] = (cam['distortion']['k1'] - tr['distortion'][0]) / sd['distortion']['k1']
        rec.update(z=z, est={k: cam[k] for k in ('fx', 'fy', 'cx', 'cy')}, k1e=cam['distortion'].get('k1'),
                   sd={k: sd[k] for k in ('fx', 'fy', 'cx', 'cy')}, sdk1=sd['distortion'].get('k1'),
                   warn=[(w['code'], w['message']) for w in res['warnings']], rms=res['rms'],
                   nrej=res['num_rejected'], term=res['solver']['termination_code'],
                   iters=res['solver']['iterations'], init=res['initial']['method'],
                   any_nan=any(isinstance(x, float) and math.isnan(x) for x in [cam['fx'], cam['fy'], cam['cx'], cam['cy']]))
    if os.environ.get('TRUTHSTART') and res is not None:
        tr_ = d['truth']
        g_ = f"{tr_['fx']},{tr_['fy']},{tr_['cx']},{tr_['cy']}"
        dg = ','.join(str(v) for v in tr_['distortion'])
        rt, _ = run_calib(path, path + '.ts', extra + ['--guess=' + g_, '--distortion-guess=' + dg])
        if rt is not None:
            rec['ts_rms'] = rt['rms']
            rec['ts_est'] = {k: rt['camera'][k] for k in ('fx', 'fy', 'cx', 'cy')}
            rec['ts_z'] = {k: (rt['camera'][k] - tr_[k]) / rt['camera']['std'][k] for k in ('fx', 'fy', 'cx', 'cy')}
    if noise_free:
        g0 = dict(g)
        g0['noise'] = 0.0
        d0 = gen(seed=seed, **g0)
        p0 = f'{W}/{name}_{seed}_nf.json'
        json.dump(d0, open(p0, 'w'))
        r0, e0 = run_calib(p0, p0 + '.out', extra)
        if r0 is None:
            rec['nf_refused'] = e0
        else:
            c0 = r0['camera']
            rec['nf_rel'] = max(abs(c0[k] - tr[k]) / tr['fx'] for k in ('fx', 'fy', 'cx', 'cy'))
            rec['nf_term'] = r0['solver']['termination_code']
            rec['nf_rms'] = r0['rms']
        os.remove(p0)
        if os.path.exists(p0 + '.out'):
            os.remove(p0 + '.out')
    if do_cv:
        model = extra[extra.index('--model') + 1] if '--model' in extra else 'brown-conrady4'
        global EXTRA
        EXTRA = extra
        cvr = opencv(d, model)
        rec['cv'] = cvr
        if 'sd' in cvr and cvr['sd'][0] > 0:
            rec['cv_z'] = {k: (cvr[k] - tr[k]) / s for k, s in zip(('fx', 'fy', 'cx', 'cy'), cvr['sd'][:4]) if s > 0}
    return rec


def summary(name, recs):
    n = len(recs)
    ref = [r for r in recs if 'refused' in r]
    ok = [r for r in recs if 'refused' not in r]
    warned = [r for r in ok if any(c == 'poorly-determined' for c, _ in r['warn'])]
    other_w = {}
    for r in ok:
        for c, _ in r['warn']:
            other_w[c] = other_w.get(c, 0) + 1
    zs = {k: np.array([r['z'][k] for r in ok if k in r['z']]) for k in ('fx', 'fy', 'cx', 'cy', 'k1')}
    zall = np.concatenate([v for v in zs.values() if len(v)]) if ok else np.array([0.0])
    zrms = {k: float(np.sqrt(np.mean(v ** 2))) if len(v) else float('nan') for k, v in zs.items()}
    silent = [r for r in ok if r not in warned]
    zs_sil = np.concatenate([[r['z'][k] for k in r['z']] for r in silent]) if silent else np.array([0.0])
    maxz = float(np.max(np.abs(zall))) if len(zall) else 0
    nonconv = [r['seed'] for r in ok if r['term'] not in ('function_tolerance', 'gradient_tolerance', 'step_tolerance', 'parameter_tolerance')]
    line = (f'{name}: n={n} refused={len(ref)} warned(pd)={len(warned)} warns={other_w} '
            f'maxz={maxz:.2f} zrms=' + ' '.join(f'{k}:{v:.2f}' for k, v in zrms.items()) +
            f' zrms_silent={np.sqrt(np.mean(zs_sil**2)):.2f} nonconv={nonconv[:5]}')
    nf = [r['nf_rel'] for r in recs if 'nf_rel' in r]
    if nf:
        line += f' nf_rel_max={max(nf):.1e} nf_refused={sum("nf_refused" in r for r in recs)}'
    cvd = [r['cv']['rms'] - r['rms'] for r in ok if 'cv' in r and 'rms' in r['cv'] and r['nrej'] == 0]
    if cvd:
        worse = sum(x < -1e-6 for x in cvd)
        line += f' cv: ours_lower={sum(x > 1e-6 for x in cvd)} same={sum(abs(x) <= 1e-6 for x in cvd)} ours_higher={worse} cv_err={sum("error" in r["cv"] for r in recs if "cv" in r)}'
        cz = np.concatenate([[v for v in r['cv_z'].values()] for r in ok if 'cv_z' in r] or [[0]])
        line += f' cv_zrms={np.sqrt(np.mean(cz**2)):.2f} cv_maxz={np.max(np.abs(cz)):.1f}'
    ts = [r['ts_rms'] - r['rms'] for r in ok if 'ts_rms' in r]
    if ts:
        line += f' truthstart: lower={sum(x < -1e-6 for x in ts)} higher={sum(x > 1e-6 for x in ts)} min_diff={min(ts):.1e}'
    big = [(r['seed'], {k: round(v, 1) for k, v in r['z'].items() if abs(v) > 5}) for r in ok if any(abs(v) > 5 for v in r['z'].values())]
    if big:
        line += f' bigz={big[:6]}'
    return line


if __name__ == '__main__':
    ap = argparse.ArgumentParser()
    ap.add_argument('name')
    ap.add_argument('seeds', type=int)
    ap.add_argument('gargs')
    ap.add_argument('--cv', action='store_true')
    ap.add_argument('--nf', action='store_true')
    ap.add_argument('--extra', default='')
    ap.add_argument('--procs', type=int, default=2)
    a = ap.parse_args()
    extra = a.extra.split() if a.extra else []
    jobs = [(a.name, s, json.loads(a.gargs), extra, a.cv, a.nf) for s in range(1, a.seeds + 1)]
    with Pool(a.procs) as p:
        recs = p.map(one, jobs)
    with open(f'{OUT}/res/{a.name}.jsonl', 'w') as f:
        for r in recs:
            f.write(json.dumps(r, default=float) + '\n')
    print(summary(a.name, recs), flush=True)
