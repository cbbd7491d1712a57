// Follower loads (circulatory forces) through every stage:
//  - the core's Q(q) and its exact Jacobian ∂Q/∂q on a 3-D tree with follower
//    loads behind hinge, ball, free and slide joints, against central
//    differences and against the definition Qᵀq̇ = Σ f·ẋ (ẋ by forward AD);
//  - Ziegler's pendulum (docs/design.md R6): M, K, the circulatory flag, and the
//    modes on both sides of the flutter load;
//  - the discrete Euler column (R5): its buckling load (4k/a) sin²(π/(4N+2)),
//    checked first against an independently assembled stiffness matrix and then
//    against modal's K and stability class;
//  - an equilibrium that only a follower load explains, found by find_equilibria;
//  - "<chain>.tip" in scenes.
#include "modal/equilibrium.hpp"
#include "modal/linearize.hpp"
#include "modal/modes.hpp"
#include "modal/scene.hpp"

#include "core/model.hpp"

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <string>

namespace {

using namespace modal;

double max_abs(const MatrixX& A) { return A.cwiseAbs().maxCoeff(); }

std::string model_path(const std::string& name) { return std::string(MODAL_SOURCE_DIR) + "/models/" + name; }

System scene_system(const std::string& name, const std::vector<ParameterOverride>& set = {}) {
  return build_system(load_scene(model_path(name), set));
}

std::string number(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

// A 3-D tree: hinge → ball → slide, and a free body on the hinge; follower
// loads on every body (so each sits behind a hinge, a ball, a slide or a free
// joint), plus gravity, a joint spring and a dead load so that Q is not all
// there is (they must not leak into Q).
System follower_tree() {
  SystemDescription d;
  d.gravity = Vec3(0.1, 0.2, -9.81);
  Body base;
  base.name = "base";
  base.joint = JointType::hinge;
  base.axis = Vec3(0.2, 1, 0.1).normalized();
  base.origin = Vec3(0.1, 0, 0);
  base.mass = 1.2;
  base.com = Vec3(0.2, 0.1, -0.8);
  base.stiffness = 3;
  d.bodies.push_back(base);
  Body ball;
  ball.name = "ball";
  ball.parent = 0;
  ball.joint = JointType::ball;
  ball.origin = Vec3(0.1, 0.2, -1.0);
  ball.mass = 0.7;
  ball.com = Vec3(0.05, -0.1, -0.6);
  d.bodies.push_back(ball);
  Body slide;
  slide.name = "slider";
  slide.parent = 1;
  slide.joint = JointType::slide;
  slide.axis = Vec3(1, 0.3, -0.2).normalized();
  slide.origin = Vec3(0, 0, -0.7);
  slide.mass = 0.4;
  d.bodies.push_back(slide);
  Body flyer;
  flyer.name = "flyer";
  flyer.parent = 0;
  flyer.joint = JointType::free;
  flyer.origin = Vec3(0.5, 0, -0.5);
  flyer.mass = 0.9;
  flyer.inertia = Vec3(0.04, 0.05, 0.03).asDiagonal();
  d.bodies.push_back(flyer);
  d.loads.push_back({{1, Vec3(0.2, 0.1, 0)}, Vec3(1.5, -0.5, 0.7)});
  d.followers.push_back({{0, Vec3(0.3, -0.2, -1.1)}, Vec3(0.8, 0.4, -1.3)});   // behind a hinge
  d.followers.push_back({{1, Vec3(-0.2, 0.3, -0.5)}, Vec3(-0.6, 1.1, 0.9)});   // behind a ball
  d.followers.push_back({{2, Vec3(0.1, 0.1, 0.2)}, Vec3(0.5, -0.7, 0.2)});     // behind a slide
  d.followers.push_back({{3, Vec3(0.15, -0.05, 0.25)}, Vec3(-1.2, 0.3, 0.6)}); // behind a free joint
  d.followers.push_back({{3, Vec3(0, 0, 0)}, Vec3(0.2, 0.2, -0.4)});           // at the free body's origin
  return System(d);
}

VectorX random_state(const System& s, std::mt19937& rng, double spread) {
  std::uniform_real_distribution<double> u(-spread, spread);
  VectorX q(s.size());
  for (int i = 0; i < s.size(); ++i) q[i] = u(rng);
  return q;
}

TEST(Follower, ForceJacobianMatchesCentralDifferences) {
  const System s = follower_tree();
  ASSERT_TRUE(s.has_follower_loads());
  ASSERT_FALSE(s.has_damping());
  Workspace w(s);
  std::mt19937 rng(7);
  const VectorX zero = VectorX::Zero(s.size());
  for (int trial = 0; trial < 5; ++trial) {
    const VectorX q = random_state(s, rng, trial == 0 ? 0.0 : 0.9);  // q = 0 too: the series branch of J_l
    const MatrixX A = generalized_force_jacobian(s, w, q);
    // Central differences with h = 1e-5: truncation h²/6·|Q'''| ~ 1e-11 and
    // rounding ε|Q|/h ~ 1e-11 for forces and lever arms of order 1, so 1e-7
    // relative to the largest entry leaves four orders of margin while still
    // catching any missing term (each is of order 1).
    const double h = 1e-5;
    MatrixX fd(s.size(), s.size());
    for (int k = 0; k < s.size(); ++k) {
      VectorX qp = q, qm = q;
      qp[k] += h;
      qm[k] -= h;
      fd.col(k) = (generalized_forces(s, w, qp, zero) - generalized_forces(s, w, qm, zero)) / (2 * h);
    }
    EXPECT_LE(max_abs(A - fd), 1e-7 * max_abs(fd)) << "trial " << trial << "\nA\n" << A << "\nfd\n" << fd;
    // Circulatory: the Jacobian is genuinely non-symmetric.
    EXPECT_GT(max_abs(A - A.transpose()), 1e-3 * max_abs(A)) << "trial " << trial;
  }
}

TEST(Follower, GeneralizedForcesDoThePowerOfTheFollowerForces) {
  // Qᵀq̇ = Σ f·ẋ with f = R_b f_body and ẋ the exact velocity of the load point
  // (forward AD of the templated forward kinematics along q̇): the definition of Q.
  const System s = follower_tree();
  Workspace w(s);
  std::mt19937 rng(11);
  using D = Dual<double, 1>;
  for (int trial = 0; trial < 5; ++trial) {
    const VectorX q = random_state(s, rng, 1.0), qd = random_state(s, rng, 1.0);
    model::VX<D> qdual(s.size());
    for (int i = 0; i < s.size(); ++i) {
      qdual[i] = D(q[i]);
      qdual[i].d[0] = qd[i];
    }
    model::TreeState<D> st;
    model::forward_kinematics(s, qdual.data(), st);
    double power = 0, scale = 0;
    for (const FollowerLoad& l : s.followers()) {
      const model::V3<D> x = model::world_point(st, l.at);
      const auto b = static_cast<std::size_t>(l.at.body);
      for (int i = 0; i < 3; ++i) {
        double fi = 0;
        for (int j = 0; j < 3; ++j) fi += st.rotation[b](i, j).v * l.force[j];
        power += fi * x[i].d[0];
        scale += std::abs(fi * x[i].d[0]);
      }
    }
    const VectorX Q = generalized_forces(s, w, q, qd);
    EXPECT_NEAR(Q.dot(qd), power, 1e-13 * scale) << "trial " << trial;
  }
}

TEST(Follower, DampersAndFollowersAddUp) {
  const System plain = follower_tree();
  SystemDescription d;
  d.gravity = plain.gravity();
  d.bodies = plain.bodies();
  d.loads = plain.loads();
  d.followers = plain.followers();
  d.bodies[0].damping = 0.5;
  d.bodies[1].damping = 0.25;
  const System damped(d);
  Workspace w1(plain), w2(damped);
  std::mt19937 rng(3);
  const VectorX q = random_state(plain, rng, 0.8), qd = random_state(plain, rng, 0.8);
  const VectorX expected = generalized_forces(plain, w1, q, VectorX::Zero(plain.size())) - damping_matrix(damped, w2, q) * qd;
  EXPECT_LE((generalized_forces(damped, w2, q, qd) - expected).lpNorm<Eigen::Infinity>(), 1e-14 * expected.norm());
}

TEST(Follower, SystemRejectsAFollowerLoadOnTheWorld) {
  SystemDescription d;
  Body b;
  b.name = "p";
  b.mass = 1;
  d.bodies.push_back(b);
  d.followers.push_back({{-1, Vec3::Zero()}, Vec3(1, 0, 0)});
  EXPECT_THROW(System{d}, std::invalid_argument);
  d.followers[0] = {{0, Vec3::Zero()}, Vec3(std::nan(""), 0, 0)};
  EXPECT_THROW(System{d}, std::invalid_argument);
}

// --- Ziegler's pendulum (R6) ------------------------------------------------

struct Ziegler {
  double m, l, k;
  // Absolute-angle matrices of R6 and the map θ = T φ to modal's relative angles.
  MatrixX T() const { return (MatrixX(2, 2) << 1, 0, 1, 1).finished(); }
  MatrixX M() const { return m * l * l * (MatrixX(2, 2) << 3, 1, 1, 1).finished(); }
  MatrixX K(double P) const { return (MatrixX(2, 2) << 2 * k - P * l, -k + P * l, -k, k).finished(); }
};

TEST(Follower, ZieglerMatricesMatchR6) {
  for (const auto& [m, l, k] : {std::tuple{1.0, 1.0, 1.0}, std::tuple{2.5, 0.7, 3.0}}) {
    const Ziegler z{m, l, k};
    for (const double p : {0.0, 0.5, 2.0, 3.7}) {
      const double P = p * k / l;
      const System s = scene_system("ziegler.toml", {{"m", number(m)}, {"l", number(l)}, {"k", number(k)}, {"P", number(P)}});
      ASSERT_TRUE(s.has_follower_loads());
      const LinearModel lm = linearize(s, VectorX::Zero(2));
      EXPECT_TRUE(lm.circulatory);
      EXPECT_FALSE(lm.symmetric());
      const MatrixX Mphi = z.T().transpose() * z.M() * z.T();
      const MatrixX Kphi = z.T().transpose() * z.K(P) * z.T();
      EXPECT_LE(max_abs(lm.M - Mphi), 1e-12 * max_abs(Mphi)) << "p = " << p << "\n" << lm.M;
      EXPECT_LE(max_abs(lm.K - Kphi), 1e-12 * max_abs(Kphi)) << "p = " << p << "\n" << lm.K << "\nR6\n" << Kphi;
      EXPECT_EQ(lm.D.size(), 0);  // no dampers: empty
    }
  }
}

TEST(Follower, ZieglerFluttersAtSevenHalvesMinusRootTwo) {
  const double m = 1.5, l = 0.8, k = 2.0;
  const double unit = k / (m * l * l);  // ω² = λ k/(m l²)
  const double p_cr = 3.5 - std::sqrt(2.0);
  for (const double p : {0.0, 1.0, 2.0, 0.999 * p_cr, 1.001 * p_cr, 2.5, 3.0, 4.0}) {
    const System s = scene_system("ziegler.toml", {{"m", number(m)}, {"l", number(l)}, {"k", number(k)}, {"P", number(p * k / l)}});
    const LinearModel lm = linearize(s, VectorX::Zero(2));
    const ModalResult r = solve_modes(lm);
    ASSERT_EQ(r.modes.size(), 2u) << "p = " << p;
    EXPECT_EQ(r.morse_index, 0) << "p = " << p;  // no divergence at any p ≤ 4
    for (const Mode& mode : r.modes) EXPECT_NE(mode.kind, ModeKind::divergent) << "p = " << p;
    // 2λ² + (2p − 7)λ + 1 = 0
    const double b = 2 * p - 7, disc = b * b - 8;
    if (p < p_cr) {
      EXPECT_EQ(r.stability, Stability::stable) << "p = " << p;
      const double lam1 = (-b - std::sqrt(disc)) / 4, lam2 = (-b + std::sqrt(disc)) / 4;
      EXPECT_NEAR(r.modes[0].omega, std::sqrt(lam1 * unit), 1e-9 * std::sqrt(lam2 * unit)) << "p = " << p;
      EXPECT_NEAR(r.modes[1].omega, std::sqrt(lam2 * unit), 1e-9 * std::sqrt(lam2 * unit)) << "p = " << p;
      for (const Mode& mode : r.modes) {
        EXPECT_EQ(mode.kind, ModeKind::oscillatory) << "p = " << p;
        EXPECT_LE(std::abs(mode.growth_rate), 1e-9 * mode.omega);
      }
    } else {
      EXPECT_EQ(r.stability, Stability::flutter) << "p = " << p;
      // λ = (−b ± i√−disc)/4, s² = −λ k/(m l²): one pair with σ > 0.
      const std::complex<double> lam((-b) / 4, std::sqrt(-disc) / 4);
      std::complex<double> s_exact = std::sqrt(-lam * unit);
      if (s_exact.real() < 0) s_exact = -s_exact;
      if (s_exact.imag() < 0) s_exact = std::conj(s_exact);
      bool found = false;
      for (const Mode& mode : r.modes)
        if (mode.kind == ModeKind::flutter) {
          found = true;
          EXPECT_GT(mode.growth_rate, 0.0);
          EXPECT_NEAR(std::abs(mode.s - s_exact), 0.0, 1e-8 * std::abs(s_exact)) << "p = " << p << " s = " << mode.s;
        }
      EXPECT_TRUE(found) << "p = " << p;
    }
  }
}

TEST(Follower, DampedZieglerHasTheDampersOnTheHinges) {
  const System s = scene_system("ziegler_damped.toml", {{"P", "1"}});
  ASSERT_TRUE(s.has_damping());
  const LinearModel lm = linearize(s, VectorX::Zero(2));
  const double c = 0.01;  // 0.01·sqrt(k m l²) with the defaults
  EXPECT_LE(max_abs(lm.D - c * MatrixX::Identity(2, 2)), 1e-15);
  EXPECT_TRUE(lm.circulatory);
  const ModalResult r = solve_modes(lm);
  EXPECT_EQ(r.stability, Stability::asymptotically_stable);  // p = 1: below any flutter load
}

// --- Euler column (R5) -------------------------------------------------------

// (4k/a) sin²(π/(4N+2)), k = EI/a, a = L/N.
double column_buckling_load(int N, double EI, double L) {
  const double a = L / N, k = EI / a, s = std::sin(std::numbers::pi / (4 * N + 2));
  return 4 * k / a * s * s;
}

TEST(Follower, DiscreteColumnBucklingFormula) {
  // Independent of modal: in absolute link angles θ (θ_0 = 0 at the clamp) the
  // dead-loaded column has V = ½k Σ(θ_i − θ_{i−1})² + P a Σ cos θ_i, so
  // ∇∇V(0) = k BᵀB − P a I with B the first-difference matrix. P_cr is the
  // lowest eigenvalue of BᵀB times k/a; the formula says it is 4 sin²(π/(4N+2)).
  for (const int N : {1, 2, 3, 5, 20, 100}) {
    MatrixX B = MatrixX::Identity(N, N);
    for (int i = 1; i < N; ++i) B(i, i - 1) = -1;
    const Eigen::SelfAdjointEigenSolver<MatrixX> eig(B.transpose() * B);
    const double s = std::sin(std::numbers::pi / (4 * N + 2));
    EXPECT_NEAR(eig.eigenvalues()[0], 4 * s * s, 1e-13) << "N = " << N;
  }
  // N = 2 is R5's two-link column; large N tends to Euler's π²EI/(4L²).
  EXPECT_NEAR(column_buckling_load(2, 1.0, 2.0), (3 - std::sqrt(5.0)) / 2, 1e-15);  // k = EI/a = 1, l = a = 1
  const double euler = std::numbers::pi * std::numbers::pi / 4;
  EXPECT_NEAR(column_buckling_load(2000, 1, 1), euler, 1e-3 * euler);
}

TEST(Follower, EulerColumnBucklesAtTheDiscreteLoad) {
  for (const int N : {2, 5, 20}) {
    const double EI = 1.3, L = 1.7;
    const double P_cr = column_buckling_load(N, EI, L);
    auto model_at = [&](double P) {
      const System s = scene_system("euler_column.toml", {{"N", std::to_string(N)}, {"EI", number(EI)},
                                                          {"L", number(L)}, {"P", number(P)}});
      EXPECT_FALSE(s.has_follower_loads());
      return linearize(s, VectorX::Zero(N));
    };
    auto lowest = [](const MatrixX& K) { return Eigen::SelfAdjointEigenSolver<MatrixX>(K).eigenvalues()[0]; };
    const LinearModel below = model_at(P_cr * (1 - 1e-6)), at = model_at(P_cr), above = model_at(P_cr * (1 + 1e-6));
    const double kscale = max_abs(at.K);
    EXPECT_GT(lowest(below.K), 0.0) << "N = " << N;
    EXPECT_LT(lowest(above.K), 0.0) << "N = " << N;
    EXPECT_LE(std::abs(lowest(at.K)), 1e-12 * kscale) << "N = " << N;
    EXPECT_FALSE(at.circulatory);
    EXPECT_EQ(solve_modes(model_at(0.98 * P_cr)).stability, Stability::stable) << "N = " << N;
    const ModalResult r = solve_modes(model_at(1.02 * P_cr));
    EXPECT_EQ(r.stability, Stability::divergence) << "N = " << N;
    EXPECT_EQ(r.morse_index, 1) << "N = " << N;
  }
}

TEST(Follower, ChainTipNamesTheLastLink) {
  for (const int N : {1, 4, 10}) {
    for (const char* file : {"euler_column.toml", "follower_column.toml"}) {
      const System s = scene_system(file, {{"N", std::to_string(N)}});
      const std::size_t count = s.loads().size() + s.followers().size();
      ASSERT_EQ(count, 1u);
      const int body = s.loads().empty() ? s.followers()[0].at.body : s.loads()[0].at.body;
      EXPECT_EQ(s.bodies()[static_cast<std::size_t>(body)].name, "column" + std::to_string(N)) << file;
    }
  }
  // Springs too, and a body's own name wins.
  const std::string text =
      "[[chain]]\nname = \"c\"\nlinks = 3\nlength = 3\nmass = 1\n"
      "[[spring]]\na = \"c.tip\"\nb = \"world\"\nstiffness = 1\nrest_length = 0\n";
  const Scene scene = parse_scene(text, "tip.toml");
  EXPECT_EQ(scene.description.springs[0].a.body, 2);
}

TEST(Follower, FollowerColumnIsCirculatoryAndStableUnloaded) {
  const System s = scene_system("follower_column.toml", {{"N", "6"}, {"P", "2"}});
  const LinearModel lm = linearize(s, VectorX::Zero(6));
  EXPECT_TRUE(lm.circulatory);
  // P = 2 is below the Euler load π²/4 of the dead-loaded column, and the
  // follower column is stable there too.
  EXPECT_EQ(solve_modes(lm).stability, Stability::stable);
}

TEST(Follower, FollowerColumnFluttersBelowBecksLoad) {
  // Brackets of the flutter loads modal sweep finds (18.0195 for N = 10,
  // 19.5724 for N = 40, EI = L = 1): the class is stable just below and flutter
  // just above, never divergence, and the load rises towards Beck's continuous
  // 20.05 EI/L² as N grows.
  for (const auto& [N, lo, hi] : {std::tuple{10, 17.95, 18.10}, std::tuple{40, 19.50, 19.65}}) {
    auto at = [&, N = N](double P) {
      const System s = scene_system("follower_column.toml", {{"N", std::to_string(N)}, {"P", number(P)}});
      return solve_modes(linearize(s, VectorX::Zero(N)));
    };
    const ModalResult below = at(lo), above = at(hi);
    EXPECT_EQ(below.stability, Stability::stable) << "N = " << N;
    EXPECT_EQ(above.stability, Stability::flutter) << "N = " << N;
    EXPECT_EQ(above.morse_index, 0) << "N = " << N;
    EXPECT_LT(hi, 20.05);
  }
}

// --- equilibrium -------------------------------------------------------------

TEST(Follower, EquilibriumBalancesAFollowerTorqueAgainstAJointSpring) {
  // A hinge (axis y) with spring k carries a follower force f_b = (F, 0, −G) at
  // r = (d, 0, l) in its body frame; no gravity. Everything turns with the body,
  // so the torque about y is constant: (r × f_b)_y = l F + d G, and the only
  // equilibrium is θ = (l F + d G)/k (+ rest). No potential has it as a
  // minimum of anything: V = ½k θ² alone would put it at θ = rest.
  const double k = 4.0, l = 1.2, d = 0.3, F = 1.5, G = 2.0, rest = 0.1;
  SystemDescription desc;
  desc.gravity = Vec3::Zero();
  Body b;
  b.name = "arm";
  b.mass = 0.5;
  b.com = Vec3(0, 0, l);
  b.stiffness = k;
  b.rest = VectorX::Constant(1, rest);
  desc.bodies.push_back(b);
  desc.followers.push_back({{0, Vec3(d, 0, l)}, Vec3(F, 0, -G)});
  const System s(desc);
  const std::vector<Equilibrium> all = find_equilibria(s);
  ASSERT_EQ(all.size(), 1u);
  const double expected = rest + (l * F + d * G) / k;
  EXPECT_NEAR(all[0].q[0], expected, 1e-12);
  EXPECT_LE(all[0].residual, 1e-12);
  Workspace w(s);
  EXPECT_LE(std::abs(equilibrium_residual(s, w, all[0].q)[0]), 1e-12 * k);
  // ... and linearizes there: K = k (the follower torque does not change with θ).
  const LinearModel lm = linearize(s, all[0].q);
  EXPECT_NEAR(lm.K(0, 0), k, 1e-12 * k);
  EXPECT_THROW(linearize(s, VectorX::Constant(1, rest)), NotAnEquilibrium);
}

TEST(Follower, EquilibriumOfATwoLinkArmUnderATipFollowerForce) {
  // Ziegler's geometry with a follower force perpendicular to the second link,
  // f_b = (F, 0, 0) at its tip (body frame), no gravity. With relative angles
  // φ1, φ2 (absolute θ1 = φ1, θ2 = φ1 + φ2) the tip is l(sin θ1 + sin θ2, ·,
  // cos θ1 + cos θ2) and f = F(cos θ2, ·, −sin θ2), so Q = f·∂x/∂φ gives
  // Q2 = F l and Q1 = F l (1 + cos φ2). Equilibrium: k φ2 = F l, k φ1 = F l (1 + cos φ2).
  const double k = 3.0, l = 1.0, F = 1.1;
  const System s = scene_system("ziegler.toml", {{"k", number(k)}, {"l", number(l)}});
  SystemDescription desc;
  desc.gravity = Vec3::Zero();
  desc.bodies = s.bodies();
  desc.followers.push_back({{1, Vec3(0, 0, l)}, Vec3(F, 0, 0)});
  const System arm(desc);
  const Equilibrium e = find_equilibrium(arm, VectorX::Zero(2));
  const double phi2 = F * l / k, phi1 = F * l * (1 + std::cos(phi2)) / k;
  EXPECT_NEAR(e.q[0], phi1, 1e-12);
  EXPECT_NEAR(e.q[1], phi2, 1e-12);
}

}  // namespace
