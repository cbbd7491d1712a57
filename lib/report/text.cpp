// Human-readable output of the report stage.
#include "modal/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <ostream>

namespace modal {

namespace {

std::string coordinate_name(const Report& report, std::size_t i) {
  if (i < report.coordinates.size()) return report.coordinates[i];
  return "q" + std::to_string(i + 1);
}

bool is_angular(const Report& report, std::size_t i) {
  return i < report.kinds.size() && report.kinds[i] != CoordinateKind::length;
}

// An angle for a human table: rounding residue below 1e-13 rad (a polished
// equilibrium is not more accurate than that) is shown as 0; CSV and JSON keep
// every digit.
double display_angle(double radians) { return std::abs(radians) < 1e-13 ? 0.0 : radians; }

// A number for a table: `digits` significant digits, "-" when it has no value.
std::string num(double x, int digits = 10) {
  if (std::isnan(x)) return "-";
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  return fmt::format("{:.{}g}", x, digits);
}

std::string sci(double x) {
  if (!std::isfinite(x)) return num(x);
  return fmt::format("{:.1e}", x);
}


std::string vec(const Vec3& v) { return fmt::format("[{}, {}, {}]", num(v.x(), 6), num(v.y(), 6), num(v.z(), 6)); }

std::size_t name_width(const Report& report, std::size_t n, std::size_t least) {
  std::size_t w = least;
  for (std::size_t i = 0; i < n; ++i) w = std::max(w, coordinate_name(report, i).size());
  return w;
}

std::string parameter_line(const std::vector<std::pair<std::string, double>>& parameters) {
  std::string line;
  for (const auto& [name, value] : parameters) {
    if (!line.empty()) line += ", ";
    line += fmt::format("{} = {}", name, num(value, 12));
  }
  return line;
}

// "name 0.62, name 0.31, 3 others 0.07": the `top` largest shares by
// magnitude, then how many others there are and what they add up to.
std::string largest_shares(const std::vector<std::string>& names, const std::vector<double>& f, std::size_t top) {
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < f.size(); ++i)
    if (f[i] != 0.0) order.push_back(i);
  const std::size_t shown = std::min(top, order.size());
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(shown), order.end(),
                    [&](std::size_t a, std::size_t b) { return std::abs(f[a]) > std::abs(f[b]); });
  std::string line;
  for (std::size_t k = 0; k < shown; ++k)
    line += fmt::format("{}{} {}", k > 0 ? ", " : "", names[order[k]], num(f[order[k]], 4));
  if (order.size() > shown) {
    double rest = 0;
    for (std::size_t k = shown; k < order.size(); ++k) rest += f[order[k]];
    line += fmt::format(", {} others {}", order.size() - shown, num(rest, 4));
  }
  return line;
}

// `--energy`: each mode's largest kinetic and potential shares, then the
// participation table (the CSV and JSON have every share).
void print_energy(std::ostream& out, const EnergyDistribution& d) {
  constexpr std::size_t top = 5, modes_shown = 20;
  out << fmt::format("\nEnergy distribution (shares of each mode's kinetic and potential energy {}; "
                     "the largest {} by magnitude)\n",
                     d.split == EnergyDistribution::Split::element ? "by element" : "by coordinate", top);
  for (std::size_t i = 0; i < std::min(d.modes.size(), modes_shown); ++i) {
    const ModeEnergy& m = d.modes[i];
    out << fmt::format("  mode {:>3}  kinetic:   {}\n", m.mode, largest_shares(d.kinetic_elements, m.kinetic, top));
    out << fmt::format("            potential: {}\n",
                       m.potential.empty() ? std::string("not defined (zero mode)")
                                           : largest_shares(d.potential_elements, m.potential, top));
  }
  if (d.modes.size() > modes_shown)
    out << fmt::format("  ({} more modes in the CSV/JSON output)\n", d.modes.size() - modes_shown);
  if (d.directions.empty()) return;
  out << "\nParticipation in base translation (effective mass in kg; cumulative: over the modes above, "
         "divided by the movable mass)\n";
  out << fmt::format("  {:>4}", "mode");
  for (const ParticipationDirection& p : d.directions)
    out << fmt::format("  {:>11}  {:>12}  {:>10}", "gamma_" + p.name, "m_eff_" + p.name, "cum_" + p.name);
  out << '\n';
  for (std::size_t i = 0; i < std::min(d.modes.size(), modes_shown); ++i) {
    const ModeEnergy& m = d.modes[i];
    out << fmt::format("  {:>4}", m.mode);
    for (std::size_t a = 0; a < d.directions.size(); ++a)
      out << fmt::format("  {:>11}  {:>12}  {:>10}", num(m.participation_factor[a], 5), num(m.effective_mass[a], 6),
                         num(m.cumulative_fraction[a], 6));
    out << '\n';
  }
  out << "  movable mass:";
  for (const ParticipationDirection& p : d.directions) out << fmt::format(" {} {} kg", p.name, num(p.movable_mass, 10));
  out << '\n';
}

void print_header(std::ostream& out, const Report& report) {
  out << (report.title.empty() ? std::string("(untitled scene)") : report.title) << '\n';
  if (!report.scene_file.empty()) out << "scene: " << report.scene_file << '\n';
  if (!report.parameters.empty()) out << "parameters: " << parameter_line(report.parameters) << '\n';
}

}  // namespace

std::string describe_stability(const ModalResult& r) {
  auto plural = [](int count, const char* word) {
    return fmt::format("{} {}{}", count, word, count == 1 ? "" : "s");
  };
  std::string zero = r.zero_modes > 0
                         ? fmt::format("; {} (rigid-body motion or an ignorable coordinate)",
                                       plural(r.zero_modes, "zero-frequency mode"))
                         : std::string();
  switch (r.stability) {
    case Stability::stable:
      return "stable: every mode oscillates, none grows";
    case Stability::asymptotically_stable:
      return "asymptotically stable: every mode decays";
    case Stability::marginal:
      return fmt::format("marginal: {}, nothing grows",
                         plural(r.zero_modes, "zero-frequency mode") +
                             " (rigid-body motion or an ignorable coordinate)");
    case Stability::divergence:
      return fmt::format("divergence: statically unstable, Morse index {} ({} growing without oscillation){}",
                         r.morse_index, plural(r.morse_index, "mode"), zero);
    case Stability::flutter:
      return fmt::format("flutter: dynamically unstable, an oscillation grows{}{}",
                         r.morse_index > 0 ? fmt::format("; Morse index {}", r.morse_index) : "",
                         zero);
  }
  return to_string(r.stability);
}

// The limited joints at an equilibrium (all inactive: the pipeline refuses an
// active one), one line each, angles also in degrees.
void print_limits(std::ostream& out, const Report& report, const Equilibrium& e, const std::string& indent) {
  if (e.limits.empty()) return;
  out << indent << "joint limits (inactive: the equilibrium is inside every range)\n";
  std::size_t w = 0;
  for (const JointLimitState& l : e.limits)
    w = std::max(w, coordinate_name(report, static_cast<std::size_t>(l.coordinate)).size());
  for (const JointLimitState& l : e.limits) {
    const auto i = static_cast<std::size_t>(l.coordinate);
    const bool angle = is_angular(report, i);
    const double deg = 180 / std::numbers::pi;
    out << fmt::format("{}  {:<{}} = {} in [{}, {}] {}{}\n", indent, coordinate_name(report, i), w, num(l.value, 10),
                       num(l.lower, 10), num(l.upper, 10), angle ? "rad" : "m",
                       angle ? fmt::format("  ({} in [{}, {}] deg)", num(l.value * deg, 8), num(l.lower * deg, 8),
                                           num(l.upper * deg, 8))
                             : std::string());
  }
}

void print_analysis(std::ostream& out, const Report& report) {
  print_header(out, report);
  if (report.equilibria.empty()) {
    out << "\nno equilibrium\n";
    return;
  }
  const Equilibrium& e = report.equilibria.front().equilibrium;
  const ModalResult& r = report.equilibria.front().result;
  const std::size_t n = static_cast<std::size_t>(e.q.size());
  const std::size_t w = name_width(report, n, 8);

  out << "\nEquilibrium\n";
  if (n > 40) {  // a large scene: a summary instead of every coordinate (the CSV has them all)
    Eigen::Index big = 0;
    const double largest = e.q.size() > 0 ? e.q.cwiseAbs().maxCoeff(&big) : 0.0;
    out << fmt::format("  {} coordinates; the largest |q| is {} ({}); all in the CSV/JSON output\n", n,
                       num(largest, 10), coordinate_name(report, static_cast<std::size_t>(big)));
  }
  for (std::size_t i = 0; i < (n > 40 ? 0 : n); ++i) {
    const double v = is_angular(report, i) ? display_angle(e.q[static_cast<Eigen::Index>(i)])
                                           : e.q[static_cast<Eigen::Index>(i)];
    if (is_angular(report, i))
      out << fmt::format("  {:<{}} = {:>22} rad  ({} deg)\n", coordinate_name(report, i), w,
                         num(v, 15), num(v * 180 / std::numbers::pi, 10));
    else
      out << fmt::format("  {:<{}} = {:>22} m\n", coordinate_name(report, i), w, num(v, 15));
  }
  out << fmt::format("  {:<{}} = {:>22} J\n", "V", w, num(e.potential, 15));
  out << fmt::format("  relative residual {} (|grad V - Q{}| = {}, {} Newton iteration{})\n", sci(e.residual),
                     r.constraint_forces.empty() ? "" : " - grad c s", sci(e.residual_norm), e.iterations,
                     e.iterations == 1 ? "" : "s");
  if (!e.method.empty()) out << "  found by " << e.method << "\n";
  print_limits(out, report, e, "  ");
  if (!r.steady.empty()) {
    out << "  steady motion (ignorable coordinates; the others analyzed at these momenta by Routh's reduction):\n";
    for (const SteadyRate& sr : r.steady)
      out << fmt::format("    {}' = {} /s, momentum {}\n", sr.coordinate, num(sr.rate, 12), num(sr.momentum, 12));
  }
  if (!r.constraint_forces.empty()) {
    // Point constraints: the force on end a (N, world components); distance: the tension.
    const std::vector<ConstraintEquationForce> eq = constraint_equation_forces(r);
    auto value = [&](std::size_t i) { return eq[i].determined ? num(eq[i].force, 10) : std::string("undetermined"); };
    out << "  constraint forces (Lagrange multipliers, N):\n";
    std::size_t cw = 0;
    for (const ConstraintForce& f : r.constraint_forces) cw = std::max(cw, f.name.size());
    std::size_t row = 0;
    for (const ConstraintForce& f : r.constraint_forces) {
      if (f.type == Constraint::Type::point) {
        out << fmt::format("    {:<{}}  point     force on its first end (x, y, z) = ({}, {}, {})\n", f.name, cw,
                           value(row), value(row + 1), value(row + 2));
        row += 3;
      } else if (f.type == Constraint::Type::coupling) {
        out << fmt::format("    {:<{}}  coupling  generalized force on its driven joint {} (N·m or N)\n", f.name, cw,
                           value(row));
        row += 1;
      } else {
        const std::string t = eq[row].determined ? num(std::abs(eq[row].force), 10) : "undetermined";
        out << fmt::format("    {:<{}}  distance  {} {}\n", f.name, cw,
                           eq[row].determined && eq[row].force > 0 ? "compression" : "tension", t);
        row += 1;
      }
    }
  }

  out << "\nStability: " << describe_stability(r) << '\n';

  // Columns: ω² always (negative shown negative, "-" where complex); σ when
  // anything grows or decays; the damping ratio for first-order solutions.
  const bool first_order = std::any_of(r.modes.begin(), r.modes.end(),
                                       [](const Mode& m) { return std::isnan(m.omega2); });
  const bool sigma = std::any_of(r.modes.begin(), r.modes.end(),
                                 [](const Mode& m) { return m.growth_rate != 0; });
  out << "\nModes";
  if (!r.solver.empty()) out << " (" << r.solver << ")";
  out << '\n';
  auto row = [&](std::string mode, std::string omega2, std::string growth, std::string omega,
                 std::string f, std::string period, std::string zeta, std::string error,
                 std::string bound, std::string kind) {
    std::string line = fmt::format("  {:>4}  {:>20}", mode, omega2);
    if (sigma) line += fmt::format("  {:>18}", growth);
    line += fmt::format("  {:>18}  {:>16}  {:>16}", omega, f, period);
    if (first_order) line += fmt::format("  {:>13}", zeta);
    line += fmt::format("  {:>9}", error);
    if (!first_order) line += fmt::format("  {:>9}", bound);
    line += fmt::format("  {}\n", kind);
    out << line;
  };
  row("mode", "omega^2 [rad2/s2]", "sigma [1/s]", "omega [rad/s]", "f [Hz]", "period [s]",
      "damping ratio", "error", "bound", "kind");
  for (std::size_t k = 0; k < r.modes.size(); ++k) {
    const Mode& m = r.modes[k];
    row(std::to_string(k + 1), num(m.omega2), num(m.growth_rate), num(m.omega), num(m.frequency_hz),
        m.omega == 0 ? "-" : num(m.period), num(m.damping_ratio, 6), sci(m.error_estimate), sci(m.residual_bound),
        to_string(m.kind));
  }
  if (r.modes.empty()) out << "  (none)\n";

  // Shapes: only for small systems, where a table is readable.
  const std::size_t shown = std::min<std::size_t>(r.modes.size(), 8);
  if (shown > 0 && n <= 12) {
    out << "\nMode shapes " << (first_order ? "(amplitude@phase in degrees; largest component 1@0)" : "(M-normalized)")
        << '\n';
    // The cells first: a column is as wide as its widest (amplitude@phase
    // runs to 16 characters, "1.234e-05@-179.6").
    std::vector<std::vector<std::string>> cells(n, std::vector<std::string>(shown));
    std::size_t cell = 12;
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t k = 0; k < shown; ++k) {
        const auto& s = r.modes[k].shape;
        const std::complex<double> v = static_cast<Eigen::Index>(i) < s.size() ? s[static_cast<Eigen::Index>(i)]
                                                                               : std::complex<double>(std::nan(""), 0);
        cells[i][k] = first_order ? num(std::abs(v), 4) + "@" + num(std::arg(v) * 180 / std::numbers::pi, 4)
                                  : num(v.real(), 6);
        cell = std::max(cell, cells[i][k].size());
      }
    out << fmt::format("  {:<{}}", "coordinate", std::max<std::size_t>(w, 10));
    for (std::size_t k = 0; k < shown; ++k) out << fmt::format("  {:>{}}", fmt::format("mode {}", k + 1), cell);
    out << '\n';
    for (std::size_t i = 0; i < n; ++i) {
      out << fmt::format("  {:<{}}", coordinate_name(report, i), std::max<std::size_t>(w, 10));
      for (std::size_t k = 0; k < shown; ++k) out << fmt::format("  {:>{}}", cells[i][k], cell);
      out << '\n';
    }
    if (shown < r.modes.size()) out << fmt::format("  ({} more modes in the CSV/JSON output)\n", r.modes.size() - shown);
  }

  if (report.equilibria.front().energy) print_energy(out, *report.equilibria.front().energy);

  if (!r.notes.empty()) {
    out << "\nNotes\n";
    for (const std::string& note : r.notes) out << "  - " << note << '\n';
  }
}

void print_equilibria(std::ostream& out, const Report& report) {
  print_header(out, report);
  out << fmt::format("\n{} equilibri{} found\n", report.equilibria.size(),
                     report.equilibria.size() == 1 ? "um" : "a");
  if (report.equilibria.empty()) return;
  std::size_t n = report.coordinates.size();
  out << fmt::format("  {:>3}  {:<21}  {:>5}  {:>22}  {:>9}", "#", "stability", "morse", "V [J]",
                     "residual");
  for (std::size_t i = 0; i < n; ++i) {
    std::string name = coordinate_name(report, i);
    if (is_angular(report, i)) name += " [deg]";
    out << fmt::format("  {:>14}", name);
  }
  out << '\n';
  for (std::size_t e = 0; e < report.equilibria.size(); ++e) {
    const AnalyzedEquilibrium& a = report.equilibria[e];
    out << fmt::format("  {:>3}  {:<21}  {:>5}  {:>22}  {:>9}", e + 1, to_string(a.result.stability),
                       a.result.morse_index, num(a.equilibrium.potential, 15),
                       sci(a.equilibrium.residual));
    for (std::size_t i = 0; i < n; ++i) {
      double v = i < static_cast<std::size_t>(a.equilibrium.q.size())
                     ? a.equilibrium.q[static_cast<Eigen::Index>(i)]
                     : std::nan("");
      if (is_angular(report, i)) v = display_angle(v) * 180 / std::numbers::pi;
      out << fmt::format("  {:>14}", num(v, 8));
    }
    out << '\n';
  }
  for (std::size_t e = 0; e < report.equilibria.size(); ++e) {
    if (report.equilibria[e].equilibrium.limits.empty()) continue;
    out << fmt::format("\n  equilibrium {}:\n", e + 1);
    print_limits(out, report, report.equilibria[e].equilibrium, "    ");
  }
  bool any_notes = false;
  for (std::size_t e = 0; e < report.equilibria.size(); ++e)
    for (const std::string& note : report.equilibria[e].result.notes) {
      if (!any_notes) out << "\nNotes\n";
      any_notes = true;
      out << fmt::format("  - equilibrium {}: {}\n", e + 1, note);
    }
}

namespace {

// Neumaier's compensated sum: 343 000 particles of 0.01 kg add up to 3430 kg,
// not to the 3430.00000003 kg of a plain running sum.
class CompensatedSum {
 public:
  void add(double x) {
    const double t = sum_ + x;
    error_ += std::abs(sum_) >= std::abs(x) ? (sum_ - t) + x : (x - t) + sum_;
    sum_ = t;
  }
  double value() const { return sum_ + error_; }

 private:
  double sum_ = 0, error_ = 0;
};

// `modal check` of a kinematic map: coordinates (with what the core decided
// about their kind and periodicity, and the ignorable ones), points, potential.
void print_map_summary(std::ostream& out, const System& system) {
  const KinematicMap& m = system.map();
  out << fmt::format("\nKinematic map: {} coordinate{}, {} point{}{}\n", m.coordinates.size(),
                     m.coordinates.size() == 1 ? "" : "s", m.points.size(), m.points.size() == 1 ? "" : "s",
                     system.map_time_dependent() ? ", moving steadily with t" : "");
  out << fmt::format("\nCoordinates ({} analyzed)\n", system.size());
  for (const Coordinate& c : system.coordinates())
    out << fmt::format("  {:<16}  {:<8}  {:<12}  initial {}\n", c.name, to_string(c.kind),
                       c.periodic ? "periodic" : "not periodic", num(c.initial, 12));
  for (const int i : system.ignorable_coordinates()) {
    const MapCoordinate& c = m.coordinates[static_cast<std::size_t>(i)];
    const bool rate = c.ignorable->given == Ignorable::Given::rate;
    out << fmt::format("  {:<16}  ignorable: {} {} (Routh's reduction)\n", c.name, rate ? "steady rate" : "momentum",
                       num(c.ignorable->value, 12));
  }
  CompensatedSum total_mass;
  out << fmt::format("\nPoints ({})\n", m.points.size());
  for (const MapMass& p : m.points) {
    total_mass.add(p.mass);
    out << fmt::format("  {:<16}  mass {} kg{}\n    position [{}, {}, {}]\n", p.name, num(p.mass, 10),
                       p.inertia.isZero(0.0) ? "" : ", rigid body", p.position[0].text(), p.position[1].text(),
                       p.position[2].text());
  }
  if (!m.potential.text().empty()) out << fmt::format("\nPotential: {}\n", m.potential.text());
  out << fmt::format("\nTotal mass: {} kg\n", num(total_mass.value(), 12));
  out << fmt::format("Gravity: {} m/s^2\n", vec(system.gravity()));
}

}  // namespace

void print_summary(std::ostream& out, const std::string& scene_file,
                   const std::vector<std::pair<std::string, double>>& parameters,
                   const System& system, std::size_t list_limit) {
  // Whether row i (0-based) of a list of `total` is printed; after the last
  // printed row, a line saying how many were left out.
  auto shown = [&](std::size_t i, std::size_t total, const char* what) {
    if (list_limit == 0 || i < list_limit) return true;
    if (i == list_limit)
      out << fmt::format("  … and {} more {} (modal check --all lists them)\n", total - list_limit, what);
    return false;
  };
  out << (system.title().empty() ? std::string("(untitled scene)") : system.title()) << '\n';
  out << "scene: " << scene_file << "  (valid)\n";

  out << fmt::format("\nParameters ({})\n", parameters.size());
  for (const auto& [name, value] : parameters) out << fmt::format("  {:<16} = {}\n", name, num(value, 15));

  if (system.is_map()) {
    print_map_summary(out, system);
    return;
  }
  const auto& bodies = system.bodies();
  auto body_name = [&](int index) -> std::string {
    return index < 0 ? std::string("world") : bodies[static_cast<std::size_t>(index)].name;
  };
  CompensatedSum total_mass;
  out << fmt::format("\nBodies ({})\n", bodies.size());
  if (!bodies.empty())
    out << fmt::format("  {:<16}  {:<8}  {:<16}  {:>14}  {}\n", "name", "joint", "parent", "mass [kg]",
                       "coordinates");
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const Body& body = bodies[b];
    total_mass.add(body.mass);
    if (!shown(b, bodies.size(), "bodies")) continue;
    out << fmt::format("  {:<16}  {:<8}  {:<16}  {:>14}  {}\n", body.name, to_string(body.joint),
                       body_name(body.parent), num(body.mass, 10),
                       system.joint_size(static_cast<int>(b)));
  }

  const auto& coords = system.coordinates();
  out << fmt::format("\nCoordinates ({})\n", coords.size());
  for (std::size_t i = 0; i < coords.size(); ++i) {
    const Coordinate& c = coords[i];
    if (!shown(i, coords.size(), "coordinates")) break;
    out << fmt::format("  {:<16}  {:<8}  initial {}\n", c.name, to_string(c.kind), num(c.initial, 12));
  }

  out << fmt::format("\nSprings ({})\n", system.springs().size());
  for (std::size_t i = 0; i < system.springs().size(); ++i) {
    const Spring& s = system.springs()[i];
    if (!shown(i, system.springs().size(), "springs")) break;
    out << fmt::format("  {} {} -- {} {}: stiffness {} N/m, rest length {} m{}\n", body_name(s.a.body),
                       vec(s.a.point), body_name(s.b.body), vec(s.b.point), num(s.stiffness, 10),
                       num(s.rest_length, 10),
                       s.damping != 0 ? fmt::format(", damping {} N s/m", num(s.damping, 10)) : "");
  }
  std::size_t joint_springs = 0;
  for (const Body& body : bodies)
    if (body.stiffness != 0 || body.damping != 0) ++joint_springs;
  if (joint_springs > 0) {
    out << fmt::format("  joint springs/dampers on {} bod{}:\n", joint_springs,
                       joint_springs == 1 ? "y" : "ies");
    for (const Body& body : bodies)
      if (body.stiffness != 0 || body.damping != 0)
        out << fmt::format("    {}: stiffness {}, damping {}\n", body.name, num(body.stiffness, 10),
                           num(body.damping, 10));
  }

  out << fmt::format("\nLoads ({})\n", system.loads().size() + system.followers().size());
  for (const DeadLoad& l : system.loads())
    out << fmt::format("  {} at {}: force {} N (dead load)\n", body_name(l.at.body), vec(l.at.point),
                       vec(l.force));
  for (const FollowerLoad& l : system.followers())
    out << fmt::format("  {} at {}: force {} N (follower load, body frame)\n", body_name(l.at.body),
                       vec(l.at.point), vec(l.force));

  if (system.has_constraints()) {
    out << fmt::format("\nConstraints ({}, {} equation{})\n", system.constraints().size(),
                       system.constraint_equations(), system.constraint_equations() == 1 ? "" : "s");
    for (const Constraint& c : system.constraints()) {
      if (c.type == Constraint::Type::coupling) {
        std::string p;
        for (std::size_t k = 0; k < c.polynomial.size(); ++k)
          if (c.polynomial[k] != 0.0 && (k == 0 || c.b.body >= 0))
            p += fmt::format("{}{}{}", p.empty() ? "" : " + ", num(c.polynomial[k], 12),
                             k == 0 ? "" : k == 1 ? "*" + body_name(c.b.body) : "*" + body_name(c.b.body) + "^" + std::to_string(k));
        out << fmt::format("  {}: coupling {} = {}\n", c.name, body_name(c.a.body), p.empty() ? "0" : p);
        continue;
      }
      out << fmt::format("  {}: {} {} {} -- {} {}{}\n", c.name, to_string(c.type), body_name(c.a.body),
                         vec(c.a.point), body_name(c.b.body), vec(c.b.point),
                         c.type == Constraint::Type::distance ? fmt::format(", length {} m", num(c.length, 12)) : "");
    }
  }

  out << fmt::format("\nTotal mass: {} kg\n", num(total_mass.value(), 12));
  out << fmt::format("Gravity: {} m/s^2\n", vec(system.gravity()));
  out << fmt::format("Damping: {}\n", system.has_damping() ? "yes" : "none");
}

}  // namespace modal
