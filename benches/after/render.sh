#!/usr/bin/env bash
# Renders a calib report in headless Chromium and fails on broken images.
# Usage: benches/after/render.sh REPORT_DIR [SCREENSHOT.png]
# Prints "N broken of M; screenshot FILE"; exit 0 only when N is 0. Not run in CI.
#
# Browser: $CHROMIUM if set, else chromium, chromium-browser or google-chrome from PATH, else
# the Chromium that Playwright installs into this folder's venv (benches/after/.venv: pip
# install playwright, then python -m playwright install chromium; needs network once). The
# workspace never depends on a browser.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
DIR=$(cd "$1" && pwd)
SHOT=${2:-$DIR/screenshot.png}
find_browser() {
    if [[ -n "${CHROMIUM:-}" ]]; then echo "$CHROMIUM"; return; fi
    for b in chromium chromium-browser google-chrome; do
        if command -v "$b" >/dev/null 2>&1; then command -v "$b"; return; fi
    done
    local venv=$HERE/.venv
    [[ -x "$venv/bin/python" ]] || python3 -m venv "$venv"
    "$venv/bin/python" -c "import playwright" 2>/dev/null || "$venv/bin/python" -m pip install --quiet playwright >&2
    "$venv/bin/python" -m playwright install chromium >&2
    "$venv/bin/python" -c "from playwright.sync_api import sync_playwright as p
with p() as q: print(q.chromium.executable_path)"
}
BROWSER=$(find_browser)
# Every <img> must have loaded with a non-zero natural size: a script appended to a copy of the
# page writes the count into the title, which --dump-dom prints after the load.
PAGE="$DIR/.check.html"
sed 's|</body>|<script>addEventListener("load",()=>{document.title=[...document.images].filter(i=>!(i.complete\&\&i.naturalWidth>0)).length+" broken of "+document.images.length})</script></body>|' \
    "$DIR/index.html" > "$PAGE"
RESULT=$("$BROWSER" --headless --no-sandbox --disable-gpu --virtual-time-budget=5000 --dump-dom "file://$PAGE" 2>/dev/null \
    | grep -o '<title>[^<]*</title>' | sed 's/<[^>]*>//g')
rm -f "$PAGE"
"$BROWSER" --headless --no-sandbox --disable-gpu --window-size=1400,3000 --screenshot="$SHOT" "file://$DIR/index.html" >/dev/null 2>&1
echo "$RESULT; screenshot $SHOT"
case "$RESULT" in 0\ broken*) exit 0 ;; *) exit 1 ;; esac
