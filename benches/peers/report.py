#!/usr/bin/env python3
"""Build the peer-comparison table from the per-problem result files written by run.sh.

    report.py OUT_DIR MANIFEST.tsv --command "benches/peers/run.sh ..." [--calib-rev REV]

MANIFEST.tsv has one line per problem: name, kind (single|stereo), observation file, repeats.
For each problem it reads OUT_DIR/NAME.opencv.json (opencv_peer.py output) and
OUT_DIR/NAME.calib.r*.json (one `calib` result per repeat, fields rms and elapsed_seconds), and
OUT_DIR/NAME.status (optional, a short failure note). Prints Markdown to stdout.
"""

import argparse
import datetime
import glob
import json
import os
import platform
import re
import statistics
import subprocess


def machine():
    cpu = None
    try:
        with open("/proc/cpuinfo") as f:
            text = f.read()
        for key in ("model name", "Model", "cpu model", "Hardware"):
            m = re.search(rf"^{key}\s*:\s*(.+)$", text, re.M)
            if m:
                cpu = m.group(1).strip()
                break
        mhz = re.search(r"^cpu MHz\s*:\s*([\d.]+)", text, re.M)
        if cpu and mhz:
            cpu += f" ({float(mhz.group(1)):.0f} MHz)"
        phys = {(p, c) for p, c in re.findall(
            r"physical id\s*:\s*(\d+)[\s\S]*?core id\s*:\s*(\d+)", text)}
    except OSError:
        text, phys = "", set()
    cpu = cpu or platform.processor() or platform.machine()
    logical = os.cpu_count()
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = logical
    osname = None
    try:
        with open("/etc/os-release") as f:
            m = re.search(r'^PRETTY_NAME="?([^"\n]*)"?', f.read(), re.M)
            osname = m.group(1) if m else None
    except OSError:
        pass
    uname = platform.uname()
    cores = f"{logical} logical CPUs"
    if phys:
        cores += f" ({len(phys)} physical cores)"
    if usable != logical:
        cores += f", {usable} usable by this process"
    return {
        "cpu": cpu,
        "cores": cores,
        "os": f"{osname or uname.system}, kernel {uname.release} ({uname.machine})",
    }


def fmt_time(s):
    if s is None:
        return "-"
    if s < 1e-3:
        return f"{s * 1e6:.0f} µs"
    if s < 1:
        return f"{s * 1e3:.2f} ms" if s < 0.1 else f"{s * 1e3:.1f} ms"
    if s < 100:
        return f"{s:.2f} s"
    return f"{s:.0f} s"


def fmt_rms(x):
    return "-" if x is None else f"{x:.8f}"


def load_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def shape_of(obs_file, kind, opencv):
    if opencv and opencv.get("n_views"):
        nv, npts = opencv["n_views"], opencv["n_points"]
    else:
        d = load_json(obs_file)
        if d is None:
            return "?"
        views = d.get("views" if kind == "single" else "pairs", [])
        nv, npts = len(views), sum(len(v["object_points"]) for v in views)
    if nv == 0:
        return "0"
    per = npts / nv
    return f"{nv} x {int(per)}" if per == int(per) else f"{nv} x {per:.1f} (avg)"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out_dir")
    ap.add_argument("manifest")
    ap.add_argument("--command", required=True)
    ap.add_argument("--calib-rev", default="unknown", help="git revision of the calib sources")
    ap.add_argument("--note", action="append", default=[], help="extra header line (repeatable)")
    a = ap.parse_args()

    rows = []
    notes = []
    cv_version = None
    for line in open(a.manifest):
        if not line.strip():
            continue
        name, kind, obs, repeats = line.rstrip("\n").split("\t")[:4]
        base = os.path.join(a.out_dir, name)
        cv = load_json(base + ".opencv.json")
        if cv:
            cv_version = cv.get("opencv_version", cv_version)
        ours = []
        for p in sorted(glob.glob(base + ".calib.r*.json")):
            d = load_json(p)
            if (isinstance(d, dict) and isinstance(d.get("rms"), (int, float))
                    and isinstance(d.get("elapsed_seconds"), (int, float))):
                ours.append(d)
        status = None
        if os.path.exists(base + ".status"):
            lines = [x.strip() for x in open(base + ".status") if x.strip()]
            status = "; ".join(lines) or None
        cv_t = cv.get("seconds_median") if cv else None
        cv_rms = cv.get("rms") if cv else None
        our_ts = [d["elapsed_seconds"] for d in ours]
        our_t = statistics.median(our_ts) if our_ts else None
        # With --repeat, one result holds every in-process run.
        our_runs = sum(len(d.get("elapsed_seconds_all", [0])) for d in ours)
        our_rms_all = [d["rms"] for d in ours]
        our_rms = our_rms_all[0] if our_rms_all else None
        if our_rms_all and max(our_rms_all) - min(our_rms_all) > 1e-9:
            notes.append(f"{name}: calib rms varies between repeats "
                         f"({min(our_rms_all):.10f} .. {max(our_rms_all):.10f}).")
        ratio = f"{cv_t / our_t:.2f}x" if cv_t and our_t else "-"
        diff = f"{our_rms - cv_rms:+.2e}" if cv_rms is not None and our_rms is not None else "-"
        cv_rms64 = cv.get("rms_f64") if cv else None
        diff64 = (f"{our_rms - cv_rms64:+.2e}" if cv_rms64 is not None and our_rms is not None
                  else "n/a" if cv and cv.get("rms_f64_skipped") else "-")
        rows.append([
            name, shape_of(obs, kind, cv),
            fmt_time(cv_t) if cv else "FAILED" if status and "opencv" in status else "-",
            fmt_time(our_t) if our_t is not None else "FAILED" if status and "calib" in status else "-",
            ratio, fmt_rms(cv_rms), fmt_rms(our_rms), diff, diff64,
        ])
        rep_cv = cv.get("repeats") if cv else 0
        rep_note = f"{name}: {rep_cv} OpenCV / {our_runs} calib repeats"
        if status:
            rep_note += f"; {status}"
        if cv and cv.get("rms_f64_skipped"):
            rep_note += f"; no float64 re-evaluation: {cv['rms_f64_skipped']}"
        if cv and cv.get("warnings"):
            rep_note += "; OpenCV: " + "; ".join(cv["warnings"])
        notes.append(rep_note)

    m = machine()
    head = ["problem", "views x points", "OpenCV time", "calib time", "ratio (OpenCV/calib)",
            "OpenCV RMS (px)", "calib RMS (px)", "RMS difference (calib - OpenCV)",
            "calib - OpenCV solution in float64 (px)"]
    align = [":--", ":--", "--:", "--:", "--:", "--:", "--:", "--:", "--:"]
    out = []
    out.append("# Peer comparison: OpenCV vs calib")
    out.append("")
    out.append(f"- Date: {datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}")
    out.append(f"- Machine: {m['cpu']}; {m['cores']}; {m['os']}")
    out.append(f"- OpenCV: opencv-python-headless {cv_version or '?'} (cv2.setNumThreads(1), flags "
               "CALIB_FIX_K3, default criteria); calib: git "
               f"{a.calib_rev} (`--threads 1`, RAYON_NUM_THREADS=1)")
    for n in a.note:
        out.append(f"- {n}")
    out.append(f"- Command: `{a.command}`")
    out.append("- Times: median solve time. OpenCV = perf_counter around the cv2 call; calib = "
               "`elapsed_seconds` from its result JSON (`--repeat R`: the median of R runs in one process, "
               "like OpenCV's in-process repeats). "
               "Neither includes file reading or process start.")
    out.append("- RMS: OpenCV RMS is cv2's return value, computed on the float32 copies of the points "
               "that OpenCV requires; the last column compares calib's RMS with OpenCV's solution "
               "re-evaluated on the original float64 points (untimed), which is the like-for-like "
               "comparison: negative = calib's fit is better. Differences of order 1e-7 in the "
               "'RMS difference' column are float32 rounding, not solver quality.")
    out.append("")
    out.append("| " + " | ".join(head) + " |")
    out.append("|" + "|".join(align) + "|")
    for r in rows:
        out.append("| " + " | ".join(r) + " |")
    out.append("")
    out.append("Repeats and notes:")
    out.append("")
    for n in notes:
        out.append(f"- {n}")
    print("\n".join(out))


if __name__ == "__main__":
    main()
