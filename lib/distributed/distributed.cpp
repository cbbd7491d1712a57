// lib/distributed/distributed.cpp — analyze_distributed(): the sparse path
// (equilibrium, K and M, the lowest modes) over MPI ranks with PETSc and SLEPc
// (docs/design.md, "Distributed backend").
//
// Partition. The particles (bodies) are split into contiguous index ranges,
// rank r owning ⌊N/p⌋ or ⌊N/p⌋ + 1 of them (PETSc's rule); their coordinates
// are then the contiguous range PETSc's vectors and matrices own. Each rank
// builds a local System: its own particles as they are (mass, joint springs,
// loads), the springs whose first end particle it owns (the second end if the
// first is the world), and the other end particles of those springs as ghosts
// (no mass, no joint spring, no loads: they only carry the configuration).
// ∇V, ∇∇V and M of the whole scene are the sums over the ranks of the local
// ones, which the core functions compute with the same element derivatives as
// the serial path; they are added into PETSc's MPI vectors and MPIAIJ
// matrices at the global coordinate indices (ADD_VALUES).
//
// Errors. Every phase is run on every rank inside agree(): an exception on any
// rank becomes, through MPI_Allreduce and a broadcast from the lowest failing
// rank, the same message and exit status on all ranks before the next
// collective call, so no rank waits for a peer that has given up.
#include "modal/distributed.hpp"
#include "modal/equilibrium.hpp"

#include <fmt/format.h>
#include <mpi.h>
#include <petscsnes.h>
#include <slepceps.h>

#include <array>
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <numeric>
#include <functional>
#include <optional>
#include <ostream>
#include <stdexcept>

namespace modal {
namespace {

constexpr double eps = std::numeric_limits<double>::epsilon();
using Clock = std::chrono::steady_clock;

// A PETSc call that failed: its name and error code (PETSc prints nothing).
void check(PetscErrorCode code, const char* what) {
  if (code != 0) throw NumericalError(fmt::format("--backend petsc: {} failed (PETSc error {})", what, static_cast<int>(code)));
}
#define MODAL_PETSC(call) check((call), #call)

// ---------------------------------------------------------------- agreement

struct Failure {
  int status = 0;
  std::string message;
  std::string cause;  // the exception's own text, without the prefix of `message`
  bool scene_error = false;  // a SceneError (its cause starts with its file)
};
// Thrown on every rank once the ranks agree that one of them failed.
struct Agreed {
  Failure failure;
};

int world_rank() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}
int world_size() {
  int s = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &s);
  return s;
}

// Collective: the outcome of the lowest failing rank, on every rank.
Failure agree(const Failure& mine) {
  const int size = world_size();
  int first = mine.status != 0 ? world_rank() : size;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  if (first == size) return {};
  Failure f = mine;
  int length = static_cast<int>(f.message.size());
  MPI_Bcast(&f.status, 1, MPI_INT, first, MPI_COMM_WORLD);
  MPI_Bcast(&f.scene_error, 1, MPI_CXX_BOOL, first, MPI_COMM_WORLD);
  MPI_Bcast(&length, 1, MPI_INT, first, MPI_COMM_WORLD);
  f.message.resize(static_cast<std::size_t>(length));
  MPI_Bcast(f.message.data(), length, MPI_CHAR, first, MPI_COMM_WORLD);
  length = static_cast<int>(f.cause.size());
  MPI_Bcast(&length, 1, MPI_INT, first, MPI_COMM_WORLD);
  f.cause.resize(static_cast<std::size_t>(length));
  MPI_Bcast(f.cause.data(), length, MPI_CHAR, first, MPI_COMM_WORLD);
  return f;
}

// Runs `work` on this rank, then agrees with the others; throws Agreed on
// every rank when any failed.
template <class Work>
void phase(Work&& work) {
  Failure mine;
  try {
    work();
  } catch (const Agreed&) {
    throw;
  } catch (const std::exception& e) {
    mine = {static_cast<int>(exit_status(e)), error_message(e), e.what(), dynamic_cast<const SceneError*>(&e) != nullptr};
  } catch (...) {
    mine = {static_cast<int>(ExitStatus::numerical), "modal: failure: unknown error", "unknown error"};
  }
  if (Failure f = agree(mine); f.status != 0) throw Agreed{f};
}

// Σ over the ranks of a local evaluation (a double, or a std::array of them
// summed entrywise), agreed on first: a rank whose evaluation throws must not
// leave the others waiting in the sum.
template <class Evaluate>
auto sum_over_ranks(Evaluate&& evaluate) {
  using Value = std::decay_t<decltype(evaluate())>;
  Value v{};
  phase([&] { v = evaluate(); });
  if constexpr (std::is_same_v<Value, double>)
    MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  else
    MPI_Allreduce(MPI_IN_PLACE, v.data(), static_cast<int>(v.size()), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  return v;
}

// ---------------------------------------------------------------- the scene

// Collective: rank 0 reads the scene whole (`read_whole`, the serial path);
// its SceneError, when `accept` takes it, becomes the agreed failure, with
// the serial message.
void serial_failure(const std::function<void()>& read_whole, const std::function<bool(const SceneError&)>& accept) {
  phase([&] {
    if (world_rank() != 0) return;
    try {
      read_whole();
    } catch (const SceneError& e) {
      if (accept(e)) throw;
    }
  });
}

// What no rank can see alone in a scene read in parts (SceneWindow), checked
// by all together: every [[network]] edge owned by one part (an edge whose
// first node no part has is owned by none, so the owned rows add up to fewer
// than the scene's), and no body name owned twice (each rank sends a 64-bit
// hash of each owned body's name to rank hash % size, MPI_Alltoallv, which
// looks for repeats). When either fails, rank 0 reads the scene whole,
// `read_whole` (the serial path), whose error is the agreed failure with the
// serial message; if that reading succeeds (a hash collision), on we go.
// Collective; memory of the part's size except in that failure.
void check_read_in_parts(const Scene& part, const std::function<void()>& read_whole) {
  const int size = world_size();
  std::vector<std::uint64_t> hashes;
  std::vector<int> counts(static_cast<std::size_t>(size), 0), offsets(static_cast<std::size_t>(size), 0);
  phase([&] {
    const auto& bodies = part.description.bodies;
    for (std::size_t b = 0; b < bodies.size(); ++b) {
      const long long g = part.global_bodies.empty() ? static_cast<long long>(b) : part.global_bodies[b];
      if (g < part.first_owned || g >= part.end_owned) continue;
      std::uint64_t h = 1469598103934665603ULL;  // FNV-1a
      for (const char c : bodies[b].name) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ULL;
      hashes.push_back(h);
    }
    std::sort(hashes.begin(), hashes.end(), [size](std::uint64_t x, std::uint64_t y) {
      return std::pair(x % static_cast<std::uint64_t>(size), x) < std::pair(y % static_cast<std::uint64_t>(size), y);
    });
    for (const std::uint64_t h : hashes) ++counts[static_cast<std::size_t>(h % static_cast<std::uint64_t>(size))];
    std::partial_sum(counts.begin(), counts.end() - 1, offsets.begin() + 1);
  });
  std::vector<int> incoming(static_cast<std::size_t>(size)), at(static_cast<std::size_t>(size), 0);
  MPI_Alltoall(counts.data(), 1, MPI_INT, incoming.data(), 1, MPI_INT, MPI_COMM_WORLD);
  std::partial_sum(incoming.begin(), incoming.end() - 1, at.begin() + 1);
  std::vector<std::uint64_t> mine(static_cast<std::size_t>(at.back() + incoming.back()));
  MPI_Alltoallv(hashes.data(), counts.data(), offsets.data(), MPI_UINT64_T, mine.data(), incoming.data(), at.data(),
                MPI_UINT64_T, MPI_COMM_WORLD);
  std::sort(mine.begin(), mine.end());
  long long checks[2] = {part.owned_network_edges,
                         std::adjacent_find(mine.begin(), mine.end()) != mine.end() ? 1LL : 0LL};
  MPI_Allreduce(MPI_IN_PLACE, checks, 2, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  if (checks[0] == part.network_edges && checks[1] == 0) return;
  serial_failure(read_whole, [](const SceneError&) { return true; });
}

std::optional<std::string> distributed_unsupported(const System& s) {
  if (const auto why = sparse_unsupported(s)) return why;
  for (const Body& b : s.bodies())
    if ((b.joint != JointType::particle && b.joint != JointType::fixed) || b.parent != -1)
      return "body '" + b.name + "' is not a free particle (the backend partitions particles and springs)";
  return std::nullopt;
}

// The part of the scene one rank assembles.
struct Part {
  long long first_body = 0, end_body = 0;   // owned particles [first, end) of the whole scene
  PetscInt first_coordinate = 0, end_coordinate = 0;
  std::optional<System> system;             // owned particles, then ghosts
  std::vector<int> held;                    // the rank's System's body of each body of `system`
  int owned_count = 0;                      // the first owned_count of them are owned
  std::vector<PetscInt> global;             // local coordinate → global coordinate
  PetscInt max_row = 0;                     // entries in the fullest row of K (global bound)
};

// The local System from the part of the scene the rank has read (`s`, its
// bodies at scene.global_bodies of the whole scene: distributed generation,
// SceneWindow): the owned particles, the springs whose first end it owns,
// their other ends as ghosts. Local (no communication); global_coordinates()
// then numbers the coordinates.
Part partition(const System& s, const Scene& scene) {
  Part p;
  p.first_body = scene.first_owned;
  p.end_body = scene.end_owned;
  const int n_held = static_cast<int>(s.bodies().size());
  const auto global = [&](int b) {
    return scene.global_bodies.empty() ? static_cast<long long>(b) : scene.global_bodies[static_cast<std::size_t>(b)];
  };
  const auto owned = [&](int b) { return global(b) >= p.first_body && global(b) < p.end_body; };

  SystemDescription d;
  d.title = s.title();
  d.gravity = s.gravity();
  std::vector<int> local(static_cast<std::size_t>(n_held), -1);
  for (int b = 0; b < n_held; ++b)
    if (owned(b)) {
      local[static_cast<std::size_t>(b)] = static_cast<int>(p.held.size());
      p.held.push_back(b);
      d.bodies.push_back(s.bodies()[static_cast<std::size_t>(b)]);
    }
  p.owned_count = static_cast<int>(p.held.size());
  const auto local_body = [&](int body) {
    if (body < 0) return -1;
    int& l = local[static_cast<std::size_t>(body)];
    if (l < 0) {  // a ghost
      l = static_cast<int>(p.held.size());
      p.held.push_back(body);
      Body ghost = s.bodies()[static_cast<std::size_t>(body)];
      ghost.mass = 0;
      ghost.inertia.setZero();
      ghost.stiffness = 0;
      ghost.damping = 0;
      ghost.armature = 0;
      d.bodies.push_back(std::move(ghost));
    }
    return l;
  };
  // The springs' count at a particle, over the springs this rank has read
  // (each lattice or network particle inside the owned range sees all of its
  // own; the maximum over the ranks bounds a row of K).
  std::vector<int> degree(static_cast<std::size_t>(n_held), 0);
  for (const Spring& spring : s.springs()) {
    for (int end : {spring.a.body, spring.b.body})
      if (end >= 0) ++degree[static_cast<std::size_t>(end)];
    const int owner_end = spring.a.body >= 0 ? spring.a.body : spring.b.body;
    if (owner_end < 0 || !owned(owner_end)) continue;
    Spring mine = spring;
    mine.a.body = local_body(spring.a.body);
    mine.b.body = local_body(spring.b.body);
    d.springs.push_back(mine);
  }
  for (const DeadLoad& load : s.loads())
    if (load.at.body >= 0 && owned(load.at.body)) {
      DeadLoad mine = load;
      mine.at.body = local[static_cast<std::size_t>(load.at.body)];
      d.loads.push_back(mine);
    }
  p.system.emplace(std::move(d));
  const int widest = degree.empty() ? 0 : *std::max_element(degree.begin(), degree.end());
  p.max_row = 3 * (widest + 1);
  return p;
}

// Collective: the global coordinates of the part's bodies. The owned ones
// follow the coordinates of the lower ranks (an exclusive prefix sum); each
// ghost's come from its owner, through a vector of the whole scene's bodies
// holding each body's first coordinate. Returns the scene's coordinate count.
PetscInt global_coordinates(Part& p, const System& s, const Scene& scene) {
  const System& part = *p.system;
  PetscInt mine = 0;
  for (int l = 0; l < p.owned_count; ++l) mine += part.joint_size(l);
  long long whole = mine;  // counted wide first: PETSc's indices may be 32-bit
  MPI_Allreduce(MPI_IN_PLACE, &whole, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  phase([&] {
    if (whole > static_cast<long long>(PETSC_MAX_INT))
      throw InputError(fmt::format("the scene has {} coordinates; this PETSc numbers them with {}-bit integers (at most "
                                   "{}): a PETSc configured with --with-64-bit-indices is needed",
                                   whole, 8 * sizeof(PetscInt), static_cast<long long>(PETSC_MAX_INT)));
  });
  PetscInt offset = 0, n = mine;
  MPI_Exscan(&mine, &offset, 1, MPIU_INT, MPI_SUM, MPI_COMM_WORLD);
  if (world_rank() == 0) offset = 0;
  MPI_Allreduce(MPI_IN_PLACE, &n, 1, MPIU_INT, MPI_SUM, MPI_COMM_WORLD);
  p.first_coordinate = offset;
  p.end_coordinate = offset + mine;
  MPI_Allreduce(MPI_IN_PLACE, &p.max_row, 1, MPIU_INT, MPI_MAX, MPI_COMM_WORLD);
  p.max_row = std::min(p.max_row, std::max<PetscInt>(n, 1));

  const auto global = [&](int b) {
    return static_cast<PetscInt>(scene.global_bodies.empty() ? b : scene.global_bodies[static_cast<std::size_t>(b)]);
  };
  Vec starts = nullptr, ghosts = nullptr;
  MODAL_PETSC(VecCreateMPI(PETSC_COMM_WORLD, static_cast<PetscInt>(p.end_body - p.first_body),
                           static_cast<PetscInt>(scene.total_bodies), &starts));
  std::vector<PetscInt> first(p.held.size(), 0);
  for (int l = 0, next = static_cast<int>(offset); l < p.owned_count; ++l) {
    first[static_cast<std::size_t>(l)] = next;
    MODAL_PETSC(VecSetValue(starts, global(p.held[static_cast<std::size_t>(l)]), next, INSERT_VALUES));
    next += part.joint_size(l);
  }
  MODAL_PETSC(VecAssemblyBegin(starts));
  MODAL_PETSC(VecAssemblyEnd(starts));
  std::vector<PetscInt> wanted;
  for (std::size_t l = static_cast<std::size_t>(p.owned_count); l < p.held.size(); ++l) wanted.push_back(global(p.held[l]));
  IS from = nullptr;
  VecScatter scatter = nullptr;
  MODAL_PETSC(ISCreateGeneral(PETSC_COMM_SELF, static_cast<PetscInt>(wanted.size()), wanted.data(), PETSC_COPY_VALUES, &from));
  MODAL_PETSC(VecCreateSeq(PETSC_COMM_SELF, static_cast<PetscInt>(wanted.size()), &ghosts));
  MODAL_PETSC(VecScatterCreate(starts, from, ghosts, nullptr, &scatter));
  MODAL_PETSC(VecScatterBegin(scatter, starts, ghosts, INSERT_VALUES, SCATTER_FORWARD));
  MODAL_PETSC(VecScatterEnd(scatter, starts, ghosts, INSERT_VALUES, SCATTER_FORWARD));
  const PetscScalar* values = nullptr;
  MODAL_PETSC(VecGetArrayRead(ghosts, &values));
  for (std::size_t g = 0; g < wanted.size(); ++g)
    first[static_cast<std::size_t>(p.owned_count) + g] = static_cast<PetscInt>(std::llround(values[g]));
  MODAL_PETSC(VecRestoreArrayRead(ghosts, &values));
  MODAL_PETSC(VecScatterDestroy(&scatter));
  MODAL_PETSC(ISDestroy(&from));
  MODAL_PETSC(VecDestroy(&ghosts));
  MODAL_PETSC(VecDestroy(&starts));
  p.global.clear();
  for (std::size_t l = 0; l < p.held.size(); ++l)
    for (int k = 0; k < s.joint_size(p.held[l]); ++k) p.global.push_back(first[l] + k);
  return n;
}

// The names and kinds of the whole scene's coordinates, on rank 0 (each rank
// sends its owned ones', in rank order): what the report names its values by.
void gather_coordinate_names(const Part& p, std::vector<std::string>& names, std::vector<CoordinateKind>& kinds) {
  std::string text;
  std::vector<int> mine;
  const auto& coordinates = p.system->coordinates();
  for (PetscInt c = 0; c < p.end_coordinate - p.first_coordinate; ++c) {
    text += coordinates[static_cast<std::size_t>(c)].name;
    text += '\0';
    mine.push_back(static_cast<int>(coordinates[static_cast<std::size_t>(c)].kind));
  }
  const int size = world_size(), root = world_rank() == 0;
  std::vector<int> lengths(static_cast<std::size_t>(size)), counts(static_cast<std::size_t>(size));
  const int length = static_cast<int>(text.size()), count = static_cast<int>(mine.size());
  MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  std::vector<int> at(static_cast<std::size_t>(size), 0), kind_at(static_cast<std::size_t>(size), 0);
  for (std::size_t r = 1; r < at.size(); ++r) {
    at[r] = at[r - 1] + lengths[r - 1];
    kind_at[r] = kind_at[r - 1] + counts[r - 1];
  }
  std::string all(root ? static_cast<std::size_t>(at.back() + lengths.back()) : 0, '\0');
  std::vector<int> all_kinds(root ? static_cast<std::size_t>(kind_at.back() + counts.back()) : 0);
  MPI_Gatherv(text.data(), length, MPI_CHAR, all.data(), lengths.data(), at.data(), MPI_CHAR, 0, MPI_COMM_WORLD);
  MPI_Gatherv(mine.data(), count, MPI_INT, all_kinds.data(), counts.data(), kind_at.data(), MPI_INT, 0, MPI_COMM_WORLD);
  for (std::size_t i = 0, begin = 0; i < all.size(); ++i)
    if (all[i] == '\0') {
      names.emplace_back(all, begin, i - begin);
      begin = i + 1;
    }
  for (const int k : all_kinds) kinds.push_back(static_cast<CoordinateKind>(k));
}

// ---------------------------------------------------------------- assembly

// The global vectors and matrices and the local evaluation that fills them.
struct Assembly {
  const Part* part = nullptr;
  Workspace* ws = nullptr;
  VecScatter gather = nullptr;  // global x → the local coordinates (owned and ghosts)
  Vec local = nullptr;          // sequential, part->global.size()
  std::string failure;          // a local evaluation that threw (the ranks agree on it after the solve)

  VectorX local_configuration(Vec x) {
    MODAL_PETSC(VecScatterBegin(gather, x, local, INSERT_VALUES, SCATTER_FORWARD));
    MODAL_PETSC(VecScatterEnd(gather, x, local, INSERT_VALUES, SCATTER_FORWARD));
    const PetscScalar* v = nullptr;
    MODAL_PETSC(VecGetArrayRead(local, &v));
    VectorX q = Eigen::Map<const VectorX>(v, static_cast<Eigen::Index>(part->global.size()));
    MODAL_PETSC(VecRestoreArrayRead(local, &v));
    return q;
  }
  void add_vector(Vec f, const VectorX& g) {
    MODAL_PETSC(VecSetValues(f, static_cast<PetscInt>(part->global.size()), part->global.data(), g.data(), ADD_VALUES));
  }
  void add_matrix(Mat A, const SparseMatrix& S) {
    std::vector<PetscInt> rows;
    std::vector<PetscScalar> values;
    for (Eigen::Index j = 0; j < S.outerSize(); ++j) {
      rows.clear();
      values.clear();
      for (SparseMatrix::InnerIterator it(S, j); it; ++it) {
        rows.push_back(part->global[static_cast<std::size_t>(it.row())]);
        values.push_back(it.value());
      }
      const PetscInt column = part->global[static_cast<std::size_t>(j)];
      if (!rows.empty())
        MODAL_PETSC(MatSetValues(A, static_cast<PetscInt>(rows.size()), rows.data(), 1, &column, values.data(), ADD_VALUES));
    }
  }
};

Mat create_matrix(const Part& p, PetscInt n) {
  Mat A = nullptr;
  MODAL_PETSC(MatCreate(PETSC_COMM_WORLD, &A));
  MODAL_PETSC(MatSetSizes(A, p.end_coordinate - p.first_coordinate, p.end_coordinate - p.first_coordinate, n, n));
  MODAL_PETSC(MatSetType(A, MATAIJ));
  MODAL_PETSC(MatSeqAIJSetPreallocation(A, p.max_row, nullptr));
  MODAL_PETSC(MatMPIAIJSetPreallocation(A, p.max_row, nullptr, p.max_row, nullptr));
  MODAL_PETSC(MatSetOption(A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE));
  return A;
}

PetscErrorCode form_gradient(SNES, Vec x, Vec f, void* context) {
  auto& a = *static_cast<Assembly*>(context);
  PetscErrorCode code = VecZeroEntries(f);
  if (code) return code;
  VectorX g;
  try {
    g = potential_gradient(*a.part->system, *a.ws, a.local_configuration(x));
    if (!g.allFinite()) throw NumericalError("the potential gradient ∇V is not finite on the way to the equilibrium");
  } catch (const std::exception& e) {
    // NaN makes the norm NaN on every rank: SNES stops (collectively) and the
    // ranks agree on this message afterwards.
    if (a.failure.empty()) a.failure = e.what();  // the cause; error_message adds the prefix once
    g = VectorX::Constant(static_cast<Eigen::Index>(a.part->global.size()), std::numeric_limits<double>::quiet_NaN());
  }
  a.add_vector(f, g);
  code = VecAssemblyBegin(f);
  if (code) return code;
  return VecAssemblyEnd(f);
}

PetscErrorCode form_hessian(SNES, Vec x, Mat J, Mat, void* context) {
  auto& a = *static_cast<Assembly*>(context);
  PetscErrorCode code = MatZeroEntries(J);
  if (code) return code;
  try {
    a.add_matrix(J, sparse_potential_hessian(*a.part->system, *a.ws, a.local_configuration(x)));
  } catch (const std::exception& e) {
    if (a.failure.empty()) a.failure = e.what();  // the cause; error_message adds the prefix once
  }
  code = MatAssemblyBegin(J, MAT_FINAL_ASSEMBLY);
  if (code) return code;
  return MatAssemblyEnd(J, MAT_FINAL_ASSEMBLY);
}

// The whole of a distributed vector on rank 0 (empty elsewhere).
VectorX gather_to_root(Vec v) {
  VecScatter to_zero = nullptr;
  Vec all = nullptr;
  MODAL_PETSC(VecScatterCreateToZero(v, &to_zero, &all));
  MODAL_PETSC(VecScatterBegin(to_zero, v, all, INSERT_VALUES, SCATTER_FORWARD));
  MODAL_PETSC(VecScatterEnd(to_zero, v, all, INSERT_VALUES, SCATTER_FORWARD));
  PetscInt n = 0;
  MODAL_PETSC(VecGetLocalSize(all, &n));
  const PetscScalar* values = nullptr;
  MODAL_PETSC(VecGetArrayRead(all, &values));
  VectorX out = Eigen::Map<const VectorX>(values, n);
  MODAL_PETSC(VecRestoreArrayRead(all, &values));
  MODAL_PETSC(VecScatterDestroy(&to_zero));
  MODAL_PETSC(VecDestroy(&all));
  return out;
}

// A KSP that applies one MUMPS factorization (LU or Cholesky) of its operator; its PC.
PC direct_mumps(KSP ksp, PCType type) {
  PC pc = nullptr;
  MODAL_PETSC(KSPSetType(ksp, KSPPREONLY));
  MODAL_PETSC(KSPGetPC(ksp, &pc));
  MODAL_PETSC(PCSetType(pc, type));
  MODAL_PETSC(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  return pc;
}

// Newton steps with a reused factorization (after the serial truncated
// Newton, lib/equilibrium/large.cpp): ∇∇V d = −∇V by conjugate gradients
// preconditioned with the MUMPS Cholesky factor of an earlier Hessian, to a
// relative residual η = min(0.1, ‖∇V‖/‖∇V₀‖) (at least 1e-10, below which
// rounding decides), at most 40 iterations. The factor is renewed (SNES's
// lagged preconditioner, rebuilt at the next step) after a step whose solve
// failed (breakdown on an indefinite Hessian or factor, or 40 iterations),
// and after a step whose iterations took longer than half a factorization: both
// are measured (the wall time of each KSPSolve, a renewing one holding its
// factorization), since their ratio depends on the solver and the size (MUMPS
// at 117 612 coordinates: a numeric factorization costs about 6 solves). The
// ranks agree on the decision (the largest vote), so they factor together.
struct Lagging {
  double g0 = 0;           // ‖∇V‖ at the start of the first run
  int factorizations = 0;  // fresh factors asked for
  bool renew_next = true;  // the next step factors afresh
  double target = 0;       // the accepted ‖∇V‖
  double previous = 0;     // ‖∇V‖ before the last step
  bool renewed_last = false;      // the last step factored afresh
  Clock::time_point solve_started;
  double solve_seconds = 0;       // the last KSPSolve (with its factorization when it renewed)
  double iteration_seconds = 0;   // one iteration with the factor, as last measured
  double factor_seconds = 0;      // one factorization, as last measured
};

constexpr PetscInt lagged_max_iterations = 40;

PetscErrorCode lagged_solve_starts(KSP, Vec, Vec, void* context) {
  static_cast<Lagging*>(context)->solve_started = Clock::now();
  return 0;
}
PetscErrorCode lagged_solve_ends(KSP, Vec, Vec, void* context) {
  auto& lag = *static_cast<Lagging*>(context);
  lag.solve_seconds = std::chrono::duration<double>(Clock::now() - lag.solve_started).count();
  return 0;
}

PetscErrorCode lagged_step(SNES snes, PetscInt step) {
  void* context = nullptr;
  PetscErrorCode code = SNESGetApplicationContext(snes, &context);
  if (code) return code;
  auto& lag = *static_cast<Lagging*>(context);
  KSP ksp = nullptr;
  if ((code = SNESGetKSP(snes, &ksp))) return code;
  if (step > 0) {
    PetscInt iterations = 0;
    KSPConvergedReason reason = KSP_CONVERGED_ITERATING;
    if ((code = KSPGetIterationNumber(ksp, &iterations))) return code;
    if ((code = KSPGetConvergedReason(ksp, &reason))) return code;
    int renew = reason < 0 ? 1 : 0;
    if (lag.renewed_last) {
      lag.factor_seconds = std::max(0.0, lag.solve_seconds - static_cast<double>(iterations) * lag.iteration_seconds);
    } else {
      if (iterations > 0) lag.iteration_seconds = lag.solve_seconds / static_cast<double>(iterations);
      // The next steps on this factor need at least as many iterations (it
      // only gets staler): two more such steps cost more than a factorization.
      if (2 * lag.solve_seconds > lag.factor_seconds) renew = 1;
    }
    MPI_Allreduce(MPI_IN_PLACE, &renew, 1, MPI_INT, MPI_MAX, PetscObjectComm(reinterpret_cast<PetscObject>(snes)));
    if (renew) lag.renew_next = true;
  }
  PetscReal norm = 0;
  if ((code = SNESGetFunctionNorm(snes, &norm))) return code;
  if (lag.g0 == 0) lag.g0 = norm;
  const double eta = std::max(1e-10, std::min(0.1, lag.g0 > 0 ? norm / lag.g0 : 0.1));
  if ((code = KSPSetTolerances(ksp, eta, 0.0, PETSC_DEFAULT, lagged_max_iterations))) return code;
  lag.renewed_last = lag.renew_next;
  if (lag.renew_next) {
    lag.renew_next = false;
    ++lag.factorizations;
    return SNESSetLagPreconditioner(snes, -2);  // factor at this step, then keep the factor
  }
  return SNESSetLagPreconditioner(snes, -1);
}

// SNES's own test, and a stop once ‖∇V‖ is accepted and a step no longer
// halves it: the inexact directions at the rounding level would otherwise
// keep the line search stepping in the noise.
PetscErrorCode lagged_converged(SNES snes, PetscInt step, PetscReal xnorm, PetscReal snorm, PetscReal fnorm,
                                SNESConvergedReason* reason, void* context) {
  auto& lag = *static_cast<Lagging*>(context);
  const PetscErrorCode code = SNESConvergedDefault(snes, step, xnorm, snorm, fnorm, reason, nullptr);
  if (code) return code;
  if (*reason == SNES_CONVERGED_ITERATING && step > 0 && fnorm <= lag.target && fnorm > 0.5 * lag.previous)
    *reason = SNES_CONVERGED_FNORM_ABS;
  lag.previous = fnorm;
  return 0;
}

// ---------------------------------------------------------------- inertia

// The number of eigenvalues of (K, M) below σ: the negative pivots of a MUMPS
// LDLᵀ of K − σM (ICNTL(13) = 1: no ScaLAPACK root, so every pivot is seen;
// ICNTL(24) = 1: null pivots detected, at CNTL(3) = null_threshold).
// Nothing when a pivot is null.
// A MUMPS Cholesky (LDLᵀ, with its inertia) of A = K − σM, or of K + σI
// when M is null; `factored` false when MUMPS met a problem (a null pivot).
// The caller destroys the KSP and A.
KSP mumps_cholesky(Mat K, Mat M, double sigma, Mat& A, Mat& F, bool& factored, double null_threshold) {
  MODAL_PETSC(MatDuplicate(K, MAT_COPY_VALUES, &A));
  if (M) {
    MODAL_PETSC(MatAXPY(A, -sigma, M, DIFFERENT_NONZERO_PATTERN));
  } else {
    MODAL_PETSC(MatSetOption(A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE));
    MODAL_PETSC(MatShift(A, sigma));
  }
  MODAL_PETSC(MatSetOption(A, MAT_SYMMETRIC, PETSC_TRUE));
  KSP ksp = nullptr;
  MODAL_PETSC(KSPCreate(PETSC_COMM_WORLD, &ksp));
  MODAL_PETSC(KSPSetOperators(ksp, A, A));
  PC pc = direct_mumps(ksp, PCCHOLESKY);
  MODAL_PETSC(PCFactorSetUpMatSolverType(pc));
  MODAL_PETSC(PCFactorGetMatrix(pc, &F));
  MODAL_PETSC(MatMumpsSetIcntl(F, 13, 1));
  MODAL_PETSC(MatMumpsSetIcntl(F, 24, 1));
  MODAL_PETSC(MatMumpsSetCntl(F, 3, null_threshold));
  MODAL_PETSC(KSPSetErrorIfNotConverged(ksp, PETSC_FALSE));
  MODAL_PETSC(KSPSetUp(ksp));
  MatFactorError error = MAT_FACTOR_NOERROR;
  MODAL_PETSC(MatFactorGetError(F, &error));
  factored = error == MAT_FACTOR_NOERROR;
  return ksp;
}

std::optional<PetscInt> inertia_below(Mat K, Mat M, double sigma) {
  Mat A = nullptr, F = nullptr;
  bool factored = false;
  KSP ksp = mumps_cholesky(K, M, sigma, A, F, factored, null_pivot_threshold);  // a count (modes.hpp)
  std::optional<PetscInt> result;
  if (factored) {
    PetscInt negative = 0, zero = 0, positive = 0;
    MODAL_PETSC(MatGetInertia(F, &negative, &zero, &positive));
    if (zero == 0) result = negative;
  }
  MODAL_PETSC(KSPDestroy(&ksp));
  MODAL_PETSC(MatDestroy(&A));
  return result;
}

// The inertia's count below σ, moving σ by 1e-6·max(|σ|, s) while a pivot
// is null (down, or up with direction +1; at most 8 shifts), or −1 with σ
// as it was given where every shift tried failed (the completeness checks
// and count_by_inertia then say the count was not made); inertia_near
// throws there instead.
long inertia_count(Mat K, Mat M, double& sigma, double s, int direction = -1) {
  const double given = sigma;
  for (int attempt = 0; attempt < 8; ++attempt) {
    if (const auto below = inertia_below(K, M, sigma)) return static_cast<long>(*below);
    sigma += direction * 1e-6 * std::max(std::abs(sigma), s);
  }
  sigma = given;
  return -1;
}

PetscInt inertia_near(Mat K, Mat M, double& sigma, double s, int direction = -1) {
  const long below = inertia_count(K, M, sigma, s, direction);
  if (below < 0)
    throw NumericalError(fmt::format("--backend petsc: K − σM is singular at every shift tried near σ = {:.6g}", sigma));
  return static_cast<PetscInt>(below);
}

// d = −(H + shift·I)⁻¹ r when H + shift·I is positive definite (a MUMPS
// Cholesky with no negative or zero pivot and a converged solve); false
// otherwise (collective, the same answer on every rank).
bool solve_shifted_positive(Mat H, double shift, Vec r, Vec d) {
  Mat A = nullptr, F = nullptr;
  bool factored = false;
  KSP ksp = mumps_cholesky(H, nullptr, shift, A, F, factored, 0.0);  // MUMPS's default: a solve
  bool ok = false;
  if (factored) {
    PetscInt negative = 0, zero = 0, positive = 0;
    MODAL_PETSC(MatGetInertia(F, &negative, &zero, &positive));
    if (negative == 0 && zero == 0) {
      MODAL_PETSC(KSPSolve(ksp, r, d));
      KSPConvergedReason reason = KSP_CONVERGED_ITERATING;
      MODAL_PETSC(KSPGetConvergedReason(ksp, &reason));
      PetscReal norm = 0;
      MODAL_PETSC(VecNorm(d, NORM_2, &norm));
      ok = reason >= 0 && std::isfinite(norm);
      MODAL_PETSC(VecScale(d, -1.0));
    }
  }
  MODAL_PETSC(KSPDestroy(&ksp));
  MODAL_PETSC(MatDestroy(&A));
  return ok;
}

// The peak resident memory of this process, bytes (Linux VmHWM; 0 elsewhere).
double peak_memory() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmHWM:", 0) == 0) return 1024.0 * std::strtod(line.c_str() + 6, nullptr);
  return 0;
}

// The probe of a Krylov–Schur run (as solve_sparse_modes probes its Lanczos
// runs; modal/modes.hpp, near_zero_probe): at restart `restarts` (or when
// the run converges before it), the run is given up (EPS_CONVERGED_USER,
// `stopped`) where probe_move says so of its `nev` wanted Ritz values
// λ̃ = σ + 1/θ with `floor`, and `moved` is its shift. The values
// are those of the restart before (SLEPc calls the monitor after the
// stopping test): upper bounds of the lowest eigenvalues that fall as the
// run goes on, so a stale highest under |σ|/100 is a true one, and the move
// to −λ̃_max a shift above the one the current values would give (more
// moves, not a wrong one: the inertia checks each, that K − σM stays
// positive definite where m = 0 and has m eigenvalues below σ where k > m;
// a stale lowest, where all are negative, errs the same way). The monitor and
// the test run on every rank with the same (replicated) projected problem,
// so every rank decides alike.
struct ProbeWatch {
  PetscInt nev = 0;
  PetscInt restarts = 0;
  double sigma = 0;
  double floor = 0;
  std::vector<double> values;  // the latest Ritz values λ̃ of the wanted
  bool stopped = false;
  double moved = 0;  // probe_move's shift, where stopped
};

PetscErrorCode watch_ritz_values(EPS eps, PetscInt, PetscInt, PetscScalar* eigr, PetscScalar* eigi, PetscReal*,
                                 PetscInt nest, void* context) {
  auto& watch = *static_cast<ProbeWatch*>(context);
  ST st = nullptr;
  if (const PetscErrorCode code = EPSGetST(eps, &st)) return code;
  watch.values.clear();
  for (PetscInt i = 0; i < std::min(nest, watch.nev); ++i) {
    PetscScalar re = eigr[i], im = eigi[i];
    if (const PetscErrorCode code = STBackTransform(st, 1, &re, &im)) return code;
    watch.values.push_back(static_cast<double>(re));
  }
  return 0;
}

PetscErrorCode probe_stops(EPS eps, PetscInt its, PetscInt max_it, PetscInt nconv, PetscInt nev,
                           EPSConvergedReason* reason, void* context) {
  if (const PetscErrorCode code = EPSStoppingBasic(eps, its, max_it, nconv, nev, reason, nullptr)) return code;
  auto& watch = *static_cast<ProbeWatch*>(context);
  const bool at_probe = its == watch.restarts || (*reason == EPS_CONVERGED_TOL && its < watch.restarts);
  if (!at_probe || static_cast<PetscInt>(watch.values.size()) < watch.nev) return 0;
  const auto [lowest, highest] = std::minmax_element(watch.values.begin(), watch.values.end());
  if (const std::optional<double> to = probe_move(*lowest, *highest, watch.sigma, watch.floor)) {
    *reason = EPS_CONVERGED_USER;
    watch.stopped = true;
    watch.moved = *to;
  }
  return 0;
}

// Vectors of K's layout, destroyed with their owner.
struct OwnedVecs {
  std::vector<std::unique_ptr<Vec>> vecs;
  Vec& add(Mat like) {
    vecs.push_back(std::make_unique<Vec>(nullptr));
    MODAL_PETSC(MatCreateVecs(like, vecs.back().get(), nullptr));
    return *vecs.back();
  }
  OwnedVecs() = default;
  OwnedVecs(const OwnedVecs&) = delete;
  OwnedVecs& operator=(const OwnedVecs&) = delete;
  ~OwnedVecs() {
    for (auto& v : vecs)
      if (*v) VecDestroy(v.get());
  }
};

struct Timings {
  std::vector<std::pair<std::string, double>> seconds;
  Clock::time_point last = Clock::now();
  void mark(const std::string& name) {
    const auto now = Clock::now();
    seconds.emplace_back(name, std::chrono::duration<double>(now - last).count());
    last = now;
  }
};

}  // namespace

// ---------------------------------------------------------------- session

DistributedSession::DistributedSession() {
  if (SlepcInitializeNoArguments() != 0) throw std::runtime_error("modal-mpi: MPI, PETSc and SLEPc could not start");
  PetscPopSignalHandler();  // modal's own handlers (removing partial outputs) stay
  PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);  // errors come back as codes, printed by modal
  rank_ = world_rank();
  size_ = world_size();
}

DistributedSession::~DistributedSession() { SlepcFinalize(); }

// ---------------------------------------------------------------- analysis

namespace {

// Keeps the `count` lowest of `numbers` (a stable order: equal ones as they
// came) with their shapes and, where given, their vectors; the vectors not
// kept are destroyed.
template <class Sums>
void keep_lowest(std::size_t count, std::vector<std::pair<double, Sums>>& numbers, std::vector<VectorX>& shapes,
                 std::vector<Vec>* vectors = nullptr) {
  std::vector<std::size_t> order(numbers.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t i, std::size_t j) { return numbers[i].first < numbers[j].first; });
  std::vector<std::pair<double, Sums>> kept_numbers;
  std::vector<VectorX> kept_shapes;
  std::vector<Vec> kept_vectors;
  for (std::size_t j = 0; j < order.size(); ++j) {
    const std::size_t i = order[j];
    if (j < count) {
      kept_numbers.push_back(numbers[i]);
      kept_shapes.push_back(std::move(shapes[i]));
      if (vectors != nullptr) kept_vectors.push_back((*vectors)[i]);
    } else if (vectors != nullptr) {
      MODAL_PETSC(VecDestroy(&(*vectors)[i]));
    }
  }
  numbers = std::move(kept_numbers);
  shapes = std::move(kept_shapes);
  if (vectors != nullptr) *vectors = std::move(kept_vectors);
}

// The PETSc and SLEPc objects of one point, released with it.
struct PointSolver {
  Part part;
  std::optional<Workspace> ws;
  Assembly assembly;
  Vec x = nullptr, f = nullptr;
  Mat J = nullptr, K = nullptr, M = nullptr, F = nullptr;  // F: K's rounding form (sparse_rounding_form)
  Mat K_abs = nullptr, K_square = nullptr;                  // |K_ij| and T_ij², T the sizes of K's terms (the modes' sums)
  std::vector<Vec> found;                                   // the modes' vectors, M-normalized
  std::vector<Vec> negatives;  // with k > m: the m eigenvectors below σ₀ from a shift below the spectrum
  SNES snes = nullptr;
  EPS eps_solver = nullptr;
  PointSolver() = default;
  PointSolver(const PointSolver&) = delete;
  PointSolver& operator=(const PointSolver&) = delete;
  ~PointSolver() {
    if (assembly.gather) VecScatterDestroy(&assembly.gather);
    for (Vec* v : {&assembly.local, &x, &f})
      if (*v) VecDestroy(v);
    for (std::vector<Vec>* vectors : {&found, &negatives})
      for (Vec& v : *vectors) VecDestroy(&v);
    for (Mat* A : {&J, &K, &M, &F, &K_abs, &K_square})
      if (*A) MatDestroy(A);
    if (snes) SNESDestroy(&snes);
    if (eps_solver) EPSDestroy(&eps_solver);
  }
};

struct Point {
  Equilibrium eq;
  ModalResult result;
  long long coordinates = 0;  // of the whole scene
};

// Where solve_point leaves the equilibrium and the shapes: the whole on rank 0
// (a report), or each rank's owned coordinates of q and no shapes (a sweep,
// whose next point starts from q and which reports no shapes: no rank holds
// the whole).
enum class Gathered { root, owned };

// The equilibrium and lowest modes of the scene whose part this rank holds
// (`held`, read from `scene`: distributed generation), over the ranks
// (collective; a failure on any rank throws Agreed on all), from `start`:
// this rank's owned coordinates of a configuration (the sweep's previous
// point, as Gathered::owned left it) or empty (the scene's initial
// configuration, also taken on every rank when the start does not fit on
// some rank: the scene's size changed). `numbered` is called on every rank
// once the coordinates are numbered (collective work such as gathering names
// may go there). eq.q and the shapes as `gathered` says; the modes' numbers,
// Morse index, zero modes and class on every rank.
Point solve_point(const System& held, const Scene& scene, const VectorX& start, const AnalysisOptions& options,
                  Gathered gathered, Timings& timings, const std::function<void(const Part&)>& numbered = {}) {
  const int rank = world_rank(), size = world_size();
  PetscInt n = 0;
  PointSolver solver;
  Part& part = solver.part;
  std::optional<Workspace>& ws = solver.ws;
  Assembly& assembly = solver.assembly;
  Vec &x = solver.x, &f = solver.f;
  Mat &J = solver.J, &K = solver.K, &M = solver.M, &F = solver.F, &K_abs = solver.K_abs, &K_square = solver.K_square;
  SNES& snes = solver.snes;
  EPS& eps_solver = solver.eps_solver;
  {  // the phases, in order; each agreed on by the ranks

    phase([&] {
      part = partition(held, scene);
      ws.emplace(*part.system);
    });
    n = global_coordinates(part, held, scene);
    if (numbered) numbered(part);
    int fits = start.size() > 0 && start.size() == part.end_coordinate - part.first_coordinate;
    MPI_Allreduce(MPI_IN_PLACE, &fits, 1, MPI_INT, MPI_LAND, MPI_COMM_WORLD);
    phase([&] {  // collective from here on: nothing rank-local throws before the PETSc calls
      assembly.part = &part;
      assembly.ws = &*ws;
      MODAL_PETSC(VecCreateMPI(PETSC_COMM_WORLD, part.end_coordinate - part.first_coordinate, n, &x));
      MODAL_PETSC(VecDuplicate(x, &f));
      MODAL_PETSC(VecCreateSeq(PETSC_COMM_SELF, static_cast<PetscInt>(part.global.size()), &assembly.local));
      IS from = nullptr;
      MODAL_PETSC(ISCreateGeneral(PETSC_COMM_SELF, static_cast<PetscInt>(part.global.size()), part.global.data(),
                                  PETSC_COPY_VALUES, &from));
      MODAL_PETSC(VecScatterCreate(x, from, assembly.local, nullptr, &assembly.gather));
      MODAL_PETSC(ISDestroy(&from));
      const VectorX q0 = fits ? start : part.system->initial_configuration();  // the owned coordinates first
      for (PetscInt i = part.first_coordinate; i < part.end_coordinate; ++i)
        MODAL_PETSC(VecSetValue(x, i, q0(i - part.first_coordinate), INSERT_VALUES));
      MODAL_PETSC(VecAssemblyBegin(x));
      MODAL_PETSC(VecAssemblyEnd(x));
      J = create_matrix(part, n);
    });
    timings.mark("partition");

    // ---- equilibrium: Newton with a line search, then with a trust region
    Equilibrium eq;
    // The force scales at a configuration, summed over the ranks' parts (the
    // rounding scale, a 2-norm, in 2-norm).
    const auto scales_at = [&](Vec at) {
      const VectorX q = assembly.local_configuration(at);
      const std::array<double, 3> sum = sum_over_ranks([&] {
        const ForceScales mine = force_scales(*part.system, *ws, q);
        return std::array<double, 3>{mine.full, mine.acting, mine.rounding * mine.rounding};
      });
      return ForceScales{sum[0], sum[1], std::sqrt(sum[2])};
    };
    double scale = 0;  // force_scale at the start
    phase([&] {
      scale = scales_at(x).full;
      const double tolerance = options.equilibrium_tolerance;
      // The Newton runs' target (against the start's force scale), and the
      // acceptance: the serial relative residual (modal::relative_residual:
      // beyond the rounding level, against the acting forces) at the point.
      const double target = tolerance * scale;
      const auto balanced = [&](Vec at, double rnorm) {
        return std::isfinite(rnorm) && relative_residual(rnorm, scales_at(at)) <= tolerance;
      };
      Vec start = nullptr;
      MODAL_PETSC(VecDuplicate(x, &start));
      MODAL_PETSC(VecCopy(x, start));
      PetscReal norm = std::numeric_limits<double>::infinity();
      PetscInt iterations = 0;
      Lagging lag;
      lag.target = target;
      KSP reused = nullptr;  // the lagged runs' KSP, whose factor the polish keeps
      // One Newton run from x: SNES `type`, line search `search` (line-search
      // Newton only); ‖∇V‖ after it in `norm`, its steps added to `iterations`.
      // `lagged`: conjugate gradients with a reused factor (Lagging), else a
      // fresh MUMPS LU at every step.
      const auto newton = [&](SNESType type, SNESLineSearchType search, PetscInt max_steps, bool lagged) {
        MODAL_PETSC(SNESCreate(PETSC_COMM_WORLD, &snes));
        MODAL_PETSC(SNESSetType(snes, type));
        MODAL_PETSC(SNESSetFunction(snes, f, form_gradient, &assembly));
        MODAL_PETSC(SNESSetJacobian(snes, J, J, form_hessian, &assembly));
        MODAL_PETSC(SNESSetTolerances(snes, 1e-3 * eps * scale, 0.0, 0.0, max_steps, 100000));
        if (lagged) {
          if (!reused) {
            MODAL_PETSC(KSPCreate(PETSC_COMM_WORLD, &reused));
            direct_mumps(reused, PCCHOLESKY);
            MODAL_PETSC(KSPSetType(reused, KSPCG));
            MODAL_PETSC(KSPSetPreSolve(reused, lagged_solve_starts, &lag));
            MODAL_PETSC(KSPSetPostSolve(reused, lagged_solve_ends, &lag));
          }
          MODAL_PETSC(SNESSetKSP(snes, reused));
          MODAL_PETSC(SNESSetApplicationContext(snes, &lag));
          MODAL_PETSC(SNESSetUpdate(snes, lagged_step));
          MODAL_PETSC(SNESSetMaxLinearSolveFailures(snes, max_steps));  // a failed solve renews the factor
          MODAL_PETSC(SNESSetConvergenceTest(snes, lagged_converged, &lag, nullptr));
        } else {
          KSP ksp = nullptr;
          MODAL_PETSC(SNESGetKSP(snes, &ksp));
          direct_mumps(ksp, PCLU);
        }
        if (search) {
          SNESLineSearch line = nullptr;
          MODAL_PETSC(SNESGetLineSearch(snes, &line));
          MODAL_PETSC(SNESLineSearchSetType(line, search));
        }
        MODAL_PETSC(SNESSetFromOptions(snes));  // PETSC_OPTIONS may change any of the above
        MODAL_PETSC(SNESSolve(snes, nullptr, x));
        PetscInt steps = 0;
        MODAL_PETSC(SNESGetIterationNumber(snes, &steps));
        iterations += steps;
        MODAL_PETSC(SNESDestroy(&snes));
        MODAL_PETSC(form_gradient(nullptr, x, f, &assembly));
        MODAL_PETSC(VecNorm(f, NORM_2, &norm));
      };
      const auto converged = [&] { return std::isfinite(norm) && norm <= target; };
      // ∇V is a gradient: the critical-point line search (the step along the
      // Newton direction d where ∇V·d vanishes, by secants) shortens the first
      // steps from a flat or slack start without the many short steps of
      // backtracking on ‖∇V‖ (a 10 092-coordinate sagging net: 5 Newton steps
      // against 23). It may stop short of the rounding level, so a polish with
      // backtracking follows, which takes full steps there and stops when a
      // step no longer decreases ‖∇V‖ (as the serial polish), at most 3. The
      // steps reuse a factorization (Lagging); if that run fails, the same
      // with a fresh LU at every step from the same start, then a trust region.
      MODAL_PETSC(MatSetOption(J, MAT_SYMMETRIC, PETSC_TRUE));
      MODAL_PETSC(MatSetOption(J, MAT_SYMMETRY_ETERNAL, PETSC_TRUE));
      // Damped Newton (Levenberg–Marquardt on V) from x, as the serial large
      // equilibrium's (lib/equilibrium/large.cpp, docs/design.md "Equilibria
      // of large scenes"): for degenerate starts, where ∇∇V is singular or
      // indefinite (a slack net's flat start has no stiffness out of its
      // plane) and a Newton step overshoots. Each step solves
      // (∇∇V + μhI) d = −∇V by a MUMPS Cholesky that must be positive
      // definite (h: the mean |diagonal| of ∇∇V), takes it when V falls by
      // more than 10⁻⁴ of the decrease the quadratic model predicts, and
      // moves μ by Nielsen's rule; it hands over to Newton once μ < 10⁻³ and
      // ‖∇V‖ has fallen 10³-fold.
      int damped_steps = 0;
      const auto damped = [&] {
        const auto energy = [&](Vec at) {
          const VectorX q = assembly.local_configuration(at);
          return sum_over_ranks([&] { return potential(*part.system, *ws, q); });
        };
        double length = part.system->length_scale();
        MPI_Allreduce(MPI_IN_PLACE, &length, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
        Vec d = nullptr, trial = nullptr, g = nullptr, diagonal = nullptr;
        MODAL_PETSC(VecDuplicate(x, &d));
        MODAL_PETSC(VecDuplicate(x, &trial));
        MODAL_PETSC(VecDuplicate(x, &g));
        MODAL_PETSC(VecDuplicate(x, &diagonal));
        MODAL_PETSC(form_gradient(nullptr, x, f, &assembly));
        PetscReal rnorm = 0;
        MODAL_PETSC(VecNorm(f, NORM_2, &rnorm));
        const double r0 = rnorm;
        double v = energy(x);
        NielsenDamping damping;
        double& mu = damping.mu;
        for (int it = 0; it < 200 && std::isfinite(rnorm) && !balanced(x, rnorm); ++it) {
          if (mu >= 0 && mu < 1e-3 && rnorm < 1e-3 * r0) break;  // Newton's region
          MODAL_PETSC(form_hessian(nullptr, x, J, J, &assembly));
          MODAL_PETSC(MatGetDiagonal(J, diagonal));
          MODAL_PETSC(VecAbs(diagonal));
          PetscScalar sum = 0;
          MODAL_PETSC(VecSum(diagonal, &sum));
          const double h = std::max(static_cast<double>(sum) / static_cast<double>(n), std::numeric_limits<double>::min());
          if (mu < 0) {
            PetscReal largest = 0;
            MODAL_PETSC(VecNorm(f, NORM_INFINITY, &largest));
            mu = std::max(largest / (h * 1e-3 * length), 1e-10);
          }
          bool solved = false;
          for (int tries = 0; tries < 60 && !solved; ++tries) {
            solved = solve_shifted_positive(J, mu * h, f, d);
            if (!solved) mu = std::max(4 * mu, 1e-10);
          }
          if (!solved) break;
          ++damped_steps;
          PetscScalar rd = 0, dd = 0;
          MODAL_PETSC(VecDot(f, d, &rd));
          MODAL_PETSC(VecDot(d, d, &dd));
          // −(rᵀd + ½dᵀ∇∇V d), with (∇∇V + μhI)d = −r
          const double predicted = -0.5 * rd + 0.5 * mu * h * dd;
          MODAL_PETSC(VecWAXPY(trial, 1.0, d, x));
          double vt = std::numeric_limits<double>::infinity();
          try {
            vt = energy(trial);
          } catch (const Agreed&) {  // every rank: a configuration some element cannot take
          }
          double rho = predicted > 0 && std::isfinite(vt) ? (v - vt) / predicted : -1;
          if (NielsenDamping::taken(rho)) {
            MODAL_PETSC(form_gradient(nullptr, trial, g, &assembly));
            PetscReal gnorm = 0;
            MODAL_PETSC(VecNorm(g, NORM_2, &gnorm));
            if (std::isfinite(gnorm)) {
              MODAL_PETSC(VecCopy(trial, x));
              MODAL_PETSC(VecCopy(g, f));
              rnorm = gnorm;
              v = vt;
            } else {
              rho = -1;
            }
          }
          damping.update(rho);
        }
        assembly.failure.clear();  // failed trial points were refused above
        for (Vec* w : {&d, &trial, &g, &diagonal}) MODAL_PETSC(VecDestroy(w));
      };
      std::string method = "line search", solves;
      // A run that reached the target is polished (Newton from there reaches
      // the rounding level in one or two steps) and accepted when balanced.
      // A flat slack start can be within the target (its weight against the
      // springs' forces at 100 % strain) and not balanced: then the damped
      // steps below.
      const auto accepted = [&](bool with_lag) {
        if (!converged()) return false;
        newton(SNESNEWTONLS, SNESLINESEARCHBT, 3, with_lag);
        return converged() && balanced(x, norm);
      };
      newton(SNESNEWTONLS, SNESLINESEARCHCP, 100, true);
      bool lagged = accepted(true);
      if (!lagged) {
        const std::string cause = assembly.failure;
        assembly.failure.clear();
        MODAL_PETSC(VecCopy(start, x));
        iterations = 0;
        damped();  // a degenerate start: damped steps first, then Newton
        newton(SNESNEWTONLS, SNESLINESEARCHCP, 100, false);
        bool done = accepted(false);
        if (!done && damped_steps > 0) {  // from the start, undamped
          MODAL_PETSC(VecCopy(start, x));
          iterations = 0;
          damped_steps = 0;
          newton(SNESNEWTONLS, SNESLINESEARCHCP, 100, false);
          done = accepted(false);
        }
        if (!done) {
          MODAL_PETSC(VecCopy(start, x));
          iterations = 0;
          newton(SNESNEWTONTR, nullptr, 100, false);
          method = "trust region";
          done = accepted(false);
        }
        if (!done && assembly.failure.empty()) assembly.failure = cause;
      }
      if (reused) MODAL_PETSC(KSPDestroy(&reused));
      solves = lagged ? fmt::format("conjugate gradients preconditioned by a reused MUMPS Cholesky factor, {} "
                                    "factorization{}",
                                    lag.factorizations, lag.factorizations == 1 ? "" : "s")
                      : std::string("MUMPS LU");
      MODAL_PETSC(VecDestroy(&start));
      eq.iterations = static_cast<int>(iterations);
      eq.method = fmt::format("{}Newton with a {} (PETSc SNES, {}) over {} rank{}",
                              damped_steps > 0 ? fmt::format("damped Newton ({} steps), then ", damped_steps) : "",
                              method, solves, size, size == 1 ? "" : "s");
      eq.residual_norm = norm;
      // The cause first: an evaluation that failed on some rank (the others
      // only saw a NaN residual).
      if (!assembly.failure.empty()) throw NumericalError(assembly.failure);
    });
    phase([&] {
      const double tolerance = options.equilibrium_tolerance, norm = eq.residual_norm;
      const ForceScales at = scales_at(x);
      const double relative = at.full > 0 ? relative_residual(norm, at) : norm;
      if (!(relative <= tolerance))
        throw NumericalError(fmt::format("--backend petsc: Newton's method (PETSc SNES, line search and then trust "
                                         "region) did not reach an equilibrium from the scene's configuration: "
                                         "relative residual {:.2e}, accepted {:.0e}",
                                         relative, tolerance));
      eq.residual = relative;
      const VectorX q = assembly.local_configuration(x);
      eq.potential = sum_over_ranks([&] { return potential(*part.system, *ws, q); });
    });
    timings.mark("equilibrium");

    // ---- K and M at the equilibrium
    phase([&] {
      K = create_matrix(part, n);
      MODAL_PETSC(form_hessian(nullptr, x, K, K, &assembly));
      if (!assembly.failure.empty()) throw NumericalError(assembly.failure);
      M = create_matrix(part, n);
      const VectorX q = assembly.local_configuration(x);
      SparseMatrix local_mass;
      phase([&] { local_mass = sparse_mass_matrix(*part.system, *ws, q); });
      assembly.add_matrix(M, local_mass);
      // K's rounding form, the positions' rounding included (positive
      // semidefinite, each rank's springs): the kinds are decided with it, as
      // on the serial sparse path (an empty local form adds nothing).
      F = create_matrix(part, n);
      SparseMatrix local_form;
      phase([&] { local_form = sparse_rounding_form(*part.system, *ws, q); });
      assembly.add_matrix(F, local_form);
      // The sizes of K's terms (Σ|terms| of each entry, summed over the
      // ranks' parts), in K_square's place until the modes' phase squares
      // them: K's entries are rounded at these sizes, far above |K_ij| where
      // a spring's terms cancel (the transverse k(1 − L₀/L) at a small
      // prestrain p carries ε/p of itself), as on the serial sparse path
      // (SparseModalOptions::K_magnitude). With K's own entries, generated
      // nets at p = 3e-7 … 6e-12 had estimates 1e4–1e9 × below their true
      // errors (tests/distributed/prestrained_nets.py).
      K_square = create_matrix(part, n);
      {
        SparseMatrix local_terms;
        phase([&] { local_terms = sparse_potential_hessian_magnitude(*part.system, *ws, q); });
        assembly.add_matrix(K_square, local_terms);
      }
      for (Mat A : {M, F, K_square}) {
        MODAL_PETSC(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
        MODAL_PETSC(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
      }
      for (Mat A : {K, M, F}) MODAL_PETSC(MatSetOption(A, MAT_SYMMETRIC, PETSC_TRUE));
    });
    timings.mark("assembly");

    // ---- the lowest modes
    ModalResult result;
    std::vector<VectorX> shapes;  // rank 0
    std::vector<std::pair<double, QuotientSums>> numbers;  // λ and its sums (quotient_mode) per mode
    phase([&] {
      const auto started = Clock::now();
      OwnedVecs work;  // this phase's vectors, destroyed with it (also on a throw)
      Vec &dk = work.add(K), &dm = work.add(K);
      MODAL_PETSC(MatGetDiagonal(K, dk));
      MODAL_PETSC(MatGetDiagonal(M, dm));
      PetscReal min_mass = 0;
      MODAL_PETSC(VecMin(dm, nullptr, &min_mass));
      if (!(min_mass > 0))
        throw SingularMassMatrix("--backend petsc: a particle coordinate has no mass (M is singular)");
      // The shift rule of solve_sparse_modes: s = max K_ii/M_ii (then max |K_ii|/M_ii, then 1), ζ = 1e-8·s.
      Vec ratio = nullptr;
      MODAL_PETSC(VecDuplicate(dk, &ratio));
      MODAL_PETSC(VecPointwiseDivide(ratio, dk, dm));
      PetscReal s = 0;
      MODAL_PETSC(VecMax(ratio, nullptr, &s));
      if (!(s > 0)) {
        MODAL_PETSC(VecAbs(ratio));
        MODAL_PETSC(VecMax(ratio, nullptr, &s));
      }
      if (!(s > 0)) s = 1;
      MODAL_PETSC(VecDestroy(&ratio));
      const double zeta = zero_margin * s;
      double s0 = -zeta;
      const PetscInt m = inertia_near(K, M, s0, s);
      const PetscInt k = std::min<PetscInt>(options.modes > 0 ? options.modes : 10, n);
      // Where SLEPc looks: the user's shift; σ₀ when no eigenvalue lies below
      // it; else, for the min(k, m) lowest (all below σ₀), a shift below
      // the whole spectrum, found from the inertia alone (down by factors of
      // 4, then up by bisection until it is within a quarter of its distance
      // to σ₀ below λ₁), so that the ones nearest it are the lowest (with
      // k > m, placed when first needed: the runs at σ₀ below may find all m).
      double target = s0;
      std::string where = "σ₀ = −ζ";
      const auto below_spectrum = [&] {
        double low = zeta, high = 0;  // distances below σ₀: low fails (eigenvalues below), high succeeds
        for (int tries = 0;; ++tries) {
          if (tries > 200) throw NumericalError("--backend petsc: no shift below the spectrum was found");
          double sigma = s0 - 4 * low;
          if (inertia_near(K, M, sigma, s) == 0) {
            high = s0 - sigma;
            break;
          }
          low = s0 - sigma;
        }
        while (high - low > 0.25 * high) {
          const double mid = 0.5 * (low + high);
          double sigma = s0 - mid;
          if (inertia_near(K, M, sigma, s) == 0) high = s0 - sigma;
          else low = mid;
        }
        return s0 - high;
      };
      if (options.shift) {
        target = *options.shift;
        where = "the shift";
      } else if (m > 0 && k <= m) {
        target = below_spectrum();
        where = "a shift below the spectrum";
      }
      // |K_ij| and T_ij² for T the sizes of K's terms (quotient_mode's
      // sums: the products' rounding is the stored entries', the entries'
      // own rounding their terms'), and the most nonzeros in a row of K (M
      // is diagonal): the terms of an entry of Kφ.
      double width = 1;
      {
        Mat terms_matrix = K_square;  // T, as the assembly left it
        K_square = nullptr;
        struct Owned {  // destroyed with this block, also on a throw
          Mat& A;
          ~Owned() {
            if (A) MatDestroy(&A);
          }
        } owned{terms_matrix};
        MODAL_PETSC(MatDuplicate(K, MAT_DO_NOT_COPY_VALUES, &K_abs));
        MODAL_PETSC(MatDuplicate(terms_matrix, MAT_DO_NOT_COPY_VALUES, &K_square));
        PetscInt first = 0, end = 0;
        MODAL_PETSC(MatGetOwnershipRange(K, &first, &end));
        std::vector<PetscScalar> entries;
        std::vector<PetscInt> kept;
        // A's row, each entry mapped, into B's row.
        const auto map_row = [&](Mat A, Mat B, PetscInt row, auto&& map) {
          PetscInt count = 0;
          const PetscInt* columns = nullptr;
          const PetscScalar* values = nullptr;
          MODAL_PETSC(MatGetRow(A, row, &count, &columns, &values));
          entries.resize(static_cast<std::size_t>(count));
          for (PetscInt j = 0; j < count; ++j) entries[static_cast<std::size_t>(j)] = map(values[j]);
          kept.assign(columns, columns + count);
          // (MatRestoreRow sets its count to 0: the row's is kept before.
          // Reading it afterwards had left |K| and K∘K all zero here.)
          const PetscInt kept_count = count;
          MODAL_PETSC(MatRestoreRow(A, row, &count, &columns, &values));
          MODAL_PETSC(MatSetValues(B, 1, &row, kept_count, kept.data(), entries.data(), INSERT_VALUES));
          return kept_count;
        };
        for (PetscInt row = first; row < end; ++row) {
          const PetscInt count = map_row(K, K_abs, row, [](PetscScalar v) { return std::abs(v); });
          width = std::max(width, static_cast<double>(count));
          map_row(terms_matrix, K_square, row, [](PetscScalar v) { return v * v; });
        }
        for (Mat A : {K_abs, K_square}) {
          MODAL_PETSC(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
          MODAL_PETSC(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
        }
        MPI_Allreduce(MPI_IN_PLACE, &width, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
      }
      const auto factored = Clock::now();
      int moves = 0;  // of the shift, by the probe below
      // The workspace of the modes' sums, and take_mode: φ M-normalized in
      // place, λ its Rayleigh quotient and quotient_mode's sums kept in
      // `numbers`, its shape (as `gathered` says) in `shapes` and a copy of
      // φ in `found`.
      Vec& phi = work.add(K);
      Vec &Kphi = work.add(K), &Mphi = work.add(K), &r = work.add(K), &a = work.add(K), &w = work.add(K),
          &terms = work.add(K);
      std::vector<Vec>& found = solver.found;
      const auto sum_of = [&](Vec v) {  // Σ v_i
        PetscScalar sum = 0;
        MODAL_PETSC(VecSum(v, &sum));
        return static_cast<double>(sum);
      };
      const auto dot = [&](Vec u, Vec v) {
        PetscScalar d = 0;
        MODAL_PETSC(VecDot(u, v, &d));
        return static_cast<double>(d);
      };
      const auto abs_dot = [&](Vec u, Vec v) {  // Σ|u_i v_i| (w as workspace)
        MODAL_PETSC(VecPointwiseMult(w, u, v));
        MODAL_PETSC(VecAbs(w));
        return sum_of(w);
      };
      const auto product_norm = [&](Vec u, Vec v) {  // ‖u ∘ v‖₂
        MODAL_PETSC(VecPointwiseMult(w, u, v));
        PetscReal norm = 0;
        MODAL_PETSC(VecNorm(w, NORM_2, &norm));
        return static_cast<double>(norm);
      };
      const auto inverse_mass_norm = [&](Vec v) {  // ‖v‖_{M⁻¹}, M diagonal
        MODAL_PETSC(VecPointwiseMult(w, v, v));
        MODAL_PETSC(VecPointwiseDivide(w, w, dm));
        return std::sqrt(std::max(0.0, sum_of(w)));
      };
      const auto take_mode = [&](Vec phi) {
        // φ M-normalized, λ its Rayleigh quotient, r = Kφ − λMφ; the sums
        // of quotient_mode as solve_sparse_modes forms them (M diagonal:
        // |M| = M, and F, |K| and T∘T summed over the ranks' parts).
        MODAL_PETSC(MatMult(M, phi, Mphi));
        const double unit = 1.0 / std::sqrt(dot(phi, Mphi));
        MODAL_PETSC(VecScale(phi, unit));
        MODAL_PETSC(VecScale(Mphi, unit));
        MODAL_PETSC(MatMult(K, phi, Kphi));
        const double lambda = dot(phi, Kphi);
        MODAL_PETSC(VecWAXPY(r, -lambda, Mphi, Kphi));
        QuotientSums sums;
        sums.width = width;
        sums.n = static_cast<double>(n);
        MODAL_PETSC(VecCopy(phi, a));
        MODAL_PETSC(VecAbs(a));
        MODAL_PETSC(MatMult(K_abs, a, terms));  // |K|a
        const double error = inverse_mass_norm(r);
        sums.rows = product_norm(a, terms);
        sums.quotient_terms = dot(a, terms);
        MODAL_PETSC(MatMult(M, a, Kphi));  // |M|a in Kphi's place (Kφ no longer needed after the sums below)
        sums.rows += std::abs(lambda) * product_norm(a, Kphi);
        const double aMa = dot(a, Kphi);
        sums.quotient_terms += std::abs(lambda) * aMa;
        MODAL_PETSC(VecAXPY(terms, std::abs(lambda), Kphi));  // |K|a + |λ||M|a
        const double r_rounding = eps * inverse_mass_norm(terms);
        sums.residual = error + std::sqrt(width + 2) * r_rounding;
        sums.residual_worst = error + (width + 2) * r_rounding;
        MODAL_PETSC(MatMult(K, phi, Kphi));
        sums.sums_K = abs_dot(phi, Kphi);
        sums.sums_M = abs_dot(phi, Mphi);
        // (Σ(T_ij φ_i φ_j)²)^½ = ((φ∘φ)ᵀ(T∘T)(φ∘φ))^½, and with M (diagonal)
        MODAL_PETSC(VecPointwiseMult(a, phi, phi));
        MODAL_PETSC(MatMult(K_square, a, terms));
        const double K2 = dot(a, terms);
        const double M2 = product_norm(a, dm);
        MODAL_PETSC(MatMult(F, phi, terms));
        const double form = std::max(0.0, dot(phi, terms));
        sums.entries = std::min(std::sqrt(std::max(0.0, K2)), form) + std::abs(lambda) * M2;
        // The kind's data level as the serial sparse path's: φᵀFφ (F with
        // the positions' rounding; ‖K‖₁ alone had generated rest-length
        // nets 10–1e4 spacings from the origin called divergent, 9 of 10,
        // and called zero every resolved lowest mode of a chain of
        // particles whose masses span 12 decades).
        sums.data = form + std::abs(lambda) * aMa;
        numbers.emplace_back(lambda, sums);
        shapes.push_back(gathered == Gathered::root ? gather_to_root(phi) : VectorX::Zero(1));
        found.push_back(nullptr);
        MODAL_PETSC(VecDuplicate(phi, &found.back()));
        MODAL_PETSC(VecCopy(phi, found.back()));
      };
      // One Krylov–Schur run for the `nev` eigenpairs nearest the target:
      // their numbers and (as `gathered` says) shapes, in place of the last
      // run's; false (and nothing kept) when `probe` gave the run up. With
      // `each`, it gets the pairs (λ, φ) instead of take_mode and the
      // numbers are left as they were; with `start`, the run starts from it.
      bool short_run = false;  // a check run converged fewer pairs than it asked for
      const auto solve_nearest = [&](PetscInt nev, ProbeWatch* probe, Vec start = nullptr,
                                     const std::function<void(double, Vec)>& each = {}) {
        if (!each) {
          numbers.clear();
          shapes.clear();
          for (Vec& v : found) MODAL_PETSC(VecDestroy(&v));
          found.clear();
        }
        MODAL_PETSC(EPSCreate(PETSC_COMM_WORLD, &eps_solver));
        if (start) MODAL_PETSC(EPSSetInitialSpace(eps_solver, 1, &start));
        MODAL_PETSC(EPSSetOperators(eps_solver, K, M));
        MODAL_PETSC(EPSSetProblemType(eps_solver, EPS_GHEP));
        MODAL_PETSC(EPSSetType(eps_solver, EPSKRYLOVSCHUR));
        MODAL_PETSC(EPSSetDimensions(eps_solver, nev, PETSC_DEFAULT, PETSC_DEFAULT));
        MODAL_PETSC(EPSSetTolerances(eps_solver, options.tolerance, 1000));
        MODAL_PETSC(EPSSetTarget(eps_solver, target));
        MODAL_PETSC(EPSSetWhichEigenpairs(eps_solver, EPS_TARGET_MAGNITUDE));
        ST st = nullptr;
        KSP ksp = nullptr;
        MODAL_PETSC(EPSGetST(eps_solver, &st));
        MODAL_PETSC(STSetType(st, STSINVERT));
        MODAL_PETSC(STGetKSP(st, &ksp));
        direct_mumps(ksp, PCCHOLESKY);
        if (probe) {
          probe->sigma = target;
          MODAL_PETSC(EPSMonitorSet(eps_solver, watch_ritz_values, probe, nullptr));
          MODAL_PETSC(EPSSetStoppingTestFunction(eps_solver, probe_stops, probe, nullptr));
        }
        MODAL_PETSC(EPSSetFromOptions(eps_solver));
        MODAL_PETSC(EPSSolve(eps_solver));
        if (probe && probe->stopped) {
          MODAL_PETSC(EPSDestroy(&eps_solver));
          return false;
        }
        PetscInt converged = 0;
        MODAL_PETSC(EPSGetConverged(eps_solver, &converged));
        if (start && converged < nev) {  // a check run: its converged pairs only (the caller says so)
          short_run = true;
          nev = converged;
        }
        if (converged < nev)
          throw NumericalError(fmt::format("--backend petsc: SLEPc's Krylov–Schur iteration converged {} of the {} "
                                           "modes asked for; try a larger --tol",
                                           converged, nev));
        for (PetscInt i = 0; i < nev; ++i) {
          PetscScalar value = 0;
          MODAL_PETSC(EPSGetEigenpair(eps_solver, i, &value, nullptr, phi, nullptr));
          if (each) each(static_cast<double>(value), phi);
          else take_mode(phi);
        }
        MODAL_PETSC(EPSDestroy(&eps_solver));
        return true;
      };
      // Completeness by inertia, as solve_sparse_modes checks it: a Krylov
      // run from one start vector can skip a copy of a repeated eigenvalue.
      // For the lowest modes (no shift), with b = λ_k − δ
      // (δ = 1e-6|λ_k| + η, η = completeness_margin·ζ) below the k-th returned eigenvalue, the inertia
      // of K − bM must count no more eigenvalues below b than were returned
      // below it; else the run is repeated with more wanted (at most 4 times).
      std::optional<std::pair<CompletenessCheck, std::size_t>> completeness;  // the check and its note's index
      // The numbers' eigenvalues, any order.
      const auto eigenvalues = [&] {
        std::vector<double> lambdas;
        for (const auto& number : numbers) lambdas.push_back(number.first);
        return lambdas;
      };
      // The first run of each case without a user shift that wants modes at
      // or above σ₀, probed as solve_sparse_modes probes its own (see there
      // and ProbeWatch): at σ₀ = −ζ the wanted θ = 1/(λ − σ₀) of eigenvalues
      // far nearer 0 than ζ differ by (λ_i − λ_j)/ζ relative (a chain of 400
      // particles with masses over 12 decades, its lowest λ some 1e-22 s:
      // "converged 0 of the 10 modes" after 1000 restarts). A run given up
      // moves the shift to −λ̃_nev (or 2λ̃_1 where all are negative:
      // probe_move), down by factors of 8 until K − σM has the inertia of
      // σ₀ there (`below`: 0, positive definite, where m = 0; m, none between
      // σ₀ and the shift, where k > m), or stays at the last shift with the
      // whole budget if none is found above it; the run there is probed again
      // against its own |σ|. The floor is the rounding of λ̃ = σ + 1/θ itself,
      // 16ε|σ|: the serial path's other floor, the Ritz vectors' data level,
      // needs vectors SLEPc does not return for a run it has not converged,
      // so a shift here may move nearer a cluster of zero modes than the
      // serial one does (more factorizations, not other modes: the kinds are
      // decided by the modes' own sums). `target` is left at the run's shift.
      const auto probed_solve = [&](PetscInt nev, PetscInt below) {
        for (double sigma_j = s0;; ++moves) {
          target = sigma_j;
          ProbeWatch watch;
          watch.nev = nev;
          watch.restarts = static_cast<PetscInt>(moves == 0 ? near_zero_probe : moved_probe);
          watch.floor = 16 * eps * std::abs(sigma_j);
          if (solve_nearest(nev, moves < near_zero_moves ? &watch : nullptr)) break;
          double sigma = watch.moved;
          while (sigma < 0 && sigma > sigma_j && inertia_below(K, M, sigma) != std::optional<PetscInt>(below))
            sigma *= 8;
          if (!(sigma < 0 && sigma > sigma_j)) {
            solve_nearest(nev, nullptr);
            break;
          }
          sigma_j = sigma;
        }
        if (moves > 0)
          where = fmt::format("σ = {:.6g}, moved {} time{} from σ₀ = −ζ (the Ritz values lay within {} |σ| of zero)",
                              target, moves, moves == 1 ? "" : "s", near_zero_fraction);
      };
      // check_lowest's runs: the first probed (probed_solve, `below` as
      // there), its repeats wanting more modes at the shift it settled on.
      const auto probed_first = [&](PetscInt below) {
        return [&, below, probed = false](PetscInt nev) mutable {
          if (probed) {
            solve_nearest(nev, nullptr);
          } else {
            probed = true;
            probed_solve(nev, below);
          }
        };
      };
      // Each set of modes returned is checked for completeness as the lowest
      // modes at σ₀ are (check_completeness): a run from one start vector
      // can skip a copy of a repeated eigenvalue, negative (a compressed net,
      // all its lowest λ negative, returned its 9th, double, eigenvalue once
      // and the 11th as its 10th) or not (a compressed net of side 6 beside
      // a nearly slack one, 20 modes wanted: the 16 negative ones and
      // 8.83e-7, double, once). Not fatal where K − bM cannot be factored
      // near b: the note says the check was not made.
      const auto check_lowest = [&](double sigma_check, const std::function<void(PetscInt)>& run) {
        const CompletenessCheck check = check_completeness(
            k, n, sigma_check, zeta,
            [&](long nev) {
              run(static_cast<PetscInt>(nev));
              return eigenvalues();
            },
            [&](double& b, bool) { return inertia_count(K, M, b, s); });  // moves b down past a singular K − bM
        if (check.outcome != CompletenessCheck::Outcome::not_needed) {
          completeness = {check, result.notes.size()};
          result.notes.push_back(
              completeness_note(check, fmt::format("{:.8g}", check.bound), "SLEPc's Krylov–Schur iteration"));
        }
      };
      if (options.shift) {
        solve_nearest(k, nullptr);
      } else if (m > 0 && k <= m) {
        // The k nearest the shift below the spectrum are the k lowest,
        // checked as at σ₀ (nothing below the shift).
        check_lowest(target, [&](PetscInt nev) { solve_nearest(nev, nullptr); });
      } else if (m > 0) {
        // k > m, as solve_sparse_modes (lib/modal/sparse.cpp): the k − m
        // lowest at or above σ₀ from runs at σ₀ (the k nearest it), the first
        // probed as where m = 0 with a moved shift kept only where the
        // inertia there is still m (the modes within η of zero beside a
        // compressed net converge slowly from a shift far below them, or not
        // at all from one below the spectrum: tests/distributed/
        // prestrained_nets.py --mixed, seed 3's scene 4 returned 2.457e-6 as
        // its 19th where a copy of 1.538e-6 belongs); the m below σ₀ from the
        // same runs where they found all m, else from a shift below the
        // spectrum (placed when first needed), wanting the shortfall plus 2
        // more while a run finds fewer than m there (at most 4 repeats).
        double upper_sigma = s0, low_sigma = std::numeric_limits<double>::quiet_NaN();
        std::vector<std::pair<double, QuotientSums>> low_numbers;  // the m negatives' (solver.negatives: their vectors)
        std::vector<VectorX> low_shapes;
        std::vector<Vec>& negatives = solver.negatives;
        const auto find_negatives = [&] {
          low_sigma = below_spectrum();
          target = low_sigma;
          long want = static_cast<long>(m), below = 0;
          for (int attempt = 0;; ++attempt) {
            low_numbers.clear();
            low_shapes.clear();
            for (Vec& v : negatives) MODAL_PETSC(VecDestroy(&v));
            negatives.clear();
            solve_nearest(static_cast<PetscInt>(want), nullptr, nullptr, [&](double, Vec phi) {
              take_mode(phi);  // then moved aside from the numbers
              low_numbers.push_back(numbers.back());
              numbers.pop_back();
              low_shapes.push_back(std::move(shapes.back()));
              shapes.pop_back();
              negatives.push_back(found.back());
              found.pop_back();
            });
            below = std::count_if(low_numbers.begin(), low_numbers.end(), [&](const auto& p) { return p.first < s0; });
            if (below >= m || attempt == 4 || want >= n - 2) break;
            want = std::min<long>(static_cast<long>(n) - 2, want + static_cast<long>(m) - below + 2);
          }
          if (below < m)
            throw NumericalError(fmt::format("--backend petsc: the inertia of K − σM at σ₀ = {:.3g} counts {} "
                                             "eigenvalues below it, but SLEPc found {} of them from σ = {:.6g}",
                                             s0, m, below, low_sigma));
          keep_lowest(static_cast<std::size_t>(m), low_numbers, low_shapes, &negatives);  // the m lowest, all below σ₀
          target = upper_sigma;
        };
        bool merged = false;  // the last run's set took the m negatives from low_sigma
        check_lowest(s0, [&, run = probed_first(m)](PetscInt nev) mutable {
          target = upper_sigma;
          merged = false;
          run(nev);
          upper_sigma = target;
          const auto below = std::count_if(numbers.begin(), numbers.end(), [&](const auto& p) { return p.first < s0; });
          const PetscInt above = static_cast<PetscInt>(numbers.size()) - static_cast<PetscInt>(below);
          if (above < k - m)
            throw NumericalError(fmt::format("--backend petsc: SLEPc's Krylov–Schur iteration at σ = {:.6g} returned "
                                             "{} eigenvalues at or above σ₀ = {:.3g}, fewer than the {} that the "
                                             "inertia guarantees",
                                             upper_sigma, above, s0, k - m));
          if (below == m) return;  // the run found all m
          if (negatives.empty()) find_negatives();
          merged = true;
          // the merged set: this run's at or above σ₀, and the m negatives (copies)
          for (std::size_t i = numbers.size(); i-- > 0;) {
            if (!(numbers[i].first < s0)) continue;
            MODAL_PETSC(VecDestroy(&found[i]));
            found.erase(found.begin() + static_cast<std::ptrdiff_t>(i));
            numbers.erase(numbers.begin() + static_cast<std::ptrdiff_t>(i));
            shapes.erase(shapes.begin() + static_cast<std::ptrdiff_t>(i));
          }
          for (std::size_t j = 0; j < negatives.size(); ++j) {
            numbers.push_back(low_numbers[j]);
            shapes.push_back(low_shapes[j]);
            found.push_back(nullptr);
            MODAL_PETSC(VecDuplicate(negatives[j], &found.back()));
            MODAL_PETSC(VecCopy(negatives[j], found.back()));
          }
        });
        if (merged)
          where += fmt::format(", and at σ = {:.6g} below the spectrum for the {} below σ₀", low_sigma, m);
      } else {
        check_lowest(s0, probed_first(0));
      }
      // Copies the inertia cannot check. Where the shift moved and every
      // returned eigenvalue lies within η of zero (some of them resolved,
      // not zero modes), the inertia cannot tell whether a copy of a
      // repeated eigenvalue is missing, and a run from one start vector
      // finds one direction of each eigenspace in exact arithmetic (others
      // only through rounding): a chain of 400 particles, whose eigenvalues
      // across it are all double (y and z), returned 2.894e-12 once and
      // 4.258e-12 as its 10th mode under 3 ranks. So runs from random start
      // vectors follow: of each of their pairs below the k-th returned
      // eigenvalue, the part M-orthogonal to every vector found, this run's
      // added ones included (classical Gram–Schmidt, twice; a run returns
      // both vectors of a double eigenvalue, and against the earlier vectors
      // alone both were added: three modes at 1.967e-11), is a new direction
      // where it keeps more than 1e-3 of its M-norm; as a mode, it is added
      // (a missed copy) when its residual estimate is within
      // copies_resolution of its λ and wholly below the k-th, else counted
      // as unresolved. The runs stop
      // when one has found no new direction at all and converged every pair
      // it asked for (its direction in each eigenspace then lies in the span
      // found, so the span is the eigenspace), at most 4 runs; otherwise
      // the note says a mode may be missing. A check run that converges
      // fewer pairs does not fail the point. (SLEPc's deflation space was
      // tried instead: its deflated runs converged to pairs with residuals
      // of 0.1–1 × λ here, masses over 12 decades.)
      std::string copies_note;
      // (also where b > 0 but returned modes resolved from λ_k lie in [b, λ_k): uncovered_modes)
      const bool unchecked = completeness && [&] {
        std::vector<Mode> modes;  // of which the k lowest (a repeated run returned more)
        for (const auto& number : numbers) modes.push_back(quotient_mode(VectorX::Zero(1), number.first, number.second));
        return leaves_modes_unchecked(completeness->first, std::move(modes), k);
      }();
      if (moves > 0 && unchecked && completeness->first.outcome == CompletenessCheck::Outcome::complete &&
          std::min(static_cast<PetscInt>(found.size()), k) + k < n) {
        struct Random {  // destroyed with the phase, also on a throw
          PetscRandom random = nullptr;
          ~Random() {
            if (random) PetscRandomDestroy(&random);
          }
        } generator;
        MODAL_PETSC(PetscRandomCreate(PETSC_COMM_WORLD, &generator.random));
        Vec& start = work.add(K);
        Vec& Md = work.add(K);
        // Per run: directions added, and directions outside the span found
        // whose residual was not within copies_resolution of λ (neither added nor
        // evidence that nothing is missing).
        int runs = 0, added = 0, added_last = 0, unresolved_last = 0;
        std::vector<PetscScalar> coefficients;
        do {
          std::vector<double> lambdas;
          for (const auto& number : numbers) lambdas.push_back(number.first);
          std::nth_element(lambdas.begin(), lambdas.begin() + (k - 1), lambdas.end());
          const double kth = lambdas[static_cast<std::size_t>(k - 1)];
          // a seed per run and rank (each rank draws its own entries)
          MODAL_PETSC(PetscRandomSetSeed(generator.random, static_cast<unsigned long>(2026 + 1000 * runs + rank)));
          MODAL_PETSC(PetscRandomSeed(generator.random));
          MODAL_PETSC(VecSetRandom(start, generator.random));
          added_last = unresolved_last = 0;
          short_run = false;
          solve_nearest(k, nullptr, start, [&](double value, Vec d) {
            if (!(value < kth)) return;
            MODAL_PETSC(MatMult(M, d, Md));
            const double before = std::sqrt(std::max(0.0, dot(d, Md)));
            const PetscInt base = static_cast<PetscInt>(found.size());  // those of this run added so far too
            for (int pass = 0; pass < 2; ++pass) {
              coefficients.assign(static_cast<std::size_t>(base), 0.0);
              MODAL_PETSC(MatMult(M, d, Md));
              MODAL_PETSC(VecMDot(Md, base, found.data(), coefficients.data()));
              for (PetscScalar& c : coefficients) c = -c;
              MODAL_PETSC(VecMAXPY(d, base, coefficients.data(), found.data()));
            }
            MODAL_PETSC(MatMult(M, d, Md));
            if (!(std::sqrt(std::max(0.0, dot(d, Md))) > 1e-3 * before)) return;
            take_mode(d);
            const auto& [lambda, sums] = numbers.back();
            if (sums.residual <= copies_resolution * std::abs(lambda) && lambda + sums.residual < kth) {
              ++added_last;
              return;
            }
            ++unresolved_last;
            numbers.pop_back();
            shapes.pop_back();
            MODAL_PETSC(VecDestroy(&found.back()));
            found.pop_back();
          });
          ++runs;
          added += added_last;
        } while (runs < 4 && (added_last > 0 || unresolved_last > 0 || short_run) &&
                 static_cast<PetscInt>(found.size()) + k < n);
        copies_note = copies_check_note(runs, added, static_cast<long>(k),
                                        added_last == 0 && unresolved_last == 0 && !short_run, short_run,
                                        unresolved_last, "Krylov–Schur");
      }
      // The vectors are needed no more (the shapes are kept as `gathered`
      // says): released before the inertia counts below factor K − σM.
      for (std::vector<Vec>* vectors : {&found, &solver.negatives}) {
        for (Vec& v : *vectors) MODAL_PETSC(VecDestroy(&v));
        vectors->clear();
      }
      if (static_cast<PetscInt>(numbers.size()) > k)  // the k lowest of a repeated run
        keep_lowest(static_cast<std::size_t>(k), numbers, shapes);
      // The modes on every rank (the numbers come from collective reductions,
      // so every rank decides alike; the shapes only on rank 0), then the
      // inertia's account of those not returned: Morse index, zero modes and
      // class over the whole spectrum (collective factorizations).
      for (std::size_t i = 0; i < numbers.size(); ++i)
        result.modes.push_back(
            quotient_mode(rank == 0 ? std::move(shapes[i]) : VectorX::Zero(1), numbers[i].first, numbers[i].second));
      // Where the completeness check passed, Kato–Temple's δ²/g (as
      // solve_sparse_modes): the linear δ had made the nets' estimates about
      // 10 × the Lanczos path's.
      if (completeness && completeness->first.outcome == CompletenessCheck::Outcome::complete) {
        std::vector<double> bound, typical;
        for (const auto& number : numbers) {
          bound.push_back(number.second.residual_worst);
          typical.push_back(number.second.residual);
        }
        kato_temple(result.modes, bound, typical, completeness->first.bound);
      }
      std::stable_sort(result.modes.begin(), result.modes.end(),
                       [](const Mode& a, const Mode& b) { return a.omega2 < b.omega2; });
      add_cluster_notes(result.modes, true, result.notes);
      if (completeness && !copies_note.empty())
        replace_note(result.notes, completeness->second, copies_note);
      else if (completeness)
        if (auto note = unchecked_completeness_note(completeness->first, result.modes,
                                                    fmt::format("{:.3g}", completeness_margin * zeta),
                                                    fmt::format("{:.8g}", completeness->first.bound)))
          replace_note(result.notes, completeness->second, std::move(*note));
      InertiaAccount account;
      account.below_s0 = static_cast<long>(m);
      account.s0 = s0;
      account.zeta = zeta;
      account.shift = options.shift;
      count_by_inertia(result, account,
                       [&](double& sigma, const char*, bool) { return inertia_count(K, M, sigma, s, +1); });
      {  // on every rank: the same numbers, the same decision
        if (!options.shift && m > 0 && k >= m) {
          const auto below = std::count_if(result.modes.begin(), result.modes.end(),
                                           [&](const Mode& mode) { return mode.omega2 < s0; });
          if (below != m)
            throw NumericalError(fmt::format("--backend petsc: the inertia of K − σM at σ₀ = {:.3g} counts {} "
                                             "eigenvalues below it, but SLEPc found {} of them",
                                             s0, m, below));
        }
        if (k < m)
          result.notes.push_back(fmt::format("the equilibrium has {} negative eigenvalues below −ζ = {:.3g}; only the "
                                             "{} most negative are returned (morse_index counts all of them)",
                                             m, s0, k));
        if (options.shift) result.notes.push_back(fmt::format("the {} modes nearest the shift σ = {:.8g}", k, *options.shift));
        result.solver = fmt::format("distributed shift-invert Krylov–Schur (SLEPc, MUMPS Cholesky of K − σM at {}, "
                                    "{} rank{}; inertia of K − σM at σ₀ = −ζ = {:.3g}: {} eigenvalue{} below)",
                                    where, size, size == 1 ? "" : "s", s0, m, m == 1 ? "" : "s");
        result.timings = {
            {"factorization", std::chrono::duration<double>(factored - started).count()},
            {"eigen-solution", std::chrono::duration<double>(Clock::now() - factored).count()}};
      }
    });
    timings.mark("eigen");
    if (gathered == Gathered::root) {
      eq.q = gather_to_root(x);
    } else {
      const PetscScalar* values = nullptr;
      MODAL_PETSC(VecGetArrayRead(x, &values));
      eq.q = Eigen::Map<const VectorX>(values, part.end_coordinate - part.first_coordinate);
      MODAL_PETSC(VecRestoreArrayRead(x, &values));
    }
    return {std::move(eq), std::move(result), static_cast<long long>(n)};
  }
}

// This rank's part of the scene (distributed generation: each rank reads and
// builds its part only, SceneWindow, never the whole) from the scene file's
// text, checked to be one the backend applies to.
Model read_part(const std::string& text, const std::string& file, const std::vector<ParameterOverride>& overrides,
                const SceneLimits& limits, SceneFormat format) {
  if (scene_format(file, text, format) != SceneFormat::toml)
    throw InputError("--backend petsc reads TOML scenes of particles and springs; an MJCF or URDF model needs the "
                     "serial backend");
  const SceneWindow window{world_rank(), world_size()};
  Scene scene = parse_scene(text, file, overrides, limits, &window);
  System system = build_system(scene);
  if (const auto why = distributed_unsupported(system))
    throw InputError("--backend petsc does not apply to this scene: " + *why);
  return {text, overrides, std::move(scene), std::move(system), limits, SceneFormat::toml, nullptr};
}

// Collective: read_part on every rank after `before` (checks of the request,
// in the same agreed phase), a failure on any rank the failure of all; then
// what no rank sees alone (check_read_in_parts). A scene error is reported as
// the serial path reports it: a part sees the faults of its own rows (and
// every row's values), and the first it meets may come after one another
// part met, so rank 0 then reads the scene whole for the serial message
// (only then does a rank hold the whole scene, on bad input).
Model read_part_agreed(const std::string& file, const std::vector<std::string>& sets, const SceneLimits& limits,
                       SceneFormat format, const std::function<void()>& before) {
  std::string text;
  std::vector<ParameterOverride> overrides;
  std::optional<Model> part;
  const auto read_whole = [&] {  // rank 0, for the serial path's message only
    if (!text.empty()) (void)parse_scene(text, file, overrides, limits);
  };
  try {
    phase([&] {
      if (before) before();
      for (const std::string& set : sets) overrides.push_back(parse_override(set));
      text = read_scene_file(file);
      part.emplace(read_part(text, file, overrides, limits, format));
    });
  } catch (const Agreed& a) {
    if (a.failure.scene_error && world_size() > 1)
      serial_failure(read_whole, [&](const SceneError& e) { return a.failure.cause.starts_with(e.where().file + ":"); });
    throw;
  }
  check_read_in_parts(part->scene, read_whole);
  return std::move(*part);
}

}  // namespace

int analyze_distributed(const DistributedRequest& request, std::ostream& out, std::ostream& err) {
  const int rank = world_rank(), size = world_size();
  Timings timings;
  std::optional<Model> model;  // the part of the scene this rank has read and built
  const AnalysisOptions& options = request.options;
  int status = 0;
  try {
    model.emplace(read_part_agreed(request.scene_file, request.sets, request.limits, request.format, [&] {
      const Outputs& o = request.outputs;
      if (o.energy || !o.report.empty() || !o.matrices.empty())
        throw InputError("--backend petsc writes the text, --csv and --json; --energy, --report and --export-matrices "
                         "need the serial backend");
      if (options.at) throw InputError("--at: the petsc backend starts from the scene's configuration only");
      if (options.solver == SolverChoice::dense)
        throw InputError("--solver dense does not go with --backend petsc, which solves the sparse problem");
      if (options.derivatives != DerivativeMethod::exact)
        throw InputError("--derivatives: the petsc backend assembles K exactly from the elements' derivatives");
      if (rank == 0) check_outputs(Command::analyze, o, request.scene_file);
    }));
    const Scene* scene = &model->scene;
    const System* held = &model->system;
    timings.mark("parse+build");
    Report names;
    const auto numbered = [&](const Part& part) {
      if (request.timing) {  // what each rank holds: its part of the scene, never the whole
        long long counts[3] = {part.end_body - part.first_body, static_cast<long long>(held->bodies().size()),
                               static_cast<long long>(part.held.size())};
        std::vector<long long> all(3 * static_cast<std::size_t>(size));
        MPI_Gather(counts, 3, MPI_LONG_LONG, all.data(), 3, MPI_LONG_LONG, 0, MPI_COMM_WORLD);
        for (int r = 0; r < size && rank == 0; ++r)
          err << fmt::format("distribution: rank {} of {} owns {} of the scene's {} bodies, built {}, assembles {}\n",
                             r, size, all[3 * static_cast<std::size_t>(r)], scene->total_bodies,
                             all[3 * static_cast<std::size_t>(r) + 1], all[3 * static_cast<std::size_t>(r) + 2]);
      }
      gather_coordinate_names(part, names.coordinates, names.kinds);
    };
    Point point = solve_point(*held, *scene, VectorX(), options, Gathered::root, timings, numbered);

    // ---- one report, by rank 0
    bool unstable = false;
    phase([&] {
      if (rank != 0) return;
      Analysis a;
      a.report = std::move(names);
      a.report.scene_file = scene->file;
      a.report.title = held->title();
      a.report.parameters = scene->parameters;
      a.report.equilibria.push_back({std::move(point.eq), std::move(point.result), std::nullopt, std::nullopt});
      write_analysis(out, a, request.outputs);
      unstable = a.unstable();
    });
    timings.mark("report");
    int flag = unstable ? 1 : 0;
    MPI_Bcast(&flag, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (request.timing) {
      for (const auto& [name, seconds] : timings.seconds) {
        double high = seconds, low = seconds;
        MPI_Allreduce(MPI_IN_PLACE, &high, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
        MPI_Allreduce(MPI_IN_PLACE, &low, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
        if (rank == 0)
          err << fmt::format("timing: {:<16} {:>12.3f} ms max {:>12.3f} ms min over {} rank{}\n", name, 1e3 * high,
                             1e3 * low, size, size == 1 ? "" : "s");
      }
      double high = peak_memory(), low = high;
      MPI_Allreduce(MPI_IN_PLACE, &high, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
      MPI_Allreduce(MPI_IN_PLACE, &low, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
      if (rank == 0)
        err << fmt::format("timing: peak memory per rank {:.1f} MiB max {:.1f} MiB min\n", high / 1048576, low / 1048576);
    }
    if (request.require_stable && flag) {
      if (rank == 0) err << "modal: the equilibrium is unstable\n";
      status = static_cast<int>(ExitStatus::unstable);
    }
  } catch (const Agreed& a) {
    if (rank == 0) err << a.failure.message << '\n';
    status = a.failure.status;
  }
  return status;
}

int sweep_distributed(const DistributedSweepRequest& request, std::ostream& out, std::ostream& err) {
  const int rank = world_rank();
  std::optional<Model> model;  // this rank's part of the scene, as at the start
  std::optional<SweepStudy> study;
  std::vector<SweepAxis> axes;
  int status = 0;
  try {
    model.emplace(read_part_agreed(request.scene_file, request.sets, request.limits, request.format, [&] {
      for (const std::string& v : request.varies) axes.push_back(parse_vary(v));
      if (rank == 0) check_outputs(Command::sweep, request.outputs, request.scene_file, request.options.extrapolate);
    }));
    SweepStudyOptions options = request.options;
    AnalysisOptions analysis = request.analysis;
    analysis.modes = options.modes > 0 ? options.modes : 10;
    // Every point is read in parts as `analyze` reads it (each rank its part
    // only, never the whole), agreed on by the ranks, and solved by
    // solve_point from the previous point's owned coordinates. A failure
    // agreed on by the ranks becomes the same exception on all of them, so
    // the sweep (which runs on every rank in step) fails that point
    // everywhere alike.
    options.sweep.window = SceneWindow{rank, world_size()};
    options.sweep.agree_read = [](const std::string& failure) {
      Failure mine;
      if (!failure.empty()) mine = {static_cast<int>(ExitStatus::bad_input), failure, failure};
      return agree(mine).cause;
    };
    bool named = false;  // the coordinates' names gathered (once, at the first point solved)
    options.sweep.analyze_point = [&](const Scene& scene, const System& part, const VectorX& start) {
      try {
        phase([&] {
          if (const auto why = distributed_unsupported(part))
            throw InputError("--backend petsc does not apply to the scene at this point: " + *why);
        });
        PointAnalysis a;
        Timings timings;
        std::vector<CoordinateKind> kinds;
        Point p = solve_point(part, scene, start, analysis, Gathered::owned, timings, [&](const Part& numbered) {
          if (!named) gather_coordinate_names(numbered, a.names, kinds);
        });
        named = true;
        a.equilibrium = std::move(p.eq);
        a.result = std::move(p.result);
        a.coordinates = p.coordinates;
        return a;
      } catch (const Agreed& a) {
        if (a.failure.status == static_cast<int>(ExitStatus::bad_input)) throw InputError(a.failure.cause);
        throw NumericalError(a.failure.cause);
      }
    };
    phase([&] { study.emplace(sweep(*model, axes, options)); });
    phase([&] {
      if (rank == 0) write_sweep(out, *study, request.outputs);
    });
  } catch (const Agreed& a) {
    if (rank == 0) err << a.failure.message << '\n';
    status = a.failure.status;
  }
  return status;
}

}  // namespace modal
