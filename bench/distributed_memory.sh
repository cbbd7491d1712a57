#!/bin/sh
# Peak memory and time per rank of `analyze --backend petsc` against the
# coordinate count (results/distributed.md, "Memory per rank and projection").
#
#   bench/distributed_memory.sh [BUILD_DIR] [RANKS...]     (default: build, 1 2)
#   SHAPE=block bench/distributed_memory.sh ...            (3-D lattices)
#
# SHAPE=net (default): models/net.toml with its size as a parameter n (a
# square net, n x n particles, fixed boundary: 3 (n-2)^2 coordinates), sizes
# n = 60 100 184 318 580 (1.0e4, 2.8e4, 9.9e4, 3.0e5, 1.0e6 coordinates).
# SHAPE=block: models/lattice.toml as an n x n x n block with diagonals,
# clamped base (3 n^2 (n-1) coordinates), n = 15 22 32 (9.5e3, 3.0e4, 9.5e4).
# SIZES overrides the list of n. 10 lowest modes. The runs go one after
# another; one line per run: ranks, n, coordinates, phase times (max over the
# ranks, s), peak memory per rank (MiB, max and min over the ranks), then
# the ranks' "distribution:" lines.
set -eu
build=${1:-build}
[ $# -gt 0 ] && shift
ranks=${*:-1 2}
shape=${SHAPE:-net}
here=$(cd "$(dirname "$0")/.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ "$shape" = net ]; then
  sed -e 's/^size = \[30, 30, 1\]/size = ["n", "n", 1]/' \
      -e 's|^origin = .*|origin = ["-(n-1)*a/2", "-(n-1)*a/2", 0]|' \
      -e 's/^g = 9.81 .*/g = 9.81\nn = 30/' "$here/models/net.toml" > "$tmp/scene.toml"
  sizes=${SIZES:-60 100 184 318 580}
else
  sed -e 's/^size = \[6, 6, 6\]/size = ["n", "n", "n"]/' \
      -e 's/^a = 0.1 .*/a = 0.1\nn = 6/' "$here/models/lattice.toml" > "$tmp/scene.toml"
  sizes=${SIZES:-15 22 32}
fi
printf '%-5s %-4s %-9s %-8s %-9s %-11s %-8s %-8s %-8s %-8s\n' ranks n coords parse partition equilibrium assembly eigen mem_max mem_min
for n in $sizes; do
  for np in $ranks; do
    mpirun --quiet --allow-run-as-root --oversubscribe -np "$np" "$build/modal" analyze "$tmp/scene.toml" \
      --set n="$n" --modes 10 --backend petsc --timing > "$tmp/out" 2> "$tmp/err" || { cat "$tmp/err"; exit 1; }
    awk -v np="$np" -v n="$n" -v shape="$shape" '
      /^timing: parse\+build/ {p=$3/1000} /^timing: partition/ {q=$3/1000} /^timing: equilibrium/ {e=$3/1000}
      /^timing: assembly/ {a=$3/1000} /^timing: eigen/ {g=$3/1000}
      /^timing: peak memory/ {mx=$6; mn=$9}
      END {c = shape == "net" ? 3*(n-2)*(n-2) : 3*n*n*(n-1)
           printf "%-5s %-4s %-9d %-8.2f %-9.2f %-11.2f %-8.2f %-8.2f %-8.0f %-8.0f\n", np, n, c, p, q, e, a, g, mx, mn}
    ' "$tmp/err"
    grep '^distribution:' "$tmp/err" | sed 's/^/  /'
  done
done
