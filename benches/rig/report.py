#!/usr/bin/env python3
"""Markdown tables for the rig benchmark from benches/rig/out/ (see README.md).

    report.py OUT MANIFEST --command CMD [--note TEXT ...] [--rig-speed FILE]
"""

import argparse
import json
import os
import platform
import re
import sys


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def px(v):
    return f"{v:.6f}" if abs(v) < 1000 else f"{v:.3g}"


def secs(t):
    if t is None:
        return "FAILED"
    return f"{t * 1000:.1f} ms" if t < 1 else f"{t:.2f} s"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("manifest")
    ap.add_argument("--command", required=True)
    ap.add_argument("--note", action="append", default=[])
    ap.add_argument("--rig-speed")
    a = ap.parse_args()

    rows, failures = [], []
    with open(a.manifest) as f:
        for line in f:
            name, file, ours_rep, cv_rep = line.rstrip("\n").split("\t")[:4]
            base = os.path.join(a.out, name)
            status = open(base + ".status").read().strip() if os.path.exists(base + ".status") else ""
            row = json.load(open(base + ".row.json")) if os.path.exists(base + ".row.json") else None
            rows.append((name, row, int(ours_rep), int(cv_rep), status))
            if status:
                failures.append(f"{name}: {status}")

    cv_version = next((r["opencv_version"] for _, r, *_ in rows if r), "n/a")
    print("## Rig calibration: `calib rig` vs OpenCV `cv2.calibrateMultiview`, one thread each")
    print()
    print("| data set | cameras | frames | views | points | models | noise | RMS calib | RMS OpenCV | "
          "OpenCV's returned value | time calib | time OpenCV | speed-up |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    verdicts = []
    for name, r, ours_rep, cv_rep, status in rows:
        if r is None:
            print(f"| {name} | | | | | | | FAILED | FAILED | | | | |")
            continue
        m = re.search(r"noise ([0-9.]+) px", r.get("name", ""))
        noise = f"{m.group(1)} px" if m else "?"
        models = ", ".join(x.replace("brown-conrady", "bc") for x in r["models"])
        o, u = r["opencv"], r.get("ours")
        ratio = o["seconds_median"] / u["seconds_median"] if u else None
        # An OpenCV solution 10x worse than ours did not calibrate the rig: no speed comparison.
        cv_failed = bool(u) and o["rms"] > 10 * u["rms"]
        ratio_text = "n/a (OpenCV wrong)" if cv_failed else (f"{ratio:.0f}x" if ratio else "n/a")
        print(f"| {name} | {r['cameras']} | {r['frames']} | {r['views']} | {r['points']} | {models} | {noise} | "
              f"{px(u['rms'])} | {px(o['rms'])} | {px(o['rms_returned'])} | "
              f"{secs(u['seconds_median']) if u else 'FAILED'} | {secs(o['seconds_median'])} | "
              f"{ratio_text} |" if u else
              f"| {name} | {r['cameras']} | {r['frames']} | {r['views']} | {r['points']} | {models} | {noise} | "
              f"FAILED | {px(o['rms'])} | {px(o['rms_returned'])} | FAILED | {secs(o['seconds_median'])} | n/a |")
        if u:
            verdicts.append((name, u["rms"] <= o["rms"] * (1 + 1e-9), u["rms"] - o["rms"], ratio,
                             u["seconds_median"], r, cv_failed))
    print()
    print("Accuracy against the generator's truth (largest over the cameras; T in mm: the boards have "
          "0.025 m squares):")
    print()
    print("| data set | max \\|T - T_true\\| calib | OpenCV | max rotation error calib | OpenCV | "
          "max \\|f - f_true\\| calib | OpenCV | max \\|c - c_true\\| calib | OpenCV |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, r, *_ in rows:
        if r is None or "ours" not in r or not r["ours"]["truth"]:
            continue
        tu, to = r["ours"]["truth"], r["opencv"]["truth"]
        g = lambda v, d: f"{v:.{d}f}" if abs(v) < 1000 else f"{v:.3g}"  # noqa: E731
        print(f"| {name} | {g(tu['max_T_error'] * 1000, 3)} mm | {g(to['max_T_error'] * 1000, 3)} mm | "
              f"{g(tu['max_R_error_deg'], 4)} deg | {g(to['max_R_error_deg'], 4)} deg | "
              f"{g(tu['max_f_error_px'], 3)} px | {g(to['max_f_error_px'], 3)} px | "
              f"{g(tu['max_c_error_px'], 3)} px | {g(to['max_c_error_px'], 3)} px |")
    print()
    print("Checks (issue 14: same or lower RMS, at least 10x faster):")
    print()
    for name, lower, diff, ratio, t, r, cv_failed in verdicts:
        per_view = r["points"] / max(1, r["views"])
        size = (f"{r['cameras']} cameras x {r['frames']} frames x "
                f"{per_view:.0f} points" if per_view == int(per_view) else
                f"{r['cameras']} cameras x {r['frames']} frames x {per_view:.1f} points on average")
        if cv_failed:
            print(f"- {name}: OpenCV's solution is wrong (RMS {px(r['opencv']['rms'])} px against calib's "
                  f"{px(r['ours']['rms'])} px): no speed comparison; calib {secs(t)} for {size} ({r['views']} views)")
            continue
        print(f"- {name}: RMS calib - OpenCV = {diff:+.3g} px ({'same or lower' if lower else 'HIGHER'}); "
              f"speed-up {ratio:.1f}x ({'>= 10x' if ratio >= 10 else 'BELOW 10x'}); "
              f"calib {secs(t)} for {size} ({r['views']} views)")
    if a.rig_speed and os.path.exists(a.rig_speed):
        print()
        print("`rig_speed` example (library call, 10 cameras x 500 frames x 54 points, ring 360, one thread):")
        print()
        print("```")
        print(open(a.rig_speed).read().rstrip())
        print("```")
    if failures:
        print()
        print("Failures:")
        print()
        for x in failures:
            print(f"- {x}")
    print()
    print("Timing: median of the in-process repeats (calib: `elapsed_seconds` of `--repeat` runs; "
          "OpenCV: `time.perf_counter()` around the call). Repeats per data set: "
          + ", ".join(f"{n} {o} calib / {c} OpenCV" for n, _, o, c, _ in rows) + ".")
    shares = []
    for name, r, *_ in rows:
        if r is None:
            continue
        o = r["opencv"]
        cv_share = sum(o.get("cpu_seconds_all", [])) / sum(o["seconds_all"]) if o.get("cpu_seconds_all") else None
        u_share = r.get("ours", {}).get("process_cpu_share")
        f = lambda x: f"{x:.2f}" if x is not None else "n/a"  # noqa: E731
        shares.append(f"{name} calib {f(u_share)} / OpenCV {f(cv_share)}")
    print("CPU share (CPU time / wall time; 1.00 = a core to itself, lower = other work on the machine "
          "took turns): " + "; ".join(shares) + ".")
    print("RMS: sqrt(mean over points of |projected - measured|^2), recomputed by compare_opencv.py "
          "with cv2.projectPoints from each tool's returned parameters on the float64 points.")
    print()
    print(f"- machine: {cpu_model()}, {os.cpu_count()} cores, {platform.system()} {platform.release()}; "
          "one thread per tool (cv2.setNumThreads(1), calib --threads 1)")
    print(f"- OpenCV {cv_version} (opencv-python-headless), numpy "
          f"{__import__('numpy').__version__}, Python {platform.python_version()}")
    for n in a.note:
        print(f"- {n}")
    print(f"- command: `{a.command}`")


if __name__ == "__main__":
    sys.exit(main())
