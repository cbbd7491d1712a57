#!/usr/bin/env bash
# Whole-process cost of `modal analyze` on hanging chains of N point-mass links
# (models/hanging_chain.toml with --set N=…), with the split by stage that
# `--timing` reports, and peak memory. Writes results/chain_analyze.md.
#
#   bench/chain_analyze.sh [build-dir]        (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
modal="$build/modal"
out=results/chain_analyze.md
[ -x "$modal" ] || { echo "no $modal: build first" >&2; exit 1; }

sizes=(10 100 300 1000)
repeats=3
{
  echo "# \`modal analyze\` on hanging chains"
  echo
  echo "Regenerate: \`bench/chain_analyze.sh\` (after \`cmake --build build\`)."
  echo "Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); $(date -u +%Y-%m-%d)."
  echo "Scene: \`models/hanging_chain.toml --set N=…\` (N point-mass links, all modes computed)."
  echo "Times are the median of $repeats runs of the whole process (wall clock), and the median"
  echo "of the per-stage times that \`--timing\` prints; memory is the peak resident set."
  echo
  echo "| links N | whole process [s] | parse+build [ms] | equilibrium [ms] | linearize [ms] | eigen [ms] | report [ms] | peak RSS [MiB] |"
  echo "|---:|---:|---:|---:|---:|---:|---:|---:|"
} > "$out"

median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }

for n in "${sizes[@]}"; do
  walls=(); declare -A stage=()
  for stage_name in "parse+build" equilibrium linearize eigen report; do stage[$stage_name]=""; done
  rss=0
  for ((r = 0; r < repeats; r++)); do
    /usr/bin/time -f "%e %M" -o /tmp/modal_time.txt "$modal" analyze models/hanging_chain.toml --set "N=$n" --timing \
      > /dev/null 2> /tmp/modal_timing.txt
    read -r wall kb < /tmp/modal_time.txt
    walls+=("$wall")
    (( kb > rss )) && rss=$kb
    for stage_name in "parse+build" equilibrium linearize eigen report; do
      v=$(awk -v s="$stage_name" '$1 == "timing:" && $2 == s {print $3}' /tmp/modal_timing.txt)
      stage[$stage_name]+="$v"$'\n'
    done
  done
  row="| $n | $(printf '%s\n' "${walls[@]}" | median)"
  for stage_name in "parse+build" equilibrium linearize eigen report; do
    row+=" | $(printf '%s' "${stage[$stage_name]}" | median)"
  done
  row+=" | $(awk -v k="$rss" 'BEGIN {printf "%.1f", k / 1024}') |"
  echo "$row" >> "$out"
  unset stage
done

cat >> "$out" <<'TXT'

Targets (issue: end-to-end toolkit): 100 links under 0.2 s, 1000 links under 10 s.
The eigen-solution (dense generalized symmetric, O(n³)) dominates from a few
hundred links on; the exact Hessian and mass matrix cost O(n·depth) = O(n²)
for a chain (see results/bench_core.md).
TXT
echo "wrote $out"
