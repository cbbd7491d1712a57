// HTML reports (`modal analyze --report`; docs/design.md, "HTML reports"): the
// drawing's displacements against the closed form of a double pendulum, the
// decimation of a large lattice and the page's size, and the command line's
// handling of the report path. The page in a browser: tests/report_browser.py.
#include "program.hpp"

#include "modal/pipeline.hpp"
#include "modal/report.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <filesystem>
#include <random>
#include <string>

namespace {

namespace fs = std::filesystem;
const std::string models = std::string(MODAL_SOURCE_DIR) + "/models/";

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("modal_html_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Hinges about y at the hanging equilibrium: a mode (φ1, φ2) moves the first
// mass by −l1 φ1 along x and the second by −(l1 φ1 + l2 (φ1 + φ2)), nothing
// along y or z (to first order). Random masses and lengths (seeded). The
// drawing differentiates the positions by central differences with a step of
// 1e-6 rad: truncation error ~1e-12 relative, so 1e-8 leaves room for rounding.
TEST(HtmlReport, DrawingIsTheLinearizedMotionOfADoublePendulum) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0.3, 3.0);
  for (int trial = 0; trial < 8; ++trial) {
    const double l1 = u(rng), l2 = u(rng);
    const modal::Model model = modal::load_model(
        models + "double_pendulum.toml",
        {"l1=" + std::to_string(l1), "l2=" + std::to_string(l2), "m1=" + std::to_string(u(rng)),
         "m2=" + std::to_string(u(rng))});
    const double L1 = model.scene.parameters[2].second, L2 = model.scene.parameters[3].second;
    modal::AnalysisOptions options;
    options.drawing = true;
    const modal::Analysis a = modal::analyze(model, options);
    const auto& drawing = a.report.equilibria.front().drawing;
    ASSERT_TRUE(drawing.has_value());
    EXPECT_EQ(drawing->dimensions, 2);
    EXPECT_EQ(drawing->plane[0], 0);
    EXPECT_EQ(drawing->plane[1], 2);
    ASSERT_EQ(drawing->points.size(), 4u);  // pivot, first mass, second hinge (at the first mass), second mass
    ASSERT_EQ(drawing->modes.size(), 2u);
    for (std::size_t m = 0; m < 2; ++m) {
      const Eigen::VectorXd phi = a.result().modes[m].shape.real();
      const auto& d = drawing->displacements[m];
      const double x1 = -L1 * phi[0], x2 = -(L1 * phi[0] + L2 * (phi[0] + phi[1]));
      const double scale = std::max(std::abs(x1), std::abs(x2));
      EXPECT_NEAR(d[1].x(), x1 / scale, 1e-8) << "trial " << trial << " mode " << m + 1;
      EXPECT_NEAR(d[3].x(), x2 / scale, 1e-8) << "trial " << trial << " mode " << m + 1;
      for (const modal::Vec3& v : d) {
        EXPECT_NEAR(v.y(), 0, 1e-12);
        EXPECT_NEAR(v.z(), 0, 1e-8);
      }
      EXPECT_NEAR(d[0].norm(), 0, 1e-12);
    }
  }
}

// A lattice of 40 x 40 x 20 particles (96000 coordinates) with 10 modes of
// random shapes (no eigen-solution: the drawing and the page only need
// shapes): at most 20000 points drawn, a note saying so, and a page under
// the 10 MB the design promises.
TEST(HtmlReport, LargeLatticeIsDecimatedAndTheReportStaysSmall) {
  const std::string scene = R"(title = "big"
[[lattice]]
name = "b"
size = [40, 40, 20]
spacing = 0.1
origin = [0, 0, 0]
mass = 0.01
stiffness = 1000
fixed = "z-"
)";
  const modal::Model model = modal::model_from_text(scene, "big.toml");
  const int n = model.system.size();
  ASSERT_GE(n, 90000);
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  modal::ModalResult result;
  for (int m = 0; m < 12; ++m) {
    modal::Mode mode;
    mode.omega2 = m + 1.0;
    mode.shape = Eigen::VectorXcd(n);
    for (int i = 0; i < n; ++i) mode.shape[i] = g(rng);
    result.modes.push_back(mode);
  }
  modal::Equilibrium eq;
  eq.q = model.system.initial_configuration();
  auto drawing = modal::scene_drawing(model.system, eq.q, result);
  ASSERT_TRUE(drawing.has_value());
  EXPECT_EQ(drawing->dimensions, 3);
  EXPECT_LE(drawing->points.size(), modal::DrawingLimits{}.points);
  EXPECT_EQ(drawing->total_points, 40u * 40u * 20u);  // every particle, the clamped base's too
  EXPECT_EQ(drawing->modes.size(), 10u);
  EXPECT_NE(drawing->note.find("is drawn"), std::string::npos) << drawing->note;
  EXPECT_NE(drawing->note.find("lowest 10 of the 12 modes"), std::string::npos) << drawing->note;
  modal::Report report = modal::make_report(model.system, "big.toml", {});
  report.equilibria.push_back({eq, result, std::nullopt, std::move(drawing)});
  const std::string page = modal::analysis_html(report);
  EXPECT_LT(page.size(), 10'000'000u);
  std::cout << "page of a " << n << "-coordinate lattice: " << page.size() << " bytes\n";
  // Nothing fetched: no external script, style sheet or image.
  EXPECT_EQ(page.find("src=\"http"), std::string::npos);
  EXPECT_EQ(page.find("<link"), std::string::npos);
}

TEST(HtmlReport, CommandLineWritesTheReportWithTheOtherOutputs) {
  const fs::path dir = fresh_dir("outputs");
  const std::string prefix = (dir / "dp").string(), page = (dir / "dp.html").string();
  const auto ok = modal::test::run_modal(
      {"analyze", models + "double_pendulum.toml", "--csv", prefix, "--json", prefix + ".json", "--report", page}, dir);
  ASSERT_EQ(ok.status, 0) << ok.err;
  const std::string html = modal::test::slurp(page);
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(html.find("uPlot"), std::string::npos);
  EXPECT_NE(html.find("id=\"modal-drawing\">{"), std::string::npos);
  EXPECT_TRUE(fs::exists(prefix + "_modes.csv"));
  EXPECT_TRUE(fs::exists(prefix + ".json"));
}

// A report path that cannot be written, or is not an .html name, is refused
// with status 2 before anything is computed or written (no CSV either).
TEST(HtmlReport, BadReportPathIsRefusedBeforeComputing) {
  const fs::path dir = fresh_dir("bad");
  const std::string prefix = (dir / "dp").string();
  for (const std::string& page : {std::string("/nonexistent-dir/r.html"), (dir / "r.txt").string(), (dir / "r").string(),
                                  dir.string() + "/"}) {
    const auto r = modal::test::run_modal(
        {"analyze", models + "double_pendulum.toml", "--csv", prefix, "--report", page}, dir);
    EXPECT_EQ(r.status, 2) << page << ": " << r.err;
    EXPECT_NE(r.err.find(page), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(prefix + "_modes.csv")) << page;
    EXPECT_EQ(r.out, "") << page;  // refused before the analysis printed anything
  }
  const auto txt = modal::test::run_modal(
      {"analyze", models + "double_pendulum.toml", "--report", (dir / "r.txt").string()}, dir);
  EXPECT_NE(txt.err.find("ending in .html"), std::string::npos) << txt.err;
  // Same path as another output of the run.
  const auto twice = modal::test::run_modal(
      {"analyze", models + "double_pendulum.toml", "--json", (dir / "x.html").string(), "--report",
       (dir / "x.html").string()}, dir);
  EXPECT_EQ(twice.status, 2) << twice.err;
  EXPECT_FALSE(fs::exists(dir / "x.html"));
}

}  // namespace
