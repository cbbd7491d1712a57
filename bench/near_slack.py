#!/usr/bin/env python3
"""Nearly slack nets: the lowest modes far below the sparse solver's default shift.

    python3 bench/near_slack.py SIDE PROGRAM [PROGRAM ...] > results/near_slack.md

A flat square net of SIDE x SIDE particles (spacing 0.1 m, 2 g, springs of
1000 N/m, boundary fixed), without gravity, at prestrain p. Its out-of-plane
eigenvalues are known in closed form,
    omega^2 = (k p / m) 4 [sin^2(i pi / 2(N + 1)) + sin^2(j pi / 2(N + 1))],
N = SIDE - 2 free particles a side, and lie between about 1e-5 p and 8 p of
the in-plane scale k/m: from p = 1e-8 down they are far below
zeta = 1e-8 max K_ii/M_ii, the distance of the default shift below zero.
p = 0.02 is the easy variant (the bundled net's prestrain) and p = 0 the
degenerate one (every out-of-plane eigenvalue zero).

For each p and each PROGRAM (a `modal` executable: e.g. an older build and
this one) it runs `PROGRAM analyze NET --modes 10 --timing --json FILE
--export-matrices DIR` and reports the eigen-solution's time, the Lanczos
solves, the kinds, and every returned omega^2 against the closed form
(the largest |error| / estimate, which must not exceed 1, and the largest
estimate / |error|). The peer, in the same run on the first program's
exported matrices, is scipy.sparse.linalg.eigsh(K, 10, M, sigma=0,
tol=1e-10) (SuperLU shift-invert, bench/scipy_eigsh.py), timed alone.
"""
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
PRESTRAINS = [0.02, 1e-6, 1e-10, 1e-12, 1e-13, 0.0]


def scene(side, p):
    return f"""gravity = [0, 0, 0]
[[lattice]]
name = "net"
size = [{side}, {side}, 1]
spacing = 0.1
mass = 0.002
stiffness = 1000
prestrain = {p!r}
fixed = "boundary"
"""


def reference(side, p):
    n = side - 2
    k, m = 1000.0, 0.002
    values = [k * p / m * 4 * (math.sin(i * math.pi / (2 * (n + 1))) ** 2 + math.sin(j * math.pi / (2 * (n + 1))) ** 2)
              for i in range(1, n + 1) for j in range(1, n + 1)]
    return sorted(values)


def run_modal(program, path, workdir, export):
    out_json = os.path.join(workdir, "modes.json")
    command = [program, "analyze", path, "--modes", "10", "--timing", "--json", out_json]
    if export:
        command += ["--export-matrices", os.path.join(workdir, "matrices")]
    t0 = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    text = done.stdout + done.stderr
    if done.returncode != 0:
        return {"failed": text.strip().splitlines()[-1] if text.strip() else f"exit {done.returncode}"}
    eigen = re.search(r"timing:\s+eigen-solution\s+([0-9.]+) ms", text)
    solves = sum(int(s) for s in re.findall(r"(\d+) solves", text))
    with open(out_json) as f:
        result = json.load(f)
    return {"wall": wall, "eigen": float(eigen.group(1)) / 1000 if eigen else float("nan"), "solves": solves,
            "result": result}


def modes_of(result):
    for key in ("modes",):
        if key in result:
            return result[key]
    for value in result.values():
        if isinstance(value, dict) and "modes" in value:
            return value["modes"]
    raise KeyError("no modes in the JSON output")


def summarize(run, ref):
    modes = modes_of(run["result"])
    kinds = {}
    worst, loosest = 0.0, 0.0
    for j, mode in enumerate(modes):
        kind = mode["kind"]
        kinds[kind] = kinds.get(kind, 0) + 1
        value = 0.0 if kind == "zero" else mode["omega2"]
        error = abs(value - ref[j])
        estimate = mode["error_estimate"]
        worst = max(worst, error / estimate if estimate > 0 else math.inf)
        if error > 0:
            loosest = max(loosest, estimate / error)
    return ", ".join(f"{v} {k}" for k, v in sorted(kinds.items())), worst, loosest


def scipy_time(directory):
    done = subprocess.run([sys.executable, os.path.join(HERE, "scipy_eigsh.py"), directory, "10", "0", "1e-10"],
                          capture_output=True, text=True)
    match = re.search(r"eigsh_s ([0-9.]+)", done.stdout)
    if done.returncode != 0 or not match:
        last = (done.stderr.strip().splitlines() or ["failed"])[-1]
        return None, last[:80]
    return float(match.group(1)), ""


def main():
    side = int(sys.argv[1])
    programs = sys.argv[2:]
    n = 3 * (side - 2) ** 2
    print(f"# Nearly slack nets: modes far below the default shift ({side} x {side}, {n} coordinates)\n")
    print(f"Regenerate: `python3 bench/near_slack.py {side} " + " ".join(programs) + " > results/near_slack.md`.\n")
    print(__doc__.split("\n\n", 2)[2].strip() + "\n")
    load = os.getloadavg()[0]
    print(f"Run {time.strftime('%Y-%m-%d')}, one-minute load {load:.1f} at the start.\n")
    print("| p | program | eigen-solution s | Lanczos solves | kinds | max error / estimate | max estimate / error |"
          " scipy eigsh s |")
    print("|---|---|---:|---:|---|---:|---:|---:|")
    for p in PRESTRAINS:
        ref = reference(side, p)
        with tempfile.TemporaryDirectory() as workdir:
            path = os.path.join(workdir, "net.toml")
            with open(path, "w") as f:
                f.write(scene(side, p))
            peer = ""
            for index, program in enumerate(programs):
                run = run_modal(program, path, workdir, export=index == 0)
                if index == 0:
                    seconds, why = scipy_time(os.path.join(workdir, "matrices"))
                    peer = f"{seconds:.2f}" if seconds is not None else f"failed ({why})"
                if "failed" in run:
                    print(f"| {p:g} | {program} | – | – | failed: {run['failed'][:80]} | – | – | {peer} |")
                    continue
                kinds, worst, loosest = summarize(run, ref)
                print(f"| {p:g} | {program} | {run['eigen']:.2f} | {run['solves']} | {kinds} | {worst:.2g} | "
                      f"{loosest:.3g} | {peer} |")
                sys.stdout.flush()


if __name__ == "__main__":
    main()
