#!/usr/bin/env bash
# Peer comparison: OpenCV (cv2.calibrateCamera / cv2.stereoCalibrate) vs our `calib` tool on the
# same observation files, both single-threaded. See benches/peers/README.md.
#
# Usage: benches/peers/run.sh [options]
#   --quick             skip the 1000-view problems (the 1000x400 stereo OpenCV run takes minutes)
#   --repeats N         repeats for every problem (default: 5; for the 1000-view problems
#                       2 single / 1 stereo, see --repeats-large)
#   --repeats-large N   repeats for the 1000-view problems (default 2 single, 1 stereo)
#   --seed S            base seed for `calib synth` (default 1; problem k uses S + k)
#   --only REGEX        run only problems whose name matches REGEX (grep -E)
#   --timeout SECONDS   give up on one OpenCV or calib run after SECONDS (default: no limit)
#   --calib PATH        use this calib binary instead of building target/release/calib
#   --no-build          do not run cargo build (binary must already exist)
#   --python-synth      generate problems with make_synthetic.py instead of `calib synth`
#                       (testing the harness only: the files then differ from `calib synth`'s)
#   -h, --help          this text
set -euo pipefail

ORIG_ARGS=("$@")
# shellcheck source=../script_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../script_common.sh"

QUICK=0
REPEATS=""
REPEATS_LARGE=""
SEED=1
ONLY=""
TIMEOUT=""
CALIB=""
BUILD=1
PYSYNTH=0
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
        --python-synth) PYSYNTH=1 ;;
        -h|--help) usage; exit 0 ;;
        *) die "unknown option '$1' (see --help)" ;;
    esac
    shift
done
is_posint() { [[ "$1" =~ ^[1-9][0-9]*$ ]]; }
[[ -z "$REPEATS" ]] || is_posint "$REPEATS" || die "--repeats must be a positive integer"
[[ -z "$REPEATS_LARGE" ]] || is_posint "$REPEATS_LARGE" || die "--repeats-large must be a positive integer"
[[ "$SEED" =~ ^[0-9]+$ ]] || die "--seed must be a non-negative integer"
[[ -z "$TIMEOUT" ]] || is_posint "$TIMEOUT" || die "--timeout must be a positive integer (seconds)"
if [[ -n "$CALIB" ]]; then
    [[ "$CALIB" = /* ]] || CALIB="$PWD/$CALIB"   # relative to the caller's directory
fi

COMMAND="$(command_line benches/peers/run.sh "${ORIG_ARGS[@]+"${ORIG_ARGS[@]}"}")"

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
cd "$ROOT"
PEERS=benches/peers
OUT=$PEERS/out
VENV=$PEERS/.venv
PY=$VENV/bin/python
mkdir -p "$OUT"

# Single-threaded everywhere.
export RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1

# ---------------------------------------------------------------- 1. Python + OpenCV
python_venv "$VENV" 'import cv2, numpy' opencv-python-headless numpy
CV_VERSION="$("$PY" -c 'import cv2; print(cv2.__version__)')"
NP_VERSION="$("$PY" -c 'import numpy; print(numpy.__version__)')"
echo "cv2 $CV_VERSION, numpy $NP_VERSION ($("$PY" --version 2>&1))"

# ---------------------------------------------------------------- 2. calib
# shellcheck source=../calib_binary.sh
source "$ROOT/benches/calib_binary.sh"

# ---------------------------------------------------------------- 3. problems
# name kind views board seed-offset ("-" board = bundled real data file in column 3)
PROBLEMS=(
    "real_left        single data/sourishg1/left.json   -     0"
    "real_stereo      stereo data/sourishg1/stereo.json -     0"
    "single_10x54     single 10                         9x6   1"
    "single_100x54    single 100                        9x6   2"
    "single_1000x54   single 1000                       9x6   3"
    "single_10x400    single 10                         20x20 4"
    "single_100x400   single 100                        20x20 5"
    "single_1000x400  single 1000                       20x20 6"
    "stereo_10x54     stereo 10                         9x6   7"
    "stereo_200x54    stereo 200                        9x6   8"
    "stereo_1000x400  stereo 1000                       20x20 9"
)

run_limited() {  # run "$@" under the optional --timeout
    if [[ -n "$TIMEOUT" ]]; then timeout "$TIMEOUT" "$@"; else "$@"; fi
}

exit_text() {  # describe exit status $1 (always succeeds)
    if [[ $1 -eq 124 && -n "$TIMEOUT" ]]; then echo "timed out after ${TIMEOUT}s"
    else echo "exit status $1"; fi
}

SELECTED=()
declare -A NEED=()   # calib (sub)commands the selected problems need
for p in "${PROBLEMS[@]}"; do
    read -r name kind views board off <<<"$p"
    if [[ -n "$ONLY" ]] && ! grep -qE -- "$ONLY" <<<"$name"; then continue; fi
    if [[ "$board" != "-" && $QUICK -eq 1 && $views -ge 1000 ]]; then
        echo "  skip $name (--quick)"; continue
    fi
    SELECTED+=("$p")
    NEED["$kind"]=1
    [[ "$board" = "-" || $PYSYNTH -eq 1 ]] || NEED["synth $kind"]=1
done
[[ ${#SELECTED[@]} -gt 0 ]] || die "no problem selected (check --only / --quick)"

# Does the binary have the (sub)command "$@" (e.g. "stereo" or "synth single")? `calib ... --help`
# succeeding is enough; otherwise look for it in the command list of the parent's help, where
# clap-style help lists one command per line, indented.
has_command() {
    if "$CALIB" "$@" --help >/dev/null 2>&1; then return 0; fi
    local parent=("${@:1:$#-1}") last="${!#}" help
    help="$({ "$CALIB" "${parent[@]}" --help; "$CALIB" help "${parent[@]}"; } 2>&1 || true)"
    grep -qE -- "^[[:space:]]+${last}([[:space:]]|,|$)" <<<"$help"
}
missing=()
for cmd in "single" "stereo" "synth single" "synth stereo"; do
    [[ -n "${NEED[$cmd]:-}" ]] || continue
    # shellcheck disable=SC2086  # split "synth single" into words on purpose
    has_command $cmd || missing+=("'calib $cmd'")
done
if [[ ${#missing[@]} -gt 0 ]]; then
    hint=""
    if [[ " ${missing[*]} " == *"stereo'"* ]]; then
        hint+=$'\n'"       To run only the single-camera problems: --only '^(real_left|single_)'."
    fi
    if [[ " ${missing[*]} " == *"synth"* ]]; then
        hint+=$'\n'"       To test the harness without \`calib synth\`: --python-synth (files then differ from calib synth's)."
    fi
    die "the calib binary ($CALIB) lacks: ${missing[*]}
       ('calib ... --help' failed and the parent's help does not list it.)
       The harness needs: calib synth {single|stereo} --views M --board CxR --noise 0.2 --seed S -o FILE,
       calib {single|stereo} FILE -o RESULT.json --threads 1 --quiet.$hint"
fi

MANIFEST=$OUT/manifest.tsv
: > "$MANIFEST"
echo "== generating problems in $OUT ($([[ $PYSYNTH -eq 1 ]] && echo 'make_synthetic.py, TEST MODE' || echo 'calib synth'))"
for p in "${SELECTED[@]}"; do
    read -r name kind views board off <<<"$p"
    if [[ "$board" = "-" ]]; then
        file="$views"
        [[ -f "$file" ]] || die "bundled data file $file is missing"
        large=0
    else
        file=$OUT/$name.obs.json
        seed=$((SEED + off))
        if [[ $PYSYNTH -eq 1 ]]; then
            gen=("$PY" "$PEERS/make_synthetic.py" "$kind")
        else
            gen=("$CALIB" synth "$kind")
        fi
        gen+=(--views "$views" --board "$board" --noise 0.2 --seed "$seed" -o "$file")
        echo "  ${gen[*]#"$ROOT/"}"
        rm -f "$file"
        if ! "${gen[@]}" >"$OUT/$name.synth.log" 2>&1 </dev/null; then
            cat "$OUT/$name.synth.log" >&2
            die "generating $name failed: ${gen[*]}"
        fi
        [[ -s "$file" ]] || die "generator did not write $file: ${gen[*]}"
        large=$([[ $views -ge 1000 ]] && echo 1 || echo 0)
    fi
    if [[ -n "$REPEATS" ]]; then reps=$REPEATS
    elif [[ $large -eq 1 ]]; then reps=${REPEATS_LARGE:-$([[ $kind = single ]] && echo 2 || echo 1)}
    else reps=5; fi
    printf '%s\t%s\t%s\t%s\n' "$name" "$kind" "$file" "$reps" >>"$MANIFEST"
done

# ---------------------------------------------------------------- 4. run both tools
FAILED=0
while IFS=$'\t' read -r -u 3 name kind file reps; do
    base=$OUT/$name
    rm -f "$base".opencv.json "$base".opencv.log "$base".calib.r*.json* "$base".calib.log "$base".status
    echo "== $name ($kind, $reps repeat(s))"

    echo "  opencv_peer.py $kind $file --repeats $reps"
    if run_limited "$PY" "$PEERS/opencv_peer.py" "$kind" "$file" --repeats "$reps" \
            >"$base.opencv.json.tmp" 2>"$base.opencv.log" </dev/null; then
        mv "$base.opencv.json.tmp" "$base.opencv.json"
        "$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); print("    rms %.8f  median %.6f s  all %s" % (d["rms"], d["seconds_median"], ["%.4f" % t for t in d["seconds_all"]]))' "$base.opencv.json"
    else
        rc=$?
        rm -f "$base.opencv.json.tmp"
        msg="opencv failed ($(exit_text "$rc"))"
        echo "  $msg; see $base.opencv.log" >&2
        tail -n 5 "$base.opencv.log" >&2 || true
        echo "$msg" >>"$base.status"
        FAILED=1
    fi

    # One process, the calibration repeated in it (like OpenCV's in-process repeats): the
    # result's elapsed_seconds is the median, elapsed_seconds_all every run.
    res=$base.calib.r1.json
    cmd=("$CALIB" "$kind" "$file" -o "$res" --threads 1 --quiet --repeat "$reps")
    echo "  ${cmd[*]}"
    if run_limited "${cmd[@]}" >>"$base.calib.log" 2>&1 </dev/null; then
        if ! "$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); assert isinstance(d["elapsed_seconds"], (int, float)) and isinstance(d["rms"], (int, float))' "$res" 2>/dev/null; then
            echo "  calib result $res lacks numeric 'rms' / 'elapsed_seconds' fields" >&2
            echo "calib result lacks rms/elapsed_seconds" >>"$base.status"
            mv "$res" "$res.invalid"
            FAILED=1
        fi
    else
        rc=$?
        msg="calib failed ($(exit_text "$rc"))"
        echo "  $msg: ${cmd[*]}" >&2
        tail -n 10 "$base.calib.log" >&2 || true
        echo "$msg" >>"$base.status"
        rm -f "$res"
        FAILED=1
    fi
    ls "$base".calib.r*.json >/dev/null 2>&1 && "$PY" -c '
import json, statistics, sys
ds = [json.load(open(p)) for p in sys.argv[1:]]
ts = [d["elapsed_seconds"] for d in ds if isinstance(d.get("elapsed_seconds"), (int, float))]
if ts:
    print("    rms %.8f  median %.6f s  all %s" % (ds[0]["rms"], statistics.median(ts), ["%.4f" % t for t in ts]))
' "$base".calib.r*.json || true
done 3<"$MANIFEST"

# ---------------------------------------------------------------- 5. table
echo
echo "== results"
echo
notes=(--note "calib binary: ${CALIB#"$ROOT/"}")
[[ $PYSYNTH -eq 1 ]] && notes+=(--note "TEST MODE: problems generated by make_synthetic.py, not calib synth")
"$PY" "$PEERS/report.py" "$OUT" "$MANIFEST" --command "$COMMAND" --calib-rev "$CALIB_REV" \
    "${notes[@]}" | tee "$OUT/results.md"
echo
echo "(written to $OUT/results.md; per-problem JSON and logs in $OUT/)"
if [[ $FAILED -ne 0 ]]; then
    echo "run.sh: some runs failed (see the table and $OUT/*.log)" >&2
    exit 1
fi
