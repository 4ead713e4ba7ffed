#!/usr/bin/env python3
"""One rig data set, OpenCV's cv2.calibrateMultiview against our `calib rig` result.

    compare_opencv.py OBS.json --ours RESULT.json [--repeats N] [--time-extended] > ROW.json

OBS.json is a rig observation file written by `calib synth rig` (with its "truth" key);
RESULT.json is what `calib rig OBS.json -o RESULT.json --threads 1 --repeat K -q` wrote for it.

OpenCV side (single thread: cv2.setNumThreads(1), OMP/BLAS pools at 1):

    cv2.calibrateMultiview(objPoints, imagePoints, imageSizes, detectionMask, models,
                           None, None, None, None, flagsForIntrinsics)

  objPoints     NUM_FRAMES x NUM_POINTS x 3 float32 (the frame's board points)
  imagePoints   NUM_CAMERAS x NUM_FRAMES x NUM_POINTS x 2 float32; a camera that did not see a
                frame gets -1 everywhere (ignored: its detectionMask entry is 0); a partial view
                (an observation with its own object_points) gets -1 at the corners it lacks
  detectionMask NUM_CAMERAS x NUM_FRAMES uint8, 1 where the file has an observation
  models        CALIB_MODEL_PINHOLE for every camera
  flagsForIntrinsics  per camera: brown-conrady4 -> CALIB_FIX_K3 (k1 k2 p1 p2, k3 = 0),
                brown-conrady5 -> 0 (OpenCV's default k1 k2 p1 p2 k3)
  flags, criteria: not passed (OpenCV's defaults, what users run)

Timing: time.perf_counter() around that call only (array construction outside), --repeats times
in this process; median and best are reported. After the timed runs the identical job is run once
more, untimed, with cv2.calibrateMultiviewExtended to get the board pose of every frame (the plain
call does not return them); its intrinsics and rig are checked to equal the timed call's.
With --time-extended the timed call is calibrateMultiviewExtended itself (the same job, the plain
function's outputs plus the board poses) and there is no second run: on the 10 x 500 set one
OpenCV call takes minutes.

RMS, computed here the same way for both tools: sqrt(mean over every observed point of
|projected - measured|^2), projected with cv2.projectPoints in float64 from the tool's own
camera matrices, distortion, camera-from-reference transforms and board poses, measured = the
float64 pixels of the file. OpenCV's own return value is reported too (rms_returned): in 5.0 it
is sqrt(sum over views of the view's mean squared error / number of views), which equals the
per-point RMS when every view has the same number of points, but is computed on the float32
points OpenCV was given.

Accuracy against the file's truth, per tool: largest over cameras of |T - T_true| (board units),
rotation angle of R R_true^T (degrees), max(|fx - fx_true|, |fy - fy_true|) and
max(|cx - cx_true|, |cy - cy_true|) (pixels).
"""

import argparse
import json
import math
import os
import statistics
import sys
import time

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402
import cv2  # noqa: E402

cv2.setNumThreads(1)

FLAGS_FOR_MODEL = {
    "brown-conrady4": cv2.CALIB_FIX_K3,
    "brown-conrady5": 0,
}


def load(path):
    with open(path) as f:
        d = json.load(f)
    cams = d["cameras"]
    models = [c.get("model", "brown-conrady4") for c in cams]
    for i, m in enumerate(models):
        if m not in FLAGS_FOR_MODEL:
            raise SystemExit(
                f"{path}: camera {i} has model {m!r}; this bench compares the pinhole models "
                f"OpenCV's calibrateMultiview shares with calib ({', '.join(FLAGS_FOR_MODEL)})"
            )
    sizes = [tuple(int(v) for v in c["image_size"]) for c in cams]
    nc, nf = len(cams), len(d["frames"])
    npts = max(len(fr["object_points"]) for fr in d["frames"])
    obj = np.zeros((nf, npts, 3), np.float64)
    img = np.full((nc, nf, npts, 2), -1.0, np.float64)
    mask = np.zeros((nc, nf), np.uint8)
    # For our own RMS: every observation as (camera, frame, object points, image points).
    views = []
    for f, fr in enumerate(d["frames"]):
        fo = np.asarray(fr["object_points"], np.float64).reshape(-1, 3)
        if len(fo) != npts:
            raise SystemExit(f"{path}: frame {f} has {len(fo)} board points, others {npts}: "
                             "OpenCV's calibrateMultiview needs one board size for all frames")
        obj[f] = fo
        for o in fr["observations"]:
            c = int(o["camera"])
            ip = np.asarray(o["image_points"], np.float64).reshape(-1, 2)
            op = np.asarray(o["object_points"], np.float64).reshape(-1, 3) if "object_points" in o else fo
            if len(op) != len(ip):
                raise SystemExit(f"{path}: frame {f}, camera {c}: {len(op)} object points, {len(ip)} image points")
            if "object_points" in o:
                # A partial view: place each corner at its index in the frame's board.
                for p, q in zip(op, ip):
                    k = np.flatnonzero(np.all(np.abs(fo - p) < 1e-9, axis=1))
                    if len(k) != 1:
                        raise SystemExit(f"{path}: frame {f}, camera {c}: a corner not on the frame's board")
                    img[c, f, k[0]] = q
            else:
                img[c, f] = ip
            mask[c, f] = 1
            views.append((c, f, op, ip))
    return {
        "data": d, "models": models, "sizes": sizes, "obj": obj, "img": img, "mask": mask,
        "views": views, "nc": nc, "nf": nf, "npts": npts,
    }


def as_rotation(r):
    r = np.asarray(r, np.float64)
    if r.size == 9:
        return r.reshape(3, 3)
    return cv2.Rodrigues(r.reshape(3, 1))[0]


def rms_of(p, Ks, dists, Rs, Ts, frame_R, frame_T):
    """Per-point RMS of a solution (X_cam = R_c (R_f X + T_f) + T_c) on the float64 points."""
    total, count = 0.0, 0
    for c, f, op, ip in p["views"]:
        if frame_R[f] is None:
            raise SystemExit(f"no board pose for frame {f}")
        R = Rs[c] @ frame_R[f]
        T = Rs[c] @ frame_T[f] + Ts[c]
        proj, _ = cv2.projectPoints(op.reshape(-1, 1, 3), cv2.Rodrigues(R)[0], T.reshape(3, 1),
                                    Ks[c], dists[c])
        e = proj.reshape(-1, 2) - ip
        total += float(np.sum(e * e))
        count += len(ip)
    return math.sqrt(total / count), count


def truth_errors(p, Ks, Rs, Ts):
    truth = p["data"].get("truth")
    if not truth:
        return None
    dT = dR = df = dc = 0.0
    for c, t in enumerate(truth["cameras"]):
        Rt = np.asarray(t["R"], np.float64)
        Tt = np.asarray(t["T"], np.float64)
        dT = max(dT, float(np.linalg.norm(Ts[c] - Tt)))
        cosang = (np.trace(Rs[c] @ Rt.T) - 1.0) / 2.0
        dR = max(dR, math.degrees(math.acos(max(-1.0, min(1.0, cosang)))))
        K = Ks[c]
        df = max(df, abs(K[0, 0] - t["fx"]), abs(K[1, 1] - t["fy"]))
        dc = max(dc, abs(K[0, 2] - t["cx"]), abs(K[1, 2] - t["cy"]))
    return {"max_T_error": dT, "max_R_error_deg": dR, "max_f_error_px": df, "max_c_error_px": dc}


def run_opencv(p, repeats, time_extended=False):
    obj = np.ascontiguousarray(p["obj"], np.float32)
    img = np.ascontiguousarray(p["img"], np.float32)
    mask = np.ascontiguousarray(p["mask"])
    models = np.full((p["nc"], 1), cv2.CALIB_MODEL_PINHOLE, np.uint8)
    flags_i = np.array([[FLAGS_FOR_MODEL[m]] for m in p["models"]], np.int32)
    sizes = p["sizes"]
    def extended():
        return cv2.calibrateMultiviewExtended(obj, img, sizes, mask, models, None, None, None, None,
                                              None, None, None, None, flags_i)

    times, cpu, out, ext = [], [], None, None
    for _ in range(repeats):
        c0 = time.process_time()
        t0 = time.perf_counter()
        if time_extended:
            ext = extended()
        else:
            out = cv2.calibrateMultiview(obj, img, sizes, mask, models, None, None, None, None, flags_i)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    if time_extended:
        same = None  # nothing to compare: the timed call is the one whose poses are used
        called = "calibrateMultiviewExtended"
    else:
        ext = extended()
        called = "calibrateMultiview"
    rms_ext, Ks2, dists2, Rs2, Ts2, pairs, rvecs0, tvecs0, per_frame = ext
    if not time_extended:
        rms_ret, Ks, dists, Rs, Ts = out
        same = bool(abs(rms_ext - rms_ret) <= 1e-12 * max(1.0, rms_ret)
                    and all(np.array_equal(np.asarray(a), np.asarray(b)) for a, b in zip(Ks, Ks2))
                    and all(np.array_equal(np.asarray(a), np.asarray(b)) for a, b in zip(Ts, Ts2)))
    else:
        rms_ret = rms_ext
    Ks = [np.asarray(k, np.float64).reshape(3, 3) for k in Ks2]
    dists = [np.asarray(d, np.float64).ravel() for d in dists2]
    Rs = [as_rotation(r) for r in Rs2]
    Ts = [np.asarray(t, np.float64).ravel() for t in Ts2]
    frame_R, frame_T = [], []
    for f in range(p["nf"]):
        r, t = np.asarray(rvecs0[f]), np.asarray(tvecs0[f])
        if r.size == 0:
            frame_R.append(None)
            frame_T.append(None)
        else:
            frame_R.append(as_rotation(r))
            frame_T.append(t.astype(np.float64).ravel())
    rms, n = rms_of(p, Ks, dists, Rs, Ts, frame_R, frame_T)
    return {
        "seconds_all": times,
        "seconds_median": statistics.median(times),
        "seconds_best": min(times),
        # CPU time of this process during each timed call: close to the wall time when the
        # call had a core to itself, lower when other work on the machine took turns.
        "cpu_seconds_all": cpu,
        "rms_returned": float(rms_ret),
        "rms": rms,
        "points": n,
        "timed_call": called,
        "extended_matches_timed": same,
        "initialization_pairs": np.asarray(pairs).tolist() if pairs is not None else None,
        "truth": truth_errors(p, Ks, Rs, Ts),
        "cameras": [{"camera_matrix": K.tolist(), "dist_coeffs": d.tolist(), "R": R.tolist(), "T": T.tolist()}
                    for K, d, R, T in zip(Ks, dists, Rs, Ts)],
    }


def read_ours(p, path, process_times=None):
    with open(path) as f:
        r = json.load(f)
    Ks = [np.asarray(c["camera_matrix"], np.float64) for c in r["cameras"]]
    dists = [np.asarray(c["dist_coeffs"], np.float64).ravel() for c in r["cameras"]]
    Rs = [np.asarray(c["R"], np.float64) for c in r["cameras"]]
    Ts = [np.asarray(c["T"], np.float64).ravel() for c in r["cameras"]]
    frame_R, frame_T = [None] * p["nf"], [None] * p["nf"]
    for fr in r["frames"]:
        i = fr["index"]
        frame_R[i] = np.asarray(fr["rotation_matrix"], np.float64)
        frame_T[i] = np.asarray(fr["translation"], np.float64).ravel()
    rms, n = rms_of(p, Ks, dists, Rs, Ts, frame_R, frame_T)
    ts = r.get("elapsed_seconds_all") or [r["elapsed_seconds"]]
    share = None
    if process_times and os.path.exists(process_times):
        # "user sys real" of the whole calib process (bash's time; all repeats plus file I/O).
        user, system, real = (float(x) for x in open(process_times).read().split()[:3])
        share = (user + system) / real if real > 0 else None
    return {
        "seconds_median": float(r["elapsed_seconds"]),
        "seconds_all": ts,
        "seconds_best": min(ts),
        "process_cpu_share": share,
        "rms_reported": float(r["rms"]),
        "rms": rms,
        "points": n,
        "truth": truth_errors(p, Ks, Rs, Ts),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("obs")
    ap.add_argument("--ours", help="our calib rig result JSON for the same file")
    ap.add_argument("--ours-time", help="file with 'user sys real' seconds of the calib process")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--time-extended", action="store_true",
                    help="time cv2.calibrateMultiviewExtended (the same job, also returning the board "
                         "poses) and skip the untimed second run: halves the OpenCV time on large sets")
    a = ap.parse_args()
    p = load(a.obs)
    row = {
        "file": a.obs,
        "name": p["data"].get("name", ""),
        "cameras": p["nc"],
        "frames": p["nf"],
        "views": int(p["mask"].sum()),
        "points": sum(len(v[3]) for v in p["views"]),
        "models": sorted(set(p["models"])),
        "opencv_version": cv2.__version__,
        "opencv_threads": cv2.getNumThreads(),
    }
    row["opencv"] = run_opencv(p, a.repeats, a.time_extended)
    if a.ours:
        row["ours"] = read_ours(p, a.ours, a.ours_time)
    json.dump(row, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
