#!/usr/bin/env python3
"""The sparse paths on generated graded chains: the distributed backend
(ctest label mpi) and, with NP 0, the serial sparse path (label python).

Usage: graded_chains.py MODAL NP SEED CHAINS FEWEST MOST
(NP 0: the serial sparse path, `modal analyze CHAIN --solver sparse`, which
has the same probe, moved shift and copies check.)

Generates CHAINS chains of FEWEST–MOST particles between two anchors along x
(seeded by SEED): masses log-uniform over [1e-6, 1e6] and stiffnesses over
[1e-3, 1e3], ascending, descending or shuffled, each spring's rest length set
so that all carry the same tension (no gravity). Their lowest eigenvalues lie
some 1e-22 of the spectrum's scale above zero, where a shift at −ζ cannot
separate them (before the probe, the backend refused every such chain:
"converged 0 of the 10 modes asked for"), and every eigenvalue across the
chain is double (y and z), which a run from one start vector can return once.

Runs `mpirun -np NP modal analyze CHAIN --backend petsc --json` (NP 0:
`modal analyze CHAIN --solver sparse --json`) and requires
a stable chain, every returned mode oscillatory, and the i-th mode within its
error estimate of the i-th lowest eigenvalue of a reference, one to one, so
that a missed copy of a double eigenvalue fails, and no note that a mode may
be missing or that completeness was not checked without the copies check
having answered ("… checked instead by …"): these eigenvalues lie
within η of zero, where the inertia cannot check completeness, and the
copies check (runs from random start vectors) must answer. Before it, runs
from one start vector returned double eigenvalues once: on the serial path
seed 2027's chain 2 had every copy missing under "completeness not
checked"; on the distributed backend up to 9 of 10 modes were added by the
check. The reference: the pencil at the equilibrium
modal reports (written position + q, formed in double as modal forms it; the
transverse stiffness k(1 − L0/L) of a spring at strain 1e-9 moves by 1e-5 of
itself with rounding-level moves of its ends), x, y and z decoupled, each a
tridiagonal pencil (K, diag m), its eigenvalues by Sturm counts of the LDLᵀ
recurrence of K − σM in 60-digit decimal arithmetic (Sylvester's law),
bisected to 1e-25 of themselves: independent of modal (no LAPACK, no double).
"""
import decimal
import json
import math
import os
import random
import sys
import tempfile

import mpi_launch

from decimal import Decimal as D

decimal.getcontext().prec = 60
WANTED = 10


def log_uniform(rng, a, b):
    return math.exp(rng.uniform(math.log(a), math.log(b)))


def chain(rng, particles):
    masses = [log_uniform(rng, 1e-6, 1e6) for _ in range(particles)]
    stiffness = [log_uniform(rng, 1e-3, 1e3) for _ in range(particles + 1)]
    order = rng.randrange(3)
    if order == 0:
        masses.sort()
    elif order == 1:
        masses.sort(reverse=True)
    spacing = 0.1
    tension = spacing * min(stiffness) * log_uniform(rng, 1e-3, 0.5)
    rest = [spacing - tension / k for k in stiffness]
    return masses, stiffness, rest, spacing


def toml(masses, stiffness, rest, spacing):
    n = len(masses)
    lines = ["gravity = [0, 0, 0]"]
    for i, m in enumerate(masses):
        lines += ["[[particle]]", 'name = "p%d"' % i, "position = [%r, 0, 0]" % (spacing * (i + 1)), "mass = %r" % m]
    for i in range(n + 1):
        lines += ["[[spring]]", 'a = "%s"' % ("world" if i == 0 else "p%d" % (i - 1)),
                  'b = "%s"' % ("world" if i == n else "p%d" % i)]
        if i == n:
            lines.append("b_point = [%r, 0, 0]" % (spacing * (n + 1)))
        lines += ["stiffness = %r" % stiffness[i], "rest_length = %r" % rest[i]]
    return "\n".join(lines) + "\n"


def lowest(diag, off, m, count):
    """The lowest `count` eigenvalues of the tridiagonal pencil (diag, off; diag m), K − σM definite for σ < 0."""
    n = len(m)

    def below(sigma):
        negative, d = 0, D(1)
        for i in range(n):
            d = diag[i] - sigma * m[i] - (off[i - 1] * off[i - 1] / d if i > 0 else 0)
            if d == 0:
                d = D("1e-400")
            if d < 0:
                negative += 1
        return negative

    top = max((abs(diag[i]) + (abs(off[i - 1]) if i > 0 else 0) + (abs(off[i]) if i + 1 < n else 0)) / m[i]
              for i in range(n))
    values = []
    for j in range(min(count, n)):
        lo, hi = D(0), 2 * top
        floor = hi * D("1e-60")
        while hi - lo > D("1e-25") * hi:
            # geometric steps while the bracket spans decades, then halving
            mid = (lo * hi).sqrt() if lo > 0 and hi > 4 * lo else (floor if lo == 0 and hi > floor * 4 else (lo + hi) / 2)
            if lo == 0 and mid == floor and below(floor) > j:
                raise SystemExit("FAIL: reference: an eigenvalue below 1e-60 of the spectrum's scale")
            if below(mid) > j:
                hi = mid
            else:
                lo = mid
        values.append((lo + hi) / 2)
    return values


def reference(masses, stiffness, rest, spacing, q):
    n = len(masses)
    x = [D(spacing * (i + 1) + q["p%d.x" % i]) for i in range(n)]  # in double, as modal forms it
    along_d, across_d = [D(0)] * n, [D(0)] * n
    along_o, across_o = [D(0)] * (n - 1), [D(0)] * (n - 1)
    for i in range(n + 1):
        xa = D(0) if i == 0 else x[i - 1]
        xb = D(spacing * (n + 1)) if i == n else x[i]
        k = D(stiffness[i])
        across = k * (1 - D(rest[i]) / (xb - xa))
        for end in (i - 1, i):
            if 0 <= end < n:
                along_d[end] += k
                across_d[end] += across
        if 0 < i < n:
            along_o[i - 1], across_o[i - 1] = -k, -across
    m = [D(v) for v in masses]
    a = lowest(along_d, along_o, m, WANTED)
    t = lowest(across_d, across_o, m, WANTED)
    return sorted(a + t + t)[:WANTED]


def main():
    modal, np_, seed, chains, fewest, most = sys.argv[1], sys.argv[2], *map(int, sys.argv[3:7])
    rng = random.Random(seed)
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        for trial in range(chains):
            particles = rng.randint(fewest, most)
            data = chain(rng, particles)
            scene, out = os.path.join(tmp, "chain%d.toml" % trial), os.path.join(tmp, "chain%d.json" % trial)
            with open(scene, "w") as f:
                f.write(toml(*data))
            command = ([modal, "analyze", scene, "--solver", "sparse", "--json", out] if np_ == "0" else
                       mpi_launch.MPIRUN + [np_, modal, "analyze", scene, "--backend", "petsc", "--json", out])
            r = mpi_launch.run(command, 240)
            what = "chain %d (%d particles, seed %d)" % (trial, particles, seed)
            if r.returncode != 0:
                failures.append("%s: exit %d: %s" % (what, r.returncode, r.stderr.strip()))
                continue
            with open(out) as f:
                result = json.load(f)
            q = result["equilibrium"]["coordinates"]
            ref = reference(*data, q)
            modes = result["modes"]
            if result["stability"] != "stable":
                failures.append("%s: %s" % (what, result["stability"]))
            worst = 0.0
            for note in result["notes"]:  # the copies check must answer (its note says "checked instead")
                if "may be missing" in note or ("completeness not checked" in note and "checked instead" not in note):
                    failures.append("%s: %s" % (what, note))
            for i, (mode, value) in enumerate(zip(modes, ref)):
                err = abs(D(mode["omega2"]) - value)
                worst = max(worst, float(err / value))
                if mode["kind"] != "oscillatory":
                    failures.append("%s mode %d: %s" % (what, i + 1, mode["kind"]))
                if err > D(mode["error_estimate"]):
                    failures.append("%s mode %d: %.10g, reference %.10g: error %.2g over its estimate %.2g" %
                                    (what, i + 1, mode["omega2"], float(value), float(err), mode["error_estimate"]))
            if len(modes) != WANTED:
                failures.append("%s: %d modes" % (what, len(modes)))
                continue
            copies = [note.split("checked instead by ")[-1] for note in result["notes"] if "checked instead" in note]
            print("%s: %s, lowest %.4g, worst relative error %.2g; %s%s" %
                  (what, result["stability"], modes[0]["omega2"], worst, result["solver"],
                   "; " + copies[0] if copies else ""))
    if failures:
        sys.exit("FAIL: " + "\n  ".join(failures))


if __name__ == "__main__":
    main()
