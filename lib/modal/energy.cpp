// The energy distribution and base-excitation participation of modes
// (modal/energy.hpp; docs/design.md, "Energy distribution and participation").
#include "modal/energy.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace modal {

namespace {

// Shares x / Σx; empty when Σx is zero (nothing to share).
std::vector<double> shares(const VectorX& x, double& total) {
  total = x.sum();
  if (total == 0.0 || !std::isfinite(total)) return {};
  std::vector<double> f(static_cast<std::size_t>(x.size()));
  for (Eigen::Index i = 0; i < x.size(); ++i) f[static_cast<std::size_t>(i)] = x[i] / total;
  return f;
}

bool real_modes(const ModalResult& r) {
  for (const Mode& m : r.modes)
    if (!std::isfinite(m.omega2)) return false;
  return true;
}

// One mode's shares: split(v, kinetic, potential) gives the quadratic forms of
// a real direction v element by element; a complex shape a + ib adds those of
// a and of b (the time average).
template <class Split>
ModeEnergy mode_energy(int index, const Mode& mode, Split&& split) {
  ModeEnergy e;
  e.mode = index;
  VectorX kinetic, potential;
  split(mode.shape.real(), kinetic, potential);
  if (!mode.shape.imag().isZero(0.0)) {  // time average of a complex mode: aᵀXa + bᵀXb
    VectorX k2, p2;
    split(mode.shape.imag(), k2, p2);
    kinetic += k2;
    potential += p2;
  }
  e.kinetic = shares(kinetic, e.kinetic_total);
  double total = 0;
  std::vector<double> p = shares(potential, total);
  e.potential_total = total;
  if (mode.kind != ModeKind::zero) e.potential = std::move(p);
  return e;
}

void check_shape(const Mode& mode, Eigen::Index size) {
  if (mode.shape.size() != size)
    throw std::invalid_argument("energy_distribution: a mode shape has " + std::to_string(mode.shape.size()) +
                                " components, the model " + std::to_string(size));
}

// Mode shapes are in all n coordinates (solve_modes maps a constrained model's
// shapes back by N), so the elements see the coordinates' motion directly.
EnergyDistribution tree_distribution(const System& sys, const VectorX& q, const VectorX& multipliers,
                                     const ModalResult& result) {
  EnergyDistribution d;
  d.split = EnergyDistribution::Split::element;
  for (const Body& b : sys.bodies()) d.kinetic_elements.push_back(b.name);
  d.potential_elements = potential_terms(sys);
  if (real_modes(result)) {
    const char* names[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a) {
      const Vec3 dir = Vec3::Unit(a);
      const double m = movable_mass(sys, q, dir);
      if (m > 0) d.directions.push_back({names[a], dir, m});
    }
  }
  std::vector<double> cumulative(d.directions.size(), 0.0);
  for (std::size_t i = 0; i < result.modes.size(); ++i) {
    const Mode& mode = result.modes[i];
    check_shape(mode, sys.size());
    Vec3 momentum = Vec3::Zero();
    bool first = true;
    ModeEnergy e = mode_energy(static_cast<int>(i) + 1, mode, [&](const VectorX& phi, VectorX& k, VectorX& p) {
      ElementQuadratics x = element_quadratics(sys, q, phi, multipliers);
      if (first) momentum = x.momentum;  // the real part (participation: real modes only)
      first = false;
      k = std::move(x.kinetic);
      p = std::move(x.potential);
    });
    for (std::size_t a = 0; a < d.directions.size(); ++a) {
      const double l = d.directions[a].direction.dot(momentum);  // φᵀL_d
      const double eff = e.kinetic_total > 0 ? l * l / e.kinetic_total : 0.0;
      cumulative[a] += eff;
      e.participation_factor.push_back(e.kinetic_total > 0 ? l / e.kinetic_total : 0.0);
      e.effective_mass.push_back(eff);
      e.cumulative_fraction.push_back(cumulative[a] / d.directions[a].movable_mass);
    }
    d.modes.push_back(std::move(e));
  }
  return d;
}

// Kinematic maps: per coordinate, φ_i(Xφ)_i for X = M and the symmetric part of K.
EnergyDistribution coordinate_distribution(const LinearModel& model, const ModalResult& result) {
  EnergyDistribution d;
  d.split = EnergyDistribution::Split::coordinate;
  d.kinetic_elements = model.coordinates;
  d.potential_elements = model.coordinates;
  const MatrixX Ks = 0.5 * (model.K + model.K.transpose());
  for (std::size_t i = 0; i < result.modes.size(); ++i) {
    check_shape(result.modes[i], model.dof());
    d.modes.push_back(mode_energy(static_cast<int>(i) + 1, result.modes[i],
                                  [&](const VectorX& phi, VectorX& k, VectorX& p) {
                                    k = phi.cwiseProduct(model.M * phi);
                                    p = phi.cwiseProduct(Ks * phi);
                                  }));
  }
  return d;
}

}  // namespace

EnergyDistribution energy_distribution(const System& system, const LinearModel& model, const ModalResult& result) {
  if (system.is_map()) return coordinate_distribution(model, result);
  VectorX multipliers;
  if (!model.constraint_forces.empty()) {
    multipliers.resize(system.constraint_equations());
    Eigen::Index row = 0;
    for (const ConstraintForce& f : model.constraint_forces) {
      multipliers.segment(row, f.multipliers.size()) = f.multipliers;
      row += f.multipliers.size();
    }
    if (row != multipliers.size())
      throw std::invalid_argument("energy_distribution: the model's constraint forces do not fit the system");
  }
  return tree_distribution(system, model.q, multipliers, result);
}

EnergyDistribution energy_distribution(const System& system, const SparseLinearModel& model,
                                       const ModalResult& result) {
  return tree_distribution(system, model.q, VectorX(), result);
}

}  // namespace modal
