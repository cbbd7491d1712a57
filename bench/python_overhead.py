#!/usr/bin/env python3
"""What a Python call of modal.analyze costs beyond the C++ call (issue 19:
less than 1 ms on the double pendulum).

    PYTHONPATH=build/python /usr/bin/python3 bench/python_overhead.py [SCENE] [--repeats N]

Each figure is the fastest of N calls (the machine's other load only ever
adds time), all in this one process:
  C++ analyze        modal::analyze(model, options) in a C++ loop (modal._modal._time_analyze)
  Python analyze     modal.analyze(model): keyword options, the call, the Analysis object
  + arrays           the same and reading omega2, errors, bounds, shapes, M, K as numpy arrays
  C++ load+analyze   modal::load_model + analyze from the path
  Python from path   modal.analyze(path)
"""

import argparse
import pathlib
import sys
import time

import modal
from modal import _modal


def fastest(f, repeats):
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return best


def main():
    here = pathlib.Path(__file__).resolve().parent
    parser = argparse.ArgumentParser()
    parser.add_argument("scene", nargs="?", default=str(here.parent / "models" / "double_pendulum.toml"))
    parser.add_argument("--repeats", type=int, default=2000)
    args = parser.parse_args()
    n = args.repeats

    model = modal.load(args.scene)
    options = _modal._analysis_options(-1, None, "auto", None, 1e-10, "auto", "exact", 0.0, 1e-12, "newton")
    for _ in range(50):  # warm up (first LAPACK call, caches)
        modal.analyze(model)

    def with_arrays():
        a = modal.analyze(model)
        return a.omega2, a.errors, a.bounds, a.shapes, a.M, a.K

    rows = []
    cxx = _modal._time_analyze(model, options, n)
    py = fastest(lambda: modal.analyze(model), n)
    arrays = fastest(with_arrays, n)
    cxx_load = _modal._time_analyze(model, options, n // 4, True)
    py_load = fastest(lambda: modal.analyze(args.scene), n // 4)
    rows.append(("C++ analyze", cxx))
    rows.append(("Python analyze", py))
    rows.append(("  + 6 arrays", arrays))
    rows.append(("C++ load+analyze", cxx_load))
    rows.append(("Python from path", py_load))
    print(f"scene: {args.scene} ({model.size} coordinates), fastest of {n} calls (load: {n // 4})")
    for name, t in rows:
        print(f"  {name:<18} {t * 1e6:9.1f} µs")
    print(f"  overhead of the call          {(py - cxx) * 1e6:7.1f} µs (Python analyze − C++ analyze)")
    print(f"  overhead with 6 arrays        {(arrays - cxx) * 1e6:7.1f} µs")
    print(f"  overhead from a path          {(py_load - cxx_load) * 1e6:7.1f} µs")
    ok = py - cxx < 1e-3 and arrays - cxx < 1e-3 and py_load - cxx_load < 1e-3
    print("within 1 ms: " + ("yes" if ok else "NO"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
