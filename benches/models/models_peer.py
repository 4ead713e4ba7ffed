#!/usr/bin/env python3
"""OpenCV side of the lens-model comparison (benches/models/run.sh), and its report.

    models_peer.py opencv FILE.json --model MODEL [--repeats N]
        Calibrate one observation file with OpenCV's counterpart of MODEL; print JSON.
    models_peer.py reference [--root DIR]
        Write DIR/data/sourishgN/reference/opencv5_models_{left,right}.json: OpenCV's result for
        every model on the four bundled cameras (the reference files the Rust tests load).
    models_peer.py report OUT_DIR --command "..."
        Print the Markdown tables from the files run.sh left in OUT_DIR.

Models and the OpenCV calls (default termination criteria, as users run them):

    brown-conrady4   cv2.calibrateCamera, CALIB_FIX_K3
    brown-conrady5   cv2.calibrateCamera, flags 0 (OpenCV's default model)
    rational8        cv2.calibrateCamera, CALIB_RATIONAL_MODEL
    thin-prism12     cv2.calibrateCamera, CALIB_RATIONAL_MODEL | CALIB_THIN_PRISM_MODEL
    kannala-brandt4  cv2.fisheye.calibrate, CALIB_RECOMPUTE_EXTRINSIC | CALIB_FIX_SKEW

Points: cv2.calibrateCamera in OpenCV 5 rejects float64 object points, so the pinhole models get
float32 arrays of shape (N, 3) / (N, 2); cv2.fisheye.calibrate takes float64 but in 5.0 only as
(1, N, 3) / (1, N, 2) per view ((N, 1, 3) fails with "Sizes of input arguments do not match").
Because of the float32 rounding, OpenCV's own RMS is measured against slightly different
observations; `rms_f64` is OpenCV's solution (intrinsics, distortion, poses) re-evaluated with
cv2.projectPoints / cv2.fisheye.projectPoints on the original float64 points: the number to
compare our RMS with.

Timing: time.perf_counter around the plain calibration call (cv2.calibrateCamera or
cv2.fisheye.calibrate; no standard deviations), repeated, median; one thread
(cv2.setNumThreads(1)). The standard deviations and poses come from one extra, untimed
cv2.calibrateCameraExtended call with the same inputs (checked to reach the same RMS).
"""

import argparse
import datetime
import json
import math
import os
import platform
import re
import statistics
import sys
import time

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402
import cv2  # noqa: E402

MODELS = ["brown-conrady4", "brown-conrady5", "rational8", "thin-prism12", "kannala-brandt4"]
NAMES = {
    "brown-conrady4": ["k1", "k2", "p1", "p2"],
    "brown-conrady5": ["k1", "k2", "p1", "p2", "k3"],
    "rational8": ["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"],
    "thin-prism12": ["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4"],
    "kannala-brandt4": ["k1", "k2", "k3", "k4"],
}
PINHOLE_FLAGS = {
    "brown-conrady4": ("CALIB_FIX_K3", cv2.CALIB_FIX_K3),
    "brown-conrady5": ("0 (k1 k2 p1 p2 k3 free)", 0),
    "rational8": ("CALIB_RATIONAL_MODEL", cv2.CALIB_RATIONAL_MODEL),
    "thin-prism12": ("CALIB_RATIONAL_MODEL | CALIB_THIN_PRISM_MODEL",
                     cv2.CALIB_RATIONAL_MODEL | cv2.CALIB_THIN_PRISM_MODEL),
}
FISHEYE_FLAGS = ("CALIB_RECOMPUTE_EXTRINSIC | CALIB_FIX_SKEW",
                 cv2.CALIB_RECOMPUTE_EXTRINSIC | cv2.CALIB_FIX_SKEW)
CRITERIA_TEXT = {
    "pinhole": "OpenCV default (not passed; in OpenCV 5.0 not 30 iterations: thin-prism12 on sourishg2/left needs about 118, benches/models/opencv_iterations.py)",
    "fisheye": "OpenCV default (not passed): COUNT|EPS, 100, DBL_EPSILON",
}
# Used only to check that the default criteria reached the minimum (reference mode).
TIGHT = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 1000, sys.float_info.epsilon)
# OpenCV's stdDeviationsIntrinsics order: fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4 tx ty.
STD_ORDER = ["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6",
             "s1", "s2", "s3", "s4", "tau_x", "tau_y"]
SETS = [("sourishg1", "left"), ("sourishg1", "right"), ("sourishg2", "left"), ("sourishg2", "right")]


# ------------------------------------------------------------------------------------ OpenCV
def load(path):
    with open(path) as f:
        d = json.load(f)
    size = tuple(int(v) for v in d["image_size"])
    obj64 = [np.asarray(v["object_points"], np.float64) for v in d["views"]]
    img64 = [np.asarray(v["image_points"], np.float64) for v in d["views"]]
    for i, (o, p) in enumerate(zip(obj64, img64)):
        if o.ndim != 2 or o.shape[1] != 3 or p.shape != (len(o), 2):
            raise SystemExit(f"{path}: view {i}: bad point arrays {o.shape}, {p.shape}")
    return {"size": size, "obj64": obj64, "img64": img64, "truth": d.get("truth")}


def intrinsics(k):
    return {"fx": float(k[0, 0]), "fy": float(k[1, 1]), "cx": float(k[0, 2]), "cy": float(k[1, 2])}


def rms_f64(p, k, dist, rvecs, tvecs, fisheye):
    e, n = 0.0, 0
    for o, im, rv, tv in zip(p["obj64"], p["img64"], rvecs, tvecs):
        rv = np.asarray(rv, np.float64).reshape(3, 1)
        tv = np.asarray(tv, np.float64).reshape(3, 1)
        if fisheye:
            proj, _ = cv2.fisheye.projectPoints(o.reshape(1, -1, 3), rv, tv, k, dist)
        else:
            proj, _ = cv2.projectPoints(o, rv, tv, k, dist)
        d = proj.reshape(-1, 2) - im
        e += float(np.sum(d * d))
        n += len(im)
    return math.sqrt(e / n)


def calibrate(p, model, criteria=None, extended=False):
    """One OpenCV calibration; returns (seconds, result dict, poses)."""
    kw = {} if criteria is None else {"criteria": criteria}
    if model == "kannala-brandt4":
        obj = [o.reshape(1, -1, 3) for o in p["obj64"]]
        img = [i.reshape(1, -1, 2) for i in p["img64"]]
        t0 = time.perf_counter()
        rms, k, dist, rvecs, tvecs = cv2.fisheye.calibrate(obj, img, p["size"], None, None,
                                                           flags=FISHEYE_FLAGS[1], **kw)
        dt = time.perf_counter() - t0
        std = None
    else:
        obj = [np.ascontiguousarray(o, np.float32) for o in p["obj64"]]
        img = [np.ascontiguousarray(i, np.float32) for i in p["img64"]]
        fn = cv2.calibrateCameraExtended if extended else cv2.calibrateCamera
        t0 = time.perf_counter()
        r = fn(obj, img, p["size"], None, None, flags=PINHOLE_FLAGS[model][1], **kw)
        dt = time.perf_counter() - t0
        rms, k, dist, rvecs, tvecs = r[:5]
        std = np.ravel(r[5]) if extended else None
    n = len(NAMES[model])
    dist = np.ravel(dist)
    out = {"rms": float(rms)}
    out.update(intrinsics(k))
    out["dist_coeffs"] = [float(x) for x in dist[:n]]
    if std is not None:
        by_name = dict(zip(STD_ORDER, (float(x) for x in std)))
        out["std"] = {key: by_name[key] for key in ("fx", "fy", "cx", "cy")}
        out["std"]["dist_coeffs"] = [by_name[name] for name in NAMES[model]]
    out["rms_f64"] = rms_f64(p, k, dist, rvecs, tvecs, model == "kannala-brandt4")
    return dt, out, (rvecs, tvecs)


def describe(model):
    if model == "kannala-brandt4":
        return {"call": "cv2.fisheye.calibrate", "flags": FISHEYE_FLAGS[0],
                "flags_value": int(FISHEYE_FLAGS[1]), "criteria": CRITERIA_TEXT["fisheye"],
                "points": "float64, (1, N, 3) and (1, N, 2) per view"}
    return {"call": "cv2.calibrateCamera", "flags": PINHOLE_FLAGS[model][0],
            "flags_value": int(PINHOLE_FLAGS[model][1]), "criteria": CRITERIA_TEXT["pinhole"],
            "points": "float32, (N, 3) and (N, 2) per view"}


def full_result(p, model):
    """Result with standard deviations where OpenCV gives them (untimed), plus a check that the
    default criteria reached the minimum: the same call with 1000 iterations."""
    _, res, _ = calibrate(p, model, extended=True)
    _, tight, _ = calibrate(p, model, criteria=TIGHT)
    res["tight_criteria_check"] = {
        "criteria": "COUNT|EPS, 1000, DBL_EPSILON",
        "rms": tight["rms"],
        "max_abs_change_fx_fy_cx_cy": max(abs(tight[k] - res[k]) for k in ("fx", "fy", "cx", "cy")),
    }
    return res


def cmd_opencv(a):
    cv2.setNumThreads(1)
    p = load(a.file)
    times, first, failure = [], None, None
    try:
        for _ in range(a.repeats):
            dt, out, _ = calibrate(p, a.model)
            times.append(dt)
            if first is None:
                first = out
            elif abs(out["rms"] - first["rms"]) > 1e-9:
                first.setdefault("warnings", []).append(
                    f"rms differs between repeats: {first['rms']!r} vs {out['rms']!r}")
    except cv2.error as e:
        failure = " ".join(str(e).split())
    result = {"tool": "opencv", "file": a.file, "model": a.model,
              "opencv_version": cv2.__version__, "threads": cv2.getNumThreads(),
              "n_views": len(p["obj64"]), "n_points": int(sum(len(o) for o in p["obj64"]))}
    result.update(describe(a.model))
    if failure is not None:
        result["failed"] = failure
    else:
        if a.model != "kannala-brandt4":
            # Standard deviations from an untimed calibrateCameraExtended with the same inputs.
            _, ext, _ = calibrate(p, a.model, extended=True)
            if abs(ext["rms"] - first["rms"]) <= 1e-9 * max(1.0, first["rms"]):
                first["std"] = ext["std"]
        result.update(first)
        result["repeats"] = a.repeats
        result["seconds_median"] = statistics.median(times)
        result["seconds_all"] = times
    json.dump(result, sys.stdout, indent=1)
    sys.stdout.write("\n")


def cmd_reference(a):
    cv2.setNumThreads(1)
    root = a.root
    for s, camera in SETS:
        rel = f"data/{s}/{camera}.json"
        p = load(os.path.join(root, rel))
        doc = {
            "name": f"{s}_{camera}_models",
            "dataset": f"{camera}.json",
            "kind": "single",
            "image_size": list(p["size"]),
            "n_views": len(p["obj64"]),
            "n_points": int(sum(len(o) for o in p["obj64"])),
            "opencv_version": cv2.__version__,
            "numpy_version": np.__version__,
            "python": platform.python_version(),
            "generated": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "generator": "benches/models/models_peer.py reference (run.sh --reference)",
            "pixel_convention": "OpenCV: (0,0) = centre of the top-left pixel, x right, y down",
            "rms_definition": "sqrt(sum over all points of (dx^2+dy^2) / N_points), pixels",
            "rms_note": "rms is OpenCV's return value (pinhole models: computed on float32-rounded "
                        "points); rms_f64 is the same solution evaluated on the file's float64 "
                        "points, the value to compare a float64 calibration with",
            "std_note": "one standard deviation as OpenCV reports it (calibrateCameraExtended: "
                        "sigma^2 (J^T J)^-1); null for cv2.fisheye.calibrate, which reports none",
            "models": {},
        }
        for model in MODELS:
            entry = {"distortion_names": NAMES[model]}
            entry.update(describe(model))
            if model != "kannala-brandt4":
                entry["call"] = ("cv2.calibrateCameraExtended (cv2.calibrateCamera plus standard "
                                 "deviations; same result)")
            try:
                entry.update(full_result(p, model))
            except cv2.error as e:
                entry["failed"] = " ".join(str(e).split())
            entry.setdefault("std", None)
            doc["models"][model] = entry
        out = os.path.join(root, f"data/{s}/reference/opencv5_models_{camera}.json")
        with open(out, "w") as f:
            json.dump(doc, f, indent=1)
            f.write("\n")
        print(f"wrote {out}")
        for model in MODELS:
            e = doc["models"][model]
            if "failed" in e:
                print(f"  {model:16s} FAILED: {e['failed']}")
            else:
                print(f"  {model:16s} rms {e['rms']:.10f} (f64 {e['rms_f64']:.10f})  fx {e['fx']:.4f}"
                      f"  default vs tight criteria: d rms {e['tight_criteria_check']['rms'] - e['rms']:.1e},"
                      f" max d intrinsics {e['tight_criteria_check']['max_abs_change_fx_fy_cx_cy']:.1e}")


# ------------------------------------------------------------------------------------ report
def machine():
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            m = re.search(r"^model name\s*:\s*(.+)$", f.read(), re.M)
            cpu = m.group(1).strip() if m else cpu
    except OSError:
        pass
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    try:
        load_avg = "load average %.2f %.2f %.2f (1, 5, 15 min) at report time" % os.getloadavg()
    except OSError:
        load_avg = ""
    return f"{cpu}; {os.cpu_count()} logical CPUs ({usable} usable); {load_avg}"


def read(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def fmt_ms(s):
    return "-" if s is None else (f"{s * 1e3:.2f}" if s < 0.1 else f"{s * 1e3:.0f}")


def fmt_small(x):
    """Absolute differences: 0 to 3 decimals, or a power of ten when tiny."""
    if x == 0:
        return "0"
    return f"{x:.1e}" if x < 1e-3 else f"{x:.3f}"


def ratio(ours, theirs):
    if ours is None or theirs is None or ours <= 0:
        return "-"
    r = theirs / ours
    return f"{r:.0f}x" if r >= 10 else f"{r:.1f}x"


def time_to_peer_rms(res, peer_rms, fastest):
    """Where the peer stops more than 1e-6 px above our RMS: our time until the solver's cost first
    reached the peer's, as "ms (peer time / ours)". That is the whole run less the solver's
    iterations after that point (per_iteration trace of the reported run, evaluation plus solve of
    each), scaled to the fastest repeat. "-" when the peer's RMS is not that far above ours."""
    if res is None or peer_rms is None or peer_rms < res["rms"] + 1e-6:
        return None
    solver = res["solver"]
    target = 0.5 * peer_rms**2 * res["num_points"]
    spent = 0.0
    for it in solver["per_iteration"]:
        spent += it["evaluate_seconds"] + (it["solve_seconds"] or 0.0)
        cost = it["trial_cost"] if it["accepted"] else it["cost"]
        if cost is not None and cost <= target:
            whole = res["elapsed_seconds"]
            return (whole - max(solver["total_seconds"] - spent, 0.0)) * fastest / whole
    return None


def fov_of_truth(truth, size):
    """Nominal fields of view of the true Kannala-Brandt camera (horizontal, diagonal, degrees):
    the angle whose distorted angle reaches the farthest image edge / corner from (cx, cy)."""
    k = truth["distortion"]
    fx, fy, cx, cy = truth["fx"], truth["fy"], truth["cx"], truth["cy"]
    w, h = size

    def theta_for(theta_d):
        lo, hi = 0.0, math.pi
        td = lambda t: t * (1 + k[0] * t**2 + k[1] * t**4 + k[2] * t**6 + k[3] * t**8)  # noqa
        # The map is monotonic up to its first turning point; search there.
        grid = np.linspace(1e-6, math.pi, 4000)
        vals = np.array([td(t) for t in grid])
        turn = np.argmax(np.diff(vals) <= 0) if np.any(np.diff(vals) <= 0) else len(grid) - 1
        if theta_d >= vals[turn]:
            return None
        hi = grid[turn]
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if td(mid) < theta_d else (lo, mid)
        return lo

    horiz = [theta_for(cx / fx), theta_for((w - 1 - cx) / fx)]
    diag = theta_for(max(math.hypot(x / fx, y / fy) for x in (cx, w - 1 - cx) for y in (cy, h - 1 - cy)))
    h_total = None if None in horiz else math.degrees(sum(horiz))
    d_total = None if diag is None else 2 * math.degrees(diag)
    return h_total, d_total


def sampled_fov(path):
    """Twice the largest angle off the optical axis of any observed board point (from the truth
    poses): the field of view the data actually covers."""
    d = read(path)
    t = d["truth"]
    best = 0.0
    for v, pose in zip(d["views"], t["poses"]):
        r = np.asarray(pose["rotation_matrix"])
        x = np.asarray(v["object_points"]) @ r.T + np.asarray(pose["translation"])
        best = max(best, float(np.max(np.degrees(np.arctan2(np.hypot(x[:, 0], x[:, 1]), x[:, 2])))))
    return 2 * best


def ours_summary(res):
    cam = res["camera"]
    return {"rms": res["rms"], "fx": cam["fx"], "fy": cam["fy"], "cx": cam["cx"], "cy": cam["cy"],
            "dist_coeffs": cam["dist_coeffs"], "seconds": res["elapsed_seconds"],
            "std": cam.get("std"), "start": res.get("initial", {}).get("method"),
            "warnings": [w.get("code") for w in res.get("warnings", [])]}


def cmd_report(a):
    out = a.out
    manifest = [line.rstrip("\n").split("\t") for line in open(os.path.join(out, "manifest.tsv"))
                if line.strip()]
    lines = []
    add = lines.append
    add(f"Command: `{a.command}`  ")
    add(f"calib revision: {a.calib_rev}; OpenCV {cv2.__version__}, numpy {np.__version__}, "
        f"Python {platform.python_version()}  ")
    add(f"Machine: {machine()}  ")
    add("Both tools on one thread (cv2.setNumThreads(1); calib --threads 1), run one after the "
        "other; times are medians of the repeats in one process. The last column compares the "
        "fastest repeat of each tool: on a shared virtual machine the median of one case can "
        "move by 2x between runs, the fastest much less.")
    add("")
    notes = []
    for section in ("real", "synth-pinhole", "synth"):
        rows = [m for m in manifest if m[0] == section]
        if not rows:
            continue
        if section == "real":
            add("### Bundled cameras (every point used: calib --no-outlier-rejection)")
            add("")
            add("| model | camera | RMS ours | RMS OpenCV | ours − OpenCV | Δfx | Δfy | Δcx | Δcy "
                "| max Δ/σ | ours: start, its ms | time ours ms | time OpenCV ms | OpenCV/ours | fastest: OpenCV/ours "
                "| fastest, ours to OpenCV's RMS: ms, OpenCV/ours |")
            add("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        elif section == "synth-pinhole":
            add("### Synthetic pinhole cameras (calib synth single --model MODEL), against the truth")
            add("")
            add("| model | true fx | RMS ours | RMS OpenCV | ours − OpenCV "
                "| ours: max Δf, Δc vs truth | OpenCV: max Δf, Δc vs truth "
                "| ours: start, its ms | time ours ms | time OpenCV ms | OpenCV/ours | fastest: OpenCV/ours "
                "| fastest, ours to OpenCV's RMS: ms, OpenCV/ours |")
            add("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        else:
            add("### Synthetic fisheye (calib synth single --model kannala-brandt4), against the truth")
            add("")
            add("| true fx | lens FOV h / diag ° | data FOV ° | RMS ours | RMS OpenCV | ours − OpenCV "
                "| ours: max Δf, Δc vs truth | OpenCV: max Δf, Δc vs truth | ours: max Δk "
                "| OpenCV: max Δk | ours: start, its ms | time ours ms | time OpenCV ms | OpenCV/ours | fastest: OpenCV/ours |")
            add("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for _, name, obs, model in rows:
            cv = read(os.path.join(out, f"{name}.opencv.json"))
            res = read(os.path.join(out, f"{name}.calib.json"))
            log = os.path.join(out, f"{name}.calib.log")
            ours = ours_summary(res) if res else None
            cv_ok = cv is not None and "failed" not in cv
            if ours is None:
                msg = open(log).read().strip().splitlines()[-1:] if os.path.exists(log) else ["?"]
                notes.append(f"{name}: calib failed: {msg[0] if msg else '?'}")
            if cv is not None and not cv_ok:
                notes.append(f"{name}: OpenCV failed: {cv['failed']}")
            elif cv is None:
                notes.append(f"{name}: OpenCV produced no result (see {name}.opencv.log)")
            r_ours = f"{ours['rms']:.8f}" if ours else "FAILED"
            r_cv = f"{cv['rms_f64']:.8f}" if cv_ok else "FAILED"
            diff = f"{ours['rms'] - cv['rms_f64']:+.1e}" if ours and cv_ok else "-"
            t_ours = ours["seconds"] if ours else None
            t_cv = cv["seconds_median"] if cv_ok else None
            fast_ours = min(res.get("elapsed_seconds_all") or [t_ours]) if res and t_ours else None
            fast_cv = min(cv.get("seconds_all") or [t_cv]) if cv_ok else None
            reach = time_to_peer_rms(res, cv["rms_f64"] if cv_ok else None, fast_ours)
            to_peer = "-" if reach is None else f"{fmt_ms(reach)}, {ratio(reach, fast_cv)}"
            start = "-"
            if res:
                init = res.get("stage_seconds", {}).get("initialization")
                start = f"{res['initial']['method']}, {fmt_ms(init)}"
            if section == "real":
                d = ["-"] * 4
                sig = "-"
                if ours and cv_ok:
                    keys = ("fx", "fy", "cx", "cy")
                    d = [fmt_small(abs(ours[k] - cv[k])) for k in keys]
                    std = ours["std"] or {}
                    z = [abs(ours[k] - cv[k]) / std[k] for k in keys if std.get(k)]
                    sig = fmt_small(max(z)) if z else "-"
                add(f"| {model} | {name.split('.', 1)[1].replace('.', '/')} | {r_ours} | {r_cv} | {diff} | "
                    + " | ".join(d) + f" | {sig} | {start} | {fmt_ms(t_ours)} | {fmt_ms(t_cv)} | {ratio(t_ours, t_cv)} | {ratio(fast_ours, fast_cv)} | {to_peer} |")
            elif section == "synth-pinhole":
                truth = read(obs)["truth"]

                def err(sol):
                    if not sol:
                        return "-"
                    return f"{max(abs(sol[k] - truth[k]) for k in ('fx', 'fy', 'cx', 'cy')):.3f}"

                add(f"| {model} | {truth['fx']:g} | {r_ours} | {r_cv} | {diff} | {err(ours)} "
                    f"| {err(cv if cv_ok else None)} | {start} | {fmt_ms(t_ours)} | {fmt_ms(t_cv)} "
                    f"| {ratio(t_ours, t_cv)} | {ratio(fast_ours, fast_cv)} | {to_peer} |")
            else:
                d = read(obs)
                truth = d["truth"]
                h, dg = fov_of_truth(truth, d["image_size"])
                lens = " / ".join("fold" if v is None else f"{v:.0f}" for v in (h, dg))

                def errs(sol):
                    if not sol:
                        return "-", "-"
                    e = max(abs(sol[k] - truth[k]) for k in ("fx", "fy", "cx", "cy"))
                    ek = max(abs(x - y) for x, y in zip(sol["dist_coeffs"], truth["distortion"]))
                    return f"{e:.3f}", f"{ek:.4f}"

                eo, eko = errs(ours)
                ec, ekc = errs(cv if cv_ok else None)
                add(f"| {truth['fx']:g} | {lens} | {sampled_fov(obs):.0f} | {r_ours} | {r_cv} | {diff} "
                    f"| {eo} | {ec} | {eko} | {ekc} | {start} | {fmt_ms(t_ours)} | {fmt_ms(t_cv)} | {ratio(t_ours, t_cv)} | {ratio(fast_ours, fast_cv)} |")
        add("")
    if notes:
        add("Failures:")
        add("")
        for n in notes:
            add(f"- {n}")
        add("")
    print("\n".join(lines))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    o = sub.add_parser("opencv")
    o.add_argument("file")
    o.add_argument("--model", choices=MODELS, required=True)
    o.add_argument("--repeats", type=int, default=5)
    r = sub.add_parser("reference")
    r.add_argument("--root", default=".")
    rp = sub.add_parser("report")
    rp.add_argument("out")
    rp.add_argument("--command", default="benches/models/run.sh")
    rp.add_argument("--calib-rev", default="unknown")
    a = ap.parse_args(argv)
    if a.cmd == "opencv":
        if a.repeats < 1:
            ap.error("--repeats must be >= 1")
        cmd_opencv(a)
    elif a.cmd == "reference":
        cmd_reference(a)
    else:
        cmd_report(a)


if __name__ == "__main__":
    main()
