// Slack structures (issue 15 part 2): nets whose springs sit at their rest
// length have no transverse stiffness at the flat start, so ∇∇V is singular
// there and plain Newton cannot step. Generated families (seeded, random
// sizes, spacing, masses and stiffnesses over decades) must reach their
// equilibrium by the damped Newton method, the same equilibrium as the
// independent L-BFGS-then-Newton strategy, and modes that a dense solver on
// the same K and M confirms.
#include "modal/pipeline.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <random>
#include <string>

namespace {

struct Net {
  int size;
  double spacing, mass, stiffness, prestrain;
};

std::string net_scene(const Net& n) {
  return "gravity = [0, 0, -9.81]\n[[lattice]]\nname = \"net\"\nsize = [" + std::to_string(n.size) + ", " +
         std::to_string(n.size) + ", 1]\nspacing = " + std::to_string(n.spacing) + "\nmass = " + std::to_string(n.mass) +
         "\nstiffness = " + std::to_string(n.stiffness) + "\nprestrain = " + std::to_string(n.prestrain) +
         "\nfixed = \"boundary\"\n";
}

// log-uniform in [lo, hi]
double log_uniform(std::mt19937& rng, double lo, double hi) {
  return std::exp(std::uniform_real_distribution<double>(std::log(lo), std::log(hi))(rng));
}

TEST(Slack, GeneratedSlackNetsReachTheirEquilibriumByDampedNewton) {
  std::mt19937 rng(20261125);
  for (int trial = 0; trial < 4; ++trial) {
    Net net;
    net.size = std::uniform_int_distribution<int>(21, 24)(rng);  // 1083 … 1452 coordinates: the large path
    net.spacing = log_uniform(rng, 0.01, 1.0);
    net.mass = log_uniform(rng, 1e-3, 1.0);
    net.stiffness = log_uniform(rng, 10, 1e5);
    net.prestrain = trial % 2 == 0 ? 0.0 : 1e-6;  // slack, and nearly slack
    SCOPED_TRACE(net_scene(net));
    const modal::Model model = modal::model_from_text(net_scene(net), "slack.toml");
    ASSERT_GT(model.system.size(), modal::large_system_coordinates);

    modal::EquilibriumOptions newton;
    const modal::Equilibrium e = modal::find_equilibrium(model.system, model.system.initial_configuration(), newton);
    EXPECT_LE(e.residual, newton.tolerance);
    // Slack: the flat start's Hessian is singular, so the damped method runs;
    // nearly slack: Newton may manage alone. Never the slow L-BFGS fallback.
    if (net.prestrain == 0) {
      EXPECT_NE(e.method.find("damped Newton"), std::string::npos) << e.method;
    }
    EXPECT_EQ(e.method.find("L-BFGS"), std::string::npos) << e.method;

    // The same equilibrium by the independent strategy.
    modal::EquilibriumOptions lbfgs;
    lbfgs.large_method = modal::LargeEquilibriumMethod::lbfgs;
    const modal::Equilibrium f = modal::find_equilibrium(model.system, model.system.initial_configuration(), lbfgs);
    const double sag = e.q.cwiseAbs().maxCoeff();
    EXPECT_GT(sag, 0);
    EXPECT_LT((e.q - f.q).cwiseAbs().maxCoeff(), 1e-7 * sag);

    // The sparse modes at it against a dense symmetric solve of the same K, M.
    modal::AnalysisOptions options;
    options.modes = 6;
    const modal::Analysis a = modal::analyze(model, options);
    ASSERT_TRUE(a.sparse.has_value());
    const Eigen::MatrixXd K(a.sparse->K), M(a.sparse->M);
    Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> dense(K, M, Eigen::EigenvaluesOnly);
    ASSERT_EQ(dense.info(), Eigen::Success);
    EXPECT_EQ(a.result().stability, modal::Stability::stable);
    for (std::size_t k = 0; k < a.result().modes.size(); ++k) {
      const modal::Mode& m = a.result().modes[k];
      const double reference = dense.eigenvalues()(static_cast<Eigen::Index>(k));
      // The dense solver's own error is about n·ε·‖K‖ normwise.
      const double dense_error = 1e-13 * dense.eigenvalues().cwiseAbs().maxCoeff();
      EXPECT_LE(std::abs(m.omega2 - reference), m.error_estimate + dense_error)
          << "mode " << k + 1 << ": " << m.omega2 << " against " << reference;
    }
  }
}

}  // namespace
