#!/usr/bin/env python3
"""Peer for bench/map_linearize.sh: SymPy mechanics linearizes the spherical
pendulum in spherical angles (the scene models/spherical_pendulum_angles.toml)
about its conical motion, the way a SymPy user would: Lagrange's equations from
the particle's position, then LagrangesMethod.linearize at the operating point
(phi0, theta' = w), then the eigenvalues of the numeric A matrix.

Prints the wall time of each step (s) and the nutation frequency it finds, so
that the comparison also checks that both tools solve the same problem.
"""
import math
import sys
import time

import sympy as sp
from sympy.physics.mechanics import (LagrangesMethod, Lagrangian, Particle, Point, ReferenceFrame,
                                     dynamicsymbols)

t_start = time.perf_counter()
m, r, g, w = sp.symbols("m r g w", positive=True)
phi, theta = dynamicsymbols("phi theta")
phid, thetad = dynamicsymbols("phi theta", 1)
N = ReferenceFrame("N")
O = Point("O")
O.set_vel(N, 0)
P = O.locatenew("P", r * sp.cos(theta) * sp.sin(phi) * N.x + r * sp.sin(theta) * sp.sin(phi) * N.y
                + r * sp.cos(phi) * N.z)
P.set_vel(N, P.pos_from(O).dt(N))
bob = Particle("bob", P, m)
bob.potential_energy = m * g * r * sp.cos(phi)
lm = LagrangesMethod(Lagrangian(N, bob), [phi, theta])
lm.form_lagranges_equations()
t_equations = time.perf_counter()

values = {m: 1.0, r: 1.0, g: 9.81, w: 5.0}
phi0 = math.pi - math.acos(values[g] / (values[r] * values[w] ** 2))
op = {phi: phi0, theta: 0, phid: 0, thetad: values[w], phid.diff(): 0, thetad.diff(): 0}
A, _, _ = lm.linearize(q_ind=[phi, theta], qd_ind=[phid, thetad], A_and_B=True, op_point=op)
A = A.subs(values)
t_linearize = time.perf_counter()

eigen = sp.Matrix(A).evalf().eigenvals()
omega = max(abs(complex(s).imag) for s in eigen)
t_end = time.perf_counter()

print(f"sympy {sp.__version__}, python {sys.version.split()[0]}")
print(f"equations   {t_equations - t_start:.4f} s")
print(f"linearize   {t_linearize - t_equations:.4f} s")
print(f"eigenvalues {t_end - t_linearize:.4f} s")
print(f"total       {t_end - t_start:.4f} s")
print(f"omega       {omega:.10f} rad/s   (closed form w*sqrt(1 + 3 cos^2 a0) = "
      f"{values[w] * math.sqrt(1 + 3 * (values[g] / (values[r] * values[w] ** 2)) ** 2):.10f})")
