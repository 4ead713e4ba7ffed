#!/usr/bin/env python3
"""mrcal side of the mrcal comparison (benches/mrcal/run.sh). Run it with Debian's python3, which
has python3-mrcal; set OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 before it starts (run.sh does).

    mrcal_peer.py solve FILE --model MODEL --settings {comparable,default} [--repeats N] [--focal F]
        Calibrate the observation file FILE (calib's single-camera format) with mrcal, the way
        mrcal-calibrate-cameras does it, R times in this process; print a JSON result.
    mrcal_peer.py ours FILE RESULT.json [--polish]
        Evaluate our calib result (its intrinsics, distortion and view poses) on every point of
        FILE with mrcal's own projection (mrcal.project); print a JSON result. A model check: it
        must reproduce our reported rms_all_points. --polish: also start mrcal's optimizer
        (regularization off, every point, flat board) at our solution (untimed) and report
        where it ends: a lower cost there means our solve stopped early.
    mrcal_peer.py report OUT_DIR MANIFEST --command CMD --calib-rev REV
        Print the Markdown tables from OUT_DIR.

MODEL is our name: brown-conrady4 (LENSMODEL_OPENCV4: k1 k2 p1 p2), brown-conrady5
(LENSMODEL_OPENCV5: k1 k2 p1 p2 k3), rational8 (LENSMODEL_OPENCV8: k1 k2 p1 p2 k3 k4 k5 k6).
Both tools use the same parameter order and OpenCV's pixel convention ((0,0) = centre of the
top-left pixel; mrcal's seed puts the centre at ((W-1)/2, (H-1)/2), the same convention).

Settings, following mrcal-calibrate-cameras (mrcal 2.2) step by step:
  common: mrcal.seed_stereographic(focal_estimate=F) -> optimize LENSMODEL_STEREOGRAPHIC, geometry
          only -> optimize with its core -> widen the intrinsics to MODEL (new distortion terms
          random in +-1e-6, the rational denominator's k4..k6 1e-3 of that; np.random seeded 0)
          -> optimize everything with regularization (outlier rejection per setting).
  default:    that optimize with outlier rejection on, then the final optimize with the board
              warp (calobject_warp) solved too, regularization and outlier rejection on: what
              `mrcal-calibrate-cameras --lensmodel MODEL --focal F ...` runs.
  comparable: that optimize with outlier rejection off, then once more with regularization off
              (what --skip-regularization adds), no board warp: what
              `mrcal-calibrate-cameras --skip-regularization --skip-outlier-rejection
              --skip-calobject-warp-solve` runs. Every point used, a flat board, plain least
              squares: the problem calib --no-outlier-rejection solves.
F (--focal): mrcal needs a focal-length guess in pixels (mrcal-calibrate-cameras --focal is
required); default: the image width.

Timing: one untimed warm-up run (mrcal's seed imports cv2 on first use), then
time.perf_counter() around the whole sequence above (seed and every optimize), not the
JSON parsing nor the building of the observation arrays; per repeat from fresh copies, so every
repeat does the same work. The solution is then evaluated (untimed) on every point with
mrcal.project and mrcal's own board (warped by its calobject_warp in the default setting).
"""

import argparse
import datetime
import glob
import json
import os
import platform
import re
import statistics
import sys
import time

import numpy as np

MODELS = {
    "brown-conrady4": "LENSMODEL_OPENCV4",
    "brown-conrady5": "LENSMODEL_OPENCV5",
    "rational8": "LENSMODEL_OPENCV8",
}


def threads_now():
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        return None


def load_problem(path):
    """The observation file as mrcal arrays: observations (Nviews, H, W, 3) with weight 1 for a
    corner seen and -1 for a corner absent from the view; board dims and spacing."""
    d = json.load(open(path))
    views = d["views"]
    board = d.get("board") or {}
    square = board.get("square")
    if square is None:  # infer: the smallest non-zero coordinate step
        xs = np.unique(np.abs(np.concatenate([np.asarray(v["object_points"])[:, :2].ravel()
                                              for v in views])))
        square = float(xs[xs > 0].min())
    idx = []
    for v in views:
        op = np.asarray(v["object_points"], dtype=float)
        if op.shape[1] != 3 or np.max(np.abs(op[:, 2])) > 1e-9:
            raise SystemExit(f"{path}: object points must be (X, Y, 0)")
        c = op[:, 0] / square
        r = op[:, 1] / square
        ci, ri = np.rint(c).astype(int), np.rint(r).astype(int)
        if np.max(np.abs(c - ci)) > 1e-9 or np.max(np.abs(r - ri)) > 1e-9 or ci.min() < 0 or ri.min() < 0:
            raise SystemExit(f"{path}: object points are not on the {square} grid from (0, 0)")
        idx.append((ri, ci))
    W = int(board.get("cols") or max(ci.max() for _, ci in idx) + 1)
    H = int(board.get("rows") or max(ri.max() for ri, _ in idx) + 1)
    obs = np.zeros((len(views), H, W, 3))
    obs[..., 2] = -1.0
    for i, (v, (ri, ci)) in enumerate(zip(views, idx)):
        ip = np.asarray(v["image_points"], dtype=float)
        obs[i, ri, ci, :2] = ip
        obs[i, ri, ci, 2] = 1.0
    w, h = d["image_size"]
    return obs, W, H, float(square), (int(w), int(h)), d


def expand_intrinsics(lensmodel, intrinsics_data, mrcal, rng):
    """mrcal-calibrate-cameras' expand_intrinsics (mrcal 2.2), with a seeded generator."""
    n_new = mrcal.lensmodel_num_params(lensmodel) - intrinsics_data.shape[-1]
    new = (rng.random((intrinsics_data.shape[0], n_new)) - 0.5) * 2.0 * 1e-6
    m = re.search("OPENCV([0-9]+)", lensmodel)
    if m and int(m.group(1)) >= 8:
        # As written in mrcal-calibrate-cameras 2.2: this indexes the first axis (cameras) of
        # the (Ncameras, n) array, so with one camera it changes nothing; kept as the tool has it.
        new[5:8] *= 1e-3
    return np.concatenate((intrinsics_data, new), axis=-1)


def calibrate(mrcal, obs, W, H, square, imagersize, lensmodel, settings, focal, snapshot=None):
    """One full calibration as mrcal-calibrate-cameras runs it. Returns (inputs, stats, stages).
    With a dict `snapshot` (untimed runs only), stores in it the state before the last step: the
    regularized solve (comparable) or the solve without board warp (default)."""
    t0 = time.perf_counter()
    stages = {}
    obs = obs.copy()
    n = obs.shape[0]
    imagersizes = np.array([imagersize], dtype=np.int32)
    indices_frame_camera = np.column_stack((np.arange(n, dtype=np.int32),
                                            np.zeros(n, dtype=np.int32)))
    ifcc = np.column_stack((indices_frame_camera, indices_frame_camera[:, 1] - 1)).astype(np.int32)
    intr, extr, frames = mrcal.seed_stereographic(
        imagersizes=imagersizes, focal_estimate=focal, indices_frame_camera=indices_frame_camera,
        observations=obs, object_spacing=square)
    t1 = time.perf_counter()
    stages["seed"] = t1 - t0
    for core in (False, True):
        mrcal.optimize(intr, extr, frames, None, obs, ifcc, None, None, "LENSMODEL_STEREOGRAPHIC",
                       imagersizes=imagersizes, do_optimize_intrinsics_core=core,
                       do_optimize_intrinsics_distortions=False, do_optimize_calobject_warp=False,
                       calibration_object_spacing=square, do_apply_outlier_rejection=False,
                       do_apply_regularization=False, verbose=False)
    t2 = time.perf_counter()
    stages["stereographic_presolves"] = t2 - t1
    intr = expand_intrinsics(lensmodel, intr, mrcal, np.random.default_rng(0))
    outliers = settings == "default"
    inputs = dict(
        intrinsics=intr, extrinsics_rt_fromref=extr, frames_rt_toref=frames, points=None,
        observations_board=obs, indices_frame_camintrinsics_camextrinsics=ifcc,
        observations_point=None, indices_point_camintrinsics_camextrinsics=None,
        lensmodel=lensmodel, imagersizes=imagersizes, calobject_warp=None,
        do_optimize_intrinsics_core=True, do_optimize_intrinsics_distortions=True,
        do_optimize_extrinsics=True, do_optimize_frames=True, do_optimize_calobject_warp=False,
        calibration_object_spacing=square, do_apply_outlier_rejection=outliers,
        do_apply_regularization=True, verbose=False)
    stats = mrcal.optimize(**inputs)
    t3 = time.perf_counter()
    stages["main_optimize"] = t3 - t2
    if snapshot is not None and settings == "default":
        snapshot.update(intrinsics=inputs["intrinsics"].copy(),
                        frames=inputs["frames_rt_toref"].copy(),
                        observations=inputs["observations_board"].copy())
    if settings == "default":
        inputs["calobject_warp"] = np.array((0.0, 0.0))
        inputs["do_optimize_calobject_warp"] = True
        stats = mrcal.optimize(**inputs)
    else:
        # --skip-regularization: once more with regularization (everything else before the
        # regularization-free step, as the tool does), then without.
        stats = mrcal.optimize(**inputs)
        if snapshot is not None:
            snapshot.update(intrinsics=inputs["intrinsics"].copy(),
                            frames=inputs["frames_rt_toref"].copy(),
                            observations=inputs["observations_board"].copy())
        inputs["do_apply_regularization"] = False
        t3b = time.perf_counter()
        stages["second_regularized_optimize"] = t3b - t3
        t3 = t3b
        stats = mrcal.optimize(**inputs)
    t4 = time.perf_counter()
    stages["final_optimize"] = t4 - t3  # the last mrcal.optimize call alone
    stages["total"] = t4 - t0
    return inputs, stats, stages


def rms_on_all(mrcal, obs, W, H, square, frames_rt, lensmodel, intrinsics, warp=None):
    board = mrcal.ref_calibration_object(W, H, square, calobject_warp=warp)  # (H, W, 3)
    pts = mrcal.transform_point_rt(frames_rt[:, None, None, :], board[None, ...])
    q = mrcal.project(pts, lensmodel, intrinsics)
    seen = obs[..., 2] > 0
    d2 = np.sum((q - obs[..., :2]) ** 2, axis=-1)[seen]
    return float(np.sqrt(np.mean(d2))), int(seen.sum()), d2


def cmd_solve(a):
    import mrcal
    threads_before = threads_now()
    obs, W, H, square, imagersize, _ = load_problem(a.file)
    lensmodel = MODELS[a.model]
    focal = a.focal if a.focal else float(imagersize[0])
    # mrcal's seed calls cv2.solvePnP (Debian's python3-opencv): its thread pool gets one
    # thread. Then one untimed run: the seed imports cv2 on first use (about 1 s here), a
    # one-time cost that is no part of a calibration.
    try:
        import cv2
        cv2.setNumThreads(1)
    except ImportError:
        pass
    snap = {}
    calibrate(mrcal, obs, W, H, square, imagersize, lensmodel, a.settings, focal, snap)
    # The state before the last step (from that untimed run): what the last step changed.
    # comparable: regularized, every point, flat board; default: regularized, outliers
    # rejected, flat board (before the board-warp step).
    rms_before_last, _, _ = rms_on_all(mrcal, obs, W, H, square, snap["frames"], lensmodel,
                                       snap["intrinsics"][0])
    before_last = {"rms_all_points": rms_before_last,
                   "n_outliers": int((obs[..., 2] > 0).sum() - (snap["observations"][..., 2] > 0).sum()),
                   "fx": float(snap["intrinsics"][0][0]), "fy": float(snap["intrinsics"][0][1]),
                   "cx": float(snap["intrinsics"][0][2]), "cy": float(snap["intrinsics"][0][3]),
                   "dist_coeffs": [float(x) for x in snap["intrinsics"][0][4:]]}
    times, stages_all = [], []
    inputs = stats = None
    for _ in range(a.repeats):
        inputs, stats, stages = calibrate(mrcal, obs, W, H, square, imagersize, lensmodel,
                                          a.settings, focal)
        times.append(stages["total"])
        stages_all.append(stages)
    intr = inputs["intrinsics"][0]
    warp = inputs["calobject_warp"]
    out_obs = inputs["observations_board"]
    rms_all, n_all, _ = rms_on_all(mrcal, obs, W, H, square, inputs["frames_rt_toref"],
                                   lensmodel, intr, warp)
    # and over the points mrcal kept (its outliers have weight < 0 in the returned array)
    kept = out_obs[..., 2] > 0
    board = mrcal.ref_calibration_object(W, H, square, calobject_warp=warp)
    q = mrcal.project(mrcal.transform_point_rt(inputs["frames_rt_toref"][:, None, None, :],
                                               board[None, ...]), lensmodel, intr)
    d2k = np.sum((q - obs[..., :2]) ** 2, axis=-1)[kept]
    res = {
        "tool": "mrcal",
        "mrcal_version": mrcal_version(),
        "numpy_version": np.__version__,
        "python": platform.python_version(),
        "file": a.file,
        "model": a.model,
        "lensmodel": lensmodel,
        "settings": a.settings,
        "focal_estimate": focal,
        "board": [W, H, square],
        "n_views": int(obs.shape[0]),
        "n_points": n_all,
        "repeats": a.repeats,
        "seconds_all": times,
        "seconds_median": statistics.median(times),
        "seconds_min": min(times),
        "stage_seconds_fastest": min(stages_all, key=lambda s: s["total"]),
        "rms_all_points": rms_all,
        "rms_kept_points": float(np.sqrt(np.mean(d2k))) if d2k.size else None,
        "n_outliers": int(n_all - kept.sum()),
        "mrcal_rms_reported": float(stats["rms_reproj_error__pixels"]),
        "fx": float(intr[0]), "fy": float(intr[1]), "cx": float(intr[2]), "cy": float(intr[3]),
        "dist_coeffs": [float(x) for x in intr[4:]],
        "before_last_step": before_last,
        "calobject_warp": None if warp is None else [float(x) for x in warp],
        "threads_before": threads_before,
        "threads_after": threads_now(),
        "env": {k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")},
    }
    json.dump(res, sys.stdout, indent=1)
    print()


def mrcal_version():
    try:
        import subprocess
        return subprocess.run(["dpkg-query", "-W", "-f=${Version}", "python3-mrcal"],
                              capture_output=True, text=True).stdout.strip() or "?"
    except OSError:
        return "?"


def cmd_ours(a):
    import mrcal
    obs, W, H, square, imagersize, d = load_problem(a.file)
    r = json.load(open(a.result))
    cam = r["camera"]
    lensmodel = MODELS[cam["model"]]
    intr = np.array([cam["fx"], cam["fy"], cam["cx"], cam["cy"]] + list(cam["dist_coeffs"]))
    views = r["views"]
    frames = np.zeros((obs.shape[0], 6))
    used = np.zeros(obs.shape[0], dtype=bool)
    for v in views:
        frames[v["index"], :3] = v["rotation_vector"]
        frames[v["index"], 3:] = v["translation"]
        used[v["index"]] = True
    rms_all, n_all, _ = rms_on_all(mrcal, obs[used], W, H, square, frames[used], lensmodel, intr)
    polish = None
    if a.polish:
        # mrcal's own solver started at our solution (every point, flat board, no
        # regularization): does it find a lower cost nearby?
        sub = obs[used].copy()
        n = sub.shape[0]
        ifcc = np.column_stack((np.arange(n), np.zeros(n), -np.ones(n))).astype(np.int32)
        p_intr = intr[None, :].copy()
        p_frames = frames[used].copy()
        mrcal.optimize(p_intr, np.zeros((0, 6)), p_frames, None, sub, ifcc, None, None, lensmodel,
                       imagersizes=np.array([imagersize], dtype=np.int32),
                       do_optimize_intrinsics_core=True, do_optimize_intrinsics_distortions=True,
                       do_optimize_extrinsics=False, do_optimize_frames=True,
                       do_optimize_calobject_warp=False, calibration_object_spacing=square,
                       do_apply_outlier_rejection=False, do_apply_regularization=False,
                       verbose=False)
        rp, _, _ = rms_on_all(mrcal, sub, W, H, square, p_frames, lensmodel, p_intr[0])
        polish = {"rms_all_points": rp,
                  "max_abs_move_fx_fy_cx_cy": float(np.max(np.abs(p_intr[0][:4] - intr[:4]))),
                  "fx": float(p_intr[0][0]), "fy": float(p_intr[0][1]),
                  "cx": float(p_intr[0][2]), "cy": float(p_intr[0][3])}
    json.dump({"rms_all_points_mrcal_projection": rms_all, "n_points": n_all,
               "mrcal_started_at_ours": polish,
               "views_used": int(used.sum()), "views_in_file": int(obs.shape[0]),
               "rms": r["rms"], "rms_all_points": r.get("rms_all_points"),
               "num_rejected": r.get("num_rejected"),
               "elapsed_seconds": r["elapsed_seconds"],
               "elapsed_seconds_all": r.get("elapsed_seconds_all", [r["elapsed_seconds"]]),
               "fx": cam["fx"], "fy": cam["fy"], "cx": cam["cx"], "cy": cam["cy"],
               "dist_coeffs": cam["dist_coeffs"],
               "std": {k: cam["std"][k] for k in ("fx", "fy", "cx", "cy")} if cam.get("std") else None,
               "warnings": [w.get("code") for w in r.get("warnings", [])]},
              sys.stdout, indent=1)
    print()


# ------------------------------------------------------------------------------------ report
def load(p):
    try:
        return json.load(open(p))
    except (OSError, ValueError):
        return None


def ms(s):
    return "-" if s is None else f"{1e3 * s:.2f}" if s < 0.1 else f"{1e3 * s:.1f}"


def machine():
    cpu = "?"
    try:
        m = re.search(r"^model name\s*:\s*(.+)$", open("/proc/cpuinfo").read(), re.M)
        cpu = m.group(1).strip() if m else cpu
    except OSError:
        pass
    osname = ""
    try:
        m = re.search(r'^PRETTY_NAME="?([^"\n]*)"?', open("/etc/os-release").read(), re.M)
        osname = m.group(1) if m else ""
    except OSError:
        pass
    return f"{cpu}; {os.cpu_count()} logical CPUs; {osname}, kernel {platform.release()}"


def polish_effect(o):
    p = o.get("mrcal_started_at_ours")
    if not p:
        return "-"
    return f"{p['rms_all_points'] - o['rms_all_points']:+.1e}, {p['max_abs_move_fx_fy_cx_cy']:.1e}"


def reg_effect(m):
    b = m.get("before_last_step")
    if not b:
        return "-"
    d = max(abs(b[k] - m[k]) for k in ("fx", "fy", "cx", "cy"))
    return f"{b['rms_all_points'] - m['rms_all_points']:+.1e}, {d:.1e}"


def cmd_report(a):
    rows_cmp, rows_def, notes = [], [], []
    mv = None
    for line in open(a.manifest):
        if not line.strip():
            continue
        name, file, model = line.rstrip("\n").split("\t")[:3]
        base = os.path.join(a.out_dir, name)
        mc, md = load(base + ".mrcal.comparable.json"), load(base + ".mrcal.default.json")
        oc, od = load(base + ".ours.comparable.json"), load(base + ".ours.default.json")
        load_c = open(base + ".load").read().strip() if os.path.exists(base + ".load") else "?"
        mv = (mc or md or {}).get("mrcal_version", mv)
        shape = f"{mc['n_views']} x {mc['n_points'] / mc['n_views']:.0f}" if mc else "?"
        if mc and oc:
            d = {k: oc[k] - mc[k] for k in ("fx", "fy", "cx", "cy")}
            sig = oc.get("std") or {}
            dsig = max(abs(d[k]) / sig[k] for k in d if sig.get(k)) if sig else None
            nd = min(len(oc["dist_coeffs"]), len(mc["dist_coeffs"]))
            ddist = max(abs(oc["dist_coeffs"][i] - mc["dist_coeffs"][i]) for i in range(nd))
            rows_cmp.append([
                name, model, shape,
                f"{mc['rms_all_points']:.8f}", f"{oc['rms_all_points']:.8f}",
                f"{oc['rms_all_points'] - mc['rms_all_points']:+.1e}",
                f"{oc['rms_all_points_mrcal_projection'] - oc['rms_all_points']:+.0e}",
                f"{d['fx']:+.1e}", f"{d['fy']:+.1e}", f"{d['cx']:+.1e}", f"{d['cy']:+.1e}",
                "-" if dsig is None else f"{dsig:.1e}", f"{ddist:.1e}",
                polish_effect(oc),
                reg_effect(mc),
                ms(mc["seconds_median"]), ms(oc["elapsed_seconds"]),
                f"{mc['seconds_median'] / oc['elapsed_seconds']:.0f}x",
                ms(mc["seconds_min"]), ms(min(oc["elapsed_seconds_all"])),
                f"{mc['seconds_min'] / min(oc['elapsed_seconds_all']):.0f}x",
                f"{ms(mc['stage_seconds_fastest']['final_optimize'])}, "
                f"{mc['stage_seconds_fastest']['final_optimize'] / min(oc['elapsed_seconds_all']):.1f}x",
                load_c,
            ])
            if mc.get("threads_after") not in (None, 1):
                notes.append(f"{name}: the mrcal process had {mc['threads_after']} threads")
        else:
            rows_cmp.append([name, model, shape] + ["FAILED"] * 20)
        if md and od:
            d = {k: od[k] - md[k] for k in ("fx", "fy", "cx", "cy")}
            dmax = max(abs(x) for x in d.values())
            rows_def.append([
                name, model,
                f"{md['rms_all_points']:.6f}", f"{od['rms_all_points']:.6f}",
                f"{md['rms_kept_points']:.6f} ({md['n_outliers']})",
                f"{od['rms']:.6f} ({od['num_rejected']})",
                f"{md['calobject_warp'][0]:+.2e}, {md['calobject_warp'][1]:+.2e}"
                if md.get("calobject_warp") else "-",
                f"{md['before_last_step']['rms_all_points']:.6f}" if md.get("before_last_step") else "-",
                f"{dmax:.2e}",
                ms(md["seconds_median"]), ms(od["elapsed_seconds"]),
                f"{md['seconds_median'] / od['elapsed_seconds']:.0f}x",
                ms(md["seconds_min"]), ms(min(od["elapsed_seconds_all"])),
                f"{md['seconds_min'] / min(od['elapsed_seconds_all']):.0f}x",
            ])
        else:
            rows_def.append([name, model] + ["FAILED"] * 13)
        for tag, j in (("mrcal comparable", mc), ("mrcal default", md)):
            if j and j.get("threads_after") not in (None, 1):
                notes.append(f"{name}: {tag}: the process had {j['threads_after']} threads")
    out = []
    out.append(f"Command: `{a.command}`  ")
    out.append(f"calib revision: {a.calib_rev}; mrcal {mv or '?'} (Debian python3-mrcal, in-process "
               f"Python API); {a.python or ''}  ")
    out.append(f"Machine: {machine()}  ")
    out.append(f"Date: {datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}  ")
    out.append("One thread each (mrcal: OMP_NUM_THREADS=OPENBLAS_NUM_THREADS=1, one thread in "
               "its process after the solves; calib --threads 1), run one after the other per case. "
               "Times: median and fastest of the repeats in one process; the ratio is mrcal / calib.")
    out.append("")
    out.append("### Comparable settings: every point, no regularization, flat board")
    out.append("")
    out.append("mrcal: regularization off (after the regularized solve, as "
               "`--skip-regularization`), outlier rejection off, no board warp; calib: "
               "`--no-outlier-rejection`. RMS over every point, each solution with its own "
               "projection; Δ = calib − mrcal.")
    out.append("")
    head = ["case", "model", "views x points", "RMS mrcal", "RMS calib", "calib − mrcal",
            "calib via mrcal.project − calib", "Δfx", "Δfy", "Δcx", "Δcy", "max Δ/σ (calib σ)",
            "max Δ distortion", "mrcal started at calib's solution: RMS − calib, max abs move fx fy cx cy",
            "mrcal regularized: RMS − unregularized, max abs Δ fx fy cx cy",
            "mrcal ms (median)", "calib ms (median)", "ratio (median)",
            "mrcal ms (fastest)", "calib ms (fastest)", "ratio (fastest)",
            "mrcal's last optimize call alone (fastest run): ms, ratio to calib's whole run",
            "load avg (1, 5, 15 min) before"]
    out.append("| " + " | ".join(head) + " |")
    out.append("|" + "|".join(["---"] * len(head)) + "|")
    out += ["| " + " | ".join(r) + " |" for r in rows_cmp]
    out.append("")
    out.append("### Default settings of each tool")
    out.append("")
    out.append("mrcal: as `mrcal-calibrate-cameras` by default (regularization on, outlier "
               "rejection on, board warp solved in the final step); calib: `calib single FILE "
               "--model M --threads 1` (its outlier rejection on). RMS over every point (each "
               "with its own board and projection), then over the points each kept (count "
               "rejected).")
    out.append("")
    head = ["case", "model", "RMS all mrcal", "RMS all calib", "RMS kept mrcal (outliers)",
            "RMS kept calib (outliers)", "mrcal board warp", "RMS all mrcal before the warp step",
            "max abs Δ fx fy cx cy",
            "mrcal ms (median)", "calib ms (median)", "ratio (median)", "mrcal ms (fastest)",
            "calib ms (fastest)", "ratio (fastest)"]
    out.append("| " + " | ".join(head) + " |")
    out.append("|" + "|".join(["---"] * len(head)) + "|")
    out += ["| " + " | ".join(r) + " |" for r in rows_def]
    if notes:
        out.append("")
        out += [f"- {n}" for n in notes]
    print("\n".join(out))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("solve")
    s.add_argument("file")
    s.add_argument("--model", required=True, choices=sorted(MODELS))
    s.add_argument("--settings", required=True, choices=("comparable", "default"))
    s.add_argument("--repeats", type=int, default=5)
    s.add_argument("--focal", type=float, default=None)
    o = sub.add_parser("ours")
    o.add_argument("file")
    o.add_argument("result")
    o.add_argument("--polish", action="store_true",
                   help="also run mrcal's optimizer (no regularization, every point) from it")
    r = sub.add_parser("report")
    r.add_argument("out_dir")
    r.add_argument("manifest")
    r.add_argument("--command", required=True)
    r.add_argument("--calib-rev", default="unknown")
    r.add_argument("--python", default=None)
    a = ap.parse_args()
    {"solve": cmd_solve, "ours": cmd_ours, "report": cmd_report}[a.cmd](a)


if __name__ == "__main__":
    main()
