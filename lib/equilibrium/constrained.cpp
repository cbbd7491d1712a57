// Constrained equilibria: ∇V − Q = ∇c s, c(q) = 0 (modal/equilibrium.hpp).
//
// Three pieces, each a plain loop over exact derivatives:
//   project   Gauss–Newton on c(q) = 0 with minimum-norm steps (a complete
//             orthogonal decomposition of A, so redundant equations are
//             harmless), backtracking on ‖c‖: brings a start onto the manifold.
//   search    NLopt SLSQP: minimize V subject to c_I(q) = 0 (the independent
//             equations at the projected start), exact gradients ∇V and A_I.
//   newton    Newton on the KKT system of the modal/equilibrium.hpp header,
//             with the constraint rows scaled by α = force_scale/length_scale
//             (so both blocks are in newtons) and a backtracking line search on
//             the merit (‖∇V − Q − A_Iᵀs‖/force_scale)² + (‖c‖/length_scale)².
//             The independent set I is re-decided at every iterate by
//             constraint_basis(A); redundant equations carry s = 0.
// Cost per Newton step: ∇∇V and Σ sᵢ∇∇cᵢ (tree accumulation, O(n·depth)),
// A (O(m·depth)), and a dense (n + r)² decomposition.
#include "equilibrium/problem.hpp"

#include <nlopt.hpp>

#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <exception>
#include <iomanip>
#include <limits>
#include <sstream>

namespace modal::equilibrium_detail {
namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

// A constrained system with its scratch memory.
class Constrained {
 public:
  explicit Constrained(const System& s) : s_(s), w_(s), p_(s) {}
  const System& system() const { return s_; }
  Problem& problem() { return p_; }
  int n() const { return s_.size(); }
  int m() const { return s_.constraint_equations(); }
  double length() const { return s_.length_scale(); }

  // c(q), m; NaN where undefined (a distance constraint with coincident ends).
  VectorX values(const VectorX& q) {
    try {
      return constraint_values(s_, w_, q);
    } catch (const NumericalError&) {
      return VectorX::Constant(m(), nan);
    }
  }
  MatrixX jacobian(const VectorX& q) {
    try {
      return constraint_jacobian(s_, w_, q);
    } catch (const NumericalError&) {
      return MatrixX::Constant(m(), n(), nan);
    }
  }
  MatrixX multiplier_hessian(const VectorX& q, const VectorX& s) {
    try {
      return constraint_hessian(s_, w_, q, s);
    } catch (const NumericalError&) {
      return MatrixX::Constant(n(), n(), nan);
    }
  }
  ConstraintProjection project(const VectorX& q) { return project_onto_constraints(s_, w_, q); }
  double force_scale_at(const VectorX& q) { return usable(force_scales(s_, w_, q)).full; }
  // The unbalanced force's two relative residuals, from one computation of the
  // force scales: against the full scale (the merit's) and the one accepted
  // and reported (modal::relative_residual).
  struct Measures {
    double merit, accepted;
  };
  Measures measures(const VectorX& q, double force_norm) {
    const ForceScales scales = usable(force_scales(s_, w_, q));
    return {force_norm / scales.full, relative_residual(force_norm, scales)};
  }

 private:
  // A scene with no force scale (nothing acting, or not finite) is measured in newtons.
  static ForceScales usable(const ForceScales& scales) {
    return scales.full > 0 && std::isfinite(scales.full) ? scales : ForceScales{1.0, 1.0, 0.0};
  }
  const System& s_;
  Workspace w_;
  Problem p_;
};

struct Point {
  VectorX q, s;          // coordinates (n), multipliers (m; 0 on redundant equations)
  VectorX force;         // ∇V − Q − Aᵀ s, n
  VectorX c;             // constraint values, m
  MatrixX A;             // constraint Jacobian, m×n
  ConstraintBasis basis;
  double rel = nan, violation = nan, merit = nan;
  double measured = nan;  // the relative residual accepted and reported (Constrained::measures)
  bool finite() const { return std::isfinite(merit); }
};

// Evaluates everything at (q, s); with `fit`, s is replaced by the least-squares multipliers.
Point evaluate(Constrained& k, const VectorX& q, const VectorX& s, bool fit) {
  Point p;
  p.q = q;
  p.c = k.values(q);
  p.A = k.jacobian(q);
  const VectorX r = k.problem().residual(q);
  if (!p.c.allFinite() || !p.A.allFinite() || !r.allFinite()) return p;
  p.basis = constraint_basis(p.A);
  p.s = fit ? fit_multipliers(p.A, p.basis, r) : s;
  for (const int i : p.basis.redundant) p.s[i] = 0;
  p.force = r - p.A.transpose() * p.s;
  const Constrained::Measures measures = k.measures(q, p.force.norm());
  p.rel = measures.merit;
  p.measured = measures.accepted;
  p.violation = p.c.norm();
  const double cv = p.violation / k.length();
  p.merit = p.rel * p.rel + cv * cv;
  return p;
}

Equilibrium record(Constrained& k, const Point& p, int iterations) {
  Equilibrium e;
  e.q = p.q;
  e.limits = joint_limits(k.problem().system(), p.q);
  e.potential = k.problem().potential(p.q);
  e.residual = p.measured;
  e.residual_norm = p.force.norm();
  e.iterations = iterations;
  e.multipliers = p.s;
  e.constraint_violation = p.violation;
  return e;
}

struct Newton {
  bool converged = false;
  Equilibrium best;
  double best_merit = std::numeric_limits<double>::infinity();
};

// Newton on the KKT system from q (multipliers fitted by least squares first).
Newton newton(Constrained& k, const VectorX& q0, const EquilibriumOptions& options) {
  const System& s = k.system();
  Newton out;
  Point p = evaluate(k, canonical_coordinates(s, q0), VectorX(), true);
  int refinements = 0;
  for (int it = 0;; ++it) {
    if (!p.finite()) return out;
    const bool accepted = p.measured <= options.tolerance && p.violation <= options.tolerance * k.length();
    // Where a compressed spring's ends meet V is not differentiable: no
    // equilibrium (as in the unconstrained polish).
    if (accepted && !out.converged && !k.problem().differentiable_at(p.q)) return out;
    if (accepted && !out.converged) out.converged = true;
    if (p.merit < out.best_merit || (accepted && out.best.q.size() == 0)) {
      out.best_merit = p.merit;
      out.best = record(k, p, it);
    }
    if (out.converged && (refinements++ == 3 || p.merit == 0)) return out;
    if (!out.converged && it >= options.max_iterations) return out;

    const int n = s.size(), r = p.basis.rank;
    const double fs = k.force_scale_at(p.q), alpha = fs / k.length();
    const MatrixX H = k.problem().jacobian(p.q) - k.multiplier_hessian(p.q, p.s);
    if (!H.allFinite()) return out;
    MatrixX AI(r, n);
    VectorX cI(r);
    for (int i = 0; i < r; ++i) {
      AI.row(i) = p.A.row(p.basis.independent[static_cast<std::size_t>(i)]);
      cI[i] = p.c[p.basis.independent[static_cast<std::size_t>(i)]];
    }
    // Unknowns (δq, δσ) with δs = α δσ; rows: forces (N), α × constraints (N).
    MatrixX J = MatrixX::Zero(n + r, n + r);
    J.topLeftCorner(n, n) = H;
    J.topRightCorner(n, r) = -alpha * AI.transpose();
    J.bottomLeftCorner(r, n) = alpha * AI;
    VectorX rhs(n + r);
    rhs << -p.force, -alpha * cI;
    Eigen::CompleteOrthogonalDecomposition<MatrixX> cod(J);
    cod.setThreshold(1e3 * std::numeric_limits<double>::epsilon());
    const VectorX d = cod.solve(rhs);
    if (!d.allFinite()) return out;
    VectorX ds = VectorX::Zero(p.s.size());
    for (int i = 0; i < r; ++i) ds[p.basis.independent[static_cast<std::size_t>(i)]] = alpha * d[n + i];
    bool stepped = false;
    for (double t = 1; t > 1e-9; t *= 0.5) {
      Point trial = evaluate(k, canonical_coordinates(s, p.q + t * d.head(n)), p.s + t * ds, false);
      if (trial.finite() && trial.merit < p.merit * (1 - 1e-4 * t)) {
        p = std::move(trial);
        stepped = true;
        break;
      }
    }
    if (!stepped) {
      if (out.converged) return out;
      // Refit the multipliers once before giving up (the linear model of s may be poor far away).
      Point refit = evaluate(k, p.q, VectorX(), true);
      if (!refit.finite() || !(refit.merit < p.merit)) return out;
      p = std::move(refit);
    }
  }
}

// NLopt SLSQP: minimize V on c_I = 0 from a point on the manifold.
struct Slsqp {
  Constrained* k = nullptr;
  std::vector<int> equations;
  VectorX q;
};

double slsqp_objective(unsigned n, const double* x, double* grad, void* data) {
  auto* o = static_cast<Slsqp*>(data);
  o->q = Eigen::Map<const VectorX>(x, static_cast<Eigen::Index>(n));
  Problem& p = o->k->problem();
  const double v = p.potential(o->q);
  if (grad != nullptr) {
    const VectorX& g = p.residual(o->q);  // ∇V (conservative systems only reach here)
    for (unsigned i = 0; i < n; ++i) grad[i] = std::isfinite(g[i]) ? g[i] : 0.0;
  }
  return std::isfinite(v) ? v : 1e300;
}

void slsqp_constraints(unsigned m, double* result, unsigned n, const double* x, double* grad, void* data) {
  auto* o = static_cast<Slsqp*>(data);
  const VectorX q = Eigen::Map<const VectorX>(x, static_cast<Eigen::Index>(n));
  const VectorX c = o->k->values(q);
  for (unsigned i = 0; i < m; ++i) result[i] = c[o->equations[i]];
  if (grad != nullptr) {
    const MatrixX A = o->k->jacobian(q);
    for (unsigned i = 0; i < m; ++i)
      for (unsigned j = 0; j < n; ++j) grad[i * n + j] = A(o->equations[i], static_cast<Eigen::Index>(j));
  }
}

VectorX minimize_on_manifold(Constrained& k, const VectorX& q0) {
  const int n = k.n();
  Slsqp o;
  o.k = &k;
  o.equations = constraint_basis(k.jacobian(q0)).independent;
  nlopt::opt opt(nlopt::LD_SLSQP, static_cast<unsigned>(n));
  opt.set_min_objective(slsqp_objective, &o);
  if (!o.equations.empty())
    opt.add_equality_mconstraint(slsqp_constraints, &o,
                                 std::vector<double>(o.equations.size(), 1e-10 * k.length()));
  opt.set_xtol_rel(1e-10);
  opt.set_ftol_rel(1e-14);
  opt.set_maxeval(200 + 10 * n);
  std::vector<double> x(q0.data(), q0.data() + n);
  double f = 0;
  try {
    opt.optimize(x, f);
  } catch (const std::exception&) {
    // roundoff_limited or failure: Newton takes over from wherever it stopped.
  }
  return Eigen::Map<const VectorX>(x.data(), n);
}

std::string format(double v) {
  std::ostringstream out;
  out << std::setprecision(3) << v;
  return out.str();
}

// "the constraints cannot all be satisfied …" for the best attempt.
std::string infeasible_message(Constrained& k, const ConstraintProjection& best, int starts) {
  std::ostringstream m;
  m << "the constraints cannot all be satisfied: from " << starts << " start" << (starts == 1 ? "" : "s")
    << " the smallest violation reached is ‖c‖ = " << format(best.violation) << " m";
  if (best.q.size() == k.n()) {
    const VectorX c = k.values(best.q);
    Eigen::Index worst = 0;
    if (c.size() > 0 && c.allFinite()) {
      c.cwiseAbs().maxCoeff(&worst);
      m << ", largest in the equation '" << k.system().constraint_equation_names()[static_cast<std::size_t>(worst)]
        << "' (" << format(c[worst]) << " m)";
    }
  }
  m << ". No configuration near the starts closes the loops: check the constraints' lengths and attachment "
       "points (and that the joints allow the motion they need)";
  return m.str();
}

std::string no_equilibrium(Constrained& k, const Equilibrium& best, int starts) {
  std::ostringstream m;
  m << "no equilibrium found on the constraint manifold: the unbalanced generalized force ‖∇V − Q − ∇c s‖ "
       "could not be reduced below "
    << format(best.residual_norm) << " (relative " << format(best.residual) << ") from " << starts << " start"
    << (starts == 1 ? "" : "s");
  if (best.q.size() == k.n() && k.n() > 0) {
    const Point p = evaluate(k, best.q, VectorX(), true);
    if (p.finite() && p.force.size() > 0) {
      Eigen::Index worst = 0;
      p.force.cwiseAbs().maxCoeff(&worst);
      m << "; it is largest on the coordinate " << k.system().coordinates()[static_cast<std::size_t>(worst)].name
        << " (" << format(p.force[worst]) << ")";
    }
  }
  m << " — the constraints leave a motion that nothing in the scene resists";
  return m.str();
}

struct Candidates {
  std::vector<Equilibrium> found;
  ConstraintProjection best_projection{VectorX(), std::numeric_limits<double>::infinity()};
  Equilibrium best_failure;
  bool feasible = false;
  int starts = 0;
};

// Every start: onto the manifold, Newton from there (any equilibrium), and for
// a conservative system SLSQP (a minimum of V) then Newton.
void try_start(Constrained& k, const VectorX& start, const EquilibriumOptions& options, Candidates& out) {
  ++out.starts;
  const ConstraintProjection on = k.project(start);
  if (on.violation < out.best_projection.violation) out.best_projection = on;
  if (!(on.violation <= std::max(options.tolerance, 1e-10) * k.length())) return;
  out.feasible = true;
  auto keep = [&](const Newton& r) {
    if (r.converged)
      out.found.push_back(r.best);
    else if (r.best.q.size() == k.n() && (out.best_failure.q.size() == 0 || r.best.residual < out.best_failure.residual))
      out.best_failure = r.best;
  };
  keep(newton(k, on.q, options));
  if (!k.system().has_follower_loads() && k.n() > 0) {
    const ConstraintProjection min = k.project(minimize_on_manifold(k, on.q));
    if (min.q.size() == k.n()) keep(newton(k, min.q, options));
  }
}

}  // namespace

std::optional<Equilibrium> polish_constrained(const System& s, const VectorX& q, const EquilibriumOptions& options) {
  Constrained k(s);
  const ConstraintProjection on = k.project(q);
  if (on.q.size() != s.size()) return std::nullopt;
  Newton r = newton(k, on.q, options);
  if (!r.converged) return std::nullopt;
  return r.best;
}

Equilibrium find_constrained_equilibrium(const System& s, const VectorX& start, const EquilibriumOptions& options) {
  Constrained k(s);
  const ConstraintProjection on = k.project(start);
  if (on.violation <= std::max(options.tolerance, 1e-10) * k.length()) {
    Newton r = newton(k, on.q, options);
    if (r.converged) return r.best;
    if (!s.has_follower_loads()) {
      r = newton(k, k.project(minimize_on_manifold(k, on.q)).q, options);
      if (r.converged) return r.best;
    }
  }
  std::vector<Equilibrium> all = find_constrained_equilibria(s, options);
  std::size_t nearest = 0;
  double dmin = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < all.size(); ++i) {
    const double d = configuration_distance(s, all[i].q, start);
    if (d < dmin) {
      dmin = d;
      nearest = i;
    }
  }
  return all[nearest];
}

std::vector<Equilibrium> find_constrained_equilibria(const System& s, const EquilibriumOptions& options) {
  Constrained k(s);
  Candidates all;
  const std::vector<VectorX> starts = starting_points(s, halton_starts(s, options));
  for (std::size_t i = 0; i < starts.size(); ++i) {
    if (options.progress) options.progress(static_cast<int>(i), static_cast<int>(starts.size()));
    try_start(k, starts[i], options, all);
  }
  if (!all.feasible) throw NumericalError(infeasible_message(k, all.best_projection, all.starts));
  if (all.found.empty()) throw NumericalError(no_equilibrium(k, all.best_failure, all.starts));
  deduplicate_and_sort(s, options, all.found);
  return all.found;
}

}  // namespace modal::equilibrium_detail
