// lib/simulate/amplitude.cpp — the frequency of a mode's nonlinear motion
// against its amplitude (modal/simulate.hpp, "validity of the linearization").
#include "modal/simulate.hpp"

#include "messages.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

namespace modal {
namespace {

using simulate_detail::number;

// What one measurement needs: the start direction φ̂ (largest component 1)
// and the weight w = M(q̄) φ̂ of the modal coordinate η = wᵀ(q − q̄) (a
// multiple of φᵀM(q − q̄); the scale does not move its zeros).
struct Setup {
  System system;  // with ignorable coordinates given by the momenta of the steady motion at q̄
  VectorX equilibrium, direction, weight;
  double period = 0;  // 2π/ω_lin, s
  int dominant = 0;
};

Setup prepare(const System& s, const VectorX& equilibrium, const VectorX& shape, double omega_linear) {
  const Eigen::Index n = s.size();
  if (equilibrium.size() != n || shape.size() != n)
    throw std::invalid_argument("amplitude: the equilibrium and the shape need " + std::to_string(n) +
                                " coordinates, got " + std::to_string(equilibrium.size()) + " and " +
                                std::to_string(shape.size()));
  if (!equilibrium.allFinite() || !shape.allFinite() || shape.cwiseAbs().maxCoeff() == 0)
    throw std::invalid_argument("amplitude: the equilibrium and the shape must be finite, the shape not zero");
  if (!(omega_linear > 0) || !std::isfinite(omega_linear))
    throw std::invalid_argument("amplitude: the linear frequency must be positive and finite (an oscillating mode)");
  // Ignorable coordinates given by their rate: the free system at the momenta
  // of the steady motion at q̄, once, as linearize() analyzes it. simulate()
  // would otherwise take the momenta at each start it is given (q̄ + a φ̂,
  // every chunk, every crossing refinement), which shifts the frequency by
  // O(a) and changes the motion from one integration to the next.
  Setup su{with_steady_momenta(s, equilibrium), equilibrium, {}, {}};
  Eigen::Index dominant = 0;
  shape.cwiseAbs().maxCoeff(&dominant);
  su.dominant = static_cast<int>(dominant);
  su.direction = shape / shape[dominant];
  Workspace w(su.system);
  su.weight = mass_matrix(su.system, w, equilibrium) * su.direction;
  su.period = 2 * std::numbers::pi / omega_linear;
  return su;
}

double modal_coordinate(const Setup& su, const VectorX& q) { return su.weight.dot(q - su.equilibrium); }

// One integration from (q, q̇) over `duration`, sampled every `interval`.
Trajectory integrate(const Setup& su, const VectorX& q, const VectorX& qd, double duration, double interval,
                     const AmplitudeOptions& o, long& evaluations) {
  SimulationOptions so;
  so.duration = duration;
  so.interval = interval;
  so.tolerance = o.tolerance;
  ++evaluations;
  return simulate(su.system, q, qd, so);
}

// The time after (q, q̇) at which η crosses zero, from a first guess, by
// Newton's method with η̇ = wᵀq̇: each iterate integrates from (q, q̇) afresh.
double refine_crossing(const Setup& su, const VectorX& q, const VectorX& qd, double guess,
                       const AmplitudeOptions& o, long& evaluations) {
  double dt = guess;
  for (int iteration = 0; iteration < 20; ++iteration) {
    if (!(dt > 0)) dt = 1e-9 * su.period;
    const Trajectory tr = integrate(su, q, qd, dt, dt, o, evaluations);
    const double eta = modal_coordinate(su, tr.q.back()), rate = su.weight.dot(tr.qd.back());
    if (rate == 0) break;
    const double step = -eta / rate;
    dt += step;
    if (std::abs(step) <= 1e-13 * su.period) break;
  }
  return dt;
}

// The configuration q̄ + b φ̂ brought onto the constraints (project_onto_constraints,
// minimum-norm Gauss–Newton), wrapped back to the chart of q̄ + b φ̂ for
// periodic hinge angles (the projection canonicalizes them to (−π, π]).
// Empty when the projection does not reach c = 0.
std::optional<VectorX> projected(const Setup& su, Workspace& w, double b) {
  const VectorX target = su.equilibrium + b * su.direction;
  const ConstraintProjection p = project_onto_constraints(su.system, w, target);
  if (!(p.violation <= 1e-10 * su.system.length_scale())) return std::nullopt;
  VectorX q = p.q;
  for (Eigen::Index i = 0; i < q.size(); ++i) {
    const Coordinate& c = su.system.coordinates()[static_cast<std::size_t>(i)];
    if (c.kind == CoordinateKind::angle && c.periodic)
      q[i] += 2 * std::numbers::pi * std::round((target[i] - q[i]) / (2 * std::numbers::pi));
  }
  return q;
}

// The start of the motion at `amplitude`: q̄ + a φ̂, which moves the
// coordinate of φ̂'s largest component by exactly a. With constraints, the
// projection of q̄ + b φ̂ onto c = 0, b chosen by a secant iteration so that
// that coordinate still moves by exactly a (to 1e-14 of a): the amplitude
// keeps its meaning (a pendulum written as a particle on a rod of length l,
// released at x = a, starts at θ₀ = asin(a/l)).
VectorX start(const Setup& su, double amplitude) {
  if (!su.system.has_constraints()) return su.equilibrium + amplitude * su.direction;
  Workspace w(su.system);
  const Coordinate& dominant = su.system.coordinates()[static_cast<std::size_t>(su.dominant)];
  const double unit = dominant.kind == CoordinateKind::length ? su.system.length_scale() : 1.0;
  const double tolerance = 1e-14 * std::max(amplitude, unit);
  const auto miss = [&](const VectorX& q) { return q[su.dominant] - su.equilibrium[su.dominant] - amplitude; };
  const std::string refusal = "amplitude: on the constraints, coordinate '" + dominant.name + "' cannot be moved by " +
                              number(amplitude) + " along this mode";
  std::optional<VectorX> q = projected(su, w, amplitude);
  if (!q) throw NumericalError(refusal + " (its start cannot be brought onto the constraints): give smaller amplitudes");
  double b0 = amplitude, f0 = miss(*q);
  double b1 = amplitude - f0;  // the projection moves the coordinate by about b
  for (int iteration = 0; iteration < 60 && std::abs(f0) > tolerance; ++iteration) {
    const std::optional<VectorX> next = projected(su, w, b1);
    if (!next) break;
    const double f1 = miss(*next), slope = (f1 - f0) / (b1 - b0);
    q = next;
    b0 = b1;
    f0 = f1;
    if (!(slope > 0) || !std::isfinite(slope)) break;  // the coordinate no longer follows b: out of reach
    b1 -= f1 / slope;
  }
  if (!(std::abs(f0) <= 100 * tolerance))
    throw NumericalError(refusal + " (the closest start found misses by " + number(std::abs(f0)) +
                         "): give smaller amplitudes");
  return *q;
}

AmplitudePoint measure(const Setup& su, double amplitude, const AmplitudeOptions& o,
                       long& evaluations) {
  if (!(amplitude > 0) || !std::isfinite(amplitude))
    throw std::invalid_argument("amplitude: amplitudes must be positive and finite");
  if (o.cycles < 1) throw std::invalid_argument("amplitude: at least one cycle must be measured");
  AmplitudePoint p;
  p.amplitude = amplitude;
  VectorX q = start(su, amplitude);
  VectorX qd = VectorX::Zero(su.system.size());
  // Samples 64 per linear period, integrated in chunks of 8 periods, for at
  // most 20 linear periods per cycle wanted: a motion that has not come back
  // through η = 0 by then has left the well (or is slower than any mode here).
  const double interval = su.period / 64, chunk = 8 * su.period, limit = 20.0 * (o.cycles + 1) * su.period;
  std::vector<double> crossings;
  double start = 0;
  while (crossings.size() < static_cast<std::size_t>(o.cycles + 1) && start < limit) {
    const Trajectory tr = integrate(su, q, qd, chunk, interval, o, evaluations);
    for (std::size_t i = 1; i < tr.size() && crossings.size() < static_cast<std::size_t>(o.cycles + 1); ++i) {
      const double before = modal_coordinate(su, tr.q[i - 1]), after = modal_coordinate(su, tr.q[i]);
      if (!(before > 0 && after <= 0)) continue;
      const double guess = (tr.time[i] - tr.time[i - 1]) * before / (before - after);
      crossings.push_back(start + tr.time[i - 1] + refine_crossing(su, tr.q[i - 1], tr.qd[i - 1], guess, o, evaluations));
    }
    q = tr.q.back();
    qd = tr.qd.back();
    start += tr.time.back();
  }
  p.seconds = start;
  if (crossings.size() < static_cast<std::size_t>(o.cycles + 1)) return p;  // did not oscillate
  p.oscillates = true;
  p.cycles = o.cycles;
  const double period = (crossings.back() - crossings.front()) / o.cycles;
  p.omega = 2 * std::numbers::pi / period;
  p.shift = p.omega * su.period / (2 * std::numbers::pi) - 1;
  for (std::size_t i = 1; i < crossings.size(); ++i)
    p.spread = std::max(p.spread, std::abs((crossings[i] - crossings[i - 1]) / period - 1));
  return p;
}

// The amplitude where |shift| reaches `level` inside [lo, hi] (|shift(lo)| <
// level ≤ |shift(hi)|): regula falsi on log a with the Illinois modification,
// a bisection step whenever two steps have not halved the bracket.
AmplitudeThreshold refine_level(const Setup& su, double level, AmplitudePoint lo, AmplitudePoint hi,
                                const AmplitudeOptions& o, const std::string& unit, long& evaluations) {
  AmplitudeThreshold t;
  t.level = level;
  t.reached = true;
  double x0 = std::log(lo.amplitude), x1 = std::log(hi.amplitude);
  double f0 = std::abs(lo.shift) - level, f1 = hi.oscillates ? std::abs(hi.shift) - level : 1.0;
  double g0 = f0, g1 = f1;  // the same without the Illinois halving, for the final interpolation
  double spread0 = lo.spread, spread1 = hi.spread;  // of the measurements at the bracket's ends
  bool upper_oscillates = hi.oscillates;             // false: the upper end has left the well
  int side = 0;
  double width = x1 - x0;
  for (int k = 0; k < 60 && std::exp(x1) - std::exp(x0) > o.amplitude_tolerance * std::exp(x1); ++k) {
    double x = (f1 != f0) ? x1 - f1 * (x1 - x0) / (f1 - f0) : 0.5 * (x0 + x1);
    if (k % 2 == 1) {  // every other step: has the bracket halved?
      if (x1 - x0 > 0.5 * width) x = 0.5 * (x0 + x1);
      width = x1 - x0;
    }
    const double margin = 0.01 * (x1 - x0);
    x = std::clamp(x, x0 + margin, x1 - margin);
    const AmplitudePoint p = measure(su, std::exp(x), o, evaluations);
    if (!p.oscillates) {  // the well ends before the level: shrink from above
      x1 = x;
      f1 = g1 = 1.0;
      spread1 = 0;
      upper_oscillates = false;
      continue;
    }
    const double f = std::abs(p.shift) - level;
    if (f < 0) {
      x0 = x;
      f0 = g0 = f;
      spread0 = p.spread;
      if (side == -1) f1 *= 0.5;
      side = -1;
    } else {
      x1 = x;
      f1 = g1 = f;
      spread1 = p.spread;
      upper_oscillates = true;
      if (side == 1) f0 *= 0.5;
      side = 1;
    }
  }
  t.amplitude = 0.5 * (std::exp(x0) + std::exp(x1));
  t.error = 0.5 * (std::exp(x1) - std::exp(x0));
  // Inside the final bracket the departure is linear in log a to far below its
  // width: the interpolated amplitude, with half the width kept as the error.
  if (upper_oscillates && g1 > g0) t.amplitude = std::exp(x0 - g0 * (x1 - x0) / (g1 - g0));
  if (!upper_oscillates) {  // the bracket closed on the edge of the oscillations, below the level
    t.reached = false;
    t.note = "the motion stops oscillating about the equilibrium at amplitude " + number(t.amplitude) + " " + unit +
             " (beyond it, it does not return through the equilibrium within 20 linear periods per cycle: it "
             "leaves the well, or its period grows past that) before the frequency departs this far";
    return t;
  }
  // The measurement's own uncertainty (the spread of the periods, where modes
  // exchange energy) moves the level's amplitude by spread / (d|shift|/da),
  // the slope taken over the scan's bracket (from its lower end to the level
  // found when its upper end did not oscillate).
  const double slope = hi.oscillates ? (std::abs(hi.shift) - std::abs(lo.shift)) / (hi.amplitude - lo.amplitude)
                                     : (level - std::abs(lo.shift)) / (t.amplitude - lo.amplitude);
  if (slope > 0) t.error += std::max(spread0, spread1) * (1 + level) / slope;
  return t;
}

}  // namespace

AmplitudePoint measure_frequency(const System& system, const VectorX& equilibrium, const VectorX& shape,
                                 double omega_linear, double amplitude, const AmplitudeOptions& options) {
  long evaluations = 0;
  return measure(prepare(system, equilibrium, shape, omega_linear), amplitude, options, evaluations);
}

AmplitudeResponse amplitude_response(const System& system, const VectorX& equilibrium, const VectorX& shape,
                                     double omega_linear, const AmplitudeOptions& options) {
  const Setup su = prepare(system, equilibrium, shape, omega_linear);
  AmplitudeResponse r;
  r.omega_linear = omega_linear;
  const Coordinate& c = su.system.coordinates()[static_cast<std::size_t>(su.dominant)];
  r.coordinate = c.name;
  r.kind = c.kind;
  const std::string unit = c.kind == CoordinateKind::length ? "m" : "rad";
  std::vector<double> amplitudes = options.amplitudes;
  if (amplitudes.empty()) {
    const double top = options.max_amplitude > 0 ? options.max_amplitude
                       : c.kind == CoordinateKind::length ? 0.5 * su.system.length_scale()
                                                          : 2.5;
    const int count = std::max(options.points, 2);
    for (int i = 0; i < count; ++i) amplitudes.push_back(top * std::pow(1e-3, 1.0 - double(i) / (count - 1)));
  }
  if (!std::is_sorted(amplitudes.begin(), amplitudes.end()))
    throw std::invalid_argument("amplitude: the amplitudes must be given in ascending order");
  const int total = static_cast<int>(amplitudes.size() + options.levels.size());
  int done = 0;
  for (const double a : amplitudes) {
    r.points.push_back(measure(su, a, options, r.evaluations));
    if (options.progress) options.progress(++done, total);
  }

  for (const double level : options.levels) {
    AmplitudeThreshold t;
    t.level = level;
    std::size_t i = 0;
    while (i < r.points.size() && r.points[i].oscillates && std::abs(r.points[i].shift) < level) ++i;
    if (i == r.points.size()) {
      t.amplitude = r.points.empty() ? 0 : r.points.back().amplitude;
      t.note = "not reached up to the largest amplitude measured, " + number(t.amplitude) + " " + unit;
    } else if (i == 0 && !r.points[0].oscillates) {
      t.amplitude = r.points[0].amplitude;
      t.note = "the motion does not oscillate about the equilibrium even at the smallest amplitude measured, " +
               number(t.amplitude) + " " + unit;
    } else if (i == 0) {
      t.reached = true;
      t.amplitude = r.points[0].amplitude;
      t.note = "already at the smallest amplitude measured: give smaller ones";
    } else {  // a bracket; its upper end may have left the well (refine_level says whether the level comes first)
      t = refine_level(su, level, r.points[i - 1], r.points[i], options, unit, r.evaluations);
    }
    r.thresholds.push_back(t);
    if (options.progress) options.progress(++done, total);
  }
  return r;
}

}  // namespace modal
