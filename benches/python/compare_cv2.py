#!/usr/bin/env python3
"""The Python package `calib` against OpenCV, from Python, on the bundled data (not CI).

    benches/python/run.sh [--repeats N] [--threads N]

(run.sh makes benches/python/.venv with opencv-python-headless and numpy, installs
./crates/calib-py into it, and runs this script.) For each bundled camera it times, in the same
process and on the same float64 observations:

    cv2.calibrateCamera(obj32, img32, size, None, None, flags=CALIB_FIX_K3)
    calib.calibrate_camera(obj, img, size)                      (standard deviations included)
    calib.calibrate_camera(obj, img, size, compute_std=False)   (like cv2: no uncertainties)

(OpenCV 5 rejects float64 object points, so cv2 gets float32 copies), both stereo pairs with
cv2.stereoCalibrate(..., flags=CALIB_FIX_K3) against calib.stereo_calibrate, and chessboard
detection on the bundled photographs: cv2.findChessboardCorners + cv2.cornerSubPix (11x11, the
usual tutorial call) against calib.detect_chessboard on the same grey images. Each time is the
median of --repeats runs of the whole Python call (argument conversion and result arrays
included), one thread each by default (cv2.setNumThreads, calib's threads=). The RMS of both is
printed to show that they reach the same minimum. The ratio is OpenCV's time over calib's: above
1 means calib is faster.
"""

import argparse
import json
import os
import pathlib
import platform
import statistics
import sys
import time

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

import calib  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "data"


def median_time(f, repeats):
    """Median wall time of `f()` over `repeats` calls, and the results of every call."""
    times = []
    results = []
    for _ in range(repeats):
        t = time.perf_counter()
        results.append(f())
        times.append(time.perf_counter() - t)
    return statistics.median(times), results


def median_elapsed(results):
    """Median of calib's own timing (`elapsed`, measured inside Rust) over the calls."""
    return statistics.median(r.elapsed for r in results)


def single_case(name, repeats, threads):
    d = json.loads((DATA / name).read_text())
    obj = [np.array(v["object_points"]) for v in d["views"]]
    img = [np.array(v["image_points"]) for v in d["views"]]
    obj32 = [o.astype(np.float32) for o in obj]
    img32 = [i.astype(np.float32).reshape(-1, 1, 2) for i in img]
    size = tuple(d["image_size"])
    t_cv, (r_cv, *_) = median_time(
        lambda: cv2.calibrateCamera(obj32, img32, size, None, None, flags=cv2.CALIB_FIX_K3), repeats
    )
    t_std, rs = median_time(lambda: calib.calibrate_camera(obj, img, size, threads=threads), repeats)
    r = rs[0]
    t_nostd, _ = median_time(
        lambda: calib.calibrate_camera(obj, img, size, compute_std=False, threads=threads), repeats
    )
    return {
        "case": f"calibrate {name}",
        "size": f"{len(obj)} x {len(obj[0])}",
        "cv2": t_cv,
        "calib": t_std,
        "calib_nostd": t_nostd,
        "calib_inner": median_elapsed(rs),
        "rms_cv2": r_cv[0],
        "rms_calib": r.rms,
    }


def stereo_case(name, repeats, threads):
    d = json.loads((DATA / name).read_text())
    obj = [np.array(p["object_points"]) for p in d["pairs"]]
    left = [np.array(p["left_points"]) for p in d["pairs"]]
    right = [np.array(p["right_points"]) for p in d["pairs"]]
    obj32 = [o.astype(np.float32) for o in obj]
    l32 = [p.astype(np.float32).reshape(-1, 1, 2) for p in left]
    r32 = [p.astype(np.float32).reshape(-1, 1, 2) for p in right]
    size = tuple(d["image_size"])
    t_cv, (r_cv, *_) = median_time(
        lambda: cv2.stereoCalibrate(obj32, l32, r32, None, None, None, None, size, flags=cv2.CALIB_FIX_K3),
        repeats,
    )
    t, rs = median_time(lambda: calib.stereo_calibrate(obj, left, right, size, threads=threads), repeats)
    r = rs[0]
    return {
        "case": f"stereo {name}",
        "size": f"{len(obj)} pairs x {len(obj[0])}",
        "cv2": t_cv,
        "calib": t,
        "calib_nostd": None,
        "calib_inner": median_elapsed(rs),
        "rms_cv2": r_cv[0],
        "rms_calib": r.rms,
    }


def detect_case(folder, repeats):
    paths = sorted((DATA / folder / "images").glob("*.jpg"))
    images = [calib.imread_gray(p) for p in paths]
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)

    def run_cv2():
        found = 0
        for im in images:
            ok, corners = cv2.findChessboardCorners(im, (9, 6), None)
            if ok:
                cv2.cornerSubPix(im, corners, (11, 11), (-1, -1), criteria)
                found += 1
        return found

    def run_calib():
        return sum(calib.detect_chessboard(im, (9, 6)) is not None for im in images)

    t_cv, (n_cv, *_) = median_time(run_cv2, repeats)
    t, (n, *_) = median_time(run_calib, repeats)
    return {
        "case": f"detect {folder}/images",
        "size": f"{len(images)} images {images[0].shape[1]}x{images[0].shape[0]}",
        "cv2": t_cv / len(images),
        "calib": t / len(images),
        "calib_nostd": None,
        "calib_inner": None,
        "rms_cv2": f"{n_cv} found",
        "rms_calib": f"{n} found",
    }


def fmt_ms(t):
    return "-" if t is None else f"{t * 1e3:.2f}"


def fmt_rms(v):
    return v if isinstance(v, str) else f"{v:.6f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--threads", type=int, default=1, help="threads for both (default 1)")
    ap.add_argument("--command", default="benches/python/run.sh", help="the command line, for the report")
    args = ap.parse_args()
    cv2.setNumThreads(args.threads)
    rows = []
    for name in ["sourishg1/left.json", "sourishg1/right.json", "sourishg2/left.json", "sourishg2/right.json"]:
        rows.append(single_case(name, args.repeats, args.threads))
    for name in ["sourishg1/stereo.json", "sourishg2/stereo.json"]:
        rows.append(stereo_case(name, args.repeats, args.threads))
    for folder in ["sourishg1", "sourishg2"]:
        rows.append(detect_case(folder, max(1, args.repeats // 5)))

    cpu = platform.processor() or platform.machine()
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    print(f"Command: `{args.command}` ({args.repeats} repeats, median; {args.threads} thread(s) each)")
    print(f"Machine: {cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}")
    print(f"Python {platform.python_version()}, numpy {np.__version__}, cv2 {cv2.__version__}, calib {calib.__version__}")
    print()
    print("| case | data | cv2 ms | calib ms | ratio cv2/calib | calib ms, no std | calib ms inside Rust | cv2 RMS | calib RMS |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        ratio = r["cv2"] / r["calib"]
        print(
            f"| {r['case']} | {r['size']} | {fmt_ms(r['cv2'])} | {fmt_ms(r['calib'])} | {ratio:.1f} | "
            f"{fmt_ms(r['calib_nostd'])} | {fmt_ms(r['calib_inner'])} | {fmt_rms(r['rms_cv2'])} | {fmt_rms(r['rms_calib'])} |"
        )
    print()
    print("Detection rows: time per image; 'found' counts the images where the whole board was found.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
