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
// or not. Each point is linearized and solved with all modes, which gives its
// stability class (DESIGN.md §1).
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
// TO < FROM sweeps downwards).
struct SweepAxis {
  std::string name;
  double from = 0;
  double to = 0;
  int count = 0;
  double value(int i) const;  // the i-th value (0 … count − 1); exactly `to` for the last
};

// "NAME=FROM:TO:COUNT" (FROM, TO finite numbers, COUNT an integer ≥ 2). Throws
// SweepInputError saying what is wrong and what is expected.
SweepAxis parse_vary(std::string_view text);

struct SweepOptions {
  int modes = -1;            // modes kept per point (-1: all); the class always uses all
  bool refine = true;        // refine the critical values (sweep() only)
  double tolerance = 1e-10;  // relative width of the final bracket of a critical value
  int max_evaluations = 200; // per critical value
  EquilibriumOptions equilibrium;
  // Called after every point of the grid (and every evaluation of a refinement)
  // with the points done and the points of the grid in all; may be empty.
  std::function<void(int done, int total)> progress;
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

}  // namespace modal
