// lib/sweep/sweep.cpp — sweep(), sweep_map(), parse_vary(): continuation of the
// equilibrium along a parameter grid, classification at every point, and the
// refinement of every change of class (the method is described in
// modal/sweep.hpp).
#include "modal/sweep.hpp"

#include "modal/linearize.hpp"
#include "modal/modes.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <optional>
#include <tuple>
#include <utility>

namespace modal {
namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

// Exact text of a double (round trip), for --set style overrides.
std::string exact_text(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string short_text(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

bool unstable(Stability s) { return s == Stability::divergence || s == Stability::flutter; }

// What guides the refinement of one change of class (modal/sweep.hpp).
enum class Indicator { none, real_eigenvalue, discriminant, growth_rate };

const char* describe(Indicator i) {
  switch (i) {
    case Indicator::none: return "bisection on the class";
    case Indicator::real_eigenvalue:
      return "regula falsi on the real eigenvalue μ of M⁻¹K nearest 0 (signed by det K)";
    case Indicator::discriminant:
      return "regula falsi on the discriminant (μ₁ − μ₂)² of the closest pair of eigenvalues of M⁻¹K";
    case Indicator::growth_rate: return "regula falsi on the largest growth rate of an oscillating mode";
  }
  return "";
}

CriticalKind kind_of(Stability before, Stability after) {
  const bool div = before == Stability::divergence || after == Stability::divergence;
  const bool flu = before == Stability::flutter || after == Stability::flutter;
  if (div && flu) return after == Stability::flutter ? CriticalKind::flutter : CriticalKind::divergence;
  if (div) return CriticalKind::divergence;
  if (flu) return CriticalKind::flutter;
  return CriticalKind::marginal;
}

// Everything one point of the parameter space gives.
struct Evaluation {
  bool ok = false;
  bool scene_error = false;
  std::string failure;
  Equilibrium equilibrium;
  ModalResult result;  // all modes
  std::vector<std::string> coordinates;
  long long coordinate_count = 0;
  bool symmetric = true;
  bool velocity_terms = false;  // damping or gyroscopic terms
  double max_growth_rate = 0;
  double min_omega2 = 0;
  double frame_rate = 0;  // |Ω| of the scene's frame, rad/s
  double f = nan;      // the requested indicator
  double omega = nan;  // frequency of the pair that the indicator follows, rad/s
};

// Real eigenvalues (sorted) and complex ones (upper half plane) of M⁻¹K.
struct Spectrum {
  std::vector<double> real;
  std::vector<std::complex<double>> complex;
};

// `lin` null: a symmetric problem solved elsewhere (SweepOptions::analyze_point).
Spectrum stiffness_spectrum(const LinearModel* lin, const ModalResult& r) {
  Spectrum sp;
  if (lin == nullptr || lin->symmetric()) {  // the modes are the eigenvalues λ of (K, M)
    for (const Mode& m : r.modes) sp.real.push_back(m.omega2);
  } else {
    const MatrixX MinvK = Eigen::LLT<MatrixX>(0.5 * (lin->M + lin->M.transpose())).solve(lin->K);
    Eigen::EigenSolver<MatrixX> eig(MinvK, false);
    if (eig.info() != Eigen::Success) return sp;
    for (Eigen::Index i = 0; i < eig.eigenvalues().size(); ++i) {
      const std::complex<double> mu = eig.eigenvalues()(i);
      if (mu.imag() == 0)
        sp.real.push_back(mu.real());
      else if (mu.imag() > 0)
        sp.complex.push_back(mu);
    }
  }
  std::sort(sp.real.begin(), sp.real.end());
  return sp;
}

// The frequency of a pair of eigenvalues μ = ω² that merge: (μ₁μ₂)^¼.
double pair_frequency(double product, double sum) {
  return product > 0 && sum > 0 ? std::sqrt(std::sqrt(product)) : nan;
}

// `lin` null: the symmetric problem's lowest modes only (SweepOptions::
// analyze_point); the real eigenvalue nearest 0 is then known only when the
// modes hold every negative eigenvalue and one more.
void compute_indicator(Indicator ind, const LinearModel* lin, Evaluation& e) {
  switch (ind) {
    case Indicator::none: return;
    case Indicator::real_eigenvalue: {
      if (lin == nullptr && !(e.result.modes.size() > static_cast<std::size_t>(e.result.morse_index))) return;
      const Spectrum sp = stiffness_spectrum(lin, e.result);
      if (sp.real.empty()) return;
      double nearest = std::numeric_limits<double>::infinity();
      int negatives = 0;
      for (double mu : sp.real) {
        nearest = std::min(nearest, std::abs(mu));
        if (mu < 0) ++negatives;
      }
      e.f = negatives % 2 == 0 ? nearest : -nearest;  // sign of det K (complex pairs are positive)
      e.omega = 0;
      return;
    }
    case Indicator::discriminant: {
      if (lin == nullptr) return;  // a symmetric problem has no merging pair, and not all modes are known
      const Spectrum sp = stiffness_spectrum(lin, e.result);
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i + 1 < sp.real.size(); ++i) {
        const double d = (sp.real[i + 1] - sp.real[i]) * (sp.real[i + 1] - sp.real[i]);
        if (d < best) {
          best = d;
          e.omega = pair_frequency(sp.real[i] * sp.real[i + 1], sp.real[i] + sp.real[i + 1]);
        }
      }
      for (const std::complex<double>& mu : sp.complex) {
        const double d = -4 * mu.imag() * mu.imag();
        if (d < best) {
          best = d;
          e.omega = pair_frequency(std::norm(mu), 2 * mu.real());
        }
      }
      if (std::isfinite(best)) e.f = best;
      return;
    }
    case Indicator::growth_rate: {
      double best = -std::numeric_limits<double>::infinity();
      for (const Mode& m : e.result.modes)
        if (m.omega > m.error_estimate && m.growth_rate > best) {
          best = m.growth_rate;
          e.omega = m.omega;
        }
      if (std::isfinite(best)) e.f = best;
      return;
    }
  }
}

// Runs the pipeline at one point of the parameter space.
class Evaluator {
 public:
  Evaluator(const std::string& text, const std::string& file, const std::vector<ParameterOverride>& fixed,
            std::vector<std::string> names, const SweepOptions& options)
      : text_(text), file_(file), fixed_(fixed), names_(std::move(names)), options_(options) {}

  Evaluation operator()(const std::vector<double>& values, const VectorX* start, Indicator ind) const {
    Evaluation e;
    std::vector<ParameterOverride> overrides = fixed_;
    for (std::size_t i = 0; i < names_.size(); ++i) overrides.push_back({names_[i], exact_text(values[i])});
    std::optional<Scene> scene;
    std::optional<System> sys;
    std::string failure;
    try {
      scene.emplace(parse_scene(text_, file_, overrides, options_.scene_limits,
                                options_.window ? &*options_.window : nullptr));
      sys.emplace(build_system(*scene));
    } catch (const SceneError& ex) {
      failure = std::string("invalid scene: ") + ex.what();
    } catch (const std::invalid_argument& ex) {
      failure = std::string("invalid scene: ") + ex.what();
    } catch (const std::exception& ex) {
      if (!options_.agree_read) throw;
      failure = std::string("the scene could not be read: ") + ex.what();  // on this process alone, e.g. its memory
    }
    if (options_.agree_read) failure = options_.agree_read(failure);
    if (!failure.empty()) {
      e.scene_error = true;
      e.failure = failure;
      return e;
    }
    e.frame_rate = sys->frame_rotation().norm();
    std::string stage = "no equilibrium";
    try {
      std::optional<LinearModel> lin;
      if (options_.analyze_point) {
        stage = "the analysis failed";
        PointAnalysis a = options_.analyze_point(*scene, *sys, start != nullptr ? *start : VectorX());
        e.equilibrium = std::move(a.equilibrium);
        e.result = std::move(a.result);
        e.coordinates = std::move(a.names);
        e.coordinate_count = a.coordinates;
      } else {
        const VectorX q0 = start != nullptr && start->size() == sys->size() ? *start : sys->initial_configuration();
        e.coordinate_count = sys->size();
        // A point whose scene the parameter has grown past what fits (--vary N=…).
        stage = "not analyzed";
        if (const auto r = memory_refusal(dense_analysis_memory(*sys),
                                          "the dense analysis of " + std::to_string(sys->size()) + " coordinates",
                                          options_.scene_limits.memory))
          throw std::runtime_error(*r);
        stage = "no equilibrium";
        e.equilibrium = find_equilibrium(*sys, q0, options_.equilibrium);
        stage = "at a joint limit";
        if (const std::string why = active_limit(*sys, e.equilibrium); !why.empty()) throw std::runtime_error(why);
        stage = "linearization failed";
        lin.emplace(linearize(*sys, e.equilibrium.q));
        stage = "eigen-solution failed";
        e.result = solve_modes(*lin);
        e.coordinates = lin->coordinates;
        e.symmetric = lin->symmetric();
        e.velocity_terms = lin->has_damping || lin->has_gyroscopic;
      }
      e.max_growth_rate = e.result.modes.empty() ? 0.0 : -std::numeric_limits<double>::infinity();
      e.min_omega2 = e.result.modes.empty() ? 0.0 : std::numeric_limits<double>::infinity();
      for (const Mode& m : e.result.modes) {
        e.max_growth_rate = std::max(e.max_growth_rate, m.growth_rate);
        const double w2 = std::isfinite(m.omega2) ? m.omega2 : (-(m.s * m.s)).real();
        e.min_omega2 = std::min(e.min_omega2, w2);
      }
      compute_indicator(ind, lin ? &*lin : nullptr, e);
      e.ok = true;
    } catch (const std::exception& ex) {
      e.failure = stage + ": " + ex.what();
    }
    return e;
  }

 private:
  const std::string& text_;
  const std::string& file_;
  const std::vector<ParameterOverride>& fixed_;
  std::vector<std::string> names_;
  const SweepOptions& options_;
};

// Checks the scene and the axes before anything runs.
void validate(const std::string& text, const std::string& file, const std::vector<ParameterOverride>& fixed,
              const std::vector<const SweepAxis*>& axes, const SweepOptions& options) {
  if (options.window && !options.analyze_point)
    throw std::invalid_argument("SweepOptions::window needs analyze_point (a scene read in parts has no serial analysis)");
  // SceneError: bad scene or --set
  const Scene scene = parse_scene(text, file, fixed, options.scene_limits, options.window ? &*options.window : nullptr);
  std::string known;
  for (const auto& [name, value] : scene.parameters) known += (known.empty() ? "" : ", ") + name;
  for (const SweepAxis* axis : axes) {
    if (axis->count < 2 || !std::isfinite(axis->from) || !std::isfinite(axis->to) || axis->from == axis->to)
      throw SweepInputError("--vary " + axis->name + ": needs finite FROM ≠ TO and COUNT ≥ 2");
    if (!axis->values.empty()) {
      bool monotone = axis->values.size() == static_cast<std::size_t>(axis->count);
      for (int i = 1; monotone && i < axis->count; ++i)
        monotone = std::isfinite(axis->value(i)) && (axis->value(i) - axis->value(i - 1)) * (axis->to - axis->from) > 0;
      if (!monotone)
        throw SweepInputError("--vary " + axis->name + ": a list of values must be finite and strictly monotone");
    }
    const bool found = std::any_of(scene.parameters.begin(), scene.parameters.end(),
                                   [&](const auto& p) { return p.first == axis->name; });
    if (!found)
      throw SweepInputError("--vary: '" + axis->name + "' is not a parameter of " + file +
                            (known.empty() ? " (it has no [parameters])" : "; its parameters are: " + known));
    for (const ParameterOverride& o : fixed)
      if (o.name == axis->name)
        throw SweepInputError("--vary and --set both give the parameter '" + axis->name + "'");
  }
  if (axes.size() == 2 && axes[0]->name == axes[1]->name)
    throw SweepInputError("the two --vary options name the same parameter '" + axes[0]->name + "'");
  long long points = 1;
  for (const SweepAxis* axis : axes) points *= axis->count;
  if (points > max_sweep_points)
    throw SweepInputError("the stability map would have " + std::to_string(points) + " points (" +
                          std::to_string(axes.front()->count) + " × " + std::to_string(axes.back()->count) +
                          "); a sweep takes at most " + std::to_string(max_sweep_points));
}

void fill_point(SweepPoint& p, const Evaluation& e, int modes) {
  p.ok = e.ok;
  p.scene_error = e.scene_error;
  p.failure = e.failure;
  if (!e.ok) return;
  p.equilibrium = e.equilibrium;
  p.result = e.result;
  if (modes >= 0 && static_cast<std::size_t>(modes) < p.result.modes.size())
    p.result.modes.resize(static_cast<std::size_t>(modes));
  p.symmetric = e.symmetric;
  p.max_growth_rate = e.max_growth_rate;
  p.min_omega2 = e.min_omega2;
  p.frame_rate = e.frame_rate;
  p.coordinates = e.coordinate_count;
}

// The change of class between a (class ea) and b (class eb), neighbours in sweep order.
CriticalValue refine(const Evaluator& evaluate, const SweepAxis& axis, double a, Evaluation ea, double b,
                     Evaluation eb, const SweepOptions& options, std::vector<std::string>& notes) {
  CriticalValue c;
  c.before = ea.result.stability;
  c.after = eb.result.stability;
  c.kind = kind_of(c.before, c.after);
  c.omega = c.kind == CriticalKind::divergence ? 0.0 : nan;

  Indicator ind = Indicator::none;
  if (c.kind == CriticalKind::divergence && !(unstable(c.before) && unstable(c.after)))
    ind = Indicator::real_eigenvalue;
  if (c.kind == CriticalKind::flutter && !(unstable(c.before) && unstable(c.after)))
    ind = ea.velocity_terms || eb.velocity_terms ? Indicator::growth_rate : Indicator::discriminant;

  // Which side of the change a class belongs to: that of b, or not.
  const Stability target = eb.result.stability;
  auto on_b_side = [&](Stability s) {
    if (c.kind == CriticalKind::divergence && ind != Indicator::none)
      return (s == Stability::divergence) == (target == Stability::divergence);
    if (c.kind == CriticalKind::flutter && ind != Indicator::none)
      return (s == Stability::flutter) == (target == Stability::flutter);
    return s == target;
  };

  const double span = std::abs(axis.to - axis.from);
  auto tolerance = [&] { return options.tolerance * std::max({std::abs(a), std::abs(b), 1e-6 * span}); };

  if (!options.refine) {
    c.value = 0.5 * (a + b);
    c.error = 0.5 * std::abs(b - a);
    c.indicator = "none (not refined)";
    return c;
  }

  if (ind != Indicator::none) {  // the endpoints again, with the indicator
    Evaluation ra = evaluate({a}, &ea.equilibrium.q, ind), rb = evaluate({b}, &eb.equilibrium.q, ind);
    c.evaluations += 2;
    if (ra.ok && rb.ok && ra.result.stability == ea.result.stability &&
        rb.result.stability == eb.result.stability) {
      ea = std::move(ra);
      eb = std::move(rb);
    } else {
      ind = Indicator::none;
    }
  }
  c.indicator = describe(ind);
  double fa = ea.f, fb = eb.f;
  bool secant = ind != Indicator::none && std::isfinite(fa) && std::isfinite(fb) && fa * fb < 0;
  if (ind != Indicator::none && !secant) c.indicator = describe(Indicator::none);

  double undecided_lo = std::numeric_limits<double>::infinity(), undecided_hi = -undecided_lo;
  double undecided_error = 0;  // largest error estimate of an undecided trial's zero mode, in indicator units
  // The latest trials on either side whose class was decided: they give the
  // indicator's slope across the change.
  double decided_a = a, decided_fa = fa, decided_b = b, decided_fb = fb;
  int last = 0;  // −1: a was replaced last, +1: b
  int since_halving = 0;
  double checkpoint = std::abs(b - a);
  bool noted_third = false;
  while (std::abs(b - a) > tolerance() && c.evaluations < options.max_evaluations) {
    const double tol = tolerance();
    double x = a + 0.5 * (b - a);
    if (secant && since_halving < 2) {
      const double s = b - fb * (b - a) / (fb - fa);
      const double lo = std::min(a, b) + 0.25 * tol, hi = std::max(a, b) - 0.25 * tol;
      if (std::isfinite(s) && lo < hi) x = std::clamp(s, lo, hi);
    }
    if (x == a || x == b) break;  // no representable value in between
    const VectorX& start = std::abs(x - a) <= std::abs(x - b) ? ea.equilibrium.q : eb.equilibrium.q;
    Evaluation ex = evaluate({x}, &start, ind);
    ++c.evaluations;
    if (!ex.ok) {
      notes.push_back("the refinement of the change at " + axis.name + " between " + short_text(a) + " and " +
                      short_text(b) + " stopped at " + axis.name + " = " + short_text(x) + ": " + ex.failure);
      break;
    }
    const Stability sx = ex.result.stability;
    if (sx == Stability::marginal && c.kind != CriticalKind::marginal && sx != ea.result.stability &&
        sx != eb.result.stability) {
      // A zero mode: x is the change itself, up to rounding (the interpolation
      // hits it exactly when the indicator is linear in the parameter). Close
      // the bracket around it.
      const double d = std::copysign(0.25 * tol, b - a);
      Evaluation el = evaluate({x - d}, &ex.equilibrium.q, ind), er = evaluate({x + d}, &ex.equilibrium.q, ind);
      c.evaluations += 2;
      if (el.ok && er.ok && el.result.stability == ea.result.stability && on_b_side(er.result.stability)) {
        a = x - d;
        b = x + d;
        ea = std::move(el);
        eb = std::move(er);
        break;
      }
    }
    if (sx != ea.result.stability && sx != eb.result.stability && !noted_third &&
        !(sx == Stability::marginal && c.kind != CriticalKind::marginal)) {  // a zero mode at a change is expected
      noted_third = true;
      notes.push_back("between " + axis.name + " = " + short_text(a) + " and " + short_text(b) + " the class is also " +
                      to_string(sx) + " (at " + short_text(x) + "): refine the grid to separate the changes");
    }
    bool on_b = on_b_side(sx);
    double fx = ex.f;
    if (sx != c.before && sx != c.after) {
      // The class cannot tell (typically a mode that is zero within its error
      // estimate, in a band around the change whose width is that error over
      // the indicator's slope): the continuous indicator's sign decides, and
      // the reported error will cover every such undecided trial.
      undecided_lo = std::min(undecided_lo, x);
      undecided_hi = std::max(undecided_hi, x);
      for (const Mode& m : ex.result.modes)
        if (m.kind == ModeKind::zero)  // ω² units: λ's error, or |δs|² for a first-order s near 0
          undecided_error = std::max(undecided_error, ex.symmetric ? m.error_estimate : m.error_estimate * m.error_estimate);
      if (secant && std::isfinite(fx) && fx != 0) on_b = (fx > 0) == (fb > 0);
    } else if (std::isfinite(fx)) {
      (on_b ? decided_b : decided_a) = x;
      (on_b ? decided_fb : decided_fa) = fx;
    }
    if (secant) {
      if (!std::isfinite(fx)) {
        secant = false;
      } else {  // the class decides the side; keep the indicator's sign consistent with it
        const double side = on_b ? fb : fa;
        if (fx == 0 || (fx > 0) != (side > 0)) fx = std::copysign(std::max(std::abs(fx), 1e-300), side);
      }
    }
    if (on_b) {
      b = x;
      fb = fx;
      if (last == 1) fa *= 0.5;
      last = 1;
      eb = std::move(ex);
    } else {
      a = x;
      fa = fx;
      if (last == -1) fb *= 0.5;
      last = -1;
      ea = std::move(ex);
    }
    if (std::abs(b - a) <= 0.5 * checkpoint) {  // halved: the interpolation is doing its work
      checkpoint = std::abs(b - a);
      since_halving = 0;
    } else {
      ++since_halving;  // two steps without halving: the next one bisects
    }
  }
  c.value = 0.5 * (a + b);
  c.error = 0.5 * std::abs(b - a);
  c.refined = std::abs(b - a) <= tolerance();
  if (undecided_lo <= undecided_hi) {
    // The class could not confirm the side of these trials: the change lies
    // somewhere in the band where a mode is zero within its error estimate,
    // whose half width is that estimate over the indicator's slope.
    c.error = std::max({c.error, std::abs(undecided_lo - c.value), std::abs(undecided_hi - c.value)});
    const double slope = std::abs(decided_fb - decided_fa) / std::abs(decided_b - decided_a);
    if (secant && slope > 0 && std::isfinite(slope)) c.error = std::max(c.error, undecided_error / slope);
  }
  if (c.refined && 2 * c.error > options.tolerance * std::max(std::abs(a), std::abs(b))) {
    // Refined to the absolute floor near 0, not to the tolerance of the value:
    // say so, with the interval. A narrower sweep locates a change that is
    // not at 0 itself; one at 0 has no scale, and its bracket is the answer.
    const double low = c.value - c.error, high = c.value + c.error;
    notes.push_back("the change at " + axis.name + " ≈ " + short_text(c.value) +
                    " lies within 1e-6 of the swept range (" + short_text(span) +
                    ") from 0, where the refinement stops at " + short_text(1e-6 * options.tolerance) +
                    " of the range rather than " + short_text(options.tolerance) + " of the value: it lies between " +
                    short_text(low) + " and " + short_text(high) +
                    (low <= 0 && high >= 0 ? ", an interval that holds 0; unless the change is at 0 itself, a sweep "
                                             "of that interval locates it further"
                                           : "; a sweep of that interval locates it further"));
  }
  if (!c.refined && c.evaluations >= options.max_evaluations)
    notes.push_back("the change at " + axis.name + " ≈ " + short_text(c.value) + " was not refined to the tolerance within " +
                    std::to_string(options.max_evaluations) + " evaluations");
  if (c.kind == CriticalKind::flutter && ind != Indicator::none) {
    double sum = 0;
    int count = 0;
    for (double w : {ea.omega, eb.omega})
      if (std::isfinite(w)) sum += w, ++count;
    c.omega = count > 0 ? sum / count : nan;
  }
  return c;
}

// Two changes that meet (a class seen at a single point between them, such as
// a zero mode exactly at a grid value) are one change.
std::vector<CriticalValue> merge_touching(std::vector<CriticalValue> in, double tolerance) {
  std::vector<CriticalValue> out;
  for (CriticalValue& c : in) {
    if (!out.empty()) {
      CriticalValue& p = out.back();
      const double gap = std::abs(c.value - p.value);
      if (gap <= p.error + c.error + tolerance * std::max({std::abs(p.value), std::abs(c.value), 1e-300})) {
        const double lo = std::min(p.value - p.error, c.value - c.error);
        const double hi = std::max(p.value + p.error, c.value + c.error);
        p.value = 0.5 * (lo + hi);
        p.error = 0.5 * (hi - lo);
        p.after = c.after;
        p.kind = kind_of(p.before, p.after);
        p.omega = p.kind == CriticalKind::divergence ? 0.0 : (std::isfinite(p.omega) ? p.omega : c.omega);
        p.evaluations += c.evaluations;
        p.refined = p.refined && c.refined;
        continue;
      }
    }
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace

double SweepAxis::value(int i) const {
  if (!values.empty()) return values[static_cast<std::size_t>(std::clamp(i, 0, static_cast<int>(values.size()) - 1))];
  if (i >= count - 1) return to;
  return from + (to - from) * (static_cast<double>(i) / static_cast<double>(count - 1));
}

bool SweepAxis::integer_valued() const {
  for (int i = 0; i < count; ++i)
    if (const double v = value(i); !std::isfinite(v) || v != std::floor(v)) return false;
  return count > 0;
}

const char* to_string(CriticalKind k) {
  switch (k) {
    case CriticalKind::divergence: return "divergence";
    case CriticalKind::flutter: return "flutter";
    case CriticalKind::marginal: return "marginal";
  }
  return "unknown";
}

bool CriticalValue::restabilization() const { return unstable(before) && !unstable(after); }
bool CriticalValue::loss() const { return !unstable(before) && unstable(after); }

SweepAxis parse_vary(std::string_view text) {
  const std::string expected = "--vary expects NAME=FROM:TO:COUNT (e.g. P=0:4:41) or NAME=V1,V2,... (e.g. N=10,20,40)";
  const std::string got = "; got '" + std::string(text) + "'";
  auto trim = [](std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
  };
  const std::size_t eq = text.find('=');
  if (eq == std::string_view::npos) throw SweepInputError(expected + got + " (no '=')");
  SweepAxis axis;
  axis.name = std::string(trim(text.substr(0, eq)));
  if (axis.name.empty()) throw SweepInputError(expected + got + " (the parameter name is missing)");
  auto split = [&](std::string_view rest, char separator) {
    std::vector<std::string_view> parts;
    for (std::size_t at; (at = rest.find(separator)) != std::string_view::npos; rest.remove_prefix(at + 1))
      parts.push_back(trim(rest.substr(0, at)));
    parts.push_back(trim(rest));
    return parts;
  };
  auto number = [&](std::string_view s, const std::string& what) {
    const std::string str(s);
    char* end = nullptr;
    const double v = str.empty() ? nan : std::strtod(str.c_str(), &end);
    if (str.empty() || end != str.c_str() + str.size() || !std::isfinite(v))
      throw SweepInputError(expected + got + " (" + what + " '" + str + "' is not a finite number)");
    return v;
  };
  if (text.find(',', eq) != std::string_view::npos) {  // an explicit list
    const std::vector<std::string_view> items = split(text.substr(eq + 1), ',');
    for (std::size_t i = 0; i < items.size(); ++i) axis.values.push_back(number(items[i], "value " + std::to_string(i + 1)));
    const double direction = axis.values[1] - axis.values[0];
    for (std::size_t i = 1; i < axis.values.size(); ++i)
      if (!((axis.values[i] - axis.values[i - 1]) * direction > 0))
        throw SweepInputError(expected + got + " (the values must be strictly increasing or strictly decreasing)");
    axis.count = static_cast<int>(axis.values.size());
    axis.from = axis.values.front();
    axis.to = axis.values.back();
    return axis;
  }
  const std::vector<std::string_view> parts = split(text.substr(eq + 1), ':');
  if (parts.size() != 3)
    throw SweepInputError(expected + got + " (" + std::to_string(parts.size()) + " part" +
                          (parts.size() == 1 ? "" : "s") + " after '=', expected FROM:TO:COUNT)");
  axis.from = number(parts[0], "FROM");
  axis.to = number(parts[1], "TO");
  const std::string_view count = parts[2];
  long long points = 0;
  const auto [ptr, ec] = std::from_chars(count.data(), count.data() + count.size(), points);
  const bool integer = !count.empty() && ptr == count.data() + count.size() &&
                       (ec == std::errc() || ec == std::errc::result_out_of_range);
  if (!integer) throw SweepInputError(expected + got + " (COUNT '" + std::string(count) + "' is not a whole number)");
  if (ec == std::errc::result_out_of_range || points > max_sweep_points)
    throw SweepInputError("--vary " + axis.name + ": " + std::string(count) + " points are more than a sweep takes (at most " +
                          std::to_string(max_sweep_points) + ")");
  if (points < 2) throw SweepInputError(expected + got + " (COUNT must be at least 2, got " + std::string(count) + ")");
  axis.count = static_cast<int>(points);
  if (axis.from == axis.to)
    throw SweepInputError(expected + got + " (FROM and TO are equal: nothing to sweep)");
  if (!std::isfinite(axis.to - axis.from))
    throw SweepInputError("--vary " + axis.name + ": the range from " + std::string(parts[0]) + " to " +
                          std::string(parts[1]) + " is wider than a double holds (TO − FROM overflows); sweep a "
                          "narrower range");
  return axis;
}

SweepResult sweep(const std::string& scene_text, const std::string& file,
                  const std::vector<ParameterOverride>& fixed, const SweepAxis& axis, const SweepOptions& options) {
  validate(scene_text, file, fixed, {&axis}, options);
  const Evaluator evaluate(scene_text, file, fixed, {axis.name}, options);

  SweepResult result;
  result.axis = axis;
  result.points.resize(static_cast<std::size_t>(axis.count));
  std::vector<Evaluation> evaluations(static_cast<std::size_t>(axis.count));
  const VectorX* start = nullptr;
  for (int i = 0; i < axis.count; ++i) {
    const std::size_t k = static_cast<std::size_t>(i);
    SweepPoint& p = result.points[k];
    p.value = axis.value(i);
    const auto started = std::chrono::steady_clock::now();
    evaluations[k] = evaluate({p.value}, start, Indicator::none);
    ++result.evaluations;
    fill_point(p, evaluations[k], options.modes);
    p.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    if (p.ok) {
      start = &evaluations[k].equilibrium.q;
      if (result.coordinates.empty()) result.coordinates = evaluations[k].coordinates;
    }
    if (options.progress) options.progress(i + 1, axis.count);
  }

  // Changes of class between consecutive points that worked.
  std::vector<CriticalValue> found;
  std::size_t previous = evaluations.size();
  for (std::size_t k = 0; k < evaluations.size(); ++k) {
    if (!evaluations[k].ok) continue;
    if (previous < evaluations.size() &&
        evaluations[previous].result.stability != evaluations[k].result.stability) {
      CriticalValue c = refine(evaluate, axis, result.points[previous].value, evaluations[previous],
                               result.points[k].value, evaluations[k], options, result.notes);
      result.evaluations += c.evaluations;
      found.push_back(std::move(c));
    }
    previous = k;
  }
  result.critical = merge_touching(std::move(found), options.tolerance);
  return result;
}

StabilityMap sweep_map(const std::string& scene_text, const std::string& file,
                       const std::vector<ParameterOverride>& fixed, const SweepAxis& x, const SweepAxis& y,
                       const SweepOptions& options) {
  validate(scene_text, file, fixed, {&x, &y}, options);
  const Evaluator evaluate(scene_text, file, fixed, {x.name, y.name}, options);
  StabilityMap map;
  map.x = x;
  map.y = y;
  map.points.resize(static_cast<std::size_t>(x.count) * static_cast<std::size_t>(y.count));
  std::optional<VectorX> row_start, start;
  for (int j = 0; j < y.count; ++j) {
    start = row_start;
    for (int i = 0; i < x.count; ++i) {
      MapPoint& p = map.points[static_cast<std::size_t>(j * x.count + i)];
      p.x = x.value(i);
      p.y = y.value(j);
      const Evaluation e = evaluate({p.x, p.y}, start ? &*start : nullptr, Indicator::none);
      p.ok = e.ok;
      p.scene_error = e.scene_error;
      p.failure = e.failure;
      if (e.ok) {
        p.stability = e.result.stability;
        p.max_growth_rate = e.max_growth_rate;
        p.min_omega2 = e.min_omega2;
        start = e.equilibrium.q;
        if (i == 0 || !row_start) row_start = e.equilibrium.q;
      }
      if (options.progress) options.progress(j * x.count + i + 1, x.count * y.count);
    }
  }
  return map;
}

namespace {

// ln(eᵗ − 1) for t > 0, without overflow for large t.
double log_expm1(double t) { return t > 30 ? t + std::log1p(-std::exp(-t)) : std::log(std::expm1(t)); }

// ln[(N1^−p − N2^−p)/(N2^−p − N3^−p)] with u = ln(N2/N1), v = ln(N3/N2): the
// ratio is (e^{pu} − 1) e^{pv}/(e^{pv} − 1), which increases strictly with p
// from u/v at p → 0 (modal/sweep.hpp).
double log_difference_ratio(double p, double u, double v) { return log_expm1(p * u) - log_expm1(p * v) + p * v; }

constexpr double max_order = 100;

struct TripleFit {
  bool ok = false;
  std::string reason;
  double order = nan, value = nan;
};

// Order and Richardson value of three points n[0] < n[1] < n[2] with values f
// and error estimates d of f.
TripleFit fit_triple(const double* n, const double* f, const double* d) {
  TripleFit t;
  const double d1 = f[1] - f[0], d2 = f[2] - f[1];
  const std::string at = " (N = " + short_text(n[0]) + ", " + short_text(n[1]) + ", " + short_text(n[2]) + ")";
  auto noise_level = [](double diff, double e1, double e2) { return !(std::abs(diff) > 10 * (e1 + e2)); };
  if (noise_level(d1, d[0], d[1]) || noise_level(d2, d[1], d[2])) {
    t.reason = "a difference of consecutive values is zero or at the level of their own error estimates" + at +
               ": the values have converged as far as they can be told apart, or the points are too close";
    return t;
  }
  if ((d1 > 0) != (d2 > 0)) {
    t.reason = "the differences of consecutive values change sign" + at + ": the values oscillate, not in the "
               "asymptotic range";
    return t;
  }
  const double u = std::log(n[1] / n[0]), v = std::log(n[2] / n[1]);
  const double target = std::log(d1 / d2);  // ln[(f1 − f2)/(f2 − f3)]
  // The relative uncertainty of that ratio from the values' errors: a ratio
  // within it of the p → 0 limit would give an order (and a value) made of
  // rounding.
  const double uncertainty = (d[0] + d[1]) / std::abs(d1) + (d[1] + d[2]) / std::abs(d2);
  if (!(target - std::log(u / v) > 2 * uncertainty)) {
    t.reason = "the differences do not shrink fast enough for any positive order" + at + " (|f2 − f1|/|f3 − f2| = " +
               short_text(d1 / d2) + ", which needs to exceed ln(N2/N1)/ln(N3/N2) = " + short_text(u / v) +
               "): not in the asymptotic range";
    return t;
  }
  if (!(target < log_difference_ratio(max_order, u, v))) {
    t.reason = "the differences shrink faster than order " + short_text(max_order) + at +
               ": convergence is faster than any power these points resolve";
    return t;
  }
  double lo = 0, hi = max_order;  // the ratio at lo is below the target, at hi above
  while (hi - lo > 1e-13 * hi) {
    const double mid = 0.5 * (lo + hi);
    if (mid == lo || mid == hi) break;
    (log_difference_ratio(mid, u, v) < target ? lo : hi) = mid;
  }
  t.order = 0.5 * (lo + hi);
  t.value = f[2] + d2 / std::expm1(t.order * v);
  t.ok = true;
  return t;
}

}  // namespace

Extrapolation richardson(const std::vector<double>& n, const std::vector<double>& f,
                         const std::vector<double>& f_error) {
  if (f.size() != n.size() || (!f_error.empty() && f_error.size() != n.size()))
    throw std::invalid_argument("richardson: n, f (and f_error when given) must have the same size");
  for (std::size_t i = 0; i < n.size(); ++i)
    if (!(n[i] > 0) || !std::isfinite(n[i]) || (i > 0 && !(n[i] > n[i - 1])))
      throw std::invalid_argument("richardson: n must be finite, positive and strictly increasing");
  Extrapolation e;
  const std::size_t size = n.size();
  if (size < 3) {
    e.reason = "needs at least three values, got " + std::to_string(size);
    return e;
  }
  // Error of each value: its estimate, and never below its rounding.
  std::vector<double> d(size);
  for (std::size_t i = 0; i < size; ++i)
    d[i] = std::max(f_error.empty() ? 0.0 : std::abs(f_error[i]), 8 * std::numeric_limits<double>::epsilon() * std::abs(f[i]));
  for (std::size_t i = 0; i < size; ++i)
    if (!std::isfinite(f[i]) || !std::isfinite(d[i])) {
      e.reason = "the value at N = " + short_text(n[i]) + " is not finite";
      return e;
    }
  const std::size_t last = size - 3;
  e.n1 = n[last];
  e.n2 = n[last + 1];
  e.n3 = n[last + 2];
  const TripleFit t = fit_triple(&n[last], &f[last], &d[last]);
  if (!t.ok) {
    e.reason = t.reason;
    return e;
  }
  e.asymptotic = true;
  e.order = t.order;
  e.value = t.value;
  const double f3 = f[last + 2];
  const double r = e.n3 / e.n2, rp = std::pow(r, e.order);
  const double correction = std::abs(e.value - f3);
  double model = correction;
  e.error_rule = "correction |f∞ − f(N3)| (three points: nothing checks the power law)";
  if (size >= 4) {
    const TripleFit previous = fit_triple(&n[last - 1], &f[last - 1], &d[last - 1]);
    if (previous.ok) {
      e.previous_order = previous.order;
      e.previous_value = previous.value;
      const double change = std::abs(e.value - previous.value);
      const double drift = rp * std::log(r) / (rp - 1) * std::abs(e.order - previous.order) * correction;
      model = std::max(change, drift);
      e.error_rule = change >= drift ? "|f∞ − f∞'| of the previous triple" : "sensitivity to the order's drift |p − p'|";
    } else {
      e.error_rule = "correction |f∞ − f(N3)| (the previous triple is not in the asymptotic range)";
    }
  }
  const double noise = (rp * d[last + 2] + d[last + 1]) / (rp - 1);
  e.error = model + noise;
  if (noise > model) e.error_rule = "the values' own error estimates";
  return e;
}

void check_extrapolation_axis(const SweepAxis& axis) {
  const std::string what = "--extrapolate needs an integer parameter (a number of links, elements, …) with at least "
                           "three values, such as --vary N=10,20,40,80";
  if (axis.count < 3)
    throw SweepInputError(what + "; --vary " + axis.name + " has " + std::to_string(axis.count) + " value" +
                          (axis.count == 1 ? "" : "s"));
  for (int i = 0; i < axis.count; ++i) {
    const double v = axis.value(i);
    if (!std::isfinite(v) || v != std::floor(v) || v < 1)
      throw SweepInputError(what + "; " + axis.name + " = " + short_text(v) + " is not an integer ≥ 1");
  }
}

std::vector<ModeConvergence> extrapolate_modes(const SweepResult& result, int modes) {
  check_extrapolation_axis(result.axis);
  std::vector<const SweepPoint*> sorted;
  for (const SweepPoint& p : result.points)
    if (p.ok) sorted.push_back(&p);
  std::sort(sorted.begin(), sorted.end(), [](const SweepPoint* a, const SweepPoint* b) { return a->value < b->value; });
  std::vector<ModeConvergence> out;
  for (int k = 0; k < modes; ++k) {
    ModeConvergence c;
    c.mode = k + 1;
    for (const SweepPoint* p : sorted) {
      if (static_cast<std::size_t>(k) >= p->result.modes.size()) continue;
      const Mode& m = p->result.modes[static_cast<std::size_t>(k)];
      if (!(m.omega > 0) || !std::isfinite(m.omega)) continue;
      c.n.push_back(p->value);
      c.omega.push_back(m.omega);
      // A symmetric problem estimates the error of ω² = λ: δω = δλ/(2ω).
      c.omega_error.push_back(std::isfinite(m.omega2) ? m.error_estimate / (2 * m.omega) : m.error_estimate);
    }
    if (c.n.size() < 3)
      c.extrapolation.reason = "only " + std::to_string(c.n.size()) + " point" + (c.n.size() == 1 ? "" : "s") +
                               " of the sweep gave an oscillating mode " + std::to_string(c.mode) + "; three are needed";
    else
      c.extrapolation = richardson(c.n, c.omega, c.omega_error);
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace modal
