// Private to lib/equilibrium: the residual r(q) = ∇V(q) − Q(q, 0), its
// Jacobian J = ∂r/∂q, the relative residual, and the Newton step — the pieces
// shared by the local solvers (equilibrium.cpp) and the multi-start search
// (search.cpp).
#pragma once

#include "modal/equilibrium.hpp"

#include <string>

namespace modal::equilibrium_detail {

// One System with its scratch memory. Every evaluation of the residual and of
// its Jacobian goes through here, so a non-conservative term Q(q, 0) (a
// follower load, say) is added in exactly one place: add_forces_at_rest().
class Problem {
 public:
  explicit Problem(const System& s) : s_(s), w_(s) {}

  const System& system() const { return s_; }
  int size() const { return s_.size(); }

  // r(q) = ∇V(q) − Q(q, 0). The reference lives until the next call.
  const VectorX& residual(const VectorX& q);
  // J(q) = ∂r/∂q = ∇∇V − ∂Q/∂q at rest. The reference lives until the next call.
  const MatrixX& jacobian(const VectorX& q);
  // True while J is symmetric (no circulatory forces).
  bool symmetric_jacobian() const { return !s_.has_follower_loads(); }

  double potential(const VectorX& q) { return modal::potential(s_, w_, q); }
  // False where V is not differentiable (modal::spring_with_meeting_ends).
  bool differentiable_at(const VectorX& q) { return !spring_with_meeting_ends(s_, w_, q); }

  // r made relative: modal::relative_residual(s, w, q, r) (‖r‖ against the
  // forces at 100 % strain, and its excess over their rounding against the
  // acting forces; each |r_k| likewise against coordinate k's own). The full scale is a sum of the
  // magnitudes of all force-producing elements, so it is 0 only when nothing
  // produces a force; then V is constant, r ≡ 0, and we fall back to the
  // absolute measure ‖r‖ / (‖J‖_F · 1 + DBL_MIN) (the force a unit displacement
  // would produce), which is 0 for r = 0.
  double relative_residual(const VectorX& q, const VectorX& r);

  // A stiffness scale per coordinate (n, units of J_kk: N·m/rad, N/m):
  // coordinate_force_scales(q).stiffness, a coordinate without one taking the
  // largest. Independent of the rounding in J (a zero mode's J_kk is rounding
  // of its own elements' scale, not 1). Empty for maps and where no element
  // has a stiffness.
  VectorX stiffness_scales(const VectorX& q);
  // Weights of the residual's entries (n): 1 / coordinate k's full force
  // scale (coordinate_force_scales(q).full, a coordinate without one taking
  // the largest), so that ‖W r‖ sees every coordinate's unbalanced force
  // against its own forces. Ones for maps. Unweighted, a graded chain's light
  // link (forces 1e-14 of the heavy one's) was invisible to the line search
  // and to Levenberg–Marquardt's JᵀJ, and it ended at 180° from 0.2 rad.
  VectorX residual_weights(const VectorX& q);

  int residual_evaluations = 0;
  int jacobian_evaluations = 0;

 private:
  // coordinate_force_scales(s, w, q), kept for the last q asked: a Newton
  // iteration asks three times at one point (the relative residual, the
  // weights and the stiffness scales).
  const CoordinateForceScales& coordinate_scales(const VectorX& q);

  const System& s_;
  Workspace w_;
  VectorX r_;
  MatrixX j_;
  VectorX scales_q_;
  CoordinateForceScales scales_;
};

// Least-squares solution d of J d = −r of least norm in S⁻¹d, S =
// diag(stiffness)^-½ (J may be singular: zero modes of ignorable
// coordinates), solved in the scaled form S J S, whose cutoffs are thereby
// relative to each coordinate's own stiffness (Problem::stiffness_scales;
// empty: unscaled). Large, well-conditioned positive definite S J S:
// Cholesky. Otherwise a symmetric eigen-decomposition with eigenvalues below
// a relative cutoff discarded (or a complete orthogonal decomposition when J
// is not symmetric).
VectorX newton_step(const MatrixX& j, const VectorX& r, bool symmetric, const VectorX& stiffness);

// Result of a Newton polish: success, or the best point reached (for messages).
struct Polished {
  bool converged = false;
  Equilibrium best;  // canonical q with the smallest residual seen
};
Polished polish(Problem& p, const VectorX& q0, const EquilibriumOptions& options);

// Multi-start search: every distinct polished equilibrium (unsorted), and the
// best non-equilibrium point if none was found.
struct SearchResult {
  std::vector<Equilibrium> found;
  Equilibrium best_failure;  // smallest relative residual among failed starts
  bool have_failure = false;
  int starts = 0;
};
SearchResult search(Problem& p, const EquilibriumOptions& options);

// The deterministic starts of the multi-start search (search.cpp header).
// The Halton starts to make: options.starts, or the default for the system.
int halton_starts(const System& s, const EquilibriumOptions& options);
std::vector<VectorX> starting_points(const System& s, int halton_count);

// Constrained systems (constrained.cpp): the nearest equilibrium from a
// start, the multi-start search, and one Newton polish on the KKT system.
Equilibrium find_constrained_equilibrium(const System& s, const VectorX& start, const EquilibriumOptions& options);
std::vector<Equilibrium> find_constrained_equilibria(const System& s, const EquilibriumOptions& options);
std::optional<Equilibrium> polish_constrained(const System& s, const VectorX& q, const EquilibriumOptions& options);

// Large scenes (large.cpp): more than large_system_coordinates coordinates, a
// conservative tree; Newton with the sparse Hessian (L-BFGS when it stalls).
bool is_large_system(const System& s);
// The sparse solver also serves smaller conservative trees whose ∇∇V at the
// start is sparse (at most 5 % nonzero) from this many coordinates on: the
// dense local search's O(n³) steps (eigen-decompositions where ∇∇V is
// singular) took 24 s on a slack 20×20 net of 972 coordinates.
inline constexpr int sparse_equilibrium_coordinates = 500;
bool prefers_sparse_equilibrium(const System& s, const VectorX& start);
Equilibrium find_large_equilibrium(const System& s, const VectorX& start, const EquilibriumOptions& options);

// Keeps the candidate with the smaller residual among those closer than
// configuration_distance 1e-6 (angles modulo 2π), one member of each
// continuous family (the one nearest the initial configuration; polishes
// with `options` test curved families), then sorts by potential and
// coordinates.
void deduplicate_and_sort(const System& s, const EquilibriumOptions& options, std::vector<Equilibrium>& list);

// "no equilibrium found: …" naming the coordinates that carry the unbalanced
// generalized force at the best point reached.
std::string no_equilibrium_message(Problem& p, const Equilibrium& best, int starts);

}  // namespace modal::equilibrium_detail
