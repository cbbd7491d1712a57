// Rank structure and null-space basis of constraint Jacobians.
#include "modal/core.hpp"

#include <Eigen/QR>

#include <algorithm>

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

}  // namespace modal
