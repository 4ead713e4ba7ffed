#!/usr/bin/env bash
# Is the model `calib single --compare-models` recommends the one a user should use? Synthetic
# corner files of known lenses of every family (brown-conrady4 narrow and wide, brown-conrady5
# with a k3 that matters, a strong rational barrel lens, Kannala-Brandt fisheyes of 120, 150
# and 190 degrees diagonal) with 5, 8, 15 and 30 views, 0.1, 0.3 and 1 px of noise, tilts of 45
# degrees and (8 and 15 views, 0.3 px) 10 and 5 degrees; each run through
# `calib single --compare-models` and through `calib single --model M` for every model, each fit
# judged against the true camera over a grid of pixels out to the image corners (sweep.py). The
# summary (report.py): per lens, how often each model is recommended, how far the recommended
# model's projection error over the image lies above the true model's fit's, refusals, and the
# time --compare-models takes. See docs/camera-model.md, "Choosing a model".
#
# Usage: benches/compare_models/run.sh [options]
#   --seeds N       seeds per case (default 3; the low-tilt cases 2, scaled with N)
#   --procs N       cases run at once (default 2)
#   --venv DIR      Python environment with numpy (default benches/compare_models/.venv,
#                   created with numpy if it cannot import it)
#   --report-only   only summarise the last sweep's results
#   --calib PATH    use this calib binary instead of building it
#   --no-build      do not run cargo build (the binary must exist)
#   -h, --help      this text
#
# Results: benches/compare_models/out/cases.jsonl (one record per case), the summary in
# benches/compare_models/out/summary.txt.
set -euo pipefail

ORIG_ARGS=("$@")
# shellcheck source=../script_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../script_common.sh"

SEEDS=3
PROCS=2
VENV=""
REPORT_ONLY=0
CALIB=""
BUILD=1
while [[ $# -gt 0 ]]; do
    case "$1" in
        --seeds) [[ $# -ge 2 ]] || die "--seeds needs a value"; SEEDS="$2"; shift ;;
        --seeds=*) SEEDS="${1#*=}" ;;
        --procs) [[ $# -ge 2 ]] || die "--procs needs a value"; PROCS="$2"; shift ;;
        --procs=*) PROCS="${1#*=}" ;;
        --venv) [[ $# -ge 2 ]] || die "--venv needs a value"; VENV="$2"; shift ;;
        --venv=*) VENV="${1#*=}" ;;
        --report-only) REPORT_ONLY=1 ;;
        --calib) [[ $# -ge 2 ]] || die "--calib needs a value"; CALIB="$2"; shift ;;
        --calib=*) CALIB="${1#*=}" ;;
        --no-build) BUILD=0 ;;
        -h|--help) usage; exit 0 ;;
        *) die "unknown option '$1' (see --help)" ;;
    esac
    shift
done
[[ "$SEEDS" =~ ^[1-9][0-9]*$ ]] || die "--seeds must be a positive integer"
[[ "$PROCS" =~ ^[1-9][0-9]*$ ]] || die "--procs must be a positive integer"
if [[ -n "$CALIB" ]]; then
    [[ "$CALIB" = /* ]] || CALIB="$PWD/$CALIB"
fi

COMMAND="$(command_line benches/compare_models/run.sh "${ORIG_ARGS[@]+"${ORIG_ARGS[@]}"}")"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
cd "$ROOT"
BENCH=benches/compare_models
VENV="${VENV:-$BENCH/.venv}"
PY=$VENV/bin/python
OUT=$BENCH/out
mkdir -p "$OUT"

python_venv "$VENV" 'import numpy' numpy

if [[ $REPORT_ONLY -eq 0 ]]; then
    # shellcheck source=../calib_binary.sh
    source benches/calib_binary.sh
    export CALIB
    echo "Command: \`$COMMAND\`" >"$OUT/header.txt"
    echo "calib revision: $CALIB_REV; numpy $("$PY" -c 'import numpy; print(numpy.__version__)')" >>"$OUT/header.txt"
    # The cases: lens name, true model, intrinsics (640x480 image), distortion.
    "$PY" - "$SEEDS" >"$OUT/cases.json" <<'PYEOF'
import json, sys
seeds = int(sys.argv[1])
lenses = [
    ('bc4-narrow', 'brown-conrady4', '800,800,319.5,239.5', '-0.2,0.05,0.001,-0.0005'),
    ('bc4-wide', 'brown-conrady4', '420,420,319.5,239.5', '-0.3,0.09,0.001,-0.0005'),
    ('bc5-wide', 'brown-conrady5', '400,400,319.5,239.5', '-0.32,0.1,0.001,-0.0005,-0.012'),
    ('rational-barrel', 'rational8', '320,320,319.5,239.5', '1.0,0.2,0.001,-0.0005,0.0,1.5,0.5,0.0'),
    ('fisheye-120', 'kannala-brandt4', '382,382,319.5,239.5', '0.05,-0.01,0.003,-0.0005'),
    ('fisheye-150', 'kannala-brandt4', '306,306,319.5,239.5', '0.05,-0.01,0.003,-0.0005'),
    ('fisheye-190', 'kannala-brandt4', '241,241,319.5,239.5', '0.05,-0.01,0.003,-0.0005'),
]
cases = []
for lens, model, k, dist in lenses:
    base = {'lens': lens, 'model': model, 'intrinsics': k, 'distortion': dist}
    for views in (5, 8, 15, 30):
        for noise in (0.1, 0.3, 1.0):
            for seed in range(1, seeds + 1):
                cases.append(dict(base, views=views, noise=noise, tilt=45, seed=seed))
    for tilt in (10, 5):
        for views in (8, 15):
            for seed in range(1, max(1, 2 * seeds // 3) + 1):
                cases.append(dict(base, views=views, noise=0.3, tilt=tilt, seed=seed))
print(json.dumps(cases))
PYEOF
    echo "== $(wc -c <"$OUT/cases.json") bytes of cases; sweep.py ($PROCS at once)"
    "$PY" "$BENCH/sweep.py" "$OUT/cases.jsonl" "$OUT/cases.json" --procs "$PROCS"
fi
"$PY" "$BENCH/report.py" "$OUT/cases.jsonl" | cat "$OUT/header.txt" - | tee "$OUT/summary.txt"
