#!/usr/bin/env bash
# Two builds of modal on the same scenes, interleaved (A, B, A, B, … in one
# run, so that the machine's drift over minutes falls on both alike): the
# plain `modal analyze SCENE --modes 10 --timing` process, its stages
# (equilibrium, factorization, eigen-solution, total) and wall time and peak
# memory by /usr/bin/time.
#
#   bench/compare_programs.sh PROGRAM_A PROGRAM_B ROUNDS SCENE...
#
# PROGRAM_A/B: two `modal` executables (e.g. a copy of build/modal made
# before a change, and build/modal after it). Prints one CSV row per run on
# standard output: scene,program,round,equilibrium_s,factorization_s,
# eigen_solution_s,total_s,wall_s,peak_MiB. Any scene file will do; the
# 10⁶-coordinate nets of results/sparse_scaling.md are one [[lattice]] of
# size [580, 580, 1], spacing 0.1, mass 0.002, stiffness 1000, fixed =
# "boundary", under gravity [0, 0, -9.81], with prestrain 0.02 (net) or 0
# (slack): bench/sparse_scaling.sh's net_scene and slack_scene.
set -euo pipefail
[ $# -ge 4 ] || { sed -n 2,17p "$0" >&2; exit 1; }
a=$1 b=$2 rounds=$3
shift 3
log=$(mktemp)
trap 'rm -f "$log"' EXIT
echo "scene,program,round,equilibrium_s,factorization_s,eigen_solution_s,total_s,wall_s,peak_MiB"
for ((r = 1; r <= rounds; ++r)); do
  for scene in "$@"; do
    for program in "$a" "$b"; do
      /usr/bin/time -f "time: %e %M" "$program" analyze "$scene" --modes 10 --timing > /dev/null 2> "$log"
      awk -v scene="$(basename "$scene")" -v program="$program" -v round="$r" '
        $1 == "timing:" && $2 == "equilibrium" {eq = $3 / 1000}
        $1 == "timing:" && $2 == "factorization" {fac = $3 / 1000}
        $1 == "timing:" && $2 == "eigen-solution" {eig = $3 / 1000}
        $1 == "timing:" && $2 == "total" {tot = $3 / 1000}
        $1 == "time:" {wall = $2; peak = $3 / 1024}
        END {printf "%s,%s,%d,%.2f,%.2f,%.2f,%.2f,%.2f,%.0f\n", scene, program, round, eq, fac, eig, tot, wall, peak}' "$log"
    done
  done
done
