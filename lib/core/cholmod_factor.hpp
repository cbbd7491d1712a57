// Private to the library: what modal asks of an Eigen CHOLMOD decomposition
// beyond Eigen's interface, written once for the equilibrium's Newton steps
// (lib/equilibrium/large.cpp) and the sparse modal path (lib/modal/sparse.cpp).
// Only stages that link CHOLMOD include it.
#pragma once

#include "modal/core.hpp"

#include "core/supernodal_solve.hpp"

#include <Eigen/CholmodSupport>

#include <new>
#include <string>
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

  // Bytes the numeric factor may take (> 0), e.g. a limit the user set
  // (--max-memory); 0: what the machine has available. Checked after every
  // symbolic analysis (check_analysis, check_factor_memory).
  double memory_limit = 0;
  CholmodAccess(const CholmodAccess&) = delete;
  CholmodAccess& operator=(const CholmodAccess&) = delete;

  // Eigen's analyzePattern, factorize and compute, with the factor's absence
  // checked (check_analysis): Eigen's factorize reads the factor the
  // analysis left, and where CHOLMOD gave none it would read a null pointer.
  using MatrixType = typename Decomposition::MatrixType;
  void analyzePattern(const MatrixType& A) {
    Decomposition::analyzePattern(A);
    check_analysis(A.rows());
  }
  void factorize(const MatrixType& A) {
    check_analysis(A.rows());
    Decomposition::factorize(A);
  }
  CholmodAccess& compute(const MatrixType& A) {
    analyzePattern(A);
    factorize(A);
    return *this;
  }

  // x = A⁻¹b for one vector (n each; x may be b) in two parts on two cores,
  // where the factor is a supernodal LLᵀ large enough to pay
  // (core/supernodal_solve.hpp); false otherwise: the caller then solves with
  // CHOLMOD.
  bool solve_in_parts(const double* b, double* x) {
    return supernodal_solve(this->m_cholmodFactor, b, x, schedule_);
  }

  // The fill-reducing pivot order of the analysis (entry k: the k-th
  // variable); empty before an analysis.
  std::vector<int> ordering() const {
    const cholmod_factor* L = this->m_cholmodFactor;
    if (L == nullptr || L->Perm == nullptr) return {};
    const auto* perm = static_cast<const int*>(L->Perm);
    return std::vector<int>(perm, perm + L->n);
  }

  // The memory the numeric factor of the last analysis will take, in bytes
  // (0 before one): a supernodal factor's values (xsize, with the zeros its
  // relaxed supernodes hold), its row indices (ssize) and the largest update
  // matrix of the factorization (maxcsize); a simplicial one's values and
  // row indices, one each per entry of L (CHOLMOD's count lnz for the
  // analysis's order).
  double factor_bytes() {
    const cholmod_factor* L = this->m_cholmodFactor;
    if (L == nullptr) return 0;
    if (L->is_super)
      return 8.0 * static_cast<double>(L->xsize) + 4.0 * static_cast<double>(L->ssize) +
             8.0 * static_cast<double>(L->maxcsize);
    return 12.0 * this->cholmod().lnz;
  }

  // Refuses the factorization of the n × n matrix just analyzed, before it
  // allocates, when its factor (factor_bytes) would bring the process over
  // `limit` bytes (> 0: a limit the user set) or, with limit 0, would take
  // more than the machine has available (check_allocation; unknown: no
  // refusal): OutOfMemory, with the factor's size and the matrix's. Without
  // it a factor the kernel lets the process reserve but cannot give ends the
  // process by the kernel's out-of-memory killer, with no message.
  void check_factor_memory(Eigen::Index n, double limit) {
    try {
      check_allocation(factor_bytes(),
                       "the sparse Cholesky factor (CHOLMOD) of " + matrix_words(n) + ", by its symbolic analysis", limit);
    } catch (const OutOfMemory&) {
      this->m_analysisIsOk = false;  // no factorization of this analysis
      throw;
    }
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

 protected:
  // After a symbolic analysis of an n × n matrix: CHOLMOD gives no factor
  // when it runs out of memory (the program's out-of-memory failure), when
  // the factor would hold more entries than its int indices address, 2³¹ − 1
  // (a 3-D lattice of 10⁶ coordinates: its status CHOLMOD_TOO_LARGE), which
  // no amount of memory mends, or on an invalid argument (its status named);
  // a factor more than the machine has available is refused
  // (check_factor_memory).
  void check_analysis(Eigen::Index n) {
    if (const cholmod_factor* L = this->m_cholmodFactor) {
      // Before the factor's numbers are allocated only (a factor that holds
      // them is already in use: what remains available no longer counts it).
      if (L->xtype == CHOLMOD_PATTERN) check_factor_memory(n, memory_limit);
      return;
    }
    this->m_analysisIsOk = false;
    const int status = this->cholmod().status;
    if (status == CHOLMOD_OUT_OF_MEMORY) throw std::bad_alloc();
    const std::string matrix = matrix_words(n);
    if (status == CHOLMOD_TOO_LARGE)
      throw NumericalError("the sparse Cholesky factor (CHOLMOD) of " + matrix +
                           " would hold more than 2³¹ − 1 entries (16 GiB), more than its 32-bit indices address: "
                           "the system is too large for the sparse path of one process");
    throw NumericalError("CHOLMOD's symbolic analysis of " + matrix + " failed (its status " + std::to_string(status) +
                         ")");
  }

 private:
  SupernodalSchedule schedule_;  // solve_in_parts's cut of the factor's tree, kept while its structure stays

  static std::string matrix_words(Eigen::Index n) {
    return "this system's " + std::to_string(n) + " × " + std::to_string(n) + " matrix";
  }
};

}  // namespace modal::detail
