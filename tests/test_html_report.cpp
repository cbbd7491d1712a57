// HTML reports (`--report`; docs/design.md, "HTML reports"): the drawing's
// displacements against the closed form of a double pendulum, the decimation
// of a large lattice and the page's size; the data of the sweep page against
// the spinning hoop's closed form, the simulation page's decimation keeping
// every series' extremes, the map page's cells; and the command line's
// handling of the report path. The pages in a browser: tests/report_browser.py.
#include "program.hpp"

#include "modal/pipeline.hpp"
#include "modal/report.hpp"

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <filesystem>
#include <numbers>
#include <random>
#include <sstream>
#include <string>

namespace {

namespace fs = std::filesystem;
const std::string models = std::string(MODAL_SOURCE_DIR) + "/models/";

// The results block of a page (#modal-data), parsed.
nlohmann::json page_data(const std::string& page) {
  const std::string open = "id=\"modal-data\">";
  const std::size_t begin = page.find(open);
  EXPECT_NE(begin, std::string::npos);
  const std::size_t start = begin + open.size(), end = page.find("</script>", start);
  std::string text = page.substr(start, end - start);
  for (std::size_t i = 0; (i = text.find("<\\/", i)) != std::string::npos;) text.erase(i + 1, 1);
  return nlohmann::json::parse(text);
}

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("modal_html_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Hinges about y at the hanging equilibrium: a mode (φ1, φ2) moves the first
// mass by −l1 φ1 along x and the second by −(l1 φ1 + l2 (φ1 + φ2)), nothing
// along y or z (to first order). Random masses and lengths (seeded). The
// drawing's displacements are exact (AD of the kinematics): rounding only.
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
      EXPECT_NEAR(d[1].x(), x1 / scale, 1e-13) << "trial " << trial << " mode " << m + 1;
      EXPECT_NEAR(d[3].x(), x2 / scale, 1e-13) << "trial " << trial << " mode " << m + 1;
      for (const modal::Vec3& v : d) {
        EXPECT_NEAR(v.y(), 0, 1e-15);
        EXPECT_NEAR(v.z(), 0, 1e-15);
      }
      EXPECT_TRUE(drawing->displacements_imag[m].empty());  // a real shape
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

// The bead on a hoop spinning at Omega, written in the turning frame: the
// bottom has ω² = g/R − Ω² (closed form, docs/design.md R7) and loses
// stability at Ω = sqrt(g/R). The page's branch, frame rate (|Ω|, here the
// parameter itself: a Campbell diagram) and critical value against that, for
// random R and g (seeded). ω² of a 1-coordinate model is one division of
// exactly formed terms: 1e-12 relative to g/R leaves room for rounding.
TEST(HtmlReport, SweepPageHasTheSpinningHoopsBranchAndCampbellData) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(0.5, 2.0);
  for (int trial = 0; trial < 4; ++trial) {
    const double R = u(rng), g = 9.81 * u(rng);
    const modal::Model model = modal::load_model(models + "bead_on_hoop_frame.toml",
                                                 {"R=" + std::to_string(R), "g=" + std::to_string(g)});
    const double r = model.scene.parameters[1].second, gg = model.scene.parameters[2].second;
    const double top = 2 * std::sqrt(gg / r);
    const modal::SweepStudy study = modal::sweep(model, {modal::parse_vary("Omega=0:" + std::to_string(top) + ":17")});
    const nlohmann::json d = page_data(modal::sweep_html(*study.result, study.scene_file, study.tolerance));
    EXPECT_EQ(d["kind"], "sweep");
    EXPECT_TRUE(d["symmetric"].get<bool>());
    ASSERT_TRUE(d["frame_rate"].is_array()) << "a sweep of the frame's rate draws a Campbell diagram";
    ASSERT_EQ(d["x"].size(), 17u);
    for (std::size_t i = 0; i < 17; ++i) {
      const double omega = d["x"][i].get<double>();
      EXPECT_EQ(d["frame_rate"][i].get<double>(), std::abs(omega));
      if (omega * omega < gg / r) {  // the stable bottom; beyond it the branch may leave for the off-axis equilibria
        EXPECT_NEAR(d["branches"][0]["omega2"][i].get<double>(), gg / r - omega * omega, 1e-12 * gg / r)
            << "trial " << trial << " Omega " << omega;
      }
    }
    ASSERT_EQ(d["critical"].size(), 1u);
    const auto& c = d["critical"][0];
    EXPECT_EQ(c["kind"], "divergence");
    EXPECT_NEAR(c["value"].get<double>(), std::sqrt(gg / r), c["error"].get<double>() + 1e-9 * std::sqrt(gg / r));
    // The tables are the CSV writers' rows.
    EXPECT_EQ(d["table"]["total_rows"].get<std::size_t>(), 17u);
    EXPECT_EQ(d["critical_table"]["rows"].size(), 1u);
  }
}

// A sweep that does not turn the frame has no Campbell diagram; a follower
// load makes the points first order (Re s and Im s plotted instead of ω²).
TEST(HtmlReport, FollowerSweepIsFirstOrderWithoutCampbellDiagram) {
  const modal::Model model = modal::load_model(models + "ziegler.toml");
  const modal::SweepStudy study = modal::sweep(model, {modal::parse_vary("P=0:4:5")});
  const nlohmann::json d = page_data(modal::sweep_html(*study.result, study.scene_file, study.tolerance));
  EXPECT_TRUE(d["frame_rate"].is_null());
  EXPECT_FALSE(d["symmetric"].get<bool>());
  EXPECT_TRUE(d["convergence"].is_null());
}

// Random trajectories (seeded: sizes from 1 to 50000 samples, 1 to 12
// coordinates): the page's series keep each coordinate's and the energy
// error's extremes over the whole run (the buckets keep minimum and maximum),
// start and end at the run's first and last time, draw at most 8
// coordinates and 4000 times, and the samples table has the trajectory CSV's
// first and last rows.
TEST(HtmlReport, SimulationPageKeepsEveryExtremeOfLongRuns) {
  std::mt19937 rng(41);
  std::uniform_int_distribution<int> samples(1, 50000), coordinates(1, 12);
  std::normal_distribution<double> noise;
  for (int trial = 0; trial < 6; ++trial) {
    modal::Trajectory tr;
    const int count = trial == 0 ? 1 : samples(rng), n = coordinates(rng);
    for (int k = 0; k < count; ++k) {
      tr.time.push_back(0.01 * k);
      tr.q.push_back(Eigen::VectorXd::NullaryExpr(n, [&](Eigen::Index) { return noise(rng); }));
      tr.qd.push_back(Eigen::VectorXd::NullaryExpr(n, [&](Eigen::Index) { return noise(rng); }));
      tr.energy.push_back(noise(rng));
      tr.work.push_back(0);
      tr.energy_error.push_back(1e-12 * noise(rng));
    }
    const nlohmann::json d = page_data(modal::simulation_html(tr, {}, "random", "random.toml"));
    const auto& time = d["time"];
    ASSERT_LE(time.size(), 4000u);
    EXPECT_EQ(time.front().get<double>(), tr.time.front());
    EXPECT_EQ(time.back().get<double>(), tr.time.back());
    const std::size_t shown = std::min<std::size_t>(8, static_cast<std::size_t>(n));
    ASSERT_EQ(d["q"].size(), shown);
    for (std::size_t i = 0; i < shown; ++i) {
      double lo = INFINITY, hi = -INFINITY;
      for (const Eigen::VectorXd& q : tr.q) lo = std::min(lo, q[static_cast<Eigen::Index>(i)]), hi = std::max(hi, q[static_cast<Eigen::Index>(i)]);
      std::vector<double> drawn = d["q"][i].get<std::vector<double>>();
      ASSERT_EQ(drawn.size(), time.size());
      EXPECT_EQ(*std::min_element(drawn.begin(), drawn.end()), lo) << "trial " << trial << " coordinate " << i;
      EXPECT_EQ(*std::max_element(drawn.begin(), drawn.end()), hi) << "trial " << trial << " coordinate " << i;
    }
    const std::vector<double> error = d["energy_error"].get<std::vector<double>>();
    EXPECT_EQ(*std::max_element(error.begin(), error.end()), *std::max_element(tr.energy_error.begin(), tr.energy_error.end()));
    EXPECT_EQ(*std::min_element(error.begin(), error.end()), *std::min_element(tr.energy_error.begin(), tr.energy_error.end()));
    std::ostringstream csv;
    modal::write_trajectory_csv(csv, tr);
    std::istringstream lines(csv.str());
    std::vector<std::string> rows;
    for (std::string line; std::getline(lines, line);) rows.push_back(line);
    const auto& table = d["table"]["rows"];
    ASSERT_EQ(table.size(), std::min<std::size_t>(21, static_cast<std::size_t>(count)));
    auto joined = [](const nlohmann::json& row) {
      std::string s;
      for (const auto& f : row) s += (s.empty() ? "" : ",") + f.get<std::string>();
      return s;
    };
    EXPECT_EQ(joined(table.front()), rows[1]);
    EXPECT_EQ(joined(table.back()), rows.back());
  }
}

// A map of random classes and failures (seeded sizes): the page's cells are
// the points' classes in the map's order (x fastest), −1 where a point failed.
TEST(HtmlReport, MapPageCellsAreThePointsClasses) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> size(2, 30), cls(-1, 4);
  const modal::Stability classes[] = {modal::Stability::stable, modal::Stability::asymptotically_stable,
                                      modal::Stability::marginal, modal::Stability::divergence, modal::Stability::flutter};
  for (int trial = 0; trial < 5; ++trial) {
    modal::StabilityMap map;
    map.x = modal::parse_vary("a=0:1:" + std::to_string(size(rng)));
    map.y = modal::parse_vary("b=2:-1:" + std::to_string(size(rng)));
    std::vector<int> expected;
    for (int j = 0; j < map.y.count; ++j)
      for (int i = 0; i < map.x.count; ++i) {
        modal::MapPoint p;
        p.x = map.x.value(i);
        p.y = map.y.value(j);
        const int c = cls(rng);
        p.ok = c >= 0;
        if (p.ok) p.stability = classes[c];
        else p.failure = "no equilibrium";
        map.points.push_back(p);
        expected.push_back(c);
      }
    const nlohmann::json d = page_data(modal::map_html(map, "m.toml"));
    EXPECT_EQ(d["cells"].get<std::vector<int>>(), expected);
    EXPECT_EQ(d["y"]["values"].front().get<double>(), 2.0);
    EXPECT_EQ(d["table"]["total_rows"].get<int>(), map.x.count * map.y.count);
  }
}

// Every command but check writes its page with its other outputs; a bad
// report path is refused (status 2) before anything is computed or written.
TEST(HtmlReport, EveryCommandWritesItsReport) {
  const fs::path dir = fresh_dir("commands");
  const std::string dp = models + "double_pendulum.toml";
  const std::vector<std::vector<std::string>> runs = {
      {"equilibria", dp},
      {"sweep", models + "ziegler.toml", "--vary", "P=0:4:5"},
      {"sweep", models + "ziegler.toml", "--vary", "P=0:4:3", "--vary", "k=1:2:2"},
      {"amplitude", dp, "--amplitudes", "0.1,0.2", "--cycles", "1"},
      {"simulate", dp, "--duration", "1"}};
  int k = 0;
  for (std::vector<std::string> args : runs) {
    const std::string page = (dir / ("r" + std::to_string(++k) + ".html")).string();
    const std::string csv = (dir / ("r" + std::to_string(k) + ".csv")).string();
    args.insert(args.end(), {"--csv", csv, "--report", page});
    const auto ok = modal::test::run_modal(args, dir);
    ASSERT_EQ(ok.status, 0) << args[0] << ": " << ok.err;
    const std::string html = modal::test::slurp(page);
    EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u) << args[0];
    EXPECT_EQ(html.find("src=\"http"), std::string::npos) << args[0];
    EXPECT_TRUE(fs::exists(csv)) << args[0];
    args.back() = (dir / "missing" / "r.html").string();
    fs::remove(csv);
    const auto bad = modal::test::run_modal(args, dir);
    EXPECT_EQ(bad.status, 2) << args[0] << ": " << bad.err;
    EXPECT_NE(bad.err.find(args.back()), std::string::npos) << bad.err;
    EXPECT_FALSE(fs::exists(csv)) << args[0] << ": the CSV was written although the report path is bad";
  }
}


// Complex shapes (first-order problems: a spinning top, Ziegler's column with
// dampers under a follower load, Foucault's pendulum; two of them maps): the
// drawing carries J Re φ and J Im φ,
// checked against central differences of the drawn points' positions (an
// independent computation: step 1e-6 of the shape's largest component,
// truncation ~1e-12, rounding ~1e-10 of the scene's size: 1e-6 is loose), and
// the motion J Re φ cos t − J Im φ sin t peaks at norm 1.
TEST(HtmlReport, ComplexShapesAreDrawnWithTheirPhase) {
  const std::pair<const char*, std::vector<std::string>> scenes[] = {
      {"spinning_top.toml", {}}, {"ziegler_damped.toml", {"P=1.5"}}, {"foucault.toml", {}}};
  for (const auto& [scene, set] : scenes) {
    SCOPED_TRACE(scene);
    const modal::Model model = modal::load_model(models + scene, set);
    modal::AnalysisOptions options;
    options.drawing = true;
    const modal::Analysis a = modal::analyze(model, options);
    const auto& drawing = a.report.equilibria.front().drawing;
    ASSERT_TRUE(drawing.has_value());
    const modal::VectorX& q = a.equilibrium().q;
    modal::Workspace w(model.system);
    auto positions = [&](const modal::VectorX& x) {  // the drawn points, as drawing.cpp lays them out
      if (model.system.is_map()) return modal::map_point_positions(model.system, x);
      std::vector<modal::Vec3> out;
      const std::vector<modal::Pose> poses = modal::body_poses(model.system, w, x);
      for (std::size_t b = 0; b < poses.size(); ++b) {
        out.push_back(poses[b].position);
        if (model.system.bodies()[b].com.norm() > 0)
          out.push_back(poses[b].position + poses[b].rotation * model.system.bodies()[b].com);
      }
      return out;
    };
    int complex = 0;
    for (std::size_t k = 0; k < drawing->modes.size(); ++k) {
      const modal::Mode& mode = a.result().modes[static_cast<std::size_t>(drawing->modes[k] - 1)];
      const modal::VectorX re = mode.shape.real(), im = mode.shape.imag();
      const auto& u = drawing->displacements[k];
      const auto& v = drawing->displacements_imag[k];
      if (v.empty()) continue;
      ++complex;
      ASSERT_EQ(v.size(), u.size());
      const double h = 1e-6 / mode.shape.cwiseAbs().maxCoeff();
      const auto plus_re = positions(q + h * re), minus_re = positions(q - h * re);
      const auto plus_im = positions(q + h * im), minus_im = positions(q - h * im);
      ASSERT_GE(plus_re.size(), u.size());
      // max over t of |a cos t − b sin t|: the square root of the larger
      // eigenvalue of the Gram matrix of a and b (solved by Eigen here).
      auto semi_axis = [](const modal::Vec3& a, const modal::Vec3& b) {
        Eigen::Matrix2d G;
        G << a.dot(a), a.dot(b), a.dot(b), b.dot(b);
        return std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(G).eigenvalues()(1));
      };
      double scale = 0, peak = 0;  // the differenced motion's largest, and the drawing's
      for (std::size_t i = 0; i < u.size(); ++i) {
        scale = std::max(scale, semi_axis((plus_re[i] - minus_re[i]) / (2 * h), (plus_im[i] - minus_im[i]) / (2 * h)));
        peak = std::max(peak, semi_axis(u[i], v[i]));
      }
      ASSERT_GT(scale, 0);
      EXPECT_NEAR(peak, 1.0, 1e-12);
      for (std::size_t i = 0; i < u.size(); ++i) {
        EXPECT_LE((u[i] - (plus_re[i] - minus_re[i]) / (2 * h) / scale).norm(), 1e-6) << "point " << i;
        EXPECT_LE((v[i] - (plus_im[i] - minus_im[i]) / (2 * h) / scale).norm(), 1e-6) << "point " << i;
      }
    }
    EXPECT_GT(complex, 0);
  }
}

}  // namespace
