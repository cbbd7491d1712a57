#!/usr/bin/env bash
# MJCF import against MuJoCo itself on hinge chains (bench/bench_import.cpp):
# modal importing and analyzing the file (all modes) against MuJoCo compiling
# it and building M and a central-difference K. Writes results/import_chain.md.
#
#   bench/import_chain.sh [build-dir]        (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
bench="$build/bench/bench_import"
out=results/import_chain.md
[ -x "$bench" ] || { echo "no $bench: build first (-DMODAL_BUILD_BENCH=ON)" >&2; exit 1; }
{
  echo "# MJCF import: modal against MuJoCo on chains of hinged bodies"
  echo
  echo "Regenerate: \`bench/import_chain.sh\` (after \`cmake --build build\`)."
  echo "Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); $(date -u +%Y-%m-%d); shared with other builds, so times are the best of 3 runs."
  echo "Model: N bodies in chains of 50 hanging side by side from the world (MuJoCo's XML reader refuses elements"
  echo "nested about 100 deep, so a single 500-body chain cannot be written in MJCF), hinges alternating about"
  echo "y and x with springs (50 N·m/rad, springref 0.01),"
  echo "capsule geoms of 0.1 kg (MuJoCo infers the inertias), hanging under gravity."
  echo "modal: \`load_model\` (MuJoCo's compile, the conversion to a TOML scene, modal's reader) then \`analyze\`"
  echo "(equilibrium by Newton, exact M and K, all N modes by the dense solver)."
  echo "MuJoCo: \`mj_loadXML\`, \`mj_forward\` + \`mj_fullM\`, and K by 2N evaluations of qfrc_bias − qfrc_passive"
  echo "(\`mj_forward\` each), without an equilibrium search or modes."
  echo
  echo '```'
  for n in 100 500; do "$bench" "$n" 3; echo; done
  echo '```'
} > "$out"
cat "$out"
