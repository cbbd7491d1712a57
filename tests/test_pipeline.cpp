// The pipeline API (modal/pipeline.hpp): the same results as the stages it
// strings together, checked against closed forms; errors carry the CLI's exit
// status and message; outputs are checked before computing and written all or
// none; scene files are read safely.
#include "modal/pipeline.hpp"

#include "program.hpp"

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;
using modal::test::slurp;

namespace {

const std::string models = std::string(MODAL_SOURCE_DIR) + "/models/";

class Pipeline : public modal::test::ProgramTest {
 protected:
  Pipeline() : ProgramTest("modal_pipeline_") {}
  void write(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }
};

// Options values set field by field (GCC 12 warns about designated
// initializers that leave members out).
modal::Outputs outputs(const std::string& csv, const std::string& json = "") {
  modal::Outputs o;
  o.csv = csv;
  o.json = json;
  return o;
}
modal::SimulationRequest for_seconds(double duration) {
  modal::SimulationRequest r;
  r.duration = duration;
  return r;
}

// R1: ω² = g/(2 m1 l1 l2)[(m1+m2)(l1+l2) ∓ √((m1+m2)((m1+m2)(l1+l2)² − 4 m1 l1 l2))].
double r1(double m1, double m2, double l1, double l2, double g, int sign) {
  const double s = m1 + m2, l = l1 + l2;
  return g / (2 * m1 * l1 * l2) * (s * l + sign * std::sqrt(s * (s * l * l - 4 * m1 * l1 * l2)));
}

TEST_F(Pipeline, AnalyzeMatchesTheClosedFormWithOverrides) {
  for (const auto& [m2, l2] : {std::pair{1.0, 1.0}, std::pair{3.0, 0.5}, std::pair{0.25, 2.0}}) {
    const modal::Model model = modal::load_model(
        models + "double_pendulum.toml", {"m2=" + std::to_string(m2), "l2=" + std::to_string(l2)});
    const modal::Analysis a = modal::analyze(model);
    ASSERT_TRUE(a.linear.has_value());
    EXPECT_FALSE(a.sparse.has_value());
    ASSERT_EQ(a.result().modes.size(), 2u);
    for (int k = 0; k < 2; ++k) {
      const modal::Mode& m = a.result().modes[static_cast<std::size_t>(k)];
      const double exact = r1(1, m2, 1, l2, 1, k == 0 ? -1 : 1);
      EXPECT_NEAR(m.omega2, exact, 1e-13 * exact);
      EXPECT_LE(std::abs(m.omega2 - exact), std::max(m.error_estimate, 4e-16 * exact));
    }
    EXPECT_EQ(a.result().stability, modal::Stability::stable);
    EXPECT_FALSE(a.unstable());
  }
}

// One constant Model analyzed from several threads at once (docs/design.md
// section 5: every call makes its own workspace, nothing global): each thread
// gets the closed form, a dense and a sparse scene alike.
TEST_F(Pipeline, OneModelIsAnalyzedFromSeveralThreadsAtOnce) {
  const modal::Model pendulum = modal::load_model(models + "double_pendulum.toml");
  const modal::Model net = modal::load_model(models + "net.toml");
  const modal::Analysis net_alone = modal::analyze(net);
  std::vector<modal::Analysis> results(8);
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < results.size(); ++t)
    threads.emplace_back([&, t] { results[t] = modal::analyze(t % 2 == 0 ? pendulum : net); });
  for (std::thread& t : threads) t.join();
  for (std::size_t t = 0; t < results.size(); ++t) {
    const modal::ModalResult& r = results[t].result();
    if (t % 2 == 0) {
      ASSERT_EQ(r.modes.size(), 2u);
      for (int k = 0; k < 2; ++k)
        EXPECT_NEAR(r.modes[static_cast<std::size_t>(k)].omega2, r1(1, 1, 1, 1, 1, k == 0 ? -1 : 1), 1e-14);
    } else {
      const modal::ModalResult& alone = net_alone.result();
      ASSERT_EQ(r.modes.size(), alone.modes.size());
      for (std::size_t k = 0; k < r.modes.size(); ++k)
        EXPECT_NEAR(r.modes[k].omega2, alone.modes[k].omega2,
                    std::max(alone.modes[k].error_estimate, 1e-12 * std::abs(alone.modes[k].omega2)));
    }
  }
}

TEST_F(Pipeline, ModelFromTextEqualsModelFromFile) {
  const std::string text = slurp(models + "double_pendulum.toml");
  const modal::Analysis a = modal::analyze(modal::model_from_text(text, "dp.toml"), [] {
    modal::AnalysisOptions o;
    o.modes = 1;
    return o;
  }());
  ASSERT_EQ(a.result().modes.size(), 1u);
  EXPECT_NEAR(a.result().modes[0].omega2, 2 - std::sqrt(2.0), 1e-14);
  EXPECT_EQ(a.report.scene_file, "dp.toml");
}

TEST_F(Pipeline, AtAnalyzesTheGivenEquilibriumOrRefusesWithExitStatus2) {
  const modal::Model model = modal::load_model(models + "double_pendulum.toml");
  modal::AnalysisOptions o;
  o.at = modal::parse_coordinates(model.system, "--at", "3.141592653589793,0");
  const modal::Analysis a = modal::analyze(model, o);
  EXPECT_EQ(a.result().stability, modal::Stability::divergence);
  EXPECT_EQ(a.result().morse_index, 2);
  EXPECT_TRUE(a.unstable());

  o.at = modal::parse_coordinates(model.system, "--at", "0.5,0");
  try {
    (void)modal::analyze(model, o);
    FAIL() << "a point that is no equilibrium was accepted";
  } catch (const modal::InputError& e) {
    EXPECT_EQ(modal::exit_status(e), modal::ExitStatus::bad_input);
    EXPECT_NE(std::string(e.what()).find("not an equilibrium"), std::string::npos) << e.what();
  }
  EXPECT_THROW(modal::parse_coordinates(model.system, "--at", "1,2,3"), modal::InputError);
  EXPECT_THROW(modal::parse_coordinates(model.system, "--at", "1,nan"), modal::InputError);
}

TEST_F(Pipeline, ErrorsCarryTheCliExitStatusAndMessage) {
  const fs::path bad = dir / "bad.toml";
  write(bad, "title = \"x\"\n[[body]]\nname = \"a\"\njoint = \"hinge\"\naxis = [0, 1, 0]\nmass = -1\n");
  try {
    (void)modal::load_model(bad.string());
    FAIL();
  } catch (const modal::SceneError& e) {
    EXPECT_EQ(modal::exit_status(e), modal::ExitStatus::bad_input);
    EXPECT_EQ(modal::error_message(e).rfind(bad.string() + ":6:", 0), 0u) << modal::error_message(e);
  }
  const modal::NumericalError numerical("no equilibrium");
  EXPECT_EQ(modal::exit_status(numerical), modal::ExitStatus::numerical);
  EXPECT_EQ(modal::error_message(numerical), "modal: numerical failure: no equilibrium");
  const std::bad_alloc oom;
  EXPECT_EQ(modal::exit_status(oom), modal::ExitStatus::numerical);
  EXPECT_NE(modal::error_message(oom).find("out of memory"), std::string::npos);
}

TEST_F(Pipeline, EquilibriaSweepAmplitudeAndSimulateThroughTheApi) {
  const modal::Model dp = modal::load_model(models + "double_pendulum.toml");
  const modal::EquilibriumSurvey survey = modal::equilibria(dp);
  EXPECT_EQ(survey.report.equilibria.size(), 4u);  // R1

  const modal::Model ziegler = modal::load_model(models + "ziegler.toml");
  const modal::SweepStudy study = modal::sweep(ziegler, {modal::parse_vary("P=0:4:9")});
  ASSERT_TRUE(study.result.has_value());
  bool flutter = false;
  for (const modal::CriticalValue& c : study.result->critical)
    if (c.kind == modal::CriticalKind::flutter && std::abs(c.value - (3.5 - std::sqrt(2.0))) <= c.error + 1e-12)
      flutter = true;
  EXPECT_TRUE(flutter) << "Ziegler's flutter load 7/2 − √2 not found";

  modal::AmplitudeRequest request;
  request.options.amplitudes = {0.01, 0.02};
  const modal::AmplitudeStudy amp = modal::amplitude(dp, request);
  ASSERT_EQ(amp.response.points.size(), 2u);
  EXPECT_NEAR(amp.omega2, 2 - std::sqrt(2.0), 1e-14);

  const modal::Simulation sim = modal::simulate(dp, for_seconds(1.0));
  EXPECT_LT(sim.trajectory.max_energy_error, 1e-9);
  EXPECT_THROW(modal::simulate(dp, for_seconds(-1.0)), modal::InputError);
}

TEST_F(Pipeline, OutputsThatCollideOrCannotBeWrittenAreRefusedBeforeComputing) {
  const std::string scene = models + "double_pendulum.toml";
  EXPECT_THROW(modal::check_outputs(modal::Command::analyze, outputs("", scene), scene), modal::ReportError);
  EXPECT_THROW(modal::check_outputs(modal::Command::analyze, outputs((dir / "a").string(), (dir / "a_modes.csv").string()),
                                    scene),
               modal::ReportError);
  EXPECT_THROW(modal::check_outputs(modal::Command::equilibria, outputs((dir / "no/such/dir/x.csv").string()), scene),
               modal::ReportError);
  EXPECT_THROW(modal::check_outputs(modal::Command::equilibria, outputs(dir.string()), scene), modal::ReportError);
  EXPECT_NO_THROW(modal::check_outputs(modal::Command::analyze, outputs((dir / "ok").string()), scene));
  EXPECT_TRUE(fs::is_empty(dir)) << "checking must not leave files behind";
}

TEST_F(Pipeline, FilesAreWrittenAllOrNone) {
  const fs::path a = dir / "a.csv", locked = dir / "locked";
  write(a, "old\n");
  fs::create_directory(locked);
  modal::OutputFiles files;
  files.add(a.string(), "new\n");
  files.add((locked / "b.csv").string(), "new\n");
  fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
  const bool root = geteuid() == 0;  // root writes anywhere: use a missing directory instead
  if (root) {
    modal::OutputFiles other;
    other.add(a.string(), "new\n");
    other.add((dir / "missing" / "b.csv").string(), "new\n");
    EXPECT_THROW(other.commit(), modal::ReportError);
  } else {
    EXPECT_THROW(files.commit(), modal::ReportError);
  }
  fs::permissions(locked, fs::perms::owner_all);
  EXPECT_EQ(slurp(a), "old\n") << "a failed run replaced an earlier result";
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(".modal-"), std::string::npos) << "temporary left behind";

  modal::OutputFiles good;
  good.add(a.string(), "new\n");
  good.add((dir / "c.csv").string(), "c\n");
  EXPECT_EQ(good.commit().size(), 2u);
  EXPECT_EQ(slurp(a), "new\n");
  EXPECT_EQ(slurp(dir / "c.csv"), "c\n");
}

TEST_F(Pipeline, SceneFilesThatAreNotRegularFilesAreRefused) {
  for (const std::string& path : {std::string("/dev/zero"), dir.string()}) {
    try {
      (void)modal::load_model(path);
      FAIL() << path << " was read";
    } catch (const modal::SceneError& e) {
      EXPECT_EQ(modal::exit_status(e), modal::ExitStatus::bad_input);
    }
  }
  const fs::path fifo = dir / "scene.fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_THROW(modal::load_model(fifo.string()), modal::SceneError);  // refused, not blocked on
  const fs::path big = dir / "big.toml";
  {
    std::ofstream out(big, std::ios::binary);
    const std::string line = "# " + std::string(1022, 'x') + "\n";
    for (std::size_t i = 0; i <= modal::max_scene_bytes / line.size(); ++i) out << line;
  }
  try {
    (void)modal::load_model(big.string());
    FAIL();
  } catch (const modal::SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("MiB"), std::string::npos) << e.what();
  }
}

// The CLI end to end on the same guarantees: refusals before computing,
// a failed stdout is an error, option errors read as sentences.
TEST_F(Pipeline, ExportedMatricesAreWrittenAllOrNoneWithTheOtherFiles) {
  // The matrices join the run's commit: when another file of the run cannot
  // be written, the directory keeps the earlier export whole (K.mtx was
  // written in place before the other files were tried).
  const modal::Analysis damped = modal::analyze(modal::load_model(models + "ziegler_damped.toml"));
  const modal::Analysis plain = modal::analyze(modal::load_model(models + "double_pendulum.toml"));
  ASSERT_TRUE(damped.linear && plain.linear);
  const fs::path mx = dir / "all_or_none";
  modal::export_matrices(mx.string(), *damped.linear);
  auto text = [](const fs::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string k_before = text(mx / "K.mtx");
  modal::OutputFiles files;
  modal::add_matrix_exports(files, mx.string(), *plain.linear);
  files.add((dir / "no_such_directory" / "x.json").string(), std::string("{}"));
  EXPECT_THROW(files.commit(), modal::ReportError);
  EXPECT_EQ(text(mx / "K.mtx"), k_before);
  EXPECT_TRUE(fs::exists(mx / "D.mtx"));  // a stale matrix goes only when the commit succeeds
  for (const auto& entry : fs::directory_iterator(mx))
    EXPECT_EQ(entry.path().filename().string().find(".modal-"), std::string::npos) << entry.path();
  // And once it can: the new model's matrices, the stale damping matrix gone.
  modal::OutputFiles again;
  modal::add_matrix_exports(again, mx.string(), *plain.linear);
  again.commit();
  EXPECT_NE(text(mx / "K.mtx"), k_before);
  EXPECT_FALSE(fs::exists(mx / "D.mtx"));

  // A directory the run would create (with a missing parent) is not left
  // behind, empty, by a commit that fails; a successful one makes both.
  const fs::path fresh = dir / "new_parent" / "matrices";
  modal::OutputFiles failing;
  modal::add_matrix_exports(failing, fresh.string(), *plain.linear);
  failing.add((dir / "no_such_directory" / "x.json").string(), std::string("{}"));
  EXPECT_THROW(failing.commit(), modal::ReportError);
  EXPECT_FALSE(fs::exists(dir / "new_parent")) << "a failed run left the directory it made";
  modal::OutputFiles succeeding;
  modal::add_matrix_exports(succeeding, fresh.string(), *plain.linear);
  succeeding.commit();
  EXPECT_EQ(text(fresh / "K.mtx"), text(mx / "K.mtx"));
}

TEST_F(Pipeline, AnInterruptDuringTheCommitLeavesNoDirectoryItMade) {
  // A signal while the commit writes its files (here raised by the writer of
  // the last file, after the matrices' temporaries are written into the
  // directories the commit made): the process ends by that signal, and
  // neither a temporary nor the new directories (nor their new parent) stay.
  // The handler had removed the temporaries only, leaving the directories.
  const modal::Analysis plain = modal::analyze(modal::load_model(models + "double_pendulum.toml"));
  ASSERT_TRUE(plain.linear);
  for (const int signal : {SIGINT, SIGTERM, SIGHUP}) {
    const fs::path parent = dir / ("interrupted_" + std::to_string(signal)), fresh = parent / "deeper" / "matrices";
    auto interrupted_commit = [&] {
      modal::remove_output_temporaries_on_signals();
      modal::OutputFiles files;
      modal::add_matrix_exports(files, fresh.string(), *plain.linear);
      files.add((dir / ("x" + std::to_string(signal) + ".json")).string(), [&](const modal::TextSink& sink) {
        sink("{");
        std::raise(signal);
      });
      files.commit();
    };
    const pid_t child = fork();  // the child has this test's directory (a death test's re-executed one would not)
    if (child == 0) {
      interrupted_commit();
      _exit(0);
    }
    ASSERT_GT(child, 0);
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal) << "status " << status;
    EXPECT_FALSE(fs::exists(parent)) << "an interrupted run left the directory it made";
    for (const auto& entry : fs::directory_iterator(dir))
      EXPECT_EQ(entry.path().filename().string().find(".modal-"), std::string::npos) << entry.path();
    EXPECT_FALSE(fs::exists(dir / ("x" + std::to_string(signal) + ".json")));
  }
}

TEST_F(Pipeline, ASurveyIsNotFailedByAPointBetweenTwoEquilibria) {
  // The family tests evaluate the model between two equilibria; on the
  // spring chain a point there has a spring with coincident ends, whose
  // NumericalError failed the whole survey (exit 4). Now such a pair is two
  // rows, and the survey lists the chain at rest.
  const auto r = run({"equilibria", models + "spring_chain.toml"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("equilibria found"), std::string::npos) << r.out;
}

TEST_F(Pipeline, ComplexShapeColumnsLineUp) {
  // amplitude@phase cells run to 16 characters; the columns were 12 wide
  // and every longer cell pushed the rest of its row out of line.
  const auto r = run({"analyze", models + "arm7.xml"});
  ASSERT_EQ(r.status, 0) << r.err;
  const std::size_t at = r.out.find("Mode shapes (amplitude@phase");
  ASSERT_NE(at, std::string::npos) << r.out;
  std::istringstream table(r.out.substr(r.out.find('\n', at) + 1));
  std::vector<std::string> lines;
  for (std::string line; std::getline(table, line) && !line.empty();) lines.push_back(line);
  ASSERT_EQ(lines.size(), 8u);  // the heading and seven joints
  for (const std::string& line : lines) EXPECT_EQ(line.size(), lines.front().size()) << line;
}

TEST_F(Pipeline, CliRefusesBadPathsAndReportsFailedOutput) {
  const std::string scene = models + "double_pendulum.toml";
  auto r = run({"analyze", scene, "--json", scene});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("overwrite an input"), std::string::npos) << r.err;
  r = run({"analyze", scene, "--csv", (dir / "missing" / "x").string()});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("does not exist"), std::string::npos) << r.err;
  r = run({"analyze", "/dev/zero"});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("not a regular file"), std::string::npos) << r.err;
  // An empty scene name, a --csv prefix that ends in a directory (it wrote
  // DIR/_modes.csv), help that lists status 3 only where --require-stable is.
  r = run({"check", ""});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("'': the scene file's name is empty"), std::string::npos) << r.err;
  r = run({"analyze", scene, "--csv", dir.string() + "/"});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("ends in a directory"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "_modes.csv"));
  EXPECT_NE(run({"analyze", "--help"}).out.find("3 unstable under analyze --require-stable"), std::string::npos);
  for (const char* command : {"equilibria", "sweep", "check", "simulate", "amplitude", "convert"}) {
    const std::string help = run({command, "--help"}).out;
    EXPECT_NE(help.find("Exit status: 0 success, 1 usage, 2 bad scene or input, 4 numerical failure."),
              std::string::npos)
        << command << ": " << help;
  }
  r = run({"analyze", scene, "--timing"});
  EXPECT_NE(r.err.find("timing: peak memory"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\t'), std::string::npos) << r.err;
  // CLI11's texts that were not sentences, and a user's text quoted whole.
  r = run({"analyze", scene, "--modes", "2", "--modes", "3"});
  EXPECT_EQ(r.err.rfind("modal analyze: --modes: given 2 times; give it once", 0), 0u) << r.err;
  r = run({"analyze", scene, "--modes"});
  EXPECT_EQ(r.err.rfind("modal analyze: --modes: needs a value (INT)", 0), 0u) << r.err;
  r = run({"analyze", scene, "--foo", "bar", "baz"});
  EXPECT_EQ(r.err.rfind("modal analyze: not an option or argument of this command: --foo bar baz", 0), 0u) << r.err;
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"analyze", scene, "--modes", std::string(100000, '9')},
        std::vector<std::string>{"check", scene, "--set", "m1=" + std::string(100000, '1')}}) {
    r = run(args);
    EXPECT_NE(r.status, 0);
    EXPECT_LT(r.err.size(), 2000u) << r.err.substr(0, 300);
  }
  // A difference step below ε vanishes against q = π (q + h = q): refused as
  // input, not a 0/0 blamed on the model.
  r = run({"analyze", scene, "--at", "3.141592653589793,3.141592653589793", "--derivatives", "central", "--step",
           "1e-17"});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("vanishes against a coordinate"), std::string::npos) << r.err;
  r = run({"analyze", scene, "--modes", "0"});
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("must be a whole number ≥ 1, got '0'"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("1.79769"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.rfind("modal analyze: --modes: ", 0), 0u) << r.err;  // a sentence naming the command first
  const std::string huge(60, '9');  // beyond every integer type: CLI11's conversion message, rewritten
  r = run({"analyze", scene, "--modes", huge});
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err.rfind("modal analyze: --modes: '", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("is not a value it takes"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("Could not convert"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find(huge), std::string::npos) << r.err;  // cut to 40 characters

  // A usage error is short: the sentence, the named option's own help line,
  // the usage line and where the whole help is; not the 40-line help.
  auto lines = [](const std::string& text) { return std::count(text.begin(), text.end(), '\n'); };
  r = run({"analyze", scene, "--modes", "0"});
  EXPECT_LE(lines(r.err), 6) << r.err;
  EXPECT_NE(r.err.find("number of lowest modes to report"), std::string::npos) << r.err;  // --modes' own line
  EXPECT_EQ(r.err.find("--eq-tol"), std::string::npos) << r.err;                        // no other option's
  EXPECT_NE(r.err.find("Usage: modal analyze"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("'modal analyze --help'"), std::string::npos) << r.err;
  r = run({"analyze", scene, "--mdoes", "3"});  // misspelt: the names it may be
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("did you mean --modes?"), std::string::npos) << r.err;
  EXPECT_LE(lines(r.err), 6) << r.err;
  r = run({"analyze", scene, "--solver", "fast"});
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err.rfind("modal analyze: --solver: 'fast' is not one of auto, dense, sparse, tree", 0), 0u) << r.err;
  r = run({"analyse", scene});  // a misspelt command
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err.rfind("modal: 'analyse' is not a command of modal; did you mean analyze?", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("equilibria"), std::string::npos) << r.err;  // the commands are listed

  if (fs::exists("/dev/full")) {
    const std::string cmd = modal::test::quote(MODAL_BINARY) + " analyze " + modal::test::quote(scene) +
                            " > /dev/full 2> " + modal::test::quote((dir / "err.txt").string());
    const int raw = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(raw));
    EXPECT_EQ(WEXITSTATUS(raw), 2);
    EXPECT_NE(slurp(dir / "err.txt").find("standard output: writing failed"), std::string::npos);
  }
}

// A network's data files are inputs too: no output may replace them (an
// analyze --json and an equilibria --csv over the scene's CSV destroyed the
// scene and exited 0). --export-matrices names a directory: refused up front
// when it is a file or another output's path, and it holds only the matrices
// of the model analyzed (a damped scene's D.mtx was left beside an undamped
// one's M and K). A closed pipe is a failed write, exit status 2, not a
// death by SIGPIPE.
TEST_F(Pipeline, CliProtectsDataFilesAndExportDirectories) {
  const fs::path data = dir / "data";
  fs::create_directories(data);
  for (const char* f : {"tower_nodes.csv", "tower_edges.csv"}) fs::copy_file(models + "data/" + f, data / f);
  fs::copy_file(models + "network.toml", dir / "network.toml");
  const std::string nodes = (data / "tower_nodes.csv").string(), original = slurp(data / "tower_nodes.csv");
  const std::string network = (dir / "network.toml").string();
  auto r = run({"analyze", network, "--json", nodes});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("overwrite an input"), std::string::npos) << r.err;
  r = run({"equilibria", network, "--csv", (data / "tower_edges.csv").string()});
  EXPECT_EQ(r.status, 2) << r.err;
  r = run({"analyze", network, "--json", (dir / "." / "data" / ".." / "data" / "tower_nodes.csv").string()});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_EQ(slurp(data / "tower_nodes.csv"), original);
  EXPECT_TRUE(run({"check", network}).status == 0);

  const std::string pendulum = models + "double_pendulum.toml";
  const fs::path prefix = dir / "c";
  r = run({"analyze", pendulum, "--csv", prefix.string(), "--export-matrices", prefix.string() + "_modes.csv"});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_FALSE(fs::exists(prefix.string() + "_modes.csv")) << "nothing is written for a refused run";
  write(dir / "afile", "x\n");
  r = run({"analyze", pendulum, "--export-matrices", (dir / "afile").string()});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("this path is a file"), std::string::npos) << r.err;
  r = run({"analyze", pendulum, "--json", (dir / "mx" / "K.mtx").string(), "--export-matrices", (dir / "mx").string()});
  EXPECT_EQ(r.status, 2) << r.err;
  const fs::path mx = dir / "mx";
  ASSERT_EQ(run({"analyze", models + "ziegler_damped.toml", "--export-matrices", mx.string()}).status, 0);
  EXPECT_TRUE(fs::exists(mx / "D.mtx"));
  ASSERT_EQ(run({"analyze", pendulum, "--export-matrices", mx.string()}).status, 0);
  EXPECT_TRUE(fs::exists(mx / "K.mtx"));
  EXPECT_FALSE(fs::exists(mx / "D.mtx")) << "a damping matrix the undamped model does not have";

  // More output than a pipe holds, into a pipe closed after one line.
  const std::string cmd = modal::test::quote(MODAL_BINARY) + " simulate " + modal::test::quote(pendulum) +
                          " --duration 2 --interval 0.0001 --at 1,1 2> " + modal::test::quote((dir / "pipe.txt").string()) +
                          " | head -1 > /dev/null; exit ${PIPESTATUS[0]}";
  const int raw = std::system(("bash -c " + modal::test::quote(cmd)).c_str());
  ASSERT_TRUE(WIFEXITED(raw));
  EXPECT_EQ(WEXITSTATUS(raw), 2) << slurp(dir / "pipe.txt");
  EXPECT_NE(slurp(dir / "pipe.txt").find("writing failed"), std::string::npos);
}

// --modes k on the dense path analyzes only the lowest k modes and those whose
// kind a cheap estimate leaves in doubt (lib/modal/symmetric.cpp): the k
// returned, the stability class, the Morse index and the zero modes must be
// those of the full analysis. Generated: hanging and inverted chains (every
// mode divergent) of random length, point or rod links, on both dense solvers
// (Eigen below 150 coordinates, LAPACK above); free lattices (six zero
// modes) of random size; k random, from 1 to beyond the zero modes.
// Above 150 coordinates the two runs use different LAPACK drivers (every
// pair by divide and conquer; with k, every eigenvalue by dsterf and the
// lowest vectors by MRRR), so there each λ must agree within the two error
// estimates and each shape within its residual over the gap; below, the same
// vectors and formulas give rounding-level differences.
TEST_F(Pipeline, LowestModesEqualThoseOfTheFullAnalysis) {
  std::mt19937_64 rng(20261125);
  auto pick = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  int cases = 0, divergent = 0, zero = 0;
  for (int trial = 0; trial < 16; ++trial) {
    std::string text;
    if (trial % 4 == 3) {
      const int a = pick(3, 5), b = pick(3, 5), c = pick(3, 6);
      text = "gravity = [0, 0, 0]\n[[lattice]]\nname = \"b\"\nsize = [" + std::to_string(a) + ", " + std::to_string(b) +
             ", " + std::to_string(c) + "]\nspacing = 0.1\nmass = 0.01\nstiffness = 1000.0\ndiagonals = true\n";
    } else {
      const int links = trial % 2 == 0 ? pick(20, 140) : pick(150, 320);
      const bool inverted = trial % 4 == 2;
      text = std::string("gravity = [0, 0, ") + (inverted ? "9.81" : "-9.81") + "]\n[[chain]]\nname = \"l\"\nlinks = " +
             std::to_string(links) + "\nlength = 1.0\nmass = 1.0\nmass_model = \"" + (pick(0, 1) ? "point" : "rod") +
             "\"\naxis = [0, 1, 0]\ndirection = [0, 0, -1]\n";
    }
    const modal::Model model = modal::model_from_text(text, "generated.toml");
    modal::AnalysisOptions all;
    all.solver = modal::SolverChoice::dense;
    const modal::Analysis full = modal::analyze(model, all);
    modal::AnalysisOptions some = all;
    some.modes = pick(1, 12);
    const modal::Analysis low = modal::analyze(model, some);
    SCOPED_TRACE(text + "modes " + std::to_string(some.modes));
    const modal::ModalResult &f = full.result(), &l = low.result();
    EXPECT_EQ(l.stability, f.stability);
    EXPECT_EQ(l.morse_index, f.morse_index);
    EXPECT_EQ(l.zero_modes, f.zero_modes);
    ASSERT_EQ(l.modes.size(), static_cast<std::size_t>(some.modes));
    double largest = 0;
    for (const modal::Mode& m : f.modes) largest = std::max(largest, std::abs(m.omega2));
    const bool same_driver = l.solver == f.solver;
    if (model.system.size() >= 150) {
      EXPECT_FALSE(same_driver) << l.solver;
      // (MRRR on the tridiagonal form, or a hanging point-mass chain's
      // bidiagonal by dbdsvdx)
      EXPECT_NE(l.solver.find("the lowest modes' vectors"), std::string::npos) << l.solver;
    }
    for (std::size_t j = 0; j < l.modes.size(); ++j) {
      const modal::Mode &a = l.modes[j], &b = f.modes[j];
      EXPECT_EQ(a.kind, b.kind) << "mode " << j + 1;
      if (same_driver) {
        // The same vectors and the same formulas, products over fewer
        // columns: rounding-level differences only (zero modes: their λ is
        // rounding).
        EXPECT_LE(std::abs(a.omega2 - b.omega2), 1e-12 * std::abs(b.omega2) + 64 * 2.2e-16 * largest)
            << "mode " << j + 1;
      } else {
        EXPECT_LE(std::abs(a.omega2 - b.omega2), a.error_estimate + b.error_estimate) << "mode " << j + 1;
      }
      // Zero modes are one eigenspace whose basis (and order, by λ at
      // rounding level) depends on the last bits of the products: compared
      // as a kind only.
      if (b.kind != modal::ModeKind::zero && same_driver) {
        EXPECT_LE(std::abs(a.error_estimate - b.error_estimate), 0.01 * b.error_estimate) << "mode " << j + 1;
      }
      if (b.kind != modal::ModeKind::zero && j + 1 < f.modes.size() &&
          std::abs(f.modes[j + 1].omega2 - b.omega2) > 1e-6 * largest) {  // a unique shape
        ASSERT_EQ(a.shape.size(), b.shape.size());
        // Two drivers: each shape is within (residual / gap) of the true one
        // (Davis–Kahan); the gap here is at least 1e-6 of the largest λ and
        // the residual bounds at rounding level, so 1e-6 leaves a margin.
        EXPECT_LE((a.shape - b.shape).norm(), (same_driver ? 1e-8 : 1e-6) * b.shape.norm()) << "mode " << j + 1;
      }
    }
    ++cases;
    divergent += f.morse_index > 0;
    zero += f.zero_modes > 0;
  }
  EXPECT_EQ(cases, 16);
  EXPECT_GT(divergent, 0);  // both kinds of doubt occurred
  EXPECT_GT(zero, 0);
}

// Inverted chains (every eigenvalue negative, all below −ζ) on the sparse
// path, whose runs from a shift below the spectrum are checked for
// completeness: where K − bM cannot be factored there (it could not on an
// inverted chain of 400 links, length 0.1, in joint angles, whose run had
// succeeded) the analysis still answers, with a note that the check was not
// made, instead of exit 4 ("K − σM cannot be factored near the completeness
// check σ"). Generated lengths of 160–560 links; reference: the dense path
// (every eigenvalue), each mode within both estimates, the same Morse index.
TEST_F(Pipeline, InvertedChainsOnTheSparsePathAnswerAsTheDensePathDoes) {
  std::mt19937_64 rng(20261129);
  int unchecked = 0;
  for (int trial = 0; trial < 4; ++trial) {
    const int links = std::uniform_int_distribution<int>(160, 560)(rng);
    const std::string text = "gravity = [0, 0, -9.81]\n[[chain]]\nname = \"c\"\nlinks = " + std::to_string(links) +
                             "\nlength = 0.1\nmass = 0.1\ndirection = [0, 0, 1]\n";
    SCOPED_TRACE(text);
    const modal::Model model = modal::model_from_text(text, "inverted.toml");
    modal::AnalysisOptions dense, sparse;
    dense.solver = modal::SolverChoice::dense;
    sparse.solver = modal::SolverChoice::sparse;
    dense.modes = sparse.modes = 10;
    const modal::ModalResult d = modal::analyze(model, dense).result();
    modal::ModalResult s;
    ASSERT_NO_THROW(s = modal::analyze(model, sparse).result());
    EXPECT_EQ(s.stability, modal::Stability::divergence);
    EXPECT_EQ(s.morse_index, links);
    EXPECT_EQ(d.morse_index, links);
    ASSERT_EQ(s.modes.size(), d.modes.size());
    for (std::size_t j = 0; j < s.modes.size(); ++j)
      EXPECT_LE(std::abs(s.modes[j].omega2 - d.modes[j].omega2), s.modes[j].error_estimate + d.modes[j].error_estimate)
          << "mode " << j + 1;
    for (const std::string& note : s.notes) unchecked += note.find("completeness not checked: K − σM could not") == 0;
  }
  std::printf("inverted chains: %d of 4 with the completeness check not made\n", unchecked);
}


// The equilibrium of a large scene reports its progress (the CLI's bar): done
// of 100, never decreasing, 100 at convergence; slack and pre-tensioned nets
// of random size (above large_system_coordinates: Newton with the sparse
// Hessian), and nothing on a small scene (the dense path is quick).
TEST_F(Pipeline, LargeEquilibriaReportTheirProgress) {
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 4; ++trial) {
    const int size = std::uniform_int_distribution<int>(22, 40)(rng);
    const std::string text = "gravity = [0, 0, -9.81]\n[[lattice]]\nname = \"net\"\nsize = [" + std::to_string(size) +
                             ", " + std::to_string(size) + ", 1]\nspacing = 0.1\nmass = 0.002\nstiffness = 1000\n"
                             "prestrain = " + (trial % 2 ? "0.02" : "0") + "\nfixed = \"boundary\"\n";
    SCOPED_TRACE(text);
    const modal::Model model = modal::model_from_text(text, "net.toml");
    ASSERT_GT(model.system.size(), modal::large_system_coordinates);
    std::vector<std::pair<int, int>> calls;
    modal::AnalysisOptions options;
    options.modes = 2;
    options.progress = [&calls](int done, int total) { calls.emplace_back(done, total); };
    (void)modal::analyze(model, options);
    ASSERT_FALSE(calls.empty());
    for (std::size_t i = 0; i < calls.size(); ++i) {
      EXPECT_EQ(calls[i].second, 100);
      if (i > 0) {
        EXPECT_GT(calls[i].first, calls[i - 1].first);
      }
    }
    EXPECT_EQ(calls.back().first, 100);
  }
  int small_calls = 0;
  modal::AnalysisOptions options;
  options.progress = [&small_calls](int, int) { ++small_calls; };
  (void)modal::analyze(modal::load_model(models + "double_pendulum.toml"), options);
  EXPECT_EQ(small_calls, 0);
}

}  // namespace
