"""calib vs OpenCV on the same calibration (sourishg1): FileStorage read-back of our YAML,
stereoRectify, getOptimalNewCameraMatrix and initUndistortRectifyMap + remap.

Every OpenCV number is computed here, at run time, from the calibration calib wrote; nothing
is copied into the Rust code. Run through run.sh (its own venv with opencv-python-headless).
"""
import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np


def run(calib, *args):
    done = subprocess.run([calib, *map(str, args)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        sys.exit(f"calib {' '.join(map(str, args))} failed: {done.stderr}")


def rel(ours, theirs):
    ours, theirs = np.asarray(ours, float), np.asarray(theirs, float)
    return float(np.max(np.abs(ours - theirs)) / max(np.max(np.abs(theirs)), 1e-300))


def m(rows):
    return np.array(rows, dtype=float)


def cam(j):
    return m(j["camera_matrix"]), np.array(j["dist_coeffs"], float), tuple(j["image_size"])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--calib", required=True)
    ap.add_argument("--data", required=True)
    a = ap.parse_args()
    data = Path(a.data)
    tmp = Path(tempfile.mkdtemp(prefix="calib-after-"))
    print(f"OpenCV {cv2.__version__}, numpy {np.__version__}; work folder {tmp}")
    failures = []

    def check(name, value, bound):
        ok = value <= bound
        print(f"  {'ok  ' if ok else 'FAIL'} {name:58s} {value:10.3e}  (bound {bound:.0e})")
        if not ok:
            failures.append(name)

    # --- Calibrations by calib -------------------------------------------------------------
    rig_json = tmp / "rig.json"
    run(a.calib, "stereo", data / "stereo.json", "-q", "-o", rig_json, f"--export=opencv={tmp/'rig.yaml'}")
    left_json = tmp / "left.json"
    run(a.calib, "single", data / "left.json", "-q", "-o", left_json, f"--export=opencv={tmp/'left.yaml'}")
    # A fisheye rig: synthetic (the sourishg1 lenses are narrow; a Kannala-Brandt fit of them is
    # not invertible out to the right image's corners, which calib rectify reports as an error).
    kb_obs = tmp / "synth-kb.json"
    run(a.calib, "synth", "stereo", "--model", "kannala-brandt4", "--intrinsics", "300,300,319.5,239.5",
        "--right-intrinsics", "305,303,322,236", "--views", "25", "--noise", "0.1", "-o", kb_obs)
    kb_json = tmp / "rig-kb.json"
    run(a.calib, "stereo", kb_obs, "-q", "--model", "kannala-brandt4", "-o", kb_json)
    rig = json.loads(rig_json.read_text())
    left = json.loads(left_json.read_text())

    # --- 1. FileStorage reads back exactly our numbers -------------------------------------
    print("\n1. cv2.FileStorage reads our OpenCV YAML back (max |difference|, exact expected)")
    fs = cv2.FileStorage(str(tmp / "left.yaml"), cv2.FILE_STORAGE_READ)
    K, D, size = cam(left["camera"])
    check("single: camera_matrix", np.max(np.abs(fs.getNode("camera_matrix").mat() - K)), 0.0)
    check("single: distortion_coefficients", np.max(np.abs(fs.getNode("distortion_coefficients").mat().ravel() - D)), 0.0)
    check("single: image_width/height", abs(fs.getNode("image_width").real() - size[0]) + abs(fs.getNode("image_height").real() - size[1]), 0.0)
    fs.release()
    rect_json = tmp / "rect.json"
    run(a.calib, "rectify", rig_json, "-q", "--alpha", "0", "-o", rect_json)
    rect = json.loads(rect_json.read_text())
    fs = cv2.FileStorage(str(tmp / "rig.yaml"), cv2.FILE_STORAGE_READ)
    K1, D1, _ = cam(rig["left"])
    K2, D2, _ = cam(rig["right"])
    expected = {"M1": K1, "D1": D1, "M2": K2, "D2": D2, "R": m(rig["R"]), "T": np.array(rig["T"]),
                "R1": m(rect["R1"]), "R2": m(rect["R2"]), "P1": m(rect["P1"]), "P2": m(rect["P2"]), "Q": m(rect["Q"])}
    for key, value in expected.items():
        got = fs.getNode(key).mat()
        check(f"stereo: {key}", np.max(np.abs(got.reshape(value.shape) - value)), 0.0)
    E = fs.getNode("E").mat()
    F = fs.getNode("F").mat()
    check("stereo: E vs result E (relative)", rel(E, m(rig["E"])), 1e-12)
    check("stereo: F vs result F (relative)", rel(F, m(rig["F"])), 1e-9)
    fs.release()

    # --- 2. stereoRectify -------------------------------------------------------------------
    print("\n2. cv2.stereoRectify(flags=CALIB_ZERO_DISPARITY) vs calib rectify (max relative difference per matrix)")
    R, T = m(rig["R"]), np.array(rig["T"], float).reshape(3, 1)
    zero = dict(rig)
    zero["left"] = dict(rig["left"]); zero["right"] = dict(rig["right"])
    zero["left"]["dist_coeffs"] = [0.0] * len(D1)
    zero["right"]["dist_coeffs"] = [0.0] * len(D2)
    zero_json = tmp / "rig-zero.json"
    zero_json.write_text(json.dumps(zero))
    for label, source, d1, d2, bound in [
        # OpenCV keeps the four image corners of stereoRectify in single precision (CV_32FC2):
        # the principal point and focal length then carry ~1e-8 relative rounding.
        ("no distortion (exact undistortion in both; OpenCV's corners in float32)", zero_json, np.zeros(len(D1)), np.zeros(len(D2)), 5e-8),
        # ... and undistorts them (and getUndistortRectangles' grid) by a few fixed-point
        # iterations, where calib solves exactly (Newton to 1e-14).
        ("calibrated distortion (OpenCV's undistortPoints iterates a fixed number of times)", rig_json, D1, D2, 1e-5),
    ]:
        print(f"  {label}:")
        for alpha in [0.0, 0.5, 1.0, -1.0]:
            out = tmp / f"rect-{alpha}.json"
            run(a.calib, "rectify", source, "-q", "--alpha", alpha, "-o", out)
            ours = json.loads(out.read_text())
            cv = cv2.stereoRectify(K1, d1, K2, d2, size, R, T, flags=cv2.CALIB_ZERO_DISPARITY, alpha=alpha)
            for name, theirs in zip(["R1", "R2", "P1", "P2", "Q"], cv[:5]):
                check(f"alpha {alpha:4}: {name}", rel(m(ours[name]), theirs), 1e-12 if name in ("R1", "R2") else bound)
    print("  fisheye (kannala-brandt4): cv2.fisheye.stereoRectify's R1, R2 (its P1, P2 use another focal choice)")
    kb = json.loads(kb_json.read_text())
    out = tmp / "rect-kb.json"
    run(a.calib, "rectify", kb_json, "-q", "--alpha", "0", "-o", out)
    ours = json.loads(out.read_text())
    Kf1, Df1, _ = cam(kb["left"])
    Kf2, Df2, _ = cam(kb["right"])
    cv = cv2.fisheye.stereoRectify(Kf1, Df1, Kf2, Df2, tuple(kb["left"]["image_size"]), m(kb["R"]), np.array(kb["T"], float).reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY)
    check("fisheye: R1", rel(m(ours["R1"]), cv[0]), 1e-12)
    check("fisheye: R2", rel(m(ours["R2"]), cv[1]), 1e-12)
    # Our fisheye rectification with Bouguet's focal choice: its rectified rows must agree. Use
    # OpenCV's fisheye undistortPoints with our R and P on the calibration's corners.
    obs = json.loads(kb_obs.read_text())
    dys = []
    for pair in obs["pairs"]:
        pl = np.array(pair["left_points"], float).reshape(-1, 1, 2)
        pr = np.array(pair["right_points"], float).reshape(-1, 1, 2)
        ql = cv2.fisheye.undistortPoints(pl, Kf1, Df1, R=m(ours["R1"]), P=m(ours["P1"]))
        qr = cv2.fisheye.undistortPoints(pr, Kf2, Df2, R=m(ours["R2"]), P=m(ours["P2"]))
        dys.extend(np.abs(ql[:, 0, 1] - qr[:, 0, 1]))
    print(f"  fisheye: corners rectified by cv2.fisheye.undistortPoints with our R, P: |dy| mean {np.mean(dys):.3f} px, max {np.max(dys):.3f} px")
    check("fisheye: mean |dy| of the corners with our R, P (px)", float(np.mean(dys)), 0.5)

    # --- 3. Undistortion --------------------------------------------------------------------
    print("\n3. cv2.getOptimalNewCameraMatrix and initUndistortRectifyMap + remap vs calib undistort")
    png = tmp / "left1.png"
    cv2.imwrite(str(png), cv2.imread(str(data / "images" / "left1.jpg")))
    for alpha in [0.0, 0.5, 1.0]:
        out = tmp / f"und-{alpha}"
        run(a.calib, "undistort", left_json, png, "-q", "--alpha", alpha, "-o", out)
        ours = json.loads((out / "undistortion.json").read_text())
        Knew, roi = cv2.getOptimalNewCameraMatrix(K, D, size, alpha)
        check(f"alpha {alpha}: new camera matrix (relative)", rel(m(ours["new_camera_matrix"]), Knew), 1e-5)
        print(f"       valid ROI ours {ours['valid_roi']} OpenCV {list(roi)}")
        # Same new matrix in both, then compare the images where OpenCV's map stays inside.
        K_ours = m(ours["new_camera_matrix"])
        map1, map2 = cv2.initUndistortRectifyMap(K, D, None, K_ours, size, cv2.CV_32FC1)
        theirs = cv2.remap(cv2.imread(str(png)), map1, map2, cv2.INTER_LINEAR).astype(float)
        mine = cv2.imread(str(out / "left1.png")).astype(float)
        inside = (map1 >= 1) & (map2 >= 1) & (map1 <= size[0] - 2) & (map2 <= size[1] - 2)
        diff = np.abs(mine - theirs)[inside]
        print(f"       remapped image: |difference| mean {diff.mean():.3f}, 99% {np.percentile(diff, 99):.1f}, max {diff.max():.0f} grey levels over {inside.sum()} pixels")
        check(f"alpha {alpha}: remapped image mean |difference| (levels)", float(diff.mean()), 1.0)
    print(f"\n{'all checks passed' if not failures else 'FAILED: ' + ', '.join(failures)}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
