// Expression-defined systems (kinematic maps; modal/core.hpp "kinematic maps",
// scene syntax [coordinates], [[point]], potential):
//  1. the same system and coordinates written as bodies and as a map agree to
//     rounding in V, ∇V, ∇∇V, M, Γ, C, g, G, q̈ and E (double pendulum, seesaw,
//     a rigid top with a general inertia on three gimbal hinges; the bead on a
//     hoop as a body in a rotating frame vs the map with t), and so do their
//     equilibria and linear models (R1 frequencies 2 ∓ √2);
//  2. the exact derivatives (∇V, ∇∇V, ∂M/∂q, G) against central differences for
//     maps with t (Foucault), rotations and inertia (the top, rate and momentum
//     forms), and Routh's reduction (spherical angles);
//  3. Ṁ − 2C skew-symmetric;
//  4. docs/design.md R7 through the map model, the switch found by modal::sweep;
//  5. Foucault's pendulum: M, K, G and ω = √(g/l + Wz²) ± Wz;
//  6. the sleeping top: gyroscopic stabilization, its threshold by modal::sweep,
//     the momentum form equal to the rate form, steady_motion();
//  7. Routh's reduction: a pendulum on a free cart (an ignorable length coupled
//     to the swing), rate and momentum forms; the spherical pendulum in angles:
//     conical motion, and the pole, where the mass matrix is singular, reported
//     as such;
//  8. non-steady maps (Floquet) and wrongly declared ignorable coordinates rejected;
//  9. coordinate kinds and periodicity;
// 10. the Jacobi integral conserved by modal::simulate.
// References are closed forms (model header comments, docs/design.md section 2) or the
// body version of the same system, never earlier output of this code.
#include "modal/core.hpp"
#include "modal/equilibrium.hpp"
#include "modal/linearize.hpp"
#include "modal/modes.hpp"
#include "modal/scene.hpp"
#include "modal/simulate.hpp"
#include "modal/sweep.hpp"

#include "checks.hpp"
#include "systems.hpp"

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace {

using namespace modal;
using test::max_abs;

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kPi = std::numbers::pi;

std::string model_path(const std::string& name) { return std::string(MODAL_SOURCE_DIR) + "/models/" + name; }

std::string read_model(const std::string& name) {
  std::ifstream in(model_path(name));
  EXPECT_TRUE(in.good()) << model_path(name);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// --set NAME=VALUE with every digit of the value.
ParameterOverride set(const std::string& name, double value) {
  std::ostringstream text;
  text.precision(17);
  text << value;
  return {name, text.str()};
}

System load(const std::string& name, const std::vector<ParameterOverride>& overrides = {}) {
  return build_system(load_scene(model_path(name), overrides));
}

// `text` with its first line that starts with `prefix` replaced by `line`
// (a test failure when there is none: the model changed under the test).
std::string replace_line(const std::string& text, const std::string& prefix, const std::string& line) {
  std::istringstream in(text);
  std::string out, current;
  bool found = false;
  while (std::getline(in, current)) {
    if (!found && current.rfind(prefix, 0) == 0) {
      current = line;
      found = true;
    }
    out += current + "\n";
  }
  EXPECT_TRUE(found) << "no line starting with '" << prefix << "'";
  return out;
}

System parse(const std::string& text, const std::vector<ParameterOverride>& overrides = {}) {
  return build_system(parse_scene(text, "modified.toml", overrides));
}

// The eigen-frequencies ω (rad/s) of the modes, ascending.
std::vector<double> omegas(const ModalResult& r) {
  std::vector<double> w;
  for (const Mode& m : r.modes) w.push_back(m.omega);
  std::sort(w.begin(), w.end());
  return w;
}

double relative(double a, double b) { return std::abs(a - b) / std::abs(b); }

// --- 1. the same system as bodies and as a map ---------------------------------

// Everything the core evaluates, compared between the body and the map version
// at random states. Both evaluate the same trigonometric expressions in a
// different order (a kinematic tree vs expressions through forward AD), so
// they differ by rounding, ~1e-15 of the size of each quantity; the tolerance
// 1e-12 leaves three orders of margin while any wrong or missing term would be
// of order 1. Sizes: the potential's scale E = max(|V|, ‖∇V‖, ‖∇∇V‖) (J per
// rad^k) for V and its derivatives; ‖M‖ for M and Γ, ‖M‖·|q̇| for C; √(‖M‖E)
// (M times the natural rate) for g and G; (E + ‖M‖q̇²)/λ_min(M) for q̈;
// E + ‖M‖q̇² for the energy. Returns the worst relative disagreement.
double compare_body_and_map(const System& body, const System& map, double spread, unsigned seed) {
  EXPECT_FALSE(body.is_map());
  EXPECT_TRUE(map.is_map());
  if (body.size() != map.size()) {
    ADD_FAILURE() << "sizes " << body.size() << " and " << map.size();
    return 1;
  }
  Workspace wb(body), wm(map);
  std::mt19937 rng(seed);
  double worst = 0;
  for (int trial = 0; trial < 4; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const VectorX q = test::random_state(body, rng, spread), qd = test::random_state(body, rng, 2.0);
    const auto check = [&](const char* what, double difference, double size) {
      EXPECT_LE(difference, 1e-12 * size) << what;
      worst = std::max(worst, difference / size);
    };
    const double Vb = potential(body, wb, q);
    const VectorX gb = potential_gradient(body, wb, q);
    const MatrixX Hb = potential_hessian(body, wb, q);
    const MatrixX Mb = mass_matrix(body, wb, q);
    const double E = std::max({std::abs(Vb), max_abs(gb), max_abs(Hb)});
    const double Ms = max_abs(Mb), v = qd.cwiseAbs().maxCoeff();
    const double lambda_min = Eigen::SelfAdjointEigenSolver<MatrixX>(Mb).eigenvalues().minCoeff();
    check("V", std::abs(Vb - potential(map, wm, q)), E);
    check("gradient", max_abs(gb - potential_gradient(map, wm, q)), E);
    check("Hessian", max_abs(Hb - potential_hessian(map, wm, q)), E);
    check("M", max_abs(Mb - mass_matrix(map, wm, q)), Ms);
    const std::vector<MatrixX> Gb = christoffel(body, wb, q), Gm = christoffel(map, wm, q);
    for (std::size_t i = 0; i < Gb.size(); ++i) check("Christoffel symbols", max_abs(Gb[i] - Gm[i]), Ms);
    check("C", max_abs(coriolis(body, wb, q, qd) - coriolis(map, wm, q, qd)), Ms * v);
    check("g", max_abs(frame_coupling(body, wb, q) - frame_coupling(map, wm, q)), std::sqrt(Ms * E));
    check("G", max_abs(gyroscopic_matrix(body, wb, q) - gyroscopic_matrix(map, wm, q)), std::sqrt(Ms * E));
    check("accelerations", max_abs(accelerations(body, wb, q, qd) - accelerations(map, wm, q, qd)),
          (E + Ms * v * v) / lambda_min);
    check("energy", std::abs(energy(body, wb, q, qd) - energy(map, wm, q, qd)), E + Ms * v * v);
  }
  return worst;
}

TEST(Map, DoublePendulumAsBodiesAndAsMapAgree) {
  const double worst = compare_body_and_map(load("double_pendulum.toml"), load("double_pendulum_map.toml"), 3.0, 1);
  std::cout << "  double pendulum: worst relative disagreement " << worst << "\n";
}

TEST(Map, SeesawAsBodiesAndAsMapAgree) {
  const double worst = compare_body_and_map(load("seesaw.toml"), load("seesaw_map.toml"), 3.0, 2);
  std::cout << "  seesaw: worst relative disagreement " << worst << "\n";
}

TEST(Map, BeadOnHoopInARotatingFrameAndAsMapWithTimeAgree) {
  // V_eff = −mgR cos θ − ½mR²Ω² sin²θ both ways: from frame_rotation (T₀ of the
  // body) and from ∂ₜx of the map. Ω = 5: the centrifugal part dominates.
  const System frame = load("bead_on_hoop_frame.toml", {set("Omega", 5)});
  const System map = load("bead_on_hoop.toml", {set("Omega", 5)});
  EXPECT_TRUE(map.map_time_dependent());
  EXPECT_TRUE(map.has_frame_coupling());
  const double worst = compare_body_and_map(frame, map, 3.0, 3);
  std::cout << "  bead on a hoop: worst relative disagreement " << worst << "\n";
  // And the closed form of V_eff and of its Hessian.
  Workspace w(map);
  const double m = 1, R = 1, g = 9.81, Omega = 5;
  for (const double theta : {-2.0, 0.3, 1.1, 2.9}) {
    const VectorX q = VectorX::Constant(1, theta);
    const double V = -m * g * R * std::cos(theta) - 0.5 * m * R * R * Omega * Omega * std::pow(std::sin(theta), 2);
    const double H = m * g * R * std::cos(theta) - m * R * R * Omega * Omega * std::cos(2 * theta);
    const double E = m * g * R + m * R * R * Omega * Omega;  // size of V and H
    EXPECT_NEAR(potential(map, w, q), V, 1e-14 * E);
    EXPECT_NEAR(potential_hessian(map, w, q)(0, 0), H, 1e-14 * E);
    EXPECT_NEAR(mass_matrix(map, w, q)(0, 0), m * R * R, 1e-15);
  }
}

// The top of models/spinning_top.toml with psi a plain coordinate and a
// general (non-symmetric, with products) inertia, as a map and as three hinges
// about x, y, z (massless gimbals, the body on the last): the same orientation
// R = Rx(a) Ry(b) Rz(psi) and centre of mass R (0, 0, h). Exercises the map's
// angular Jacobians W_k and I_w = R I Rᵀ against the tree.
TEST(Map, RigidTopAsHingesAndAsMapAgree) {
  const double m = 1, h = 0.1, g = 9.81;  // the model's defaults
  Mat3 inertia;
  inertia << 0.002, 0.0003, -0.0002, 0.0003, 0.003, 0.0001, -0.0002, 0.0001, 0.004;
  std::string text = replace_line(read_model("spinning_top.toml"), "psi = ", "psi = 0.0");
  text = replace_line(text, "inertia = ", "inertia = [0.002, 0.003, 0.004, 0.0003, -0.0002, 0.0001]");
  const System map = parse(text);
  SystemDescription d;
  d.gravity = Vec3(0, 0, -g);
  d.bodies.push_back(test::hinge("a", -1, Vec3::Zero(), 0, Vec3::Zero(), Vec3::UnitX()));
  d.bodies.push_back(test::hinge("b", 0, Vec3::Zero(), 0, Vec3::Zero(), Vec3::UnitY()));
  Body top = test::hinge("psi", 1, Vec3::Zero(), m, Vec3(0, 0, h), Vec3::UnitZ());
  top.inertia = inertia;
  d.bodies.push_back(top);
  // b within ±1.2 rad of 0: away from the gimbal lock at b = ±π/2, where M is singular.
  const double worst = compare_body_and_map(System(d), map, 1.2, 4);
  std::cout << "  rigid top: worst relative disagreement " << worst << "\n";
}

TEST(Map, DoublePendulumEquilibriaAsBodiesAndAsMap) {
  // R1: four equilibria, Morse indices 0, 1, 1, 2; the map's angles are
  // periodic, so its search deduplicates them modulo 2π like the tree's.
  const System body = load("double_pendulum.toml"), map = load("double_pendulum_map.toml");
  const std::vector<Equilibrium> eb = find_equilibria(body), em = find_equilibria(map);
  ASSERT_EQ(eb.size(), 4u);
  ASSERT_EQ(em.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_LE(configuration_distance(map, eb[i].q, em[i].q), 1e-10) << i;
    EXPECT_NEAR(eb[i].potential, em[i].potential, 1e-12);
    EXPECT_EQ(solve_modes(linearize(map, em[i].q)).morse_index, static_cast<int>(i == 0 ? 0 : i == 3 ? 2 : 1)) << i;
  }
}

TEST(Map, DoublePendulumLinearModelsAgreeAndGiveR1) {
  const System body = load("double_pendulum.toml"), map = load("double_pendulum_map.toml");
  const Equilibrium eb = find_equilibrium(body, body.initial_configuration());
  const Equilibrium em = find_equilibrium(map, map.initial_configuration());
  EXPECT_LE((eb.q - em.q).cwiseAbs().maxCoeff(), 1e-14);  // the hanging rest, (0, 0)
  const LinearModel lb = linearize(body, eb.q), lm = linearize(map, em.q);
  // M = [[2, 1], [1, 1]], K = diag(2, 1) (m = l = g = 1): entries of order 1.
  EXPECT_LE(max_abs(lb.M - lm.M), 1e-12);
  EXPECT_LE(max_abs(lb.K - lm.K), 1e-12);
  EXPECT_EQ(lb.G.size() + lm.G.size(), 0);  // neither is gyroscopic: both empty
  EXPECT_FALSE(lb.has_gyroscopic);
  EXPECT_FALSE(lm.has_gyroscopic);
  EXPECT_TRUE(lm.steady.empty());
  EXPECT_EQ(lm.coordinates, (std::vector<std::string>{"upper", "lower"}));
  const ModalResult r = solve_modes(lm);
  ASSERT_EQ(r.modes.size(), 2u);
  EXPECT_EQ(r.stability, Stability::stable);
  // R1: ω² = 2 ∓ √2, well separated eigenvalues of a 2×2 pencil: rounding ~1e-16.
  const double lambda[2] = {2 - std::sqrt(2.0), 2 + std::sqrt(2.0)};
  for (int i = 0; i < 2; ++i) {
    const Mode& mode = r.modes[static_cast<std::size_t>(i)];
    EXPECT_NEAR(mode.omega2, lambda[i], 1e-12 * lambda[1]);
    EXPECT_LE(std::abs(mode.omega2 - lambda[i]), mode.error_estimate + 8 * kEps * lambda[i]);
  }
}

// --- 2. exact derivatives vs central differences -----------------------------------

// ∇V (vs differences of V), ∇∇V (of ∇V), ∂M/∂q_k (of M) and G (of the
// coupling g: G = J − Jᵀ, J_ik = ∂g_i/∂q_k) at q. Each coordinate is stepped by
// h = 1e-5 of its unit (1 rad, or the system's length scale for lengths) and
// the comparison is made in those units. The central difference of f is off by
// the truncation h²f‴/6 (~1e-10 relative) plus the rounding ~ε·|f|/h (~1e-11
// of |f|); the tolerance is 1e-7 of the exact quantity's size (the √ε level,
// three orders above what the differences achieve and far below the order-1
// error of a missing term) plus 100 ε|f|/h, the rounding floor of the quotient
// when f itself is much larger than its derivative (a constant part of V).
void expect_derivatives_match_differences(const System& s, const VectorX& q, const std::string& label) {
  SCOPED_TRACE(label);
  const int n = s.size();
  Workspace w(s);
  VectorX unit(n);
  for (int k = 0; k < n; ++k)
    unit[k] = s.coordinates()[static_cast<std::size_t>(k)].kind == CoordinateKind::length ? s.length_scale() : 1.0;
  const double h = 1e-5;
  const auto scaled = [&](const MatrixX& A) { return MatrixX(unit.asDiagonal() * A * unit.asDiagonal()); };

  const double V = potential(s, w, q);
  const VectorX g = unit.cwiseProduct(potential_gradient(s, w, q));
  const MatrixX H = scaled(potential_hessian(s, w, q));
  const MatrixX M = mass_matrix(s, w, q);
  const std::vector<MatrixX> dM = mass_matrix_derivatives(s, w, q);
  const MatrixX G = gyroscopic_matrix(s, w, q);
  ASSERT_EQ(dM.size(), static_cast<std::size_t>(n));
  EXPECT_EQ(max_abs(G + G.transpose()), 0.0);

  VectorX g_fd(n);
  MatrixX H_fd(n, n), J(n, n);
  double V_size = std::abs(V), g_size = g.cwiseAbs().maxCoeff(), M_size = max_abs(M);
  double c_size = frame_coupling(s, w, q).cwiseAbs().maxCoeff();
  double dM_error = 0, dM_scale = 0;  // measured, printed
  for (int k = 0; k < n; ++k) {
    VectorX qp = q, qm = q;
    qp[k] += h * unit[k];
    qm[k] -= h * unit[k];
    const double Vp = potential(s, w, qp), Vm = potential(s, w, qm);
    g_fd[k] = (Vp - Vm) / (2 * h);
    V_size = std::max({V_size, std::abs(Vp), std::abs(Vm)});
    const VectorX gp = unit.cwiseProduct(potential_gradient(s, w, qp));  // copies: the workspace is reused
    const VectorX gm = unit.cwiseProduct(potential_gradient(s, w, qm));
    H_fd.col(k) = (gp - gm) / (2 * h);
    g_size = std::max({g_size, gp.cwiseAbs().maxCoeff(), gm.cwiseAbs().maxCoeff()});
    const MatrixX Mp = mass_matrix(s, w, qp), Mm = mass_matrix(s, w, qm);
    M_size = std::max({M_size, max_abs(Mp), max_abs(Mm)});
    const MatrixX dM_fd = (Mp - Mm) / (2 * h);
    const MatrixX dM_k = unit[k] * dM[static_cast<std::size_t>(k)];
    EXPECT_LE(max_abs(dM_k - dM_fd), 1e-7 * max_abs(dM_k) + 100 * kEps * M_size / h)
        << "∂M/∂q_" << k << "\nexact\n" << dM_k << "\ndifferences\n" << dM_fd;
    dM_error = std::max(dM_error, max_abs(dM_k - dM_fd));
    dM_scale = std::max(dM_scale, max_abs(dM_k));
    const VectorX cp = frame_coupling(s, w, qp), cm = frame_coupling(s, w, qm);
    J.col(k) = (cp - cm) / (2 * h);
    c_size = std::max({c_size, cp.cwiseAbs().maxCoeff(), cm.cwiseAbs().maxCoeff()});
  }
  EXPECT_LE((g - g_fd).cwiseAbs().maxCoeff(), 1e-7 * g.cwiseAbs().maxCoeff() + 100 * kEps * V_size / h)
      << "gradient " << g.transpose() << "\ndifferences " << g_fd.transpose();
  EXPECT_LE(max_abs(H - H_fd), 1e-7 * max_abs(H) + 100 * kEps * g_size / h) << "Hessian\n" << H << "\ndifferences\n" << H_fd;
  // J's columns are per unit step of q_k already; its rows (g_i, per unit of q̇_i) are scaled here.
  const MatrixX J_scaled = unit.asDiagonal() * J, G_scaled = scaled(G);
  const MatrixX G_fd = J_scaled - J_scaled.transpose();
  EXPECT_LE(max_abs(G_scaled - G_fd), 1e-7 * max_abs(G_scaled) + 100 * kEps * c_size * unit.maxCoeff() / h)
      << "G\n" << G_scaled << "\ndifferences\n" << G_fd;
  const auto rel = [](double error, double size) { return size > 0 ? error / size : error; };
  std::cout << "  " << label << ": relative errors of the differences: gradient "
            << rel((g - g_fd).cwiseAbs().maxCoeff(), g.cwiseAbs().maxCoeff()) << ", Hessian "
            << rel(max_abs(H - H_fd), max_abs(H)) << ", dM/dq " << rel(dM_error, dM_scale) << ", G "
            << rel(max_abs(G_scaled - G_fd), max_abs(G_scaled)) << "\n";
}

// Random states: angles in ±spread rad about `centre`, lengths in ±spread/2 length scales.
VectorX random_around(const System& s, const VectorX& centre, std::mt19937& rng, double spread) {
  std::uniform_real_distribution<double> u(-spread, spread);
  VectorX q = centre;
  for (int k = 0; k < s.size(); ++k)
    q[k] += s.coordinates()[static_cast<std::size_t>(k)].kind == CoordinateKind::length ? 0.5 * s.length_scale() * u(rng)
                                                                                         : u(rng);
  return q;
}

// The spinning top with psi given by its momentum p = C·spin instead of its rate.
std::string top_by_momentum() {
  std::string text = read_model("spinning_top.toml");
  text = replace_line(text, "spin = ", "spin = 80.0\np = \"C*spin\"   # kg m^2/s");
  return replace_line(text, "psi = ", "psi = { initial = 0, momentum = \"p\" }");
}

TEST(Map, ExactDerivativesMatchCentralDifferences) {
  std::mt19937 rng(21);
  // Foucault: lengths, a map with t (g, G from the frame's turning), and an
  // exaggerated Wz so that G is not lost below the rounding of g.
  const System foucault = load("foucault.toml", {set("Omega", 0.3)});
  EXPECT_TRUE(foucault.has_frame_coupling());
  const System top = load("spinning_top.toml");
  const System top_p = parse(top_by_momentum());
  const System spherical = load("spherical_pendulum_angles.toml");
  const VectorX phi0 = VectorX::Constant(1, 2.0);
  const System spherical_p = with_steady_momenta(spherical, phi0);  // Routh: V' has p²/(2 m r² sin²φ)
  EXPECT_EQ(spherical_p.map().coordinates[1].ignorable->given, Ignorable::Given::momentum);
  for (int trial = 0; trial < 2; ++trial) {
    const std::string t = " trial " + std::to_string(trial);
    expect_derivatives_match_differences(foucault, random_around(foucault, VectorX::Zero(2), rng, 1.0), "foucault" + t);
    expect_derivatives_match_differences(top, random_around(top, VectorX::Zero(2), rng, 0.9), "top, rate" + t);
    expect_derivatives_match_differences(top_p, random_around(top_p, VectorX::Zero(2), rng, 0.9), "top, momentum" + t);
    expect_derivatives_match_differences(spherical, random_around(spherical, phi0, rng, 0.8), "spherical, rate" + t);
    expect_derivatives_match_differences(spherical_p, random_around(spherical_p, phi0, rng, 0.8), "spherical, momentum" + t);
  }
  // The momentum form's G is not zero off the upright: g' = (p sin b, 0).
  Workspace w(top_p);
  EXPECT_GT(max_abs(gyroscopic_matrix(top_p, w, Eigen::Vector2d(0.3, 0.2))), 0.1 * 0.32);
}

// --- 3. Ṁ − 2C skew -----------------------------------------------------------------

TEST(Map, MdotMinusTwoCIsSkewSymmetric) {
  // Ṁ = Σ_k ∂M/∂q_k q̇_k; C + Cᵀ = Ṁ holds term by term in the Christoffel
  // symbols, so the symmetric part of Ṁ − 2C is rounding: 1e-13 of ‖Ṁ‖.
  std::mt19937 rng(31);
  for (const System& s : {load("double_pendulum_map.toml"), parse(top_by_momentum())}) {
    Workspace w(s);
    const VectorX q = test::random_state(s, rng, 1.2), qd = test::random_state(s, rng, 2.0);
    const std::vector<MatrixX> dM = mass_matrix_derivatives(s, w, q);
    MatrixX Mdot = MatrixX::Zero(s.size(), s.size());
    for (int k = 0; k < s.size(); ++k) Mdot += dM[static_cast<std::size_t>(k)] * qd[k];
    const MatrixX N = Mdot - 2 * coriolis(s, w, q, qd);
    EXPECT_GT(max_abs(Mdot), 0.01 * max_abs(mass_matrix(s, w, q)));  // not trivially zero
    EXPECT_LE(max_abs(N + N.transpose()), 1e-13 * max_abs(Mdot)) << s.title();
  }
}

// --- 4. R7: bead on a hoop, as a map ------------------------------------------------

struct Analysis {
  Equilibrium equilibrium;
  LinearModel lin;
  ModalResult modes;
};
Analysis analyze(const System& s, const VectorX& start) {
  Analysis a;
  a.equilibrium = find_equilibrium(s, start);
  a.lin = linearize(s, a.equilibrium.q);
  a.modes = solve_modes(a.lin);
  return a;
}

TEST(Map, R7BeadOnHoopBranches) {
  // Closed forms evaluated with the model's defaults; the eigenvalue of a 1×1
  // problem is K/M, computed to rounding: 1e-10 relative leaves ample margin.
  const double g = 9.81, R = 1.0;
  {
    const Analysis bottom = analyze(load("bead_on_hoop.toml"), VectorX::Constant(1, 0.1));  // Ω = 2
    EXPECT_NEAR(bottom.equilibrium.q[0], 0.0, 1e-12);
    ASSERT_EQ(bottom.modes.modes.size(), 1u);
    EXPECT_NEAR(bottom.modes.modes[0].omega2, 5.81, 1e-10 * 5.81);
    EXPECT_NEAR(bottom.modes.modes[0].omega2, g / R - 4.0, 1e-10 * 5.81);
    EXPECT_EQ(bottom.modes.stability, Stability::stable);
    EXPECT_FALSE(bottom.lin.has_gyroscopic);
  }
  const double Omega = 5.0;
  const System s = load("bead_on_hoop.toml", {set("Omega", Omega)});
  const Analysis bottom = analyze(s, VectorX::Constant(1, 0.02));
  EXPECT_NEAR(bottom.equilibrium.q[0], 0.0, 1e-12);
  EXPECT_NEAR(bottom.modes.modes[0].omega2, g / R - Omega * Omega, 1e-10 * Omega * Omega);
  EXPECT_EQ(bottom.modes.stability, Stability::divergence);
  const double theta0 = std::acos(g / (R * Omega * Omega)), lambda = Omega * Omega - g * g / (R * R * Omega * Omega);
  for (const double side : {1.0, -1.0}) {
    const Analysis off = analyze(s, VectorX::Constant(1, side * (theta0 + 0.05)));
    EXPECT_NEAR(off.equilibrium.q[0], side * theta0, 1e-10);
    EXPECT_NEAR(off.modes.modes[0].omega2, lambda, 1e-10 * lambda);
    EXPECT_EQ(off.modes.stability, Stability::stable);
  }
}

TEST(Map, R7SwitchFoundBySweep) {
  // 13 points, 0 to 6 rad/s, along the bottom branch: stable until Ω² = g/R.
  // The refinement's bracket is 1e-10 relative (SweepOptions); its indicator,
  // λ = g/R − Ω², is linear near the switch. Checked to 1e-9 relative and
  // within the reported error.
  const SweepResult r = sweep(read_model("bead_on_hoop.toml"), model_path("bead_on_hoop.toml"), {},
                              parse_vary("Omega=0:6:13"));
  ASSERT_EQ(r.critical.size(), 1u);
  const CriticalValue& c = r.critical[0];
  const double exact = std::sqrt(9.81 / 1.0);
  EXPECT_NEAR(exact, 3.132091953, 1e-9);
  EXPECT_EQ(c.kind, CriticalKind::divergence);
  EXPECT_EQ(c.before, Stability::stable);
  EXPECT_EQ(c.after, Stability::divergence);
  EXPECT_TRUE(c.refined);
  EXPECT_LE(std::abs(c.value - exact), 1e-9 * exact);
  EXPECT_LE(std::abs(c.value - exact), c.error + 4 * kEps * exact);
  std::cout << "  R7 switch: " << c.value << " ± " << c.error << ", off by " << c.value - exact << "\n";
}

// --- 5. Foucault's pendulum -------------------------------------------------------------

TEST(Map, FoucaultPendulum) {
  const System s = load("foucault.toml");
  const double m = 28, l = 67, g = 9.81, Omega = 7.2921159e-5, latitude = 48.8462 * kPi / 180;
  const double Wz = Omega * std::sin(latitude);
  EXPECT_EQ(s.coordinates()[0].kind, CoordinateKind::length);
  const Equilibrium e = find_equilibrium(s, s.initial_configuration());  // from x = 0.5 m
  EXPECT_LE(e.q.cwiseAbs().maxCoeff(), 1e-12 * l);
  const LinearModel lin = linearize(s, e.q);
  // M = m I, K = m g/l I, G = 2 m Wz [[0, −1], [1, 0]]: G_ij = ∂g_i/∂q_j − ∂g_j/∂q_i
  // with g = m Wz (−y, x) (the laboratory turns counter-clockwise seen from
  // above), the same matrix as for a rotating frame (modal/core.hpp).
  const Eigen::Matrix2d I = Eigen::Matrix2d::Identity();
  EXPECT_LE(max_abs(lin.M - m * I), 1e-14 * m);
  // K = m g/l I − m Wz² I + m Wz² I (the potential line cancels −T₀): exact
  // cancellation of terms 2e-8 of K, rounding only.
  EXPECT_LE(max_abs(lin.K - m * g / l * I), 1e-12 * m * g / l);
  ASSERT_TRUE(lin.has_gyroscopic);
  EXPECT_LE(max_abs(lin.G - 2 * m * Wz * Eigen::Matrix2d{{0, -1}, {1, 0}}), 1e-12 * 2 * m * Wz);
  // ω = √(g/l + Wz²) ± Wz. The first-order eigenvalues of this 4×4 system are
  // computed to ~ε‖A‖ ≈ 1e-16 rad/s, ~1e-15 relative: 1e-12. Their half
  // difference Wz = 5.5e-5 rad/s is 7000 times smaller than ω, so the same
  // absolute error is ~1e-12 relative there: 1e-9.
  const ModalResult r = solve_modes(lin);
  EXPECT_EQ(r.stability, Stability::stable);
  const std::vector<double> w = omegas(r);
  ASSERT_EQ(w.size(), 2u);
  const double w0 = std::sqrt(g / l + Wz * Wz);
  EXPECT_LE(relative(w[0], w0 - Wz), 1e-12);
  EXPECT_LE(relative(w[1], w0 + Wz), 1e-12);
  const double precession = 0.5 * (w[1] - w[0]);
  EXPECT_LE(relative(precession, Omega * std::sin(latitude)), 1e-9);
  std::cout << "  Foucault: omega " << w[0] << ", " << w[1] << " (rel. errors " << relative(w[0], w0 - Wz) << ", "
            << relative(w[1], w0 + Wz) << "); precession " << precession << " rad/s, rel. error "
            << relative(precession, Wz) << "; one turn in " << 2 * kPi / precession / 3600 << " h\n";
}

// --- 6. the sleeping top --------------------------------------------------------------

struct Top {
  double m = 1, h = 0.1, A_c = 0.002, C = 0.004, g = 9.81;  // the model's defaults
  double A() const { return A_c + m * h * h; }               // about the tip
  double critical_spin() const { return 2 * std::sqrt(A() * m * g * h) / C; }
};

TEST(Map, SleepingTopIsStabilizedBySpin) {
  const Top top;
  const double spin = 80, p = top.C * spin;
  const System s = load("spinning_top.toml");
  EXPECT_EQ(s.coordinate_names(), (std::vector<std::string>{"a", "b"}));
  ASSERT_EQ(s.ignorable_coordinates(), std::vector<int>{2});
  const Analysis a = analyze(s, s.initial_configuration());
  EXPECT_LE(a.equilibrium.q.cwiseAbs().maxCoeff(), 1e-14);
  // M = A I, K = −m g h I, G = p [[0, 1], [−1, 0]] (model header); entries of
  // order 0.01–1 computed to rounding.
  const Eigen::Matrix2d I = Eigen::Matrix2d::Identity();
  EXPECT_LE(max_abs(a.lin.M - top.A() * I), 1e-14);
  EXPECT_LE(max_abs(a.lin.K + top.m * top.g * top.h * I), 1e-13);
  EXPECT_LE(max_abs(a.lin.G - p * Eigen::Matrix2d{{0, 1}, {-1, 0}}), 1e-14);
  // A ω² − p ω + m g h = 0: ω = [p ± √(p² − 4 A m g h)]/(2A); well separated
  // (3.5 and 23 rad/s), computed to ~1e-15 relative: 1e-12.
  const double root = std::sqrt(p * p - 4 * top.A() * top.m * top.g * top.h);
  const std::vector<double> w = omegas(a.modes);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_LE(relative(w[0], (p - root) / (2 * top.A())), 1e-12);
  EXPECT_LE(relative(w[1], (p + root) / (2 * top.A())), 1e-12);
  EXPECT_EQ(a.modes.stability, Stability::stable);
  // The steady motion: ψ̇ = spin, p = C ψ̇ (M_cc = C, no g_c).
  const std::vector<SteadyRate> steady = steady_motion(s, a.equilibrium.q);
  ASSERT_EQ(steady.size(), 1u);
  EXPECT_EQ(steady[0].coordinate, "psi");
  EXPECT_EQ(steady[0].rate, spin);
  EXPECT_NEAR(steady[0].momentum, p, 1e-15);
  ASSERT_EQ(a.modes.steady.size(), 1u);
  EXPECT_NEAR(a.modes.steady[0].momentum, p, 1e-15);

  // Below the threshold: a complex quadruple (flutter); without spin, K < 0 alone (divergence).
  const Analysis slow = analyze(load("spinning_top.toml", {set("spin", 30)}), VectorX::Zero(2));
  EXPECT_EQ(slow.modes.stability, Stability::flutter);
  const Analysis still = analyze(load("spinning_top.toml", {set("spin", 0)}), VectorX::Zero(2));
  EXPECT_EQ(still.modes.stability, Stability::divergence);
  EXPECT_EQ(still.modes.morse_index, 2);
}

TEST(Map, SleepingTopByMomentumEqualsByRate) {
  // The same steady motion given by p = C·80 instead of ψ̇ = 80: Routh's
  // reduction at p vs the rate form turned into it by with_steady_momenta.
  // M, K, G agree to rounding; the modes to 1e-10 (they are ~1e-15 apart).
  const System rate = load("spinning_top.toml"), momentum = parse(top_by_momentum());
  const VectorX q = VectorX::Zero(2);
  const std::vector<SteadyRate> steady = steady_motion(momentum, q);
  ASSERT_EQ(steady.size(), 1u);
  EXPECT_NEAR(steady[0].rate, 80.0, 1e-13);
  EXPECT_NEAR(steady[0].momentum, 0.004 * 80, 1e-15);
  const Analysis a = analyze(rate, q), b = analyze(momentum, q);
  EXPECT_LE(max_abs(a.lin.M - b.lin.M), 1e-15);
  EXPECT_LE(max_abs(a.lin.K - b.lin.K), 1e-14);
  EXPECT_LE(max_abs(a.lin.G - b.lin.G), 1e-15);
  ASSERT_EQ(a.modes.modes.size(), b.modes.modes.size());
  for (std::size_t i = 0; i < a.modes.modes.size(); ++i) {
    EXPECT_LE(std::abs(a.modes.modes[i].s - b.modes.modes[i].s), 1e-10 * std::abs(a.modes.modes[i].s));
    EXPECT_LE((a.modes.modes[i].shape - b.modes.modes[i].shape).cwiseAbs().maxCoeff(), 1e-10);
  }
  EXPECT_EQ(a.modes.stability, b.modes.stability);
}

TEST(Map, SleepingTopThresholdBySweep) {
  // 19 points from 10 to 100 rad/s (step 5): flutter until the threshold
  // 2√(A m g h)/C, stable after. The bracket is refined to 1e-10 relative;
  // near the threshold the pair's growth rate goes as √(spin_c − spin) and the
  // eigenvalues of the nearly defective pair carry errors ~√ε, which may move
  // the class change by ~ε relative: checked to 1e-8 and within the error.
  const Top top;
  const SweepResult r = sweep(read_model("spinning_top.toml"), model_path("spinning_top.toml"), {},
                              parse_vary("spin=10:100:19"));
  ASSERT_EQ(r.critical.size(), 1u);
  const CriticalValue& c = r.critical[0];
  const double exact = top.critical_spin();
  EXPECT_NEAR(exact, 54.24942, 1e-5);
  EXPECT_EQ(c.kind, CriticalKind::flutter);
  EXPECT_EQ(c.before, Stability::flutter);
  EXPECT_EQ(c.after, Stability::stable);
  EXPECT_TRUE(c.restabilization());
  EXPECT_LE(relative(c.value, exact), 1e-8);
  EXPECT_LE(std::abs(c.value - exact), c.error + 4 * kEps * exact);
  // Both modes meet at ω = p/(2A) = √(m g h / A) there: on the flutter side of
  // the bracket Im s = C·spin/(2A) exactly, so its error is the spin's (1e-8);
  // on the stable side the two split by ~√(relative distance) ≈ √(1e-10):
  // 1e-5 allowed.
  const double omega = std::sqrt(top.m * top.g * top.h / top.A());
  EXPECT_LE(relative(c.omega, omega), 1e-5);
  std::cout << "  top threshold: " << c.value << " ± " << c.error << " (exact " << exact << ", rel. "
            << relative(c.value, exact) << "); omega " << c.omega << " (exact " << omega << ", rel. "
            << relative(c.omega, omega) << ")\n";
}

// A pendulum (mass m, length l) hanging from a cart (mass M) that rolls
// freely along x: x does not appear in T or V (ignorable; a length), and its
// momentum is coupled to the swing at the equilibrium (M_rc = m l ≠ 0).
std::string pendulum_on_cart(const std::string& x_line) {
  return R"toml(gravity = [0, 0, "-g"]
[parameters]
M = 2.0
m = 0.5
l = 0.8
g = 9.81
v = 0.7
[coordinates]
)toml" + x_line + R"toml(
phi = 0.1
[[point]]
name = "cart"
mass = "M"
position = ["x", 0, 0]
[[point]]
name = "bob"
mass = "m"
position = ["x + l*sin(phi)", 0, "-l*cos(phi)"]
)toml";
}

TEST(Map, RouthReductionOfAPendulumOnAFreeCart) {
  // Routh: M' = m l² − (m l)²/(M + m) at phi = 0, K = m g l, so
  // ω² = g (M + m)/(M l) for any conserved momentum p of the cart (Galilean
  // invariance; p enters V' only through the constant p²/(2(M + m))). Given
  // the rate v instead, the steady motion has p = (M + m) v and is analyzed as
  // the free motion at that momentum (modal/linearize.hpp): the same ω².
  // A 1×1 problem: rounding only, 1e-12.
  const double M = 2, m = 0.5, l = 0.8, g = 9.81, v = 0.7;
  const double lambda = g * (M + m) / (M * l);
  for (const std::string& x : {std::string("x = { initial = 0, rate = \"v\" }"),
                               std::string("x = { initial = 0, momentum = \"(M + m)*v\" }"),
                               std::string("x = { initial = 0, momentum = 0 }")}) {
    SCOPED_TRACE(x);
    const System s = parse(pendulum_on_cart(x));
    EXPECT_EQ(s.coordinate_names(), std::vector<std::string>{"phi"});
    const Analysis a = analyze(s, s.initial_configuration());
    EXPECT_NEAR(a.equilibrium.q[0], 0.0, 1e-14);
    EXPECT_NEAR(a.lin.M(0, 0), m * l * l * M / (M + m), 1e-15);
    EXPECT_NEAR(a.lin.K(0, 0), m * g * l, 1e-14);
    ASSERT_EQ(a.modes.modes.size(), 1u);
    EXPECT_LE(relative(a.modes.modes[0].omega2, lambda), 1e-12);
    ASSERT_EQ(a.lin.steady.size(), 1u);
    EXPECT_EQ(a.lin.steady[0].coordinate, "x");
    const bool at_rest = x.find("momentum = 0") != std::string::npos;
    EXPECT_NEAR(a.lin.steady[0].momentum, at_rest ? 0.0 : (M + m) * v, 1e-15);
    EXPECT_NEAR(a.lin.steady[0].rate, at_rest ? 0.0 : v, 1e-15);
  }
  // Without the reduction (x kept): a zero mode (the cart's drift) and the same swing.
  const System kept = parse(pendulum_on_cart("x = 0.0"));
  const ModalResult r = solve_modes(linearize(kept, VectorX::Zero(2)));
  EXPECT_EQ(r.stability, Stability::marginal);
  EXPECT_EQ(r.zero_modes, 1);
  EXPECT_LE(relative(r.modes.back().omega2, lambda), 1e-12);
  EXPECT_TRUE(steady_motion(kept, VectorX::Zero(2)).empty());
}

// --- 7. the spherical pendulum in spherical angles --------------------------------------

TEST(Map, SphericalPendulumConicalMotion) {
  const double m = 1, r = 1, g = 9.81, w = 5;
  const System s = load("spherical_pendulum_angles.toml");
  EXPECT_EQ(s.coordinate_names(), std::vector<std::string>{"phi"});
  const Analysis a = analyze(s, s.initial_configuration());  // from phi = 2.5
  // The rod at a0 from the downward vertical, cos a0 = g/(r w²); ω² = w²(1 + 3 cos² a0).
  const double a0 = std::acos(g / (r * w * w)), phi0 = kPi - a0;
  EXPECT_NEAR(a.equilibrium.q[0], phi0, 1e-10);
  ASSERT_EQ(a.modes.modes.size(), 1u);
  const double lambda = w * w * (1 + 3 * std::pow(std::cos(a0), 2));
  EXPECT_LE(relative(a.modes.modes[0].omega2, lambda), 1e-10);
  EXPECT_EQ(a.modes.stability, Stability::stable);
  ASSERT_EQ(a.lin.steady.size(), 1u);
  EXPECT_EQ(a.lin.steady[0].coordinate, "theta");
  EXPECT_LE(relative(a.lin.steady[0].rate, w), 1e-12);  // p/M_cc of the momentum form analyzed
  EXPECT_LE(relative(a.lin.steady[0].momentum, m * r * r * std::pow(std::sin(phi0), 2) * w), 1e-12);
  std::cout << "  conical motion: phi0 " << a.equilibrium.q[0] << ", omega2 " << a.modes.modes[0].omega2
            << " (rel. error " << relative(a.modes.modes[0].omega2, lambda) << ")\n";
}

TEST(Map, SphericalAnglesAtThePoleReportASingularMassMatrix) {
  // w = 0: the steady motion is the rest at the bottom phi = π, where the mass
  // of theta, m r² sin²φ, vanishes: Routh's reduction is undefined.
  const System s = load("spherical_pendulum_angles.toml", {set("w", 0)});
  const Equilibrium e = find_equilibrium(s, s.initial_configuration());  // as `modal analyze` does
  EXPECT_NEAR(std::abs(e.q[0]), kPi, 1e-8);
  try {
    (void)linearize(s, e.q);
    ADD_FAILURE() << "no error at the pole";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("mass matrix is singular"), std::string::npos) << e.what();
  }
  // theta as a plain coordinate: M = diag(m r², m r² sin²φ) is singular at (π, 0),
  // which solve_modes reports naming theta.
  const System plain = parse(replace_line(read_model("spherical_pendulum_angles.toml"), "theta = ", "theta = 0.0"));
  EXPECT_EQ(plain.coordinate_names(), (std::vector<std::string>{"phi", "theta"}));
  EXPECT_TRUE(plain.ignorable_coordinates().empty());
  const LinearModel lin = linearize(plain, Eigen::Vector2d(kPi, 0));
  try {
    (void)solve_modes(lin);
    ADD_FAILURE() << "no error for a singular mass matrix";
  } catch (const SingularMassMatrix& e) {
    EXPECT_NE(std::string(e.what()).find("theta"), std::string::npos) << e.what();
  }
}

// --- 8. what maps cannot be -------------------------------------------------------------

// A point mass 1 kg at `position` (a TOML array of expressions in phi), with
// the parameters g = 9.81, l = 1 and `parameters` (TOML lines); [coordinates] is line 7
// when `parameters` has two lines.
std::string pendulum_scene(const std::string& parameters, const std::string& position) {
  return "gravity = [0, 0, \"-g\"]\n[parameters]\ng = 9.81\nl = 1.0\n" + parameters +
         "[coordinates]\nphi = 0.1\n[[point]]\nmass = 1\nposition = " + position + "\n";
}

std::string parse_error(const std::string& text) {
  try {
    (void)parse_scene(text, "bad.toml");
  } catch (const SceneError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error for:\n" << text;
  return "";
}

TEST(Map, NonSteadyMapsAreRejected) {
  // A pendulum whose pivot oscillates: g = −l a w sin(wt) cos φ depends on t,
  // a periodic (Floquet) problem, not an equilibrium.
  const std::string shaken = pendulum_scene("a = 0.1\nw = 3.0\n", R"x(["l*sin(phi) + a*cos(w*t)", 0, "-l*cos(phi)"])x");
  const std::string what = parse_error(shaken);
  EXPECT_NE(what.find("bad.toml:7:1: coordinates: "), std::string::npos) << what;
  EXPECT_NE(what.find("depends on time"), std::string::npos) << what;
  EXPECT_NE(what.find("Floquet"), std::string::npos) << what;
  // A steadily turning frame written with t is accepted.
  EXPECT_NO_THROW((void)parse_scene(read_model("bead_on_hoop.toml"), "bead_on_hoop.toml"));
  // The same pivot at rest: accepted.
  EXPECT_NO_THROW((void)parse_scene(shaken, "bad.toml", {{"a", "0"}}));
}

TEST(Map, IgnorableCoordinateTheEnergyDependsOnIsRejected) {
  std::string text = read_model("spherical_pendulum_angles.toml");
  text = replace_line(text, "phi = ", "phi = { initial = 2.5, rate = \"w\" }");
  text = replace_line(text, "theta = ", "theta = 0.0");
  const std::string what = parse_error(text);
  EXPECT_NE(what.find("coordinate 'phi' is declared ignorable"), std::string::npos) << what;
}

// A plane pendulum whose plane is at a fixed azimuth given by a parameter
// named t. The expressions' variables are [coordinates, t, parameters]; were
// `t` resolved to the time (the first match), the pendulum would silently
// become a bead on a hoop turning at 1 rad/s (ω² = g/l − 1 = 8.81 instead of
// g/l = 9.81), as it did before the reader rejected the name. Either cure
// passes: a SceneError at parameters.t, or a `t` that really is the parameter.
TEST(Map, ParameterNamedTIsNotSilentlyTheTime) {
  const std::string text =
      pendulum_scene("t = 0.5\n", R"x(["l*sin(phi)*cos(t)", "l*sin(phi)*sin(t)", "-l*cos(phi)"])x");
  try {
    const System s = parse(text);
    const Analysis a = analyze(s, s.initial_configuration());
    EXPECT_LE(relative(a.modes.modes[0].omega2, 9.81), 1e-12);
  } catch (const SceneError& e) {
    EXPECT_EQ(e.key(), "parameters.t") << e.what();
  }
}

// --- 9. kinds and periodicity -------------------------------------------------------------

TEST(Map, CoordinateKindsAndPeriodicity) {
  const System pendulum = load("double_pendulum_map.toml");
  for (const Coordinate& c : pendulum.coordinates()) {
    EXPECT_EQ(c.kind, CoordinateKind::angle) << c.name;
    EXPECT_TRUE(c.periodic) << c.name;
  }
  const System foucault = load("foucault.toml");
  for (const Coordinate& c : foucault.coordinates()) {
    EXPECT_EQ(c.kind, CoordinateKind::length) << c.name;
    EXPECT_FALSE(c.periodic) << c.name;
  }
  // A torsion spring ½kφ² makes φ and φ + 2π different configurations.
  const std::string spring = R"toml(potential = "0.5*k*phi^2"
[parameters]
k = 2.0
[coordinates]
phi = 0.1
[[point]]
mass = 1
position = ["sin(phi)", 0, "-cos(phi)"]
)toml";
  const System with_spring = parse(spring);
  EXPECT_FALSE(with_spring.coordinates()[0].periodic);
  EXPECT_EQ(with_spring.coordinates()[0].kind, CoordinateKind::length);  // unset and not periodic (core.hpp)
  const System declared = parse(replace_line(spring, "phi = ", "phi = { initial = 0.1, kind = \"angle\" }"));
  EXPECT_FALSE(declared.coordinates()[0].periodic);
  EXPECT_EQ(declared.coordinates()[0].kind, CoordinateKind::angle);
  const System without = parse(spring, {{"k", "0"}});
  EXPECT_TRUE(without.coordinates()[0].periodic);
  EXPECT_EQ(without.coordinates()[0].kind, CoordinateKind::angle);
}

// --- 10. the Jacobi integral in time integration -----------------------------------------

// The largest |E − E₀| over the samples relative to the largest kinetic
// energy ½q̇ᵀMq̇ of the motion: unlike simulate()'s max_energy_error (relative
// to max(|E₀|, …)), not diluted by a constant in V − T₀ (for the top, ½Cψ̇² is
// 40 times the energy of the wobble).
double drift_per_kinetic_energy(const System& s, const Trajectory& tr) {
  Workspace w(s);
  double drift = 0, kinetic = 0;
  for (std::size_t i = 0; i < tr.size(); ++i) {
    drift = std::max(drift, std::abs(tr.energy[i] - tr.energy.front()));
    kinetic = std::max(kinetic, kinetic_energy(s, w, tr.q[i], tr.qd[i]));
  }
  return drift / kinetic;
}

// Why 1e-9: rk8pd at its default tolerance 1e-12 keeps the energy error of
// such motions near 1e-12–1e-11 (printed), while a wrong term in the equations
// of motion breaks the balance at 1e-3 or more within a period.
TEST(Map, JacobiIntegralIsConservedForTheBead) {
  // Ω = 2 (bottom ω² = 5.81), from θ = 1 rad at rest, for 100 periods of the
  // linear mode (the large swing's own period is longer: ~90 swings).
  const System s = load("bead_on_hoop.toml");
  SimulationOptions o;
  o.duration = 100 * 2 * kPi / std::sqrt(5.81);
  const Trajectory tr = simulate(s, VectorX::Constant(1, 1.0), VectorX::Zero(1), o);
  const double drift = drift_per_kinetic_energy(s, tr);
  EXPECT_LE(tr.max_energy_error, 1e-9);
  EXPECT_LE(drift, 1e-9);
  std::cout << "  bead: " << tr.steps << " steps, energy error " << tr.max_energy_error << ", per kinetic energy "
            << drift << "\n";
}

TEST(Map, JacobiIntegralIsConservedForTheTop) {
  // Spin 80, tipped by a = 0.05 rad at rest: 2 periods of the slow mode
  // (3.5 rad/s), 13 of the fast one (23 rad/s). Kept short: the top's
  // right-hand side is the most expensive of the bundled maps (~45 µs in
  // Release, ~15 times that under the sanitizers).
  const System s = load("spinning_top.toml");
  const Top top;
  const double p = top.C * 80, root = std::sqrt(p * p - 4 * top.A() * top.m * top.g * top.h);
  const double slow = (p - root) / (2 * top.A()), fast = (p + root) / (2 * top.A());
  SimulationOptions o;
  o.duration = 2 * 2 * kPi / slow;
  o.interval = o.duration / 200;
  const Trajectory tr = simulate(s, Eigen::Vector2d(0.05, 0), VectorX::Zero(2), o);
  const double drift = drift_per_kinetic_energy(s, tr);
  EXPECT_LE(tr.max_energy_error, 1e-9);
  EXPECT_LE(drift, 1e-9);
  // Gyroscopically stable: released at rest, the linear motion z = a + ib is a
  // sum of the two circular modes with |z| ≤ 0.05 (ω₊ + ω₋)/(ω₊ − ω₋) = 0.068;
  // a top that fell would reach tilts of order 1.
  double tilt = 0;
  for (const VectorX& q : tr.q) tilt = std::max(tilt, q.norm());
  EXPECT_LE(tilt, 0.05 * (fast + slow) / (fast - slow) * 1.05);  // 5 %: the nonlinear terms, O(0.05²)
  std::cout << "  top: " << tr.steps << " steps, energy error " << tr.max_energy_error << ", per kinetic energy "
            << drift << ", largest tilt " << tilt << "\n";
}

}  // namespace
