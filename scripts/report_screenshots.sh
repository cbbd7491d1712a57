#!/usr/bin/env bash
# Regenerates the screenshots of the HTML reports kept in results/ (README,
# docs/design.md "HTML reports"), one per kind of report: analyze (the double
# pendulum, 2-D, with --energy), sweep (the bead on a spinning hoop: branches,
# root locus and Campbell diagram), map (Ziegler's column, follower load P
# against the spring k), amplitude and simulate (the double pendulum),
# equilibria (the double pendulum). Each page is opened in headless Chromium
# with the network disabled.
# Usage: scripts/report_screenshots.sh   (after building build/modal)
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
quiet() { "$@" > /dev/null 2>&1; }
quiet build/modal analyze models/double_pendulum.toml --energy --report "$work/analyze.html"
quiet build/modal sweep models/bead_on_hoop_frame.toml --vary Omega=0:6:61 --report "$work/sweep.html"
quiet build/modal sweep models/ziegler_damped.toml --vary P=0:4:41 --vary k=0.5:1.5:21 --report "$work/map.html"
quiet build/modal amplitude models/double_pendulum.toml --report "$work/amplitude.html"
quiet build/modal simulate models/double_pendulum.toml --at 1.5,0.5 --duration 20 --report "$work/simulate.html"
quiet build/modal equilibria models/double_pendulum.toml --report "$work/equilibria.html"
shot() {  # shot NAME HEIGHT
  chromium --headless --no-sandbox --disable-gpu --hide-scrollbars --user-data-dir="$work/profile" \
    "--host-resolver-rules=MAP * ~NOTFOUND" --proxy-server=127.0.0.1:9 --virtual-time-budget=1300 \
    --window-size=1000,"$2" --screenshot="$PWD/results/report_$1.png" "file://$work/$1.html" 2> /dev/null
  echo "results/report_$1.png"
}
shot analyze 1900
shot sweep 1900
shot map 950
shot amplitude 1500
shot simulate 1300
shot equilibria 1500
