#!/usr/bin/env bash
# Are the error estimates and residual bounds true, in both directions
# (issue 15, part 3)? Runs `modal analyze` on hanging chains (N up to 2000),
# graded chains, the sagging net at four --eq-tol and damped, follower and
# gyroscopic scenes, against extended-precision references computed without
# modal's double path; writes results/estimate_honesty.md.
#
#   bench/estimate_honesty.sh [build-dir]     (default: build; under a minute on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
[ -x "$build/modal" ] || { echo "no $build/modal: build first (--target modal_app)" >&2; exit 1; }
# Debian's python3 (numpy, scipy and mpmath from the packages that
# scripts/setup-debian.sh installs), not whatever python3 comes first on PATH.
/usr/bin/python3 bench/estimate_honesty.py "$build"
