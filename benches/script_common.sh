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
