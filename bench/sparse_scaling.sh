#!/usr/bin/env bash
# Time and peak memory of `modal analyze --solver sparse --modes 10` against n
# for a 2-D pre-tensioned net sagging under gravity and a 3-D lattice clamped
# at its base, split into the stages modal reports (--timing): parse+build,
# equilibrium, assembly, factorization, eigen-solution. Side by side, in the
# same run: scipy.sparse.linalg.eigsh(K, 10, M, sigma=0, tol=1e-10) on the
# matrices modal exported (--export-matrices), with the ratio of the
# eigen-solution times and the largest relative eigenvalue difference.
#
#   bench/sparse_scaling.sh [build-dir] [max-exponent]   (default: build 6)
#
# Environment: SCENES (default "net slack lattice"; slack: the same net at its
# rest length, prestrain 0, whose flat start has no transverse stiffness),
# SLACK_ONLY=1 (only the slack rows, into results/sparse_scaling_slack.csv and
# its eigenvalues, and the target's measurement on the slack 10⁶ net into
# results/sparse_target_slack.csv; the other results are left as they are:
# about 10 minutes instead of 25), LATTICE_MAX_EXP (default: 5, or the max
# exponent if smaller; the 70³ lattice of 10⁶ coordinates is refused, exit 4:
# its sparse Cholesky factor would hold more than the 2³¹ − 1 entries CHOLMOD's
# int indices address, at least 16 GiB), SCIPY_MAX_N (default 200000): above it scipy is not run
# (SuperLU's factorization of a 10⁶-coordinate matrix takes longer than the
# whole benchmark) and its columns are left empty.
#
# Writes results/sparse_scaling.csv, results/sparse_scaling_eigenvalues.csv (both
# tools' eigenvalues, case by case), results/sparse_scaling.png and, with the 10⁶
# net, results/sparse_target.csv (the plain `modal analyze NET --modes 10`
# process, TARGET_RUNS times: the 60 s / 8 GiB target's measurement).
# TARGET_ONLY=1 repeats only that measurement (about 1 minute per run) and
# leaves the scaling table, its eigenvalues and the plot as they are. Needs
# /usr/bin/time and python3 with scipy and matplotlib (Debian: time,
# python3-scipy, python3-matplotlib).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
max_exp=${2:-6}
modal="$build/modal"
py=/usr/bin/python3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
slack_only=${SLACK_ONLY:-0}
suffix=
[ "$slack_only" = 1 ] && suffix=_slack
csv=results/sparse_scaling$suffix.csv
eigen_csv=results/sparse_scaling${suffix}_eigenvalues.csv  # every eigenvalue of both tools, to check the agreement
target_only=${TARGET_ONLY:-0}
[ "$target_only" = 1 ] || echo "scene,n,index,modal_omega2,scipy_omega2,modal_error_estimate" > "$eigen_csv"
[ "$target_only" = 1 ] || echo "scene,n,parse_build_s,equilibrium_s,assembly_s,export_s,factorization_s,eigen_solution_s,total_s,peak_MiB,scipy_eigsh_s,scipy_read_s,ratio_eigsh_over_modal,max_rel_diff,lambda1,ratio_eigsh_over_modal_total,load_1min" > "$csv"

net_scene() {  # N×N net, boundary fixed: 3 (N − 2)² coordinates
  PRESTRAIN=0.02 prestrained_net "$@"
}
slack_scene() {  # the same net with its springs at their rest length
  PRESTRAIN=0 prestrained_net "$@"
}
prestrained_net() {
  cat > "$1" <<EOF
gravity = [0, 0, -9.81]
[[lattice]]
name = "net"
size = [$2, $2, 1]
spacing = 0.1
mass = 0.002
stiffness = 1000
prestrain = $PRESTRAIN
fixed = "boundary"
EOF
}
lattice_scene() {  # s×s×s lattice with face diagonals, base fixed: 3 s² (s − 1) coordinates
  cat > "$1" <<EOF
gravity = [0, 0, -9.81]
[[lattice]]
name = "block"
size = [$2, $2, $2]
spacing = 0.1
mass = 0.01
stiffness = 1000
diagonals = true
fixed = "z-"
EOF
}

run_case() {  # kind size
  local kind=$1 size=$2 scene="$work/$1_$2.toml" out="$work/$1_$2"
  "${kind}_scene" "$scene" "$size"
  rm -rf "$out.mtx"
  local load
  load=$(cut -d' ' -f1 /proc/loadavg)
  /usr/bin/time -v "$modal" analyze "$scene" --solver sparse --modes 10 --tol 1e-10 --timing \
    --export-matrices "$out.mtx" --csv "$out" > "$out.txt" 2> "$out.err"
  local n
  n=$(sed -n '/^[0-9]/{p;q}' "$out.mtx/M.mtx" | awk '{print $1}')
  ms() { awk -v k="$1" '$1 == "timing:" && $2 == k {print $3 / 1000; f=1} END {if (!f) print 0}' "$out.err"; }
  local peak
  peak=$(awk '/Maximum resident set size/ {printf "%.1f", $6 / 1024}' "$out.err")
  if [ "$n" -le "${SCIPY_MAX_N:-200000}" ]; then
    "$py" bench/scipy_eigsh.py "$out.mtx" 10 0 1e-10 > "$out.scipy"
  else
    : > "$out.scipy"
  fi
  EIGEN_CSV="$eigen_csv" "$py" - "$out" "$kind" "$n" "$(ms parse+build)" "$(ms equilibrium)" "$(ms assembly)" "$(ms export)" \
    "$(ms factorization)" "$(ms eigen-solution)" "$(ms total)" "$peak" "$load" >> "$csv" <<'EOF'
import csv, os, sys
out, kind, n, pb, eq, asm, exp, fac, eig, total, peak, load = sys.argv[1:]
rows = list(csv.DictReader(open(out + "_modes.csv")))
modal = [float(r["omega2"]) for r in rows]
scipy = {}
lams = []
for line in open(out + ".scipy"):
    key, value = line.split()
    if key == "lambda":
        lams.append(float(value))
    else:
        scipy[key] = float(value)
modal_eigen = float(fac) + float(eig)
with open(os.environ["EIGEN_CSV"], "a") as f:
    for i, r in enumerate(rows):
        other = f"{lams[i]:.17g}" if i < len(lams) else ""
        f.write(f"{kind},{n},{i + 1},{float(r['omega2']):.17g},{other},{r['error_estimate']}\n")
if lams:
    diff = max(abs(a - b) / abs(b) for a, b in zip(sorted(modal), lams))
    print(f"{kind},{n},{pb},{eq},{asm},{exp},{fac},{eig},{total},{peak},{scipy['eigsh_s']:.3f},{scipy['read_s']:.3f},"
          f"{scipy['eigsh_s'] / modal_eigen:.2f},{diff:.2e},{sorted(modal)[0]:.10g},"
          f"{scipy['eigsh_s'] / float(total):.2f},{load}")
else:  # scipy not run at this size
    print(f"{kind},{n},{pb},{eq},{asm},{exp},{fac},{eig},{total},{peak},,,,,{sorted(modal)[0]:.10g},,{load}")
EOF
  echo "done: $kind $size (n = $n)" >&2
}

net_sizes=(20 60 185 580)        # ~1e3, 1e4, 1e5, 1e6 coordinates
lattice_sizes=(7 15 32 70)
scenes=${SCENES:-net slack lattice}
[ "$slack_only" = 1 ] && scenes=slack
lattice_max_exp=${LATTICE_MAX_EXP:-$((max_exp < 5 ? max_exp : 5))}
for i in $(seq 0 $((max_exp - 3))); do
  [ "$target_only" = 1 ] && break
  case " $scenes " in *" net "*) run_case net "${net_sizes[$i]}" ;; esac
  case " $scenes " in *" slack "*) run_case slack "${net_sizes[$i]}" ;; esac
  if [ $((i + 3)) -le "$lattice_max_exp" ]; then
    case " $scenes " in *" lattice "*) run_case lattice "${lattice_sizes[$i]}" ;; esac
  fi
done

# The target's measurement: the plain process a user runs on the largest net
# (no export, no CSV files), TARGET_RUNS times (default 3), wall time and peak
# RSS each, into results/sparse_target.csv.
target=results/sparse_target$suffix.csv
target_kind=net
[ "$slack_only" = 1 ] && target_kind=slack
echo "scene,n,run,wall_s,peak_MiB,equilibrium_s,factorization_s,eigen_solution_s,load_before" > "$target"
if [ "$max_exp" -ge 6 ] && case " $scenes " in *" $target_kind "*) true ;; *) false ;; esac; then
  scene="$work/net_target.toml"
  "${target_kind}_scene" "$scene" "${net_sizes[3]}"
  for run in $(seq 1 "${TARGET_RUNS:-3}"); do
    load=$(cut -d' ' -f1 /proc/loadavg)
    /usr/bin/time -f "wall %e\npeak %M" "$modal" analyze "$scene" --modes 10 --timing > "$work/target.txt" 2> "$work/target.err"
    awk -v run="$run" -v kind="$target_kind" -v load="$load" '
      $1 == "wall" {wall = $2} $1 == "peak" {peak = $2 / 1024}
      $1 == "timing:" && $2 == "equilibrium" {eq = $3 / 1000}
      $1 == "timing:" && $2 == "factorization" {fac = $3 / 1000}
      $1 == "timing:" && $2 == "eigen-solution" {eig = $3 / 1000}
      END {printf "%s,1002252,%d,%.2f,%.1f,%.2f,%.2f,%.2f,%s\n", kind, run, wall, peak, eq, fac, eig, load}' "$work/target.err" >> "$target"
    echo "done: target run $run" >&2
  done
fi
[ "$target_only" = 1 ] && { echo "wrote $target" >&2; exit 0; }
[ "$slack_only" = 1 ] && { echo "wrote $csv and $target" >&2; exit 0; }

"$py" - "$csv" <<'EOF'
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
rows = list(csv.DictReader(open(sys.argv[1])))
fig, axes = plt.subplots(1, 3, figsize=(16, 4.2))
for ax, kind in zip(axes, ["net", "slack", "lattice"]):
    rs = [r for r in rows if r["scene"] == kind]
    n = [int(r["n"]) for r in rs]
    for key, label in [("parse_build_s", "parse+build"), ("equilibrium_s", "equilibrium"), ("assembly_s", "assembly"),
                       ("factorization_s", "factorization"), ("eigen_solution_s", "eigen-solution"),
                       ("total_s", "modal total"), ("scipy_eigsh_s", "scipy eigsh")]:
        pts = [(m, float(r[key])) for m, r in zip(n, rs) if r[key]]
        ax.loglog([p[0] for p in pts], [max(p[1], 1e-4) for p in pts], marker="o", label=label)
    ax.set_title(f"{kind}: time against coordinates (10 lowest modes)")
    ax.set_xlabel("coordinates n")
    ax.set_ylabel("seconds")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
fig.tight_layout()
fig.savefig("results/sparse_scaling.png", dpi=110)
EOF
echo "wrote $csv and results/sparse_scaling.png" >&2
