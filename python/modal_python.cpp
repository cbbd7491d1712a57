// python/modal_python.cpp — the extension module modal._modal: the pipeline
// API (modal/pipeline.hpp) for Python. The package modal (python/modal/) is
// the public face; it turns paths, TOML text and dicts into models and keyword
// options into the option values below, and re-exports the result types.
//
// Results are the library's own values, held by the Python objects; their
// properties build numpy arrays (dense matrices) and scipy.sparse matrices
// (the sparse path's M and K) on access, copies the caller owns. The heavy
// calls release the GIL. Errors become modal.Error and its subclasses (see
// translate() below), with the message the CLI prints and its exit status.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "modal/pipeline.hpp"

namespace py = pybind11;

namespace {

constexpr double not_a_number = std::numeric_limits<double>::quiet_NaN();

// --- exceptions -----------------------------------------------------------------
// The classes are made once by the module and kept for its lifetime (module
// objects are never unloaded in CPython).
struct ErrorClasses {
  PyObject* error = nullptr;            // modal.Error(Exception)
  PyObject* scene = nullptr;            // modal.SceneError(Error, ValueError)
  PyObject* input = nullptr;            // modal.InputError(Error, ValueError)
  PyObject* sweep_input = nullptr;      // modal.SweepInputError(InputError)
  PyObject* report = nullptr;           // modal.ReportError(Error, OSError)
  PyObject* numerical = nullptr;        // modal.NumericalError(Error, RuntimeError)
  PyObject* singular_mass = nullptr;    // modal.SingularMassMatrix(NumericalError)
  PyObject* not_equilibrium = nullptr;  // modal.NotAnEquilibrium(NumericalError)
};
ErrorClasses errors;

PyObject* make_error_class(py::module_& m, const char* name, const char* doc, py::tuple bases) {
  const std::string qualified = std::string("modal.") + name;
  PyObject* cls = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases.ptr(), nullptr);
  if (!cls) throw py::error_already_set();
  m.add_object(name, py::handle(cls));  // the module keeps a reference; so does `errors`
  return cls;
}

// Sets the Python error `cls(message)` with exit_status (and, for scene
// errors, the location) as attributes.
void set_error(PyObject* cls, const std::string& message, int status, const modal::SceneError* scene = nullptr) {
  py::object exc = py::reinterpret_borrow<py::object>(cls)(message);
  exc.attr("exit_status") = status;
  if (scene) {
    exc.attr("file") = scene->where().file;
    exc.attr("line") = scene->where().line > 0 ? py::object(py::int_(scene->where().line)) : py::none();
    exc.attr("column") = scene->where().column > 0 ? py::object(py::int_(scene->where().column)) : py::none();
    exc.attr("key") = scene->key();
    exc.attr("reason") = scene->reason();
  }
  PyErr_SetObject(cls, exc.ptr());
}

void translate(std::exception_ptr p) {
  if (!p) return;
  try {
    std::rethrow_exception(p);
  } catch (const py::builtin_exception&) {
    throw;  // pybind11's own (TypeError, IndexError, …): its default translation
  } catch (const std::bad_alloc&) {
    throw;  // MemoryError
  } catch (const modal::SceneError& e) {
    set_error(errors.scene, modal::error_message(e), static_cast<int>(modal::exit_status(e)), &e);
  } catch (const modal::SweepInputError& e) {
    set_error(errors.sweep_input, modal::error_message(e), static_cast<int>(modal::exit_status(e)));
  } catch (const modal::InputError& e) {
    set_error(errors.input, modal::error_message(e), static_cast<int>(modal::exit_status(e)));
  } catch (const modal::ReportError& e) {
    set_error(errors.report, modal::error_message(e), static_cast<int>(modal::exit_status(e)));
  } catch (const modal::SingularMassMatrix& e) {
    set_error(errors.singular_mass, modal::error_message(e), static_cast<int>(modal::exit_status(e)));
  } catch (const modal::NotAnEquilibrium& e) {
    set_error(errors.not_equilibrium, modal::error_message(e), static_cast<int>(modal::exit_status(e)));
  } catch (const std::invalid_argument& e) {
    // The library's functions refuse arguments out of range this way; the
    // pipeline checks what the CLI can pass, the module's arguments reach
    // further (e.g. amplitude levels). Bad input, status 2.
    set_error(errors.input, std::string("modal: ") + e.what(), static_cast<int>(modal::ExitStatus::bad_input));
  } catch (const std::exception& e) {
    // NumericalError and anything else: the CLI's "numerical failure", status 4.
    set_error(errors.numerical, modal::error_message(e), static_cast<int>(modal::exit_status(e)));
  }
}

// --- conversions ------------------------------------------------------------------

template <class Enum, std::size_t N>
Enum parse_choice(const std::string& option, const std::string& word,
                  const std::pair<const char*, Enum> (&choices)[N]) {
  std::string list;
  for (const auto& [name, value] : choices) {
    if (word == name) return value;
    list += (list.empty() ? "" : ", ") + std::string("'") + name + "'";
  }
  throw modal::InputError(option + " must be one of " + list + ", got '" + word + "'");
}

py::array_t<double> to_array(const std::vector<double>& v) {
  py::array_t<double> a(static_cast<py::ssize_t>(v.size()));
  auto r = a.mutable_unchecked<1>();
  for (std::size_t i = 0; i < v.size(); ++i) r(static_cast<py::ssize_t>(i)) = v[i];
  return a;
}

// Rows of possibly different lengths → a rows × max-length array padded with NaN.
py::array_t<double> to_matrix(const std::vector<std::vector<double>>& rows) {
  std::size_t cols = 0;
  for (const auto& r : rows) cols = std::max(cols, r.size());
  py::array_t<double> a({static_cast<py::ssize_t>(rows.size()), static_cast<py::ssize_t>(cols)});
  auto m = a.mutable_unchecked<2>();
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (std::size_t j = 0; j < cols; ++j)
      m(static_cast<py::ssize_t>(i), static_cast<py::ssize_t>(j)) = j < rows[i].size() ? rows[i][j] : not_a_number;
  return a;
}

py::array_t<double> to_matrix(const std::vector<modal::VectorX>& rows) {
  std::vector<std::vector<double>> r;
  r.reserve(rows.size());
  for (const modal::VectorX& v : rows) r.emplace_back(v.data(), v.data() + v.size());
  return to_matrix(r);
}

py::object str_array(const std::vector<std::string>& words) {
  static py::object array = py::module_::import("numpy").attr("array");
  return array(py::cast(words), "str");
}

py::dict parameter_dict(const std::vector<std::pair<std::string, double>>& parameters) {
  py::dict d;
  for (const auto& [name, value] : parameters) d[py::str(name)] = value;
  return d;
}

py::object sparse_matrix(const modal::SparseMatrix& m) {
  modal::SparseMatrix c = m;
  c.makeCompressed();
  return py::cast(std::move(c));  // pybind11/eigen.h: scipy.sparse.csc_matrix
}

std::string write_to_string(const std::function<void(std::ostream&)>& writer) {
  std::ostringstream out;
  writer(out);
  return out.str();
}

// --- the analysis -------------------------------------------------------------------

const std::vector<modal::Mode>& modes_of(const modal::Analysis& a) { return a.result().modes; }

template <class F>
py::array_t<double> per_mode(const modal::Analysis& a, F f) {
  const auto& modes = modes_of(a);
  py::array_t<double> out(static_cast<py::ssize_t>(modes.size()));
  auto r = out.mutable_unchecked<1>();
  for (std::size_t k = 0; k < modes.size(); ++k) r(static_cast<py::ssize_t>(k)) = f(modes[k]);
  return out;
}

py::object shapes_of(const std::vector<modal::Mode>& modes, py::ssize_t n) {
  bool real = true;
  for (const modal::Mode& m : modes)
    if (m.shape.size() && m.shape.imag().cwiseAbs().maxCoeff() != 0) real = false;
  const auto k = static_cast<py::ssize_t>(modes.size());
  if (k > 0) n = static_cast<py::ssize_t>(modes.front().shape.size());
  if (real) {
    py::array_t<double> a({n, k});
    auto r = a.mutable_unchecked<2>();
    for (py::ssize_t j = 0; j < k; ++j)
      for (py::ssize_t i = 0; i < n; ++i) r(i, j) = modes[static_cast<std::size_t>(j)].shape[i].real();
    return a;
  }
  py::array_t<std::complex<double>> a({n, k});
  auto r = a.mutable_unchecked<2>();
  for (py::ssize_t j = 0; j < k; ++j)
    for (py::ssize_t i = 0; i < n; ++i) r(i, j) = modes[static_cast<std::size_t>(j)].shape[i];
  return a;
}

modal::MatrixX or_zero(const modal::MatrixX& m, Eigen::Index n) { return m.size() ? m : modal::MatrixX::Zero(n, n); }

modal::AnalysisOptions analysis_options(int modes, std::optional<modal::VectorX> at, const std::string& solver,
                                        std::optional<double> shift, double tol, const std::string& dense_solver,
                                        const std::string& derivatives, double step, double eq_tol,
                                        const std::string& large_equilibrium, bool energy, bool drawing) {
  static const std::pair<const char*, modal::SolverChoice> solvers[] = {{"auto", modal::SolverChoice::automatic},
                                                                        {"dense", modal::SolverChoice::dense},
                                                                        {"sparse", modal::SolverChoice::sparse},
                                                                        {"tree", modal::SolverChoice::tree}};
  static const std::pair<const char*, modal::DenseSolver> dense_solvers[] = {{"auto", modal::DenseSolver::automatic},
                                                                             {"eigen", modal::DenseSolver::eigen},
                                                                             {"lapack", modal::DenseSolver::lapack}};
  static const std::pair<const char*, modal::DerivativeMethod> methods[] = {
      {"exact", modal::DerivativeMethod::exact},
      {"central", modal::DerivativeMethod::central},
      {"forward", modal::DerivativeMethod::forward},
      {"complex-step", modal::DerivativeMethod::complex_step},
      {"complex_step", modal::DerivativeMethod::complex_step}};
  static const std::pair<const char*, modal::LargeEquilibriumMethod> large[] = {
      {"newton", modal::LargeEquilibriumMethod::newton}, {"lbfgs", modal::LargeEquilibriumMethod::lbfgs}};
  if (modes == 0 || modes < -1) throw modal::InputError("modes must be a number >= 1 (or None: all)");
  if (!(tol > 0 && tol < 1)) throw modal::InputError("tol must lie in (0, 1)");
  if (!(eq_tol > 0 && eq_tol < 1)) throw modal::InputError("eq_tol must lie in (0, 1)");
  if (!(step >= 0 && std::isfinite(step))) throw modal::InputError("step must be a finite number > 0");
  if (shift && !std::isfinite(*shift)) throw modal::InputError("shift must be a finite number");
  modal::AnalysisOptions o;
  o.modes = modes;
  o.at = std::move(at);
  o.solver = parse_choice("solver", solver, solvers);
  o.shift = shift;
  o.tolerance = tol;
  o.dense_solver = parse_choice("dense_solver", dense_solver, dense_solvers);
  o.derivatives = parse_choice("derivatives", derivatives, methods);
  o.step_factor = step;
  o.equilibrium_tolerance = eq_tol;
  o.large_equilibrium = parse_choice("large_equilibrium", large_equilibrium, large);
  o.energy = energy;
  o.drawing = drawing;
  return o;
}

// What write() was asked for; nothing at all is an error.
modal::Outputs outputs(const std::optional<std::string>& csv, const std::optional<std::string>& json,
                       const std::optional<std::string>& matrices = std::nullopt,
                       const std::optional<std::string>& report = std::nullopt) {
  modal::Outputs o;
  o.csv = csv.value_or("");
  o.json = json.value_or("");
  o.matrices = matrices.value_or("");
  o.report = report.value_or("");
  if (o.csv.empty() && o.json.empty() && o.matrices.empty() && o.report.empty())
    throw modal::InputError("write: give at least one file to write (csv=, json=, matrices= or report=)");
  return o;
}

using Clock = std::chrono::steady_clock;

// --- sweeps -------------------------------------------------------------------------

py::dict critical_dict(const modal::CriticalValue& c) {
  py::dict d;
  d["value"] = c.value;
  d["error"] = c.error;
  d["kind"] = modal::to_string(c.kind);
  d["before"] = modal::to_string(c.before);
  d["after"] = modal::to_string(c.after);
  d["omega"] = c.omega;
  d["refined"] = c.refined;
  d["evaluations"] = c.evaluations;
  d["indicator"] = c.indicator;
  return d;
}

py::dict convergence_dict(const modal::ModeConvergence& c) {
  py::dict d;
  d["mode"] = c.mode;
  d["n"] = to_array(c.n);
  d["omega"] = to_array(c.omega);
  d["omega_error"] = to_array(c.omega_error);
  const modal::Extrapolation& e = c.extrapolation;
  d["asymptotic"] = e.asymptotic;
  d["reason"] = e.reason;
  d["order"] = e.order;
  d["value"] = e.value;
  d["error"] = e.error;
  d["error_rule"] = e.error_rule;
  return d;
}

const modal::SweepResult& sweep_result(const modal::SweepStudy& s) {
  if (!s.result)
    throw py::attribute_error(
        "a stability map (two axes) has no per-point modes: use x, y, stability, "
        "min_omega2, max_growth_rate");
  return *s.result;
}

template <class F>
py::array_t<double> per_point(const modal::SweepStudy& s, F f) {
  std::vector<double> v;
  if (s.result)
    for (const modal::SweepPoint& p : s.result->points) v.push_back(p.ok ? f(p) : not_a_number);
  return to_array(v);
}

template <class F>
py::array_t<double> per_point_mode(const modal::SweepStudy& s, F f) {
  std::vector<std::vector<double>> rows;
  for (const modal::SweepPoint& p : sweep_result(s).points) {
    std::vector<double> row;
    if (p.ok)
      for (const modal::Mode& m : p.result.modes) row.push_back(f(m));
    rows.push_back(std::move(row));
  }
  return to_matrix(rows);
}

// Map values as a (y.count, x.count) array: rows are y, columns x.
template <class F>
py::array_t<double> map_grid(const modal::StabilityMap& map, F f) {
  py::array_t<double> a({static_cast<py::ssize_t>(map.y.count), static_cast<py::ssize_t>(map.x.count)});
  auto r = a.mutable_unchecked<2>();
  for (int j = 0; j < map.y.count; ++j)
    for (int i = 0; i < map.x.count; ++i) {
      const modal::MapPoint& p = map.at(i, j);
      r(j, i) = p.ok ? f(p) : not_a_number;
    }
  return a;
}

template <class F>
py::array_t<double> per_equilibrium(const modal::EquilibriumSurvey& s, F f) {
  std::vector<double> v;
  for (const modal::AnalyzedEquilibrium& e : s.report.equilibria) v.push_back(f(e));
  return to_array(v);
}

// k equilibria × their modes.
template <class F>
py::array_t<double> per_equilibrium_mode(const modal::EquilibriumSurvey& s, F f) {
  std::vector<std::vector<double>> rows;
  for (const modal::AnalyzedEquilibrium& e : s.report.equilibria) {
    rows.emplace_back();
    for (const modal::Mode& x : e.result.modes) rows.back().push_back(f(x));
  }
  return to_matrix(rows);
}

template <class F>
py::array_t<double> per_amplitude(const modal::AmplitudeStudy& s, F f) {
  std::vector<double> v;
  for (const modal::AmplitudePoint& p : s.response.points) v.push_back(f(p));
  return to_array(v);
}

std::vector<double> axis_values(const modal::SweepAxis& axis) {
  std::vector<double> v;
  for (int i = 0; i < axis.count; ++i) v.push_back(axis.value(i));
  return v;
}

}  // namespace

// modes × columns of one per-mode vector of EnergyDistribution (NaN where a
// mode's vector is empty: the potential shares of a zero mode).
py::array_t<double> energy_table(const modal::EnergyDistribution& e, std::size_t columns,
                                 std::vector<double> modal::ModeEnergy::*field) {
  py::array_t<double> out({static_cast<py::ssize_t>(e.modes.size()), static_cast<py::ssize_t>(columns)});
  auto r = out.mutable_unchecked<2>();
  for (std::size_t k = 0; k < e.modes.size(); ++k) {
    const std::vector<double>& v = e.modes[k].*field;
    for (std::size_t j = 0; j < columns; ++j)
      r(static_cast<py::ssize_t>(k), static_cast<py::ssize_t>(j)) = j < v.size() ? v[j] : not_a_number;
  }
  return out;
}

// f(x) for each x of a container, as a list.
template <class C, class F>
auto collect(const C& items, F f) {
  std::vector<decltype(f(*items.begin()))> out;
  for (const auto& x : items) out.push_back(f(x));
  return out;
}

const modal::EnergyDistribution& energy_of(const modal::Analysis& a) {
  const auto& e = a.report.equilibria.front().energy;
  if (!e) throw modal::InputError("this analysis was made without energy=True: analyze(..., energy=True)");
  return *e;
}

PYBIND11_MODULE(_modal, m) {
  m.doc() = "modal's C++ pipeline (modal/pipeline.hpp); use the package `modal`, which wraps it.";
  m.attr("__version__") = MODAL_VERSION;

  // --- errors
  py::object exception = py::reinterpret_borrow<py::object>(PyExc_Exception);
  errors.error = make_error_class(m, "Error",
                                  "Any error of modal. str(e) is the line the `modal` command prints; e.exit_status "
                                  "the command's exit status (2 bad input, 4 numerical failure).",
                                  py::make_tuple(exception));
  py::handle error(errors.error);
  errors.scene = make_error_class(
      m, "SceneError",
      "A scene that cannot be read or built: str(e) is 'file:line:column: key: reason'; e.file, e.line, e.column "
      "(None when unknown), e.key (a dotted path such as 'body[2].mass') and e.reason give the parts.",
      py::make_tuple(error, py::handle(PyExc_ValueError)));
  errors.input = make_error_class(
      m, "InputError",
      "Bad input that is not in the scene: an option value, a point that is not an equilibrium, options that do not "
      "fit the scene.",
      py::make_tuple(error, py::handle(PyExc_ValueError)));
  errors.sweep_input = make_error_class(m, "SweepInputError",
                                        "A sweep axis ('NAME=FROM:TO:COUNT' or 'NAME=V1,V2,...') that is malformed or "
                                        "names no parameter of the scene.",
                                        py::make_tuple(py::handle(errors.input)));
  errors.report = make_error_class(m, "ReportError", "An output file that cannot be written (the message names it).",
                                   py::make_tuple(error, py::handle(PyExc_OSError)));
  errors.numerical = make_error_class(
      m, "NumericalError",
      "Numerical trouble that makes a result impossible or untrustworthy: no equilibrium, a singular mass matrix, "
      "no convergence. The message says what failed.",
      py::make_tuple(error, py::handle(PyExc_RuntimeError)));
  errors.singular_mass = make_error_class(m, "SingularMassMatrix",
                                          "The mass matrix is singular at the point (the message names the "
                                          "coordinates that carry no inertia).",
                                          py::make_tuple(py::handle(errors.numerical)));
  errors.not_equilibrium = make_error_class(m, "NotAnEquilibrium", "The point linearized about is not an equilibrium.",
                                            py::make_tuple(py::handle(errors.numerical)));
  py::register_exception_translator(&translate);

  // --- the model
  py::class_<modal::Model, std::shared_ptr<modal::Model>>(
      m, "Model",
      "A scene and the mechanical system built from it (constant). Made by modal.load(); every function of modal "
      "takes one.")
      .def_property_readonly(
          "title", [](const modal::Model& s) { return s.system.title(); }, "the scene's title")
      .def_property_readonly(
          "file", [](const modal::Model& s) { return s.scene.file; },
          "the file name used in messages (the path, or '<string>' / '<dict>')")
      .def_property_readonly(
          "text", [](const modal::Model& s) { return s.text; }, "the scene's TOML text")
      .def_property_readonly(
          "size", [](const modal::Model& s) { return s.system.size(); }, "n, the number of generalized coordinates")
      .def("__len__", [](const modal::Model& s) { return s.system.size(); })
      .def_property_readonly(
          "coordinates", [](const modal::Model& s) { return s.system.coordinate_names(); },
          "names of the n coordinates")
      .def_property_readonly(
          "kinds",
          [](const modal::Model& s) {
            std::vector<std::string> k;
            for (const modal::Coordinate& c : s.system.coordinates()) k.emplace_back(modal::to_string(c.kind));
            return k;
          },
          "what each coordinate measures: 'angle' (rad), 'length' (m) or 'rotation' (rad)")
      .def_property_readonly(
          "parameters", [](const modal::Model& s) { return parameter_dict(s.scene.parameters); },
          "the parameters' final values (overrides applied), in file order")
      .def_property_readonly(
          "overrides",
          [](const modal::Model& s) {
            std::vector<std::string> o;
            for (const modal::ParameterOverride& p : s.overrides) o.push_back(p.name + "=" + p.value);
            return o;
          },
          "the overrides applied, as 'NAME=VALUE'")
      .def_property_readonly(
          "initial", [](const modal::Model& s) { return s.system.initial_configuration(); },
          "the scene's initial configuration (n), where searches start")
      .def_property_readonly(
          "length_scale", [](const modal::Model& s) { return s.system.length_scale(); },
          "a length that characterizes the scene, m")
      .def(
          "summary",
          [](const modal::Model& s, std::size_t limit) {
            return write_to_string([&](std::ostream& out) { modal::write_summary(out, s, limit); });
          },
          py::arg("limit") = 100, "What `modal check` prints: the scene's bodies, coordinates, parameters.")
      .def("__repr__", [](const modal::Model& s) {
        return "<modal.Model '" + s.system.title() + "' from " + s.scene.file + ", " + std::to_string(s.system.size()) +
               " coordinates>";
      });

  m.def(
      "_load_file",
      [](const std::string& path, const std::vector<std::string>& set) {
        return std::make_shared<modal::Model>(modal::load_model(path, set));
      },
      py::arg("path"), py::arg("set"), py::call_guard<py::gil_scoped_release>());
  m.def(
      "_load_text",
      [](std::string text, const std::string& name, const std::vector<std::string>& set) {
        return std::make_shared<modal::Model>(modal::model_from_text(std::move(text), name, set));
      },
      py::arg("text"), py::arg("name"), py::arg("set"), py::call_guard<py::gil_scoped_release>());

  // --- analyze
  py::class_<modal::AnalysisOptions>(m, "AnalysisOptions", "The options of modal.analyze (made by modal.analyze).");
  m.def("_analysis_options", &analysis_options, py::arg("modes"), py::arg("at"), py::arg("solver"), py::arg("shift"),
        py::arg("tol"), py::arg("dense_solver"), py::arg("derivatives"), py::arg("step"), py::arg("eq_tol"),
        py::arg("large_equilibrium"), py::arg("energy"), py::arg("drawing"));
  m.def(
      "_analyze",
      [](std::shared_ptr<const modal::Model> model, const modal::AnalysisOptions& options) {
        return std::make_shared<modal::Analysis>(modal::analyze(*model, options));
      },
      py::arg("model"), py::arg("options"), py::call_guard<py::gil_scoped_release>());
  m.def(
      "_time_analyze",
      [](std::shared_ptr<const modal::Model> model, const modal::AnalysisOptions& options, int repeats, bool reload) {
        // The pure C++ cost of analyze (and of load_model first, with
        // reload), for bench/python_overhead.py: the fastest of `repeats` calls.
        double best = std::numeric_limits<double>::infinity();
        std::vector<std::string> set;
        for (const modal::ParameterOverride& p : model->overrides) set.push_back(p.name + "=" + p.value);
        for (int i = 0; i < repeats; ++i) {
          const Clock::time_point start = Clock::now();
          if (reload) {
            const modal::Model fresh = modal::load_model(model->scene.file, set);
            const modal::Analysis a = modal::analyze(fresh, options);
          } else {
            const modal::Analysis a = modal::analyze(*model, options);
          }
          best = std::min(best, std::chrono::duration<double>(Clock::now() - start).count());
        }
        return best;
      },
      py::arg("model"), py::arg("options"), py::arg("repeats"), py::arg("reload") = false,
      py::call_guard<py::gil_scoped_release>());

  py::class_<modal::EnergyDistribution>(
      m, "EnergyDistribution",
      "Where each mode's energy is, and how much mass a base translation excites (modal.analyze(..., energy=True); "
      "docs/design.md, 'Energy distribution and participation'). Tables have one row per mode, in the order of "
      "Analysis.omega2.")
      .def_property_readonly(
          "split",
          [](const modal::EnergyDistribution& e) {
            return e.split == modal::EnergyDistribution::Split::element ? "element" : "coordinate";
          },
          "'element': shares per body and per potential term; 'coordinate': per coordinate (kinematic maps)")
      .def_readonly("kinetic_elements", &modal::EnergyDistribution::kinetic_elements,
                    "the bodies (particles are bodies), or coordinates, that carry kinetic energy: kinetic's columns")
      .def_readonly("potential_elements", &modal::EnergyDistribution::potential_elements,
                    "the springs, gravity terms, loads, constraints (or coordinates) that store potential energy: "
                    "potential's columns")
      .def_property_readonly(
          "kinetic",
          [](const modal::EnergyDistribution& e) { return energy_table(e, e.kinetic_elements.size(), &modal::ModeEnergy::kinetic); },
          "modes × kinetic_elements: each mode's share of φᵀMφ; rows sum to 1")
      .def_property_readonly(
          "potential",
          [](const modal::EnergyDistribution& e) { return energy_table(e, e.potential_elements.size(), &modal::ModeEnergy::potential); },
          "modes × potential_elements: each mode's share of φᵀKφ; rows sum to 1 (shares may be negative); NaN "
          "rows for zero modes, whose φᵀKφ is 0 within the eigenvalue's error")
      .def_property_readonly(
          "kinetic_total",
          [](const modal::EnergyDistribution& e) {
            return collect(e.modes, [](const modal::ModeEnergy& x) { return x.kinetic_total; });
          },
          "φᵀMφ of each mode (the kinetic shares' denominator)")
      .def_property_readonly(
          "potential_total",
          [](const modal::EnergyDistribution& e) {
            return collect(e.modes, [](const modal::ModeEnergy& x) { return x.potential_total; });
          },
          "φᵀKφ of each mode (the potential shares' denominator)")
      .def_property_readonly(
          "directions",
          [](const modal::EnergyDistribution& e) {
            return collect(e.directions, [](const modal::ParticipationDirection& d) { return d.name; });
          },
          "the base-translation axes with moving mass ('x', 'y', 'z'): the participation tables' columns")
      .def_property_readonly(
          "movable_mass",
          [](const modal::EnergyDistribution& e) {
            return collect(e.directions, [](const modal::ParticipationDirection& d) { return d.movable_mass; });
          },
          "the mass that can move along each direction, kg")
      .def_property_readonly(
          "participation_factor",
          [](const modal::EnergyDistribution& e) { return energy_table(e, e.directions.size(), &modal::ModeEnergy::participation_factor); },
          "modes × directions: Γ = φᵀL/φᵀMφ")
      .def_property_readonly(
          "effective_mass",
          [](const modal::EnergyDistribution& e) { return energy_table(e, e.directions.size(), &modal::ModeEnergy::effective_mass); },
          "modes × directions: effective modal mass (φᵀL)²/φᵀMφ, kg")
      .def_property_readonly(
          "cumulative_fraction",
          [](const modal::EnergyDistribution& e) { return energy_table(e, e.directions.size(), &modal::ModeEnergy::cumulative_fraction); },
          "modes × directions: the effective masses of this mode and those below it over movable_mass")
      .def("__repr__", [](const modal::EnergyDistribution& e) {
        return "<modal.EnergyDistribution: " + std::to_string(e.modes.size()) + " modes, " +
               std::to_string(e.kinetic_elements.size()) + " kinetic and " +
               std::to_string(e.potential_elements.size()) + " potential elements>";
      });

  py::class_<modal::Analysis, std::shared_ptr<modal::Analysis>>(
      m, "Analysis",
      "One analyzed equilibrium (modal.analyze): the equilibrium, its linear model M q'' + (D + G) q' + K q = 0 and "
      "its modes. Arrays are numpy copies; mode arrays have one entry per mode (the lowest first). Units: SI (omega2 "
      "rad^2/s^2, omega rad/s).")
      .def_property_readonly("title", [](const modal::Analysis& a) { return a.report.title; })
      .def_property_readonly("file", [](const modal::Analysis& a) { return a.report.scene_file; })
      .def_property_readonly("parameters", [](const modal::Analysis& a) { return parameter_dict(a.report.parameters); })
      .def_property_readonly(
          "coordinates", [](const modal::Analysis& a) { return a.report.coordinates; }, "names of the n coordinates")
      .def_property_readonly(
          "omega2", [](const modal::Analysis& a) { return per_mode(a, [](const modal::Mode& x) { return x.omega2; }); },
          "ω² = λ of K φ = λ M φ, rad²/s² (negative: divergent); NaN for first-order (damped, gyroscopic, "
          "circulatory) problems, see s")
      .def_property_readonly(
          "omega", [](const modal::Analysis& a) { return per_mode(a, [](const modal::Mode& x) { return x.omega; }); },
          "ω = Im s, rad/s")
      .def_property_readonly(
          "frequency",
          [](const modal::Analysis& a) { return per_mode(a, [](const modal::Mode& x) { return x.frequency_hz; }); },
          "ω / 2π, Hz")
      .def_property_readonly(
          "period", [](const modal::Analysis& a) { return per_mode(a, [](const modal::Mode& x) { return x.period; }); },
          "2π / ω, s (inf when ω = 0)")
      .def_property_readonly(
          "growth_rate",
          [](const modal::Analysis& a) { return per_mode(a, [](const modal::Mode& x) { return x.growth_rate; }); },
          "σ = Re s, 1/s (> 0: the mode grows)")
      .def_property_readonly(
          "damping_ratio",
          [](const modal::Analysis& a) { return per_mode(a, [](const modal::Mode& x) { return x.damping_ratio; }); },
          "−σ / |s| (NaN when s = 0)")
      .def_property_readonly(
          "s",
          [](const modal::Analysis& a) {
            const auto& modes = modes_of(a);
            py::array_t<std::complex<double>> out(static_cast<py::ssize_t>(modes.size()));
            auto r = out.mutable_unchecked<1>();
            for (std::size_t k = 0; k < modes.size(); ++k) r(static_cast<py::ssize_t>(k)) = modes[k].s;
            return out;
          },
          "eigenvalues s = σ + iω of the first-order system (ω ≥ 0), 1/s")
      .def_property_readonly(
          "errors",
          [](const modal::Analysis& a) { return per_mode(a, [](const modal::Mode& x) { return x.error_estimate; }); },
          "absolute error estimate of each eigenvalue: of omega2 (rad²/s²) for symmetric problems, of s (rad/s) "
          "otherwise; covers the solver and the rounding (or differences) of M and K")
      .def_property_readonly(
          "systematic_errors",
          [](const modal::Analysis& a) { return per_mode(a, [](const modal::Mode& x) { return x.systematic_error; }); },
          "the part of each error estimate from systematic errors of K (an equilibrium accepted at a loose "
          "tolerance, derivatives by differences); 0 where there are none")
      .def_property_readonly(
          "bounds",
          [](const modal::Analysis& a) { return per_mode(a, [](const modal::Mode& x) { return x.residual_bound; }); },
          "rigorous bound of each omega2's error (rad²/s²): an eigenvalue of (K, M) as formed lies within it (from "
          "the residual ‖Kφ − λMφ‖_{M⁻¹} and the rounding, quadratic in the residual where the other modes leave a "
          "gap, a cluster's for repeated eigenvalues); NaN for first-order problems")
      .def_property_readonly(
          "kinds",
          [](const modal::Analysis& a) {
            std::vector<std::string> k;
            for (const modal::Mode& x : modes_of(a)) k.emplace_back(modal::to_string(x.kind));
            return k;
          },
          "what each mode does: 'oscillatory', 'damped', 'zero', 'divergent', 'flutter'")
      .def_property_readonly(
          "shapes",
          [](const modal::Analysis& a) {
            return shapes_of(modes_of(a), static_cast<py::ssize_t>(a.report.coordinates.size()));
          },
          "mode shapes, n × k (column j: mode j, in the coordinates); real and M-normalized for symmetric problems, "
          "complex otherwise")
      .def_property_readonly(
          "q", [](const modal::Analysis& a) { return a.equilibrium().q; }, "the equilibrium, n (rad, m)")
      .def_property_readonly(
          "potential", [](const modal::Analysis& a) { return a.equilibrium().potential; }, "V at the equilibrium, J")
      .def_property_readonly(
          "residual", [](const modal::Analysis& a) { return a.equilibrium().residual; },
          "the equilibrium's relative residual of |grad V - Q|, as a whole and on each coordinate: against the "
          "forces acting, beyond the rounding level of the springs' forces (modal::relative_residual)")
      .def_property_readonly(
          "sparse", [](const modal::Analysis& a) { return a.sparse.has_value(); },
          "True when the sparse path ran (M and K are scipy.sparse matrices)")
      .def_property_readonly(
          "symmetric",
          [](const modal::Analysis& a) { return a.sparse.has_value() || a.tree.has_value() || a.linear->symmetric(); },
          "K φ = λ M φ describes the motion (no damping, gyroscopic or circulatory terms)")
      .def_property_readonly(
          "M",
          [](const modal::Analysis& a) -> py::object {
            if (a.sparse) return sparse_matrix(a.sparse->M);
            if (a.tree) return py::none();
            return py::cast(a.linear->M);
          },
          "mass matrix, n × n (dense numpy array; scipy.sparse.csc_matrix on the sparse path; None on the "
          "matrix-free path, which forms none; projected onto the constraints when there are some, see basis)")
      .def_property_readonly(
          "K",
          [](const modal::Analysis& a) -> py::object {
            if (a.sparse) return sparse_matrix(a.sparse->K);
            if (a.tree) return py::none();
            return py::cast(a.linear->K);
          },
          "stiffness matrix, n × n (not symmetric with follower loads)")
      .def_property_readonly(
          "D",
          [](const modal::Analysis& a) -> py::object {
            if (a.sparse) return sparse_matrix(modal::SparseMatrix(a.sparse->M.rows(), a.sparse->M.cols()));
            if (a.tree) return py::none();
            return py::cast(or_zero(a.linear->D, a.linear->M.rows()));
          },
          "damping matrix, n × n, symmetric (zero without dampers)")
      .def_property_readonly(
          "G",
          [](const modal::Analysis& a) -> py::object {
            if (a.sparse) return sparse_matrix(modal::SparseMatrix(a.sparse->M.rows(), a.sparse->M.cols()));
            if (a.tree) return py::none();
            return py::cast(or_zero(a.linear->G, a.linear->M.rows()));
          },
          "gyroscopic matrix, n × n, skew (zero when absent)")
      .def_property_readonly(
          "K_error",
          [](const modal::Analysis& a) -> py::object {
            if (a.sparse || a.tree || a.linear->K_error.size() == 0) return py::none();
            return py::cast(a.linear->K_error);
          },
          "estimate of the absolute error of K's entries (dense path), or None")
      .def_property_readonly(
          "basis",
          [](const modal::Analysis& a) -> py::object {
            if (a.sparse || a.tree || !a.linear->constrained()) return py::none();
            return py::cast(a.linear->basis);
          },
          "with constraints: N (n × n_r, orthonormal columns), M = Nᵀ M(q) N, …; a mode φ moves q by N φ. "
          "None without constraints")
      .def_property_readonly(
          "stability", [](const modal::Analysis& a) { return modal::to_string(a.result().stability); },
          "the stability class: 'asymptotically stable', 'stable', 'marginal', 'divergence' "
          "or 'flutter'")
      .def_property_readonly(
          "stability_description", [](const modal::Analysis& a) { return modal::describe_stability(a.result()); },
          "the sentence `modal analyze` prints after 'Stability: '")
      .def_property_readonly("unstable", &modal::Analysis::unstable, "divergence or flutter")
      .def_property_readonly(
          "morse_index", [](const modal::Analysis& a) { return a.result().morse_index; },
          "number of divergent modes (unstable directions)")
      .def_property_readonly(
          "zero_modes", [](const modal::Analysis& a) { return a.result().zero_modes; }, "number of zero modes")
      .def_property_readonly(
          "notes", [](const modal::Analysis& a) { return a.result().notes; }, "diagnostics a user should read")
      .def_property_readonly(
          "energy", [](const modal::Analysis& a) -> const modal::EnergyDistribution& { return energy_of(a); },
          py::return_value_policy::reference_internal,
          "the modes' energy distribution and participation (an EnergyDistribution); raises InputError unless "
          "analyze was called with energy=True")
      .def_property_readonly(
          "solver", [](const modal::Analysis& a) { return a.result().solver; }, "which eigen-solver ran")
      .def_property_readonly(
          "timings",
          [](const modal::Analysis& a) {
            py::dict d;
            for (const auto& [phase, seconds] : a.timings) {
              const std::size_t start = phase.find_first_not_of(' ');
              d[py::str(start == std::string::npos ? phase : phase.substr(start))] = seconds;
            }
            return d;
          },
          "wall time of each phase, s, in order (the sparse solver's sub-phases precede 'eigen')")
      .def(
          "text",
          [](const modal::Analysis& a) {
            return write_to_string([&](std::ostream& out) { modal::write_analysis(out, a); });
          },
          "The table `modal analyze` prints.")
      .def(
          "json", [](const modal::Analysis& a) { return modal::analysis_json(a.report); },
          "The JSON `modal analyze --json` writes, as a string.")
      .def(
          "write",
          [](const modal::Analysis& a, std::optional<std::string> csv, std::optional<std::string> json,
             std::optional<std::string> matrices, std::optional<std::string> report) {
            modal::Outputs o = outputs(csv, json, matrices, report);
            o.energy = !o.csv.empty() && a.report.equilibria.front().energy.has_value();
            modal::check_outputs(modal::Command::analyze, o, a.report.scene_file, a.report.data_files);
            std::ostringstream discard;
            modal::write_analysis(discard, a, o);
          },
          py::arg("csv") = py::none(), py::arg("json") = py::none(), py::arg("matrices") = py::none(),
          py::arg("report") = py::none(),
          "Writes files as `modal analyze` does: csv=PREFIX (PREFIX_modes.csv, _shapes.csv, _equilibria.csv; with "
          "energy=True in analyze also _energy.csv and _participation.csv), "
          "json=FILE, matrices=DIR (M, K, … in Matrix Market), report=FILE.html (the HTML report; its mode views "
          "are animated when analyze was called with drawing=True, else bar charts). All or none are written; "
          "raises ReportError.",
          py::call_guard<py::gil_scoped_release>())
      .def("__repr__", [](const modal::Analysis& a) {
        return "<modal.Analysis of '" + a.report.title + "': " + modal::to_string(a.result().stability) + ", " +
               std::to_string(a.result().modes.size()) + " modes>";
      });

  // --- equilibria
  m.def(
      "_equilibria",
      [](std::shared_ptr<const modal::Model> model, int starts, double tol, int max_iterations) {
        if (starts < -1) throw modal::InputError("starts must be a number >= 0");  // -1: the default
        if (!(tol > 0 && tol < 1)) throw modal::InputError("tol must lie in (0, 1)");
        modal::EquilibriumOptions o;
        o.starts = starts;
        o.tolerance = tol;
        o.max_iterations = max_iterations;
        return std::make_shared<modal::EquilibriumSurvey>(modal::equilibria(*model, o));
      },
      py::arg("model"), py::arg("starts"), py::arg("tol"), py::arg("max_iterations"),
      py::call_guard<py::gil_scoped_release>());

  py::class_<modal::EquilibriumSurvey, std::shared_ptr<modal::EquilibriumSurvey>>(
      m, "Equilibria",
      "The equilibria found (modal.equilibria), sorted by potential energy; arrays have one row per equilibrium. "
      "len(e) is their number, e[i] one of them as a dict.")
      .def("__len__", [](const modal::EquilibriumSurvey& s) { return s.report.equilibria.size(); })
      .def_property_readonly("coordinates", [](const modal::EquilibriumSurvey& s) { return s.report.coordinates; })
      .def_property_readonly(
          "q",
          [](const modal::EquilibriumSurvey& s) {
            std::vector<modal::VectorX> q;
            for (const auto& e : s.report.equilibria) q.push_back(e.equilibrium.q);
            return to_matrix(q);
          },
          "k × n: the equilibria")
      .def_property_readonly(
          "potential",
          [](const modal::EquilibriumSurvey& s) {
            return per_equilibrium(s, [](const auto& e) { return e.equilibrium.potential; });
          },
          "V at each, J")
      .def_property_readonly(
          "residual",
          [](const modal::EquilibriumSurvey& s) {
            return per_equilibrium(s, [](const auto& e) { return e.equilibrium.residual; });
          },
          "relative residual of each")
      .def_property_readonly(
          "stability",
          [](const modal::EquilibriumSurvey& s) {
            std::vector<std::string> v;
            for (const auto& e : s.report.equilibria) v.emplace_back(modal::to_string(e.result.stability));
            return str_array(v);
          },
          "stability class of each")
      .def_property_readonly(
          "morse_index",
          [](const modal::EquilibriumSurvey& s) {
            std::vector<int> v;
            for (const auto& e : s.report.equilibria) v.push_back(e.result.morse_index);
            return py::array_t<int>(static_cast<py::ssize_t>(v.size()), v.data());
          },
          "number of unstable directions of each")
      .def_property_readonly(
          "omega2",
          [](const modal::EquilibriumSurvey& s) {
            return per_equilibrium_mode(s, [](const modal::Mode& x) { return x.omega2; });
          },
          "k × n: ω² of every mode of each, rad²/s²")
      .def_property_readonly(
          "errors",
          [](const modal::EquilibriumSurvey& s) {
            return per_equilibrium_mode(s, [](const modal::Mode& x) { return x.error_estimate; });
          },
          "k × n: the error estimates of omega2")
      .def_property_readonly(
          "unanalyzed", [](const modal::EquilibriumSurvey& s) { return s.unanalyzed; },
          "equilibria found whose linear model does not exist, in words")
      .def("__getitem__",
           [](const modal::EquilibriumSurvey& s, py::ssize_t i) {
             const auto k = static_cast<py::ssize_t>(s.report.equilibria.size());
             if (i < 0) i += k;
             if (i < 0 || i >= k) throw py::index_error("equilibrium index out of range");
             const modal::AnalyzedEquilibrium& e = s.report.equilibria[static_cast<std::size_t>(i)];
             py::dict d;
             d["q"] = e.equilibrium.q;
             d["potential"] = e.equilibrium.potential;
             d["residual"] = e.equilibrium.residual;
             d["stability"] = modal::to_string(e.result.stability);
             d["morse_index"] = e.result.morse_index;
             d["zero_modes"] = e.result.zero_modes;
             std::vector<double> w2, err;
             for (const modal::Mode& x : e.result.modes) {
               w2.push_back(x.omega2);
               err.push_back(x.error_estimate);
             }
             d["omega2"] = to_array(w2);
             d["errors"] = to_array(err);
             d["shapes"] = shapes_of(e.result.modes, static_cast<py::ssize_t>(e.equilibrium.q.size()));
             return d;
           })
      .def(
          "text",
          [](const modal::EquilibriumSurvey& s) {
            return write_to_string([&](std::ostream& out) { modal::write_equilibria(out, s); });
          },
          "The table `modal equilibria` prints.")
      .def(
          "json", [](const modal::EquilibriumSurvey& s) { return modal::equilibria_json(s.report); },
          "The JSON `modal equilibria --json` writes.")
      .def(
          "write",
          [](const modal::EquilibriumSurvey& s, std::optional<std::string> csv, std::optional<std::string> json,
             std::optional<std::string> report) {
            const modal::Outputs o = outputs(csv, json, std::nullopt, report);
            modal::check_outputs(modal::Command::equilibria, o, s.report.scene_file, s.report.data_files);
            std::ostringstream discard;
            modal::write_equilibria(discard, s, o);
          },
          py::arg("csv") = py::none(), py::arg("json") = py::none(), py::arg("report") = py::none(),
          "Writes csv=FILE, json=FILE and/or report=FILE.html (the HTML report), all or none.",
          py::call_guard<py::gil_scoped_release>())
      .def("__repr__", [](const modal::EquilibriumSurvey& s) {
        return "<modal.Equilibria of '" + s.report.title + "': " + std::to_string(s.report.equilibria.size()) +
               " found>";
      });

  // --- sweep
  m.def(
      "_sweep",
      [](std::shared_ptr<const modal::Model> model, const std::vector<std::string>& vary, int modes, bool extrapolate,
         double tol, bool refine, int max_evaluations) {
        std::vector<modal::SweepAxis> axes;
        for (const std::string& v : vary) axes.push_back(modal::parse_vary(v));
        if (modes == 0 || modes < -1) throw modal::InputError("modes must be a number >= 1 (or None: all)");
        if (!(tol > 0 && tol < 1)) throw modal::InputError("tol must lie in (0, 1)");
        modal::SweepStudyOptions o;
        o.modes = modes;
        o.extrapolate = extrapolate;
        o.sweep.tolerance = tol;
        o.sweep.refine = refine;
        o.sweep.max_evaluations = max_evaluations;
        return std::make_shared<modal::SweepStudy>(modal::sweep(*model, axes, o));
      },
      py::arg("model"), py::arg("vary"), py::arg("modes"), py::arg("extrapolate"), py::arg("tol"), py::arg("refine"),
      py::arg("max_evaluations"), py::call_guard<py::gil_scoped_release>());

  py::class_<modal::SweepStudy, std::shared_ptr<modal::SweepStudy>>(
      m, "Sweep",
      "A sweep along one parameter (modal.sweep with one axis): per-point arrays in sweep order, NaN where a point "
      "failed; or a stability map over two (is_map: x, y, and (len(y), len(x)) grids).")
      .def_property_readonly("is_map", [](const modal::SweepStudy& s) { return s.map.has_value(); })
      .def_property_readonly(
          "name", [](const modal::SweepStudy& s) { return s.axes.front().name; }, "the (first) parameter")
      .def_property_readonly(
          "values", [](const modal::SweepStudy& s) { return to_array(axis_values(s.axes.front())); },
          "the (first) parameter's values")
      .def_property_readonly(
          "x", [](const modal::SweepStudy& s) { return to_array(axis_values(s.axes.front())); },
          "the first parameter's values")
      .def_property_readonly(
          "y",
          [](const modal::SweepStudy& s) -> py::object {
            if (s.axes.size() < 2) return py::none();
            return to_array(axis_values(s.axes[1]));
          },
          "a map's second parameter's values (None for a sweep)")
      .def_property_readonly("names",
                             [](const modal::SweepStudy& s) {
                               std::vector<std::string> n;
                               for (const modal::SweepAxis& a : s.axes) n.push_back(a.name);
                               return n;
                             })
      .def_property_readonly(
          "ok",
          [](const modal::SweepStudy& s) {
            std::vector<bool> v;
            if (s.result)
              for (const auto& p : s.result->points) v.push_back(p.ok);
            if (s.map)
              for (const auto& p : s.map->points) v.push_back(p.ok);
            py::array_t<bool> a(static_cast<py::ssize_t>(v.size()));
            auto r = a.mutable_unchecked<1>();
            for (std::size_t i = 0; i < v.size(); ++i) r(static_cast<py::ssize_t>(i)) = v[i];
            if (s.map) return py::array_t<bool>(a.reshape({s.map->y.count, s.map->x.count}));
            return a;
          },
          "whether each point worked")
      .def_property_readonly(
          "failures",
          [](const modal::SweepStudy& s) {
            std::vector<std::string> v;
            if (s.result)
              for (const auto& p : s.result->points) v.push_back(p.failure);
            if (s.map)
              for (const auto& p : s.map->points) v.push_back(p.failure);
            return v;
          },
          "why each point failed ('' where it worked)")
      .def_property_readonly(
          "stability",
          [](const modal::SweepStudy& s) -> py::object {
            std::vector<std::string> v;
            if (s.result)
              for (const auto& p : s.result->points) v.emplace_back(p.ok ? modal::to_string(p.result.stability) : "");
            if (s.map) {
              for (const auto& p : s.map->points) v.emplace_back(p.ok ? modal::to_string(p.stability) : "");
              return str_array(v).attr("reshape")(s.map->y.count, s.map->x.count);
            }
            return str_array(v);
          },
          "stability class at each point ('' where it failed)")
      .def_property_readonly(
          "min_omega2",
          [](const modal::SweepStudy& s) -> py::object {
            if (s.map) return map_grid(*s.map, [](const modal::MapPoint& p) { return p.min_omega2; });
            return per_point(s, [](const modal::SweepPoint& p) { return p.min_omega2; });
          },
          "smallest ω² − σ² of all modes at each point (λ_min for symmetric models), rad²/s²")
      .def_property_readonly(
          "max_growth_rate",
          [](const modal::SweepStudy& s) -> py::object {
            if (s.map) return map_grid(*s.map, [](const modal::MapPoint& p) { return p.max_growth_rate; });
            return per_point(s, [](const modal::SweepPoint& p) { return p.max_growth_rate; });
          },
          "largest growth rate σ of all modes at each point, 1/s")
      .def_property_readonly(
          "omega2",
          [](const modal::SweepStudy& s) { return per_point_mode(s, [](const modal::Mode& x) { return x.omega2; }); },
          "points × modes: ω² of the modes kept (NaN for first-order problems and failed points)")
      .def_property_readonly(
          "omega",
          [](const modal::SweepStudy& s) { return per_point_mode(s, [](const modal::Mode& x) { return x.omega; }); },
          "points × modes: ω, rad/s")
      .def_property_readonly(
          "growth_rate",
          [](const modal::SweepStudy& s) {
            return per_point_mode(s, [](const modal::Mode& x) { return x.growth_rate; });
          },
          "points × modes: σ, 1/s")
      .def_property_readonly(
          "errors",
          [](const modal::SweepStudy& s) {
            return per_point_mode(s, [](const modal::Mode& x) { return x.error_estimate; });
          },
          "points × modes: the error estimates")
      .def_property_readonly(
          "q",
          [](const modal::SweepStudy& s) {
            std::vector<modal::VectorX> q;
            for (const auto& p : sweep_result(s).points) q.push_back(p.ok ? p.equilibrium.q : modal::VectorX());
            return to_matrix(q);
          },
          "points × n: the equilibrium followed (NaN-padded where the size changes)")
      .def_property_readonly(
          "critical",
          [](const modal::SweepStudy& s) {
            py::list l;
            if (s.result)
              for (const modal::CriticalValue& c : s.result->critical) l.append(critical_dict(c));
            return l;
          },
          "the class changes found, refined: dicts with value, error (a bound on |value - true|), kind "
          "('divergence', 'flutter', 'marginal'), before, after, omega (rad/s), refined, evaluations, indicator")
      .def_property_readonly(
          "convergence",
          [](const modal::SweepStudy& s) {
            py::list l;
            for (const modal::ModeConvergence& c : s.convergence) l.append(convergence_dict(c));
            return l;
          },
          "with extrapolate=True: per mode, ω along the axis and its Richardson extrapolation (dicts)")
      .def_property_readonly(
          "notes", [](const modal::SweepStudy& s) { return s.result ? s.result->notes : std::vector<std::string>{}; })
      .def_property_readonly(
          "evaluations", [](const modal::SweepStudy& s) { return s.result ? s.result->evaluations : 0; },
          "points evaluated (grid and refinement)")
      .def(
          "text",
          [](const modal::SweepStudy& s) {
            return write_to_string([&](std::ostream& out) { modal::write_sweep(out, s); });
          },
          "The table `modal sweep` prints.")
      .def(
          "write",
          [](const modal::SweepStudy& s, std::optional<std::string> csv, std::optional<std::string> report) {
            const modal::Outputs o = outputs(csv, std::nullopt, std::nullopt, report);
            modal::check_outputs(modal::Command::sweep, o, s.scene_file, s.data_files, !s.convergence.empty());
            std::ostringstream discard;
            modal::write_sweep(discard, s, o);
          },
          py::arg("csv") = py::none(), py::arg("report") = py::none(),
          "Writes the CSV files `modal sweep --csv FILE` writes (FILE, FILE_critical.csv, and with extrapolation "
          "FILE_convergence.csv, FILE_extrapolation.csv; a map: FILE) and/or report=FILE.html (branches, root "
          "locus, Campbell diagram, critical values; a map: the stability map), all or none.",
          py::call_guard<py::gil_scoped_release>())
      .def("__repr__", [](const modal::SweepStudy& s) {
        std::string axes;
        for (const modal::SweepAxis& a : s.axes) axes += (axes.empty() ? "" : " × ") + a.name;
        return "<modal.Sweep over " + axes + ">";
      });

  // --- simulate
  m.def(
      "_simulate",
      [](std::shared_ptr<const modal::Model> model, double duration, std::optional<modal::VectorX> at,
         std::optional<modal::VectorX> velocity, std::optional<double> interval, double tol) {
        modal::SimulationRequest r;
        r.duration = duration;
        r.at = std::move(at);
        r.velocity = std::move(velocity);
        r.interval = interval;
        r.tolerance = tol;
        return std::make_shared<modal::Simulation>(modal::simulate(*model, r));
      },
      py::arg("model"), py::arg("duration"), py::arg("at"), py::arg("velocity"), py::arg("interval"), py::arg("tol"),
      py::call_guard<py::gil_scoped_release>());

  py::class_<modal::Simulation, std::shared_ptr<modal::Simulation>>(
      m, "Simulation", "A motion of the nonlinear equations (modal.simulate), sampled: arrays have one row per sample.")
      .def_property_readonly("coordinates", [](const modal::Simulation& s) { return s.trajectory.coordinates; })
      .def_property_readonly(
          "time", [](const modal::Simulation& s) { return to_array(s.trajectory.time); }, "s")
      .def_property_readonly(
          "q", [](const modal::Simulation& s) { return to_matrix(s.trajectory.q); },
          "samples × n: coordinates (rad, m)")
      .def_property_readonly(
          "qdot", [](const modal::Simulation& s) { return to_matrix(s.trajectory.qd); },
          "samples × n: velocities (rad/s, m/s)")
      .def_property_readonly(
          "energy", [](const modal::Simulation& s) { return to_array(s.trajectory.energy); }, "E = ½q̇ᵀMq̇ + V, J")
      .def_property_readonly(
          "work", [](const modal::Simulation& s) { return to_array(s.trajectory.work); },
          "work of the non-conservative forces, J (0 for a conservative scene)")
      .def_property_readonly(
          "energy_error", [](const modal::Simulation& s) { return to_array(s.trajectory.energy_error); },
          "(E − E0 − W) / energy_scale at each sample")
      .def_property_readonly("max_energy_error",
                             [](const modal::Simulation& s) { return s.trajectory.max_energy_error; })
      .def_property_readonly(
          "energy_scale", [](const modal::Simulation& s) { return s.trajectory.energy_scale; }, "J")
      .def_property_readonly("conservative", [](const modal::Simulation& s) { return s.trajectory.conservative; })
      .def_property_readonly("steps", [](const modal::Simulation& s) { return s.trajectory.steps; })
      .def_property_readonly("rejected_steps", [](const modal::Simulation& s) { return s.trajectory.rejected_steps; })
      .def_property_readonly("evaluations", [](const modal::Simulation& s) { return s.trajectory.evaluations; })
      .def_property_readonly("notes", [](const modal::Simulation& s) { return s.notes; })
      .def(
          "csv",
          [](const modal::Simulation& s) {
            return write_to_string([&](std::ostream& out) { modal::write_simulation(out, s); });
          },
          "The CSV `modal simulate` prints.")
      .def(
          "write",
          [](const modal::Simulation& s, std::optional<std::string> csv, std::optional<std::string> report) {
            const modal::Outputs o = outputs(csv, std::nullopt, std::nullopt, report);
            modal::check_outputs(modal::Command::simulate, o, s.scene_file, s.data_files);
            std::ostringstream discard;
            modal::write_simulation(discard, s, o);
          },
          py::arg("csv") = py::none(), py::arg("report") = py::none(),
          "Writes the CSV to a file and/or report=FILE.html (time series and energy error), all or none.",
          py::call_guard<py::gil_scoped_release>())
      .def("__len__", [](const modal::Simulation& s) { return s.trajectory.size(); })
      .def("__repr__", [](const modal::Simulation& s) {
        return "<modal.Simulation: " + std::to_string(s.trajectory.size()) + " samples to t = " +
               (s.trajectory.time.empty() ? std::string("0") : std::to_string(s.trajectory.time.back())) + " s>";
      });

  // --- amplitude
  m.def(
      "_amplitude",
      [](std::shared_ptr<const modal::Model> model, int mode, std::optional<modal::VectorX> at,
         std::vector<double> amplitudes, double max_amplitude, int points, int cycles, double tol,
         std::vector<double> levels) {
        if (points < 2) throw modal::InputError("points must be a number >= 2");
        if (cycles < 1) throw modal::InputError("cycles must be a number >= 1");
        if (!(tol > 0 && tol < 1)) throw modal::InputError("tol must lie in (0, 1)");
        if (!(max_amplitude >= 0)) throw modal::InputError("max_amplitude must be a number > 0");
        modal::AmplitudeRequest r;
        r.mode = mode;
        r.at = std::move(at);
        r.options.amplitudes = std::move(amplitudes);
        r.options.max_amplitude = max_amplitude;
        r.options.points = points;
        r.options.cycles = cycles;
        r.options.tolerance = tol;
        r.options.levels = std::move(levels);
        return std::make_shared<modal::AmplitudeStudy>(modal::amplitude(*model, r));
      },
      py::arg("model"), py::arg("mode"), py::arg("at"), py::arg("amplitudes"), py::arg("max_amplitude"),
      py::arg("points"), py::arg("cycles"), py::arg("tol"), py::arg("levels"),
      py::call_guard<py::gil_scoped_release>());

  py::class_<modal::AmplitudeStudy, std::shared_ptr<modal::AmplitudeStudy>>(
      m, "Amplitude",
      "Frequency against amplitude of one mode (modal.amplitude): arrays have one entry per amplitude measured.")
      .def_property_readonly("mode", [](const modal::AmplitudeStudy& s) { return s.mode; })
      .def_property_readonly(
          "omega2", [](const modal::AmplitudeStudy& s) { return s.omega2; }, "ω² of the linear mode, rad²/s²")
      .def_property_readonly(
          "omega_linear", [](const modal::AmplitudeStudy& s) { return s.response.omega_linear; }, "rad/s")
      .def_property_readonly(
          "coordinate", [](const modal::AmplitudeStudy& s) { return s.response.coordinate; },
          "the coordinate whose displacement is the amplitude")
      .def_property_readonly(
          "amplitudes",
          [](const modal::AmplitudeStudy& s) { return per_amplitude(s, [](const auto& p) { return p.amplitude; }); },
          "rad or m")
      .def_property_readonly(
          "omega",
          [](const modal::AmplitudeStudy& s) {
            return per_amplitude(s, [](const auto& p) { return p.oscillates ? p.omega : not_a_number; });
          },
          "measured ω, rad/s (NaN where the motion does not oscillate)")
      .def_property_readonly(
          "shift",
          [](const modal::AmplitudeStudy& s) {
            return per_amplitude(s, [](const auto& p) { return p.oscillates ? p.shift : not_a_number; });
          },
          "ω/ω_lin − 1")
      .def_property_readonly(
          "spread",
          [](const modal::AmplitudeStudy& s) { return per_amplitude(s, [](const auto& p) { return p.spread; }); },
          "largest |T_i/T − 1| of the periods measured")
      .def_property_readonly("oscillates",
                             [](const modal::AmplitudeStudy& s) {
                               py::array_t<bool> a(static_cast<py::ssize_t>(s.response.points.size()));
                               auto r = a.mutable_unchecked<1>();
                               for (std::size_t i = 0; i < s.response.points.size(); ++i)
                                 r(static_cast<py::ssize_t>(i)) = s.response.points[i].oscillates;
                               return a;
                             })
      .def_property_readonly(
          "thresholds",
          [](const modal::AmplitudeStudy& s) {
            py::list l;
            for (const modal::AmplitudeThreshold& t : s.response.thresholds) {
              py::dict d;
              d["level"] = t.level;
              d["reached"] = t.reached;
              d["amplitude"] = t.amplitude;
              d["error"] = t.error;
              d["note"] = t.note;
              l.append(d);
            }
            return l;
          },
          "dicts: level (|ω/ω_lin − 1|), reached, amplitude, error, note")
      .def(
          "text",
          [](const modal::AmplitudeStudy& s) {
            return write_to_string([&](std::ostream& out) { modal::write_amplitude(out, s); });
          },
          "The table `modal amplitude` prints.")
      .def(
          "write",
          [](const modal::AmplitudeStudy& s, std::optional<std::string> csv, std::optional<std::string> report) {
            const modal::Outputs o = outputs(csv, std::nullopt, std::nullopt, report);
            modal::check_outputs(modal::Command::amplitude, o, s.scene_file, s.data_files);
            std::ostringstream discard;
            modal::write_amplitude(discard, s, o);
          },
          py::arg("csv") = py::none(), py::arg("report") = py::none(),
          "Writes the CSV `modal amplitude --csv` writes and/or report=FILE.html (period ratio and departure "
          "against amplitude), all or none.",
          py::call_guard<py::gil_scoped_release>())
      .def("__repr__", [](const modal::AmplitudeStudy& s) {
        return "<modal.Amplitude of mode " + std::to_string(s.mode) + " of '" + s.title + "'>";
      });
}
