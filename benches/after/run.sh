#!/usr/bin/env bash
# Compares calib's exports, undistortion and rectification with OpenCV's on the bundled
# sourishg1 data (see benches/after/README.md). Not run in CI.
#
# Usage: benches/after/run.sh [--calib PATH] [--no-build]
#   --calib PATH   use this calib binary (default: build and use target/release/calib)
#   --no-build     do not run cargo build
# Writes its report to stdout and to benches/after/results.txt.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
CALIB=""
BUILD=1
while [[ $# -gt 0 ]]; do
    case "$1" in
        --calib) CALIB="$2"; shift ;;
        --no-build) BUILD=0 ;;
        -h|--help) sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "run.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
if [[ -z "$CALIB" ]]; then
    CALIB=$TARGET/release/calib
    if [[ $BUILD == 1 ]]; then
        (cd "$ROOT" && cargo build --release -p calib-cli)
    fi
fi
[[ -x "$CALIB" ]] || { echo "run.sh: no calib binary at $CALIB" >&2; exit 2; }
# OpenCV lives in this script's own virtual environment, never in the workspace.
VENV=$HERE/.venv
if [[ ! -x "$VENV/bin/python" ]]; then
    python3 -m venv "$VENV"
    "$VENV/bin/python" -m pip install --quiet --upgrade pip >/dev/null 2>&1 || true
fi
"$VENV/bin/python" -c "import cv2, numpy" 2>/dev/null \
    || "$VENV/bin/python" -m pip install --quiet opencv-python-headless numpy
"$VENV/bin/python" "$HERE/compare_opencv.py" --calib "$CALIB" --data "$ROOT/data/sourishg1" | tee "$HERE/results.txt"
# 5. Reports rendered in headless Chromium: no broken images (render.sh), for a single camera, a
# stereo rig, a rational8 fit whose lens model folds inside the image (red validity circle), and
# a rig of four cameras.
OUT=$(mktemp -d /tmp/calib-after-reports-XXXXXX)
DATA=$ROOT/data/sourishg1
{
    echo
    echo "5. Reports in headless Chromium (benches/after/render.sh; folder $OUT)"
    "$CALIB" single "$DATA/left.json" -q -o "$OUT/left.json" --report "$OUT/single"
    "$CALIB" stereo "$DATA/stereo.json" -q -o "$OUT/rig.json" --report "$OUT/stereo" 2>/dev/null
    "$CALIB" single "$DATA/left.json" -q --model rational8 -o "$OUT/rational8.json" --report "$OUT/rational8" 2>/dev/null
    "$CALIB" synth rig --cameras 4 --views 30 -o "$OUT/rig4-obs.json"
    "$CALIB" rig "$OUT/rig4-obs.json" -q -o "$OUT/rig4.json" --report "$OUT/rig4"
    for r in single stereo rational8 rig4; do
        echo "  $r: $("$HERE/render.sh" "$OUT/$r" "$OUT/$r.png" || true)"
    done
} | tee -a "$HERE/results.txt"
grep -q " [1-9][0-9]* broken" "$HERE/results.txt" && { echo "run.sh: broken images in a report" >&2; exit 1; }
exit 0
