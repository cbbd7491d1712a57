"""examples/python/sweep_plot.py runs, finds Ziegler's flutter load and writes a PNG."""

import math
import os
import subprocess
import sys

from conftest import SOURCE_DIR


def test_sweep_plot(tmp_path):
    out = tmp_path / "ziegler.png"
    env = dict(os.environ, MPLBACKEND="Agg")
    env.pop("DISPLAY", None)
    run = subprocess.run([sys.executable, str(SOURCE_DIR / "examples" / "python" / "sweep_plot.py"), str(out)],
                         capture_output=True, text=True, env=env, timeout=300)
    assert run.returncode == 0, run.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 10000
    flutter = [line for line in run.stdout.splitlines() if line.startswith("flutter at P = ")]
    assert flutter, run.stdout
    value = float(flutter[0].split("=")[1].split("±")[0])
    assert abs(value - (3.5 - math.sqrt(2))) < 1e-9


def test_sweep_plot_reports_errors(tmp_path):
    run = subprocess.run([sys.executable, str(SOURCE_DIR / "examples" / "python" / "sweep_plot.py"),
                          str(tmp_path / "x.png"), "--vary", "Q=0:1:3"], capture_output=True, text=True)
    assert run.returncode == 2 and "Q" in run.stderr and not (tmp_path / "x.png").exists()
