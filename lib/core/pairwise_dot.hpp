// Private to the library: dot products whose rounding grows with log n, not
// n (the Rayleigh quotients of the sparse path and their error bounds).
#pragma once

#include "modal/core.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace modal::detail {

// Terms summed by Eigen (in whatever order its kernels take) in one block.
constexpr Eigen::Index pairwise_block = 32;

// The rounding depth of pairwise_dot over n terms: m = pairwise_block +
// ⌈log₂ ⌈n/pairwise_block⌉⌉ (at most n), so that the computed sum of the
// n products x_i y_i is within γ_m Σ|x_i y_i| of the exact one, γ_m =
// m u/(1 − m u), u the unit roundoff: m − 1 additions and one product on
// the way of each term (Higham, Accuracy and Stability of Numerical
// Algorithms, 2nd ed., 2002, §3.1 and §4.2: any order within a block,
// pairwise over the blocks). A plain dot's is n.
inline double pairwise_depth(Eigen::Index n) {
  if (n <= pairwise_block) return static_cast<double>(std::max<Eigen::Index>(n, 1));
  const Eigen::Index blocks = (n + pairwise_block - 1) / pairwise_block;
  return static_cast<double>(pairwise_block) + std::ceil(std::log2(static_cast<double>(blocks)));
}

// xᵀy: blocks of pairwise_block terms, then their sums pairwise (each level
// adds neighbours, an odd last one carried up): a fixed order for a given n.
template <class X, class Y> double pairwise_dot(const Eigen::MatrixBase<X>& x, const Eigen::MatrixBase<Y>& y) {
  const Eigen::Index n = x.size();
  if (n <= pairwise_block) return x.dot(y);
  std::vector<double> sums;
  sums.reserve(static_cast<std::size_t>((n + pairwise_block - 1) / pairwise_block));
  for (Eigen::Index at = 0; at < n; at += pairwise_block) {
    const Eigen::Index size = std::min(pairwise_block, n - at);
    sums.push_back(x.segment(at, size).dot(y.segment(at, size)));
  }
  while (sums.size() > 1) {
    std::size_t kept = 0;
    for (std::size_t i = 0; i < sums.size(); i += 2) sums[kept++] = i + 1 < sums.size() ? sums[i] + sums[i + 1] : sums[i];
    sums.resize(kept);
  }
  return sums.front();
}

}  // namespace modal::detail
