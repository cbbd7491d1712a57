// Expression-defined systems (kinematic maps): construction checks, and the
// evaluation of V_eff, its exact gradient and Hessian, M and g by forward AD
// through the expressions (lib/core/map.hpp). The shared parts of the core
// (∂M/∂q, Christoffel symbols, Coriolis, G, accelerations, energy) reach these
// through map_kinetic() and need no second copy.
#include "core/map_eval.hpp"

#include "core/map.hpp"

#include <algorithm>
#include <string>
#include <stdexcept>
#include <cmath>
#include <numbers>

namespace modal {

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}

// Everything the energy of a map is made of, in all map coordinates, at (q, t),
// ignorable coordinates shifted by `shift` from their initial values.
struct MapEnergies {
  MatrixX M;
  VectorX g;
  double T0 = 0, V = 0, scale_V = 0;
  bool finite = true;
};

MapEnergies map_energies(const System& s, const VectorX& q, double t, double shift) {
  const std::vector<double> vars = kmap::variables<double>(s, q.data(), t, shift);
  std::vector<kmap::PointPose<double>> at;
  kmap::poses(s.map(), vars, at);
  const kmap::Kinetic<double> k = kmap::kinetic(s, vars, at, s.map_time_dependent());
  MapEnergies e;
  e.M = k.M;
  e.g = k.g;
  e.T0 = k.T0;
  e.V = kmap::plain_potential(s, vars, at);
  e.scale_V = std::abs(s.map().potential.evaluate(vars));
  for (std::size_t i = 0; i < at.size(); ++i) e.scale_V += s.map().points[i].mass * s.gravity().norm() * at[i].x.norm();
  e.finite = e.M.allFinite() && e.g.allFinite() && std::isfinite(e.T0) && std::isfinite(e.V);
  return e;
}

// Which of M, g, T₀, V differ between a and b beyond rounding; "" when none.
std::string energy_difference(const MapEnergies& a, const MapEnergies& b) {
  constexpr double tol = 1e-9;
  const double sM = std::max(a.M.cwiseAbs().maxCoeff(), b.M.cwiseAbs().maxCoeff());
  const double sT = std::max(a.T0, b.T0);
  if ((a.M - b.M).cwiseAbs().maxCoeff() > tol * sM) return "the mass matrix M";
  const double sg = std::max(a.g.cwiseAbs().maxCoeff(), b.g.cwiseAbs().maxCoeff()) + std::sqrt(sM * sT);
  if (a.g.size() > 0 && (a.g - b.g).cwiseAbs().maxCoeff() > tol * sg) return "the velocity coupling g";
  if (std::abs(a.T0 - b.T0) > tol * sT) return "the frame's kinetic energy T0";
  const double sV = std::max(a.scale_V, b.scale_V) + std::max(std::abs(a.V), std::abs(b.V)) + sT;
  if (std::abs(a.V - b.V) > tol * sV) return "the potential energy V";
  return "";
}

}  // namespace

void System::build_map() {
  KinematicMap& m = d_.map;
  require(d_.bodies.empty() && d_.springs.empty() && d_.loads.empty() && d_.followers.empty(),
          "a system is either a tree of bodies or a kinematic map, not both");
  require(!rotating(), "frame_rotation applies to body scenes; a kinematic map writes its frame's motion with t");
  require(!m.coordinates.empty(), "a kinematic map needs at least one coordinate");
  const std::size_t nz = m.coordinates.size();
  auto uses_time = [&](const Expression& e) {
    const auto used = e.variables_used();
    return std::find(used.begin(), used.end(), static_cast<int>(nz)) != used.end();
  };
  map_time_ = uses_time(m.potential);
  for (std::size_t i = 0; i < m.points.size(); ++i) {
    const MapMass& p = m.points[i];
    const std::string who = "point '" + p.name + "': ";
    require(std::isfinite(p.mass) && p.mass >= 0, who + "mass must be finite and non-negative");
    require(p.inertia.allFinite(), who + "non-finite inertia");
    for (const Expression& e : p.position) map_time_ = map_time_ || uses_time(e);
    for (const MapRotation& r : p.orientation) {
      require(std::abs(r.axis.norm() - 1.0) < 1e-12, who + "rotation axis must be a unit vector");
      map_time_ = map_time_ || uses_time(r.angle);
    }
  }
  std::optional<Ignorable::Given> given;
  for (std::size_t k = 0; k < nz; ++k) {
    const MapCoordinate& c = m.coordinates[k];
    require(std::isfinite(c.initial), "coordinate '" + c.name + "': non-finite initial value");
    if (c.ignorable) {
      require(std::isfinite(c.ignorable->value), "coordinate '" + c.name + "': non-finite rate or momentum");
      require(!given || *given == c.ignorable->given,
              "ignorable coordinates must all be given by their rate or all by their momentum");
      given = c.ignorable->given;
      ignorable_.push_back(static_cast<int>(k));
    } else {
      kept_.push_back(static_cast<int>(k));
      coords_.push_back({c.name, c.kind.value_or(CoordinateKind::length), -1, c.initial, false});
    }
  }
  require(!kept_.empty(), "every coordinate is ignorable: nothing is left to analyze");
  n_ = static_cast<int>(kept_.size());
  moving_map_ = map_time_ || !ignorable_.empty();

  // Sample configurations: the initial one and two nearby (invalid ones, where
  // an expression is undefined, are skipped).
  const VectorX q0 = initial_configuration();
  std::vector<VectorX> samples{q0};
  for (const double step : {0.1, 0.3}) {
    VectorX q = q0;
    for (int i = 0; i < n_; ++i) q[i] += step * (0.5 - 0.37 * std::sin(1.0 + 2.3 * i));
    samples.push_back(q);
  }
  const MapEnergies first = map_energies(*this, q0, 0.0, 0.0);
  require(first.finite, "the kinematic map is not defined at the initial configuration "
                        "(an expression is not finite there): check [coordinates] and the positions");
  double scale = 0;
  {
    const std::vector<double> vars = kmap::variables<double>(*this, q0.data(), 0.0);
    std::vector<kmap::PointPose<double>> at;
    kmap::poses(d_.map, vars, at);
    for (const auto& p : at) scale = std::max(scale, p.x.norm());
  }
  length_scale_ = std::max(scale, 1e-3);

  for (const VectorX& q : samples) {
    const MapEnergies ref = map_energies(*this, q, 0.0, 0.0);
    if (!ref.finite) continue;
    if (map_time_)
      for (const double t : {0.618, 2.237, 9.87}) {
        const MapEnergies e = map_energies(*this, q, t, 0.0);
        if (!e.finite) continue;
        const std::string what = energy_difference(ref, e);
        if (!what.empty())
          throw std::invalid_argument(
              "the energy of this kinematic map depends on time: " + what + " changes between t = 0 and t = " +
              kmap::short_number(t, 6) + " s. Only steadily moving frames (M, g, T0 and V independent of t) can be linearized; "
              "a periodically moving system needs Floquet analysis, which modal does not do");
      }
    for (std::size_t k = 0; k < kept_.size(); ++k) {  // periodicity: an angle that repeats after 2π
      Coordinate& c = coords_[k];
      if (c.kind == CoordinateKind::length && m.coordinates[static_cast<std::size_t>(kept_[k])].kind) continue;
      if (&q != &samples.front() && !c.periodic) continue;  // already found not to repeat
      VectorX turned = q;
      turned[static_cast<Eigen::Index>(k)] += 2 * std::numbers::pi;
      const MapEnergies e = map_energies(*this, turned, 0.0, 0.0);
      c.periodic = e.finite && energy_difference(ref, e).empty();
      if (!m.coordinates[static_cast<std::size_t>(kept_[k])].kind) c.kind = c.periodic ? CoordinateKind::angle : CoordinateKind::length;
    }
    for (const int c : ignorable_)
      for (const double shift : {0.731, 2.9}) {
        const MapEnergies e = map_energies(*this, q, 0.0, shift);
        if (!e.finite) continue;
        const std::string what = energy_difference(ref, e);
        if (!what.empty())
          throw std::invalid_argument("coordinate '" + m.coordinates[static_cast<std::size_t>(c)].name +
                                      "' is declared ignorable, but " + what + " changes when it changes by " +
                                      kmap::short_number(shift, 6) + ": an ignorable coordinate must appear in no term of T and V");
      }
  }
}

namespace map_eval {

double potential(const System& s, const VectorX& q) {
  return kmap::reduced<double>(s, q.data(), false, false, true).V;
}

namespace {

template <int B> void gradient_block(const System& s, const VectorX& q, int first, VectorX& g) {
  using D = Dual<double, B>;
  const int n = s.size();
  std::vector<D> x(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) x[static_cast<std::size_t>(i)] = D(q[i]);
  for (int d = 0; d < B && first + d < n; ++d) x[static_cast<std::size_t>(first + d)].d[static_cast<std::size_t>(d)] = 1.0;
  const D V = kmap::reduced<D>(s, x.data(), false, false, true).V;
  for (int d = 0; d < B && first + d < n; ++d) g[first + d] = V.d[static_cast<std::size_t>(d)];
}

// ∂²V/∂q_{a+i}∂q_{b+j} for the blocks starting at a and b (inner level seeded along a, outer along b).
template <int B> void hessian_block(const System& s, const VectorX& q, int a, int b, MatrixX& H) {
  using I = Dual<double, B>;
  using O = Dual<I, B>;
  const int n = s.size();
  std::vector<O> x(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) x[static_cast<std::size_t>(i)] = O(I(q[i]));
  for (int d = 0; d < B && a + d < n; ++d) x[static_cast<std::size_t>(a + d)].v.d[static_cast<std::size_t>(d)] = 1.0;
  for (int e = 0; e < B && b + e < n; ++e) x[static_cast<std::size_t>(b + e)].d[static_cast<std::size_t>(e)] = I(1.0);
  const O V = kmap::reduced<O>(s, x.data(), false, false, true).V;
  for (int d = 0; d < B && a + d < n; ++d)
    for (int e = 0; e < B && b + e < n; ++e)
      H(a + d, b + e) = H(b + e, a + d) = V.d[static_cast<std::size_t>(e)].d[static_cast<std::size_t>(d)];
}

constexpr int block = 4;

}  // namespace

void gradient(const System& s, const VectorX& q, VectorX& g) {
  g.resize(s.size());
  for (int first = 0; first < s.size(); first += block) gradient_block<block>(s, q, first, g);
}

void hessian(const System& s, const VectorX& q, MatrixX& H) {
  H.resize(s.size(), s.size());
  for (int a = 0; a < s.size(); a += block)
    for (int b = a; b < s.size(); b += block) hessian_block<block>(s, q, a, b, H);
}

void mass_matrix(const System& s, const VectorX& q, MatrixX& M) {
  M = kmap::reduced<double>(s, q.data(), true, false, false).M;
}

VectorX frame_coupling(const System& s, const VectorX& q) {
  if (!s.has_frame_coupling()) return VectorX::Zero(s.size());
  return kmap::reduced<double>(s, q.data(), false, true, false).g;
}

double force_scale(const System& s, const VectorX& q) {
  // Gravity on every point: m|gravity|‖∂x/∂q‖ (non-zero where the force is
  // balanced by the geometry, e.g. a pendulum at the bottom); the potential and
  // the frame's terms through the Hessian, one unit (1 rad, or the length
  // scale) of motion along every coordinate, and the gradient itself.
  const std::vector<double> vars = kmap::variables<double>(s, q.data(), 0.0);
  double scale = 0;
  const auto& kept = s.kept_coordinates();
  std::vector<double> jacobian2(s.map().points.size(), 0.0);
  for (const int k : kept) {
    const kmap::Velocity<double> v = kmap::velocity(s.map(), vars, static_cast<std::size_t>(k));
    for (std::size_t i = 0; i < jacobian2.size(); ++i) jacobian2[i] += v.v[i].squaredNorm();
  }
  for (std::size_t i = 0; i < jacobian2.size(); ++i)
    scale += s.map().points[i].mass * s.gravity().norm() * std::sqrt(jacobian2[i]);
  MatrixX H;
  hessian(s, q, H);
  VectorX g;
  gradient(s, q, g);
  for (int k = 0; k < s.size(); ++k) {
    const double unit = s.coordinates()[static_cast<std::size_t>(k)].kind == CoordinateKind::length ? s.length_scale() : 1.0;
    scale += unit * H.col(k).norm();
  }
  return scale + g.norm();
}

}  // namespace map_eval

std::vector<SteadyRate> steady_motion(const System& s, const VectorX& q) {
  std::vector<SteadyRate> out;
  if (!s.is_map() || s.ignorable_coordinates().empty()) return out;
  const KinematicMap& m = s.map();
  // Full kinetic terms at q (kept at rest): p = M_cc ċ + g_c.
  const MapEnergies e = map_energies(s, q, 0.0, 0.0);
  const auto& c = s.ignorable_coordinates();
  const auto nc = static_cast<Eigen::Index>(c.size());
  MatrixX Mcc(nc, nc);
  VectorX gc(nc), given(nc);
  for (Eigen::Index i = 0; i < nc; ++i) {
    const auto ci = static_cast<Eigen::Index>(c[static_cast<std::size_t>(i)]);
    gc[i] = e.g[ci];
    given[i] = m.coordinates[static_cast<std::size_t>(ci)].ignorable->value;
    for (Eigen::Index j = 0; j < nc; ++j) Mcc(i, j) = e.M(ci, static_cast<Eigen::Index>(c[static_cast<std::size_t>(j)]));
  }
  VectorX rate, momentum;
  if (m.coordinates[static_cast<std::size_t>(c.front())].ignorable->given == Ignorable::Given::rate) {
    rate = given;
    momentum = Mcc * rate + gc;
  } else {
    momentum = given;
    rate = kmap::solve_spd<double>(Mcc, MatrixX(given - gc), e.M.diagonal().cwiseAbs().maxCoeff()).col(0);
  }
  for (Eigen::Index i = 0; i < nc; ++i)
    out.push_back({m.coordinates[static_cast<std::size_t>(c[static_cast<std::size_t>(i)])].name, rate[i], momentum[i]});
  return out;
}

System with_steady_momenta(const System& s, const VectorX& q) {
  if (!s.is_map() || s.ignorable_coordinates().empty()) return s;
  const std::vector<SteadyRate> steady = steady_motion(s, q);
  // Only the given values change: the checks of the constructor (steadiness,
  // ignorability, periodicity) hold for the copy as they did for s.
  System free = s;
  for (std::size_t i = 0; i < steady.size(); ++i) {
    MapCoordinate& c = free.d_.map.coordinates[static_cast<std::size_t>(s.ignorable_coordinates()[i])];
    c.ignorable = Ignorable{Ignorable::Given::momentum, steady[i].momentum};
  }
  return free;
}

std::vector<Vec3> map_point_positions(const System& s, const VectorX& q) {
  std::vector<Vec3> out;
  if (!s.is_map()) return out;
  const std::vector<double> vars = kmap::variables<double>(s, q.data(), 0.0);
  std::vector<kmap::PointPose<double>> at;
  kmap::poses(s.map(), vars, at);
  for (std::size_t i = 0; i < at.size(); ++i) {
    out.push_back(at[i].x);
    if (s.map().points[i].inertia.isZero(0.0)) continue;
    for (int a = 0; a < 3; ++a) out.push_back(at[i].x + s.length_scale() * at[i].R.col(a));
  }
  return out;
}

std::vector<Vec3> map_point_rates(const System& s, const VectorX& q, const VectorX& dq) {
  std::vector<Vec3> out;
  if (!s.is_map()) return out;
  if (q.size() != s.size() || dq.size() != s.size())
    throw std::invalid_argument("map_point_rates: q and dq must have " + std::to_string(s.size()) + " entries");
  using D1 = Dual<double, 1>;
  std::vector<D1> z(static_cast<std::size_t>(q.size()));
  for (Eigen::Index k = 0; k < q.size(); ++k) {
    z[static_cast<std::size_t>(k)] = D1(q[k]);
    z[static_cast<std::size_t>(k)].d[0] = dq[k];
  }
  const std::vector<D1> vars = kmap::variables<D1>(s, z.data(), D1(0.0));
  std::vector<kmap::PointPose<D1>> at;
  kmap::poses(s.map(), vars, at);
  for (std::size_t i = 0; i < at.size(); ++i) {
    const Vec3 velocity(at[i].x[0].d[0], at[i].x[1].d[0], at[i].x[2].d[0]);
    out.push_back(velocity);
    if (s.map().points[i].inertia.isZero(0.0)) continue;
    for (int a = 0; a < 3; ++a)  // the tips x + L R e_a
      out.push_back(velocity + s.length_scale() * Vec3(at[i].R(0, a).d[0], at[i].R(1, a).d[0], at[i].R(2, a).d[0]));
  }
  return out;
}

}  // namespace modal
