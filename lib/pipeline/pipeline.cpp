// lib/pipeline/pipeline.cpp — the whole pipeline behind one header
// (modal/pipeline.hpp): what every `modal` subcommand computes and writes.
#include "modal/pipeline.hpp"
#include "modal/expression.hpp"
#include "modal/energy.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <chrono>
#include <filesystem>
#include <cmath>
#include <new>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

namespace modal {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point& last) {
  const Clock::time_point now = Clock::now();
  const double s = std::chrono::duration<double>(now - last).count();
  last = now;
  return s;
}

std::string join_names(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

std::string format_point(const std::vector<std::string>& names, const VectorX& q) {
  std::string out;
  for (Eigen::Index i = 0; i < q.size(); ++i)
    out += fmt::format("{}{} = {:.10g}", i ? ", " : "", names[static_cast<std::size_t>(i)], q[i]);
  return out;
}

std::vector<ParameterOverride> parse_overrides(const std::vector<std::string>& set) {
  std::vector<ParameterOverride> overrides;
  overrides.reserve(set.size());
  for (const std::string& text : set) overrides.push_back(parse_override(text));
  return overrides;
}

// SceneError at the limited joint's place in the file the user gave (a
// converted model's: the joint's element) when an equilibrium has an active limit.
void refuse_active_limits(const Model& model, const Equilibrium& e) {
  const std::string why = active_limit(model.system, e);
  if (why.empty()) {
    if (model.imported) check_imported_configuration(*model.imported, model.system, e.q);  // contacts, ball limits
    return;
  }
  const auto b = static_cast<std::size_t>(std::find_if(e.limits.begin(), e.limits.end(), [](const JointLimitState& l) {
                                            return l.active();
                                          })->body);
  const SourceLocation where =
      b < model.scene.body_locations.size() ? model.scene.body_locations[b] : SourceLocation{model.scene.file, 0, 0};
  throw SceneError(where, model.format == SceneFormat::urdf ? "limit" : "range",
                   why + "; widen or remove the range, or look for an equilibrium inside it (--at, `modal equilibria`)");
}

// The equilibrium at a point the user gave (polished), or InputError saying
// how far it is from one and where the nearest is.
Equilibrium equilibrium_at(const System& sys, const VectorX& at, const EquilibriumOptions& options) {
  constexpr double accept = 1e-3;  // configuration distance (angles mod 2π, lengths / length scale)
  const auto names = sys.coordinate_names();
  if (at.size() != sys.size())
    throw InputError(fmt::format("--at expects {} values ({}), got {}", sys.size(), join_names(names), at.size()));
  std::optional<Equilibrium> e = polish_equilibrium(sys, at, options);
  if (e && configuration_distance(sys, e->q, at) <= accept) return *e;

  Workspace ws(sys);
  const VectorX residual = equilibrium_residual(sys, ws, at);
  const double relative = relative_residual_if_scaled(sys, ws, at, residual).value_or(residual.norm());
  std::string nearest;
  if (e) {
    nearest = fmt::format("nearest equilibrium found at {}", format_point(names, e->q));
  } else {
    try {
      const Equilibrium f = find_equilibrium(sys, at, options);
      nearest = fmt::format("nearest equilibrium found at {}", format_point(names, f.q));
    } catch (const NumericalError& ex) {
      nearest = fmt::format("no equilibrium found near it ({})", ex.what());
    }
  }
  throw InputError(fmt::format("--at: the point is not an equilibrium (relative residual {:.3g}); {}", relative,
                               nearest));
}

// "the dense analysis of 2352 coordinates": what a memory estimate of an
// analysis on `path` is for, in the refusals and out-of-memory reports.
std::string analysis_words(const char* path, const System& sys) {
  return fmt::format("the {} analysis of {} coordinates", path, sys.size());
}

// The documented rule (SolverChoice): sparse for more than
// large_system_coordinates coordinates when the sparse model describes the
// scene, else dense; the matrix-free path for large trees it describes whose
// matrices fill in; and automatically another path when the preferred one
// would not fit in memory (`limit`, SceneLimits::memory) and the other would.
// A path that does not fit is refused before anything is allocated
// (InputError, exit 2).
enum class Path { dense, sparse, tree };
Path choose_path(const System& sys, SolverChoice choice, double limit, int modes) {
  const auto why = sparse_unsupported(sys);
  const auto why_tree = tree_pencil_unsupported(sys);
  if (choice == SolverChoice::sparse && why)
    throw InputError("--solver sparse: the sparse solver does not apply to this scene: " + *why);
  if (choice == SolverChoice::tree && why_tree)
    throw InputError("--solver tree: the matrix-free path does not apply to this scene: " + *why_tree);
  const auto dense_refusal = [&] {
    return memory_refusal(dense_analysis_memory(sys), analysis_words("dense", sys), limit);
  };
  const auto sparse_refusal = [&] {
    return memory_refusal(
        sparse_analysis_memory(sys),
        analysis_words("sparse", sys) + fmt::format(" ({:.3g} coupled coordinate pairs)", coupled_pairs(sys)), limit);
  };
  const auto tree_refusal = [&] {
    return memory_refusal(tree_analysis_memory(sys, modes), analysis_words("matrix-free", sys), limit);
  };
  const auto refuse = [&](const std::string& reason, const std::string& advice) {
    throw InputError("this scene cannot be analyzed here: " + reason + advice);
  };
  if (choice == SolverChoice::dense) {
    if (const auto r = dense_refusal())
      refuse(*r, !why_tree      ? "; the matrix-free solver (--solver tree) fits"
                 : why || sparse_refusal() ? ""
                                           : "; the sparse solver (--solver sparse) fits");
    return Path::dense;
  }
  if (choice == SolverChoice::sparse) {
    if (const auto r = sparse_refusal()) refuse(*r, why_tree ? "" : "; the matrix-free solver (--solver tree) fits");
    return Path::sparse;
  }
  if (choice == SolverChoice::tree) {
    if (const auto r = tree_refusal()) refuse(*r, "");
    return Path::tree;
  }
  const double n = sys.size();
  if (!why_tree && sys.size() > large_system_coordinates && coupled_pairs(sys) > 64 * n && !tree_refusal())
    return Path::tree;
  const bool prefer_sparse = !why && sys.size() > large_system_coordinates;
  const auto preferred = prefer_sparse ? sparse_refusal() : dense_refusal();
  if (!preferred) return prefer_sparse ? Path::sparse : Path::dense;
  const auto other = why ? preferred : prefer_sparse ? dense_refusal() : sparse_refusal();
  if (!other) return prefer_sparse ? Path::dense : Path::sparse;
  if (!why_tree && !tree_refusal()) return Path::tree;
  refuse(*preferred, why ? "" : fmt::format("; the {} path would need about {}", prefer_sparse ? "dense" : "sparse",
                                            format_bytes(prefer_sparse ? dense_analysis_memory(sys)
                                                                       : sparse_analysis_memory(sys))));
  return Path::dense;
}

// What refused the memory: the address-space limit where one is set
// (ulimit -v, a batch system's h_vmem), else the machine.
std::string memory_refused_by() {
  if (const double limit = address_space_limit(); limit > 0)
    return "the process's address-space limit (ulimit -v) of " + format_bytes(limit) + " allowed";
  return "this machine could give it";
}

// Runs `work`, turning memory exhaustion into OutOfMemory with the estimate
// of what `what` was expected to need.
template <class Work>
auto within_estimate(double bytes, const std::string& what, Work&& work) {
  try {
    return work();
  } catch (const OutOfMemory&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw OutOfMemory(fmt::format("out of memory: {} was estimated to need about {} and needed more than {}", what,
                                  format_bytes(bytes), memory_refused_by()));
  }
}

// Exit status when no point of a sweep worked: the first failure says why.
template <class Points>
void require_some_point(const Points& points) {
  for (const auto& p : points)
    if (p.ok) return;
  if (points.empty()) return;
  const auto& first = points.front();
  if (first.scene_error) throw InputError("every point of the sweep failed; the first: " + first.failure);
  throw NumericalError("every point of the sweep failed; the first: " + first.failure);
}

// FILE.csv → FILE_<suffix>.csv (FILE → FILE_<suffix>.csv).
std::string suffixed_path(const std::string& csv, const std::string& suffix) {
  const std::string ext = ".csv";
  const bool has_ext = csv.size() > ext.size() && csv.compare(csv.size() - ext.size(), ext.size(), ext) == 0;
  return (has_ext ? csv.substr(0, csv.size() - ext.size()) : csv) + "_" + suffix + ".csv";
}

Outputs csv_only(const Outputs& o) {
  Outputs c;
  c.csv = o.csv;
  c.energy = o.energy;
  return c;
}

template <class Writer>
std::string to_text(Writer writer, const Report& report) {
  std::ostringstream out;
  writer(out, report);
  return out.str();
}

}  // namespace

// --- errors -------------------------------------------------------------------------

ExitStatus exit_status(const std::exception& error) {
  if (dynamic_cast<const SceneError*>(&error) || dynamic_cast<const SweepInputError*>(&error) ||
      dynamic_cast<const InputError*>(&error) || dynamic_cast<const ReportError*>(&error))
    return ExitStatus::bad_input;
  return ExitStatus::numerical;
}

namespace {
std::string raw_error_message(const std::exception& error) {
  if (dynamic_cast<const SceneError*>(&error)) return error.what();
  if (dynamic_cast<const OutOfMemory*>(&error)) return std::string("modal: ") + error.what();
  if (dynamic_cast<const std::bad_alloc*>(&error))
    return "modal: out of memory: the computation needed more memory than " + memory_refused_by();
  if (exit_status(error) == ExitStatus::bad_input) return std::string("modal: ") + error.what();
  return std::string("modal: numerical failure: ") + error.what();
}
}  // namespace

std::string abridged(const std::string& line) {
  constexpr std::size_t longest = 200;
  std::string out;
  for (std::size_t at = 0; at < line.size();) {
    const std::size_t blank = std::min(line.find(' ', at), line.size());
    const std::string_view word = std::string_view(line).substr(at, blank - at);
    out += word.size() > longest ? excerpt(word, 0, 80) + " (" + std::to_string(word.size()) + " characters)"
                                 : std::string(word);
    if (blank < line.size()) out += ' ';
    at = blank + 1;
  }
  return out;
}

std::string error_message(const std::exception& error) {
  // No control character of a user's text reaches the terminal; the line
  // breaks of a message of several lines are kept; a text quoted whole is cut.
  const std::string raw = raw_error_message(error);
  std::string message;
  for (std::size_t from = 0;;) {
    const std::size_t end = raw.find('\n', from);
    message += abridged(printable(std::string_view(raw).substr(from, end == std::string::npos ? end : end - from)));
    if (end == std::string::npos) return message;
    message += '\n';
    from = end + 1;
  }
}

double parse_memory_size(const std::string& text) {
  std::size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  const std::string unit = text.substr(used);
  double factor = 0;
  for (const auto& [suffix, f] : {std::pair{"", 1.0}, std::pair{"k", 1e3}, std::pair{"K", 1e3}, std::pair{"M", 1e6},
                                  std::pair{"G", 1e9}, std::pair{"T", 1e12}})
    if (unit == suffix || unit == std::string(suffix) + "B") factor = f;
  if (used == 0 || factor == 0 || !std::isfinite(value) || !(value > 0))
    throw InputError("--max-memory must be a size such as 4G, 512M or a number of bytes, got '" + text + "'");
  return value * factor;
}

double simulation_memory(const System& system, double samples) {
  return dense_analysis_memory(system) + 32 * samples * (2.0 * system.size() + 4);
}

double sparse_analysis_memory(const System& system) { return 200 * coupled_pairs(system); }

double tree_analysis_memory(const System& system, int modes) {
  const double ncv = std::max(2.0 * std::max(modes, 10) + 1, 20.0);
  return 1500.0 * static_cast<double>(system.bodies().size()) + 8 * ncv * system.size();
}

// --- the model -------------------------------------------------------------------------

Model model_from_text(std::string text, const std::string& name, const std::vector<std::string>& set,
                      const SceneLimits& limits, SceneFormat format) {
  std::vector<ParameterOverride> overrides = parse_overrides(set);  // a bad --set before reading anything
  format = scene_format(name, text, format);
  ImportedScene imported;
  if (format != SceneFormat::toml) {
    imported = import_model(text, name, format);
    text = std::move(imported.toml);
  }
  Scene scene = [&] {
    try {
      return parse_scene(text, name, overrides, limits);
    } catch (const SceneError& e) {
      if (!imported.model) throw;
      // The converted text's lines are not the file's: a [[body]]'s error goes
      // to the element it comes from, anything else names the conversion.
      const std::string& key = e.key();
      if (key.rfind("body[", 0) == 0) {
        const std::size_t k = std::strtoul(key.c_str() + 5, nullptr, 10);
        if (k >= 1 && k <= imported.body_lines.size())
          throw SceneError({name, imported.body_lines[k - 1].second, 0}, key, e.reason());
      }
      throw SceneError({name + " as converted to TOML (`modal convert`)", e.where().line, e.where().column}, key,
                       e.reason());
    }
  }();
  if (imported.model) {  // messages about a body point into the file the user gave
    std::unordered_map<std::string, int> lines(imported.body_lines.begin(), imported.body_lines.end());
    for (std::size_t b = 0; b < scene.description.bodies.size() && b < scene.body_locations.size(); ++b) {
      const auto found = lines.find(scene.description.bodies[b].name);
      scene.body_locations[b] = {name, found != lines.end() ? found->second : 0, 0};
    }
  }
  System system = build_system(scene);
  return Model{std::move(text), std::move(overrides), std::move(scene), std::move(system), limits, format,
               std::move(imported.model)};
}

Model load_model(const std::string& path, const std::vector<std::string>& set, const SceneLimits& limits,
                 SceneFormat format) {
  parse_overrides(set);  // a bad --set before reading anything
  return model_from_text(read_scene_file(path), path, set, limits, format);
}

std::string convert_scene(const std::string& path, SceneFormat format) {
  std::string text = read_scene_file(path);
  format = scene_format(path, text, format);
  return format == SceneFormat::toml ? text : import_scene(text, path, format);
}

VectorX parse_coordinates(const System& sys, const std::string& option, const std::string& text) {
  const auto names = sys.coordinate_names();
  const std::string expected = fmt::format("{} expects {} comma-separated number{} ({})", option, names.size(),
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
  if (values.size() != names.size()) throw InputError(fmt::format("{}; got {}", expected, values.size()));
  return Eigen::Map<const VectorX>(values.data(), static_cast<Eigen::Index>(values.size()));
}

// --- analyze ---------------------------------------------------------------------------

const char* to_string(SolverChoice choice) {
  switch (choice) {
    case SolverChoice::automatic: return "auto";
    case SolverChoice::dense: return "dense";
    case SolverChoice::sparse: return "sparse";
    case SolverChoice::tree: return "tree";
  }
  return "?";
}

bool Analysis::unstable() const {
  const Stability s = result().stability;
  return s == Stability::divergence || s == Stability::flutter;
}

Analysis analyze(const Model& model, const AnalysisOptions& options) {
  const System& sys = model.system;
  Analysis a;
  Clock::time_point last = Clock::now();

  EquilibriumOptions eo;
  eo.tolerance = options.equilibrium_tolerance;
  eo.large_method = options.large_equilibrium;
  eo.memory_limit = model.limits.memory;
  eo.progress = options.progress;
  if (options.step_factor > 0 && options.derivatives == DerivativeMethod::exact)
    throw InputError("--step sets the step of differences: give --derivatives central, forward or complex-step");
  if (!(options.step_factor >= 0 && options.step_factor <= max_step_factor))
    throw InputError(fmt::format("--step {:g}: the step factor must be above 0 and at most {:g} (a tenth of a radian "
                                 "or of the scene's length scale); larger steps do not measure a derivative",
                                 options.step_factor, max_step_factor));
  if (options.step_factor > 0 && options.step_factor < min_difference_step_factor &&
      (options.derivatives == DerivativeMethod::central || options.derivatives == DerivativeMethod::forward))
    throw InputError(fmt::format("--step {:g}: a difference step below {:g} (the spacing of doubles near 1) vanishes "
                                 "against a coordinate away from 0 (q + h = q), and the difference is 0/0; the default "
                                 "{:.1e} balances truncation against rounding",
                                 options.step_factor, min_difference_step_factor, default_step_factor(options.derivatives)));
  if (options.derivatives == DerivativeMethod::complex_step && sys.is_map())
    throw InputError("--derivatives complex-step: not available for kinematic maps (their expressions are "
                     "evaluated in real arithmetic); use exact, central or forward");
  LinearizeOptions lo;
  lo.derivatives = options.derivatives;
  lo.step_factor = options.step_factor;
  // An equilibrium accepted at a looser tolerance is accepted by the linearization too.
  lo.tolerance = std::max(lo.tolerance, options.equilibrium_tolerance);
  const Path path = choose_path(sys, options.solver, model.limits.memory, options.modes);
  const bool sparse = path == Path::sparse;
  const char* path_name = path == Path::tree ? "matrix-free" : sparse ? "sparse" : "dense";
  if (path != Path::dense && options.derivatives != DerivativeMethod::exact)
    throw InputError(std::string("--derivatives ") + to_string(options.derivatives) + ": the " + path_name +
                     " path assembles K exactly from the elements' derivatives; differences apply to the dense path "
                     "(--solver dense)");
  if (path == Path::dense && options.shift)
    throw InputError("--shift applies to the sparse solver and the matrix-free one (--solver sparse or tree)");
  const double estimate = path == Path::tree ? tree_analysis_memory(sys, options.modes)
                          : sparse          ? sparse_analysis_memory(sys)
                                            : dense_analysis_memory(sys);
  return within_estimate(estimate, analysis_words(path_name, sys), [&] {

  const Equilibrium eq = !options.at ? find_equilibrium(sys, sys.initial_configuration(), eo)
                                     : equilibrium_at(sys, *options.at, eo);
  a.timings.emplace_back("equilibrium", seconds_since(last));
  refuse_active_limits(model, eq);
  ModalResult result;
  // The dense path: linearize (in the absolute angles of parallel hinges
  // where the scene has them) and solve_modes.
  const auto solve_dense = [&] {
    a.linear = linearize(sys, eq.q, lo);
    a.timings.emplace_back("linearize", seconds_since(last));
    const LinearModel& lin = *a.linear;
    ModalOptions mo;
    mo.modes = options.modes;
    mo.dense_solver = options.dense_solver;
    ModalResult dense = solve_modes(lin, mo);
    if (lo.derivatives != DerivativeMethod::exact)
      dense.notes.push_back(fmt::format(
          "K{} by {} differences (step factor {:.2g}) instead of exact derivatives; the error estimates include "
          "their error, measured from K at h, 2h and 4h (largest {:.2g})",
          lin.has_gyroscopic ? " and G" : "", to_string(lo.derivatives),
          lo.step_factor > 0 ? lo.step_factor : default_step_factor(lo.derivatives),
          lin.K_error.cwiseAbs().maxCoeff()));
    a.timings.emplace_back("eigen", seconds_since(last));
    return dense;
  };
  if (path == Path::tree) {
    // K and M in their ordered form (O(bodies)); the equilibrium was found to
    // the tolerance the linearization would check.
    Workspace w(sys);
    a.tree = tree_pencil(sys, w, eq.q);
    a.timings.emplace_back("assembly", seconds_since(last));
    SparseModalOptions so;
    if (options.modes > 0) so.modes = options.modes;
    so.shift = options.shift;
    so.tolerance = options.tolerance;
    so.inertia_scale = inertia_scale(sys, w, eq.q);
    so.memory_limit = model.limits.memory;
    so.coordinate_names = sys.coordinate_names();
    try {
      result = solve_tree_modes(*a.tree, so);
      a.timings.emplace_back("eigen", seconds_since(last));
    } catch (const SingularMassMatrix& refused) {
      // The tree's factorization of M is in the model's (relative) joint
      // coordinates, unscaled within a path: a chain of links graded over
      // decades can lose M's definiteness there in rounding, though M is
      // positive definite (docs/design.md, "Matrix-free path"). Where the
      // path was the automatic choice and the dense one fits, that one
      // decides: it equilibrates M and solves chains of parallel hinges in
      // their absolute angles, and where M is singular there too it names
      // the directions without inertia.
      // Its memory is the dense analysis's (within_estimate names that one,
      // not the matrix-free estimate, if it runs out).
      const double dense_bytes = dense_analysis_memory(sys);
      const bool dense_fits = !memory_refusal(dense_bytes, "", model.limits.memory);
      if (options.solver != SolverChoice::automatic || options.shift || !dense_fits) throw;
      a.tree.reset();
      a.timings.emplace_back("eigen (matrix-free, refused)", seconds_since(last));
      result = within_estimate(dense_bytes, analysis_words("dense", sys), solve_dense);
      result.notes.insert(result.notes.begin(),
                          fmt::format("solved on the dense path: the matrix-free path, chosen for its {} coordinates, "
                                      "refused the mass matrix ({})",
                                      sys.size(), refused.what()));
    }
  } else if (sparse) {
    a.sparse = linearize_sparse(sys, eq.q, lo);
    a.timings.emplace_back("assembly", seconds_since(last));
    SparseLinearModel& lin = *a.sparse;
    SparseModalOptions so;
    if (options.modes > 0) so.modes = options.modes;
    so.shift = options.shift;
    so.tolerance = options.tolerance;
    so.fill_reducing_order = eq.fill_reducing_order;  // ∇∇V's analysis, same pattern as K − σM
    so.memory_limit = model.limits.memory;
    // The estimates' parts of K's error: its systematic error, its rounding
    // where a spring's terms cancel, a loose equilibrium's share. Each of K's
    // size, lent to the solver and given back, not copied (an exception
    // discards the analysis).
    so.K_systematic_error = std::move(lin.K_systematic_error);
    so.K_magnitude = std::move(lin.K_magnitude);
    so.K_rounding_form = std::move(lin.K_rounding_form);
    so.K_spring_rounding = std::move(lin.K_spring_rounding);
    so.K_equilibrium_shift = std::move(lin.K_equilibrium_shift);
    so.inertia_scale = lin.inertia_scale;
    so.coordinate_names = lin.coordinates;
    result = solve_sparse_modes(lin.K, lin.M, so);
    lin.K_systematic_error = std::move(so.K_systematic_error);
    lin.K_magnitude = std::move(so.K_magnitude);
    lin.K_rounding_form = std::move(so.K_rounding_form);
    lin.K_spring_rounding = std::move(so.K_spring_rounding);
    lin.K_equilibrium_shift = std::move(so.K_equilibrium_shift);
    if (lin.residual > EquilibriumOptions{}.tolerance && lin.K_equilibrium_shift.nonZeros() == 0)
      result.notes.push_back(fmt::format(
          "the equilibrium's relative residual {:.1e} is above the rounding level, and the error it causes "
          "(K differs from K at the equilibrium) is not in the estimates: the sparse path takes it only above {:g}, "
          "where a factorization of K is worth it; tighten --eq-tol, or --solver dense includes it",
          lin.residual, sparse_equilibrium_correction_residual));
    for (const auto& [phase, seconds] : result.timings) a.timings.emplace_back("  " + phase, seconds);
    a.timings.emplace_back("eigen", seconds_since(last));
  } else {
    result = solve_dense();
  }
  std::optional<EnergyDistribution> energy;
  if (options.energy) {
    if (a.linear) {
      energy = energy_distribution(sys, *a.linear, result);
    } else if (a.sparse) {
      energy = energy_distribution(sys, *a.sparse, result);
    } else {  // matrix-free: the distribution of a tree needs the equilibrium only
      SparseLinearModel at;
      at.q = eq.q;
      energy = energy_distribution(sys, at, result);
    }
    a.timings.emplace_back("energy", seconds_since(last));
  }
  std::optional<SceneDrawing> drawing;
  if (options.drawing) {
    drawing = scene_drawing(sys, eq.q, result);
    a.timings.emplace_back("drawing", seconds_since(last));
  }
  a.report = make_report(sys, model.scene.file, model.scene.parameters);
  a.report.data_files = model.scene.data_files;
  a.report.equilibria.push_back({eq, std::move(result), std::move(energy), std::move(drawing)});
  return std::move(a);  // a is the caller's, captured by reference: not copied
  });
}

// --- equilibria --------------------------------------------------------------------------

EquilibriumSurvey equilibria(const Model& model, const EquilibriumOptions& options) {
  const System& sys = model.system;
  EquilibriumSurvey survey;
  survey.report = make_report(sys, model.scene.file, model.scene.parameters);
  survey.report.data_files = model.scene.data_files;
  const auto names = sys.coordinate_names();
  if (!sys.has_constraints() && sys.size() > large_system_coordinates)  // a documented limit, not a numerical failure
    throw InputError(fmt::format("equilibria: the multi-start search for all equilibria is for scenes of at most {} "
                                 "coordinates (its Newton steps are dense); this one has {}: `modal analyze` finds "
                                 "the equilibrium nearest the initial configuration with sparse or matrix-free steps",
                                 large_system_coordinates, sys.size()));
  const std::vector<Equilibrium> found = find_equilibria(sys, options);
  std::optional<SceneError> first_refusal;  // an equilibrium at a limit or in contact
  for (const Equilibrium& e : found) {
    if (options.progress)  // the analyses, after the starts
      options.progress(static_cast<int>(&e - found.data()), static_cast<int>(found.size()));
    try {
      refuse_active_limits(model, e);
    } catch (const SceneError& refused) {
      survey.unanalyzed.push_back(fmt::format("an equilibrium at {} was found but is not analyzed: {}",
                                              format_point(names, e.q), refused.what()));
      if (!first_refusal) first_refusal = refused;
      continue;
    }
    try {
      survey.report.equilibria.push_back({e, solve_modes(linearize(sys, e.q)), std::nullopt, std::nullopt});
    } catch (const NumericalError& error) {
      survey.unanalyzed.push_back(fmt::format("an equilibrium at {} was found but cannot be analyzed: {}",
                                              format_point(names, e.q), error.what()));
    }
  }
  // Every equilibrium is at a stop or in contact: the model cannot be analyzed anywhere (exit status 2).
  if (survey.report.equilibria.empty() && first_refusal) throw *first_refusal;
  return survey;
}

// --- sweep ---------------------------------------------------------------------------------

SweepStudy sweep(const Model& model, const std::vector<SweepAxis>& axes, const SweepStudyOptions& options) {
  if (axes.empty() || axes.size() > 2)
    throw InputError(fmt::format("sweep takes one --vary (a sweep) or two (a stability map), got {}", axes.size()));
  if (options.extrapolate && axes.size() != 1)
    throw InputError("--extrapolate works along one --vary, not on a stability map");
  if (options.extrapolate) check_extrapolation_axis(axes[0]);  // before the sweep runs
  if (model.format != SceneFormat::toml && model.scene.parameters.empty())
    throw InputError(fmt::format("--vary: {} is an {} file, which has no parameters to vary; `modal convert {} -o "
                                 "scene.toml` writes it as a TOML scene in which numbers can be made [parameters]",
                                 model.scene.file, model.format == SceneFormat::urdf ? "URDF" : "MJCF",
                                 model.scene.file));
  if (!options.sweep.analyze_point)  // every point a dense analysis; a point that grows the scene is checked itself
    if (const auto r = memory_refusal(dense_analysis_memory(model.system),
                                      "each point of the sweep (" + analysis_words("dense", model.system) + ")",
                                      model.limits.memory))
      throw InputError("this sweep cannot run here: " + *r);
  SweepStudy study;
  study.scene_file = model.scene.file;
  study.data_files = model.scene.data_files;
  study.axes = axes;
  SweepOptions so = options.sweep;
  so.modes = options.modes;
  so.scene_limits = model.limits;
  study.tolerance = so.tolerance;
  if (axes.size() == 1) {
    study.result = modal::sweep(model.text, model.scene.file, model.overrides, axes[0], so);
    require_some_point(study.result->points);
    if (options.extrapolate) {
      constexpr int default_extrapolated_modes = 3;
      study.convergence =
          extrapolate_modes(*study.result, options.modes > 0 ? options.modes : default_extrapolated_modes);
    }
    return study;
  }
  study.map = sweep_map(model.text, model.scene.file, model.overrides, axes[0], axes[1], so);
  require_some_point(study.map->points);
  return study;
}

// --- simulate --------------------------------------------------------------------------------

Simulation simulate(const Model& model, const SimulationRequest& request) {
  const System& sys = model.system;
  Simulation s;
  s.title = sys.title();
  s.scene_file = model.scene.file;
  s.data_files = model.scene.data_files;
  s.options.duration = request.duration;
  s.options.interval = request.interval.value_or(0.0);
  s.options.tolerance = request.tolerance;
  s.options.progress = request.progress;
  if (!std::isfinite(request.duration) || request.duration <= 0)
    throw InputError(fmt::format("--duration must be a finite number > 0 (seconds), got {:g}", request.duration));
  if (request.interval && !(std::isfinite(*request.interval) && *request.interval > 0))
    throw InputError(fmt::format("--interval must be a finite number > 0 (seconds), got {:g}", *request.interval));
  if (!(request.tolerance >= min_simulation_tolerance && request.tolerance < 1))
    throw InputError(fmt::format("--tolerance must lie in [{:g}, 1), got {:g}: a per-step error bound below the "
                                 "rounding of a step cannot be met (the integrator only takes more steps)",
                                 min_simulation_tolerance, request.tolerance));
  for (const auto& [given, option] : {std::pair{&request.at, "--at"}, std::pair{&request.velocity, "--velocity"}})
    if (*given && (*given)->size() != sys.size())
      throw InputError(fmt::format("{} expects {} values ({}), got {}", option, sys.size(),
                                   join_names(sys.coordinate_names()), (*given)->size()));
  {
    const double interval = request.interval.value_or(request.duration / 1000);
    const double samples = std::floor(request.duration / interval) + 2;
    if (const auto r = memory_refusal(simulation_memory(sys, samples),
                                      fmt::format("the simulation of {} coordinates over {:.3g} samples", sys.size(),
                                                  samples),
                                      model.limits.memory))
      throw InputError("this simulation cannot run here: " + *r);
  }
  VectorX q0 = request.at ? *request.at : sys.initial_configuration();
  if (!request.at && sys.has_constraints()) {
    // The scene's initial values are a guess for searches; a motion must start on the constraints.
    Workspace ws(sys);
    const ConstraintProjection p = project_onto_constraints(sys, ws, q0);
    if (!(p.violation <= 1e-12 * sys.length_scale()))
      throw NumericalError(fmt::format(
          "simulate: the initial configuration cannot be brought onto the constraints (‖c‖ = {:.3g} m remains); "
          "give a start with --at",
          p.violation));
    if ((p.q - q0).norm() > 0)
      s.notes.push_back(fmt::format("the initial configuration was brought onto the constraints (moved by {:.3g} in "
                                    "coordinate units)",
                                    (p.q - q0).norm()));
    q0 = p.q;
  }
  const VectorX qd0 = request.velocity ? *request.velocity : VectorX::Zero(sys.size());
  try {
    s.trajectory = modal::simulate(sys, q0, qd0, s.options);
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  // modal models no stop: say where the motion leaves a joint's range.
  for (const JointLimitState& l : joint_limits(sys, q0)) {
    const Body& body = sys.bodies()[static_cast<std::size_t>(l.body)];
    for (std::size_t k = 0; k < s.trajectory.size(); ++k) {
      const double v = s.trajectory.q[k][l.coordinate];
      if (v > l.lower && v < l.upper) continue;
      s.notes.push_back(fmt::format("the joint of '{}' leaves its range [{:.10g}, {:.10g}] at t = {:.6g} s: modal "
                                    "models no stop, so from there on this is the motion without the limit",
                                    body.name, l.lower, l.upper, s.trajectory.time[k]));
      break;
    }
  }
  return s;
}

// --- amplitude -------------------------------------------------------------------------------

AmplitudeStudy amplitude(const Model& model, const AmplitudeRequest& request) {
  const System& sys = model.system;
  const auto& amplitudes = request.options.amplitudes;
  if (!std::is_sorted(amplitudes.begin(), amplitudes.end()))
    throw InputError("--amplitudes must be given in ascending order");
  if (sys.size() > amplitude_max_coordinates)
    throw InputError(fmt::format("amplitude integrates the nonlinear equations with a dense mass matrix; this scene "
                                 "has {} coordinates, more than the {} supported",
                                 sys.size(), amplitude_max_coordinates));
  const Equilibrium eq = !request.at ? find_equilibrium(sys, sys.initial_configuration())
                                     : equilibrium_at(sys, *request.at, EquilibriumOptions{});
  refuse_active_limits(model, eq);
  const LinearModel lin = linearize(sys, eq.q);
  if (!lin.symmetric())
    throw InputError("amplitude measures the frequency of an undamped mode (K φ = λ M φ); this scene has dampers, "
                     "gyroscopic terms or follower loads, whose modes are not periodic motions");
  const ModalResult modes = solve_modes(lin);
  if (request.mode < 1 || request.mode > static_cast<int>(modes.modes.size()))
    throw InputError(fmt::format("--mode {}: the scene has modes 1 to {}", request.mode, modes.modes.size()));
  const Mode& m = modes.modes[static_cast<std::size_t>(request.mode - 1)];
  if (m.kind != ModeKind::oscillatory)
    throw InputError(fmt::format("--mode {}: it is {} (omega^2 = {:.6g} rad2/s2): there is no oscillation whose "
                                 "frequency could be measured",
                                 request.mode, m.kind == ModeKind::zero ? "a zero mode" : "a divergent mode",
                                 m.omega2));
  AmplitudeStudy study;
  study.title = sys.title();
  study.scene_file = model.scene.file;
  study.data_files = model.scene.data_files;
  study.mode = request.mode;
  study.omega2 = m.omega2;
  study.tolerance = request.options.tolerance;
  study.response = amplitude_response(sys, eq.q, m.shape.real(), m.omega, request.options);
  return study;
}

// --- writing results -----------------------------------------------------------------------------

std::vector<std::string> output_files(Command command, const Outputs& o, bool extrapolate) {
  std::vector<std::string> files;
  if (!o.csv.empty()) {
    switch (command) {
      case Command::analyze:
        files = {o.csv + "_modes.csv", o.csv + "_shapes.csv", o.csv + "_equilibria.csv"};
        if (o.energy) {
          files.push_back(o.csv + "_energy.csv");
          files.push_back(o.csv + "_participation.csv");
        }
        break;
      case Command::sweep:
        files = {o.csv, suffixed_path(o.csv, "critical")};
        if (extrapolate) {
          files.push_back(suffixed_path(o.csv, "convergence"));
          files.push_back(suffixed_path(o.csv, "extrapolation"));
        }
        break;
      default: files = {o.csv};
    }
  }
  if (!o.json.empty()) files.push_back(o.json);
  if (!o.report.empty()) files.push_back(o.report);
  return files;
}

void check_outputs(Command command, const Outputs& outputs, const std::string& scene_file, bool extrapolate) {
  check_outputs(command, outputs, scene_file, {}, extrapolate);
}

void check_outputs(Command command, const Outputs& outputs, const std::string& scene_file,
                   const std::vector<std::string>& data_files, bool extrapolate) {
  if (!outputs.report.empty()) {
    if (command == Command::check)
      throw InputError("--report: check prints a summary; HTML reports are written by analyze, equilibria, sweep, "
                       "amplitude and simulate");
    // A page a browser opens by its name: refused before computing, not renamed.
    const std::string extension = std::filesystem::path(outputs.report).extension().string();
    if (extension != ".html" && extension != ".htm")
      throw ReportError(outputs.report + ": --report writes an HTML page; give the file a name ending in .html (or .htm)");
  }
  if (command == Command::analyze && !outputs.csv.empty() && outputs.csv.back() == '/')
    throw ReportError(outputs.csv + ": --csv takes a prefix of the files' names, and this one ends in a directory "
                      "(the files would be named _modes.csv, _shapes.csv, … in it); give a prefix such as " +
                      (std::filesystem::path(outputs.csv) / "run").string() + " (run_modes.csv, …)");
  std::vector<std::string> inputs{scene_file};
  inputs.insert(inputs.end(), data_files.begin(), data_files.end());
  const std::vector<std::string> files = output_files(command, outputs, extrapolate);
  if (!outputs.matrices.empty()) {
    // A directory of files: not an input, not another output, not a file.
    std::vector<std::string> others = files;
    others.insert(others.end(), inputs.begin(), inputs.end());
    check_output_directory(outputs.matrices, others);
  }
  check_output_paths(files, inputs);
}

void check_outputs_spare_data(Command command, const Outputs& outputs, const std::vector<std::string>& data_files,
                              bool extrapolate) {
  if (data_files.empty()) return;
  check_not_inputs(output_files(command, outputs, extrapolate), data_files);
  if (!outputs.matrices.empty()) check_output_directory(outputs.matrices, data_files);
}

void write_analysis(std::ostream& text, const Analysis& a, const Outputs& o) {
  if (!o.matrices.empty() && a.tree)
    throw InputError("--export-matrices: the matrix-free path (--solver tree) forms no matrices; a chain of this "
                     "size has dense ones (--solver dense or sparse write them where they fit)");
  print_analysis(text, a.report);
  check_written(text, "standard output");
  OutputFiles files;  // the matrices too: all or none with the other files
  if (!o.matrices.empty()) {
    if (a.linear) add_matrix_exports(files, o.matrices, *a.linear);
    if (a.sparse) add_matrix_exports(files, o.matrices, *a.sparse);
  }
  if (!o.csv.empty()) {
    const std::vector<std::string> paths = output_files(Command::analyze, csv_only(o));
    files.add(paths[0], to_text(write_modes_csv, a.report));
    files.add(paths[1], to_text(write_shapes_csv, a.report));
    files.add(paths[2], to_text(write_equilibria_csv, a.report));
    if (o.energy) {
      if (!a.report.equilibria.front().energy)
        throw std::invalid_argument("write_analysis: outputs.energy asks for the energy files of an analysis made "
                                    "without AnalysisOptions::energy");
      files.add(paths[3], to_text(write_energy_csv, a.report));
      files.add(paths[4], to_text(write_participation_csv, a.report));
    }
  }
  if (!o.json.empty()) files.add(o.json, analysis_json(a.report));
  if (!o.report.empty()) files.add(o.report, analysis_html(a.report));
  files.commit();
}

void write_equilibria(std::ostream& text, const EquilibriumSurvey& survey, const Outputs& o) {
  print_equilibria(text, survey.report);
  check_written(text, "standard output");
  OutputFiles files;
  if (!o.csv.empty()) files.add(o.csv, to_text(write_equilibria_csv, survey.report));
  if (!o.json.empty()) files.add(o.json, equilibria_json(survey.report));
  if (!o.report.empty()) files.add(o.report, equilibria_html(survey.report, survey.unanalyzed));
  files.commit();
}

void write_sweep(std::ostream& text, const SweepStudy& study, const Outputs& o) {
  OutputFiles files;
  if (study.result) {
    const SweepResult& r = *study.result;
    print_sweep(text, r, study.scene_file, study.tolerance);
    const bool extrapolated = !study.convergence.empty();
    if (extrapolated) print_extrapolation(text, r, study.convergence);
    if (!o.csv.empty()) {
      const std::vector<std::string> paths = output_files(Command::sweep, csv_only(o), extrapolated);
      files.add(paths[0], sweep_modes_csv(r));
      files.add(paths[1], sweep_critical_csv(r));
      if (extrapolated) {
        files.add(paths[2], convergence_csv(r, study.convergence));
        files.add(paths[3], extrapolation_csv(study.convergence));
      }
    }
    if (!o.report.empty()) files.add(o.report, sweep_html(r, study.scene_file, study.tolerance, study.convergence));
  } else if (study.map) {
    print_map(text, *study.map, study.scene_file);
    if (!o.csv.empty()) files.add(o.csv, map_csv(*study.map));
    if (!o.report.empty()) files.add(o.report, map_html(*study.map, study.scene_file));
  }
  check_written(text, "standard output");
  files.commit();
}

void write_amplitude(std::ostream& text, const AmplitudeStudy& study, const Outputs& o) {
  print_amplitude(text, study.title, study.scene_file, study.mode, study.omega2, study.response, study.tolerance);
  check_written(text, "standard output");
  OutputFiles files;
  if (!o.csv.empty()) files.add(o.csv, amplitude_csv(study.response));
  if (!o.report.empty())
    files.add(o.report, amplitude_html(study.title, study.scene_file, study.mode, study.omega2, study.response,
                                       study.tolerance));
  files.commit();
}

void write_simulation(std::ostream& text, const Simulation& s, const Outputs& o) {
  OutputFiles files;
  if (o.csv.empty()) {
    write_trajectory_csv(text, s.trajectory);
    check_written(text, "standard output");
  } else {
    std::ostringstream csv;
    write_trajectory_csv(csv, s.trajectory);
    files.add(o.csv, csv.str());
  }
  if (!o.report.empty()) files.add(o.report, simulation_html(s.trajectory, s.options, s.title, s.scene_file, s.notes));
  files.commit();
}

void write_summary(std::ostream& text, const Model& model, std::size_t list_limit) {
  print_summary(text, model.scene.file, model.scene.parameters, model.system, list_limit);
  check_written(text, "standard output");
}

}  // namespace modal
