// Holonomic constraints: exact derivatives of c(q), constrained equilibria with
// their multipliers, and the projected linear model (docs/design.md section 3).
#include "modal/equilibrium.hpp"
#include "modal/modes.hpp"
#include "modal/simulate.hpp"

#include "systems.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <random>

namespace {

using namespace modal;

constexpr double g = 9.81;

Body particle(const std::string& name, const Vec3& at, double mass, std::array<bool, 3> axes = {true, true, true}) {
  Body b;
  b.name = name;
  b.joint = JointType::particle;
  b.origin = at;
  b.mass = mass;
  b.particle_axes = axes;
  return b;
}

Constraint distance(const std::string& name, Attachment a, Attachment b, double length) {
  Constraint c;
  c.type = Constraint::Type::distance;
  c.name = name;
  c.a = a;
  c.b = b;
  c.length = length;
  return c;
}

Constraint point(const std::string& name, Attachment a, Attachment b) {
  Constraint c;
  c.type = Constraint::Type::point;
  c.name = name;
  c.a = a;
  c.b = b;
  return c;
}

// A particle of mass m held at distance l below a world pivot by a rod
// (distance constraint): V = m g z has no curvature, so all of K comes from the
// multiplier term −s ∇∇c = m g (I − uuᵀ)/l.
System particle_pendulum(double m, double l, std::array<bool, 3> axes = {true, true, true}) {
  SystemDescription d;
  d.gravity = Vec3(0, 0, -g);
  d.bodies.push_back(particle("bob", Vec3(0, 0, -l), m, axes));
  d.constraints.push_back(distance("rod", {0, Vec3::Zero()}, {-1, Vec3::Zero()}, l));
  return System(d);
}

TEST(constraints, ParticlePendulumIsExactlySqrtGOverL) {
  for (const double l : {0.25, 1.0, 3.0}) {
    const System s = particle_pendulum(2.0, l);
    const Equilibrium e = find_equilibrium(s, s.initial_configuration());
    ASSERT_EQ(e.multipliers.size(), 1);
    // Hand computation: the rod carries the weight, tension m g, so s = −m g (s > 0 pushes the ends apart).
    EXPECT_NEAR(e.multipliers[0], -2.0 * g, 1e-12 * 2.0 * g);
    const LinearModel lin = linearize(s, e.q);
    ASSERT_EQ(lin.dof(), 2);   // 3 coordinates, 1 constraint
    EXPECT_EQ(lin.size(), 3);
    const ModalResult r = solve_modes(lin);
    ASSERT_EQ(r.modes.size(), 2u);
    for (const Mode& m : r.modes) {
      // ω² = g/l to rounding: the stiffness is m g/l from the multiplier term alone.
      EXPECT_NEAR(m.omega2, g / l, 4e-15 * g / l) << "l = " << l;
      EXPECT_EQ(m.shape.size(), 3);
      EXPECT_NEAR(std::abs(m.shape[2]), 0.0, 1e-15);  // tangent to the circle at the bottom
    }
    EXPECT_EQ(r.stability, Stability::stable);
    EXPECT_NEAR(std::sqrt(r.modes[0].omega2), std::sqrt(g / l), 1e-15 * std::sqrt(g / l));
  }
}

TEST(constraints, PlanarParticlePendulumHasOneMode) {
  const System s = particle_pendulum(0.5, 2.0, {true, false, true});
  ASSERT_EQ(s.size(), 2);
  const Equilibrium e = find_equilibrium(s, s.initial_configuration());
  const ModalResult r = solve_modes(linearize(s, e.q));
  ASSERT_EQ(r.modes.size(), 1u);
  EXPECT_NEAR(r.modes[0].omega2, g / 2.0, 4e-15 * g);
  // M-normalized in all coordinates: φᵀMφ = 1 with M = m I.
  EXPECT_NEAR(0.5 * r.modes[0].shape.squaredNorm(), 1.0, 1e-14);
}

TEST(constraints, InvertedParticlePendulumDiverges) {
  SystemDescription d;
  d.gravity = Vec3(0, 0, -g);
  d.bodies.push_back(particle("bob", Vec3(0, 0, 1.5), 1.0, {true, false, true}));
  d.constraints.push_back(distance("rod", {0, Vec3::Zero()}, {-1, Vec3::Zero()}, 1.5));
  const System s(d);
  const Equilibrium e = find_equilibrium(s, s.initial_configuration());
  EXPECT_NEAR(e.q.norm(), 0.0, 1e-12);             // stays on top
  EXPECT_NEAR(e.multipliers[0], g, 1e-12 * g);      // a strut: compression m g, s > 0
  const ModalResult r = solve_modes(linearize(s, e.q));
  EXPECT_NEAR(r.modes[0].omega2, -g / 1.5, 1e-14 * g);
  EXPECT_EQ(r.stability, Stability::divergence);
}

// R7 with a constraint: a particle held on a hoop (distance R from the hoop's
// centre, y fixed) in a frame spinning at Ω about the vertical. The bottom has
// ω² = g/R − Ω² (the centrifugal potential and the multiplier term together).
TEST(constraints, BeadOnAHoopThroughAConstraint) {
  const double R = 0.5, Omega = 2.0;
  SystemDescription d;
  d.gravity = Vec3(0, 0, -g);
  d.frame_rotation = Vec3(0, 0, Omega);
  d.bodies.push_back(particle("bead", Vec3(0, 0, -R), 0.3, {true, false, true}));
  d.constraints.push_back(distance("hoop", {0, Vec3::Zero()}, {-1, Vec3::Zero()}, R));
  const System s(d);
  const Equilibrium e = find_equilibrium(s, s.initial_configuration());
  const ModalResult r = solve_modes(linearize(s, e.q));
  ASSERT_EQ(r.modes.size(), 1u);
  EXPECT_NEAR(r.modes[0].omega2, g / R - Omega * Omega, 1e-13 * g / R);
}

// Damping through the projection: the planar particle pendulum with a
// horizontal spring-damper at the bob, m ẍ + c ẋ + (m g/l + k) x = 0 along the
// tangent: s = −c/2m ± i √((g/l + k/m) − (c/2m)²).
TEST(constraints, DampedConstrainedModeMatchesTheOscillator) {
  const double m = 0.8, l = 1.2, k = 3.0, c = 0.4, dx = 0.7;
  SystemDescription d;
  d.gravity = Vec3(0, 0, -g);
  d.bodies.push_back(particle("bob", Vec3(0, 0, -l), m, {true, false, true}));
  d.constraints.push_back(distance("rod", {0, Vec3::Zero()}, {-1, Vec3::Zero()}, l));
  Spring sp;
  sp.a = {0, Vec3::Zero()};
  sp.b = {-1, Vec3(-dx, 0, -l)};
  sp.stiffness = k;
  sp.damping = c;
  sp.rest_length = dx;
  d.springs.push_back(sp);
  const System s(d);
  const Equilibrium e = find_equilibrium(s, s.initial_configuration());
  const LinearModel lin = linearize(s, e.q);
  ASSERT_TRUE(lin.has_damping);
  const ModalResult r = solve_modes(lin);
  ASSERT_EQ(r.modes.size(), 1u);
  const double sigma = -c / (2 * m), w = std::sqrt(g / l + k / m - sigma * sigma);
  EXPECT_NEAR(r.modes[0].growth_rate, sigma, 1e-12);
  EXPECT_NEAR(r.modes[0].omega, w, 1e-12 * w);
  EXPECT_EQ(r.stability, Stability::asymptotically_stable);
  ASSERT_EQ(r.modes[0].shape.size(), 2);
  EXPECT_NEAR(std::abs(r.modes[0].shape[1]), 0.0, 1e-14);  // tangent: no z at the bottom
}

// A rod hinged at the world at one end, its other end held up by a vertical
// string: moments about the hinge give the tension m g / 2.
TEST(constraints, ForcesMatchAHandComputation) {
  const double m = 3.0, L = 2.0, h = 1.0;
  SystemDescription d;
  d.gravity = Vec3(0, 0, -g);
  Body rod = test::hinge("rod", -1, Vec3::Zero(), m, Vec3(L / 2, 0, 0));
  d.bodies.push_back(rod);
  d.constraints.push_back(distance("string", {0, Vec3(L, 0, 0)}, {-1, Vec3(L, 0, h)}, h));
  const System s(d);
  const Equilibrium e = find_equilibrium(s, s.initial_configuration());
  EXPECT_NEAR(e.q[0], 0.0, 1e-12);
  EXPECT_NEAR(-e.multipliers[0], m * g / 2, 1e-12 * m * g);  // tension
  const LinearModel lin = linearize(s, e.q);
  ASSERT_EQ(lin.constraint_forces.size(), 1u);
  EXPECT_NEAR(lin.constraint_forces[0].multipliers[0], -m * g / 2, 1e-12 * m * g);
  EXPECT_EQ(lin.dof(), 0);  // the string fixes the rod
  const ModalResult r = solve_modes(lin);
  EXPECT_TRUE(r.modes.empty());
  EXPECT_NE(r.solver.find("no degree of freedom"), std::string::npos);

  // The same rod held by a point constraint at its tip: force on the rod (0, 0, m g/2).
  SystemDescription p = d;
  p.constraints = {point("pin", {0, Vec3(L, 0, 0)}, {-1, Vec3(L, 0, 0)})};
  const System sp(p);
  const LinearModel lp = linearize(sp, VectorX::Zero(1));
  ASSERT_EQ(lp.constraint_forces[0].multipliers.size(), 3);
  EXPECT_NEAR(lp.constraint_forces[0].multipliers[2], m * g / 2, 1e-12 * m * g);
  EXPECT_NEAR(lp.constraint_forces[0].multipliers[0], 0.0, 1e-12 * m * g);
  // Its x and y equations are redundant here (the tip of the hinged rod moves only along z): reported, force 0.
  ASSERT_EQ(lp.redundant_equations.size(), 2u);
}

// Double pendulum of rods with inertia: hinges, and the same tree as two free
// bodies each held by two point constraints on its hinge axis.
struct Twin {
  System hinged, free;
};
Twin double_rod_twin() {
  const double m1 = 1.3, m2 = 0.7, l1 = 1.1, l2 = 0.8, h = 0.3;
  auto inertia = [](double m, double l) {
    return Vec3(m * l * l / 12 + 0.01, m * l * l / 12 + 0.012, 0.005).asDiagonal().toDenseMatrix();
  };
  SystemDescription a;
  a.gravity = Vec3(0, 0, -g);
  Body b1 = test::hinge("upper", -1, Vec3::Zero(), m1, Vec3(0.05, 0, -l1 / 2));
  b1.inertia = inertia(m1, l1);
  Body b2 = test::hinge("lower", 0, Vec3(0, 0, -l1), m2, Vec3(-0.03, 0, -l2 / 2));
  b2.inertia = inertia(m2, l2);
  a.bodies = {b1, b2};

  SystemDescription f = a;
  f.bodies[0].joint = f.bodies[1].joint = JointType::free;
  f.bodies[1].parent = -1;
  f.bodies[1].origin = Vec3(0, 0, -l1);
  for (const double y : {-h, h}) {
    f.constraints.push_back(point("pivot", {0, Vec3(0, y, 0)}, {-1, Vec3(0, y, 0)}));
    f.constraints.push_back(point("knee", {1, Vec3(0, y, 0)}, {0, Vec3(0, y, -l1)}));
  }
  return {System(a), System(f)};
}

TEST(constraints, HingeTreeAndConstrainedTwinAgree) {
  const Twin t = double_rod_twin();
  ASSERT_EQ(t.free.size(), 12);
  ASSERT_EQ(t.free.constraint_equations(), 12);
  const ModalResult a = solve_modes(linearize(t.hinged, find_equilibrium(t.hinged, t.hinged.initial_configuration()).q));
  const Equilibrium ef = find_equilibrium(t.free, t.free.initial_configuration());
  const LinearModel lf = linearize(t.free, ef.q);
  EXPECT_EQ(lf.dof(), 2);
  EXPECT_EQ(lf.redundant_equations.size(), 2u);  // one per hinge: two points on an axis fix 5, not 6
  const ModalResult b = solve_modes(lf);
  ASSERT_EQ(a.modes.size(), 2u);
  ASSERT_EQ(b.modes.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) EXPECT_NEAR(b.modes[i].omega, a.modes[i].omega, 1e-10 * a.modes[i].omega);
  // The same equilibrium reached from a start off the manifold.
  VectorX start = t.free.initial_configuration();
  start << 0.05, -0.02, 0.01, 0.1, 0.2, -0.1, 0.0, 0.03, 0.0, -0.2, 0.1, 0.05;
  const Equilibrium e2 = find_equilibrium(t.free, start);
  const ModalResult c = solve_modes(linearize(t.free, e2.q));
  for (std::size_t i = 0; i < 2; ++i) EXPECT_NEAR(c.modes[i].omega, a.modes[i].omega, 1e-10 * a.modes[i].omega);
  EXPECT_LE(e2.constraint_violation, 1e-12);
}

// The constrained twin moves exactly like the tree: upper.ry = θ₁ and
// lower.ry = θ₁ + θ₂ along a large nonlinear motion (energy conserved too).
TEST(constraints, ConstrainedMotionFollowsTheTree) {
  const Twin t = double_rod_twin();
  const double th1 = 0.6, th2 = -0.4;
  const double l1 = 1.1;
  VectorX qa(2), qf = VectorX::Zero(12);
  qa << th1, th2;
  const Vec3 knee = Eigen::AngleAxisd(th1, Vec3::UnitY()) * Vec3(0, 0, -l1);
  qf[4] = th1;
  qf.segment<3>(6) = knee - Vec3(0, 0, -l1);
  qf[10] = th1 + th2;
  SimulationOptions o;
  o.duration = 3;
  o.interval = 0.1;
  const Trajectory a = simulate(t.hinged, qa, VectorX::Zero(2), o);
  const Trajectory f = simulate(t.free, qf, VectorX::Zero(12), o);
  ASSERT_EQ(a.size(), f.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    // Both integrations hold 1e-12 per step; the motions agree to ~1e-9 over 3 s.
    EXPECT_NEAR(f.q[k][4], a.q[k][0], 1e-8) << "t = " << a.time[k];
    EXPECT_NEAR(f.q[k][10], a.q[k][0] + a.q[k][1], 1e-8) << "t = " << a.time[k];
  }
  EXPECT_LT(f.max_energy_error, 1e-11);
}

// A system with hinges, a slide, a free body, particles and both constraint
// kinds, at a random configuration (not on the manifold: the derivatives hold anywhere).
System mixed_system() {
  SystemDescription d;
  d.gravity = Vec3(0.1, 0.2, -g);
  d.bodies.push_back(test::hinge("a", -1, Vec3(0.1, 0, 0), 1.0, Vec3(0, 0, -1), Vec3(0.1, 1, 0.2)));
  d.bodies.push_back(test::hinge("b", 0, Vec3(0, 0.1, -1), 0.5, Vec3(0.2, 0, -0.8), Vec3(1, 0.3, 0)));
  Body fr;
  fr.name = "fly";
  fr.joint = JointType::free;
  fr.origin = Vec3(1, 0.5, -1);
  fr.mass = 0.4;
  fr.inertia = Vec3(0.1, 0.2, 0.3).asDiagonal();
  d.bodies.push_back(fr);
  d.bodies.push_back(particle("p", Vec3(-1, 0.2, -0.5), 0.3));
  d.bodies.push_back(particle("r", Vec3(0.5, -0.2, -0.5), 0.3, {false, true, true}));
  d.constraints.push_back(point("ab", {1, Vec3(0.1, 0.2, -0.9)}, {2, Vec3(0.3, -0.1, 0.2)}));
  d.constraints.push_back(distance("ap", {0, Vec3(0.2, 0, -0.5)}, {3, Vec3::Zero()}, 0.9));
  d.constraints.push_back(distance("pw", {4, Vec3::Zero()}, {-1, Vec3(0.3, 0.3, 0.3)}, 1.2));
  d.constraints.push_back(point("fw", {2, Vec3(0, 0.4, 0)}, {-1, Vec3(1, 1, -1)}));
  return System(d);
}

TEST(constraints, JacobianAndMultiplierHessianMatchCentralDifferences) {
  const System s = mixed_system();
  ASSERT_EQ(s.constraint_equations(), 8);
  Workspace w(s);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  for (int trial = 0; trial < 5; ++trial) {
    VectorX q(s.size());
    for (int i = 0; i < q.size(); ++i) q[i] = u(rng);
    VectorX mult(s.constraint_equations());
    for (int i = 0; i < mult.size(); ++i) mult[i] = 10 * u(rng);
    const MatrixX A = constraint_jacobian(s, w, q);
    const MatrixX H = constraint_hessian(s, w, q, mult);
    const double h = 1e-6;
    for (int k = 0; k < s.size(); ++k) {
      VectorX qp = q, qm = q;
      qp[k] += h;
      qm[k] -= h;
      const VectorX dc = (constraint_values(s, w, qp) - constraint_values(s, w, qm)) / (2 * h);
      // Central differences: truncation O(h²) ≈ 1e-12, rounding ε/h ≈ 1e-10.
      EXPECT_LE((dc - A.col(k)).norm(), 1e-8) << "column " << k;
      const VectorX dg = (constraint_jacobian(s, w, qp).transpose() * mult - constraint_jacobian(s, w, qm).transpose() * mult) / (2 * h);
      EXPECT_LE((dg - H.col(k)).norm(), 1e-7 * (1 + H.norm())) << "column " << k;
    }
    EXPECT_LE((H - H.transpose()).norm(), 1e-12 * H.norm());

    // q̇ᵀ∇∇c q̇ against the second difference of c along q̇ (truncation O(h²),
    // rounding ε/h² ≈ 1e-8 at h = 1e-4), and against Σ from the multiplier Hessian.
    VectorX qd(s.size());
    for (int i = 0; i < qd.size(); ++i) qd[i] = u(rng);
    const VectorX curv = constraint_curvature(s, w, q, qd);
    const double h2 = 1e-4;
    const VectorX second = (constraint_values(s, w, q + h2 * qd) - 2 * constraint_values(s, w, q) +
                            constraint_values(s, w, q - h2 * qd)) / (h2 * h2);
    EXPECT_LE((second - curv).norm(), 1e-6 * (1 + curv.norm()));
    for (int i = 0; i < s.constraint_equations(); ++i)
      EXPECT_NEAR(curv[i], qd.dot(constraint_hessian(s, w, q, VectorX::Unit(s.constraint_equations(), i)) * qd),
                  1e-12 * (1 + std::abs(curv[i])));
  }
}

// The accelerations keep the constraints to second order: A q̈ + q̇ᵀ∇∇c q̇ = 0.
TEST(constraints, AccelerationsHoldTheConstraints) {
  const Twin t = double_rod_twin();
  Workspace w(t.free);
  VectorX q = VectorX::Zero(12), qd = VectorX::Zero(12);
  qd[4] = 0.7;   // upper turns about y; the lower body follows at the knee
  qd[6] = -0.7 * 1.1;
  qd[10] = 1.3;
  const VectorX qdd = accelerations(t.free, w, q, qd);
  const VectorX residual = constraint_jacobian(t.free, w, q) * qdd + constraint_curvature(t.free, w, q, qd);
  EXPECT_LE(residual.norm(), 1e-12);
}

TEST(constraints, BasisIsOrthonormalNullSpaceAndFindsRedundancy) {
  MatrixX A(3, 4);
  A << 1, 2, 0, 1,  //
      0, 1, 1, 0,   //
      1, 3, 1, 1;   // = row 0 + row 1
  const ConstraintBasis b = constraint_basis(A);
  EXPECT_EQ(b.rank, 2);
  EXPECT_EQ(b.redundant.size(), 1u);
  ASSERT_EQ(b.null_space.cols(), 2);
  EXPECT_LE((A * b.null_space).norm(), 1e-14);
  EXPECT_LE((b.null_space.transpose() * b.null_space - MatrixX::Identity(2, 2)).norm(), 1e-14);
}

TEST(constraints, InconsistentConstraintsAreDiagnosed) {
  SystemDescription d;
  d.gravity = Vec3(0, 0, -g);
  d.bodies.push_back(particle("p", Vec3(0, 0, -1), 1.0));
  d.constraints.push_back(distance("left", {0, Vec3::Zero()}, {-1, Vec3(-5, 0, 0)}, 1.0));
  d.constraints.push_back(distance("right", {0, Vec3::Zero()}, {-1, Vec3(5, 0, 0)}, 1.0));
  const System s(d);
  try {
    find_equilibrium(s, s.initial_configuration(), {.starts = 8});
    FAIL() << "expected NumericalError";
  } catch (const NumericalError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("constraints cannot all be satisfied"), std::string::npos) << what;
    EXPECT_NE(what.find("m"), std::string::npos);
  }
}

TEST(constraints, LinearizeRefusesAPointOffTheManifold) {
  const System s = particle_pendulum(1.0, 1.0);
  VectorX q = VectorX::Zero(3);
  q[0] = 0.1;  // 0.5 % longer rod
  try {
    linearize(s, q);
    FAIL();
  } catch (const NotAnEquilibrium& e) {
    EXPECT_NE(std::string(e.what()).find("does not satisfy the constraints"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'rod'"), std::string::npos) << e.what();
  }
}

}  // namespace
