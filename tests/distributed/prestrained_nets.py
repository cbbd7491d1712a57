#!/usr/bin/env python3
"""The sparse paths' estimates on generated prestrained nets against their
closed form: the distributed backend (ctest label mpi) and, with NP 0, the
serial sparse path.

Usage: prestrained_nets.py MODAL NP SEED NETS SMALLEST LARGEST

Generates NETS flat square nets of SMALLEST–LARGEST particles a side (seeded
by SEED; spacing 0.1 m, 2 g, springs of 1000 N/m, boundary fixed, no
gravity), at prestrains p log-uniform over [1e-12, 1e-3], the first net of
every seed at p = 0 (the degenerate variant: every out-of-plane eigenvalue
zero). Their out-of-plane eigenvalues are known in closed form,
    omega^2 = (k p / m) 4 [sin^2(i pi / 2(N + 1)) + sin^2(j pi / 2(N + 1))]
(N = side - 2 free particles a side), and are the lowest for these p and
sides (the in-plane ones lie near (k/m)(pi/(N + 1))^2 and above). The
reference is evaluated in 40-digit decimal arithmetic (Taylor series of sin),
independent of modal.

Runs `mpirun -np NP modal analyze NET --backend petsc --modes 10 --json`
(NP 0: `modal analyze NET --solver sparse ...`) and requires 10 modes, each
within its error estimate of the reference in sorted order (a missed copy of
a double eigenvalue fails), oscillatory where the reference exceeds 10 x the
worst case of the data's rounding on a unit mode (4 eps 16 k/m: two terms of
size k in each of a node's four springs' transverse stiffnesses, and the
Laplacian's 4 + 4 entries summed in magnitude), zero at p = 0, and no note
that a mode may be missing. A spring's transverse stiffness k p is formed as
k - k L0/L and carries eps/p of itself: at p = 1e-9 the formed eigenvalues
lie some 1e-7 of themselves from the closed form, which the estimates must
say. Before the distributed backend took K's entries at the sizes of their
terms (and before it read the rows of K correctly: |K| was all zero), its
estimates at p = 1e-9 were 1e5-1e6 x below the true errors.
"""
import json
import math
import os
import random
import subprocess
import sys
import tempfile

from decimal import Decimal as D, getcontext

getcontext().prec = 40
MPIRUN = ["mpirun", "--quiet", "--allow-run-as-root", "--oversubscribe", "-np"]
WANTED = 10
K_SPRING, MASS = 1000, D("0.002")
EPS = 2.0 ** -52


def scene(side, p):
    return ("gravity = [0, 0, 0]\n[[lattice]]\nname = \"net\"\nsize = [%d, %d, 1]\nspacing = 0.1\nmass = 0.002\n"
            "stiffness = 1000\nprestrain = %r\nfixed = \"boundary\"\n" % (side, side, p))


def pi():
    # Machin: pi = 16 atan(1/5) - 4 atan(1/239)
    def atan_inv(x):
        x = D(x)
        total, term, k, sign = D(0), 1 / x, 1, 1
        while abs(term) > D(10) ** -45:
            total += sign * term / k
            term /= x * x
            k += 2
            sign = -sign
        return total
    return 16 * atan_inv(5) - 4 * atan_inv(239)


def sin(x):
    total, term, k = D(0), x, 1
    while abs(term) > D(10) ** -45:
        total += term
        term = -term * x * x / ((k + 1) * (k + 2))
        k += 2
    return total


def reference(side, p):
    n = side - 2
    scale = K_SPRING * D(repr(p)) / MASS * 4
    s = [sin(i * pi() / (2 * (n + 1))) ** 2 for i in range(1, n + 1)]
    return sorted(scale * (s[i] + s[j]) for i in range(n) for j in range(n))[:WANTED]


def main():
    modal, np_, seed, nets, smallest, largest = sys.argv[1], sys.argv[2], *map(int, sys.argv[3:7])
    rng = random.Random(seed)
    failures = []
    data = 4 * EPS * 16 * K_SPRING / float(MASS)
    with tempfile.TemporaryDirectory() as tmp:
        for trial in range(nets):
            side = rng.randint(smallest, largest)
            p = 0.0 if trial == 0 else math.exp(rng.uniform(math.log(1e-12), math.log(1e-3)))
            path, out = os.path.join(tmp, "net%d.toml" % trial), os.path.join(tmp, "net%d.json" % trial)
            with open(path, "w") as f:
                f.write(scene(side, p))
            options = ["--modes", str(WANTED), "--json", out]
            command = ([modal, "analyze", path, "--solver", "sparse"] + options if np_ == "0" else
                       MPIRUN + [np_, modal, "analyze", path, "--backend", "petsc"] + options)
            r = subprocess.run(command, capture_output=True, text=True, timeout=240)
            what = "net %d (side %d, p %.3g, seed %d)" % (trial, side, p, seed)
            if r.returncode != 0:
                failures.append("%s: exit %d: %s" % (what, r.returncode, r.stderr.strip()))
                continue
            with open(out) as f:
                result = json.load(f)
            modes = result["modes"]
            if len(modes) != WANTED:
                failures.append("%s: %d modes" % (what, len(modes)))
                continue
            for note in result["notes"]:
                if "may be missing" in note:
                    failures.append("%s: %s" % (what, note))
            ref = reference(side, p)
            worst, loosest = 0.0, 0.0
            for i, (mode, value) in enumerate(zip(modes, ref)):
                err = abs(D(mode["omega2"]) - value)
                estimate = D(mode["error_estimate"])
                worst = max(worst, float(err / estimate) if estimate > 0 else math.inf)
                loosest = max(loosest, float(estimate / max(err, D(EPS) * value, D(1e-300))))
                if err > estimate:
                    failures.append("%s mode %d: %.12g, closed form %.12g: error %.2g over its estimate %.2g" %
                                    (what, i + 1, mode["omega2"], float(value), float(err), mode["error_estimate"]))
                expected = "zero" if p == 0 else "oscillatory" if value > 10 * data else None
                if expected and mode["kind"] != expected:
                    failures.append("%s mode %d: %s, expected %s (%.6g, closed form %.6g)" %
                                    (what, i + 1, mode["kind"], expected, mode["omega2"], float(value)))
            print("%s: %s, largest error/estimate %.2g, largest estimate/error %.2g" %
                  (what, result["stability"], worst, loosest))
    if failures:
        sys.exit("FAIL: " + "\n  ".join(failures))


if __name__ == "__main__":
    main()
