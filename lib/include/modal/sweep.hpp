// modal/sweep.hpp — parameter sweeps: frequencies and stability along a
// parameter, critical values refined; stability maps over two parameters.
//
//   const std::string text = read("models/ziegler.toml");
//   modal::SweepResult r = modal::sweep(text, "models/ziegler.toml", {}, modal::parse_vary("P=0:4:41"));
//   for (const modal::CriticalValue& c : r.critical)
//     std::cout << c.value << " ± " << c.error << " " << modal::to_string(c.kind) << " ω = " << c.omega << "\n";
//   // 2.0857864376 ± 1e-11 flutter ω = 0.8408964153
//
// Continuation. The scene text is re-parsed at every value with the parameter
// overridden (so that every expression depending on it follows), the system
// built, and the equilibrium found by find_equilibrium() started from the
// equilibrium of the previous point (the first point from the scene's initial
// configuration): the branch that starts there is followed continuously, stable
// or not. Where the parameter changes the number of coordinates (a number of
// links), the previous equilibrium does not fit and each such point starts from
// its scene's initial configuration. Each point is linearized and solved with all modes, which gives its
// stability class (docs/design.md, "Mode kinds and stability classes").
//
// Critical values. Wherever consecutive points differ in class, the change is
// bracketed between them and the bracket shrunk until its width is at most
// `tolerance` × max(|parameter|, 10⁻⁶ |TO − FROM|) (relative, with a floor for a
// critical value at 0). Which side of the bracket a trial value falls on is
// decided by its class alone; a continuous indicator that changes sign at the
// change only chooses the trial value (regula falsi with the Illinois
// modification, a bisection step whenever two steps have not halved the
// bracket, trials kept a quarter tolerance inside it):
//   divergence, symmetric model     smallest eigenvalue λ of (K, M)
//   divergence, otherwise           det K (a real eigenvalue s crosses 0 where it changes sign)
//   flutter, no damping/gyroscopic  discriminant (μ₁ − μ₂)² of the closest pair of eigenvalues
//                                   μ = ω² of M⁻¹K: > 0 real and distinct, < 0 complex; it is
//                                   linear in the parameter where two frequencies merge
//   flutter, otherwise              largest growth rate σ of an oscillating mode (Hopf crossing)
//   anything else                   none: bisection
// The critical value is the midpoint of the final bracket and `error` its half
// width, a bound on the distance to the class change (as long as the classes
// of the trial points are right; they are decided with the modal stage's error
// estimates).
#pragma once

#include "modal/equilibrium.hpp"
#include "modal/modes.hpp"
#include "modal/scene.hpp"

#include <functional>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace modal {

// A malformed --vary, a parameter the scene does not have, or a sweep that
// cannot be run as asked. Command-line exit status 2.
class SweepInputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// COUNT evenly spaced values from FROM to TO, both included (COUNT ≥ 2, FROM ≠ TO;
// TO < FROM sweeps downwards), or an explicit list of values.
struct SweepAxis {
  std::string name;
  double from = 0;
  double to = 0;
  int count = 0;
  // The explicit list (NAME=V1,V2,…), strictly increasing or strictly
  // decreasing; then count = its size, from = its first and to = its last
  // value. Empty: evenly spaced.
  std::vector<double> values;
  double value(int i) const;  // the i-th value (0 … count − 1); exactly `to` for the last
  bool integer_valued() const;  // every value is an integer
};

// "NAME=FROM:TO:COUNT" (FROM, TO finite numbers, COUNT an integer ≥ 2) or
// "NAME=V1,V2,…" (at least two finite values, strictly monotone; e.g. the
// numbers of links N=10,20,40,80). Throws SweepInputError saying what is wrong
// and what is expected.
SweepAxis parse_vary(std::string_view text);

// The most points one sweep evaluates: along its axis, or in all for a
// stability map (each point is an analysis and keeps its modes in memory; a
// larger request is refused before anything runs, with this limit in words).
inline constexpr long long max_sweep_points = 1'000'000;

// What SweepOptions::analyze_point gives for one point.
struct PointAnalysis {
  Equilibrium equilibrium;        // its q comes back as the next point's start, as it is
  ModalResult result;
  long long coordinates = 0;      // of the whole scene at this point
  std::vector<std::string> names; // the coordinates' names, or empty (SweepResult::coordinates)
};
struct SweepOptions {
  int modes = -1;            // modes kept per point (-1: all); the class always uses all
  bool refine = true;        // refine the critical values (sweep() only)
  double tolerance = 1e-10;  // relative width of the final bracket of a critical value
  int max_evaluations = 200; // per critical value
  EquilibriumOptions equilibrium;
  SceneLimits scene_limits;  // for reading the scene at every point (as it was read before the sweep)
  // Called after every point of the grid (and every evaluation of a refinement)
  // with the points done and the points of the grid in all; may be empty.
  std::function<void(int done, int total)> progress;
  // The analysis of one point in place of the serial one (find_equilibrium,
  // linearize, solve_modes with all modes), as the distributed backend's sweep
  // does it: the equilibrium of the scene at this point from `start` and its
  // lowest modes, with morse_index, zero_modes and stability over the whole
  // spectrum (the inertia). The problem is then the symmetric one,
  // K φ = λ M φ. `scene` and `system` are what was read at this point (its
  // part with `window`); `start` is the equilibrium.q this function returned
  // for the neighbouring point the sweep continues from, or empty: it may not
  // fit (a parameter that changes the scene's size), which the function
  // decides. It may throw as the serial stages do (the point fails with the
  // message). Every call must give the same classes wherever it is made (the
  // distributed sweep runs this function on every process in step). Empty:
  // the serial analysis.
  std::function<PointAnalysis(const Scene& scene, const System& system, const VectorX& start)> analyze_point;
  // Read the scene in parts at every point (SceneWindow: the distributed
  // backend, whose processes each read and build only their part); only with
  // analyze_point, which then gets the part.
  std::optional<SceneWindow> window;
  // With `window`: called on every process once it has read a point, with its
  // failure to read it ("": none), and returns the failure every process then
  // takes ("": none), so that all skip the point together (the distributed
  // backend agrees over its ranks). Empty: each its own.
  std::function<std::string(const std::string& failure)> agree_read;
};

// One value of the parameter.
struct SweepPoint {
  double value = 0;
  bool ok = false;           // false: the point failed and is skipped
  bool scene_error = false;  // the failure is an invalid scene at this value (else numerical)
  std::string failure;       // in words, when !ok
  Equilibrium equilibrium;
  ModalResult result;        // the lowest `modes` modes; stability from all of them
  bool symmetric = true;     // solved as K φ = λ M φ (no damping, gyroscopic, circulatory terms)
  double max_growth_rate = 0;  // largest σ = Re s of all modes, 1/s (0 for a stable conservative system)
  double min_omega2 = 0;       // smallest ω² − σ² = Re(−s²) of all modes: λ_min for symmetric models
  // |Ω| of the frame the scene is written in at this point (frame_rotation,
  // rad/s; 0 for an inertial frame). A sweep whose points differ in it sweeps
  // a rotation speed: its HTML report draws a Campbell diagram against it.
  double frame_rate = 0;
  double seconds = 0;          // wall time of the point: parse, build, equilibrium, linearization, all modes
  long long coordinates = 0;   // of the scene at this point (equilibrium.q has them all, except from analyze_point)
};

enum class CriticalKind {
  divergence,  // a real eigenvalue crosses zero (conservative: det K = 0)
  flutter,     // a pair of frequencies merges, or a complex pair crosses the imaginary axis
  marginal,    // a change between classes that are neither divergence nor flutter
};
const char* to_string(CriticalKind k);  // "divergence", "flutter", "marginal"

struct CriticalValue {
  double value = 0;       // the parameter where the class changes
  double error = 0;       // half width of the final bracket (≥ |value − true value|)
  CriticalKind kind = CriticalKind::marginal;
  Stability before = Stability::stable;  // class just below `value` (towards FROM)
  Stability after = Stability::stable;   // class just beyond it (towards TO)
  double omega = 0;       // rad/s: frequency of the merging / crossing pair there; 0 for
                          // divergence; NaN when there is none (marginal)
  int evaluations = 0;    // points evaluated by the refinement
  std::string indicator;  // what guided the refinement, in words
  bool refined = false;   // false: the bracket is the grid interval (refinement off or failed)

  bool restabilization() const;  // unstable before, not after: the class becomes stable again
  bool loss() const;             // not unstable before, unstable after
};

struct SweepResult {
  SweepAxis axis;
  std::vector<std::string> coordinates;  // of the first point that built
  std::vector<SweepPoint> points;        // axis.count, in sweep order
  std::vector<CriticalValue> critical;   // in sweep order
  std::vector<std::string> notes;        // what a user should read (refinements cut short, …)
  int evaluations = 0;                   // all evaluated points (grid and refinement)
};

// The sweep along one parameter. `fixed` are further overrides (--set) that
// hold for every point; `file` names the scene in messages. Throws SceneError
// when the scene (with `fixed`) is invalid, SweepInputError when the axis names
// no parameter of the scene or one that `fixed` also sets. Points that fail
// are kept with their message (SweepPoint::ok false).
SweepResult sweep(const std::string& scene_text, const std::string& file,
                  const std::vector<ParameterOverride>& fixed, const SweepAxis& axis,
                  const SweepOptions& options = {});

// One point of a stability map.
struct MapPoint {
  double x = 0, y = 0;       // values of the first and second parameter
  bool ok = false;
  bool scene_error = false;
  std::string failure;
  Stability stability = Stability::stable;
  double max_growth_rate = 0;  // as in SweepPoint
  double min_omega2 = 0;       // as in SweepPoint
};

struct StabilityMap {
  SweepAxis x, y;
  std::vector<MapPoint> points;  // x.count × y.count, x fastest: points[j * x.count + i]
  const MapPoint& at(int i, int j) const { return points[static_cast<std::size_t>(j * x.count + i)]; }
};

// The class at every point of the grid x × y (no refinement). Each row (fixed
// y) is continued along x from its first point, which is continued from the
// first point of the previous row.
StabilityMap sweep_map(const std::string& scene_text, const std::string& file,
                       const std::vector<ParameterOverride>& fixed, const SweepAxis& x,
                       const SweepAxis& y, const SweepOptions& options = {});

// --- convergence in a discretization parameter (modal sweep --extrapolate) -------
//
//   const modal::SweepResult r = modal::sweep(text, "models/hanging_chain.toml", {}, modal::parse_vary("N=10,20,40,80,160"));
//   for (const modal::ModeConvergence& c : modal::extrapolate_modes(r, 3))
//     if (c.extrapolation.asymptotic)
//       std::cout << c.mode << ": p = " << c.extrapolation.order << ", ω∞ = " << c.extrapolation.value
//                 << " ± " << c.extrapolation.error << " rad/s\n";
//   // 1: p = 0.98579, ω∞ = 3.76615 ± 0.00023 rad/s  (R3: (j₀,₁/2) sqrt(g/L) = 3.7660674)
//
// A discretized model's value f(N) (N links, elements, …) is assumed to follow
// f(N) = f∞ + b N^−p + smaller terms for N large enough (the asymptotic range).
// From the last three points N1 < N2 < N3 (any spacing) the observed order p
// solves
//     (f1 − f2)/(f2 − f3) = (N1^−p − N2^−p)/(N2^−p − N3^−p),
// whose right side increases strictly with p from ln(N2/N1)/ln(N3/N2) (p → 0)
// to ∞, so p > 0 exists and is unique exactly when the left side exceeds that
// limit: the differences have one sign and shrink faster than a logarithm
// would. p is found by bisection on the logarithm of both sides (to 1e-13
// relative; p ≤ 100). The Richardson value is then
//     f∞ = f3 + (f3 − f2)/(r^p − 1),  r = N3/N2.
//
// Error rule (`error`, with the term that gave it in `error_rule`):
//  - with a fourth point N0 < N1 whose triple (N0, N1, N2) is in the
//    asymptotic range too, giving p' and f∞':
//        max(|f∞ − f∞'|, S |p − p'| |f∞ − f3|),  S = r^p ln r/(r^p − 1).
//    The first term is the usual check of an extrapolation against the
//    previous one: as long as the extrapolants' own errors shrink by at least
//    a factor 2 from one triple to the next, or change sign, it exceeds the
//    error of f∞. The second is the sensitivity of f∞ to the order
//    (∂f∞/∂p = −S (f∞ − f3)) times the order's drift between the triples: it
//    guards against two extrapolants agreeing by accident while the power law
//    is still bending.
//  - with only three usable points: |f∞ − f3|, the correction itself. Three
//    points fix f∞, b and p exactly, so nothing checks the power law; the
//    estimate only claims that f∞ is no worse than the finest model.
//  - plus, always, the propagated errors of the inputs themselves (the
//    modal stage's error estimates, at least 8 ε |f|):
//    (r^p δ3 + δ2)/(r^p − 1).
// Not in the asymptotic range (no value is made up; `reason` says which):
// fewer than three values, a difference f2 − f1 or f3 − f2 of zero or at the
// level of the inputs' errors (10 δ), differences of opposite signs
// (oscillation), or differences that do not shrink fast enough for any p > 0
// (the ratio of the differences not above the p → 0 limit by more than twice
// its own relative uncertainty from the inputs' errors).

// The extrapolation of one sequence to N → ∞.
struct Extrapolation {
  bool asymptotic = false;  // false: no order and no value; `reason` says why
  std::string reason;       // in words, when !asymptotic
  double n1 = 0, n2 = 0, n3 = 0;  // the triple used (the last three values)
  double order = std::numeric_limits<double>::quiet_NaN();  // observed p
  double value = std::numeric_limits<double>::quiet_NaN();  // f∞, units of f
  double error = std::numeric_limits<double>::quiet_NaN();  // estimate of |f∞ − the limit|, units of f
  std::string error_rule;   // which term of the rule gave `error`
  double previous_order = std::numeric_limits<double>::quiet_NaN();  // p' of (N0, N1, N2), if asymptotic
  double previous_value = std::numeric_limits<double>::quiet_NaN();  // f∞' of (N0, N1, N2), if asymptotic
};

// Richardson extrapolation of f(n) to n → ∞ from the last three values (the
// fourth from last, when there is one, for the error estimate; rule above).
// n: strictly increasing positive values; f: the values, same size; f_error:
// absolute error estimates of f (same size, or empty: rounding only). Fewer
// than three values give !asymptotic; sizes that differ or n not strictly
// increasing and positive throw std::invalid_argument.
Extrapolation richardson(const std::vector<double>& n, const std::vector<double>& f,
                         const std::vector<double>& f_error = {});

// The convergence of one mode's frequency along an integer axis.
struct ModeConvergence {
  int mode = 0;                  // 1: the lowest
  std::vector<double> n;         // the axis values whose point gave this mode, increasing
  std::vector<double> omega;     // ω (rad/s) there
  std::vector<double> omega_error;  // its error estimate (rad/s) from the modal stage
  Extrapolation extrapolation;   // of ω
};

// Throws SweepInputError unless `axis` can be extrapolated in: integer values
// ≥ 1, at least three of them.
void check_extrapolation_axis(const SweepAxis& axis);

// ω of each of the lowest `modes` modes (by index, as solved) at the points
// that worked and have that mode oscillating (ω > 0), sorted by the axis value,
// and its Richardson extrapolation. Throws SweepInputError as
// check_extrapolation_axis().
std::vector<ModeConvergence> extrapolate_modes(const SweepResult& result, int modes);

}  // namespace modal
