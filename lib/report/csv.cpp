// CSV writers of the report stage (docs/design.md, "Output files").
#include "modal/report.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <complex>
#include <numbers>
#include <ostream>
#include <string>
#include <vector>

namespace modal {

namespace {

std::string coordinate_name(const Report& report, std::size_t i) {
  if (i < report.coordinates.size()) return report.coordinates[i];
  return "q" + std::to_string(i + 1);
}

}  // namespace

Report make_report(const System& system, std::string scene_file,
                   std::vector<std::pair<std::string, double>> parameters) {
  Report r;
  r.scene_file = std::move(scene_file);
  r.title = system.title();
  r.parameters = std::move(parameters);
  for (const Coordinate& c : system.coordinates()) {
    r.coordinates.push_back(c.name);
    r.kinds.push_back(c.kind);
  }
  return r;
}

std::vector<ConstraintEquationForce> constraint_equation_forces(const ModalResult& result) {
  std::vector<ConstraintEquationForce> out;
  for (const ConstraintForce& f : result.constraint_forces)
    for (Eigen::Index i = 0; i < f.multipliers.size(); ++i) {
      ConstraintEquationForce e;
      e.equation = f.type == Constraint::Type::point ? f.name + "." + "xyz"[i] : f.name;
      e.force = f.multipliers[i];
      e.determined = std::find(result.redundant_equations.begin(), result.redundant_equations.end(), e.equation) ==
                     result.redundant_equations.end();
      out.push_back(std::move(e));
    }
  return out;
}

const char* mode_stability(ModeKind kind) {
  switch (kind) {
    case ModeKind::oscillatory: return "stable";
    case ModeKind::damped: return "asymptotically stable";
    case ModeKind::zero: return "marginal";
    case ModeKind::divergent: return "divergence";
    case ModeKind::flutter: return "flutter";
  }
  return "unknown";
}

std::string csv_number(double value) {
  if (!std::isfinite(value)) return {};
  char buffer[40];
  const auto r = std::to_chars(buffer, buffer + sizeof buffer, value);  // shortest form that reads back exactly
  return std::string(buffer, r.ptr);
}

std::string csv_field(std::string_view text) {
  if (text.find_first_of(",\"\r\n") == std::string_view::npos) return std::string(text);
  std::string quoted = "\"";
  for (char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  quoted += '"';
  return quoted;
}

void write_modes_csv(std::ostream& out, const Report& report) {
  out << "equilibrium,mode,omega2,growth_rate,omega,frequency_hz,period,damping_ratio,"
         "stability,error_estimate,residual_bound\n";
  for (std::size_t e = 0; e < report.equilibria.size(); ++e) {
    const auto& modes = report.equilibria[e].result.modes;
    for (std::size_t k = 0; k < modes.size(); ++k) {
      const Mode& m = modes[k];
      out << (e + 1) << ',' << (k + 1) << ',' << csv_number(m.omega2) << ','
          << csv_number(m.growth_rate) << ',' << csv_number(m.omega) << ','
          << csv_number(m.frequency_hz) << ',' << csv_number(m.period) << ','
          << csv_number(m.damping_ratio) << ',' << csv_field(mode_stability(m.kind)) << ','
          << csv_number(m.error_estimate) << ',' << csv_number(m.residual_bound) << '\n';
    }
  }
}

void write_shapes_csv(std::ostream& out, const Report& report) {
  out << "equilibrium,mode,coordinate,value,amplitude,phase_deg\n";
  // One row per coordinate and mode (10⁷ rows for 10 modes of a 10⁶-coordinate
  // net): formatted into a buffer written in blocks.
  std::vector<std::string> names(report.coordinates.size());
  for (std::size_t i = 0; i < names.size(); ++i) names[i] = csv_field(report.coordinates[i]);
  std::string buffer;
  buffer.reserve(1 << 20);
  char number[40];
  auto append = [&](double value) {
    if (std::isfinite(value)) buffer.append(number, std::to_chars(number, number + sizeof number, value).ptr);
  };
  for (std::size_t e = 0; e < report.equilibria.size(); ++e) {
    const auto& modes = report.equilibria[e].result.modes;
    for (std::size_t k = 0; k < modes.size(); ++k) {
      const Eigen::VectorXcd& shape = modes[k].shape;
      const std::string prefix = std::to_string(e + 1) + ',' + std::to_string(k + 1) + ',';
      for (Eigen::Index i = 0; i < shape.size(); ++i) {
        const auto c = static_cast<std::size_t>(i);
        buffer += prefix;
        buffer += c < names.size() ? names[c] : coordinate_name(report, c);
        buffer += ',';
        append(shape[i].real());
        buffer += ',';
        append(std::abs(shape[i]));
        buffer += ',';
        append(std::arg(shape[i]) * 180 / std::numbers::pi);
        buffer += '\n';
        if (buffer.size() > (1 << 20) - 256) {
          out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
          buffer.clear();
        }
      }
    }
  }
  out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
}

void write_equilibria_csv(std::ostream& out, const Report& report) {
  std::size_t n = report.coordinates.size();
  for (const auto& a : report.equilibria)
    n = std::max(n, static_cast<std::size_t>(a.equilibrium.q.size()));
  out << "equilibrium,stability,morse_index,potential,residual";
  for (std::size_t i = 0; i < n; ++i) out << ',' << csv_field(coordinate_name(report, i));
  // Steady motions: the rate and momentum of each ignorable coordinate.
  std::vector<std::string> ignorable;
  for (const auto& a : report.equilibria)
    for (const SteadyRate& sr : a.result.steady)
      if (std::find(ignorable.begin(), ignorable.end(), sr.coordinate) == ignorable.end()) ignorable.push_back(sr.coordinate);
  for (const std::string& c : ignorable) out << ',' << csv_field(c + "_rate") << ',' << csv_field(c + "_momentum");
  // Constraint forces: one column per equation (the same constraints at every equilibrium).
  std::vector<std::string> equations;
  for (const auto& a : report.equilibria)
    if (equations.empty())
      for (const ConstraintEquationForce& f : constraint_equation_forces(a.result)) equations.push_back(f.equation);
  for (const std::string& c : equations) out << ',' << csv_field(c + "_force");
  out << '\n';
  for (std::size_t e = 0; e < report.equilibria.size(); ++e) {
    const AnalyzedEquilibrium& a = report.equilibria[e];
    out << (e + 1) << ',' << csv_field(to_string(a.result.stability)) << ','
        << a.result.morse_index << ',' << csv_number(a.equilibrium.potential) << ','
        << csv_number(a.equilibrium.residual);
    for (std::size_t i = 0; i < n; ++i) {
      out << ',';
      if (i < static_cast<std::size_t>(a.equilibrium.q.size()))
        out << csv_number(a.equilibrium.q[static_cast<Eigen::Index>(i)]);
    }
    for (const std::string& c : ignorable) {
      const auto it = std::find_if(a.result.steady.begin(), a.result.steady.end(),
                                   [&](const SteadyRate& sr) { return sr.coordinate == c; });
      if (it != a.result.steady.end())
        out << ',' << csv_number(it->rate) << ',' << csv_number(it->momentum);
      else
        out << ",,";
    }
    const std::vector<ConstraintEquationForce> forces = constraint_equation_forces(a.result);
    for (std::size_t i = 0; i < equations.size(); ++i) {
      out << ',';
      if (i < forces.size() && forces[i].determined) out << csv_number(forces[i].force);
    }
    out << '\n';
  }
}

namespace {

// The one equilibrium whose energy distribution the energy files describe
// (analyze's); ReportError when several carry one (their layout has no
// equilibrium column).
const EnergyDistribution* energy_of(const Report& report) {
  const EnergyDistribution* found = nullptr;
  for (const AnalyzedEquilibrium& a : report.equilibria) {
    if (!a.energy) continue;
    if (found) throw ReportError("the energy and participation files describe one equilibrium; this report has energy "
                                 "distributions at several");
    found = &*a.energy;
  }
  return found;
}

}  // namespace

void write_energy_csv(std::ostream& out, const Report& report) {
  out << "mode,kind,element,fraction\n";
  const EnergyDistribution* d = energy_of(report);
  if (!d) return;
  auto rows = [&](int mode, const char* kind, const std::vector<std::string>& names, const std::vector<double>& f) {
    for (std::size_t i = 0; i < f.size(); ++i)
      if (f[i] != 0.0) out << mode << ',' << kind << ',' << csv_field(names[i]) << ',' << csv_number(f[i]) << '\n';
  };
  for (const ModeEnergy& m : d->modes) {
    rows(m.mode, "kinetic", d->kinetic_elements, m.kinetic);
    rows(m.mode, "potential", d->potential_elements, m.potential);
  }
}

void write_participation_csv(std::ostream& out, const Report& report) {
  out << "mode,direction,participation_factor,effective_mass,cumulative_fraction\n";
  const EnergyDistribution* d = energy_of(report);
  if (!d) return;
  for (const ModeEnergy& m : d->modes)
    for (std::size_t a = 0; a < d->directions.size(); ++a)
      out << m.mode << ',' << d->directions[a].name << ',' << csv_number(m.participation_factor[a]) << ','
          << csv_number(m.effective_mass[a]) << ',' << csv_number(m.cumulative_fraction[a]) << '\n';
}

void write_file(const std::string& path, void (*writer)(std::ostream&, const Report&),
                const Report& report) {
  std::ofstream file(path, std::ios::binary);
  if (!file) throw ReportError(path + ": cannot open the file for writing");
  writer(file, report);
  file.flush();
  if (!file) throw ReportError(path + ": writing failed");
}

void write_text_file(const std::string& path, const std::string& text) {
  std::ofstream file(path, std::ios::binary);
  if (!file) throw ReportError(path + ": cannot open the file for writing");
  file << text;
  file.flush();
  if (!file) throw ReportError(path + ": writing failed");
}

std::vector<std::string> write_csv_files(const std::string& prefix, const Report& report) {
  std::vector<std::string> paths = {prefix + "_modes.csv", prefix + "_shapes.csv",
                                    prefix + "_equilibria.csv"};
  write_file(paths[0], write_modes_csv, report);
  write_file(paths[1], write_shapes_csv, report);
  write_file(paths[2], write_equilibria_csv, report);
  const bool energy = std::any_of(report.equilibria.begin(), report.equilibria.end(),
                                  [](const AnalyzedEquilibrium& a) { return a.energy.has_value(); });
  if (energy) {
    paths.push_back(prefix + "_energy.csv");
    paths.push_back(prefix + "_participation.csv");
    write_file(paths[3], write_energy_csv, report);
    write_file(paths[4], write_participation_csv, report);
  }
  return paths;
}

}  // namespace modal
