// tests/test_linearize.cpp — linearize() against hand-derived references.
//
// Systems are built directly from a SystemDescription (no scene files), so the
// test depends only on the core's public API (modal/core.hpp).
//
// R1 (docs/design.md, section 2): double pendulum of point masses on massless rods, with
// absolute angles θ from the hanging vertical:
//   M_abs(θ) = [[(m1+m2) l1², m2 l1 l2 cos(θ1 − θ2)], [·, m2 l2²]],
//   V(θ) = −(m1+m2) g l1 cos θ1 − m2 g l2 cos θ2, so ∇∇V = diag((m1+m2) g l1 cos θ1, m2 g l2 cos θ2).
// The core's coordinates are joint angles relative to the parent,
// φ = (θ1, θ2 − θ1), i.e. θ = T φ with T = [[1, 0], [1, 1]]; since the map is
// linear, M(φ) = Tᵀ M_abs T and ∇∇V(φ) = Tᵀ ∇∇V_abs T exactly.
//
// Tolerance 1e-12 relative to the matrix norm: the core evaluates M and K with
// exact (AD) derivatives, so they agree with the closed forms to a few ε;
// 1e-12 leaves ample room for rounding in the kinematic chain.
#include "modal/linearize.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <string>

namespace {

using modal::Body;
using modal::LinearModel;
using modal::MatrixX;
using modal::VectorX;

constexpr double matrix_tolerance = 1e-12;  // relative, see the header comment
constexpr double pi = std::numbers::pi;

struct PendulumParameters {
  double m1, m2, l1, l2, g;
};

Body hinge_body(const std::string& name, int parent, double mass, double length, double origin_z) {
  Body b;
  b.name = name;
  b.parent = parent;
  b.joint = modal::JointType::hinge;
  b.axis = modal::Vec3::UnitY();
  b.origin = modal::Vec3(0, 0, origin_z);
  b.mass = mass;
  b.com = modal::Vec3(0, 0, -length);
  b.rest = VectorX::Zero(1);
  b.initial = VectorX::Zero(1);
  return b;
}

modal::System double_pendulum(const PendulumParameters& p, double lower_damping = 0) {
  modal::SystemDescription d;
  d.title = "double pendulum (R1)";
  d.gravity = modal::Vec3(0, 0, -p.g);
  d.bodies.push_back(hinge_body("upper", -1, p.m1, p.l1, 0));
  d.bodies.push_back(hinge_body("lower", 0, p.m2, p.l2, -p.l1));
  d.bodies.back().damping = lower_damping;
  return modal::System(d);
}

// Relative angles φ → absolute θ = T φ.
MatrixX T() {
  MatrixX t(2, 2);
  t << 1, 0, 1, 1;
  return t;
}

// R1 closed forms at absolute angles θ, in the core's relative coordinates.
MatrixX reference_mass(const PendulumParameters& p, double theta1, double theta2) {
  MatrixX M(2, 2);
  const double c = p.m2 * p.l1 * p.l2 * std::cos(theta1 - theta2);
  M << (p.m1 + p.m2) * p.l1 * p.l1, c, c, p.m2 * p.l2 * p.l2;
  return T().transpose() * M * T();
}

MatrixX reference_stiffness(const PendulumParameters& p, double theta1, double theta2) {
  MatrixX K = MatrixX::Zero(2, 2);
  K(0, 0) = (p.m1 + p.m2) * p.g * p.l1 * std::cos(theta1);
  K(1, 1) = p.m2 * p.g * p.l2 * std::cos(theta2);
  return T().transpose() * K * T();
}

void expect_close(const MatrixX& actual, const MatrixX& expected, const char* what) {
  EXPECT_LE((actual - expected).norm(), matrix_tolerance * expected.norm())
      << what << ":\n" << actual << "\nexpected:\n" << expected;
}

// R1: the four parameter rows of the table, each at the four equilibria (each
// rod down or up; absolute angles θ ∈ {0, π}²).
TEST(Linearize, DoublePendulumMatchesR1AtAllEquilibria) {
  const PendulumParameters rows[] = {{1, 1, 1, 1, 1}, {2, 1, 1, 1, 1}, {1, 2, 1, 1, 1}, {1, 1, 1, 2, 1}};
  const double equilibria[4][2] = {{0, 0}, {pi, pi}, {0, pi}, {pi, 0}};
  for (const PendulumParameters& p : rows) {
    const modal::System sys = double_pendulum(p);
    for (const auto& theta : equilibria) {
      SCOPED_TRACE("m1=" + std::to_string(p.m1) + " m2=" + std::to_string(p.m2) + " l2=" + std::to_string(p.l2) +
                   " θ=(" + std::to_string(theta[0]) + ", " + std::to_string(theta[1]) + ")");
      const VectorX q = (VectorX(2) << theta[0], theta[1] - theta[0]).finished();
      const LinearModel lin = modal::linearize(sys, q);
      EXPECT_EQ(lin.size(), 2);
      EXPECT_EQ(lin.q, q);
      ASSERT_EQ(lin.coordinates.size(), 2u);
      EXPECT_EQ(lin.coordinates[0], "upper");
      EXPECT_EQ(lin.coordinates[1], "lower");
      expect_close(lin.M, reference_mass(p, theta[0], theta[1]), "M");
      expect_close(lin.K, reference_stiffness(p, theta[0], theta[1]), "K");
      // Exactly symmetric, as promised.
      EXPECT_EQ(lin.M, lin.M.transpose());
      EXPECT_EQ(lin.K, lin.K.transpose());
      EXPECT_LE(lin.residual, 1e-12);
      EXPECT_FALSE(lin.has_damping);
      EXPECT_FALSE(lin.has_gyroscopic);
      EXPECT_FALSE(lin.circulatory);
      EXPECT_TRUE(lin.symmetric());
      EXPECT_EQ(lin.D.size(), 0);  // none: empty
      EXPECT_EQ(lin.G.size(), 0);
    }
  }
}

// Away from an equilibrium: refused with the residual and the coordinate in
// words. At θ = (0.3, 0.2) the unbalanced generalized forces are
// −∂V/∂φ1 = −(2 sin 0.3 + sin 0.2) ≈ −0.79 N·m and −∂V/∂φ2 = −sin 0.2 ≈ −0.20 N·m
// (m = l = g = 1), so the largest acts on "upper".
TEST(Linearize, RefusesAPointThatIsNotAnEquilibrium) {
  const PendulumParameters p{1, 1, 1, 1, 1};
  const modal::System sys = double_pendulum(p);
  const VectorX q = (VectorX(2) << 0.3, -0.1).finished();
  try {
    modal::linearize(sys, q);
    FAIL() << "expected NotAnEquilibrium";
  } catch (const modal::NotAnEquilibrium& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("not an equilibrium"), std::string::npos) << what;
    EXPECT_NE(what.find("relative residual"), std::string::npos) << what;
    EXPECT_NE(what.find("'upper'"), std::string::npos) << what;
    EXPECT_NE(what.find("N·m"), std::string::npos) << what;
    EXPECT_NE(what.find("-0.7897"), std::string::npos) << what;  // −(2 sin 0.3 + sin 0.2)
    EXPECT_NE(what.find("equilibrium first"), std::string::npos) << what;
  }
  // A generous tolerance accepts it; M and K are then those of R1 at that θ.
  const LinearModel lin = modal::linearize(sys, q, {.tolerance = std::numeric_limits<double>::infinity()});
  EXPECT_GT(lin.residual, 1e-3);
  expect_close(lin.M, reference_mass(p, 0.3, 0.2), "M");
  expect_close(lin.K, reference_stiffness(p, 0.3, 0.2), "K");
}

// A joint damper c on the lower hinge: Q = −c φ̇2, so D = diag(0, c) in the
// core's relative coordinates; the model is then no longer symmetric.
TEST(Linearize, JointDamperGivesDampingMatrix) {
  const double c = 0.25;
  const modal::System sys = double_pendulum({1, 1, 1, 1, 1}, c);
  const LinearModel lin = modal::linearize(sys, VectorX::Zero(2));
  EXPECT_TRUE(lin.has_damping);
  EXPECT_FALSE(lin.symmetric());
  MatrixX D = MatrixX::Zero(2, 2);
  D(1, 1) = c;
  expect_close(lin.D, D, "D");
}

// A slide joint along x held by a spring along the same line (rest length 1 at
// x = 0), gravity across the slide: V = ½ k x², so M = m, K = k; the unbalanced
// force away from x = 0 is in newtons.
TEST(Linearize, SlideWithSpring) {
  const double m = 3, k = 40;
  modal::SystemDescription d;
  Body cart;
  cart.name = "cart";
  cart.joint = modal::JointType::slide;
  cart.axis = modal::Vec3::UnitX();
  cart.mass = m;
  cart.rest = VectorX::Zero(1);
  cart.initial = VectorX::Zero(1);
  d.bodies.push_back(cart);
  modal::Spring spring;
  spring.a.body = 0;
  spring.b.body = -1;
  spring.b.point = modal::Vec3(1, 0, 0);
  spring.stiffness = k;
  spring.rest_length = 1;
  d.springs.push_back(spring);
  const modal::System sys(d);

  const LinearModel lin = modal::linearize(sys, VectorX::Zero(1));
  EXPECT_NEAR(lin.M(0, 0), m, matrix_tolerance * m);
  EXPECT_NEAR(lin.K(0, 0), k, matrix_tolerance * k);
  try {
    modal::linearize(sys, VectorX::Constant(1, 0.1));
    FAIL() << "expected NotAnEquilibrium";
  } catch (const modal::NotAnEquilibrium& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("-4 N acting on the coordinate 'cart'"), std::string::npos) << what;  // −k·x
  }
}

TEST(Linearize, RejectsAConfigurationOfTheWrongSize) {
  const modal::System sys = double_pendulum({1, 1, 1, 1, 1});
  EXPECT_THROW(modal::linearize(sys, VectorX::Zero(3)), std::invalid_argument);
}

}  // namespace
