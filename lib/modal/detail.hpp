// lib/modal/detail.hpp — internals of the modal stage shared by its sources
// (not installed, not part of the public API).
//
// solve_modes() (modes.cpp) validates the LinearModel, factors the mass matrix
// once (mass.cpp) and hands the factor to one of two dense solvers:
//   symmetric.cpp    K φ = λ M φ           (no damping, gyroscopic or circulatory terms)
//   first_order.cpp  2n first-order system (everything else)
// Both fill Modes through the helpers below, so that the meaning of every Mode
// field and the clustering diagnostics are written once.
#pragma once

#include "modal/modes.hpp"

#include "core/text.hpp"

#include <Eigen/Cholesky>

#include <complex>
#include <exception>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace modal::detail {

using Cholesky = Eigen::LLT<MatrixX>;

// M's Cholesky factor, formed on first use (by the function given, which
// also tests M's definiteness: factor_mass) or given formed. A point-mass
// chain's path (solve_symmetric) needs none unless MRRR and its bidiagonal
// solve fail: its M = UUᵀ with U⁻¹ bidiagonal is positive definite by its
// structure, and the dense factor (n³/3 flops, OpenBLAS's threads) was an
// eighth of a 1000-link chain's eigen phase. Not for use from several
// threads at once.
class MassFactor {
 public:
  explicit MassFactor(std::function<Cholesky()> make) : make_(std::move(make)) {}
  explicit MassFactor(Cholesky formed) : formed_(std::move(formed)) {}
  const Cholesky& operator()() const {
    if (!definite()) std::rethrow_exception(failure_);
    return *formed_;
  }
  // Whether the factor can be formed (M definite to factor_mass's test). The
  // failure (SingularMassMatrix) is kept and thrown where the factor is
  // then asked for: a chain's path answers without it, where M's
  // definiteness is its structure's, not the normwise test's.
  bool definite() const {
    if (formed_) return true;
    if (failure_) return false;
    try {
      formed_ = make_();
      return true;
    } catch (const SingularMassMatrix&) {
      failure_ = std::current_exception();
      return false;
    }
  }

 private:
  std::function<Cholesky()> make_;
  mutable std::optional<Cholesky> formed_;
  mutable std::exception_ptr failure_;
};

// A lower bound μ > 0 on the smallest eigenvalue of D^{-1/2}MD^{-1/2} for the
// tree's M (`diagonal` = diag M = D, tree_diagonal(p, 0, 1); `mass` M's
// factor through the tree), 0 when none is found: the matrix-free path's
// worst case of rounding through M⁻¹ in its residual bounds (sparse.cpp,
// set_residual).
double tree_mass_floor(const TreePencil& p, const TreeFactor& mass, const VectorX& diagonal);

// Symmetric diagonal equilibration (docs/design.md, "Scaling (equilibration)").
// Every solver works on the congruent pencil (SKS, SMS), S = diag(s), with
// s_i a power of two near 1/√d_i for the coordinates' natural inertia scales
// d (LinearModel::inertia_scale, d_i ≥ M_ii), so that SMS has a diagonal
// below 2 that is near 1 unless the coordinate is near a singularity: the
// scaling is exact in floating point (no rounding, barring overflow and
// underflow), the eigenvalues are those of (K, M) exactly, a shape φ̃ of the
// scaled pencil is φ = Sφ̃ in the original coordinates (φᵀMφ = φ̃ᵀ(SMS)φ̃),
// the residual bound ‖Kφ − λMφ‖_{M⁻¹} is the same number in both, and the
// entries' relative errors are unchanged. What changes is that the
// normwise tests and rounding (definiteness, singularity, Cholesky,
// L⁻¹KL⁻ᵀ) see a mass matrix whose entries are of one size: a graded scene
// (masses or lengths over many decades) is no longer singular "relative to
// ‖M‖". Not diag(M) itself: at a coordinate singularity (spherical angles at
// the pole, M_ii ≈ 1e-32 from rounding) scaling by √M_ii would blow the
// vanishing inertia up to 1 and hide the singularity. A zero (or non-finite)
// d_i gets the geometric mean of the other scales (1 when there are none):
// the coordinate stays without inertia and the singularity test names it.
VectorX equilibrating_scale(const VectorX& diagonal);
// equilibrating_scale(inertia) when it has n entries; otherwise (no natural
// scale: kinematic maps, hand-made models) all ones, no scaling.
VectorX coordinate_scale(const VectorX& inertia, Eigen::Index n);
// diag(s) A diag(s), entry by entry (exact for powers of two), and in place.
MatrixX scale_symmetric(const MatrixX& A, const VectorX& s);
void scale_symmetric_in_place(MatrixX& A, const VectorX& s);
// Whether diag(s) A diag(s) (s: powers of two) is exact: no entry overflows or
// loses digits to underflow.
bool scales_exactly(const MatrixX& A, const VectorX& s);

// Cholesky factor M = L Lᵀ of the symmetric mass matrix M (n×n), normally an
// equilibrated one (SMS above; `scale` = s, empty for none). Throws
// SingularMassMatrix when M is singular or indefinite within the relative
// tolerance 16·ε·‖M‖_F; the message names the coordinate combinations that
// carry no inertia, in the original coordinates (S times the null vectors).
// `names` has n entries. `absolute` (LinearModel::absolute's parent, or
// empty): M is in the absolute angles θ of parallel hinges, and the named
// directions are turned back into the coordinates q = Tθ.
// An upper bound of the smallest eigenvalue of the SPD matrix factored in
// `llt` (n×n), by a few steps of inverse iteration (mass.cpp).
double smallest_eigenvalue_bound(const Cholesky& llt, Eigen::Index n);
// The same with M⁻¹ applied in place by `solve` (x ← M⁻¹x).
double smallest_eigenvalue_bound(const std::function<void(VectorX&)>& solve, Eigen::Index n);

// "the combination 0.71·upper.rx − 0.71·upper.rz" for a unit vector v over
// the coordinates `names` (components below a tenth of the largest left out,
// at most six shown), or "the coordinate upper.rx" when one carries almost all
// of it: how a singular mass matrix's direction is named.
std::string describe_combination(VectorX v, const std::vector<std::string>& names);
// `names` when it names n coordinates, else q1 … qn (mass.cpp).
std::vector<std::string> names_or_default(const std::vector<std::string>& names, Eigen::Index n);

Cholesky factor_mass(const MatrixX& M, const std::vector<std::string>& names, const VectorX& scale = {},
                     const std::vector<int>& absolute = {});

// M = UUᵀ + R of a planar chain of rigid links in absolute angles (docs/
// design.md, "Chains of rigid links"): U = D_l Ĵᵀ D_μ^½ as a point-mass
// chain's (upper triangular, U⁻¹ upper bidiagonal) and R diagonal. Each
// link's centre of mass on the line of the hinges makes M_ij = l_i a_j for
// i < j (semiseparable), whatever its rotational inertia, which with the
// centre of mass's offset goes to R (negative for a uniform rod: −ml²/6).
struct LinkChain {
  PointMassChain generators;  // l (signed, l_0 = 1: a convention) and μ > 0 of UUᵀ; mismatch: of M's off-diagonal entries against UUᵀ's
  VectorX remainder;          // n: R_jj = M_jj − (UUᵀ)_jj (R_00 = R_{n−1,n−1} = 0)
};
// M's structure as such a chain, read from its entries (n×n, n ≥ 3: l_i from
// column n − 1, a_j from row 0, every entry above the diagonal within 1e-12
// relative of (UUᵀ)_ij as formed from the suffix sums of μ, every μ_j =
// a_j/l_j − a_{j+1}/l_{j+1} positive, every number finite and nonzero);
// else nothing. Whether M is definite is not decided here (the solver's
// factor of I + U⁻¹RU⁻ᵀ decides).
std::optional<LinkChain> link_chain(const MatrixX& M);

// K φ = λ M φ with K, M symmetric (n×n) and `mass` the factor of M (formed
// where the path needs it).
// `K_error` (n×n, or empty: 4ε|K|) estimates the absolute error of K's
// entries (LinearModel::K_error). Fills modes (ascending λ), morse_index,
// zero_modes, solver, notes (not the cluster notes: add_cluster_notes, once
// the eigenvalues are in the caller's units).
// `solver` picks Eigen's self-adjoint QR or LAPACK's dsygvd (automatic:
// lapack_wins(n)).
// `K_systematic_error` (n×n or empty) is the part of K_error measured from
// differences (LinearModel::K_systematic_error).
// `wanted` (≥ 0): only the lowest `wanted` modes are needed; every mode is
// still returned and classified, but the others carry a normwise estimate
// (no shape) unless their kind is in doubt (see symmetric.cpp).
// `K_rounding_form` (n×n or empty; LinearModel::K_rounding_form, scaled as
// K): where given, the kinds take the data's rounding as 4ε φᵀFφ instead of
// the entrywise |φ|ᵀ(K_error − K_systematic_error)|φ|.
// `springs` (or null; LinearModel::K_spring_rounding, scaled as K): where
// given, the estimates may take the springs' rounding at its typical size
// (spring_by_spring).
// `chain` (or null): M's point-mass chain structure (PointMassChain, in the
// units of M as given), within its mismatch of M: the products with M and
// M⁻¹ of the analysis then cost O(n) per vector, and where K is diagonal
// every pair comes from the tridiagonal U⁻¹KU⁻ᵀ (MRRR) in O(n²), and where
// the chain hangs (every K_jj > 0) the lowest from the bidiagonal U⁻¹K^½.
// `links` (or null; not with `chain`): M's structure as a chain of rigid
// links (LinkChain), within its mismatch of M: where LAPACK solves and K is
// diagonal, the analysis's products and solves with M by that structure in
// O(n) per vector, and the pairs from the tridiagonal pencil
// (U⁻¹KU⁻ᵀ, I + U⁻¹RU⁻ᵀ) reduced to standard form by LAPACK dsbgst (T in
// O(n²), its transformation X in Θ(n³) of plane rotations).
struct ScaledSprings;  // below
ModalResult solve_symmetric(const MatrixX& M, const MatrixX& K, const MassFactor& mass, const MatrixX& K_error = {},
                            const MatrixX& K_systematic_error = {}, DenseSolver solver = DenseSolver::automatic,
                            Eigen::Index wanted = -1, const SparseMatrix& K_rounding_form = SparseMatrix(),
                            const PointMassChain* chain = nullptr, const LinkChain* links = nullptr,
                            const ScaledSprings* springs = nullptr);
// The documented rule of DenseSolver::automatic: LAPACK from lapack_threshold coordinates.
bool lapack_wins(Eigen::Index n);
// Whether every entry off A's diagonal is zero (O(n²), leaves at the first
// that is not).
bool is_diagonal(const MatrixX& A);

// M q̈ + C q̇ + K q = 0 with C = D + G (all n×n, K and C unrestricted) as the 2n
// first-order system. Fills modes (ascending ω, then σ), morse_index,
// zero_modes, solver, notes (not the cluster notes, as above).
// `K_error` (n×n or empty: 4ε|K|) bounds K's entries' errors as in
// solve_symmetric; `K_systematic_error` and `C_error` (n×n or empty) are
// measured entrywise errors of K and C (differences: LinearModel::
// K_systematic_error, G_error), whose effect the estimates include;
// `C_rounding` (n×n or empty: 4ε|C|) bounds the rounding of C's entries.
// `K_rounding_form` (n×n or empty) as for solve_symmetric: where given, the
// kinds take K's rounding as 4ε times F's bilinear bound instead of the
// entrywise one.
ModalResult solve_first_order(const MatrixX& M, const MatrixX& K, const MatrixX& C, const Cholesky& mass,
                              const MatrixX& K_error = {}, const MatrixX& K_systematic_error = {},
                              const MatrixX& C_error = {}, const MatrixX& C_rounding = {},
                              const SparseMatrix& K_rounding_form = SparseMatrix());

// Exact rescaling by powers of two of the magnitudes of a solved pencil:
// the solvers ran on (αM, √(αβ)C, βK) with α = 4^a, β = 4^b, so that no
// square of an entry or of λ over- or underflows in the estimates; the
// eigenvalues of the model are λ = λ' α/β and s = s' 2^(a−b), and a
// symmetric (M-normalized) shape is φ = 2^a φ'. `symmetric` says which
// fields carry meaning. Throws NumericalError when an eigenvalue, estimate
// or bound is not finite afterwards (it overflowed: no class can be given).
struct Magnitudes {
  int a = 0, b = 0;  // exponents of four for M and K
};
// The exponents that bring the largest absolute entries of M and K (given)
// near 1 (0 for a zero or non-finite one).
Magnitudes magnitudes(double largest_M, double largest_K);
// Multiplies A by 2^p entry by entry; false (A unchanged) when that would
// not be exact (overflow, underflow to subnormals). scales_exactly: the test alone.
bool scale_exactly(MatrixX& A, int p);
bool scales_exactly(const MatrixX& A, int p);
void restore_magnitudes(ModalResult& result, const Magnitudes& m, bool symmetric);

// A Mode with the eigenvalue fields filled from s = σ + iω (1/s) and its kind:
// growth_rate, omega, frequency_hz, period, damping_ratio (NaN for zero modes).
// omega2 is left NaN, shape empty; error_estimate is set to `error`.
Mode make_mode(std::complex<double> s, double error, ModeKind kind);

// The typical size of the rounding in a Rayleigh quotient λ = φᵀKφ/φᵀMφ
// and of the assembly's rounding of K and M, for an error estimate (the
// worst case sums the same magnitudes without square roots: residual_bound),
// all for an M-normalized φ. Rounding errors of different entries taken as
// independent, each at its worst size, and the sum doubled:
//   2ε(√width·rows + √n·sums) + 2·entries,
// rows = ‖φ∘(|K||φ| + |λ||M||φ|)‖₂ (each entry of Kφ, Mφ a sum of `width`
// terms), sums = Σ_i |φ_i (Kφ)_i| (the n terms of φᵀ(Kφ)), entries =
// (Σ_ij (δK_ij φ_i φ_j)²)^½ + |λ| (Σ_ij (δM_ij φ_i φ_j)²)^½ for the entries'
// own errors δK, δM at their worst (4ε per entry unless given). On a smooth
// mode of a net or a long chain, |φ|ᵀ|K||φ| and |φ|ᵀ|M||φ| are 10²–10⁶ × λ,
// and the worst case made the estimates as many times the true error. Used
// by the dense and sparse paths alike.
double typical_quotient_rounding(double width, double n, double rows, double sums, double entries);

// SpringRounding as it applies to the pencil (S K S)·2^b the solvers see:
// G's columns by S (`scale`, empty: none), the sizes by 2^b (`factor`),
// `others` by S²·2^b, applied on the fly (at 10⁶ coordinates a copy of G
// and the blocks is about 110 MB).
struct ScaledSprings {
  const SpringRounding* springs = nullptr;  // or null: none
  VectorX scale;
  double factor = 1;
  // Whether it is given and of n coordinates.
  bool fits(Eigen::Index n) const;
};
// The data's rounding of φᵀKφ at its typical size from the springs'
// rounding kept spring by spring (+∞ where `springs` is not given or not of
// φ's size), in the units of typical_quotient_rounding's `entries` over 4ε
// (which that doubles): ε(C + R)/8 … see modes.cpp.
double spring_by_spring(const ScaledSprings& springs, const VectorX& phi);

// Shapes solved in the absolute angles θ of parallel hinges to the model's
// coordinates, q_c = θ_c − θ_parent(c) (parent: per coordinate, −1 where
// it is its own), signed again (modes.cpp).
void absolute_to_relative(const std::vector<int>& parent, bool real, std::vector<Mode>& modes);

// A hanging point-mass chain's lowest `wanted` modes (all where wanted ≤ 0
// or ≥ n) from its O(n) data in absolute angles (TreePencil::chain, chain_K,
// chain_K_terms): the singular values of the bidiagonal U⁻¹K^½, Sturm-count brackets as
// residual bounds, the chain's estimates, shapes in relative angles
// (q_j = θ_j − θ_{j−1}). O(n·wanted). Nothing where the chain's path cannot
// answer rigorously (some K_jj ≤ 0, over- or underflow, a bracket not
// verified): the caller then solves otherwise (symmetric.cpp).
std::optional<ModalResult> solve_chain_modes(const PointMassChain& chain, const VectorX& K, const VectorX& K_terms,
                                             Eigen::Index wanted);

// Index of the largest-|component| entry of v; among entries equal to the
// largest within a relative 1e-12 (ties broken by rounding), the first.
Eigen::Index dominant_index(const Eigen::VectorXcd& v);

using text::format_number;  // core/text.hpp

}  // namespace modal::detail
