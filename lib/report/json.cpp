// JSON output of the report stage.
#include "modal/report.hpp"

#include <cmath>
#include <complex>
#include <numbers>

#include <nlohmann/json.hpp>

namespace modal {

namespace {

using Json = nlohmann::ordered_json;

std::string coordinate_name(const Report& report, std::size_t i) {
  if (i < report.coordinates.size()) return report.coordinates[i];
  return "q" + std::to_string(i + 1);
}

Json header(const Report& report) {
  Json j;
  j["scene"] = report.scene_file;
  j["title"] = report.title;
  Json parameters = Json::object();
  for (const auto& [name, value] : report.parameters) parameters[name] = value;
  j["parameters"] = parameters;
  j["coordinates"] = report.coordinates;
  return j;
}

Json equilibrium_json(const Report& report, const Equilibrium& e) {
  Json j;
  Json q = Json::object();
  for (Eigen::Index i = 0; i < e.q.size(); ++i)
    q[coordinate_name(report, static_cast<std::size_t>(i))] = e.q[i];
  j["coordinates"] = q;
  j["potential"] = e.potential;
  j["residual"] = e.residual;
  j["residual_norm"] = e.residual_norm;
  j["iterations"] = e.iterations;
  if (!e.method.empty()) j["method"] = e.method;
  if (!e.limits.empty()) {  // the limited joints (all inactive: an active limit is refused)
    Json limits = Json::array();
    for (const JointLimitState& l : e.limits)
      limits.push_back({{"coordinate", coordinate_name(report, static_cast<std::size_t>(l.coordinate))},
                        {"value", l.value},
                        {"lower", l.lower},
                        {"upper", l.upper}});
    j["limits"] = limits;
  }
  return j;
}

Json mode_json(std::size_t index, const Mode& m) {
  Json j;
  j["mode"] = index + 1;
  j["omega2"] = m.omega2;  // NaN (complex mode) is written as null
  j["growth_rate"] = m.growth_rate;
  j["omega"] = m.omega;
  j["frequency_hz"] = m.frequency_hz;
  j["period"] = m.period;  // ∞ (zero frequency) is written as null
  j["damping_ratio"] = m.damping_ratio;
  j["error_estimate"] = m.error_estimate;
  if (std::isfinite(m.residual_bound)) j["residual_bound"] = m.residual_bound;
  if (m.systematic_error > 0) j["systematic_error"] = m.systematic_error;
  j["kind"] = to_string(m.kind);
  j["stability"] = mode_stability(m.kind);
  std::vector<double> re, im;
  bool complex = false;
  for (Eigen::Index i = 0; i < m.shape.size(); ++i) {
    re.push_back(m.shape[i].real());
    im.push_back(m.shape[i].imag());
    if (m.shape[i].imag() != 0) complex = true;
  }
  j["shape"] = re;
  if (complex) {
    j["shape_imag"] = im;
    std::vector<double> amplitude, phase;
    for (Eigen::Index i = 0; i < m.shape.size(); ++i) {
      amplitude.push_back(std::abs(m.shape[i]));
      phase.push_back(std::arg(m.shape[i]) * 180 / std::numbers::pi);
    }
    j["shape_amplitude"] = amplitude;
    j["shape_phase_deg"] = phase;
  }
  return j;
}

// A mode's "energy" (nonzero shares by element; potential null where not
// defined) and "participation" (per direction) members.
void add_energy(Json& j, const EnergyDistribution& d, const ModeEnergy& e) {
  auto named = [](const std::vector<std::string>& names, const std::vector<double>& f) {
    Json o = Json::object();
    for (std::size_t i = 0; i < f.size(); ++i)
      if (f[i] != 0.0) o[names[i]] = f[i];
    return o;
  };
  Json energy;
  energy["kinetic"] = named(d.kinetic_elements, e.kinetic);
  energy["potential"] = e.potential.empty() ? Json(nullptr) : named(d.potential_elements, e.potential);
  j["energy"] = energy;
  if (d.directions.empty()) return;
  Json participation = Json::object();
  for (std::size_t a = 0; a < d.directions.size(); ++a)
    participation[d.directions[a].name] = {{"participation_factor", e.participation_factor[a]},
                                           {"effective_mass", e.effective_mass[a]},
                                           {"cumulative_fraction", e.cumulative_fraction[a]}};
  j["participation"] = participation;
}

void add_result(Json& j, const AnalyzedEquilibrium& a) {
  const ModalResult& r = a.result;
  j["stability"] = to_string(r.stability);
  j["stability_description"] = describe_stability(r);
  j["morse_index"] = r.morse_index;
  j["zero_modes"] = r.zero_modes;
  Json modes = Json::array();
  for (std::size_t k = 0; k < r.modes.size(); ++k) modes.push_back(mode_json(k, r.modes[k]));
  if (a.energy) {
    const EnergyDistribution& d = *a.energy;
    for (const ModeEnergy& e : d.modes) add_energy(modes[static_cast<std::size_t>(e.mode - 1)], d, e);
    j["energy_split"] = d.split == EnergyDistribution::Split::element ? "element" : "coordinate";
    Json directions = Json::array();
    for (const ParticipationDirection& p : d.directions)
      directions.push_back({{"direction", p.name}, {"movable_mass", p.movable_mass}});
    j["participation_directions"] = directions;
  }
  j["modes"] = modes;
  j["solver"] = r.solver;
  j["notes"] = r.notes;
  if (!r.steady.empty()) {
    Json steady = Json::array();
    for (const SteadyRate& sr : r.steady)
      steady.push_back({{"coordinate", sr.coordinate}, {"rate", sr.rate}, {"momentum", sr.momentum}});
    j["steady_motion"] = steady;
  }
  if (!r.constraint_forces.empty()) {
    const std::vector<ConstraintEquationForce> eq = constraint_equation_forces(r);
    Json constraints = Json::array();
    std::size_t row = 0;
    for (const ConstraintForce& f : r.constraint_forces) {
      Json c = {{"name", f.name}, {"type", to_string(f.type)}};
      auto value = [&](std::size_t i) { return eq[i].determined ? Json(eq[i].force) : Json(nullptr); };
      if (f.type == Constraint::Type::point) {
        c["force"] = Json::array({value(row), value(row + 1), value(row + 2)});
        row += 3;
      } else {
        c["multiplier"] = value(row);
        if (f.type == Constraint::Type::distance) c["tension"] = eq[row].determined ? Json(-eq[row].force) : Json(nullptr);
        row += 1;
      }
      constraints.push_back(c);
    }
    j["constraints"] = constraints;
    j["redundant_equations"] = r.redundant_equations;
  }
}

}  // namespace

std::string analysis_json(const Report& report) {
  Json j = header(report);
  if (!report.equilibria.empty()) {
    const AnalyzedEquilibrium& a = report.equilibria.front();
    j["equilibrium"] = equilibrium_json(report, a.equilibrium);
    add_result(j, a);
  }
  return j.dump(2) + "\n";
}

std::string equilibria_json(const Report& report) {
  Json j = header(report);
  Json list = Json::array();
  for (std::size_t e = 0; e < report.equilibria.size(); ++e) {
    Json item;
    item["index"] = e + 1;
    item["equilibrium"] = equilibrium_json(report, report.equilibria[e].equilibrium);
    add_result(item, report.equilibria[e]);
    list.push_back(item);
  }
  j["equilibria"] = list;
  return j.dump(2) + "\n";
}

}  // namespace modal
