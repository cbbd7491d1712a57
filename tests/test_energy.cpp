// The energy distribution and base-excitation participation of modes
// (modal/energy.hpp; docs/design.md, "Energy distribution and participation").
//
// References are independent of modal's energy code: closed-form eigenvectors
// of 2×2 problems (the two-mass, three-spring chain; the double pendulum),
// evaluated in long double, give every share in closed form; for generated
// scenes, the shares' denominators must equal φᵀMφ and φᵀKφ of the linear
// model (M-normalized modes: 1 and λ), and the effective masses must add up to
// L_dᵀM⁻¹L_d with L_d from the potential gradient of gravity along d (a
// different code path: the tree's reverse accumulation) solved in long double.
//
// Tolerances. Shares are ratios of sums of O(10) well-scaled terms formed in
// double: their rounding is a few ε relative to Σ|terms| / |Σ terms|, ≤ 1e-14
// for the positive kinetic terms. The eigenvectors of the 2×2 problems come
// from a backward-stable solver with relative gaps above 0.1, accurate to
// ~1e-14; 1e-10 leaves four orders of margin and still catches any wrong
// element (a share off by a factor, a missing term: errors ≥ 1e-3). Shares sum
// to 1 to 1e-12 × max(1, Σ|shares|): the denominator is the sum itself, so only
// the rounding of n ≤ 50 additions remains (n ε ≈ 1e-14), amplified by
// cancellation when some shares are negative.
#include <gtest/gtest.h>

#include "csv_fields.hpp"
#include "program.hpp"
#include "modal/energy.hpp"
#include "modal/pipeline.hpp"

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <map>
#include <random>
#include <string>
#include <vector>

namespace {

using modal::EnergyDistribution;
using modal::ModeEnergy;
using modal::Vec3;
using modal::VectorX;
using LD = long double;

const std::string models = std::string(MODAL_SOURCE_DIR) + "/models/";

// The two eigenpairs of K φ = λ M φ (2×2, symmetric, M positive definite) in
// closed form: λ from the quadratic det(K − λM) = 0, φ from a row of K − λM.
struct Pair2 {
  LD lambda;
  std::array<LD, 2> phi;
};
std::array<Pair2, 2> eigen2(const LD K[2][2], const LD M[2][2]) {
  const LD a = M[0][0] * M[1][1] - M[0][1] * M[0][1];
  const LD b = -(K[0][0] * M[1][1] + K[1][1] * M[0][0] - 2 * K[0][1] * M[0][1]);
  const LD c = K[0][0] * K[1][1] - K[0][1] * K[0][1];
  const LD root = std::sqrt(b * b - 4 * a * c);
  std::array<Pair2, 2> out;
  const LD lambdas[2] = {(-b - root) / (2 * a), (-b + root) / (2 * a)};
  for (int i = 0; i < 2; ++i) {
    const LD l = lambdas[i];
    const LD r0 = std::abs(K[0][0] - l * M[0][0]) + std::abs(K[0][1] - l * M[0][1]);
    const LD r1 = std::abs(K[1][0] - l * M[1][0]) + std::abs(K[1][1] - l * M[1][1]);
    if (r0 >= r1)
      out[static_cast<std::size_t>(i)] = {l, {-(K[0][1] - l * M[0][1]), K[0][0] - l * M[0][0]}};
    else
      out[static_cast<std::size_t>(i)] = {l, {K[1][1] - l * M[1][1], -(K[1][0] - l * M[1][0])}};
  }
  return out;
}

// The share of `name` (0 when the element is absent).
double share(const std::vector<std::string>& names, const std::vector<double>& f, const std::string& name) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return f.at(i);
  ADD_FAILURE() << "no element " << name;
  return std::nan("");
}

void expect_sums_to_one(const std::vector<double>& f, const std::string& what) {
  if (f.empty()) return;
  double sum = 0, magnitude = 0;
  for (double x : f) {
    sum += x;
    magnitude += std::abs(x);
  }
  EXPECT_NEAR(sum, 1.0, 1e-12 * std::max(1.0, magnitude)) << what;
}

double uniform(std::mt19937& rng, double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }

modal::Analysis analyze_with_energy(const modal::Model& model) {
  modal::AnalysisOptions o;
  o.energy = true;
  return modal::analyze(model, o);
}

// --- closed forms -------------------------------------------------------------

// wall —k1— m1 —k2— m2 —k3— wall along x (particles held in y and z).
std::string two_mass_chain(double m1, double m2, double k1, double k2, double k3) {
  auto num = [](double x) { return std::to_string(x); };
  return "title = \"two masses, three springs\"\ngravity = [0, 0, 0]\n"
         "[[particle]]\nname = \"m1\"\nposition = [1, 0, 0]\nmass = " + num(m1) + "\nfixed = [false, true, true]\n"
         "[[particle]]\nname = \"m2\"\nposition = [2, 0, 0]\nmass = " + num(m2) + "\nfixed = [false, true, true]\n"
         "[[spring]]\na = \"world\"\nb = \"m1\"\nstiffness = " + num(k1) + "\n"
         "[[spring]]\na = \"m1\"\nb = \"m2\"\nstiffness = " + num(k2) + "\n"
         "[[spring]]\na = \"m2\"\nb = \"world\"\nb_point = [3, 0, 0]\nstiffness = " + num(k3) + "\n";
}

TEST(EnergyClosedForm, TwoMassesThreeSprings) {
  std::mt19937 rng(17);
  for (int trial = 0; trial < 20; ++trial) {
    // std::to_string keeps 6 decimals: the reference takes the values as the scene has them
    const auto round6 = [](double x) { return std::stod(std::to_string(x)); };
    const double m1 = round6(uniform(rng, 0.5, 2)), m2 = round6(uniform(rng, 0.5, 2));
    const double k1 = round6(uniform(rng, 0.5, 5)), k2 = round6(uniform(rng, 0.5, 5)), k3 = round6(uniform(rng, 0.5, 5));
    const modal::Analysis a =
        analyze_with_energy(modal::model_from_text(two_mass_chain(m1, m2, k1, k2, k3), "chain.toml"));
    const EnergyDistribution& d = *a.report.equilibria.front().energy;
    ASSERT_EQ(d.modes.size(), 2u);
    const LD K[2][2] = {{LD(k1) + k2, -LD(k2)}, {-LD(k2), LD(k2) + k3}};
    const LD M[2][2] = {{m1, 0}, {0, m2}};
    const auto pairs = eigen2(K, M);
    for (std::size_t i = 0; i < 2; ++i) {
      const auto& [lambda, phi] = pairs[i];
      const ModeEnergy& e = d.modes[i];
      const LD T = m1 * phi[0] * phi[0] + m2 * phi[1] * phi[1];
      const LD e1 = k1 * phi[0] * phi[0], e2 = k2 * (phi[1] - phi[0]) * (phi[1] - phi[0]), e3 = k3 * phi[1] * phi[1];
      const LD V = e1 + e2 + e3;
      EXPECT_NEAR(share(d.kinetic_elements, e.kinetic, "m1"), double(m1 * phi[0] * phi[0] / T), 1e-10);
      EXPECT_NEAR(share(d.kinetic_elements, e.kinetic, "m2"), double(m2 * phi[1] * phi[1] / T), 1e-10);
      EXPECT_NEAR(share(d.potential_elements, e.potential, "spring1"), double(e1 / V), 1e-10);
      EXPECT_NEAR(share(d.potential_elements, e.potential, "spring2"), double(e2 / V), 1e-10);
      EXPECT_NEAR(share(d.potential_elements, e.potential, "spring3"), double(e3 / V), 1e-10);
      EXPECT_NEAR(e.potential_total, double(lambda), 1e-10 * double(lambda));
      // base translation along x: L = (m1, m2), effective mass (φᵀL)²/φᵀMφ
      ASSERT_EQ(d.directions.size(), 1u);
      EXPECT_EQ(d.directions[0].name, "x");
      EXPECT_NEAR(e.effective_mass[0], double(std::pow(m1 * phi[0] + m2 * phi[1], 2) / T), 1e-10 * (m1 + m2));
    }
    // particles free along x: the effective masses add up to the whole mass
    EXPECT_NEAR(d.directions[0].movable_mass, m1 + m2, 1e-15 * (m1 + m2));
    EXPECT_NEAR(d.modes.back().cumulative_fraction[0], 1.0, 1e-12);
  }
}

// Point masses m1, m2 on rods l1, l2 (models/double_pendulum.toml). In the
// absolute angles a = (θ1, θ2) at the hanging equilibrium: M = [[(m1+m2)l1²,
// m2 l1 l2], [m2 l1 l2, m2 l2²]], K = diag((m1+m2) g l1, m2 g l2); body 1's
// kinetic share ∝ m1 (l1 ȧ1)², body 2's ∝ m2 (l1 ȧ1 + l2 ȧ2)² (velocities
// horizontal there); gravity's potential ∝ m1 g l1 a1² (upper) and
// m2 g (l1 a1² + l2 a2²) (lower, which the upper rod also raises).
TEST(EnergyClosedForm, DoublePendulum) {
  std::mt19937 rng(29);
  for (int trial = 0; trial < 20; ++trial) {
    const double m1 = uniform(rng, 0.5, 2), m2 = uniform(rng, 0.5, 2), l1 = uniform(rng, 0.5, 2),
                 l2 = uniform(rng, 0.5, 2), g = uniform(rng, 1, 10);
    auto set = [](const char* name, double v) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%s=%.17g", name, v);
      return std::string(buf);
    };
    const modal::Analysis a = analyze_with_energy(modal::load_model(
        models + "double_pendulum.toml", {set("m1", m1), set("m2", m2), set("l1", l1), set("l2", l2), set("g", g)}));
    const EnergyDistribution& d = *a.report.equilibria.front().energy;
    ASSERT_EQ(d.modes.size(), 2u);
    const LD M[2][2] = {{(LD(m1) + m2) * l1 * l1, LD(m2) * l1 * l2}, {LD(m2) * l1 * l2, LD(m2) * l2 * l2}};
    const LD K[2][2] = {{(LD(m1) + m2) * g * l1, 0}, {0, LD(m2) * g * l2}};
    const auto pairs = eigen2(K, M);
    for (std::size_t i = 0; i < 2; ++i) {
      const auto& phi = pairs[i].phi;
      const ModeEnergy& e = d.modes[i];
      const LD t1 = m1 * std::pow(l1 * phi[0], 2), t2 = m2 * std::pow(l1 * phi[0] + l2 * phi[1], 2);
      const LD v1 = m1 * g * l1 * phi[0] * phi[0], v2 = m2 * g * (l1 * phi[0] * phi[0] + l2 * phi[1] * phi[1]);
      EXPECT_NEAR(share(d.kinetic_elements, e.kinetic, "upper"), double(t1 / (t1 + t2)), 1e-10);
      EXPECT_NEAR(share(d.kinetic_elements, e.kinetic, "lower"), double(t2 / (t1 + t2)), 1e-10);
      EXPECT_NEAR(share(d.potential_elements, e.potential, "upper.gravity"), double(v1 / (v1 + v2)), 1e-10);
      EXPECT_NEAR(share(d.potential_elements, e.potential, "lower.gravity"), double(v2 / (v1 + v2)), 1e-10);
      // horizontal base motion: φᵀL_x = −(m1 l1 a1 + m2 (l1 a1 + l2 a2)) (a positive angle about y
      // moves a mass below its hinge towards −x)
      const LD L = -(m1 * l1 * phi[0] + m2 * (l1 * phi[0] + l2 * phi[1]));
      ASSERT_FALSE(d.directions.empty());
      EXPECT_EQ(d.directions[0].name, "x");
      EXPECT_NEAR(e.effective_mass[0], double(L * L / (t1 + t2)), 1e-10 * (m1 + m2));
    }
    // point masses: a rigid horizontal translation is (θ̇1, θ̇2) = (v/l1, 0) to
    // first order, so the effective masses add up to m1 + m2; nothing moves vertically
    EXPECT_EQ(d.directions.size(), 1u);
    EXPECT_NEAR(d.directions[0].movable_mass, m1 + m2, 1e-15 * (m1 + m2));
    EXPECT_NEAR(d.modes.back().cumulative_fraction[0], 1.0, 1e-12);
  }
}

// A point mass m on a rod l standing above its hinge, held up by a joint
// spring k > m g l: V = ½kθ² − m g l (1 − cos θ), so φᵀKφ ∝ k − m g l and
// the gravity share is −m g l / (k − m g l) < 0, the spring's k / (k − m g l) > 1.
TEST(EnergyClosedForm, InvertedPendulumHasANegativeGravityShare) {
  std::mt19937 rng(61);
  for (int trial = 0; trial < 10; ++trial) {
    const double m = uniform(rng, 0.5, 2), l = uniform(rng, 0.5, 2), g = 9.81;
    const double k = m * g * l * uniform(rng, 1.2, 5);
    char text[512];
    std::snprintf(text, sizeof text,
                  "gravity = [0, 0, %.17g]\n[[body]]\nname = \"rod\"\njoint = \"hinge\"\nmass = %.17g\n"
                  "com = [0, 0, %.17g]\nstiffness = %.17g\n",
                  -g, m, l, k);
    const modal::Analysis a = analyze_with_energy(modal::model_from_text(text, "inverted.toml"));
    const EnergyDistribution& d = *a.report.equilibria.front().energy;
    ASSERT_EQ(d.modes.size(), 1u);
    const LD net = LD(k) - LD(m) * g * l;
    EXPECT_NEAR(share(d.potential_elements, d.modes[0].potential, "rod.gravity"), double(-LD(m) * g * l / net), 1e-12);
    EXPECT_NEAR(share(d.potential_elements, d.modes[0].potential, "rod.joint"), double(LD(k) / net), 1e-12);
    EXPECT_EQ(d.modes[0].kinetic, std::vector<double>{1.0});
  }
}

// --- generated scenes ------------------------------------------------------------

// L_dᵀM⁻¹L_d in long double, with L_d = −∇V of gravity d alone (modal's
// reverse tree accumulation of the potential gradient, not the forward
// momentum that energy_distribution uses); constrained: L_r = NᵀL_d, M_r = NᵀMN.
double reference_effective_mass(const modal::System& sys, const modal::LinearModel& lin, const Vec3& d) {
  modal::SystemDescription desc;
  desc.bodies = sys.bodies();
  for (modal::Body& b : desc.bodies) b.stiffness = 0;
  desc.gravity = d;
  const modal::System gravity_only(desc);
  modal::Workspace w(gravity_only);
  VectorX L = -modal::potential_gradient(gravity_only, w, lin.q);
  if (lin.constrained()) L = lin.basis.transpose() * L;
  const Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic> M = lin.M.cast<LD>();
  const Eigen::Matrix<LD, Eigen::Dynamic, 1> Ll = L.cast<LD>();
  return double(Ll.dot(M.ldlt().solve(Ll)));
}

void check_distribution(const modal::System& sys, const modal::LinearModel& lin, const modal::ModalResult& r,
                        const EnergyDistribution& d, const std::string& what) {
  ASSERT_EQ(d.modes.size(), r.modes.size()) << what;
  for (std::size_t i = 0; i < r.modes.size(); ++i) {
    const ModeEnergy& e = d.modes[i];
    expect_sums_to_one(e.kinetic, what + " kinetic, mode " + std::to_string(i + 1));
    expect_sums_to_one(e.potential, what + " potential, mode " + std::to_string(i + 1));
    EXPECT_EQ(e.potential.empty(), r.modes[i].kind == modal::ModeKind::zero) << what;
    // The elements' sums are φᵀMφ and φᵀKφ of the model as solved (complex shapes a + ib:
    // aᵀXa + bᵀXb; a circulatory K enters by its symmetric part), to rounding relative to
    // |φ|ᵀ|X||φ|. Shapes are in all coordinates; the model's matrices are on the
    // constraint manifold (φ = N φ_r, N orthonormal). Real modes are M-normalized: φᵀMφ = 1.
    double kinetic = 0, potential = 0, M_scale = 0, K_scale = 0;
    for (const Eigen::VectorXd& full : {Eigen::VectorXd(r.modes[i].shape.real()), Eigen::VectorXd(r.modes[i].shape.imag())}) {
      const Eigen::VectorXd phi = lin.constrained() ? Eigen::VectorXd(lin.basis.transpose() * full) : full;
      kinetic += phi.dot(lin.M * phi);
      potential += phi.dot(lin.K * phi);
      M_scale += phi.cwiseAbs().dot(lin.M.cwiseAbs() * phi.cwiseAbs());
      K_scale += phi.cwiseAbs().dot(lin.K.cwiseAbs() * phi.cwiseAbs());
    }
    if (std::isfinite(r.modes[i].omega2)) {
      EXPECT_NEAR(e.kinetic_total, 1.0, 1e-10) << what;
    }
    EXPECT_NEAR(e.kinetic_total, kinetic, 1e-10 * M_scale) << what;
    EXPECT_NEAR(e.potential_total, potential, 1e-10 * K_scale) << what;
  }
  for (std::size_t a = 0; a < d.directions.size(); ++a) {
    double total = 0;
    for (const ModeEnergy& e : d.modes) total += e.effective_mass[a];
    const double reference = reference_effective_mass(sys, lin, d.directions[a].direction);
    EXPECT_NEAR(total, reference, 1e-9 * d.directions[a].movable_mass) << what << " " << d.directions[a].name;
    EXPECT_LE(total, d.directions[a].movable_mass * (1 + 1e-12)) << what;
  }
}

// A generated scene at its equilibrium, solved, with its distribution checked.
EnergyDistribution solve_and_check(const modal::SystemDescription& desc, const std::string& what) {
  const modal::System sys(desc);
  const modal::Equilibrium eq = modal::find_equilibrium(sys, sys.initial_configuration());
  const modal::LinearModel lin = modal::linearize(sys, eq.q);
  const modal::ModalResult r = modal::solve_modes(lin);
  EnergyDistribution d = modal::energy_distribution(sys, lin, r);
  check_distribution(sys, lin, r, d, what);
  return d;
}

modal::Spring spring(modal::Attachment a, modal::Attachment b, double stiffness, double rest_length) {
  modal::Spring s;
  s.a = a;
  s.b = b;
  s.stiffness = stiffness;
  s.rest_length = rest_length;
  return s;
}

// Particles, some axes fixed, joined by springs with random rest lengths and
// to the world, under gravity: each particle's free axes are coordinates of
// their own, so a rigid translation along any axis is a motion of the
// coordinates and the effective masses add up to the movable mass exactly.
TEST(EnergyGenerated, ParticleSpringFamilies) {
  std::mt19937 rng(41);
  for (int trial = 0; trial < 12; ++trial) {
    modal::SystemDescription desc;
    desc.gravity = Vec3(0, 0, -uniform(rng, 0, 10));
    const int n = 2 + static_cast<int>(rng() % 7);
    for (int i = 0; i < n; ++i) {
      modal::Body b;
      b.name = "p" + std::to_string(i);
      b.joint = modal::JointType::particle;
      b.origin = Vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
      b.mass = uniform(rng, 0.1, 10);
      for (auto& axis : b.particle_axes) axis = rng() % 4 != 0;
      b.particle_axes[0] = true;
      desc.bodies.push_back(b);
    }
    for (int i = 0; i < n; ++i) {  // each particle to the world (three springs, stable) and to a neighbour
      for (int k = 0; k < 3; ++k) {
        const double length = uniform(rng, 0.5, 1.5);
        desc.springs.push_back(spring({i, Vec3::Zero()},
                                      {-1, desc.bodies[static_cast<std::size_t>(i)].origin + Vec3::Unit(k) * length},
                                      uniform(rng, 10, 100), length * uniform(rng, 0.9, 1.0)));
      }
      if (i > 0)
        desc.springs.push_back(spring({i - 1, Vec3::Zero()}, {i, Vec3::Zero()}, uniform(rng, 1, 50), uniform(rng, 0.5, 2)));
    }
    const std::string what = "particles, trial " + std::to_string(trial);
    const EnergyDistribution d = solve_and_check(desc, what);
    for (std::size_t a = 0; a < d.directions.size(); ++a) {
      double free_mass = 0;
      for (const modal::Body& b : desc.bodies)
        if (b.particle_axes[static_cast<std::size_t>(d.directions[a].name[0] - 'x')]) free_mass += b.mass;
      EXPECT_NEAR(d.directions[a].movable_mass, free_mass, 1e-13 * free_mass) << what;
      EXPECT_NEAR(d.modes.back().cumulative_fraction[a], 1.0, 1e-10) << what << " " << d.directions[a].name;
    }
  }
}

// Random trees of hinges, slides and balls with rotational inertia, joint
// springs, springs and gravity: the effective masses add up to L_dᵀM⁻¹L_d,
// strictly below the movable mass where rotational inertia takes part.
TEST(EnergyGenerated, RandomTrees) {
  std::mt19937 rng(53);
  int below = 0;
  for (int trial = 0; trial < 12; ++trial) {
    modal::SystemDescription desc;
    desc.gravity = Vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), -uniform(rng, 1, 10));
    const int n = 2 + static_cast<int>(rng() % 6);
    for (int i = 0; i < n; ++i) {
      modal::Body b;
      b.name = "b" + std::to_string(i);
      b.parent = i == 0 ? -1 : static_cast<int>(rng() % static_cast<unsigned>(i));
      const int kind = static_cast<int>(rng() % 3);
      b.joint = kind == 0 ? modal::JointType::hinge : kind == 1 ? modal::JointType::slide : modal::JointType::ball;
      b.axis = Vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)).normalized();
      b.origin = Vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
      b.mass = uniform(rng, 0.1, 5);
      b.com = Vec3(uniform(rng, -0.5, 0.5), uniform(rng, -0.5, 0.5), uniform(rng, -0.5, 0.5));
      const double I = uniform(rng, 0.01, 1);
      b.inertia = modal::Mat3::Identity() * I;
      b.stiffness = uniform(rng, 200, 1000);
      b.armature = rng() % 3 == 0 ? uniform(rng, 0.01, 0.1) : 0.0;
      desc.bodies.push_back(b);
    }
    for (int k = 0; k < n; ++k) {
      const modal::Attachment a{static_cast<int>(rng() % static_cast<unsigned>(n)), Vec3(uniform(rng, -0.5, 0.5), 0, 0)};
      const modal::Attachment b{-1, Vec3(uniform(rng, -2, 2), uniform(rng, -2, 2), uniform(rng, -2, 2))};
      desc.springs.push_back(spring(a, b, uniform(rng, 1, 20), uniform(rng, 0.1, 1)));
    }
    const EnergyDistribution d = solve_and_check(desc, "tree, trial " + std::to_string(trial));
    for (std::size_t a = 0; a < d.directions.size(); ++a)
      if (d.modes.back().cumulative_fraction[a] < 1 - 1e-6) ++below;
  }
  EXPECT_GT(below, 0);  // rotational inertia: a rigid translation is not a motion of these trees
}

// Every bundled scene (constraints, maps, rotating frames, follower loads,
// dampers): shares sum to 1 and, for real modes, the elements add up to φᵀMφ
// and φᵀKφ of the model as solved.
TEST(EnergyGenerated, BundledModels) {
  int checked = 0;
  std::vector<std::pair<std::string, std::vector<std::string>>> runs;
  for (const auto& entry : std::filesystem::directory_iterator(models))
    if (entry.path().extension() == ".toml") runs.push_back({entry.path().string(), {}});
  // follower loads that do work in the modes (the defaults have P = 0)
  runs.push_back({models + "ziegler.toml", {"P=1.5"}});
  runs.push_back({models + "ziegler_damped.toml", {"P=1.5"}});
  for (const auto& [path, set] : runs) {
    const modal::Model model = modal::load_model(path, set);
    if (model.system.size() > 200) continue;
    modal::AnalysisOptions o;
    o.energy = true;
    o.solver = modal::SolverChoice::dense;
    modal::Analysis a;
    try {
      a = modal::analyze(model, o);
    } catch (const modal::NumericalError&) {
      continue;  // a scene analyze refuses as a whole is not this test's business
    }
    const auto& eq = a.report.equilibria.front();
    ASSERT_TRUE(eq.energy);
    check_distribution(model.system, *a.linear, eq.result, *eq.energy, path);
    ++checked;
  }
  EXPECT_GE(checked, 20);
}

// The sparse path gives the same shares as the dense one (a rectangular
// pre-tensioned net sagging under gravity).
TEST(EnergyGenerated, SparseMatchesDense) {
  const modal::Model model = modal::model_from_text(
      "gravity = [0, 0, -9.81]\n[[lattice]]\nname = \"net\"\nsize = [12, 9, 1]\nspacing = [0.1, 0.13, 0.1]\n"
      "mass = 0.002\nstiffness = 1000\nprestrain = 0.02\nfixed = \"boundary\"\n",
      "net.toml");
  modal::AnalysisOptions o;
  o.energy = true;
  o.modes = 4;
  o.solver = modal::SolverChoice::dense;
  const modal::Analysis dense = modal::analyze(model, o);
  o.solver = modal::SolverChoice::sparse;
  const modal::Analysis sparse = modal::analyze(model, o);
  const EnergyDistribution& a = *dense.report.equilibria.front().energy;
  const EnergyDistribution& b = *sparse.report.equilibria.front().energy;
  ASSERT_EQ(a.modes.size(), b.modes.size());
  const auto& modes = dense.result().modes;
  int compared = 0;
  for (std::size_t i = 0; i < a.modes.size(); ++i) {
    // a simple eigenvalue (the square net has pairs) has one shape up to sign, whose
    // shares agree to the eigenvectors' accuracy (gaps ≥ 1e-3 relative: ~1e-12)
    const double l = modes[i].omega2;
    if ((i > 0 && std::abs(modes[i - 1].omega2 - l) < 1e-3 * l) ||
        (i + 1 < modes.size() && std::abs(modes[i + 1].omega2 - l) < 1e-3 * l))
      continue;
    ++compared;
    for (std::size_t k = 0; k < a.modes[i].kinetic.size(); ++k)
      EXPECT_NEAR(a.modes[i].kinetic[k], b.modes[i].kinetic[k], 1e-8);
    for (std::size_t k = 0; k < a.modes[i].potential.size(); ++k)
      EXPECT_NEAR(a.modes[i].potential[k], b.modes[i].potential[k], 1e-8);
    for (std::size_t k = 0; k < a.directions.size(); ++k)
      EXPECT_NEAR(a.modes[i].effective_mass[k], b.modes[i].effective_mass[k], 1e-8 * a.directions[k].movable_mass);
  }
  EXPECT_GE(compared, 3);
}

// --- command line ------------------------------------------------------------------

class EnergyCli : public modal::test::ProgramTest {
 protected:
  EnergyCli() : ProgramTest("modal_energy_") {}
};

TEST_F(EnergyCli, CsvJsonAndTextAgree) {
  const std::string prefix = (dir / "dp").string(), json = (dir / "dp.json").string();
  const auto r = run({"analyze", models + "double_pendulum.toml", "--energy", "--csv", prefix, "--json", json});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("Energy distribution"), std::string::npos);
  EXPECT_NE(r.out.find("Participation in base translation"), std::string::npos);
  const auto energy = modal::test::read_csv(prefix + "_energy.csv");
  EXPECT_EQ(energy.header, (std::vector<std::string>{"mode", "kind", "element", "fraction"}));
  const auto part = modal::test::read_csv(prefix + "_participation.csv");
  EXPECT_EQ(part.header, (std::vector<std::string>{"mode", "direction", "participation_factor",
                                                   "effective_mass", "cumulative_fraction"}));
  const nlohmann::json j = nlohmann::json::parse(modal::test::slurp(json));
  std::map<std::pair<int, std::string>, double> sums;
  for (const auto& row : energy.rows) {
    const int mode = static_cast<int>(modal::test::number(row, "mode"));
    const double f = modal::test::number(row, "fraction");
    sums[{mode, row.at("kind")}] += f;
    EXPECT_EQ(f, j["modes"][static_cast<std::size_t>(mode - 1)]["energy"][row.at("kind")][row.at("element")].get<double>());
  }
  EXPECT_EQ(sums.size(), 4u);  // two modes, kinetic and potential
  for (const auto& [key, sum] : sums) EXPECT_NEAR(sum, 1.0, 1e-12);
  ASSERT_EQ(part.rows.size(), 2u);  // x only: nothing moves vertically at the hanging equilibrium
  for (const auto& row : part.rows) {
    const auto& p = j["modes"][static_cast<std::size_t>(modal::test::number(row, "mode") - 1)]["participation"]["x"];
    EXPECT_EQ(modal::test::number(row, "effective_mass"), p["effective_mass"].get<double>());
    EXPECT_EQ(modal::test::number(row, "participation_factor"), p["participation_factor"].get<double>());
    EXPECT_EQ(modal::test::number(row, "cumulative_fraction"), p["cumulative_fraction"].get<double>());
  }
  EXPECT_NEAR(modal::test::number(part.rows.back(), "cumulative_fraction"), 1.0, 1e-12);
}

TEST_F(EnergyCli, ZeroModeHasNoPotentialShares) {
  // a free particle on x joined to a second one: one rigid (zero) mode, one oscillation
  const std::string scene = (dir / "free.toml").string();
  std::ofstream(scene) << "gravity = [0, 0, 0]\n"
                          "[[particle]]\nname = \"a\"\nposition = [0, 0, 0]\nmass = 1\nfixed = [false, true, true]\n"
                          "[[particle]]\nname = \"b\"\nposition = [1, 0, 0]\nmass = 2\nfixed = [false, true, true]\n"
                          "[[spring]]\na = \"a\"\nb = \"b\"\nstiffness = 3\n";
  const std::string prefix = (dir / "free").string();
  const auto r = run({"analyze", scene, "--energy", "--csv", prefix});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("not defined (zero mode)"), std::string::npos) << r.out;
  int potential_rows_mode1 = 0, potential_rows_mode2 = 0;
  for (const auto& row : modal::test::read_csv(prefix + "_energy.csv").rows)
    if (row.at("kind") == "potential") ++(row.at("mode") == "1" ? potential_rows_mode1 : potential_rows_mode2);
  EXPECT_EQ(potential_rows_mode1, 0);
  EXPECT_EQ(potential_rows_mode2, 1);  // spring1 stores it all
  // the rigid mode carries the whole mass: effective mass 3 kg, cumulative 1 after it
  const auto part = modal::test::read_csv(prefix + "_participation.csv");
  ASSERT_EQ(part.rows.size(), 2u);
  EXPECT_NEAR(modal::test::number(part.rows[0], "effective_mass"), 3.0, 1e-12);
  EXPECT_NEAR(modal::test::number(part.rows[1], "effective_mass"), 0.0, 1e-12);
}

TEST_F(EnergyCli, NoEnergyFilesWithoutTheFlag) {
  const std::string prefix = (dir / "dp").string();
  const auto r = run({"analyze", models + "double_pendulum.toml", "--csv", prefix});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(prefix + "_modes.csv"));
  EXPECT_FALSE(std::filesystem::exists(prefix + "_energy.csv"));
  EXPECT_FALSE(std::filesystem::exists(prefix + "_participation.csv"));
  EXPECT_EQ(r.out.find("Energy distribution"), std::string::npos);
}

}  // namespace
