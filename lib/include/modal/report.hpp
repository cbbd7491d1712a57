// modal/report.hpp — the report stage: human tables, CSV files and JSON for the
// results of the pipeline (docs/design.md, "Output files").
//
//   modal::Report r = modal::make_report(sys, "models/double_pendulum.toml", scene.parameters);
//   r.equilibria.push_back({equilibrium, modal::solve_modes(modal::linearize(sys, equilibrium.q))});
//   modal::print_analysis(std::cout, r);                  // title, equilibrium, stability, modes, notes
//   modal::write_csv_files("out/dp", r);                  // out/dp_modes.csv, _shapes.csv, _equilibria.csv
//   std::ofstream("out/dp.json") << modal::analysis_json(r);
//   modal::write_trajectory_csv(std::cout, modal::simulate(sys, q0, qd0, {.duration = 10}));  // `modal simulate`
//
// All functions are free functions on plain values; none of them computes
// anything but presentation. CSV numbers are written with 17 significant digits
// (%.17g, exact round trip of a double); fields that have no value (NaN, ±∞:
// omega2 of a complex mode, the period of a zero-frequency mode, …) are empty.
// Text fields are quoted per RFC 4180 when they contain a comma, a double quote
// or a line break. JSON writes non-finite numbers as null.
#pragma once

#include "modal/energy.hpp"
#include "modal/equilibrium.hpp"
#include "modal/modes.hpp"
#include "modal/simulate.hpp"
#include "modal/sweep.hpp"

#include <array>
#include <functional>
#include <iosfwd>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace modal {

// A file could not be written (the message names it). Command-line exit status 2.
class ReportError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What an HTML report draws of a scene with geometry (bodies, particles,
// lattices, networks, imported models, the points of a kinematic map): world
// points at the equilibrium, segments between them, and each animated mode's
// displacement of every point, the linearized motion J φ of the shape's real
// part, scaled so that the largest displacement of the mode is 1.
struct SceneDrawing {
  int dimensions = 3;                       // 2: every point and displacement lies in one plane
  std::array<int, 2> plane{0, 2};           // 2-D: the world axes drawn (0 x, 1 y, 2 z) as horizontal, vertical
  std::vector<Vec3> points;                 // m, world, at the equilibrium (decimated: see note)
  std::vector<std::array<int, 2>> segments; // indices into points: body links, springs
  std::vector<int> modes;                   // the animated modes (1 = the lowest)
  // Per animated mode, per point: J Re φ and J Im φ (empty for a real shape),
  // exact; the motion over a period, J Re φ cos ωt − J Im φ sin ωt, has the
  // largest norm 1.
  std::vector<std::vector<Vec3>> displacements;
  std::vector<std::vector<Vec3>> displacements_imag;
  std::size_t total_points = 0;             // before decimation
  std::string note;                         // what decimation left out, in words (empty: nothing)
};

// Limits of a drawing: a 10⁵-coordinate lattice drawn whole would embed
// hundreds of megabytes; at these limits a report stays under 10 MB.
struct DrawingLimits {
  std::size_t points = 20000;    // every k-th point beyond this (segments between kept points only)
  std::size_t segments = 40000;  // none drawn beyond this
  std::size_t modes = 10;        // the lowest modes are animated
};

// The drawing of `system` at q for the modes of `result` (their shapes are n
// coordinates of q); none for a system that has no points (abstract
// coordinates), whose reports show each shape as a bar chart instead.
std::optional<SceneDrawing> scene_drawing(const System& system, const VectorX& q, const ModalResult& result,
                                          const DrawingLimits& limits = {});

// One equilibrium and the modal solution of the linear model about it.
struct AnalyzedEquilibrium {
  Equilibrium equilibrium;
  ModalResult result;
  // Where each mode's energy is (modal/energy.hpp), when asked for (`--energy`).
  std::optional<EnergyDistribution> energy;
  // What an HTML report animates (`--report`); none for abstract coordinates.
  std::optional<SceneDrawing> drawing;
};

// Everything a report shows. `coordinates` and `kinds` are parallel (n each);
// when `coordinates` is empty, coordinates are named q1 … qn, and when `kinds`
// is empty no values are shown in degrees.
struct Report {
  std::string scene_file;
  std::vector<std::string> data_files;  // read by the scene besides itself (inputs no output may replace)
  std::string title;
  std::vector<std::pair<std::string, double>> parameters;  // final values, file order
  std::vector<std::string> coordinates;
  std::vector<CoordinateKind> kinds;
  std::vector<AnalyzedEquilibrium> equilibria;  // analyze: one; equilibria: all found
};

// A Report with the scene's names filled in and no equilibria yet.
Report make_report(const System& system, std::string scene_file,
                   std::vector<std::pair<std::string, double>> parameters);

// --- small pieces, exposed for tests and other writers -----------------------

// The stability class of one mode in the vocabulary of docs/design.md ("Mode
// kinds and stability classes"):
// oscillatory → "stable", damped → "asymptotically stable", zero → "marginal",
// divergent → "divergence", flutter → "flutter".
const char* mode_stability(ModeKind kind);
// "%.17g", or "" for NaN and ±∞.
std::string csv_number(double value);
// The field as is, or in double quotes (inner quotes doubled) when it contains
// a comma, a double quote, CR or LF.
std::string csv_field(std::string_view text);
// The stability of an analysed equilibrium in words, e.g. "divergence (Morse
// index 1: statically unstable)" or "marginal (2 zero-frequency modes)".
std::string describe_stability(const ModalResult& result);

// One constraint equation's force at an equilibrium: the equation's name
// ("loop.x", "rod"), its multiplier s (N; point: the force component on end a;
// distance: positive pushing the ends apart, −s is the tension), and whether
// statics determines it (false for a redundant equation).
struct ConstraintEquationForce {
  std::string equation;
  double force = 0;
  bool determined = true;
};
std::vector<ConstraintEquationForce> constraint_equation_forces(const ModalResult& result);

// --- CSV (docs/design.md, "Output files") ---------------------------------------
// Header "equilibrium,mode,omega2,growth_rate,omega,frequency_hz,period,
// damping_ratio,stability,error_estimate,residual_bound"; one row per mode per equilibrium,
// equilibrium and mode numbered from 1.
void write_modes_csv(std::ostream& out, const Report& report);
// Header "equilibrium,mode,coordinate,value,amplitude,phase_deg": value is the
// real part of the shape component, amplitude its modulus and phase_deg its
// argument in degrees (complex shapes of first-order problems are scaled so
// that the largest component is 1 at phase 0).
void write_shapes_csv(std::ostream& out, const Report& report);
// Header "equilibrium,stability,morse_index,potential,residual,<coordinate names>…",
// then <name>_rate,<name>_momentum per ignorable coordinate (steady motions)
// and <equation>_force per constraint equation (N; empty when redundant).
void write_equilibria_csv(std::ostream& out, const Report& report);
// Energy distributions (equilibria that have one; docs/design.md, "Energy
// distribution and participation"): header "mode,kind,element,fraction", one
// row per nonzero share (kind "kinetic" or "potential"; no
// potential rows for a mode whose potential shares are not defined).
void write_energy_csv(std::ostream& out, const Report& report);
// Header "mode,direction,participation_factor,effective_mass,
// cumulative_fraction": one row per mode and direction (x, y, z along which
// mass moves; none for first-order problems and kinematic maps).
void write_participation_csv(std::ostream& out, const Report& report);
// Writes PREFIX_modes.csv, PREFIX_shapes.csv, PREFIX_equilibria.csv and, when
// an equilibrium has its energy distribution, PREFIX_energy.csv and
// PREFIX_participation.csv; returns their paths. Throws ReportError when a file cannot be written.
std::vector<std::string> write_csv_files(const std::string& prefix, const Report& report);
// Writes one file with `writer`; throws ReportError when it cannot be written.
void write_file(const std::string& path, void (*writer)(std::ostream&, const Report&),
                const Report& report);
// `modal simulate`: header "time,<coordinate names>…,<coordinate name>_dot…,
// energy,work,energy_error", one row per sample of the trajectory (time in s,
// q, q̇, E and W in J, energy_error = (E − E0 − W) / energy_scale; see
// modal/simulate.hpp). Coordinates are named q1 … qn when the trajectory has
// no names.
void write_trajectory_csv(std::ostream& out, const Trajectory& trajectory);

// --- Matrix Market -------------------------------------------------------------
// A in Matrix Market coordinate format, real, 1-based indices, values in the
// shortest text that reads back to the same double: "symmetric" storing the
// lower triangle when `symmetric`, else "general". `comment` goes on a %-line.
// Throws ReportError when the file cannot be written.
void write_matrix_market(const std::string& path, const SparseMatrix& A, bool symmetric, const std::string& comment);
// Receives a file's text in pieces (OutputFiles::add with a writer).
using TextSink = std::function<void(std::string_view)>;
// The same text, in pieces of at most about 1 MB, to `sink`.
void write_matrix_market(const TextSink& sink, const SparseMatrix& A, bool symmetric, const std::string& comment);
// `--export-matrices DIR`: DIR/M.mtx and DIR/K.mtx, and DIR/D.mtx, DIR/G.mtx
// where the model has them, of the model as analyzed (constrained: the
// matrices on the constraint manifold, with DIR/N.mtx the basis mapping them
// to the coordinates); the directory is created. Returns the paths written.
// Files of these names in DIR that the model does not have (D.mtx of an
// earlier, damped scene) are removed, so that DIR describes this model alone.
std::vector<std::string> export_matrices(const std::string& dir, const LinearModel& model);
std::vector<std::string> export_matrices(const std::string& dir, const SparseLinearModel& model);
class OutputFiles;
// The same files added to `files` (written, and the stale ones removed, when
// it commits, all or none with the run's other outputs); the directory is
// created by the commit (OutputFiles::add_directory). Returns the paths it
// will write.
std::vector<std::string> add_matrix_exports(OutputFiles& files, const std::string& dir, const LinearModel& model);
std::vector<std::string> add_matrix_exports(OutputFiles& files, const std::string& dir,
                                            const SparseLinearModel& model);
inline constexpr const char* exported_matrix_names[] = {"M.mtx", "K.mtx", "D.mtx", "G.mtx", "N.mtx"};

// --- JSON ---------------------------------------------------------------------
// `modal analyze`: {scene, title, parameters{name: value}, coordinates[names],
// equilibrium{coordinates{name: value}, potential, residual, residual_norm,
// iterations}, stability, morse_index, zero_modes, [constraints[{name, type,
// force (point: [x, y, z] on end a, null where not determined) | multiplier
// and tension (distance)}], redundant_equations[names],] modes[{mode, omega2,
// growth_rate, omega, frequency_hz, period, damping_ratio, error_estimate, kind,
// stability, shape[real], shape_imag[only when complex], [energy{kinetic{element:
// share}, potential{term: share} or null}, participation{x|y|z: {participation_factor,
// effective_mass, cumulative_fraction}}: with an energy distribution]}],
// [energy_split, participation_directions[{direction, movable_mass}]], solver, notes}
// for the first equilibrium of the report (indented text).
std::string analysis_json(const Report& report);
// `modal equilibria`: {scene, title, parameters, coordinates, equilibria[{index,
// equilibrium, stability, morse_index, zero_modes, modes, solver, notes}]}.
std::string equilibria_json(const Report& report);
void write_text_file(const std::string& path, const std::string& text);  // throws ReportError

// --- HTML (docs/design.md, "HTML reports") ----------------------------------------
// `modal analyze --report`: one self-contained page (CSS, JavaScript and data
// inline; nothing is fetched when it is opened) for the first equilibrium of
// the report: scene, parameters, the equilibrium, the stability in words, the
// mode table (the CSV's numbers: omega2 … residual_bound), each mode animated
// over the equilibrium (AnalyzedEquilibrium::drawing) or, without a drawing,
// its shape as a bar chart, and with an energy distribution each mode's
// kinetic and potential shares and the participation table. The page's
// element #report-status says, once its script ran, how many plots and
// animated views it drew and how many script errors it met.
std::string analysis_html(const Report& report);
// The other commands' pages, each as self-contained as analysis_html's, from
// the values their CSV writers take; every table shows the CSV's own text
// (the rows of the CSV writer's output), every plot the values behind it
// (long series decimated, the page says so). #report-status counts plots.
// `modal sweep --report`: the branches against the parameter (ω², or Re s and
// Im s when a point is not symmetric), the root locus (s in the complex plane,
// with its mirror image), a Campbell diagram (ω against |Ω|) when the points
// differ in their frame rate (SweepPoint::frame_rate: the parameter is a
// rotation speed), the critical values marked with their error and tabled as
// sweep_critical_csv, the points as sweep_modes_csv, and with `convergence`
// (--extrapolate) |ω − ω∞| against the parameter with each mode's observed
// order, and the extrapolation table (extrapolation_csv).
std::string sweep_html(const SweepResult& result, const std::string& scene_file, double tolerance,
                       const std::vector<ModeConvergence>& convergence = {});
// `modal sweep --report` with two --vary: the grid coloured by stability
// class, the boundary between classes drawn, and the grid as map_csv.
std::string map_html(const StabilityMap& map, const std::string& scene_file);
// `modal amplitude --report`: the period ratio T/T_lin and the departure
// |ω/ω_lin − 1| against the amplitude with the levels' amplitudes marked, the
// scan as amplitude_csv and the departure amplitudes with their errors.
std::string amplitude_html(const std::string& title, const std::string& scene_file, int mode, double omega2,
                           const AmplitudeResponse& response, double tolerance);
// `modal simulate --report`: the coordinates against time (the first 8
// of them) and the energy error (E − E0 − W)/scale, each series
// reduced to its minimum and maximum in each of at most 2000 time buckets; a
// table of 21 samples spread over the run as write_trajectory_csv writes them,
// and the integration's summary.
std::string simulation_html(const Trajectory& trajectory, const SimulationOptions& options,
                            const std::string& title, const std::string& scene_file,
                            const std::vector<std::string>& notes = {});
// `modal equilibria --report`: the potential of each equilibrium by
// stability, the table of write_equilibria_csv, each equilibrium's stability
// in words and its frequency table (write_modes_csv's rows); no animation.
// `unanalyzed`: equilibria found but not analyzed, in words.
std::string equilibria_html(const Report& report, const std::vector<std::string>& unanalyzed = {});

// --- human-readable text --------------------------------------------------------
// Title, the equilibrium (coordinates, angles also in degrees, V, residual),
// stability in words, the mode table, mode shapes (small systems) and notes.
void print_analysis(std::ostream& out, const Report& report);
// One row per equilibrium: index, stability, Morse index, V, residual, coordinates.
void print_equilibria(std::ostream& out, const Report& report);
// `modal check`: title, parameters, bodies (name, joint, parent, mass),
// coordinates (name, kind, initial), springs, loads, total mass, gravity.
// Each list shows its first `list_limit` rows and then says how many it left
// out (a 10⁶-coordinate lattice would otherwise print 360 MB); 0: all rows.
void print_summary(std::ostream& out, const std::string& scene_file,
                   const std::vector<std::pair<std::string, double>>& parameters,
                   const System& system, std::size_t list_limit = 0);

// --- studies: sweeps, maps, convergence, amplitude scans, simulations -----------
// `modal sweep`: the points (class, largest growth rate, the three lowest ω²,
// or ω for first-order models), the critical values with their errors and
// the notes. `tolerance` is the relative width the critical values were
// refined to (SweepOptions::tolerance).
void print_sweep(std::ostream& out, const SweepResult& result, const std::string& scene_file, double tolerance);
// A critical value in words: "P = 2.08578643 ± 1e-11  flutter (stable → flutter:
// loss of stability)  ω = 0.84 rad/s".
std::string describe_critical(const CriticalValue& critical, const std::string& parameter);
// Header "<parameter>,mode,omega2,growth_rate,omega,frequency_hz,period,
// damping_ratio,stability,error_estimate": one row per point and mode ("failed"
// and empty numbers for a point that failed).
std::string sweep_modes_csv(const SweepResult& result);
// Header "parameter,value,error,kind,omega,before,after": one row per critical value.
std::string sweep_critical_csv(const SweepResult& result);
// `modal sweep` with two --vary: the grid as characters (o stable,
// a asymptotically stable, m marginal, D divergence, F flutter, ? failed),
// the second parameter upwards, and the first failures in words.
void print_map(std::ostream& out, const StabilityMap& map, const std::string& scene_file);
// Header "<x>,<y>,stability,max_growth_rate,min_omega2": one row per grid point.
std::string map_csv(const StabilityMap& map);
// `sweep --extrapolate`: ω of the lowest modes at every point with the
// point's cost, then each mode's observed order and Richardson value.
void print_extrapolation(std::ostream& out, const SweepResult& result, const std::vector<ModeConvergence>& modes);
// Header "<parameter>,coordinates,seconds,mode,omega,error_estimate".
std::string convergence_csv(const SweepResult& result, const std::vector<ModeConvergence>& modes);
// Header "mode,n1,n2,n3,omega_n3,order,omega_extrapolated,error,error_rule,
// previous_order,previous_extrapolated,asymptotic,note": one row per mode.
std::string extrapolation_csv(const std::vector<ModeConvergence>& modes);
// `modal amplitude`: the scan (amplitude, ω, ω/ω_lin − 1, spread, cycles),
// the departure amplitudes, and how it was integrated (`tolerance`).
void print_amplitude(std::ostream& out, const std::string& title, const std::string& scene_file, int mode,
                     double omega2, const AmplitudeResponse& response, double tolerance);
// Header "amplitude,oscillates,omega,omega_ratio_minus_1,spread,cycles,simulated_seconds".
std::string amplitude_csv(const AmplitudeResponse& response);
// `modal simulate`'s summary (on stderr): steps, samples, and how well the
// energy (or the energy balance with the work W) held.
void print_simulation_summary(std::ostream& out, const Trajectory& trajectory, const SimulationOptions& options);

// `--timing`: one line per phase (name, milliseconds; names indented by two
// spaces are sub-phases of the phase that follows them), the total of the
// phases, and the peak resident memory of the process (Linux VmHWM).
void print_timings(std::ostream& out, const std::vector<std::pair<std::string, double>>& seconds);

// Progress of long work (sweeps, …) on a terminal: "sweep [#####     ] 12/40
// 3.1 s, about 7 s left", redrawn on stderr in place, shown only when stderr
// is a terminal, the environment variable CI is unset (or empty, "0",
// "false"), `shown` is true (the CLI's --quiet makes it false) and the work
// has taken more than a second; silent in pipes, files and CI. finish()
// clears the line.
class ProgressBar {
 public:
  explicit ProgressBar(std::string label, bool shown = true);
  void update(int done, int total);
  void finish();
  ~ProgressBar();

 private:
  std::string label_;
  bool terminal_ = false;
  bool shown_ = false;
  double start_ = 0;  // s, steady clock
};

// --- output files: checked before computing, written all or none ---------------
// Refuses (ReportError, naming the path and the reason) an output that is a
// directory, that lies in a directory that does not exist or cannot be
// written, that is also one of `inputs` (the scene file, its data files), or
// that is given twice. Call it before a long computation, so that a bad path
// costs nothing.
void check_output_paths(const std::vector<std::string>& outputs, const std::vector<std::string>& inputs = {});
// Refuses (ReportError) an output that is also one of `inputs`: the comparison
// of check_output_paths alone, for inputs known only once a scene is read.
void check_not_inputs(const std::vector<std::string>& outputs, const std::vector<std::string>& inputs);
// Refuses (ReportError) a directory of exported matrices (export_matrices)
// that exists as something other than a directory, or that is, or would
// hold a file that is, one of `others` (the run's other outputs and inputs).
void check_output_directory(const std::string& dir, const std::vector<std::string>& others);
// The files one run writes. commit() writes each to a temporary file beside
// its target and, only when all were written completely, renames them into
// place: either every file is replaced or none (on failure the temporaries
// are removed and ReportError names the file and the reason).
// A file may also be given as a writer, called during commit() with a sink
// for its text (a large matrix is then never held whole in memory), and a
// path as one to remove once the files are in place (a stale output of an
// earlier run; not removed when the commit fails), and a directory to create
// (with its missing parents) before the files are written: the directories
// a commit created are removed again when it fails, so a failed run leaves
// no trace.
class OutputFiles {
 public:
  void add(std::string path, std::string content);
  void add(std::string path, std::function<void(const TextSink&)> writer);
  void remove_after(std::string path);
  void add_directory(std::string path);
  bool empty() const { return files_.empty() && removals_.empty() && directories_.empty(); }
  std::vector<std::string> commit();

 private:
  struct File {
    std::string path;
    std::string content;
    std::function<void(const TextSink&)> writer;  // when set, instead of content
  };
  std::vector<File> files_;
  std::vector<std::string> removals_;
  std::vector<std::string> directories_;
};
// Interrupted runs (SIGINT, SIGTERM, SIGHUP). OutputFiles' temporaries exist
// only while commit() writes them; remove_output_temporaries() unlinks those
// that exist at the moment and removes the directories the commit has created
// for them (add_directory) while they are empty (async-signal-safe), and
// remove_output_temporaries_on_signals() installs handlers that call it and
// then end the process by the same signal (exit status 128 + signal in a
// shell: 130, 143, 129), so an interrupt never leaves a temporary or a partial
// output behind and the previous outputs stay as they were. The CLI installs
// them; a program embedding modal decides for itself.
void remove_output_temporaries() noexcept;
void remove_output_temporaries_on_signals();

// Flushes `out` and throws ReportError("<what>: writing failed …") when the
// stream failed (a full disk, a closed pipe): output is never lost silently.
void check_written(std::ostream& out, const std::string& what);

}  // namespace modal
