// modal/linearize.hpp — the linear model about an equilibrium q̄:
//
//   M δq̈ + (D + G) δq̇ + K δq = 0,   M = M(q̄), K = ∇∇V(q̄), D from dampers, G gyroscopic
//
//   modal::LinearModel lin = modal::linearize(sys, equilibrium.q);
//
// Throws NotAnEquilibrium (with the residual, in words) when q̄ is not one.
//
// Constraints c(q) = 0 (docs/design.md, "The linear model"): q̄ must satisfy them, and the
// multipliers s are the least-squares solution of ∇V − Q = ∇c_I s_I on the
// independent equations I (constraint_basis; redundant equations get s = 0
// and are listed). With N an orthonormal basis of the null space of ∇c_Iᵀ
// (n×n_r, n_r = n − rank) the model is the projection onto the manifold,
//   M = NᵀM(q̄)N,  K = Nᵀ(∇∇V − ∂Q/∂q − Σ sᵢ∇∇cᵢ)N,  D = NᵀDN,  G = NᵀGN,
// (the multiplier term gives a particle held on a circle all its stiffness),
// and a mode φ of it moves the coordinates by N φ.
#pragma once

#include "modal/core.hpp"

#include <optional>
#include <string>
#include <vector>

namespace modal {

class NotAnEquilibrium : public NumericalError {
 public:
  using NumericalError::NumericalError;
};

// The force one constraint exerts at the equilibrium (its multipliers).
struct ConstraintForce {
  std::string name;        // the constraint's name
  Constraint::Type type = Constraint::Type::point;
  // point: the force on end a (world components, N; b gets its opposite);
  // distance: s (1 entry, N), positive pushing the ends apart (−s is the tension).
  VectorX multipliers;
  bool redundant = false;  // some of its equations were redundant (their share is not determined: set 0)
};

struct LinearModel {
  VectorX q;                             // the equilibrium, n
  std::vector<std::string> coordinates;  // names, n
  MatrixX M;                             // mass, n×n, symmetric
  MatrixX K;                             // stiffness, n×n (symmetric unless circulatory)
  // Empty (0×0) where the scene has none (has_damping, has_gyroscopic false):
  // two zero n×n matrices were 16 MB of fresh pages on a 1000-link chain.
  MatrixX D;                             // damping, n×n, symmetric PSD
  MatrixX G;                             // gyroscopic, n×n, skew
  bool has_damping = false;
  bool has_gyroscopic = false;
  bool circulatory = false;              // K not symmetric (follower loads)
  double residual = 0;                   // relative equilibrium residual at q
  // An estimate of the absolute error of K's entries (dof×dof, units of K),
  // for the eigenvalues' error estimates: 4ε × Σ|terms| of each entry (see
  // potential_hessian_magnitude: where terms cancel, the error is not that of
  // the small result), plus, for K from differences, their measured error
  // from K at h, 2h and 4h (rest_force_jacobian). Empty: 4ε|K| is taken (a model
  // written by hand).
  MatrixX K_error;
  // The part of K_error that is systematic (dof×dof; empty when there is
  // none): the measured error of differences, and the change of K between q
  // and the equilibrium nearest it when q is one only to a loose tolerance
  // (equilibrium_stiffness_change). Unlike rounding it is smooth from entry to
  // entry, so the eigenvalues' estimates add it without cancellation.
  MatrixX K_systematic_error;
  // sparse_rounding_form at q (dof×dof, positive semidefinite) where K is
  // ∇∇V itself (less the multiplier term, whose rounding it includes, and
  // projected as NᵀFN with constraints) and the scene has springs; empty
  // otherwise (follower loads, differences, maps). The symmetric
  // solver decides the modes' kinds with its 4ε φᵀFφ instead of K_error's
  // entrywise worst case, which leaves out the positions' rounding.
  SparseMatrix K_rounding_form;
  // spring_rounding at q (F kept spring by spring) where K_rounding_form is
  // given and the scene has neither constraints nor damping (a damped scene
  // takes the first-order solver, which does not use it); empty otherwise. The symmetric
  // solver's estimates take the springs' rounding at its typical size with
  // it (detail::spring_by_spring).
  SpringRounding K_spring_rounding;
  // The measured error of G (dof×dof) when it comes from differences
  // (gyroscopic_matrix with an error), systematic like the above; empty when
  // G is exact or absent. The first-order solver adds its effect, with that
  // of K_systematic_error, to the estimates.
  MatrixX G_error;
  DerivativeMethod derivatives = DerivativeMethod::exact;  // how K and G were obtained
  // Steady motion: rates and momenta of ignorable coordinates (maps analyzed
  // through Routh's reduction); empty otherwise.
  std::vector<SteadyRate> steady;
  // Constraints: M, K, D, G above are the projections onto the constraint
  // manifold (n_r×n_r) and `basis` is N (n×n_r, orthonormal columns); a mode
  // shape φ (n_r) moves the coordinates by N φ. Empty without constraints.
  MatrixX basis;
  std::vector<ConstraintForce> constraint_forces;  // one per constraint, in scene order
  std::vector<std::string> redundant_equations;    // names of the redundant constraint equations
  double constraint_violation = 0;                 // ‖c(q̄)‖, m
  // The natural inertia scale of each analyzed coordinate (dof; kg·m² or kg,
  // see modal::inertia_scale): an upper bound of M_ii. solve_modes equilibrates
  // the pencil by it (S = diag(s), s_i the power of two near 1/√scale_i), so
  // that a graded scene is not singular "relative to ‖M‖" while a coordinate
  // singularity (M_ii ≪ scale_i) still is. Constrained models: the bound
  // (Σ_i |N_ij| √scale_i)² of the reduced coordinate j (|M_ik| ≤ √(M_ii M_kk)).
  // Empty (kinematic maps, hand-made models): no scaling.
  VectorX inertia_scale;
  // Graded chains (docs/design.md, "Graded scenes"): where hinges about the
  // same world axis follow one another (and the scene is a tree with
  // potential forces only, no dampers, exact derivatives), the pencil
  // assembled again in their absolute angles θ (q = Tθ; modal::
  // absolute_angle_model), with K_magnitude turned into the rounding part of
  // K's error (4ε Σ|terms|) and `systematic` (empty or dof×dof) the above
  // K_systematic_error carried to θ as |T|ᵀ(·)|T|. solve_modes solves this
  // pencil and maps the shapes back to q (φ_q = T φ_θ). M and K above stay
  // the pencil in the user's coordinates. Empty otherwise.
  AbsoluteAngleModel absolute;
  MatrixX absolute_systematic_error;

  int size() const { return static_cast<int>(q.size()); }              // n, all coordinates
  int dof() const { return static_cast<int>(M.rows()); }               // degrees of freedom analyzed (n_r)
  bool constrained() const { return basis.rows() > 0; }
  // K φ = λ M φ describes the motion completely (no D, G, circulatory part).
  bool symmetric() const { return !has_damping && !has_gyroscopic && !circulatory; }
};

struct LinearizeOptions {
  double tolerance = 1e-8;  // largest relative residual accepted as an equilibrium
  // How K and G are differentiated (modal/core.hpp, DerivativeMethod); the
  // step factor of differences, 0: the method's default.
  DerivativeMethod derivatives = DerivativeMethod::exact;
  double step_factor = 0;
};

LinearModel linearize(const System& s, const VectorX& q, const LinearizeOptions& options = {});

// --- large scenes: the linear model assembled sparse ---------------------------
// K = ∇∇V(q̄) and M = M(q̄) as sparse matrices (n×n, both triangles; see
// sparse_potential_hessian), for the sparse eigen-solver (solve_sparse_modes):
// no dense n×n matrix is formed. Only for what K φ = λ M φ describes
// completely: see sparse_unsupported.
struct SparseLinearModel {
  VectorX q;                             // the equilibrium, n
  std::vector<std::string> coordinates;  // names, n
  SparseMatrix M;                        // mass, n×n
  SparseMatrix K;                        // stiffness, n×n
  // Σ|terms| of each entry of K (n×n, ≥ 0, K's pattern: as LinearModel::
  // K_error / 4ε without the systematic part): the size of K's rounding,
  // for SparseModalOptions::K_magnitude.
  SparseMatrix K_magnitude;
  // sparse_rounding_form at q (n×n, positive semidefinite; empty without
  // springs): for SparseModalOptions::K_rounding_form.
  SparseMatrix K_rounding_form;
  // spring_rounding at q (empty without springs): for SparseModalOptions::
  // K_spring_rounding.
  SpringRounding K_spring_rounding;
  double residual = 0;                   // relative equilibrium residual at q
  // |K(q + δq) − K(q)| for the Newton correction δq (see above); empty when
  // the residual is negligible. For the eigenvalues' error estimates.
  SparseMatrix K_systematic_error;
  // K(q + δq) − K(q), signed (see above): the loose equilibrium's change of K
  // for SparseModalOptions::K_equilibrium_shift; empty when the residual is
  // negligible. K_systematic_error is then left empty.
  SparseMatrix K_equilibrium_shift;
  VectorX inertia_scale;  // n, as LinearModel::inertia_scale; for SparseModalOptions::inertia_scale
  int size() const { return static_cast<int>(q.size()); }
};
// Why the sparse model cannot describe s (a map, constraints, follower loads,
// a rotating frame, dampers), in words; nullopt when it can.
std::optional<std::string> sparse_unsupported(const System& s);
// Throws std::invalid_argument when sparse_unsupported(s), NotAnEquilibrium
// as linearize().
SparseLinearModel linearize_sparse(const System& s, const VectorX& q, const LinearizeOptions& options = {});

// An equilibrium accepted at a loose tolerance is not the equilibrium, and K
// there differs from K at the equilibrium: with the residual force r at q and
// the Newton correction δq = −K⁻¹r, |K(q + δq) − K(q)| entry by entry. Zero
// (empty) when the relative residual is below negligible_equilibrium_residual
// (1e-14, the level a Newton polish reaches). The relative residual alone
// says little: a pre-tensioned net's force scale counts its springs at 100 %
// strain, and at 4e-12 its lowest λ was still 8.7e-9 off (results/tradeoff.md). Dense: least-squares δq where K is
// singular; sparse: a sparse LDLᵀ of K (skipped, with an empty result, when
// it fails). Both linearize functions add it to the model's systematic error.
inline constexpr double negligible_equilibrium_residual = 1e-14;
// The sparse path takes the correction only above this residual: its LDLᵀ of
// K can cost more than the eigen-solution (5 s for an 11 520-coordinate
// lattice, where the default equilibrium ends at 2e-13 and its effect on the
// eigenvalues was measured at 8e-15, results/tradeoff.md). Between the
// default equilibrium tolerance (1e-12) and this, `modal analyze` says in a
// note that the estimates leave it out.
inline constexpr double sparse_equilibrium_correction_residual = 1e-11;

}  // namespace modal
