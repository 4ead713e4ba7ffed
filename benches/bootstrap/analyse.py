"""Honesty of the standard deviations over seeds (benches/bootstrap/run.sh).

    python analyse.py NAME=LIST [NAME=LIST ...]

LIST holds one line per seed: the corner file of `calib synth single` (with its `truth`) and the
result of `calib single --bootstrap B` on it. For fx, fy, cx, cy and k1, over the seeds:

  z lin    RMS of (estimate - truth) / linearized sigma (`camera.std`);
  z boot   RMS of (estimate - truth) / bootstrap sigma (`bootstrap.std`);
  boot/lin median ratio of the two sigmas;
  bias     mean error over the seeds, with its standard error (spread / sqrt(seeds));
  spread   standard deviation of the errors over the seeds; rms the errors' RMS.

Honest sigmas give z near 1 (with 50 seeds an RMS of z from truly unit-variance errors lies in
0.8 to 1.2 with 95% probability: relative standard error 1 / sqrt(2 n)). A bias well beyond its
standard error, comparable to the spread, would mean no sigma can cover the error. Also counts
the runs with the `bootstrap-spread` and `poorly-determined` warnings, and the failed resamples.
"""
import json
import sys

import numpy as np

NAMES = ["fx", "fy", "cx", "cy", "k1"]


def values(camera):
    return [camera["fx"], camera["fy"], camera["cx"], camera["cy"], camera["dist_coeffs"][0]]


def sigmas(std):
    return [std["fx"], std["fy"], std["cx"], std["cy"], std["dist_coeffs"][0]]


def main():
    print("| case | seeds | param | z lin | z boot | boot/lin | bias +- s.e. | spread | rms |")
    print("|---|---|---|---|---|---|---|---|---|")
    notes = []
    for arg in sys.argv[1:]:
        name, path = arg.split("=", 1)
        err, lin, boot = [], [], []
        spread_warn = poorly = failed = resamples = 0
        for line in open(path):
            synth_path, result_path = line.split()
            truth = json.load(open(synth_path))["truth"]
            result = json.load(open(result_path))
            t = [truth["fx"], truth["fy"], truth["cx"], truth["cy"], truth["distortion"][0]]
            err.append(np.subtract(values(result["camera"]), t))
            lin.append(sigmas(result["camera"]["std"]))
            boot.append(sigmas(result["bootstrap"]["std"]))
            codes = [w["code"] for w in result["warnings"]]
            spread_warn += "bootstrap-spread" in codes
            poorly += "poorly-determined" in codes
            failed += result["bootstrap"]["failed"]
            resamples += result["bootstrap"]["resamples"]
        if not err:
            continue
        err, lin, boot = np.array(err), np.array(lin), np.array(boot)
        n = len(err)
        with np.errstate(divide="ignore", invalid="ignore"):
            z_lin = np.sqrt(np.mean((err / lin) ** 2, axis=0))
            z_boot = np.sqrt(np.mean((err / boot) ** 2, axis=0))
            ratio = np.median(boot / lin, axis=0)
        bias = err.mean(axis=0)
        spread = err.std(axis=0, ddof=1) if n > 1 else np.zeros(len(NAMES))
        rms = np.sqrt(np.mean(err**2, axis=0))
        for j, p in enumerate(NAMES):
            print(
                f"| {name} | {n} | {p} | {z_lin[j]:.2f} | {z_boot[j]:.2f} | {ratio[j]:.2f} | "
                f"{bias[j]:+.3g} +- {spread[j] / np.sqrt(n):.2g} | {spread[j]:.3g} | {rms[j]:.3g} |"
            )
        notes.append(
            f"{name}: bootstrap-spread warning in {spread_warn} of {n} runs, poorly-determined in "
            f"{poorly}; {failed} of {resamples} resamples failed"
        )
    print()
    for note in notes:
        print(note)


if __name__ == "__main__":
    main()
