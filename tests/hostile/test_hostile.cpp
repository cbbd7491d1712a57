// Hostile input, generated: every case is a class (deep nesting of each kind,
#include <cmath>
// at many depths, in a scene file and on the command line), and every outcome
// is a clear refusal or an answer — never a crash. docs/design.md section 9
// lists the guarantees these tests hold the program to.
#include "modal/expression.hpp"
#include "modal/pipeline.hpp"
#include "modal/scene.hpp"

#include "program.hpp"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <string>
#include <vector>

namespace {

using modal::test::Outcome;

class Hostile : public modal::test::ProgramTest {
 protected:
  Hostile() : ProgramTest("modal_hostile_") {}
  std::string write(const std::string& name, const std::string& text) const {
    const std::string path = (dir / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
};

// An expression nested `depth` levels deep in one of four ways.
std::string nested(const std::string& kind, int depth) {
  std::string s;
  if (kind == "parentheses") return std::string(static_cast<std::size_t>(depth), '(') + "1" +
                                    std::string(static_cast<std::size_t>(depth), ')');
  if (kind == "signs") {
    for (int i = 0; i < depth; ++i) s += "-";
    return s + "1";
  }
  if (kind == "powers") {
    for (int i = 0; i < depth; ++i) s += "1^";
    return s + "1";
  }
  for (int i = 0; i < depth; ++i) s += "sin(";  // calls
  return s + "1" + std::string(static_cast<std::size_t>(depth), ')');
}

const std::vector<std::string> kinds{"parentheses", "signs", "powers", "calls"};
const std::vector<int> depths{1, 50, modal::max_expression_depth - 1, modal::max_expression_depth + 1, 1000, 14000,
                              100000};

TEST(hostile_expressions, NestingIsBoundedNotAStackOverflow) {
  for (const std::string& kind : kinds)
    for (int depth : depths) {
      const std::string text = nested(kind, depth);
      // Each kind adds one level per repetition, plus the outermost operand.
      const bool fits = depth + 1 <= modal::max_expression_depth;
      try {
        const double v = modal::Expression::parse(text, {}).evaluate(std::vector<double>{});
        EXPECT_TRUE(fits) << kind << " " << depth << " was accepted";
        EXPECT_TRUE(std::isfinite(v));
      } catch (const modal::ExpressionError& e) {
        EXPECT_FALSE(fits) << kind << " " << depth << ": " << e.what();
        EXPECT_NE(std::string(e.what()).find("nested more than"), std::string::npos) << e.what();
      }
    }
}

TEST_F(Hostile, DeepExpressionsInASceneAndOnTheCommandLineAreRefusedWithTheirPlace) {
  const std::string head = "title = \"deep\"\n[parameters]\ng = 1\n";
  for (const std::string& kind : kinds)
    for (int depth : {modal::max_expression_depth + 1, 14000}) {
      const std::string expression = nested(kind, depth);
      const std::string scene = write("deep.toml", head + "m = \"" + expression +
                                                       "\"\n[[body]]\nname = \"p\"\njoint = \"hinge\"\n"
                                                       "axis = [0, 1, 0]\nmass = 1\ncom = [0, 0, -1]\n");
      Outcome r = run({"analyze", scene});
      EXPECT_EQ(r.status, 2) << kind << " " << depth << ": " << r.err;
      EXPECT_NE(r.err.find("deep.toml:4:"), std::string::npos) << r.err.substr(0, 300);
      EXPECT_NE(r.err.find("parameters.m"), std::string::npos) << r.err.substr(0, 300);
      EXPECT_NE(r.err.find("nested more than"), std::string::npos) << r.err.substr(0, 300);
      EXPECT_TRUE(r.out.empty());

      const std::string plain = write("plain.toml", head + "m = 1\n[[body]]\nname = \"p\"\njoint = \"hinge\"\n"
                                                           "axis = [0, 1, 0]\nmass = \"m\"\ncom = [0, 0, -1]\n");
      r = run({"analyze", plain, "--set", "m=" + expression});
      EXPECT_EQ(r.status, 2) << kind << " " << depth << ": " << r.err.substr(0, 300);
      EXPECT_NE(r.err.find("--set"), std::string::npos) << r.err.substr(0, 300);
      EXPECT_NE(r.err.find("nested more than"), std::string::npos) << r.err.substr(0, 300);
    }
}

}  // namespace

namespace {

// --- interrupted runs -------------------------------------------------------------

// Runs `modal args…` (stdout and stderr to /dev/null) and sends it `signal`
// after `delay_us`; its exit status as a shell reports it (128 + signal when
// the signal ended it).
int run_interrupted(const std::vector<std::string>& args, int signal, useconds_t delay_us) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int null = open("/dev/null", O_WRONLY);
    dup2(null, 1);
    dup2(null, 2);
    std::vector<char*> argv{const_cast<char*>(MODAL_BINARY)};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(MODAL_BINARY, argv.data());
    _exit(127);
  }
  usleep(delay_us);
  kill(pid, signal);
  int raw = 0;
  waitpid(pid, &raw, 0);
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
}

// Interrupts at random moments, from before the scene is read to after the
// files are written: every time, the outputs are either all the previous ones
// or all complete new ones, never a mix, never a partial file, and no
// temporary is left in the directory; an interrupted run ends with 128 +
// the signal.
TEST_F(Hostile, InterruptsLeaveOldOrNewOutputsNeverAMixOrTemporaries) {
  const std::string scene = (dir / "chain.toml").string();
  std::filesystem::copy_file(std::string(MODAL_SOURCE_DIR) + "/models/hanging_chain.toml", scene);
  const std::string prefix = (dir / "out").string(), json = (dir / "out.json").string();
  const std::vector<std::string> files{prefix + "_modes.csv", prefix + "_shapes.csv", prefix + "_equilibria.csv", json};
  const std::vector<std::string> args{"analyze", scene, "--set", "N=150", "--csv", prefix, "--json", json};
  ASSERT_EQ(run(args).status, 0);
  std::vector<std::string> complete;
  for (const std::string& f : files) complete.push_back(modal::test::slurp(f));

  std::mt19937 random(20261125);
  std::uniform_int_distribution<useconds_t> delay(0, 60000);
  int interrupted = 0, finished = 0;
  for (int trial = 0; trial < 40; ++trial) {
    for (const std::string& f : files) std::ofstream(f) << "previous " << f << "\n";
    const int signal = trial % 3 == 0 ? SIGTERM : trial % 3 == 1 ? SIGINT : SIGHUP;
    const int status = run_interrupted(args, signal, delay(random));
    int fresh = 0;
    for (std::size_t i = 0; i < files.size(); ++i) {
      const std::string content = modal::test::slurp(files[i]);
      if (content == complete[i]) ++fresh;
      else EXPECT_EQ(content, "previous " + files[i] + "\n") << "trial " << trial << ": a partial file";
    }
    if (status == 0) {
      ++finished;
      EXPECT_EQ(fresh, 4) << "trial " << trial;
    } else {
      ++interrupted;
      EXPECT_EQ(status, 128 + signal) << "trial " << trial;
      EXPECT_TRUE(fresh == 0 || fresh == 4) << "trial " << trial << ": " << fresh << " of 4 files new";
    }
    for (const auto& entry : std::filesystem::directory_iterator(dir))
      EXPECT_EQ(entry.path().filename().string().find(".modal-"), std::string::npos)
          << "trial " << trial << ": temporary left: " << entry.path();
  }
  EXPECT_GT(interrupted, 5);
  std::cout << interrupted << " runs interrupted, " << finished << " finished\n";
}

}  // namespace

namespace {

// --- text from someone else's scene ------------------------------------------------

// Whether `text` holds a byte a terminal may act on: C0 controls other than
// the line break, DEL, or a C1 control (U+0080–U+009F, UTF-8 C2 80–C2 9F).
bool has_control(const std::string& text) {
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if ((c < 0x20 && c != '\n') || c == 0x7F) return true;
    if (c == 0xC2 && i + 1 < text.size() && static_cast<unsigned char>(text[i + 1]) >= 0x80 &&
        static_cast<unsigned char>(text[i + 1]) <= 0x9F)
      return true;
  }
  return false;
}

// Control characters written as TOML escapes (which the TOML reader decodes)
// in every kind of text a scene has: never on the terminal, always refused
// with the place and the character shown escaped.
TEST_F(Hostile, ControlCharactersNeverReachTheTerminal) {
  const std::vector<std::string> controls{"\\u0001", "\\u0007", "\\b", "\\r", "\\u001b[2J", "\\u007f", "\\u0085",
                                          "\\u009b31m", "\\t"};
  const std::vector<std::string> places{"title", "body name", "parent", "spring end", "parameter name", "expression",
                                        "quoted key"};
  int refused = 0;
  for (const std::string& c : controls)
    for (const std::string& place : places) {
      const std::string title = place == "title" ? "t" + c + "x" : "t";
      const std::string name = place == "body name" ? "p" + c : "p";
      const std::string parent = place == "parent" ? "world" + c : "world";
      const std::string end = place == "spring end" ? "p" + c : "p";
      const std::string parameter = place == "parameter name" ? "\"m" + c + "\"" : "m";
      const std::string mass = place == "expression" ? "\"1 + " + c + "\"" : "1";
      const std::string extra = place == "quoted key" ? "\"k" + c + "\" = 1\n" : "";
      const std::string scene = write("s.toml", "title = \"" + title + "\"\n" + extra + "[parameters]\n" + parameter +
                                                    " = 1\n[[body]]\nname = \"" + name + "\"\nparent = \"" + parent +
                                                    "\"\njoint = \"hinge\"\nmass = " + mass +
                                                    "\ncom = [0, 0, -1]\n[[spring]]\na = \"" + end +
                                                    "\"\nb = \"world\"\nstiffness = 1\n");
      for (const char* command : {"analyze", "check"}) {
        const Outcome r = run({command, scene});
        EXPECT_FALSE(has_control(r.out)) << place << " " << c << ": stdout has a control character";
        EXPECT_FALSE(has_control(r.err)) << place << " " << c << ": stderr has a control character: " << r.err;
        EXPECT_EQ(r.status, 2) << place << " " << c << ": " << r.err;
        EXPECT_NE(r.err.find("s.toml:"), std::string::npos) << r.err;
        refused += r.status == 2;
      }
    }
  EXPECT_EQ(refused, static_cast<int>(2 * controls.size() * places.size()));
}

// A network's node names come from a CSV file, raw bytes and all.
TEST_F(Hostile, ControlCharactersInDataFilesAreRefused) {
  for (const std::string& c : {std::string("\x1b[31m"), std::string("\x07"), std::string("\xc2\x9b"), std::string("\xff")}) {
    std::ofstream(dir / "nodes.csv") << "name,x,y,z,mass,fixed\na" << c << ",0,0,0,1,1\nb,1,0,0,1,0\n";
    std::ofstream(dir / "edges.csv") << "a,b,stiffness\na" << c << ",b,1\n";
    const std::string scene = write("net.toml", "[[network]]\nname = \"n\"\nnodes = \"nodes.csv\"\n"
                                                "edges = \"edges.csv\"\n");
    const Outcome r = run({"analyze", scene});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_FALSE(has_control(r.err)) << r.err;
    EXPECT_NE(r.err.find("nodes.csv:2:"), std::string::npos) << r.err;
  }
}

// --- data files from elsewhere ---------------------------------------------------------

TEST_F(Hostile, DataFilesOutsideTheSceneDirectoryAreRefusedAndNeverEchoed) {
  const auto scenes = dir / "scenes", elsewhere = dir / "elsewhere";
  std::filesystem::create_directories(scenes / "data");
  std::filesystem::create_directories(elsewhere);
  // A file that is not a data file, with a recognizable first line.
  const std::string secret = "root:x:0:0:SECRET:/root:/bin/bash";
  std::ofstream(elsewhere / "passwd") << secret << "\nmore:x:1:1\n";
  std::ofstream(elsewhere / "nodes.csv") << "name,x,y,z,mass,fixed\na,0,0,0,1,1\nb,1,0,0,1,0\n";
  std::ofstream(scenes / "data" / "edges.csv") << "a,b,stiffness\na,b,1\n";
  std::filesystem::create_symlink(elsewhere / "nodes.csv", scenes / "data" / "link.csv");
  std::filesystem::create_symlink(elsewhere, scenes / "data" / "dirlink");
  const std::vector<std::string> outside{"../elsewhere/nodes.csv", (elsewhere / "nodes.csv").string(),
                                         "data/link.csv", "data/dirlink/nodes.csv", "data/../../elsewhere/nodes.csv",
                                         "../elsewhere/passwd", (elsewhere / "passwd").string(), "/etc/passwd"};
  for (const std::string& path : outside) {
    const std::string scene = (scenes / "net.toml").string();
    std::ofstream(scene) << "[[network]]\nname = \"n\"\nnodes = \"" << path << "\"\nedges = \"data/edges.csv\"\n";
    Outcome r = run({"analyze", scene});
    EXPECT_EQ(r.status, 2) << path << ": " << r.err;
    EXPECT_NE(r.err.find("outside the scene file's directory"), std::string::npos) << path << ": " << r.err;
    EXPECT_NE(r.err.find("net.toml:3:"), std::string::npos) << r.err;
    // Allowed explicitly: a data file is read; any other file is refused without a word of its content.
    r = run({"analyze", scene, "--allow-outside-data"});
    if (path.find("passwd") == std::string::npos) {
      EXPECT_EQ(r.status, 0) << path << ": " << r.err;
    } else {
      EXPECT_EQ(r.status, 2) << path << ": " << r.err;
      EXPECT_NE(r.err.find("is not the header of a nodes file"), std::string::npos) << r.err;
      EXPECT_EQ(r.err.find("root"), std::string::npos) << "content echoed: " << r.err;
      EXPECT_EQ(r.err.find("SECRET"), std::string::npos) << "content echoed: " << r.err;
    }
  }
  // Inside, through a symbolic link that stays inside: read.
  std::ofstream(scenes / "data" / "nodes.csv") << "name,x,y,z,mass,fixed\na,0,0,0,1,1\nb,1,0,0,1,0\n";
  std::filesystem::create_symlink("nodes.csv", scenes / "data" / "inside.csv");
  std::ofstream(scenes / "net.toml") << "[[network]]\nname = \"n\"\nnodes = \"data/inside.csv\"\nedges = \"data/edges.csv\"\n";
  const Outcome r = run({"analyze", (scenes / "net.toml").string()});
  EXPECT_EQ(r.status, 0) << r.err;
}

}  // namespace

namespace {

// --- requests beyond the documented limits ---------------------------------------------

// Refused at once with the limit in words, never run out of memory (a sweep
// of 2·10⁹ points was killed by the kernel after exhausting memory).
TEST_F(Hostile, SweepsBeyondTheLimitAreRefusedWithTheLimit) {
  const std::string scene = std::string(MODAL_SOURCE_DIR) + "/models/ziegler.toml";
  const std::string limit = std::to_string(modal::max_sweep_points);
  for (const std::string& count : {std::to_string(modal::max_sweep_points + 1), std::string("2000000000"),
                                   std::string("1000000000000"), std::string("100000000000000000000000000000")}) {
    const Outcome r = run({"sweep", scene, "--vary", "P=0:4:" + count});
    EXPECT_EQ(r.status, 2) << count << ": " << r.err;
    EXPECT_NE(r.err.find("at most " + limit), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty());
  }
  const Outcome map = run({"sweep", scene, "--vary", "P=0:4:1001", "--vary", "k=0:1:1000"});
  EXPECT_EQ(map.status, 2) << map.err;
  EXPECT_NE(map.err.find("1001000 points"), std::string::npos) << map.err;
  EXPECT_NE(map.err.find("at most " + limit), std::string::npos) << map.err;
  // At the limit's scale but within it the request is taken (checked on the parser, not run).
  EXPECT_EQ(modal::parse_vary("P=0:4:" + limit).count, modal::max_sweep_points);
}


// Silently wrong numbers (issue 20, part 2), from the command line: huge
// frequencies are answered, not classed zero, and --require-stable holds;
// steps beyond the largest factor are refused in words; a free lattice's six
// rigid-body modes are counted whatever --modes asks for, on both solvers.
TEST_F(Hostile, HugeFrequenciesLargeStepsAndUnrequestedZeroModes) {
  const std::string pendulum = std::string(MODAL_SOURCE_DIR) + "/models/double_pendulum.toml";
  for (const char* g : {"1e155", "1e160", "1e250", "1e300"}) {
    const Outcome r = run({"analyze", pendulum, "--set", std::string("g=") + g, "--require-stable"});
    EXPECT_EQ(r.status, 0) << g << ": " << r.err;
    EXPECT_NE(r.out.find("Stability: stable"), std::string::npos) << g << ": " << r.out;
    EXPECT_EQ(r.out.find("zero"), std::string::npos) << g << ": " << r.out;
  }
  for (const char* step : {"0.11", "1", "3.14159", "6.2831853", "1e300", "inf", "nan", "-0.01", "0"}) {
    const Outcome r = run({"analyze", pendulum, "--derivatives", "central", "--step", step});
    EXPECT_EQ(r.status, 1) << step << ": " << r.err;  // a usage error (CLI11 validation)
    EXPECT_NE(r.err.find("at most 0.1"), std::string::npos) << step << ": " << r.err;
    EXPECT_TRUE(r.out.empty()) << step;
  }
  const std::string lattice = write("free_lattice.toml",
                                    "title = \"free block\"\ngravity = [0, 0, 0]\n[[lattice]]\nname = \"b\"\n"
                                    "size = [5, 5, 5]\nspacing = 0.1\nmass = 0.01\nstiffness = 1000\n"
                                    "diagonals = true\n");
  for (const char* solver : {"sparse", "dense"})
    for (const char* modes : {"1", "3", "6", "7"}) {
      const Outcome r = run({"analyze", lattice, "--solver", solver, "--modes", modes});
      EXPECT_EQ(r.status, 0) << solver << " " << modes << ": " << r.err;
      EXPECT_NE(r.out.find("marginal: 6 zero-frequency modes"), std::string::npos)
          << solver << " --modes " << modes << ": " << r.out;
    }
}

}  // namespace

namespace {

// --- work and memory beyond what fits (issue 20 parts 3 and 6) ---------------------------------

std::string chain_scene(int links) {
  return "title = \"chain\"\ngravity = [0, 0, -9.81]\n[[chain]]\nname = \"link\"\nlinks = " + std::to_string(links) +
         "\nlength = 1\nmass = 1\nmass_model = \"point\"\n";
}

// The hanging chain's force scale in closed form: link i (1-based) carries
// m = 1/N at depth i·a, moved by hinges k ≤ i with levers (i − k + 1)·a, so
// ‖J_i‖² = a² Σ_{j ≤ i} j² and the scale is Σ_i m g ‖J_i‖.
double chain_force_scale(int links) {
  const double a = 1.0 / links, m = 1.0 / links, g = 9.81;
  double squares = 0, scale = 0;
  for (int i = 1; i <= links; ++i) {
    squares += static_cast<double>(i) * i;
    scale += m * g * a * std::sqrt(squares);
  }
  return scale;
}

// force_scale walked every body's path (O(n²) for a chain: over a minute at
// the documented 10⁵ links); at the limit it must take no longer than
// building the chain, and still be the sum it was.
TEST(hostile_limits, ForceScaleOfTheLongestChainIsLinearAndExact) {
  for (int links : {1, 7, 300, modal::SceneLimits{}.links}) {
    const modal::Model model = modal::model_from_text(chain_scene(links), "chain.toml");
    modal::Workspace ws(model.system);
    const double scale = modal::force_scale(model.system, ws, model.system.initial_configuration());
    EXPECT_NEAR(scale, chain_force_scale(links), 1e-12 * chain_force_scale(links)) << links << " links";
  }
}

// Chains near and above what fits: refused before anything is allocated,
// with the estimate and the limit in words (exit 2), on both matrix paths;
// the automatic choice takes the matrix-free path where that fits (1.5 kB per
// link and the Lanczos basis: 20000 links in 100 MB, not 10⁵).
TEST_F(Hostile, ChainsThatDoNotFitAreRefusedWithTheEstimate) {
  for (int links : {1500, 3000, 20000, modal::SceneLimits{}.links}) {
    const std::string scene = write("chain" + std::to_string(links) + ".toml", chain_scene(links));
    for (const char* solver : {"auto", "dense", "sparse"}) {
      const Outcome r = run({"analyze", scene, "--max-memory", "100M", "--solver", solver, "--modes", "3"});
      EXPECT_EQ(r.err.find("bad_alloc"), std::string::npos) << r.err;
      if (std::string(solver) == "auto" && links <= 20000) {
        EXPECT_EQ(r.status, 0) << links << " auto: " << r.err;
        EXPECT_NE(r.out.find("matrix-free"), std::string::npos) << r.out;
        continue;
      }
      EXPECT_EQ(r.status, 2) << links << " " << solver << ": " << r.err;
      EXPECT_NE(r.err.find("would need about"), std::string::npos) << r.err;
      EXPECT_NE(r.err.find("more than the 100 MB allowed (--max-memory)"), std::string::npos) << r.err;
      if (std::string(solver) != "auto" && links <= 20000) {
        EXPECT_NE(r.err.find("the matrix-free solver (--solver tree) fits"), std::string::npos) << r.err;
      }
      EXPECT_TRUE(r.out.empty());
    }
  }
  // The documented maximum needs terabytes as matrices: no machine's available memory holds them.
  const std::string longest = write("longest.toml", chain_scene(modal::SceneLimits{}.links));
  const Outcome r = run({"analyze", longest, "--solver", "dense"});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("TB of memory"), std::string::npos) << r.err;
  // check needs no matrices: the longest chain is summarized.
  EXPECT_EQ(run({"check", longest}).status, 0);
}

// The other commands estimate before allocating too (issue 20 part 3): a
// sweep (every point a dense analysis), a simulation (the dense matrices and
// the trajectory) and the survey of equilibria (dense Newton steps, at most
// 1000 coordinates) are refused up front in words (exit 2), and a sweep
// whose parameter grows the scene past what fits fails that point with the
// estimate instead of running out of memory.
TEST_F(Hostile, SweepsSimulationsAndSurveysThatDoNotFitAreRefused) {
  for (int links : {3000, 20000}) {
    const std::string scene = write("chain" + std::to_string(links) + ".toml", chain_scene(links));
    for (const std::vector<std::string>& command :
         {std::vector<std::string>{"sweep", scene, "--vary", "g=1:2:3"},
          std::vector<std::string>{"simulate", scene, "--duration", "1"}}) {
      std::vector<std::string> args = command;
      args.insert(args.end(), {"--max-memory", "100M"});
      const Outcome r = run(args);
      EXPECT_EQ(r.status, 2) << command[0] << " " << links << ": " << r.err;
      EXPECT_NE(r.err.find("would need about"), std::string::npos) << r.err;
      EXPECT_NE(r.err.find("more than the 100 MB allowed (--max-memory)"), std::string::npos) << r.err;
      EXPECT_TRUE(r.out.empty()) << r.out.substr(0, 200);
    }
    const Outcome survey = run({"equilibria", scene});
    EXPECT_EQ(survey.status, 2) << survey.err;
    EXPECT_NE(survey.err.find("at most 1000 coordinates"), std::string::npos) << survey.err;
    EXPECT_EQ(survey.err.find("numerical failure"), std::string::npos) << survey.err;
  }
  const Outcome r = run({"sweep", std::string(MODAL_SOURCE_DIR) + "/models/hanging_chain.toml", "--vary", "N=10,20,5000",
                         "--max-memory", "100M"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("failed: not analyzed: it would need about"), std::string::npos) << r.out;
}

// The automatic choice takes the path that fits: the bundled lattice (540
// coordinates, dense by default) goes sparse under a limit the dense path
// exceeds; forcing the dense path is refused with a pointer to the other.
TEST_F(Hostile, TheAutomaticSolverTakesThePathThatFits) {
  const std::string scene = std::string(MODAL_SOURCE_DIR) + "/models/lattice.toml";
  const Outcome fits = run({"analyze", scene, "--max-memory", "20M"});
  EXPECT_EQ(fits.status, 0) << fits.err;
  const Outcome dense = run({"analyze", scene, "--max-memory", "20M", "--solver", "dense"});
  EXPECT_EQ(dense.status, 2) << dense.err;
  EXPECT_NE(dense.err.find("--solver sparse) fits"), std::string::npos) << dense.err;
  for (const char* size : {"0", "-1G", "4X", "G", "nan"}) {
    // A value the option never takes: a usage error (1), read with the command line.
    const Outcome bad = run({"analyze", scene, "--max-memory", size});
    EXPECT_EQ(bad.status, 1) << size;
    EXPECT_NE(bad.err.find("--max-memory: must be a size such as 4G"), std::string::npos) << bad.err;
  }
  EXPECT_EQ(modal::parse_memory_size("4G"), 4e9);
  EXPECT_EQ(modal::parse_memory_size("512MB"), 512e6);
  EXPECT_EQ(modal::format_bytes(1), "1 byte");
  EXPECT_EQ(modal::format_bytes(2), "2 bytes");
}

std::string lattices_scene(int count, const std::string& size) {
  std::string text = "title = \"lattices\"\n";
  for (int i = 0; i < count; ++i)
    text += "[[lattice]]\nname = \"l" + std::to_string(i) + "\"\nsize = " + size +
            "\nspacing = 0.1\nmass = 0.01\nstiffness = 1000\ndiagonals = true\nfixed = \"x-\"\n";
  return text;
}

// The refusal of a scene: its key and reason ("" and "accepted" when it is taken).
std::pair<std::string, std::string> refusal(const std::string& text, const modal::SceneLimits& limits) {
  try {
    (void)modal::parse_scene(text, "many.toml", {}, limits);
  } catch (const modal::SceneError& e) {
    return {e.key(), e.reason()};
  }
  return {"", "accepted"};
}

// Many lattices: the particles of all of them count against the limit, and the
// scene's memory against the memory limit, refused at the size key of the
// lattice that goes over, before any lattice is generated.
TEST(hostile_limits, LatticeTotalsAreBoundedAtTheLatticeThatGoesOver) {
  modal::SceneLimits limits;
  limits.particles = 1000;
  for (int count : {2, 10, 11, 40}) {
    const auto [key, reason] = refusal(lattices_scene(count, "[10, 10, 1]"), limits);
    if (count * 100 <= limits.particles) {
      EXPECT_EQ(key, "") << count << ": " << reason;
      continue;
    }
    EXPECT_EQ(key, "lattice[11].size") << reason;
    EXPECT_NE(reason.find("1100 particles in all"), std::string::npos) << reason;
    EXPECT_NE(reason.find("at most 1000"), std::string::npos) << reason;
  }
  // One lattice within the particle limit but beyond the memory limit, and
  // two of 3·10⁶ particles: the first is already too much.
  modal::SceneLimits memory;
  memory.memory = 50e6;
  for (const auto& [count, size] : {std::pair{1, "[100, 100, 10]"}, std::pair{2, "[3000, 1000, 1]"}}) {
    const auto [key, reason] = refusal(lattices_scene(count, size), memory);
    EXPECT_EQ(key, "lattice[1].size") << reason;
    EXPECT_NE(reason.find("more than the 50 MB allowed"), std::string::npos) << reason;
  }
  // The defaults, with memory to spare: 40 lattices at the limit of one are
  // refused at the second before any is generated (the first's gigabytes
  // were spent before).
  modal::SceneLimits plenty;
  plenty.memory = 1e18;
  const auto [key, reason] = refusal(lattices_scene(40, "[5000, 1000, 1]"), plenty);
  EXPECT_EQ(key, "lattice[2].size") << reason;
  EXPECT_NE(reason.find("10000000 particles in all"), std::string::npos) << reason;
}

// Out of memory is said in words with the estimate, never "std::bad_alloc".
TEST(hostile_limits, OutOfMemoryReadsAsARealReason) {
  const modal::OutOfMemory oom("out of memory: the dense analysis of 20000 coordinates was estimated to need about "
                               "90 GB and needed more than this machine could give it");
  EXPECT_EQ(modal::error_message(oom), std::string("modal: ") + oom.what());
  EXPECT_EQ(modal::exit_status(oom), modal::ExitStatus::numerical);
  const std::bad_alloc plain;
  EXPECT_NE(modal::error_message(plain).find("out of memory"), std::string::npos);
  EXPECT_EQ(modal::error_message(plain).find("bad_alloc"), std::string::npos);
}

// The survey's default number of starts falls with the scene's size, and its
// progress is reported once per start.
TEST(hostile_limits, EquilibriumSurveysScaleTheirStartsAndReportProgress) {
  const modal::Model lattice = modal::load_model(std::string(MODAL_SOURCE_DIR) + "/models/lattice.toml");
  EXPECT_EQ(modal::default_equilibrium_starts(lattice.system), 2);
  const modal::Model pendulum = modal::load_model(std::string(MODAL_SOURCE_DIR) + "/models/double_pendulum.toml");
  EXPECT_EQ(modal::default_equilibrium_starts(pendulum.system), 64);
  modal::EquilibriumOptions options;
  int calls = 0, total = 0;
  options.progress = [&](int done, int of) {
    EXPECT_EQ(done, calls);
    total = of;
    ++calls;
  };
  (void)modal::find_equilibria(pendulum.system, options);
  EXPECT_EQ(calls, total);
  EXPECT_GE(total, 64);
}

}  // namespace
