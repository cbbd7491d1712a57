// Equilibria of large scenes (modal/equilibrium.hpp): no dense n×n matrix.
//
// Used by find_equilibrium when the system has more than
// large_system_coordinates coordinates and is a conservative tree (no follower
// loads, constraints or kinematic map). Two strategies
// (EquilibriumOptions::large_method):
//   newton (default): Newton's method from the start with the exact sparse
//      Hessian ∇∇V and backtracking until ‖∇V‖ or (along a descent direction)
//      V decreases enough (the equilibrium nearest the start, whatever its
//      stability); if it stalls, the lbfgs strategy;
//   lbfgs: NLopt LD_LBFGS minimizes V from the start with the exact gradient
//      ∇V (O(elements) per evaluation) until ‖∇V‖ has fallen to 1e-4 of its
//      starting value (at most 2000 evaluations), and Newton polishes from
//      there.
// Newton steps are inexact (a truncated Newton method): ∇∇V d = −∇V is solved
// by conjugate gradients preconditioned with the Cholesky factor of an earlier
// Hessian, to a relative residual η = min(0.1, ‖∇V‖/‖∇V₀‖) (superlinear
// convergence as ∇V → 0); ∇∇V is factored afresh (CHOLMOD supernodal LLᵀ; a
// simplicial LDLᵀ when ∇∇V is not positive definite) at the first step, when
// the conjugate gradients break down (∇∇V not positive definite along a
// direction) or need more than 40 iterations, after a step that needed
// more than 15 (a factorization costs about 15 iterations' worth), and when
// the rate of the last converged run predicts more than 15 for the forcing
// asked (the last steps, where η is small). A factorization costs
// O(n^1.5) flops for a 2-D net of n coordinates with nested-dissection
// ordering (tens of solves' worth), so reusing it is what keeps the
// equilibrium of a 10⁶-coordinate net within seconds per step. The symbolic
// analysis is done once (and kept after a failed factorization). Where a
// row of ∇∇V vanishes (a coordinate with no stiffness, as a slack net's
// out-of-plane coordinates at its flat start) no Newton step is attempted:
// the damped method below starts at once.
#include "equilibrium/problem.hpp"
#include "core/cholmod_factor.hpp"
#include "core/sparse_product.hpp"

#include <nlopt.hpp>

#include <Eigen/CholmodSupport>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <exception>
#include <iomanip>
#include <limits>
#include <new>
#include <optional>
#include <sstream>
#include <vector>

namespace modal {

void NielsenDamping::update(double rho) {
  if (taken(rho)) {
    const double t = 2 * rho - 1;
    mu *= std::max(1.0 / 3.0, 1 - t * t * t);
    if (mu < 1e-10) mu = 0;
    growth = 2;
  } else {
    mu = std::max(growth * mu, 1e-10);
    growth *= 2;
  }
}

}  // namespace modal

namespace modal::equilibrium_detail {
namespace {

struct Lbfgs {
  const System* s = nullptr;
  Workspace* w = nullptr;
  VectorX q;
  double target = 0;  // stop when ‖∇V‖ is below this
};

double lbfgs_objective(unsigned n, const double* x, double* grad, void* data) {
  auto* o = static_cast<Lbfgs*>(data);
  o->q = Eigen::Map<const VectorX>(x, static_cast<Eigen::Index>(n));
  try {
    const double v = potential(*o->s, *o->w, o->q);
    if (grad != nullptr) {
      const VectorX& g = potential_gradient(*o->s, *o->w, o->q);
      Eigen::Map<VectorX>(grad, static_cast<Eigen::Index>(n)) = g;
      if (g.norm() <= o->target) throw nlopt::forced_stop();
    }
    return std::isfinite(v) ? v : 1e300;
  } catch (const NumericalError&) {
    if (grad != nullptr) Eigen::Map<VectorX>(grad, static_cast<Eigen::Index>(n)).setZero();
    return 1e300;
  }
}

// CHOLMOD's supernodal Cholesky factor, with the pivot order its analysis
// chose. A matrix that is not positive definite is an answer here (the damped
// method then shifts it).
using SupernodalLlt = detail::CholmodAccess<Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower>>;

// Newton steps d with ∇∇V d = −r (see the header comment), with counters for
// the report.
class NewtonSteps {
 public:
  int factorizations = 0, cg_iterations = 0;
  // No Newton step where ∇∇V is not positive definite (set once damped
  // steps have run: there an indefinite ∇∇V sends the caller back to them).
  bool definite_only = false;

  void set_memory_limit(double bytes) { llt_.memory_limit = bytes; }

  // −A⁻¹ r by a fresh supernodal Cholesky factorization of A (the symbolic
  // analysis kept while the pattern stays); empty when A is not positive
  // definite. The factor is kept as the preconditioner of later steps.
  // `hessian`: A is ∇∇V itself (not a damped step's H⁺ + μhD).
  VectorX solve_positive(const SparseMatrix& A, const VectorX& r, bool hessian = true) {
    refactor_ = false;
    have_factor_ = false;
    shifted_ = !hessian;
    if (!same_pattern(A)) {
      llt_.analyzePattern(A);
      outer_.assign(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1);
      inner_.assign(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
    }
    ++factorizations;
    llt_.factorize(A);
    rate_ = 0;
    if (llt_.out_of_memory()) throw std::bad_alloc();  // the program's out-of-memory report, not an indefinite ∇∇V
    if (llt_.info() != Eigen::Success) return {};
    VectorX d = -solve(r);
    if (!d.allFinite()) return {};
    have_factor_ = true;
    return d;
  }

  // −A⁻¹ r by conjugate gradients preconditioned with the kept factor (of an
  // earlier A), to a relative residual of 0.1 within 12 iterations; empty when
  // no factor is kept or they do not reach it.
  VectorX solve_kept(const SparseMatrix& A, const VectorX& r) {
    if (!have_factor_) return {};
    return preconditioned_cg(A, r, 0.1, 12);
  }

  // Called as Newton takes over from the damped steps: a kept factor of
  // their matrix H⁺ + μhD is dropped, so that Newton's first step factors
  // ∇∇V, which its later steps then reuse. The damped matrix preconditions
  // ∇∇V poorly (10–12 CG iterations per Newton step on the slack nets,
  // 30–35 in all, about twice a factorization's cost); a factor of ∇∇V
  // near the solution needs 2–3.
  void renew() {
    if (shifted_) refactor_ = true;
  }

  // The pivot order of the last symbolic analysis of ∇∇V (empty: none).
  std::vector<int> ordering() const { return llt_.ordering(); }

  // Empty when no step can be computed (both factorizations fail, or a
  // coordinate has no stiffness at all).
  VectorX step(const SparseMatrix& H, const VectorX& r, double forcing) {
    if (has_vanishing_row(H)) return {};
    if (have_factor_ && !refactor_ && !(predicted_iterations(forcing) > aged_after)) {
      if (VectorX d = preconditioned_cg(H, r, forcing); d.size() > 0) return d;
    }
    return exact(H, r);
  }

 private:
  VectorX exact(const SparseMatrix& H, const VectorX& r) {
    if (VectorX d = solve_positive(H, r); d.size() > 0) return d;
    if (definite_only) return {};
    Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower> ldlt(H);
    if (ldlt.info() == Eigen::Success) {
      VectorX d = -ldlt.solve(r);
      if (d.allFinite()) return d;
    }
    return {};
  }

  // Conjugate gradients on H d = −r from d = 0, preconditioned by the kept
  // factor, to ‖H d + r‖ ≤ forcing·‖r‖; empty on breakdown or after
  // `limit` iterations.
  VectorX preconditioned_cg(const SparseMatrix& H, const VectorX& r, double forcing, int limit = 40) {
    const double target = forcing * r.norm();
    VectorX d = VectorX::Zero(r.size());
    VectorX res = -r;
    VectorX z = solve(res);
    VectorX p = z;
    double rz = res.dot(z);
    double best = 1;  // the smallest ‖H d + r‖/‖r‖ so far
    for (int it = 1; it <= limit; ++it) {
      const VectorX Hp = detail::symmetric_product(H, p);  // H holds both triangles
      const double curvature = p.dot(Hp);
      if (!(curvature > 0) || !std::isfinite(rz)) break;  // not positive definite along p
      const double alpha = rz / curvature;
      d += alpha * p;
      res -= alpha * Hp;
      ++cg_iterations;
      if (res.norm() <= target) {
        if (it > aged_after) refactor_ = true;  // the kept factor has aged
        if (const double reached = res.norm() / r.norm(); reached > 0) rate_ = std::pow(reached, 1.0 / it);
        return d;
      }
      // A run that stagnates is given up early: from the 4th iteration on,
      // when the best residual so far, at the geometric rate it implies,
      // would need more than twice the limit. A factor of an earlier, far
      // different matrix (μ fell 100× since) leaves the residual near 1 for
      // all 12 iterations of a damped step's run, and each costs a solve
      // (0.24 s at 10⁶ coordinates); the runs that converge in these scenes
      // have their best residual below 0.55 by the 4th.
      best = std::min(best, res.norm() / r.norm());
      if (it >= 4 && !(best < 1 && it * std::log(forcing) / std::log(best) <= 2.0 * limit)) break;
      z = solve(res);
      const double rz_next = res.dot(z);
      p = z + (rz_next / rz) * p;
      rz = rz_next;
    }
    return {};
  }

  // A⁻¹r with the kept factor of A: in two parts where it is large
  // (solve_in_parts), else by CHOLMOD.
  VectorX solve(const VectorX& r) {
    VectorX x(r.size());
    if (llt_.solve_in_parts(r.data(), x.data())) return x;
    return llt_.solve(r);
  }

  // True when some row of H vanishes to rounding against the largest
  // diagonal entry: H is singular along that coordinate (a slack net's
  // out-of-plane coordinates at the flat start), so no factorization can give
  // a Newton step, and trying both (a failing LLᵀ, then a simplicial LDLᵀ: 15 s
  // at 10⁶ coordinates) only delays the damped method.
  static bool has_vanishing_row(const SparseMatrix& H) {
    const double scale = H.diagonal().cwiseAbs().maxCoeff();
    if (!(scale > 0)) return true;
    VectorX row = VectorX::Zero(H.rows());
    for (Eigen::Index j = 0; j < H.outerSize(); ++j) {
      for (SparseMatrix::InnerIterator it(H, j); it; ++it) row(it.row()) = std::max(row(it.row()), std::abs(it.value()));
    }
    return row.minCoeff() <= 64 * std::numeric_limits<double>::epsilon() * scale;
  }

  bool same_pattern(const SparseMatrix& H) const {
    return !outer_.empty() && H.isCompressed() && outer_.size() == static_cast<std::size_t>(H.outerSize() + 1) &&
           inner_.size() == static_cast<std::size_t>(H.nonZeros()) &&
           std::equal(outer_.begin(), outer_.end(), H.outerIndexPtr()) &&
           std::equal(inner_.begin(), inner_.end(), H.innerIndexPtr());
  }

  // The conjugate gradients' iterations from which a fresh factorization is
  // cheaper: one costs about 15 of them (a solve with the factor and a
  // product with ∇∇V each) on 2-D nets, measured 14 at 10⁵ and 20 at 10⁶
  // coordinates (the factorization's O(n^1.5) flops run at BLAS-3 rates, the
  // solves' O(n log n) at memory speed).
  static constexpr int aged_after = 15;

  // The iterations predicted to reach ‖H d + r‖ ≤ forcing·‖r‖ with the kept
  // factor, at the rate (residual reduction per iteration) of its last
  // converged run; 0 when none has converged since the factorization.
  double predicted_iterations(double forcing) const {
    if (!(rate_ > 0 && rate_ < 1) || !(forcing > 0 && forcing < 1)) return 0;
    return std::log(forcing) / std::log(rate_);
  }

  SupernodalLlt llt_;
  std::vector<SparseMatrix::StorageIndex> outer_, inner_;
  bool have_factor_ = false, refactor_ = false, shifted_ = false;
  double rate_ = 0;
};

// D scaled to a mean diagonal of 1, every empty diagonal entry (a coordinate
// that no spring holds) set to 1 and a floor of 10⁻⁶ added to all, so that
// D is definite and μ h D has the size of μ h I on average.
SparseMatrix normalized_metric(SparseMatrix D) {
  const double mean = D.diagonal().mean();
  if (!(mean > 0) || !std::isfinite(mean)) {
    D.setIdentity();
    return D;
  }
  D /= mean;
  for (Eigen::Index k = 0; k < D.rows(); ++k) {
    double& dkk = D.coeffRef(k, k);
    dkk = (dkk > 0 ? dkk : 1.0) + 1e-6;
  }
  return D;
}

}  // namespace

bool is_large_system(const System& s) {
  return s.size() > large_system_coordinates && !s.is_map() && !s.has_constraints() && !s.has_follower_loads();
}

bool prefers_sparse_equilibrium(const System& s, const VectorX& start) {
  if (is_large_system(s)) return true;
  if (s.size() < sparse_equilibrium_coordinates || s.is_map() || s.has_constraints() || s.has_follower_loads()) return false;
  Workspace w(s);
  try {
    const SparseMatrix& H = sparse_potential_hessian(s, w, start);
    return static_cast<double>(H.nonZeros()) <= 0.05 * static_cast<double>(s.size()) * static_cast<double>(s.size());
  } catch (const NumericalError&) {
    return false;
  }
}

Equilibrium find_large_equilibrium(const System& s, const VectorX& start, const EquilibriumOptions& options) {
  Workspace w(s);
  const int n = s.size();
  // Deep trees (long chains): ∇∇V is dense, so every step goes through its
  // ordered form instead (TreePencil, O(bodies)): an exact Newton step by the
  // tree's LDLᵀ, the damped steps by that of ∇∇V + μhI.
  const bool matrix_free = !tree_pencil_unsupported(s) && coupled_pairs(s) > 64.0 * n;
  int tree_factorizations = 0;
  auto tree_solve = [&](const TreePencil& p, double shift, bool positive, const VectorX& r) -> VectorX {
    TreeFactor f;
    ++tree_factorizations;
    if (!f.factor(p, 1.0, 0.0, shift) || (positive && f.negative_pivots() > 0)) return {};
    VectorX d = -f.solve(r);
    if (!d.allFinite()) return {};
    return d;
  };
  VectorX q = canonical_coordinates(s, start);
  auto relative = [&](const VectorX& x, const VectorX& r) {
    return relative_residual_if_scaled(s, w, x, r).value_or(r.norm());
  };

  // Progress (EquilibriumOptions::progress): the digits of the relative
  // residual gained since the first point, out of those to the tolerance.
  double first_residual = -1;
  int shown = -1;
  auto progress = [&](double rel) {
    if (!options.progress || !(rel > 0) || !std::isfinite(rel)) return;
    if (first_residual < 0) first_residual = rel;
    const double digits = std::log(first_residual / options.tolerance);
    const int done = digits > 0 ? static_cast<int>(std::clamp(100 * std::log(first_residual / rel) / digits, 0.0, 100.0))
                                : 100;
    if (done > shown) {
      shown = done;
      options.progress(done, 100);
    }
  };

  // Newton with the sparse Hessian from x; the best point seen goes to `best`.
  Equilibrium best;
  best.residual = std::numeric_limits<double>::infinity();
  NewtonSteps steps;
  steps.set_memory_limit(options.memory_limit);
  int newton_iterations = 0;
  auto newton = [&](VectorX q) {
    steps.renew();
    VectorX r = potential_gradient(s, w, q);
    const double r0 = r.norm();
    // Once the residual is accepted, up to two more steps while each still
    // halves it: a kept factor makes them cheap, and the rounding level they
    // reach is what the eigenvalues' estimates assume. (A slack net accepted
    // at 1.2e-13 had its λ₁ 3e-9 off, 400 times its estimate; one more step
    // gave 3.7e-16 and the λ₁ of the equilibrium at the rounding level.)
    int polish = 0;
    double accepted_rel = 0;
    for (int it = 0; it <= options.max_iterations; ++it) {
      const double rnorm = r.norm();
      const double rel = relative(q, r);
      if (rel < best.residual) {
        best.q = q;
        best.residual = rel;
        best.residual_norm = rnorm;
        best.iterations = it;
      }
      progress(rel);
      if (rnorm == 0) return;
      if (rel <= options.tolerance) {
        if (polish == 2 || (polish > 0 && rel > 0.5 * accepted_rel)) return;
        ++polish;
        accepted_rel = rel;
      }
      const double forcing = std::min(0.1, r0 > 0 ? rnorm / r0 : 0.1);
      const VectorX d = matrix_free ? tree_solve(tree_pencil(s, w, q), 0.0, false, r)
                                    : steps.step(sparse_potential_hessian(s, w, q), r, forcing);
      if (d.size() == 0) return;
      ++newton_iterations;
      bool accepted = false;
      const double slope = r.dot(d);  // d V(q + t d)/dt at t = 0
      const double v = slope < 0 ? potential(s, w, q) : 0.0;
      for (double t = 1; t > 1e-10; t *= 0.5) {
        const VectorX qt = q + t * d;
        VectorX rt;
        try {
          rt = potential_gradient(s, w, qt);
        } catch (const NumericalError&) {
          continue;
        }
        // Sufficient decrease of ‖∇V‖, or (d a descent direction) Armijo's
        // condition on V: from a flat net the full Newton step is accepted
        // far more often than by the residual alone (5 steps instead of 7
        // for the benchmark nets).
        bool decrease = rt.allFinite() && rt.norm() < (1 - 1e-4 * t) * rnorm;
        if (!decrease && rt.allFinite() && slope < 0) {
          try {
            const double vt = potential(s, w, qt);
            decrease = std::isfinite(vt) && vt <= v + 1e-4 * t * slope;
          } catch (const NumericalError&) {
          }
        }
        if (decrease) {
          q = canonical_coordinates(s, qt);
          r = rt;
          accepted = true;
          break;
        }
      }
      if (!accepted) return;  // at the rounding floor, or stalled
    }
  };
  // Damped Newton (Levenberg–Marquardt on V) for degenerate and indefinite
  // starts, where ∇∇V is singular or indefinite (a slack net: springs at
  // their rest length have no transverse stiffness, so a flat start has
  // none out of its plane). Each step solves (H⁺ + μ h D) d = −∇V, where H⁺
  // is ∇∇V without the compressed springs' negative transverse stiffness
  // (sparse_convex_potential_hessian: definite with any μ > 0 on a scene of
  // particles and springs), D is the tension metric (sparse_tension_metric: the stiffness the scene
  // would have if every spring were tensioned to T/L = k, scaled to a mean
  // diagonal of 1) and h the mean diagonal of H⁺, so μ is dimensionless.
  // From a flat start D makes the first step a membrane's sag (a Poisson
  // solve: every spring stretched), where the identity made a uniform drop
  // of the interior that stretched only the springs at the boundary.
  // The system is solved by conjugate gradients preconditioned with the kept
  // factor of an earlier step when they converge within 12 iterations, else
  // by a fresh Cholesky factorization. A line search on V along d then sets
  // the length (doubling or halving while V falls, then a golden section):
  // V costs O(elements), a factorization far more, and along a sag V is
  // quartic, which the quadratic model cannot say. The ratio ρ of V's actual
  // decrease to the decrease the model predicts for that length decides: a
  // step with ρ > 10⁻⁴ is taken, μ follows the length (a step t d is about
  // what μ/t would give) and shrinks by up to 3× as ρ approaches 1
  // (Nielsen's rule; 9× when ρ is within 10 % of 1), a refused step or a
  // failed factorization grows it 2×, 4×, 8× … in a row. μ starts where a
  // gradient step moves the largest coordinate by 10⁻³ of the scene's length
  // scale (the line search corrects it); a step with ρ > 0.5 divides μ by
  // a further 100 (below). Once μ < 10⁻³, a plain Newton step
  // (μ = 0) is tried by the same conjugate gradients, which stop at the
  // first direction of negative curvature (a failing factorization would
  // cost a whole one: 5 s at 10⁶ coordinates); when that step is taken with
  // ρ > 0.5, the truncated Newton above finishes with its kept factor (if
  // not, two damped steps pass before the next trial). Counted in
  // `damped_steps`.
  // Measured on the slack nets (results/sparse_scaling.md): at 10⁵
  // coordinates 4 factorizations (10 with the identity metric and ∇∇V
  // itself), at 10⁶ 5 (12).
  int damped_steps = 0;
  auto damped = [&](VectorX q, bool handover_any) {
    VectorX r = potential_gradient(s, w, q);
    const double r0 = r.norm();
    double v = potential(s, w, q);
    SparseMatrix metric;  // the matrix path's shift: the tension metric, mean diagonal 1
    int newton_wait = 0;  // damped steps before the next trial of μ = 0
    NielsenDamping damping;  // μ set from the first Hessian
    double& mu = damping.mu;
    for (int it = 0; it < 200; ++it) {
      const double rnorm = r.norm();
      const double rel = relative(q, r);
      if (rel < best.residual) {
        best.q = q;
        best.residual = rel;
        best.residual_norm = rnorm;
        best.iterations = it;
      }
      progress(rel);
      if (rel <= options.tolerance || rnorm == 0) return q;
      // Newton's region (the model trusted with a small shift): a step with
      // μ = 0 is tried by CG on the kept factor, and once such a step is
      // taken with ρ > 0.5, the truncated Newton finishes with its kept
      // factor. (In the second round, the residual must also be down by 10³.)
      const bool newton_trial = mu >= 0 && mu < 1e-3 && (handover_any ? newton_wait == 0 : rnorm < 1e-3 * r0);
      if (newton_trial && !handover_any) return q;
      if (newton_wait > 0) --newton_wait;
      // The damped steps' matrix: ∇∇V with the compressed springs' negative
      // transverse stiffness left out (sparse_convex_potential_hessian), so
      // that μ shifts for trust, not for definiteness: a net whose springs
      // are compressed somewhere (the sag develops unevenly) had ∇∇V + μhD
      // indefinite for every μ below 10⁻³ long after V was within 10⁻⁵ of its
      // minimum. The Newton trial takes ∇∇V itself.
      std::optional<TreePencil> pencil;
      SparseMatrix H, C;
      if (matrix_free) {
        pencil = tree_pencil(s, w, q);
      } else {
        if (newton_trial) H = sparse_potential_hessian(s, w, q);
        C = sparse_convex_potential_hessian(s, w, q);
      }
      const VectorX diagonal = matrix_free ? tree_diagonal(*pencil, 1.0, 0.0) : VectorX(C.diagonal());
      const double h = std::max(diagonal.cwiseAbs().mean(), std::numeric_limits<double>::min());
      if (mu < 0) {
        // First step: the size at which a gradient step moves the largest
        // coordinate by 10⁻³ of the scene's length scale, unless H is
        // positive definite (then Newton is tried first, μ = 0).
        mu = std::max(r.cwiseAbs().maxCoeff() / (h * 1e-3 * s.length_scale()), 1e-10);
      }
      if (!matrix_free && metric.size() == 0) metric = normalized_metric(sparse_tension_metric(s, w, q));
      VectorX d;
      if (newton_trial) {
        d = matrix_free ? tree_solve(*pencil, 0.0, true, r) : steps.solve_kept(H, r);
        if (d.size() == 0) newton_wait = 2;  // CG met non-positive curvature or did not converge
      }
      const bool newton_step = d.size() > 0;
      if (d.size() == 0 && !matrix_free) d = steps.solve_kept(C + (mu * h) * metric, r);
      for (int tries = 0; tries < 60 && d.size() == 0; ++tries) {
        d = matrix_free ? tree_solve(*pencil, mu * h, true, r) : steps.solve_positive(C + (mu * h) * metric, r, false);
        if (d.size() == 0) mu = std::max(4 * mu, 1e-10);
      }
      if (d.size() == 0) return q;
      ++damped_steps;
      // The model's curvature along d: of the matrix the step was solved with.
      const VectorX Hd = matrix_free ? tree_product(*pencil, 1.0, 0.0, d) : detail::symmetric_product(newton_step ? H : C, d);
      // A line search on V along d: V costs O(elements), a factorization far
      // more. Where V still falls at twice the step (the model, quadratic in
      // d, underrates how far the shape d goes: from a slack start V is
      // quartic along a sag) the step doubles while it does; where V rose,
      // the step is halved until it falls and on while it still falls; then
      // a golden section between half and twice that length. μ then follows
      // the length taken (a step t d is about what the shift μ/t would have
      // given).
      auto energy_at = [&](double t) {
        try {
          const double e = potential(s, w, q + t * d);
          return std::isfinite(e) ? e : std::numeric_limits<double>::infinity();
        } catch (const NumericalError&) {
          return std::numeric_limits<double>::infinity();
        }
      };
      double t = 1, vt = energy_at(1);
      if (vt < v) {
        for (int k = 0; k < 40; ++k) {
          const double wider = energy_at(2 * t);
          if (!(wider < vt)) break;
          t *= 2;
          vt = wider;
        }
      } else {
        for (int k = 0; k < 40 && !(vt < v); ++k) vt = energy_at(t *= 0.5);
        for (int k = 0; k < 40 && vt < v; ++k) {  // and on while V still falls
          const double shorter = energy_at(0.5 * t);
          if (!(shorter < vt)) break;
          t *= 0.5;
          vt = shorter;
        }
      }
      if (t != 1 && vt < v) {
        // A golden-section search in log t between t/2 and 2t, where the
        // bracket above left the minimum along d.
        double lo = std::log(0.5 * t), hi = std::log(2 * t);
        const double g = 0.5 * (std::sqrt(5.0) - 1);
        double a = hi - g * (hi - lo), b = lo + g * (hi - lo);
        double va = energy_at(std::exp(a)), vb = energy_at(std::exp(b));
        for (int k = 0; k < 6; ++k) {
          if (va < vb) {
            hi = b;
            b = a;
            vb = va;
            a = hi - g * (hi - lo);
            va = energy_at(std::exp(a));
          } else {
            lo = a;
            a = b;
            va = vb;
            b = lo + g * (hi - lo);
            vb = energy_at(std::exp(b));
          }
        }
        if (va < vt && va <= vb) {
          t = std::exp(a);
          vt = va;
        } else if (vb < vt) {
          t = std::exp(b);
          vt = vb;
        }
      }
      const double predicted = -(t * r.dot(d) + 0.5 * t * t * d.dot(Hd));
      // Where V still fell beyond twice the model's minimum along d, the
      // model's decrease at that length is negative although V's is not: the
      // model underrated the step (H⁺ leaves out a compressed spring's
      // negative stiffness), which counts as a model that held (ρ = 1).
      const double rho = !std::isfinite(vt) ? -1
                         : predicted > 0    ? (v - vt) / predicted
                         : vt < v           ? 1.0
                                            : -1;
      VectorX rt;
      if (NielsenDamping::taken(rho)) {
        const VectorX qt = q + t * d;
        try {
          rt = potential_gradient(s, w, qt);
        } catch (const NumericalError&) {
        }
        if (rt.allFinite() && rt.size() == n) {
          q = canonical_coordinates(s, qt);
          r = rt;
          v = vt;
          mu /= t;
          if (newton_step && rho > 0.5) return q;
        }
      }
      // No decrease of V even at t = 2⁻⁴⁰ of the step: V is at its rounding
      // floor along d (its differences below ε|V|), where more damping
      // only shortens a step that V cannot judge; Newton, which judges by
      // ‖∇V‖, takes over.
      if (!(vt < v) && t < 1e-11) return q;
      damping.update(rho);
      if (std::abs(rho - 1) < 0.1) mu /= 3;  // the model holds to 10 %: towards Newton faster
      // A step the model predicted well moves μ two decades further towards
      // Newton: the line search is the safeguard (a step too long for the
      // smaller μ is shortened to t < 1, and μ/t restores the shift), where
      // Nielsen's rule, at most 3× per step, was made for steps taken whole.
      // Slack nets: 8 → 5 damped steps at 10⁵ coordinates, 10 → 6 at 10⁶.
      if (NielsenDamping::taken(rho) && rho > 0.5) mu /= 100;
    }
    return q;
  };

  // L-BFGS on V from x (see the header comment); returns where it stopped.
  int lbfgs_evaluations = 0;
  auto lbfgs = [&](const VectorX& from) {
    Lbfgs o;
    o.s = &s;
    o.w = &w;
    // Down to 1e-4 of the starting ‖∇V‖: into Newton's basin, not to the
    // tolerance. (A relative residual ‖∇V‖/force_scale is no guide here: a
    // pre-tensioned net starts far below 1e-6 of its spring force scale.)
    o.target = 1e-4 * potential_gradient(s, w, from).norm();
    nlopt::opt opt(nlopt::LD_LBFGS, static_cast<unsigned>(n));
    opt.set_min_objective(lbfgs_objective, &o);
    opt.set_maxeval(2000);
    opt.set_ftol_rel(1e-15);
    std::vector<double> x(from.data(), from.data() + n);
    double f = 0;
    try {
      opt.optimize(x, f);
    } catch (const std::exception&) {
      // forced_stop at the target, or roundoff: Newton takes over from x.
    }
    lbfgs_evaluations += opt.get_numevals();
    return VectorX(Eigen::Map<const VectorX>(x.data(), n));
  };

  // Accepted at the tolerance or at the rounding floor of a large sum, 10 ε √n relative.
  const double floor = 10 * std::numeric_limits<double>::epsilon() * std::sqrt(static_cast<double>(n));
  const double accept = std::max(options.tolerance, floor);
  bool lbfgs_done = false;
  if (options.large_method == LargeEquilibriumMethod::lbfgs) {
    const VectorX reached = lbfgs(q);
    lbfgs_done = true;
    if (reached.allFinite()) newton(reached);
  } else {
    newton(q);
  }
  if (!(best.residual <= accept) && !lbfgs_done) {  // Newton stalled: damped Newton from the start, then Newton
    // Newton after every damped round, also one that reached the tolerance:
    // its polishing steps take the residual to the rounding level (the
    // tolerance is relative to a force scale that counts every spring at
    // 100 % strain, far above a slack net's forces).
    const VectorX reached = damped(q, true);
    steps.definite_only = true;
    if (reached.allFinite()) newton(reached);
    // Newton with LDLᵀ steps where ∇∇V is indefinite, from the best point:
    // for a saddle that the damped steps (which lower V) came close to but
    // cannot settle on, and would leave. (A lattice without diagonals, its
    // columns compressed by their weight: the damped steps left ‖∇V‖ at
    // 2e-11 of the acting forces, and further damped steps buckled it.)
    auto newton_indefinite = [&] {
      if (best.residual <= accept || !best.q.allFinite() || best.q.size() != n) return;
      steps.definite_only = false;
      newton(best.q);
      steps.definite_only = true;
    };
    // Only near an equilibrium (Newton's region), where the damped steps
    // stopped: from further away, on wrinkled nets, such steps took a
    // factorization each for about 100 steps.
    if (best.residual <= 1e-8) newton_indefinite();
    for (int round = 0; round < 8 && !(best.residual <= accept) && best.q.allFinite() && best.q.size() == n; ++round) {
      // Handed over too early, or Newton met an indefinite ∇∇V (it takes
      // no LDLᵀ step after damped steps: on wrinkled nets that was a
      // factorization per step, for about 100 steps): damped again from the
      // best point, now until the residual has fallen 10³-fold as well;
      // rounds go on while each halves the best residual.
      const double before = best.residual;
      const VectorX again = damped(best.q, false);
      if (again.allFinite()) newton(again);
      if (!(best.residual < 0.5 * before)) break;
    }
    newton_indefinite();  // still not: from wherever the damped rounds left it
  }
  if (!(best.residual <= accept) && !lbfgs_done) {  // still not: L-BFGS from the start, then Newton
    const VectorX reached = lbfgs(q);
    if (reached.allFinite()) newton(reached);
  }
  if (!(best.residual <= accept)) {
    Problem p(s);
    throw NumericalError(no_equilibrium_message(p, best, 1) +
                         " (large-scene search: L-BFGS, then Newton with the sparse Hessian)");
  }
  // Where a compressed spring's ends meet, the balance is of a force without
  // direction (modal::spring_with_meeting_ends): no equilibrium, as on the
  // dense path, whose polish accepts no such point.
  if (const std::optional<MeetingEnds> meet = spring_with_meeting_ends(s, w, best.q)) {
    std::ostringstream m;
    m << std::setprecision(3) << "no equilibrium found: the large-scene search came to rest (relative residual "
      << best.residual << ") where " << describe_meeting_ends(s, *meet) << ", so it is no equilibrium";
    throw NumericalError(m.str());
  }
  best.potential = potential(s, w, best.q);
  best.limits = joint_limits(s, best.q);
  best.fill_reducing_order = steps.ordering();
  best.method = (lbfgs_evaluations > 0 ? "L-BFGS (" + std::to_string(lbfgs_evaluations) + " evaluations of V and ∇V), then " : std::string()) +
                (damped_steps > 0 ? "damped Newton (" + std::to_string(damped_steps) + " steps), then " : std::string()) +
                (matrix_free ? "Newton through the tree (matrix-free): " + std::to_string(newton_iterations) +
                                   " steps, " + std::to_string(tree_factorizations) + " O(n) factorizations"
                             : "truncated Newton with the sparse Hessian: " + std::to_string(newton_iterations) +
                                   " steps, " + std::to_string(steps.factorizations) + " factorizations, " +
                                   std::to_string(steps.cg_iterations) + " preconditioned CG iterations");
  return best;
}

}  // namespace modal::equilibrium_detail
