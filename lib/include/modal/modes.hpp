// modal/modes.hpp — eigen-solution of a LinearModel and stability.
//
//   modal::ModalResult r = modal::solve_modes(lin);
//   for (const modal::Mode& m : r.modes) std::cout << m.omega << "\n";
//
// Symmetric problems (no damping, gyroscopic or circulatory terms) are solved
// as K φ = λ M φ with λ = ω² and M-normalized modes (ΦᵀMΦ = I); a negative λ
// is a divergent mode and is reported as negative, never as |λ|. Otherwise the
// 2n first-order system is solved for s = σ ± iω. Stability classes follow
// docs/design.md ("Mode kinds and stability classes"). Every eigenvalue
// carries an error estimate.
#pragma once

#include "modal/linearize.hpp"

#include <complex>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace modal {

enum class Stability { asymptotically_stable, stable, marginal, divergence, flutter };
const char* to_string(Stability s);  // "asymptotically stable", "stable", "marginal", "divergence", "flutter"

// What one mode does.
enum class ModeKind {
  oscillatory,  // σ = 0 (within error), ω > 0
  damped,       // σ < 0
  zero,         // s = 0 within its error estimate (rigid-body motion, ignorable coordinate)
  divergent,    // real s > 0 (symmetric: λ < 0)
  flutter,      // σ > 0, ω > 0
};
const char* to_string(ModeKind k);

struct Mode {
  double omega2 = 0;          // λ = ω² for symmetric problems (negative: divergent); NaN otherwise
  std::complex<double> s;     // eigenvalue of the first-order system, σ + iω with ω ≥ 0, 1/s
  double growth_rate = 0;     // σ = Re s, 1/s
  double omega = 0;           // ω = Im s, rad/s
  double frequency_hz = 0;    // ω / 2π, Hz
  double period = 0;          // 2π / ω, s (infinity when ω = 0)
  double damping_ratio = 0;   // −σ / |s| (NaN when s = 0)
  double error_estimate = 0;  // absolute error estimate of the eigenvalue: of omega2
                              // (rad²/s²) for symmetric problems, of s (rad/s) otherwise;
                              // covers the solver and the rounding (or differences) of M and K
  // Symmetric problems: a rigorous bound (rad²/s²) for the matrices as
  // formed: an eigenvalue of the pencil solved lies within it of omega2. From
  // the residual δ = ‖Kφ − λMφ‖_{M⁻¹} and the rounding: δ itself (Parlett,
  // thm 4.5.1, in the M-inner product), δ²/g where the other modes leave a
  // gap g (Kato–Temple), a cluster's quadratic bound for repeated eigenvalues
  // (Mathias), and for a hanging point-mass chain Sturm counts where they
  // bracket it more narrowly. So it bounds the eigenvalue's distance, not
  // the residual, which may exceed it. The pencil solved is (K, M) of the LinearModel, or, for a
  // chain of parallel hinges, the congruent one in absolute angles
  // (LinearModel::absolute), whose rounding differs. It bounds what the
  // eigen-solver left, not the errors of K and M. error_estimate covers both
  // but takes rounding at its typical size: with an ill-conditioned M it can
  // be far below this worst-case bound.
  // NaN for first-order problems (no such bound for non-normal matrices).
  double residual_bound = std::numeric_limits<double>::quiet_NaN();
  // The part of error_estimate (same units) that comes from systematic errors
  // of the data rather than from rounding and the eigen-solver: of K (an
  // equilibrium accepted at a loose tolerance, where K changes on the way to
  // the exact one; derivatives by differences), of C where it is measured
  // (first-order problems), and a point-mass chain's departure from its
  // structure above rounding (M); 0 when there are none. Two eigenvalues whose
  // estimates overlap only through this part are distinct eigenvalues of the
  // matrices as formed (their shapes are unique), known no better than it.
  double systematic_error = 0;
  ModeKind kind = ModeKind::oscillatory;
  Eigen::VectorXcd shape;     // n; symmetric: real, M-normalized, largest |component| positive
};

struct ModalResult {
  std::vector<Mode> modes;  // symmetric: ascending λ; first-order: ascending ω, then σ
  Stability stability = Stability::stable;
  int morse_index = 0;      // number of divergent modes (negative λ, real s > 0); first-order:
                            // eigenvalues of the 2n system (a pair real within error counts 2)
  int zero_modes = 0;       // number of zero modes; first-order: zero eigenvalues of the 2n
                            // system (an undamped rigid-body motion contributes two)
  std::string solver;       // which solver ran, e.g. "dense symmetric (Eigen, Cholesky)"
  std::vector<std::string> notes;  // diagnostics a user should read
  // The steady motion analyzed (rates and momenta of ignorable coordinates,
  // copied from the linear model); empty for an equilibrium proper.
  std::vector<SteadyRate> steady;
  // Constraints (copied from the linear model): the constraint forces at the
  // equilibrium and the redundant equations; empty without constraints.
  std::vector<ConstraintForce> constraint_forces;
  std::vector<std::string> redundant_equations;
  // Wall time of the solver's phases, seconds, in order (e.g. {"factorization",
  // 1.2}, {"eigen-solution", 3.4}); filled by the sparse solver.
  std::vector<std::pair<std::string, double>> timings;
};

// The mass matrix is singular (or not positive definite) at the point: the
// message names the coordinates that carry no inertia there.
class SingularMassMatrix : public NumericalError {
 public:
  using NumericalError::NumericalError;
};

// The dense symmetric eigen-solver: Eigen (Cholesky of M, L⁻¹KL⁻ᵀ, self-adjoint
// tridiagonal QR) or LAPACK dsygvd (divide and conquer, through the system's
// LAPACK: OpenBLAS where installed). automatic: LAPACK from lapack_threshold
// coordinates, where it is faster (results/tradeoff.md); both agree to
// rounding and get the same error estimates.
enum class DenseSolver { automatic, eigen, lapack };
const char* to_string(DenseSolver s);  // "auto", "eigen", "lapack"
inline constexpr int lapack_threshold = 150;  // measured crossover: 100 (Eigen faster) … 200 (LAPACK 1.3× faster)

struct ModalOptions {
  int modes = -1;  // how many of the lowest modes to return (-1: all)
  DenseSolver dense_solver = DenseSolver::automatic;  // symmetric problems
};

// Memory the dense analysis of `system` needs (docs/design.md, "Memory
// policy"): M, K, the eigenvectors and the solvers' workspaces, 224 bytes per
// coordinate pair (measured: 896 MB for a 2000-link chain); problems solved in
// first order (dampers, gyroscopic terms, follower loads) as for 2n
// coordinates. Estimated before anything is allocated: analyze, every point
// of a sweep, simulate.
double dense_analysis_memory(const System& system);

// Eigen-solution of the linear model (sizes from model.M, n×n; model.q and
// model.coordinates may be empty, the latter then named q1 … qn; empty D or G
// mean zero). Symmetric problems use the dense symmetric-definite solver,
// everything else the dense 2n first-order solver; `solver` says which.
// Throws SingularMassMatrix (M not positive definite), NumericalError
// (non-finite entries, no convergence), std::invalid_argument (sizes, M not
// symmetric).
ModalResult solve_modes(const LinearModel& model, const ModalOptions& options = {});

// --- sparse: the k lowest modes of large symmetric problems -----------------------
struct SparseModalOptions {
  int modes = 10;                // k, the number of lowest eigenvalues wanted (≥ 1)
  std::optional<double> shift;   // σ (rad²/s²); unset: below the spectrum (see solve_sparse_modes)
  double tolerance = 1e-10;      // relative convergence tolerance of the Lanczos iteration
  int max_iterations = 1000;     // restarts of the Lanczos iteration
  // A fill-reducing pivot order for the factorizations of K − σM
  // (order[k] = the k-th coordinate), e.g. Equilibrium::fill_reducing_order;
  // any permutation of 0..n−1 gives correct results, a good one for K's
  // pattern saves the ordering step. Empty, or not a permutation of 0..n−1:
  // CHOLMOD chooses (AMD or METIS).
  std::vector<int> fill_reducing_order;
  // A systematic error of K's entries (n×n, ≥ 0, e.g. SparseLinearModel::
  // K_systematic_error), added to each mode's error estimate as |φ|ᵀE|φ|.
  // Empty: none.
  SparseMatrix K_systematic_error;
  // Σ|terms| of each entry of K (n×n, ≥ 0, e.g. SparseLinearModel::
  // K_magnitude): the assembly's rounding of K is taken as 4ε per term, so
  // 4ε × this, in each mode's estimate (at its typical size, as independent
  // errors). Where a spring's terms cancel (a small prestrain) it is far
  // above |K|. Empty: |K| (no cancellation in K's entries).
  SparseMatrix K_magnitude;
  // A positive semidefinite F (n×n, e.g. SparseLinearModel::K_rounding_form,
  // sparse_rounding_form) with |φᵀδKφ| ≤ 4ε φᵀFφ for the rounding δK of K's
  // assembly and of the positions: where given, each mode's kind is decided
  // with it (4ε φᵀFφ + 4ε|λ||φ|ᵀ|M||φ|) instead of the entrywise worst case
  // 4ε|φ|ᵀE|φ| of K_magnitude, which takes no account of the position's
  // rounding and on a smooth mode of a net is 10²–10⁴ × its possible effect.
  // Empty: the entrywise worst case.
  SparseMatrix K_rounding_form;
  // F of K_rounding_form kept spring by spring (e.g. SparseLinearModel::
  // K_spring_rounding, spring_rounding): where given, each mode's estimate
  // may take the springs' rounding at its typical size, the part that
  // springs computed alike share added coherently and their end points'
  // independent rounding as a root sum of squares over the springs (on a
  // smooth mode of a large net 10²–10³ × below the entrywise figures).
  // Empty: K_magnitude's and K_rounding_form's figures alone.
  SpringRounding K_spring_rounding;
  // A loose equilibrium's change of K on the way to the equilibrium (n×n,
  // signed, e.g. SparseLinearModel::K_equilibrium_shift, ΔK = K(q + δq) −
  // K(q)): each mode's estimate adds 2(|φᵀΔKφ| + δ_Δ²/g), first-order
  // perturbation of the eigenvalue and its second-order remainder (δ_Δ =
  // ‖ΔKφ − (φᵀΔKφ)Mφ‖_{M⁻¹}, g the gap to the other eigenvalues; δ_Δ itself
  // where g is not known), doubled for the Newton step's own error. Empty: none.
  SparseMatrix K_equilibrium_shift;
  // The natural inertia scale of each coordinate (n, e.g. SparseLinearModel::
  // inertia_scale): the pencil is equilibrated by it as in solve_modes
  // (LinearModel::inertia_scale). Empty: no scaling.
  VectorX inertia_scale;
  // The coordinates' names (n), by which a singular mass matrix is described.
  // Empty: q1 … qn.
  std::vector<std::string> coordinate_names;
  // Bytes a sparse Cholesky factor (of M, of K − σM) may take (> 0, e.g. a
  // limit the user set); 0: what the machine has available. A factor its
  // symbolic analysis finds larger is refused before it is allocated
  // (OutOfMemory).
  double memory_limit = 0;
};

// The k eigenvalues λ of K φ = λ M φ nearest the shift σ (by default the k
// lowest), for K (n×n, symmetric, both triangles stored) and M (n×n, symmetric
// positive definite), both sparse. Shift-invert Lanczos (Spectra's
// SymGEigsShiftSolver) with the operator (K − σM)⁻¹ applied by a sparse
// Cholesky (CHOLMOD) or, when K − σM is indefinite, an LDLᵀ factorization.
// The inertia of K − σM counts the eigenvalues below σ, so that zero and
// negative modes are never lost: morse_index is the number of negative
// eigenvalues (all of them, whether or not among the k returned), and the
// stability class uses it. Modes are M-normalized (ΦᵀMΦ = I), ascending in
// λ, with error_estimate and residual_bound as Mode describes them.
// Throws SingularMassMatrix (M not positive definite), NumericalError (no
// convergence, a factorization failure), std::invalid_argument (sizes, k).
ModalResult solve_sparse_modes(const SparseMatrix& K, const SparseMatrix& M, const SparseModalOptions& options = {});

// The same for a tree without forming K or M (the matrix-free path,
// docs/design.md "Matrix-free path"; modal/core.hpp, TreePencil): every
// factorization of K − σM and every product is a recursion over the tree,
// O(n) time and memory, so a chain of 10⁵ links needs megabytes where its
// dense K needs 80 GB. The same shift-invert Lanczos iteration, inertia
// counts, options and result as solve_sparse_modes (n ≤ 200: the matrices
// are formed and solve_sparse_modes answers). The rounding part of each
// estimate is 4ε(1 + 2√depth)(|φ|ᵀ|K||φ| + |λ||φ|ᵀ|M||φ|), |·| the
// magnitude recursion (tree_product), for sums along paths of `depth`
// bodies. A hanging point-mass chain (TreePencil::chain, no shift given) is
// solved in its absolute angles instead, from O(n) data: the lowest k modes
// from the singular values of the bidiagonal U⁻¹K^½ (LAPACK dbdsvdx), each
// bracketed by Sturm counts (residual_bound) and estimated from the chain's
// data (docs/design.md "Point-mass chains"), O(nk). Throws as
// solve_sparse_modes.
ModalResult solve_tree_modes(TreePencil pencil, const SparseModalOptions& options = {});

// One mode of the symmetric pencil (quotient_mode's, and the tree path's):
// phi M-normalized, lambda = phiᵀK phi its Rayleigh quotient, error =
// ‖K phi − lambda M phi‖ in the M⁻¹-norm, rounding = the caller's rounding
// level of evaluating phiᵀK phi (quotient_mode: at its typical size),
// systematic = |phi|ᵀ E |phi| for a known error E of K (else 0). A zero mode
// when |lambda| is within error + systematic, within rounding or within
// zero_level (the caller's level for deciding the kind, e.g. with the data's
// rounding at its worst case; a zero mode's estimate is then at least it),
// divergent when negative beyond all; the shape's largest component made
// positive.
Mode sparse_mode(VectorX phi, double lambda, double error, double rounding, double systematic = 0,
                 double zero_level = 0);

// The sums a mode of the symmetric pencil is judged by, computed by whoever
// holds K, M and φ (solve_sparse_modes with Eigen, the distributed backend
// with PETSc); φ M-normalized, λ = φᵀKφ, a = |φ|, F K's rounding form
// (sparse_rounding_form).
struct QuotientSums {
  double width = 1;          // the most nonzeros in a row of K or M: the terms of an entry of Kφ
  double n = 1;              // the rounding depth of the sums φᵀ(Kφ), φᵀ(Mφ): their terms (n) for a plain sum, less for a pairwise one
  double residual = 0;       // ‖r‖_{M⁻¹} + r's own rounding at its typical size (error_estimate's part)
  double residual_worst = 0;  // the same at its worst case (residual_bound's part)
  double rows = 0;            // ‖a ∘ |K|a‖₂ + |λ|‖a ∘ |M|a‖₂: the rounding of Kφ and Mφ seen by the quotient
  double sums_K = 0, sums_M = 0;  // Σ|φ_i(Kφ)_i|, Σ|φ_i(Mφ)_i|
  double quotient_terms = 0;  // aᵀ(|K| + |λ||M|)a
  double entries = 0;         // the entries' own rounding, typical: min((Σ(K_ij φ_i φ_j)²)^½, φᵀFφ) + |λ|(Σ(M_ij φ_i φ_j)²)^½
  double data = 0;            // the data's rounding at its worst: φᵀFφ (else aᵀ|K|a) + |λ|aᵀ|M|a
  double systematic = 0;      // |φ|ᵀE|φ| for a known error E of K (else 0)
};
// The mode of the sums (sparse_mode): the estimate is the residual and the
// quotient's rounding at their typical sizes (independent errors: √width
// terms in an entry of Kφ, √n in the sum φᵀ(Kφ) with n its rounding depth
// (QuotientSums::n), and 4ε per entry of K and M, each doubled); the kind is
// decided, as on the dense path, with the residual and the data's rounding
// at its worst, 4ε·data; residual_bound sums the magnitudes (width + 1
// terms in each entry of Kφ, n + 1 in the sums).
Mode quotient_mode(VectorX phi, double lambda, const QuotientSums& sums);

// Notes about clusters of (nearly) repeated eigenvalues among consecutive
// entries of `modes` (already sorted), appended to `notes` (every solver
// adds them once, the distributed backend too). The eigenvalue compared is
// λ = omega2 when `symmetric`, s otherwise; two neighbours belong to one
// cluster when they differ by less than the sum of their error estimates or
// by less than 1e-8 of the largest |eigenvalue|.
void add_cluster_notes(const std::vector<Mode>& modes, bool symmetric, std::vector<std::string>& notes);

// Kato–Temple for the modes a shift-invert solver returned (both sparse
// paths and the distributed backend share it). Where every eigenvalue below
// b = `complete_below` (a passed completeness check's bound; +∞ where none
// passed) is among the returned modes, each within its δ of one, a Rayleigh
// quotient's error is quadratic: |λ_j − λ| ≤ δ_j²/g_j with g_j = min(b − λ_j,
// min_i |λ_i − λ_j| − δ_i) > δ_j (Parlett, The Symmetric Eigenvalue
// Problem, thm 11.7.1). `bound` and `typical`: each mode's δ as its
// residual_bound and its error_estimate carry it (worst case and typical
// size of r's rounding); replaced there by δ²/g for the modes below b that
// are not zero modes and have such a gap, with the other modes' intervals
// taken at the same size. Returns the estimate's new residual share, δ²/g
// (typical), where it was replaced and NaN elsewhere. Any order of modes.
std::vector<double> kato_temple(std::vector<Mode>& modes, const std::vector<double>& bound,
                                const std::vector<double>& typical, double complete_below);

// What the inertia of K − σM says about the modes a shift-invert solver did
// not return (solve_sparse_modes and the distributed backend share it).
struct InertiaAccount {
  long below_s0 = 0;             // eigenvalues below σ₀ = −ζ (the Morse index before the returned modes)
  double s0 = 0;                 // σ₀
  double zeta = 0;               // ζ = 1e-8·s
  std::optional<double> shift;   // the user's shift, when the modes are those nearest it
  double unit = 1;               // the factor that turns the solver's λ into rad²/s² in notes
};
// Sets result.morse_index (below_s0 plus the returned modes in [σ₀, 0) that
// are negative beyond their error estimate; when the highest returned mode
// is divergent, a note gives the inertia's count below −η, η =
// completeness_margin·ζ, which may include zero modes), result.zero_modes (the returned
// zero modes; when the highest returned mode is a zero mode, the inertia at
// the largest zero-mode error estimate counts all of them, with a note) and
// result.stability, from result.modes (ascending) and count_below(σ, what,
// expect_indefinite): the number of eigenvalues below σ, which may move σ
// off a singular point, or a negative number where K − σM cannot be
// factored near σ (that count is then not made, and a note says so, where
// it would have said something). With a shift and no divergent or zero mode returned,
// zero eigenvalues outside the returned modes (inertia at ζ) make the class
// marginal, with a note.
void count_by_inertia(ModalResult& result, const InertiaAccount& account,
                      const std::function<long(double& sigma, const char* what, bool expect_indefinite)>& count_below);

// The note of the copies check that follows a moved shift where the
// inertia cannot check completeness (solve_sparse_modes and the distributed
// backend): `runs` runs from random start vectors of `iteration`, `added`
// directions added below the k-th eigenvalue, `spanned` when the last run
// found no new direction and converged (else, as `short_run` and
// `unresolved` say, a mode may be missing).
std::string copies_check_note(int runs, int added, long k, bool spanned, bool short_run, int unresolved,
                              const std::string& iteration);
// A new direction of the copies check is added as a mode when its error
// estimate is within this much of its λ (and it lies wholly below the k-th
// eigenvalue): the serial path's estimates on graded chains run to 2e-5 of
// λ (honest, loose), while the contaminated pairs this guards against had
// residuals of 0.1–1 × λ.
inline constexpr double copies_resolution = 1e-3;
// The completeness rule for the k lowest modes of a shift-invert solver
// (solve_sparse_modes and the distributed backend share it): a Krylov run
// from one start vector can skip a copy of a repeated eigenvalue. With
// b = λ_k − 1e-6|λ_k| − η just below the k-th returned eigenvalue (η =
// completeness_margin·ζ, 1e-12 of the spectrum's scale s: the inertia of a
// factorization is exact for a pencil within a few ε·s, and η keeps about
// 4500 ε·s from it), the inertia of K − bM must count no more eigenvalues
// below b than the run returned below it; otherwise the run is repeated with
// more wanted (the shortfall plus 2, at most nev = n − 2, at most 4 repeats).
// With ζ itself as the margin (before 2026-11-28) nothing within 1e-8 s of
// zero was checked: a net at prestrain 1e-10, all its low ω² near 1e-11 s,
// went unchecked.
inline constexpr double completeness_margin = 1e-4;
// The null-pivot threshold of MUMPS's LDLᵀ (CNTL(3), with null pivots
// detected, ICNTL(24) = 1) for the inertia counts of an indefinite K − σM
// (the serial sparse path and the distributed backend): negative, hence
// absolute, so only pivot rows whose entries underflow are null. MUMPS's
// default is normwise (a multiple of ε times the norm of the scaled
// matrix): it took a legitimate pivot row of a graded matrix for null (an
// inverted chain of 400 links in joint angles had its completeness check
// "not made", K − bM refused at every shift tried, b 1e-6 |λ₁₀| below
// λ₁₀ and the nearest other eigenvalue 1e-2 |λ₁₀| away; the row measured
// between 1e-15 and 1e-14 of the norm). A count is then that of a matrix
// within the factorization's backward error of K − σM (typically a small
// multiple of ε s), which the margins the counts are read with are set far
// above (η = 1e-12 s, about 4500 ε s; 1e-6 |λ_k| + η). A shift the user
// chose keeps MUMPS's default (MumpsLdlt::factor): it may be an eigenvalue
// itself, and is then moved off, with a note.
inline constexpr double null_pivot_threshold = -std::numeric_limits<double>::min();
// ζ = zero_margin·s, s the spectrum's scale (the largest K_ii/M_ii): the
// shift-invert solvers' default shift σ₀ = −ζ lies just below zero, so that
// zero modes are found and counted by the inertia at σ₀ (solve_sparse_modes
// and the distributed backend).
inline constexpr double zero_margin = 1e-8;
// The probe of the default shift's first run (solve_sparse_modes; the
// distributed backend alike): after near_zero_probe restarts, a run is
// given up where probe_move says so, and the runs move to its shift, at
// most near_zero_moves times (each nearer 0 by 1/near_zero_fraction where
// K − σM is positive definite there; where m > 0, on the serial path with
// k > m, where its inertia is still m). A run at a moved shift is probed
// after moved_probe restarts: long enough that such runs on the nets of
// results/near_slack.md (21–23 restarts) converge within it, and so are
// kept as they are (a probe of near_zero_probe there is made afresh: 1.6 ×
// the solves).
inline constexpr long near_zero_probe = 20;
inline constexpr double near_zero_fraction = 1e-2;
inline constexpr double near_zero_floor = 10 * std::numeric_limits<double>::epsilon();
inline constexpr int near_zero_moves = 16;
inline constexpr long moved_probe = 2 * near_zero_probe;
// The probe's decision on the wanted Ritz values λ̃ of a run at σ (the
// lowest and highest of them). Where the highest is positive: given up
// where it lies below near_zero_fraction·|σ| and above `floor` (the data's
// level: at most near_zero_floor·s on the serial path, which has the Ritz
// vectors), moving to −λ̃_max. Where every λ̃ is negative: given up where
// all lie within near_zero_fraction·|σ| of zero and beyond −floor, moving
// to 2λ̃_min, below the lowest by its own distance from zero (a compressed
// net at p = −2e-13, its λ in [−7.9e-7, −5e-9], had its 10th mode left
// unconverged at σ₀, "zero" with an estimate 16 × its λ, and 315 resolved
// negative eigenvalues counted as zero modes; a net at p = 0, whose 10
// lowest Ritz values are rounding in [−2.5e-9, −1.6e-9] against a floor of
// 2.2e-9, is not moved). The caller moves the shift on down while K − σM is
// not positive definite there (where m > 0: while the inertia there is not
// m). nullopt where the run is not given up.
inline std::optional<double> probe_move(double lowest, double highest, double sigma, double floor) {
  const double within = near_zero_fraction * std::abs(sigma);
  if (highest > 0) {
    if (!(highest < within) || !(highest > floor)) return std::nullopt;
    return -highest;
  }
  if (!(-lowest < within) || !(-highest > floor)) return std::nullopt;
  return 2 * lowest;
}
struct CompletenessCheck {
  enum class Outcome {
    not_needed,  // −η ≤ λ_k ≤ 0 (or b ≤ σ₀): nothing to check between σ₀ and it
    complete,    // exactly `count` eigenvalues below `bound`, as found
    incomplete,  // more below `bound` than found after the last repeat
    unavailable  // K − bM could not be factored (count_below returned < 0)
  };
  Outcome outcome = Outcome::not_needed;
  double bound = 0;         // b, as count_below left it
  double top = 0;           // λ_k, the k-th lowest eigenvalue returned
  long count = 0, found = 0;  // the inertia's count below b, and the run's
  long nev = 0;             // the number wanted in the last run
  // b ≤ 0 < λ_k: the returned eigenvalues from b up lie within about η of
  // zero, where the inertia cannot tell them from rounding (a negative λ_k
  // below −η, whose b lies further below, is checked as any other).
  bool near_zero() const { return bound <= 0 && top > 0; }
};
// solve(nev) runs the solver wanting nev (≥ k) modes and returns the
// eigenvalues it found, any order, at least k of them; count_below(b,
// expect_indefinite) is the inertia's number of eigenvalues below b and may
// move b off a singular K − bM (expect_indefinite: the run found some below b),
// or return a negative count where K − bM cannot be factored (the check is
// then `unavailable`, and says so, instead of failing the analysis).
// s0: the shift below which no eigenvalue is sought: σ₀ = −ζ, or a shift
// below the whole spectrum where the lowest modes are negative beyond −ζ;
// zeta: ζ (η = completeness_margin·ζ); n: the number of coordinates. The
// check is made for a negative λ_k too (below −η): a divergent net whose 10
// lowest λ were all negative had a copy of its 9th, double, eigenvalue
// skipped and the 11th returned as its 10th, unchecked.
CompletenessCheck check_completeness(long k, long n, double s0, double zeta,
                                     const std::function<std::vector<double>(long nev)>& solve,
                                     const std::function<long(double& b, bool expect_indefinite)>& count_below);
// The note that reports a check (complete or incomplete; empty when not
// needed): `bound_text` is b as the caller writes it, `iteration` names the
// solver's iteration ("the Lanczos iteration").
std::string completeness_note(const CompletenessCheck& check, const std::string& bound_text,
                              const std::string& iteration);
// A complete check leaves [b, λ_k] unchecked: copies of λ_k not returned
// are equally valid k-th modes, but where returned modes resolved
// from λ_k (farther from it than both estimates) and not zero modes lie in
// [b, λ_k), a copy of one of them may have been skipped, the check blind to
// it (a net at p = 7e-12 had 7 there, within η of λ_k). The number of such
// modes (modes: in the check's units, the k returned); 0 when the check did
// not pass. (Near zero, b ≤ 0 < λ_k, every mode from b up is unchecked: see
// below.)
long uncovered_modes(const CompletenessCheck& check, const std::vector<Mode>& modes);
// Whether a complete check leaves some of the k lowest of `modes` (in the
// check's units, any order) unchecked, the copies check's trigger on both
// sparse paths: near zero, any of them at or above b that is not a zero
// mode (those below b the inertia counted: a divergent one); elsewhere,
// uncovered_modes counts some. False where the check did not pass.
bool leaves_modes_unchecked(const CompletenessCheck& check, std::vector<Mode> modes, long k);
// The note of a complete check that leaves returned modes unchecked
// (modes: in the check's units, ascending): not near zero, where
// uncovered_modes counts some (else nullopt). A complete check near zero (CompletenessCheck::near_zero: b = λ_k − δ ≤ 0
// < λ_k, every returned eigenvalue from b up within about η of zero) says
// nothing of whether a copy of a repeated eigenvalue among the returned
// modes above b was skipped. When some returned mode is not a zero mode
// (modes: in the check's units), the note that says so, naming η and b as
// the caller writes them; nullopt when not near zero or the check did not pass; an
// empty string, the note to drop, when every mode it left uncovered is a zero
// mode (count_by_inertia's own inertia counts those).
std::optional<std::string> unchecked_completeness_note(const CompletenessCheck& check, const std::vector<Mode>& modes,
                                                       const std::string& margin_text, const std::string& bound_text);
// notes[at] = note, or the note at `at` erased when `note` is empty.
void replace_note(std::vector<std::string>& notes, std::size_t at, std::string note);

// Stability class (docs/design.md, "Mode kinds and stability classes") of a
// complete set of modes, from their kinds: divergence if any mode is
// divergent, else flutter if any flutters, else marginal if any is a zero
// mode, else asymptotically stable if all are damped, else stable (no modes:
// stable). solve_modes() classifies all modes before keeping the `modes`
// lowest.
Stability classify(const std::vector<Mode>& modes);

}  // namespace modal
