# Sourced first by the bench scripts (benches/*/run.sh): their --help text, their errors and the
# command line their reports print, written once.

# The script's header comment (from line 2 up to its `set -euo pipefail`), as --help.
usage() { sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'; }

# A command-line error: the message on stderr, exit 2.
die() { echo "run.sh: error: $*" >&2; exit 2; }

# command_line NAME ARGS...: NAME followed by the arguments, each shell-quoted, as the reports
# print the command that made them.
command_line() {
    local line="$1" a
    shift
    for a in "$@"; do line+=" $(printf '%q' "$a")"; done
    printf '%s' "$line"
}

# python_venv VENV CHECK PACKAGE...: the bench's own virtual environment. Creates VENV with
# `python3 -m venv` if it has no python yet, and installs the PACKAGEs with pip unless the Python
# statement CHECK (e.g. 'import cv2, numpy') already runs there.
python_venv() {
    local venv="$1" check="$2"
    shift 2
    echo "== Python environment ($venv)"
    if [[ ! -x "$venv/bin/python" ]]; then
        command -v python3 >/dev/null || die "python3 not found"
        python3 -m venv "$venv" || die "could not create the virtual environment $venv (python3-venv missing?)"
    fi
    if ! "$venv/bin/python" -c "$check" 2>/dev/null; then
        "$venv/bin/python" -m pip install --quiet --upgrade pip >/dev/null 2>&1 || true
        "$venv/bin/python" -m pip install --quiet --upgrade "$@" || die "pip install $* failed"
    fi
}
