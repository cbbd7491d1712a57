// modal/energy.hpp — where each mode's energy is, and how much of the mass a
// base translation excites (docs/design.md, "Energy distribution and
// participation").
//
//   modal::LinearModel lin = modal::linearize(sys, q);
//   modal::ModalResult r = modal::solve_modes(lin);
//   modal::EnergyDistribution e = modal::energy_distribution(sys, lin, r);
//   // e.modes[i].kinetic[j]: the share of mode i's kinetic energy carried by
//   // e.kinetic_elements[j]; e.modes[i].potential[t]: the share of its
//   // potential energy stored in e.potential_elements[t].
//
// For a mode shape φ (constrained scenes: the coordinates' motion N φ;
// complex shapes a + ib of first-order problems: the time average, aᵀXa + bᵀXb
// for each quadratic form X) the kinetic share of a body b is φᵀM_bφ / φᵀMφ
// and the potential share of a term t is φᵀK_tφ / φᵀKφ, with M = Σ M_b and
// K = Σ K_t element by element (element_quadratics in modal/core.hpp). The
// shares of a mode sum to 1; potential shares can be negative (gravity above
// its support, compressed springs' geometric stiffness), balanced by others
// above 1. Kinematic maps are not split by element: their shares are per
// coordinate, φ_i(Mφ)_i / φᵀMφ and φ_i(Kφ)_i / φᵀKφ (Routh-reduced maps: of the
// kept coordinates), which also sum to 1 and can be negative.
//
// Participation in base translation along a world axis d: with L_d = Σ_b m_b
// J_bᵀ d (J_b the Jacobian of body b's centre of mass), the participation
// factor Γ = φᵀL_d / φᵀMφ (1/…: for M-normalized modes, φᵀMφ = 1, simply
// φᵀL_d, in kg times the units of φ) and the effective modal mass (φᵀL_d)² /
// φᵀMφ (kg, independent of φ's scale). Over all modes the effective masses sum
// to L_dᵀM⁻¹L_d ≤ the movable mass m_d (modal/core.hpp, movable_mass), with
// equality exactly when rigid translation along d of the bodies that can move
// along d is a motion of the coordinates (free particles, a hanging chain of
// point masses horizontally); rotational inertia or armature that such a
// translation would turn, or a body that cannot follow, leaves a part out.
// Only real (symmetric) modes of body scenes; directions along which no mass
// moves are left out.
#pragma once

#include "modal/linearize.hpp"
#include "modal/modes.hpp"

#include <string>
#include <vector>

namespace modal {

// Base translation along one world axis.
struct ParticipationDirection {
  std::string name;          // "x", "y", "z"
  Vec3 direction = Vec3::Zero();
  double movable_mass = 0;   // m_d, kg (> 0: directions without moving mass are left out)
};

// One mode's shares and participation.
struct ModeEnergy {
  int mode = 0;                   // 1 = the lowest, as in ModalResult::modes
  // φᵀMφ and φᵀKφ from the elements' sums (the shares' denominators; the
  // units of M and K times those of φ²).
  double kinetic_total = 0;
  double potential_total = 0;
  std::vector<double> kinetic;    // per EnergyDistribution::kinetic_elements, sum 1
  // Per EnergyDistribution::potential_elements, sum 1; empty when they are
  // not defined: a zero mode (φᵀKφ = 0 within the eigenvalue's error).
  std::vector<double> potential;
  // Per EnergyDistribution::directions (empty without them): Γ, 1 per unit of
  // φ (kg·(units of φ) / (units of φᵀMφ)); the effective mass, kg; and the
  // effective masses of this mode and all below it divided by movable_mass.
  std::vector<double> participation_factor;
  std::vector<double> effective_mass;
  std::vector<double> cumulative_fraction;
};

struct EnergyDistribution {
  // Element: shares per body and per potential term; coordinate: per
  // coordinate (kinematic maps).
  enum class Split { element, coordinate };
  Split split = Split::element;
  std::vector<std::string> kinetic_elements;    // bodies (particles are bodies) or coordinates
  std::vector<std::string> potential_elements;  // potential_terms() or coordinates
  std::vector<ParticipationDirection> directions;
  std::vector<ModeEnergy> modes;                // one per mode of the result, in its order
};

// The distribution for every mode of `result` (solved from `model`, which
// gives q, the constraint basis and multipliers, and, for maps, M and K).
// Cost per mode O(bodies + springs + loads + constraints) (maps: the dense
// products Mφ, Kφ). Throws std::invalid_argument when the shapes do not fit.
EnergyDistribution energy_distribution(const System& system, const LinearModel& model, const ModalResult& result);
EnergyDistribution energy_distribution(const System& system, const SparseLinearModel& model, const ModalResult& result);

}  // namespace modal
