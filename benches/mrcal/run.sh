#!/usr/bin/env bash
# mrcal (https://mrcal.secretsauce.net) against calib, in the same run and on one thread each:
# the four bundled cameras (data/sourishg{1,2}/{left,right}.json) and a few `calib synth single`
# problems, lens models brown-conrady4 / brown-conrady5 / rational8 (mrcal's LENSMODEL_OPENCV4 /
# OPENCV5 / OPENCV8), each tool once in settings comparable with the other (every point, no
# regularization, flat board) and once with its defaults. See benches/mrcal/README.md and
# docs/benchmarks-mrcal.md.
#
# Usage: benches/mrcal/run.sh [options]
#   --repeats N         timed repeats per case and tool (default 10; median and fastest reported)
#   --models LIST       comma-separated subset of brown-conrady4,brown-conrady5,rational8
#   --only REGEX        run only the cases whose name matches REGEX (grep -E)
#   --no-synth          skip the synthetic problems
#   --seed S            seed of `calib synth` (default 1)
#   --calib PATH        use this calib binary (default: $CARGO_TARGET_DIR/release/calib, built)
#   --no-build          do not run cargo build (the binary must exist)
#   -h, --help          this text
#
# mrcal: Debian's packages `mrcal python3-mrcal` (bookworm: 2.2), used through Debian's
# /usr/bin/python3; installed with apt-get when `import mrcal` fails there (needs root). This is
# a benchmark script: mrcal is no dependency of the crates and not run in CI.
set -euo pipefail

ORIG_ARGS=("$@")
# shellcheck source=../script_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../script_common.sh"

REPEATS=10
MODELS_ARG="brown-conrady4,brown-conrady5,rational8"
ONLY=""
SYNTH=1
SEED=1
CALIB=""
BUILD=1
while [[ $# -gt 0 ]]; do
    case "$1" in
        --repeats) [[ $# -ge 2 ]] || die "--repeats needs a value"; REPEATS="$2"; shift ;;
        --models) [[ $# -ge 2 ]] || die "--models needs a value"; MODELS_ARG="$2"; shift ;;
        --only) [[ $# -ge 2 ]] || die "--only needs a value"; ONLY="$2"; shift ;;
        --no-synth) SYNTH=0 ;;
        --seed) [[ $# -ge 2 ]] || die "--seed needs a value"; SEED="$2"; shift ;;
        --calib) [[ $# -ge 2 ]] || die "--calib needs a value"; CALIB="$2"; shift ;;
        --no-build) BUILD=0 ;;
        -h|--help) usage; exit 0 ;;
        *) die "unknown option '$1' (see --help)" ;;
    esac
    shift
done
[[ "$REPEATS" =~ ^[1-9][0-9]*$ ]] || die "--repeats must be a positive integer"
[[ "$SEED" =~ ^[0-9]+$ ]] || die "--seed must be a non-negative integer"
IFS=, read -r -a MODELS <<<"$MODELS_ARG"
for m in "${MODELS[@]}"; do
    case "$m" in brown-conrady4|brown-conrady5|rational8) ;;
        *) die "--models: '$m' is not one of brown-conrady4, brown-conrady5, rational8" ;; esac
done
if [[ -n "$CALIB" && "$CALIB" != /* ]]; then CALIB="$PWD/$CALIB"; fi

COMMAND="$(command_line benches/mrcal/run.sh "${ORIG_ARGS[@]+"${ORIG_ARGS[@]}"}")"

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
cd "$ROOT"
PEER=benches/mrcal/mrcal_peer.py
OUT=benches/mrcal/out
# Debian's interpreter, not whatever python3 comes first in PATH (pyenv, a venv): python3-mrcal
# is installed for it.
PY=/usr/bin/python3

# One thread everywhere: mrcal's solver (libdogleg, CHOLMOD) links OpenBLAS and libgomp; its seed
# calls OpenCV (mrcal_peer.py sets cv2.setNumThreads(1)); calib gets --threads 1.
export RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1

echo "== mrcal (Debian python3-mrcal, $PY)"
[[ -x "$PY" ]] || die "$PY not found (Debian's python3; mrcal's Python API is packaged for it)"
if ! "$PY" -c 'import mrcal' 2>/dev/null; then
    command -v apt-get >/dev/null || die "apt-get not found: install mrcal and python3-mrcal (Debian bookworm: 2.2) by hand"
    [[ $(id -u) -eq 0 ]] || die "mrcal is not installed; run as root or: sudo apt-get install -y mrcal python3-mrcal"
    echo "  apt-get install -y mrcal python3-mrcal"
    DEBIAN_FRONTEND=noninteractive apt-get install -y mrcal python3-mrcal >/dev/null \
        || { apt-get update >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y mrcal python3-mrcal >/dev/null; } \
        || die "apt-get install mrcal python3-mrcal failed"
    "$PY" -c 'import mrcal' || die "import mrcal still fails after installing"
fi
MRCAL_VERSION="$(dpkg-query -W -f='${Version}' python3-mrcal 2>/dev/null || echo '?')"
PY_DESC="numpy $("$PY" -c 'import numpy; print(numpy.__version__)'), Python $("$PY" -c 'import platform; print(platform.python_version())')"
echo "python3-mrcal $MRCAL_VERSION, $PY_DESC"

# shellcheck source=../calib_binary.sh
source "$ROOT/benches/calib_binary.sh"

rm -rf "$OUT"
mkdir -p "$OUT"
MANIFEST=$OUT/manifest.tsv
: >"$MANIFEST"

# name, observation file, model
add_case() {
    if [[ -n "$ONLY" ]] && ! grep -qE -- "$ONLY" <<<"$1"; then return; fi
    printf '%s\t%s\t%s\n' "$1" "$2" "$3" >>"$MANIFEST"
}
for model in "${MODELS[@]}"; do
    for set in sourishg1 sourishg2; do
        for cam in left right; do add_case "$set.$cam.$model" "data/$set/$cam.json" "$model"; done
    done
done
if [[ $SYNTH -eq 1 ]]; then
    echo "== synthetic problems (calib synth single: 640x480, 9x6 board, 0.2 px noise, seed $SEED)"
    # name, views, synth model; fitted with every selected model of at least the synth model's terms
    for spec in "synth20:20:brown-conrady4" "synth100:100:brown-conrady4" "synth20bc5:20:brown-conrady5"; do
        IFS=: read -r sname views smodel <<<"$spec"
        file=$OUT/$sname.obs.json
        gen=("$CALIB" synth single --model "$smodel" --views "$views" --board 9x6 --noise 0.2
             --seed "$SEED" -o "$file")
        echo "  ${gen[*]#"$ROOT/"}"
        "${gen[@]}" >"$OUT/$sname.synth.log" 2>&1 || die "generating $sname failed: $(tail -n 1 "$OUT/$sname.synth.log")"
        for model in "${MODELS[@]}"; do
            [[ "$smodel" == brown-conrady5 && "$model" == brown-conrady4 ]] && continue
            add_case "$sname.$model" "$file" "$model"
        done
    done
fi
[[ -s "$MANIFEST" ]] || die "no case selected (check --only / --models)"

echo "== running both tools ($REPEATS timed repeats each; load average before each case)"
FAILED=0
while IFS=$'\t' read -r -u 3 name file model; do
    base=$OUT/$name
    cut -d' ' -f1-3 /proc/loadavg >"$base.load"
    for settings in comparable default; do
        if ! "$PY" "$PEER" solve "$file" --model "$model" --settings "$settings" --repeats "$REPEATS" \
                >"$base.mrcal.$settings.json" 2>"$base.mrcal.$settings.log" </dev/null; then
            echo "  mrcal failed on $name ($settings): $(tail -n 1 "$base.mrcal.$settings.log")" >&2
            rm -f "$base.mrcal.$settings.json"; FAILED=1
        fi
        flags=()
        [[ $settings == comparable ]] && flags=(--no-outlier-rejection)
        cmd=("$CALIB" single "$file" --model "$model" "${flags[@]}" --threads 1 --repeat "$REPEATS"
             -q -o "$base.calib.$settings.json")
        if "${cmd[@]}" >"$base.calib.$settings.log" 2>&1 </dev/null; then
            polish=()
            [[ $settings == comparable ]] && polish=(--polish)
            "$PY" "$PEER" ours "$file" "$base.calib.$settings.json" "${polish[@]}" >"$base.ours.$settings.json" \
                2>>"$base.calib.$settings.log" || { rm -f "$base.ours.$settings.json"; FAILED=1; }
        else
            echo "  calib failed on $name ($settings): $(tail -n 1 "$base.calib.$settings.log")" >&2
            FAILED=1
        fi
    done
    "$PY" - "$base" "$name" "$(cat "$base.load")" <<'EOF'
import json, sys
base, name, load = sys.argv[1:4]
def get(p):
    try: return json.load(open(p))
    except Exception: return None
m, o = get(base + ".mrcal.comparable.json"), get(base + ".ours.comparable.json")
if m and o:
    print("  %-28s rms mrcal %.8f calib %.8f (%+.1e)  mrcal %7.2f ms calib %6.2f ms  %4.0fx (fastest %4.0fx)  load %s"
          % (name, m["rms_all_points"], o["rms_all_points"], o["rms_all_points"] - m["rms_all_points"],
             1e3 * m["seconds_median"], 1e3 * o["elapsed_seconds"], m["seconds_median"] / o["elapsed_seconds"],
             m["seconds_min"] / min(o["elapsed_seconds_all"]), load))
else:
    print("  %-28s FAILED (see %s.*.log)" % (name, base))
EOF
done 3<"$MANIFEST"

echo
"$PY" "$PEER" report "$OUT" "$MANIFEST" --command "$COMMAND" --calib-rev "$CALIB_REV" \
    --python "$PY_DESC" | tee "$OUT/results.md"
echo
echo "(written to $OUT/results.md; per-case JSON and logs in $OUT/)"
[[ $FAILED -eq 0 ]] || { echo "run.sh: some runs failed (see $OUT/*.log)" >&2; exit 1; }
