#!/usr/bin/env python3
"""The distributed backend against the serial sparse path (ctest label mpi).

Usage: compare.py MODAL NP SCENE [modal analyze options...]
Runs `modal analyze SCENE --solver sparse --json` (serial) and
`mpirun -np NP modal analyze SCENE --backend petsc --json` (which executes
modal-mpi), and requires the same equilibrium and eigenvalues to 1e-10
relative, the same stability class, Morse index, number of zero modes
(counted over the whole spectrum by the inertia, not only among the modes
returned) and mode kinds. The serial
path is an independent computation of the same quantities (CHOLMOD, MUMPS
sequential, Spectra's Lanczos; its own Newton) rather than past output.
Tolerance: both equilibria are converged to the rounding level of the
residual (relative 1e-14 here), so they differ by about cond(K)·1e-14; the
eigenvalues are Rayleigh quotients with residual bounds far below 1e-10.

With `--halo H` among the options, the ranks' reports of what they hold
(`distribution:` lines of --timing) must show distributed generation: the
owned body counts add up to the scene's, and with two ranks or more no rank
has built the whole scene, each at most H bodies beyond its own (its ghosts:
the other ends of its springs, a layer of a lattice).

Usage: compare.py MODAL NP --sweep SCENE [modal sweep options...]: the
sweep with --backend petsc against the serial sweep (compare_sweep).

Usage: compare.py MODAL NP --refused COMMAND SCENE [options...]: a command
the backend refuses (equilibria) ends with status 2 and one message.

Usage: compare.py MODAL NP --fails STATUS SCENE [options...]: the backend
must end every rank with exit status STATUS and exactly one message line,
within a timeout, without output on stdout. zero_length_spring.toml fails on
one rank only (the one that owns the spring of zero length): the message
must be that rank's (the spring's), not the other ranks' stopped Newton.
With STATUS 2 (bad input) the message must also be exactly the serial
run's (`modal analyze SCENE` without the backend, which reads the scene
whole): a fault that no rank sees alone in its part of the scene (an edge
naming a node no rank has, a node name repeated in two ranks' parts) must
still be reported with the serial path's file, line, key and reason.
"""
import csv
import json
import os
import re
import subprocess
import sys
import tempfile

import mpi_launch

TIMEOUT = 240


def run(cmd):
    return mpi_launch.run(cmd, TIMEOUT)


def unresolved_groups(result):
    """The (first, last) modes of each "modes i–j are not resolved" note."""
    groups = []
    for note in result.get("notes", []):
        match = re.match(r"modes (\d+)–(\d+) are not resolved", note)
        if match:
            groups.append((int(match.group(1)), int(match.group(2))))
    return groups


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def relative(a, b):
    return abs(a - b) / max(abs(a), 1e-300)


def compare_sweep(modal, np_, scene, options):
    """`sweep --backend petsc` against the serial sweep: per point and mode the
    same ω² to 1e-10 relative and the same kind; the same critical values
    (kind, classes on either side), their values within the sum of the two
    reported error bounds (each the half width of its final bracket, which
    contains the change of class) plus 1e-10 relative."""
    with tempfile.TemporaryDirectory() as tmp:
        serial, petsc = os.path.join(tmp, "serial.csv"), os.path.join(tmp, "petsc.csv")
        r = run([modal, "sweep", scene, "--csv", serial] + options)
        if r.returncode != 0:
            sys.exit("FAIL: serial sweep: %d %s" % (r.returncode, r.stderr))
        serial_text = r.stdout
        r = run(mpi_launch.MPIRUN + [np_, modal, "sweep", scene, "--backend", "petsc", "--csv", petsc] + options)
        print(r.stdout)
        print(r.stderr)
        if r.returncode != 0:
            sys.exit("FAIL: petsc sweep: %d %s" % (r.returncode, r.stderr))
        if r.stdout.count("Critical values") + r.stdout.count("No change of stability") != 1:
            sys.exit("FAIL: the text was not written exactly once")
        if serial_text.count("failed") or r.stdout.count("failed"):
            sys.exit("FAIL: a point failed")
        s, p = read_csv(serial), read_csv(petsc)
        sc, pc = read_csv(serial[:-4] + "_critical.csv"), read_csv(petsc[:-4] + "_critical.csv")
    failures = []
    if len(s) != len(p):
        failures.append("row counts differ: %d, %d" % (len(s), len(p)))
    worst = 0.0
    for a, b in zip(s, p):
        worst = max(worst, relative(float(a["omega2"]), float(b["omega2"])))
        if a["stability"] != b["stability"] or a["mode"] != b["mode"] or float(list(a.values())[0]) != float(list(b.values())[0]):
            failures.append("row differs: %s / %s" % (dict(a), dict(b)))
    if worst > 1e-10:
        failures.append("eigenvalues differ by %.3g relative" % worst)
    if len(sc) != len(pc):
        failures.append("critical values differ in number: %d, %d" % (len(sc), len(pc)))
    for a, b in zip(sc, pc):
        for key in ("kind", "before", "after"):
            if a[key] != b[key]:
                failures.append("critical %s differs: %s, %s" % (key, a[key], b[key]))
        va, vb = float(a["value"]), float(b["value"])
        if abs(va - vb) > float(a["error"]) + float(b["error"]) + 1e-10 * abs(va):
            failures.append("critical values differ: %r ± %s, %r ± %s" % (va, a["error"], vb, b["error"]))
    print("np %s: %d rows, eigenvalues within %.2g relative; critical values %s" %
          (np_, len(s), worst, [(c["value"], c["error"], c["kind"]) for c in pc]))
    if failures:
        sys.exit("FAIL: " + "; ".join(failures))


def main():
    modal, np_ = sys.argv[1], sys.argv[2]
    args = sys.argv[3:]
    if args[0] == "--sweep":
        compare_sweep(modal, np_, args[1], args[2:])
        return
    if args[0] == "--refused":
        # a command the backend refuses: exit status 2 and one message line, nothing on stdout
        r = run(mpi_launch.MPIRUN + [np_, modal] + args[1:])
        print(r.stderr)
        lines = [l for l in r.stderr.splitlines() if l.strip()]
        if r.returncode != 2 or len(lines) != 1 or r.stdout.strip():
            sys.exit("FAIL: expected exit status 2 and one message line, got %d and %d lines" %
                     (r.returncode, len(lines)))
        return
    if args[0] == "--fails":
        status, scene, options = int(args[1]), args[2], args[3:]
        try:
            r = run(mpi_launch.MPIRUN + [np_, modal, "analyze", scene, "--backend", "petsc"] + options)
        except subprocess.TimeoutExpired:
            sys.exit("FAIL: the ranks did not end within %d s (a hang)" % TIMEOUT)
        lines = [l for l in r.stderr.splitlines() if l.strip()]
        print(r.stderr)
        if r.returncode != status:
            sys.exit("FAIL: exit status %d, expected %d" % (r.returncode, status))
        if "zero_length" in scene and "between 'p2' and 'p3'" not in r.stderr:
            sys.exit("FAIL: the message is not the failing rank's")
        if len(lines) != 1:
            sys.exit("FAIL: expected one message line, got %d" % len(lines))
        if r.stderr.count("modal:") > 1 or r.stderr.count("failure:") > 1:
            sys.exit("FAIL: the message repeats its prefix: " + r.stderr)
        if r.stdout.strip():
            sys.exit("FAIL: output on stdout: " + r.stdout)
        if status == 2:
            serial = run([modal, "analyze", scene] + options)
            if serial.returncode != 2 or serial.stderr.strip() != lines[0].strip():
                sys.exit("FAIL: the message differs from the serial run's (status %d):\n  %s\n  %s" %
                         (serial.returncode, lines[0], serial.stderr.strip()))
        return
    scene, options = args[0], args[1:]
    halo = None
    if "--halo" in options:
        at = options.index("--halo")
        halo = int(options[at + 1])
        del options[at:at + 2]
    with tempfile.TemporaryDirectory() as tmp:
        serial_json, petsc_json = os.path.join(tmp, "serial.json"), os.path.join(tmp, "petsc.json")
        r = run([modal, "analyze", scene, "--solver", "sparse", "--json", serial_json] + options)
        if r.returncode not in (0,):
            sys.exit("FAIL: serial run: %d %s" % (r.returncode, r.stderr))
        r = run(mpi_launch.MPIRUN + [np_, modal, "analyze", scene, "--backend", "petsc", "--json", petsc_json, "--timing"] + options)
        print(r.stderr)
        if r.returncode != 0:
            sys.exit("FAIL: petsc run: %d %s" % (r.returncode, r.stderr))
        if r.stdout.count("modal") > 1 and r.stdout.count("Modes") > 1:
            sys.exit("FAIL: the text was written more than once")
        s, p = json.load(open(serial_json)), json.load(open(petsc_json))
    failures = []
    parts = [l.split() for l in r.stderr.splitlines() if l.startswith("distribution:")]
    # "distribution: rank R of P owns O of the scene's N bodies, built B, assembles A"
    owned = [int(f[6]) for f in parts]
    built = [int(f[13].rstrip(",")) for f in parts]
    total = int(parts[0][10]) if parts else 0
    if len(parts) != int(np_) or sum(owned) != total:
        failures.append("the ranks' owned bodies (%s) do not add up to the scene's %d" % (owned, total))
    if halo is not None and int(np_) > 1:
        for rank, (o, b) in enumerate(zip(owned, built)):
            if b >= total or b - o > halo:
                failures.append("rank %d built %d bodies owning %d of %d (halo at most %d)" % (rank, b, o, total, halo))
    print("distribution: owned %s, built %s of %d" % (owned, built, total))
    qs, qp = s["equilibrium"]["coordinates"], p["equilibrium"]["coordinates"]
    vs, vp = [qs[name] for name in qs], [qp.get(name, float("nan")) for name in qs]
    if len(vs) != len(vp):
        failures.append("coordinate counts differ: %d, %d" % (len(vs), len(vp)))
    scale = max(abs(v) for v in vs) or 1.0
    worst_q = max(abs(a - b) for a, b in zip(vs, vp)) / scale
    if worst_q > 1e-10:
        failures.append("equilibria differ by %.3g relative" % worst_q)
    ls = [m["omega2"] for m in s["modes"]]
    lp = [m["omega2"] for m in p["modes"]]
    if len(ls) != len(lp):
        failures.append("mode counts differ: %d, %d" % (len(ls), len(lp)))
    top = max(abs(v) for v in ls)
    # A zero mode's λ is rounding (zero within its error estimate) on both
    # paths: those are compared within the sum of the two estimates, the
    # others to 1e-10 relative.
    worst_l = 0.0
    for ms, mp in zip(s["modes"], p["modes"]):
        a, b = ms["omega2"], mp["omega2"]
        if ms["kind"] == "zero" and mp["kind"] == "zero":
            if abs(a - b) > ms["error_estimate"] + mp["error_estimate"]:
                failures.append("zero modes' eigenvalues %.3g, %.3g differ beyond their error estimates" % (a, b))
            continue
        worst_l = max(worst_l, abs(a - b) / max(abs(a), 1e-300))
    if worst_l > 1e-10:
        failures.append("eigenvalues differ by %.3g relative: %s vs %s" % (worst_l, ls, lp))
    for key in ("stability", "morse_index", "zero_modes"):
        if s[key] != p[key]:
            failures.append("%s differs: %s, %s" % (key, s[key], p[key]))
    if [m["kind"] for m in s["modes"]] != [m["kind"] for m in p["modes"]]:
        failures.append("mode kinds differ")
    # Repeated eigenvalues are noted on both paths: every group the serial
    # path cannot resolve ("modes i–j are not resolved") lies within one the
    # backend notes (its estimates are no tighter than the serial path's).
    groups_s, groups_p = unresolved_groups(s), unresolved_groups(p)
    for first, last in groups_s:
        if not any(a <= first and last <= b for a, b in groups_p):
            failures.append("modes %d–%d are not resolved on the serial path but not so noted: %s" %
                            (first, last, p.get("notes", [])))
    print("np %s: %d coordinates, equilibrium within %.2g, eigenvalues within %.2g relative (largest |λ| %.4g), %s, "
          "Morse index %s, %s zero modes" % (np_, len(vs), worst_q, worst_l, top, p["stability"], p["morse_index"],
                                            p["zero_modes"]))
    if failures:
        sys.exit("FAIL: " + "; ".join(failures))


if __name__ == "__main__":
    main()
