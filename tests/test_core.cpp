// The Lagrangian core against independent references:
//  - the tree-structured exact gradient and Hessian of V against nested
//    forward-mode AD through the whole templated potential (an independent path
//    through the same model) and against central differences;
//  - M(q) against Jᵀ𝕄J built from AD Jacobians of the body poses;
//  - R1 (docs/design.md, section 2) for the double pendulum;
//  - Ṁ − 2C skew-symmetric; energy conserved by a GSL rk8pd integration.
#include "modal/core.hpp"
#include "modal/scene.hpp"

#include "core/model.hpp"
#include "checks.hpp"
#include "systems.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <numbers>
#include <random>
#include <string>
#include <tuple>
#include <vector>

namespace {

using namespace modal;
using test::double_pendulum;

using test::everything_tree;
using test::energy_drift;
using test::max_abs;
using test::nested_ad;
using test::Oracle;
using test::random_state;

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

// The sparse ∇∇V (large equilibria, sparse modes) against the nested-AD
// oracle, on generated scenes: lattice nets of random size, slack (springs
// at rest length) or pre-tensioned, at random sagged configurations, and the
// everything tree (hinges, balls, slides, a free body, springs and
// dampers). The first call in a workspace builds the pattern (counting pass,
// column by column); later calls add in place (runs down a column); both
// are checked, at different q, and the pattern must hold every entry of the
// oracle that is not zero. Tolerance as above.
TEST(Core, SparseHessianMatchesNestedADOnFirstAndLaterAssemblies) {
  std::mt19937 rng(1126);
  auto check = [](const System& s, Workspace& w, const VectorX& q, const std::string& what) {
    const Oracle o = nested_ad(s, q);
    const MatrixX H = MatrixX(sparse_potential_hessian(s, w, q));
    EXPECT_LE(max_abs(H - o.hessian), 1e-12 * max_abs(o.hessian)) << what;
  };
  for (int trial = 0; trial < 8; ++trial) {
    const int a = std::uniform_int_distribution<int>(3, 6)(rng), b = std::uniform_int_distribution<int>(3, 6)(rng);
    const double prestrain = trial % 2 == 0 ? 0.0 : 0.03;
    const std::string text = "gravity = [0, 0, -9.81]\n[[lattice]]\nname = \"n\"\nsize = [" + std::to_string(a) +
                             ", " + std::to_string(b) + ", 1]\nspacing = 0.1\nmass = 0.002\nstiffness = 1000\n"
                             "prestrain = " + std::to_string(prestrain) + "\nfixed = \"boundary\"\n";
    const System s = build_system(parse_scene(text, "net.toml"));
    Workspace w(s);
    std::uniform_real_distribution<double> u(-0.02, 0.02);
    for (int call = 0; call < 3; ++call) {
      VectorX q(s.size());
      for (int i = 0; i < s.size(); ++i) q[i] = u(rng) - (i % 3 == 2 ? 0.03 * call : 0.0);
      check(s, w, q, "net " + std::to_string(a) + "×" + std::to_string(b) + " prestrain " + std::to_string(prestrain) +
                         " call " + std::to_string(call));
    }
  }
  const System s = everything_tree();
  Workspace w(s);
  for (int call = 0; call < 3; ++call) check(s, w, random_state(s, rng, 1.2), "everything tree call " + std::to_string(call));
}

// Large scenes' elements are evaluated in two parts on two threads (from
// 16384 springs on, lib/core/derivatives.cpp, element_parts). ∇V and the
// sparse ∇∇V of slack and pre-tensioned particle nets on both sides of that
// threshold against the closed form of their springs and weights (V =
// ½k(L − L0)² − Σ m g·x: per spring ∂V/∂x_a = k(L − L0)u, ∂²V/∂x_a² =
// k[uuᵀ + (1 − L0/L)(I − uuᵀ)]), at random sagged configurations, on the
// first assembly (the pattern) and in place. The same q twice gives the same
// bits: the parts' sums are added in a fixed order whatever the timing.
// The same for sparse_convex_potential_hessian, whose springs in compression
// (L < L0) have the transverse term max(0, 1 − L0/L) instead.
// Tolerance 1e-12 of the largest entry (an entry sums at most 5 terms).
TEST(Core, LargeNetsDerivativesInPartsMatchTheClosedForm) {
  std::mt19937 rng(2711);
  bool below = false, above = false;
  for (const int side : {40, 91, 92, 130}) {
    const double prestrain = side % 2 == 0 ? 0.0 : 0.02;
    const std::string text = "gravity = [0, 0, -9.81]\n[[lattice]]\nname = \"n\"\nsize = [" + std::to_string(side) +
                             ", " + std::to_string(side) + ", 1]\nspacing = 0.1\nmass = 0.002\nstiffness = 1000\n"
                             "prestrain = " + std::to_string(prestrain) + "\nfixed = \"boundary\"\n";
    const System s = build_system(parse_scene(text, "net.toml"));
    (s.springs().size() >= 16384 ? above : below) = true;
    Workspace w(s);
    std::uniform_real_distribution<double> u(-0.01, 0.01);
    for (int call = 0; call < 3; ++call) {
      VectorX q(s.size());
      for (int i = 0; i < s.size(); ++i) q[i] = u(rng) - (i % 3 == 2 ? 0.02 * (call + 1) : 0.0);
      // The closed form, from the bodies' world positions.
      const std::vector<Pose> poses = body_poses(s, w, q);
      VectorX g = VectorX::Zero(s.size());
      std::vector<Eigen::Triplet<double>> t, tc, tm;  // ∇∇V; with the compressed springs' positive parts; the tension metric
      int compressed = 0, stretched = 0;
      auto coordinate = [&](int body) {
        if (body < 0 || s.joint_size(body) == 0) return -1;
        EXPECT_EQ(s.bodies()[static_cast<std::size_t>(body)].joint, JointType::particle);
        EXPECT_EQ(s.joint_size(body), 3);
        return s.first_coordinate(body);
      };
      for (std::size_t b = 0; b < s.bodies().size(); ++b) {
        const int k = coordinate(static_cast<int>(b));
        if (k >= 0) g.segment<3>(k) -= s.bodies()[b].mass * s.gravity();
      }
      for (const Spring& sp : s.springs()) {
        auto position = [&](const Attachment& a) {
          if (a.body < 0) return a.point;
          const Pose& p = poses[static_cast<std::size_t>(a.body)];
          return Vec3(p.position + p.rotation * a.point);
        };
        const Vec3 d = position(sp.a) - position(sp.b);
        const double L = d.norm();
        const Vec3 e = d / L;
        const Mat3 B = sp.stiffness * (e * e.transpose() + (1 - sp.rest_length / L) * (Mat3::Identity() - e * e.transpose()));
        const Mat3 Bc = sp.stiffness * (e * e.transpose() + std::max(0.0, 1 - sp.rest_length / L) * (Mat3::Identity() - e * e.transpose()));
        const int ka = coordinate(sp.a.body), kb = coordinate(sp.b.body);
        if (ka >= 0 || kb >= 0) ++(L < sp.rest_length ? compressed : stretched);
        const Vec3 f = sp.stiffness * (L - sp.rest_length) * e;
        auto block = [&](int r, int c, const Mat3& m) {
          const Mat3& mc = &m == &B ? Bc : Mat3(-Bc);
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
              t.emplace_back(r + i, c + j, m(i, j));
              tc.emplace_back(r + i, c + j, mc(i, j));
            }
        };
        if (ka >= 0) {
          g.segment<3>(ka) += f;
          block(ka, ka, B);
        }
        if (kb >= 0) {
          g.segment<3>(kb) -= f;
          block(kb, kb, B);
        }
        if (ka >= 0 && kb >= 0) {
          block(ka, kb, -B);
          block(kb, ka, -B);
        }
        // The tension metric's block: k [I −I; −I I].
        for (const auto& [r, c, sign] : {std::tuple{ka, ka, 1.0}, std::tuple{kb, kb, 1.0}, std::tuple{ka, kb, -1.0},
                                         std::tuple{kb, ka, -1.0}})
          if (r >= 0 && c >= 0)
            for (int i = 0; i < 3; ++i) tm.emplace_back(r + i, c + i, sign * sp.stiffness);
      }
      SparseMatrix reference(s.size(), s.size());
      reference.setFromTriplets(t.begin(), t.end());
      const std::string what = "net " + std::to_string(side) + "² (" + std::to_string(s.springs().size()) +
                               " springs) call " + std::to_string(call);
      const SparseMatrix H = sparse_potential_hessian(s, w, q);
      const double scale = reference.coeffs().cwiseAbs().maxCoeff();
      EXPECT_LE(SparseMatrix(H - reference).coeffs().cwiseAbs().maxCoeff(), 1e-12 * scale) << what;
      const VectorX gradient = potential_gradient(s, w, q);
      EXPECT_LE((gradient - g).cwiseAbs().maxCoeff(), 1e-12 * g.cwiseAbs().maxCoeff()) << what;
      // The same q again: the same bits.
      const SparseMatrix again = sparse_potential_hessian(s, w, q);
      if (call > 0) {
        EXPECT_TRUE(std::equal(H.valuePtr(), H.valuePtr() + H.nonZeros(), again.valuePtr())) << what;
      }
      EXPECT_TRUE(potential_gradient(s, w, q) == gradient) << what;
      // The convex form (sparse_convex_potential_hessian): in place on ∇∇V's
      // pattern, and in a fresh workspace (by columns); both kinds of spring
      // present.
      EXPECT_GT(compressed, 0) << what;
      EXPECT_GT(stretched, 0) << what;
      SparseMatrix convex(s.size(), s.size());
      convex.setFromTriplets(tc.begin(), tc.end());
      const SparseMatrix C = sparse_convex_potential_hessian(s, w, q);
      EXPECT_LE(SparseMatrix(C - convex).coeffs().cwiseAbs().maxCoeff(), 1e-12 * scale) << what;
      Workspace fresh(s);
      const SparseMatrix first = sparse_convex_potential_hessian(s, fresh, q);
      EXPECT_LE(SparseMatrix(first - convex).coeffs().cwiseAbs().maxCoeff(), 1e-12 * scale) << what;
      // The tension metric (sparse_tension_metric): in place on ∇∇V's
      // pattern, in two parts above the threshold, the same bits twice; by
      // columns in a fresh workspace.
      SparseMatrix metric(s.size(), s.size());
      metric.setFromTriplets(tm.begin(), tm.end());
      const SparseMatrix D = sparse_tension_metric(s, w, q), D_again = sparse_tension_metric(s, w, q);
      EXPECT_LE(SparseMatrix(D - metric).coeffs().cwiseAbs().maxCoeff(), 1e-12 * scale) << what;
      EXPECT_TRUE(D.nonZeros() == D_again.nonZeros() &&
                  std::equal(D.valuePtr(), D.valuePtr() + D.nonZeros(), D_again.valuePtr()))
          << what;
      Workspace fresh_metric(s);
      const SparseMatrix D_first = sparse_tension_metric(s, fresh_metric, q);
      EXPECT_LE(SparseMatrix(D_first - metric).coeffs().cwiseAbs().maxCoeff(), 1e-12 * scale) << what;
    }
  }
  EXPECT_TRUE(below && above) << "the nets must lie on both sides of the two-part threshold";

  // An element's failure in the second part (on its thread) reaches the
  // caller: the last spring between two free particles (in the second half),
  // its ends made to coincide.
  const std::string text = "gravity = [0, 0, -9.81]\n[[lattice]]\nname = \"n\"\nsize = [100, 100, 1]\nspacing = 0.1\n"
                           "mass = 0.002\nstiffness = 1000\nprestrain = 0.02\nfixed = \"boundary\"\n";
  const System s = build_system(parse_scene(text, "net.toml"));
  ASSERT_GE(s.springs().size(), 16384u);
  Workspace w(s);
  VectorX q = VectorX::Zero(s.size());
  sparse_potential_hessian(s, w, q);  // the pattern; what follows is in place
  auto it = std::find_if(s.springs().rbegin(), s.springs().rend(), [&](const Spring& sp) {
    return sp.a.body >= 0 && sp.b.body >= 0 && s.joint_size(sp.a.body) == 3 && s.joint_size(sp.b.body) == 3;
  });
  ASSERT_NE(it, s.springs().rend());
  const std::vector<Pose> poses = body_poses(s, w, q);
  q.segment<3>(s.first_coordinate(it->b.body)) += poses[static_cast<std::size_t>(it->a.body)].position -
                                                   poses[static_cast<std::size_t>(it->b.body)].position;
  EXPECT_THROW(sparse_potential_hessian(s, w, q), NumericalError);
  EXPECT_THROW(potential_gradient(s, w, q), NumericalError);
}

TEST(Core, DerivativesMatchCentralDifferences) {
  test::expect_derivatives_match_central_differences(everything_tree(), 11);
}

TEST(Core, MassMatrixMatchesJacobianTransposeInertiaJacobian) {
  // Independent construction: AD Jacobians of each body's centre of mass and of
  // its rotation (ω̂ = Ṙ Rᵀ), then M = Σ m J_vᵀJ_v + J_ωᵀ (R I Rᵀ) J_ω.
  const System s = everything_tree();
  Workspace w(s);
  std::mt19937 rng(3);
  const VectorX q = random_state(s, rng, 1.0);
  const int n = s.size();
  const test::BodyJacobians J = test::body_jacobians(s, q);
  MatrixX M_ref = MatrixX::Zero(n, n);
  for (std::size_t b = 0; b < s.bodies().size(); ++b) {
    const Body& body = s.bodies()[b];
    const Mat3 Iw = J.st.rotation[b] * body.inertia * J.st.rotation[b].transpose();
    M_ref += body.mass * J.Jv[b].transpose() * J.Jv[b] + J.Jw[b].transpose() * Iw * J.Jw[b];
  }
  const MatrixX& M = mass_matrix(s, w, q);
  EXPECT_LE(max_abs(M - M_ref), 1e-13 * max_abs(M_ref));
}

TEST(Core, DoublePendulumMatricesMatchR1) {
  // docs/design.md R1 gives M and K in absolute angles θ; joint angles are
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
  // dE/dt = Qᵀq̇ = −q̇ᵀDq̇ ≤ 0 (docs/design.md section 3).
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
