"""Honesty of the stereo standard deviations over seeds (benches/bootstrap/run.sh --stereo).

    python analyse_stereo.py NAME=LIST [NAME=LIST ...]

LIST holds one line per seed: the pair file of `calib synth stereo` (with its `truth`) and the
result of `calib stereo` on it (with `--bootstrap B`, or without: then only the linearized
column). For each camera's fx, fy, cx, cy, the rig's three rotation parameters (rx, ry, rz), its
translation (Tx, Ty, Tz) and the baseline |T|, over the seeds:

  z lin    RMS of (estimate - truth) / linearized sigma (`left.std`, `right.std`, `rig_std`);
  z boot   RMS of (estimate - truth) / bootstrap sigma (`bootstrap`), when present;
  boot/lin median ratio of the two sigmas;
  spread   standard deviation of the errors over the seeds.

The rotation error is the rotation vector of R_true^T R_estimate (body-frame increments, the
`so3` parameterization's convention of `rig_std`). The baseline's linearized sigma is not in the
result (only T's diagonal sigmas are); it is approximated from them, ignoring their correlations:
sqrt(sum (T_i / |T|)^2 sigma_Ti^2) (for the default rig, T = (-100, 1, 2), that is sigma_Tx).
Honest sigmas give z near 1 (with 30 seeds an RMS of z from unit-variance errors lies in 0.75 to
1.25 with 95% probability: relative standard error 1 / sqrt(2 n)).
"""
import json
import sys

import numpy as np

CAMERA = ["fx", "fy", "cx", "cy"]
NAMES = [f"left {p}" for p in CAMERA] + [f"right {p}" for p in CAMERA] + [
    "rig rx", "rig ry", "rig rz", "rig Tx", "rig Ty", "rig Tz", "baseline"]


def log_so3(r):
    """Rotation vector of the rotation matrix r."""
    c = np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(c)
    w = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / 2.0
    s = np.sin(angle)
    return w if s < 1e-12 else w * angle / s


def errors_and_sigmas(truth, result):
    err, lin = [], []
    for side in ["left", "right"]:
        t, cam = truth[side], result[side]
        err += [cam[p] - t[p] for p in CAMERA]
        lin += [cam["std"][p] for p in CAMERA]
    r_true, r_est = np.array(truth["R"]), np.array(result["R"])
    err += list(log_so3(r_true.T @ r_est))
    t_true, t_est = np.array(truth["T"]), np.array(result["T"])
    err += list(t_est - t_true)
    err.append(np.linalg.norm(t_est) - np.linalg.norm(t_true))
    lin += list(result["rig_std"])
    u = t_est / np.linalg.norm(t_est)
    lin.append(float(np.sqrt(np.sum((u * np.array(result["rig_std"][3:])) ** 2))))
    boot = None
    b = result.get("bootstrap")
    if b is not None:
        boot = [b["left"]["std"][p] for p in CAMERA] + [b["right"]["std"][p] for p in CAMERA]
        boot += list(b["rig_std"]) + [b["baseline_std"]]
    return err, lin, boot


def main():
    print("| case | seeds | param | z lin | z boot | boot/lin | spread |")
    print("|---|---|---|---|---|---|---|")
    notes = []
    for arg in sys.argv[1:]:
        name, path = arg.split("=", 1)
        err, lin, boot = [], [], []
        spread_warn = failed = resamples = 0
        for line in open(path):
            synth_path, result_path = line.split()
            truth = json.load(open(synth_path))["truth"]
            result = json.load(open(result_path))
            e, l, b = errors_and_sigmas(truth, result)
            err.append(e)
            lin.append(l)
            if b is not None:
                boot.append(b)
                failed += result["bootstrap"]["failed"]
                resamples += result["bootstrap"]["resamples"]
            spread_warn += "bootstrap-spread" in [w["code"] for w in result["warnings"]]
        if not err:
            continue
        err, lin = np.array(err), np.array(lin)
        n = len(err)
        with np.errstate(divide="ignore", invalid="ignore"):
            z_lin = np.sqrt(np.mean((err / lin) ** 2, axis=0))
            if len(boot) == n:
                boot = np.array(boot)
                z_boot = [f"{z:.2f}" for z in np.sqrt(np.mean((err / boot) ** 2, axis=0))]
                ratio = [f"{r:.2f}" for r in np.median(boot / lin, axis=0)]
            else:
                z_boot = ratio = ["-"] * len(NAMES)
        spread = err.std(axis=0, ddof=1) if n > 1 else np.zeros(len(NAMES))
        for j, p in enumerate(NAMES):
            print(f"| {name} | {n} | {p} | {z_lin[j]:.2f} | {z_boot[j]} | {ratio[j]} | {spread[j]:.3g} |")
        if len(boot) == n:
            notes.append(
                f"{name}: bootstrap-spread warning in {spread_warn} of {n} runs; "
                f"{failed} of {resamples} resamples failed"
            )
    print()
    for note in notes:
        print(note)


if __name__ == "__main__":
    main()
