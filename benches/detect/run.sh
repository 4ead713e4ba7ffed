#!/usr/bin/env bash
# Detector comparison on the bundled real images: OpenCV findChessboardCorners + cornerSubPix
# (11x11 and 5x5 half-windows), optionally calib-targets, and board-detect, all
# single-threaded. Each detector's corners are written as observation files and calibrated
# with the same calibrator; prints a Markdown table (boards found, calibration RMS, median ms
# per image for detection + refinement, decoding excluded). See benches/detect/README.md.
#
# Usage: benches/detect/run.sh [options]
#   --calib PATH        calibrator binary (default: /work/calib-baseline if present, else
#                       the workspace's `calib`, built with cargo build --release -p calib-cli)
#   --calib-targets     also build and run the calib-targets peer (benches/detect/calib-targets-peer;
#                       first build takes a few minutes)
#   --variants          also run board-detect's other refinements (gradient, saddle + joint warp)
#   --repeats N         time every image N times and keep the fastest (default 3)
#   --out DIR           output directory (default benches/detect/out)
#   -h, --help          this text
set -euo pipefail

# shellcheck source=../script_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../script_common.sh"

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
CALIB=""
CT=0
VARIANTS=0
REPEATS=3
OUT="$HERE/out"
ORIG_ARGS=("$@")
while [[ $# -gt 0 ]]; do
    case "$1" in
        --calib) [[ $# -ge 2 ]] || die "--calib needs a value"; CALIB="$2"; shift ;;
        --calib=*) CALIB="${1#*=}" ;;
        --calib-targets) CT=1 ;;
        --variants) VARIANTS=1 ;;
        --repeats) [[ $# -ge 2 ]] || die "--repeats needs a value"; REPEATS="$2"; shift ;;
        --repeats=*) REPEATS="${1#*=}" ;;
        --out) [[ $# -ge 2 ]] || die "--out needs a value"; OUT="$2"; shift ;;
        --out=*) OUT="${1#*=}" ;;
        -h|--help) usage; exit 0 ;;
        *) die "unknown option $1 (see --help)" ;;
    esac
    shift
done
mkdir -p "$OUT"
TARGET="${CARGO_TARGET_DIR:-$ROOT/target}"

# 1. Python environment with OpenCV.
VENV="$HERE/.venv"
if [[ ! -x "$VENV/bin/python" ]]; then
    python3 -m venv "$VENV"
fi
if ! "$VENV/bin/python" -c "import cv2, numpy" 2>/dev/null; then
    "$VENV/bin/pip" install --quiet "opencv-python-headless>=5.0.0" numpy
fi
PY="$VENV/bin/python"

# 2. Binaries.
if [[ -z "$CALIB" ]]; then
    if [[ -x /work/calib-baseline ]]; then
        CALIB=/work/calib-baseline
    else
        (cd "$ROOT" && cargo build --release -q -p calib-cli)
        CALIB="$TARGET/release/calib"
    fi
fi
[[ -x "$CALIB" ]] || die "calibrator $CALIB is not executable"
(cd "$ROOT" && cargo build --release -q -p board-detect --example eval)
OURS="$TARGET/release/examples/eval"
if [[ $CT -eq 1 ]]; then
    (cd "$HERE/calib-targets-peer" && CARGO_TARGET_DIR="$OUT/target-calib-targets" cargo build --release -q)
    CTBIN="$OUT/target-calib-targets/release/calib-targets-peer"
fi

# 3. Detect and calibrate.
images() { ls "$ROOT/data/$1/images/$2"*.jpg | sort -V; }
calibrate() { # name -> prints nothing, writes $OUT/$name.res.json
    "$CALIB" single "$OUT/$1.obs.json" -o "$OUT/$1.res.json" -q || echo "{\"error\": \"calibration failed\"}" > "$OUT/$1.res.json"
}
METHODS=()
for set in sourishg1 sourishg2; do
    sq=24.23; [[ $set == sourishg2 ]] && sq=1.0
    for cam in left right; do
        mapfile -t IMGS < <(images "$set" "$cam")
        for hw in 11 5; do
            name="opencv-hw$hw.$set.$cam"
            "$PY" "$HERE/opencv_detect.py" --square "$sq" --half-win "$hw" --repeats "$REPEATS" -o "$OUT/$name.obs.json" "${IMGS[@]}"
            calibrate "$name"
        done
        if [[ $CT -eq 1 ]]; then
            name="calib-targets.$set.$cam"
            "$CTBIN" 9 6 "$sq" "$OUT/$name.obs.json" "${IMGS[@]}" 2>/dev/null
            calibrate "$name"
        fi
        name="board-detect.$set.$cam"
        "$OURS" 9 6 "$sq" "$OUT/$name.obs.json" --threads 1 --repeats "$REPEATS" "${IMGS[@]}" 2>/dev/null
        calibrate "$name"
        if [[ $VARIANTS -eq 1 ]]; then
            for v in "none:--refine none" "gradient-0.25:--refine gradient:0.25:12" "gradient-0.4:--refine gradient:0.4:12" \
                     "saddle-uncapped:--refine saddle:0.1:0.2:6:15" "saddle+warp2:--warp 2" "saddle+warp3:--warp 3"; do
                vname="${v%%:*}"; vargs="${v#*:}"
                name="board-detect-$vname.$set.$cam"
                # shellcheck disable=SC2086
                "$OURS" 9 6 "$sq" "$OUT/$name.obs.json" --threads 1 --repeats "$REPEATS" $vargs "${IMGS[@]}" 2>/dev/null
                calibrate "$name"
            done
        fi
    done
done

# 4. Report.
"$PY" "$HERE/report.py" --out "$OUT" --calib "$CALIB" --command "$(command_line benches/detect/run.sh "${ORIG_ARGS[@]+"${ORIG_ARGS[@]}"}")" | tee "$OUT/results.md"
