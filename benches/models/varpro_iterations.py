#!/usr/bin/env python3
"""Experiment: variable projection (VarPro) for thin-prism12, against a plain Levenberg-Marquardt
on all parameters, both with MINPACK's LM (scipy.optimize.least_squares(method="lm"), numerical
Jacobian), from the brown-conrady5 minimum that `calib` starts thin-prism12 from.

The pixel of a thin-prism12 camera is linear in (cx, cy, k1, k2, k3, p1, p2, s1, s2, s3, s4) once
fx, fy, k4, k5, k6 and the board poses are fixed. VarPro solves those 11 exactly (linear least
squares) for every value of the others and runs LM on the others only (Golub and Pereyra; the
Jacobian here by finite differences of the projected residual). The question it answers: does
eliminating the linear parameters shorten the path along the rational valley (issue 13's speed
bar)? Results in docs/benchmarks-models.md, section 3 ("Variable projection").

    python3 -m venv /tmp/vp && /tmp/vp/bin/pip install numpy scipy
    /tmp/vp/bin/python benches/models/varpro_iterations.py OBSERVATIONS.json BC5_RESULT.json [varpro|full]

BC5_RESULT.json is `calib single OBSERVATIONS.json --model brown-conrady5 --no-outlier-rejection
-o BC5_RESULT.json`. Prints the final RMS (px, over points), the residual evaluations outside
the Jacobians (`nfev`), all calls, the number of Jacobians (calls - nfev) / parameters, and the
MINPACK status. Slow (pure numpy, numerical Jacobians: seconds to minutes per camera); not run in
CI.
"""

import json
import sys
import time
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

obs_file, bc5_file = sys.argv[1], sys.argv[2]
which = sys.argv[3] if len(sys.argv) > 3 else "varpro"
d = json.load(open(obs_file))
r = json.load(open(bc5_file))
views = d["views"]
used = {v["image"]: v for v in r["views"]}
X, U = [], []
poses = []
for v in views:
    if v["image"] not in used:
        continue
    rv = used[v["image"]]
    R = np.array(rv["rotation_matrix"])
    rvec = Rotation.from_matrix(R).as_rotvec()
    poses.append(np.concatenate([rvec, rv["translation"]]))
    X.append(np.array(v["object_points"], float))
    U.append(np.array(v["image_points"], float))
nv = len(X)
cam = r["camera"]
k5 = cam["dist_coeffs"]  # k1 k2 p1 p2 k3
k = np.zeros(12)
k[:5] = k5
intr = np.array([cam["fx"], cam["fy"], cam["cx"], cam["cy"]])
obs = np.concatenate([u.ravel() for u in U])


def normalized(pose_params):
    out = []
    for j in range(nv):
        p = pose_params[6 * j:6 * j + 6]
        R = Rotation.from_rotvec(p[:3]).as_matrix()
        s = X[j] @ R.T + p[3:]
        out.append(s[:, :2] / s[:, 2:3])
    return np.concatenate(out)


def project(intr, k, pose_params):
    n = normalized(pose_params)
    x, y = n[:, 0], n[:, 1]
    r2 = x * x + y * y
    r4, r6 = r2 * r2, r2 * r2 * r2
    num = 1 + k[0] * r2 + k[1] * r4 + k[4] * r6
    den = 1 + k[5] * r2 + k[6] * r4 + k[7] * r6
    c = num / den
    xd = x * c + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x) + k[8] * r2 + k[9] * r4
    yd = y * c + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y + k[10] * r2 + k[11] * r4
    return np.stack([intr[0] * xd + intr[2], intr[1] * yd + intr[3]], 1).ravel()


def full_res(p):
    return project(p[:4], p[4:16], p[16:]) - obs


def linear_design(fx, fy, k4, k5_, k6, pose_params):
    """Pixel = A @ l + b, l = (cx, cy, k1, k2, k3, p1, p2, s1, s2, s3, s4)."""
    n = normalized(pose_params)
    x, y = n[:, 0], n[:, 1]
    r2 = x * x + y * y
    r4, r6 = r2 * r2, r2 * r2 * r2
    den = 1 + k4 * r2 + k5_ * r4 + k6 * r6
    m = len(x)
    A = np.zeros((2 * m, 11))
    b = np.zeros(2 * m)
    # u rows (even), v rows (odd)
    A[0::2, 0] = 1
    A[1::2, 1] = 1
    for col, term in zip((2, 3, 4), (r2, r4, r6)):
        A[0::2, col] = fx * x * term / den
        A[1::2, col] = fy * y * term / den
    A[0::2, 5] = fx * 2 * x * y
    A[1::2, 5] = fy * (r2 + 2 * y * y)
    A[0::2, 6] = fx * (r2 + 2 * x * x)
    A[1::2, 6] = fy * 2 * x * y
    A[0::2, 7] = fx * r2
    A[0::2, 8] = fx * r4
    A[1::2, 9] = fy * r2
    A[1::2, 10] = fy * r4
    b[0::2] = fx * x / den
    b[1::2] = fy * y / den
    return A, b


def split_theta(t):
    return t[0], t[1], t[2], t[3], t[4], t[5:]


def vp_res(t):
    fx, fy, k4, k5_, k6, pp = split_theta(t)
    A, b = linear_design(fx, fy, k4, k5_, k6, pp)
    l, *_ = np.linalg.lstsq(A, obs - b, rcond=None)
    return A @ l + b - obs


def vp_full(t):
    fx, fy, k4, k5_, k6, pp = split_theta(t)
    A, b = linear_design(fx, fy, k4, k5_, k6, pp)
    l, *_ = np.linalg.lstsq(A, obs - b, rcond=None)
    kk = np.array([l[2], l[3], l[5], l[6], l[4], k4, k5_, k6, l[7], l[8], l[9], l[10]])
    return np.concatenate([[fx, fy, l[0], l[1]], kk, pp])


pose0 = np.concatenate(poses)
p0 = np.concatenate([intr, k, pose0])
print("views", nv, "points", len(obs) // 2, "start rms", np.sqrt(np.mean(full_res(p0).reshape(-1, 2) ** 2 * 2)))
for label, fun, x0 in ((
    ("full", full_res, p0),
    ("varpro", vp_res, np.concatenate([[intr[0], intr[1], 0, 0, 0], pose0])),
)):
    if label != which:
        continue
    t = time.time()
    calls = [0]
    def counted(x, fun=fun):
        calls[0] += 1
        return fun(x)
    sol = least_squares(counted, x0, method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=400 * (len(x0) + 1))
    res = sol.fun
    rms = np.sqrt(np.sum(res ** 2) / (len(res) / 2))
    print(f"{label:7s} rms {rms:.12f} nfev {sol.nfev} calls {calls[0]} jacobians ~{(calls[0] - sol.nfev) / len(x0):.1f} status {sol.status} {time.time() - t:.1f}s", flush=True)
    if label == "varpro":
        print("  full cost from varpro solution:", np.sqrt(np.sum(full_res(vp_full(sol.x)) ** 2) / (len(res) / 2)))
