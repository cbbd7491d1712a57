// Private to the library: compensated sums shared by the chain paths.
#pragma once

#include "modal/core.hpp"

#include <cmath>

namespace modal::sums {

// W_j = Σ_{b≥j} v_b (n each), summed from the end with compensation
// (Neumaier): for terms of one sign each W_j is within 2ε(1 + nε) of the
// exact sum, where plain summation would leave up to (n − j)ε (12ε measured
// on graded masses at n = 2000, 18ε on 300 equal ones).
inline VectorX compensated_suffix_sums(const VectorX& v) {
  const Eigen::Index n = v.size();
  VectorX W(n);
  double sum = 0, carried = 0;
  for (Eigen::Index j = n - 1; j >= 0; --j) {
    const double t = sum + v(j);
    carried += std::abs(sum) >= std::abs(v(j)) ? (sum - t) + v(j) : (v(j) - t) + sum;
    sum = t;
    W(j) = sum + carried;
  }
  return W;
}

}  // namespace modal::sums
