// Equilibria of large scenes (modal/equilibrium.hpp): no dense n×n matrix.
//
// Used by find_equilibrium when the system has more than
// large_system_coordinates coordinates and is a conservative tree (no follower
// loads, constraints or kinematic map):
//   1. Newton's method from the start with the exact sparse Hessian ∇∇V,
//      factored by CHOLMOD (supernodal LLᵀ; an LDLᵀ when ∇∇V is not positive
//      definite), with backtracking on ‖∇V‖: the equilibrium nearest the start,
//      whatever its stability, in a few factorizations when the start is in
//      Newton's basin (a pre-tensioned net sagging under gravity is);
//   2. if that stalls, NLopt LD_LBFGS minimizes V from the start with the exact
//      gradient ∇V (O(elements) per evaluation) until the relative residual
//      ‖∇V‖/force_scale falls below 1e-6 (at most 2000 evaluations), and
//      Newton polishes from there.
// Cost per Newton step: one sparse assembly (O(elements)) and one sparse
// factorization (for a 2-D net of n coordinates with nested-dissection
// ordering, O(n^1.5) flops and O(n log n) memory).
#include "equilibrium/problem.hpp"

#include <nlopt.hpp>

#include <Eigen/CholmodSupport>
#include <Eigen/SparseCholesky>

#include <cmath>
#include <exception>
#include <limits>

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

// Newton step d with ∇∇V d = −r: supernodal Cholesky, or LDLᵀ when ∇∇V is not
// positive definite (a saddle, or far from the minimum). Empty when both fail.
VectorX sparse_newton_step(const SparseMatrix& H, const VectorX& r) {
  Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower> llt(H);
  if (llt.info() == Eigen::Success) {
    VectorX d = -llt.solve(r);
    if (d.allFinite()) return d;
  }
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower> ldlt(H);
  if (ldlt.info() == Eigen::Success) {
    VectorX d = -ldlt.solve(r);
    if (d.allFinite()) return d;
  }
  return {};
}

}  // namespace

bool is_large_system(const System& s) {
  return s.size() > large_system_coordinates && !s.is_map() && !s.has_constraints() && !s.has_follower_loads();
}

Equilibrium find_large_equilibrium(const System& s, const VectorX& start, const EquilibriumOptions& options) {
  Workspace w(s);
  const int n = s.size();
  VectorX q = canonical_coordinates(s, start);
  auto relative = [&](const VectorX& x, double rnorm) {
    const double scale = force_scale(s, w, x);
    return scale > 0 ? rnorm / scale : rnorm;
  };

  // Newton with the sparse Hessian from x; the best point seen goes to `best`.
  Equilibrium best;
  best.residual = std::numeric_limits<double>::infinity();
  auto newton = [&](VectorX q) {
    VectorX r = potential_gradient(s, w, q);
    for (int it = 0; it <= options.max_iterations; ++it) {
      const double rnorm = r.norm();
      const double rel = relative(q, rnorm);
      if (rel < best.residual) {
        best.q = q;
        best.residual = rel;
        best.residual_norm = rnorm;
        best.iterations = it;
      }
      if (rel <= options.tolerance || rnorm == 0) return;
      const VectorX d = sparse_newton_step(sparse_potential_hessian(s, w, q), r);
      if (d.size() == 0) return;
      bool accepted = false;
      for (double t = 1; t > 1e-10; t *= 0.5) {
        const VectorX qt = q + t * d;
        VectorX rt;
        try {
          rt = potential_gradient(s, w, qt);
        } catch (const NumericalError&) {
          continue;
        }
        if (rt.allFinite() && rt.norm() < (1 - 1e-4 * t) * rnorm) {
          q = canonical_coordinates(s, qt);
          r = rt;
          accepted = true;
          break;
        }
      }
      if (!accepted) return;  // at the rounding floor, or stalled
    }
  };
  // Accepted at the tolerance or at the rounding floor of a large sum, 10 ε √n relative.
  const double floor = 10 * std::numeric_limits<double>::epsilon() * std::sqrt(static_cast<double>(n));
  const double accept = std::max(options.tolerance, floor);
  newton(q);

  if (!(best.residual <= accept)) {  // 2. L-BFGS on V down to a relative residual of 1e-6, then Newton.
    Lbfgs o;
    o.s = &s;
    o.w = &w;
    const double r0 = potential_gradient(s, w, q).norm();
    const double rel0 = relative(q, r0);
    o.target = rel0 > 0 ? 1e-6 * r0 / rel0 : 0.0;
    nlopt::opt opt(nlopt::LD_LBFGS, static_cast<unsigned>(n));
    opt.set_min_objective(lbfgs_objective, &o);
    opt.set_maxeval(2000);
    opt.set_ftol_rel(1e-15);
    std::vector<double> x(q.data(), q.data() + n);
    double f = 0;
    try {
      opt.optimize(x, f);
    } catch (const std::exception&) {
      // forced_stop at the target, or roundoff: Newton takes over from x.
    }
    const VectorX reached = Eigen::Map<const VectorX>(x.data(), n);
    if (reached.allFinite()) newton(reached);
  }
  if (!(best.residual <= accept)) {
    Problem p(s);
    throw NumericalError(no_equilibrium_message(p, best, 1) +
                         " (large-scene search: L-BFGS, then Newton with the sparse Hessian)");
  }
  best.potential = potential(s, w, best.q);
  return best;
}

}  // namespace modal::equilibrium_detail
