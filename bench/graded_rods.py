#!/usr/bin/env python3
"""Hanging chains of N rigid rods, uniform and graded, by `modal analyze --modes 3`
with every default (the path it chooses), against an independent reference.

Each chain is written as a TOML scene ([[body]] list of hinges, each rod's centre of
mass at half its length, rotational inertia m L^2 / 12). The graded family draws
lengths log-uniform over 10^-1.5 .. 10^1.5 and masses over 10^-2 .. 10^2 (seeded);
the uniform family has unit rods. Reference: the same chain in the lateral
displacements of its hinges, where M and K are tridiagonal, its three lowest
eigenvalues bisected by Sturm counts from the very doubles of the file: first in
long double (80-bit), then within 1e-9 of that in mpmath at 40 digits. Long double
alone is not enough: on a graded chain that pencil is ill-conditioned (its entries
k/L² and J/L² spread over the lengths' decades squared), and at 1500 links the
long double bisection was off by 7e-14 relative (checked against the Rayleigh
quotient of its vector on the exact absolute-angle M and K). Peer in the same run:
scipy.linalg.eigh on that tridiagonal pencil as dense matrices
(subset_by_index=[0, 2]), its own time and error.

  /usr/bin/python3 bench/graded_rods.py [build-dir]     writes results/graded_rods.md
"""
import os, random, re, subprocess, sys, tempfile, time
import mpmath
import numpy as np
import scipy.linalg

LD = np.longdouble
G = 9.81


def chain(n, graded, seed):
    rng = random.Random(seed)
    L, m = [], []
    for _ in range(n):
        L.append(10 ** rng.uniform(-1.5, 1.5) if graded else 1.0)
        m.append(10 ** rng.uniform(-2, 2) if graded else 1.0)
    lines = [f'title = "{"graded" if graded else "uniform"} rods"', f"gravity = [0, 0, -{G!r}]", ""]
    for j in range(n):
        J = m[j] * L[j] * L[j] / 12
        lines += ["[[body]]", f'name = "r{j}"']
        if j:
            lines += [f'parent = "r{j - 1}"', f"origin = [0, 0, {-L[j - 1]!r}]"]
        lines += ['joint = "hinge"', "axis = [0, 1, 0]", f"mass = {m[j]!r}", f"com = [0, 0, {-L[j] / 2!r}]",
                  f"inertia = [{J!r}, {J!r}, {J * 1e-3!r}, 0, 0, 0]", ""]
    return L, m, "\n".join(lines)


def pencil(L, m, num):
    """K and M (tridiagonal: diagonals and off-diagonals, as lists) in the hinges' lateral displacements
    y_1..y_n, formed in the arithmetic of `num` (np.float64, np.longdouble, mpmath.mpf) from the file's doubles."""
    n = len(L)
    zero = num(0.0)
    kd, ko, md, mo = [zero] * n, [zero] * (n - 1), [zero] * n, [zero] * (n - 1)
    beyond = zero
    for j in range(n - 1, -1, -1):
        Lj, mj = num(L[j]), num(m[j])
        c, J = Lj / 2, num(m[j] * L[j] * L[j] / 12)  # both exactly the file's doubles
        F = c / Lj
        s = num(G) * (mj * c + Lj * beyond) / (Lj * Lj)
        r = J / (Lj * Lj)
        beyond += mj
        md[j] += mj * F * F + r
        kd[j] += s
        if j:
            md[j - 1] += mj * (1 - F) ** 2 + r
            mo[j - 1] += mj * F * (1 - F) - r
            kd[j - 1] += s
            ko[j - 1] -= s
    return kd, ko, md, mo


def sturm_below(kd, ko, md, mo, sigma, one, tiny):
    """How many eigenvalues of the tridiagonal pencil (K, M) lie below sigma (LDLᵀ of K − σM)."""
    d, neg = one, 0
    for i in range(len(kd)):
        off = ko[i - 1] - sigma * mo[i - 1] if i else 0 * one
        d = (kd[i] - sigma * md[i]) - (off * off / d if i else 0 * one)
        if d == 0:
            d = tiny
        neg += d < 0
    return neg


def reference(L, m, count):
    kd, ko, md, mo = pencil(L, m, LD)
    mpmath.mp.dps = 40
    exact = pencil(L, m, mpmath.mpf)
    values = []
    for j in range(count):
        lo, hi = LD(0), LD(1)
        while sturm_below(kd, ko, md, mo, hi, LD(1), LD(1e-300)) <= j:
            hi *= 2
        for _ in range(80):
            mid = (lo + hi) / 2
            lo, hi = (lo, mid) if sturm_below(kd, ko, md, mo, mid, LD(1), LD(1e-300)) > j else (mid, hi)
        # Then in 40 digits, from a bracket 1e-9 around it (checked to hold the eigenvalue).
        centre = mpmath.mpf(float((lo + hi) / 2))
        a, b = centre * (1 - mpmath.mpf("1e-9")), centre * (1 + mpmath.mpf("1e-9"))
        below = lambda x: sturm_below(*exact, x, mpmath.mpf(1), mpmath.mpf("1e-300"))
        if not (below(a) <= j < below(b)):
            sys.exit(f"reference: the long double bracket does not hold eigenvalue {j + 1}")
        for _ in range(70):
            mid = (a + b) / 2
            a, b = (a, mid) if below(mid) > j else (mid, b)
        values.append((a + b) / 2)
    return values


def peer(L, m):
    kd, ko, md, mo = (np.array(v, dtype=np.float64) for v in pencil(L, m, np.float64))
    K = np.diag(kd) + np.diag(ko, 1) + np.diag(ko, -1)
    M = np.diag(md) + np.diag(mo, 1) + np.diag(mo, -1)
    t = time.perf_counter()
    w = scipy.linalg.eigh(K, M, eigvals_only=True, subset_by_index=[0, 2])
    return time.perf_counter() - t, w


def run_modal(modal, scene):
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "rods.toml")
        with open(path, "w") as f:
            f.write(scene)
        t = time.perf_counter()
        p = subprocess.run([modal, "analyze", path, "--modes", "3", "--timing", "--csv", os.path.join(d, "out")],
                           capture_output=True, text=True)
        wall = time.perf_counter() - t
        if p.returncode != 0:
            return wall, None, p.stdout + p.stderr
        rows = open(os.path.join(d, "out_modes.csv")).read().splitlines()
        head = rows[0].split(",")
        modes = [dict(zip(head, r.split(","))) for r in rows[1:4]]
        return wall, modes, p.stdout + p.stderr


def main():
    build = sys.argv[1] if len(sys.argv) > 1 else "build"
    modal = os.path.join(build, "modal")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = [
        "# Hanging chains of rigid rods, uniform and graded (`bench/graded_rods.py`)",
        "",
        f"Regenerate: `/usr/bin/python3 bench/graded_rods.py build`. {time.strftime('%Y-%m-%d', time.gmtime())}, "
        f"{os.cpu_count()} cores.",
        "",
        "`modal analyze SCENE --modes 3` with every other option at its default. Path: the solver line, "
        "and whether the matrix-free path refused M first. Error: the worst |ω² − reference| / reference of the three "
        "lowest, against the hinges' lateral-displacement pencil bisected in 40 digits (mpmath); estimate / error: the "
        "smallest and largest ratio (≥ 1 means the estimate covers the error; errors are floored at 1e-300). Peer: scipy.linalg.eigh on that "
        "tridiagonal pencil as dense matrices, the three lowest (its time, and its worst error likewise).",
        "",
        "| family | links | modal whole [s] | modal eigen [ms] | path | modal error | estimate / error | "
        "scipy eigh [s] | scipy error |",
        "|---|---:|---:|---:|---|---:|---:|---:|---:|",
    ]
    for n in (500, 1000, 1500, 3000):
        for graded in (False, True):
            L, m, scene = chain(n, graded, seed=n)
            ref = reference(L, m, 3)
            wall, modes, text = run_modal(modal, scene)
            ptime, pw = peer(L, m)
            perr = max(abs(mpmath.mpf(float(w)) - r) / r for w, r in zip(pw, ref))
            family = "graded" if graded else "uniform"
            if modes is None:
                reason = text.strip().splitlines()[-1][:80]
                out.append(f"| {family} | {n} | {wall:.2f} | — | refused: {reason} | — | — | {ptime:.2f} | {float(perr):.1e} |")
                continue
            eigen = re.search(r"timing: eigen\s+([0-9.]+) ms", text)
            if "solved on the dense path" in text:
                path = "dense, after matrix-free refused M"
            elif "matrix-free" in text:
                path = "matrix-free"
            else:
                path = "dense" if "dense" in text else "sparse"
            errors = [abs(mpmath.mpf(float(mo["omega2"])) - r) / r for mo, r in zip(modes, ref)]
            ratios = [float(mo["error_estimate"]) / max(float(abs(mpmath.mpf(float(mo["omega2"])) - r)), 1e-300)
                      for mo, r in zip(modes, ref)]
            out.append(f"| {family} | {n} | {wall:.2f} | {float(eigen.group(1)) if eigen else float('nan'):.0f} | "
                       f"{path} | {float(max(errors)):.1e} | {min(ratios):.2g} … {max(ratios):.2g} | {ptime:.2f} | "
                       f"{float(perr):.1e} |")
            print(out[-1], flush=True)
    with open(os.path.join(root, "results", "graded_rods.md"), "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
