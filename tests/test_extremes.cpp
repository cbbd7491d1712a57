// Numerical extremes (issue 6, part 5): each case either matches its closed
// form within the error modal itself reports (Mode::error_estimate, plus the
// rounding of the closed form), or is diagnosed in words. Never a silently
// wrong number.
//
// Cases so far: mass ratios 1e-9 … 1e9 between the two bobs of a double
// pendulum (R1), stiffness ratios up to 1e12 along a spring chain, and the
// same pendulum in nanometres and in kilometres, NaN, infinite and
// overflowing inputs, the spherical pendulum's double mode (orthogonal
// shapes), a chain of 5000 links (diagnosed: M at the rounding level), an
// equilibrium exactly at a bifurcation (λ = 0), free bodies (exact zero
// modes), and nearly singular mass matrices.
#include "modal/equilibrium.hpp"
#include "modal/linearize.hpp"
#include "modal/modes.hpp"
#include "modal/scene.hpp"
#include "program.hpp"
#include "systems.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <regex>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

namespace {

using namespace modal;
constexpr double kEps = std::numeric_limits<double>::epsilon();

ModalResult analyze_text(const std::string& text) {
  const Scene scene = parse_scene(text, "extreme.toml");
  const System sys = build_system(scene);
  const Equilibrium eq = find_equilibrium(sys, sys.initial_configuration());
  return solve_modes(linearize(sys, eq.q));
}

// |λ − λ_ref| within the reported error estimate and the closed form's own rounding.
void expect_within_estimate(const Mode& m, double lambda_ref, const std::string& what) {
  EXPECT_LE(std::abs(m.omega2 - lambda_ref), m.error_estimate + 16 * kEps * std::abs(lambda_ref))
      << what << ": omega2 " << m.omega2 << " reference " << lambda_ref << " estimate " << m.error_estimate;
}

std::string number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

// A planar double pendulum, equal rods l, bobs m1 (upper) and m2, gravity g.
std::string double_pendulum(double m1, double m2, double l, double g) {
  return "gravity = [0, 0, " + number(-g) + "]\n"
         "[[body]]\nname = \"upper\"\njoint = \"hinge\"\naxis = [0, 1, 0]\nmass = " + number(m1) +
         "\ncom = [0, 0, " + number(-l) + "]\n"
         "[[body]]\nname = \"lower\"\nparent = \"upper\"\njoint = \"hinge\"\naxis = [0, 1, 0]\norigin = [0, 0, " +
         number(-l) + "]\nmass = " + number(m2) + "\ncom = [0, 0, " + number(-l) + "]\n";
}

// R1 with l1 = l2 = l: ω² = (g/l)(1 + μ)(1 ∓ r), r = √(μ/(1 + μ)), μ = m2/m1.
// The lower root without cancellation: (1 + μ)(1 − r) = (1 + μ)(1 − r²)/(1 + r)
// = 1/(1 + r), since 1 − r² = 1/(1 + μ) (forming 1 − r² itself would lose
// 1e-7 relative at μ = 1e9).
std::vector<double> double_pendulum_reference(double mu, double l, double g) {
  const double r = std::sqrt(mu / (1 + mu));
  return {g / l / (1 + r), g / l * (1 + mu) * (1 + r)};
}

TEST(Extremes, MassRatiosFrom1eMinus9To1e9) {
  for (double mu : {1e-9, 1e-6, 1e-3, 1.0, 1e3, 1e6, 1e9}) {
    const ModalResult r = analyze_text(double_pendulum(1.0, mu, 1.0, 9.81));
    const std::vector<double> ref = double_pendulum_reference(mu, 1.0, 9.81);
    ASSERT_EQ(r.modes.size(), 2u);
    for (std::size_t j = 0; j < 2; ++j)
      expect_within_estimate(r.modes[j], ref[j], "m2/m1 = " + number(mu) + ", mode " + std::to_string(j + 1));
    EXPECT_EQ(r.stability, Stability::stable) << "m2/m1 = " << mu;
  }
}

// Huge and tiny units in one scene: the same double pendulum with rods of
// 1 nm and of 1 km (ω² scales as g/l, by 1e9 and 1e-3).
TEST(Extremes, NanometresAndKilometres) {
  for (double l : {1e-9, 1e3}) {
    const ModalResult r = analyze_text(double_pendulum(1.0, 1.0, l, 9.81));
    const std::vector<double> ref = double_pendulum_reference(1.0, l, 9.81);
    ASSERT_EQ(r.modes.size(), 2u);
    for (std::size_t j = 0; j < 2; ++j)
      expect_within_estimate(r.modes[j], ref[j], "l = " + number(l) + ", mode " + std::to_string(j + 1));
  }
}

// Four unit masses on slides between two walls, joined by five springs
// k = [1, 1, K, 1, 1] (wall–1–2–3–4–wall), rest lengths as written. The
// chain is mirror-symmetric. Modes with u1 = u4, u2 = u3 leave the stiff
// spring unstretched: λ² − 3λ + 1 = 0, λ = (3 ∓ √5)/2 whatever K. Modes with
// u1 = −u4, u2 = −u3 stretch it: λ² − (3 + 2K)λ + (1 + 4K) = 0, the lower root
// formed as the product over the upper one (no cancellation).
std::string stiff_chain(double K) {
  std::string text = "gravity = [0, 0, 0]\n";
  for (int i = 1; i <= 4; ++i)
    text += "[[body]]\nname = \"m" + std::to_string(i) + "\"\njoint = \"slide\"\naxis = [1, 0, 0]\norigin = [" +
            std::to_string(i) + ", 0, 0]\nmass = 1\n";
  const std::vector<double> k = {1, 1, K, 1, 1};
  for (int i = 0; i <= 4; ++i) {
    const std::string a = i == 0 ? "world" : "m" + std::to_string(i);
    const std::string b = i == 4 ? "world" : "m" + std::to_string(i + 1);
    text += "[[spring]]\na = \"" + a + "\"\nb = \"" + b + "\"\n" + (i == 4 ? "b_point = [5, 0, 0]\n" : "") +
            "stiffness = " + number(k[static_cast<std::size_t>(i)]) + "\n";
  }
  return text;
}

TEST(Extremes, StiffnessRatiosUpTo1e12) {
  for (double K : {1.0, 1e6, 1e12}) {
    const double upper = ((3 + 2 * K) + std::sqrt((3 + 2 * K) * (3 + 2 * K) - 4 * (1 + 4 * K))) / 2;
    std::vector<double> ref = {(3 - std::sqrt(5.0)) / 2, (3 + std::sqrt(5.0)) / 2, (1 + 4 * K) / upper, upper};
    std::sort(ref.begin(), ref.end());
    const ModalResult r = analyze_text(stiff_chain(K));
    ASSERT_EQ(r.modes.size(), 4u);
    for (std::size_t j = 0; j < 4; ++j)
      expect_within_estimate(r.modes[j], ref[j], "K = " + number(K) + ", mode " + std::to_string(j + 1));
  }
}

// NaN, infinite and overflowing inputs: refused where they are written,
// with file:line:column, key and reason; never carried into a result.
TEST(Extremes, NanInfAndOverflowingInputs) {
  struct Case {
    std::string value, message;
  };
  const Case cases[] = {{"nan", "the value must be finite, got nan"},
                        {"inf", "the value must be finite, got inf"},
                        {"-inf", "the value must be finite, got -inf"},
                        {"\"1e400\"", "number '1e400' is out of range"},
                        {"\"1/0\"", "\"1/0\" evaluates to inf; the value must be finite"},
                        {"\"sqrt(-1)\"", "\"sqrt(-1)\" evaluates to nan; the value must be finite"},
                        {"\"1e300*1e300\"", "\"1e300*1e300\" evaluates to inf; the value must be finite"}};
  for (const Case& c : cases) {
    const std::string text = "[[body]]\nname = \"p\"\njoint = \"hinge\"\naxis = [0, 1, 0]\nmass = " + c.value +
                             "\ncom = [0, 0, -1]\n";
    try {
      (void)parse_scene(text, "extreme.toml");
      ADD_FAILURE() << "mass = " << c.value << " was accepted";
    } catch (const SceneError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind("extreme.toml:5:", 0), 0u) << what;
      EXPECT_NE(what.find("body[1].mass"), std::string::npos) << what;
      EXPECT_NE(what.find(c.message), std::string::npos) << what;
    }
  }
}

// Repeated eigenvalues: the spherical pendulum with a solid bob (ball joint)
// has a double swing mode, ω² = m g l/(m l² + I), and a zero mode (spin about
// the rod). The double mode's two shapes must be M-orthogonal and
// M-normalized, and orthogonal to the zero mode's: any basis of the
// eigenspace is right, a non-orthogonal one is not.
TEST(Extremes, RepeatedEigenvaluesHaveOrthogonalShapes) {
  const Scene scene = load_scene(std::string(MODAL_SOURCE_DIR) + "/models/spherical_pendulum.toml");
  const System sys = build_system(scene);
  const Equilibrium eq = find_equilibrium(sys, sys.initial_configuration());
  const LinearModel lin = linearize(sys, eq.q);
  const ModalResult r = solve_modes(lin);
  ASSERT_EQ(r.modes.size(), 3u);
  const double m = 1.0, l = 1.0, g = 9.81, I = 0.4 * m * 0.1 * 0.1;
  EXPECT_EQ(r.modes[0].kind, ModeKind::zero);
  EXPECT_LE(std::abs(r.modes[0].omega2), r.modes[0].error_estimate + 16 * kEps * g / l);
  EXPECT_EQ(r.zero_modes, 1);
  EXPECT_EQ(r.stability, Stability::marginal);
  for (std::size_t j : {1u, 2u}) expect_within_estimate(r.modes[j], m * g * l / (m * l * l + I), "swing " + std::to_string(j));
  Eigen::MatrixXd Phi(3, 3);
  for (int j = 0; j < 3; ++j) Phi.col(j) = r.modes[static_cast<std::size_t>(j)].shape.real();
  const Eigen::MatrixXd gram = Phi.transpose() * lin.M * Phi;
  EXPECT_LE((gram - Eigen::MatrixXd::Identity(3, 3)).cwiseAbs().maxCoeff(), 1e-12) << gram;
}

// Chains of thousands of links in relative joint angles: M_ij = m l² Σ_k
// (k − i + 1)(k − j + 1) over the links k below both joints, so ‖M‖ grows as
// N⁴ while its smallest eigenvalue does not. At N = 5000 the condition number
// is about 1e15 (smallest eigenvalue 6.6e-13 of ‖M‖₁ = 625) and the modes
// cannot be trusted in double precision: modal refuses, and says why. (At
// N = 2000 it reports ω₁² = 14.1797 against the continuum's 14.1834, R3.)
TEST(Extremes, ChainOf5000LinksIsDiagnosed) {
  const Scene scene = load_scene(std::string(MODAL_SOURCE_DIR) + "/models/hanging_chain.toml", {{"N", "5000"}});
  const System sys = build_system(scene);
  ASSERT_EQ(sys.size(), 5000);
  // The diagnosis depends on M alone (it comes before K is factored), so K is
  // left out of this test: M at the hanging configuration, as written.
  Workspace w(sys);
  const SparseMatrix M = sparse_mass_matrix(sys, w, sys.initial_configuration());
  SparseMatrix K(5000, 5000);
  K.setIdentity();
  try {
    (void)solve_sparse_modes(K, M, SparseModalOptions{});
    ADD_FAILURE() << "no diagnosis for a mass matrix at the rounding level";
  } catch (const SingularMassMatrix& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("at the rounding level"), std::string::npos) << what;
    EXPECT_NE(what.find("too ill-conditioned for double precision"), std::string::npos) << what;
  }
}

// An equilibrium exactly at a bifurcation: an inverted pendulum (mass m on a
// massless rod l, upright) with a joint spring at its buckling stiffness
// k = m g l, so V = ½kθ² + m g l cos θ has V'' = 0 at θ = 0 (a pitchfork:
// V' = m g l (θ − sin θ) ≈ m g l θ³/6). The true λ is 0; what modal computes
// can only be at the rounding level of K = k − m g l cos θ, i.e. a few ε·2mgl,
// and it must say so: a zero mode (|λ| within its estimate), stability
// marginal. Just above (k = m g l (1 + 1e-6)) the pendulum is stable with
// λ = 1e-6 g/l, which must come out within its estimate. (Before the fix the
// polish stopped at θ = 5e-5 and λ = 1.3e-8 was reported stable with an
// estimate of 4e-23.)
std::string sprung_inverted_pendulum(double k) {
  return "gravity = [0, 0, -9.81]\n[[body]]\nname = \"rod\"\njoint = \"hinge\"\naxis = [0, 1, 0]\nmass = 1\n"
         "com = [0, 0, 1]\nstiffness = " + number(k) + "\ninitial = 0.05\n";
}

TEST(Extremes, EquilibriumAtABifurcationIsAZeroMode) {
  const double g = 9.81;
  const ModalResult at = analyze_text(sprung_inverted_pendulum(g));
  ASSERT_EQ(at.modes.size(), 1u);
  EXPECT_EQ(at.modes[0].kind, ModeKind::zero) << "omega2 " << at.modes[0].omega2 << " estimate " << at.modes[0].error_estimate;
  EXPECT_LE(std::abs(at.modes[0].omega2), at.modes[0].error_estimate);
  EXPECT_LE(at.modes[0].error_estimate, 1e-13 * g);  // rounding level, not a loose bound
  EXPECT_EQ(at.stability, Stability::marginal);

  const ModalResult above = analyze_text(sprung_inverted_pendulum(g * (1 + 1e-6)));
  ASSERT_EQ(above.modes.size(), 1u);
  expect_within_estimate(above.modes[0], 1e-6 * g, "k = m g l (1 + 1e-6)");
  EXPECT_EQ(above.stability, Stability::stable);
}

// Exact zero modes: two free bodies in space (no gravity) joined by one
// unstretched spring between off-centre points. Of the 12 coordinates only the
// stretch of the spring is stiff: 11 zero modes (rigid motions, the bodies'
// turns about the spring's ends, its swing), each reported as a zero mode with
// |λ| within its estimate — none as divergent or stable by a rounding-size
// sign — and the stretch mode itself within its estimate of the closed form
// λ = k (1/m1 + 1/m2 + r²/I1 + r²/I2) for attachments offset by r from the
// centres perpendicular to the spring (a turn θ about z moves them by r θ
// along it; isotropic inertias).
TEST(Extremes, FreeBodiesHaveExactZeroModes) {
  const double k = 1e3, m1 = 2, m2 = 0.5, I1 = 0.3, I2 = 0.05, r1 = 0.2, r2 = r1;  // r2 = r1: the spring along x
  const std::string text =
      "gravity = [0, 0, 0]\n"
      "[[body]]\nname = \"a\"\njoint = \"free\"\nmass = " + number(m1) + "\ninertia = [" + number(I1) + ", " + number(I1) +
      ", " + number(I1) + ", 0, 0, 0]\n"
      "[[body]]\nname = \"b\"\njoint = \"free\"\norigin = [1, 0, 0]\nmass = " + number(m2) + "\ninertia = [" +
      number(I2) + ", " + number(I2) + ", " + number(I2) + ", 0, 0, 0]\n"
      "[[spring]]\na = \"a\"\na_point = [0, " + number(r1) + ", 0]\nb = \"b\"\nb_point = [0, " + number(r2) +
      ", 0]\nstiffness = " + number(k) + "\nrest_length = 1\n";
  const ModalResult r = analyze_text(text);
  ASSERT_EQ(r.modes.size(), 12u);
  EXPECT_EQ(r.zero_modes, 11);
  EXPECT_EQ(r.morse_index, 0);
  EXPECT_EQ(r.stability, Stability::marginal);
  for (std::size_t j = 0; j < 11; ++j) {
    EXPECT_EQ(r.modes[j].kind, ModeKind::zero) << "mode " << j + 1 << " omega2 " << r.modes[j].omega2;
    EXPECT_LE(std::abs(r.modes[j].omega2), r.modes[j].error_estimate) << "mode " << j + 1;
  }
  expect_within_estimate(r.modes[11], k * (1 / m1 + 1 / m2 + r1 * r1 / I1 + r2 * r2 / I2), "stretch");
}

// A nearly singular mass matrix: a double pendulum whose lower bob is lighter
// by μ = 1e-12 … 1e-18 than the upper, and a massless one (μ = 0). M's
// condition number grows as 1/μ and the upper mode as (g/l)/√μ. Each case is
// either within its own estimate of R1 or refused as a singular mass matrix
// naming the coordinate; never a wrong number presented as right.
TEST(Extremes, NearlySingularMassMatrix) {
  int refused = 0;
  for (double mu : {1e-12, 1e-14, 1e-16, 1e-18, 0.0}) {
    try {
      const ModalResult r = analyze_text(double_pendulum(1.0, mu, 1.0, 9.81));
      const std::vector<double> ref = double_pendulum_reference(mu, 1.0, 9.81);
      ASSERT_EQ(r.modes.size(), 2u);
      for (std::size_t j = 0; j < 2; ++j)
        expect_within_estimate(r.modes[j], ref[j], "m2/m1 = " + number(mu) + ", mode " + std::to_string(j + 1));
    } catch (const SingularMassMatrix& e) {
      ++refused;
      EXPECT_NE(std::string(e.what()).find("lower"), std::string::npos) << e.what();  // names the coordinate
    }
  }
  EXPECT_GE(refused, 1);  // a massless bob (μ = 0) at least is refused
}

// An equilibrium accepted at a loose tolerance: the modes at a point 1e-6 m
// off the equilibrium of a pre-tensioned, sagging net (dense and sparse
// paths; 588 coordinates, so that the sparse solver iterates) must be within
// their own estimates of the modes at the equilibrium.
// Before the estimates included the change of K on the way to the
// equilibrium (|K(q + δq) − K(q)|, δq the Newton correction), a net accepted
// at --eq-tol 1e-6 reported λ₁ = 234.5 ± 2e-9 against the true 265.7.
TEST(Extremes, LooseEquilibriumIsCoveredByTheEstimates) {
  std::string text =
      "gravity = [0, 0, -9.81]\n[[lattice]]\nname = \"net\"\nsize = [16, 16, 1]\nplane = \"xy\"\nspacing = 0.1\n"
      "mass = 0.002\nstiffness = 1000\nprestrain = 0.02\nfixed = \"boundary\"\n";
  const System sys = build_system(parse_scene(text, "net.toml"));
  const Equilibrium eq = find_equilibrium(sys, sys.initial_configuration());
  VectorX off = eq.q;
  for (Eigen::Index i = 0; i < off.size(); ++i) off[i] += 1e-6 * std::sin(1.0 + 7.0 * static_cast<double>(i));
  LinearizeOptions loose;
  loose.tolerance = 1e-2;
  const ModalResult exact = solve_modes(linearize(sys, eq.q));
  const LinearModel lin = linearize(sys, off, loose);
  ASSERT_GT(lin.residual, negligible_equilibrium_residual);
  ASSERT_GT(lin.K_systematic_error.size(), 0);
  const ModalResult dense = solve_modes(lin);
  ASSERT_EQ(dense.modes.size(), exact.modes.size());
  double worst = 0;  // the actual error, to show the case is not trivial
  for (std::size_t j = 0; j < dense.modes.size(); ++j) {
    const double actual = std::abs(dense.modes[j].omega2 - exact.modes[j].omega2);
    worst = std::max(worst, actual / exact.modes[j].omega2);
    EXPECT_LE(actual, dense.modes[j].error_estimate + exact.modes[j].error_estimate) << "dense mode " << j + 1;
  }
  EXPECT_GT(worst, 1e-9);
  const SparseLinearModel sparse = linearize_sparse(sys, off, loose);
  ASSERT_GT(sparse.K_equilibrium_shift.nonZeros(), 0);
  SparseModalOptions options;
  options.modes = 6;
  options.K_equilibrium_shift = sparse.K_equilibrium_shift;
  const ModalResult lowest = solve_sparse_modes(sparse.K, sparse.M, options);
  for (std::size_t j = 0; j < lowest.modes.size(); ++j)
    EXPECT_LE(std::abs(lowest.modes[j].omega2 - exact.modes[j].omega2),
              lowest.modes[j].error_estimate + exact.modes[j].error_estimate)
        << "sparse mode " << j + 1;
}

// The groups [first, last] (1-based) of the "modes a–b are not resolved"
// notes: the claims that eigenvalues may be one.
std::vector<std::pair<int, int>> multiplicity_claims(const ModalResult& r) {
  std::vector<std::pair<int, int>> groups;
  const std::regex claim("^modes ([0-9]+)–([0-9]+) are not resolved");
  for (const std::string& note : r.notes) {
    std::smatch m;
    if (std::regex_search(note, m, claim)) groups.emplace_back(std::stoi(m[1]), std::stoi(m[2]));
  }
  return groups;
}

int systematic_overlap_notes(const ModalResult& r) {
  int count = 0;
  for (const std::string& note : r.notes)
    count += note.find("closer together than the systematic part of their error estimates") != std::string::npos;
  return count;
}

// No multiplicity claimed where the eigenvalues are separated, at any
// equilibrium tolerance (issue 15, part 3). Generated pre-tensioned nets
// (rectangular or square: the square ones repeat eigenvalues by symmetry),
// prestrain log-uniform over [0.005, 0.05], linearized at a point 1e-5 … 1e-3
// m off their equilibrium and accepted there (loose tolerance), on the dense
// and the sparse paths. A group of modes claimed "not resolved … may be one
// repeated eigenvalue" is false where the exact equilibrium's eigenvalues of
// the group lie further apart than twice the largest error the loose values
// actually have (the criterion of bench/estimate_honesty.py; a pair repeated
// for the matrices as formed may be split at the exact equilibrium by less
// than that, as the flat net's (1,3)/(3,1) pair by its sag).
// Before the systematic part was kept out of the grouping
// (Mode::systematic_error), the estimates' loose-equilibrium share put
// separated modes into such claims.
TEST(Extremes, LooseEquilibriumClaimsNoFalseMultiplicity) {
  std::mt19937_64 rng(1503);
  int overlaps = 0, repeats_found = 0;
  for (int trial = 0; trial < 6; ++trial) {
    const int nx = std::uniform_int_distribution<int>(8, 14)(rng);
    const int ny = trial % 2 == 0 ? nx : std::uniform_int_distribution<int>(8, 14)(rng);
    const double prestrain = std::exp(std::uniform_real_distribution<double>(std::log(0.005), std::log(0.05))(rng));
    const double amplitude = std::exp(std::uniform_real_distribution<double>(std::log(1e-5), std::log(1e-3))(rng));
    const std::string what = "net " + std::to_string(nx) + "×" + std::to_string(ny) + " prestrain " +
                             std::to_string(prestrain) + " offset " + std::to_string(amplitude);
    const std::string text = "gravity = [0, 0, -9.81]\n[[lattice]]\nname = \"net\"\nsize = [" + std::to_string(nx) +
                             ", " + std::to_string(ny) +
                             ", 1]\nplane = \"xy\"\nspacing = 0.1\nmass = 0.002\nstiffness = 1000\nprestrain = " +
                             std::to_string(prestrain) + "\nfixed = \"boundary\"\n";
    const System sys = build_system(parse_scene(text, "net.toml"));
    const Equilibrium eq = find_equilibrium(sys, sys.initial_configuration());
    VectorX off = eq.q;
    for (Eigen::Index i = 0; i < off.size(); ++i)
      off[i] += amplitude * std::sin(1.0 + 7.0 * static_cast<double>(i));
    LinearizeOptions loose;
    // Accepted however loose (an offset of 1e-3 m unbalances a node by up
    // to a fifth of its own springs' forces): the notes are under test.
    loose.tolerance = 1;
    ModalOptions lowest;
    lowest.modes = 8;
    const ModalResult exact = solve_modes(linearize(sys, eq.q), lowest);
    repeats_found += static_cast<int>(multiplicity_claims(exact).size());
    auto check = [&](const ModalResult& r, const std::string& path) {
      ASSERT_GE(r.modes.size(), 8u) << what << path;
      for (std::size_t j = 0; j < 8; ++j) {
        EXPECT_GT(r.modes[j].systematic_error, 0) << what << path << " mode " << j + 1;
        EXPECT_LE(r.modes[j].systematic_error, r.modes[j].error_estimate) << what << path << " mode " << j + 1;
      }
      for (const auto& [first, last] : multiplicity_claims(r)) {
        if (last > 8) continue;
        const double a = exact.modes[static_cast<std::size_t>(first - 1)].omega2;
        const double b = exact.modes[static_cast<std::size_t>(last - 1)].omega2;
        double moved = 0;
        for (int j = first - 1; j < last; ++j)
          moved = std::max(moved, std::abs(r.modes[static_cast<std::size_t>(j)].omega2 -
                                           exact.modes[static_cast<std::size_t>(j)].omega2));
        EXPECT_LE(std::abs(b - a), 2 * moved + 1e-8 * std::abs(b))
            << what << path << ": modes " << first << "–" << last << " claimed not resolved, but at the exact "
            << "equilibrium their eigenvalues are " << a << " and " << b;
      }
      overlaps += systematic_overlap_notes(r);
    };
    const LinearModel lin = linearize(sys, off, loose);
    ASSERT_GT(lin.residual, negligible_equilibrium_residual) << what;
    check(solve_modes(lin, lowest), " (dense)");
    const SparseLinearModel sparse = linearize_sparse(sys, off, loose);
    SparseModalOptions options;
    options.modes = 8;
    options.K_equilibrium_shift = sparse.K_equilibrium_shift;
    check(solve_sparse_modes(sparse.K, sparse.M, options), " (sparse)");
  }
  EXPECT_GE(overlaps, 1);      // the loose estimates do overlap somewhere: the case is exercised
  EXPECT_GE(repeats_found, 1);  // and the square nets' true repeats are still claimed
}

// No multiplicity claimed beside a stiff mode: a cart (neutral slide) with a
// pendulum, a light link on a stiff joint at its end, and a bead on a second
// neutral slide, hanging. Closed form: λ = 0 twice (cart with pendulum, the
// bead), the pendulum's g/l (1 + mp/M) to within the link's share, and the
// link's k/I, 1e14 … 1e19 times the pendulum's. Only the two zero modes may
// be claimed as one eigenvalue: "64ε of the largest |λ|" had put the
// pendulum's λ (estimate 1.4e-3 at 19.6 rad²/s²) into the zero modes' group
// from a ratio of 7e13 on. (The pendulum's own estimate, 1e-19 of the stiff
// λ while the link was solved in its absolute angle, is now about 1e-13 of
// its own λ at every ratio: Graded.StiffJointsKeepTheSoftModes.)
TEST(Extremes, AStiffModeDoesNotMergeTheLowerOnes) {
  std::mt19937 rng(1964);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int trial = 0; trial < 6; ++trial) {
    const double ms = std::pow(10.0, -9 + 6 * unit(rng)), ls = std::pow(10.0, -4 + 2 * unit(rng));
    const double l = std::pow(10.0, -1 + 2 * unit(rng));
    const double k = std::pow(10.0, 14 + 5 * unit(rng)) * (9.81 / l * 2) * ms * ls * ls;  // λ ratio × λ × I
    const std::string what = "k " + number(k) + ", link mass " + number(ms) + ", link " + number(ls) + " m";
    const std::string text =
        "gravity = [0, 0, -9.81]\n"
        "[[body]]\nname = \"cart\"\njoint = \"slide\"\naxis = [1, 0, 0]\nmass = 1\n"
        "[[body]]\nname = \"pendulum\"\nparent = \"cart\"\njoint = \"hinge\"\naxis = [0, 1, 0]\nmass = 1\ncom = [0, 0, " +
        number(-l) + "]\n[[body]]\nname = \"link\"\nparent = \"pendulum\"\norigin = [0, 0, " + number(-l) +
        "]\njoint = \"hinge\"\naxis = [0, 1, 0]\nmass = " + number(ms) + "\ncom = [0, 0, " + number(-ls) +
        "]\nstiffness = " + number(k) +
        "\n[[body]]\nname = \"bead\"\njoint = \"slide\"\naxis = [0, 1, 0]\norigin = [5, 0, 0]\nmass = 1\n";
    const System sys = build_system(parse_scene(text, "stiff_link.toml"));
    const ModalResult r = solve_modes(linearize(sys, VectorX::Zero(sys.size())));
    ASSERT_EQ(r.modes.size(), 4u) << what;
    EXPECT_EQ(multiplicity_claims(r), (std::vector<std::pair<int, int>>{{1, 2}})) << what;
    const double pendulum = 9.81 / l * 2;  // g/l (1 + mp/M), mp = M = 1, the link's share below 1e-3
    EXPECT_NEAR(r.modes[2].omega2, pendulum, 2e-3 * pendulum) << what;
    EXPECT_GT(r.modes[3].omega2, 1e3 * pendulum) << what;
  }
}

}  // namespace

namespace {

// One hinge (about y) with moment of inertia I, a joint spring k and a joint
// damper c, no gravity: I θ̈ + c θ̇ + k θ = 0.
std::string oscillator(double I, double k, double c) {
  return "gravity = [0, 0, 0]\n[[body]]\nname = \"hinge\"\njoint = \"hinge\"\naxis = [0, 1, 0]\ninertia = [" +
         number(I) + ", " + number(I) + ", " + number(I) + ", 0, 0, 0]\nstiffness = " + number(k) +
         (c > 0 ? "\ndamping = " + number(c) : std::string()) + "\n";
}

}  // namespace

// Magnitudes over the whole double range (issue 20, part 2): ω² = k/I with
// I = 10^a and k = 10^b, a, b from −300 to 300, on the symmetric path, and
// with a damper c = 2ζ√(kI) (ζ = 0.1, s = ω(−ζ ± i√(1 − ζ²))) on the
// first-order path. Each case is answered within its stated error and
// classed as an oscillation, or refused in words — never "marginal" because
// an estimate overflowed (ω² = 1e160 was classed a zero mode, exit 0). Where
// ω² and the inputs are well inside the range (|b − a| ≤ 280, |a|, |b| ≤ 150)
// an answer is required.
TEST(Extremes, FrequenciesAcrossTheWholeDoubleRange) {
  for (int a = -300; a <= 300; a += 25)
    for (int b = -300; b <= 300; b += 25) {
      const long double I = std::pow(10.0L, a), k = std::pow(10.0L, b);
      const long double omega2 = k / I, omega = std::sqrt(omega2);
      const bool required = std::abs(b - a) <= 280 && std::abs(a) <= 150 && std::abs(b) <= 150;
      const std::string what = "I = 1e" + std::to_string(a) + ", k = 1e" + std::to_string(b);
      for (const bool damped : {false, true}) {
        const double zeta = 0.1;
        const long double c = damped ? 2 * zeta * std::sqrt(k * I) : 0.0L;
        if (damped && !(std::isfinite(static_cast<double>(c)) && static_cast<double>(c) > 0)) continue;
        try {
          const ModalResult r = analyze_text(oscillator(static_cast<double>(I), static_cast<double>(k),
                                                        static_cast<double>(c)));
          ASSERT_EQ(r.modes.size(), 1u) << what;
          const Mode& m = r.modes[0];
          if (!damped) {
            EXPECT_EQ(m.kind, ModeKind::oscillatory) << what;
            EXPECT_EQ(r.stability, Stability::stable) << what;
            EXPECT_LE(std::abs(m.omega2 - omega2), m.error_estimate + 16 * kEps * omega2) << what;
          } else {
            EXPECT_EQ(m.kind, ModeKind::damped) << what;
            EXPECT_EQ(r.stability, Stability::asymptotically_stable) << what;
            const long double re = -zeta * omega, im = omega * std::sqrt(1 - zeta * zeta);
            const long double err = std::hypot(m.s.real() - re, m.s.imag() - im);
            EXPECT_LE(err, m.error_estimate + 16 * kEps * omega) << what << " damped: s = " << m.s;
          }
        } catch (const NumericalError& e) {
          EXPECT_FALSE(required) << what << (damped ? " damped" : "") << ": " << e.what();
        } catch (const SceneError& e) {
          EXPECT_FALSE(required) << what << (damped ? " damped" : "") << ": " << e.what();
        }
      }
    }
}

// The issue's own case: the double pendulum with g up to 1e300 (ω² up to
// 3.4e300): stable, within the estimate of the closed form (2 ∓ √2) g/l.
TEST(Extremes, HugeGravityIsNotAZeroMode) {
  for (const double g : {1e150, 1e155, 1e160, 1e200, 1e250, 1e300}) {
    const ModalResult r = analyze_text(double_pendulum(1.0, 1.0, 1.0, g));
    const std::vector<double> ref = double_pendulum_reference(1.0, 1.0, g);
    ASSERT_EQ(r.modes.size(), 2u);
    EXPECT_EQ(r.stability, Stability::stable) << "g = " << g;
    EXPECT_EQ(r.zero_modes, 0) << "g = " << g;
    for (std::size_t j = 0; j < 2; ++j)
      expect_within_estimate(r.modes[j], ref[j], "g = " + number(g) + ", mode " + std::to_string(j + 1));
  }
}

namespace {

TEST(Extremes, WhereACompressedSpringsEndsMeetIsNoEquilibrium) {
  // models/spring_chain.toml (three masses on slides between walls, springs
  // of rest length a) compressed until its three masses meet: V is not
  // differentiable there (each inner spring's force has no direction), yet
  // the survey listed it as a stable equilibrium. The smooth equilibria
  // (closed form: every spring at its rest length, or some flipped through,
  // 5 configurations, no two masses closer than a/2) stay; the meeting point
  // is no equilibrium and has no linear model.
  const Scene scene = load_scene(std::string(MODAL_SOURCE_DIR) + "/models/spring_chain.toml");
  const System s = build_system(scene);
  const std::vector<Equilibrium> all = find_equilibria(s);
  EXPECT_EQ(all.size(), 5u);
  for (const Equilibrium& e : all) {
    const double x1 = 1 + e.q[0], x2 = 2 + e.q[1], x3 = 3 + e.q[2];  // positions, a = 1
    EXPECT_GT(std::min({std::abs(x1 - x2), std::abs(x2 - x3)}), 0.25) << e.q.transpose();
  }
  VectorX met(3);
  met << 1, 1e-12, -1;  // all three at x = 2a, within 1e-12 m (exactly together, ∇V throws)
  try {
    linearize(s, met);
    ADD_FAILURE() << "linearized where V is not differentiable";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("meet at this configuration"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'mass1' and 'mass2'"), std::string::npos) << e.what();
  }
}

TEST(Extremes, AStartWhereASpringsEndsCoincideIsNoStartButTheSurveyGoesOn) {
  // The chain's three masses written at one point (x = 0.3 m; rest lengths
  // 1 m, walls at 0 and 4 m): ∇V cannot be evaluated at the initial
  // configuration. The survey had stopped there ("a spring … has coincident
  // end points"); its other starts find the chain's 5 equilibria (every
  // spring carrying the same axial force, none with its ends within 0.25 m). The
  // nearest-equilibrium search goes on from the survey; with 1000 more
  // coordinates (beads on springs of their own) it is the large-scene
  // search's, which cannot start there, and says so naming the spring.
  auto chain = [](int beads) {
    std::string t = "title = \"coincident start\"\n";
    for (int i = 1; i <= 3; ++i)
      t += "[[body]]\nname = \"mass" + std::to_string(i) + "\"\njoint = \"slide\"\naxis = [1, 0, 0]\norigin = [0.3, 0, 0]\nmass = 1.0\n";
    const char* ends[][2] = {{"world", "mass1"}, {"mass1", "mass2"}, {"mass2", "mass3"}, {"mass3", "world"}};
    for (const auto& e : ends)
      t += std::string("[[spring]]\na = \"") + e[0] + "\"\nb = \"" + e[1] + "\"\nstiffness = 1.0\nrest_length = 1.0\n" +
           (std::string(e[1]) == "world" ? "b_point = [4, 0, 0]\n" : "");
    for (int j = 0; j < beads; ++j)
      t += "[[body]]\nname = \"bead" + std::to_string(j) + "\"\njoint = \"slide\"\naxis = [0, 1, 0]\norigin = [" +
           std::to_string(10 + j) + ", 0.5, 0]\nmass = 1.0\n[[spring]]\na = \"world\"\na_point = [" + std::to_string(10 + j) +
           ", 0, 0]\nb = \"bead" + std::to_string(j) + "\"\nstiffness = 1.0\nrest_length = 0.3\n";
    return build_system(parse_scene(t, "coincident.toml"));
  };
  const System small = chain(0);
  const std::vector<Equilibrium> all = find_equilibria(small);
  EXPECT_EQ(all.size(), 5u);
  for (const Equilibrium& e : all) {
    // Balance along x: every spring carries the same axial force k (|d| − 1) sign d.
    const double x[] = {0, 0.3 + e.q[0], 0.3 + e.q[1], 0.3 + e.q[2], 4};
    auto force = [&](int i) {
      const double d = x[i + 1] - x[i];
      return (std::abs(d) - 1) * (d > 0 ? 1 : -1);
    };
    for (int i = 0; i < 4; ++i) {
      EXPECT_GT(std::abs(x[i + 1] - x[i]), 0.25) << e.q.transpose();
      EXPECT_NEAR(force(i), force(0), 1e-12) << e.q.transpose();
    }
  }
  const Equilibrium nearest = find_equilibrium(small, small.initial_configuration());
  EXPECT_LE(nearest.residual, 1e-12);
  const System large = chain(1000);
  try {
    find_equilibrium(large, large.initial_configuration());
    ADD_FAILURE() << "a search started where V is not differentiable";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("initial configuration is no start"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("between 'mass1' and 'mass2'"), std::string::npos) << e.what();
  }
}

TEST(Extremes, WhereACompressedSpringsEndsMeetTheConstrainedSearchFindsNoEquilibrium) {
  // The same chain beside a bead held by a distance constraint (so the
  // constrained solver runs the survey): its Newton steps on the KKT system
  // had accepted four points where a spring's ends meet (mass1 at the wall,
  // or mass1 on mass2), each then refused by linearize. Only the 5 smooth
  // equilibria of the chain (the bead at its only place) are equilibria.
  std::string text = modal::test::slurp(std::string(MODAL_SOURCE_DIR) + "/models/spring_chain.toml");
  ASSERT_FALSE(text.empty());
  text += R"(
[[body]]
name = "bead"
joint = "slide"
axis = [0, 1, 0]
origin = [20, 0, 0]
mass = 1.0

[[constraint]]
name = "rod"
type = "distance"
a = "bead"
b = "world"
b_point = [20, 1, 0]
)";
  const System s = build_system(parse_scene(text, "spring_chain_bead.toml"));
  ASSERT_TRUE(s.has_constraints());
  const std::vector<Equilibrium> all = find_equilibria(s);
  EXPECT_EQ(all.size(), 5u);
  for (const Equilibrium& e : all) {
    const double x1 = 1 + e.q[0], x2 = 2 + e.q[1], x3 = 3 + e.q[2];  // positions, a = 1; walls at 0 and 4
    EXPECT_GT(std::min({std::abs(x1), std::abs(x1 - x2), std::abs(x2 - x3), std::abs(4 - x3)}), 0.25) << e.q.transpose();
    EXPECT_NEAR(e.q[3], 0.0, 1e-9);
    EXPECT_NO_THROW(linearize(s, e.q));
  }
}

}  // namespace

// A flat net at a small prestrain p (no gravity): its out-of-plane ω² are
// (k p/m)·4[sin²(iπ/2(N+1)) + sin²(jπ/2(N+1))] (N×N free nodes), carried by
// a transverse stiffness k(1 − L₀/L) = k p computed as the difference of k
// and k L₀/L, each rounded, and of L₀ = (1 − p)L, rounded itself: ε/p of the
// stiffness. ∇∇V's magnitudes had counted the difference (≈ k p) instead of
// its terms (≈ 2k), and at p = 1e-9 the estimates were 2e-14 of ω² while the
// error was 2.8e-8 (found by a generated family of a user's). Generated:
// N = 3 … 7, p over 1e-12 … 1e-4, k, m and the spacing over decades; the
// dense path (every mode) against the closed form in long double.
// A flat square net of free_nodes² free particles at prestrain p, no
// gravity, and its out-of-plane ω² in closed form (long double), ascending.
struct PrestrainedNet {
  System sys;
  std::vector<long double> reference;
  double k_over_m = 0;  // the springs' stiffness over the particles' mass
};
PrestrainedNet prestrained_net(int free_nodes, double p, double k, double m, double spacing) {
  char text[512];
  std::snprintf(text, sizeof text,
                "gravity = [0, 0, 0]\n[[lattice]]\nname = \"net\"\nsize = [%d, %d, 1]\nspacing = %.17g\nmass = "
                "%.17g\nstiffness = %.17g\nprestrain = %.17g\nfixed = \"boundary\"\n",
                free_nodes + 2, free_nodes + 2, spacing, m, k, p);
  PrestrainedNet net{build_system(parse_scene(text, "prestrained.toml")), {}, k / m};
  const long double pi = 3.141592653589793238462643383279502884L;
  for (int i = 1; i <= free_nodes; ++i)
    for (int j = 1; j <= free_nodes; ++j) {
      const long double si = std::sin(i * pi / (2 * (free_nodes + 1))), sj = std::sin(j * pi / (2 * (free_nodes + 1)));
      net.reference.push_back(static_cast<long double>(k) * static_cast<long double>(p) / static_cast<long double>(m) *
                              4 * (si * si + sj * sj));
    }
  std::sort(net.reference.begin(), net.reference.end());
  return net;
}

void expect_prestrained_modes(const ModalResult& r, const std::vector<long double>& reference, std::size_t count,
                              const std::string& what) {
  ASSERT_GE(r.modes.size(), count) << what;
  for (std::size_t n = 0; n < count; ++n) {
    const double err = static_cast<double>(std::abs(static_cast<long double>(r.modes[n].omega2) - reference[n]));
    EXPECT_LE(err, r.modes[n].error_estimate) << what << " mode " << n + 1 << ": ω² " << r.modes[n].omega2
                                              << ", closed form " << static_cast<double>(reference[n]);
    EXPECT_EQ(r.modes[n].kind, ModeKind::oscillatory) << what << " mode " << n + 1;
  }
}

// `trials` nets of first_nodes … first_nodes + 4 free nodes a side, p over
// p_low … p_high (1e-12 … 1e-4), k, m and the spacing over decades;
// check(net, what) each.
template <class Check>
void for_generated_prestrained_nets(unsigned seed, int trials, int first_nodes, Check&& check, double p_low = 1e-12,
                                    double p_high = 1e-4) {
  std::mt19937 rng(seed);
  auto log_uniform = [&rng](double lo, double hi) {
    return std::exp(std::uniform_real_distribution<double>(std::log(lo), std::log(hi))(rng));
  };
  for (int trial = 0; trial < trials; ++trial) {
    const int free_nodes = first_nodes + trial % 5;
    const double p = log_uniform(p_low, p_high), k = log_uniform(1e-2, 1e6), m = log_uniform(1e-3, 1e3),
                 spacing = log_uniform(1e-2, 10);
    char what[96];
    std::snprintf(what, sizeof what, "trial %d (p %.3g, k %.3g, m %.3g, spacing %.3g, %d² nodes)", trial, p, k, m,
                  spacing, free_nodes);
    check(prestrained_net(free_nodes, p, k, m, spacing), std::string(what));
  }
}

TEST(Extremes, SmallPrestrainsAreCoveredByTheEstimates) {
  for_generated_prestrained_nets(28112026, 12, 3, [](const PrestrainedNet& net, const std::string& what) {
    const ModalResult r = solve_modes(linearize(net.sys, VectorX::Zero(net.sys.size())));
    expect_prestrained_modes(r, net.reference, net.reference.size(), what);
  });
}

// The same on the sparse path (Lanczos from 243 coordinates on: 9 … 13 free
// nodes a side), whose estimates had taken K's entries at their own size:
// a 38 × 38 net at p = 1e-9 reported ω² 7.205022409e-6 ± 6.4e-19 against
// the closed form 7.205022915e-6 (now ± 3.2e-10). The lowest 8 modes.
// The sparse path's modes of the flat net (K_magnitude and inertia_scale
// from its model, as the pipeline passes them); lin: the model.
// The sparse path's modes, with the matrices the pipeline lends (the
// rounding form too unless `rounding_form` is false).
ModalResult sparse_net_modes(const PrestrainedNet& net, int modes, SparseLinearModel& lin, bool rounding_form = true) {
  lin = linearize_sparse(net.sys, VectorX::Zero(net.sys.size()));
  return test::sparse_modes_of(lin, modes, rounding_form);
}

TEST(Extremes, SmallPrestrainsAreCoveredByTheSparseEstimates) {
  for_generated_prestrained_nets(2811202602u, 8, 9, [](const PrestrainedNet& net, const std::string& what) {
    SparseLinearModel lin;
    expect_prestrained_modes(sparse_net_modes(net, 8, lin), net.reference, 8, what);
  });
}

// Estimates true in the other direction too (issue 15, part 3): on the
// same generated flat nets, p over 1e-12 … 1e-2, k, m and the spacing over
// decades, the sparse path's 8 lowest modes and the dense path's all,
// estimate/max(true error, ε ω²) against the closed form. With the springs'
// rounding taken spring by spring (SpringRounding, detail::spring_by_spring)
// instead of the entrywise figures alone: sparse median 39.5 → 10.4, 90th
// percentile 187 → 26.7, largest 908 → 239; dense (3 … 7 free nodes a side,
// where the quotient's rounding weighs more) median 17.7 → 12, 90th
// percentile 140 → 93, largest 4820 → 2640. Not 10 × everywhere: the
// rest length (1 − p)a is rounded once for every spring, and where that
// rounding happens to be small the error is far below what the estimate
// must allow for (ε/p of ω² at small p); the largest ratios are such nets.
// Asserted with a margin over what was measured: medians 15, 90th
// percentiles 40 and 150, every mode within 400 and 4000 × (and, as
// everywhere, never below the error).
TEST(Extremes, NetEstimatesAreWithinAFewTimesTheError) {
  const double eps = std::numeric_limits<double>::epsilon();
  std::vector<double> sparse, dense;
  auto ratio = [eps](const Mode& mode, long double reference) {
    const double err = static_cast<double>(std::abs(static_cast<long double>(mode.omega2) - reference));
    return mode.error_estimate / std::max(err, eps * static_cast<double>(reference));
  };
  for_generated_prestrained_nets(312202601u, 10, 9, [&](const PrestrainedNet& net, const std::string& what) {
    SparseLinearModel lin;
    const ModalResult r = sparse_net_modes(net, 8, lin);
    expect_prestrained_modes(r, net.reference, 8, what);
    for (std::size_t n = 0; n < 8 && n < r.modes.size(); ++n) {
      sparse.push_back(ratio(r.modes[n], net.reference[n]));
      EXPECT_LE(sparse.back(), 400) << what << " mode " << n + 1;
    }
  }, 1e-12, 1e-2);
  for_generated_prestrained_nets(312202602u, 10, 3, [&](const PrestrainedNet& net, const std::string& what) {
    const ModalResult r = solve_modes(linearize(net.sys, VectorX::Zero(net.sys.size())));
    expect_prestrained_modes(r, net.reference, net.reference.size(), what);
    for (std::size_t n = 0; n < net.reference.size() && n < r.modes.size(); ++n) {
      dense.push_back(ratio(r.modes[n], net.reference[n]));
      EXPECT_LE(dense.back(), 4000) << what << " mode " << n + 1;
    }
  }, 1e-12, 1e-2);
  for (auto* ratios : {&sparse, &dense}) std::sort(ratios->begin(), ratios->end());
  ASSERT_EQ(sparse.size(), 80u);
  ASSERT_FALSE(dense.empty());
  auto at = [](const std::vector<double>& v, double fraction) {
    return v[static_cast<std::size_t>(fraction * static_cast<double>(v.size() - 1))];
  };
  EXPECT_LE(at(sparse, 0.5), 15);
  EXPECT_LE(at(sparse, 0.9), 40);
  EXPECT_LE(at(dense, 0.5), 15);
  EXPECT_LE(at(dense, 0.9), 150);
}

// The dense path's residual bounds count a product's rounding by the
// nonzeros of a row of K or M (w + 2 terms, a zero entry's product being an
// exact zero) and its quotients' dot products pairwise (depth 32 +
// ⌈log₂ ⌈n/32⌉⌉), no longer n: on generated flat nets (p over 1e-12 … 1e-2,
// k, m and spacing over decades, 27 … 147 coordinates) every mode's
// residual_bound still covers its distance to the eigenvalue of the
// matrices as formed (K and M of the linear model, solved in long double),
// and every estimate covers it as well.
// The eigenvalues of a flat net's pencil (K, M) as formed, in long double,
// ascending. The out-of-plane coordinates (z, every third) decouple exactly
// (their entries with x and y are exact zeros, asserted): each block solved
// on its own, so that the small out-of-plane eigenvalues are not lost in the
// in-plane ones' normwise rounding (long double: 1e-19 of k/m).
std::vector<long double> flat_net_formed_eigenvalues(const MatrixX& K_formed, const MatrixX& M_formed,
                                                     const std::string& what) {
  using MatLD = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
  const Eigen::Index n = K_formed.rows();
  std::vector<long double> formed;
  for (const bool out_of_plane : {true, false}) {
    std::vector<Eigen::Index> index;
    for (Eigen::Index i = 0; i < n; ++i)
      if ((i % 3 == 2) == out_of_plane) index.push_back(i);
    const auto size = static_cast<Eigen::Index>(index.size());
    MatLD K(size, size), M(size, size);
    for (Eigen::Index a = 0; a < size; ++a)
      for (Eigen::Index b = 0; b < size; ++b) {
        K(a, b) = K_formed(index[a], index[b]);
        M(a, b) = M_formed(index[a], index[b]);
      }
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index a = 0; a < size; ++a)
        if ((i % 3 == 2) != out_of_plane) {
          EXPECT_EQ(K_formed(i, index[a]), 0.0) << what;
        }
    const Eigen::GeneralizedSelfAdjointEigenSolver<MatLD> block(K, M, Eigen::EigenvaluesOnly);
    EXPECT_EQ(block.info(), Eigen::Success) << what;
    for (Eigen::Index a = 0; a < size; ++a) formed.push_back(block.eigenvalues()(a));
  }
  std::sort(formed.begin(), formed.end());
  return formed;
}

// The mode's residual bound and error estimate each cover its distance to
// the reference eigenvalue.
void expect_covered(const Mode& mode, long double reference, const std::string& what) {
  const double distance = static_cast<double>(std::abs(static_cast<long double>(mode.omega2) - reference));
  EXPECT_LE(distance, mode.residual_bound) << what << ": ω² " << mode.omega2;
  EXPECT_LE(distance, mode.error_estimate) << what << ": ω² " << mode.omega2;
}

TEST(Extremes, DenseBoundsByTheRowsNonzerosHold) {
  for_generated_prestrained_nets(312202603u, 10, 3, [&](const PrestrainedNet& net, const std::string& what) {
    const LinearModel model = linearize(net.sys, VectorX::Zero(net.sys.size()));
    const ModalResult r = solve_modes(model);
    const std::vector<long double> formed = flat_net_formed_eigenvalues(model.K, model.M, what);
    ASSERT_EQ(r.modes.size(), formed.size()) << what;
    for (std::size_t j = 0; j < r.modes.size(); ++j) {
      const Mode& mode = r.modes[j];
      const long double reference = formed[j];
      expect_covered(mode, reference, what + " mode " + std::to_string(j + 1));
    }
  }, 1e-12, 1e-2);
}

// Repeated eigenvalues on the sparse path: a square net's symmetry repeats
// most of its eigenvalues (ω²_ij = ω²_ji). Where a pair's two Ritz vectors
// are each any vector of the pair's plane, each has a residual 10²–10⁴ ×
// a lone mode's and Kato–Temple finds no gap: models/net.toml's modes 2–3
// (--modes 6) had bounds of 4.6e-8 and 8.0e-7 beside mode 1's 3.3e-10.
// With the cluster bound (lanczos_modes: the pair's projected pencil and
// Mathias's δ²/η), checked against the eigenvalues of the pencil as formed
// (long double): every bound and estimate covers its distance, and a pair's
// relative bound is within 3 × the largest relative bound of the modes
// that are alone, wherever the pair lies below the completeness check's b
// (the modes at the highest returned eigenvalue lie above it and have no
// gap above them).
TEST(Extremes, SparseBoundsOfRepeatedEigenvaluesAreQuadratic) {
  int pairs = 0;
  for_generated_prestrained_nets(312202604u, 8, 9, [&](const PrestrainedNet& net, const std::string& what) {
    SparseLinearModel lin;
    const ModalResult r = sparse_net_modes(net, 10, lin);
    const std::vector<long double> formed = flat_net_formed_eigenvalues(MatrixX(lin.K), MatrixX(lin.M), what);
    ASSERT_EQ(r.modes.size(), 10u) << what;
    const double top = r.modes.back().omega2;
    double alone = 0, paired = 0;
    for (std::size_t j = 0; j < r.modes.size(); ++j) {
      const Mode& mode = r.modes[j];
      const long double reference = formed[j];
      expect_covered(mode, reference, what + " mode " + std::to_string(j + 1));
      const auto near = [&](long double tolerance) {
        for (std::size_t i = 0; i < formed.size(); ++i)
          if (i != j && std::abs(formed[i] - reference) <= tolerance * std::abs(reference)) return true;
        return false;
      };
      const double relative = mode.residual_bound / std::abs(mode.omega2);
      if (!near(1e-3L)) alone = std::max(alone, relative);
      if (near(1e-9L) && mode.omega2 < top * (1 - 1e-5)) {
        paired = std::max(paired, relative);
        ++pairs;
      }
    }
    ASSERT_GT(alone, 0) << what;
    EXPECT_LE(paired, 3 * alone) << what;
  }, 1e-12, 1e-2);
  EXPECT_GE(pairs, 16);  // the family has pairs below b
}

// Nets whose out-of-plane ω² lie far below the in-plane ones (p from 1e-12
// on): the completeness check's b = λ_k − 1e-6|λ_k| − η (η = 1e-12 max
// K_ii/M_ii) falls below zero when λ_k is within η of it, and then counts
// none of the returned modes. With ζ = 1e-8 max K_ii/M_ii as the margin, a
// 38 × 38 net at p = 1e-13 returned the double eigenvalue 1.2149e-14 once
// and the next one as the 10th mode, with the note "completeness checked …
// just below the highest returned eigenvalue: exactly 0 eigenvalues lie
// below it, as found". Now: where a returned mode is not the reference's (the
// k lowest, within the estimate) or b ≤ 0, no note may claim the check, and
// the note that it was not made must be there unless every returned mode is
// a zero mode; where b > 0, the modes are the reference's.
// Nets whose lowest ω² lie far below ζ = 1e-8 max K_ii/M_ii, yet well above
// the rounding of their data (p = 1e-12 … 1e-10): at the default shift −ζ
// their ν = 1/(λ + ζ) differ by 1e-6 relative, and a 28 × 28 net at
// p = 1e-12 took 1001 solves, returned the second copy of its 5th double
// eigenvalue as a "zero" mode with an estimate of 4e-5 (ω² 9.8e-8, resolved
// to 4e-10) and, from that estimate, counted 775 of its oscillatory modes as
// zero modes. Now the first run is given up when its Ritz values show the
// wanted ones all below ζ/100 and the runs move next to them. Checked
// against the closed form: each returned ω² within its estimate (a zero
// mode's estimate covers the reference itself), oscillatory wherever the
// reference exceeds 10 × the worst case of the data's rounding on a unit
// mode, 4ε·16 k/m (two terms of size k in each of a node's four springs'
// transverse stiffnesses, and the Laplacian's 4 + 4 entries summed in
// magnitude), and no more zero modes counted than eigenvalues below the
// largest zero-mode estimate.
TEST(Extremes, NearlySlackNetsAreSolvedNearTheirLowestModes) {
  for (const bool form : {true, false}) {
    auto check = [form](const PrestrainedNet& net, const std::string& what_net) {
      const std::string what = what_net + (form ? "" : " (without the rounding form)");
      SparseLinearModel lin;
      const ModalResult r = sparse_net_modes(net, 10, lin, form);
      ASSERT_EQ(r.modes.size(), 10u) << what;
      const double data = 4 * std::numeric_limits<double>::epsilon() * 16 * net.k_over_m;
      double zero_estimate = 0;
      for (std::size_t n = 0; n < r.modes.size(); ++n) {
        const Mode& mode = r.modes[n];
        const long double reference = net.reference[n];
        const double err = static_cast<double>(
            std::abs((mode.kind == ModeKind::zero ? 0.0L : static_cast<long double>(mode.omega2)) - reference));
        EXPECT_LE(err, mode.error_estimate) << what << " mode " << n + 1 << ": ω² " << mode.omega2
                                            << ", closed form " << static_cast<double>(reference);
        if (reference > 10 * data) {
          EXPECT_EQ(mode.kind, ModeKind::oscillatory)
              << what << " mode " << n + 1 << ": ω² " << mode.omega2 << " ± " << mode.error_estimate
              << ", closed form " << static_cast<double>(reference) << ", data level " << data;
        }
        if (mode.kind == ModeKind::zero) zero_estimate = std::max(zero_estimate, mode.error_estimate);
      }
      // The count is the computed pencil's (inertia below the largest zero
      // estimate): its eigenvalues lie within the data level of the closed
      // form's (a double eigenvalue 1.7e-3 relative above the estimate, at
      // p = 1.2e-14, is counted below it as formed).
      const auto below = std::count_if(net.reference.begin(), net.reference.end(), [&](long double l) {
        return l <= static_cast<long double>(zero_estimate) + static_cast<long double>(data);
      });
      EXPECT_LE(r.zero_modes, below) << what << ": largest zero estimate " << zero_estimate << ", data level " << data;
    };
    for_generated_prestrained_nets(2811202604u, 8, 14, check, 1e-12, 1e-10);
    // Down to the data's rounding (p = 1e-14 … 1e-12: the lowest λ about
    // 1e-18 … 1e-14 s, around the probe's floor 10 ε s). With and without
    // the rounding form (the pipeline lends it; a library caller may not):
    // without it, a net at p = 2.7e-14 had a mode called oscillatory 3.6 × its
    // estimate from the closed form, the run at σ₀ having converged within
    // the probe's restarts with copies of double eigenvalues missed (such a
    // run is now moved as an unconverged one is).
    for_generated_prestrained_nets(2811202608u, 8, 14, check, 1e-14, 1e-12);
  }
}

TEST(Extremes, TinyEigenvaluesDoNotClaimACompletenessCheck) {
  for_generated_prestrained_nets(2811202603u, 10, 12, [](const PrestrainedNet& net, const std::string& what) {
    SparseLinearModel lin;
    const ModalResult r = sparse_net_modes(net, 10, lin);
    ASSERT_EQ(r.modes.size(), 10u) << what;
    bool all_zero = true, tiny = true, matches = true;
    double largest = 0;  // max K_ii/M_ii
    for (Eigen::Index j = 0; j < lin.K.rows(); ++j) largest = std::max(largest, lin.K.coeff(j, j) / lin.M.coeff(j, j));
    for (std::size_t n = 0; n < r.modes.size(); ++n) {
      const Mode& mode = r.modes[n];
      all_zero = all_zero && mode.kind == ModeKind::zero;
      tiny = tiny && mode.omega2 * (1 - 1e-6) <= 1e-12 * largest;
      matches = matches && static_cast<double>(std::abs(static_cast<long double>(mode.omega2) - net.reference[n])) <=
                               mode.error_estimate;
    }
    const auto has = [&](const char* start) {
      return std::any_of(r.notes.begin(), r.notes.end(), [&](const std::string& note) { return note.rfind(start, 0) == 0; });
    };
    // Not tiny: checked by the inertia, or, where returned modes resolved
    // from the highest lie within the check's margin of it (uncovered_modes:
    // trial 1 here, p = 8.1e-12), by the copies check, which must have found
    // the span complete.
    const bool copies_checked = std::any_of(r.notes.begin(), r.notes.end(), [](const std::string& note) {
      return note.find("copies of repeated eigenvalues checked instead") != std::string::npos &&
             note.find("found no direction below the highest returned eigenvalue outside the span") != std::string::npos;
    });
    if (!matches || tiny) {
      EXPECT_FALSE(has("completeness checked")) << what;
    } else {
      EXPECT_TRUE(has("completeness checked") || copies_checked) << what;
    }
    if (!all_zero && tiny) {
      EXPECT_TRUE(has("completeness not checked")) << what;
    }
    // Zero modes counted beyond those returned (the last returned is zero):
    // with the returned oscillatory ones below the count's σ = t, no more
    // than the eigenvalues below t (a net at prestrain 1e-13 had counted the
    // oscillatory ones among its zero modes too).
    if (r.modes.back().kind == ModeKind::zero) {
      double t = r.modes.back().omega2;
      for (const Mode& mode : r.modes)
        if (mode.kind == ModeKind::zero) t = std::max(t, mode.error_estimate);
      const auto oscillatory_below = std::count_if(r.modes.begin(), r.modes.end(), [&](const Mode& mode) {
        return mode.kind == ModeKind::oscillatory && mode.omega2 < t;
      });
      const auto below = std::count_if(net.reference.begin(), net.reference.end(),
                                       [&](long double l) { return l < static_cast<long double>(t) * (1 + 1e-6L); });
      EXPECT_LE(r.zero_modes + oscillatory_below, below) << what;
    }
  });
}

// sparse_rounding_form bounds the rounding of ∇∇V's data where the entrywise
// magnitudes do not: the springs' lengths are differences of positions,
// each rounded to ε of its size, so far from the origin (ρ = (‖x_a‖ +
// ‖x_b‖)/L up to 2e3 here) a flat net at its rest length has out-of-plane
// eigenvalues of either sign as formed, zero in exact arithmetic (a 100 ×
// 100 net: −1.3e-14 s, localized at the springs the rounding left
// compressed). Generated nets (6–12 free particles a side, prestrain 0 or
// 1e-12 … 1e-3, spacing, stiffness, mass over decades, the net's corner up
// to 1e3 spacings from the origin), the particles moved by up to ε of
// their position's size, coordinate by coordinate at random (as rounding
// moves them): for random vectors and for the smooth lowest out-of-plane
// mode, |φᵀ(K(q + δq) − K(q))φ| ≤ 4ε φᵀFφ (first order: with a margin of
// 2 for the second-order remainder and K's own rounding at the two points,
// which F also bounds), and F positive semidefinite; on the smooth mode
// φᵀFφ is far below the entrywise bound of the same rounding, (1 + ρ)|φ|ᵀE|φ|
// (the reason it decides kinds).
TEST(Extremes, TheRoundingFormBoundsThePositionsRounding) {
  std::mt19937 rng(2811202605u);
  auto log_uniform = [&rng](double lo, double hi) {
    return std::exp(std::uniform_real_distribution<double>(std::log(lo), std::log(hi))(rng));
  };
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double eps = std::numeric_limits<double>::epsilon();
  int smooth_checked = 0;
  for (int trial = 0; trial < 12; ++trial) {
    const int free_nodes = 6 + trial % 7;
    const double p = trial % 3 == 0 ? 0.0 : log_uniform(1e-12, 1e-3), k = log_uniform(1e-2, 1e6),
                 m = log_uniform(1e-3, 1e3), spacing = log_uniform(1e-2, 10), offset = log_uniform(1, 1e3) * spacing;
    char text[600];
    std::snprintf(text, sizeof text,
                  "gravity = [0, 0, 0]\n[[lattice]]\nname = \"net\"\nsize = [%d, %d, 1]\nspacing = %.17g\nmass = "
                  "%.17g\nstiffness = %.17g\nprestrain = %.17g\nfixed = \"boundary\"\norigin = [%.17g, %.17g, 0]\n",
                  free_nodes + 2, free_nodes + 2, spacing, m, k, p, offset, -0.5 * offset);
    const std::string what = "trial " + std::to_string(trial) + ": " + text;
    const System sys = build_system(parse_scene(text, "net.toml"));
    Workspace w(sys);
    const VectorX q = VectorX::Zero(sys.size());
    const SparseMatrix K0 = sparse_potential_hessian(sys, w, q);
    const SparseMatrix E = sparse_potential_hessian_magnitude(sys, w, q);
    const SparseMatrix F = sparse_rounding_form(sys, w, q);
    ASSERT_EQ(F.rows(), sys.size()) << what;
    // Positive semidefinite: a Cholesky factorization of F + τI for a τ far
    // below F's scale.
    {
      const double tau = 1e-12 * std::abs(F.diagonal().maxCoeff());
      SparseMatrix shifted = F;
      for (Eigen::Index j = 0; j < shifted.rows(); ++j) shifted.coeffRef(j, j) += tau;
      Eigen::SimplicialLLT<SparseMatrix> llt(shifted);
      EXPECT_EQ(llt.info(), Eigen::Success) << what;
    }
    // The positions' rounding: each coordinate of each particle moved by up to
    // ε of the size of its position (the net's own coordinates are
    // displacements from the written positions, so the size is the
    // position's).
    const double size = std::hypot(offset + (free_nodes + 1) * spacing, 0.5 * offset + (free_nodes + 1) * spacing);
    VectorX dq(sys.size());
    for (Eigen::Index j = 0; j < dq.size(); ++j) dq(j) = eps * size * unit(rng);
    Workspace w2(sys);
    const SparseMatrix change = SparseMatrix(sparse_potential_hessian(sys, w2, dq)) - K0;
    // The smooth mode: sin(πi/(N+1)) sin(πj/(N+1)) out of plane (every third coordinate, z).
    const double pi = std::acos(-1.0);
    VectorX smooth = VectorX::Zero(sys.size());
    for (int i = 0; i < free_nodes; ++i)
      for (int j = 0; j < free_nodes; ++j)
        smooth(3 * (i * free_nodes + j) + 2) =
            std::sin(pi * (i + 1) / (free_nodes + 1)) * std::sin(pi * (j + 1) / (free_nodes + 1));
    std::vector<VectorX> vectors{smooth};
    for (int r = 0; r < 4; ++r) vectors.push_back(VectorX::NullaryExpr(sys.size(), [&] { return unit(rng); }));
    for (std::size_t v = 0; v < vectors.size(); ++v) {
      const VectorX& phi = vectors[v];
      const double moved = std::abs(phi.dot(change * phi));
      const double bound = 4 * eps * phi.dot(F * phi);
      EXPECT_LE(moved, 2 * bound) << what << " vector " << v << ": |φᵀΔKφ| " << moved << ", 4ε φᵀFφ " << bound;
    }
    const VectorX a = smooth.cwiseAbs();
    const double entrywise = a.dot(E * a), structured = smooth.dot(F * smooth);
    // Against the entrywise form of the same rounding: E has no share of the
    // positions; with it, each spring's transverse entries would be up to
    // (1 + ρ) × E's.
    const double rho = 2 * size / spacing;
    if (p > 0 && p < 1e-6) {
      EXPECT_LT(structured, 0.1 * (1 + rho) * entrywise)
          << what << ": φᵀFφ " << structured << ", (1 + ρ)|φ|ᵀE|φ| " << (1 + rho) * entrywise;
      ++smooth_checked;
    }
  }
  EXPECT_GT(smooth_checked, 0);
}

// A flat net at its rest length without gravity, N × N free particles inside
// a fixed boundary, its corner 10–1e4 spacings from the origin (spacing, k,
// m over decades, drawn from `rng` in that order), with dampers along the
// springs (c = 1e-4 … 1 × √(km), drawn next) and a distance constraint
// between two of its particles where asked.
namespace {
std::string far_rest_length_net(std::mt19937& rng, int free_nodes, bool damped, bool constrained) {
  auto log_uniform = [&rng](double lo, double hi) {
    return std::exp(std::uniform_real_distribution<double>(std::log(lo), std::log(hi))(rng));
  };
  const double k = log_uniform(1e-2, 1e6), m = log_uniform(1e-3, 1e3), spacing = log_uniform(1e-2, 10),
               offset = log_uniform(10, 1e4) * spacing;
  char text[800];
  std::snprintf(text, sizeof text,
                "gravity = [0, 0, 0]\n[[lattice]]\nname = \"net\"\nsize = [%d, %d, 1]\nspacing = %.17g\nmass = "
                "%.17g\nstiffness = %.17g\nprestrain = 0\nfixed = \"boundary\"\norigin = [%.17g, %.17g, 0]\n",
                free_nodes + 2, free_nodes + 2, spacing, m, k, offset, 0.3 * offset);
  std::string scene = text;
  if (damped) {
    std::snprintf(text, sizeof text, "damping = %.17g\n", log_uniform(1e-4, 1) * std::sqrt(k * m));
    scene += text;
  }
  if (constrained) scene += "[[constraint]]\ntype = \"distance\"\na = \"net.1.1\"\nb = \"net.2.2\"\n";
  return scene;
}
}  // namespace

// A flat net at its rest length without gravity is neutral out of its plane:
// every out-of-plane eigenvalue is zero in exact arithmetic. Placed far from
// the origin, the rounding of its positions leaves springs stretched or
// compressed by ε of the positions' size, and K as formed has λ of either
// sign; the kinds, decided with an entrywise bound of the data's rounding that
// had no share of the positions, called an 8 × 8 net 100 m away "divergence,
// Morse index 18" (the default, dense, path) and a 30 × 30 one "Morse index
// 3" (sparse). Generated nets (4–12 free particles a side), both paths: no
// mode divergent, Morse index 0.
TEST(Extremes, ARestLengthNetFarFromTheOriginIsNotDivergent) {
  std::mt19937 rng(2811202606u);
  for (int trial = 0; trial < 10; ++trial) {
    const int free_nodes = 4 + trial % 9;
    const std::string text = far_rest_length_net(rng, free_nodes, false, false);
    const std::string what = "trial " + std::to_string(trial) + ": " + text;
    const System sys = build_system(parse_scene(text, "net.toml"));
    const VectorX q = VectorX::Zero(sys.size());
    const ModalResult dense = solve_modes(linearize(sys, q));
    const ModalResult sparse = test::sparse_modes_of(linearize_sparse(sys, q), 6);
    for (const auto& [r, path] : {std::pair<const ModalResult*, const char*>{&dense, "dense"}, {&sparse, "sparse"}}) {
      EXPECT_EQ(r->morse_index, 0) << what << path;
      for (const Mode& mode : r->modes)
        EXPECT_NE(mode.kind, ModeKind::divergent)
            << what << path << ": ω² " << mode.omega2 << " ± " << mode.error_estimate;
    }
  }
}

// The same nets with dampers (the first-order path) and with a distance
// constraint between two particles in the plane (the constrained path:
// NᵀKN), 3–7 free particles a side (the first-order solve is dense in 2n).
// At the rest length the out-of-plane stiffness and damping are exactly zero
// and the constraint does not act out of the plane, so each free particle
// has a zero eigenvalue there (N² of them; double in the first-order
// system, 2N²) and every other mode is oscillatory (damped with dampers).
// The entrywise bound of K's rounding leaves out the positions' and had
// rounding-level values called "divergence" or the zero modes miscounted in
// 9 of these 20 nets (3 of the 5 damped ones, 4 of the 5 constrained, 2 of
// the 5 with both; none of the 5 with neither) before the kinds of the
// first-order path and of the projected NᵀKN were decided with F.
TEST(Extremes, DampedOrConstrainedRestLengthNetsFarFromTheOriginAreNotDivergent) {
  std::mt19937 rng(2811202607u);
  for (int trial = 0; trial < 20; ++trial) {
    const int free_nodes = 3 + trial % 5;
    const bool constrained = trial % 2 == 1, damped = trial % 4 < 2;
    const std::string text = far_rest_length_net(rng, free_nodes, damped, constrained);
    const std::string what = "trial " + std::to_string(trial) + ": " + text;
    const System sys = build_system(parse_scene(text, "net.toml"));
    const LinearModel lin = linearize(sys, VectorX::Zero(sys.size()));
    ASSERT_EQ(lin.has_damping, damped) << what;
    ASSERT_EQ(lin.constrained(), constrained) << what;
    const ModalResult r = solve_modes(lin);
    EXPECT_EQ(r.morse_index, 0) << what;
    EXPECT_EQ(r.zero_modes, (damped ? 2 : 1) * free_nodes * free_nodes) << what;
    EXPECT_EQ(r.stability, Stability::marginal) << what;
    const ModeKind moving = damped ? ModeKind::damped : ModeKind::oscillatory;
    for (const Mode& mode : r.modes)
      EXPECT_TRUE(mode.kind == ModeKind::zero || mode.kind == moving)
          << what << "s " << mode.s << " ± " << mode.error_estimate << ": " << to_string(mode.kind);
  }
}
