#!/usr/bin/env bash
# Renders a calib report in headless Chromium and fails on broken images.
# Usage: benches/after/render.sh REPORT_DIR [SCREENSHOT.png]
# Needs the Debian package `chromium` (apt-get install chromium). Not run in CI.
set -euo pipefail
DIR=$(cd "$1" && pwd)
SHOT=${2:-$DIR/screenshot.png}
# Every <img> must have loaded with a non-zero natural size.
PAGE="$DIR/.check.html"
sed 's|</body>|<script>addEventListener("load",()=>{document.title=[...document.images].filter(i=>!(i.complete\&\&i.naturalWidth>0)).length+" broken of "+document.images.length})</script></body>|' \
    "$DIR/index.html" > "$PAGE"
RESULT=$(chromium --headless --no-sandbox --disable-gpu --virtual-time-budget=5000 --dump-dom "file://$PAGE" 2>/dev/null \
    | grep -o '<title>[^<]*</title>' | sed 's/<[^>]*>//g')
rm -f "$PAGE"
chromium --headless --no-sandbox --disable-gpu --window-size=1400,3000 --screenshot="$SHOT" "file://$DIR/index.html" >/dev/null 2>&1
echo "$RESULT; screenshot $SHOT"
case "$RESULT" in 0\ broken*) exit 0 ;; *) exit 1 ;; esac
