#!/usr/bin/env python3
"""How many Levenberg-Marquardt iterations OpenCV 5 needs for the rational models, and what one
costs: cv2.calibrateCamera on the four bundled cameras with the iteration limit set to N
(TermCriteria COUNT + EPS, epsilon DBL_EPSILON), for growing N, against its default criteria.

    benches/models/.venv/bin/python benches/models/opencv_iterations.py   # after run.sh made the venv

Prints, per camera and model, the RMS above OpenCV's own converged RMS (limit 1000) and the time
of each call (one thread). The slope of time over N is OpenCV's cost per iteration; the N where the
RMS difference reaches zero is how many iterations its default run takes. Used in
docs/benchmarks-models.md, section 3 ("Where the time goes").
"""

import json
import os
import sys
import time

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402
import cv2  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
CAMERAS = ["sourishg1/left", "sourishg1/right", "sourishg2/left", "sourishg2/right"]
MODELS = [
    ("rational8", cv2.CALIB_RATIONAL_MODEL),
    ("thin-prism12", cv2.CALIB_RATIONAL_MODEL | cv2.CALIB_THIN_PRISM_MODEL),
]
LIMITS = [5, 10, 20, 30, 50, 100, 150, 200]


def main():
    cv2.setNumThreads(1)
    print(f"OpenCV {cv2.__version__}; columns: iteration limit: RMS above the converged RMS / ms")
    for camera in CAMERAS:
        with open(os.path.join(ROOT, "data", camera + ".json")) as f:
            data = json.load(f)
        # OpenCV 5's calibrateCamera rejects float64 object points (see models_peer.py).
        obj = [np.array(v["object_points"], np.float32) for v in data["views"]]
        img = [np.array(v["image_points"], np.float32) for v in data["views"]]
        size = tuple(data["image_size"])

        def run(flags, criteria=None):
            t = time.perf_counter()
            if criteria is None:
                rms = cv2.calibrateCamera(obj, img, size, None, None, flags=flags)[0]
            else:
                rms = cv2.calibrateCamera(obj, img, size, None, None, flags=flags, criteria=criteria)[0]
            return rms, (time.perf_counter() - t) * 1e3

        for name, flags in MODELS:
            eps = sys.float_info.epsilon
            converged, _ = run(flags, (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 1000, eps))
            default, default_ms = run(flags)
            cells = []
            for n in LIMITS:
                rms, ms = run(flags, (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, n, eps))
                cells.append(f"{n}: {rms - converged:.1e} / {ms:.0f}")
            print(
                f"{camera:16s} {name:13s} default {default - converged:+.1e} px, {default_ms:.0f} ms | "
                + " | ".join(cells)
            )


if __name__ == "__main__":
    main()
