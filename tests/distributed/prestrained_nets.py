#!/usr/bin/env python3
"""The sparse paths' estimates on generated prestrained nets against their
closed form: the distributed backend (ctest label mpi) and, with NP 0, the
serial sparse path.

Usage: prestrained_nets.py MODAL NP SEED NETS SMALLEST LARGEST [--mixed | --tiny]

Generates NETS flat square nets of SMALLEST–LARGEST particles a side (seeded
by SEED; spacing 0.1 m, 2 g, springs of 1000 N/m, boundary fixed, no
gravity), at prestrains p log-uniform over [1e-12, 1e-3], every third one
compressed (-p: written as particles and springs, every out-of-plane
eigenvalue negative), the first net of every seed at p = 0 (the degenerate
variant: every out-of-plane eigenvalue zero). Their out-of-plane eigenvalues are known in closed form,
    omega^2 = (k p / m) 4 [sin^2(i pi / 2(N + 1)) + sin^2(j pi / 2(N + 1))]
(N = side - 2 free particles a side), and are the lowest for these p and
sides (the in-plane ones lie near (k/m)(pi/(N + 1))^2 and above; under
compression, the lowest are the most negative). The
reference is evaluated in 40-digit decimal arithmetic (Taylor series of sin),
independent of modal.

With --tiny, every net is compressed at |p| log-uniform over [1e-14, 1e-11]:
its eigenvalues lie from within eta of zero (negative, all above -zeta) to
some 40 eta (a net of side 20 at p = -2e-13 had its 10th mode unconverged
and 315 of its resolved negative eigenvalues counted as zero modes).

With --mixed, each scene is a compressed net of side 3-6 (all its
out-of-plane eigenvalues below -zeta, m of them) beside such a net at p > 0,
and m plus 1-10 modes are wanted (mixed_scene).

Runs `mpirun -np NP modal analyze NET --backend petsc --modes 10 --json`
(NP 0: `modal analyze NET --solver sparse ...`) and requires 10 modes, each
within its error estimate of the reference in sorted order (a missed copy of
a double eigenvalue fails), oscillatory where the reference exceeds 10 x the
worst case of the data's rounding on a unit mode (4 eps 16 k/m: two terms of
size k in each of a node's four springs' transverse stiffnesses, and the
Laplacian's 4 + 4 entries summed in magnitude), divergent where it lies
below -10 x that, zero at p = 0, no note that a mode may be missing, and
under compression the class divergence, the Morse index the eigenvalues
below -zeta or returned as divergent, and a note with the inertia's count
below -eta (eta = 1e-12 max K_ii/M_ii) where that is more: a net of side 20
at p = -1e-9 (324 negative eigenvalues, all above -zeta = -1e-8 max
K_ii/M_ii) has Morse index 10 and the note says 324 (the others are not
counted: for modes not returned, the rounding of zero is not measured). A spring's transverse stiffness k p is formed as
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
import sys
import tempfile

import mpi_launch

from decimal import Decimal as D, getcontext

getcontext().prec = 40
WANTED = 10
K_SPRING, MASS = 1000, D("0.002")
EPS = 2.0 ** -52


def scene(side, p):
    if p < 0:
        return explicit_scene(side, p)
    return ("gravity = [0, 0, 0]\n[[lattice]]\nname = \"net\"\nsize = [%d, %d, 1]\nspacing = 0.1\nmass = 0.002\n"
            "stiffness = 1000\nprestrain = %r\nfixed = \"boundary\"\n" % (side, side, p))


def explicit_scene(side, p, offset=0):
    """The same net as particles and springs (the lattice takes no negative
    prestrain): rest length h (1 - p), so that T/L = k p as the lattice's, the
    boundary nodes as fixed points of the springs. h = 1/8 and p a multiple of
    2^-50 make the positions and rest lengths exact in binary: the scene as
    written is the closed form's (with h = 0.1, the rest length's rounding,
    eps/2 of it, moved the eigenvalues by eps/2p, 2.6e-10 of themselves at
    p = -4.3e-7, beyond the estimates of the scene as written)."""
    h = 0.125

    def inner(i, j):
        return 0 < i < side - 1 and 0 < j < side - 1

    lines = ["gravity = [0, 0, 0]"]
    for i in range(1, side - 1):
        for j in range(1, side - 1):
            lines += ["[[particle]]", 'name = "p%d_%d"' % (i, j), "position = [%r, %r, 0]" % (offset + h * i, h * j),
                      "mass = 0.002"]
    for i in range(side):
        for j in range(side):
            for a, b in (((i, j), (i + 1, j)), ((i, j), (i, j + 1))):
                if b[0] >= side or b[1] >= side or not (inner(*a) or inner(*b)):
                    continue
                lines.append("[[spring]]")
                for key, (x, y) in (("a", a), ("b", b)):
                    lines += (['%s = "p%d_%d"' % (key, x, y)] if inner(x, y) else
                              ['%s = "world"' % key, "%s_point = [%r, %r, 0]" % (key, offset + h * x, h * y)])
                lines += ["stiffness = 1000", "rest_length = %r" % (h * (1 - p))]
    return "\n".join(lines) + "\n"


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


def out_of_plane(side, p):
    n = side - 2
    scale = K_SPRING * D(p) / MASS * 4  # p's exact binary value
    s = [sin(i * pi() / (2 * (n + 1))) ** 2 for i in range(1, n + 1)]
    return sorted(scale * (s[i] + s[j]) for i in range(n) for j in range(n))


def dyadic(p):
    return round(p * 2.0 ** 50) / 2.0 ** 50


def mixed_scene(rng, smallest, largest):
    """A compressed net of side 3-6 (1-16 out-of-plane eigenvalues, all below
    -zeta) beside a prestrained net of side SMALLEST-LARGEST at p log-uniform
    over [1e-12, 1e-3], 100 m away, and the number of modes wanted: m plus
    1-10 (k > m: the lowest non-negative ones come from runs at sigma_0).
    Returns the scene, its sorted out-of-plane eigenvalues, k and a label."""
    side_c, side = rng.randint(3, 6), rng.randint(smallest, largest)
    p_c = -dyadic(math.exp(rng.uniform(math.log(1e-6), math.log(1e-3))))
    p = math.exp(rng.uniform(math.log(1e-12), math.log(1e-3)))
    # the compressed net 100 m away (h = 1/8: its positions stay exact; the
    # lattice's, 0.1 apart, would be rounded there at 1.4e-14 m, which moves
    # its transverse stiffness by 1.4e-14/(0.1 p) of itself)
    compressed = explicit_scene(side_c, p_c, offset=100)
    values = sorted(out_of_plane(side_c, p_c) + out_of_plane(side, p))
    wanted = (side_c - 2) ** 2 + rng.randint(1, 10)
    return (scene(side, p) + compressed.replace("gravity = [0, 0, 0]\n", ""), values, wanted, p,
            "compressed net side %d (p %.3g) beside net side %d (p %.3g), %d modes" % (side_c, p_c, side, p, wanted))


def main():
    modal, np_, seed, nets, smallest, largest = sys.argv[1], sys.argv[2], *map(int, sys.argv[3:7])
    mixed, tiny = sys.argv[7:] == ["--mixed"], sys.argv[7:] == ["--tiny"]
    rng = random.Random(seed)
    failures = []
    data = 4 * EPS * 16 * K_SPRING / float(MASS)
    with tempfile.TemporaryDirectory() as tmp:
        for trial in range(nets):
            wanted = WANTED
            if mixed:
                text, values, wanted, p_zeta, label = mixed_scene(rng, smallest, largest)
                compressed, at_rest = True, False  # the other net's p (p_zeta) sets zeta
            else:
                side = rng.randint(smallest, largest)
                p = 0.0 if trial == 0 else math.exp(rng.uniform(math.log(1e-12), math.log(1e-3)))
                if trial % 3 == 2:  # compressed: every out-of-plane eigenvalue negative
                    p = -dyadic(p)
                if tiny:
                    p = -dyadic(math.exp(rng.uniform(math.log(1e-14), math.log(1e-11))))
                    if trial == 0:
                        side, p = 20, -dyadic(2e-13)
                text, values, p_zeta = scene(side, p), out_of_plane(side, p), p
                compressed, at_rest = p < 0, p == 0
                label = "net %d (side %d, p %.3g" % (trial, side, p)
            path, out = os.path.join(tmp, "net%d.toml" % trial), os.path.join(tmp, "net%d.json" % trial)
            with open(path, "w") as f:
                f.write(text)
            options = ["--modes", str(wanted), "--json", out]
            command = ([modal, "analyze", path, "--solver", "sparse"] + options if np_ == "0" else
                       mpi_launch.MPIRUN + [np_, modal, "analyze", path, "--backend", "petsc"] + options)
            r = mpi_launch.run(command, 240)
            what = "%s, seed %d)" % (label, seed) if not mixed else "trial %d: %s (seed %d)" % (trial, label, seed)
            if r.returncode != 0:
                failures.append("%s: exit %d: %s" % (what, r.returncode, r.stderr.strip()))
                continue
            with open(out) as f:
                result = json.load(f)
            modes = result["modes"]
            if len(modes) != wanted:
                failures.append("%s: %d modes" % (what, len(modes)))
                continue
            # A note that a mode may be missing fails: the paths at sigma_0
            # must resolve it, beside a compressed net too (k > m: both
            # backends probe their runs near zero and check their copies;
            # before the distributed backend did, 9 of seeds 1-6's 48 mixed
            # scenes had such a note, seed 3's scene 4 with 2.457e-6 as its
            # 19th mode where a copy of 1.538e-6 belongs).
            missing = [note for note in result["notes"] if "may be missing" in note]
            failures += ["%s: %s" % (what, note) for note in missing]
            ref = values[:wanted]
            worst, loosest = 0.0, 0.0
            unresolved = 0  # modes within 10 eta of zero returned as zero modes where the data resolve them
            for i, (mode, value) in enumerate(zip(modes, ref)):
                err = abs(D(mode["omega2"]) - value)
                estimate = D(mode["error_estimate"])
                worst = max(worst, float(err / estimate) if estimate > 0 else math.inf)
                loosest = max(loosest, float(estimate / max(err, D(EPS) * abs(value), D(1e-300))))
                if err > estimate:
                    failures.append("%s mode %d: %.12g, closed form %.12g: error %.2g over its estimate %.2g" %
                                    (what, i + 1, mode["omega2"], float(value), float(err), mode["error_estimate"]))
                expected = ("zero" if at_rest else "oscillatory" if value > 10 * data else
                            "divergent" if value < -10 * data else None)
                if tiny and trial > 0:
                    # beyond 10 x the data's worst case the estimates may
                    # still exceed |lambda| (they are loose: up to 1e15 x the
                    # error here), "zero": only the sign is required
                    if mode["kind"] == "zero" and abs(value) > 10 * data:
                        unresolved += 1
                    expected = (None if mode["kind"] == "zero" else
                                "divergent" if value < 0 else "oscillatory" if value > 0 else None)
                if expected and mode["kind"] != expected:
                    failures.append("%s mode %d: %s, expected %s (%.6g, closed form %.6g)" %
                                    (what, i + 1, mode["kind"], expected, mode["omega2"], float(value)))
            if compressed:
                # The Morse index: the eigenvalues below -zeta (zeta = 1e-8
                # max K_ii/M_ii, K_ii = 2k(1 + p) in-plane) or returned as
                # divergent; a note gives the inertia's count below -eta
                # (eta = 1e-4 zeta) where that is more (the others may lie
                # within the rounding of zero, not measured for modes not
                # returned), where no eigenvalue lies within a factor 2 of
                # either level
                zeta = 1e-8 * 2 * K_SPRING * (1 + p_zeta) / float(MASS)
                eta = 1e-4 * zeta
                values = [float(v) for v in values]
                if tiny and trial > 0:
                    # the Morse index between what is known and the truth
                    # (the dense path, below 200 coordinates, resolves all)
                    known = sum(1 for m in modes if m["kind"] == "divergent")
                    if not known <= result["morse_index"] <= sum(1 for v in values if v < 0):
                        failures.append("%s: Morse index %d, outside [%d, %d]" % (
                            what, result["morse_index"], known, sum(1 for v in values if v < 0)))
                    if (result["morse_index"] > 0) != (result["stability"] == "divergence"):
                        failures.append("%s: %s with Morse index %d" % (what, result["stability"], result["morse_index"]))
                elif not any(0.5 * level < -v < 2 * level for v in values for level in (eta, zeta)):
                    morse = max(sum(1 for v in values if v < -zeta), sum(1 for m in modes if m["kind"] == "divergent"))
                    below_eta = sum(1 for v in values if v < -eta)
                    if result["stability"] != "divergence" or result["morse_index"] != morse:
                        failures.append("%s: %s, Morse index %d, expected divergence with %d" %
                                        (what, result["stability"], result["morse_index"], morse))
                    counted = "counts %d eigenvalues below it" % below_eta
                    if below_eta > morse and not any(counted in note for note in result["notes"]):
                        failures.append("%s: no note that the inertia %s" % (what, counted))
            print("%s: %s (Morse index %d), largest error/estimate %.2g, largest estimate/error %.2g%s" %
                  (what, result["stability"], result["morse_index"], worst, loosest,
                   ("; %d near zero returned as zero modes" % unresolved if unresolved else "") +
                   ("; a note: a mode may be missing" if missing else "")))
    if failures:
        sys.exit("FAIL: " + "\n  ".join(failures))


if __name__ == "__main__":
    main()
