"""modal.analyze on the dense path, checked against numpy/scipy themselves:
the returned M, K (D, G) are solved again with scipy and must give the
returned eigenvalues to within the returned error estimates."""

import json
import math
import subprocess

import numpy as np
import pytest
import scipy.linalg

import modal

EPS = np.finfo(float).eps


def test_double_pendulum_closed_form(models):
    a = modal.analyze(models / "double_pendulum.toml")
    # R1: ω² = 2 ∓ √2 for unit masses, lengths and gravity.
    expected = np.array([2 - math.sqrt(2), 2 + math.sqrt(2)])
    assert a.omega2.shape == (2,)
    assert np.all(np.abs(a.omega2 - expected) <= a.errors + 4 * EPS * expected)
    assert np.allclose(a.omega, np.sqrt(expected), rtol=1e-14)
    assert a.stability == "stable"
    assert a.morse_index == 0 and a.zero_modes == 0
    assert a.kinds == ["oscillatory", "oscillatory"]
    assert a.coordinates == ["upper", "lower"]
    np.testing.assert_array_equal(a.q, [0.0, 0.0])
    assert a.potential == pytest.approx(-3.0, abs=1e-15)
    assert not a.sparse and a.symmetric


def test_eigh_of_returned_matrices_gives_omega2(models):
    # Heavier second mass, longer rods: nothing special about the numbers.
    a = modal.analyze(models / "double_pendulum.toml", set={"m2": 2.5, "l2": "1.7*l1", "g": 9.81})
    M, K = a.M, a.K
    assert isinstance(M, np.ndarray) and M.shape == (2, 2)
    np.testing.assert_array_equal(M, M.T)
    np.testing.assert_array_equal(K, K.T)
    lam = scipy.linalg.eigh(K, M, eigvals_only=True)
    ulps = 8 * EPS * np.abs(lam).max()
    assert np.all(np.abs(lam - a.omega2) <= a.errors + ulps), (lam, a.omega2, a.errors)
    # The residual bound is rigorous for the pencil modal solved. For this
    # chain of point masses that pencil is formed in absolute angles
    # (docs/design.md, "Point-mass chains"), not from the relative-angle M
    # and K returned, whose eigenvalues may differ from it by the two
    # formations' rounding (the estimate covers that, above); a scene solved
    # in its own coordinates (particles on slides) tests the bound below.
    assert np.all(np.isfinite(a.bounds)) and np.all(a.bounds > 0)
    np.testing.assert_array_equal(a.D, np.zeros((2, 2)))
    np.testing.assert_array_equal(a.G, np.zeros((2, 2)))


def test_residual_bounds_hold_for_the_returned_matrices_where_they_are_the_pencil_solved(models):
    # Masses on slides joined by springs: M and K returned are the pencil
    # solved (no change of coordinates), so eigh's eigenvalues of them lie
    # within each bound, up to eigh's own rounding (a few units of the
    # largest eigenvalue). Masses and stiffnesses unequal: nothing special.
    a = modal.analyze(models / "spring_chain.toml", set={"m": 2.5, "k": 0.7})
    lam = scipy.linalg.eigh(a.K, a.M, eigvals_only=True)
    ulps = 8 * EPS * np.abs(lam).max()
    assert np.all(np.abs(lam - a.omega2) <= a.bounds + ulps), (lam, a.omega2, a.bounds)
    assert np.all(np.abs(lam - a.omega2) <= a.errors + ulps), (lam, a.omega2, a.errors)


def test_shapes_are_m_orthonormal_eigenvectors(models):
    a = modal.analyze(models / "lattice.toml", solver="dense", modes=12)
    Phi, M, K = a.shapes, a.M, a.K
    n = M.shape[0]
    assert Phi.shape == (n, 12) and Phi.dtype == np.float64
    np.testing.assert_allclose(Phi.T @ M @ Phi, np.eye(12), atol=1e-10)
    residual = K @ Phi - M @ Phi * a.omega2
    # ‖r‖_{M⁻¹} ≤ the residual bound reported (slack for the rounding of this check).
    Minv_r = scipy.linalg.cho_solve(scipy.linalg.cho_factor(M), residual)
    norms = np.sqrt(np.einsum("ij,ij->j", residual, Minv_r))
    assert np.all(norms <= a.bounds * (1 + 1e-6) + 64 * EPS * np.abs(a.omega2))
    # The lowest 12 of scipy's complete solution.
    lam = scipy.linalg.eigh(K, M, eigvals_only=True, subset_by_index=[0, 11])
    assert np.all(np.abs(lam - a.omega2) <= a.errors + 64 * EPS * np.abs(lam).max())


def test_dense_solvers_agree(models):
    e = modal.analyze(models / "lattice.toml", dense_solver="eigen", modes=5)
    l = modal.analyze(models / "lattice.toml", dense_solver="lapack", modes=5)
    assert "Eigen" in e.solver and "LAPACK" in l.solver
    assert np.all(np.abs(e.omega2 - l.omega2) <= e.errors + l.errors)


def test_differences_are_within_their_estimates(models):
    exact = modal.analyze(models / "double_pendulum.toml")
    central = modal.analyze(models / "double_pendulum.toml", derivatives="central")
    assert np.all(np.abs(central.omega2 - exact.omega2) <= central.errors + exact.errors)
    assert central.errors.min() > exact.errors.min()  # differences cost accuracy, and say so
    assert any("central differences" in n for n in central.notes)
    assert central.K_error is not None and central.K_error.shape == (2, 2)


def test_first_order_problem_against_scipy_eig(models):
    # Damped follower column: K not symmetric, D ≠ 0; s from the 2n state matrix.
    a = modal.analyze(models / "ziegler_damped.toml")
    M, K, D, G = a.M, a.K, a.D, a.G
    n = M.shape[0]
    assert not a.symmetric and np.all(np.isnan(a.omega2))
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ (D + G)]])
    s = scipy.linalg.eigvals(A)
    upper = np.sort_complex(s[s.imag >= 0])
    for sk, err in zip(a.s, a.errors):
        assert np.min(np.abs(upper - sk)) <= err + 1e-12 * abs(sk)
    assert a.shapes.dtype == np.complex128 and a.shapes.shape == (n, n)
    for k, sk in enumerate(a.s):
        phi = a.shapes[:, k]
        r = (sk**2 * M + sk * (D + G) + K) @ phi
        assert np.linalg.norm(r) <= 1e-10 * np.linalg.norm(K) * np.linalg.norm(phi)
    np.testing.assert_allclose(a.growth_rate, a.s.real)
    assert a.stability == "asymptotically stable"


def test_gyroscopic_top(models):
    a = modal.analyze(models / "spinning_top.toml")
    G = a.G
    np.testing.assert_allclose(G, -G.T, atol=1e-14 * np.abs(G).max())
    assert np.abs(G).max() > 0
    n = a.M.shape[0]
    Minv = np.linalg.inv(a.M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ a.K, -Minv @ (a.D + G)]])
    s = scipy.linalg.eigvals(A)
    for sk, err in zip(a.s, a.errors):
        assert np.min(np.abs(s - sk)) <= err + 1e-12 * abs(sk)


def test_constrained_model_is_the_projection(models):
    a = modal.analyze(models / "closed_chain.toml")
    N = a.basis
    n, r = N.shape
    assert a.M.shape == (r, r) and a.shapes.shape[0] == n
    np.testing.assert_allclose(N.T @ N, np.eye(r), atol=1e-12)
    lam = scipy.linalg.eigh(a.K, a.M, eigvals_only=True)
    assert np.all(np.abs(lam - a.omega2) <= a.errors + 16 * EPS * np.abs(lam).max())


def test_modes_and_at(models):
    a = modal.analyze(models / "double_pendulum.toml", modes=1)
    assert a.omega2.shape == (1,) and a.shapes.shape == (2, 1)
    # The inverted equilibrium (upper rod up, lower rod down), given with at.
    b = modal.analyze(models / "double_pendulum.toml", at=[math.pi, math.pi])
    assert b.stability == "divergence" and b.morse_index == 1
    lam = scipy.linalg.eigh(b.K, b.M, eigvals_only=True)
    assert np.all(np.abs(lam - b.omega2) <= b.errors + 16 * EPS * np.abs(lam).max())
    assert "divergent" in b.kinds


def test_text_json_and_files(models, tmp_path):
    a = modal.analyze(models / "double_pendulum.toml")
    text = a.text()
    assert text.startswith("Planar double pendulum (point masses)\n")
    assert "Stability: " + a.stability_description in text
    doc = json.loads(a.json())
    assert doc["stability"] == a.stability and doc["stability_description"] == a.stability_description
    assert [m["omega2"] for m in doc["modes"]] == list(a.omega2)
    a.write(csv=str(tmp_path / "dp"), json=str(tmp_path / "dp.json"))
    modes = np.genfromtxt(tmp_path / "dp_modes.csv", delimiter=",", names=True)
    np.testing.assert_array_equal(modes["omega2"], a.omega2)  # %.17g: exact round trip
    assert json.loads((tmp_path / "dp.json").read_text()) == doc
    a.write(matrices=str(tmp_path / "mm"))
    import scipy.io
    K = scipy.io.mmread(str(tmp_path / "mm" / "K.mtx"))
    np.testing.assert_array_equal(np.asarray(K.todense() if hasattr(K, "todense") else K), a.K)


def test_text_is_what_the_command_prints(models, cli):
    path = str(models / "double_pendulum.toml")
    a = modal.analyze(path, set={"m2": 2})
    out = subprocess.run([cli, "analyze", path, "--set", "m2=2"], capture_output=True, text=True, check=True)
    assert a.text() == out.stdout


def test_timings_and_repr(models):
    a = modal.analyze(models / "double_pendulum.toml")
    assert list(a.timings) == ["equilibrium", "linearize", "eigen"]
    assert all(t >= 0 for t in a.timings.values())
    assert "stable" in repr(a)


def test_arrays_are_copies(models):
    a = modal.analyze(models / "double_pendulum.toml")
    w = a.omega2
    w[0] = 99
    assert a.omega2[0] != 99
