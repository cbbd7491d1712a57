// lib/modal/mumps/mumps_ldlt.cpp — detail::MumpsLdlt (../mumps.hpp): a sparse
// symmetric indefinite LDLᵀ factorization with pivoting by MUMPS
// (multifrontal with BLAS-3 fronts, METIS or AMD ordering chosen by MUMPS, or
// a given order): the inertia of an indefinite K − σM (its negative pivots,
// INFOG(12)) at the cost of a supernodal Cholesky, where CHOLMOD's LDLᵀ is
// simplicial (scalar, several times slower on 2-D and 3-D meshes) and does not
// pivot. Null pivots are detected (ICNTL(24)) and reported as a failure, like
// a zero pivot: for inertia counts only pivots whose rows underflow (CNTL(3)
// < 0: an absolute threshold; null_pivot_threshold, modal/modes.hpp). One
// symbolic analysis serves every σ (the pattern of A is fixed).
//
// Compiled twice (see ../mumps.hpp): without MODAL_MUMPS_MPI against the
// sequential MUMPS (its communicator is the stand-in's USE_COMM_WORLD), with
// it against the parallel MUMPS of modal-mpi, where MPI is already running
// (PetscInitialize) and each factorization is a private one on MPI_COMM_SELF.
//
// MUMPS keeps state in Fortran module variables (its memory and load
// bookkeeping), so two factorizations running at once in one process corrupt
// each other (seen: analyses of two models from two threads crashing in
// dmumps_load_mem_update). Every call goes through one lock: modal's
// functions stay safe to call from several threads, and MUMPS jobs, which are
// short next to the rest of a sparse analysis, take turns.
#include "modal/mumps.hpp"
#include "modal/modes.hpp"

#include <dmumps_c.h>
#if defined(MODAL_MUMPS_MPI)
#include <mpi.h>
#endif

#include <algorithm>
#include <mutex>
#include <new>

namespace modal::detail {
namespace {

// The job set in `id`. A workspace MUMPS could not allocate (INFOG(1) = −5,
// −7 in the analysis: real, integer; −13 in any job: a Fortran ALLOCATE
// refused) is the
// program's out-of-memory failure (std::bad_alloc), not a failed
// factorization, which callers would take for a singular K − σM. Not for the
// termination job (-2) of a destructor.
void run_mumps(DMUMPS_STRUC_C& id) {
  {
    static std::mutex mumps;
    const std::lock_guard<std::mutex> lock(mumps);
    dmumps_c(&id);
  }
  if (id.job != -2 && (id.infog[0] == -5 || id.infog[0] == -7 || id.infog[0] == -13)) throw std::bad_alloc();
}

}  // namespace

struct MumpsLdlt::State {
  Eigen::Index n = 0;
  std::vector<Eigen::Index> positions;  // of the lower-triangle entries in A's value array
  std::vector<MUMPS_INT> irn, jcn, perm_in;
  std::vector<double> values;
  DMUMPS_STRUC_C id{};
  double memory_limit = 0;  // MumpsLdlt's
  bool initialized = false, analyzed = false, factored = false;
};

MumpsLdlt::MumpsLdlt(const SparseMatrix& A, const std::vector<int>& order, double memory_limit)
    : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.n = A.rows();
  s.memory_limit = memory_limit;
  for (Eigen::Index j = 0; j < A.outerSize(); ++j)
    for (Eigen::Index p = A.outerIndexPtr()[j]; p < A.outerIndexPtr()[j + 1]; ++p)
      if (A.innerIndexPtr()[p] >= j) {
        s.positions.push_back(p);
        s.irn.push_back(static_cast<MUMPS_INT>(A.innerIndexPtr()[p] + 1));
        s.jcn.push_back(static_cast<MUMPS_INT>(j + 1));
      }
  s.values.resize(s.positions.size());
#if defined(MODAL_MUMPS_MPI)
  s.id.comm_fortran = static_cast<MUMPS_INT>(MPI_Comm_c2f(MPI_COMM_SELF));
#else
  s.id.comm_fortran = -987654;  // USE_COMM_WORLD of the sequential MPI stand-in
#endif
  s.id.par = 1;
  s.id.sym = 2;  // symmetric, not necessarily definite: LDLᵀ with 1×1 and 2×2 pivots
  s.id.job = -1;
  run_mumps(s.id);
  s.initialized = s.id.infog[0] >= 0;
  if (!s.initialized) throw NumericalError("solve_sparse_modes: MUMPS could not be initialized");
  for (int i : {0, 1, 2}) s.id.icntl[i] = -1;  // no output
  s.id.icntl[3] = 0;
  if (order.size() == static_cast<std::size_t>(s.n)) {
    s.perm_in.resize(order.size());
    for (std::size_t k = 0; k < order.size(); ++k)
      s.perm_in[static_cast<std::size_t>(order[k])] = static_cast<MUMPS_INT>(k + 1);
    s.id.icntl[6] = 1;  // ICNTL(7): the given order (PERM_IN)
    s.id.perm_in = s.perm_in.data();
  } else {
    s.id.icntl[6] = 7;  // ICNTL(7): ordering chosen by MUMPS
  }
  s.id.icntl[23] = 1;  // ICNTL(24): detect null pivots (CNTL(3): in factor)
  s.id.n = static_cast<MUMPS_INT>(s.n);
  s.id.nnz = static_cast<MUMPS_INT8>(s.positions.size());
  s.id.irn = s.irn.data();
  s.id.jcn = s.jcn.data();
  s.id.a = s.values.data();
}

MumpsLdlt::~MumpsLdlt() {
  if (state_->initialized) {
    state_->id.job = -2;
    run_mumps(state_->id);
  }
}

std::optional<Eigen::Index> MumpsLdlt::factor(const SparseMatrix& A, bool normwise_null) {
  State& s = *state_;
  s.id.cntl[2] = normwise_null ? 0.0 : null_pivot_threshold;  // CNTL(3): 0 is MUMPS's default
  for (std::size_t i = 0; i < s.positions.size(); ++i) s.values[i] = A.valuePtr()[s.positions[i]];
  if (!s.analyzed) {
    s.id.job = 1;
    run_mumps(s.id);
    if (s.id.infog[0] < 0) return std::nullopt;
    // INFOG(17): the analysis's estimate of the factorization's memory in
    // core, in millions of bytes (all processes: here one).
    const std::string n = std::to_string(s.n);
    check_allocation(1e6 * static_cast<double>(s.id.infog[16]),
                     "the sparse LDLᵀ factorization (MUMPS) of this system's " + n + " × " + n + " matrix, by its analysis",
                     s.memory_limit);
    s.analyzed = true;
  }
  s.factored = false;
  for (int attempt = 0; attempt < 4; ++attempt) {
    s.id.job = 2;
    run_mumps(s.id);
    // INFOG(1) = −8, −9: the estimated workspace was too small; grow it.
    if (s.id.infog[0] == -8 || s.id.infog[0] == -9) {
      s.id.icntl[13] = std::max<MUMPS_INT>(40, 2 * s.id.icntl[13]);
      continue;
    }
    break;
  }
  if (s.id.infog[0] < 0 || s.id.infog[27] > 0) return std::nullopt;  // INFOG(28): null pivots
  s.factored = true;
  return static_cast<Eigen::Index>(s.id.infog[11]);  // INFOG(12): negative pivots
}

bool MumpsLdlt::solve(const double* in, double* out, int columns) {
  State& s = *state_;
  if (!s.factored) return false;
  std::copy_n(in, static_cast<std::size_t>(s.n) * static_cast<std::size_t>(columns), out);
  s.id.rhs = out;
  s.id.nrhs = static_cast<MUMPS_INT>(columns);
  s.id.lrhs = static_cast<MUMPS_INT>(s.n);
  s.id.job = 3;
  run_mumps(s.id);
  return s.id.infog[0] >= 0;
}

}  // namespace modal::detail
