#!/usr/bin/env bash
# Builds modal and runs the whole test suite with ctest: once as a release
# build, then again under AddressSanitizer and UndefinedBehaviorSanitizer;
# then fuzzes the scene reader (libFuzzer, clang build in build-fuzz) for a
# bounded time: any crash, hang, sanitizer report or undocumented exception
# fails the run and leaves the input in build-fuzz/findings/.
# Usage: scripts/test.sh            (MODAL_JOBS=N to change parallelism,
#                                    MODAL_FUZZ_SECONDS=S for the fuzzing time, default 180)
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=${MODAL_JOBS:-$(nproc)}
# At most one compile per 6 GB of available memory: a test translation unit
# with long double references takes 2 GB to compile, 5.2 GB under the
# sanitizers (tests/test_graded.cpp, measured), and where nproc reports more
# cores than the memory feeds, parallel compiles can be killed (a CI build
# stopped in test_tree and test_graded at once, with no compiler message;
# the likely cause, not a certain one).
if [ -z "${MODAL_JOBS:-}" ] && [ -r /proc/meminfo ]; then
  available_kb=$(awk '/^MemAvailable:/ {print $2}' /proc/meminfo)
  memory_jobs=$(( ${available_kb:-0} / (6 * 1024 * 1024) ))
  if [ "$memory_jobs" -lt 1 ]; then memory_jobs=1; fi
  if [ "$memory_jobs" -lt "$jobs" ]; then jobs=$memory_jobs; fi
fi
echo "test.sh: $jobs parallel jobs"
# The free disk is printed before each build: the three builds, ccache's copy
# of them and the tests' files take several GB, and a full disk shows up as
# unrelated failures ("No space left on device" inside a linker or MPI).
# Information only: it never stops the run.
free_disk() { df -hP . "${TMPDIR:-/tmp}" 2>&1 | sed 's/^/test.sh: /' || true; }
free_disk
# Compiles go through ccache where it is installed (setup-debian.sh installs
# it), with paths taken relative to this checkout, so that a fresh clone on a
# machine that built modal before recompiles only what changed.
launcher=()
if command -v ccache > /dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=1
fi

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMODAL_BUILD_BENCH=ON "${launcher[@]}"
cmake --build build -j"$jobs"
cmake --build build --target docs
ctest --test-dir build --output-on-failure -j"$jobs"

# The sanitizer and fuzzing builds keep line tables only (-g1), which is what
# their reports' stack traces read: full debug information made these two
# builds about three times larger on disk (the sanitizer object of
# lib/modal/sparse.cpp: 97 MB with -g, 31 MB with -g1).
debug_flags=(-DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG")

free_disk
cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo "${debug_flags[@]}" -DMODAL_SANITIZE=ON -DMODAL_BUILD_BENCH=OFF "${launcher[@]}"
cmake --build build-sanitize -j"$jobs"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-sanitize --output-on-failure -j"$jobs"

free_disk
cmake -S . -B build-fuzz -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo "${debug_flags[@]}" -DMODAL_FUZZ=ON "${launcher[@]}" \
  -DMODAL_BUILD_TESTS=OFF -DMODAL_BUILD_BENCH=OFF
cmake --build build-fuzz -j"$jobs" --target fuzz_scene
mkdir -p build-fuzz/corpus build-fuzz/findings
# The corpus grows in build-fuzz/corpus; models/ seeds it (read only).
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  build-fuzz/fuzz/fuzz_scene -max_total_time="${MODAL_FUZZ_SECONDS:-180}" -timeout=20 -rss_limit_mb=4096 \
  -max_len=65536 -dict=fuzz/scene.dict -artifact_prefix=build-fuzz/findings/ -print_final_stats=1 \
  build-fuzz/corpus models
