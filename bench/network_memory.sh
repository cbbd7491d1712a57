#!/bin/sh
# Peak memory per rank of `analyze --backend petsc` reading a large
# [[network]] from CSV files in parts (results/distributed.md, "Networks
# read in parts").
#
#   bench/network_memory.sh [BUILD_DIR] [RANKS...]      (default: build, 1 2 4)
#
# The network: an n x n grid of nodes (N = 1000: 10^6 nodes, 2 (n-1) n
# edges to the right and lower neighbours, rows in order, names
# "r<i>c<j>"), pre-tensioned (prestrain 0.02), every node fixed but a 10 x 10
# block in the middle, so that the solve is small (300 coordinates) and the
# peak memory is the reading and building of the rank's part. One line per
# run: ranks, then the parse+build time (max over the ranks) and the peak
# memory per rank (max, min) as --timing prints them.
set -eu
build=${1:-build}
[ $# -gt 0 ] && shift
ranks=${*:-1 2 4}
n=${N:-1000}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 - "$tmp" "$n" <<'PY'
import sys
tmp, n = sys.argv[1], int(sys.argv[2])
lo, hi = n // 2 - 5, n // 2 + 5
with open(tmp + "/nodes.csv", "w") as f:
    f.write("name,x,y,z,fixed\n")
    for i in range(n):
        f.writelines("r%dc%d,%d,%d,0,%d\n" % (i, j, j, i, 0 if lo <= i < hi and lo <= j < hi else 1) for j in range(n))
with open(tmp + "/edges.csv", "w") as f:
    f.write("a,b\n")
    for i in range(n):
        for j in range(n):
            if j + 1 < n: f.write("r%dc%d,r%dc%d\n" % (i, j, i, j + 1))
            if i + 1 < n: f.write("r%dc%d,r%dc%d\n" % (i, j, i + 1, j))
PY
cat > "$tmp/scene.toml" <<'TOML'
[[network]]
name = "grid"
nodes = "nodes.csv"
edges = "edges.csv"
mass = 0.01
stiffness = 100.0
prestrain = 0.02
TOML
ls -l "$tmp"/*.csv >&2
for r in $ranks; do
  out=$(mpirun --quiet --allow-run-as-root --oversubscribe -np "$r" "$build/modal" analyze "$tmp/scene.toml" \
        --backend petsc --timing --modes 4 2>&1 >/dev/null)
  echo "$out" | grep -E "^(modal|distribution)" >&2 || true
  echo "ranks $r: $(echo "$out" | grep 'parse+build' | sed 's/  */ /g'); $(echo "$out" | grep 'peak memory' | sed 's/timing: //')"
done
