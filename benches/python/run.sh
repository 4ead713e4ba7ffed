#!/usr/bin/env bash
# The Python package against OpenCV from Python, on the bundled data: cv2.calibrateCamera vs
# calib.calibrate_camera, cv2.stereoCalibrate vs calib.stereo_calibrate, and chessboard detection
# (see compare_cv2.py for what is timed). Not run in CI.
#
# Usage: benches/python/run.sh [--repeats N] [--threads N] [--no-install]
#
# Creates benches/python/.venv (python3 -m venv) with opencv-python-headless, numpy and maturin,
# installs ./crates/calib-py into it (a release build; cargo's target directory is
# $CARGO_TARGET_DIR or target/), unless --no-install, then runs compare_cv2.py.
set -euo pipefail
# shellcheck source=../script_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../script_common.sh"

ORIG_ARGS=("$@")
INSTALL=1
PASS=()
while [[ $# -gt 0 ]]; do
    case "$1" in
        --no-install) INSTALL=0 ;;
        --repeats|--threads) [[ $# -ge 2 ]] || { echo "run.sh: $1 needs a value" >&2; exit 2; }; PASS+=("$1" "$2"); shift ;;
        -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "run.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    esac
    shift
done
COMMAND="$(command_line benches/python/run.sh "${ORIG_ARGS[@]+"${ORIG_ARGS[@]}"}")"

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$ROOT"
VENV=benches/python/.venv
if [[ ! -x "$VENV/bin/python" ]]; then
    python3 -m venv "$VENV"
fi
if ! "$VENV/bin/python" -c 'import cv2, numpy, maturin' 2>/dev/null; then
    "$VENV/bin/pip" install --quiet opencv-python-headless numpy maturin
fi
if [[ $INSTALL -eq 1 ]]; then
    # --no-build-isolation: use the maturin just installed (no second download).
    PATH="$ROOT/$VENV/bin:$PATH" "$VENV/bin/pip" install --quiet --no-build-isolation --force-reinstall --no-deps ./crates/calib-py
fi
"$VENV/bin/python" benches/python/compare_cv2.py --command "$COMMAND" "${PASS[@]+"${PASS[@]}"}"
