// lib/core/map.hpp — kinematic maps (expression-defined systems), written once,
// templated on the scalar (internal header of lib/core).
//
// A map system's energies come from its expressions x(z, t), R(z, t) and the
// potential Φ(z) (see modal/core.hpp, KinematicMap). Velocities are directional
// derivatives: S_k = ∂x/∂z_k and ∂ₜx are the derivative parts of x evaluated
// with one extra dual level seeded along z_k or t, so that M, g, T₀ are
// functions of z written for any scalar S and their own derivatives (∂M/∂q,
// ∂g/∂q, ∇∇V_eff) come from AD one or two levels further out.
#pragma once

#include "core/model.hpp"
#include "modal/ad.hpp"
#include "modal/core.hpp"

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <string>
#include <vector>

namespace modal::kmap {

using model::M3;
using model::MX;
using model::V3;
using model::VX;

// Where one map point is and how it is turned.
template <class S> struct PointPose {
  V3<S> x;
  M3<S> R;
};

// Rotation by `angle` about the unit `axis` (Rodrigues).
template <class S> M3<S> axis_rotation(const Vec3& axis, const S& angle) {
  using std::cos;
  using std::sin;
  const S c = cos(angle), s = sin(angle);
  M3<S> R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R(i, j) = (1.0 - c) * (axis[i] * axis[j]) + (i == j ? c : S(0.0));
  const V3<S> a = model::cast3<S>(axis) * s;
  R += model::hat<S>(a);
  return R;
}

// The variables of the expressions [z…, t, constants…] for kept coordinates q
// (size n) and time t; ignorable coordinates at their initial value, or at
// `shift` added to it (used to check that the energy does not depend on them).
template <class S>
std::vector<S> variables(const System& s, const S* q, const S& t, double shift = 0.0) {
  const KinematicMap& m = s.map();
  const std::size_t nz = m.coordinates.size();
  std::vector<S> v(nz + 1 + m.constants.size());
  for (const int c : s.ignorable_coordinates())
    v[static_cast<std::size_t>(c)] = S(m.coordinates[static_cast<std::size_t>(c)].initial + shift);
  const auto& kept = s.kept_coordinates();
  for (std::size_t k = 0; k < kept.size(); ++k) v[static_cast<std::size_t>(kept[k])] = q[k];
  v[nz] = t;
  for (std::size_t i = 0; i < m.constants.size(); ++i) v[nz + 1 + i] = S(m.constants[i]);
  return v;
}

template <class S> void poses(const KinematicMap& m, const std::vector<S>& vars, std::vector<PointPose<S>>& out) {
  out.resize(m.points.size());
  for (std::size_t i = 0; i < m.points.size(); ++i) {
    const MapMass& p = m.points[i];
    for (int c = 0; c < 3; ++c) out[i].x[c] = p.position[static_cast<std::size_t>(c)].template evaluate<S>(vars.data());
    out[i].R = M3<S>::Identity();
    if (p.inertia.isZero(0.0)) continue;
    for (const MapRotation& r : p.orientation) out[i].R = (out[i].R * axis_rotation<S>(r.axis, r.angle.template evaluate<S>(vars.data()))).eval();
  }
}

// V = Σ −m gravity·x + Φ (no centrifugal part), J.
template <class S> S plain_potential(const System& s, const std::vector<S>& vars, const std::vector<PointPose<S>>& at) {
  const KinematicMap& m = s.map();
  S V = m.potential.template evaluate<S>(vars.data());
  for (std::size_t i = 0; i < m.points.size(); ++i)
    V -= m.points[i].mass * (s.gravity().x() * at[i].x.x() + s.gravity().y() * at[i].x.y() + s.gravity().z() * at[i].x.z());
  return V;
}

// Velocity of every point (linear and angular, world) along direction `dir` of
// the variables (an index into vars: a coordinate z_k, or t).
template <class S> struct Velocity {
  std::vector<V3<S>> v, w;
};
template <class S> Velocity<S> velocity(const KinematicMap& m, const std::vector<S>& vars, std::size_t dir) {
  using D = Dual<S, 1>;
  std::vector<D> dv(vars.size());
  for (std::size_t i = 0; i < vars.size(); ++i) dv[i] = D(vars[i]);
  dv[dir].d[0] = S(1.0);
  std::vector<PointPose<D>> p;
  poses(m, dv, p);
  Velocity<S> out;
  out.v.resize(p.size());
  out.w.resize(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (int c = 0; c < 3; ++c) out.v[i][c] = p[i].x[c].d[0];
    if (m.points[i].inertia.isZero(0.0)) {
      out.w[i].setZero();
      continue;
    }
    M3<S> R, dR;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        R(a, b) = p[i].R(a, b).v;
        dR(a, b) = p[i].R(a, b).d[0];
      }
    const M3<S> W = dR * R.transpose();  // ω̂
    out.w[i] = V3<S>(0.5 * (W(2, 1) - W(1, 2)), 0.5 * (W(0, 2) - W(2, 0)), 0.5 * (W(1, 0) - W(0, 1)));
  }
  return out;
}

// Kinetic terms in all map coordinates z (n_z): M (n_z×n_z), g (n_z), T₀.
template <class S> struct Kinetic {
  MX<S> M;
  VX<S> g;
  S T0 = S(0.0);
};

template <class S>
Kinetic<S> kinetic(const System& s, const std::vector<S>& vars, const std::vector<PointPose<S>>& at, bool moving) {
  const KinematicMap& m = s.map();
  const std::size_t nz = m.coordinates.size(), np = m.points.size();
  std::vector<Velocity<S>> col(nz + (moving ? 1 : 0));
  for (std::size_t k = 0; k < col.size(); ++k) col[k] = velocity(m, vars, k);  // k = nz: ∂/∂t
  std::vector<M3<S>> Iw(np);
  for (std::size_t i = 0; i < np; ++i)
    if (!m.points[i].inertia.isZero(0.0)) Iw[i] = at[i].R * model::cast33<S>(m.points[i].inertia) * at[i].R.transpose();
  auto product = [&](const Velocity<S>& a, const Velocity<S>& b) {
    S r(0.0);
    for (std::size_t i = 0; i < np; ++i) {
      r += m.points[i].mass * a.v[i].dot(b.v[i]);
      if (!m.points[i].inertia.isZero(0.0)) r += a.w[i].dot(Iw[i] * b.w[i]);
    }
    return r;
  };
  Kinetic<S> k;
  const auto n = static_cast<Eigen::Index>(nz);
  k.M.resize(n, n);
  k.g = VX<S>::Zero(n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j <= i; ++j) k.M(i, j) = k.M(j, i) = product(col[static_cast<std::size_t>(i)], col[static_cast<std::size_t>(j)]);
  if (moving) {
    for (Eigen::Index i = 0; i < n; ++i) k.g[i] = product(col[static_cast<std::size_t>(i)], col[nz]);
    k.T0 = 0.5 * product(col[nz], col[nz]);
  }
  return k;
}

// Solves A X = B for a small symmetric positive definite A (LDLᵀ without
// pivoting, any scalar). Throws NumericalError when A is not positive definite.
inline std::string short_number(double x, int digits = 3) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, x);
  return buffer;
}

// `scale`: the size of the whole mass matrix A is a block of; a pivot below
// 1e-13 of it counts as zero.
template <class S> MX<S> solve_spd(MX<S> A, MX<S> B, double scale) {
  const Eigen::Index n = A.rows();
  for (Eigen::Index j = 0; j < n; ++j) {
    if (!(value(A(j, j)) > 1e-13 * scale))
      throw NumericalError(
          "the mass matrix is singular here: the block of the ignorable coordinates is not positive definite "
          "(pivot " + short_number(value(A(j, j))) + " against a mass scale " + short_number(scale) +
          "), as at a pole of spherical angles, where the coordinates themselves degenerate. Routh's reduction "
          "and the steady motion's momentum are undefined there: write the system in coordinates that are "
          "regular at this configuration");
    for (Eigen::Index i = j + 1; i < n; ++i) {
      const S f = A(i, j) / A(j, j);
      for (Eigen::Index c = j; c < n; ++c) A(i, c) -= f * A(j, c);
      for (Eigen::Index c = 0; c < B.cols(); ++c) B(i, c) -= f * B(j, c);
    }
  }
  for (Eigen::Index j = n - 1; j >= 0; --j)
    for (Eigen::Index c = 0; c < B.cols(); ++c) {
      S r = B(j, c);
      for (Eigen::Index k = j + 1; k < n; ++k) r -= A(j, k) * B(k, c);
      B(j, c) = r / A(j, j);
    }
  return B;
}

// The reduced system in the kept coordinates q (n): M', g', V' (modal/core.hpp,
// KinematicMap) at t = 0. Parts not asked for are left empty (V: 0).
template <class S> struct Reduced {
  MX<S> M;
  VX<S> g;
  S V = S(0.0);
};

template <class S> Reduced<S> reduced(const System& s, const S* q, bool want_M, bool want_g, bool want_V) {
  const KinematicMap& m = s.map();
  const std::vector<S> vars = variables<S>(s, q, S(0.0));
  std::vector<PointPose<S>> at;
  poses(m, vars, at);
  Reduced<S> out;
  if (want_V) out.V = plain_potential(s, vars, at);
  const bool moving = s.has_frame_coupling();
  if (!want_M && !want_g && !(want_V && moving)) return out;
  const bool time = !m.coordinates.empty() && s.map_time_dependent();
  const Kinetic<S> k = kinetic(s, vars, at, time);
  if (want_V) out.V -= k.T0;
  const auto& r = s.kept_coordinates();
  const auto& c = s.ignorable_coordinates();
  if (c.empty()) {
    if (want_M) out.M = k.M;
    if (want_g) out.g = k.g;
    return out;
  }
  const auto nr = static_cast<Eigen::Index>(r.size()), nc = static_cast<Eigen::Index>(c.size());
  MX<S> Mrr(nr, nr), Mrc(nr, nc), Mcc(nc, nc);
  VX<S> gr(nr), gc(nc);
  auto at_ = [](const std::vector<int>& idx, Eigen::Index i) { return static_cast<Eigen::Index>(idx[static_cast<std::size_t>(i)]); };
  for (Eigen::Index i = 0; i < nr; ++i) {
    gr[i] = k.g[at_(r, i)];
    for (Eigen::Index j = 0; j < nr; ++j) Mrr(i, j) = k.M(at_(r, i), at_(r, j));
    for (Eigen::Index j = 0; j < nc; ++j) Mrc(i, j) = k.M(at_(r, i), at_(c, j));
  }
  for (Eigen::Index i = 0; i < nc; ++i) {
    gc[i] = k.g[at_(c, i)];
    for (Eigen::Index j = 0; j < nc; ++j) Mcc(i, j) = k.M(at_(c, i), at_(c, j));
  }
  VX<S> given(nc);
  for (Eigen::Index i = 0; i < nc; ++i) given[i] = S(m.coordinates[static_cast<std::size_t>(at_(c, i))].ignorable->value);
  const bool by_rate = m.coordinates[static_cast<std::size_t>(c.front())].ignorable->given == Ignorable::Given::rate;
  if (by_rate) {
    // The coordinate driven at the given rate Ω: T evaluated with ċ = Ω.
    if (want_M) out.M = Mrr;
    if (want_g) out.g = gr + Mrc * given;
    if (want_V) out.V -= given.dot(gc) + 0.5 * given.dot(Mcc * given);
    return out;
  }
  // Routh's reduction at the given momenta p.
  const VX<S> excess = given - gc;  // p − g_c
  MX<S> rhs(nc, 1 + (want_M ? nr : 0));
  rhs.col(0) = excess;
  if (want_M) rhs.rightCols(nr) = Mrc.transpose();
  double scale = 0;
  for (Eigen::Index i = 0; i < k.M.rows(); ++i) scale = std::max(scale, std::abs(value(k.M(i, i))));
  const MX<S> sol = solve_spd<S>(Mcc, rhs, scale);  // [M_cc⁻¹(p − g_c), M_cc⁻¹M_cr]
  if (want_M) out.M = Mrr - Mrc * sol.rightCols(nr);
  if (want_g) out.g = gr + Mrc * sol.col(0);
  if (want_V) out.V += 0.5 * excess.dot(sol.col(0));
  return out;
}

}  // namespace modal::kmap
