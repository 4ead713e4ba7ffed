#!/usr/bin/env bash
# The lens models' validity check (docs/camera-model.md, "Validity") against brute force, over
# the fits users produce: corner files from `calib synth single` (every model, fits with more
# terms than the true lens, boards near the centre only, strong barrel, fisheyes to 190 degrees
# fitted with kannala-brandt4 and with pinhole models, fx != fy, principal points far off-centre,
# 1920x1080 and 4000x3000 images) calibrated with `calib single --model FIT`; analyse.py then
# samples each fitted map densely in 2-D (numpy), finds where it stops being one-to-one (Jacobian
# determinant, rational denominator) and compares with the result's `validity`, its
# `model-invalid` warning, and the Rust undistortion of pixels inside the reported valid radius
# (the `validity_probe` example, which also times the check). One table row per fit.
#
# Usage: benches/validity/run.sh [options]
#   --seeds N       seeds per case (default 2)
#   --only REGEX    run only cases whose name matches REGEX (grep -E)
#   --python PATH   a Python with numpy and cv2 (default: the bench's own venv
#                   benches/validity/.venv, created with opencv-python-headless and numpy)
#   --calib PATH    use this calib binary instead of building it (the probe is then looked for
#                   next to it, in examples/)
#   --no-build      do not run cargo build (the binaries must exist)
#   -h, --help      this text
#
# Corner files and results go to benches/validity/out/, the table to
# benches/validity/out/summary.md.
set -euo pipefail

ORIG_ARGS=("$@")
# shellcheck source=../script_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../script_common.sh"

SEEDS=2
ONLY=""
CALIB=""
PY=""
BUILD=1
while [[ $# -gt 0 ]]; do
    case "$1" in
        --seeds) [[ $# -ge 2 ]] || die "--seeds needs a value"; SEEDS="$2"; shift ;;
        --seeds=*) SEEDS="${1#*=}" ;;
        --only) [[ $# -ge 2 ]] || die "--only needs a value"; ONLY="$2"; shift ;;
        --only=*) ONLY="${1#*=}" ;;
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
[[ "$SEEDS" =~ ^[1-9][0-9]*$ ]] || die "--seeds must be a positive integer"
if [[ -n "$CALIB" ]]; then
    [[ "$CALIB" = /* ]] || CALIB="$PWD/$CALIB"
fi
if [[ -n "$PY" ]]; then
    [[ "$PY" = /* ]] || PY="$PWD/$PY"
fi

COMMAND="$(command_line benches/validity/run.sh "${ORIG_ARGS[@]+"${ORIG_ARGS[@]}"}")"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
cd "$ROOT"
BENCH=benches/validity
OUT=$BENCH/out
mkdir -p "$OUT/files"

if [[ -z "$PY" ]]; then
    python_venv "$BENCH/.venv" 'import cv2, numpy' "opencv-python-headless>=5.0.0" numpy
    PY=$BENCH/.venv/bin/python
fi
"$PY" -c 'import cv2, numpy' 2>/dev/null || die "$PY lacks numpy or cv2"

# shellcheck source=../calib_binary.sh
source benches/calib_binary.sh
PROBE="$(dirname "$CALIB")/examples/validity_probe"
if [[ $BUILD -eq 1 ]]; then
    echo "== cargo build --release -p calib-benches --example validity_probe"
    cargo build --release -p calib-benches --example validity_probe || die "building validity_probe failed"
fi
[[ -x "$PROBE" ]] || die "validity_probe not found at $PROBE (build with: cargo build --release -p calib-benches --example validity_probe)"

RESULTS=()
# case NAME FIT SYNTH-ARGS...: SEEDS corner files from `calib synth single SYNTH-ARGS --seed K`,
# each calibrated with `calib single --model FIT`.
case_() {
    local name="$1" fit="$2"
    shift 2
    [[ -z "$ONLY" ]] || grep -Eq -- "$ONLY" <<<"$name" || return 0
    local seed file result
    for seed in $(seq 1 "$SEEDS"); do
        file=$OUT/files/$name-s$seed.json
        result=$OUT/files/$name-s$seed.result.json
        "$CALIB" synth single "$@" --seed "$seed" -o "$file" >/dev/null
        if "$CALIB" single "$file" --model "$fit" -q -o "$result" >/dev/null 2>"$OUT/files/$name-s$seed.err"; then
            RESULTS+=("$result")
        else
            echo "$name seed $seed: calib single refused: $(tail -1 "$OUT/files/$name-s$seed.err")"
        fi
    done
}

VGA=(--image 640x480)
# Every model on its own default lens, and fits with more terms than the true lens.
for fit in brown-conrady4 brown-conrady5 rational8 thin-prism12; do
    case_ "bc4-lens.$fit" "$fit" "${VGA[@]}" --views 20 --noise 0.3
done
case_ rational-lens.rational8 rational8 "${VGA[@]}" --model rational8 --views 20 --noise 0.3
case_ prism-lens.thin-prism12 thin-prism12 "${VGA[@]}" --model thin-prism12 --views 20 --noise 0.3
case_ kb-lens.kannala-brandt4 kannala-brandt4 "${VGA[@]}" --model kannala-brandt4 --intrinsics 300,300,319.5,239.5 --views 20 --noise 0.3
# Boards near the centre only: few views, small tilt, a long lens.
for fit in brown-conrady5 rational8 thin-prism12; do
    case_ "centre.$fit" "$fit" "${VGA[@]}" --intrinsics 2000,2000,319.5,239.5 --distortion=-0.1,0.05,0,0 --views 4 --tilt 10 --noise 0.3
done
# Wide lenses with strong barrel.
for fit in brown-conrady4 brown-conrady5 rational8 thin-prism12 kannala-brandt4; do
    case_ "barrel.$fit" "$fit" "${VGA[@]}" --intrinsics 280,280,319.5,239.5 --model rational8 --distortion=-0.35,0.08,0,0,-0.005,0.1,0,0 --views 25 --noise 0.3
done
# Fisheyes to 190 degrees (half-diagonal at 95 degrees), fitted as fisheye and as pinhole.
for fit in kannala-brandt4 rational8 thin-prism12 brown-conrady5; do
    case_ "fish190.$fit" "$fit" "${VGA[@]}" --model kannala-brandt4 --intrinsics 241,241,319.5,239.5 --distortion=0.02,-0.005,0.001,0 --views 30 --noise 0.3
done
# Non-square pixels, principal points far off-centre, large and non-square images.
for fit in brown-conrady5 rational8 thin-prism12; do
    case_ "fxfy.$fit" "$fit" "${VGA[@]}" --intrinsics 400,520,319.5,239.5 --model brown-conrady5 --distortion=-0.3,0.1,0.001,-0.001,-0.01 --views 20 --noise 0.3
    case_ "offpp.$fit" "$fit" "${VGA[@]}" --intrinsics 400,400,180,330 --model brown-conrady5 --distortion=-0.3,0.1,0.001,-0.001,-0.01 --views 20 --noise 0.3
    case_ "hd.$fit" "$fit" --image 1920x1080 --intrinsics 1000,1000,959.5,539.5 --model brown-conrady5 --distortion=-0.3,0.1,0.002,0.001,-0.01 --views 20 --noise 0.5
    case_ "12mp.$fit" "$fit" --image 4000x3000 --intrinsics 2400,2400,1999.5,1499.5 --model brown-conrady5 --distortion=-0.25,0.08,0.001,0.001,-0.01 --views 20 --noise 0.8
done
case_ 12mp-fish.kannala-brandt4 kannala-brandt4 --image 4000x3000 --model kannala-brandt4 --intrinsics 1100,1100,1999.5,1499.5 --views 25 --noise 0.8

[[ ${#RESULTS[@]} -gt 0 ]] || die "no calibration succeeded"
SUMMARY=$OUT/summary.md
{
    echo "Command: \`$COMMAND\`"
    echo "calib revision: $CALIB_REV; numpy $("$PY" -c 'import numpy; print(numpy.__version__)'), OpenCV $("$PY" -c 'import cv2; print(cv2.__version__)')"
    echo
} >"$SUMMARY"
nice -n 10 "$PY" "$BENCH/analyse.py" "$PROBE" "${RESULTS[@]}" | tee -a "$SUMMARY"
echo "summary: $SUMMARY"
