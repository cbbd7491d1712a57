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
#include "modal/simulate.hpp"
#include "modal/sweep.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <unistd.h>

namespace {

// The memory policy of the process, for the large scenes of the sparse path.
//
// A 10⁶-coordinate analysis allocates and frees vectors, triplet lists and
// factor workspaces of tens to hundreds of MB, thousands of times. glibc's
// defaults serve each with a fresh mmap and return it with munmap, so every
// reuse faults its pages in again, 4 KiB at a time, and on a virtual machine a
// page fault costs microseconds. Keeping freed memory in the heap
// (mmap_max = 0, trim_threshold = 1 TB) and backing the heap with transparent
// huge pages (hugetlb = 1: malloc madvises its memory, 2 MiB pages) took the
// 10⁶-coordinate net from 113 s to 65 s, and its parse+build from 2.0 s to
// 0.34 s (results/sparse_scaling.md); small scenes do not notice either way.
//
// glibc reads these settings from GLIBC_TUNABLES only when a process starts
// (huge pages have no mallopt), so when the variable is unset modal sets it
// and executes itself once more. A GLIBC_TUNABLES the user set is respected
// as it is. Not under the sanitizers, which bring their own allocator.
void tune_allocator(char** argv) {
#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
  if (std::getenv("GLIBC_TUNABLES") != nullptr) return;  // the user's choice, or already executed again
  if (setenv("GLIBC_TUNABLES",
             "glibc.malloc.hugetlb=1:glibc.malloc.mmap_max=0:glibc.malloc.trim_threshold=1000000000000", 1) != 0)
    return;
  execv("/proc/self/exe", argv);
  // Only reached when the new image could not be executed (no /proc, say): go
  // on with the default allocator, which is slower but equally correct.
  unsetenv("GLIBC_TUNABLES");
#else
  (void)argv;
#endif
}

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
  // A phase inside the next lap (measured by the library), shown indented under it.
  void add(const std::string& name, double seconds) { inner.emplace_back(laps.size(), "  " + name, 1e3 * seconds); }
  std::vector<std::tuple<std::size_t, std::string, double>> inner;
  void print(std::ostream& err) const {
    for (std::size_t i = 0; i < laps.size(); ++i) {
      for (const auto& [at, name, ms] : inner)
        if (at == i) err << fmt::format("timing: {:<16} {:>12.3f} ms\n", name, ms);
      err << fmt::format("timing: {:<16} {:>12.3f} ms\n", laps[i].first, laps[i].second);
    }
    err << fmt::format("timing: {:<16} {:>12.3f} ms\n", "total",
                       std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    // Peak resident memory of the process so far (Linux: VmHWM).
    std::ifstream status("/proc/self/status");
    for (std::string line; std::getline(status, line);)
      if (line.rfind("VmHWM:", 0) == 0) err << "timing: peak memory    " << line.substr(6) << '\n';
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

// "q1,q2,..." given to `option` (--at, --velocity) → n numbers, or InputError
// saying what is expected.
modal::VectorX parse_point(const std::string& option, const std::string& text, const modal::System& sys) {
  const auto names = sys.coordinate_names();
  const std::string expected =
      fmt::format("{} expects {} comma-separated number{} ({})", option, names.size(),
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

// `--solver`: which eigen-solver analyze uses.
struct SolverChoice {
  std::string solver = "auto";  // auto | dense | sparse
  std::optional<double> shift;  // sparse: σ
  double tolerance = 1e-10;     // sparse: Lanczos convergence tolerance
  std::string export_dir;       // --export-matrices
  std::string large_equilibrium = "newton";  // newton | lbfgs (scenes above large_system_coordinates)
  std::string derivatives = "exact";         // --derivatives: exact | central | forward | complex-step
  double step_factor = 0;                    // --step: factor of the difference step (0: the method's rule)
  double equilibrium_tolerance = modal::EquilibriumOptions{}.tolerance;  // --eq-tol
  std::string dense_solver = "auto";         // --dense-solver: auto | eigen | lapack
};

// The linearization options a choice asks for (derivative method and step;
// an equilibrium accepted at a looser --eq-tol is accepted by the
// linearization too).
modal::LinearizeOptions linearize_options(const SolverChoice& choice) {
  modal::LinearizeOptions lo;
  lo.derivatives = *modal::parse_derivative_method(choice.derivatives);  // checked by CLI11
  lo.step_factor = choice.step_factor;
  lo.tolerance = std::max(lo.tolerance, choice.equilibrium_tolerance);
  return lo;
}

// The documented rule: sparse for more than large_system_coordinates
// coordinates when the sparse model describes the scene, else dense.
bool use_sparse(const modal::System& sys, const SolverChoice& choice) {
  if (choice.solver == "dense") return false;
  const auto why = modal::sparse_unsupported(sys);
  if (choice.solver == "sparse") {
    if (why) throw InputError("--solver sparse: the sparse solver does not apply to this scene: " + *why);
    return true;
  }
  return !why && sys.size() > modal::large_system_coordinates;
}

int run_analyze(const SceneOptions& so, int modes, const std::optional<std::string>& at, const std::string& csv,
                const std::string& json, bool require_stable, bool timing, const SolverChoice& choice) {
  Stopwatch clock;
  const modal::Scene scene = load(so);
  const modal::System sys = modal::build_system(scene);
  clock.lap("parse+build");

  modal::EquilibriumOptions eo;
  eo.tolerance = choice.equilibrium_tolerance;
  if (choice.large_equilibrium == "lbfgs") eo.large_method = modal::LargeEquilibriumMethod::lbfgs;
  if (choice.step_factor > 0 && choice.derivatives == "exact")
    throw InputError("--step sets the step of differences: give --derivatives central, forward or complex-step");
  const modal::LinearizeOptions lo = linearize_options(choice);
  if (lo.derivatives == modal::DerivativeMethod::complex_step && sys.is_map())
    throw InputError("--derivatives complex-step: not available for kinematic maps (their expressions are "
                     "evaluated in real arithmetic); use exact, central or forward");
  const modal::Equilibrium eq = !at ? modal::find_equilibrium(sys, sys.initial_configuration(), eo)
                                    : equilibrium_at(sys, parse_point("--at", *at, sys));
  clock.lap("equilibrium");
  modal::ModalResult result;
  auto export_if_asked = [&](const auto& lin) {
    if (choice.export_dir.empty()) return;
    modal::export_matrices(choice.export_dir, lin);
    clock.lap("export");
  };
  if (use_sparse(sys, choice)) {
    if (lo.derivatives != modal::DerivativeMethod::exact)
      throw InputError("--derivatives " + choice.derivatives +
                       ": the sparse path assembles K exactly from the elements' derivatives; differences apply "
                       "to the dense path (--solver dense)");
    const modal::SparseLinearModel lin = modal::linearize_sparse(sys, eq.q, lo);
    clock.lap("assembly");
    export_if_asked(lin);
    modal::SparseModalOptions so_sparse;
    if (modes > 0) so_sparse.modes = modes;
    so_sparse.shift = choice.shift;
    so_sparse.tolerance = choice.tolerance;
    so_sparse.fill_reducing_order = eq.fill_reducing_order;  // ∇∇V's analysis, same pattern as K − σM
    so_sparse.K_systematic_error = lin.K_systematic_error;     // a loose equilibrium's share of the error
    result = modal::solve_sparse_modes(lin.K, lin.M, so_sparse);
    if (lin.residual > modal::EquilibriumOptions{}.tolerance && lin.K_systematic_error.nonZeros() == 0)
      result.notes.push_back(fmt::format(
          "the equilibrium's relative residual {:.1e} is above the rounding level, and the error it causes "
          "(K differs from K at the equilibrium) is not in the estimates: the sparse path takes it only above {:g}, "
          "where a factorization of K is worth it; tighten --eq-tol, or --solver dense includes it",
          lin.residual, modal::sparse_equilibrium_correction_residual));
    for (const auto& [phase, seconds] : result.timings) clock.add(phase, seconds);
    clock.lap("eigen");
  } else {
    if (choice.shift) throw InputError("--shift applies to the sparse solver (--solver sparse)");
    const modal::LinearModel lin = modal::linearize(sys, eq.q, lo);
    clock.lap("linearize");
    export_if_asked(lin);
    modal::ModalOptions mo;
    mo.modes = modes;
    for (const auto s : {modal::DenseSolver::automatic, modal::DenseSolver::eigen, modal::DenseSolver::lapack})
      if (choice.dense_solver == modal::to_string(s)) mo.dense_solver = s;
    result = modal::solve_modes(lin, mo);
    if (lo.derivatives != modal::DerivativeMethod::exact)
      result.notes.push_back(fmt::format(
          "K{} by {} differences (step factor {:.2g}) instead of exact derivatives; the error estimates include "
          "their error, measured as 2|K(h) - K(2h)| (largest {:.2g})",
          lin.has_gyroscopic ? " and G" : "", choice.derivatives,
          lo.step_factor > 0 ? lo.step_factor : modal::default_step_factor(lo.derivatives),
          lin.K_error.cwiseAbs().maxCoeff()));
    clock.lap("eigen");
  }

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
  std::vector<std::string> unanalyzed;  // equilibria found whose linear model does not exist
  for (const modal::Equilibrium& e : all) {
    try {
      report.equilibria.push_back({e, modal::solve_modes(modal::linearize(sys, e.q))});
    } catch (const modal::NumericalError& error) {
      std::string at;
      for (Eigen::Index i = 0; i < e.q.size(); ++i)
        at += (i > 0 ? ", " : "") + sys.coordinates()[static_cast<std::size_t>(i)].name + " = " + std::to_string(e.q[i]);
      unanalyzed.push_back("an equilibrium at " + at + " was found but cannot be analyzed: " + error.what());
    }
  }
  modal::print_equilibria(std::cout, report);
  for (const std::string& note : unanalyzed) std::cerr << "modal: " << note << '\n';
  if (!csv.empty()) modal::write_file(csv, modal::write_equilibria_csv, report);
  if (!json.empty()) modal::write_text_file(json, modal::equilibria_json(report));
  return ok;
}

int run_check(const SceneOptions& so, bool all) {
  const modal::Scene scene = load(so);
  const modal::System sys = modal::build_system(scene);
  modal::print_summary(std::cout, scene.file, scene.parameters, sys, all ? 0 : 100);
  return ok;
}

// --- sweep ---------------------------------------------------------------------

// A progress bar on stderr, only when stderr is a terminal and the sweep has
// already taken more than a second.
class ProgressBar {
 public:
  ProgressBar() : tty_(isatty(STDERR_FILENO) == 1) {}
  void operator()(int done, int total) {
    if (!tty_ || total <= 0) return;
    const double elapsed = std::chrono::duration<double>(Stopwatch::Clock::now() - start_).count();
    if (elapsed < 1.0) return;
    constexpr int width = 40;
    const int filled = static_cast<int>(static_cast<long long>(width) * done / total);
    std::cerr << '\r' << "sweep [" << std::string(static_cast<std::size_t>(filled), '#')
              << std::string(static_cast<std::size_t>(width - filled), ' ') << "] " << done << '/' << total
              << fmt::format(" {:.1f} s", elapsed) << std::flush;
    shown_ = true;
  }
  void finish() {
    if (shown_) std::cerr << '\r' << std::string(72, ' ') << '\r' << std::flush;
    shown_ = false;
  }

 private:
  bool tty_;
  bool shown_ = false;
  Stopwatch::Clock::time_point start_ = Stopwatch::Clock::now();
};

std::string read_scene_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the scene file");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// FILE.csv → FILE_critical.csv (FILE → FILE_critical.csv).
std::string critical_path(const std::string& csv) {
  const std::string ext = ".csv";
  const bool has_ext = csv.size() > ext.size() && csv.compare(csv.size() - ext.size(), ext.size(), ext) == 0;
  return (has_ext ? csv.substr(0, csv.size() - ext.size()) : csv) + "_critical.csv";
}

std::string g(double v, int digits = 6) {
  if (std::isnan(v)) return "-";
  return fmt::format("{:.{}g}", v, digits);
}

// "P = 2.0857864376 ± 3.1e-12" style value with its error.
std::string value_with_error(double value, double error) {
  return fmt::format("{:.12g} ± {:.2g}", value, error);
}

// A critical value in words: kind, the change of class, frequency.
std::string describe_critical(const modal::CriticalValue& c, const std::string& name) {
  std::string out = fmt::format("{} = {}  {}", name, value_with_error(c.value, c.error), modal::to_string(c.kind));
  out += fmt::format(" ({} → {}", modal::to_string(c.before), modal::to_string(c.after));
  if (c.restabilization()) out += ": restabilization";
  if (c.loss()) out += ": loss of stability";
  out += ")";
  if (c.kind == modal::CriticalKind::divergence) out += "  ω = 0";
  else if (std::isfinite(c.omega)) out += fmt::format("  ω = {:.10g} rad/s", c.omega);
  if (!c.refined) out += "  [not refined]";
  return out;
}

void print_sweep(std::ostream& out, const modal::SweepResult& r, const std::string& file, double tolerance) {
  const modal::SweepAxis& ax = r.axis;
  out << fmt::format("Sweep of {} in {}: {} points from {} to {}", ax.name, file, ax.count, g(ax.from, 10),
                     g(ax.to, 10));
  if (!r.coordinates.empty()) out << fmt::format(" ({} coordinates)", r.coordinates.size());
  out << "\n\n";
  bool all_symmetric = true;
  for (const modal::SweepPoint& p : r.points)
    if (p.ok && !p.symmetric) all_symmetric = false;
  constexpr std::size_t shown = 3;
  const std::string modes_header = all_symmetric ? "lowest ω² [rad²/s²]" : "lowest ω [rad/s]";
  const int width = std::max(12, static_cast<int>(ax.name.size()));
  out << fmt::format("{:>{}}  {:<22}  {:>16}  {}\n", ax.name, width, "class", "max growth [1/s]", modes_header);
  for (const modal::SweepPoint& p : r.points) {
    if (!p.ok) {
      out << fmt::format("{:>{}}  failed: {}\n", g(p.value, 10), width, p.failure);
      continue;
    }
    std::string modes;
    for (std::size_t i = 0; i < p.result.modes.size() && i < shown; ++i) {
      const modal::Mode& m = p.result.modes[i];
      modes += fmt::format("{:>12}", g(all_symmetric ? m.omega2 : m.omega));
    }
    out << fmt::format("{:>{}}  {:<22}  {:>16}  {}\n", g(p.value, 10), width,
                       modal::to_string(p.result.stability), g(p.max_growth_rate), modes);
  }
  out << '\n';
  if (r.critical.empty()) {
    out << "No change of stability class between " << g(ax.from, 10) << " and " << g(ax.to, 10) << ".\n";
  } else {
    out << fmt::format("Critical values (class changes, refined to {:.0e} relative):\n", tolerance);
    for (const modal::CriticalValue& c : r.critical) out << "  " << describe_critical(c, ax.name) << '\n';
  }
  for (const std::string& note : r.notes) out << "note: " << note << '\n';
  out << fmt::format("{} evaluations ({} grid points, {} in refinements)\n", r.evaluations, ax.count,
                     r.evaluations - ax.count);
}

std::string sweep_modes_csv(const modal::SweepResult& r) {
  std::ostringstream out;
  out << modal::csv_field(r.axis.name)
      << ",mode,omega2,growth_rate,omega,frequency_hz,period,damping_ratio,stability,error_estimate\n";
  for (const modal::SweepPoint& p : r.points) {
    const std::string value = modal::csv_number(p.value);
    if (!p.ok) {
      out << value << ",,,,,,,,failed,\n";
      continue;
    }
    int index = 0;
    for (const modal::Mode& m : p.result.modes)
      out << value << ',' << ++index << ',' << modal::csv_number(m.omega2) << ',' << modal::csv_number(m.growth_rate)
          << ',' << modal::csv_number(m.omega) << ',' << modal::csv_number(m.frequency_hz) << ','
          << modal::csv_number(m.period) << ',' << modal::csv_number(m.damping_ratio) << ','
          << modal::csv_field(modal::mode_stability(m.kind)) << ',' << modal::csv_number(m.error_estimate) << '\n';
  }
  return out.str();
}

std::string sweep_critical_csv(const modal::SweepResult& r) {
  std::ostringstream out;
  out << "parameter,value,error,kind,omega,before,after\n";
  for (const modal::CriticalValue& c : r.critical)
    out << modal::csv_field(r.axis.name) << ',' << modal::csv_number(c.value) << ',' << modal::csv_number(c.error)
        << ',' << modal::to_string(c.kind) << ',' << modal::csv_number(c.omega) << ','
        << modal::csv_field(modal::to_string(c.before)) << ',' << modal::csv_field(modal::to_string(c.after)) << '\n';
  return out.str();
}

char map_symbol(const modal::MapPoint& p) {
  if (!p.ok) return '?';
  switch (p.stability) {
    case modal::Stability::stable: return 'o';
    case modal::Stability::asymptotically_stable: return 'a';
    case modal::Stability::marginal: return 'm';
    case modal::Stability::divergence: return 'D';
    case modal::Stability::flutter: return 'F';
  }
  return '?';
}

void print_map(std::ostream& out, const modal::StabilityMap& map, const std::string& file) {
  const modal::SweepAxis &x = map.x, &y = map.y;
  out << fmt::format("Stability map of {}: {} across ({} values, {} … {}), {} upwards ({} values, {} … {})\n\n",
                     file, x.name, x.count, g(x.from), g(x.to), y.name, y.count, g(y.from), g(y.to));
  std::vector<std::string> labels;
  std::size_t label_width = y.name.size();
  for (int j = 0; j < y.count; ++j) {
    labels.push_back(g(y.value(j)));
    label_width = std::max(label_width, labels.back().size());
  }
  out << fmt::format("{:>{}}\n", y.name, label_width);
  for (int j = y.count - 1; j >= 0; --j) {
    std::string row;
    for (int i = 0; i < x.count; ++i) row += map_symbol(map.at(i, j));
    out << fmt::format("{:>{}} |{}\n", labels[static_cast<std::size_t>(j)], label_width, row);
  }
  out << fmt::format("{:>{}} +{}\n", "", label_width, std::string(static_cast<std::size_t>(x.count), '-'));
  out << fmt::format("{:>{}}  {} = {} … {}\n\n", "", label_width, x.name, g(x.from), g(x.to));
  out << "legend: o stable, a asymptotically stable, m marginal, D divergence, F flutter, ? failed\n";
  int shown = 0, failed = 0;
  for (const modal::MapPoint& p : map.points) {
    if (p.ok) continue;
    ++failed;
    if (shown++ < 5) out << fmt::format("failed at {} = {}, {} = {}: {}\n", x.name, g(p.x), y.name, g(p.y), p.failure);
  }
  if (failed > shown) out << fmt::format("… {} failed points in all\n", failed);
}

std::string map_csv(const modal::StabilityMap& map) {
  std::ostringstream out;
  out << modal::csv_field(map.x.name) << ',' << modal::csv_field(map.y.name)
      << ",stability,max_growth_rate,min_omega2\n";
  for (const modal::MapPoint& p : map.points) {
    out << modal::csv_number(p.x) << ',' << modal::csv_number(p.y) << ',';
    if (p.ok)
      out << modal::csv_field(modal::to_string(p.stability)) << ',' << modal::csv_number(p.max_growth_rate) << ','
          << modal::csv_number(p.min_omega2) << '\n';
    else
      out << "failed,,\n";
  }
  return out.str();
}

// FILE.csv → FILE_<suffix>.csv (FILE → FILE_<suffix>.csv), as critical_path.
std::string suffixed_path(const std::string& csv, const std::string& suffix) {
  const std::string critical = critical_path(csv);
  return critical.substr(0, critical.size() - std::string("_critical.csv").size()) + "_" + suffix + ".csv";
}

// The frequencies of the lowest modes at every point, with the cost of each
// point, then the Richardson extrapolation of each mode (modal/sweep.hpp).
void print_extrapolation(std::ostream& out, const modal::SweepResult& r,
                         const std::vector<modal::ModeConvergence>& conv) {
  const std::string& name = r.axis.name;
  const int width = std::max(8, static_cast<int>(name.size()));
  out << fmt::format("\nConvergence in {} (ω in rad/s; time: parse, build, equilibrium and all modes of the point)\n",
                     name);
  out << fmt::format("{:>{}}  {:>11}  {:>9}", name, width, "coordinates", "time [s]");
  for (const modal::ModeConvergence& c : conv) out << fmt::format("  {:>17}", fmt::format("ω{}", c.mode));
  out << '\n';
  for (const modal::SweepPoint& p : r.points) {
    if (!p.ok) {
      out << fmt::format("{:>{}}  failed: {}\n", g(p.value, 10), width, p.failure);
      continue;
    }
    out << fmt::format("{:>{}}  {:>11}  {:>9.3g}", g(p.value, 10), width, p.equilibrium.q.size(), p.seconds);
    for (const modal::ModeConvergence& c : conv) {
      const std::size_t k = static_cast<std::size_t>(c.mode - 1);
      out << fmt::format("  {:>17}", k < p.result.modes.size() ? g(p.result.modes[k].omega, 12) : "-");
    }
    out << '\n';
  }
  out << fmt::format("\nRichardson extrapolation to {} → ∞ from the last three points of each mode "
                     "(f∞ = f3 + (f3 − f2)/((N3/N2)^p − 1)):\n",
                     name);
  out << fmt::format("{:>4}  {:>16}  {:>9}  {:>17}  {:>17}  {:>8}  {}\n", "mode", fmt::format("{} used", name),
                     "order p", "ω(N3)", "ω∞", "± error", "error from");
  for (const modal::ModeConvergence& c : conv) {
    const modal::Extrapolation& e = c.extrapolation;
    if (!e.asymptotic) {
      out << fmt::format("{:>4}  no extrapolation: {}\n", c.mode, e.reason);
      continue;
    }
    out << fmt::format("{:>4}  {:>16}  {:>9.5f}  {:>17}  {:>17}  {:>8.2g}  {}\n", c.mode,
                       fmt::format("{},{},{}", g(e.n1, 10), g(e.n2, 10), g(e.n3, 10)), e.order,
                       g(c.omega.back(), 12), g(e.value, 12), e.error, e.error_rule);
  }
}

// One row per point and mode: the convergence data behind the extrapolation.
std::string convergence_csv(const modal::SweepResult& r, const std::vector<modal::ModeConvergence>& conv) {
  std::ostringstream out;
  out << modal::csv_field(r.axis.name) << ",coordinates,seconds,mode,omega,error_estimate\n";
  for (const modal::ModeConvergence& c : conv)
    for (std::size_t i = 0; i < c.n.size(); ++i) {
      const auto point = std::find_if(r.points.begin(), r.points.end(),
                                      [&](const modal::SweepPoint& p) { return p.ok && p.value == c.n[i]; });
      out << modal::csv_number(c.n[i]) << ',' << point->equilibrium.q.size() << ','
          << modal::csv_number(point->seconds) << ',' << c.mode << ',' << modal::csv_number(c.omega[i]) << ','
          << modal::csv_number(c.omega_error[i]) << '\n';
    }
  return out.str();
}

// One row per mode: the extrapolation (empty numbers and the reason in `note`
// when the mode is not in the asymptotic range).
std::string extrapolation_csv(const std::vector<modal::ModeConvergence>& conv) {
  std::ostringstream out;
  out << "mode,n1,n2,n3,omega_n3,order,omega_extrapolated,error,error_rule,previous_order,previous_extrapolated,"
         "asymptotic,note\n";
  for (const modal::ModeConvergence& c : conv) {
    const modal::Extrapolation& e = c.extrapolation;
    auto number = [&](double v) { return e.asymptotic && std::isfinite(v) ? modal::csv_number(v) : std::string(); };
    out << c.mode << ',' << number(e.n1) << ',' << number(e.n2) << ',' << number(e.n3) << ','
        << number(c.omega.empty() ? std::nan("") : c.omega.back()) << ',' << number(e.order) << ','
        << number(e.value) << ',' << number(e.error) << ',' << modal::csv_field(e.error_rule) << ','
        << number(e.previous_order) << ',' << number(e.previous_value) << ',' << (e.asymptotic ? "true" : "false")
        << ',' << modal::csv_field(e.reason) << '\n';
  }
  return out.str();
}

// Exit status when no point of a sweep worked: the first failure says why.
template <class Points>
void require_some_point(const Points& points) {
  for (const auto& p : points)
    if (p.ok) return;
  if (points.empty()) return;
  const auto& first = points.front();
  if (first.scene_error) throw InputError("every point of the sweep failed; the first: " + first.failure);
  throw modal::NumericalError("every point of the sweep failed; the first: " + first.failure);
}

int run_sweep(const SceneOptions& so, const std::vector<std::string>& varies, const std::string& csv, int modes,
              bool extrapolate) {
  std::vector<modal::SweepAxis> axes;
  for (const std::string& v : varies) axes.push_back(modal::parse_vary(v));
  if (axes.empty() || axes.size() > 2)
    throw InputError(fmt::format("sweep takes one --vary (a sweep) or two (a stability map), got {}", axes.size()));
  if (extrapolate && axes.size() != 1) throw InputError("--extrapolate works along one --vary, not on a stability map");
  if (extrapolate) modal::check_extrapolation_axis(axes[0]);  // before the sweep runs
  constexpr int default_extrapolated_modes = 3;
  const int extrapolated_modes = modes > 0 ? modes : default_extrapolated_modes;
  std::vector<modal::ParameterOverride> fixed;
  for (const std::string& text : so.sets) fixed.push_back(modal::parse_override(text));
  const std::string text = read_scene_text(so.file);

  ProgressBar bar;
  modal::SweepOptions options;
  options.modes = modes;
  options.progress = [&bar](int done, int total) { bar(done, total); };

  if (axes.size() == 1) {
    const modal::SweepResult r = modal::sweep(text, so.file, fixed, axes[0], options);
    bar.finish();
    require_some_point(r.points);
    print_sweep(std::cout, r, so.file, options.tolerance);
    std::vector<modal::ModeConvergence> conv;
    if (extrapolate) {
      conv = modal::extrapolate_modes(r, extrapolated_modes);
      print_extrapolation(std::cout, r, conv);
    }
    if (!csv.empty()) {
      modal::write_text_file(csv, sweep_modes_csv(r));
      modal::write_text_file(critical_path(csv), sweep_critical_csv(r));
      if (extrapolate) {
        modal::write_text_file(suffixed_path(csv, "convergence"), convergence_csv(r, conv));
        modal::write_text_file(suffixed_path(csv, "extrapolation"), extrapolation_csv(conv));
      }
    }
    return ok;
  }
  const modal::StabilityMap map = modal::sweep_map(text, so.file, fixed, axes[0], axes[1], options);
  bar.finish();
  require_some_point(map.points);
  print_map(std::cout, map, so.file);
  if (!csv.empty()) modal::write_text_file(csv, map_csv(map));
  return ok;
}

// --- simulate ------------------------------------------------------------------

struct SimulateArgs {
  double duration = 0, tolerance = modal::SimulationOptions{}.tolerance;
  std::optional<double> interval;  // s; none: duration / 1000
  std::optional<std::string> at, velocity;
  std::string csv;
};

void print_simulation_summary(std::ostream& err, const modal::Trajectory& tr, const modal::SimulationOptions& o) {
  err << fmt::format("simulate: {:g} s, {} steps ({} rejected, {} evaluations), {} samples, tolerance {:g}\n",
                     tr.time.back(), tr.steps, tr.rejected_steps, tr.evaluations, tr.size(), o.tolerance);
  if (tr.conservative) {
    err << fmt::format("simulate: energy E0 = {:.10g} J conserved to a relative error of {:.2g} "
                       "(max |E - E0| / {:.6g} J)\n",
                       tr.energy.front(), tr.max_energy_error, tr.energy_scale);
    return;
  }
  err << fmt::format("simulate: energy is not conserved (dampers or follower loads): E went from {:.10g} J to "
                     "{:.10g} J, the work of the non-conservative forces is W = {:.10g} J\n",
                     tr.energy.front(), tr.energy.back(), tr.work.back());
  err << fmt::format("simulate: energy balance E - E0 - W = 0 held to a relative error of {:.2g} "
                     "(max |E - E0 - W| / {:.6g} J)\n",
                     tr.max_energy_error, tr.energy_scale);
}

// A CSV file that cannot be written fails before a long integration, not
// after it (an empty file stays until the results replace it; callers remove
// it when the integration fails).
void probe_output_file(const std::string& file) {
  if (file.empty()) return;
  std::ofstream probe(file, std::ios::binary);
  if (!probe) throw modal::ReportError(file + ": cannot open the file for writing");
}

int run_simulate(const SceneOptions& so, const SimulateArgs& a) {
  const modal::Scene scene = load(so);
  const modal::System sys = modal::build_system(scene);
  modal::VectorX q0 = a.at ? parse_point("--at", *a.at, sys) : sys.initial_configuration();
  if (!a.at && sys.has_constraints()) {
    // The scene's initial values are a guess for searches; a motion must start on the constraints.
    modal::Workspace ws(sys);
    const modal::ConstraintProjection p = modal::project_onto_constraints(sys, ws, q0);
    if (!(p.violation <= 1e-12 * sys.length_scale()))
      throw modal::NumericalError(fmt::format(
          "simulate: the initial configuration cannot be brought onto the constraints (‖c‖ = {:.3g} m remains); "
          "give a start with --at",
          p.violation));
    if ((p.q - q0).norm() > 0)
      std::cerr << "modal: the initial configuration was brought onto the constraints (moved by "
                << fmt::format("{:.3g}", (p.q - q0).norm()) << " in coordinate units)\n";
    q0 = p.q;
  }
  const modal::VectorX qd0 =
      a.velocity ? parse_point("--velocity", *a.velocity, sys) : modal::VectorX::Zero(sys.size());
  modal::SimulationOptions o;
  o.duration = a.duration;
  o.interval = a.interval.value_or(0.0);
  o.tolerance = a.tolerance;
  if (!std::isfinite(o.duration) || o.duration <= 0)
    throw InputError(fmt::format("--duration must be a finite number > 0 (seconds), got {:g}", o.duration));
  if (a.interval && !(std::isfinite(*a.interval) && *a.interval > 0))
    throw InputError(fmt::format("--interval must be a finite number > 0 (seconds), got {:g}", *a.interval));
  if (!(o.tolerance > 0 && o.tolerance < 1))
    throw InputError(fmt::format("--tolerance must lie in (0, 1), got {:g}", o.tolerance));
  probe_output_file(a.csv);
  modal::Trajectory tr;
  try {
    tr = modal::simulate(sys, q0, qd0, o);
  } catch (const std::invalid_argument& e) {
    if (!a.csv.empty()) std::remove(a.csv.c_str());  // no empty file left behind
    throw InputError(e.what());
  } catch (...) {
    if (!a.csv.empty()) std::remove(a.csv.c_str());
    throw;
  }
  if (a.csv.empty()) {
    modal::write_trajectory_csv(std::cout, tr);
    std::cout.flush();
  } else {
    std::ostringstream text;
    modal::write_trajectory_csv(text, tr);
    modal::write_text_file(a.csv, text.str());
  }
  print_simulation_summary(std::cerr, tr, o);
  return ok;
}

// --- amplitude -----------------------------------------------------------------

struct AmplitudeArgs {
  int mode = 1;
  std::optional<std::string> at;
  modal::AmplitudeOptions options;
  std::string csv;
};

// The largest scene `amplitude` integrates: each step solves with the dense M.
constexpr int amplitude_max_coordinates = 2000;

std::string amplitude_csv(const modal::AmplitudeResponse& r) {
  std::string out = "amplitude,oscillates,omega,omega_ratio_minus_1,spread,cycles,simulated_seconds\n";
  for (const modal::AmplitudePoint& p : r.points)
    out += fmt::format("{:.17g},{},{:.17g},{:.17g},{:.17g},{},{:.17g}\n", p.amplitude, p.oscillates ? 1 : 0,
                       p.omega, p.shift, p.spread, p.cycles, p.seconds);
  return out;
}

int run_amplitude(const SceneOptions& so, const AmplitudeArgs& a) {
  if (!std::is_sorted(a.options.amplitudes.begin(), a.options.amplitudes.end()))
    throw InputError("--amplitudes must be given in ascending order");
  const modal::Scene scene = load(so);
  const modal::System sys = modal::build_system(scene);
  if (sys.size() > amplitude_max_coordinates)
    throw InputError(fmt::format("amplitude integrates the nonlinear equations with a dense mass matrix; this scene "
                                 "has {} coordinates, more than the {} supported",
                                 sys.size(), amplitude_max_coordinates));
  const modal::Equilibrium eq = !a.at ? modal::find_equilibrium(sys, sys.initial_configuration())
                                      : equilibrium_at(sys, parse_point("--at", *a.at, sys));
  const modal::LinearModel lin = modal::linearize(sys, eq.q);
  if (!lin.symmetric())
    throw InputError("amplitude measures the frequency of an undamped mode (K φ = λ M φ); this scene has dampers, "
                     "gyroscopic terms or follower loads, whose modes are not periodic motions");
  const modal::ModalResult modes = modal::solve_modes(lin);
  if (a.mode < 1 || a.mode > static_cast<int>(modes.modes.size()))
    throw InputError(fmt::format("--mode {}: the scene has modes 1 to {}", a.mode, modes.modes.size()));
  const modal::Mode& m = modes.modes[static_cast<std::size_t>(a.mode - 1)];
  if (m.kind != modal::ModeKind::oscillatory)
    throw InputError(fmt::format("--mode {}: it is {} (omega^2 = {:.6g} rad2/s2): there is no oscillation whose "
                                 "frequency could be measured",
                                 a.mode, m.kind == modal::ModeKind::zero ? "a zero mode" : "a divergent mode",
                                 m.omega2));
  probe_output_file(a.csv);
  modal::AmplitudeResponse r;
  try {
    r = modal::amplitude_response(sys, eq.q, m.shape.real(), m.omega, a.options);
  } catch (...) {
    if (!a.csv.empty()) std::remove(a.csv.c_str());  // no empty file left behind
    throw;
  }

  const char* unit = r.kind == modal::CoordinateKind::length ? "m" : "rad";
  std::cout << fmt::format("{}\nscene: {}\n\nMode {}: omega_lin = {:.10g} rad/s (omega^2 = {:.10g} rad2/s2), "
                           "released from rest at the equilibrium plus amplitude × the shape, its largest component "
                           "'{}' = amplitude [{}]\n\n",
                           sys.title(), scene.file, a.mode, r.omega_linear, m.omega2, r.coordinate, unit);
  std::cout << fmt::format("  {:>16}  {:>18}  {:>14}  {:>9}  {:>6}\n", fmt::format("amplitude [{}]", unit),
                           "omega [rad/s]", "omega/lin - 1", "spread", "cycles");
  for (const modal::AmplitudePoint& p : r.points) {
    if (p.oscillates)
      std::cout << fmt::format("  {:>16.8g}  {:>18.12g}  {:>14.6e}  {:>9.1e}  {:>6}\n", p.amplitude, p.omega, p.shift,
                               p.spread, p.cycles);
    else
      std::cout << fmt::format("  {:>16.8g}  does not return through the equilibrium within {:.4g} s: the motion "
                               "has left the well\n",
                               p.amplitude, p.seconds);
  }
  std::cout << '\n';
  for (const modal::AmplitudeThreshold& t : r.thresholds) {
    const std::string level = fmt::format("{:g} %", 100 * t.level);
    if (t.reached && t.note.empty())
      std::cout << fmt::format("Frequency departs by {} at amplitude {:.8g} ± {:.1e} {}\n", level, t.amplitude,
                               t.error, unit);
    else if (t.reached)
      std::cout << fmt::format("Frequency departs by {} at amplitude ≤ {:.8g} {}: {}\n", level, t.amplitude, unit,
                               t.note);
    else
      std::cout << fmt::format("Frequency departs by {}: {}\n", level, t.note);
  }
  std::cout << fmt::format("({} motions integrated, rk8pd at tolerance {:g}; spread: largest deviation of one "
                           "period from their mean, the uncertainty of omega where modes exchange energy)\n",
                           r.evaluations, a.options.tolerance);
  std::cout.flush();
  if (!a.csv.empty()) modal::write_text_file(a.csv, amplitude_csv(r));
  return ok;
}

}  // namespace

int main(int argc, char** argv) {
  tune_allocator(argv);
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
  analyze->add_flag("--timing", timing, "print the wall time of each stage and the peak memory on stderr");
  SolverChoice solver_choice;
  analyze->add_option("--solver", solver_choice.solver,
                      "eigen-solver: dense (all modes), sparse (the --modes lowest, default 10, by shift-invert "
                      "Lanczos with a sparse Cholesky), or auto: sparse above " +
                          std::to_string(modal::large_system_coordinates) +
                          " coordinates when the scene has no dampers, follower loads, constraints, rotating frame "
                          "or map")
      ->check(CLI::IsMember({"auto", "dense", "sparse"}))
      ->capture_default_str();
  analyze->add_option("--shift", solver_choice.shift,
                      "sparse solver: find the modes with ω² nearest this shift (rad²/s²; default: the lowest)");
  analyze->add_option("--tol", solver_choice.tolerance, "sparse solver: relative convergence tolerance")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  analyze->add_option("--large-equilibrium", solver_choice.large_equilibrium,
                      "equilibrium of a scene above " + std::to_string(modal::large_system_coordinates) +
                          " coordinates: newton (truncated Newton from the start with the sparse Hessian; L-BFGS if "
                          "it stalls) or lbfgs (L-BFGS down to 1e-4 of the starting gradient first, then Newton)")
      ->check(CLI::IsMember({"newton", "lbfgs"}))
      ->capture_default_str();
  analyze
      ->add_option("--dense-solver", solver_choice.dense_solver,
                   "dense symmetric eigen-solver: eigen (self-adjoint QR), lapack (dsygvd, divide and conquer), or "
                   "auto: lapack from " + std::to_string(modal::lapack_threshold) + " coordinates")
      ->check(CLI::IsMember({"auto", "eigen", "lapack"}))
      ->capture_default_str();
  analyze
      ->add_option("--derivatives", solver_choice.derivatives,
                   "how K (and G) are differentiated: exact (automatic differentiation), central, forward "
                   "(differences of the exact forces) or complex-step; dense path only")
      ->check(CLI::IsMember({"exact", "central", "forward", "complex-step"}))
      ->capture_default_str();
  analyze
      ->add_option("--step", solver_choice.step_factor,
                   "difference step as a factor of max(|q|, 1 rad or the length scale) (default: sqrt(eps) "
                   "forward, cbrt(eps) central, 1e-20 complex-step)")
      ->check(CLI::PositiveNumber);
  analyze
      ->add_option("--eq-tol", solver_choice.equilibrium_tolerance,
                   "equilibrium: accepted relative residual |grad V - Q| / force scale")
      ->check(CLI::Range(1e-16, 1e-2))
      ->capture_default_str();
  analyze->add_option("--export-matrices", solver_choice.export_dir,
                      "write M, K (and D, G where present) at the equilibrium as Matrix Market files into DIR")
      ->type_name("DIR");

  CLI::App* equilibria = app.add_subcommand(
      "equilibria", "enumerate equilibria with their stability and Morse index");
  add_scene_options(equilibria, equilibria_scene);
  equilibria->add_option("--starts", starts, "number of deterministic search starts")
      ->check(CLI::NonNegativeNumber);
  equilibria->add_option("--csv", equilibria_csv, "write the equilibria table as CSV")->type_name("FILE");
  equilibria->add_option("--json", equilibria_json, "write all equilibria and their modes as JSON")
      ->type_name("FILE");

  SceneOptions sweep_scene;
  std::vector<std::string> varies;
  std::string sweep_csv;
  int sweep_modes = -1;
  CLI::App* sweep = app.add_subcommand(
      "sweep",
      "frequencies and stability along a parameter, critical values refined; two --vary: a stability map");
  add_scene_options(sweep, sweep_scene);
  sweep->add_option("--vary", varies,
                    "vary a parameter over COUNT evenly spaced values (COUNT >= 2) or over a list of values "
                    "(N=10,20,40); give it twice for a map")
      ->type_name("N=FROM:TO:COUNT|N=V1,V2,...")
      ->required()
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sweep->add_option("--csv", sweep_csv,
                    "one --vary: one row per point and mode, critical values to FILE_critical.csv; "
                    "two: one row per grid point")
      ->type_name("FILE");
  sweep->add_option("--modes", sweep_modes,
                    "number of lowest modes per point in the CSV (default: all), and extrapolated (default: 3)")
      ->check(CLI::PositiveNumber);
  bool sweep_extrapolate = false;
  sweep->add_flag("--extrapolate", sweep_extrapolate,
                  "the parameter is a number of links or elements (integers, at least 3 values): report each "
                  "mode's observed order of convergence and its Richardson-extrapolated frequency with an error "
                  "estimate; with --csv also FILE_convergence.csv and FILE_extrapolation.csv");

  CLI::App* check = app.add_subcommand("check", "validate the scene and print a summary");
  add_scene_options(check, check_scene);
  bool check_all = false;
  check->add_flag("--all", check_all, "list every body, coordinate and spring (default: the first 100 of each)");

  SceneOptions simulate_scene;
  SimulateArgs simulate_args;
  std::string simulate_at, simulate_velocity;
  double simulate_interval = 0;
  CLI::App* simulate = app.add_subcommand(
      "simulate",
      "integrate the nonlinear equations of motion from the initial configuration (or --at) and write the "
      "trajectory with its energy as CSV");
  add_scene_options(simulate, simulate_scene);
  simulate->add_option("--duration", simulate_args.duration, "end time of the motion, s")
      ->type_name("T")
      ->required();
  CLI::Option* simulate_at_option = simulate->add_option(
      "--at", simulate_at, "initial configuration q1,q2,... (taken as given; default: the scene's initial values)");
  CLI::Option* simulate_velocity_option =
      simulate->add_option("--velocity", simulate_velocity, "initial velocities v1,v2,... (default: 0)");
  CLI::Option* simulate_interval_option =
      simulate->add_option("--interval", simulate_interval, "spacing of the output samples, s (default: T/1000)")
          ->type_name("DT");
  simulate
      ->add_option("--tolerance", simulate_args.tolerance,
                   fmt::format("error bound per integration step, relative and absolute (default: {:g})",
                               modal::SimulationOptions{}.tolerance))
      ->type_name("TOL");
  simulate->add_option("--csv", simulate_args.csv, "write the trajectory to FILE instead of standard output")
      ->type_name("FILE");

  SceneOptions amplitude_scene;
  AmplitudeArgs amplitude_args;
  std::string amplitude_at;
  CLI::App* amplitude = app.add_subcommand(
      "amplitude",
      "release a mode from rest at growing amplitudes, integrate the nonlinear equations and measure its frequency: "
      "where does the linear model stop holding?");
  add_scene_options(amplitude, amplitude_scene);
  amplitude->add_option("--mode", amplitude_args.mode, "the mode (1 = the lowest)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  CLI::Option* amplitude_at_option =
      amplitude->add_option("--at", amplitude_at, "the equilibrium near this point: q1,q2,... (default: the initial one)");
  amplitude
      ->add_option("--amplitudes", amplitude_args.options.amplitudes,
                   "amplitudes to measure, ascending, in the unit of the shape's largest component (rad or m)")
      ->delimiter(',')
      ->check(CLI::PositiveNumber);
  amplitude
      ->add_option("--max-amplitude", amplitude_args.options.max_amplitude,
                   "largest amplitude of the default scan (default: 2.5 rad, or half the length scale)")
      ->check(CLI::PositiveNumber);
  amplitude->add_option("--points", amplitude_args.options.points, "amplitudes in the default scan (log-spaced)")
      ->capture_default_str()
      ->check(CLI::Range(2, 1000));
  amplitude->add_option("--cycles", amplitude_args.options.cycles, "periods measured per amplitude")
      ->capture_default_str()
      ->check(CLI::Range(1, 10000));
  amplitude->add_option("--tolerance", amplitude_args.options.tolerance, "integrator error bound per step")
      ->capture_default_str()
      ->check(CLI::Range(1e-15, 1e-3));
  amplitude->add_option("--csv", amplitude_args.csv, "write the scan as CSV")->type_name("FILE");

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
      return run_analyze(analyze_scene, modes, at_option->count() ? std::optional<std::string>(at) : std::nullopt, analyze_csv, analyze_json, require_stable, timing, solver_choice);
    if (*equilibria) return run_equilibria(equilibria_scene, starts, equilibria_csv, equilibria_json);
    if (*check) return run_check(check_scene, check_all);
    if (*sweep) return run_sweep(sweep_scene, varies, sweep_csv, sweep_modes, sweep_extrapolate);
    if (*amplitude) {
      if (amplitude_at_option->count()) amplitude_args.at = amplitude_at;
      return run_amplitude(amplitude_scene, amplitude_args);
    }
    if (*simulate) {
      if (simulate_at_option->count()) simulate_args.at = simulate_at;
      if (simulate_velocity_option->count()) simulate_args.velocity = simulate_velocity;
      if (simulate_interval_option->count()) simulate_args.interval = simulate_interval;
      return run_simulate(simulate_scene, simulate_args);
    }
    return usage;
  } catch (const modal::SceneError& e) {
    std::cerr << e.what() << '\n';
    return bad_input;
  } catch (const modal::SweepInputError& e) {
    std::cerr << "modal: " << e.what() << '\n';
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
