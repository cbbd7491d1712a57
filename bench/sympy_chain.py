#!/usr/bin/env python3
"""Peer for bench/startup.py: SymPy mechanics linearizes the hanging chain of
N point-mass links (models/hanging_chain.toml, L = M = 1, g = 9.81) about its
hanging equilibrium the way a SymPy user would (Lagrange's equations from the
particles' positions, LagrangesMethod.linearize), then the eigenvalues of the
numeric M⁻¹K. Prints the wall time (s) and the lowest ω², which bench/startup.py
compares with modal's and with the Laguerre closed form.

Usage: sympy_chain.py N
"""
import sys
import time

import numpy as np
import sympy as sp
from sympy.physics.mechanics import LagrangesMethod, Lagrangian, Particle, Point, ReferenceFrame, dynamicsymbols

start = time.perf_counter()
n = int(sys.argv[1])
a, m, g = 1.0 / n, 1.0 / n, 9.81
q = dynamicsymbols(f"q0:{n}")
qd = [qi.diff() for qi in q]
N = ReferenceFrame("N")
O = Point("O")
O.set_vel(N, 0)
particles, previous = [], O
for i in range(n):
    P = previous.locatenew(f"P{i}", a * sp.sin(q[i]) * N.x - a * sp.cos(q[i]) * N.z)
    P.set_vel(N, P.pos_from(O).dt(N))
    p = Particle(f"p{i}", P, m)
    p.potential_energy = m * g * P.pos_from(O).dot(N.z)
    particles.append(p)
    previous = P
lm = LagrangesMethod(Lagrangian(N, *particles), q)
lm.form_lagranges_equations()
op = {qi: 0 for qi in q}
op.update({qi: 0 for qi in qd})
op.update({qi.diff(): 0 for qi in qd})
Ml, Al, _, _ = lm.linearize(q_ind=q, qd_ind=qd, A_and_B=False, op_point=op)
Ml = np.array(sp.Matrix(Ml).subs(op).evalf(), dtype=float)
Al = np.array(sp.Matrix(Al).subs(op).evalf(), dtype=float)
A = np.linalg.solve(Ml, Al)  # [q'; u'] = A [q; u]
omega2 = np.sort(-np.linalg.eigvals(A[n:, :n]).real)
print(f"{time.perf_counter() - start:.3f} {omega2[0]:.12g}")
