"""Telephoto / machine-vision single-camera corner files with known truth.

gen(seed, W, H, hfov_deg, views, noise, tilt=(10,50), frac=(0.2,0.5), model='brown-conrady4',
    dist=None, pp_off=0.05, board=(9,6), square=25.0)
Board fills `frac` of the image width, placed anywhere fully inside (5 px margin),
tilted by tilt degrees about a random in-plane axis, with random in-plane rotation.
"""
import json, math, sys
import numpy as np


def rodrigues(v):
    th = np.linalg.norm(v)
    if th < 1e-15:
        return np.eye(3)
    k = v / th
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(th) * Kx + (1 - math.cos(th)) * Kx @ Kx


def distort(xn, yn, d, model):
    r2 = xn * xn + yn * yn
    k1, k2, p1, p2 = d[:4]
    k3 = d[4] if model == 'brown-conrady5' else 0.0
    rad = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 ** 3
    xd = xn * rad + 2 * p1 * xn * yn + p2 * (r2 + 2 * xn * xn)
    yd = yn * rad + p1 * (r2 + 2 * yn * yn) + 2 * p2 * xn * yn
    return xd, yd


def project(K, d, model, R, t, obj):
    Xc = obj @ R.T + t
    xn = Xc[:, 0] / Xc[:, 2]
    yn = Xc[:, 1] / Xc[:, 2]
    xd, yd = distort(xn, yn, d, model)
    return np.stack([K[0] * xd + K[2], K[1] * yd + K[3]], 1), Xc[:, 2]


def gen(seed, W, H, hfov, views, noise, tilt=(10, 50), frac=(0.2, 0.5), model='brown-conrady4',
        dist=None, pp_off=0.05, board=(9, 6), square=25.0, fy_ratio=1.0, fx=None):
    rng = np.random.default_rng(seed)
    if fx is None:
        fx = (W / 2) / math.tan(math.radians(hfov) / 2)
    fy = fx * fy_ratio
    cx = (W - 1) / 2 + rng.uniform(-pp_off, pp_off) * W
    cy = (H - 1) / 2 + rng.uniform(-pp_off, pp_off) * H
    if dist is None:
        # small distortion typical of a long lens: a few px at the corner at most
        rc = math.hypot(W / 2, H / 2) / fx  # normalized corner radius
        k1 = rng.uniform(-1, 1) * 2.0 / (fx * rc ** 3)  # up to 2 px at the corner
        k1 = float(np.clip(k1, -1, 1))
        d = [k1, 0.0, rng.uniform(-1, 1) * 2e-4, rng.uniform(-1, 1) * 2e-4]
        if model == 'brown-conrady5':
            d.append(0.0)
    else:
        d = list(dist)
    cols, rows = board
    obj = np.array([[i * square, j * square, 0.0] for j in range(rows) for i in range(cols)])
    cen = obj.mean(0)
    bw = (cols - 1) * square
    K = (fx, fy, cx, cy)
    out_views, poses = [], []
    tries = 0
    while len(out_views) < views:
        tries += 1
        if tries > 100000:
            raise RuntimeError('cannot place boards')
        f = rng.uniform(*frac)
        Z = fx * bw / (f * W)
        ang = math.radians(rng.uniform(*tilt))
        phi = rng.uniform(0, 2 * math.pi)
        axis = np.array([math.cos(phi), math.sin(phi), 0.0])
        Rt = rodrigues(axis * ang)
        Rz = rodrigues(np.array([0, 0, 1.0]) * math.radians(rng.uniform(-30, 30)))
        R = Rt @ Rz
        # board centre at pixel (u, v)
        u = rng.uniform(0, W)
        v = rng.uniform(0, H)
        dirn = np.array([(u - cx) / fx, (v - cy) / fy, 1.0])
        C = dirn * Z
        t = C - R @ cen
        m, z = project(K, d, model, R, t, obj)
        if np.any(z <= 0):
            continue
        if np.any(m[:, 0] < 5) or np.any(m[:, 0] > W - 6) or np.any(m[:, 1] < 5) or np.any(m[:, 1] > H - 6):
            continue
        m = m + rng.normal(0, noise, m.shape)
        out_views.append({'image': f'v{len(out_views)}', 'object_points': obj.tolist(),
                          'image_points': m.tolist()})
        poses.append({'rotation_matrix': R.tolist(), 'translation': t.tolist()})
    return {'image_size': [W, H], 'views': out_views,
            'truth': {'model': model, 'fx': fx, 'fy': fy, 'cx': cx, 'cy': cy, 'distortion': d,
                      'poses': poses}}


if __name__ == '__main__':
    args = json.loads(sys.argv[1])
    out = sys.argv[2]
    json.dump(gen(**args), open(out, 'w'))
