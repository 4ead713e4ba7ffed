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


# OpenCV's algorithms in double precision with converged undistortion ---------------------------
# cv2.stereoRectify and cv2.getOptimalNewCameraMatrix keep some corners in float32 and undistort
# with a fixed number of iterations (5 by default), which limits any comparison with them to
# ~1e-8 relative (and to pixels for strong distortion, e.g. rational8). The functions below are
# line-by-line transcriptions of OpenCV 4/5's C++ (calibration.cpp: cvStereoRectify,
# getUndistortRectangles, getOptimalNewCameraMatrix) in float64, with cv2.undistortPoints run to
# convergence. Each is first checked against the cv2 function itself (to float32 rounding), then
# compared with calib at 1e-9 relative, the bound.
CONVERGED = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 1000, 1e-15)


def undistort_exact(pts, K, D, R=None, P=None):
    pts = np.asarray(pts, float).reshape(-1, 1, 2)
    return cv2.undistortPoints(pts, K, D, None, R, P, criteria=CONVERGED).reshape(-1, 2)


def rectangles(K, D, R, P, size):
    """getUndistortRectangles: inner and outer rectangles (x, y, w, h) of a 9x9 border grid."""
    n = 9
    grid = [(x * (size[0] - 1) / (n - 1), y * (size[1] - 1) / (n - 1)) for y in range(n) for x in range(n)]
    q = undistort_exact(grid, K, D, R, P).reshape(n, n, 2)
    ix0, ix1 = q[:, 0, 0].max(), q[:, n - 1, 0].min()
    iy0, iy1 = q[0, :, 1].max(), q[n - 1, :, 1].min()
    ox0, ox1, oy0, oy1 = q[..., 0].min(), q[..., 0].max(), q[..., 1].min(), q[..., 1].max()
    return (ix0, iy0, ix1 - ix0, iy1 - iy0), (ox0, oy0, ox1 - ox0, oy1 - oy0)


def optimal_new_camera_matrix_f64(K, D, size, alpha):
    inner, outer = rectangles(K, D, None, None, size)
    w, h = size
    fx0, fy0 = (w - 1) / inner[2], (h - 1) / inner[3]
    cx0, cy0 = -fx0 * inner[0], -fy0 * inner[1]
    fx1, fy1 = (w - 1) / outer[2], (h - 1) / outer[3]
    cx1, cy1 = -fx1 * outer[0], -fy1 * outer[1]
    mix = lambda a, b: a * (1 - alpha) + b * alpha
    return np.array([[mix(fx0, fx1), 0, mix(cx0, cx1)], [0, mix(fy0, fy1), mix(cy0, cy1)], [0, 0, 1.0]])


def stereo_rectify_f64(K1, D1, K2, D2, size, R, T, alpha):
    """cvStereoRectify with CALIB_ZERO_DISPARITY and newImageSize = imageSize."""
    T = np.asarray(T, float).ravel()
    om, _ = cv2.Rodrigues(R)
    r_r, _ = cv2.Rodrigues(-0.5 * om)
    t = r_r @ T
    idx = 0 if abs(t[0]) > abs(t[1]) else 1
    c = t[idx]
    nt = np.linalg.norm(t)
    uu = np.zeros(3)
    uu[idx] = 1.0 if c > 0 else -1.0
    ww = np.cross(t, uu)
    nw = np.linalg.norm(ww)
    if nw > 0:
        ww *= np.arccos(abs(c) / nt) / nw
    wR, _ = cv2.Rodrigues(ww)
    R1 = wR @ r_r.T
    R2 = wR @ r_r
    t = R2 @ T
    nx, ny = size
    fc = (K1[idx ^ 1, idx ^ 1] + K2[idx ^ 1, idx ^ 1]) / 2
    cc = []
    for K, D, Rk in [(K1, D1, R1), (K2, D2, R2)]:
        corners = [((i % 2) * (nx - 1), (i // 2) * (ny - 1)) for i in range(4)]
        n = undistort_exact(corners, K, D)
        p3 = np.concatenate([n, np.ones((4, 1))], 1) @ Rk.T
        proj = fc * p3[:, :2] / p3[:, 2:]
        avg = proj.mean(0)
        cc.append(np.array([(nx - 1) / 2 - avg[0], (ny - 1) / 2 - avg[1]]))
    centre = (cc[0] + cc[1]) / 2
    cc = [centre, centre.copy()]

    def P(f, c, tx):
        p = np.array([[f, 0, c[0], 0], [0, f, c[1], 0], [0, 0, 1.0, 0]])
        p[idx, 3] = tx
        return p

    P1, P2 = P(fc, cc[0], 0), P(fc, cc[1], t[idx] * fc)
    in1, out1 = rectangles(K1, D1, R1, P1[:, :3], size)
    in2, out2 = rectangles(K2, D2, R2, P2[:, :3], size)
    s = 1.0
    if alpha >= 0:
        ratios = lambda r, c: [c[0] / (c[0] - r[0]), c[1] / (c[1] - r[1]),
                               (nx - 1 - c[0]) / (r[0] + r[2] - c[0]), (ny - 1 - c[1]) / (r[1] + r[3] - c[1])]
        s0 = max(ratios(in1, cc[0]) + ratios(in2, cc[1]))
        s1 = min(ratios(out1, cc[0]) + ratios(out2, cc[1]))
        s = s0 * (1 - alpha) + s1 * alpha
    fc *= s
    P1, P2 = P(fc, cc[0], 0), P(fc, cc[1], s * t[idx] * (fc / s))
    Q = np.array([[1, 0, 0, -cc[0][0]], [0, 1, 0, -cc[0][1]], [0, 0, 0, fc],
                  [0, 0, -1 / t[idx], (cc[0][idx] - cc[1][idx]) / t[idx]]])
    return R1, R2, P1, P2, Q


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
    print("\n1. cv2.FileStorage reads our OpenCV YAML back (max |difference|, exact expected; single, stereo, rig)")
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

    # A rig of four cameras (synthetic: a ring, two pinhole and two fisheye lenses) in the
    # OpenCV rig layout (camera_0 ...: camera_matrix, distortion_coefficients, R, T, name).
    rig4_obs = tmp / "synth-rig4.json"
    run(a.calib, "synth", "rig", "--cameras", "4", "--views", "30", "-o", rig4_obs)
    rig4_json = tmp / "rig4.json"
    run(a.calib, "rig", rig4_obs, "-q", "--model", "cam1=kannala-brandt4", "--model", "cam3=kannala-brandt4",
        "-o", rig4_json, f"--export=opencv={tmp/'rig4.yaml'}")
    rig4 = json.loads(rig4_json.read_text())
    fs = cv2.FileStorage(str(tmp / "rig4.yaml"), cv2.FILE_STORAGE_READ)
    check("rig: rig_cameras", abs(fs.getNode("rig_cameras").real() - len(rig4["cameras"])), 0.0)
    worst = 0.0
    for i, c in enumerate(rig4["cameras"]):
        node = fs.getNode(f"camera_{i}")
        if node.getNode("name").string() != c["name"]:
            failures.append(f"rig: camera_{i}.name")
        Kc, Dc, _ = cam(c)
        for key, value in [("camera_matrix", Kc), ("distortion_coefficients", Dc), ("R", m(c["R"])), ("T", np.array(c["T"]))]:
            got = node.getNode(key).mat()
            worst = max(worst, float(np.max(np.abs(got.reshape(value.shape) - value))))
    check("rig (4 cameras, 2 fisheye): K, D, R, T of every camera", worst, 0.0)
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
            f64 = stereo_rectify_f64(K1, d1, K2, d2, size, R, T, alpha)
            for name, theirs, exact in zip(["R1", "R2", "P1", "P2", "Q"], cv[:5], f64):
                check(f"alpha {alpha:4}: {name} vs cv2.stereoRectify", rel(m(ours[name]), theirs), 1e-12 if name in ("R1", "R2") else bound)
                # The transcription reproduces cv2 to the same float32/iteration limits ...
                check(f"alpha {alpha:4}: {name}: float64 transcription vs cv2", rel(exact, theirs), 1e-12 if name in ("R1", "R2") else bound)
                # ... and calib to the bound.
                check(f"alpha {alpha:4}: {name} vs OpenCV's algorithm in float64", rel(m(ours[name]), exact), 1e-9)
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
        check(f"alpha {alpha}: new camera matrix vs cv2 (relative)", rel(m(ours["new_camera_matrix"]), Knew), 1e-5)
        check(f"alpha {alpha}: new camera matrix vs OpenCV's algorithm in float64", rel(m(ours["new_camera_matrix"]), optimal_new_camera_matrix_f64(K, D, size, alpha)), 1e-9)
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
    # --- 4. Every lens model ------------------------------------------------------------------
    print("\n4. Every lens model (synthetic 640x480 calibrations): FileStorage read-back, undistortion maps")
    # A smooth texture (sums of sines) so that a remap difference measures the maps' difference.
    yy, xx = np.mgrid[0:480, 0:640].astype(float)
    texture = np.zeros((480, 640, 3))
    for c, (fx_, fy_, ph) in enumerate([(0.031, 0.017, 0.3), (0.013, 0.029, 1.1), (0.021, 0.023, 2.0)]):
        texture[:, :, c] = 127.5 + 120 * np.sin(fx_ * xx + ph) * np.cos(fy_ * yy - ph)
    tex_png = tmp / "texture.png"
    cv2.imwrite(str(tex_png), np.round(texture).astype(np.uint8))
    for model in ["brown-conrady4", "brown-conrady5", "rational8", "thin-prism12", "kannala-brandt4"]:
        obs = tmp / f"synth-{model}.json"
        run(a.calib, "synth", "single", "--model", model, "--views", "25", "--noise", "0.1", "-o", obs)
        res = tmp / f"single-{model}.json"
        run(a.calib, "single", obs, "-q", "--model", model, "-o", res, f"--export=opencv={tmp / f'single-{model}.yaml'}")
        j = json.loads(res.read_text())
        Km, Dm, sz = cam(j["camera"])
        fs = cv2.FileStorage(str(tmp / f"single-{model}.yaml"), cv2.FILE_STORAGE_READ)
        back = max(np.max(np.abs(fs.getNode("camera_matrix").mat() - Km)),
                   np.max(np.abs(fs.getNode("distortion_coefficients").mat().ravel() - Dm)))
        fs.release()
        check(f"{model}: FileStorage read-back of K and {len(Dm)} coefficients", back, 0.0)
        out = tmp / f"und-{model}"
        run(a.calib, "undistort", res, tex_png, "-q", "--alpha", "0", "-o", out)
        ours = json.loads((out / "undistortion.json").read_text())
        K_ours = m(ours["new_camera_matrix"])
        if model == "kannala-brandt4":
            map1, map2 = cv2.fisheye.initUndistortRectifyMap(Km, Dm, np.eye(3), K_ours, sz, cv2.CV_32FC1)
        else:
            Knew, _ = cv2.getOptimalNewCameraMatrix(Km, Dm, sz, 0.0)
            # OpenCV's fixed 5 undistortion iterations do not converge for every model (rational8
            # misses the border by pixels): how far, and the comparison that does not depend on it.
            grid = np.array([(x * (sz[0] - 1) / 8, y * (sz[1] - 1) / 8) for y in range(9) for x in range(9)])
            n5 = cv2.undistortPoints(grid.reshape(-1, 1, 2), Km, Dm).reshape(-1, 2)
            back, _ = cv2.projectPoints(np.concatenate([n5, np.ones((len(n5), 1))], 1), np.zeros(3), np.zeros(3), Km, Dm)
            miss = np.abs(back.reshape(-1, 2) - grid).max()
            print(f"       {model}: cv2.undistortPoints (default iterations) misses the border grid by up to {miss:.2e} px; cv2's new matrix differs from ours by {rel(K_ours, Knew):.2e} relative")
            if miss < 1e-3:
                check(f"{model}: new camera matrix vs cv2 (relative)", rel(K_ours, Knew), 1e-5)
            check(f"{model}: new camera matrix vs OpenCV's algorithm in float64", rel(K_ours, optimal_new_camera_matrix_f64(Km, Dm, sz, 0.0)), 1e-9)
            map1, map2 = cv2.initUndistortRectifyMap(Km, Dm, None, K_ours, sz, cv2.CV_32FC1)
        theirs = cv2.remap(cv2.imread(str(tex_png)), map1, map2, cv2.INTER_LINEAR).astype(float)
        mine = cv2.imread(str(out / "texture.png")).astype(float)
        inside = (map1 >= 1) & (map2 >= 1) & (map1 <= sz[0] - 2) & (map2 <= sz[1] - 2)
        diff = np.abs(mine - theirs)[inside]
        print(f"       {model}: remapped texture |difference| mean {diff.mean():.4f}, max {diff.max():.0f} grey levels over {inside.sum()} pixels")
        check(f"{model}: remapped texture mean |difference| (levels)", float(diff.mean()), 0.5)

    print(f"\n{'all checks passed' if not failures else 'FAILED: ' + ', '.join(failures)}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
