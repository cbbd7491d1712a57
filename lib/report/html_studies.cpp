// lib/report/html_studies.cpp — the HTML reports of sweep, stability map,
// amplitude, simulate and equilibria (modal/report.hpp; docs/design.md, "HTML
// reports"). Each page is html::page with a JSON block of the results: the
// series the plots draw (decimated where long) and the tables as the CSV
// writers' own rows (html::csv_table), so a table in a page is the CSV.
#include "html_page.hpp"

#include "modal/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

namespace modal {
namespace {

using html::csv_table;
using html::Json;

// What a page plots and tables at most: the lowest modes of a sweep, its
// points (every k-th beyond), the coordinates of a simulation, its time
// buckets, the rows of a long table.
constexpr std::size_t plotted_modes = 8;
constexpr std::size_t plotted_points = 4000;
constexpr std::size_t plotted_coordinates = 8;
constexpr std::size_t time_buckets = 2000;
constexpr std::size_t table_rows = 2000;
constexpr std::size_t sample_rows = 21;

// A number for a plot: null where it is not finite.
Json finite_or_null(double x) { return std::isfinite(x) ? Json(x) : Json(nullptr); }

std::string text_of(void (*writer)(std::ostream&, const Report&), const Report& report) {
  std::ostringstream out;
  writer(out, report);
  return out.str();
}

// The stability classes in the order the map's colours are listed.
constexpr Stability classes[] = {Stability::stable, Stability::asymptotically_stable, Stability::marginal,
                                 Stability::divergence, Stability::flutter};

int class_index(Stability s) {
  for (int k = 0; k < 5; ++k)
    if (classes[k] == s) return k;
  return -1;
}

Json class_names() {
  Json names = Json::array();
  for (Stability s : classes) names.push_back(to_string(s));
  return names;
}

Json convergence_json(const std::vector<ModeConvergence>& convergence) {
  Json modes = Json::array();
  for (const ModeConvergence& c : convergence) {
    const Extrapolation& e = c.extrapolation;
    Json omega = Json::array();
    for (double w : c.omega) omega.push_back(finite_or_null(w));
    modes.push_back({{"mode", c.mode},
                     {"n", c.n},
                     {"omega", omega},
                     {"asymptotic", e.asymptotic},
                     {"order", finite_or_null(e.order)},
                     {"value", finite_or_null(e.value)},
                     {"error", finite_or_null(e.error)},
                     {"reason", e.reason}});
  }
  return {{"modes", modes}, {"table", csv_table(extrapolation_csv(convergence))}};
}

}  // namespace

std::string sweep_html(const SweepResult& r, const std::string& scene_file, double tolerance,
                       const std::vector<ModeConvergence>& convergence) {
  Json j;
  j["kind"] = "sweep";
  j["scene"] = scene_file;
  j["parameter"] = r.axis.name;
  j["tolerance"] = tolerance;
  bool symmetric = true;
  std::size_t modes = 0;
  double rate_low = std::numeric_limits<double>::infinity(), rate_high = -rate_low;
  for (const SweepPoint& p : r.points) {
    if (!p.ok) continue;
    symmetric = symmetric && p.symmetric;
    modes = std::max(modes, p.result.modes.size());
    rate_low = std::min(rate_low, p.frame_rate);
    rate_high = std::max(rate_high, p.frame_rate);
  }
  modes = std::min(modes, plotted_modes);
  j["symmetric"] = symmetric;
  const std::size_t stride = std::max<std::size_t>(1, (r.points.size() + plotted_points - 1) / plotted_points);
  // Campbell diagram: the parameter turns the scene's frame (docs/design.md).
  const bool rotating = rate_high > rate_low;
  Json x = Json::array(), stability = Json::array(), rate = Json::array();
  std::vector<Json> omega2(modes, Json::array()), growth(modes, Json::array()), omega(modes, Json::array());
  for (std::size_t i = 0; i < r.points.size(); i += stride) {
    const SweepPoint& p = r.points[i];
    x.push_back(finite_or_null(p.value));
    stability.push_back(p.ok ? class_index(p.result.stability) : -1);
    rate.push_back(p.ok ? finite_or_null(p.frame_rate) : Json(nullptr));
    for (std::size_t m = 0; m < modes; ++m) {
      const bool has = p.ok && m < p.result.modes.size();
      const Mode* mode = has ? &p.result.modes[m] : nullptr;
      omega2[m].push_back(has ? finite_or_null(mode->omega2) : Json(nullptr));
      growth[m].push_back(has ? finite_or_null(mode->growth_rate) : Json(nullptr));
      omega[m].push_back(has ? finite_or_null(mode->omega) : Json(nullptr));
    }
  }
  j["x"] = x;
  j["stability"] = stability;
  j["class_names"] = class_names();
  j["frame_rate"] = rotating ? rate : Json(nullptr);
  Json branches = Json::array();
  for (std::size_t m = 0; m < modes; ++m)
    branches.push_back({{"mode", m + 1}, {"omega2", omega2[m]}, {"growth_rate", growth[m]}, {"omega", omega[m]}});
  j["branches"] = branches;
  j["points_total"] = r.points.size();
  j["stride"] = stride;
  Json critical = Json::array();
  for (const CriticalValue& c : r.critical)
    critical.push_back({{"value", c.value},
                        {"error", c.error},
                        {"kind", to_string(c.kind)},
                        {"omega", finite_or_null(c.omega)},
                        {"text", describe_critical(c, r.axis.name)}});
  j["critical"] = critical;
  j["critical_table"] = csv_table(sweep_critical_csv(r));
  j["table"] = csv_table(sweep_modes_csv(r), table_rows);
  j["notes"] = r.notes;
  j["evaluations"] = r.evaluations;
  j["coordinates"] = r.coordinates.size();
  j["convergence"] = convergence.empty() ? Json(nullptr) : convergence_json(convergence);
  return html::page(fmt::format("Sweep of {} in {}", r.axis.name, scene_file), "modal sweep", "modal sweep --report", j);
}

std::string map_html(const StabilityMap& map, const std::string& scene_file) {
  Json j;
  j["kind"] = "map";
  j["scene"] = scene_file;
  auto axis = [](const SweepAxis& a) {
    Json values = Json::array();
    for (int i = 0; i < a.count; ++i) values.push_back(a.value(i));
    return Json{{"name", a.name}, {"values", values}};
  };
  j["x"] = axis(map.x);
  j["y"] = axis(map.y);
  Json cells = Json::array();
  Json failures = Json::array();
  for (const MapPoint& p : map.points) {
    cells.push_back(p.ok ? class_index(p.stability) : -1);
    if (!p.ok && failures.size() < 5)
      failures.push_back(fmt::format("{} = {:.6g}, {} = {:.6g}: {}", map.x.name, p.x, map.y.name, p.y, p.failure));
  }
  j["cells"] = cells;
  j["class_names"] = class_names();
  j["failures"] = failures;
  j["table"] = csv_table(map_csv(map), table_rows);
  return html::page(fmt::format("Stability map of {} and {} in {}", map.x.name, map.y.name, scene_file),
                    "modal stability map", "modal sweep --report", j);
}

std::string amplitude_html(const std::string& title, const std::string& scene_file, int mode, double omega2,
                           const AmplitudeResponse& r, double tolerance) {
  Json j;
  j["kind"] = "amplitude";
  j["scene"] = scene_file;
  j["mode"] = mode;
  j["omega2"] = omega2;
  j["omega_linear"] = r.omega_linear;
  j["coordinate"] = r.coordinate;
  j["unit"] = r.kind == CoordinateKind::length ? "m" : "rad";
  j["tolerance"] = tolerance;
  j["evaluations"] = r.evaluations;
  Json amplitude = Json::array(), ratio = Json::array(), departure = Json::array(), spread = Json::array();
  for (const AmplitudePoint& p : r.points) {
    amplitude.push_back(p.amplitude);
    // T/T_lin = ω_lin/ω = 1/(1 + shift); nothing where the motion left the well.
    ratio.push_back(p.oscillates ? finite_or_null(1 / (1 + p.shift)) : Json(nullptr));
    departure.push_back(p.oscillates ? finite_or_null(std::abs(p.shift)) : Json(nullptr));
    spread.push_back(p.oscillates ? finite_or_null(p.spread) : Json(nullptr));
  }
  j["amplitude"] = amplitude;
  j["period_ratio"] = ratio;
  j["departure"] = departure;
  j["spread"] = spread;
  Json thresholds = Json::array();
  for (const AmplitudeThreshold& t : r.thresholds)
    thresholds.push_back({{"level", t.level},
                          {"reached", t.reached},
                          {"amplitude", finite_or_null(t.amplitude)},
                          {"error", finite_or_null(t.error)},
                          {"note", t.note}});
  j["thresholds"] = thresholds;
  j["table"] = csv_table(amplitude_csv(r));
  return html::page(fmt::format("{}: mode {} against amplitude", title.empty() ? scene_file : title, mode),
                    "modal amplitude", "modal amplitude --report", j);
}

std::string simulation_html(const Trajectory& tr, const SimulationOptions& options, const std::string& title,
                            const std::string& scene_file, const std::vector<std::string>& notes) {
  Json j;
  j["kind"] = "simulate";
  j["scene"] = scene_file;
  const std::size_t samples = tr.size();
  const std::size_t n = samples ? static_cast<std::size_t>(tr.q.front().size()) : 0;
  const std::size_t shown = std::min(n, plotted_coordinates);
  Json names = Json::array();
  for (std::size_t i = 0; i < shown; ++i)
    names.push_back(i < tr.coordinates.size() ? tr.coordinates[i] : "q" + std::to_string(i + 1));
  j["coordinates"] = names;
  j["coordinate_count"] = n;
  // Each bucket of samples contributes its first and last time, and every
  // series its minimum and maximum there in the order they occur: the
  // envelope of an oscillation survives (plain thinning would alias it).
  const std::size_t per_bucket = std::max<std::size_t>(1, (samples + time_buckets - 1) / time_buckets);
  Json time = Json::array();
  std::vector<Json> q(shown, Json::array());
  Json error = Json::array();
  auto series = [&](const std::function<double(std::size_t)>& at, Json& out, std::size_t b, std::size_t e) {
    if (e - b == 1) {
      out.push_back(finite_or_null(at(b)));
      return;
    }
    std::size_t lo = b, hi = b;
    for (std::size_t k = b; k < e; ++k) {
      if (at(k) < at(lo)) lo = k;
      if (at(k) > at(hi)) hi = k;
    }
    out.push_back(finite_or_null(at(std::min(lo, hi))));
    out.push_back(finite_or_null(at(std::max(lo, hi))));
  };
  for (std::size_t b = 0; b < samples; b += per_bucket) {
    const std::size_t e = std::min(samples, b + per_bucket);
    time.push_back(tr.time[b]);
    if (e - b > 1) time.push_back(tr.time[e - 1]);
    for (std::size_t i = 0; i < shown; ++i)
      series([&](std::size_t k) { return tr.q[k][static_cast<Eigen::Index>(i)]; }, q[i], b, e);
    series([&](std::size_t k) { return tr.energy_error[k]; }, error, b, e);
  }
  j["time"] = time;
  j["q"] = q;
  j["energy_error"] = error;
  j["samples"] = samples;
  j["per_bucket"] = per_bucket;
  // A few samples spread over the run, as the CSV writes them.
  Trajectory picked;
  picked.coordinates = tr.coordinates;
  for (std::size_t k = 0; k < sample_rows && samples; ++k) {
    const std::size_t s = samples == 1 ? 0 : k * (samples - 1) / (sample_rows - 1);
    if (!picked.time.empty() && picked.time.back() == tr.time[s]) continue;
    picked.time.push_back(tr.time[s]);
    picked.q.push_back(tr.q[s]);
    picked.qd.push_back(tr.qd[s]);
    picked.energy.push_back(tr.energy[s]);
    picked.work.push_back(tr.work[s]);
    picked.energy_error.push_back(tr.energy_error[s]);
  }
  std::ostringstream csv;
  write_trajectory_csv(csv, picked);
  j["table"] = csv_table(csv.str());
  j["summary"] = {{"duration", samples ? tr.time.back() : 0.0},
                  {"steps", tr.steps},
                  {"rejected_steps", tr.rejected_steps},
                  {"evaluations", tr.evaluations},
                  {"tolerance", options.tolerance},
                  {"conservative", tr.conservative},
                  {"energy_start", samples ? finite_or_null(tr.energy.front()) : Json(nullptr)},
                  {"energy_end", samples ? finite_or_null(tr.energy.back()) : Json(nullptr)},
                  {"work_end", samples ? finite_or_null(tr.work.back()) : Json(nullptr)},
                  {"energy_scale", finite_or_null(tr.energy_scale)},
                  {"max_energy_error", finite_or_null(tr.max_energy_error)}};
  j["notes"] = notes;
  return html::page(fmt::format("{}: simulation", title.empty() ? scene_file : title), "modal simulation",
                    "modal simulate --report", j);
}

std::string equilibria_html(const Report& report, const std::vector<std::string>& unanalyzed) {
  Json j;
  j["kind"] = "equilibria";
  j["scene"] = report.scene_file;
  Json parameters = Json::array();
  for (const auto& [name, v] : report.parameters) parameters.push_back({name, csv_number(v)});
  j["parameters"] = parameters;
  Json potential = Json::array(), stable = Json::array(), described = Json::array();
  for (const AnalyzedEquilibrium& a : report.equilibria) {
    potential.push_back(finite_or_null(a.equilibrium.potential));
    stable.push_back(a.result.stability != Stability::divergence && a.result.stability != Stability::flutter);
    described.push_back(describe_stability(a.result));
  }
  j["potential"] = potential;
  j["stable"] = stable;
  j["stability"] = described;
  j["table"] = csv_table(text_of(write_equilibria_csv, report), table_rows);
  j["modes"] = csv_table(text_of(write_modes_csv, report), 20 * table_rows);
  j["unanalyzed"] = unanalyzed;
  const std::string title = report.title.empty() ? report.scene_file : report.title;
  return html::page(title, "modal equilibria", "modal equilibria --report", j);
}

}  // namespace modal
