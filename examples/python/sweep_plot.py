#!/usr/bin/env python3
"""Sweeps a parameter with modal and plots the frequencies, growth rates and
stability along it (matplotlib; the Agg backend when there is no display).

    PYTHONPATH=build/python /usr/bin/python3 examples/python/sweep_plot.py ziegler.png
    /usr/bin/python3 examples/python/sweep_plot.py out.png --scene models/ziegler.toml --vary P=0:6:121

By default: Ziegler's pendulum under a follower load P, 0 ≤ P ≤ 6 (docs/design.md section 2
R6), stable up to P = 7/2 − √2, where its two frequencies merge (flutter),
and divergent beyond 7/2 + √2.
"""

import argparse
import os
import pathlib
import sys

import matplotlib

if not os.environ.get("DISPLAY") and not os.environ.get("MPLBACKEND"):
    matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import modal

COLORS = {"stable": "#d8f0d8", "asymptotically stable": "#c8e8ff", "marginal": "#f0f0c0",
          "divergence": "#ffe0c0", "flutter": "#ffd0d0", "": "#e0e0e0"}


def main():
    here = pathlib.Path(__file__).resolve().parent
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", help="the image to write (e.g. sweep.png)")
    parser.add_argument("--scene", default=str(here.parents[1] / "models" / "ziegler.toml"))
    parser.add_argument("--vary", default="P=0:6:121", help="NAME=FROM:TO:COUNT")
    parser.add_argument("--set", action="append", default=[], help="NAME=VALUE (repeatable)")
    args = parser.parse_args()

    try:
        s = modal.sweep(args.scene, vary=args.vary, set=args.set)
    except modal.Error as e:
        print(e, file=sys.stderr)
        return e.exit_status

    x = s.values
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    # Stability classes as bands, each point's class over half a step either side.
    edges = np.concatenate([[x[0]], (x[1:] + x[:-1]) / 2, [x[-1]]])
    for ax in (top, bottom):
        for i, cls in enumerate(s.stability):
            ax.axvspan(edges[i], edges[i + 1], color=COLORS.get(cls, "#e0e0e0"), lw=0)
    # Points, not lines: modes are numbered by ω at each point, and where two
    # share ω (a flutter pair σ ± iω) their order is arbitrary.
    for k in range(s.omega.shape[1]):
        top.plot(x, s.omega[:, k], "o", ms=6 - 1.5 * k, label=f"mode {k + 1}")
        bottom.plot(x, s.growth_rate[:, k], "o", ms=6 - 1.5 * k)
    for c in s.critical:
        for ax in (top, bottom):
            ax.axvline(c["value"], color="k", ls="--", lw=0.8)
        top.annotate(f"{c['kind']}\n{s.name} = {c['value']:.10g}", (c["value"], top.get_ylim()[1]),
                     xytext=(4, -4), textcoords="offset points", va="top", fontsize=8)
    top.set_ylabel("ω [rad/s]")
    bottom.set_ylabel("growth rate σ [1/s]")
    bottom.set_xlabel(s.name)
    top.set_title(modal.load(args.scene, args.set).title)
    top.legend(loc="lower left", fontsize=8)
    handles = [matplotlib.patches.Patch(color=COLORS[c], label=c) for c in dict.fromkeys(s.stability) if c]
    bottom.legend(handles=handles, loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(args.output, dpi=100)
    for c in s.critical:
        print(f"{c['kind']} at {s.name} = {c['value']:.12g} ± {c['error']:.1g} ({c['before']} -> {c['after']})")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
