#!/usr/bin/env python3
"""The distributed backend against the serial sparse path (ctest label mpi).

Usage: compare.py MODAL NP SCENE [modal analyze options...]
Runs `modal analyze SCENE --solver sparse --json` (serial) and
`mpirun -np NP modal analyze SCENE --backend petsc --json` (which executes
modal-mpi), and requires the same equilibrium and eigenvalues to 1e-10
relative, the same stability class, Morse index and mode kinds. The serial
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

Usage: compare.py MODAL NP --fails STATUS SCENE [options...]: the backend
must end every rank with exit status STATUS and exactly one message line,
within a timeout, without output on stdout. zero_length_spring.toml fails on
one rank only (the one that owns the spring of zero length): the message
must be that rank's (the spring's), not the other ranks' stopped Newton.
"""
import json
import os
import subprocess
import sys
import tempfile

MPIRUN = ["mpirun", "--quiet", "--allow-run-as-root", "--oversubscribe", "-np"]
TIMEOUT = 240


def run(cmd):
    return subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT)


def main():
    modal, np_ = sys.argv[1], sys.argv[2]
    args = sys.argv[3:]
    if args[0] == "--fails":
        status, scene, options = int(args[1]), args[2], args[3:]
        try:
            r = run(MPIRUN + [np_, modal, "analyze", scene, "--backend", "petsc"] + options)
        except subprocess.TimeoutExpired:
            sys.exit("FAIL: the ranks did not end within %d s (a hang)" % TIMEOUT)
        lines = [l for l in r.stderr.splitlines() if l.strip()]
        print(r.stderr)
        if r.returncode != status:
            sys.exit("FAIL: exit status %d, expected %d" % (r.returncode, status))
        if "zero_length" in scene and "coincident end points" not in r.stderr:
            sys.exit("FAIL: the message is not the failing rank's")
        if len(lines) != 1:
            sys.exit("FAIL: expected one message line, got %d" % len(lines))
        if r.stderr.count("modal:") > 1 or r.stderr.count("failure:") > 1:
            sys.exit("FAIL: the message repeats its prefix: " + r.stderr)
        if r.stdout.strip():
            sys.exit("FAIL: output on stdout: " + r.stdout)
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
        r = run(MPIRUN + [np_, modal, "analyze", scene, "--backend", "petsc", "--json", petsc_json, "--timing"] + options)
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
    worst_l = max(abs(a - b) / max(abs(a), 1e-300) for a, b in zip(ls, lp))
    if worst_l > 1e-10:
        failures.append("eigenvalues differ by %.3g relative: %s vs %s" % (worst_l, ls, lp))
    for key in ("stability", "morse_index"):
        if s[key] != p[key]:
            failures.append("%s differs: %s, %s" % (key, s[key], p[key]))
    if [m["kind"] for m in s["modes"]] != [m["kind"] for m in p["modes"]]:
        failures.append("mode kinds differ")
    print("np %s: %d coordinates, equilibrium within %.2g, eigenvalues within %.2g relative (largest |λ| %.4g), %s, "
          "Morse index %s" % (np_, len(vs), worst_q, worst_l, top, p["stability"], p["morse_index"]))
    if failures:
        sys.exit("FAIL: " + "; ".join(failures))


if __name__ == "__main__":
    main()
