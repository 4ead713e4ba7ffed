#!/usr/bin/env bash
# Lens models against OpenCV 5, in the same run and on one thread each: every model on the four
# bundled cameras (data/sourishg{1,2}/{left,right}.json), every pinhole model on synthetic data of
# its own kind (known truth, a narrow and a wider lens), and Kannala-Brandt on synthetic
# wide-angle / fisheye data with known truth. See docs/benchmarks-models.md.
#
# Usage: benches/models/run.sh [options]
#   --reference         only (re)write data/sourishgN/reference/opencv5_models_{left,right}.json
#                       (OpenCV's result for every model on the bundled cameras; the Rust test
#                       crates/calib-single/tests/models_opencv.rs loads them) and stop
#   --repeats N         timed repeats per case for both tools (default 5; median reported)
#   --fx LIST           true focal lengths (px, 640x480 image) of the synthetic fisheye sweep
#                       (default 400,300,275,250,225,200,160,120: fields of view up to ~180 deg)
#   --pinhole-fx LIST   true focal lengths (px, 640x480 image) of the synthetic pinhole cases, one
#                       case per pinhole model and value (default 800,450: 44 and 71 deg across)
#   --seed S            seed of the synthetic data (default 1)
#   --no-synth          skip the synthetic cases (pinhole and fisheye)
#   --calib PATH        use this calib binary (default: $CARGO_TARGET_DIR/release/calib, built)
#   --no-build          do not run cargo build (the binary must exist)
#   -h, --help          this text
#
# Python: creates benches/models/.venv (python3 -m venv) and installs opencv-python-headless and
# numpy into it. This is a benchmark script: it is no dependency of the crates and not run in CI.
set -euo pipefail

ORIG_ARGS=("$@")
# shellcheck source=../script_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../script_common.sh"

REFERENCE=0
REPEATS=5
FXS="400,300,275,250,225,200,160,120"
PINHOLE_FXS="800,450"
SEED=1
SYNTH=1
CALIB=""
BUILD=1
while [[ $# -gt 0 ]]; do
    case "$1" in
        --reference) REFERENCE=1 ;;
        --repeats) [[ $# -ge 2 ]] || die "--repeats needs a value"; REPEATS="$2"; shift ;;
        --fx) [[ $# -ge 2 ]] || die "--fx needs a value"; FXS="$2"; shift ;;
        --pinhole-fx) [[ $# -ge 2 ]] || die "--pinhole-fx needs a value"; PINHOLE_FXS="$2"; shift ;;
        --seed) [[ $# -ge 2 ]] || die "--seed needs a value"; SEED="$2"; shift ;;
        --no-synth) SYNTH=0 ;;
        --calib) [[ $# -ge 2 ]] || die "--calib needs a value"; CALIB="$2"; shift ;;
        --no-build) BUILD=0 ;;
        -h|--help) usage; exit 0 ;;
        *) die "unknown option '$1' (see --help)" ;;
    esac
    shift
done
[[ "$REPEATS" =~ ^[1-9][0-9]*$ ]] || die "--repeats must be a positive integer"
[[ "$SEED" =~ ^[0-9]+$ ]] || die "--seed must be a non-negative integer"
[[ "$FXS" =~ ^[0-9]+(\.[0-9]+)?(,[0-9]+(\.[0-9]+)?)*$ ]] || die "--fx must be a comma-separated list of numbers"
[[ "$PINHOLE_FXS" =~ ^[0-9]+(\.[0-9]+)?(,[0-9]+(\.[0-9]+)?)*$ ]] || die "--pinhole-fx must be a comma-separated list of numbers"
if [[ -n "$CALIB" && "$CALIB" != /* ]]; then CALIB="$PWD/$CALIB"; fi

COMMAND="$(command_line benches/models/run.sh "${ORIG_ARGS[@]+"${ORIG_ARGS[@]}"}")"

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
cd "$ROOT"
VENV=benches/models/.venv
PY=$VENV/bin/python
PEER=benches/models/models_peer.py
OUT=benches/models/out

# One thread everywhere (OpenCV sets its own with cv2.setNumThreads(1); calib gets --threads 1).
export RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1

echo "== Python environment ($VENV)"
if [[ ! -x "$PY" ]]; then
    command -v python3 >/dev/null || die "python3 not found"
    python3 -m venv "$VENV" || die "could not create $VENV (python3-venv missing?)"
fi
if ! "$PY" -c 'import cv2, numpy' 2>/dev/null; then
    "$PY" -m pip install --quiet opencv-python-headless numpy \
        || die "pip install opencv-python-headless numpy failed"
fi
echo "cv2 $("$PY" -c 'import cv2; print(cv2.__version__)'), numpy $("$PY" -c 'import numpy; print(numpy.__version__)')"

if [[ $REFERENCE -eq 1 ]]; then
    echo "== OpenCV reference results for every model on the bundled cameras"
    "$PY" "$PEER" reference --root "$ROOT"
    exit 0
fi

# shellcheck source=../calib_binary.sh
source "$ROOT/benches/calib_binary.sh"

rm -rf "$OUT"
mkdir -p "$OUT"
MANIFEST=$OUT/manifest.tsv
: >"$MANIFEST"
MODELS=(brown-conrady4 brown-conrady5 rational8 thin-prism12 kannala-brandt4)

# section name observation-file model
for model in "${MODELS[@]}"; do
    for set in sourishg1 sourishg2; do
        for cam in left right; do
            printf 'real\t%s\t%s\t%s\n' "$model.$set.$cam" "data/$set/$cam.json" "$model" >>"$MANIFEST"
        done
    done
done
if [[ $SYNTH -eq 1 ]]; then
    echo "== synthetic pinhole data (calib synth single --model MODEL, its default distortion, 640x480, 20 views, 0.2 px)"
    IFS=, read -r -a pfx_list <<<"$PINHOLE_FXS"
    for model in brown-conrady4 brown-conrady5 rational8 thin-prism12; do
        for fx in "${pfx_list[@]}"; do
            name="$model.fx$fx"
            file=$OUT/$name.obs.json
            gen=("$CALIB" synth single --model "$model" --image 640x480
                 --intrinsics "$fx,$fx,319.5,239.5" --views 20 --noise 0.2 --seed "$SEED" -o "$file")
            echo "  ${gen[*]#"$ROOT/"}"
            if "${gen[@]}" >"$OUT/$name.synth.log" 2>&1; then
                printf 'synth-pinhole\t%s\t%s\t%s\n' "$name" "$file" "$model" >>"$MANIFEST"
            else
                echo "  (generator failed for $name: $(tail -n 1 "$OUT/$name.synth.log"))" >&2
            fi
        done
    done
    echo "== synthetic fisheye data (calib synth single --model kannala-brandt4, 640x480, 20 views, 0.2 px)"
    IFS=, read -r -a fx_list <<<"$FXS"
    for fx in "${fx_list[@]}"; do
        file=$OUT/kb_fx$fx.obs.json
        gen=("$CALIB" synth single --model kannala-brandt4 --image 640x480
             --intrinsics "$fx,$fx,319.5,239.5" --views 20 --noise 0.2 --seed "$SEED" -o "$file")
        echo "  ${gen[*]#"$ROOT/"}"
        if "${gen[@]}" >"$OUT/kb_fx$fx.synth.log" 2>&1; then
            printf 'synth\t%s\t%s\t%s\n' "kb_fx$fx" "$file" kannala-brandt4 >>"$MANIFEST"
        else
            echo "  (generator failed for fx = $fx: $(tail -n 1 "$OUT/kb_fx$fx.synth.log"))" >&2
        fi
    done
fi

echo "== running both tools ($REPEATS repeats each)"
while IFS=$'\t' read -r -u 3 section name file model; do
    base=$OUT/$name
    "$PY" "$PEER" opencv "$file" --model "$model" --repeats "$REPEATS" \
        >"$base.opencv.json" 2>"$base.opencv.log" || echo "  opencv crashed on $name (see $base.opencv.log)" >&2
    cmd=("$CALIB" single "$file" --model "$model" --no-outlier-rejection --threads 1
         --repeat "$REPEATS" -q -o "$base.calib.json")
    if ! "${cmd[@]}" >"$base.calib.log" 2>&1; then
        rm -f "$base.calib.json"
        echo "  calib failed on $name: $(tail -n 1 "$base.calib.log")" >&2
    fi
    "$PY" - "$base" "$name" <<'EOF'
import json, sys
base, name = sys.argv[1], sys.argv[2]
def get(p):
    try: return json.load(open(p))
    except Exception: return None
o, c = get(base + ".calib.json"), get(base + ".opencv.json")
cv_ok = c is not None and "failed" not in c
ours = "FAILED" if o is None else "rms %.8f %8.2f ms" % (o["rms"], 1e3 * o["elapsed_seconds"])
cv = "FAILED" if not cv_ok else "rms %.8f %8.2f ms" % (c["rms_f64"], 1e3 * c["seconds_median"])
both = o is not None and cv_ok
diff = "rms ours-OpenCV %+.1e" % (o["rms"] - c["rms_f64"]) if both else ""
ratio = "OpenCV/ours %.1fx" % (c["seconds_median"] / o["elapsed_seconds"]) if both and o["elapsed_seconds"] > 0 else ""
print("  %-34s ours %-28s OpenCV %-28s %s  %s" % (name, ours, cv, diff, ratio))
EOF
done 3<"$MANIFEST"

echo
"$PY" "$PEER" report "$OUT" --command "$COMMAND" --calib-rev "$CALIB_REV" | tee "$OUT/results.md"
echo
echo "(written to $OUT/results.md; per-case JSON and logs in $OUT/)"
