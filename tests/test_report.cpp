// Tests of the report stage: CSV writers (exact headers, empty fields for values
// that do not exist, 17-digit round trip, RFC 4180 quoting), JSON and the text
// output, on hand-built ModalResult / Equilibrium values.
#include "modal/report.hpp"
#include "modal/scene.hpp"

#include <gtest/gtest.h>

#include "csv_fields.hpp"
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

namespace {

using modal::AnalyzedEquilibrium;
using modal::Mode;
using modal::ModeKind;
using modal::Report;

constexpr double nan = std::numeric_limits<double>::quiet_NaN();
constexpr double inf = std::numeric_limits<double>::infinity();

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  std::string line;
  while (std::getline(in, line)) out.push_back(line);
  return out;
}

using modal::test::fields;

Mode symmetric_mode(double lambda, ModeKind kind, Eigen::VectorXd shape) {
  Mode m;
  m.omega2 = lambda;
  if (lambda >= 0) {
    m.s = {0, std::sqrt(lambda)};
  } else {
    m.s = {std::sqrt(-lambda), 0};
  }
  m.growth_rate = m.s.real();
  m.omega = m.s.imag();
  m.frequency_hz = m.omega / (2 * std::numbers::pi);
  m.period = m.omega > 0 ? 2 * std::numbers::pi / m.omega : inf;
  m.damping_ratio = std::abs(m.s) > 0 ? -m.s.real() / std::abs(m.s) : nan;
  m.error_estimate = 1e-15;
  m.kind = kind;
  m.shape = shape.cast<std::complex<double>>();
  return m;
}

// Two equilibria of a two-coordinate system: one stable with an irrational
// frequency (tests the round trip), one with a divergent mode and a zero mode
// (negative omega2 kept negative, infinite period and NaN damping ratio empty).
Report sample() {
  Report r;
  r.scene_file = "models/sample.toml";
  r.title = "Sample, with \"quotes\", commas";
  r.parameters = {{"m", 1.5}, {"g", 9.81}};
  r.coordinates = {"theta", "x,1"};  // a name that needs quoting
  r.kinds = {modal::CoordinateKind::angle, modal::CoordinateKind::length};

  AnalyzedEquilibrium a;
  a.equilibrium.q = Eigen::Vector2d(0.1, -0.2);
  a.equilibrium.potential = -1.0 / 3.0;
  a.equilibrium.residual = 2.5e-17;
  a.equilibrium.residual_norm = 1e-16;
  a.result.modes.push_back(symmetric_mode(std::numbers::sqrt2 - 1, ModeKind::oscillatory,
                                          Eigen::Vector2d(1.0 / 3.0, -2.0 / 7.0)));
  a.result.modes.push_back(symmetric_mode(std::numbers::pi, ModeKind::oscillatory,
                                          Eigen::Vector2d(0.5, 0.25)));
  a.result.stability = modal::Stability::stable;
  a.result.solver = "hand-built";

  AnalyzedEquilibrium b;
  b.equilibrium.q = Eigen::Vector2d(std::numbers::pi, 0.0);
  b.equilibrium.potential = 2.0;
  b.result.modes.push_back(symmetric_mode(-9.81, ModeKind::divergent, Eigen::Vector2d(1, 0)));
  b.result.modes.push_back(symmetric_mode(0.0, ModeKind::zero, Eigen::Vector2d(0, 1)));
  b.result.stability = modal::Stability::divergence;
  b.result.morse_index = 1;
  b.result.zero_modes = 1;
  b.result.notes = {"one zero mode"};

  r.equilibria = {a, b};
  return r;
}

TEST(ReportCsv, NumbersRoundTripWith17Digits) {
  // %.17g is the shortest format that round-trips every double exactly; the
  // tests of the whole program rely on that to check 1e-9 and better.
  for (double x : {1.0 / 3.0, std::numbers::pi, -9.81, 1e-300, 6.02214076e23, 0.1 + 0.2,
                   std::nextafter(1.0, 2.0), -0.0, 5e-324}) {
    const std::string text = modal::csv_number(x);
    EXPECT_EQ(std::strtod(text.c_str(), nullptr), x) << text;
  }
  EXPECT_EQ(modal::csv_number(nan), "");
  EXPECT_EQ(modal::csv_number(inf), "");
  EXPECT_EQ(modal::csv_number(-inf), "");
  EXPECT_EQ(modal::csv_number(2.0), "2");
}

TEST(ReportCsv, QuotesPerRfc4180) {
  EXPECT_EQ(modal::csv_field("plain"), "plain");
  EXPECT_EQ(modal::csv_field("asymptotically stable"), "asymptotically stable");
  EXPECT_EQ(modal::csv_field("a,b"), "\"a,b\"");
  EXPECT_EQ(modal::csv_field("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(modal::csv_field("two\nlines"), "\"two\nlines\"");
  EXPECT_EQ(modal::csv_field("cr\r"), "\"cr\r\"");
  EXPECT_EQ(modal::csv_field(""), "");
}

TEST(ReportCsv, ModeStabilityVocabulary) {
  EXPECT_STREQ(modal::mode_stability(ModeKind::oscillatory), "stable");
  EXPECT_STREQ(modal::mode_stability(ModeKind::damped), "asymptotically stable");
  EXPECT_STREQ(modal::mode_stability(ModeKind::zero), "marginal");
  EXPECT_STREQ(modal::mode_stability(ModeKind::divergent), "divergence");
  EXPECT_STREQ(modal::mode_stability(ModeKind::flutter), "flutter");
}

TEST(ReportCsv, ModesTable) {
  const Report r = sample();
  std::ostringstream out;
  modal::write_modes_csv(out, r);
  const auto l = lines(out.str());
  ASSERT_EQ(l.size(), 5u);
  EXPECT_EQ(l[0],
            "equilibrium,mode,omega2,growth_rate,omega,frequency_hz,period,damping_ratio,stability,"
            "error_estimate,residual_bound");
  for (std::size_t i = 1; i < l.size(); ++i) EXPECT_EQ(fields(l[i]).size(), 11u) << l[i];

  const auto f1 = fields(l[1]);
  EXPECT_EQ(f1[0], "1");
  EXPECT_EQ(f1[1], "1");
  const Mode& m = r.equilibria[0].result.modes[0];
  // Exact round trip: the file holds the very doubles of the result.
  EXPECT_EQ(std::strtod(f1[2].c_str(), nullptr), m.omega2);
  EXPECT_EQ(std::strtod(f1[4].c_str(), nullptr), m.omega);
  EXPECT_EQ(std::strtod(f1[5].c_str(), nullptr), m.frequency_hz);
  EXPECT_EQ(std::strtod(f1[6].c_str(), nullptr), m.period);
  EXPECT_EQ(f1[8], "stable");
  EXPECT_EQ(std::strtod(f1[9].c_str(), nullptr), 1e-15);
  EXPECT_EQ(f1[10], "");  // no residual bound set (NaN): an empty field

  const auto div = fields(l[3]);  // equilibrium 2, mode 1: divergent
  EXPECT_EQ(div[0], "2");
  EXPECT_EQ(div[1], "1");
  EXPECT_EQ(std::strtod(div[2].c_str(), nullptr), -9.81);  // negative, never |λ|
  EXPECT_EQ(std::strtod(div[3].c_str(), nullptr), std::sqrt(9.81));
  EXPECT_EQ(div[4], "0");
  EXPECT_EQ(div[6], "");  // infinite period
  EXPECT_EQ(div[8], "divergence");

  const auto zero = fields(l[4]);
  EXPECT_EQ(zero[6], "");  // infinite period
  EXPECT_EQ(zero[7], "");  // NaN damping ratio
  EXPECT_EQ(zero[8], "marginal");
}

TEST(ReportCsv, ComplexModeHasEmptyOmega2) {
  Report r;
  r.coordinates = {"x"};
  AnalyzedEquilibrium a;
  a.equilibrium.q = Eigen::VectorXd::Zero(1);
  Mode m;
  m.omega2 = nan;
  m.s = {-0.1, 2.0};
  m.growth_rate = -0.1;
  m.omega = 2.0;
  m.frequency_hz = 2.0 / (2 * std::numbers::pi);
  m.period = std::numbers::pi;
  m.damping_ratio = 0.1 / std::abs(m.s);
  m.kind = ModeKind::damped;
  m.shape = Eigen::VectorXcd::Constant(1, {0.5, -0.25});
  a.result.modes = {m};
  a.result.stability = modal::Stability::asymptotically_stable;
  r.equilibria = {a};
  std::ostringstream out;
  modal::write_modes_csv(out, r);
  const auto f = fields(lines(out.str()).at(1));
  EXPECT_EQ(f[2], "");
  EXPECT_EQ(std::strtod(f[3].c_str(), nullptr), -0.1);
  EXPECT_EQ(f[8], "asymptotically stable");

  std::ostringstream shapes;
  modal::write_shapes_csv(shapes, r);
  // value = real part; amplitude and phase of 0.5 − 0.25i: √0.3125 and atan2(−0.25, 0.5).
  const auto sf = fields(lines(shapes.str()).at(1));
  ASSERT_EQ(sf.size(), 6u);
  EXPECT_EQ(sf[3], "0.5");
  EXPECT_NEAR(std::strtod(sf[4].c_str(), nullptr), std::sqrt(0.3125), 1e-15);
  EXPECT_NEAR(std::strtod(sf[5].c_str(), nullptr), std::atan2(-0.25, 0.5) * 180 / std::numbers::pi, 1e-13);

  const auto j = nlohmann::json::parse(modal::analysis_json(r));
  EXPECT_TRUE(j["modes"][0]["omega2"].is_null());
  EXPECT_EQ(j["modes"][0]["shape_imag"][0].get<double>(), -0.25);
  EXPECT_NEAR(j["modes"][0]["shape_amplitude"][0].get<double>(), std::sqrt(0.3125), 1e-15);
}

TEST(ReportCsv, ShapesTable) {
  const Report r = sample();
  std::ostringstream out;
  modal::write_shapes_csv(out, r);
  const auto l = lines(out.str());
  ASSERT_EQ(l.size(), 1u + 2 * 2 * 2);
  EXPECT_EQ(l[0], "equilibrium,mode,coordinate,value,amplitude,phase_deg");
  EXPECT_EQ(fields(l[1]), (std::vector<std::string>{"1", "1", "theta", modal::csv_number(1.0 / 3.0),
                                                    modal::csv_number(1.0 / 3.0), "0"}));
  EXPECT_EQ(l[2].substr(0, 11), "1,1,\"x,1\",-");  // quoted name
  EXPECT_EQ(fields(l[2])[2], "x,1");
  EXPECT_EQ(std::strtod(fields(l[2])[3].c_str(), nullptr), -2.0 / 7.0);
  EXPECT_EQ(fields(l[8]), (std::vector<std::string>{"2", "2", "x,1", "1", "1", "0"}));
  EXPECT_EQ(fields(l[2])[5], "180");  // a negative real component is phase 180°
}

TEST(ReportCsv, EquilibriaTable) {
  const Report r = sample();
  std::ostringstream out;
  modal::write_equilibria_csv(out, r);
  const auto l = lines(out.str());
  ASSERT_EQ(l.size(), 3u);
  EXPECT_EQ(l[0], "equilibrium,stability,morse_index,potential,residual,theta,\"x,1\"");
  const auto a = fields(l[1]);
  ASSERT_EQ(a.size(), 7u);
  EXPECT_EQ(a[1], "stable");
  EXPECT_EQ(a[2], "0");
  EXPECT_EQ(std::strtod(a[3].c_str(), nullptr), -1.0 / 3.0);
  EXPECT_EQ(std::strtod(a[4].c_str(), nullptr), 2.5e-17);
  EXPECT_EQ(std::strtod(a[5].c_str(), nullptr), 0.1);
  const auto b = fields(l[2]);
  EXPECT_EQ(b[0], "2");
  EXPECT_EQ(b[1], "divergence");
  EXPECT_EQ(b[2], "1");
  EXPECT_EQ(std::strtod(b[5].c_str(), nullptr), std::numbers::pi);
}

TEST(ReportCsv, UnnamedCoordinatesAreNumbered) {
  Report r = sample();
  r.coordinates.clear();
  std::ostringstream out;
  modal::write_equilibria_csv(out, r);
  EXPECT_EQ(lines(out.str()).at(0), "equilibrium,stability,morse_index,potential,residual,q1,q2");
}

TEST(ReportCsv, WritesThreeFilesAndReportsUnwritablePaths) {
  const Report r = sample();
  EXPECT_THROW(modal::write_csv_files("/nonexistent-directory/x/prefix", r), modal::ReportError);
}

TEST(ReportJson, AnalysisHasEverything) {
  const Report r = sample();
  const auto j = nlohmann::json::parse(modal::analysis_json(r));
  EXPECT_EQ(j["scene"], "models/sample.toml");
  EXPECT_EQ(j["title"], r.title);
  EXPECT_EQ(j["parameters"]["g"].get<double>(), 9.81);
  EXPECT_EQ(j["coordinates"][1], "x,1");
  EXPECT_EQ(j["equilibrium"]["coordinates"]["theta"].get<double>(), 0.1);
  EXPECT_EQ(j["equilibrium"]["potential"].get<double>(), -1.0 / 3.0);
  EXPECT_EQ(j["stability"], "stable");
  ASSERT_EQ(j["modes"].size(), 2u);
  EXPECT_EQ(j["modes"][0]["omega2"].get<double>(), std::numbers::sqrt2 - 1);  // exact round trip
  EXPECT_EQ(j["modes"][1]["shape"][1].get<double>(), 0.25);
  EXPECT_EQ(j["solver"], "hand-built");
  EXPECT_TRUE(j["notes"].is_array());
}

TEST(ReportJson, EquilibriaListsAll) {
  const Report r = sample();
  const auto j = nlohmann::json::parse(modal::equilibria_json(r));
  ASSERT_EQ(j["equilibria"].size(), 2u);
  EXPECT_EQ(j["equilibria"][1]["stability"], "divergence");
  EXPECT_EQ(j["equilibria"][1]["morse_index"], 1);
  EXPECT_EQ(j["equilibria"][1]["modes"][0]["omega2"].get<double>(), -9.81);
  EXPECT_TRUE(j["equilibria"][1]["modes"][1]["period"].is_null());  // ∞ → null
  EXPECT_EQ(j["equilibria"][1]["notes"][0], "one zero mode");
}

TEST(ReportText, AnalysisShowsSignsDegreesAndStability) {
  Report r = sample();
  std::swap(r.equilibria[0], r.equilibria[1]);  // report the unstable one
  std::ostringstream out;
  modal::print_analysis(out, r);
  const std::string s = out.str();
  EXPECT_NE(s.find(r.title), std::string::npos);
  EXPECT_NE(s.find("180 deg"), std::string::npos) << s;  // θ = π shown in degrees too
  EXPECT_NE(s.find("-9.81"), std::string::npos) << s;    // negative ω² shown negative
  EXPECT_NE(s.find("divergence"), std::string::npos);
  EXPECT_NE(s.find("Morse index 1"), std::string::npos);
  EXPECT_NE(s.find("one zero mode"), std::string::npos);  // notes
}

TEST(ReportText, StabilityInWords) {
  modal::ModalResult r;
  r.stability = modal::Stability::marginal;
  r.zero_modes = 2;
  EXPECT_NE(modal::describe_stability(r).find("2 zero-frequency modes"), std::string::npos);
  r.stability = modal::Stability::flutter;
  EXPECT_EQ(modal::describe_stability(r).rfind("flutter", 0), 0u);
}

TEST(ReportText, SummaryOfAScene) {
  const modal::Scene scene = modal::parse_scene(R"(
title = "Two bodies"
[parameters]
m = 2.0
[[body]]
name = "a"
joint = "hinge"
axis = [0, 1, 0]
mass = "m"
com = [0, 0, -1]
[[body]]
name = "b"
parent = "a"
joint = "slide"
axis = [0, 0, 1]
mass = 0.5
)",
                                                "two.toml");
  const modal::System sys = modal::build_system(scene);
  std::ostringstream out;
  modal::print_summary(out, scene.file, scene.parameters, sys);
  const std::string s = out.str();
  EXPECT_NE(s.find("Two bodies"), std::string::npos);
  EXPECT_NE(s.find("Total mass: 2.5 kg"), std::string::npos) << s;
  EXPECT_NE(s.find("slide"), std::string::npos);
  EXPECT_NE(s.find("Bodies (2)"), std::string::npos);
}

}  // namespace
