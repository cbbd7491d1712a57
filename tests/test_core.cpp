// The Lagrangian core against independent references:
//  - the tree-structured exact gradient and Hessian of V against nested
//    forward-mode AD through the whole templated potential (an independent path
//    through the same model) and against central differences;
//  - M(q) against Jᵀ𝕄J built from AD Jacobians of the body poses;
//  - R1 (REFERENCES.md) for the double pendulum;
//  - Ṁ − 2C skew-symmetric; energy conserved by a GSL rk8pd integration.
#include "modal/core.hpp"

#include "core/model.hpp"
#include "systems.hpp"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>
#include <gtest/gtest.h>

#include <numbers>
#include <random>

namespace {

using namespace modal;
using test::double_pendulum;

// hinge(name, parent, axis, origin, mass, com) in the order these tests write it.
Body hinge(const std::string& name, int parent, const Vec3& axis, const Vec3& origin, double mass, const Vec3& com) {
  return test::hinge(name, parent, origin, mass, com, axis);
}

// A 3-D tree with every joint type, inertias, springs between bodies and to the
// world, joint springs and dead loads: exercises every term of the derivatives.
System everything_tree() {
  SystemDescription d;
  d.gravity = Vec3(0.3, -0.2, -9.81);
  Body base = hinge("base", -1, Vec3(0.2, 1, 0.1), Vec3(0.1, 0, 0), 1.3, Vec3(0.2, 0.1, -0.8));
  base.inertia << 0.3, 0.01, 0.02, 0.01, 0.25, 0.03, 0.02, 0.03, 0.2;
  base.stiffness = 2.0;
  base.rest = VectorX::Constant(1, 0.1);
  d.bodies.push_back(base);
  Body ball;
  ball.name = "ball";
  ball.parent = 0;
  ball.joint = JointType::ball;
  ball.origin = Vec3(0.1, 0.2, -1.0);
  ball.mass = 0.7;
  ball.com = Vec3(0.05, -0.1, -0.6);
  ball.inertia = Vec3(0.05, 0.06, 0.02).asDiagonal();
  ball.stiffness = 0.8;
  ball.rest = Vec3(0.05, -0.02, 0.1);
  d.bodies.push_back(ball);
  Body slide;
  slide.name = "slider";
  slide.parent = 1;
  slide.joint = JointType::slide;
  slide.axis = Vec3(1, 0.3, -0.2).normalized();
  slide.origin = Vec3(0, 0, -0.7);
  slide.mass = 0.4;
  slide.com = Vec3(0.1, 0, 0);
  slide.stiffness = 5;
  d.bodies.push_back(slide);
  Body fixed;
  fixed.name = "bracket";
  fixed.parent = 2;
  fixed.joint = JointType::fixed;
  fixed.origin = Vec3(0.2, 0.1, 0);
  fixed.mass = 0.2;
  fixed.com = Vec3(0, 0.05, 0);
  fixed.inertia = Vec3(0.01, 0.02, 0.015).asDiagonal();
  d.bodies.push_back(fixed);
  Body tip = hinge("tip", 3, Vec3(0, 0.4, 1), Vec3(0, 0, -0.1), 0.3, Vec3(0.3, 0, -0.2));
  d.bodies.push_back(tip);
  Body flyer;
  flyer.name = "flyer";
  flyer.parent = 0;
  flyer.joint = JointType::free;
  flyer.origin = Vec3(0.5, 0, -0.5);
  flyer.mass = 0.9;
  flyer.com = Vec3(0.02, 0.01, -0.03);
  Mat3 I;
  I << 0.04, 0.002, 0.001, 0.002, 0.05, 0.003, 0.001, 0.003, 0.03;
  flyer.inertia = I;
  d.bodies.push_back(flyer);
  Spring s1;  // body to world, non-zero rest length
  s1.a = {4, Vec3(0.1, 0, -0.3)};
  s1.b = {-1, Vec3(1.0, 0.5, -2.0)};
  s1.stiffness = 30;
  s1.rest_length = 0.4;
  s1.damping = 0.3;
  Spring s2;  // between two bodies of different branches, zero rest length
  s2.a = {5, Vec3(0, 0.1, 0.1)};
  s2.b = {2, Vec3(0, 0, 0.05)};
  s2.stiffness = 12;
  Spring s3;  // flyer to world
  s3.a = {5, Vec3(0.05, -0.05, 0)};
  s3.b = {-1, Vec3(0.7, -0.2, -0.4)};
  s3.stiffness = 20;
  s3.rest_length = 0.1;
  d.springs = {s1, s2, s3};
  d.loads.push_back({{4, Vec3(0.2, 0.1, 0)}, Vec3(1.5, -0.5, 0.7)});
  d.loads.push_back({{5, Vec3(0, 0, 0.1)}, Vec3(-0.3, 0.2, 0.4)});
  return System(d);
}

VectorX random_state(const System& s, std::mt19937& rng, double spread) {
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
Oracle nested_ad(const System& s, const VectorX& q) {
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

double max_abs(const MatrixX& m) { return m.cwiseAbs().maxCoeff(); }

TEST(Core, CoordinateLayoutAndNames) {
  const System s = everything_tree();
  EXPECT_EQ(s.size(), 1 + 3 + 1 + 0 + 1 + 6);
  const auto names = s.coordinate_names();
  const std::vector<std::string> expected{"base", "ball.rx", "ball.ry", "ball.rz", "slider", "tip",
                                          "flyer.x", "flyer.y", "flyer.z", "flyer.rx", "flyer.ry", "flyer.rz"};
  EXPECT_EQ(names, expected);
}

TEST(Core, TreeStructuredDerivativesMatchNestedAD) {
  // Both are exact; they differ by rounding only (sums of O(n·depth) terms of
  // size ~ the largest entry), hence a 1e-12 relative tolerance.
  const System s = everything_tree();
  Workspace w(s);
  std::mt19937 rng(7);
  for (int trial = 0; trial < 5; ++trial) {
    const VectorX q = random_state(s, rng, trial == 0 ? 0.0 : 1.2);  // includes φ = 0 (series branch)
    const Oracle o = nested_ad(s, q);
    const VectorX& g = potential_gradient(s, w, q);
    EXPECT_LE((g - o.gradient).cwiseAbs().maxCoeff(), 1e-12 * max_abs(o.gradient)) << "trial " << trial;
    const MatrixX& H = potential_hessian(s, w, q);
    EXPECT_LE(max_abs(H - o.hessian), 1e-12 * max_abs(o.hessian)) << "trial " << trial << "\nH\n" << H << "\noracle\n" << o.hessian;
    EXPECT_LE(max_abs(H - H.transpose()), 1e-14 * max_abs(H));
  }
}

TEST(Core, DerivativesMatchCentralDifferences) {
  // Central differences with step h have truncation error O(h²·f''') and
  // rounding O(ε·f/h); h = 1e-5 gives ~1e-9 relative agreement at best, so the
  // tolerance is 1e-7 relative to the largest entry.
  const System s = everything_tree();
  Workspace w(s);
  std::mt19937 rng(11);
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

TEST(Core, MassMatrixMatchesJacobianTransposeInertiaJacobian) {
  // Independent construction: AD Jacobians of each body's centre of mass and of
  // its rotation (ω̂ = Ṙ Rᵀ), then M = Σ m J_vᵀJ_v + J_ωᵀ (R I Rᵀ) J_ω.
  const System s = everything_tree();
  Workspace w(s);
  std::mt19937 rng(3);
  const VectorX q = random_state(s, rng, 1.0);
  const int n = s.size();
  using D = Dual<double, 1>;
  std::vector<MatrixX> Jv(s.bodies().size(), MatrixX(3, n)), Jw(s.bodies().size(), MatrixX(3, n));
  model::TreeState<double> st0;
  model::forward_kinematics(s, q.data(), st0);
  for (int k = 0; k < n; ++k) {
    model::VX<D> qd(n);
    for (int i = 0; i < n; ++i) qd[i] = D(q[i]);
    qd[k].d[0] = 1.0;
    model::TreeState<D> st;
    model::forward_kinematics(s, qd.data(), st);
    for (std::size_t b = 0; b < s.bodies().size(); ++b) {
      const model::V3<D> x = st.position[b] + st.rotation[b] * model::cast3<D>(s.bodies()[b].com);
      Mat3 dR;
      for (int r = 0; r < 3; ++r) {
        Jv[b](r, k) = x[r].d[0];
        for (int c = 0; c < 3; ++c) dR(r, c) = st.rotation[b](r, c).d[0];
      }
      const Mat3 wh = dR * st0.rotation[b].transpose();
      Jw[b].col(k) = Vec3(wh(2, 1), wh(0, 2), wh(1, 0));
    }
  }
  MatrixX M_ref = MatrixX::Zero(n, n);
  for (std::size_t b = 0; b < s.bodies().size(); ++b) {
    const Body& body = s.bodies()[b];
    const Mat3 Iw = st0.rotation[b] * body.inertia * st0.rotation[b].transpose();
    M_ref += body.mass * Jv[b].transpose() * Jv[b] + Jw[b].transpose() * Iw * Jw[b];
  }
  const MatrixX& M = mass_matrix(s, w, q);
  EXPECT_LE(max_abs(M - M_ref), 1e-13 * max_abs(M_ref));
}

TEST(Core, DoublePendulumMatricesMatchR1) {
  // REFERENCES.md R1 gives M and K in absolute angles θ; joint angles are
  // relative, θ = T φ with T = [[1,0],[1,1]], so M_φ = TᵀMT and K_φ = TᵀKT.
  const double m1 = 2, m2 = 1, l1 = 1.5, l2 = 0.7, g = 9.81;
  const System s = double_pendulum(m1, m2, l1, l2, g);
  Workspace w(s);
  const VectorX q = VectorX::Zero(2);
  Eigen::Matrix2d Ma, Ka, T;
  Ma << (m1 + m2) * l1 * l1, m2 * l1 * l2, m2 * l1 * l2, m2 * l2 * l2;
  Ka << (m1 + m2) * g * l1, 0, 0, m2 * g * l2;
  T << 1, 0, 1, 1;
  EXPECT_LE(max_abs(mass_matrix(s, w, q) - T.transpose() * Ma * T), 1e-14 * max_abs(Ma));
  EXPECT_LE(max_abs(potential_hessian(s, w, q) - T.transpose() * Ka * T), 1e-14 * max_abs(Ka));
  EXPECT_LE(potential_gradient(s, w, q).norm(), 1e-14);
  // V = −Σ m g·x with g = (0, 0, −g): V = Σ m g z = −g (m1 l1 + m2 (l1 + l2)) at the bottom.
  EXPECT_NEAR(potential(s, w, q), -g * (m1 * l1 + m2 * (l1 + l2)), 1e-12);
}

TEST(Core, MassMatrixDerivativesMatchCentralDifferences) {
  const System s = everything_tree();
  Workspace w(s);
  std::mt19937 rng(5);
  const VectorX q = random_state(s, rng, 0.8);
  const auto dM = mass_matrix_derivatives(s, w, q);
  const double h = 1e-5;
  for (int k = 0; k < s.size(); ++k) {
    VectorX qp = q, qm = q;
    qp[k] += h;
    qm[k] -= h;
    const MatrixX fd = (MatrixX(mass_matrix(s, w, qp)) - MatrixX(mass_matrix(s, w, qm))) / (2 * h);
    EXPECT_LE(max_abs(dM[static_cast<std::size_t>(k)] - fd), 1e-7 * std::max(1.0, max_abs(fd))) << "k = " << k;
  }
}

TEST(Core, MdotMinusTwoCoriolisIsSkewSymmetric) {
  const System s = everything_tree();
  Workspace w(s);
  std::mt19937 rng(9);
  for (int trial = 0; trial < 4; ++trial) {
    const VectorX q = random_state(s, rng, 1.0), qd = random_state(s, rng, 2.0);
    const auto dM = mass_matrix_derivatives(s, w, q);
    MatrixX Mdot = MatrixX::Zero(s.size(), s.size());
    for (int k = 0; k < s.size(); ++k) Mdot += dM[static_cast<std::size_t>(k)] * qd[k];
    const MatrixX N = Mdot - 2 * coriolis(s, w, q, qd);
    EXPECT_LE(max_abs(N + N.transpose()), 1e-13 * max_abs(Mdot));
  }
}

TEST(Core, ChristoffelSymbolsAreSymmetricInLastTwoIndices) {
  const System s = everything_tree();
  Workspace w(s);
  std::mt19937 rng(13);
  const auto G = christoffel(s, w, random_state(s, rng, 1.0));
  for (const MatrixX& Gi : G) EXPECT_LE(max_abs(Gi - Gi.transpose()), 1e-14 * std::max(1.0, max_abs(Gi)));
}

// Integrates q̈ = M⁻¹(Q − Cq̇ − ∇V) with GSL's rk8pd (Prince–Dormand 8(9)).
struct Integration {
  const System* system;
  Workspace* ws;
};
int rhs(double, const double y[], double dydt[], void* p) {
  auto* in = static_cast<Integration*>(p);
  const int n = in->system->size();
  const VectorX q = Eigen::Map<const VectorX>(y, n), qd = Eigen::Map<const VectorX>(y + n, n);
  const VectorX qdd = accelerations(*in->system, *in->ws, q, qd);
  for (int i = 0; i < n; ++i) {
    dydt[i] = qd[i];
    dydt[n + i] = qdd[i];
  }
  return GSL_SUCCESS;
}

double energy_drift(const System& s, VectorX q, VectorX qd, double duration) {
  Workspace w(s);
  Integration in{&s, &w};
  const auto n = static_cast<std::size_t>(s.size());
  gsl_odeiv2_system sys{rhs, nullptr, 2 * n, &in};
  gsl_odeiv2_driver* drv = gsl_odeiv2_driver_alloc_y_new(&sys, gsl_odeiv2_step_rk8pd, 1e-3, 1e-13, 1e-13);
  std::vector<double> y(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    y[i] = q[static_cast<Eigen::Index>(i)];
    y[n + i] = qd[static_cast<Eigen::Index>(i)];
  }
  const double e0 = energy(s, w, q, qd);
  double t = 0, worst = 0;
  for (int step = 1; step <= 200; ++step) {
    const int status = gsl_odeiv2_driver_apply(drv, &t, duration * step / 200, y.data());
    EXPECT_EQ(status, GSL_SUCCESS);
    q = Eigen::Map<VectorX>(y.data(), s.size());
    qd = Eigen::Map<VectorX>(y.data() + n, s.size());
    worst = std::max(worst, std::abs(energy(s, w, q, qd) - e0));
  }
  gsl_odeiv2_driver_free(drv);
  // Relative to the energy that moves: kinetic plus potential above its minimum here.
  return worst / std::abs(e0);
}

TEST(Core, EnergyIsConservedOverTenPeriods) {
  // Double pendulum (R1, ω1 ≈ 0.765 with g = 1) at a large amplitude: 10
  // periods of the slow mode. Energy drift ≤ 1e-9 relative (the bound);
  // rk8pd at tolerance 1e-13 keeps it near 1e-12.
  const System s = double_pendulum(1, 1, 1, 1, 1);
  const double period = 2 * std::numbers::pi / 0.7653668647;
  const double drift = energy_drift(s, Eigen::Vector2d(1.0, -0.5), Eigen::Vector2d(0.2, 0.1), 10 * period);
  EXPECT_LE(drift, 1e-9);
}

TEST(Core, EnergyIsConservedForAThreeDimensionalTree) {
  SystemDescription d = [] {
    System s = everything_tree();
    SystemDescription dd;
    dd.gravity = s.gravity();
    dd.bodies = s.bodies();
    dd.springs = s.springs();
    for (auto& sp : dd.springs) sp.damping = 0;  // conservative
    dd.loads = s.loads();
    return dd;
  }();
  const System s(d);
  std::mt19937 rng(17);
  const double drift = energy_drift(s, random_state(s, rng, 0.3), random_state(s, rng, 0.5), 3.0);
  EXPECT_LE(drift, 1e-9);
}

TEST(Core, DampersDissipateAtTheRateQdotQ) {
  // dE/dt = Qᵀq̇ = −q̇ᵀDq̇ ≤ 0 (DESIGN.md §1).
  const System s = everything_tree();
  Workspace w(s);
  std::mt19937 rng(21);
  const VectorX q = random_state(s, rng, 0.7), qd = random_state(s, rng, 1.0);
  const MatrixX D = damping_matrix(s, w, q);
  EXPECT_LE(max_abs(D - D.transpose()), 1e-15);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<MatrixX>(D).eigenvalues().minCoeff(), -1e-14);
  EXPECT_NEAR(generalized_forces(s, w, q, qd).dot(qd), -qd.dot(D * qd), 1e-12);
  EXPECT_LT(-qd.dot(D * qd), 0.0);
}

// everything_tree() without joint springs: its hinge and ball coordinates are periodic.
System periodic_tree() {
  const System t = everything_tree();
  SystemDescription d;
  d.gravity = t.gravity();
  d.bodies = t.bodies();
  for (Body& b : d.bodies) b.stiffness = 0;
  d.springs = t.springs();
  d.loads = t.loads();
  return System(d);
}

TEST(Core, JointSpringsMakeCoordinatesNonPeriodic) {
  // V = ½k(θ − rest)² differs at θ and θ + 2π: such coordinates are not wrapped.
  const System s = everything_tree();
  EXPECT_FALSE(s.coordinates()[0].periodic);  // hinge with a spring
  EXPECT_FALSE(s.coordinates()[1].periodic);  // ball with a spring
  EXPECT_TRUE(s.coordinates()[5].periodic);   // hinge without one
  VectorX q = VectorX::Zero(s.size());
  q[0] = 5.0;
  EXPECT_EQ(canonical_coordinates(s, q)[0], 5.0);
  VectorX r = q;
  r[0] -= 2 * std::numbers::pi;
  EXPECT_NEAR(configuration_distance(s, q, r), 2 * std::numbers::pi, 1e-12);
}

TEST(Core, CanonicalCoordinatesWrapAnglesAndRotations) {
  const System s = periodic_tree();
  VectorX q = VectorX::Zero(s.size());
  q[0] = 3 * std::numbers::pi / 2;                // hinge → −π/2
  q.segment<3>(1) = Vec3(0, 0, 1.5 * std::numbers::pi);  // rotation of 3π/2 about z → −π/2 about z
  q[4] = 7.0;                                      // slide: unchanged
  const VectorX c = canonical_coordinates(s, q);
  EXPECT_NEAR(c[0], -std::numbers::pi / 2, 1e-15);
  EXPECT_NEAR(c[3], -std::numbers::pi / 2, 1e-15);
  EXPECT_EQ(c[4], 7.0);
  EXPECT_NEAR(configuration_distance(s, q, c), 0.0, 1e-12);
  VectorX r = c;
  r[0] += 0.1;
  EXPECT_NEAR(configuration_distance(s, q, r), 0.1, 1e-12);
}

}  // namespace
