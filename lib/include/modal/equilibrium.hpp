// modal/equilibrium.hpp — equilibria: ∇V(q) = Q(q, 0).
//
//   modal::Equilibrium e = modal::find_equilibrium(sys, sys.initial_configuration());
//   std::vector<modal::Equilibrium> all = modal::find_equilibria(sys, {.starts = 200});
//
// find_equilibrium returns the equilibrium nearest a start, whatever its
// stability (an inverted pendulum started near the top is found at the top).
// find_equilibria minimizes the residual ‖∇V − Q‖² with NLopt from many
// deterministic starts, Newton-polishes every candidate with the exact Hessian,
// drops those that do not reach the tolerance, and removes duplicates (angles
// modulo 2π; a continuous family of equilibria — configurations that differ
// only by a motion V cannot see, such as the spin of a point mass on a ball
// joint — is reported once, by its member nearest the initial configuration).
// Failures throw NumericalError with a message in words (for a
// scene that has no equilibrium, which generalized force cannot be balanced).
#pragma once

#include "modal/core.hpp"

#include <optional>
#include <vector>

namespace modal {

struct EquilibriumOptions {
  double tolerance = 1e-12;  // accepted relative residual ‖∇V − Q‖ / force_scale
  int starts = 64;           // deterministic starts of find_equilibria (besides the
                             // initial configuration and the {0, π} corners of hinges)
  int max_iterations = 100;  // per Newton polish
};

struct Equilibrium {
  VectorX q;                 // canonical coordinates (n)
  double potential = 0;      // V(q), J
  double residual = 0;       // relative residual ‖∇V − Q‖ / force_scale
  double residual_norm = 0;  // ‖∇V − Q‖, same units as ∇V
  int iterations = 0;        // Newton iterations of the final polish
};

// ∇V(q) − Q(q, 0), n.
VectorX equilibrium_residual(const System& s, Workspace& w, const VectorX& q);

// Newton's method with the exact Hessian and a line search on the residual
// from q; nullopt if the tolerance is not reached.
std::optional<Equilibrium> polish_equilibrium(const System& s, const VectorX& q,
                                              const EquilibriumOptions& options = {});

Equilibrium find_equilibrium(const System& s, const VectorX& start,
                             const EquilibriumOptions& options = {});

// Sorted by potential energy, then by coordinates.
std::vector<Equilibrium> find_equilibria(const System& s, const EquilibriumOptions& options = {});

}  // namespace modal
