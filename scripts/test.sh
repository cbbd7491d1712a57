#!/usr/bin/env bash
# Builds modal and runs the whole test suite with ctest: once as a release
# build, then again under AddressSanitizer and UndefinedBehaviorSanitizer.
# Usage: scripts/test.sh            (MODAL_JOBS=N to change parallelism)
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=${MODAL_JOBS:-$(nproc)}

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMODAL_BUILD_BENCH=ON
cmake --build build -j"$jobs"
ctest --test-dir build --output-on-failure -j"$jobs"

cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMODAL_SANITIZE=ON -DMODAL_BUILD_BENCH=OFF
cmake --build build-sanitize -j"$jobs"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-sanitize --output-on-failure -j"$jobs"
