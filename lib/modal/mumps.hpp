// lib/modal/mumps.hpp — the sparse symmetric indefinite LDLᵀ of the modal
// stage (MUMPS), behind a small interface (internal: not installed).
//
// The implementation (lib/modal/mumps/mumps_ldlt.cpp) is compiled twice,
// against two builds of MUMPS that must never meet in one process: the
// sequential one (libdmumps_seq with its MPI stand-in libmpiseq_seq, which
// defines MPI_Init and friends itself) for libmodal and the program `modal`,
// and the parallel one (libdmumps over OpenMPI, the build PETSc links) for
// `modal-mpi`, where it runs on MPI_COMM_SELF. The stage library modal_modal
// therefore links neither: each final link adds one variant
// (docs/design.md, "Distributed backend").
#pragma once

#include "modal/core.hpp"

#include <memory>
#include <optional>
#include <vector>

namespace modal::detail {

class MumpsLdlt {
 public:
  // A: full symmetric storage, compressed; its lower triangle is used.
  // `order`: a fill-reducing pivot order (order[k] = the k-th variable), e.g.
  // CHOLMOD's for the same pattern, which spares MUMPS its own ordering;
  // empty: MUMPS chooses. `memory_limit`: bytes the process may hold once
  // the factorization has allocated its workspace (> 0, a limit the user
  // set), 0: what the machine has available; checked against MUMPS's own
  // estimate after its analysis (check_allocation), before the
  // factorization allocates: OutOfMemory. Throws NumericalError when MUMPS
  // cannot start.
  MumpsLdlt(const SparseMatrix& A, const std::vector<int>& order, double memory_limit = 0);
  MumpsLdlt(const MumpsLdlt&) = delete;
  MumpsLdlt& operator=(const MumpsLdlt&) = delete;
  ~MumpsLdlt();

  // Factors A (same pattern as at construction); the number of negative
  // pivots, or nothing when the factorization failed or met a null pivot:
  // one whose row underflows (null_pivot_threshold, modal/modes.hpp), or
  // with `normwise_null`, one whose row is below MUMPS's default, a
  // multiple of ε times the norm (for a shift the user chose, which may be
  // an eigenvalue: the caller moves it).
  std::optional<Eigen::Index> factor(const SparseMatrix& A, bool normwise_null = false);
  // Y = A⁻¹X for `columns` vectors (n × columns, column-major, one solve
  // phase for all); false when MUMPS fails.
  bool solve(const double* in, double* out, int columns = 1);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace modal::detail
