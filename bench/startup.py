#!/usr/bin/env python3
"""Whole-process cost of small runs of `modal` (issue 15 part 4: a scene of a
few coordinates under 5 ms), against the floor of any process on the same
machine, and SymPy mechanics on the same chains. Writes results/startup.md.

Usage: bench/startup.py [BUILD [BEFORE_BUILD]]    (default: build)
  BEFORE_BUILD: another build of modal, measured in the same runs (the ratio
  shows what a change bought). SYMPY_N="3 5" sets SymPy's chain sizes.

Every command runs RUNS times (default 200), interleaved with the others so
that a change in the machine's load touches all alike; the table gives the
median and the 10th percentile (the quiet runs) in ms.
"""
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
build = sys.argv[1] if len(sys.argv) > 1 else "build"
before = sys.argv[2] if len(sys.argv) > 2 else None
runs = int(os.environ.get("RUNS", "200"))
modal = os.path.join(root, build, "modal")
models = os.path.join(root, "models")
work = tempfile.mkdtemp()
hello = os.path.join(work, "hello")
with open(hello + ".cpp", "w") as f:
    f.write('#include <cstdio>\nint main() { std::puts("modal"); }\n')
subprocess.run(["g++", "-O2", hello + ".cpp", "-o", hello], check=True)

commands = {
    "`/bin/true` (a bare process)": ["/bin/true"],
    "C++ hello world (libstdc++)": [hello],
}
programs = [("", modal)] + ([(" (before)", os.path.join(root, before, "modal"))] if before else [])
for tag, program in programs:
    commands[f"`modal --version`{tag}"] = [program, "--version"]
    commands[f"`modal analyze double_pendulum.toml`{tag}"] = [program, "analyze",
                                                             os.path.join(models, "double_pendulum.toml")]
    for n in (3, 10):
        commands[f"`modal analyze hanging_chain.toml --set N={n}`{tag}"] = [
            program, "analyze", os.path.join(models, "hanging_chain.toml"), "--set", f"N={n}"]
    commands[f"`modal analyze spinning_top.toml`{tag}"] = [program, "analyze",
                                                          os.path.join(models, "spinning_top.toml")]

times = {k: [] for k in commands}
for _ in range(runs):
    for k, c in commands.items():
        t = time.perf_counter()
        subprocess.run(c, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        times[k].append(time.perf_counter() - t)


def ms(v, q):
    v = sorted(v)
    return 1000 * v[min(len(v) - 1, int(q * len(v)))]


sympy_rows = []
python = "/usr/bin/python3"
for n in [int(x) for x in os.environ.get("SYMPY_N", "3 5").split()]:
    out = subprocess.run([python, os.path.join(root, "bench", "sympy_chain.py"), str(n)], capture_output=True,
                         text=True)
    if out.returncode != 0:
        print(out.stderr, file=sys.stderr)
        continue
    seconds, omega2 = out.stdout.split()
    mine = [modal, "analyze", os.path.join(models, "hanging_chain.toml"), "--set", f"N={n}", "--csv",
            os.path.join(work, f"chain{n}")]
    t = []
    for _ in range(20):
        s = time.perf_counter()
        subprocess.run(mine, stdout=subprocess.DEVNULL, check=True)
        t.append(time.perf_counter() - s)
    with open(os.path.join(work, f"chain{n}_modes.csv")) as f:
        rows = f.read().splitlines()
    col = rows[0].split(",").index("omega2")
    modal_omega2 = float(rows[1].split(",")[col])
    sympy_rows.append((n, float(seconds), statistics.median(t), float(omega2), modal_omega2))
shutil.rmtree(work)

load = open("/proc/loadavg").read().split()[0]
cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name")), "?")
lines = [
    "# Start-up and small scenes, whole process",
    "",
    f"Regenerate: `bench/startup.py {build}{' ' + before if before else ''}` (after `cmake --build {build}`).",
    f"Machine: {os.cpu_count()} cores, {cpu}; {time.strftime('%Y-%m-%d', time.gmtime())}; "
    f"load average {load} at the end. {runs} runs of each command, interleaved.",
    "",
    "| command | median [ms] | 10th percentile [ms] |",
    "|---|---:|---:|",
]
for k, v in times.items():
    lines.append(f"| {k} | {ms(v, 0.5):.2f} | {ms(v, 0.1):.2f} |")
if sympy_rows:
    lines += [
        "",
        "SymPy mechanics (bench/sympy_chain.py: Lagrange's equations, `linearize`, eigenvalues of M⁻¹K) on",
        "the same chains, one run each, against `modal analyze hanging_chain.toml --set N=…` (median of 20",
        "runs); both give the lowest ω², which the Laguerre closed form fixes (models/hanging_chain.toml).",
        "",
        "| links N | SymPy [s] | modal [ms] | ratio | SymPy ω²₁ | modal ω²₁ |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for n, s, m, o_s, o_m in sympy_rows:
        lines.append(f"| {n} | {s:.2f} | {1000 * m:.2f} | {s / m:.0f}× | {o_s:.12g} | {o_m:.12g} |")
out = os.path.join(root, "results", "startup.md")
with open(out, "w") as f:
    f.write("\n".join(lines) + "\n")
print("\n".join(lines))
