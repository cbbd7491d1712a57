#!/usr/bin/env bash
# Speed against accuracy of `modal analyze` (issue 6, part 4): derivative
# methods, dense solvers, sparse tolerances and equilibrium tolerances on
# hanging chains (n = 10 … 2000), elastic lattices (n = 144 … 95 232) and a
# sagging net, each against a reference. Writes results/tradeoff.csv,
# results/tradeoff.png and results/tradeoff.md.
#
#   bench/tradeoff.sh [build-dir]        (default: build; about 6 minutes on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
[ -x "$build/modal" ] || { echo "no $build/modal: build first" >&2; exit 1; }
# Debian's python3 (numpy, scipy, matplotlib and mpmath from the packages that
# scripts/setup-debian.sh installs), not whatever python3 comes first on PATH.
/usr/bin/python3 bench/tradeoff.py "$build"
