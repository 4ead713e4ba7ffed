#!/usr/bin/env python3
"""OpenCV chessboard detection for the detector comparison (benches/detect/run.sh).

Runs cv2.findChessboardCorners (flags ADAPTIVE_THRESH | NORMALIZE_IMAGE, as in our data files)
followed by cv2.cornerSubPix with a fixed square window of half-size --half-win, single-threaded,
on every image given, and writes an observation file in the workspace format (docs/formats.md):
views, rejected_images, detection_seconds_per_image (median over all images, detection plus
refinement only: decoding is excluded).
"""
import argparse
import json
import os
import statistics
import time

import cv2
import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cols", type=int, default=9)
    ap.add_argument("--rows", type=int, default=6)
    ap.add_argument("--square", type=float, required=True)
    ap.add_argument("--half-win", type=int, default=11,
                    help="cornerSubPix half window (11 -> 23x23 pixels, OpenCV's winSize=(11,11))")
    ap.add_argument("--repeats", type=int, default=1, help="time each image this many times (min)")
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("images", nargs="+")
    a = ap.parse_args()
    cv2.setNumThreads(1)
    pattern = (a.cols, a.rows)
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
    obj = [[c * a.square, r * a.square, 0.0] for r in range(a.rows) for c in range(a.cols)]
    views, rejected, times = [], [], []
    size = None
    for path in a.images:
        name = os.path.basename(path)
        gray = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        if gray is None:
            rejected.append({"image": name, "reason": "unreadable"})
            continue
        size = [gray.shape[1], gray.shape[0]]
        best = None
        for _ in range(max(1, a.repeats)):
            t0 = time.perf_counter()
            ok, corners = cv2.findChessboardCorners(gray, pattern, flags=flags)
            if ok:
                corners = cv2.cornerSubPix(gray, corners, (a.half_win, a.half_win), (-1, -1), criteria)
            dt = time.perf_counter() - t0
            best = dt if best is None else min(best, dt)
        times.append(best)
        if not ok:
            rejected.append({"image": name, "reason": "findChessboardCorners failed"})
            continue
        pts = corners.reshape(-1, 2).astype(np.float64)
        views.append({"image": name, "object_points": obj, "image_points": pts.tolist()})
    out = {
        "image_size": size,
        "views": views,
        "rejected_images": rejected,
        "detection_seconds_per_image": statistics.median(times) if times else None,
        "board": {"cols": a.cols, "rows": a.rows, "square": a.square},
        "detector": f"opencv {cv2.__version__} findChessboardCorners + cornerSubPix half-win {a.half_win}",
    }
    with open(a.output, "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    main()
