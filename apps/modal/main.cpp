// modal — the command-line program (DESIGN.md §4).
//
// Thin: parses options, runs the pipeline stages, and maps failures to exit
// statuses: 0 success, 1 usage, 2 bad scene or input, 3 unstable under
// --require-stable, 4 numerical failure.
#include "modal/equilibrium.hpp"
#include "modal/linearize.hpp"
#include "modal/modes.hpp"
#include "modal/report.hpp"
#include "modal/scene.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace {

enum Exit { ok = 0, usage = 1, bad_input = 2, unstable = 3, numerical = 4 };

// Bad input found by the program itself (--at, --set, output paths): exit 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SceneOptions {
  std::string file;
  std::vector<std::string> sets;
};

struct Stopwatch {
  using Clock = std::chrono::steady_clock;
  Clock::time_point start = Clock::now(), last = start;
  std::vector<std::pair<std::string, double>> laps;
  void lap(std::string name) {
    const auto now = Clock::now();
    laps.emplace_back(std::move(name), std::chrono::duration<double, std::milli>(now - last).count());
    last = now;
  }
  void print(std::ostream& err) const {
    for (const auto& [name, ms] : laps) err << fmt::format("timing: {:<12} {:>10.3f} ms\n", name, ms);
    err << fmt::format("timing: {:<12} {:>10.3f} ms\n", "total",
                       std::chrono::duration<double, std::milli>(Clock::now() - start).count());
  }
};

void add_scene_options(CLI::App* cmd, SceneOptions& s) {
  cmd->add_option("SCENE", s.file, "scene file (TOML, DESIGN.md §3)")->required();
  cmd->add_option("--set", s.sets, "override a parameter: NAME=VALUE (VALUE may be an expression)")
      ->type_name("N=V")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
}

modal::Scene load(const SceneOptions& s) {
  std::vector<modal::ParameterOverride> overrides;
  for (const std::string& text : s.sets) overrides.push_back(modal::parse_override(text));
  {
    std::ifstream probe(s.file);
    if (!probe) throw InputError(s.file + ": cannot open the scene file");
  }
  return modal::load_scene(s.file, overrides);
}

std::string join_names(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

std::string format_point(const std::vector<std::string>& names, const modal::VectorX& q) {
  std::string out;
  for (Eigen::Index i = 0; i < q.size(); ++i)
    out += fmt::format("{}{} = {:.10g}", i ? ", " : "", names[static_cast<std::size_t>(i)], q[i]);
  return out;
}

// "q1,q2,..." → n numbers, or InputError saying what is expected.
modal::VectorX parse_at(const std::string& text, const modal::System& sys) {
  const auto names = sys.coordinate_names();
  const std::string expected =
      fmt::format("--at expects {} comma-separated number{} ({})", names.size(),
                  names.size() == 1 ? "" : "s", join_names(names));
  std::vector<double> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(item, &used);
    } catch (const std::exception&) {
      throw InputError(fmt::format("{}; '{}' is not a number", expected, item));
    }
    while (used < item.size() && std::isspace(static_cast<unsigned char>(item[used]))) ++used;
    if (used != item.size() || !std::isfinite(v))
      throw InputError(fmt::format("{}; '{}' is not a finite number", expected, item));
    values.push_back(v);
  }
  if (!text.empty() && text.back() == ',') throw InputError(expected + "; got a trailing comma");
  if (values.size() != names.size())
    throw InputError(fmt::format("{}; got {}", expected, values.size()));
  return Eigen::Map<const modal::VectorX>(values.data(), static_cast<Eigen::Index>(values.size()));
}

modal::Equilibrium equilibrium_at(const modal::System& sys, const modal::VectorX& at) {
  constexpr double accept = 1e-3;  // configuration distance (angles mod 2π, lengths / length scale)
  const auto names = sys.coordinate_names();
  std::optional<modal::Equilibrium> e = modal::polish_equilibrium(sys, at);
  if (e && modal::configuration_distance(sys, e->q, at) <= accept) return *e;

  modal::Workspace ws(sys);
  const double scale = modal::force_scale(sys, ws, at);
  const double residual = modal::equilibrium_residual(sys, ws, at).norm();
  const double relative = scale > 0 ? residual / scale : residual;
  std::string nearest;
  if (e) {
    nearest = fmt::format("nearest equilibrium found at {}", format_point(names, e->q));
  } else {
    try {
      const modal::Equilibrium f = modal::find_equilibrium(sys, at);
      nearest = fmt::format("nearest equilibrium found at {}", format_point(names, f.q));
    } catch (const modal::NumericalError& ex) {
      nearest = fmt::format("no equilibrium found near it ({})", ex.what());
    }
  }
  throw InputError(fmt::format("--at: the point is not an equilibrium (relative residual {:.3g}); {}",
                               relative, nearest));
}

int run_analyze(const SceneOptions& so, int modes, const std::optional<std::string>& at, const std::string& csv,
                const std::string& json, bool require_stable, bool timing) {
  Stopwatch clock;
  const modal::Scene scene = load(so);
  const modal::System sys = modal::build_system(scene);
  clock.lap("parse+build");

  const modal::Equilibrium eq = !at ? modal::find_equilibrium(sys, sys.initial_configuration())
                                    : equilibrium_at(sys, parse_at(*at, sys));
  clock.lap("equilibrium");
  const modal::LinearModel lin = modal::linearize(sys, eq.q);
  clock.lap("linearize");
  modal::ModalOptions mo;
  mo.modes = modes;
  const modal::ModalResult result = modal::solve_modes(lin, mo);
  clock.lap("eigen");

  modal::Report report = modal::make_report(sys, scene.file, scene.parameters);
  report.equilibria.push_back({eq, result});
  modal::print_analysis(std::cout, report);
  if (!csv.empty()) modal::write_csv_files(csv, report);
  if (!json.empty()) modal::write_text_file(json, modal::analysis_json(report));
  std::cout.flush();
  clock.lap("report");
  if (timing) clock.print(std::cerr);

  if (require_stable && (result.stability == modal::Stability::divergence ||
                         result.stability == modal::Stability::flutter)) {
    std::cerr << "modal: the equilibrium is unstable (" << modal::describe_stability(result) << ")\n";
    return unstable;
  }
  return ok;
}

int run_equilibria(const SceneOptions& so, int starts, const std::string& csv, const std::string& json) {
  const modal::Scene scene = load(so);
  const modal::System sys = modal::build_system(scene);
  modal::EquilibriumOptions eo;
  if (starts >= 0) eo.starts = starts;
  const std::vector<modal::Equilibrium> all = modal::find_equilibria(sys, eo);
  modal::Report report = modal::make_report(sys, scene.file, scene.parameters);
  for (const modal::Equilibrium& e : all)
    report.equilibria.push_back({e, modal::solve_modes(modal::linearize(sys, e.q))});
  modal::print_equilibria(std::cout, report);
  if (!csv.empty()) modal::write_file(csv, modal::write_equilibria_csv, report);
  if (!json.empty()) modal::write_text_file(json, modal::equilibria_json(report));
  return ok;
}

int run_check(const SceneOptions& so) {
  const modal::Scene scene = load(so);
  const modal::System sys = modal::build_system(scene);
  modal::print_summary(std::cout, scene.file, scene.parameters, sys);
  return ok;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"modal — linearization and modal analysis of Lagrangian mechanical systems", "modal"};
  // Set before adding subcommands: they copy it. On a usage error, print the
  // message and the help of the command that failed.
  app.failure_message(CLI::FailureMessage::help);
  app.set_version_flag("--version", std::string("modal ") + MODAL_VERSION);
  app.require_subcommand(1);
  app.footer(
      "Exit status: 0 success, 1 usage, 2 bad scene or input, 3 unstable under --require-stable, "
      "4 numerical failure.\n");

  SceneOptions analyze_scene, equilibria_scene, check_scene;
  int modes = -1, starts = -1;
  std::string at, analyze_csv, analyze_json, equilibria_csv, equilibria_json;
  bool require_stable = false, timing = false;

  CLI::App* analyze = app.add_subcommand(
      "analyze", "find the equilibrium nearest the initial configuration (or --at), linearize, report modes");
  add_scene_options(analyze, analyze_scene);
  analyze->add_option("--modes", modes, "number of lowest modes to report (default: all)")
      ->check(CLI::PositiveNumber);
  CLI::Option* at_option =
      analyze->add_option("--at", at, "analyze the equilibrium at this point: q1,q2,... (one value per coordinate)");
  analyze->add_option("--csv", analyze_csv, "write PREFIX_modes.csv, PREFIX_shapes.csv, PREFIX_equilibria.csv")
      ->type_name("PREFIX");
  analyze->add_option("--json", analyze_json, "write the whole result as JSON")->type_name("FILE");
  analyze->add_flag("--require-stable", require_stable,
                    "exit with status 3 if the equilibrium is unstable (divergence or flutter)");
  analyze->add_flag("--timing", timing, "print the wall time of each stage on stderr");

  CLI::App* equilibria = app.add_subcommand(
      "equilibria", "enumerate equilibria with their stability and Morse index");
  add_scene_options(equilibria, equilibria_scene);
  equilibria->add_option("--starts", starts, "number of deterministic search starts")
      ->check(CLI::NonNegativeNumber);
  equilibria->add_option("--csv", equilibria_csv, "write the equilibria table as CSV")->type_name("FILE");
  equilibria->add_option("--json", equilibria_json, "write all equilibria and their modes as JSON")
      ->type_name("FILE");

  CLI::App* check = app.add_subcommand("check", "validate the scene and print a summary");
  add_scene_options(check, check_scene);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    CLI::App* where = &app;
    for (CLI::App* sub : app.get_subcommands()) where = sub;
    const int code = where->exit(e);
    return code == 0 ? ok : usage;
  }

  try {
    if (*analyze)
      return run_analyze(analyze_scene, modes, at_option->count() ? std::optional<std::string>(at) : std::nullopt, analyze_csv, analyze_json, require_stable, timing);
    if (*equilibria) return run_equilibria(equilibria_scene, starts, equilibria_csv, equilibria_json);
    if (*check) return run_check(check_scene);
    return usage;
  } catch (const modal::SceneError& e) {
    std::cerr << e.what() << '\n';
    return bad_input;
  } catch (const InputError& e) {
    std::cerr << "modal: " << e.what() << '\n';
    return bad_input;
  } catch (const modal::ReportError& e) {
    std::cerr << "modal: " << e.what() << '\n';
    return bad_input;
  } catch (const modal::NumericalError& e) {
    std::cerr << "modal: numerical failure: " << e.what() << '\n';
    return numerical;
  } catch (const std::exception& e) {
    std::cerr << "modal: numerical failure: " << e.what() << '\n';
    return numerical;
  } catch (...) {
    std::cerr << "modal: failure: unknown error\n";
    return numerical;
  }
}
