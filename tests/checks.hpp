// Independent references shared by the tests of the core: nested forward AD
// through the templated potential, AD Jacobians of the bodies, and the energy
// drift of a modal::simulate integration of the equations of motion.
#pragma once

#include "modal/core.hpp"
#include "modal/simulate.hpp"

#include "core/model.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace modal::test {

inline double max_abs(const MatrixX& m) { return m.cwiseAbs().maxCoeff(); }

inline VectorX random_state(const System& s, std::mt19937& rng, double spread) {
  std::uniform_real_distribution<double> u(-spread, spread);
  VectorX q(s.size());
  for (int i = 0; i < s.size(); ++i) q[i] = u(rng);
  return q;
}

// Oracle: V, ∇V, ∇∇V by nested forward AD through the whole templated potential,
// one pair of directions at a time (no tree structure used).
struct Oracle {
  VectorX gradient;
  MatrixX hessian;
};
inline Oracle nested_ad(const System& s, const VectorX& q) {
  using D = Dual<Dual<double, 1>, 1>;
  const int n = s.size();
  Oracle o{VectorX(n), MatrixX(n, n)};
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      model::VX<D> qd(n);
      for (int k = 0; k < n; ++k) {
        qd[k] = D(Dual<double, 1>(q[k]));
        if (k == i) qd[k].v.d[0] = 1.0;
        if (k == j) qd[k].d[0].v = 1.0;
      }
      model::TreeState<D> st;
      model::forward_kinematics(s, qd.data(), st);
      const D v = model::potential(s, st, qd.data());
      o.hessian(i, j) = v.d[0].d[0];
      if (j == 0) o.gradient[i] = v.v.d[0];
    }
  return o;
}

// Per body, AD Jacobians of the centre of mass (J_v, 3×n) and of the rotation
// (J_ω, 3×n, from ω̂ = Ṙ Rᵀ), with the kinematics at q.
struct BodyJacobians {
  model::TreeState<double> st;
  std::vector<MatrixX> Jv, Jw;
  std::vector<Vec3> com;  // world centre of mass per body
};
inline BodyJacobians body_jacobians(const System& s, const VectorX& q) {
  const int n = s.size();
  const std::size_t nb = s.bodies().size();
  using D = Dual<double, 1>;
  BodyJacobians J;
  J.Jv.assign(nb, MatrixX(3, n));
  J.Jw.assign(nb, MatrixX(3, n));
  model::forward_kinematics(s, q.data(), J.st);
  for (std::size_t b = 0; b < nb; ++b) J.com.push_back(J.st.position[b] + J.st.rotation[b] * s.bodies()[b].com);
  for (int k = 0; k < n; ++k) {
    model::VX<D> qd(n);
    for (int i = 0; i < n; ++i) qd[i] = D(q[i]);
    qd[k].d[0] = 1.0;
    model::TreeState<D> st;
    model::forward_kinematics(s, qd.data(), st);
    for (std::size_t b = 0; b < nb; ++b) {
      const model::V3<D> x = st.position[b] + st.rotation[b] * model::cast3<D>(s.bodies()[b].com);
      Mat3 dR;
      for (int r = 0; r < 3; ++r) {
        J.Jv[b](r, k) = x[r].d[0];
        for (int c = 0; c < 3; ++c) dR(r, c) = st.rotation[b](r, c).d[0];
      }
      const Mat3 wh = dR * J.st.rotation[b].transpose();
      J.Jw[b].col(k) = Vec3(wh(2, 1), wh(0, 2), wh(1, 0));
    }
  }
  return J;
}

// Integrates the equations of motion with modal::simulate (GSL rk8pd) at
// tolerance 1e-13 over `duration`, and returns the largest |energy − E₀| / |E₀|
// seen at 200 evenly spaced times (energy(): T + V, or the Jacobi integral
// ½q̇ᵀMq̇ + V − T₀ in a rotating frame).
inline double energy_drift(const System& s, const VectorX& q, const VectorX& qd, double duration) {
  SimulationOptions o;
  o.duration = duration;
  o.interval = duration / 200;
  o.tolerance = 1e-13;
  const Trajectory tr = simulate(s, q, qd, o);
  double worst = 0;
  for (const double e : tr.energy) worst = std::max(worst, std::abs(e - tr.energy.front()));
  return worst / std::abs(tr.energy.front());
}

// ∇V and ∇∇V against central differences at a random state. Step h = 1e-5:
// truncation O(h²·f‴) and rounding O(ε·f/h) leave ~1e-9 relative agreement at
// best, so the tolerance is 1e-7 relative to the largest entry, far below the
// order-1 error of any missing term.
inline void expect_derivatives_match_central_differences(const System& s, unsigned seed) {
  Workspace w(s);
  std::mt19937 rng(seed);
  const VectorX q = random_state(s, rng, 0.9);
  const double h = 1e-5;
  const VectorX g = potential_gradient(s, w, q);
  const MatrixX H = potential_hessian(s, w, q);
  VectorX g_fd(s.size());
  MatrixX H_fd(s.size(), s.size());
  for (int k = 0; k < s.size(); ++k) {
    VectorX qp = q, qm = q;
    qp[k] += h;
    qm[k] -= h;
    g_fd[k] = (potential(s, w, qp) - potential(s, w, qm)) / (2 * h);
    const VectorX gp = potential_gradient(s, w, qp);  // copies: the workspace result is overwritten
    const VectorX gm = potential_gradient(s, w, qm);
    H_fd.col(k) = (gp - gm) / (2 * h);
  }
  EXPECT_LE((g - g_fd).cwiseAbs().maxCoeff(), 1e-7 * g.cwiseAbs().maxCoeff());
  EXPECT_LE(max_abs(H - H_fd), 1e-7 * max_abs(H));
}

}  // namespace modal::test
