#!/usr/bin/env python3
"""OpenCV side of the peer benchmark: calibrate one observation file, print a JSON result.

    opencv_peer.py single FILE.json [--repeats N] [--criteria default|tight]
    opencv_peer.py stereo FILE.json [--repeats N] [--criteria default|tight]

single: cv2.calibrateCamera(obj, img, (w, h), None, None, flags=CALIB_FIX_K3)
stereo: cv2.stereoCalibrate(obj, left, right, None, None, None, None, (w, h), flags=CALIB_FIX_K3)
        (intrinsics free; OpenCV initialises each camera with its own calibrateCamera internally,
        which is part of the timed call)

OpenCV runs single-threaded (cv2.setNumThreads(1)). By default no criteria argument is passed, so
OpenCV uses its defaults, which is what users run (OpenCV 4 documented COUNT|EPS, 30 iterations;
OpenCV 5.0's calibrateCamera iterates longer by default: benches/models/opencv_iterations.py).
`--criteria tight` uses (COUNT|EPS, 2000, 1e-15) instead,
for checking how far the default stops from the optimum; it is not what the benchmark table uses.

Timing: time.perf_counter around the cv2 call only (file reading and array construction are
outside), repeated --repeats times with fresh initial values; seconds_median is the median.
Points are passed as float32 (OpenCV 5's calib module rejects float64 object points).

Output (stdout, one JSON object): rms, seconds_median, seconds_all, repeats, criteria, flags,
opencv_version, n_views, n_points, and the calibrated parameters (single: fx, fy, cx, cy, dist;
stereo: left/right {fx, fy, cx, cy, dist}, R, T with X_right = R X_left + T).
"""

import argparse
import json
import math
import os
import statistics
import sys
import time

# Belt and braces: keep any OpenMP/BLAS pool inside cv2 single-threaded too.
for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402
import cv2  # noqa: E402

TIGHT = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 2000, 1e-15)
DEFAULT_CRITERIA_TEXT = {
    "single": "default (cv2.calibrateCamera default, not passed)",
    "stereo": "default (cv2.stereoCalibrate default, not passed)",
}


def pts(rows, ncols, what, f64=None):
    a = np.asarray(rows, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != ncols:
        raise SystemExit(f"{what}: expected a list of {ncols}-vectors, got shape {a.shape}")
    if f64 is not None:
        f64.append(a)
    return np.ascontiguousarray(a, dtype=np.float32)


def load(path, kind):
    with open(path) as f:
        d = json.load(f)
    size = tuple(int(v) for v in d["image_size"])
    if kind == "single":
        if "views" not in d:
            raise SystemExit(f"{path}: no 'views' (is this a stereo file? use 'stereo')")
        obj, img, obj64, img64 = [], [], [], []
        for i, v in enumerate(d["views"]):
            o = pts(v["object_points"], 3, f"views[{i}].object_points", obj64)
            p = pts(v["image_points"], 2, f"views[{i}].image_points", img64)
            if len(o) != len(p):
                raise SystemExit(f"views[{i}]: {len(o)} object points but {len(p)} image points")
            obj.append(o)
            img.append(p)
        return {"size": size, "obj": obj, "img": img, "obj64": obj64, "img64": img64}
    if "pairs" not in d:
        raise SystemExit(f"{path}: no 'pairs' (is this a single-camera file? use 'single')")
    obj, left, right, obj64, left64, right64 = [], [], [], [], [], []
    for i, v in enumerate(d["pairs"]):
        o = pts(v["object_points"], 3, f"pairs[{i}].object_points", obj64)
        l = pts(v["left_points"], 2, f"pairs[{i}].left_points", left64)
        r = pts(v["right_points"], 2, f"pairs[{i}].right_points", right64)
        if not (len(o) == len(l) == len(r)):
            raise SystemExit(f"pairs[{i}]: point counts differ ({len(o)}, {len(l)}, {len(r)})")
        obj.append(o)
        left.append(l)
        right.append(r)
    rsize = tuple(int(v) for v in d.get("right_image_size", size))
    return {"size": size, "right_size": rsize, "obj": obj, "left": left, "right": right,
            "obj64": obj64, "left64": left64, "right64": right64}


def sq_residuals(obj64, img64, rvec, tvec, k, dist):
    """Sum of squared reprojection residuals (px^2) and point count, all in float64."""
    proj, _ = cv2.projectPoints(obj64, np.asarray(rvec, np.float64), np.asarray(tvec, np.float64),
                                np.asarray(k, np.float64), np.asarray(dist, np.float64))
    d = proj.reshape(-1, 2) - img64
    return float(np.sum(d * d)), len(img64)


def intr(k, dist):
    return {"fx": float(k[0, 0]), "fy": float(k[1, 1]), "cx": float(k[0, 2]), "cy": float(k[1, 2]),
            "dist": [float(x) for x in np.ravel(dist)]}


def run_single(p, criteria):
    kw = {"flags": cv2.CALIB_FIX_K3}
    if criteria is not None:
        kw["criteria"] = criteria
    t0 = time.perf_counter()
    r = cv2.calibrateCamera(p["obj"], p["img"], p["size"], None, None, **kw)
    dt = time.perf_counter() - t0
    rms, k, dist, rvecs, tvecs = r[:5]
    out = {"rms": float(rms)}
    out.update(intr(k, dist))
    out["_poses"] = (rvecs, tvecs)
    return dt, out


def recheck_single(p, res, criteria, args):
    rvecs, tvecs = res.pop("_poses")
    k = np.array([[res["fx"], 0, res["cx"]], [0, res["fy"], res["cy"]], [0, 0, 1]])
    e, n = 0.0, 0
    for o, im, rv, tv in zip(p["obj64"], p["img64"], rvecs, tvecs):
        de, dn = sq_residuals(o, im, rv, tv, k, res["dist"])
        e, n = e + de, n + dn
    res["rms_f64"] = math.sqrt(e / n)


def run_stereo(p, criteria):
    kw = {"flags": cv2.CALIB_FIX_K3}
    if criteria is not None:
        kw["criteria"] = criteria
    t0 = time.perf_counter()
    if p["right_size"] == p["size"]:
        r = cv2.stereoCalibrate(p["obj"], p["left"], p["right"], None, None, None, None,
                                p["size"], **kw)
    else:
        # stereoCalibrate takes one image size, used only to initialise both cameras. With a
        # different right size, do that initialisation explicitly (what stereoCalibrate does
        # internally: calibrateCamera per camera with the same flags, default criteria), then
        # start the joint refinement from it. Timed as one job.
        _, k1, d1, _, _ = cv2.calibrateCamera(p["obj"], p["left"], p["size"], None, None,
                                              flags=cv2.CALIB_FIX_K3)
        _, k2, d2, _, _ = cv2.calibrateCamera(p["obj"], p["right"], p["right_size"], None, None,
                                              flags=cv2.CALIB_FIX_K3)
        kw["flags"] |= cv2.CALIB_USE_INTRINSIC_GUESS
        r = cv2.stereoCalibrate(p["obj"], p["left"], p["right"], k1, d1, k2, d2, p["size"], **kw)
    dt = time.perf_counter() - t0
    rms, k1, d1, k2, d2, rot, t = r[:7]
    out = {"rms": float(rms), "left": intr(k1, d1), "right": intr(k2, d2),
           "R": np.asarray(rot, dtype=float).tolist(),
           "T": [float(x) for x in np.ravel(t)],
           "convention": "X_right = R * X_left + T"}
    if p["right_size"] != p["size"]:
        out["note"] = ("right_image_size differs: explicit per-camera calibrateCamera init + "
                       "stereoCalibrate(CALIB_USE_INTRINSIC_GUESS|CALIB_FIX_K3), all timed")
    return dt, out


def recheck_stereo(p, res, criteria, args):
    """cv2.stereoCalibrate does not return the board poses, so repeat the identical job untimed
    with cv2.stereoCalibrateExtended (same inputs, flags, criteria; deterministic), check that it
    lands on the same rms, and re-evaluate that solution on the float64 points."""
    if p["right_size"] != p["size"]:
        res["rms_f64_skipped"] = "right_image_size differs (not implemented)"
        return
    if res["_seconds"] > args.recheck_limit:
        res["rms_f64_skipped"] = (f"the timed call took {res['_seconds']:.0f} s > --recheck-limit "
                                  f"{args.recheck_limit:g} s")
        return
    kw = {"flags": cv2.CALIB_FIX_K3}
    if criteria is not None:
        kw["criteria"] = criteria
    r = cv2.stereoCalibrateExtended(p["obj"], p["left"], p["right"], None, None, None, None,
                                    p["size"], None, None, **kw)
    rms, k1, d1, k2, d2, rot, t, _e, _f, rvecs, tvecs = r[:11]
    if abs(float(rms) - res["rms"]) > 1e-9 * max(1.0, res["rms"]):
        res["rms_f64_skipped"] = (f"stereoCalibrateExtended gave rms {float(rms)!r}, "
                                  f"not the timed call's {res['rms']!r}")
        return
    rot = np.asarray(rot, np.float64)
    t = np.asarray(t, np.float64).reshape(3, 1)
    e, n = 0.0, 0
    for o, il, ir, rv, tv in zip(p["obj64"], p["left64"], p["right64"], rvecs, tvecs):
        de, dn = sq_residuals(o, il, rv, tv, k1, d1)
        e, n = e + de, n + dn
        r_left, _ = cv2.Rodrigues(np.asarray(rv, np.float64))
        rv2, _ = cv2.Rodrigues(rot @ r_left)
        tv2 = rot @ np.asarray(tv, np.float64).reshape(3, 1) + t
        de, dn = sq_residuals(o, ir, rv2, tv2, k2, d2)
        e, n = e + de, n + dn
    res["rms_f64"] = math.sqrt(e / n)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("kind", choices=["single", "stereo"])
    ap.add_argument("file")
    ap.add_argument("--repeats", type=int, default=5, help="timed repeats (default 5); median reported")
    ap.add_argument("--criteria", choices=["default", "tight"], default="default")
    ap.add_argument("--no-recheck", dest="recheck", action="store_false",
                    help="skip the untimed float64 re-evaluation (rms_f64)")
    ap.add_argument("--recheck-limit", type=float, default=60.0, metavar="SECONDS",
                    help="stereo: skip rms_f64 when the timed call took longer than this, since it "
                         "needs a second, untimed stereoCalibrateExtended run (default 60)")
    a = ap.parse_args(argv)
    if a.repeats < 1:
        ap.error("--repeats must be >= 1")

    cv2.setNumThreads(1)
    p = load(a.file, a.kind)
    criteria = TIGHT if a.criteria == "tight" else None
    fn = run_single if a.kind == "single" else run_stereo

    times, res = [], None
    for _ in range(a.repeats):
        dt, out = fn(p, criteria)
        times.append(dt)
        if res is None:
            res = out
            res["_seconds"] = dt
        elif abs(out["rms"] - res["rms"]) > 1e-9:
            # Deterministic algorithm; a difference would mean something odd (threads, state).
            res.setdefault("warnings", []).append(
                f"rms differs between repeats: {res['rms']!r} vs {out['rms']!r}")

    if a.recheck:
        (recheck_single if a.kind == "single" else recheck_stereo)(p, res, criteria, a)
    for k in [k for k in res if k.startswith("_")]:
        del res[k]

    n_views = len(p["obj"])
    result = {
        "tool": "opencv",
        "kind": a.kind,
        "file": a.file,
        "opencv_version": cv2.__version__,
        "numpy_version": np.__version__,
        "threads": cv2.getNumThreads(),
        "n_views": n_views,
        "n_points": int(sum(len(o) for o in p["obj"])),
        "points_per_view": int(len(p["obj"][0])) if n_views else 0,
        "flags": "CALIB_FIX_K3",
        "criteria": DEFAULT_CRITERIA_TEXT[a.kind] if criteria is None
        else "tight: COUNT|EPS, 2000, 1e-15",
        "repeats": a.repeats,
        "seconds_median": statistics.median(times),
        "seconds_all": times,
    }
    result.update(res)
    json.dump(result, sys.stdout, indent=1)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
