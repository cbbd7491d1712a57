// Scenes written in a steadily rotating frame (frame_rotation = Ω):
//  - V_eff = V − T₀ with T₀ = ½ Σ_b [m|Ω × x|² + Ωᵀ R I Rᵀ Ω] computed here from the poses;
//  - its tree-structured gradient and Hessian against nested forward AD through
//    the templated potential (1e-12) and against central differences;
//  - the frame coupling g against Σ_b J_vᵀ m (Ω × x) + J_ωᵀ R I Rᵀ Ω from AD
//    Jacobians of the bodies; G skew and against central differences of g;
//  - closed forms: a particle on two slides in a rotating plane (G = 2mΩ[[0,−1],[1,0]],
//    K = (k − mΩ²)I, accelerations with the Coriolis force, frequencies ω₀ ± Ω, gyroscopic
//    stabilization for Ω > ω₀) and a spherical pendulum with a spinning inertia
//    (G_xy = −Ω(2A − C), K = mgl − Ω²(A − C));
//  - R7 (docs/design.md, section 2) through the whole library: both branches, the top, and
//    the switch at Ω² = g/R found by modal::sweep to 1e-10;
//  - the Jacobi integral ½q̇ᵀMq̇ + V − T₀ conserved to 1e-9 by rk8pd.
#include "modal/core.hpp"
#include "modal/equilibrium.hpp"
#include "modal/linearize.hpp"
#include "modal/modes.hpp"
#include "modal/scene.hpp"
#include "modal/sweep.hpp"

#include "checks.hpp"
#include "systems.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace {

using namespace modal;
using test::max_abs;
using test::random_state;

// A copy of `t` written in a frame rotating at Omega; dampers removed when `conservative`.
System with_rotation(const System& t, const Vec3& Omega, bool conservative = false) {
  SystemDescription d;
  d.gravity = t.gravity();
  d.bodies = t.bodies();
  d.springs = t.springs();
  d.loads = t.loads();
  d.followers = t.followers();
  d.frame_rotation = Omega;
  if (conservative) {
    for (Body& b : d.bodies) b.damping = 0;
    for (Spring& s : d.springs) s.damping = 0;
  }
  return System(d);
}

const Vec3 kOmega(0.7, -0.4, 1.3);

System rotating_tree() { return with_rotation(test::everything_tree(), kOmega); }

TEST(Frame, DescriptionAndAccessors) {
  const System plain = test::everything_tree();
  EXPECT_FALSE(plain.rotating());
  EXPECT_EQ(plain.frame_rotation(), Vec3::Zero());
  const System s = rotating_tree();
  EXPECT_TRUE(s.rotating());
  EXPECT_EQ(s.frame_rotation(), kOmega);
  Workspace w(plain);
  const VectorX q = VectorX::Zero(plain.size());
  EXPECT_EQ(frame_coupling(plain, w, q), VectorX::Zero(plain.size()));
  EXPECT_EQ(gyroscopic_matrix(plain, w, q), MatrixX::Zero(plain.size(), plain.size()));
  SystemDescription bad;
  bad.frame_rotation = Vec3(0, 0, std::nan(""));
  EXPECT_THROW(System{bad}, std::invalid_argument);
}

TEST(Frame, PotentialIsVMinusCentrifugalEnergy) {
  const System plain = test::everything_tree(), s = rotating_tree();
  Workspace wp(plain), w(s);
  std::mt19937 rng(5);
  for (int trial = 0; trial < 3; ++trial) {
    const VectorX q = random_state(s, rng, 1.0);
    const std::vector<Pose> poses = body_poses(s, w, q);
    double T0 = 0;
    for (std::size_t b = 0; b < s.bodies().size(); ++b) {
      const Body& body = s.bodies()[b];
      const Vec3 x = poses[b].position + poses[b].rotation * body.com;
      const Vec3 wb = poses[b].rotation.transpose() * kOmega;  // Ω in body axes
      T0 += 0.5 * (body.mass * kOmega.cross(x).squaredNorm() + wb.dot(body.inertia * wb));
    }
    EXPECT_NEAR(potential(s, w, q), potential(plain, wp, q) - T0, 1e-13 * (std::abs(T0) + 1));
  }
}

TEST(Frame, TreeStructuredDerivativesMatchNestedAD) {
  // The centrifugal elements (a point at each centre of mass, three body-fixed
  // directions for each inertia) go through the same accumulation as every other
  // element: the tree result and the nested-AD oracle differ by rounding only.
  const System s = rotating_tree();
  Workspace w(s);
  std::mt19937 rng(7);
  for (int trial = 0; trial < 5; ++trial) {
    const VectorX q = random_state(s, rng, trial == 0 ? 0.0 : 1.2);  // includes φ = 0 (series branch)
    const test::Oracle o = test::nested_ad(s, q);
    const VectorX& g = potential_gradient(s, w, q);
    EXPECT_LE((g - o.gradient).cwiseAbs().maxCoeff(), 1e-12 * max_abs(o.gradient)) << "trial " << trial;
    const MatrixX& H = potential_hessian(s, w, q);
    EXPECT_LE(max_abs(H - o.hessian), 1e-12 * max_abs(o.hessian)) << "trial " << trial << "\nH\n" << H << "\noracle\n" << o.hessian;
    EXPECT_LE(max_abs(H - H.transpose()), 1e-14 * max_abs(H));
  }
}

TEST(Frame, CentrifugalPartAloneMatchesNestedAD) {
  // No gravity, springs, loads or joint springs: only −T₀ (so that a mistake in
  // it cannot hide below the other terms).
  const System t = test::everything_tree();
  SystemDescription d;
  d.gravity = Vec3::Zero();
  d.bodies = t.bodies();
  for (Body& b : d.bodies) b.stiffness = 0;
  d.frame_rotation = Vec3(-1.1, 0.5, 2.0);
  const System s(d);
  Workspace w(s);
  std::mt19937 rng(8);
  for (int trial = 0; trial < 3; ++trial) {
    const VectorX q = random_state(s, rng, 1.5);
    const test::Oracle o = test::nested_ad(s, q);
    EXPECT_LE((potential_gradient(s, w, q) - o.gradient).cwiseAbs().maxCoeff(), 1e-12 * max_abs(o.gradient));
    EXPECT_LE(max_abs(potential_hessian(s, w, q) - o.hessian), 1e-12 * max_abs(o.hessian));
  }
}

TEST(Frame, DerivativesMatchCentralDifferences) {
  test::expect_derivatives_match_central_differences(rotating_tree(), 11);
}

TEST(Frame, CouplingMatchesBodyJacobians) {
  // T = Σ_b ½m|J_v q̇ + Ω × x|² + ½(J_ω q̇ + Ω)ᵀ R I Rᵀ (J_ω q̇ + Ω): the part linear in q̇ is q̇ᵀg.
  const System s = rotating_tree();
  Workspace w(s);
  std::mt19937 rng(3);
  for (int trial = 0; trial < 3; ++trial) {
    const VectorX q = random_state(s, rng, 1.0);
    const test::BodyJacobians J = test::body_jacobians(s, q);
    VectorX g_ref = VectorX::Zero(s.size());
    for (std::size_t b = 0; b < s.bodies().size(); ++b) {
      const Body& body = s.bodies()[b];
      const Mat3 Iw = J.st.rotation[b] * body.inertia * J.st.rotation[b].transpose();
      g_ref += body.mass * J.Jv[b].transpose() * kOmega.cross(J.com[b]) + J.Jw[b].transpose() * Iw * kOmega;
    }
    EXPECT_LE((frame_coupling(s, w, q) - g_ref).cwiseAbs().maxCoeff(), 1e-13 * g_ref.cwiseAbs().maxCoeff());
  }
}

TEST(Frame, GyroscopicMatrixIsSkewAndMatchesCentralDifferences) {
  const System s = rotating_tree();
  Workspace w(s);
  std::mt19937 rng(19);
  const VectorX q = random_state(s, rng, 1.0);
  const MatrixX G = gyroscopic_matrix(s, w, q);
  EXPECT_GT(max_abs(G), 0.1);
  EXPECT_EQ(max_abs(G + G.transpose()), 0.0);
  const double h = 1e-5;
  MatrixX J(s.size(), s.size());  // J_ik = ∂g_i/∂q_k
  for (int k = 0; k < s.size(); ++k) {
    VectorX qp = q, qm = q;
    qp[k] += h;
    qm[k] -= h;
    J.col(k) = (frame_coupling(s, w, qp) - frame_coupling(s, w, qm)) / (2 * h);
  }
  EXPECT_LE(max_abs(G - (J - J.transpose())), 1e-8 * max_abs(G));
}

// A particle of mass m on two slides (x, then y on it) with joint springs k, in
// a plane rotating at Ω about z, no gravity.
System rotating_particle(double m, double k, double Omega) {
  SystemDescription d;
  d.gravity = Vec3::Zero();
  d.frame_rotation = Vec3(0, 0, Omega);
  Body x;
  x.name = "x";
  x.joint = JointType::slide;
  x.axis = Vec3::UnitX();
  x.stiffness = k;
  Body y = x;
  y.name = "y";
  y.parent = 0;
  y.axis = Vec3::UnitY();
  y.mass = m;
  d.bodies = {x, y};
  return System(d);
}

TEST(Frame, ParticleInARotatingPlane) {
  // Inertial velocity (ẋ − Ωy, ẏ + Ωx): T = ½m(ẋ² + ẏ²) + mΩ(xẏ − yẋ) + ½mΩ²(x² + y²),
  // g = mΩ(−y, x), G_ij = ∂g_i/∂q_j − ∂g_j/∂q_i = 2mΩ[[0, −1], [1, 0]], so that
  // m ẍ − 2mΩẏ + (k − mΩ²)x = 0: the Coriolis force −2mΩ × ẋ has x-component +2mΩẏ.
  const double m = 1.5, k = 6.0, Omega = 0.8;
  const System s = rotating_particle(m, k, Omega);
  Workspace w(s);
  const VectorX q = Eigen::Vector2d(0.3, -0.2), qd = Eigen::Vector2d(0.5, 0.7);
  Eigen::Matrix2d G_exact;
  G_exact << 0, -2 * m * Omega, 2 * m * Omega, 0;
  EXPECT_LE(max_abs(gyroscopic_matrix(s, w, q) - G_exact), 1e-15);
  EXPECT_LE((frame_coupling(s, w, q) - m * Omega * Eigen::Vector2d(-q[1], q[0])).norm(), 1e-15);
  EXPECT_LE(max_abs(potential_hessian(s, w, q) - (k - m * Omega * Omega) * MatrixX::Identity(2, 2)), 1e-14);
  const Eigen::Vector2d a_exact((2 * m * Omega * qd[1] + (m * Omega * Omega - k) * q[0]) / m,
                                (-2 * m * Omega * qd[0] + (m * Omega * Omega - k) * q[1]) / m);
  EXPECT_LE((accelerations(s, w, q, qd) - a_exact).norm(), 1e-14);

  // About the equilibrium at the origin: z = x + iy obeys z̈ + 2iΩż + (ω₀² − Ω²)z = 0,
  // s = i(−Ω ± ω₀): frequencies |ω₀ ± Ω|, all motions bounded even when Ω > ω₀
  // (K negative definite, Morse index 2, gyroscopically stabilized).
  for (const double spin : {0.8, 3.5}) {
    const System r = rotating_particle(m, k, spin);
    const LinearModel lin = linearize(r, VectorX::Zero(2));
    EXPECT_TRUE(lin.has_gyroscopic);
    EXPECT_LE(max_abs(lin.G - 2 * m * spin * Eigen::Matrix2d{{0, -1}, {1, 0}}), 1e-15);
    const ModalResult modes = solve_modes(lin);
    const double w0 = std::sqrt(k / m);
    std::vector<double> omegas;
    for (const Mode& mode : modes.modes) omegas.push_back(mode.omega);
    std::sort(omegas.begin(), omegas.end());
    ASSERT_EQ(omegas.size(), 2u);
    EXPECT_NEAR(omegas[0], std::abs(w0 - spin), 1e-12 * (w0 + spin)) << "Ω = " << spin;
    EXPECT_NEAR(omegas[1], w0 + spin, 1e-12 * (w0 + spin)) << "Ω = " << spin;
    EXPECT_EQ(modes.stability, Stability::stable) << "Ω = " << spin;
  }
}

TEST(Frame, SphericalPendulumSpinningAboutTheVertical) {
  // Ball joint at the origin, mass m at (0, 0, −l) with inertia diag(I₁, I₁, I₃)
  // about it, frame spinning at Ω about z. At the bottom (φ = 0), with A = ml² + I₁
  // and C = I₃: M = diag(A, A, C); the centrifugal potential
  // −½Ω²[ml²(φx² + φy²) + I₃ + (I₁ − I₃)(φx² + φy²)] gives K = diag(mgl − Ω²(A − C), same, 0);
  // g = J_lᵀ R I Rᵀ Ω + m Jᵀ(Ω × x) to first order in φ gives
  // G = [[0, −Ω(2A − C), 0], [Ω(2A − C), 0, 0], [0, 0, 0]].
  const double m = 2.0, l = 0.8, g = 9.81, I1 = 0.05, I3 = 0.08, Omega = 1.7;
  SystemDescription d;
  d.gravity = Vec3(0, 0, -g);
  d.frame_rotation = Vec3(0, 0, Omega);
  Body bob;
  bob.name = "bob";
  bob.joint = JointType::ball;
  bob.mass = m;
  bob.com = Vec3(0, 0, -l);
  bob.inertia = Vec3(I1, I1, I3).asDiagonal();
  d.bodies = {bob};
  const System s(d);
  const double A = m * l * l + I1, C = I3;
  const LinearModel lin = linearize(s, VectorX::Zero(3));
  const Eigen::Matrix3d M_exact = Vec3(A, A, C).asDiagonal();
  const Eigen::Matrix3d K_exact = Vec3(m * g * l - Omega * Omega * (A - C), m * g * l - Omega * Omega * (A - C), 0).asDiagonal();
  Eigen::Matrix3d G_exact = Eigen::Matrix3d::Zero();
  G_exact(0, 1) = -Omega * (2 * A - C);
  G_exact(1, 0) = Omega * (2 * A - C);
  EXPECT_LE(max_abs(lin.M - M_exact), 1e-15);
  EXPECT_LE(max_abs(lin.K - K_exact), 1e-13 * m * g * l);
  EXPECT_LE(max_abs(lin.G - G_exact), 1e-14 * Omega * A);
  EXPECT_TRUE(lin.has_gyroscopic);
  EXPECT_FALSE(lin.symmetric());
}

// --- R7: bead on a hoop ---------------------------------------------------------

std::string model_path() { return std::string(MODAL_SOURCE_DIR) + "/models/bead_on_hoop_frame.toml"; }

// --set Omega=… with every digit of the value.
std::vector<ParameterOverride> spin(double Omega) {
  std::ostringstream value;
  value.precision(17);
  value << Omega;
  return {ParameterOverride{"Omega", value.str()}};
}

struct Branch {
  double theta = 0;
  LinearModel lin;
  ModalResult modes;
};
Branch analyze_bead(double Omega, double start) {
  const System s = build_system(load_scene(model_path(), spin(Omega)));
  Branch b;
  b.theta = find_equilibrium(s, VectorX::Constant(1, start)).q[0];
  b.lin = linearize(s, VectorX::Constant(1, b.theta));
  b.modes = solve_modes(b.lin);
  return b;
}

TEST(Frame, BeadOnHoopBothBranches) {
  const double g = 9.81, R = 1.0;  // the model's defaults
  for (const double Omega : {0.5, 2.0, 3.0, 3.2, 4.0, 6.0}) {
    SCOPED_TRACE("Omega = " + std::to_string(Omega));
    // Bottom: ω² = g/R − Ω² (stable below the switch, divergence above).
    const Branch bottom = analyze_bead(Omega, 0.05);
    EXPECT_NEAR(bottom.theta, 0.0, 1e-12);
    EXPECT_FALSE(bottom.lin.has_gyroscopic);  // one coordinate: G = 0, symmetric solver
    ASSERT_EQ(bottom.modes.modes.size(), 1u);
    const double bottom2 = g / R - Omega * Omega;
    EXPECT_NEAR(bottom.modes.modes[0].omega2, bottom2, 1e-12 * std::abs(bottom2));
    EXPECT_EQ(bottom.modes.stability, bottom2 > 0 ? Stability::stable : Stability::divergence);
    // Top: ω² = −g/R − Ω², always unstable.
    const Branch top = analyze_bead(Omega, 3.0);
    EXPECT_NEAR(std::abs(top.theta), std::numbers::pi, 1e-12);
    EXPECT_NEAR(top.modes.modes[0].omega2, -g / R - Omega * Omega, 1e-12 * (g / R + Omega * Omega));
    EXPECT_EQ(top.modes.stability, Stability::divergence);
    // Off-axis, for Ω² > g/R: cos θ₀ = g/(RΩ²), ω² = Ω² − g²/(R²Ω²).
    if (Omega * Omega > g / R) {
      const double theta0 = std::acos(g / (R * Omega * Omega));
      for (const double side : {1.0, -1.0}) {
        const Branch off = analyze_bead(Omega, side * (theta0 + 0.05));
        EXPECT_NEAR(off.theta, side * theta0, 1e-12);
        const double off2 = Omega * Omega - g * g / (R * R * Omega * Omega);
        EXPECT_NEAR(off.modes.modes[0].omega2, off2, 1e-12 * off2);
        EXPECT_EQ(off.modes.stability, Stability::stable);
      }
    }
  }
}

TEST(Frame, BeadOnHoopSwitchBySweep) {
  std::ifstream in(model_path());
  std::stringstream text;
  text << in.rdbuf();
  const SweepResult r = sweep(text.str(), model_path(), {}, parse_vary("Omega=0:6:61"));
  ASSERT_EQ(r.critical.size(), 1u);
  const CriticalValue& c = r.critical[0];
  const double exact = std::sqrt(9.81 / 1.0);
  EXPECT_EQ(c.kind, CriticalKind::divergence);
  EXPECT_EQ(c.before, Stability::stable);
  EXPECT_EQ(c.after, Stability::divergence);
  EXPECT_TRUE(c.refined);
  EXPECT_LE(std::abs(c.value - exact), 1e-10 * exact);
  EXPECT_LE(std::abs(c.value - exact), c.error + 1e-15);
}

// --- Jacobi integral ---------------------------------------------------------------

TEST(Frame, JacobiIntegralIsConservedForAThreeDimensionalTree) {
  const System s = with_rotation(test::everything_tree(), kOmega, true);
  std::mt19937 rng(17);
  const double drift = test::energy_drift(s, random_state(s, rng, 0.3), random_state(s, rng, 0.5), 3.0);
  EXPECT_LE(drift, 1e-9);
}

TEST(Frame, JacobiIntegralIsConservedForTheBead) {
  // Ω = 5: ω² ≈ 21.15 about θ₀, period ≈ 1.37 s; 10 periods from a large swing.
  const System s = build_system(load_scene(model_path(), spin(5.0)));
  const double drift = test::energy_drift(s, VectorX::Constant(1, 0.4), VectorX::Constant(1, 1.0), 14.0);
  EXPECT_LE(drift, 1e-9);
}

TEST(Frame, JacobiIntegralIsConservedForASpinningTop) {
  // A heavy body on a ball joint with unequal inertias in a rotating frame:
  // gyroscopic, centrifugal and Coriolis terms all act.
  SystemDescription d;
  d.gravity = Vec3(0, 0, -9.81);
  d.frame_rotation = Vec3(0.3, 0.2, 2.5);
  Body top;
  top.name = "top";
  top.joint = JointType::ball;
  top.mass = 1.2;
  top.com = Vec3(0.05, 0, -0.7);
  top.inertia = Vec3(0.04, 0.06, 0.09).asDiagonal();
  d.bodies = {top};
  const System s(d);
  const double drift = test::energy_drift(s, Eigen::Vector3d(0.4, -0.3, 0.2), Eigen::Vector3d(1.0, 0.5, -2.0), 10.0);
  EXPECT_LE(drift, 1e-9);
}

}  // namespace
