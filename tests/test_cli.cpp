// End-to-end tests of the `modal` program: each test runs the built binary
// (MODAL_BINARY) on the models in MODAL_SOURCE_DIR/models or on scenes written
// into a temporary directory, and checks exit statuses, messages and the CSV /
// JSON files it writes against closed forms (docs/design.md, section 2).
//
// Tolerances. The CSV files hold %.17g numbers, so what is compared is the
// program's own double. The reference values are closed forms evaluated in
// double (error ~1e-15). The eigen-solutions are of well-conditioned dense
// problems of size ≤ 40 (stiffness ratios ≤ ~1e3), for which the backward-
// stable symmetric-definite solver gives eigenvalues to ~1e-13 relative. 1e-9
// relative therefore leaves four orders of margin for round-off while still
// catching any modelling error (a wrong mass or length changes ω by ≥ 1e-3).
#include <gtest/gtest.h>

#include "csv_fields.hpp"
#include "program.hpp"
#include <nlohmann/json.hpp>

#include <Eigen/Eigenvalues>


#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

const std::string models = std::string(MODAL_SOURCE_DIR) + "/models/";

using modal::test::Outcome;
using modal::test::slurp;

using modal::test::Csv;
using modal::test::Row;
using modal::test::number;
using modal::test::read_csv;

class Cli : public modal::test::ProgramTest {
 protected:
  Cli() : ProgramTest("modal_cli_") {}

  std::string write(const std::string& name, const std::string& text) const {
    const fs::path p = dir / name;
    std::ofstream(p) << text;
    return p.string();
  }

  std::string prefix(const std::string& name = "P") const { return (dir / name).string(); }
};

// Checks |actual − expected| ≤ tol·|expected|.
#define EXPECT_REL(actual, expected, tol)                                          \
  EXPECT_LE(std::abs((actual) - (expected)), (tol) * std::abs(expected))           \
      << "actual " << (actual) << ", expected " << (expected)

// --- R1: double pendulum (Kibble & Berkshire eq. 11.21, docs/design.md R1) -----

TEST_F(Cli, R1DoublePendulumAllFourRows) {
  struct Case { double m1, m2, l1, l2; };
  const Case cases[] = {{1, 1, 1, 1}, {2, 1, 1, 1}, {1, 2, 1, 1}, {1, 1, 1, 2}};
  const double g = 1;
  for (const Case& c : cases) {
    SCOPED_TRACE(::testing::Message() << "m1=" << c.m1 << " m2=" << c.m2 << " l1=" << c.l1 << " l2=" << c.l2);
    auto s = [](double v) { std::ostringstream o; o.precision(17); o << v; return o.str(); };
    const Outcome r = run({"analyze", models + "double_pendulum.toml", "--set", "m1=" + s(c.m1), "--set",
                       "m2=" + s(c.m2), "--set", "l1=" + s(c.l1), "--set", "l2=" + s(c.l2), "--set",
                       "g=1", "--csv", prefix()});
    ASSERT_EQ(r.status, 0) << r.err;
    const double mt = c.m1 + c.m2, ls = c.l1 + c.l2;
    const double root = std::sqrt(mt * (mt * ls * ls - 4 * c.m1 * c.l1 * c.l2));
    const double w2[2] = {g / (2 * c.m1 * c.l1 * c.l2) * (mt * ls - root),
                          g / (2 * c.m1 * c.l1 * c.l2) * (mt * ls + root)};
    const Csv modes = read_csv(prefix() + "_modes.csv");
    ASSERT_EQ(modes.rows.size(), 2u);
    for (int k = 0; k < 2; ++k) {
      const Row& row = modes.rows[static_cast<std::size_t>(k)];
      EXPECT_EQ(row.at("equilibrium"), "1");
      EXPECT_EQ(row.at("mode"), std::to_string(k + 1));
      EXPECT_REL(number(row, "omega"), std::sqrt(w2[k]), 1e-9);
      EXPECT_REL(number(row, "omega2"), w2[k], 1e-9);
      EXPECT_REL(number(row, "period"), 2 * std::numbers::pi / std::sqrt(w2[k]), 1e-9);
      EXPECT_EQ(row.at("stability"), "stable");
    }
    const Csv eq = read_csv(prefix() + "_equilibria.csv");
    ASSERT_EQ(eq.rows.size(), 1u);
    EXPECT_EQ(eq.rows[0].at("stability"), "stable");
    EXPECT_EQ(eq.rows[0].at("morse_index"), "0");
    // Hanging equilibrium: V = −g(m1 l1 + m2 (l1 + l2)) with the pivot at V = 0.
    EXPECT_REL(number(eq.rows[0], "potential"), -g * (c.m1 * c.l1 + c.m2 * (c.l1 + c.l2)), 1e-12);
  }
}

TEST_F(Cli, R1TablePrintedValues) {
  // The printed table has 10 significant digits: docs/design.md section 2's ω1, ω2 for row 1.
  const Outcome r = run({"analyze", models + "double_pendulum.toml"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("0.7653668647"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1.847759065"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("stable"), std::string::npos);
}

// --- R2: spring–mass chain (Morin, Waves, ch. 2) ------------------------------

TEST_F(Cli, R2SpringChainFrequenciesAndShapes) {
  const double k = 3, m = 0.5;  // sqrt(k/m) = sqrt(6): not 1, so a k/m mix-up shows
  const Outcome r = run({"analyze", models + "spring_chain.toml", "--set", "k=3", "--set", "m=0.5", "--csv",
                     prefix()});
  ASSERT_EQ(r.status, 0) << r.err;
  const int N = 3;
  const Csv modes = read_csv(prefix() + "_modes.csv");
  ASSERT_EQ(modes.rows.size(), 3u);
  for (int j = 1; j <= N; ++j) {
    const double w = 2 * std::sqrt(k / m) * std::sin(j * std::numbers::pi / (2 * (N + 1)));
    EXPECT_REL(number(modes.rows[static_cast<std::size_t>(j - 1)], "omega"), w, 1e-9);
  }
  // Shapes φ_j(n) ∝ sin(n j π/(N+1)); M = m I on slides, so M-normalized means
  // m Σφ² = 1, and the sign convention makes the largest |component| positive.
  const Csv shapes = read_csv(prefix() + "_shapes.csv");
  ASSERT_EQ(shapes.rows.size(), 9u);
  EXPECT_EQ(shapes.header,
            (std::vector<std::string>{"equilibrium", "mode", "coordinate", "value", "amplitude", "phase_deg"}));
  for (int j = 1; j <= N; ++j) {
    Eigen::Vector3d ref, got;
    for (int n = 1; n <= N; ++n) ref[n - 1] = std::sin(n * j * std::numbers::pi / (N + 1));
    ref /= std::sqrt(m * ref.squaredNorm());
    Eigen::Index big;
    ref.cwiseAbs().maxCoeff(&big);
    if (ref[big] < 0) ref = -ref;
    for (const Row& row : shapes.rows)
      if (row.at("mode") == std::to_string(j)) {
        const std::string name = row.at("coordinate");
        ASSERT_EQ(name.rfind("mass", 0), 0u) << name;
        got[std::stoi(name.substr(4)) - 1] = number(row, "value");
      }
    // Shapes are eigenvectors of well-separated eigenvalues (gap/‖K‖ ≳ 0.3), so
    // their error is ~eps/gap: 1e-9 absolute on O(1) components is ample.
    EXPECT_LE((got - ref).norm(), 1e-9) << "mode " << j << ": " << got.transpose() << " vs "
                                        << ref.transpose();
  }
}

// --- R3: hanging chain (discrete: Laguerre zeros; continuum: Bessel zeros) ----

// Zeros of the Laguerre polynomial L_N: eigenvalues of its symmetric tridiagonal
// Jacobi matrix, diagonal 2i+1, off-diagonal i (Golub–Welsch), ascending.
Eigen::VectorXd laguerre_zeros(int N) {
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(N, N);
  for (int i = 0; i < N; ++i) J(i, i) = 2 * i + 1;
  for (int i = 1; i < N; ++i) J(i, i - 1) = J(i - 1, i) = i;
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(J, Eigen::EigenvaluesOnly).eigenvalues();
}

// A hanging chain of N point-mass links, in the format of models/hanging_chain.toml.
std::string chain_scene(int N) {
  return "title = \"Hanging chain, " + std::to_string(N) + " links\"\n"
         "gravity = [0, 0, \"-g\"]\n[parameters]\nL = 1.0\nM = 1.0\ng = 9.81\n"
         "[[chain]]\nname = \"link\"\nlinks = " + std::to_string(N) + "\n"
         "length = \"L\"\nmass = \"M\"\nmass_model = \"point\"\naxis = [0, 1, 0]\ndirection = [0, 0, -1]\n";
}

TEST_F(Cli, R3HangingChainLaguerreZeros) {
  // models/hanging_chain.toml: N = 20, L = 1, g = 9.81 (its [parameters]).
  const int N = 20;
  const double L = 1, g = 9.81, a = L / N;
  const Outcome r = run({"analyze", models + "hanging_chain.toml", "--modes", "5", "--csv", prefix()});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv modes = read_csv(prefix() + "_modes.csv");
  ASSERT_EQ(modes.rows.size(), 5u);  // --modes 5
  const Eigen::VectorXd x = laguerre_zeros(N);
  for (int k = 0; k < 5; ++k)
    EXPECT_REL(number(modes.rows[static_cast<std::size_t>(k)], "omega2"), g / a * x[k], 1e-9)
        << "mode " << k + 1;
  // The shapes file has N rows per reported mode.
  EXPECT_EQ(read_csv(prefix() + "_shapes.csv").rows.size(), 5u * N);
}

TEST_F(Cli, R3HangingChainConvergesToBessel) {
  // Continuum limit ω_k = (j0,k/2) sqrt(g/L) (docs/design.md R3); point-mass
  // links converge as O(1/N): doubling N should roughly halve the error.
  const double half_j0[3] = {1.202412778848, 2.760039055143, 4.326863956456};
  const double g = 9.81, L = 1;
  std::vector<std::array<double, 3>> errors;
  for (int N : {10, 20, 40}) {
    const std::string scene = write("chain" + std::to_string(N) + ".toml", chain_scene(N));
    const Outcome r = run({"analyze", scene, "--modes", "3", "--csv", prefix("C" + std::to_string(N))});
    ASSERT_EQ(r.status, 0) << r.err;
    const Csv modes = read_csv(prefix("C" + std::to_string(N)) + "_modes.csv");
    ASSERT_EQ(modes.rows.size(), 3u);
    // Each discrete chain also matches its own Laguerre zeros to 1e-9.
    const Eigen::VectorXd x = laguerre_zeros(N);
    std::array<double, 3> e{};
    for (int k = 0; k < 3; ++k) {
      const double w = number(modes.rows[static_cast<std::size_t>(k)], "omega");
      EXPECT_REL(w, std::sqrt(g * N / L * x[k]), 1e-9);
      const double exact = half_j0[k] * std::sqrt(g / L);
      e[static_cast<std::size_t>(k)] = std::abs(w - exact) / exact;
    }
    errors.push_back(e);
  }
  for (std::size_t k = 0; k < 3; ++k)
    for (std::size_t i = 0; i + 1 < errors.size(); ++i) {
      const double ratio = errors[i][k] / errors[i + 1][k];
      // O(1/N): ratio → 2 as N grows; [1.6, 2.4] tolerates the O(1/N²) terms at N = 10.
      EXPECT_GT(ratio, 1.6) << "mode " << k + 1 << ", step " << i;
      EXPECT_LT(ratio, 2.4) << "mode " << k + 1 << ", step " << i;
    }
}

// --- equilibria, stability --------------------------------------------------

TEST_F(Cli, DoublePendulumHasFourEquilibria) {
  const std::string file = prefix("eq") + ".csv";
  const Outcome r = run({"equilibria", models + "double_pendulum.toml", "--csv", file});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv eq = read_csv(file);
  EXPECT_EQ(eq.header, (std::vector<std::string>{"equilibrium", "stability", "morse_index", "potential",
                                                 "residual", "upper", "lower"}));
  ASSERT_EQ(eq.rows.size(), 4u) << r.out;
  std::vector<int> morse;
  for (const Row& row : eq.rows) {
    morse.push_back(std::stoi(row.at("morse_index")));
    EXPECT_EQ(row.at("stability"), morse.back() == 0 ? "stable" : "divergence");
    EXPECT_LE(number(row, "residual"), 1e-10);
  }
  std::sort(morse.begin(), morse.end());
  EXPECT_EQ(morse, (std::vector<int>{0, 1, 1, 2}));  // docs/design.md R1
  EXPECT_NE(r.out.find("4 equilibria"), std::string::npos) << r.out;
}

TEST_F(Cli, InvertedPendulumDiverges) {
  // V = m g l cos θ about the top: λ = −g/l, kept negative (docs/design.md section 3).
  const double g = 9.81, l = 2;
  const Outcome r = run({"analyze", models + "inverted_pendulum.toml", "--set", "l=2", "--csv", prefix(),
                     "--json", prefix() + ".json"});
  ASSERT_EQ(r.status, 0) << r.err;  // unstable is not a failure without --require-stable
  const Csv modes = read_csv(prefix() + "_modes.csv");
  ASSERT_EQ(modes.rows.size(), 1u);
  EXPECT_REL(number(modes.rows[0], "omega2"), -g / l, 1e-9);
  EXPECT_REL(number(modes.rows[0], "growth_rate"), std::sqrt(g / l), 1e-9);
  EXPECT_EQ(modes.rows[0].at("stability"), "divergence");
  EXPECT_EQ(modes.rows[0].at("period"), "");  // ω = 0: infinite period, empty field
  const Csv eq = read_csv(prefix() + "_equilibria.csv");
  ASSERT_EQ(eq.rows.size(), 1u);
  EXPECT_EQ(eq.rows[0].at("stability"), "divergence");
  EXPECT_EQ(eq.rows[0].at("morse_index"), "1");
  EXPECT_NE(r.out.find("divergence"), std::string::npos);

  const Outcome strict = run({"analyze", models + "inverted_pendulum.toml", "--require-stable"});
  EXPECT_EQ(strict.status, 3) << strict.err;
  EXPECT_NE(strict.err.find("unstable"), std::string::npos) << strict.err;

  const Outcome fine = run({"analyze", models + "double_pendulum.toml", "--require-stable"});
  EXPECT_EQ(fine.status, 0) << fine.err;
}

TEST_F(Cli, AtSelectsAnEquilibrium) {
  // Both rods up, (π, 0) in relative angles: Morse index 2.
  const Outcome r = run({"analyze", models + "double_pendulum.toml", "--at", "3.141592653589793,0", "--csv",
                     prefix()});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv eq = read_csv(prefix() + "_equilibria.csv");
  ASSERT_EQ(eq.rows.size(), 1u);
  EXPECT_EQ(eq.rows[0].at("morse_index"), "2");
  EXPECT_REL(std::abs(number(eq.rows[0], "upper")), std::numbers::pi, 1e-12);
  const Csv modes = read_csv(prefix() + "_modes.csv");
  ASSERT_EQ(modes.rows.size(), 2u);
  EXPECT_LT(number(modes.rows[0], "omega2"), 0);
  EXPECT_LT(number(modes.rows[1], "omega2"), 0);
}

// --- errors and exit statuses ------------------------------------------------

TEST_F(Cli, MalformedScenesExit2WithFileAndLine) {
  const std::string bad = write("bad.toml", "title = \"bad\"\n\n[[body]]\nname = \"a\"\njoint = \"hinge\"\nmass = -1\n");
  Outcome r = run({"analyze", bad});
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(std::regex_search(r.err, std::regex("bad\\.toml:6:[0-9]+: .*mass"))) << r.err;

  const std::string syntax = write("syntax.toml", "title = \"bad\"\n[[body]\nname = \"a\"\n");
  r = run({"check", syntax});
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(std::regex_search(r.err, std::regex("syntax\\.toml:2:[0-9]+"))) << r.err;

  r = run({"analyze", (dir / "no_such_file.toml").string()});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("no_such_file.toml"), std::string::npos) << r.err;
}

TEST_F(Cli, BadSetAndAtExit2) {
  Outcome r = run({"analyze", models + "double_pendulum.toml", "--set", "m1"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--set"), std::string::npos) << r.err;

  r = run({"analyze", models + "double_pendulum.toml", "--set", "nosuch=1"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("nosuch"), std::string::npos) << r.err;

  r = run({"analyze", models + "double_pendulum.toml", "--at", "0.1"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("2 comma-separated"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("upper, lower"), std::string::npos) << r.err;

  r = run({"analyze", models + "double_pendulum.toml", "--at", "0.1,abc"});
  EXPECT_EQ(r.status, 2);

  r = run({"analyze", models + "double_pendulum.toml", "--at", "0.3,0.2"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("not an equilibrium"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("nearest equilibrium"), std::string::npos) << r.err;
}

TEST_F(Cli, UsageErrorsExit1) {
  EXPECT_EQ(run({"analyze", models + "double_pendulum.toml", "--no-such-option"}).status, 1);
  EXPECT_EQ(run({"frobnicate"}).status, 1);
  EXPECT_EQ(run({}).status, 1);
  EXPECT_EQ(run({"analyze"}).status, 1);  // SCENE missing
  EXPECT_EQ(run({"analyze", models + "double_pendulum.toml", "--modes", "many"}).status, 1);
}

TEST_F(Cli, FreeBodyUnderGravityHasNoEquilibrium) {
  const std::string scene = write(
      "free.toml", "title = \"falling\"\n[[body]]\nname = \"b\"\njoint = \"free\"\nmass = 1\ninertia = [1, 1, 1, 0, 0, 0]\n");
  const Outcome r = run({"analyze", scene});
  EXPECT_EQ(r.status, 4) << r.out << r.err;
  EXPECT_NE(r.err.find("numerical failure"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("no equilibrium"), std::string::npos) << r.err;
}

// --- outputs -------------------------------------------------------------------

TEST_F(Cli, JsonHasTheWholeResult) {
  const std::string file = prefix() + ".json";
  const Outcome r = run({"analyze", models + "double_pendulum.toml", "--json", file});
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(slurp(file));
  EXPECT_EQ(j["title"], "Planar double pendulum (point masses)");
  EXPECT_EQ(j["coordinates"], (std::vector<std::string>{"upper", "lower"}));
  EXPECT_EQ(j["parameters"]["g"].get<double>(), 1.0);
  EXPECT_EQ(j["stability"], "stable");
  ASSERT_EQ(j["modes"].size(), 2u);
  // R1 row 1: ω² = 2 ∓ √2.
  EXPECT_REL(j["modes"][0]["omega2"].get<double>(), 2 - std::numbers::sqrt2, 1e-9);
  EXPECT_REL(j["modes"][1]["omega2"].get<double>(), 2 + std::numbers::sqrt2, 1e-9);
  EXPECT_EQ(j["modes"][0]["shape"].size(), 2u);
  EXPECT_TRUE(j["equilibrium"]["coordinates"].contains("upper"));
  EXPECT_TRUE(j["solver"].is_string());
  EXPECT_TRUE(j["notes"].is_array());

  const std::string all = prefix("all") + ".json";
  ASSERT_EQ(run({"equilibria", models + "double_pendulum.toml", "--json", all}).status, 0);
  EXPECT_EQ(nlohmann::json::parse(slurp(all))["equilibria"].size(), 4u);
}

TEST_F(Cli, CheckSummarizes) {
  const Outcome r = run({"check", models + "double_pendulum.toml", "--set", "m2=3"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("Planar double pendulum"), std::string::npos);
  EXPECT_NE(r.out.find("Total mass: 4 kg"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("upper"), std::string::npos);
  EXPECT_NE(r.out.find("hinge"), std::string::npos);
}

TEST_F(Cli, TimingReportsEveryStage) {
  const Outcome r = run({"analyze", models + "double_pendulum.toml", "--timing"});
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* stage : {"parse+build", "equilibrium", "linearize", "eigen", "report", "total"})
    EXPECT_NE(r.err.find(stage), std::string::npos) << stage << "\n" << r.err;
}

TEST_F(Cli, VersionAndHelp) {
  Outcome r = run({"--version"});
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.out.rfind("modal ", 0), 0u) << r.out;
  r = run({"--help"});
  EXPECT_EQ(r.status, 0);
  for (const char* cmd : {"analyze", "equilibria", "check"})
    EXPECT_NE(r.out.find(cmd), std::string::npos) << r.out;
  for (const char* cmd : {"analyze", "equilibria", "check"}) {
    r = run({cmd, "--help"});
    EXPECT_EQ(r.status, 0) << cmd;
    EXPECT_NE(r.out.find("--set"), std::string::npos) << r.out;
  }
}

}  // namespace

// --- kinematic maps end to end --------------------------------------------------

TEST_F(Cli, MapSteadyMotionInTheCsv) {
  // Sleeping top at spin 80 (models/spinning_top.toml): p = C·spin = 0.32, A = A_c + m h² = 0.012,
  // ω = [p ± √(p² − 4 A m g h)]/(2A); the steady rate and momentum of psi are in the equilibria CSV.
  const Outcome r = run({"analyze", models + "spinning_top.toml", "--csv", prefix()});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv eq = read_csv(prefix() + "_equilibria.csv");
  ASSERT_EQ(eq.rows.size(), 1u);
  EXPECT_EQ(eq.rows[0].at("stability"), "stable");
  EXPECT_REL(number(eq.rows[0], "psi_rate"), 80.0, 1e-15);
  EXPECT_REL(number(eq.rows[0], "psi_momentum"), 0.32, 1e-14);
  const double p = 0.32, A = 0.012, mgh = 0.981;
  const double root = std::sqrt(p * p - 4 * A * mgh);
  const Csv modes = read_csv(prefix() + "_modes.csv");
  ASSERT_EQ(modes.rows.size(), 2u);
  EXPECT_REL(number(modes.rows[0], "omega"), (p - root) / (2 * A), 1e-10);
  EXPECT_REL(number(modes.rows[1], "omega"), (p + root) / (2 * A), 1e-10);
  EXPECT_NE(r.out.find("steady motion"), std::string::npos) << r.out;
}

TEST_F(Cli, MapSingularMassMatrixIsDiagnosed) {
  // Spherical angles at rest at the bottom (w = 0): the pole of the chart, exit 4 with words.
  const Outcome r = run({"analyze", models + "spherical_pendulum_angles.toml", "--set", "w=0"});
  EXPECT_EQ(r.status, 4);
  EXPECT_NE(r.err.find("mass matrix is singular"), std::string::npos) << r.err;
}

TEST_F(Cli, MapSweepFindsTheSleepingTopThreshold) {
  // Restabilization at spin = 2√(A m g h)/C = 54.2494239…, ω there √(m g h / A).
  const Outcome r = run({"sweep", models + "spinning_top.toml", "--vary", "spin=40:70:7", "--csv", prefix("S.csv")});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv critical = read_csv(prefix("S_critical.csv"));
  ASSERT_EQ(critical.rows.size(), 1u);
  const double expected = 2 * std::sqrt(0.012 * 0.981) / 0.004;
  EXPECT_LE(std::abs(number(critical.rows[0], "value") - expected), 1e-8 * expected);
  EXPECT_EQ(critical.rows[0].at("after"), "stable");
  EXPECT_REL(number(critical.rows[0], "omega"), std::sqrt(0.981 / 0.012), 1e-5);  // merging pair: √(bracket)
}

TEST_F(Cli, MapSimulateWritesTheTrajectory) {
  const Outcome r = run({"simulate", models + "bead_on_hoop.toml", "--duration", "2.6", "--at", "1", "--csv",
                         prefix("T.csv")});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv t = read_csv(prefix("T.csv"));
  ASSERT_EQ(t.header.front(), "time");
  ASSERT_EQ(t.header[1], "theta");
  ASSERT_FALSE(t.rows.empty());
  for (const Row& row : t.rows) EXPECT_LE(std::abs(number(row, "energy_error")), 1e-9);
}

// --- constraints (loop closures; docs/design.md section 3) ----------------------------------

namespace {

// ω of every mode of `scene` from `modal analyze --csv`.
std::vector<double> analyzed_omegas(const modal::test::Outcome& r, const std::string& prefix) {
  EXPECT_EQ(r.status, 0) << r.err;
  std::vector<double> omega;
  for (const Row& row : read_csv(prefix + "_modes.csv").rows) omega.push_back(number(row, "omega"));
  return omega;
}

}  // namespace

TEST_F(Cli, ParticlePendulumIsSqrtGOverLExactly) {
  for (const double l : {1.0, 2.5}) {
    const std::string p = prefix("pp" + std::to_string(static_cast<int>(10 * l)));
    const Outcome r = run({"analyze", models + "particle_pendulum.toml", "--set", "l=" + std::to_string(l), "--csv", p});
    const std::vector<double> omega = analyzed_omegas(r, p);
    ASSERT_EQ(omega.size(), 1u);
    // The stiffness is the multiplier term alone, m g / l; ω² = g/l to rounding.
    EXPECT_REL(omega[0], std::sqrt(9.81 / l), 4e-15);
    const Csv eq = read_csv(p + "_equilibria.csv");
    ASSERT_EQ(eq.rows.size(), 1u);
    EXPECT_REL(number(eq.rows[0], "rod_force"), -9.81, 1e-14);  // tension m g
    EXPECT_NE(r.out.find("rod  distance  tension 9.81"), std::string::npos) << r.out;
  }
}

TEST_F(Cli, HingeTreeAndItsConstrainedTwinAgree) {
  const std::string a = prefix("hinges"), b = prefix("free");
  const std::vector<double> wa = analyzed_omegas(run({"analyze", models + "twin_hinges.toml", "--csv", a}), a);
  const Outcome rb = run({"analyze", models + "twin_free.toml", "--csv", b});
  const std::vector<double> wb = analyzed_omegas(rb, b);
  ASSERT_EQ(wa.size(), 2u);
  ASSERT_EQ(wb.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) EXPECT_REL(wb[i], wa[i], 1e-10);
  // Two points per hinge axis: one redundant equation per hinge, reported.
  EXPECT_NE(rb.out.find("2 redundant constraint equations"), std::string::npos) << rb.out;
  // Mode shapes come back in all 12 coordinates.
  const Csv shapes = read_csv(b + "_shapes.csv");
  EXPECT_EQ(shapes.rows.size(), 24u);
}

TEST_F(Cli, FourBarReportsItsRedundantEquationAndSweeps) {
  const std::string json = (dir / "fb.json").string();
  const Outcome r = run({"analyze", models + "four_bar.toml", "--json", json});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("1 redundant constraint equation (loop.y)"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(slurp(json));
  ASSERT_EQ(j["constraints"].size(), 1u);
  EXPECT_TRUE(j["constraints"][0]["force"][1].is_null());  // not determined by statics
  EXPECT_TRUE(j["constraints"][0]["force"][2].is_number());
  EXPECT_EQ(j["redundant_equations"][0], "loop.y");
  EXPECT_EQ(j["modes"].size(), 1u);  // 3 hinges − 2 independent equations
  const std::string csv = (dir / "sweep.csv").string();
  const Outcome s = run({"sweep", models + "four_bar.toml", "--vary", "theta0=-3.14159:3.14159:37", "--csv", csv});
  ASSERT_EQ(s.status, 0) << s.err;
  EXPECT_EQ(read_csv(csv).rows.size(), 37u);
}

TEST_F(Cli, ClosedChainSupportsCarryHalfTheWeight) {
  const std::string csv = (dir / "eq.csv").string();
  const Outcome r = run({"equilibria", models + "closed_chain.toml", "--csv", csv});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv eq = read_csv(csv);
  ASSERT_GE(eq.rows.size(), 1u);
  const Row& hanging = eq.rows.front();  // lowest potential
  EXPECT_EQ(hanging.at("stability"), "stable");
  // Symmetry: the right support carries m g / 2 = 14.715 N vertically.
  EXPECT_REL(number(hanging, "right_support.z_force"), 3.0 * 9.81 / 2, 1e-12);
  EXPECT_EQ(hanging.at("right_support.y_force"), "");  // redundant in the plane
}

TEST_F(Cli, InconsistentConstraintsExit4) {
  const std::string scene = write("bad.toml", R"([[particle]]
name = "p"
position = [0, 0, -1]
mass = 1

[[constraint]]
type = "distance"
a = "p"
b = "world"
b_point = [-5, 0, 0]
length = 1

[[constraint]]
type = "distance"
a = "p"
b = "world"
b_point = [5, 0, 0]
length = 1
)");
  const Outcome r = run({"analyze", scene});
  EXPECT_EQ(r.status, 4);
  EXPECT_NE(r.err.find("constraints cannot all be satisfied"), std::string::npos) << r.err;
}

TEST_F(Cli, CheckAndSimulateConstrainedScenes) {
  const Outcome c = run({"check", models + "four_bar.toml"});
  ASSERT_EQ(c.status, 0) << c.err;
  EXPECT_NE(c.out.find("Constraints (1, 3 equations)"), std::string::npos) << c.out;
  const std::string csv = (dir / "sim.csv").string();
  const Outcome s = run({"simulate", models + "closed_chain.toml", "--duration", "5", "--velocity", "1,0,0,0,0,0",
                         "--csv", csv});
  ASSERT_EQ(s.status, 0) << s.err;
  EXPECT_NE(s.err.find("brought onto the constraints"), std::string::npos) << s.err;
  double worst = 0;
  for (const Row& row : read_csv(csv).rows) worst = std::max(worst, std::abs(number(row, "energy_error")));
  EXPECT_LT(worst, 1e-11);  // rk8pd at 1e-12 with the projections at every sample
}

// --- large scenes: the sparse path ------------------------------------------------

namespace {

const char* small_net = R"(gravity = [0, 0, -9.81]
[[lattice]]
name = "net"
size = [14, 14, 1]
spacing = 0.1
mass = 0.002
stiffness = 1000
prestrain = 0.02
fixed = "boundary"
)";

// --derivatives (issue 6, part 1): every method end to end, the note that
// says what K was computed with, and the misuses refused with status 2.
TEST_F(Cli, DerivativeMethodsAndTheirMisuse) {
  for (const char* method : {"exact", "central", "forward", "complex-step"}) {
    const Outcome r = run({"analyze", models + "double_pendulum.toml", "--derivatives", method});
    ASSERT_EQ(r.status, 0) << method << ": " << r.err;
    EXPECT_NE(r.out.find("0.7653668647"), std::string::npos) << method << r.out;  // R1, ω₁ (10 digits hold)
    EXPECT_EQ(r.out.find("differences (step factor") != std::string::npos, std::string(method) != "exact") << r.out;
  }
  const Outcome stepped = run({"analyze", models + "double_pendulum.toml", "--derivatives", "forward", "--step", "1e-4"});
  ASSERT_EQ(stepped.status, 0) << stepped.err;
  EXPECT_NE(stepped.out.find("step factor 0.0001"), std::string::npos) << stepped.out;
  EXPECT_EQ(run({"analyze", models + "double_pendulum.toml", "--derivatives", "numeric"}).status, 1);
  const Outcome exact_step = run({"analyze", models + "double_pendulum.toml", "--step", "1e-6"});
  EXPECT_EQ(exact_step.status, 2);
  EXPECT_NE(exact_step.err.find("--step sets the step of differences"), std::string::npos) << exact_step.err;
  const Outcome map = run({"analyze", models + "double_pendulum_map.toml", "--derivatives", "complex-step"});
  EXPECT_EQ(map.status, 2);
  EXPECT_NE(map.err.find("not available for kinematic maps"), std::string::npos) << map.err;
  const std::string net = write("net.toml", small_net);
  const Outcome sparse = run({"analyze", net, "--solver", "sparse", "--derivatives", "central"});
  EXPECT_EQ(sparse.status, 2);
  EXPECT_NE(sparse.err.find("the sparse path assembles K exactly"), std::string::npos) << sparse.err;
  // --eq-tol: a looser equilibrium tolerance is accepted end to end.
  const Outcome loose = run({"analyze", models + "double_pendulum.toml", "--eq-tol", "1e-6"});
  EXPECT_EQ(loose.status, 0) << loose.err;
  EXPECT_EQ(run({"analyze", models + "double_pendulum.toml", "--eq-tol", "0.5"}).status, 1);
  // --dense-solver: both solvers end to end, and a bad name is a usage error.
  const Outcome lapack = run({"analyze", models + "double_pendulum.toml", "--dense-solver", "lapack"});
  ASSERT_EQ(lapack.status, 0) << lapack.err;
  // Point masses at the next hinge: the point-mass chain's tridiagonal form (LAPACK's MRRR).
  EXPECT_NE(lapack.out.find("LAPACK: point-mass chain"), std::string::npos) << lapack.out;
  EXPECT_NE(lapack.out.find("0.7653668647"), std::string::npos) << lapack.out;
  EXPECT_EQ(run({"analyze", models + "double_pendulum.toml", "--dense-solver", "mkl"}).status, 1);
}

// modal amplitude (issue 6, part 3) end to end: a scan with the 1 % and 10 %
// amplitudes, its CSV, and the modes it refuses in words (status 2).
TEST_F(Cli, AmplitudeScanAndItsRefusals) {
  const std::string csv = prefix("amp.csv");
  const Outcome scan = run({"amplitude", models + "inverted_pendulum.toml", "--at", "3.14159", "--amplitudes",
                            "0.1,0.5,1.5", "--csv", csv});
  ASSERT_EQ(scan.status, 0) << scan.err;
  EXPECT_NE(scan.out.find("Frequency departs by 1 % at amplitude 0.4001643"), std::string::npos) << scan.out;
  EXPECT_NE(scan.out.find("Frequency departs by 10 % at amplitude 1.26932"), std::string::npos) << scan.out;
  std::ifstream in(csv);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "amplitude,oscillates,omega,omega_ratio_minus_1,spread,cycles,simulated_seconds");
  const Outcome divergent = run({"amplitude", models + "inverted_pendulum.toml"});  // analyzed at the top
  EXPECT_EQ(divergent.status, 2);
  EXPECT_NE(divergent.err.find("a divergent mode"), std::string::npos) << divergent.err;
  const Outcome range = run({"amplitude", models + "double_pendulum.toml", "--mode", "3"});
  EXPECT_EQ(range.status, 2);
  EXPECT_NE(range.err.find("the scene has modes 1 to 2"), std::string::npos) << range.err;
  const Outcome follower = run({"amplitude", models + "ziegler.toml"});
  EXPECT_EQ(follower.status, 2);
  EXPECT_NE(follower.err.find("undamped mode"), std::string::npos) << follower.err;
  const Outcome order = run({"amplitude", models + "double_pendulum.toml", "--amplitudes", "0.5,0.1"});
  EXPECT_EQ(order.status, 2);
  EXPECT_EQ(run({"amplitude", models + "double_pendulum.toml", "--amplitudes", "-1"}).status, 1);
}


// The progress bar (long work on a terminal): shown when stderr is a
// terminal, not with --quiet (before or after the command's name) nor under
// CI=true. The terminal is a pseudo-terminal made by script(1) (util-linux);
// a simulation of about three seconds on a fast machine (the bar waits one;
// at --duration 1000 one machine finished in 0.95 s, before the bar).
TEST_F(Cli, ProgressBarOnlyOnATerminalWithoutQuietOrCi) {
  if (std::system("command -v script > /dev/null 2>&1") != 0) GTEST_SKIP() << "script(1) is not installed";
  const std::string scene = std::string(MODAL_SOURCE_DIR) + "/models/double_pendulum.toml";
  auto shown = [&](const std::string& environment, const std::string& before, const std::string& after) {
    const std::filesystem::path log = dir / "terminal.txt";
    const std::string command = environment + " " + modal::test::quote(MODAL_BINARY) + before + " simulate " +
                                modal::test::quote(scene) + " --duration 3000 --at 0.5,0 --interval 1" + after +
                                " > /dev/null";
    const std::string run = "script -qec " + modal::test::quote(command) + " " + modal::test::quote(log.string()) +
                            " > /dev/null 2>&1";
    EXPECT_EQ(std::system(run.c_str()), 0) << run;
    return modal::test::slurp(log).find("simulate [") != std::string::npos;
  };
  EXPECT_TRUE(shown("env -u CI", "", ""));
  EXPECT_FALSE(shown("env -u CI", "", " --quiet"));
  EXPECT_FALSE(shown("env -u CI", " -q", ""));
  EXPECT_FALSE(shown("env CI=true", "", ""));
  // Not a terminal: nothing, whatever the environment.
  const Outcome piped = run({"simulate", scene, "--duration", "1000", "--at", "0.5,0", "--interval", "1"});
  EXPECT_EQ(piped.status, 0);
  EXPECT_EQ(piped.err.find("simulate ["), std::string::npos);
}

}  // namespace

// The same scene through both solvers: the 10 lowest eigenvalues agree to
// 1e-10 (both are backward stable; the sparse residuals are ~1e-11 relative).
TEST_F(Cli, SparseAndDenseSolversAgree) {
  const std::string scene = write("net.toml", small_net);
  const std::string d = prefix("dense"), s = prefix("sparse");
  const Outcome rd = run({"analyze", scene, "--solver", "dense", "--modes", "10", "--csv", d});
  const Outcome rs = run({"analyze", scene, "--solver", "sparse", "--modes", "10", "--csv", s});
  ASSERT_EQ(rd.status, 0) << rd.err;
  ASSERT_EQ(rs.status, 0) << rs.err;
  EXPECT_NE(rs.out.find("sparse shift-invert Lanczos"), std::string::npos) << rs.out;
  const Csv a = read_csv(d + "_modes.csv"), b = read_csv(s + "_modes.csv");
  ASSERT_EQ(a.rows.size(), 10u);
  ASSERT_EQ(b.rows.size(), 10u);
  for (std::size_t i = 0; i < 10; ++i)
    EXPECT_REL(number(b.rows[i], "omega2"), number(a.rows[i], "omega2"), 1e-10) << "mode " << i + 1;
}

// Above large_system_coordinates: both strategies of the large-scene
// equilibrium (Newton first; L-BFGS first) reach the same sagged net, to the
// equilibrium tolerance (1e-12 relative residual; the net's Hessian has a
// condition number of about 1e4, so the coordinates agree to ~1e-8 of the sag).
TEST_F(Cli, LargeEquilibriumStrategiesAgree) {
  std::string text = small_net;
  text.replace(text.find("[14, 14, 1]"), 11, "[21, 21, 1]");  // 3·19² = 1083 coordinates
  const std::string scene = write("net21.toml", text);
  const std::string a = prefix("newton"), b = prefix("lbfgs");
  const Outcome ra = run({"analyze", scene, "--modes", "3", "--large-equilibrium", "newton", "--csv", a});
  const Outcome rb = run({"analyze", scene, "--modes", "3", "--large-equilibrium", "lbfgs", "--csv", b});
  ASSERT_EQ(ra.status, 0) << ra.err;
  ASSERT_EQ(rb.status, 0) << rb.err;
  EXPECT_NE(ra.out.find("found by truncated Newton with the sparse Hessian"), std::string::npos) << ra.out;
  EXPECT_NE(rb.out.find("found by L-BFGS ("), std::string::npos) << rb.out;
  const Row qa = read_csv(a + "_equilibria.csv").rows.at(0), qb = read_csv(b + "_equilibria.csv").rows.at(0);
  const double sag = number(qa, "net.10.10.z");
  EXPECT_LT(sag, -0.01);  // gravity makes the net sag at its centre
  double worst = 0;
  int compared = 0;
  for (const auto& [key, value] : qa)
    if (key.rfind("net.", 0) == 0) {
      worst = std::max(worst, std::abs(number(qa, key) - number(qb, key)));
      ++compared;
    }
  EXPECT_EQ(compared, 1083);
  EXPECT_LT(worst, 1e-8 * std::abs(sag));
  const Outcome bad = run({"analyze", scene, "--large-equilibrium", "bfgs"});
  EXPECT_EQ(bad.status, 1) << bad.err;  // a usage error
}

// A large scene's summary lists the first 100 rows of each list and says how
// many it left out; --all lists every row.
TEST_F(Cli, CheckAbbreviatesLargeScenes) {
  const std::string scene = write("net.toml", small_net);  // 196 particles (52 fixed), 432 coordinates
  const Outcome brief = run({"check", scene});
  ASSERT_EQ(brief.status, 0) << brief.err;
  EXPECT_NE(brief.out.find("Bodies (196)"), std::string::npos) << brief.out;
  EXPECT_NE(brief.out.find("  … and 96 more bodies (modal check --all lists them)"), std::string::npos) << brief.out;
  EXPECT_NE(brief.out.find("  … and 332 more coordinates"), std::string::npos) << brief.out;
  EXPECT_EQ(brief.out.find("net.12.12"), std::string::npos);  // the last particle is not listed
  EXPECT_NE(brief.out.find("Total mass: 0.392 kg"), std::string::npos) << brief.out;  // over all bodies
  const Outcome all = run({"check", scene, "--all"});
  ASSERT_EQ(all.status, 0) << all.err;
  EXPECT_EQ(all.out.find(" more bodies"), std::string::npos);
  EXPECT_NE(all.out.find("net.12.12"), std::string::npos);
}

TEST_F(Cli, ExportMatricesWritesMatrixMarket) {
  const std::string scene = write("net.toml", small_net);
  const std::string out = (dir / "mm").string();
  const Outcome r = run({"analyze", scene, "--solver", "sparse", "--export-matrices", out});
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* name : {"K.mtx", "M.mtx"}) {
    std::ifstream in(fs::path(out) / name);
    std::string header, line;
    std::getline(in, header);
    EXPECT_EQ(header, "%%MatrixMarket matrix coordinate real symmetric") << name;
    while (std::getline(in, line) && line.rfind('%', 0) == 0) {
    }
    std::istringstream size(line);
    long rows = 0, cols = 0, entries = 0;
    size >> rows >> cols >> entries;
    EXPECT_EQ(rows, 12 * 12 * 3);
    EXPECT_EQ(cols, rows);
    EXPECT_GE(entries, rows);  // at least the diagonal
  }
  // The dense path exports too (and the files read back to the same doubles).
  const Outcome dense = run({"analyze", models + "double_pendulum.toml", "--export-matrices", out + "2"});
  ASSERT_EQ(dense.status, 0) << dense.err;
  EXPECT_NE(slurp(fs::path(out + "2") / "K.mtx").find("2 2 3"), std::string::npos);
}

// An unanchored block: six rigid-body modes, reported as zero modes (marginal).
TEST_F(Cli, FreeLatticeReportsItsZeroModes) {
  const std::string scene = write("block.toml", R"(gravity = [0, 0, 0]
[[lattice]]
name = "block"
size = [5, 5, 5]
spacing = 0.1
mass = 0.01
stiffness = 100
diagonals = true
)");
  const std::string p = prefix("free");
  const Outcome r = run({"analyze", scene, "--solver", "sparse", "--modes", "8", "--csv", p});
  ASSERT_EQ(r.status, 0) << r.err;
  const Csv modes = read_csv(p + "_modes.csv");
  ASSERT_EQ(modes.rows.size(), 8u);
  int zero = 0;
  for (const Row& row : modes.rows) zero += row.at("stability") == "marginal";
  EXPECT_EQ(zero, 6);
  EXPECT_EQ(read_csv(p + "_equilibria.csv").rows[0].at("stability"), "marginal");
}

// modal amplitude on a constrained scene (a particle on a rod): the amplitude
// is bob.x in metres, held exactly on the circle, so the 1 % and 10 %
// amplitudes are l sin θ₀ of the hinge pendulum's (0.38956969, 0.95490205);
// a displacement the rod does not allow is a numerical failure in words (4);
// a motion that goes over the top is said to; a zero mode is refused (2).
TEST_F(Cli, AmplitudeConstrainedOverTheTopAndZeroModes) {
  const Outcome rod = run({"amplitude", models + "particle_pendulum.toml", "--amplitudes", "0.1,0.99"});
  ASSERT_EQ(rod.status, 0) << rod.err;
  EXPECT_NE(rod.out.find("'bob.x' = amplitude [m]"), std::string::npos) << rod.out;
  EXPECT_NE(rod.out.find("Frequency departs by 1 % at amplitude 0.38956969"), std::string::npos) << rod.out;
  EXPECT_NE(rod.out.find("Frequency departs by 10 % at amplitude 0.95490205"), std::string::npos) << rod.out;
  const Outcome beyond = run({"amplitude", models + "particle_pendulum.toml", "--amplitudes", "0.5,1.5"});
  EXPECT_EQ(beyond.status, 4);
  EXPECT_NE(beyond.err.find("'bob.x' cannot be moved by 1.5"), std::string::npos) << beyond.err;
  const Outcome over =
      run({"amplitude", models + "inverted_pendulum.toml", "--at", "3.14159", "--amplitudes", "0.1,3.3"});
  ASSERT_EQ(over.status, 0) << over.err;
  EXPECT_NE(over.out.find("has left the well"), std::string::npos) << over.out;
  EXPECT_NE(over.out.find("Frequency departs by 1 % at amplitude 0.40016432"), std::string::npos) << over.out;
  const Outcome zero = run({"amplitude", models + "spherical_pendulum.toml", "--mode", "1"});
  EXPECT_EQ(zero.status, 2);
  EXPECT_NE(zero.err.find("a zero mode"), std::string::npos) << zero.err;
  // A CSV file that cannot be written is refused before integrating (2).
  EXPECT_EQ(run({"amplitude", models + "particle_pendulum.toml", "--csv", "/nonexistent-dir/amp.csv"}).status, 2);
}
