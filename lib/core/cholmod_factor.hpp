// Private to the library: what modal asks of an Eigen CHOLMOD decomposition
// beyond Eigen's interface, written once for the equilibrium's Newton steps
// (lib/equilibrium/large.cpp) and the sparse modal path (lib/modal/sparse.cpp).
// Only stages that link CHOLMOD include it.
#pragma once

#include <Eigen/CholmodSupport>

#include <vector>

namespace modal::detail {

// `Decomposition`: Eigen::CholmodSupernodalLLT, Eigen::CholmodDecomposition, …
template <class Decomposition>
class CholmodAccess : public Decomposition {
 public:
  // A factorization that fails is an answer to the caller (not positive
  // definite: the caller shifts, or counts), not a warning for the user's
  // terminal.
  CholmodAccess() { this->cholmod().print = 0; }
  CholmodAccess(const CholmodAccess&) = delete;
  CholmodAccess& operator=(const CholmodAccess&) = delete;

  // The fill-reducing pivot order of the analysis (entry k: the k-th
  // variable); empty before an analysis.
  std::vector<int> ordering() const {
    const cholmod_factor* L = this->m_cholmodFactor;
    if (L == nullptr || L->Perm == nullptr) return {};
    const auto* perm = static_cast<const int*>(L->Perm);
    return std::vector<int>(perm, perm + L->n);
  }

  // Whether the last factorize ran out of memory. Eigen judges a
  // factorization by the factor's `minor` alone, and a factor CHOLMOD could
  // not fill (the first after an analysis, or a released one refilled) keeps
  // minor = n without numbers: taken as positive definite, it would give a
  // false inertia, and a solve with it would read no numbers at all.
  bool out_of_memory() {
    const cholmod_factor* L = this->m_cholmodFactor;
    return this->cholmod().status == CHOLMOD_OUT_OF_MEMORY || (L != nullptr && L->xtype == CHOLMOD_PATTERN);
  }
};

}  // namespace modal::detail
