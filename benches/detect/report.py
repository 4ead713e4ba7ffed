#!/usr/bin/env python3
"""Markdown table for benches/detect/run.sh: one row per detector and image set."""
import argparse
import glob
import json
import os
import platform
import subprocess


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def version(cmd):
    try:
        return subprocess.run(cmd, capture_output=True, text=True, check=False).stdout.strip().splitlines()[0]
    except (OSError, IndexError):
        return "unknown"


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", required=True)
    ap.add_argument("--calib", required=True)
    ap.add_argument("--command", required=True)
    a = ap.parse_args()
    rows = []
    for obs_path in sorted(glob.glob(os.path.join(a.out, "*.obs.json"))):
        name = os.path.basename(obs_path)[: -len(".obs.json")]
        method, dataset, cam = name.rsplit(".", 2)
        obs = json.load(open(obs_path))
        res_path = obs_path.replace(".obs.json", ".res.json")
        rms = None
        if os.path.exists(res_path):
            rms = json.load(open(res_path)).get("rms")
        n = len(obs["views"]) + len(obs.get("rejected_images", []))
        t = obs.get("detection_seconds_per_image")
        rows.append((method, f"{dataset} {cam}", f"{len(obs['views'])}/{n}", rms, t))
    order = {"opencv-hw11": 0, "opencv-hw5": 1, "calib-targets": 2, "board-detect": 3}
    rows.sort(key=lambda r: (r[1], order.get(r[0], 9), r[0]))
    print("| method | images | boards found | calibration RMS (px) | ms/image (median) |")
    print("|---|---|---|---|---|")
    for method, ds, found, rms, t in rows:
        rms_s = f"{rms:.4f}" if isinstance(rms, (int, float)) else "-"
        t_s = f"{1e3 * t:.2f}" if isinstance(t, (int, float)) else "-"
        print(f"| {method} | {ds} | {found} | {rms_s} | {t_s} |")
    print()
    try:
        import cv2
        import numpy
        cv = f"opencv-python-headless {cv2.__version__}, numpy {numpy.__version__}"
    except ImportError:
        cv = "opencv: not available"
    print(f"Machine: {cpu_model()}, {os.cpu_count()} cores, {platform.system()} {platform.release()}.")
    print(f"Versions: {cv}; {version(['rustc', '--version'])}; calibrator {a.calib}.")
    print("opencv-hwN: findChessboardCorners(ADAPTIVE_THRESH|NORMALIZE_IMAGE) + cornerSubPix(winSize=(N,N)).")
    print("Times: single thread, detection + refinement only (decoding excluded), fastest of the repeats per image, median over images.")
    print(f"Command: `{a.command.strip()}`")


if __name__ == "__main__":
    main()
