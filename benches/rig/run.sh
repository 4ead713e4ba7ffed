#!/usr/bin/env bash
# Rig benchmark: OpenCV 5's cv2.calibrateMultiview vs our `calib rig` on the same synthetic rig
# files, one thread each. Prints a Markdown table (RMS, time, speed-up, accuracy against the
# truth). See benches/rig/README.md.
#
# Usage: benches/rig/run.sh [options]
#   --quick             skip the 10 cameras x 500 frames data set (OpenCV takes long on it)
#   --repeats N         calibrations per data set and tool (default 5 for calib, 3 for OpenCV;
#                       the 500-frame set: 5 for calib, 1 for OpenCV, see --repeats-large)
#   --repeats-large N   OpenCV repeats on the 500-frame set (default 1)
#   --seed S            base seed for `calib synth rig` (default 1; data set k uses S + k)
#   --only REGEX        run only data sets whose name matches REGEX (grep -E)
#   --timeout SECONDS   give up on one OpenCV or calib run after SECONDS (default: no limit)
#   --calib PATH        use this calib binary instead of building it
#   --no-build          do not run cargo build (the binary must exist)
#   --rig-speed         also build and run the calib-rig example rig_speed (10 cameras x 500
#                       frames x 54 points, library call, best of 5)
#   -h, --help          this text
set -euo pipefail

ORIG_ARGS=("$@")
# shellcheck source=../script_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../script_common.sh"

QUICK=0
REPEATS=""
REPEATS_LARGE=1
SEED=1
ONLY=""
TIMEOUT=""
CALIB=""
BUILD=1
RIG_SPEED=0
while [[ $# -gt 0 ]]; do
    case "$1" in
        --quick) QUICK=1 ;;
        --repeats) [[ $# -ge 2 ]] || die "--repeats needs a value"; REPEATS="$2"; shift ;;
        --repeats=*) REPEATS="${1#*=}" ;;
        --repeats-large) [[ $# -ge 2 ]] || die "--repeats-large needs a value"; REPEATS_LARGE="$2"; shift ;;
        --repeats-large=*) REPEATS_LARGE="${1#*=}" ;;
        --seed) [[ $# -ge 2 ]] || die "--seed needs a value"; SEED="$2"; shift ;;
        --seed=*) SEED="${1#*=}" ;;
        --only) [[ $# -ge 2 ]] || die "--only needs a value"; ONLY="$2"; shift ;;
        --only=*) ONLY="${1#*=}" ;;
        --timeout) [[ $# -ge 2 ]] || die "--timeout needs a value"; TIMEOUT="$2"; shift ;;
        --timeout=*) TIMEOUT="${1#*=}" ;;
        --calib) [[ $# -ge 2 ]] || die "--calib needs a value"; CALIB="$2"; shift ;;
        --calib=*) CALIB="${1#*=}" ;;
        --no-build) BUILD=0 ;;
        --rig-speed) RIG_SPEED=1 ;;
        -h|--help) usage; exit 0 ;;
        *) die "unknown option '$1' (see --help)" ;;
    esac
    shift
done
is_posint() { [[ "$1" =~ ^[1-9][0-9]*$ ]]; }
[[ -z "$REPEATS" ]] || is_posint "$REPEATS" || die "--repeats must be a positive integer"
is_posint "$REPEATS_LARGE" || die "--repeats-large must be a positive integer"
[[ "$SEED" =~ ^[0-9]+$ ]] || die "--seed must be a non-negative integer"
[[ -z "$TIMEOUT" ]] || is_posint "$TIMEOUT" || die "--timeout must be a positive integer (seconds)"
if [[ -n "$CALIB" ]]; then
    [[ "$CALIB" = /* ]] || CALIB="$PWD/$CALIB"
fi

COMMAND="$(command_line benches/rig/run.sh "${ORIG_ARGS[@]+"${ORIG_ARGS[@]}"}")"

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
cd "$ROOT"
BENCH=benches/rig
OUT=$BENCH/out
VENV=$BENCH/.venv
PY=$VENV/bin/python
mkdir -p "$OUT"

# One thread everywhere.
export RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1

# ---------------------------------------------------------------- 1. Python + OpenCV
python_venv "$VENV" 'import cv2, numpy; cv2.calibrateMultiview' "opencv-python-headless>=5.0.0" numpy
"$PY" -c 'import cv2; cv2.calibrateMultiview' 2>/dev/null \
    || die "cv2 $("$PY" -c 'import cv2; print(cv2.__version__)') has no calibrateMultiview (OpenCV 5 needed; delete $VENV to reinstall)"
CV_VERSION="$("$PY" -c 'import cv2; print(cv2.__version__)')"
NP_VERSION="$("$PY" -c 'import numpy; print(numpy.__version__)')"
echo "cv2 $CV_VERSION, numpy $NP_VERSION ($("$PY" --version 2>&1))"

# ---------------------------------------------------------------- 2. calib
TARGET_DIR="${CARGO_TARGET_DIR:-target}"
[[ "$TARGET_DIR" = /* ]] || TARGET_DIR="$ROOT/$TARGET_DIR"
if [[ -z "$CALIB" ]]; then
    CALIB="$TARGET_DIR/release/calib"
    if [[ $BUILD -eq 1 ]]; then
        echo "== cargo build --release -p calib-cli"
        cargo build --release -p calib-cli || die "cargo build --release -p calib-cli failed"
    fi
fi
[[ -x "$CALIB" ]] || die "calib binary not found at $CALIB (build with: cargo build --release -p calib-cli)"
"$CALIB" rig --help >/dev/null 2>&1 || die "$CALIB has no 'rig' command"
"$CALIB" synth rig --help >/dev/null 2>&1 || die "$CALIB has no 'synth rig' command"
CALIB_REV="$(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
if [[ -n "$(git status --porcelain -- crates Cargo.toml Cargo.lock 2>/dev/null)" ]]; then
    CALIB_REV+="+dirty"
fi

# ---------------------------------------------------------------- 3. data sets
# name | seed offset | calib synth rig arguments (besides -o, --seed)
# The board is 9x6 with 0.025 (m) squares: OpenCV 5.0.0's calibrateMultiview rejects 25 (mm)
# squares with "Pattern points are collinear!" (see README.md), so both tools get metres.
COMMON="--board 9x6 --square 0.025"
DATASETS=(
    "rig3x60_arc180|1|--cameras 3 --views 60 --layout ring --arc 180 --models brown-conrady4 --noise 0.3"
    "rig5x100_line|2|--cameras 5 --views 100 --layout line --spacing 0.6 --models brown-conrady5 --noise 0.2"
    "rig8x200_ring360|3|--cameras 8 --views 200 --layout ring --arc 360 --models brown-conrady4,brown-conrady5 --noise 0.5"
    "rig10x500_ring360|4|--cameras 10 --views 500 --layout ring --arc 360 --models brown-conrady4 --noise 0.2"
    # The first set again, with 30% of the views missing the board's first row (make_partial.py):
    # partial views, which calibrateMultiview takes as (-1, -1) image points.
    "rig3x60_partial|1|--cameras 3 --views 60 --layout ring --arc 180 --models brown-conrady4 --noise 0.3|0.3"
)

run_limited() {
    if [[ -n "$TIMEOUT" ]]; then timeout "$TIMEOUT" "$@"; else "$@"; fi
}
exit_text() {
    if [[ $1 -eq 124 && -n "$TIMEOUT" ]]; then echo "timed out after ${TIMEOUT}s"
    else echo "exit status $1"; fi
}

MANIFEST=$OUT/manifest.tsv
: > "$MANIFEST"
echo "== generating data sets in $OUT"
for entry in "${DATASETS[@]}"; do
    IFS='|' read -r name off args partial <<<"$entry"
    if [[ -n "$ONLY" ]] && ! grep -qE -- "$ONLY" <<<"$name"; then continue; fi
    large=0; [[ "$args" == *"--views 500"* ]] && large=1
    if [[ $QUICK -eq 1 && $large -eq 1 ]]; then echo "  skip $name (--quick)"; continue; fi
    file=$OUT/$name.obs.json
    # shellcheck disable=SC2206  # split the argument strings on purpose
    gen=("$CALIB" synth rig -o "$file" $args $COMMON --seed $((SEED + off)))
    echo "  calib synth rig -o $file $args $COMMON --seed $((SEED + off))"
    rm -f "$file"
    "${gen[@]}" >"$OUT/$name.synth.log" 2>&1 </dev/null \
        || { cat "$OUT/$name.synth.log" >&2; die "generating $name failed"; }
    if [[ -n "$partial" ]]; then
        echo "  make_partial.py $file $file --fraction $partial --seed $((SEED + off))"
        "$PY" "$BENCH/make_partial.py" "$file" "$file" --fraction "$partial" --seed $((SEED + off)) \
            >>"$OUT/$name.synth.log" 2>&1 || { cat "$OUT/$name.synth.log" >&2; die "make_partial.py failed for $name"; }
    fi
    if [[ -n "$REPEATS" ]]; then ours=$REPEATS; cv=$REPEATS; else ours=5; cv=3; fi
    [[ $large -eq 1 ]] && cv=$REPEATS_LARGE
    printf '%s\t%s\t%s\t%s\t%s\n' "$name" "$file" "$ours" "$cv" "$large" >>"$MANIFEST"
done
[[ -s "$MANIFEST" ]] || die "no data set selected (check --only / --quick)"

# ---------------------------------------------------------------- 4. both tools
FAILED=0
while IFS=$'\t' read -r -u 3 name file ours cv large; do
    base=$OUT/$name
    rm -f "$base".calib.json "$base".calib.time "$base".row.json "$base".calib.log "$base".opencv.log "$base".status
    echo "== $name"
    cmd=("$CALIB" rig "$file" -o "$base.calib.json" --threads 1 --repeat "$ours" -q)
    echo "  calib rig $file -o $base.calib.json --threads 1 --repeat $ours -q"
    # bash's `time` gives the process's CPU and wall time: their ratio shows how much of a core
    # the run had on this shared machine.
    rc=0
    { TIMEFORMAT='%U %S %R'; time run_limited "${cmd[@]}" >"$base.calib.log" 2>&1 </dev/null || rc=$?; } 2>"$base.calib.time"
    if [[ $rc -ne 0 ]]; then
        echo "  calib failed ($(exit_text $rc)); see $base.calib.log" >&2
        echo "calib failed ($(exit_text $rc))" >>"$base.status"
        rm -f "$base.calib.json"
        FAILED=1
    fi
    ours_arg=()
    [[ -f "$base.calib.json" ]] && ours_arg=(--ours "$base.calib.json" --ours-time "$base.calib.time")
    # On the 500-frame set one OpenCV call takes minutes: time the Extended call (same job, also
    # returns the board poses) instead of timing the plain one and re-running Extended for poses.
    [[ $large -eq 1 ]] && ours_arg+=(--time-extended)
    echo "  compare_opencv.py $file ${ours_arg[*]} --repeats $cv"
    if run_limited "$PY" "$BENCH/compare_opencv.py" "$file" "${ours_arg[@]}" --repeats "$cv" \
            >"$base.row.json.tmp" 2>"$base.opencv.log" </dev/null; then
        mv "$base.row.json.tmp" "$base.row.json"
        "$PY" -c '
import json, sys
d = json.load(open(sys.argv[1]))
o = d["opencv"]; print("    OpenCV rms %.6f (returned %.6f)  median %.4f s  all %s" % (o["rms"], o["rms_returned"], o["seconds_median"], ["%.4f" % t for t in o["seconds_all"]]))
if "ours" in d:
    u = d["ours"]; print("    calib  rms %.6f (reported %.6f)  median %.4f s  all %s" % (u["rms"], u["rms_reported"], u["seconds_median"], ["%.4f" % t for t in u["seconds_all"]]))
' "$base.row.json"
    else
        rc=$?
        rm -f "$base.row.json.tmp"
        echo "  OpenCV side failed ($(exit_text $rc)); see $base.opencv.log" >&2
        tail -n 5 "$base.opencv.log" >&2 || true
        echo "opencv failed ($(exit_text $rc)): $(tail -n 1 "$base.opencv.log" 2>/dev/null)" >>"$base.status"
        FAILED=1
    fi
done 3<"$MANIFEST"

# ---------------------------------------------------------------- 5. rig_speed (optional)
notes=(--note "calib binary: ${CALIB#"$ROOT/"} (commit $CALIB_REV)")
if [[ $RIG_SPEED -eq 1 ]]; then
    echo "== cargo build --release -p calib-rig --example rig_speed"
    cargo build --release -p calib-rig --example rig_speed || die "building rig_speed failed"
    "$TARGET_DIR/release/examples/rig_speed" 10 500 5 | tee "$OUT/rig_speed.txt"
    notes+=(--rig-speed "$OUT/rig_speed.txt")
fi

# ---------------------------------------------------------------- 6. table
echo
echo "== results"
echo
"$PY" "$BENCH/report.py" "$OUT" "$MANIFEST" --command "$COMMAND" "${notes[@]}" | tee "$OUT/results.md"
echo
echo "(written to $OUT/results.md; per-data-set JSON and logs in $OUT/)"
if [[ $FAILED -ne 0 ]]; then
    echo "run.sh: some runs failed (see the table and $OUT/*.log)" >&2
    exit 1
fi
