// Private to the library: products with large symmetric sparse matrices in
// two parts on the machine's two cores (docs/design.md, "Sparse solves in
// two parts").
#pragma once

#include "modal/core.hpp"
#include "core/in_parts.hpp"

#include <algorithm>
#include <array>
#include <cstddef>
#include <functional>

namespace modal::detail {

// Matrices from this many stored entries on are multiplied in two parts
// (12 MB of values and indices: a product of about 1 ms, where a thread's
// start costs tens of µs).
constexpr Eigen::Index sparse_parts_from = Eigen::Index{1} << 20;

// The first column of the second part of A's columns, halved by their
// stored entries (A.outerSize() for one part: A is small).
inline Eigen::Index second_part_column(const SparseMatrix& A) {
  if (!A.isCompressed() || A.nonZeros() < sparse_parts_from) return A.outerSize();
  const auto* outer = A.outerIndexPtr();
  const auto half = static_cast<SparseMatrix::StorageIndex>(A.nonZeros() / 2);
  return static_cast<Eigen::Index>(std::lower_bound(outer, outer + A.outerSize(), half) - outer);
}

// y = f(A) x (y_j = Σ_i f(A_ij) x_i) for a symmetric A that holds both
// triangles, column-major: entry j is the sum down column j, in the
// column's order, whatever the cores (the same bits on one core or two);
// the columns in two parts where A is large. f: each entry's value as used
// (the identity, or its magnitude for |A||x|). This is Aᵀx: an assembled
// ∇∇V is symmetric to its rounding, not to the bit (an entry and its
// mirror are sums of the same terms in other orders), so it differs from
// Eigen's A x within the assembly's rounding, which the estimates count.
template <class F = std::identity>
VectorX symmetric_product(const SparseMatrix& A, const VectorX& x, F f = {}) {
  VectorX y(A.outerSize());
  const Eigen::Index split = second_part_column(A);
  const auto columns = [&](Eigen::Index from, Eigen::Index to) {
    for (Eigen::Index j = from; j < to; ++j) {
      double sum = 0;
      for (SparseMatrix::InnerIterator it(A, j); it; ++it) sum += f(it.value()) * x[it.row()];
      y[j] = sum;
    }
  };
  in_parts(split < A.outerSize() ? 2 : 1, [&](std::size_t part) {
    if (part == 0)
      columns(0, split);
    else
      columns(split, A.outerSize());
  });
  return y;
}

// Σ over A's stored entries of term(value, row, column), in two parts
// where A is large, the second part's sum added to the first's: a fixed
// order, whatever the cores.
template <class Term> double sum_over_entries(const SparseMatrix& A, Term term) {
  const Eigen::Index split = second_part_column(A);
  std::array<double, 2> sums{0, 0};
  in_parts(split < A.outerSize() ? 2 : 1, [&](std::size_t part) {
    const Eigen::Index from = part == 0 ? 0 : split, to = part == 0 ? split : A.outerSize();
    double sum = 0;
    for (Eigen::Index j = from; j < to; ++j)
      for (SparseMatrix::InnerIterator it(A, j); it; ++it) sum += term(it.value(), it.row(), j);
    sums[part] = sum;
  });
  return sums[0] + sums[1];
}

}  // namespace modal::detail
