// Rank structure and null-space basis of constraint Jacobians.
#include "modal/core.hpp"

#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <limits>

namespace modal {

ConstraintBasis constraint_basis(const MatrixX& A) {
  const Eigen::Index m = A.rows(), n = A.cols();
  ConstraintBasis b;
  if (m == 0) {
    b.null_space = MatrixX::Identity(n, n);
    return b;
  }
  if (!A.allFinite()) throw NumericalError("the constraint Jacobian has non-finite entries at this configuration");
  Eigen::ColPivHouseholderQR<MatrixX> qr(A.transpose());  // n×m: columns are the equations' gradients
  qr.setThreshold(1e-10);
  b.rank = static_cast<int>(qr.rank());
  const auto& perm = qr.colsPermutation().indices();
  for (Eigen::Index i = 0; i < m; ++i) (i < b.rank ? b.independent : b.redundant).push_back(perm[i]);
  std::sort(b.independent.begin(), b.independent.end());
  std::sort(b.redundant.begin(), b.redundant.end());
  const MatrixX Q = qr.householderQ();  // n×n orthogonal; its first r columns span the gradients
  b.null_space = Q.rightCols(n - b.rank);
  return b;
}

VectorX fit_multipliers(const MatrixX& A, const ConstraintBasis& basis, const VectorX& force) {
  VectorX s = VectorX::Zero(A.rows());
  if (basis.rank == 0) return s;
  MatrixX AI(basis.rank, A.cols());
  for (int i = 0; i < basis.rank; ++i) AI.row(i) = A.row(basis.independent[static_cast<std::size_t>(i)]);
  const VectorX sI = AI.transpose().colPivHouseholderQr().solve(force);
  for (int i = 0; i < basis.rank; ++i) s[basis.independent[static_cast<std::size_t>(i)]] = sI[i];
  return s;
}

namespace {

// c(q), or NaN where it is undefined (a distance constraint with coincident ends).
VectorX values_or_nan(const System& s, Workspace& w, const VectorX& q) {
  try {
    return constraint_values(s, w, q);
  } catch (const NumericalError&) {
    return VectorX::Constant(s.constraint_equations(), std::numeric_limits<double>::quiet_NaN());
  }
}

}  // namespace

ConstraintProjection project_onto_constraints(const System& s, Workspace& w, const VectorX& start) {
  ConstraintProjection out{canonical_coordinates(s, start), std::numeric_limits<double>::infinity()};
  VectorX q = out.q;
  VectorX c = values_or_nan(s, w, q);
  if (!c.allFinite()) return out;
  for (int it = 0; it < 100; ++it) {
    const double norm = c.norm();
    out = {q, norm};
    if (norm <= 1e-15 * s.length_scale()) break;
    MatrixX A;
    try {
      A = constraint_jacobian(s, w, q);
    } catch (const NumericalError&) {
      break;
    }
    Eigen::CompleteOrthogonalDecomposition<MatrixX> cod(A);
    cod.setThreshold(1e-12);
    VectorX d = -cod.solve(c);
    if (!d.allFinite()) break;
    VectorX scaled = d;  // in rad and length scales
    for (int i = 0; i < s.size(); ++i)
      if (s.coordinates()[static_cast<std::size_t>(i)].kind == CoordinateKind::length) scaled[i] /= s.length_scale();
    if (scaled.norm() > 0.5) d *= 0.5 / scaled.norm();
    bool accepted = false;
    for (double t = 1; t > 1e-6; t *= 0.5) {
      const VectorX qt = q + t * d;
      const VectorX ct = values_or_nan(s, w, qt);
      if (ct.allFinite() && ct.norm() < norm) {
        q = canonical_coordinates(s, qt);
        c = ct;
        accepted = true;
        break;
      }
    }
    if (!accepted) break;
  }
  if (c.norm() < out.violation) out = {q, c.norm()};
  return out;
}

}  // namespace modal
