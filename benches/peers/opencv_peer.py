#!/usr/bin/env python3
"""OpenCV side of the peer benchmark: calibrate one observation file, print a JSON result.

    opencv_peer.py single FILE.json [--repeats N] [--criteria default|tight]
    opencv_peer.py stereo FILE.json [--repeats N] [--criteria default|tight]

single: cv2.calibrateCamera(obj, img, (w, h), None, None, flags=CALIB_FIX_K3)
stereo: cv2.stereoCalibrate(obj, left, right, None, None, None, None, (w, h), flags=CALIB_FIX_K3)
        (intrinsics free; OpenCV initialises each camera with its own calibrateCamera internally,
        which is part of the timed call)

OpenCV runs single-threaded (cv2.setNumThreads(1)). By default no criteria argument is passed, so
OpenCV uses its defaults, which is what users run: calibrateCamera (COUNT|EPS, 30, DBL_EPSILON),
stereoCalibrate (COUNT|EPS, 30, 1e-6). `--criteria tight` uses (COUNT|EPS, 2000, 1e-15) instead,
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
    "single": "default: COUNT|EPS, 30, DBL_EPSILON (cv2.calibrateCamera default, not passed)",
    "stereo": "default: COUNT|EPS, 30, 1e-6 (cv2.stereoCalibrate default, not passed)",
}


def pts(rows, ncols, what):
    a = np.asarray(rows, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != ncols:
        raise SystemExit(f"{what}: expected a list of {ncols}-vectors, got shape {a.shape}")
    return np.ascontiguousarray(a, dtype=np.float32)


def load(path, kind):
    with open(path) as f:
        d = json.load(f)
    size = tuple(int(v) for v in d["image_size"])
    if kind == "single":
        if "views" not in d:
            raise SystemExit(f"{path}: no 'views' (is this a stereo file? use 'stereo')")
        obj, img = [], []
        for i, v in enumerate(d["views"]):
            o = pts(v["object_points"], 3, f"views[{i}].object_points")
            p = pts(v["image_points"], 2, f"views[{i}].image_points")
            if len(o) != len(p):
                raise SystemExit(f"views[{i}]: {len(o)} object points but {len(p)} image points")
            obj.append(o)
            img.append(p)
        return {"size": size, "obj": obj, "img": img}
    if "pairs" not in d:
        raise SystemExit(f"{path}: no 'pairs' (is this a single-camera file? use 'single')")
    obj, left, right = [], [], []
    for i, v in enumerate(d["pairs"]):
        o = pts(v["object_points"], 3, f"pairs[{i}].object_points")
        l = pts(v["left_points"], 2, f"pairs[{i}].left_points")
        r = pts(v["right_points"], 2, f"pairs[{i}].right_points")
        if not (len(o) == len(l) == len(r)):
            raise SystemExit(f"pairs[{i}]: point counts differ ({len(o)}, {len(l)}, {len(r)})")
        obj.append(o)
        left.append(l)
        right.append(r)
    rsize = tuple(int(v) for v in d.get("right_image_size", size))
    return {"size": size, "right_size": rsize, "obj": obj, "left": left, "right": right}


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
    rms, k, dist = r[0], r[1], r[2]
    out = {"rms": float(rms)}
    out.update(intr(k, dist))
    return dt, out


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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("kind", choices=["single", "stereo"])
    ap.add_argument("file")
    ap.add_argument("--repeats", type=int, default=5, help="timed repeats (default 5); median reported")
    ap.add_argument("--criteria", choices=["default", "tight"], default="default")
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
        elif abs(out["rms"] - res["rms"]) > 1e-9:
            # Deterministic algorithm; a difference would mean something odd (threads, state).
            res.setdefault("warnings", []).append(
                f"rms differs between repeats: {res['rms']!r} vs {out['rms']!r}")

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
