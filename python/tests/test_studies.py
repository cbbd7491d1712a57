"""modal.equilibria, sweep, simulate and amplitude, checked against closed
forms computed here (numpy/scipy), not against modal's own past output."""

import math
import subprocess

import numpy as np
import pytest
import scipy.special

import modal


def test_double_pendulum_equilibria(models):
    e = modal.equilibria(models / "double_pendulum.toml")
    assert len(e) == 4
    # R1: (0, 0) stable; (0, π) and (π, ±π) Morse index 1; (π, 0) index 2 — sorted by V = −3, −1, 1, 3.
    np.testing.assert_allclose(e.potential, [-3, -1, 1, 3], atol=1e-12)
    assert list(e.morse_index) == [0, 1, 1, 2]
    assert list(e.stability) == ["stable", "divergence", "divergence", "divergence"]
    wrapped = np.abs(np.remainder(e.q + np.pi, 2 * np.pi) - np.pi)  # |angle| in [0, π]
    np.testing.assert_allclose(wrapped, [[0, 0], [0, np.pi], [np.pi, np.pi], [np.pi, 0]], atol=1e-9)
    np.testing.assert_allclose(e.omega2[0], [2 - math.sqrt(2), 2 + math.sqrt(2)], rtol=1e-14)
    first = e[0]
    assert first["stability"] == "stable" and first["shapes"].shape == (2, 2)
    assert e[-1]["morse_index"] == 2
    with pytest.raises(IndexError):
        e[4]
    assert "Morse" in e.text() or "morse" in e.text().lower()


def ziegler_lambda(p):
    """Ziegler's pendulum (R6), m = l = k = 1: 2λ² + (2p − 7)λ + 1 = 0."""
    b = 7 - 2 * p
    disc = b * b - 8
    if disc < 0:
        return None
    return np.array([(b - math.sqrt(disc)) / 4, (b + math.sqrt(disc)) / 4])


def test_ziegler_flutter_load(models):
    s = modal.sweep(models / "ziegler.toml", vary="P=0:4:41")
    assert s.name == "P" and not s.is_map
    np.testing.assert_allclose(s.values, np.linspace(0, 4, 41), rtol=0, atol=1e-15)
    assert s.ok.all()
    critical = 3.5 - math.sqrt(2)  # 2.0857864376…
    flutter = [c for c in s.critical if c["kind"] == "flutter"]
    assert len(flutter) == 1
    c = flutter[0]
    assert abs(c["value"] - critical) <= c["error"] + 1e-15 and c["error"] < 1e-9
    assert c["before"] == "stable" and c["after"] == "flutter" and c["refined"]
    assert c["omega"] == pytest.approx(2 ** -0.25, rel=1e-6)
    expected = np.where(s.values < critical, "stable", "flutter")
    assert list(s.stability) == list(expected)
    # Below the flutter load the frequencies are the closed form's.
    for p, w in zip(s.values, s.omega):
        lam = ziegler_lambda(p)
        if p < critical - 0.05:
            np.testing.assert_allclose(np.sort(w) ** 2, lam, rtol=1e-11)
    assert np.all(s.max_growth_rate[s.values > critical + 0.05] > 0)
    assert s.omega2.shape == (41, 2) and s.errors.shape == (41, 2)


def test_sweep_text_is_what_the_command_prints(models, cli, tmp_path):
    path = str(models / "ziegler.toml")
    s = modal.sweep(path, vary="P=0:4:9")
    out = subprocess.run([cli, "sweep", path, "--vary", "P=0:4:9"], capture_output=True, text=True, check=True)
    assert s.text() == out.stdout
    s.write(csv=str(tmp_path / "z.csv"))
    assert (tmp_path / "z.csv").exists() and (tmp_path / "z_critical.csv").exists()


def test_stability_map(models):
    s = modal.sweep(models / "ziegler.toml", vary=["P=0:4:5", "k=0.5:1.5:3"])
    assert s.is_map and s.names == ["P", "k"]
    assert s.stability.shape == (3, 5) and s.min_omega2.shape == (3, 5) and s.ok.shape == (3, 5) and s.ok.all()
    # With p = P l/k: stable below 7/2 − √2, flutter up to 7/2 + √2 (the roots λ of the
    # quadratic complex), divergence beyond (both real and negative).
    for j, k in enumerate(s.y):
        for i, P in enumerate(s.x):
            p = P / k
            expected = "stable" if p < 3.5 - math.sqrt(2) else "flutter" if p < 3.5 + math.sqrt(2) else "divergence"
            assert s.stability[j, i] == expected, (P, k)
    assert "divergence" in s.stability  # P = 4 at k = 0.5: p = 8
    with pytest.raises(AttributeError):
        s.omega2


def pendulum_energy(q, qd, m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=1.0):
    """E = T + V of the planar double pendulum, relative angles (R1's layout)."""
    t1, t2 = q[:, 0], q[:, 0] + q[:, 1]
    w1, w2 = qd[:, 0], qd[:, 0] + qd[:, 1]
    T = 0.5 * m1 * l1**2 * w1**2 + 0.5 * m2 * (l1**2 * w1**2 + l2**2 * w2**2 + 2 * l1 * l2 * w1 * w2 * np.cos(t2 - t1))
    V = -m1 * g * l1 * np.cos(t1) - m2 * g * (l1 * np.cos(t1) + l2 * np.cos(t2))
    return T + V


def test_simulate_conserves_energy(models):
    sim = modal.simulate(models / "double_pendulum.toml", duration=50, at=[2.0, 1.0], velocity=[0.0, 0.5],
                         interval=0.05)
    assert sim.time.shape == (1001,) and sim.q.shape == (1001, 2) and sim.qdot.shape == (1001, 2)
    assert sim.time[-1] == 50 and sim.conservative
    np.testing.assert_array_equal(sim.q[0], [2.0, 1.0])
    E = pendulum_energy(sim.q, sim.qdot)
    np.testing.assert_allclose(sim.energy, E, rtol=0, atol=1e-13 * abs(E[0]) + 1e-14)
    E0 = E[0]
    assert E0 == pytest.approx(0.5 * 0.5**2 - 2 * math.cos(2.0) - math.cos(3.0), rel=1e-14)
    assert np.max(np.abs(E - E0)) <= 1e-9 * max(abs(E0), 1.0)
    assert sim.max_energy_error <= 1e-9
    np.testing.assert_array_equal(sim.work, 0)
    # Chaotic: the motion moves far from the start.
    assert np.ptp(sim.q[:, 1]) > 2
    csv = sim.csv().splitlines()
    assert len(csv) == 1002


def test_amplitude_of_the_simple_pendulum():
    pendulum = {
        "title": "pendulum",
        "gravity": [0, 0, "-g"],
        "parameters": {"g": 9.81, "l": 0.5},
        "body": [{"name": "p", "joint": "hinge", "axis": [0, 1, 0], "mass": 1.0, "com": [0, 0, "-l"]}],
    }
    amplitudes = [0.1, 0.5, 1.0, 2.0]
    r = modal.amplitude(pendulum, amplitudes=amplitudes, cycles=2)
    omega0 = math.sqrt(9.81 / 0.5)
    assert r.omega_linear == pytest.approx(omega0, rel=1e-14)
    np.testing.assert_array_equal(r.amplitudes, amplitudes)
    # R8: T(θ₀) = T₀ · 2K(k²)/π with k = sin(θ₀/2) (scipy's ellipk takes m = k²).
    expected = np.pi / (2 * scipy.special.ellipk(np.sin(np.array(amplitudes) / 2) ** 2))
    np.testing.assert_allclose(r.omega / omega0, expected, rtol=1e-9)
    np.testing.assert_allclose(r.shift, expected - 1, atol=1e-9)
    assert r.oscillates.all() and len(r.thresholds) == 2
    one_percent = r.thresholds[0]
    assert one_percent["level"] == 0.01 and one_percent["reached"]
    # |ω/ω₀ − 1| = 1 % at the amplitude where π/(2K) = 0.99, from scipy.
    theta = scipy.optimize.brentq(lambda a: np.pi / (2 * scipy.special.ellipk(np.sin(a / 2) ** 2)) - 0.99, 0.1, 1.0)
    assert abs(one_percent["amplitude"] - theta) <= one_percent["error"] + 1e-6 * theta
    assert "pendulum" in r.text()


import scipy.optimize  # noqa: E402  (used above; scipy.optimize is not loaded by scipy.special)
