#!/usr/bin/env bash
# Regenerates the screenshots of the HTML reports kept in results/ (README,
# docs/design.md "HTML reports"): runs build/modal analyze --report on the
# double pendulum (2-D, with --energy) and opens the page in headless
# Chromium with the network disabled.
# Usage: scripts/report_screenshots.sh   (after building build/modal)
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
build/modal analyze models/double_pendulum.toml --energy --report "$work/analyze.html" > /dev/null
chromium --headless --no-sandbox --disable-gpu --hide-scrollbars --user-data-dir="$work/profile" \
  "--host-resolver-rules=MAP * ~NOTFOUND" --proxy-server=127.0.0.1:9 --virtual-time-budget=1300 \
  --window-size=1000,1900 --screenshot="$PWD/results/report_analyze.png" "file://$work/analyze.html" 2> /dev/null
echo "results/report_analyze.png"
