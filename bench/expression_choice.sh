#!/usr/bin/env bash
# The measurement behind compiling scene expressions ourselves rather than with
# GiNaC: error messages for malformed input, parse time, and the cost of value +
# gradient + Hessian of a position expression. Writes results/expression_choice.md.
#
#   bench/expression_choice.sh [build-dir]     (default: build; needs libginac-dev)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
out=results/expression_choice.md
"$build/bench/bench_expression" --benchmark_min_time=0.3 --benchmark_format=console > /tmp/bench_expression.txt 2>/dev/null
{
  echo "# Scene expressions: our compiler against GiNaC"
  echo
  echo "Regenerate: \`bench/expression_choice.sh\` (after \`cmake --build build\`; needs libginac-dev)."
  echo "Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); $(date -u +%Y-%m-%d)."
  echo "GiNaC $(pkg-config --modversion ginac)."
  echo
  echo "Case 0: \`-sqrt(l^2 - x^2 - y^2)\` (Foucault's bob), case 1: \`r*cos(theta)*sin(phi)\`"
  echo "(spherical pendulum). \`*Hessian\` = value, gradient and Hessian in the two"
  echo "coordinates at one point: modal by one pass of nested dual numbers over the"
  echo "postfix code; GiNaC with the derivatives differentiated symbolically once"
  echo "outside the loop (its best case), each then evaluated by subs() and evalf()."
  echo "Scene messages add file, line, column and key to modal's text; GiNaC reports"
  echo "every error at line 0, column 0 and, unless strict, accepts unknown names as"
  echo "new symbols."
  echo
  echo '```'
  cat /tmp/bench_expression.txt
  echo '```'
} > "$out"
echo "wrote $out"
