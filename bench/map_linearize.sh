#!/usr/bin/env bash
# Linearizing expression-defined systems (kinematic maps), against SymPy
# mechanics on the same problem in the same run: the spherical pendulum in
# spherical angles about its conical motion. Writes results/map_linearize.md.
#
#   bench/map_linearize.sh [build-dir]        (default: build; needs python3 with sympy,
#                                              Debian: python3-sympy, for the peer)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
out=results/map_linearize.md
scene=models/spherical_pendulum_angles.toml

"$build/bench/bench_map" --benchmark_min_time=0.3 --benchmark_format=console > /tmp/bench_map.txt 2>/dev/null

# Whole `modal analyze` processes (parse, equilibrium, linearize, modes, report), best of 20.
best=""
for _ in $(seq 20); do
  start=$(date +%s%N)
  "$build/modal" analyze "$scene" > /dev/null
  end=$(date +%s%N)
  ns=$((end - start))
  if [[ -z "$best" || $ns -lt $best ]]; then best=$ns; fi
done
modal_ms=$(awk -v ns="$best" 'BEGIN { printf "%.2f", ns / 1e6 }')
omega=$("$build/modal" analyze "$scene" --csv /tmp/map_bench > /dev/null && awk -F, 'NR == 2 { printf "%.10f", $5 }' /tmp/map_bench_modes.csv)

if python3 -c "import sympy" 2> /dev/null; then
  python3 bench/sympy_spherical.py > /tmp/sympy_spherical.txt
  sympy_s=$(awk '/^total/ { print $2 }' /tmp/sympy_spherical.txt)
  ratio=$(awk -v s="$sympy_s" -v m="$modal_ms" 'BEGIN { printf "%.0f", s * 1000 / m }')
else
  echo "python3 with sympy not found: the SymPy peer is left out" > /tmp/sympy_spherical.txt
  sympy_s="-"
  ratio="-"
fi

{
  echo "# Linearizing systems written as kinematic maps"
  echo
  echo "Regenerate: \`bench/map_linearize.sh\` (after \`cmake --build build\`)."
  echo "Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); $(date -u +%Y-%m-%d)."
  echo
  echo "Target (issue on kinematic maps): linearizing an expression-defined spherical"
  echo "pendulum costs under 1 ms. \`Linearize/0\` below is \`modal::linearize\` of"
  echo "models/spherical_pendulum_angles.toml at its conical motion (Routh's reduction"
  echo "over the ignorable azimuth: the residual check, ∇∇V', M' and G' by AD through"
  echo "the expressions). \`Load\` parses and validates a scene (including the map's"
  echo "steadiness, ignorability and periodicity checks); \`Analyze\` is equilibrium"
  echo "search + linearize + modes. Models: 0 spherical_pendulum_angles, 1 foucault,"
  echo "2 double_pendulum_map, 3 double_pendulum (the same system as bodies), 4 spinning_top."
  echo
  echo '```'
  cat /tmp/bench_map.txt
  echo '```'
  echo
  echo "## Against SymPy mechanics, same problem, same run"
  echo
  echo "SymPy (bench/sympy_spherical.py): Lagrange's equations of the same particle"
  echo "position, \`LagrangesMethod.linearize\` at (phi0, theta' = w), eigenvalues of A."
  echo
  echo '```'
  cat /tmp/sympy_spherical.txt
  echo '```'
  echo
  echo "| | wall time | nutation ω (rad/s) |"
  echo "|---|---|---|"
  echo "| \`modal analyze $scene\` (whole process, best of 20) | ${modal_ms} ms | ${omega} |"
  echo "| SymPy mechanics (equations + linearize + eigenvalues, import excluded) | ${sympy_s} s | see above |"
  echo
  echo "Ratio SymPy / modal: ${ratio}×."
} > "$out"
echo "wrote $out"
