#!/usr/bin/env bash
# Are the standard deviations honest? For each setup and lens model, SEEDS corner files from
# `calib synth single --model M --noise 0.5 SETUP --seed K` (the true lens is the fitted model),
# each calibrated with `calib single --model M --bootstrap B`; analyse.py then compares the
# error of every estimate with its sigma, z = (estimate - truth) / sigma, for fx, fy, cx, cy and
# k1, with (a) the linearized sigmas (`camera.std`) and (b) the view bootstrap's
# (`bootstrap.std`). Honest sigmas give an RMS of z near 1. It also prints each parameter's mean
# error over the seeds (bias, with its standard error) against the spread of the errors, and the
# runs that carried the `bootstrap-spread` warning. Setups: 20 views (the default 640x480 camera,
# fx 800), 12 views, and a wider lens (fx 450); models rational8, thin-prism12 and the control
# brown-conrady5 (docs/camera-model.md, "Terms the data does not determine").
#
# With --stereo, the same for stereo pairs instead: SEEDS pair files from `calib synth stereo
# --model M --noise 0.5 --views 20 --seed K` (both cameras of the true model M, the default rig:
# 100 mm baseline, 1.3 degrees), each calibrated with `calib stereo --model M --bootstrap B`;
# analyse_stereo.py compares z for both cameras' fx, fy, cx, cy, the rig's rotation and T and
# the baseline (docs/calib-stereo.md, "Honest standard deviations").
#
# Usage: benches/bootstrap/run.sh [options]
#   --seeds N       seeds per setup and model (default 50)
#   --resamples B   bootstrap resamples per calibration (default 100)
#   --warm          refit each resample from the calibration's solution (--bootstrap-warm)
#   --stereo        stereo pairs (cases stereo20.rational8, stereo20.brown-conrady5) instead
#   --no-bootstrap  with --stereo: calibrate without --bootstrap (linearized sigmas only)
#   --only REGEX    run only cases (SETUP.MODEL) matching REGEX (grep -E)
#   --python PATH   a Python with numpy (default: the bench's own venv benches/bootstrap/.venv,
#                   created with numpy)
#   --calib PATH    use this calib binary instead of building it
#   --no-build      do not run cargo build (the binary must exist)
#   -h, --help      this text
#
# Corner files and results go to benches/bootstrap/out/, the table to
# benches/bootstrap/out/summary.md (summary-stereo.md with --stereo). Takes about 6 minutes on
# two cores with the defaults; --stereo took 37 minutes on two cores shared with other work
# (rational8 nearly all of it), --stereo --no-bootstrap a few seconds.
set -euo pipefail

ORIG_ARGS=("$@")
# shellcheck source=../script_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../script_common.sh"

SEEDS=50
RESAMPLES=100
ONLY=""
CALIB=""
PY=""
BUILD=1
WARM=()
STEREO=0
BOOT=1
while [[ $# -gt 0 ]]; do
    case "$1" in
        --seeds) [[ $# -ge 2 ]] || die "--seeds needs a value"; SEEDS="$2"; shift ;;
        --seeds=*) SEEDS="${1#*=}" ;;
        --resamples) [[ $# -ge 2 ]] || die "--resamples needs a value"; RESAMPLES="$2"; shift ;;
        --resamples=*) RESAMPLES="${1#*=}" ;;
        --only) [[ $# -ge 2 ]] || die "--only needs a value"; ONLY="$2"; shift ;;
        --only=*) ONLY="${1#*=}" ;;
        --python) [[ $# -ge 2 ]] || die "--python needs a value"; PY="$2"; shift ;;
        --python=*) PY="${1#*=}" ;;
        --calib) [[ $# -ge 2 ]] || die "--calib needs a value"; CALIB="$2"; shift ;;
        --calib=*) CALIB="${1#*=}" ;;
        --warm) WARM=(--bootstrap-warm) ;;
        --stereo) STEREO=1 ;;
        --no-bootstrap) BOOT=0 ;;
        --no-build) BUILD=0 ;;
        -h|--help) usage; exit 0 ;;
        *) die "unknown option '$1' (see --help)" ;;
    esac
    shift
done
[[ "$SEEDS" =~ ^[1-9][0-9]*$ ]] || die "--seeds must be a positive integer"
[[ "$RESAMPLES" =~ ^[1-9][0-9]*$ && "$RESAMPLES" -ge 10 ]] || die "--resamples must be an integer of at least 10"
[[ "$BOOT" -eq 1 || "$STEREO" -eq 1 ]] || die "--no-bootstrap needs --stereo"
[[ "$STEREO" -eq 0 || ${#WARM[@]} -eq 0 ]] || die "--warm is for single cameras only"
if [[ -n "$CALIB" ]]; then
    [[ "$CALIB" = /* ]] || CALIB="$PWD/$CALIB"
fi
if [[ -n "$PY" ]]; then
    [[ "$PY" = /* ]] || PY="$PWD/$PY"
fi

COMMAND="$(command_line benches/bootstrap/run.sh "${ORIG_ARGS[@]+"${ORIG_ARGS[@]}"}")"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
cd "$ROOT"
BENCH=benches/bootstrap
OUT=$BENCH/out
mkdir -p "$OUT/files"

if [[ -z "$PY" ]]; then
    python_venv "$BENCH/.venv" 'import numpy' numpy
    PY=$BENCH/.venv/bin/python
fi
"$PY" -c 'import numpy' 2>/dev/null || die "$PY lacks numpy"

# shellcheck source=../calib_binary.sh
source benches/calib_binary.sh

CASES=()
# case NAME MODEL SYNTH-ARGS...: SEEDS corner files of the true MODEL, each calibrated with it.
case_() {
    local name="$1" model="$2"
    shift 2
    [[ -z "$ONLY" ]] || grep -Eq -- "$ONLY" <<<"$name" || return 0
    local seed file result list=$OUT/files/$name.list
    echo "== $name ($SEEDS seeds)"
    : >"$list"
    for seed in $(seq 1 "$SEEDS"); do
        file=$OUT/files/$name-s$seed.json
        result=$OUT/files/$name-s$seed.result.json
        "$CALIB" synth single --model "$model" --noise 0.5 "$@" --seed "$seed" -o "$file" >/dev/null
        if nice -n 10 "$CALIB" single "$file" --model "$model" --bootstrap "$RESAMPLES" ${WARM[@]+"${WARM[@]}"} -q -o "$result" \
            >/dev/null 2>"$OUT/files/$name-s$seed.err"; then
            echo "$file $result" >>"$list"
        else
            echo "$name seed $seed: calib single refused: $(tail -1 "$OUT/files/$name-s$seed.err")"
        fi
    done
    CASES+=("$name=$list")
}

# stereo_case NAME MODEL SYNTH-ARGS...: SEEDS pair files of the true MODEL (both cameras), each
# calibrated with it.
stereo_case() {
    local name="$1" model="$2"
    shift 2
    [[ -z "$ONLY" ]] || grep -Eq -- "$ONLY" <<<"$name" || return 0
    local seed file result list=$OUT/files/$name.list boot=()
    [[ "$BOOT" -eq 0 ]] || boot=(--bootstrap "$RESAMPLES")
    echo "== $name ($SEEDS seeds)"
    : >"$list"
    for seed in $(seq 1 "$SEEDS"); do
        file=$OUT/files/$name-s$seed.json
        result=$OUT/files/$name-s$seed.result.json
        "$CALIB" synth stereo --model "$model" --noise 0.5 "$@" --seed "$seed" -o "$file" >/dev/null
        if nice -n 10 "$CALIB" stereo "$file" --model "$model" ${boot[@]+"${boot[@]}"} -q -o "$result" \
            >/dev/null 2>"$OUT/files/$name-s$seed.err"; then
            echo "$file $result" >>"$list"
        else
            echo "$name seed $seed: calib stereo refused: $(tail -1 "$OUT/files/$name-s$seed.err")"
        fi
    done
    CASES+=("$name=$list")
}

if [[ "$STEREO" -eq 1 ]]; then
    for model in rational8 brown-conrady5; do
        stereo_case "stereo20.$model" "$model" --views 20
    done
    ANALYSE=$BENCH/analyse_stereo.py
    SUMMARY=$OUT/summary-stereo.md
else
    for model in rational8 thin-prism12 brown-conrady5; do
        case_ "views20.$model" "$model" --views 20
        case_ "views12.$model" "$model" --views 12
        case_ "wide450.$model" "$model" --views 20 --intrinsics 450,450,319.5,239.5
    done
    ANALYSE=$BENCH/analyse.py
    SUMMARY=$OUT/summary.md
fi

[[ ${#CASES[@]} -gt 0 ]] || die "no case ran"
{
    echo "Command: \`$COMMAND\`"
    echo "calib revision: $CALIB_REV; numpy $("$PY" -c 'import numpy; print(numpy.__version__)')"
    echo
} >"$SUMMARY"
"$PY" "$ANALYSE" "${CASES[@]}" | tee -a "$SUMMARY"
echo "summary: $SUMMARY"
