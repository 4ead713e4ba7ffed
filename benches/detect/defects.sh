#!/usr/bin/env bash
# Photographic defects (shadow edges, glare, motion blur, defocus, JPEG, low light,
# over-exposure, a finger over the board, clutter around it) on rendered boards with known
# corners: board-detect (`calib detect`) against OpenCV 5's findChessboardCorners + cornerSubPix
# and findChessboardCornersSB, per defect and strength: found / refused (with the reason) /
# WRONG (a corner more than 1 px off or mislabelled), corner RMS and max error, time.
# The table of docs/board-detect.md, "Photographic defects"; the defects are described in
# benches/detect/defects.py.
#
# Usage: benches/detect/defects.sh [options]
#   --count N       base boards rendered (default 20: `lens_eval pinhole N`, seed 1)
#   --only REGEX    only the groups ("DEFECT STRENGTH", e.g. 'shadow|glare r2') matching REGEX
#   --calib PATH    use this calib binary instead of building it
#   --no-build      do not run cargo build (the binaries must exist)
#   --python PATH   a Python with cv2 (OpenCV 5) and numpy to use instead of the bench's venv
#   --opencv-from F reuse OpenCV's outcomes from an earlier run's defects.jsonl (same --count:
#                   the images are the same, seeded) instead of running OpenCV again
#   --out DIR       output directory (default benches/detect/out/defects): base/ (the rendered
#                   boards), imgs/ (the defective images), defects.jsonl, table.md
#   -h, --help      this text
#
# Creates the venv benches/detect/.venv (opencv-python-headless, numpy) unless --python is given.
# About 35 minutes for the default 20 boards on 2 cores (OpenCV's classic detector takes up to
# 10 s on an image where it finds nothing); the images take about 0.5 GB.
set -euo pipefail

ORIG_ARGS=("$@")
# shellcheck source=../script_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../script_common.sh"

COUNT=20
ONLY=""
CALIB=""
BUILD=1
PY=""
OUT=""
CV_FROM=""
while [[ $# -gt 0 ]]; do
    case "$1" in
        --count) [[ $# -ge 2 ]] || die "--count needs a value"; COUNT="$2"; shift ;;
        --count=*) COUNT="${1#*=}" ;;
        --only) [[ $# -ge 2 ]] || die "--only needs a value"; ONLY="$2"; shift ;;
        --only=*) ONLY="${1#*=}" ;;
        --calib) [[ $# -ge 2 ]] || die "--calib needs a value"; CALIB="$2"; shift ;;
        --calib=*) CALIB="${1#*=}" ;;
        --no-build) BUILD=0 ;;
        --python) [[ $# -ge 2 ]] || die "--python needs a value"; PY="$2"; shift ;;
        --python=*) PY="${1#*=}" ;;
        --opencv-from) [[ $# -ge 2 ]] || die "--opencv-from needs a value"; CV_FROM="$2"; shift ;;
        --opencv-from=*) CV_FROM="${1#*=}" ;;
        --out) [[ $# -ge 2 ]] || die "--out needs a value"; OUT="$2"; shift ;;
        --out=*) OUT="${1#*=}" ;;
        -h|--help) usage; exit 0 ;;
        *) die "unknown option '$1' (see --help)" ;;
    esac
    shift
done
[[ "$COUNT" =~ ^[1-9][0-9]*$ ]] || die "--count must be a positive integer"
[[ -z "$CALIB" || "$CALIB" = /* ]] || CALIB="$PWD/$CALIB"
[[ -z "$PY" || "$PY" = /* || "$PY" != */* ]] || PY="$PWD/$PY"
[[ -z "$OUT" || "$OUT" = /* ]] || OUT="$PWD/$OUT"
[[ -z "$CV_FROM" || "$CV_FROM" = /* ]] || CV_FROM="$PWD/$CV_FROM"
[[ -z "$CV_FROM" || -f "$CV_FROM" ]] || die "--opencv-from: no file $CV_FROM"

COMMAND="$(command_line benches/detect/defects.sh "${ORIG_ARGS[@]+"${ORIG_ARGS[@]}"}")"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
cd "$ROOT"
OUT="${OUT:-$HERE/out/defects}"
mkdir -p "$OUT"

if [[ -z "$PY" ]]; then
    python_venv "$HERE/.venv" 'import cv2, numpy' "opencv-python-headless>=5.0.0" numpy
    PY="$HERE/.venv/bin/python"
fi
"$PY" -c 'import cv2, numpy' 2>/dev/null || die "$PY cannot import cv2 and numpy"

# shellcheck source=../calib_binary.sh
source benches/calib_binary.sh
TARGET_DIR="${CARGO_TARGET_DIR:-target}"
[[ "$TARGET_DIR" = /* ]] || TARGET_DIR="$ROOT/$TARGET_DIR"
if [[ $BUILD -eq 1 ]]; then
    echo "== cargo build --release -p board-detect --example lens_eval"
    cargo build --release -p board-detect --example lens_eval || die "cargo build failed"
fi
LENS_EVAL="$TARGET_DIR/release/examples/lens_eval"
[[ -x "$LENS_EVAL" ]] || die "lens_eval not found at $LENS_EVAL"

echo "== rendering $COUNT base boards in $OUT/base"
rm -rf "$OUT/base"
"$LENS_EVAL" pinhole "$COUNT" "$OUT/base" --seed 1 --save
"$PY" "$HERE/defects.py" "$OUT/base" "$OUT" --calib "$CALIB" --only "$ONLY" \
    ${CV_FROM:+--opencv-from "$CV_FROM"} | tee "$OUT/log.txt"
{
    echo "Command: \`$COMMAND\`"
    echo "calib revision: $CALIB_REV; OpenCV $("$PY" -c 'import cv2; print(cv2.__version__)'), numpy $("$PY" -c 'import numpy; print(numpy.__version__)'); $(nproc) cores"
    echo
    sed -n '/^| defect/,/^$/p' "$OUT/log.txt"
} >"$OUT/table.md"
echo "table: $OUT/table.md"
