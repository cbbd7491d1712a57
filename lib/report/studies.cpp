// lib/report/studies.cpp — text and CSV of the studies beyond one analysis:
// sweeps, stability maps, convergence and extrapolation, amplitude scans and
// simulations (modal/report.hpp). Presentation only: every number comes from
// the result values.
#include "modal/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

namespace modal {
namespace {

std::string g(double v, int digits = 6) {
  if (std::isnan(v)) return "-";
  return fmt::format("{:.{}g}", v, digits);
}

// "P = 2.0857864376 ± 3.1e-12" style value with its error.
std::string value_with_error(double value, double error) {
  return fmt::format("{:.12g} ± {:.2g}", value, error);
}

char map_symbol(const MapPoint& p) {
  if (!p.ok) return '?';
  switch (p.stability) {
    case Stability::stable: return 'o';
    case Stability::asymptotically_stable: return 'a';
    case Stability::marginal: return 'm';
    case Stability::divergence: return 'D';
    case Stability::flutter: return 'F';
  }
  return '?';
}

}  // namespace

// A critical value in words: kind, the change of class, frequency.
std::string describe_critical(const CriticalValue& c, const std::string& name) {
  std::string out = fmt::format("{} = {}  {}", name, value_with_error(c.value, c.error), to_string(c.kind));
  out += fmt::format(" ({} → {}", to_string(c.before), to_string(c.after));
  if (c.restabilization()) out += ": restabilization";
  if (c.loss()) out += ": loss of stability";
  out += ")";
  if (c.kind == CriticalKind::divergence) out += "  ω = 0";
  else if (std::isfinite(c.omega)) out += fmt::format("  ω = {:.10g} rad/s", c.omega);
  if (!c.refined) out += "  [not refined]";
  return out;
}

void print_sweep(std::ostream& out, const SweepResult& r, const std::string& file, double tolerance) {
  const SweepAxis& ax = r.axis;
  out << fmt::format("Sweep of {} in {}: {} points from {} to {}", ax.name, file, ax.count, g(ax.from, 10),
                     g(ax.to, 10));
  if (!r.coordinates.empty()) out << fmt::format(" ({} coordinates)", r.coordinates.size());
  out << "\n\n";
  bool all_symmetric = true;
  for (const SweepPoint& p : r.points)
    if (p.ok && !p.symmetric) all_symmetric = false;
  constexpr std::size_t shown = 3;
  const std::string modes_header = all_symmetric ? "lowest ω² [rad²/s²]" : "lowest ω [rad/s]";
  const int width = std::max(12, static_cast<int>(ax.name.size()));
  out << fmt::format("{:>{}}  {:<22}  {:>16}  {}\n", ax.name, width, "class", "max growth [1/s]", modes_header);
  for (const SweepPoint& p : r.points) {
    if (!p.ok) {
      out << fmt::format("{:>{}}  failed: {}\n", g(p.value, 10), width, p.failure);
      continue;
    }
    std::string modes;
    for (std::size_t i = 0; i < p.result.modes.size() && i < shown; ++i) {
      const Mode& m = p.result.modes[i];
      modes += fmt::format("{:>12}", g(all_symmetric ? m.omega2 : m.omega));
    }
    out << fmt::format("{:>{}}  {:<22}  {:>16}  {}\n", g(p.value, 10), width,
                       to_string(p.result.stability), g(p.max_growth_rate), modes);
  }
  out << '\n';
  if (r.critical.empty()) {
    out << "No change of stability class between " << g(ax.from, 10) << " and " << g(ax.to, 10) << ".\n";
  } else {
    out << fmt::format("Critical values (class changes, refined to {:.0e} relative, or {:.0e} of the range near 0):\n",
                       tolerance, 1e-6 * tolerance);
    for (const CriticalValue& c : r.critical) out << "  " << describe_critical(c, ax.name) << '\n';
  }
  for (const std::string& note : r.notes) out << "note: " << note << '\n';
  out << fmt::format("{} evaluations ({} grid points, {} in refinements)\n", r.evaluations, ax.count,
                     r.evaluations - ax.count);
}

std::string sweep_modes_csv(const SweepResult& r) {
  std::ostringstream out;
  out << csv_field(r.axis.name)
      << ",mode,omega2,growth_rate,omega,frequency_hz,period,damping_ratio,stability,error_estimate\n";
  for (const SweepPoint& p : r.points) {
    const std::string value = csv_number(p.value);
    if (!p.ok) {
      out << value << ",,,,,,,,failed,\n";
      continue;
    }
    int index = 0;
    for (const Mode& m : p.result.modes)
      out << value << ',' << ++index << ',' << csv_number(m.omega2) << ',' << csv_number(m.growth_rate)
          << ',' << csv_number(m.omega) << ',' << csv_number(m.frequency_hz) << ','
          << csv_number(m.period) << ',' << csv_number(m.damping_ratio) << ','
          << csv_field(mode_stability(m.kind)) << ',' << csv_number(m.error_estimate) << '\n';
  }
  return out.str();
}

std::string sweep_critical_csv(const SweepResult& r) {
  std::ostringstream out;
  out << "parameter,value,error,kind,omega,before,after\n";
  for (const CriticalValue& c : r.critical)
    out << csv_field(r.axis.name) << ',' << csv_number(c.value) << ',' << csv_number(c.error)
        << ',' << to_string(c.kind) << ',' << csv_number(c.omega) << ','
        << csv_field(to_string(c.before)) << ',' << csv_field(to_string(c.after)) << '\n';
  return out.str();
}

void print_map(std::ostream& out, const StabilityMap& map, const std::string& file) {
  const SweepAxis &x = map.x, &y = map.y;
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
  for (const MapPoint& p : map.points) {
    if (p.ok) continue;
    ++failed;
    if (shown++ < 5) out << fmt::format("failed at {} = {}, {} = {}: {}\n", x.name, g(p.x), y.name, g(p.y), p.failure);
  }
  if (failed > shown) out << fmt::format("… {} failed points in all\n", failed);
}

std::string map_csv(const StabilityMap& map) {
  std::ostringstream out;
  out << csv_field(map.x.name) << ',' << csv_field(map.y.name)
      << ",stability,max_growth_rate,min_omega2\n";
  for (const MapPoint& p : map.points) {
    out << csv_number(p.x) << ',' << csv_number(p.y) << ',';
    if (p.ok)
      out << csv_field(to_string(p.stability)) << ',' << csv_number(p.max_growth_rate) << ','
          << csv_number(p.min_omega2) << '\n';
    else
      out << "failed,,\n";
  }
  return out.str();
}

// FILE.csv → FILE_<suffix>.csv (FILE → FILE_<suffix>.csv), as critical_path.

// The frequencies of the lowest modes at every point, with the cost of each
// point, then the Richardson extrapolation of each mode (modal/sweep.hpp).
void print_extrapolation(std::ostream& out, const SweepResult& r,
                         const std::vector<ModeConvergence>& conv) {
  const std::string& name = r.axis.name;
  const int width = std::max(8, static_cast<int>(name.size()));
  out << fmt::format("\nConvergence in {} (ω in rad/s; time: parse, build, equilibrium and all modes of the point)\n",
                     name);
  out << fmt::format("{:>{}}  {:>11}  {:>9}", name, width, "coordinates", "time [s]");
  for (const ModeConvergence& c : conv) out << fmt::format("  {:>17}", fmt::format("ω{}", c.mode));
  out << '\n';
  for (const SweepPoint& p : r.points) {
    if (!p.ok) {
      out << fmt::format("{:>{}}  failed: {}\n", g(p.value, 10), width, p.failure);
      continue;
    }
    out << fmt::format("{:>{}}  {:>11}  {:>9.3g}", g(p.value, 10), width, p.coordinates, p.seconds);
    for (const ModeConvergence& c : conv) {
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
  for (const ModeConvergence& c : conv) {
    const Extrapolation& e = c.extrapolation;
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
std::string convergence_csv(const SweepResult& r, const std::vector<ModeConvergence>& conv) {
  std::ostringstream out;
  out << csv_field(r.axis.name) << ",coordinates,seconds,mode,omega,error_estimate\n";
  for (const ModeConvergence& c : conv)
    for (std::size_t i = 0; i < c.n.size(); ++i) {
      const auto point = std::find_if(r.points.begin(), r.points.end(),
                                      [&](const SweepPoint& p) { return p.ok && p.value == c.n[i]; });
      out << csv_number(c.n[i]) << ',' << point->coordinates << ','
          << csv_number(point->seconds) << ',' << c.mode << ',' << csv_number(c.omega[i]) << ','
          << csv_number(c.omega_error[i]) << '\n';
    }
  return out.str();
}

// One row per mode: the extrapolation (empty numbers and the reason in `note`
// when the mode is not in the asymptotic range).
std::string extrapolation_csv(const std::vector<ModeConvergence>& conv) {
  std::ostringstream out;
  out << "mode,n1,n2,n3,omega_n3,order,omega_extrapolated,error,error_rule,previous_order,previous_extrapolated,"
         "asymptotic,note\n";
  for (const ModeConvergence& c : conv) {
    const Extrapolation& e = c.extrapolation;
    auto number = [&](double v) { return e.asymptotic && std::isfinite(v) ? csv_number(v) : std::string(); };
    out << c.mode << ',' << number(e.n1) << ',' << number(e.n2) << ',' << number(e.n3) << ','
        << number(c.omega.empty() ? std::nan("") : c.omega.back()) << ',' << number(e.order) << ','
        << number(e.value) << ',' << number(e.error) << ',' << csv_field(e.error_rule) << ','
        << number(e.previous_order) << ',' << number(e.previous_value) << ',' << (e.asymptotic ? "true" : "false")
        << ',' << csv_field(e.reason) << '\n';
  }
  return out.str();
}

// Exit status when no point of a sweep worked: the first failure says why.
void print_simulation_summary(std::ostream& err, const Trajectory& tr, const SimulationOptions& o) {
  err << fmt::format("simulate: {:g} s, {} steps ({} rejected, {} evaluations), {} samples, tolerance {:g}\n",
                     tr.time.back(), tr.steps, tr.rejected_steps, tr.evaluations, tr.size(), o.tolerance);
  if (tr.energy_scale == 0) {
    // E0 = 0, no motion and no work: a relative error of 0 over 0 J says nothing.
    err << fmt::format("simulate: nothing moved and no force did work: E stayed 0 J{}, the balance held exactly\n",
                       tr.conservative ? "" : " and the work of the dampers and follower loads is 0 J");
    return;
  }
  if (tr.conservative) {
    err << fmt::format("simulate: energy E0 = {:.10g} J conserved to a relative error of {:.2g} "
                       "(max |E - E0| / {:.6g} J)\n",
                       tr.energy.front(), tr.max_energy_error, tr.energy_scale);
    return;
  }
  err << fmt::format("simulate: dampers or follower loads act, so E need not be conserved: E went from {:.10g} J to "
                     "{:.10g} J, the work of the non-conservative forces is W = {:.10g} J\n",
                     tr.energy.front(), tr.energy.back(), tr.work.back());
  err << fmt::format("simulate: energy balance E - E0 - W = 0 held to a relative error of {:.2g} "
                     "(max |E - E0 - W| / {:.6g} J)\n",
                     tr.max_energy_error, tr.energy_scale);
}

std::string amplitude_csv(const AmplitudeResponse& r) {
  std::string out = "amplitude,oscillates,omega,omega_ratio_minus_1,spread,cycles,simulated_seconds\n";
  for (const AmplitudePoint& p : r.points)
    out += fmt::format("{:.17g},{},{:.17g},{:.17g},{:.17g},{},{:.17g}\n", p.amplitude, p.oscillates ? 1 : 0,
                       p.omega, p.shift, p.spread, p.cycles, p.seconds);
  return out;
}

void print_amplitude(std::ostream& out, const std::string& title, const std::string& file, int mode, double omega2,
                     const AmplitudeResponse& r, double tolerance) {
  const char* unit = r.kind == CoordinateKind::length ? "m" : "rad";
  out << fmt::format("{}\nscene: {}\n\nMode {}: omega_lin = {:.10g} rad/s (omega^2 = {:.10g} rad2/s2), "
                           "released from rest at the equilibrium plus amplitude × the shape, its largest component "
                           "'{}' = amplitude [{}]\n\n",
                           title, file, mode, r.omega_linear, omega2, r.coordinate, unit);
  out << fmt::format("  {:>16}  {:>18}  {:>14}  {:>9}  {:>6}\n", fmt::format("amplitude [{}]", unit),
                           "omega [rad/s]", "omega/lin - 1", "spread", "cycles");
  for (const AmplitudePoint& p : r.points) {
    if (p.oscillates)
      out << fmt::format("  {:>16.8g}  {:>18.12g}  {:>14.6e}  {:>9.1e}  {:>6}\n", p.amplitude, p.omega, p.shift,
                               p.spread, p.cycles);
    else
      out << fmt::format("  {:>16.8g}  does not return through the equilibrium within {:.4g} s: the motion "
                               "has left the well\n",
                               p.amplitude, p.seconds);
  }
  out << '\n';
  for (const AmplitudeThreshold& t : r.thresholds) {
    const std::string level = fmt::format("{:g} %", 100 * t.level);
    if (t.reached && t.note.empty())
      out << fmt::format("Frequency departs by {} at amplitude {:.8g} ± {:.1e} {}\n", level, t.amplitude,
                               t.error, unit);
    else if (t.reached)
      out << fmt::format("Frequency departs by {} at amplitude ≤ {:.8g} {}: {}\n", level, t.amplitude, unit,
                               t.note);
    else
      out << fmt::format("Frequency departs by {}: {}\n", level, t.note);
  }
  out << fmt::format("({} motions integrated, rk8pd at tolerance {:g}; spread: largest deviation of one "
                           "period from their mean, the uncertainty of omega where modes exchange energy)\n",
                     r.evaluations, tolerance);
}

void print_timings(std::ostream& out, const std::vector<std::pair<std::string, double>>& seconds) {
  double total = 0;
  for (const auto& [name, s] : seconds) {
    out << fmt::format("timing: {:<16} {:>12.3f} ms\n", name, 1e3 * s);
    if (name.rfind("  ", 0) != 0) total += s;
  }
  out << fmt::format("timing: {:<16} {:>12.3f} ms\n", "total", 1e3 * total);
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmHWM:", 0) == 0) {
      // "VmHWM:\t  123456 kB": the number and unit without the tab and padding.
      const std::size_t from = line.find_first_not_of(" \t", 6);
      out << fmt::format("timing: {:<16} {:>15}\n", "peak memory", from == std::string::npos ? "" : line.substr(from));
    }
}

}  // namespace modal
