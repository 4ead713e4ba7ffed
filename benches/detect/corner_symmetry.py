"""Corner asymmetry (a Python mirror of board-detect's symmetry check, crates/board-detect/src/
symmetry.rs) on given corners: the RMS of I(q + d) - I(q - d) over the refinement window of the
blurred image, over the window's contrast (90th - 10th percentile); per board its median, its
largest corner and the largest / median ratio (the check refuses a corner above 8 times its
board's median and 0.06). The figures of docs/board-detect.md, pipeline step 7.

usage (repository root, with cv2 and numpy):
  python benches/detect/corner_symmetry.py data      # OpenCV's corners of the bundled data files
  python benches/detect/corner_symmetry.py BASEDIR   # lens_eval --save results.jsonl (our corners)
"""
import json, os, sys

import cv2
import numpy as np


def asymmetry(img, pts, cols, rows):
    g = pts.reshape(rows, cols, 2)
    d = np.r_[np.linalg.norm(np.diff(g, axis=1), axis=2).ravel(), np.linalg.norm(np.diff(g, axis=0), axis=2).ravel()]
    med = np.median(d)
    sigma = np.clip(0.1 * med, 0.7, 1.5)
    r = int(np.clip(round(0.2 * med), 2, 4))
    b = cv2.GaussianBlur(img.astype(np.float32), (0, 0), sigma)
    offs = [(dx, dy) for dy in range(0, r + 1) for dx in range(-r, r + 1) if dy > 0 or dx > 0]
    out = []
    for p in pts:
        pa = np.array([cv2.getRectSubPix(b, (1, 1), (p[0] + dx, p[1] + dy))[0, 0] for dx, dy in offs])
        pb = np.array([cv2.getRectSubPix(b, (1, 1), (p[0] - dx, p[1] - dy))[0, 0] for dx, dy in offs])
        s = np.r_[pa, pb]
        contrast = max(np.percentile(s, 90) - np.percentile(s, 10), 1.0)
        out.append(np.sqrt(np.mean((pa - pb) ** 2)) / contrast)
    return np.array(out)


def report(name, boards):
    med = np.array([np.median(a) for a in boards])
    mx = np.array([a.max() for a in boards])
    print(f'{name}: {len(boards)} boards, median per board {med.min():.3f}-{med.max():.3f}, '
          f'largest corner {mx.max():.3f}, largest/median {np.max(mx / med):.1f}')


def main():
    if sys.argv[1:] == ['data']:
        for f in ('data/sourishg1/left.json', 'data/sourishg1/right.json', 'data/sourishg2/left.json',
                  'data/sourishg2/right.json'):
            d = json.load(open(f))
            boards = []
            for v in d['views']:
                img = cv2.imread(os.path.join(os.path.dirname(f), 'images', v['image']), cv2.IMREAD_GRAYSCALE)
                boards.append(asymmetry(img, np.asarray(v['image_points'], float), 9, 6))
            report(f, boards)
    elif len(sys.argv) == 2:
        boards = []
        for line in open(os.path.join(sys.argv[1], 'results.jsonl')):
            r = json.loads(line)
            if r.get('corners'):
                img = cv2.imread(os.path.join(sys.argv[1], r['name'] + '.png'), cv2.IMREAD_GRAYSCALE)
                boards.append(asymmetry(img, np.asarray(r['corners'], float), r['cols'], r['rows']))
        report(sys.argv[1], boards)
    else:
        sys.exit(__doc__)


if __name__ == '__main__':
    main()
