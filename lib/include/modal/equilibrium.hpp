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
//
// With constraints c(q) = 0 (System::constraints()) an equilibrium solves
// ∇V − Q = ∇c s, c(q) = 0 (Lagrange's equations of the first kind at rest)
// for q and the multipliers s. The starts are first brought onto the
// constraint manifold (Gauss–Newton, minimum-norm steps); find_equilibrium
// then runs Newton on the KKT system from there (the nearest equilibrium,
// whatever its stability), and the search minimizes V on the manifold with
// NLopt's SLSQP from every start; every candidate is polished by Newton's
// method on the full KKT system
//   [K − Σ sᵢ∇∇cᵢ   −A_Iᵀ] [δq]     [∇V − Q − A_Iᵀ s]
//   [A_I               0 ] [δs] = − [c_I           ]
// over the independent equations I (constraint_basis; redundant equations
// get s = 0 and must hold to the same tolerance). Constraints that no
// configuration near the starts satisfies throw NumericalError naming the
// equation violated most.
#pragma once

#include "modal/core.hpp"

#include <functional>
#include <string>
#include <optional>
#include <vector>

namespace modal {

// Above this many coordinates a conservative tree (no follower loads,
// constraints or map) is solved without dense matrices: find_equilibrium and
// polish_equilibrium run Newton with the sparse Hessian (CHOLMOD), falling
// back to NLopt's L-BFGS on V when Newton stalls; find_equilibria (the
// multi-start enumeration) refuses such systems.
inline constexpr int large_system_coordinates = 1000;

// How find_equilibrium treats a large scene (more than
// large_system_coordinates coordinates, conservative tree): newton = Newton
// from the start, with L-BFGS only if it stalls; lbfgs = L-BFGS on V to a
// relative residual of 1e-6 first, then Newton.
enum class LargeEquilibriumMethod { newton, lbfgs };

struct EquilibriumOptions {
  double tolerance = 1e-12;  // accepted relative residual of ‖∇V − Q (− ∇c s)‖ (modal::relative_residual)
                             // (and constraint violation ‖c‖ / length_scale)
  int starts = -1;           // deterministic starts of find_equilibria (besides the
                             // initial configuration and the {0, π} corners of hinges);
                             // -1: default_equilibrium_starts(system)
  int max_iterations = 100;  // per Newton polish
  LargeEquilibriumMethod large_method = LargeEquilibriumMethod::newton;
  // Bytes a sparse factorization of a large scene's Hessian may take (> 0,
  // e.g. a limit the user set); 0: what the machine has available. A factor
  // its symbolic analysis finds larger is refused before it is allocated
  // (OutOfMemory).
  double memory_limit = 0;
  // find_equilibria: called after each start with the starts done and their
  // number (long surveys show it on a terminal). find_equilibrium and
  // polish_equilibrium of a large scene (Newton with the sparse Hessian):
  // called with total = 100 and done the share of the way, in digits of the
  // relative residual, from the start's to the tolerance (never decreasing).
  // Empty: nothing is called.
  std::function<void(int done, int total)> progress = nullptr;
};

// The number of Halton starts find_equilibria makes unless told: 64 up to 30
// coordinates, then 64·(30/n)², at least 2. Each start costs a dense Newton
// search, O(n³) per step: about 8 s for the bundled 540-coordinate lattice,
// which makes 2 starts rather than spend minutes on 64.
int default_equilibrium_starts(const System& system);

// The damping μ of the damped Newton (Levenberg–Marquardt) steps on V that
// large scenes start with from degenerate configurations, here and in the
// distributed backend (docs/design.md, "Equilibria of large scenes"):
// Nielsen's rule. A step whose ratio ρ of V's actual to predicted decrease
// exceeds 10⁻⁴ is taken and μ shrinks by up to 3× as ρ nears 1 (below 10⁻¹⁰
// it becomes 0, Newton); after a refused step μ grows 2×, 4×, 8×, … in a row.
struct NielsenDamping {
  double mu = -1;  // dimensionless; negative until the first step sets it
  double growth = 2;
  static bool taken(double rho) { return rho > 1e-4; }
  void update(double rho);
};
// A limited joint (Body::lower, Body::upper) at a configuration. The limit is
// active when the coordinate is not strictly inside its range: the stop then
// pushes, and the system has no linear model there.
struct JointLimitState {
  int body = -1;             // index into System::bodies()
  int coordinate = -1;       // its coordinate, 0 ≤ coordinate < n
  double value = 0;          // the coordinate, rad or m
  double lower = 0, upper = 0;
  bool active() const { return !(value > lower && value < upper); }
};
// The state of every limited joint of `s` at q (n values), in body order;
// empty when no joint is limited.
std::vector<JointLimitState> joint_limits(const System& s, const VectorX& q);

struct Equilibrium {
  VectorX q;                 // canonical coordinates (n)
  double potential = 0;      // V(q), J
  double residual = 0;       // relative residual of ∇V − Q (modal::relative_residual(s, w, q, r))
  double residual_norm = 0;  // ‖∇V − Q‖, same units as ∇V
  int iterations = 0;        // Newton iterations of the final polish
  // Constraint multipliers s (m, N; see Constraint for their meaning as
  // forces); 0 for redundant equations. Empty without constraints.
  VectorX multipliers;
  double constraint_violation = 0;  // ‖c(q)‖, m
  // How the start was moved before Newton's iterations (`iterations`): a
  // large scene's solver, Levenberg–Marquardt steps, the multi-start search
  // (find_equilibrium); empty when Newton alone found it, and for the rows of
  // find_equilibria.
  std::string method;
  // Large scenes: the fill-reducing pivot order (order[k] = the k-th
  // coordinate) that CHOLMOD's analysis chose for ∇∇V. K − σM has the same
  // pattern, so SparseModalOptions::fill_reducing_order can reuse it and
  // spare the modes stage its ordering (about 3 s at 10⁶ coordinates).
  // Empty otherwise.
  std::vector<int> fill_reducing_order;
  // The scene's limited joints at q (joint_limits), filled by every function
  // here that returns an Equilibrium; an active one means this is not an
  // equilibrium modal can linearize (the pipeline refuses it).
  std::vector<JointLimitState> limits;
};

// Why an equilibrium of `s` with an active joint limit has no linear model,
// in words naming the first such joint (its value and range); "" when no
// limit is active.
std::string active_limit(const System& s, const Equilibrium& e);

// ∇V(q) − Q(q, 0), n (without the constraint forces ∇c s).
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
