#!/usr/bin/env python3
"""Fits per-rank costs measured by bench/distributed_memory.sh and projects
them to 10^7 and 10^8 coordinates (results/distributed.md).

Usage: distributed_projection.py NET_TABLE [BLOCK_TABLE]
  (the outputs of bench/distributed_memory.sh with SHAPE=net and SHAPE=block)

Model, at one rank, n coordinates (least squares over the measured sizes):
  memory  M(n) = M0 + c f(n)      f = n log2 n (2-D nested dissection fill),
                                      n^(4/3) (3-D)
  time    T(n) = t0 + d g(n)      g = n^1.5 (2-D factorization flops), n^2 (3-D)
for the equilibrium and the eigen phase separately (each made of MUMPS
factorizations: SNES's Newton steps, the inertia checks and shift-invert).
Projection on P ranks: memory per rank M0 + c f(N) / P * imbalance (the
imbalance measured at two ranks: max per rank over half the one-rank
figure), time d g(N) / (P * efficiency), the efficiency assumed; both printed.
"""
import math
import sys

NODE_CORES, NODE_GIB = 64, 256
IMBALANCE = 1.5      # max over ranks / mean of the memory; replaced by the measured two-rank figure when there is one
EFFICIENCY = 0.3     # parallel efficiency of MUMPS factorization at 10^2-10^3 ranks (assumed)


def read(path):
    rows = []
    for line in open(path):
        f = line.split()
        if len(f) == 10 and f[0].isdigit():
            rows.append(dict(ranks=int(f[0]), n=int(f[1]), coords=int(f[2]), parse=float(f[3]), equilibrium=float(f[5]),
                             assembly=float(f[6]), eigen=float(f[7]), mem_max=float(f[8]), mem_min=float(f[9])))
    return rows


def fit(xs, ys):
    """y = a + b x by least squares."""
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
    return my - b * mx, b


def report(path, shape):
    rows = read(path)
    fill = (lambda n: n * math.log2(n)) if shape == "2-D" else (lambda n: n ** (4 / 3))
    flops = (lambda n: n ** 1.5) if shape == "2-D" else (lambda n: n ** 2)
    one = [r for r in rows if r["ranks"] == 1]
    print("%s (%s), one rank:" % (path, shape))
    m0, c = fit([fill(r["coords"]) for r in one], [r["mem_max"] for r in one])
    print("  memory  M(n) = %.0f MiB + %.3g MiB * %s" % (m0, c, "n log2 n" if shape == "2-D" else "n^(4/3)"))
    for r in one:
        print("    n = %9d: measured %7.0f MiB, fit %7.0f MiB" % (r["coords"], r["mem_max"], m0 + c * fill(r["coords"])))
    phases = {}
    for phase in ("equilibrium", "eigen"):
        t0, d = fit([flops(r["coords"]) for r in one], [r[phase] for r in one])
        phases[phase] = (t0, d)
        print("  %-11s T(n) = %.2f s + %.3g s * %s" % (phase, t0, d, "n^1.5" if shape == "2-D" else "n^2"))
        for r in one:
            print("    n = %9d: measured %7.2f s, fit %7.2f s" % (r["coords"], r[phase], t0 + d * flops(r["coords"])))
    two = {r["coords"]: r for r in rows if r["ranks"] == 2}
    imbalance = IMBALANCE
    for r in one:
        if r["coords"] in two:
            t = two[r["coords"]]
            print("  two ranks, n = %9d: per rank %5.0f / %5.0f MiB (max / min) against %5.0f at one rank (%.2f of it)"
                  % (r["coords"], t["mem_max"], t["mem_min"], r["mem_max"], t["mem_max"] / r["mem_max"]))
            imbalance = t["mem_max"] / (r["mem_max"] / 2)  # the largest size measured on both
    print("  projection (nodes of %d cores / %d GiB: %.1f GiB per rank; imbalance %.2f (two ranks, largest size), "
          "efficiency %.1f assumed):" % (NODE_CORES, NODE_GIB, NODE_GIB / NODE_CORES, imbalance, EFFICIENCY))
    for N in (1e7, 1e8):
        total = c * fill(N) / 1024  # GiB of the factor-dominated part
        for nodes in (1, 4, 16, 64):
            P = nodes * NODE_CORES
            per_rank = (m0 + c * fill(N) / P * imbalance) / 1024
            seconds = sum(d * flops(N) for _, d in phases.values()) / (P * EFFICIENCY)
            fits = "fits" if per_rank <= NODE_GIB / NODE_CORES else "does not fit"
            print("    N = %.0e: %7.0f GiB in all; %3d nodes (%5d ranks): %7.1f GiB per rank (%s), "
                  "equilibrium + eigen %9.0f s" % (N, total, nodes, P, per_rank, fits, seconds))


def main():
    report(sys.argv[1], "2-D")
    if len(sys.argv) > 2:
        report(sys.argv[2], "3-D")


if __name__ == "__main__":
    main()
