// lib/linearize/linearize.cpp — the linear model M δq̈ + (D + G) δq̇ + K δq = 0
// about an equilibrium q̄ of a System (DESIGN.md §1).
//
// With the core's present scope (a fixed or steadily moving frame, dead and
// follower loads, dampers, no constraints) the terms are
//   M = M(q̄), K = ∇∇V(q̄) − ∂Q/∂q(q̄, 0), D = damping_matrix(q̄) (dampers: Q = −D q̇),
//   G = gyroscopic_matrix(q̄) (rotating frame; else 0),
// where V is V_eff = V − T₀ in a rotating frame (the core's potential). K is
// symmetric unless follower loads act (circulatory): then it is kept exactly
// as computed, not symmetrized. has_gyroscopic is set only when G is not zero
// (a one-coordinate system in a rotating frame keeps the symmetric solver).
// q̄ is an equilibrium when ∇V(q̄) = Q(q̄, 0) (dampers exert no force at rest;
// follower loads do); its relative residual is ‖∇V − Q‖₂ / force_scale(q̄).
#include "modal/linearize.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace modal {
namespace {

std::string format_number(double v, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, v);
  return buffer;
}

// Unit of the generalized force conjugate to a coordinate.
const char* force_unit(CoordinateKind kind) { return kind == CoordinateKind::length ? "N" : "N·m"; }

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

  // Equilibrium check: ‖∇V − Q(q, 0)‖ relative to the scale of the forces acting.
  VectorX gradient = potential_gradient(s, ws, q);
  if (s.has_follower_loads()) gradient -= generalized_forces(s, ws, q, VectorX::Zero(n));
  if (!gradient.allFinite())
    throw NumericalError("linearize: the potential gradient ∇V is not finite at this configuration");
  const double scale = force_scale(s, ws, q);
  const double norm = gradient.norm();
  model.residual = norm == 0 ? 0.0 : (scale > 0 ? norm / scale : std::numeric_limits<double>::infinity());
  if (!(model.residual <= options.tolerance)) {
    Eigen::Index worst = 0;
    gradient.cwiseAbs().maxCoeff(&worst);
    const auto& coordinate = s.coordinates()[static_cast<std::size_t>(worst)];
    std::ostringstream out;
    out << "this configuration is not an equilibrium: the relative residual "
        << (s.has_follower_loads() ? "‖∇V − Q‖" : "‖∇V‖") << "/(force scale) is "
        << format_number(model.residual, 3) << ", above the tolerance " << format_number(options.tolerance, 3)
        << "; the largest unbalanced generalized force is " << format_number(-gradient(worst), 4) << " "
        << force_unit(coordinate.kind) << " acting on the coordinate '" << coordinate.name
        << "'. Find an equilibrium first (`modal equilibria`, or modal::find_equilibria) and linearize there";
    throw NotAnEquilibrium(out.str());
  }

  model.circulatory = s.has_follower_loads();
  if (model.circulatory) {
    const MatrixX K = potential_hessian(s, ws, q) - generalized_force_jacobian(s, ws, q);
    require_finite(K, "stiffness matrix K = ∇∇V − ∂Q/∂q", model.coordinates);
    model.K = K;  // not symmetric: its skew part is the circulatory stiffness
  } else {
    const MatrixX K = potential_hessian(s, ws, q);
    require_finite(K, "stiffness matrix K = ∇∇V", model.coordinates);
    model.K = symmetric_part(K);
  }
  const MatrixX M = mass_matrix(s, ws, q);
  require_finite(M, "mass matrix M", model.coordinates);
  model.M = symmetric_part(M);

  model.has_damping = s.has_damping();
  if (model.has_damping) {
    const MatrixX D = damping_matrix(s, ws, q);
    require_finite(D, "damping matrix D", model.coordinates);
    model.D = symmetric_part(D);
  } else {
    model.D = MatrixX::Zero(n, n);
  }
  model.G = MatrixX::Zero(n, n);
  model.has_gyroscopic = false;
  if (s.has_frame_coupling()) {
    const MatrixX G = gyroscopic_matrix(s, ws, q);
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
    }
  }
  return model;
}

}  // namespace modal
