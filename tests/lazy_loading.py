#!/usr/bin/env python3
"""The program loads its heavy libraries on first use (docs/design.md, "Start-up").

Usage: lazy_loading.py MODAL MODELS_DIR WORK_DIR

Checks, through the dynamic loader's own account (LD_DEBUG=files), that
- the program does not link LAPACK/BLAS, CHOLMOD, MUMPS, GSL, NLopt or MuJoCo;
- `--version` and small scenes on the dense, first-order, constrained and tree
  paths load none of them;
- each is loaded when the work needs it (a lattice: LAPACK; a net:
  CHOLMOD and MUMPS; `equilibria`: NLopt; `simulate`: GSL; MJCF and URDF:
  MuJoCo), and the work then gives the right answer: a closed form, GSL's
  energy conservation, MuJoCo's error reaching modal's handler (exit 2 with
  MuJoCo's message, not MuJoCo's own exit), which needs the program's copy of
  MuJoCo's data symbols to be the one MuJoCo uses.
"""
import math
import os
import re
import subprocess
import sys

modal, models, work = sys.argv[1], sys.argv[2], sys.argv[3]
os.makedirs(work, exist_ok=True)
HEAVY = ("lapack", "blas", "cholmod", "mumps", "gsl", "nlopt", "mujoco")
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
        print("FAIL:", what)


def run(*args, expect=0):
    env = dict(os.environ, LD_DEBUG="files", CI="true")
    p = subprocess.run([modal, *args], capture_output=True, text=True, env=env, timeout=600)
    loaded = sorted(set(re.findall(r"file=(\S+) \[0\];\s+dynamically loaded", p.stderr)))
    check(p.returncode == expect, f"{' '.join(args)}: exit {p.returncode}, expected {expect}\n{p.stderr[-2000:]}")
    return p, [lib for lib in loaded if any(h in lib for h in HEAVY)]


needed = subprocess.run(["readelf", "-d", modal], capture_output=True, text=True, check=True).stdout
linked = re.findall(r"\(NEEDED\)\s+Shared library: \[(\S+)\]", needed)
check(not [lib for lib in linked if any(h in lib for h in HEAVY)], f"the program links {linked}")

_, loaded = run("--version")
check(loaded == [], f"--version loaded {loaded}")
for scene in ("double_pendulum.toml", "spinning_top.toml", "ziegler_damped.toml", "four_bar.toml",
              "hanging_chain.toml", "foucault.toml", "euler_column.toml"):
    _, loaded = run("analyze", os.path.join(models, scene))
    check(loaded == [], f"analyze {scene} loaded {loaded}")

# The double pendulum's closed form (unit masses and lengths, g = 1): ω² = 2 ∓ √2.
p, _ = run("analyze", os.path.join(models, "double_pendulum.toml"), "--csv", os.path.join(work, "dp"))
rows = open(os.path.join(work, "dp_modes.csv")).read().splitlines()
header = rows[0].split(",")
omega2 = [float(r.split(",")[header.index("omega2")]) for r in rows[1:]]
check(len(omega2) == 2 and abs(omega2[0] - (2 - math.sqrt(2))) < 1e-13 and abs(omega2[1] - (2 + math.sqrt(2))) < 1e-13,
      f"double pendulum ω² {omega2}")


def loads(args, expected, expect=0):
    p, loaded = run(*args, expect=expect)
    for lib in expected:
        check(any(lib in name for name in loaded), f"{' '.join(args)} did not load {lib}: {loaded}")
    return p


# A lattice of a few hundred coordinates goes to LAPACK (dsyevd); its modes
# are checked against references elsewhere: here, that it answers.
lattice = loads(["analyze", os.path.join(models, "lattice.toml"), "--modes", "3"], ["lapack"])
check("Stability" in lattice.stdout, "lattice: no stability verdict")
loads(["analyze", os.path.join(models, "net.toml"), "--modes", "3"], ["cholmod", "mumps"])
loads(["equilibria", os.path.join(models, "four_bar.toml")], ["nlopt"])
sim = loads(["simulate", os.path.join(models, "double_pendulum.toml"), "--at", "0.3,-0.2", "--duration", "2",
             "--csv", os.path.join(work, "sim.csv")], ["gsl"])
energy = re.search(r"conserved to a relative error of (\S+)", sim.stderr)
check(energy is not None and float(energy.group(1)) < 1e-9, f"simulate energy: {sim.stderr[-500:]}")
loads(["analyze", os.path.join(models, "double_pendulum.xml")], ["mujoco"])
loads(["analyze", os.path.join(models, "arm.urdf"), "--modes", "2"], ["mujoco"])
bad = os.path.join(work, "bad.xml")
with open(bad, "w") as f:
    f.write('<mujoco><worldbody><body><joint type="hinge"/><geom type="sphere" size="-1"/></body></worldbody></mujoco>')
p = loads(["analyze", bad], ["mujoco"], expect=2)
check("MuJoCo could not load the model" in p.stderr and "sizes must be positive" in p.stderr,
      f"bad MJCF: {p.stderr[-500:]}")

if failures:
    print(f"{len(failures)} failure(s)")
    sys.exit(1)
print("lazy loading: all checks passed")
