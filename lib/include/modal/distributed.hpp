// modal/distributed.hpp — the distributed backend (`analyze --backend petsc`):
// the sparse path's equilibrium and lowest modes of a scene of particles and
// springs, with the coordinates partitioned over MPI ranks and solved by PETSc
// (SNES, MUMPS) and SLEPc (Krylov–Schur with shift-and-invert).
//
// Not part of libmodal: only the program modal-mpi links it (with MPI, PETSc,
// SLEPc and the parallel MUMPS); `modal analyze --backend petsc` executes
// modal-mpi in its place (docs/design.md, "Distributed backend").
//
//   int main(int argc, char** argv) {
//     modal::DistributedSession session;           // MPI, PETSc and SLEPc, for the process
//     modal::DistributedRequest r;
//     r.scene_file = "lattice.toml";
//     return modal::analyze_distributed(r, std::cout, std::cerr);  // the same on every rank
//   }
#pragma once

#include "modal/import.hpp"
#include "modal/pipeline.hpp"
#include "modal/scene.hpp"

#include <iosfwd>
#include <string>
#include <vector>

namespace modal {

// MPI, PETSc and SLEPc for the lifetime of the object (one per process,
// created before any other call here; PETSc reads no options from the command
// line, only from the PETSC_OPTIONS environment variable).
class DistributedSession {
 public:
  DistributedSession();
  ~DistributedSession();
  DistributedSession(const DistributedSession&) = delete;
  DistributedSession& operator=(const DistributedSession&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }

 private:
  int rank_ = 0, size_ = 1;
};

// One `analyze` as the command line gives it.
struct DistributedRequest {
  std::string scene_file;
  std::vector<std::string> sets;       // NAME=VALUE overrides
  SceneLimits limits;
  SceneFormat format = SceneFormat::automatic;
  AnalysisOptions options;             // modes, shift, tolerance, equilibrium_tolerance are used
  Outputs outputs;                     // csv and json (text always)
  bool timing = false;                 // phases' wall time, max and min over the ranks, on `err`
  bool require_stable = false;         // exit status 3 for an unstable equilibrium
};

// Runs the analysis on every rank of MPI_COMM_WORLD (collective). Rank 0
// writes the text, files and messages; the other ranks write nothing. Every
// rank returns the same exit status (modal::ExitStatus): a failure on any rank
// (bad input, no convergence) is agreed on by all before the next collective
// step, so the ranks end together with one message.
int analyze_distributed(const DistributedRequest& request, std::ostream& out, std::ostream& err);

// One `sweep --backend petsc`: the serial sweep (modal::sweep, its critical
// values and its reporting) with every point analyzed by the backend
// (SweepOptions::analyze_point): each rank reads and builds only its part of
// the scene at every point (SweepOptions::window, as analyze_distributed),
// the equilibrium continues from the previous point's (each rank keeping its
// owned coordinates of it), and the lowest `options.modes` modes (default 10)
// and the class come from the inertia. No shapes are gathered; rank 0
// writes.
struct DistributedSweepRequest {
  std::string scene_file;
  std::vector<std::string> sets;
  SceneLimits limits;
  SceneFormat format = SceneFormat::automatic;
  std::vector<std::string> varies;     // --vary texts (parse_vary, agreed on by the ranks)
  SweepStudyOptions options;           // modes, extrapolate, the refinement's tolerance
  AnalysisOptions analysis;            // tolerance, equilibrium_tolerance (modes: options.modes)
  Outputs outputs;                     // csv, report
};

// Collective as analyze_distributed; exit status 0, or that of the failure
// (a point that fails is reported in the sweep, as on the serial path).
int sweep_distributed(const DistributedSweepRequest& request, std::ostream& out, std::ostream& err);

}  // namespace modal
