"""A calibration set with some defective photographs: `calib single --board` must drop them
with a per-image reason (`rejected_images`) and still calibrate. See docs/board-detect.md,
"Photographic defects".

usage: python defects_set.py SETDIR OUTDIR --calib CALIB

SETDIR is a set rendered by `cargo run --release -p board-detect --example render_set -- barrel
SETDIR --seed 1` (view-NN.png, truth.json). OUTDIR gets the same set with six views replaced by
defective copies (the strongest level of defects.py's shadow-line, glare, occluder, motion,
lowlight and overexpose, on views 2, 5, 8, 11, 14, 17), runs `CALIB single --board 9x6 --square 1
--model MODEL OUTDIR/view-*.png -o OUTDIR/out.json` and prints the rejected images with their
reasons, the views used, the RMS and fx, fy, cx, cy against the truth (z = error / sigma).
"""
import argparse, glob, json, os, shutil, subprocess, sys, zlib

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import defects  # noqa: E402

REPLACED = {2: ('shadow-line', '70%'), 5: ('glare', 'r1.2'), 8: ('occluder', '2sq'),
            11: ('motion', '15px'), 14: ('lowlight', 'c30n20'), 17: ('overexpose', 'g4')}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('setdir')
    ap.add_argument('outdir')
    ap.add_argument('--calib', required=True)
    a = ap.parse_args()
    truth = json.load(open(os.path.join(a.setdir, 'truth.json')))
    os.makedirs(a.outdir, exist_ok=True)
    shutil.copyfile(os.path.join(a.setdir, 'truth.json'), os.path.join(a.outdir, 'truth.json'))
    for i, v in enumerate(truth['views']):
        src = os.path.join(a.setdir, v['image'])
        dst = os.path.join(a.outdir, v['image'])
        if i not in REPLACED:
            shutil.copyfile(src, dst)
            continue
        defect, level = REPLACED[i]
        img = cv2.imread(src, cv2.IMREAD_GRAYSCALE).astype(np.float32)
        g = np.asarray(v['corners'], float).reshape(6, 9, 2)
        rng = np.random.default_rng(zlib.crc32(f"{v['image']} {defect} {level}".encode()))
        out, _ = defects.apply(defect, level, img, g, rng, f'view-{i}')
        cv2.imwrite(dst, np.clip(np.round(out), 0, 255).astype(np.uint8))
        print(f"{v['image']}: {defect} {level}")
    cam = truth['camera']
    imgs = sorted(glob.glob(os.path.join(a.outdir, 'view-*.png')))
    out = os.path.join(a.outdir, 'out.json')
    p = subprocess.run([a.calib, 'single', '--board', '9x6', '--square', '1', '--model', cam['model'],
                        *imgs, '-o', out], capture_output=True, text=True)
    print(p.stderr.strip())
    if p.returncode != 0:
        sys.exit(f'calib single failed ({p.returncode})')
    r = json.load(open(out))
    for rej in r.get('rejected_images', []):
        print(f"rejected {rej['image']}: {rej['reason']}")
    c = r['camera']
    std = c.get('std', {})
    print(f"views used {r['num_views']} of {len(imgs)}, RMS {r['rms']:.4f} px, warnings: "
          + ', '.join(w.get('code', '?') if isinstance(w, dict) else str(w)[:40] for w in r.get('warnings', [])))
    for k in ('fx', 'fy', 'cx', 'cy'):
        e = c[k] - cam[k]
        s = std.get(k) if isinstance(std, dict) else None
        print(f"{k}: {c[k]:.3f} truth {cam[k]:.3f} error {e:+.3f}" + (f" z {e / s:+.2f}" if s else ''))

if __name__ == '__main__':
    main()
