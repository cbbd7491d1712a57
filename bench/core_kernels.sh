#!/usr/bin/env bash
# Cost of the exact derivative kernels on hanging chains (Google Benchmark):
# tree-structured gradient, Hessian and mass matrix, against a Hessian by nested
# forward-mode AD through the same templated model. Writes results/bench_core.md.
#
#   bench/core_kernels.sh [build-dir]        (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
out=results/bench_core.md
"$build/bench/bench_core" --benchmark_min_time=0.2 --benchmark_format=console > /tmp/bench_core.txt 2>/dev/null
{
  echo "# Derivative kernels on hanging chains of N links"
  echo
  echo "Regenerate: \`bench/core_kernels.sh\` (after \`cmake --build build\`)."
  echo "Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); $(date -u +%Y-%m-%d)."
  echo
  echo "\`Hessian\` is the production path (tree-structured accumulation of element"
  echo "cotangents, O(n·depth)); \`HessianNestedAD\` computes the same matrix by nested"
  echo "forward AD through the whole templated potential (8 directions per pass,"
  echo "O(n²·depth)). Both are exact; tests/test_core.cpp checks they agree to 1e-12."
  echo
  echo '```'
  cat /tmp/bench_core.txt
  echo '```'
} > "$out"
echo "wrote $out"
