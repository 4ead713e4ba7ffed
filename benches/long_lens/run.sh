#!/usr/bin/env bash
# Long lenses (telephoto and machine-vision lenses, horizontal fields of view 2 to 15 degrees):
# the populations of docs/calib-single.md section 6 ("Long lenses") and the telephoto pairs of
# docs/calib-stereo.md. Each population is SEEDS corner files with known truth (gen.py for
# single cameras, `calib synth stereo` for pairs) run through `calib single` / `calib stereo`
# and, for single cameras, through cv2.calibrateCamera on the same corners (run.py, stereo.py).
# One summary line per population: refusals, warnings, z RMS of the intrinsics and k1 against
# the reported sigmas, noise-free recovery, the minimum against OpenCV's.
#
# Usage: benches/long_lens/run.sh [options]
#   --seeds N       seeds per population (default 50; the stereo and truth-start lines 40 and 100
#                   at the default, scaled with N)
#   --only REGEX    run only populations whose name matches REGEX (grep -E)
#   --calib PATH    use this calib binary instead of building it
#   --no-build      do not run cargo build (the binary must exist)
#   -h, --help      this text
#
# Creates its own venv benches/long_lens/.venv (opencv-python-headless, numpy); results per seed
# go to benches/long_lens/out/res/NAME.jsonl, the summary lines to benches/long_lens/out/summary.txt.
set -euo pipefail

ORIG_ARGS=("$@")
# shellcheck source=../script_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../script_common.sh"

SEEDS=50
ONLY=""
CALIB=""
BUILD=1
while [[ $# -gt 0 ]]; do
    case "$1" in
        --seeds) [[ $# -ge 2 ]] || die "--seeds needs a value"; SEEDS="$2"; shift ;;
        --seeds=*) SEEDS="${1#*=}" ;;
        --only) [[ $# -ge 2 ]] || die "--only needs a value"; ONLY="$2"; shift ;;
        --only=*) ONLY="${1#*=}" ;;
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

COMMAND="$(command_line benches/long_lens/run.sh "${ORIG_ARGS[@]+"${ORIG_ARGS[@]}"}")"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
cd "$ROOT"
BENCH=benches/long_lens
VENV=$BENCH/.venv
PY=$VENV/bin/python
export OUT=$BENCH/out
mkdir -p "$OUT"

python_venv "$VENV" 'import cv2, numpy' "opencv-python-headless>=5.0.0" numpy

# shellcheck source=../calib_binary.sh
source benches/calib_binary.sh
export CALIB

SUMMARY=$OUT/summary.txt
{
    echo "Command: \`$COMMAND\`"
    echo "calib revision: $CALIB_REV; OpenCV $("$PY" -c 'import cv2; print(cv2.__version__)'), numpy $("$PY" -c 'import numpy; print(numpy.__version__)')"
} >"$SUMMARY"
cat "$SUMMARY"

# single NAME SEEDS GEN-JSON [run.py options]
single() {
    local name="$1" seeds="$2" gen="$3"
    shift 3
    [[ -z "$ONLY" ]] || grep -Eq -- "$ONLY" <<<"$name" || return 0
    "$PY" "$BENCH/run.py" "$name" "$seeds" "$gen" "$@" | tee -a "$SUMMARY"
}
# pair NAME SEEDS SYNTH-ARGS [CALIB-STEREO-ARGS]
pair() {
    local name="$1"
    [[ -z "$ONLY" ]] || grep -Eq -- "$ONLY" <<<"$name" || return 0
    "$PY" "$BENCH/stereo.py" "$@" | tee -a "$SUMMARY"
}

S=$SEEDS
M='"W":2448,"H":2048'
for fov in 15 8 4 2; do
    single m_fov$fov "$S" "{$M,\"hfov\":$fov,\"views\":15,\"noise\":0.2}" --cv --nf
done
for fov in 15 4; do
    single l_fov$fov "$S" "{\"W\":4096,\"H\":3000,\"hfov\":$fov,\"views\":20,\"noise\":0.3}" --cv --nf
done
for v in 4 60; do
    single views${v}_fov6 "$S" "{$M,\"hfov\":6,\"views\":$v,\"noise\":0.2}" --cv
done
for n in 0.05 0.5; do
    single noise${n}_fov6 "$S" "{$M,\"hfov\":6,\"views\":15,\"noise\":$n}" --cv
done
single zerodist_fov4 "$S" "{$M,\"hfov\":4,\"views\":15,\"noise\":0.2,\"dist\":[0,0,0,0]}" --cv --nf
single bc5_fov8 "$S" "{$M,\"hfov\":8,\"views\":15,\"noise\":0.2,\"model\":\"brown-conrady5\"}" --cv --extra="--model brown-conrady5"
single tilt10_20_fov6 "$S" "{$M,\"hfov\":6,\"views\":15,\"noise\":0.2,\"tilt\":[10,20]}" --cv
single tilt30_50_fov6 "$S" "{$M,\"hfov\":6,\"views\":15,\"noise\":0.2,\"tilt\":[30,50]}" --cv
single smallboard_fov6 "$S" "{$M,\"hfov\":6,\"views\":15,\"noise\":0.2,\"frac\":[0.1,0.25]}" --cv
single ppoff10_fov8 "$S" "{$M,\"hfov\":8,\"views\":15,\"noise\":0.2,\"pp_off\":0.1}" --cv
# The remedies the warnings offer.
for fov in 15 8 4 2; do
    single fpp_m_fov$fov "$S" "{$M,\"hfov\":$fov,\"views\":15,\"noise\":0.2}" --cv --extra="--fix-principal-point"
done
for fov in 8 2; do
    single fk2_m_fov$fov "$S" "{$M,\"hfov\":$fov,\"views\":15,\"noise\":0.2}" --extra="--fix k2"
done
TRUTHSTART=1 single ts_zerodist_fov4 $((2 * S)) "{$M,\"hfov\":4,\"views\":15,\"noise\":0.2,\"dist\":[0,0,0,0]}" --cv

# Telephoto stereo pairs (docs/calib-stereo.md).
P=$((S * 4 / 5))
ST="--image 2448x2048 --intrinsics 20000,20000,1250,1000 --distortion=0.05,0,0,0 --right-intrinsics 20100,20100,1200,1050 --right-distortion=-0.05,0,0,0 --rig 0,0.0756,0,-498.6,0,37.8"
pair st_f20k "$P" "--views 15 $ST"
pair st_f20k_v40 "$P" "--views 40 $ST"
pair st_f20k_fpp "$P" "--views 15 $ST" "--fix-principal-point"
pair st_f45k "$P" "--views 15 --image 4096x3000 --intrinsics 45000,45000,2100,1450 --distortion=0,0,0,0 --right-intrinsics 45200,45200,2000,1550 --right-distortion=0,0,0,0 --rig 0,0.2223,0,-975.4,0,220.5"
echo "summary: $SUMMARY"
