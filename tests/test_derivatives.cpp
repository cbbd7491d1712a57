// Derivatives by differences (--derivatives, issue 6 part 1) against the exact
// ones: for every bundled kind of scene (a tree, ball joints, a rotating
// frame with its gyroscopic matrix, follower loads, constraints, springs and
// particles, a kinematic map), the stiffness K and G from central, forward and
// complex-step differences agree with automatic differentiation within the
// error that modal states for them (LinearModel::K_error, which for
// differences is measured as |K_h − K_2h|), and every eigenvalue computed
// from them is within its own reported error estimate of the exact one.
#include "modal/equilibrium.hpp"
#include "modal/linearize.hpp"
#include "modal/modes.hpp"
#include "modal/scene.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <limits>
#include <string>

namespace {

using namespace modal;
constexpr double kEps = std::numeric_limits<double>::epsilon();

struct Case {
  System system;
  Equilibrium equilibrium;
};

// A bundled model; the net and the lattice made small (8 × 8 and 3 × 3 × 3
// particles) so that the dense path stays quick.
Case load(const std::string& model) {
  std::ifstream in(std::string(MODAL_SOURCE_DIR) + "/models/" + model);
  std::stringstream text;
  text << in.rdbuf();
  std::string scene = text.str();
  auto shrink = [&scene](const std::string& from, const std::string& to) {
    const auto at = scene.find(from);
    if (at != std::string::npos) scene.replace(at, from.size(), to);
  };
  shrink("size = [30, 30, 1]", "size = [8, 8, 1]");
  shrink("\"-29*a/2\", \"-29*a/2\"", "\"-7*a/2\", \"-7*a/2\"");
  shrink("size = [6, 6, 6]", "size = [3, 3, 3]");
  const System sys = build_system(parse_scene(scene, std::string(MODAL_SOURCE_DIR) + "/models/" + model));
  Equilibrium eq = find_equilibrium(sys, sys.initial_configuration());
  return {sys, eq};
}

// Trees of every kind: hinges, ball joints, a rotating frame (G), follower
// loads, constraints (loop closures, free bodies), springs and particles.
const char* const kTrees[] = {"double_pendulum.toml",   "spherical_pendulum.toml", "bead_on_hoop_frame.toml",
                              "ziegler.toml",           "follower_column.toml",    "four_bar.toml",
                              "twin_free.toml",         "closed_chain.toml",       "net.toml",
                              "particle_pendulum.toml", "euler_column.toml",       "lattice.toml"};

// max |A − B| relative to a scale.
double max_difference(const MatrixX& a, const MatrixX& b) { return (a - b).cwiseAbs().maxCoeff(); }

TEST(Derivatives, DifferencesAgreeWithExactWithinTheirStatedError) {
  for (const char* model : kTrees) {
    const Case c = load(model);
    LinearizeOptions exact_options;
    const LinearModel exact = linearize(c.system, c.equilibrium.q, exact_options);
    const double exact_error = exact.K_error.cwiseAbs().maxCoeff();  // 4ε × the largest Σ|terms|
    for (const DerivativeMethod method :
         {DerivativeMethod::central, DerivativeMethod::forward, DerivativeMethod::complex_step}) {
      LinearizeOptions options;
      options.derivatives = method;
      const LinearModel lin = linearize(c.system, c.equilibrium.q, options);
      // K within the stated errors of both (normwise: the rounding of a
      // difference is spread over its whole column).
      EXPECT_LE(max_difference(lin.K, exact.K), lin.K_error.cwiseAbs().maxCoeff() + exact_error)
          << model << " " << to_string(method);
      if (method == DerivativeMethod::complex_step) {  // no cancellation: exact to rounding
        EXPECT_LE(max_difference(lin.K, exact.K), 100 * exact_error) << model;
      }
      // G (rotating frames): differences of g, with the a-priori size of
      // their error (h² or h of an order-one derivative, and ε/h).
      EXPECT_EQ(lin.has_gyroscopic, exact.has_gyroscopic) << model;
      if (exact.has_gyroscopic) {
        const double tolerance = method == DerivativeMethod::forward ? 1e-6 : 1e-9;
        EXPECT_LE(max_difference(lin.G, exact.G), tolerance * exact.G.cwiseAbs().maxCoeff())
            << model << " " << to_string(method);
      }
    }
  }
}

// Each eigenvalue from differences is within its own error estimate of the
// exact eigenvalue (symmetric problems: the estimate covers the differences).
TEST(Derivatives, EigenvaluesWithinTheirEstimates) {
  for (const char* model : {"double_pendulum.toml", "spherical_pendulum.toml", "net.toml", "twin_free.toml",
                            "euler_column.toml", "hanging_chain.toml", "spring_chain.toml"}) {
    const Case c = load(model);
    const ModalResult exact = solve_modes(linearize(c.system, c.equilibrium.q));
    for (const DerivativeMethod method :
         {DerivativeMethod::central, DerivativeMethod::forward, DerivativeMethod::complex_step}) {
      LinearizeOptions options;
      options.derivatives = method;
      const ModalResult r = solve_modes(linearize(c.system, c.equilibrium.q, options));
      ASSERT_EQ(r.modes.size(), exact.modes.size());
      for (std::size_t j = 0; j < r.modes.size(); ++j)
        EXPECT_LE(std::abs(r.modes[j].omega2 - exact.modes[j].omega2),
                  r.modes[j].error_estimate + exact.modes[j].error_estimate)
            << model << " " << to_string(method) << " mode " << j + 1;
      EXPECT_EQ(r.stability, exact.stability) << model << " " << to_string(method);
    }
  }
}

// The step factor is the user's to choose; whatever it is, the measured
// error covers the actual one, and follows the truncation (∝ h) down.
TEST(Derivatives, StepFactorChangesTheStatedError) {
  const Case c = load("double_pendulum.toml");
  const LinearModel exact = linearize(c.system, c.equilibrium.q);
  double previous = 0;
  for (const double h : {1e-3, 1e-5, 1e-8, 1e-11}) {
    LinearizeOptions options;
    options.derivatives = DerivativeMethod::forward;
    options.step_factor = h;
    const LinearModel lin = linearize(c.system, c.equilibrium.q, options);
    const double stated = lin.K_error.cwiseAbs().maxCoeff();
    EXPECT_LE(max_difference(lin.K, exact.K), stated) << "step factor " << h;
    if (h == 1e-5) {
      EXPECT_LT(stated, previous);  // smaller truncation
    }
    previous = stated;
  }
}

// Kinematic maps: differences work; complex steps are refused in words.
TEST(Derivatives, MapsTakeDifferencesButNotComplexSteps) {
  const Case c = load("double_pendulum_map.toml");
  const LinearModel exact = linearize(c.system, c.equilibrium.q);
  LinearizeOptions options;
  options.derivatives = DerivativeMethod::central;
  const LinearModel lin = linearize(c.system, c.equilibrium.q, options);
  EXPECT_LE(max_difference(lin.K, exact.K), lin.K_error.cwiseAbs().maxCoeff() + exact.K_error.cwiseAbs().maxCoeff());
  options.derivatives = DerivativeMethod::complex_step;
  try {
    (void)linearize(c.system, c.equilibrium.q, options);
    ADD_FAILURE() << "complex steps through a map were not refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("not available for kinematic maps"), std::string::npos) << e.what();
  }
}

TEST(Derivatives, MethodNames) {
  for (const DerivativeMethod m : {DerivativeMethod::exact, DerivativeMethod::central, DerivativeMethod::forward,
                                   DerivativeMethod::complex_step})
    EXPECT_EQ(parse_derivative_method(to_string(m)), m);
  EXPECT_FALSE(parse_derivative_method("complex"));
}

}  // namespace

namespace {

// |s − s_exact| within both estimates for every mode (first-order results:
// s; symmetric ones: ω²), the modes paired in their sorted order.
void expect_covered(const ModalResult& r, const ModalResult& exact, const std::string& what) {
  ASSERT_EQ(r.modes.size(), exact.modes.size()) << what;
  for (std::size_t j = 0; j < r.modes.size(); ++j) {
    const Mode &a = r.modes[j], &b = exact.modes[j];
    const double error = std::isnan(a.omega2) ? std::abs(a.s - b.s) : std::abs(a.omega2 - b.omega2);
    EXPECT_LE(error, a.error_estimate + b.error_estimate)
        << what << " mode " << j + 1 << ": error " << error << ", estimates " << a.error_estimate << " and "
        << b.error_estimate;
  }
}

}  // namespace

// Every path's estimate includes the error of differences (issue 20, part 2):
// first-order problems with a gyroscopic G from differences (Foucault
// pendulum: true error 3.5e-12 against a stated 7e-16 before), circulatory
// and damped ones, and constrained ones; for each method and for step
// factors from the default up to the largest accepted.
TEST(Derivatives, EveryPathsEstimateCoversTheDifferences) {
  for (const char* model : {"foucault.toml", "spinning_top.toml", "bead_on_hoop_frame.toml", "ziegler.toml",
                            "ziegler_damped.toml", "follower_column.toml", "four_bar.toml", "closed_chain.toml",
                            "double_pendulum.toml"}) {
    const Case c = load(model);
    const ModalResult exact = solve_modes(linearize(c.system, c.equilibrium.q));
    for (const DerivativeMethod method :
         {DerivativeMethod::central, DerivativeMethod::forward, DerivativeMethod::complex_step})
      for (const double factor : {0.0, 1e-3, 0.03, max_step_factor}) {
        if (method == DerivativeMethod::complex_step && c.system.is_map()) continue;  // refused (tested above)
        LinearizeOptions options;
        options.derivatives = method;
        options.step_factor = factor;
        const ModalResult r = solve_modes(linearize(c.system, c.equilibrium.q, options));
        expect_covered(r, exact, std::string(model) + " " + to_string(method) + " step factor " + std::to_string(factor));
      }
  }
}

// Steps beyond max_step_factor (a tenth of a radian or of the length scale)
// are refused: near π or 2π an angle's forces repeat, the differences and
// their measured error vanish, and a stable pendulum looked "marginal".
TEST(Derivatives, StepsBeyondTheLargestAreRefused) {
  const Case c = load("double_pendulum.toml");
  for (const double factor : {0.1000001, 0.5, 3.14159, 6.2831853, 1e300, -1e-3,
                              std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()})
    for (const DerivativeMethod method :
         {DerivativeMethod::central, DerivativeMethod::forward, DerivativeMethod::complex_step}) {
      LinearizeOptions options;
      options.derivatives = method;
      options.step_factor = factor;
      EXPECT_THROW(linearize(c.system, c.equilibrium.q, options), std::invalid_argument)
          << to_string(method) << " " << factor;
    }
}
