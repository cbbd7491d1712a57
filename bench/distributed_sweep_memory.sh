#!/bin/sh
# Peak memory per rank of `sweep --backend petsc` (results/distributed.md,
# "Sweeps read in parts"): each rank's peak resident set, from /usr/bin/time
# around every rank, for 1, 2 and 4 ranks on a square net of n x n particles
# (models/net.toml with its size as a parameter), swept over its prestrain.
#
#   bench/distributed_sweep_memory.sh [BUILD_DIR] [OTHER_BUILD_DIR]
#
# With OTHER_BUILD_DIR (a build of an earlier commit), the same runs with its
# modal-mpi, side by side. N (default 184: 99 372 coordinates), POINTS
# (default p=0.01,0.02) and RANKS (default "1 2 4") change the runs.
set -eu
build=${1:-build}
other=${2:-}
here=$(cd "$(dirname "$0")/.." && pwd)
n=${N:-184}
points=${POINTS:-p=0.01,0.02}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
sed -e 's/^size = \[30, 30, 1\]/size = ["n", "n", 1]/' \
    -e 's|^origin = .*|origin = ["-(n-1)*a/2", "-(n-1)*a/2", 0]|' \
    -e 's/^g = 9.81 .*/g = 9.81\nn = 30/' "$here/models/net.toml" > "$tmp/scene.toml"
printf '%-18s %-5s %-9s %-8s %-14s %-14s\n' build ranks coords wall_s peak_max_MiB peak_min_MiB
for b in $build $other; do
  for np in ${RANKS:-1 2 4}; do
    start=$(date +%s.%N)
    mpirun --quiet --allow-run-as-root --oversubscribe -np "$np" /usr/bin/time -f "peak %M" -o "$tmp/peak.%q{OMPI_COMM_WORLD_RANK}" \
      "$b/modal-mpi" sweep "$tmp/scene.toml" --set n="$n" --vary "$points" --modes 4 --backend petsc \
      > "$tmp/out" 2> "$tmp/err" || { cat "$tmp/err"; exit 1; }
    end=$(date +%s.%N)
    cat "$tmp"/peak.* | awk -v b="$b" -v np="$np" -v n="$n" -v s="$start" -v e="$end" '
      /^peak/ {k = $2 / 1024; if (max == "" || k > max) max = k; if (min == "" || k < min) min = k}
      END {printf "%-18s %-5s %-9d %-8.1f %-14.0f %-14.0f\n", b, np, 3*(n-2)*(n-2), e - s, max, min}'
    rm -f "$tmp"/peak.*
  done
done
