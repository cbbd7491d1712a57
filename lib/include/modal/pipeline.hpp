// modal/pipeline.hpp — everything the `modal` command does, as a library: load
// a scene, run an analysis, a survey of equilibria, a sweep, a simulation or an
// amplitude scan with one options value, and write any result as text, CSV or
// JSON. The command line is a thin shell over these functions, so a C++
// program (or the Python module) gets exactly what the CLI prints.
//
//   modal::Model model = modal::load_model("models/double_pendulum.toml", {"m2=2"});
//   modal::AnalysisOptions options;
//   options.modes = 2;
//   modal::Analysis a = modal::analyze(model, options);
//   for (const modal::Mode& m : a.result().modes)
//     std::cout << m.omega2 << " ± " << m.error_estimate << " rad²/s²\n";
//   modal::Outputs files;
//   files.csv = "out/dp";                         // out/dp_modes.csv, _shapes.csv, _equilibria.csv
//   modal::write_analysis(std::cout, a, files);   // the table `modal analyze` prints, and the files
//
// Data flow (one way): Model (scene text → Scene → System, constant) →
// Analysis / EquilibriumSurvey / SweepStudy / Simulation / AmplitudeStudy
// (plain values) → write_*. Units are SI throughout: ω² in rad²/s², ω in
// rad/s, coordinates in rad or m as their kind says.
//
// Errors are exceptions whose what() is the message the CLI prints (after
// "modal: "), each mapped to the CLI's exit status by exit_status():
//   SceneError (file:line:column: key: reason), SweepInputError, InputError,
//   ReportError                                  → ExitStatus::bad_input (2)
//   NumericalError and its kinds (SingularMassMatrix, NotAnEquilibrium, …)
//                                                → ExitStatus::numerical (4)
#pragma once

#include "modal/equilibrium.hpp"
#include "modal/import.hpp"
#include "modal/linearize.hpp"
#include "modal/modes.hpp"
#include "modal/report.hpp"
#include "modal/scene.hpp"
#include "modal/simulate.hpp"
#include "modal/sweep.hpp"

#include <exception>
#include <functional>
#include <iosfwd>
#include <new>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace modal {

// The documented exit statuses of the `modal` command.
enum class ExitStatus : int { ok = 0, usage = 1, bad_input = 2, unstable = 3, numerical = 4 };

// Bad input that is not in a scene file: a point given with --at that is not
// an equilibrium, option values that do not fit the scene, combinations of
// options that do not go together. Exit status 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// "4G", "512M", "100k" or a number of bytes, as `--max-memory` takes it
// (decimal units: k = 10³, M = 10⁶, G = 10⁹, T = 10¹²); InputError otherwise.
double parse_memory_size(const std::string& text);

// What a command on `model` would need, estimated before allocating
// (docs/design.md, "Memory policy"): the dense path of analyze
// (dense_analysis_memory, modal/modes.hpp; also each point of a sweep), and
// the sparse path (200 bytes per coordinate pair the tree couples,
// coupled_pairs: a chain's factor is dense).
double sparse_analysis_memory(const System& system);
// simulate: the dense path's matrices (M and its factor at every step, as
// dense_analysis_memory) and the trajectory, kept as numbers and as CSV text
// until it is written: 32 bytes per value, 2n + 4 values per sample.
double simulation_memory(const System& system, double samples);
// The matrix-free path: 1.5 kB per body (the pencil, its factor and the
// recursions' work vectors) and the Lanczos basis, 8·ncv bytes per
// coordinate with ncv = max(2·modes + 1, 20).
double tree_analysis_memory(const System& system, int modes);

// The exit status for an exception thrown by any modal function (see above;
// std::bad_alloc and anything unknown count as numerical failures).
ExitStatus exit_status(const std::exception& error);
// The one line the CLI prints for it: a SceneError as it is
// ("file:line:column: key: reason"), a NumericalError as "modal: numerical
// failure: …", out of memory as "modal: out of memory …", others "modal: …".
std::string error_message(const std::exception& error);
// `line` with every run of more than 200 non-blank bytes (a user's text
// quoted whole: a 100 000-character name or number) cut to its first 80
// characters and its length, as error_message and the CLI's usage errors
// print it.
std::string abridged(const std::string& line);

// --- the model -------------------------------------------------------------------

// A scene and the system built from it, with the text it came from (sweeps
// re-read the text at every parameter value). Constant once made; copyable.
struct Model {
  std::string text;                          // the scene's TOML text (an MJCF or URDF file's: as converted)
  std::vector<ParameterOverride> overrides;  // --set, in order
  Scene scene;
  System system;
  SceneLimits limits;                        // as read (sweeps read the text again with them)
  SceneFormat format = SceneFormat::toml;    // what the file was (mjcf, urdf: imported, see modal/import.hpp)
  // Imported files: MuJoCo's compiled model, which checks every equilibrium
  // analyzed for contacts and ball-joint limits (check_imported_configuration);
  // scene.body_locations then point at the file's joint elements. Null for TOML.
  std::shared_ptr<const ImportedModel> imported;
};

// Reads and builds a scene file (read_scene_file: regular files only, at most
// max_scene_bytes); `set` are "NAME=VALUE" overrides (VALUE may be an
// expression over the other parameters). MJCF and URDF files are imported
// (import_scene) and then read as the TOML scene they convert to; `format`
// automatic decides by the file's name and text (scene_format). Throws SceneError.
Model load_model(const std::string& path, const std::vector<std::string>& set = {}, const SceneLimits& limits = {},
                 SceneFormat format = SceneFormat::automatic);
// The same from text in memory; `name` stands for the file in messages (and
// relative data files, such as a network's CSV, are resolved against its
// directory).
Model model_from_text(std::string text, const std::string& name, const std::vector<std::string>& set = {},
                      const SceneLimits& limits = {}, SceneFormat format = SceneFormat::automatic);
// The TOML scene of a scene file (`modal convert`): an MJCF or URDF file
// imported, a TOML file as it is.
std::string convert_scene(const std::string& path, SceneFormat format = SceneFormat::automatic);

// "q1,q2,..." (one finite number per coordinate of `system`, as for --at or
// --velocity) → n values; InputError naming `option` and the coordinates
// when the text does not fit.
VectorX parse_coordinates(const System& system, const std::string& option, const std::string& text);

// --- analyze ---------------------------------------------------------------------

// Which eigen-solver `analyze` uses: automatic = sparse above
// large_system_coordinates coordinates when the sparse model describes the
// scene (no dampers, followers, constraints, rotating frame or map), else dense;
// when that path's memory estimate exceeds the limit (Model::limits.memory, or
// the machine's available memory) the other if it fits, else InputError with
// both estimates. A forced path that does not fit is refused the same way.
// tree: the matrix-free path (solve_tree_modes; docs/design.md, "Matrix-free
// path"), which automatic takes above large_system_coordinates for a scene it
// describes (tree_pencil_unsupported) whose tree couples more than
// 64 coordinate pairs per coordinate (long chains, where the sparse matrices
// fill in), or when neither matrix path fits. Where automatic took the
// matrix-free path and it refuses M (SingularMassMatrix: its factorization
// through the tree, in the model's joint coordinates, meets a pivot ≤ 0), the
// dense path answers instead when it fits and no shift is asked for, with a
// note saying so.
enum class SolverChoice { automatic, dense, sparse, tree };
const char* to_string(SolverChoice choice);  // "auto", "dense", "sparse", "tree"

struct AnalysisOptions {
  int modes = -1;                // lowest modes to report; -1: all (dense), 10 (sparse)
  std::optional<VectorX> at;     // analyze the equilibrium at this point (n values; it must be
                                 // one, to 1e-3 in configuration distance) instead of the one
                                 // nearest the scene's initial configuration
  SolverChoice solver = SolverChoice::automatic;
  std::optional<double> shift;   // sparse: modes nearest σ, rad²/s² (unset: the lowest)
  double tolerance = 1e-10;      // sparse: relative convergence tolerance of the Lanczos iteration
  DenseSolver dense_solver = DenseSolver::automatic;
  DerivativeMethod derivatives = DerivativeMethod::exact;  // how K (and G) are differentiated; dense only
  double step_factor = 0;        // differences: step as a factor of max(|q|, 1 rad or the length scale);
                                 // 0: the method's default
  double equilibrium_tolerance = EquilibriumOptions{}.tolerance;  // accepted relative residual
  LargeEquilibriumMethod large_equilibrium = LargeEquilibriumMethod::newton;
  // The energy distribution and participation of the modes reported
  // (modal/energy.hpp; AnalyzedEquilibrium::energy): O(elements) per mode.
  bool energy = false;
  // What an HTML report animates (scene_drawing in modal/report.hpp;
  // AnalyzedEquilibrium::drawing): two evaluations of the points per mode drawn.
  bool drawing = false;
  // The equilibrium's progress on large scenes (EquilibriumOptions::progress:
  // done of 100, in digits of the residual); the CLI's progress bar. Empty:
  // nothing is called.
  std::function<void(int done, int total)> progress = nullptr;
};

// One analyzed equilibrium: the report values (names, parameters, the
// equilibrium and its modes), the linear model as solved (dense or sparse),
// and the wall time of each phase.
struct Analysis {
  Report report;                              // report.equilibria has exactly one entry
  std::optional<LinearModel> linear;          // the dense path's model (M, K, D, G; constrained: projected)
  std::optional<SparseLinearModel> sparse;    // the sparse path's model (M, K)
  std::optional<TreePencil> tree;             // the matrix-free path's K and M (no matrices formed)
  std::vector<std::pair<std::string, double>> timings;  // phase → seconds, in order (indented names:
                                                        // sub-phases of the phase that follows)
  const Equilibrium& equilibrium() const { return report.equilibria.front().equilibrium; }
  const ModalResult& result() const { return report.equilibria.front().result; }
  // Divergence or flutter: what --require-stable refuses.
  bool unstable() const;
};

// Finds the equilibrium (or polishes options.at), linearizes there and solves
// for the modes, choosing the solver as documented. Throws InputError for
// options that do not fit the scene, NumericalError when no equilibrium or no
// modes can be had.
Analysis analyze(const Model& model, const AnalysisOptions& options = {});

// --- equilibria -------------------------------------------------------------------

struct EquilibriumSurvey {
  Report report;                       // every equilibrium found that could be analyzed, with its modes
  std::vector<std::string> unanalyzed; // equilibria found whose linear model does not exist, in words
};
// Enumerates the equilibria from `options.starts` deterministic starts
// (find_equilibria) and analyzes each with the dense solvers.
EquilibriumSurvey equilibria(const Model& model, const EquilibriumOptions& options = {});

// --- sweep ------------------------------------------------------------------------

struct SweepStudyOptions {
  int modes = -1;           // modes kept per point (-1: all); with extrapolate, modes extrapolated (-1: 3)
  bool extrapolate = false; // one integer axis (a number of links): observed order and Richardson values
  SweepOptions sweep;       // tolerance, refinement, progress callback
};
struct SweepStudy {
  std::string scene_file;
  std::vector<std::string> data_files;         // read by the scene besides itself
  std::vector<SweepAxis> axes;                 // one (a sweep) or two (a stability map)
  std::optional<SweepResult> result;           // one axis
  std::optional<StabilityMap> map;             // two axes
  std::vector<ModeConvergence> convergence;    // extrapolate
  double tolerance = 0;                        // the critical values' relative refinement
};
// A sweep along one axis or a stability map over two (axes from parse_vary).
// Throws SweepInputError or InputError for axes that do not fit, and
// InputError / NumericalError when every point failed (the first failure says why).
SweepStudy sweep(const Model& model, const std::vector<SweepAxis>& axes, const SweepStudyOptions& options = {});

// --- simulate ---------------------------------------------------------------------

struct SimulationRequest {
  double duration = 0;                   // s, > 0
  std::optional<VectorX> at;             // initial configuration, taken as given (default: the scene's
                                         // initial values, brought onto the constraints if any)
  std::optional<VectorX> velocity;       // initial velocities (default: 0)
  std::optional<double> interval;        // output spacing, s (default: duration / 1000)
  double tolerance = SimulationOptions{}.tolerance;
  std::function<void(int done, int total)> progress = nullptr;  // SimulationOptions::progress
};
struct Simulation {
  Trajectory trajectory;
  SimulationOptions options;             // as integrated
  std::vector<std::string> notes;        // e.g. the start was brought onto the constraints
  std::string title, scene_file;         // of the scene (for the HTML report)
  std::vector<std::string> data_files;   // read by the scene besides itself
};
// Throws InputError for a request out of range.
Simulation simulate(const Model& model, const SimulationRequest& request);

// --- amplitude --------------------------------------------------------------------

// The largest scene `amplitude` integrates (each step solves with the dense M).
inline constexpr int amplitude_max_coordinates = 2000;
struct AmplitudeRequest {
  int mode = 1;                          // 1 = the lowest
  std::optional<VectorX> at;             // the equilibrium near this point (default: the initial one)
  AmplitudeOptions options;
};
struct AmplitudeStudy {
  std::string title, scene_file;
  std::vector<std::string> data_files;   // read by the scene besides itself
  int mode = 1;
  double omega2 = 0;                     // of the linear mode, rad²/s²
  AmplitudeResponse response;
  double tolerance = 0;                  // of the integration
};
AmplitudeStudy amplitude(const Model& model, const AmplitudeRequest& request);

// --- writing results --------------------------------------------------------------

// Where a result goes besides the text. Paths are checked by check_outputs
// before computing and written all or none (OutputFiles).
struct Outputs {
  std::string csv;       // analyze: PREFIX (PREFIX_modes.csv, _shapes.csv, _equilibria.csv);
                         // sweep: FILE (+ FILE_critical.csv, with extrapolation also
                         // FILE_convergence.csv and FILE_extrapolation.csv); others: FILE
  std::string json;      // analyze, equilibria
  std::string matrices;  // analyze: a directory for M, K (D, G, N) in Matrix Market
  // analyze: with csv also PREFIX_energy.csv and PREFIX_participation.csv; the
  // analysis must then have its energy distribution (AnalysisOptions::energy).
  bool energy = false;
  // FILE.html (or .htm), one self-contained page (docs/design.md, "HTML
  // reports"): analyze (analysis_html; the analysis should have its drawing,
  // AnalysisOptions::drawing, to animate the modes), equilibria
  // (equilibria_html), sweep (sweep_html, or map_html for two axes), amplitude
  // (amplitude_html) and simulate (simulation_html); check has none.
  std::string report;
};
enum class Command { analyze, equilibria, sweep, simulate, amplitude, check };
// The files `command` will write for `outputs` (the sweep's extra files only
// when `extrapolate`).
std::vector<std::string> output_files(Command command, const Outputs& outputs, bool extrapolate = false);
// check_output_paths on output_files, against the scene file and the data
// files it read (Scene::data_files: known once the scene is read, so a caller
// checks before reading with the scene file alone and after with
// check_outputs_spare_data) as inputs; `--export-matrices` DIR must not be a file or any other output's
// path.
void check_outputs(Command command, const Outputs& outputs, const std::string& scene_file, bool extrapolate = false);
void check_outputs(Command command, const Outputs& outputs, const std::string& scene_file,
                   const std::vector<std::string>& data_files, bool extrapolate = false);
// For a caller that ran check_outputs with the scene file alone before reading
// the scene: the outputs against the data files it read, the one check that
// could not be made before (no second writability probe).
void check_outputs_spare_data(Command command, const Outputs& outputs, const std::vector<std::string>& data_files,
                              bool extrapolate = false);

// Text to `text` (checked: a failed write throws ReportError), files as asked.
void write_analysis(std::ostream& text, const Analysis& analysis, const Outputs& outputs = {});
void write_equilibria(std::ostream& text, const EquilibriumSurvey& survey, const Outputs& outputs = {});
void write_sweep(std::ostream& text, const SweepStudy& study, const Outputs& outputs = {});
void write_amplitude(std::ostream& text, const AmplitudeStudy& study, const Outputs& outputs = {});
// The trajectory CSV to outputs.csv, or to `text` when none is given; the
// report to outputs.report.
void write_simulation(std::ostream& text, const Simulation& simulation, const Outputs& outputs = {});
// `modal check`: the summary of the scene (lists cut at `list_limit` rows; 0: all).
void write_summary(std::ostream& text, const Model& model, std::size_t list_limit = 100);

}  // namespace modal
