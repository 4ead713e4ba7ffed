#!/usr/bin/env python3
"""Synthetic observation files for testing the peer benchmark harness (numpy only).

FALLBACK / TESTING ONLY. `run.sh` generates its problems with `calib synth` so that OpenCV and
`calib` read byte-identical files; this script exists so that `opencv_peer.py` (and the harness
via `run.sh --python-synth`) can be exercised without the `calib` binary.

Usage (mirrors `calib synth`):
    make_synthetic.py single --views M --board COLSxROWS [--noise 0.2] [--seed S] -o FILE.json
    make_synthetic.py stereo --views M --board COLSxROWS [--noise 0.2] [--seed S] -o FILE.json

Scene: camera 640x480, fx = fy = 800, cx = 319.5, cy = 239.5 (OpenCV pixel convention: (0,0) is
the centre of the top-left pixel), distortion k1 = -0.2, k2 = 0.05, p1 = p2 = 0. The board is a
planar grid of COLS x ROWS inner corners (Z = 0), about 200 mm across; each view places it
350-700 mm in front of the camera, tilted up to 45 degrees about a random in-plane axis and
rolled arbitrarily, and is rejected and redrawn until every corner lands inside the image (both
images for stereo). Gaussian noise (sigma = --noise px, per coordinate) is added to the image
points. Stereo: right camera with slightly different intrinsics, X_right = R X_left + T with a
~100 mm baseline (OpenCV's stereoCalibrate convention).
"""

import argparse
import json
import math
import sys

import numpy as np

W, H = 640, 480
LEFT = {"fx": 800.0, "fy": 800.0, "cx": 319.5, "cy": 239.5, "dist": [-0.2, 0.05, 0.0, 0.0]}
RIGHT = {"fx": 805.0, "fy": 803.0, "cx": 322.0, "cy": 237.0, "dist": [-0.19, 0.045, 0.0, 0.0]}
STEREO_RVEC = [0.01, -0.02, 0.005]
STEREO_T = [-100.0, 1.0, 2.0]
MARGIN = 2.0  # px kept free at the image border
MAX_TRIES = 10000


def rodrigues(rvec):
    r = np.asarray(rvec, dtype=float)
    theta = np.linalg.norm(r)
    if theta < 1e-15:
        return np.eye(3)
    k = r / theta
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(theta) * kx + (1 - math.cos(theta)) * (kx @ kx)


def project(cam, pts_cam):
    """Pinhole + Brown-Conrady (k1, k2, p1, p2). pts_cam: Nx3 in the camera frame."""
    x = pts_cam[:, 0] / pts_cam[:, 2]
    y = pts_cam[:, 1] / pts_cam[:, 2]
    k1, k2, p1, p2 = cam["dist"]
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2 * r2
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.column_stack([cam["fx"] * xd + cam["cx"], cam["fy"] * yd + cam["cy"]])


def inside(uv):
    return bool(np.all((uv[:, 0] >= MARGIN) & (uv[:, 0] <= W - 1 - MARGIN)
                       & (uv[:, 1] >= MARGIN) & (uv[:, 1] <= H - 1 - MARGIN)))


def random_pose(rng, center):
    tilt = math.radians(rng.uniform(0.0, 45.0))
    phi = rng.uniform(0.0, 2 * math.pi)
    roll = rng.uniform(-math.pi, math.pi)
    r_tilt = rodrigues([tilt * math.cos(phi), tilt * math.sin(phi), 0.0])
    r_roll = rodrigues([0.0, 0.0, roll])
    rot = r_tilt @ r_roll
    depth = rng.uniform(350.0, 700.0)
    u, v = rng.uniform(-0.25, 0.25), rng.uniform(-0.2, 0.2)
    # Board centre goes to depth*(u, v, 1); t accounts for the board's own centre offset.
    t = depth * np.array([u, v, 1.0]) - rot @ center
    return rot, t


def parse_board(text):
    try:
        cols, rows = (int(s) for s in text.lower().split("x"))
    except ValueError:
        raise SystemExit(f"--board must look like COLSxROWS, got {text!r}")
    if cols < 2 or rows < 2:
        raise SystemExit("--board needs at least 2x2 corners")
    return cols, rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("kind", choices=["single", "stereo"])
    ap.add_argument("--views", type=int, required=True)
    ap.add_argument("--board", default="9x6", help="COLSxROWS inner corners (default 9x6)")
    ap.add_argument("--noise", type=float, default=0.2, help="pixel noise sigma per coordinate")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("-o", "--output", required=True)
    a = ap.parse_args(argv)

    cols, rows = parse_board(a.board)
    square = 200.0 / (max(cols, rows) - 1)
    obj = np.array([[i * square, j * square, 0.0] for j in range(rows) for i in range(cols)])
    center = obj.mean(axis=0)
    rng = np.random.default_rng(a.seed)
    r_lr = rodrigues(STEREO_RVEC)
    t_lr = np.array(STEREO_T)

    obj_list = [[float(c) for c in p] for p in obj]
    views = []
    for k in range(a.views):
        for _ in range(MAX_TRIES):
            rot, t = random_pose(rng, center)
            pc = obj @ rot.T + t
            if np.any(pc[:, 2] <= 1.0):
                continue
            uv_l = project(LEFT, pc)
            if not inside(uv_l):
                continue
            if a.kind == "stereo":
                pr = pc @ r_lr.T + t_lr
                if np.any(pr[:, 2] <= 1.0):
                    continue
                uv_r = project(RIGHT, pr)
                if not inside(uv_r):
                    continue
            break
        else:
            raise SystemExit("could not place the board inside the image(s); board too large?")
        uv_l = uv_l + rng.normal(0.0, a.noise, uv_l.shape)
        if a.kind == "single":
            views.append({"image": f"view{k + 1:04d}", "object_points": obj_list,
                          "image_points": uv_l.tolist()})
        else:
            uv_r = uv_r + rng.normal(0.0, a.noise, uv_r.shape)
            views.append({"left_image": f"left{k + 1:04d}", "right_image": f"right{k + 1:04d}",
                          "object_points": obj_list, "left_points": uv_l.tolist(),
                          "right_points": uv_r.tolist()})

    out = {
        "name": f"pysynth_{a.kind}_{a.views}x{cols * rows}",
        "kind": a.kind,
        "generator": "benches/peers/make_synthetic.py " + " ".join(sys.argv[1:] if argv is None else argv),
        "image_size": [W, H],
        "board": {"cols": cols, "rows": rows, "square": square, "units": "mm"},
        "truth": {"left" if a.kind == "stereo" else "camera": LEFT, "noise_sigma_px": a.noise},
    }
    if a.kind == "stereo":
        out["truth"]["right"] = RIGHT
        out["truth"]["R"] = r_lr.tolist()
        out["truth"]["T"] = STEREO_T
        out["truth"]["convention"] = "X_right = R * X_left + T"
        out["right_image_size"] = [W, H]
        out["pairs"] = views
    else:
        out["views"] = views
    with open(a.output, "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    main()
