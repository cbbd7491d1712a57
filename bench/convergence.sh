#!/usr/bin/env bash
# Model fidelity: discretized chains against their continuum limits, by
# `modal sweep --vary N=… --extrapolate` (observed order of convergence,
# Richardson-extrapolated frequencies with their error estimates).
#
#   R3: models/hanging_chain.toml, N point-mass links → ω_k = (j₀,k/2) sqrt(g/L)
#   R4: models/euler_column.toml (P = 0), N rod links with joint springs EI/a,
#       the clamp included → ω_n = (β_n L)² sqrt(EI/(ρA L⁴)), ρA L = M
#   R4 with point masses: the same chain with mass_model = "point" (a copy of
#       euler_column.toml made here): does the mass model set the order?
#   R4 with a stiffer clamp: the same chain, but the spring at the clamp is
#       2EI/a (a scene written here); shows where R4's order comes from.
#
#   bench/convergence.sh [build-dir]        (default: build)
#
# Writes results/convergence.md, results/convergence.csv (every point and mode
# with its reference and relative error) and results/convergence.png (error
# against N and against the time per point, log-log). Needs python3 with
# matplotlib (Debian: python3-matplotlib). Takes well under a minute.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
modal="$build/modal"
py=/usr/bin/python3
[ -x "$modal" ] || { echo "no $modal: build first" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Largest N first: the first point of a sweep also pays the process's warm-up
# (page faults of a fresh heap), negligible only against the largest point.
r3_n=640,320,160,80,40,20,10
r4_n=320,160,80,40,20,10
clamp_n=640,320,160,80,40,20,10
modes=3

sed 's/mass_model = "rod"/mass_model = "point"/' models/euler_column.toml > "$work/cantilever_point.toml"
# The cantilever of euler_column.toml with its first joint spring doubled:
# two chains, the first a single link at the clamp.
cat > "$work/cantilever_clamp2.toml" <<'EOF'
title = "Cantilever of N rod links, joint springs EI/a, clamp spring 2EI/a"
gravity = [0, 0, 0]
[parameters]
L = 1.0
M = 1.0
EI = 1.0
N = 10
[[chain]]
name = "foot"
links = 1
length = "L/N"
mass = "M/N"
mass_model = "rod"
axis = [0, 1, 0]
direction = [0, 0, 1]
stiffness = "2*EI*N/L"
[[chain]]
name = "column"
parent = "foot1"
origin = [0, 0, "L/N"]
links = "N - 1"
length = "L*(N - 1)/N"
mass = "M*(N - 1)/N"
mass_model = "rod"
axis = [0, 1, 0]
direction = [0, 0, 1]
stiffness = "EI*N/L"
EOF

run() {  # case scene N-list [--set …]
  local name=$1 scene=$2 list=$3
  shift 3
  local cmd=("$modal" sweep "$scene" "$@" --vary "N=$list" --extrapolate --modes "$modes")
  "${cmd[@]}" --csv "$work/$name.csv" > "$work/$name.txt"
  echo "${cmd[*]:1}" | sed "s|$work/|<work>/|; s|^|modal |" > "$work/$name.cmd"
  echo "done: $name" >&2
}
start=$(date +%s.%N)
run r3 models/hanging_chain.toml "$r3_n"
run r4 models/euler_column.toml "$r4_n" --set P=0
run r4_point "$work/cantilever_point.toml" "$r4_n" --set P=0
run r4_clamp2 "$work/cantilever_clamp2.toml" "$clamp_n"
total=$(awk -v s="$start" -v e="$(date +%s.%N)" 'BEGIN {printf "%.1f", e - s}')

MACHINE="$(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')" TOTAL="$total" \
  "$py" - "$work" <<'EOF'
import csv, math, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

work = sys.argv[1]
# R3 (docs/design.md): zeros of J0 over 2; R4: roots of cos βL cosh βL = −1.
g, L, M, EI = 9.81, 1.0, 1.0, 1.0
r3 = [z * math.sqrt(g / L) for z in (1.202412778848, 2.760039055143, 4.326863956456)]
r4 = [b * b * math.sqrt(EI / (M / L * L**4)) for b in (1.87510406871, 4.69409113297, 7.85475743824)]
cases = [
    ("r3", "R3: hanging chain, N point-mass links (models/hanging_chain.toml)", r3),
    ("r4", "R4: cantilever, N rod links, joint springs EI/a with the clamp's (models/euler_column.toml, P = 0)", r4),
    ("r4_point", "R4 with point masses at the link ends (euler_column.toml with mass_model = \"point\")", r4),
    ("r4_clamp2", "R4 with the clamp spring doubled to 2EI/a (scene written by the script)", r4),
]

def rows_of(path):
    return list(csv.DictReader(open(path)))

out = []
combined = []
fig, (ax_n, ax_t) = plt.subplots(1, 2, figsize=(12, 4.6))
colors = {"r3": "tab:blue", "r4": "tab:red", "r4_point": "tab:orange", "r4_clamp2": "tab:green"}
markers = ["o", "s", "^"]
out.append("# Model fidelity: discretized chains against their continuum limits")
out.append("")
out.append("Regenerate: `bench/convergence.sh [build-dir]` (Release build). "
           f"Machine: {os.environ['MACHINE']}. All three sweeps together took {os.environ['TOTAL']} s.")
out.append("")
out.append("Each table comes from one `modal sweep --vary N=… --extrapolate` (command under it). "
           "ω in rad/s; *rel. error* = (ω − ω_ref)/ω_ref; *time* is the sweep's wall time for the point "
           "(re-parse, build, equilibrium, linearization, all modes; the sweeps run from the largest N down, so "
           "that the process's warm-up falls on the costliest point). The observed order p and the Richardson value ω∞ use the last three points; the error "
           "estimate follows the rule in `lib/include/modal/sweep.hpp` (the change from the previous triple's "
           "extrapolation, or the sensitivity to the order's drift, plus the propagated error estimates of "
           "the modal stage). *order vs ref.* is ln(e_{N2}/e_{N3})/ln(N3/N2) from the errors against the "
           "reference, for comparison with p.")
for name, title, ref in cases:
    conv = rows_of(f"{work}/{name}_convergence.csv")
    ext = rows_of(f"{work}/{name}_extrapolation.csv")
    cmd = open(f"{work}/{name}.cmd").read().strip()
    by_n = {}
    for r in conv:
        by_n.setdefault(int(float(r["N"])), {})[int(r["mode"])] = r
    out += ["", f"## {title}", "", f"    {cmd}", ""]
    head = "| N | coordinates | time [s] |" + "".join(f" ω{k} | rel. error |" for k in range(1, len(ref) + 1))
    out.append(head)
    out.append("|" + "---:|" * (3 + 2 * len(ref)))
    for n in sorted(by_n):
        first = next(iter(by_n[n].values()))
        cells = [str(n), first["coordinates"], f"{float(first['seconds']):.4f}"]
        for k in range(1, len(ref) + 1):
            r = by_n[n].get(k)
            if r is None:
                cells += ["–", "–"]
                continue
            w = float(r["omega"])
            e = (w - ref[k - 1]) / ref[k - 1]
            cells += [f"{w:.10f}", f"{e:.3e}"]
            combined.append([name, n, first["coordinates"], first["seconds"], k, r["omega"], r["error_estimate"],
                             f"{ref[k - 1]:.12g}", f"{e:.6e}"])
        out.append("| " + " | ".join(cells) + " |")
    out += ["", f"ω_ref = {', '.join(f'{w:.10f}' for w in ref)}.", ""]
    out.append("| mode | N used | order p | order vs ref. | ω(N3) rel. error | ω∞ | ± error (estimate) | "
               "ω∞ − ω_ref | within the estimate | gain |")
    out.append("|---:|---|---:|---:|---:|---:|---:|---:|---|---:|")
    for e in ext:
        k = int(e["mode"])
        w_ref = ref[k - 1]
        ns = sorted(by_n)
        errs = [abs(float(by_n[n][k]["omega"]) - w_ref) for n in ns if k in by_n[n]]
        nk = [n for n in ns if k in by_n[n]]
        order_ref = math.log(errs[-2] / errs[-1]) / math.log(nk[-1] / nk[-2])
        if e["asymptotic"] != "true":
            out.append(f"| {k} | – | – | {order_ref:.4f} | {errs[-1] / w_ref:.3e} | – | – | – | "
                       f"not extrapolated: {e['note'].replace('|', chr(92) + '|')} | – |")
            continue
        w_inf, err = float(e["omega_extrapolated"]), float(e["error"])
        miss = w_inf - w_ref
        ax_n.plot([float(e["n3"])], [abs(miss) / w_ref], marker="*", markersize=11, color=colors[name],
                  linestyle="none")
        out.append(f"| {k} | {int(float(e['n1']))}, {int(float(e['n2']))}, {int(float(e['n3']))} | "
                   f"{float(e['order']):.4f} | {order_ref:.4f} | {errs[-1] / w_ref:.3e} | {w_inf:.10f} | "
                   f"{err:.2e} ({e['error_rule'].replace('|', chr(92) + '|')}) | {miss:.2e} | {'yes' if abs(miss) <= err else '**no**'} | "
                   f"{errs[-1] / max(abs(miss), 1e-300):.0f}× |")
    for k in range(1, len(ref) + 1):
        pts = [(n, by_n[n][k]) for n in sorted(by_n) if k in by_n[n]]
        err = [abs(float(r["omega"]) - ref[k - 1]) / ref[k - 1] for _, r in pts]
        style = dict(color=colors[name], marker=markers[k - 1], linestyle="-" if k == 1 else "--" if k == 2 else ":",
                     label=f"{name} mode {k}")
        ax_n.loglog([n for n, _ in pts], err, **style)
        ax_t.loglog([max(float(r["seconds"]), 1e-5) for _, r in pts], err, **style)

ax_n.set_xlabel("links N")
ax_n.set_ylabel("relative error of ω against the continuum")
ax_n.set_title("error against N (★: Richardson value from the last three N)")
ax_t.set_xlabel("time per point [s] (parse, build, equilibrium, all modes)")
ax_t.set_ylabel("relative error of ω")
ax_t.set_title("error against cost")
for ax in (ax_n, ax_t):
    ax.grid(True, which="both", alpha=0.3)
ax_t.legend(fontsize=7, ncol=3)
fig.tight_layout()
fig.savefig("results/convergence.png", dpi=110)

with open("results/convergence.csv", "w") as f:
    f.write("case,N,coordinates,seconds,mode,omega,error_estimate,reference,relative_error\n")
    for row in combined:
        f.write(",".join(str(c) for c in row) + "\n")
open("results/convergence.md", "w").write("\n".join(out) + "\n")
EOF
cat >> results/convergence.md <<'TXT'

![relative error against N and against the time per point](convergence.png)

## What the tables show

- **R3 converges as expected (docs/design.md, "Reference cases"), O(1/N).** Point masses at the link
  ends: the observed order is 0.98–1.00 for the three lowest modes (0.99–1.00
  from the errors against the Bessel zeros), and the Richardson value from
  N = 160, 320, 640 lands 45–300 times closer to R3 than the 640-link chain,
  inside its error estimate, which is about three times the actual error.
- **R4: the scene as it is converges to Euler–Bernoulli, at first order.**
  Both mass models give O(1/N) (rods: p = 0.97–0.99; point masses the same),
  so the mass model is not what sets the order. The spring at the clamp is:
  every joint spring EI/a stands for the bending of one link length a around
  its joint, but at the clamp only half a link (a/2) bends on the beam's side,
  so the clamp's spring should be EI/(a/2) = 2EI/a. With EI/a the foot is too
  soft over a length a/2, an error proportional to a = L/N. The static tip
  deflection under a tip force shows it in closed form: Σ (L − x_i)² a/EI over
  the joints x_i = 0, a, …, (N − 1)a gives PL³/(3EI) · (1 + 3/(2N) + 1/(2N²)),
  and with the clamp spring doubled PL³/(3EI) · (1 + 1/(2N²)). The last table
  confirms it for the frequencies: with 2EI/a at the clamp the order is 2.00,
  and the 160-link chain's ω₁ is as accurate as the scene as written would be
  with some 55 000 links. euler_column.toml is left as it is (it is R5's buckling
  model, whose closed form P_cr = (4k/a) sin²(π/(4N + 2)) assumes k at every
  joint).
- **How far the extrapolation can be pushed is set by the modal stage's
  error estimates.** A cantilever in relative joint angles has an
  ill-conditioned mass matrix (cond M ≈ 1e10 at 320 links). The first run of
  this page used the dense solver's own eigenvalues, with a linear residual
  bound of 1.5·10⁻⁴ rad/s on ω₁ at N = 320, and `--extrapolate` refused the
  clamp-2EI/a chains beyond N = 160. The dense solver now reports Rayleigh
  quotients with the quadratic (Kato–Temple) bound, accurate to 1e-12 there
  with an estimate near 1e-9 (docs/design.md, "Dense symmetric modes"), and the last table
  runs to 640 links.
TXT
echo "wrote results/convergence.md, results/convergence.csv, results/convergence.png" >&2
