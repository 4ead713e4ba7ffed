"""What the poor-coverage warning is about, measured: for each result pair (models A and B fitted
by calib to the same corners), the distance between where A and B map the ray that A sees at each
image corner, edge midpoint and the centre. A's pixel is undistorted with cv2.undistortPoints
(A's camera_matrix and dist_coeffs, OpenCV's order) and projected with B's (cv2.projectPoints).
Usage: extrapolation.py NAME A.json B.json [NAME A.json B.json ...]; prints a Markdown table.
"""
import json
import sys

import cv2
import numpy as np


def load(path):
    with open(path) as f:
        r = json.load(f)
    c = r["camera"]
    return r, np.array(c["camera_matrix"], float), np.array(c["dist_coeffs"], float)


args = sys.argv[1:]
if len(args) % 3 or not args:
    sys.exit("usage: extrapolation.py NAME A.json B.json [...]")
print("| set | A | B | RMS A, B (px) | A warned poor-coverage | top-left | top | top-right | right | bottom-right | bottom | bottom-left | left | centre (px) |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for i in range(0, len(args), 3):
    name, a_path, b_path = args[i:i + 3]
    ra, ka, da = load(a_path)
    rb, kb, db = load(b_path)
    w, h = ra["image_size"]
    x1, y1 = w - 1.0, h - 1.0
    places = np.array([[0, 0], [x1 / 2, 0], [x1, 0], [x1, y1 / 2], [x1, y1], [x1 / 2, y1], [0, y1],
                       [0, y1 / 2], [x1 / 2, y1 / 2]], float)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-14)
    rays = cv2.undistortPoints(places.reshape(-1, 1, 2), ka, da, criteria=criteria).reshape(-1, 2)
    back = cv2.projectPoints(np.hstack([rays, np.ones((len(rays), 1))]), np.zeros(3), np.zeros(3), ka, da)[0].reshape(-1, 2)
    # Rays A's own iteration did not find (a fold) are marked rather than compared.
    ok = np.hypot(*(back - places).T) < 1e-3
    moved = cv2.projectPoints(np.hstack([rays, np.ones((len(rays), 1))]), np.zeros(3), np.zeros(3), kb, db)[0].reshape(-1, 2)
    gap = np.hypot(*(moved - places).T)
    warned = any(x["code"] == "poor-coverage" for x in ra["warnings"])
    cells = ["%.1f" % g if k else "(A folds)" for g, k in zip(gap, ok)]
    print(f"| {name} | {ra['camera']['model']} | {rb['camera']['model']} | {ra['rms']:.4f}, {rb['rms']:.4f} | "
          f"{'yes' if warned else 'no'} | " + " | ".join(cells) + " |")
