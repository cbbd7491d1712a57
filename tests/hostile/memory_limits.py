#!/usr/bin/env python3
"""modal under an address-space limit (ulimit -v, a batch system's h_vmem).

Usage: memory_limits.py MODAL MODELS_DIR WORK_DIR

For three generated scenes that take the three paths (a slack net on the
sparse path with the large-scene equilibrium, a hanging chain on the dense
path, a double pendulum that loads no numerical library), `modal analyze
--json` runs under RLIMIT_AS limits from 25 MB up in steps of 40 MB, and at
4 GB. Every run must end within 60 s (Debian 12's OpenBLAS retried a refused
128 MiB buffer for ever: the process spun at full CPU), with status 0 and the
JSON, or status 4 with a sentence that names the lack of memory or the
library that ended the process, no JSON and no temporary left beside it
(before: an abort on std::bad_alloc thrown while the command line was set up,
status 1 from libgomp's exit, status 130 from OpenBLAS's raise(SIGINT)). The
answers under a limit agree with the unlimited run's to 1e-9 relative (the
BLAS threads that could be started may differ). The run at 4 GB must succeed,
and for the net and the chain some run below 1 GB too: the refusals are not
counted too eagerly. OpenBLAS and OpenMP run 2 threads whatever the machine
(each OpenBLAS thread reserves a 128 MiB buffer: on many cores 4 GB would not
be enough).
"""
import json
import os
import resource
import subprocess
import sys

MODAL, MODELS, WORK = sys.argv[1], sys.argv[2], sys.argv[3]
MB = 1_000_000
LIMITS = [25 * MB + 40 * MB * i for i in range(20)] + [4000 * MB]
ENV = dict(os.environ, OPENBLAS_NUM_THREADS="2", OMP_NUM_THREADS="2")
REASONS = ("out of memory", "ended the process before the computation finished", "cannot load")

os.makedirs(WORK, exist_ok=True)
net = os.path.join(WORK, "slack_net.toml")
with open(net, "w") as f:
    f.write('gravity = [0, 0, -9.81]\n[[lattice]]\nname = "net"\nsize = [30, 60, 1]\nspacing = 0.1\n'
            'mass = 0.002\nstiffness = 1000\nprestrain = 0\nfixed = "boundary"\n')
SCENES = [
    ("slack net, 5220 coordinates", [net, "--modes", "5"]),
    ("hanging chain, 600 links", [os.path.join(MODELS, "hanging_chain.toml"), "--set", "N=600"]),
    ("double pendulum", [os.path.join(MODELS, "double_pendulum.toml")]),
]


def run(arguments, limit, out):
    if os.path.exists(out):
        os.remove(out)

    def limited():
        if limit is not None:
            hard = resource.getrlimit(resource.RLIMIT_AS)[1]
            resource.setrlimit(resource.RLIMIT_AS, (limit if hard == resource.RLIM_INFINITY else min(limit, hard), hard))

    try:
        p = subprocess.run([MODAL, "analyze", *arguments, "--json", out, "--quiet"], capture_output=True,
                           text=True, timeout=60, preexec_fn=limited, env=ENV)
    except subprocess.TimeoutExpired:
        return None, ""
    return p.returncode, p.stderr


def eigenvalues(path):
    with open(path) as f:
        data = json.load(f)
    found = []

    def walk(node):
        if isinstance(node, dict):
            for key, value in node.items():
                if key in ("omega2", "lambda", "eigenvalue") and isinstance(value, (int, float)):
                    found.append(float(value))
                else:
                    walk(value)
        elif isinstance(node, list):
            for value in node:
                walk(value)

    walk(data)
    return found


failures = []
for name, arguments in SCENES:
    out = os.path.join(WORK, "answer.json")
    status, err = run(arguments, None, out)
    if status != 0:
        failures.append(f"{name}: the unlimited run failed ({status}): {err.strip()}")
        continue
    reference = eigenvalues(out)
    if not reference:
        failures.append(f"{name}: no eigenvalue found in the JSON")
        continue
    outcomes = []
    for limit in LIMITS:
        status, err = run(arguments, limit, out)
        where = f"{name} under {limit // MB} MB"
        leftovers = [f for f in os.listdir(WORK) if f not in ("slack_net.toml", "answer.json")]
        if leftovers:
            failures.append(f"{where}: files left beside the output: {leftovers}")
            for f in leftovers:
                os.remove(os.path.join(WORK, f))
        if status is None:
            failures.append(f"{where}: still running after 60 s (a hang)")
        elif status == 0:
            if not os.path.exists(out):
                failures.append(f"{where}: status 0 without the JSON")
            else:
                got = eigenvalues(out)
                scale = max(abs(v) for v in reference)
                if len(got) != len(reference) or any(abs(a - b) > 1e-9 * max(abs(b), scale * 1e-6)
                                                     for a, b in zip(got, reference)):
                    failures.append(f"{where}: answers differ from the unlimited run's")
        elif status == 4:
            lines = [line for line in err.splitlines() if line.startswith("modal: ")]
            if not lines or not any(reason in lines[-1] for reason in REASONS):
                failures.append(f"{where}: status 4 without a sentence naming the cause: {err.strip()!r}")
            if os.path.exists(out):
                failures.append(f"{where}: status 4 left the JSON")
        else:
            failures.append(f"{where}: status {status}: {err.strip()!r}")
        outcomes.append(f"{limit // MB}:{status}")
    if status != 0:
        failures.append(f"{name}: failed even under 4 GB")
    if not any(o.endswith(":0") for o in outcomes[:-1]) and "pendulum" not in name:
        failures.append(f"{name}: no run under 1 GB succeeded")
    print(f"{name}: " + " ".join(outcomes))

for failure in failures:
    print("FAIL " + failure)
sys.exit(1 if failures else 0)
