#!/usr/bin/env python3
"""Irregular slack nets with graded stiffnesses (issue 15, parts 2 and 5): the
class of scene the uniform slack benchmark does not cover.

    python3 bench/slack_family.py FIRST_SEED LAST_SEED PROGRAM [PROGRAM ...]

For each seed, a square net of N x N particles (N 50-110, boundary fixed) is
written to a temporary directory as a [[network]] scene: free nodes moved by
up to 0.2 spacings in x and y, every spring's rest length the moved distance
(slack) or up to 5 % shorter (pre-tensioned) for a random share of them,
stiffnesses log-uniform over 0, 2, 4 or 6 decades, masses over 0 or 3 decades,
with or without one diagonal per cell. Under gravity such a net sags unevenly:
some springs end up compressed, it wrinkles, and it has several equilibria.
Each PROGRAM (a modal binary) runs `analyze NET --modes 6 --timing --json`;
one markdown row per seed and program: the equilibrium's time, its method's
counts, V at the equilibrium found, and the stability class.
"""
import json
import math
import os
import random
import subprocess
import sys
import tempfile


def generate(seed, directory):
    r = random.Random(seed)
    n = r.randint(50, 110)
    spacing = 10 ** r.uniform(-1.5, 0)
    slack = r.choice([1.0, 0.5, 0.9])
    decades = r.choice([0, 2, 4, 6])
    mass_decades = r.choice([0, 3])
    diagonal = r.random() < 0.5
    at = {}
    with open(os.path.join(directory, "nodes.csv"), "w") as f:
        f.write("name,x,y,z,mass,fixed\n")
        for i in range(n):
            for j in range(n):
                fixed = i in (0, n - 1) or j in (0, n - 1)
                jitter = 0 if fixed else 0.2
                x = (i + r.uniform(-jitter, jitter)) * spacing
                y = (j + r.uniform(-jitter, jitter)) * spacing
                at[i, j] = (x, y)
                f.write(f"n{i}_{j},{x!r},{y!r},0,{1e-3 * 10 ** (mass_decades * r.random())!r},{int(fixed)}\n")
    k0 = 10 ** r.uniform(1, 3)
    with open(os.path.join(directory, "edges.csv"), "w") as f:
        f.write("a,b,stiffness,rest_length\n")
        steps = [(1, 0), (0, 1)] + ([(1, 1)] if diagonal else [])
        for i in range(n):
            for j in range(n):
                for di, dj in steps:
                    if i + di >= n or j + dj >= n:
                        continue
                    (x1, y1), (x2, y2) = at[i, j], at[i + di, j + dj]
                    length = math.hypot(x2 - x1, y2 - y1)
                    prestrain = 0 if r.random() < slack else 10 ** r.uniform(-4, math.log10(0.05))
                    k = k0 * 10 ** (decades * r.random())
                    f.write(f"n{i}_{j},n{i + di}_{j + dj},{k!r},{length * (1 - prestrain)!r}\n")
    with open(os.path.join(directory, "net.toml"), "w") as f:
        f.write('gravity = [0, 0, -9.81]\n[[network]]\nname = "net"\nnodes = "nodes.csv"\nedges = "edges.csv"\n')
    return (f"{n}² ({3 * (n - 2) ** 2} coordinates), slack share {slack}, k over {decades} decades, "
            f"masses over {mass_decades}, {'diagonals' if diagonal else 'no diagonals'}")


def run(program, scene, directory):
    out = os.path.join(directory, "out.json")
    p = subprocess.run([program, "analyze", scene, "--modes", "6", "--timing", "--json", out],
                       capture_output=True, text=True, timeout=900)
    timing = {}
    for line in p.stderr.splitlines():
        if line.startswith("timing: ") and line.endswith(" ms"):
            key, value = line[len("timing: "):-3].rsplit(None, 1)
            timing[key.strip()] = float(value) / 1000
    if p.returncode != 0:
        return f"exit {p.returncode}", "", "", ""
    j = json.load(open(out))
    e = j["equilibrium"]
    method = e["method"].replace(" with the sparse Hessian", "").replace(" preconditioned", "")
    return f"{timing.get('equilibrium', float('nan')):.2f}", method, f"{e['potential']:.10g}", j["stability"]


def main():
    first, last, programs = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3:]
    print("| seed | net | program | equilibrium s | method | V at the equilibrium | stability |")
    print("|---:|---|---|---:|---|---:|---|")
    for seed in range(first, last + 1):
        with tempfile.TemporaryDirectory() as directory:
            what = generate(seed, directory)
            for program in programs:
                t, method, v, stability = run(program, os.path.join(directory, "net.toml"), directory)
                print(f"| {seed} | {what} | {program} | {t} | {method} | {v} | {stability} |", flush=True)


if __name__ == "__main__":
    main()
