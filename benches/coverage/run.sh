#!/usr/bin/env bash
# The extrapolation that the poor-coverage warning (docs/calib-single.md, section 8) is about,
# on the bundled real corner sets: each set calibrated by calib with brown-conrady4 (A) and with
# brown-conrady5 and rational8 (B); extrapolation.py then prints, per pair of fits, how far apart
# A and B map the ray A sees at each image corner, edge midpoint and the centre. Fits that reach
# the same RMS but disagree by pixels at the image's corners are what the warning says: there the
# model is extrapolated, not measured.
#
# Usage: benches/coverage/run.sh [options]
#   --python PATH   a Python with numpy and cv2 (default: the bench's own venv
#                   benches/coverage/.venv, created with opencv-python-headless and numpy)
#   --calib PATH    use this calib binary instead of building it
#   --no-build      do not run cargo build (the binary must exist)
#   -h, --help      this text
#
# Results go to benches/coverage/out/, the table to benches/coverage/out/summary.md.
set -euo pipefail

ORIG_ARGS=("$@")
# shellcheck source=../script_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../script_common.sh"

CALIB=""
PY=""
BUILD=1
while [[ $# -gt 0 ]]; do
    case "$1" in
        --python) [[ $# -ge 2 ]] || die "--python needs a value"; PY="$2"; shift ;;
        --python=*) PY="${1#*=}" ;;
        --calib) [[ $# -ge 2 ]] || die "--calib needs a value"; CALIB="$2"; shift ;;
        --calib=*) CALIB="${1#*=}" ;;
        --no-build) BUILD=0 ;;
        -h|--help) usage; exit 0 ;;
        *) die "unknown option '$1' (see --help)" ;;
    esac
    shift
done
if [[ -n "$CALIB" ]]; then
    [[ "$CALIB" = /* ]] || CALIB="$PWD/$CALIB"
fi
if [[ -n "$PY" ]]; then
    [[ "$PY" = /* ]] || PY="$PWD/$PY"
fi

COMMAND="$(command_line benches/coverage/run.sh "${ORIG_ARGS[@]+"${ORIG_ARGS[@]}"}")"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
cd "$ROOT"
BENCH=benches/coverage
OUT=$BENCH/out
mkdir -p "$OUT"

if [[ -z "$PY" ]]; then
    python_venv "$BENCH/.venv" 'import cv2, numpy' "opencv-python-headless>=5.0.0" numpy
    PY=$BENCH/.venv/bin/python
fi
"$PY" -c 'import cv2, numpy' 2>/dev/null || die "$PY lacks numpy or cv2"

# shellcheck source=../calib_binary.sh
source benches/calib_binary.sh

ROWS=()
for set in sourishg1/left sourishg1/right sourishg2/left sourishg2/right; do
    tag=${set/\//-}
    for model in brown-conrady4 brown-conrady5 rational8; do
        "$CALIB" single "data/$set.json" --model "$model" -q -o "$OUT/$tag-$model.json" 2>/dev/null \
            || die "calib single data/$set.json --model $model failed"
    done
    for other in brown-conrady5 rational8; do
        ROWS+=("$set" "$OUT/$tag-brown-conrady4.json" "$OUT/$tag-$other.json")
    done
done
{
    echo "Command: \`$COMMAND\` (calib $CALIB_REV)"
    echo
    "$PY" "$BENCH/extrapolation.py" "${ROWS[@]}"
} > "$OUT/summary.md"
cat "$OUT/summary.md"
