#!/usr/bin/env python3
"""The dense eigen phase of `modal analyze` against scipy.linalg.eigh on the
very matrices modal exports (issue 15 part 4: within 1.2× of eigh, estimates
included). Writes results/dense_eigen.md.

Usage: bench/dense_eigen.py [BUILD]     (default: build; /usr/bin/python3 with scipy)

For each scene: `modal analyze SCENE --timing --export-matrices DIR` (the
eigen phase as --timing reports it: equilibration, the solver, every error
estimate and bound, the shapes), then, in the same loop, scipy's
eigh(K, M) (LAPACK dsygvd, driver "gvd", the same OpenBLAS) on DIR's K and M,
and, where modal was asked for the lowest k modes (--modes k), also
eigh(K, M, subset_by_index=[0, k-1], driver="gvx") (dsygvx: the same subset
job).
Runs interleaved, REPEAT times (default 5); medians. The whole process is
reported beside it.

eigh is timed twice: in this (long-lived) process, whose memory is already
faulted in after the first run, and in a fresh Python process started for
it (loading DIR's matrices, then timing eigh alone), whose work arrays are
fresh pages as modal's are. On a virtual machine whose balloon driver
reports freed pages to the host (Firecracker's free page reporting), a
fresh page costs a host fault, and which of the two a run meets depends on
what ran seconds before: both columns are kept.

The table is rewritten; the dated notes below it in results/dense_eigen.md
(the paragraphs that start with "**") are kept.
"""
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import scipy.io
import scipy.linalg

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
build = sys.argv[1] if len(sys.argv) > 1 else "build"
modal = os.path.join(root, build, "modal")
repeat = int(os.environ.get("REPEAT", "5"))
chain = os.path.join(root, "models", "hanging_chain.toml")
scenes = [
    ("hanging chain, 1000 links (default solver)", [chain, "--set", "N=1000"]),
    ("hanging chain, 1000 links, `--modes 10`", [chain, "--set", "N=1000", "--modes", "10"]),
    ("hanging chain, 2000 links, `--solver dense`", [chain, "--set", "N=2000", "--solver", "dense"]),
    ("lattice 6³ (models/lattice.toml), `--solver dense`", [os.path.join(root, "models", "lattice.toml"),
                                                   "--solver", "dense"]),
]
# eigh in a fresh process: the matrices loaded, then eigh alone timed.
FRESH = """
import os, sys, time
import numpy as np, scipy.io, scipy.linalg
d = sys.argv[1]
K, M = (scipy.io.mmread(os.path.join(d, f)) for f in ("K.mtx", "M.mtx"))
K = K.toarray() if hasattr(K, "toarray") else np.asarray(K)
M = M.toarray() if hasattr(M, "toarray") else np.asarray(M)
t = time.perf_counter()
scipy.linalg.eigh(K, M, driver="gvd")
print(time.perf_counter() - t)
"""
rows = []
with tempfile.TemporaryDirectory() as work:
    # The same chain of rods (uniform rods, not point masses): M is not a
    # point-mass chain's but UUᵀ plus a diagonal (a chain of rigid links),
    # whose path reduces the tridiagonal pencil (dsbgst); beside the
    # point-mass chain, which the tridiagonal form takes.
    rods = os.path.join(work, "rod_chain.toml")
    with open(chain) as source, open(rods, "w") as target:
        target.write(source.read().replace('mass_model = "point"', 'mass_model = "rod"'))
    scenes.insert(1, ("chain of rods, 1000 links (default solver)", [rods, "--set", "N=1000"]))
    scenes.insert(3, ("chain of rods, 1000 links, `--modes 10`", [rods, "--set", "N=1000", "--modes", "10"]))
    for name, args in scenes:
        out = os.path.join(work, "m")
        eig, whole, peer, subset, fresh, solver = [], [], [], [], [], ""
        k = int(args[args.index("--modes") + 1]) if "--modes" in args else 0
        for _ in range(repeat):
            t = time.perf_counter()
            p = subprocess.run([modal, "analyze", *args, "--timing", "--quiet", "--export-matrices", out],
                               capture_output=True, text=True)
            whole.append(time.perf_counter() - t)
            if p.returncode not in (0, 3):
                sys.exit(f"{name}: modal failed ({p.returncode}): {p.stderr[-1000:]}")
            for line in p.stderr.splitlines():
                f = line.split()
                if len(f) >= 3 and f[0] == "timing:" and f[1] == "eigen":
                    eig.append(float(f[2]) / 1000)
            for line in p.stdout.splitlines():
                if line.startswith("Modes ("):
                    solver = line[len("Modes ("):-1]
            K = scipy.io.mmread(os.path.join(out, "K.mtx"))
            M = scipy.io.mmread(os.path.join(out, "M.mtx"))
            K = K.toarray() if hasattr(K, "toarray") else np.asarray(K)
            M = M.toarray() if hasattr(M, "toarray") else np.asarray(M)
            t = time.perf_counter()
            scipy.linalg.eigh(K, M, driver="gvd")
            peer.append(time.perf_counter() - t)
            f = subprocess.run([sys.executable, "-c", FRESH, out], capture_output=True, text=True, check=True)
            fresh.append(float(f.stdout.split()[-1]))
            if k > 0:
                t = time.perf_counter()
                scipy.linalg.eigh(K, M, driver="gvx", subset_by_index=[0, k - 1])
                subset.append(time.perf_counter() - t)
        e, w, s = statistics.median(eig), statistics.median(whole), statistics.median(peer)
        sub = statistics.median(subset) if subset else None
        rows.append((name, K.shape[0], e, s, e / s, statistics.median(fresh), sub, w, solver))

load = open("/proc/loadavg").read().split()[0]
lines = [
    "# Dense eigen phase against scipy.linalg.eigh",
    "",
    f"Regenerate: `bench/dense_eigen.py {build}` (after `cmake --build {build}`).",
    f"Machine: {os.cpu_count()} cores; {time.strftime('%Y-%m-%d', time.gmtime())}; load average {load} at the end;",
    f"medians of {repeat} interleaved runs. `eigh` is `scipy.linalg.eigh(K, M, driver=\"gvd\")` (LAPACK dsygvd,",
    "all pairs, no error estimate) on the matrices modal exported; modal's eigen phase includes",
    "equilibration, the solve, the residuals, every error estimate and bound, and the shapes.",
    "",
    "*eigh, fresh* is the same call in a fresh Python process (after loading the matrices): its work",
    "arrays are fresh pages, as modal's are (see the script's header on this machine's page reporting).",
    "",
    "With `--modes k` the last peer columns are `eigh(K, M, subset_by_index=[0, k-1], driver=\"gvx\")`",
    "(LAPACK dsygvx, the lowest k pairs only) and modal's ratio to it.",
    "",
    "| scene | n | modal eigen [s] | eigh [s] | ratio | eigh, fresh [s] | ratio | eigh, lowest k [s] | ratio | whole process [s] | modal's solver |",
    "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
]
for name, n, e, s, r, fr, sub, w, solver in rows:
    subset_cells = f"{sub:.3f} | {e / sub:.2f}" if sub else "– | –"
    lines.append(f"| {name} | {n} | {e:.3f} | {s:.3f} | {r:.2f} | {fr:.3f} | {e / fr:.2f} | {subset_cells} | {w:.2f} | {solver} |")
target = os.path.join(root, "results", "dense_eigen.md")
notes = []
if os.path.exists(target):
    old = open(target).read().split("\n")
    first = next((i for i, line in enumerate(old) if line.startswith("**")), len(old))
    notes = old[first:]
with open(target, "w") as f:
    f.write("\n".join(lines) + "\n" + ("\n" + "\n".join(notes) if notes else ""))
print("\n".join(lines))
