"""modal.analyze(..., energy=True): the energy distribution and participation
through Python, against the double pendulum's closed form built here by hand
(not from modal's matrices), and the files Analysis.write adds."""

import csv
import math

import mpmath as mp
import numpy as np
import pytest

import modal


def closed_form(m1, m2, l1, l2, g):
    """Point masses on massless rods, hanging; coordinates: the upper rod's
    angle a and the lower rod's angle b relative to it. At the equilibrium both
    rods hang, so mass 1 moves l1·a' and mass 2 moves l1·a' + l2·(a' + b')
    horizontally; gravity's second variations are m1 g l1 a² and
    m2 g (l1 a² + l2 (a + b)²). Solved in 50-digit arithmetic (mpmath): in
    relative angles M is ill-conditioned for graded rods, and a double solve of
    these matrices (scipy's eigh) is itself off by 1e-9 relative at l1/l2 ≈ 40."""
    mp.mp.dps = 50
    m1, m2, l1, l2, g = (mp.mpf(float(x)) for x in (m1, m2, l1, l2, g))
    M = [[m1 * l1**2 + m2 * (l1 + l2)**2, m2 * l2 * (l1 + l2)], [m2 * l2 * (l1 + l2), m2 * l2**2]]
    K = [[g * (m1 * l1 + m2 * (l1 + l2)), g * m2 * l2], [g * m2 * l2, g * m2 * l2]]
    # det(K − λM) = A λ² + B λ + C.
    A = M[0][0] * M[1][1] - M[0][1]**2
    B = -(K[0][0] * M[1][1] + K[1][1] * M[0][0] - 2 * K[0][1] * M[0][1])
    C = K[0][0] * K[1][1] - K[0][1]**2
    root = mp.sqrt(B * B - 4 * A * C)
    lam, kinetic, potential, gamma, meff = [], [], [], [], []
    for lk in ((-B - root) / (2 * A), (-B + root) / (2 * A)):
        # φ from the first row of (K − λM) φ = 0.
        a, b = -(K[0][1] - lk * M[0][1]), K[0][0] - lk * M[0][0]
        t1, t2 = m1 * (l1 * a)**2, m2 * (l1 * a + l2 * (a + b))**2
        v1, v2 = m1 * g * l1 * a**2, m2 * g * (l1 * a**2 + l2 * (a + b)**2)
        # Base translation along x moves mass 1 by l1·a and mass 2 by l1·a + l2·(a + b).
        L = m1 * l1 * a + m2 * (l1 * a + l2 * (a + b))
        mass = t1 + t2  # φᵀMφ: the kinetic quadratic form itself
        lam.append(lk)
        kinetic.append([t1 / mass, t2 / mass])
        potential.append([v1 / (v1 + v2), v2 / (v1 + v2)])
        gamma.append(L / mp.sqrt(mass))  # Γ = φᵀL / φᵀMφ of the M-normalized shape φ/√(φᵀMφ)
        meff.append(L * L / mass)
    as_float = lambda x: np.array(x, dtype=float)  # noqa: E731
    return as_float(lam), as_float(kinetic), as_float(potential), as_float(gamma), as_float(meff)


@pytest.mark.parametrize("seed", range(5))
def test_double_pendulum_shares_match_the_closed_form(models, seed):
    rng = np.random.default_rng(seed)
    # Masses and lengths over two decades each: nothing special about the numbers.
    m1, m2, l1, l2 = 10 ** rng.uniform(-1, 1, 4)
    g = 9.81
    a = modal.analyze(models / "double_pendulum.toml", set={"m1": m1, "m2": m2, "l1": l1, "l2": l2, "g": g},
                      energy=True)
    e = a.energy
    assert isinstance(e, modal.EnergyDistribution) and e.split == "element"
    assert e.kinetic_elements == ["upper", "lower"]
    assert e.potential_elements == ["upper.gravity", "lower.gravity"]
    lam, kinetic, potential, gamma, meff = closed_form(m1, m2, l1, l2, g)
    # Against the 50-digit roots: within modal's own error estimate.
    assert np.all(np.abs(a.omega2 - lam) <= a.errors), (a.omega2, lam, a.errors)
    # Shares are ratios of quadratic forms of well-separated modes: rounding of
    # order 1e-15 relative, with room for the condition of the eigenvectors.
    np.testing.assert_allclose(e.kinetic, kinetic, rtol=1e-10, atol=1e-13)
    np.testing.assert_allclose(e.potential, potential, rtol=1e-10, atol=1e-13)
    np.testing.assert_allclose(e.kinetic.sum(axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(e.potential.sum(axis=1), 1.0, atol=1e-14)
    # Participation along x, of M-normalized shapes; Γ's sign follows the shape's, which is arbitrary.
    assert e.directions == ["x"]
    np.testing.assert_allclose(e.movable_mass, [m1 + m2], rtol=1e-14)
    np.testing.assert_allclose(e.effective_mass[:, 0], meff, rtol=1e-10)
    np.testing.assert_allclose(np.abs(e.participation_factor[:, 0]), np.abs(gamma), rtol=1e-10)
    # Point masses that a base translation carries along: all of the mass over both modes.
    np.testing.assert_allclose(e.cumulative_fraction[:, 0], np.cumsum(meff) / (m1 + m2), rtol=1e-10)
    assert e.cumulative_fraction[-1, 0] == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(e.kinetic_total, 1.0, rtol=1e-12)  # M-normalized shapes
    # φᵀKφ summed element by element, for M-normalized φ: ω², to the rounding
    # of evaluating that form from the relative-angle K and shapes returned
    # (measured up to 8e-15 relative; the estimate of ω², which its point-mass
    # chain's path makes a few ε, does not cover that evaluation).
    np.testing.assert_allclose(e.potential_total, [float(x) for x in lam], rtol=1e-13)


def test_energy_must_be_asked_for(models):
    a = modal.analyze(models / "double_pendulum.toml")
    with pytest.raises(modal.InputError, match="energy=True"):
        a.energy


def test_write_adds_the_energy_files(models, tmp_path):
    a = modal.analyze(models / "spring_chain.toml", energy=True)
    prefix = tmp_path / "chain"
    a.write(csv=str(prefix))
    with open(f"{prefix}_energy.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows and list(rows[0]) == ["mode", "kind", "element", "fraction"]
    e = a.energy
    for row in rows:
        k = int(row["mode"]) - 1
        names = e.kinetic_elements if row["kind"] == "kinetic" else e.potential_elements
        table = e.kinetic if row["kind"] == "kinetic" else e.potential
        assert float(row["fraction"]) == table[k, names.index(row["element"])]
    with open(f"{prefix}_participation.csv", newline="") as f:
        header = next(csv.reader(f))
    assert header == ["mode", "direction", "participation_factor", "effective_mass", "cumulative_fraction"]
    # Without energy=True, no energy files.
    b = modal.analyze(models / "spring_chain.toml")
    b.write(csv=str(tmp_path / "plain"))
    assert not (tmp_path / "plain_energy.csv").exists()
    assert math.isfinite(float(rows[0]["fraction"]))
