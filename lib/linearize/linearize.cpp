// lib/linearize/linearize.cpp — the linear model M δq̈ + (D + G) δq̇ + K δq = 0
// about an equilibrium q̄ of a System (docs/design.md, "The linear model").
//
// With the core's present scope (a fixed or steadily moving frame, dead and
// follower loads, dampers; constraints projected at the end, see the header) the terms are
//   M = M(q̄), K = ∇∇V(q̄) − ∂Q/∂q(q̄, 0), D = damping_matrix(q̄) (dampers: Q = −D q̇),
//   G = gyroscopic_matrix(q̄) (rotating frame; else 0),
// where V is V_eff = V − T₀ in a rotating frame (the core's potential). K is
// symmetric unless follower loads act (circulatory): then it is kept exactly
// as computed, not symmetrized. has_gyroscopic is set only when G is not zero
// (a one-coordinate system in a rotating frame keeps the symmetric solver).
// q̄ is an equilibrium when ∇V(q̄) = Q(q̄, 0) (dampers exert no force at rest;
// follower loads do); its relative residual is relative_residual(s, w, q̄,
// ∇V − Q) (modal/core.hpp: ‖∇V − Q‖₂ against the scene's force scale and
// each entry against its coordinate's).
#include "modal/linearize.hpp"
#include "core/text.hpp"

#include <Eigen/QR>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace modal {
namespace {

using text::force_unit;
using text::format_number;

// Throws NumericalError naming `what` when A has a non-finite entry.
void require_finite(const MatrixX& A, const char* what, const std::vector<std::string>& names) {
  for (Eigen::Index j = 0; j < A.cols(); ++j)
    for (Eigen::Index i = 0; i < A.rows(); ++i)
      if (!std::isfinite(A(i, j))) {
        std::ostringstream out;
        out << "linearize: the " << what << " has a non-finite entry (" << A(i, j) << ") at ("
            << names[static_cast<std::size_t>(i)] << ", " << names[static_cast<std::size_t>(j)]
            << "): the model is not twice differentiable or overflows at this configuration";
        throw NumericalError(out.str());
      }
}

MatrixX symmetric_part(const MatrixX& A) { return 0.5 * (A + A.transpose()); }

// The relative residual (modal::relative_residual) of the generalized force r left
// unbalanced at q; NotAnEquilibrium (naming the coordinate) above `tolerance`.
double require_equilibrium(const System& s, Workspace& ws, const VectorX& q, const VectorX& r, double tolerance) {
  if (const std::optional<MeetingEnds> meet = spring_with_meeting_ends(s, ws, q))
    throw NumericalError("linearize: " + describe_meeting_ends(s, *meet) + ", so it is no equilibrium with a linear model");
  const double residual = relative_residual(s, ws, q, r);
  if (residual <= tolerance) return residual;
  Eigen::Index worst = 0;
  r.cwiseAbs().maxCoeff(&worst);
  const auto& coordinate = s.coordinates()[static_cast<std::size_t>(worst)];
  std::ostringstream out;
  out << "this configuration is not an equilibrium: the relative residual "
      << (s.has_follower_loads() ? "‖∇V − Q" : "‖∇V") << (s.has_constraints() ? " − ∇c s‖" : "‖") << "/(force scale) is "
      << format_number(residual, 3) << ", above the tolerance " << format_number(tolerance, 3)
      << "; the largest unbalanced generalized force is " << format_number(-r(worst), 4) << " "
      << force_unit(coordinate.kind) << " acting on the coordinate '" << coordinate.name
      << "'. Find an equilibrium first (`modal equilibria`, or modal::find_equilibria) and linearize there";
  throw NotAnEquilibrium(out.str());
}

// Constraints at q: checks c(q) = 0 (NotAnEquilibrium otherwise), decides the
// independent equations, and returns the least-squares multipliers s (m; 0 on
// redundant equations) of ∇c_I s_I = ∇V − Q. Fills the model's constraint
// forces, redundant equations and violation.
VectorX constraint_multipliers(const System& s, Workspace& ws, const VectorX& q, const VectorX& force,
                               double tolerance, LinearModel& model, ConstraintBasis& basis) {
  const VectorX c = constraint_values(s, ws, q);
  const MatrixX A = constraint_jacobian(s, ws, q);
  const std::vector<std::string> equations = s.constraint_equation_names();
  model.constraint_violation = c.norm();
  if (!(model.constraint_violation <= tolerance * s.length_scale())) {
    Eigen::Index worst = 0;
    c.cwiseAbs().maxCoeff(&worst);
    std::ostringstream out;
    out << "this configuration does not satisfy the constraints: ‖c‖ = " << format_number(model.constraint_violation, 3)
        << " m, above the tolerance " << format_number(tolerance, 3) << " × the length scale "
        << format_number(s.length_scale(), 3) << " m; the equation '" << equations[static_cast<std::size_t>(worst)]
        << "' is violated by " << format_number(c[worst], 4)
        << " m. Find an equilibrium first (`modal equilibria`, or modal::find_equilibria) and linearize there";
    throw NotAnEquilibrium(out.str());
  }
  basis = constraint_basis(A);
  const VectorX mult = fit_multipliers(A, basis, force);
  for (const int i : basis.redundant) model.redundant_equations.push_back(equations[static_cast<std::size_t>(i)]);
  Eigen::Index row = 0;
  for (std::size_t k = 0; k < s.constraints().size(); ++k) {
    const Constraint& con = s.constraints()[k];
    ConstraintForce f;
    f.name = con.name;
    f.type = con.type;
    f.multipliers = mult.segment(row, con.equations());
    for (int i = 0; i < con.equations(); ++i)
      if (std::find(basis.redundant.begin(), basis.redundant.end(), static_cast<int>(row) + i) != basis.redundant.end())
        f.redundant = true;
    model.constraint_forces.push_back(std::move(f));
    row += con.equations();
  }
  return mult;
}

}  // namespace

LinearModel linearize(const System& s, const VectorX& q, const LinearizeOptions& options) {
  const int n = s.size();
  if (q.size() != n)
    throw std::invalid_argument("linearize: the configuration has " + std::to_string(q.size()) +
                                " coordinates, the system " + std::to_string(n));
  if (!q.allFinite()) throw std::invalid_argument("linearize: the configuration has non-finite coordinates");

  // A steady motion given by the rates of ignorable coordinates is analyzed as
  // the free motion at the conserved momenta it has (Routh's reduction): the
  // same equilibrium, with the stiffness of the free system.
  if (s.is_map() && !s.ignorable_coordinates().empty()) {
    const auto given = s.map().coordinates[static_cast<std::size_t>(s.ignorable_coordinates().front())].ignorable->given;
    if (given == Ignorable::Given::rate) return linearize(with_steady_momenta(s, q), q, options);
  }

  LinearModel model;
  model.q = q;
  model.steady = steady_motion(s, q);
  model.coordinates = s.coordinate_names();
  Workspace ws(s);

  // Equilibrium check: ‖∇V − Q(q, 0) (− ∇c s)‖ relative to the scale of the forces acting.
  VectorX gradient = potential_gradient(s, ws, q);
  if (s.has_follower_loads()) gradient -= generalized_forces(s, ws, q, VectorX::Zero(n));
  if (!gradient.allFinite())
    throw NumericalError("linearize: the potential gradient ∇V is not finite at this configuration");
  ConstraintBasis constraints;
  VectorX multipliers;
  if (s.has_constraints()) {
    multipliers = constraint_multipliers(s, ws, q, gradient, options.tolerance, model, constraints);
    gradient -= constraint_jacobian(s, ws, q).transpose() * multipliers;
  }
  model.residual = require_equilibrium(s, ws, q, gradient, options.tolerance);
  // The multiplier term of the constrained stiffness, −Σ sᵢ∇∇cᵢ (symmetric).
  MatrixX multiplier_term;
  if (s.has_constraints()) {
    multiplier_term = constraint_hessian(s, ws, q, multipliers);
    require_finite(multiplier_term, "multiplier term Σ sᵢ∇∇cᵢ", model.coordinates);
  }
  auto stiffness = [&](MatrixX K) {
    if (s.has_constraints()) K -= multiplier_term;
    return K;
  };

  model.circulatory = s.has_follower_loads();
  model.derivatives = options.derivatives;
  MatrixX difference_error;
  if (options.derivatives != DerivativeMethod::exact) {  // ∂f/∂q of f = ∇V − Q − ∇c s by differences
    const MatrixX K =
        rest_force_jacobian(s, ws, q, options.derivatives, multipliers, options.step_factor, &difference_error);
    require_finite(K, "stiffness matrix K (by differences)", model.coordinates);
    model.K = model.circulatory ? K : symmetric_part(K);
  } else if (model.circulatory) {
    const MatrixX K = stiffness(potential_hessian(s, ws, q) - generalized_force_jacobian(s, ws, q));
    require_finite(K, "stiffness matrix K = ∇∇V − ∂Q/∂q", model.coordinates);
    model.K = K;  // not symmetric: its skew part is the circulatory stiffness
  } else {
    const MatrixX K = stiffness(potential_hessian(s, ws, q));
    require_finite(K, "stiffness matrix K = ∇∇V", model.coordinates);
    model.K = symmetric_part(K);
  }
  // K's error: its rounding, 4ε × Σ|terms| of ∇∇V and of the follower and
  // multiplier terms subtracted from it; for differences also their own.
  MatrixX terms = potential_hessian_magnitude(s, ws, q);
  if (model.circulatory) terms += generalized_force_jacobian(s, ws, q).cwiseAbs();
  if (s.has_constraints()) terms += multiplier_term.cwiseAbs();
  model.K_error = 4 * std::numeric_limits<double>::epsilon() * terms;
  // The springs' rounding, the positions' included, as a positive
  // semidefinite form (sparse_rounding_form) for deciding the modes' kinds;
  // where K is ∇∇V itself, or ∇∇V less the multiplier term (no follower
  // loads or differences). The multiplier term's rounding, at most 4ε|T|
  // entrywise, is added as diag(Σ_j |T_ij|) (|ψ|ᵀ|T||ψ| ≤ ψᵀ diag(Σ_j
  // |T_ij|) ψ, T symmetric); the form is projected with the rest below.
  if (!model.circulatory && options.derivatives == DerivativeMethod::exact && !s.is_map()) {
    model.K_rounding_form = sparse_rounding_form(s, ws, q);
    // Spring by spring for the symmetric path's estimates; not for a damped
    // scene, which the first-order solver takes (it does not use it).
    if (!s.has_constraints() && !s.has_damping()) model.K_spring_rounding = spring_rounding(s, ws, q);
    if (s.has_constraints() && model.K_rounding_form.size() > 0) {
      const VectorX rows = multiplier_term.cwiseAbs().rowwise().sum();
      model.K_rounding_form += SparseMatrix(rows.asDiagonal());
    }
  }
  if (difference_error.size() > 0) {
    model.K_error += difference_error;
    model.K_systematic_error = difference_error;
  }
  // A loose equilibrium: K changes by |K(q + δq) − K(q)| on the way to the
  // equilibrium, δq = −K⁻¹r (least squares where K is singular).
  if (model.residual > negligible_equilibrium_residual) {
    const MatrixX K0 = rest_force_jacobian(s, ws, q, DerivativeMethod::exact, multipliers);
    Eigen::CompleteOrthogonalDecomposition<MatrixX> cod(K0);
    cod.setThreshold(1e3 * std::numeric_limits<double>::epsilon());
    const VectorX dq = -cod.solve(gradient);
    if (dq.allFinite()) {
      try {
        const MatrixX change = (rest_force_jacobian(s, ws, q + dq, DerivativeMethod::exact, multipliers) - K0).cwiseAbs();
        if (change.allFinite()) {
          model.K_error += change;
          model.K_systematic_error = model.K_systematic_error.size() > 0 ? MatrixX(model.K_systematic_error + change) : change;
        }
      } catch (const NumericalError&) {  // the corrected point is singular: no estimate
      }
    }
  }
  const MatrixX M = mass_matrix(s, ws, q);
  require_finite(M, "mass matrix M", model.coordinates);
  model.M = symmetric_part(M);
  model.inertia_scale = inertia_scale(s, ws, q);

  model.has_damping = s.has_damping();
  if (model.has_damping) {
    const MatrixX D = damping_matrix(s, ws, q);
    require_finite(D, "damping matrix D", model.coordinates);
    model.D = symmetric_part(D);
  }
  model.has_gyroscopic = false;
  if (s.has_frame_coupling()) {
    MatrixX G_error;
    const MatrixX G = gyroscopic_matrix(s, ws, q, options.derivatives, options.step_factor,
                                        options.derivatives != DerivativeMethod::exact ? &G_error : nullptr);
    require_finite(G, "gyroscopic matrix G", model.coordinates);
    const MatrixX skew = 0.5 * (G - G.transpose());
    // Zero up to rounding relative to its natural size: |Ω|·‖M‖ in a rotating
    // frame, else (a moving map, Routh's reduction) √(‖M‖‖K‖), M times the
    // modal rate scale.
    const double mass = model.M.cwiseAbs().maxCoeff();
    const double size = s.frame_rotation().norm() * mass + std::sqrt(mass * model.K.cwiseAbs().maxCoeff());
    if (skew.cwiseAbs().maxCoeff() > 1e-14 * size) {
      model.G = skew;
      model.has_gyroscopic = true;
      if (G_error.size() > 0 && G_error.allFinite()) model.G_error = G_error;
    }
  }
  if (!s.is_map() && !s.has_constraints() && !s.has_follower_loads() && !s.has_frame_coupling() &&
      options.derivatives == DerivativeMethod::exact) {
    std::vector<int> parents = absolute_angle_parents(s, ws, q);
    keep_favourable_links(s, model.M, model.K, parents);
    if (std::any_of(parents.begin(), parents.end(), [](int p) { return p >= 0; })) {
      model.absolute = absolute_angle_model(s, ws, q, parents);
      model.absolute.K_magnitude *= 4 * std::numeric_limits<double>::epsilon();
      require_finite(model.absolute.M, "mass matrix in absolute angles", model.coordinates);
      require_finite(model.absolute.K, "stiffness matrix in absolute angles", model.coordinates);
      // XᵀEX for T = I − (parent links), q = Tθ: X = T (sign −1) or |T| (+1).
      auto congruence = [&](const MatrixX& E, double sign) {
        MatrixX A = E;
        for (int c = 0; c < n; ++c)
          if (const int p = parents[static_cast<std::size_t>(c)]; p >= 0) A.col(p) += sign * E.col(c);
        MatrixX B = A;
        for (int c = 0; c < n; ++c)
          if (const int p = parents[static_cast<std::size_t>(c)]; p >= 0) B.row(p) += sign * A.row(c);
        return B;
      };
      if (model.K_systematic_error.size() > 0) model.absolute_systematic_error = congruence(model.K_systematic_error, 1);
      if (model.has_damping) {
        // TᵀDT. An entry is a sum of at most (1 + c)² of D's (c: the most
        // links to one parent), each rounded once in D: its rounding is at
        // most ((1 + c)² + 1)ε|T|ᵀ|D||T|, taken as at least 4ε.
        std::vector<int> links(static_cast<std::size_t>(n), 0);
        for (const int p : parents)
          if (p >= 0) ++links[static_cast<std::size_t>(p)];
        const double c = *std::max_element(links.begin(), links.end());
        model.absolute.D = symmetric_part(congruence(model.D, -1));
        model.absolute.D_rounding = std::max(4.0, (1 + c) * (1 + c) + 1) * std::numeric_limits<double>::epsilon() *
                                    congruence(model.D.cwiseAbs(), 1);
      }
    }
  }
  if (s.has_constraints()) {  // onto the manifold: X → NᵀXN
    const MatrixX& N = constraints.null_space;
    model.basis = N;
    model.M = symmetric_part(N.transpose() * model.M * N);
    if (model.inertia_scale.size() > 0)  // (Σ_i |N_ij| √scale_i)² ≥ (Nᵀ M N)_jj
      model.inertia_scale = (N.cwiseAbs().transpose() * model.inertia_scale.cwiseSqrt()).cwiseAbs2();
    model.K = N.transpose() * model.K * N;
    if (!model.circulatory) model.K = symmetric_part(model.K);
    const MatrixX absN = N.cwiseAbs();
    model.K_error = absN.transpose() * model.K_error * absN;
    // F's projection NᵀFN (positive semidefinite; dense, as the reduced K):
    // φ_rᵀ δK_r φ_r = ψᵀδKψ with ψ = Nφ_r, which F bounds.
    if (model.K_rounding_form.size() > 0)
      model.K_rounding_form = MatrixX(N.transpose() * (model.K_rounding_form * N)).sparseView();
    if (model.K_systematic_error.size() > 0)
      model.K_systematic_error = absN.transpose() * model.K_systematic_error * absN;
    if (model.has_damping) model.D = symmetric_part(N.transpose() * model.D * N);
    if (model.has_gyroscopic) {
      model.G = N.transpose() * model.G * N;
      model.G = 0.5 * (model.G - model.G.transpose());
    }
    if (model.G_error.size() > 0) model.G_error = absN.transpose() * model.G_error * absN;
  }
  return model;
}

std::optional<std::string> sparse_unsupported(const System& s) {
  if (s.is_map()) return "it is a kinematic map (its matrices are dense)";
  if (s.has_constraints()) return "it has constraints (the projection onto the constraint manifold is dense)";
  if (s.has_follower_loads()) return "it has follower loads (K is not symmetric)";
  if (s.has_frame_coupling()) return "it is written in a rotating frame (gyroscopic terms need the first-order solver)";
  if (s.has_damping()) return "it has dampers (the sparse solver computes undamped modes K φ = λ M φ)";
  return std::nullopt;
}

SparseLinearModel linearize_sparse(const System& s, const VectorX& q, const LinearizeOptions& options) {
  if (const auto why = sparse_unsupported(s))
    throw std::invalid_argument("the sparse linear model does not apply to this scene: " + *why);
  if (q.size() != s.size())
    throw std::invalid_argument("linearize_sparse: the configuration has " + std::to_string(q.size()) +
                                " coordinates, the system " + std::to_string(s.size()));
  if (!q.allFinite()) throw std::invalid_argument("linearize_sparse: the configuration has non-finite coordinates");
  SparseLinearModel model;
  model.q = q;
  model.coordinates = s.coordinate_names();
  Workspace ws(s);
  const VectorX gradient = potential_gradient(s, ws, q);
  if (!gradient.allFinite())
    throw NumericalError("linearize: the potential gradient ∇V is not finite at this configuration");
  model.residual = require_equilibrium(s, ws, q, gradient, options.tolerance);
  model.K = sparse_potential_hessian(s, ws, q);
  model.K_magnitude = sparse_potential_hessian_magnitude(s, ws, q);
  model.K_rounding_form = sparse_rounding_form(s, ws, q);
  model.K_spring_rounding = spring_rounding(s, ws, q);
  model.M = sparse_mass_matrix(s, ws, q);
  model.inertia_scale = inertia_scale(s, ws, q);
  if (model.residual > sparse_equilibrium_correction_residual) {  // see the header
    Eigen::SimplicialLDLT<SparseMatrix> ldlt(model.K);
    if (ldlt.info() == Eigen::Success) {
      const VectorX dq = -ldlt.solve(gradient);
      if (dq.allFinite()) {
        try {
          model.K_equilibrium_shift = sparse_potential_hessian(s, ws, q + dq) - model.K;
        } catch (const NumericalError&) {
        }
      }
    }
  }
  for (const SparseMatrix* A : {&model.K, &model.M})
    for (Eigen::Index k = 0; k < A->outerSize(); ++k)
      for (SparseMatrix::InnerIterator it(*A, k); it; ++it)
        if (!std::isfinite(it.value()))
          throw NumericalError(std::string("linearize: the ") + (A == &model.K ? "stiffness" : "mass") +
                               " matrix has a non-finite entry at (" + model.coordinates[static_cast<std::size_t>(it.row())] +
                               ", " + model.coordinates[static_cast<std::size_t>(it.col())] + ")");
  return model;
}

}  // namespace modal
