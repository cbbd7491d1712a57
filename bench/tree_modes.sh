#!/usr/bin/env bash
# The ten lowest modes of long hanging chains (models/hanging_chain.toml,
# N point-mass links) by the matrix-free path (--solver tree) against the
# sparse and dense paths where they fit, and the degenerate variant beside
# the easy one: the same chain inverted (g < 0, every mode divergent, which
# takes the shift search below the spectrum). Whole process, wall clock, the
# eigen stage from --timing, peak memory; ω²₁ with its estimate. Writes
# results/tree_modes.md.
#
#   bench/tree_modes.sh [build-dir]        (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
modal="$build/modal"
out=results/tree_modes.md
[ -x "$modal" ] || { echo "no $modal: build first" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

run() {  # solver N g -> "wall eigen_ms rss_MiB omega2_1 estimate_1"
  local solver=$1 n=$2 g=$3
  if ! /usr/bin/time -f '%e %M' -o "$tmp/time" "$modal" analyze models/hanging_chain.toml --set N="$n" --set g="$g" \
      --modes 10 --solver "$solver" --timing --csv "$tmp/run" > "$tmp/out" 2> "$tmp/err"; then
    echo "refused/failed: $(grep -m1 modal: "$tmp/err" | cut -c1-60)"
    return
  fi
  local wall rss eigen w2 est
  read -r wall rss < "$tmp/time"
  eigen=$(awk '/timing: eigen/ {print $3}' "$tmp/err")
  w2=$(awk -F, 'NR==2 {print $3}' "$tmp/run_modes.csv")
  est=$(awk -F, 'NR==2 {print $10}' "$tmp/run_modes.csv")
  echo "$wall s | $eigen ms | $((rss / 1024)) MiB | $w2 ± $est"
}

{
  echo "# The matrix-free path on long chains"
  echo
  echo "Regenerate: \`bench/tree_modes.sh\` (after \`cmake --build build\`)."
  echo "Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); $(date -u +%Y-%m-%d);"
  echo "load average at the start: $(cut -d' ' -f1-3 /proc/loadavg) (a shared machine: times are indicative)."
  echo "Scene: \`models/hanging_chain.toml --set N=… --modes 10\`, one run each; the inverted chain is"
  echo "\`--set g=-9.81\` (all N modes divergent). Columns: whole process, the eigen stage of \`--timing\`,"
  echo "peak resident memory, ω²₁ and its error estimate (first line of the modes CSV)."
  echo
  echo "| chain | links N | solver | whole process | eigen | peak memory | ω²₁ ± estimate [rad²/s²] |"
  echo "|---|---:|---|---:|---:|---:|---:|"
} > "$out"

for g in 9.81 -9.81; do
  kind=hanging; [ "$g" = -9.81 ] && kind=inverted
  for n in 1000 2000 4000 10000 100000; do
    for solver in tree sparse dense; do
      if [ "$solver" = dense ] && [ "$n" -gt 2000 ]; then continue; fi
      if [ "$solver" = sparse ] && [ "$n" -gt 4000 ]; then continue; fi
      echo "| $kind | $n | $solver | $(run "$solver" "$n" "$g") |" >> "$out"
    done
  done
done
{
  echo
  echo "Dense and sparse rows stop where their matrices stop fitting in a reasonable time or memory"
  echo "(the sparse factor of a chain is dense: 1.57 GB at 3000 links, docs/design.md, Memory policy)."
} >> "$out"
cat "$out"
