// lib/modal/sparse.cpp — solve_sparse_modes(): the k lowest (or the k nearest
// a shift) modes of a large sparse symmetric-definite pencil K φ = λ M φ.
//
// Method. Shift-invert Lanczos: for a shift σ the operator
// OP = (K − σM)⁻¹ M is self-adjoint in the M-inner product and has the
// eigenvalues ν = 1/(λ − σ), so the λ nearest σ are the ν of largest modulus,
// which a restarted Lanczos iteration finds in a few dozen applications of OP.
// Spectra's SymGEigsShiftSolver runs the iteration (in the M-inner product, so
// its Ritz vectors are M-orthonormal); OP is applied by a sparse factorization
// of K − σM computed once per shift with CHOLMOD, which chooses by the fill:
// a supernodal LLᵀ (BLAS-3; exists only when K − σM is positive definite) or a
// simplicial LDLᵀ (very sparse factors such as chains; exists for indefinite
// matrices too, unless a pivot is exactly zero; no pivoting, so its solves of
// an indefinite matrix get one step of iterative refinement). When the
// supernodal LLᵀ fails (K − σM indefinite), MUMPS factors K − σM by a
// multifrontal LDLᵀ with 1×1 and 2×2 pivoting (BLAS-3 fronts, like the
// supernodal LLᵀ). M is factored once by CHOLMOD (not positive definite →
// SingularMassMatrix) for the error estimates. Symbolic analyses (orderings)
// are computed once and reused for every shift (K and M are put on one
// sparsity pattern).
//
// Inertia (Sylvester's law). K − σM is congruent to diag(λ_i − σ), so the
// number of negative eigenvalues of D in any LDLᵀ factorization of it
// (P(K − σM)Pᵀ = LDLᵀ, D with 1×1 or 2×2 blocks) is the number of eigenvalues
// below σ, and a successful Cholesky factorization says there are none. That count is what guarantees that no
// negative or zero mode is lost, whatever the Lanczos iteration does.
//
// Shift rule (options.shift unset: the k lowest modes). Scale
// s = max_i K_ii/M_ii (the largest "diagonal frequency²"; if not positive,
// max_i |K_ii|/M_ii, then max|K_ij|/max M_ii, then 1) and ζ = 1e-8·s. The
// default shift is σ₀ = −ζ: far enough below 0 (eight orders of magnitude above
// the rounding level ε·s of a zero eigenvalue) that rigid-body modes leave
// K − σ₀M positive definite, close enough that the zero and low modes are the
// dominant ν. The inertia m at σ₀ is the number of eigenvalues below −ζ: the
// Morse index.
//   m = 0: one Lanczos run at σ₀ returns the k lowest (K − σ₀M definite).
//   m > 0 (a divergent equilibrium): with k > m, a run at σ₀ (LDLᵀ) for the
//     k nearest σ₀, which hold at most m negative eigenvalues and therefore
//     the k − m lowest non-negative ones (probed as where m = 0, moved only
//     to shifts where the inertia is still m, and followed by the copies
//     check where moved); if it also found all m negative ones that is the
//     answer. Otherwise (and always when k ≤ m) a second shift
//     σ_L below the whole spectrum is found from the inertia alone (Cholesky
//     succeeds ⇔ no eigenvalue below): start a quarter beyond a Gershgorin
//     bound of D^{-1/2}KD^{-1/2}, D = diag M (rigorous for a diagonal M, a
//     guess otherwise; the bound itself can be λ₁), move down by factors of
//     4 until K − σM is definite, then up (factors of 8, then bisection)
//     until σ_L is within a quarter of its distance to σ₀ below the lowest
//     eigenvalue λ₁, which makes λ₁ the dominant ν by at least a factor of 4
//     over every non-negative λ. Runs at σ_L give the most negative ones:
//     with k ≤ m the k lowest, all below σ₀; with k > m all m, repeated
//     wanting more while fewer are found below σ₀ than the inertia counts
//     there (else NumericalError). The k returned are checked for
//     completeness either way (check_completeness).
// morse_index = m plus the returned modes in [−ζ, 0) that are negative beyond
// their error estimate (so it is the count of all negative eigenvalues below
// −ζ, returned or not, and never hides a resolved negative λ above it).
// With options.shift = σ the k modes nearest σ are returned; the inertia at σ
// (eigenvalues below σ) is reported in a note and the Morse index still comes
// from the inertia at σ₀. A shift at which the LDLᵀ factorization breaks down
// (a zero pivot: σ is an eigenvalue, or an unlucky pivot order) is moved by
// 1e-6·max(|σ|, s), with a note.
//
// Convergence: options.tolerance and options.max_iterations (restarts) are
// Spectra's: a Ritz value θ of OP is accepted when its residual estimate is
// below tolerance·|θ|, so ‖Kφ − λMφ‖ ends near tolerance·‖K − σM‖·‖φ‖ and λ,
// quadratic in the residual, is far more accurate than that.
//
// Small problems (n ≤ 200) and k ≥ n − 1 (Spectra needs k < n − 1 … n) are
// solved densely (detail::solve_symmetric) and the k wanted modes kept.
//
// Each mode: φ M-normalized (φᵀMφ = 1), largest |component| positive;
// λ = φᵀKφ, the Rayleigh quotient of the converged Ritz vector, rather than
// σ + 1/ν from the Ritz value: forming K − σM rounds every entry, which moves
// the Ritz values by about ε·max|K_ii| (5e-11 relative for the lowest mode of
// a 2000-mass chain), while the Rayleigh quotient uses K itself (1e-14);
// residual_bound = ‖Kφ − λMφ‖_{M⁻¹}
// = sqrt(rᵀM⁻¹r), r = Kφ − λMφ (by the M-factor): for the symmetric-definite
// pencil some eigenvalue lies within it of λ (the residual bound in the
// M-inner product), plus the componentwise rounding of forming r and of
// evaluating φᵀKφ, and ε|λ| (make_sparse_mode); squared over the gap
// (Kato–Temple) where the completeness check says which eigenvalues are
// near. error_estimate takes the rounding at its typical size, with the
// assembly's rounding of K and M, and the Rayleigh quotient's error at its
// second-order size where the factor at the check's bound is at hand; plus a
// loose equilibrium's share (lanczos_modes; docs/design.md "Sparse modes").
// A mode is a zero mode when |λ| is within that estimate or within the
// residual at its typical size plus the data's rounding at its worst (4ε φᵀFφ
// with the rounding form F where given, else componentwise through K's
// terms; + 4ε|λ||φ|ᵀ|M||φ|), and divergent when λ < 0 beyond both. (Not a
// normwise level 4ε(‖K‖₁ + |λ|‖M‖₁)‖φ‖²: on a graded chain it called modes
// resolved to 1e-5 of themselves zero.)
//
// Cost. One symbolic analysis and one numeric factorization of K − σM
// (O(nnz(L)) memory); per restart of the Lanczos iteration about ncv − k
// solves with the factor (O(nnz(L)) each) and products with M, plus
// O(n·ncv²) orthogonalization, ncv = max(2k + 1, 20) ≤ n; one CHOLMOD
// factorization of M and k solves for the error estimates. A divergent
// equilibrium adds an LDLᵀ at σ₀, a handful of Cholesky attempts to place σ_L
// (each O(nnz(L))) and a second Lanczos run. A user shift adds the factorization
// at σ₀ for the Morse index.
#include "detail.hpp"
#include "core/cholmod_factor.hpp"
#include "core/pairwise_dot.hpp"
#include "core/sparse_product.hpp"
#include "mumps.hpp"

#include <Eigen/CholmodSupport>
#include <Eigen/Eigenvalues>
#include <Spectra/SymGEigsShiftSolver.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <new>
#include <numeric>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace modal {
namespace {

using Index = Eigen::Index;

constexpr double eps = std::numeric_limits<double>::epsilon();
constexpr double nan = std::numeric_limits<double>::quiet_NaN();
constexpr Index dense_limit = 200;  // n at or below which the dense solver runs

// ---------------------------------------------------------------- validation

void require_finite(const SparseMatrix& A, const char* what) {
  for (Index j = 0; j < A.outerSize(); ++j)
    for (SparseMatrix::InnerIterator it(A, j); it; ++it)
      if (!std::isfinite(it.value())) {
        std::ostringstream out;
        out << "solve_sparse_modes: the " << what << " has a non-finite entry (" << it.value() << " at row "
            << it.row() + 1 << ", column " << it.col() + 1 << "): the problem cannot be solved";
        throw NumericalError(out.str());
      }
}

// max_j Σ_i |A_ij|, which bounds ‖A‖₂ for a symmetric A.
double norm1(const SparseMatrix& A) {
  double best = 0;
  for (Index j = 0; j < A.outerSize(); ++j) {
    double column = 0;
    for (SparseMatrix::InnerIterator it(A, j); it; ++it) column += std::abs(it.value());
    best = std::max(best, column);
  }
  return best;
}

// ½(A + Aᵀ), or nothing when A is not symmetric up to the rounding of an
// assembly by sums: ‖A − Aᵀ‖_F ≤ 100·c·ε·‖A‖_F with c the largest number of
// entries in a column. Aᵀ is formed once for both.
std::optional<SparseMatrix> symmetric_part(const SparseMatrix& A) {
  Index widest = 1;
  for (Index j = 0; j < A.outerSize(); ++j) {
    Index count = 0;
    for (SparseMatrix::InnerIterator it(A, j); it; ++it) ++count;
    widest = std::max(widest, count);
  }
  const SparseMatrix At = A.transpose();
  if (SparseMatrix(A - At).norm() > 100.0 * static_cast<double>(widest) * eps * A.norm()) return std::nullopt;
  SparseMatrix S = 0.5 * (A + At);
  S.makeCompressed();
  return S;
}

// K and M rewritten on the union of their patterns (identical index arrays,
// explicit zeros kept), so that K − σM is formed entry by entry for any σ and
// one symbolic analysis serves every shift.
void to_common_pattern(SparseMatrix& K, SparseMatrix& M) {
  const Index n = K.cols();
  std::vector<Eigen::Triplet<double>> tk, tm;
  tk.reserve(static_cast<std::size_t>(K.nonZeros() + M.nonZeros()));
  tm.reserve(tk.capacity());
  for (Index j = 0; j < n; ++j) {
    SparseMatrix::InnerIterator a(K, j), b(M, j);
    while (a || b) {
      const Index i = !b ? a.index() : !a ? b.index() : std::min(a.index(), b.index());
      double kv = 0, mv = 0;
      if (a && a.index() == i) { kv = a.value(); ++a; }
      if (b && b.index() == i) { mv = b.value(); ++b; }
      tk.emplace_back(static_cast<int>(i), static_cast<int>(j), kv);
      tm.emplace_back(static_cast<int>(i), static_cast<int>(j), mv);
    }
  }
  SparseMatrix Kc(n, n), Mc(n, n);
  Kc.setFromTriplets(tk.begin(), tk.end());
  Mc.setFromTriplets(tm.begin(), tm.end());
  Kc.makeCompressed();
  Mc.makeCompressed();
  const bool same = Kc.nonZeros() == Mc.nonZeros() &&
                    std::equal(Kc.outerIndexPtr(), Kc.outerIndexPtr() + n + 1, Mc.outerIndexPtr()) &&
                    std::equal(Kc.innerIndexPtr(), Kc.innerIndexPtr() + Kc.nonZeros(), Mc.innerIndexPtr());
  if (!same) throw std::logic_error("solve_sparse_modes: K and M could not be put on one sparsity pattern");
  K = std::move(Kc);
  M = std::move(Mc);
}

// --------------------------------------------------------------- mass matrix

// A CHOLMOD factorization (through Eigen's wrapper) that also reports the
// signs of its pivots. Mode CholmodAuto lets CHOLMOD choose: a supernodal LLᵀ
// (BLAS-3, for factors with dense fill) succeeds only for a positive definite
// matrix; a simplicial LDLᵀ (for very sparse factors, such as chains) succeeds
// for any matrix without a zero pivot, and its D gives the inertia. Mode
// CholmodLDLt forces the simplicial LDLᵀ.
// Whether `order` holds each of 0..n−1 exactly once.
bool is_pivot_order(const std::vector<int>& order, Index n) {
  if (order.size() != static_cast<std::size_t>(n)) return false;
  std::vector<char> seen(order.size(), 0);
  for (int i : order) {
    if (i < 0 || i >= n || seen[static_cast<std::size_t>(i)] != 0) return false;
    seen[static_cast<std::size_t>(i)] = 1;
  }
  return true;
}

class CholmodFactor : public detail::CholmodAccess<Eigen::CholmodDecomposition<SparseMatrix, Eigen::Lower>> {
 public:
  explicit CholmodFactor(Eigen::CholmodMode mode = Eigen::CholmodAuto) { setMode(mode); }
  ~CholmodFactor() {
    for (cholmod_dense** d : {&x_, &y_, &e_}) cholmod_free_dense(d, &cholmod());
  }
  // y = A⁻¹x for one vector, in two parts where the factor is large
  // (solve_in_parts), else through cholmod_solve2 with workspace kept from
  // call to call (Eigen's solve() allocates and frees three n-vectors per
  // call, which dominates the many solves of a Lanczos run). False when
  // CHOLMOD fails.
  // `columns` right-hand sides at once (n × columns, column-major): the
  // supernodal solve then runs on blocks (BLAS 3), several times cheaper
  // per vector than one at a time.
  bool solve_into(const double* in, double* out, int columns = 1) {
    if (columns == 1 && solve_in_parts(in, out)) return true;
    cholmod_dense b{};
    b.nrow = b.d = m_cholmodFactor->n;
    b.ncol = static_cast<std::size_t>(columns);
    b.nzmax = b.nrow * b.ncol;
    b.x = const_cast<double*>(in);  // read only: B is an input of cholmod_solve2
    b.xtype = CHOLMOD_REAL;
    b.dtype = CHOLMOD_DOUBLE;
    if (!cholmod_solve2(CHOLMOD_A, m_cholmodFactor, &b, nullptr, &x_, nullptr, &y_, &e_, &cholmod())) return false;
    std::copy_n(static_cast<const double*>(x_->x), b.nzmax, out);
    return true;
  }
  // The symbolic analysis of A (both triangles stored; the lower one is
  // read) in the pivot order `order` (order[k] = the k-th variable), which
  // CHOLMOD then only postorders; when `order` is not a permutation of
  // 0..n−1, CHOLMOD's own choice (analyzePattern).
  void analyze(const SparseMatrix& A, const std::vector<int>& order) {
    if (!is_pivot_order(order, A.rows())) {
      analyzePattern(A);
      return;
    }
    if (m_cholmodFactor != nullptr) cholmod_free_factor(&m_cholmodFactor, &cholmod());
    cholmod_sparse a = Eigen::viewAsCholmod(A.selfadjointView<Eigen::Lower>());
    const int nmethods = cholmod().nmethods;
    const int ordering = cholmod().method[0].ordering;
    cholmod().nmethods = 1;
    cholmod().method[0].ordering = CHOLMOD_GIVEN;
    m_cholmodFactor = cholmod_analyze_p(&a, const_cast<int*>(order.data()), nullptr, 0, &cholmod());
    cholmod().nmethods = nmethods;
    cholmod().method[0].ordering = ordering;
    m_isInitialized = true;
    m_factorizationIsOk = false;
    check_analysis(A.rows());
    m_analysisIsOk = true;
    m_info = Eigen::Success;
  }
  // Frees a supernodal factor's numeric part and keeps its symbolic
  // analysis (the next factorize needs no new one): while MUMPS holds
  // K − σM, the two factors need not occupy memory at once (a slack net of
  // 10⁶ coordinates: peak 5.70 → 4.92 GB; on a virtual machine every page
  // first touched also costs time, about 0.4 GB/s measured here). A
  // simplicial factor (small: chains) is left as it is.
  void release_numeric() {
    if (m_cholmodFactor == nullptr || !m_cholmodFactor->is_super || m_cholmodFactor->xtype == CHOLMOD_PATTERN) return;
    cholmod_change_factor(CHOLMOD_PATTERN, /*to_ll=*/1, /*to_super=*/1, /*to_packed=*/1, /*to_monotonic=*/1,
                          m_cholmodFactor, &cholmod());
    m_factorizationIsOk = false;
  }
  // Whether the factor is LDLᵀ (else LLᵀ); valid after a factorization.
  bool is_ldlt() const { return m_cholmodFactor != nullptr && !m_cholmodFactor->is_ll && !m_cholmodFactor->is_super; }
  // Whether the symbolic analysis chose a supernodal (LLᵀ) factor.
  bool is_supernodal() const { return m_cholmodFactor != nullptr && m_cholmodFactor->is_super; }
  // Negative and zero entries of D (LDLᵀ; an LLᵀ factor that exists has none).
  std::pair<Index, Index> nonpositive_pivots() const {
    if (!is_ldlt()) return {0, 0};
    const auto* x = static_cast<const double*>(m_cholmodFactor->x);
    const auto* p = static_cast<const int*>(m_cholmodFactor->p);  // D(j,j) leads column j
    Index negative = 0, zero = 0;
    for (std::size_t j = 0; j < m_cholmodFactor->n; ++j) {
      const double d = x[p[j]];
      if (d < 0) ++negative;
      else if (!(d > 0)) ++zero;  // zero or NaN
    }
    return {negative, zero};
  }

 private:
  cholmod_dense *x_ = nullptr, *y_ = nullptr, *e_ = nullptr;  // cholmod_solve2's reusable workspace
};

// The options without their n×n matrices (K_systematic_error, K_magnitude,
// K_equilibrium_shift) and inertia_scale, which the solver has taken, scaled,
// as its own: the rest of the solve reads only the scalars, the pivot order
// and the names, and a copy of K's size (180 MB at 10⁶ coordinates) is not
// made on the way.
SparseModalOptions without_matrices(const SparseModalOptions& options) {
  SparseModalOptions o;
  o.modes = options.modes;
  o.shift = options.shift;
  o.tolerance = options.tolerance;
  o.max_iterations = options.max_iterations;
  o.fill_reducing_order = options.fill_reducing_order;
  o.coordinate_names = options.coordinate_names;
  o.memory_limit = options.memory_limit;
  return o;
}

// Whether every entry x of A has 2^p x in range with 2^-p (2^p x) = x (so
// that scaling A by 2^p is exact and undone exactly), without a copy of A.
bool exactly_scalable(const SparseMatrix& A, int p) {
  if (p == 0) return true;
  const double* v = A.valuePtr();
  for (Index i = 0; i < A.nonZeros(); ++i) {
    const double y = std::ldexp(v[i], p);
    if (!std::isfinite(y) || std::ldexp(y, -p) != v[i]) return false;
  }
  return true;
}

// Whether S A S, S = diag(s) (s and s⁻¹ powers of two), is exact and undone
// exactly by s⁻¹ = `inverse`: no entry overflows or underflows.
bool exactly_scalable(const SparseMatrix& A, const VectorX& s, const VectorX& inverse) {
  for (Index c = 0; c < A.outerSize(); ++c)
    for (SparseMatrix::InnerIterator it(A, c); it; ++it) {
      const double y = s[it.row()] * it.value() * s[c];
      if (!std::isfinite(y) || inverse[it.row()] * y * inverse[c] != it.value()) return false;
    }
  return true;
}

// A ← 2^p A, in place.
void scale_in_place(SparseMatrix& A, int p) {
  if (p == 0) return;
  Eigen::Map<VectorX> v(A.valuePtr(), A.nonZeros());
  v = v.unaryExpr([p](double x) { return std::ldexp(x, p); });
}

// A ← S A S, S = diag(s), in place.
void scale_in_place(SparseMatrix& A, const VectorX& s) {
  for (Index c = 0; c < A.outerSize(); ++c)
    for (SparseMatrix::InnerIterator it(A, c); it; ++it) it.valueRef() *= s[it.row()] * s[c];
}

// The coordinates' names of the options, or q1 … qn.
std::vector<std::string> coordinate_names(const SparseModalOptions& options, Index n) {
  return detail::names_or_default(options.coordinate_names, n);
}

[[noreturn]] void singular_mass(const SparseMatrix& M, const std::string& detail_text) {
  std::ostringstream out;
  out << "the mass matrix is singular or not positive definite to double precision (" << detail_text << ")";
  std::vector<Index> bad;
  for (Index i = 0; i < M.rows(); ++i)
    if (!(M.coeff(i, i) > 0)) bad.push_back(i);
  if (!bad.empty()) {
    out << "; coordinates without inertia (diagonal entry ≤ 0):";
    for (std::size_t j = 0; j < std::min<std::size_t>(bad.size(), 8); ++j) out << " q" << bad[j] + 1;
    if (bad.size() > 8) out << " and " << bad.size() - 8 << " more";
  }
  out << "; a body without mass or inertia, a coordinate singularity, or coordinates in which M is too "
         "ill-conditioned for double precision (condition number near 1/ε even after scaling by the coordinates' "
         "inertia)";
  throw SingularMassMatrix(out.str());
}

// CHOLMOD factor of M, the equilibrated mass matrix SMS (`scale` = s, see
// detail::equilibrating_scale); SingularMassMatrix when M is not positive
// definite (a failed LLᵀ, or non-positive pivots of an LDLᵀ) or its smallest
// eigenvalue is at the rounding level 16·ε·‖M‖₁ (the bound comes from a few
// steps of inverse iteration: 1/ρ ≥ λ_min, ρ the Rayleigh quotient of M⁻¹, as
// in mass.cpp), the direction named in the original coordinates (S x).
std::unique_ptr<CholmodFactor> factor_sparse_mass(const SparseMatrix& M, const VectorX& scale,
                                                  const std::vector<std::string>& names, double memory_limit) {
  auto llt = std::make_unique<CholmodFactor>();
  llt->memory_limit = memory_limit;
  llt->compute(M);
  if (llt->info() != Eigen::Success) singular_mass(M, "its sparse Cholesky factorization (CHOLMOD) failed");
  if (const auto [negative, zero] = llt->nonpositive_pivots(); negative + zero > 0)
    singular_mass(M, "its sparse LDLᵀ factorization (CHOLMOD) has " + std::to_string(negative) + " negative and " +
                         std::to_string(zero) + " zero pivots");
  const Index n = M.rows();
  VectorX x(n);
  for (Index i = 0; i < n; ++i) x(i) = 1.0 + 0.5 * std::cos(2.399963 * static_cast<double>(i + 1));
  x.normalize();
  double rho = 0;
  for (int it = 0; it < 8; ++it) {
    VectorX y = llt->solve(x);
    rho = x.dot(y);
    const double norm = y.norm();
    if (!(norm > 0) || !std::isfinite(norm)) singular_mass(M, "M⁻¹ overflows");
    x = y / norm;
  }
  const double tolerance = 16 * eps * norm1(M);
  if (!(rho > 0) || 1.0 / rho <= tolerance)
    singular_mass(M, "smallest eigenvalue about " + detail::format_number(rho > 0 ? 1.0 / rho : 0.0, 2) +
                         " of ‖M‖₁ = " + detail::format_number(norm1(M), 3) +
                         " (M scaled by the coordinates' inertia), at the rounding level; direction " +
                         detail::describe_combination(scale.cwiseProduct(x).normalized(), names));
  return llt;
}

// ------------------------------------------------------- K − σM, factored

// The MUMPS LDLᵀ with pivoting: detail::MumpsLdlt (mumps.hpp).
using detail::MumpsLdlt;

// The factorization of K − σM for one σ at a time (K, M on one pattern):
// CHOLMOD's automatic choice (supernodal LLᵀ, or simplicial LDLᵀ for very
// sparse factors); when a supernodal LLᵀ fails (K − σM indefinite) and the
// inertia is wanted, MUMPS's LDLᵀ with pivoting.
class ShiftedFactor {
 public:
  // `order`: the fill-reducing order of CholmodFactor::analyze (empty:
  // CHOLMOD's choice); `memory_limit`: CholmodAccess::memory_limit.
  ShiftedFactor(const SparseMatrix& K, const SparseMatrix& M, std::vector<int> order, double memory_limit = 0)
      : K_(K), M_(M), A_(K), order_(std::move(order)), memory_limit_(memory_limit) {}

  Index size() const { return K_.rows(); }
  double sigma() const { return sigma_; }
  bool valid() const { return active_ != Active::none; }
  bool positive_definite() const { return valid() && !indefinite_; }
  bool indefinite() const { return indefinite_; }
  int factorizations() const { return factorizations_; }

  // Factors K − σM and returns the number of eigenvalues below σ (the
  // negative pivots; 0 when an LLᵀ factor exists), or nothing when K − σM has
  // no factorization (a zero pivot). With `inertia` false, returns nothing as
  // soon as K − σM is known not to be positive definite (cheaper: no LDLᵀ is
  // attempted after a failed supernodal LLᵀ). `expect_indefinite`: the
  // caller knows of a vector with a negative Rayleigh quotient, so a
  // supernodal LLᵀ would only fail (after up to a whole factorization's work):
  // go to the LDLᵀ with pivoting at once. A hint only; the count is exact
  // either way. `normwise_null`: MUMPS's own test of null pivots (for a
  // shift the user chose, which may be an eigenvalue), instead of rows that
  // underflow (MumpsLdlt::factor).
  std::optional<Index> factor(double sigma, bool inertia = true, bool expect_indefinite = false,
                              bool normwise_null = false) {
    assemble(sigma);
    active_ = Active::none;
    const bool skip_llt = inertia && expect_indefinite && analyzed_ && automatic_supernodal_;
    if (!skip_llt) {
      // MUMPS's factor, of another σ: freed first, so that the two factors
      // never occupy memory at once (MUMPS 5.5 frees its factors only with
      // the whole instance: its analysis is redone when next needed).
      mumps_.reset();
      if (std::optional<Index> below = factor_automatic()) {
        active_ = Active::cholmod;
        indefinite_ = *below > 0;
        return below;
      }
    }
    if (!inertia || !automatic_supernodal_) return std::nullopt;
    // The automatic choice was a supernodal LLᵀ, which fails for an
    // indefinite matrix: MUMPS's LDLᵀ gives the inertia.
    if (!mumps_) mumps_ = std::make_unique<MumpsLdlt>(A_, automatic_->ordering(), memory_limit_);
    automatic_->release_numeric();  // CHOLMOD's factor, failed or of another σ: refactored when next needed
    ++factorizations_;
    if (std::optional<Index> below = mumps_->factor(A_, normwise_null)) {
      active_ = Active::mumps;
      indefinite_ = *below > 0;
      return below;
    }
    return std::nullopt;
  }

  // Whether K − σM is positive definite (no eigenvalue below σ).
  bool positive_definite_at(double sigma) {
    const std::optional<Index> below = factor(sigma, false);
    return below && *below == 0;
  }

  // Y = (K − σM)⁻¹ X for `columns` vectors (n × columns, column-major).
  void solve(const double* in, double* out, int columns = 1) const {
    if (active_ == Active::mumps) {
      if (!mumps_->solve(in, out, columns))
        throw NumericalError("solve_sparse_modes: a MUMPS solve with K − σM failed");
      return;
    }
    if (active_ == Active::none) throw std::logic_error("solve_sparse_modes: solve without a factorization");
    if (!automatic_->solve_into(in, out, columns)) solve_failed();
    if (indefinite_) {
      // CHOLMOD's LDLᵀ does not pivot: for an indefinite matrix its entries may
      // grow; one step of iterative refinement recovers most of the lost accuracy.
      const Eigen::Map<const MatrixX> x(in, size(), columns);
      Eigen::Map<MatrixX> y(out, size(), columns);
      residual_ = x - A_ * y;
      correction_.resize(size(), columns);
      if (!automatic_->solve_into(residual_.data(), correction_.data(), columns)) solve_failed();
      y += correction_;
    }
  }

  std::string describe() const {
    switch (active_) {
      case Active::none: return "no factorization";
      case Active::mumps: return "MUMPS LDLᵀ with pivoting";
      case Active::cholmod: break;
    }
    return automatic_->is_ldlt() ? "CHOLMOD simplicial LDLᵀ" : "CHOLMOD supernodal LLᵀ";
  }

 private:
  // A CHOLMOD solve that failed: for lack of memory (its workspace), the
  // program's out-of-memory failure, not a numerical one.
  [[noreturn]] void solve_failed() const {
    if (automatic_->out_of_memory()) throw std::bad_alloc();
    throw NumericalError("solve_sparse_modes: a CHOLMOD solve with K − σM failed");
  }
  enum class Active { none, cholmod, mumps };

  void assemble(double sigma) {
    sigma_ = sigma;
    const double* k = K_.valuePtr();
    const double* m = M_.valuePtr();
    double* a = A_.valuePtr();
    for (Index i = 0; i < A_.nonZeros(); ++i) a[i] = k[i] - sigma * m[i];
  }

  // CHOLMOD's numeric factorization of A_ (symbolic analysis once; again
  // after a failed simplicial LDLᵀ, which may leave the factor partly
  // converted; a supernodal factor keeps its structure when it stops at a
  // non-positive pivot); the count of negative pivots, or nothing when it
  // failed or met a zero pivot.
  std::optional<Index> factor_automatic() {
    if (!automatic_) {
      automatic_ = std::make_unique<CholmodFactor>();
      automatic_->memory_limit = memory_limit_;
    }
    if (!analyzed_) {
      automatic_->analyze(A_, order_);
      analyzed_ = true;
      automatic_supernodal_ = automatic_->is_supernodal();
    }
    automatic_->factorize(A_);
    ++factorizations_;
    if (automatic_->out_of_memory()) throw std::bad_alloc();  // the program's out-of-memory report, not a count
    if (automatic_->info() != Eigen::Success) {
      if (!automatic_supernodal_) analyzed_ = false;
      return std::nullopt;
    }
    const auto [negative, zero] = automatic_->nonpositive_pivots();
    if (zero > 0) return std::nullopt;
    return negative;
  }

  const SparseMatrix& K_;
  const SparseMatrix& M_;
  SparseMatrix A_;
  std::vector<int> order_;
  std::unique_ptr<CholmodFactor> automatic_;
  double memory_limit_ = 0;
  std::unique_ptr<MumpsLdlt> mumps_;
  bool analyzed_ = false;
  bool automatic_supernodal_ = false;  // what the analysis of the automatic factor chose
  Active active_ = Active::none;
  bool indefinite_ = false;
  double sigma_ = nan;
  int factorizations_ = 0;
  mutable MatrixX residual_, correction_;  // workspace of the refinement step (n × columns)
};

// The shift-invert operator in the form Spectra's SymGEigsShiftSolver expects
// (the interface of Spectra::SymShiftInvert), backed by a ShiftedFactor.
template <class Factor> class ShiftInvertOp {
 public:
  using Scalar = double;
  explicit ShiftInvertOp(Factor& factor) : factor_(factor) {}
  Index rows() const { return factor_.size(); }
  Index cols() const { return factor_.size(); }
  void set_shift(const Scalar& sigma) {
    if (factor_.valid() && factor_.sigma() == sigma) return;
    if (!factor_.factor(sigma))
      throw NumericalError("solve_sparse_modes: K − σM has no LDLᵀ factorization at σ = " +
                           detail::format_number(sigma, 10));
  }
  void perform_op(const Scalar* x_in, Scalar* y_out) const { factor_.solve(x_in, y_out); }

 private:
  Factor& factor_;
};

// y = M x for Spectra's B-inner products, which a Lanczos step takes several
// times (norm, orthogonalization, reorthogonalization): a diagonal M (particles
// and point masses) as a vector, otherwise M in full symmetric storage on its
// own pattern (not the common pattern with K, whose explicit zeros would make
// each product as dear as one with K).
class MassProduct {
 public:
  using Scalar = double;
  explicit MassProduct(const SparseMatrix& M) {
    bool diagonal = true;
    for (Index j = 0; j < M.outerSize() && diagonal; ++j)
      for (SparseMatrix::InnerIterator it(M, j); it; ++it)
        if (it.row() != j && it.value() != 0) {
          diagonal = false;
          break;
        }
    if (diagonal) {
      diagonal_ = M.diagonal();
    } else {
      M_ = M.pruned(0.0);  // exact zeros only
      M_.makeCompressed();
    }
  }
  Index rows() const { return diagonal_.size() > 0 ? diagonal_.size() : M_.rows(); }
  Index cols() const { return rows(); }
  void perform_op(const Scalar* x_in, Scalar* y_out) const {
    const Eigen::Map<const VectorX> x(x_in, rows());
    Eigen::Map<VectorX> y(y_out, rows());
    if (diagonal_.size() > 0) y = diagonal_.cwiseProduct(x);
    else y.noalias() = M_ * x;
  }

 private:
  VectorX diagonal_;
  SparseMatrix M_;
};

// Eigenvalues and shifts as the user sees them: the solver works on the
// pencil scaled by detail::Magnitudes, whose λ is the model's divided by
// `lambda`; every σ in a note or message goes through here.
struct Units {
  double lambda = 1;
  std::string operator()(double sigma, int digits) const { return detail::format_number(lambda * sigma, digits); }
};

// The `nev` eigenpairs nearest σ, ascending in λ. A run that a probe
// stopped (run_lanczos's `stop`) has no vectors, and `lambda` holds its
// current Ritz values instead (see Probe).
struct LanczosRun {
  double sigma = 0;
  VectorX lambda;
  MatrixX Phi;  // n × nev, M-orthonormal
  Index ncv = 0, restarts = 0, solves = 0;
  std::string factor;
  bool stopped = false;
  bool refined = false;  // by refine_run
  bool converged = true;  // false only where run_lanczos was told it need not (must_converge)
};

// Spectra's shift-invert solver, with its current Ritz values readable
// whether or not they have converged. After compute() they are eigenvalues of
// the pencil, λ̃ = σ + 1/θ for the Ritz values θ of OP = (K − σM)⁻¹M. Where
// K − σM is positive definite, OP is positive and self-adjoint in the
// M-inner product, so the i-th largest θ is at most the i-th largest
// eigenvalue of OP (Cauchy's interlacing, Parlett thm 10.1.1), and λ̃_i is
// at least λ_i: each is an upper bound of the i-th lowest eigenvalue, however
// far the iteration is from convergence.
// (Spectra's SymGEigsShiftSolver does the same iteration but keeps its Ritz
// values private; this is it, on Spectra's base class, with them readable.)
template <class Op, class MassOp>
class ShiftInvertSolver
    : public Spectra::SymEigsBase<Spectra::SymGEigsShiftInvertOp<Op, MassOp>, MassOp> {
  using ModeOp = Spectra::SymGEigsShiftInvertOp<Op, MassOp>;
  using Base = Spectra::SymEigsBase<ModeOp, MassOp>;

 public:
  ShiftInvertSolver(Op& op, MassOp& mass, Index nev, Index ncv, double sigma)
      : Base(shifted(ModeOp(op, mass), sigma), mass, nev, ncv), sigma_(sigma) {}
  VectorX current_values() const { return this->m_ritz_val.head(this->m_nev); }
  // The Ritz vectors of current_values() (in no particular order): those of
  // the nev largest |θ| of the current Lanczos factorization's tridiagonal H
  // (Spectra keeps its own copy of them private).
  MatrixX current_vectors() const {
    const MatrixX H = this->m_fac.matrix_H();
    Eigen::SelfAdjointEigenSolver<MatrixX> ritz(H);
    if (ritz.info() != Eigen::Success) return MatrixX();
    std::vector<Index> order(static_cast<std::size_t>(H.rows()));
    std::iota(order.begin(), order.end(), Index{0});
    std::sort(order.begin(), order.end(), [&](Index a, Index b) {
      return std::abs(ritz.eigenvalues()(a)) > std::abs(ritz.eigenvalues()(b));
    });
    MatrixX Y(H.rows(), this->m_nev);
    for (Index j = 0; j < this->m_nev; ++j) Y.col(j) = ritz.eigenvectors().col(order[static_cast<std::size_t>(j)]);
    return this->m_fac.matrix_V() * Y;
  }

 private:
  static ModeOp shifted(ModeOp&& op, double sigma) {
    op.set_shift(sigma);
    return std::move(op);
  }
  // The iteration's values are θ = 1/(λ − σ); sorted as λ.
  void sort_ritzpair(Spectra::SortRule rule) override {
    this->m_ritz_val.head(this->m_nev) = (1.0 / this->m_ritz_val.head(this->m_nev).array() + sigma_).matrix();
    Base::sort_ritzpair(rule);
  }
  double sigma_;
};

// A run's probe: after at most `restarts` restarts, `stop` sees the current
// Ritz values (ascending λ̃; converged or not) and their vectors (n × nev,
// M-orthonormal) and says whether to give the run up (it is then returned
// with stopped = true); otherwise a converged run is kept and an unconverged
// one made afresh with the whole budget (run_lanczos).
struct Probe {
  Index restarts = 0;
  std::function<bool(const VectorX&, const MatrixX&)> stop;
};

// The probe's constants (near_zero_probe, near_zero_fraction,
// near_zero_floor, near_zero_moves, moved_probe): modal/modes.hpp.

template <class Factor, class MassOp>
LanczosRun run_lanczos(Factor& factor, MassOp& mass_op, double sigma, Index nev, const SparseModalOptions& options,
                       const Units& units, const Probe* probe = nullptr, const VectorX* start = nullptr,
                       bool must_converge = true) {
  const Index n = mass_op.rows();
  LanczosRun run;
  run.sigma = sigma;
  run.ncv = std::min<Index>(n, std::max<Index>(2 * nev + 1, 20));
  ShiftInvertOp<Factor> op(factor);
  try {
    // The probe: the same iteration (Spectra's start vector is fixed), stopped
    // after probe->restarts restarts; `stop` sees its Ritz values, converged
    // or not. Where it converged and is not given up, its results are the
    // whole run's; where it did not, the run is made afresh with
    // the whole budget, so that its results are those of a run without a
    // probe (going on from the probe's first Lanczos vector gives other
    // vectors, and on a slowly converging run no fewer solves).
    // A finished iteration's results, after `earlier` restarts and solves.
    auto take = [&run](const auto& eigs, Index earlier_restarts, Index earlier_solves) {
      run.restarts = earlier_restarts + eigs.num_iterations();
      run.solves = earlier_solves + eigs.num_operations();
      run.lambda = eigs.eigenvalues();
      run.Phi = eigs.eigenvectors();
    };
    Index probe_restarts = 0, probe_solves = 0;
    bool done = false;
    if (probe && probe->restarts < options.max_iterations) {
      ShiftInvertSolver<ShiftInvertOp<Factor>, MassOp> eigs(op, mass_op, nev, run.ncv, sigma);
      eigs.init();
      eigs.compute(Spectra::SortRule::LargestMagn, probe->restarts, options.tolerance, Spectra::SortRule::SmallestAlge);
      run.restarts = probe_restarts = eigs.num_iterations();
      run.solves = probe_solves = eigs.num_operations();
      const bool converged = eigs.info() == Spectra::CompInfo::Successful;
      const VectorX values = converged ? VectorX(eigs.eigenvalues()) : eigs.current_values();
      const MatrixX vectors = converged ? MatrixX(eigs.eigenvectors()) : eigs.current_vectors();
      if (probe->stop(values, vectors)) {
        run.lambda = values;
        run.stopped = done = true;
      } else if (converged) {
        take(eigs, 0, 0);
        done = true;
      }
    }
    if (!done) {
      ShiftInvertSolver<ShiftInvertOp<Factor>, MassOp> eigs(op, mass_op, nev, run.ncv, sigma);
      if (start) eigs.init(start->data());
      else eigs.init();
      const Index converged = eigs.compute(Spectra::SortRule::LargestMagn, options.max_iterations, options.tolerance,
                                           Spectra::SortRule::SmallestAlge);
      if (eigs.info() != Spectra::CompInfo::Successful && !must_converge) {  // its converged pairs only
        run.converged = false;
        take(eigs, probe_restarts, probe_solves);
        return run;
      }
      if (eigs.info() != Spectra::CompInfo::Successful)
        throw NumericalError("solve_sparse_modes: the shift-invert Lanczos iteration at σ = " + units(sigma, 6) +
                             " did not converge: " + std::to_string(converged) + " of " + std::to_string(nev) +
                             " eigenvalues converged after " +
                             std::to_string(probe_restarts + eigs.num_iterations()) + " restarts (max_iterations " +
                             std::to_string(options.max_iterations) + ", tolerance " +
                             detail::format_number(options.tolerance, 3) +
                             "); raise max_iterations or the tolerance, or ask for fewer modes");
      take(eigs, probe_restarts, probe_solves);
    }
  } catch (const NumericalError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw;  // out of memory (a factor's solve, Spectra's workspace): said as such
  } catch (const std::exception& e) {
    throw NumericalError(std::string("solve_sparse_modes: the Lanczos iteration failed: ") + e.what());
  }
  run.factor = factor.describe();
  return run;
}

// One step of block inverse iteration on a run's vectors, then Rayleigh–Ritz:
// W = (K − σM)⁻¹MΦ, and the pencil projected on W, (Wᵀ(K − σM)W, WᵀMW) =
// (WᵀMΦ, WᵀMW), needs no product with K. Each component of a vector along
// an eigenvector of λ_i is scaled by 1/(λ_i − σ), so the rounding-level
// content of stiff modes that a run near the bottom of a spectrum spanning
// many decades leaves in its Ritz vectors (the second copy of a double
// eigenvalue of a net at prestrain 1e-12 kept 2e-12 of in-plane motion, at
// ω² 1e13 × its own: a residual three times its eigenvalue, and "zero") is
// damped by λ_wanted/λ_stiff. With `factor` at run.sigma, definite or not
// (WᵀMW is positive definite either way; a run beside m negative
// eigenvalues, m > 0, has K − σM indefinite); the run is left as it was
// where the projected pencil cannot be solved.
template <class Factor, class MassOp>
void refine_run(LanczosRun& run, Factor& factor, MassOp& mass_op) {
  if (!(factor.valid() && factor.sigma() == run.sigma) || run.Phi.cols() == 0) return;
  const Index n = run.Phi.rows(), c = run.Phi.cols();
  MatrixX MPhi(n, c), W(n, c), MW(n, c);
  for (Index j = 0; j < c; ++j) mass_op.perform_op(run.Phi.col(j).data(), MPhi.col(j).data());
  factor.solve(MPhi.data(), W.data(), static_cast<int>(c));
  for (Index j = 0; j < c; ++j) mass_op.perform_op(W.col(j).data(), MW.col(j).data());
  MatrixX A = W.transpose() * MPhi, B = W.transpose() * MW;
  A = 0.5 * (A + A.transpose()).eval();
  B = 0.5 * (B + B.transpose()).eval();
  Eigen::GeneralizedSelfAdjointEigenSolver<MatrixX> ritz(A, B);
  if (ritz.info() != Eigen::Success || !ritz.eigenvalues().allFinite()) return;
  MatrixX Phi = W * ritz.eigenvectors();
  if (!Phi.allFinite()) return;
  run.lambda = ritz.eigenvalues().array() + run.sigma;
  run.Phi = std::move(Phi);
  run.refined = true;
}

std::string describe_run(const LanczosRun& run, Index nev, const Units& units) {
  std::ostringstream out;
  out << run.factor << " of K − σM at σ = " << units(run.sigma, 6) << ", " << nev << " wanted, ncv "
      << run.ncv << ", " << run.restarts << " restarts, " << run.solves << " solves";
  if (run.refined) out << ", then one step of block inverse iteration";
  return out.str();
}

ModalResult no_coordinates() {
  ModalResult empty;
  empty.solver = "none (no coordinates)";
  return empty;
}

void check_options(const SparseModalOptions& options, const std::string& who) {
  if (options.modes < 1)
    throw std::invalid_argument(who + ": the number of modes wanted must be at least 1 (got " +
                                std::to_string(options.modes) + ")");
  if (!(options.tolerance > 0) || !std::isfinite(options.tolerance))
    throw std::invalid_argument(who + ": the tolerance must be positive and finite");
  if (options.max_iterations < 1) throw std::invalid_argument(who + ": max_iterations must be at least 1");
  if (options.shift && !std::isfinite(*options.shift)) throw std::invalid_argument(who + ": the shift must be finite");
}

// ------------------------------------------------------------------- modes

// The most nonzeros in a column of K or M.
double column_width(const SparseMatrix& K, const SparseMatrix& M) {
  Index width = 1;
  for (const SparseMatrix* A : {&K, &M})
    for (Index j = 0; j < A->outerSize(); ++j) {
      Index count = 0;
      for (SparseMatrix::InnerIterator it(*A, j); it; ++it) ++count;
      width = std::max(width, count);
    }
  return static_cast<double>(width);
}

struct Norms {
  double K1 = 0, M1 = 0;
  double width = 1;  // the most nonzeros in a column of K or M: the terms of an entry of Kφ or Mφ
  // For the worst case of r's rounding through M⁻¹ where M is not diagonal
  // (set_residual): D^{-1/2} (D = diag M) and a lower bound on the smallest
  // eigenvalue of D^{-1/2}MD^{-1/2} (equilibrated_mass_floor,
  // tree_mass_floor). Empty where M is diagonal.
  VectorX inverse_root_diagonal;
  double mass_floor = 0;
};

// How far each mode's eigenvalue may be from the exact one beyond its own
// residual, kept for the Kato–Temple pass of lanczos_modes.
struct ModeResidual {
  double relative = 0;  // ‖r‖/((‖K‖₁ + |λ|‖M‖₁)‖φ‖), for the diagnostics
  double bound = 0;     // δ = ‖r‖_{M⁻¹} + the rounding of r, worst case (in residual_bound)
  double typical = 0;   // the same with the rounding of r at its typical size (in error_estimate)
  // The loose equilibrium's change ΔK (SparseModalOptions::K_equilibrium_shift):
  double shift_first = 0;     // |φᵀΔKφ|, the first-order change of λ
  double shift_residual = 0;  // δ_Δ = ‖d‖_{M⁻¹}, d = ΔKφ − (φᵀΔKφ)Mφ
  VectorX shift_direction;    // d (empty without ΔK)
  VectorX Mphi, r;            // Mφ and r (empty on the matrix-free path)
  double typical_part = nan;  // the residual's share of error_estimate (typical, or its Kato–Temple square)
};

// A group of modes' projected pencil (lanczos_modes' cluster bound): A =
// ΦᵀKΦ and B = ΦᵀMΦ for the group's shapes Φ (M-normalized columns), and
// bounds of their entries' rounding, elementwise.
struct Projection {
  MatrixX A, B, A_rounding, B_rounding;
};

// Projection of the columns of Phi through the products K(x), M(x) and
// their magnitudes' |K|(a), |M|(a), with `dot` the pencil's sum: an entry's
// rounding bound is `entries`·|φ_a|ᵀ|K||φ_b| (Kφ_b's entries) + `sums`·Σ_i
// |φ_ai (Kφ_b)_i| (the sum), likewise with M.
template <class K, class M, class AbsK, class AbsM, class Dot>
Projection projection(const MatrixX& Phi, double entries, double sums, K&& K_of, M&& M_of, AbsK&& absK_of,
                      AbsM&& absM_of, Dot&& dot) {
  const Index g = Phi.cols();
  Projection p{MatrixX(g, g), MatrixX(g, g), MatrixX(g, g), MatrixX(g, g)};
  for (Index b = 0; b < g; ++b) {
    const VectorX phi = Phi.col(b), a = phi.cwiseAbs();
    const VectorX Kphi = K_of(phi), Mphi = M_of(phi), aK = absK_of(a), aM = absM_of(a);
    for (Index i = 0; i < g; ++i) {
      const auto other = Phi.col(i);
      p.A(i, b) = dot(other, Kphi);
      p.B(i, b) = dot(other, Mphi);
      p.A_rounding(i, b) = entries * other.cwiseAbs().dot(aK) + sums * other.cwiseProduct(Kphi).cwiseAbs().sum();
      p.B_rounding(i, b) = entries * other.cwiseAbs().dot(aM) + sums * other.cwiseProduct(Mphi).cwiseAbs().sum();
    }
  }
  return p;
}

// Fills the residual's part of `residual` (both paths): δ = ‖r‖_{M⁻¹} plus
// r's own rounding, ε‖terms‖_{M⁻¹} with terms = |K||φ| + |λ||M||φ| and
// `width` + 2 rounded operations per entry, worst case in bound, at its
// typical size √(width + 2) in typical; r and Mφ for the pass of lanczos_modes.
// Where M is not diagonal, ‖terms‖_{M⁻¹} is not the worst case of ‖e‖_{M⁻¹}
// over |e| ≤ terms (M⁻¹'s signs cancel in it); the bound takes
// ‖D^{-1/2}terms‖₂/√μ instead where larger, μ ≤ λ_min(D^{-1/2}MD^{-1/2})
// (Norms). Returns ‖r‖_{M⁻¹}.
template <class MassSolver>
double set_residual(ModeResidual& residual, const MassSolver& mass, const VectorX& r, const VectorX& Mphi,
                    const VectorX& terms, double width, const Norms& norms) {
  const double error = std::sqrt(std::max(0.0, r.dot(mass.solve(r))));
  const double r_rounding = eps * std::sqrt(std::max(0.0, terms.dot(mass.solve(terms))));
  double worst = r_rounding;
  if (norms.inverse_root_diagonal.size() == terms.size())
    worst = std::max(worst, norms.mass_floor > 0
                                ? eps * norms.inverse_root_diagonal.cwiseProduct(terms).norm() / std::sqrt(norms.mass_floor)
                                : std::numeric_limits<double>::infinity());
  residual.bound = error + (width + 2) * worst;
  residual.typical = error + std::sqrt(width + 2) * r_rounding;
  residual.typical_part = residual.typical;
  residual.Mphi = Mphi;
  residual.r = r;
  return error;
}

// Σ_i |x_i y_i|.
double phi_sum_of_products(const VectorX& x, const VectorX& y) { return x.cwiseProduct(y).cwiseAbs().sum(); }

// Σ|A_ij| a_j per row, for a ≥ 0.
VectorX absolute_product(const SparseMatrix& A, const VectorX& a) {
  return detail::symmetric_product(A, a, [](double v) { return std::abs(v); });
}

// The Mode for the converged Ritz vector φ: λ its Rayleigh quotient, shape
// M-normalized with its largest component positive, residual error bound,
// kind (see the header comment); `residual` for the diagnostics and the
// Kato–Temple pass. Rounding is componentwise, through |K||φ| and |M||φ|:
// w + 2 terms in an entry of r = Kφ − λMφ (w = Norms::width), w + n in the
// quotient φᵀKφ, worst case in residual_bound, at the typical size √(terms)
// in error_estimate, which also takes the assembly's rounding of K and M
// (4ε per entry, first order: 4ε|φ|ᵀ(|K| + |λ||M|)|φ|, with K's entries
// at `term_sizes` where that is n×n). `shift`: the loose equilibrium's change
// of K (signed, n×n, or empty), see ModeResidual.
Mode make_sparse_mode(const SparseMatrix& K, const SparseMatrix& M, const CholmodFactor& mass, const Norms& norms,
                      const SparseMatrix& systematic, const SparseMatrix& shift, const SparseMatrix& term_sizes,
                      const SparseMatrix& rounding_form, const detail::ScaledSprings& springs, VectorX phi,
                      ModeResidual& residual) {
  // φᵀMφ and φᵀKφ summed pairwise (detail::pairwise_dot): their rounding
  // grows with the depth m = 32 + ⌈log₂ ⌈n/32⌉⌉ of the sum, not with n (39
  // instead of 2352 terms for models/net.toml, 47 instead of 10⁶ at 10⁶
  // coordinates), and so do the estimate's and the bound's shares of it.
  VectorX Mphi = M * phi;
  const double scale_phi = 1.0 / std::sqrt(detail::pairwise_dot(phi, Mphi));
  phi *= scale_phi;
  Mphi *= scale_phi;
  const VectorX Kphi = detail::symmetric_product(K, phi);
  const double lambda = detail::pairwise_dot(phi, Kphi);  // the Rayleigh quotient (φᵀMφ = 1)
  const VectorX r = Kphi - lambda * Mphi;
  const double x2 = phi.squaredNorm();
  const double scale = (norms.K1 + std::abs(lambda) * norms.M1) * std::sqrt(x2);
  residual.relative = scale > 0 ? r.norm() / scale : 0.0;

  const VectorX a = phi.cwiseAbs();
  const VectorX aK = absolute_product(K, a), aM = absolute_product(M, a);
  const VectorX terms = aK + std::abs(lambda) * aM;  // |K||φ| + |λ||M||φ|
  set_residual(residual, mass, r, Mphi, terms, norms.width, norms);
  QuotientSums sums;
  sums.width = norms.width;
  sums.n = detail::pairwise_depth(K.rows());
  sums.residual = residual.typical;
  sums.residual_worst = residual.bound;
  sums.systematic = systematic.rows() == K.rows() ? a.dot(systematic * a) : 0.0;
  if (shift.rows() == K.rows()) {
    const VectorX Sphi = shift * phi;
    const double s = phi.dot(Sphi);
    residual.shift_direction = Sphi - s * Mphi;
    residual.shift_residual =
        std::sqrt(std::max(0.0, residual.shift_direction.dot(mass.solve(residual.shift_direction))));
    residual.shift_first = std::abs(s);
  }
  // The entries' rounding (4ε each) at their typical size,
  // 4ε(Σ_ij (K_ij φ_i φ_j)²)^½ and the same with |λ|M; K's entries at the
  // sizes of their terms where given (SparseModalOptions::K_magnitude): a
  // spring's transverse k(1 − L₀/L) at a small prestrain p is rounded at
  // ε k, ε/p of itself. The worst case would sum the magnitudes instead: on
  // a smooth mode of a net or a spring chain |φ|ᵀ|K||φ| is 10²–10⁴ × λ (K
  // is a discrete Laplacian), and that worst case made the estimates
  // 10³–10⁵ × the true error.
  const SparseMatrix& K_terms = term_sizes.rows() == K.rows() ? term_sizes : K;
  const auto squares = [&phi](double value, Index row, Index column) {
    return std::pow(value * phi(row) * phi(column), 2);
  };
  const double K2 = detail::sum_over_entries(K_terms, squares), M2 = detail::sum_over_entries(M, squares);
  // φᵀFφ, F = K_rounding_form (a rigorous bound, in units of 4ε, of the
  // rounding's effect, positions included; see below): where smaller, it
  // stands for K's entries at their typical size too.
  const double structured = rounding_form.rows() == K.rows() ? std::max(0.0, phi.dot(detail::symmetric_product(rounding_form, phi)))
                                                             : std::numeric_limits<double>::infinity();
  sums.rows = a.cwiseProduct(aK).norm() + std::abs(lambda) * a.cwiseProduct(aM).norm();
  sums.sums_K = phi_sum_of_products(phi, Kphi);
  sums.sums_M = phi_sum_of_products(phi, Mphi);
  sums.quotient_terms = a.dot(terms);
  // Where smaller still, the springs' rounding spring by spring
  // (detail::spring_by_spring: on a smooth mode of a net 10–100 × below
  // both).
  sums.entries = std::min({std::sqrt(K2), structured, detail::spring_by_spring(springs, phi)}) +
                 std::abs(lambda) * std::sqrt(M2);
  // The data's worst case for the kind: φᵀFφ where F is given, else
  // |φ|ᵀT|φ| with T the sizes of K's terms. With the residual's typical
  // size alone, a flat net at its rest length (every out-of-plane λ zero in
  // exact arithmetic, −6.5e-15 s as formed, with the springs' lengths
  // rounded) had its ten lowest modes called divergent once the Lanczos
  // vectors were accurate; the dense path calls them zero. With T, the
  // resolved modes of a net at prestrain 1e-12 were called zero (8 of 10 at
  // 100 × 100: T's Laplacian without its signs is 10³ × the smooth modes'
  // λ/p).
  const double data_rounding =
      std::isfinite(structured)
          ? structured
          : (term_sizes.rows() == K.rows() ? a.dot(absolute_product(term_sizes, a)) : a.dot(aK));
  sums.data = data_rounding + std::abs(lambda) * a.dot(aM);
  return quotient_mode(std::move(phi), lambda, sums);
}

std::string plural(Index count, const char* one, const char* many) {
  return std::to_string(count) + " " + (count == 1 ? one : many);
}

// ------------------------------------------------------- dense fallback

// K, M and `systematic` equilibrated (`scale`), as in the Lanczos path.
ModalResult solve_dense_fallback(const SparseMatrix& K, const SparseMatrix& M, Index k,
                                 const SparseModalOptions& options, const SparseMatrix& systematic,
                                 const SparseMatrix& term_sizes, const SparseMatrix& rounding_form, const VectorX& scale,
                                 const Units& units) {
  const Index n = K.rows();
  const MatrixX Md = MatrixX(M), Kd = MatrixX(K);
  const detail::MassFactor mass(detail::factor_mass(Md, coordinate_names(options, n), scale));
  // K_error as solve_modes takes it: the rounding (4ε per term) and the systematic part.
  MatrixX K_error;
  if (term_sizes.rows() == n) {
    K_error = 4 * eps * MatrixX(term_sizes);
    if (systematic.rows() == n) K_error += MatrixX(systematic);
  }
  ModalResult all =
      detail::solve_symmetric(Md, Kd, mass, K_error, systematic.rows() == n ? MatrixX(systematic) : MatrixX(),
                              DenseSolver::automatic, -1, rounding_form);

  ModalResult result;
  result.stability = classify(all.modes);  // every mode is known
  result.morse_index = all.morse_index;
  result.solver = all.solver + " (dense: " +
                  (n <= dense_limit ? std::to_string(n) + " coordinates, at most " + std::to_string(dense_limit) +
                                          ", are solved whole"
                                    : std::to_string(k) + " modes of " + std::to_string(n) + " asked, all but at most one") +
                  ")";
  std::vector<Mode> modes = std::move(all.modes);
  if (options.shift) {
    const double sigma = *options.shift;
    const auto below = std::count_if(modes.begin(), modes.end(), [&](const Mode& m) { return m.omega2 < sigma; });
    std::stable_sort(modes.begin(), modes.end(), [&](const Mode& a, const Mode& b) {
      return std::abs(a.omega2 - sigma) < std::abs(b.omega2 - sigma);
    });
    modes.resize(static_cast<std::size_t>(k));
    std::stable_sort(modes.begin(), modes.end(), [](const Mode& a, const Mode& b) { return a.omega2 < b.omega2; });
    result.notes.push_back("the " + plural(k, "mode", "modes") + " nearest the shift σ = " +
                           units(sigma, 8) + "; " + plural(below, "eigenvalue lies", "eigenvalues lie") +
                           " below σ");
  } else {
    modes.resize(static_cast<std::size_t>(k));
  }
  for (const std::string& note : all.notes) result.notes.push_back(note);
  result.zero_modes = all.zero_modes;  // every mode, not only the k kept
  result.modes = std::move(modes);
  return result;
}

// Whether M has no nonzero entry off its diagonal.
bool is_diagonal(const SparseMatrix& M) {
  for (Index j = 0; j < M.outerSize(); ++j)
    for (SparseMatrix::InnerIterator it(M, j); it; ++it)
      if (it.row() != j && it.value() != 0) return false;
  return true;
}

// Gershgorin's radii of diag(d)·A·diag(d): Σ_{j≠i} |d_i A_ij d_j| for every
// row i (A holding both triangles).
VectorX scaled_radii(const SparseMatrix& A, const VectorX& d) {
  VectorX radius = VectorX::Zero(A.rows());
  for (Index j = 0; j < A.outerSize(); ++j)
    for (SparseMatrix::InnerIterator it(A, j); it; ++it)
      if (it.row() != j) radius(it.row()) += std::abs(it.value()) * d(it.row()) * d(j);
  return radius;
}

// The scale s = max K_ii/M_ii of the pencil's spectrum (see the header
// comment), from K's and M's diagonals; where no K_ii is positive, the
// largest |K_ii|/M_ii, else ‖K‖₁/max M_ii, else 1.
double spectrum_scale(const VectorX& dK, const VectorX& dM, double K1) {
  double scale = (dK.array() / dM.array()).maxCoeff();
  if (!(scale > 0)) scale = (dK.cwiseAbs().array() / dM.array()).maxCoeff();
  if (!(scale > 0)) scale = K1 > 0 ? K1 / dM.maxCoeff() : 0.0;
  if (!(scale > 0)) scale = 1.0;
  return scale;
}

// Gershgorin's lower bound on the eigenvalues of diag(d)·H·diag(d), H = αK +
// βM of the tree (`diagonal` its diagonal, tree_diagonal): min_i d_i²H_ii −
// (d_i(|H|d)_i − |d_i²H_ii|), with (|H|d)_i from above by the magnitude
// recursion (tree_product), so the radius is an upper bound of row i's
// off-diagonal sum.
double tree_gershgorin(const TreePencil& p, double alpha, double beta, const VectorX& diagonal, const VectorX& d) {
  const VectorX rows = tree_product(p, alpha, beta, d, true);
  double bound = std::numeric_limits<double>::infinity();
  for (Index i = 0; i < p.size(); ++i) {
    const double entry = d(i) * d(i) * diagonal(i);
    bound = std::min(bound, entry - std::max(0.0, d(i) * rows(i) - std::abs(entry)));
  }
  return bound;
}

// A lower bound μ on the smallest eigenvalue of A = D^{-1/2}MD^{-1/2}
// (d = D^{-1/2}, D = diag M; Norms::mass_floor), for the worst case of
// rounding through M⁻¹ (set_residual): `gershgorin` (a Gershgorin bound
// of A) where positive;
// else the largest of ν/2, ν/8, ν/32, ν/128 (ν: the smallest eigenvalue's
// estimate by inverse iteration, x ↦ d⁻¹ ∘ M⁻¹(d⁻¹ ∘ x) with
// solve_mass(y) = M⁻¹y) at which definite(μ), a factorization showing
// M − μD (equivalently A − μI) positive definite, succeeds (then
// λ_min ≥ μ, to first order in ε); 0 when none does.
template <class SolveMass, class Definite>
double equilibrated_floor(double gershgorin, const VectorX& d, SolveMass&& solve_mass, Definite&& definite) {
  if (gershgorin > 0) return gershgorin;
  const Index n = d.size();
  VectorX x = VectorX::Ones(n).normalized();
  double rho = 0;  // the largest eigenvalue of A⁻¹ = D^{1/2}M⁻¹D^{1/2}, from below
  for (int step = 0; step < 8; ++step) {
    const VectorX y = d.cwiseInverse().cwiseProduct(solve_mass(VectorX(d.cwiseInverse().cwiseProduct(x))));
    rho = x.dot(y);
    const double size = y.norm();
    if (!(size > 0) || !std::isfinite(size)) return 0.0;
    x = y / size;
  }
  if (!(rho > 0) || !std::isfinite(rho)) return 0.0;
  for (const double fraction : {0.5, 0.125, 1.0 / 32, 1.0 / 128})
    if (definite(fraction / rho)) return fraction / rho;
  return 0.0;
}

// equilibrated_floor for the assembled M, with M's factor `mass`:
// Gershgorin's bound of A, else shifted Cholesky factorizations of A − μI.
double equilibrated_mass_floor(const SparseMatrix& M, const CholmodFactor& mass, const VectorX& d) {
  const Index n = M.rows();
  const SparseMatrix A = d.asDiagonal() * M * d.asDiagonal();
  const double gershgorin = n > 0 ? (A.diagonal() - scaled_radii(M, d)).minCoeff() : 1.0;
  return equilibrated_floor(
      gershgorin, d, [&](const VectorX& y) { return VectorX(mass.solve(y)); },
      [&](double mu) {
        SparseMatrix identity(n, n);
        identity.setIdentity();
        CholmodFactor shifted(Eigen::CholmodSimplicialLLt);
        shifted.compute(SparseMatrix(A - mu * identity));
        return shifted.info() == Eigen::Success;
      });
}

// The pencil K − σM as the Lanczos path uses it, assembled sparse: K and M
// on one pattern, their factorizations (ShiftedFactor; CHOLMOD for M, for
// the error estimates), M's products. The matrix-free TreeLanczosPencil
// below offers the same calls.
class SparsePencil {
 public:
  SparsePencil(SparseMatrix K, SparseMatrix M, const SparseModalOptions& options, const SparseMatrix& systematic,
               const SparseMatrix& shift, const SparseMatrix& term_sizes, const SparseMatrix& rounding_form,
               const detail::ScaledSprings& springs, const VectorX& coordinate_scale)
      : K_(std::move(K)), M_(std::move(M)), systematic_(systematic), shift_(shift), term_sizes_(term_sizes),
        rounding_form_(rounding_form), springs_(springs),
        mass_(factor_sparse_mass(M_, coordinate_scale, coordinate_names(options, M_.rows()), options.memory_limit)), norms_{norm1(K_), norm1(M_), column_width(K_, M_), VectorX(), 0.0},
        mass_op_(M_), factor_(common(K_, M_), M_, options.fill_reducing_order, options.memory_limit) {
    if (!is_diagonal(M_)) {
      norms_.inverse_root_diagonal = M_.diagonal().cwiseSqrt().cwiseInverse();
      norms_.mass_floor = equilibrated_mass_floor(M_, *mass_, norms_.inverse_root_diagonal);
    }
  }
  Index size() const { return K_.rows(); }
  ShiftedFactor& factor() { return factor_; }
  MassProduct& mass_op() { return mass_op_; }
  // s = max K_ii/M_ii (see the header comment) and the Gershgorin bound of D^{-1/2}KD^{-1/2}.
  std::pair<double, double> scale_and_gershgorin() const {
    const VectorX dM = M_.diagonal(), dK = K_.diagonal();
    const VectorX radius = scaled_radii(K_, dM.cwiseSqrt().cwiseInverse());
    const double gershgorin =
        size() > 0 ? (dK.array() / dM.array() - radius.array()).minCoeff() : std::numeric_limits<double>::infinity();
    return {spectrum_scale(dK, dM, norms_.K1), gershgorin};
  }
  Mode make_mode(VectorX phi, ModeResidual& residual) const {
    return make_sparse_mode(K_, M_, *mass_, norms_, systematic_, shift_, term_sizes_, rounding_form_, springs_,
                            std::move(phi), residual);
  }
  // The projected pencil of the columns of Phi (Projection): an entry
  // φ_aᵀ(Kφ_b) as make_mode's quotient, within (w + 1)ε|φ_a|ᵀ|K||φ_b| (w
  // rounded terms in an entry of Kφ_b) + (m + 1)ε Σ_i |φ_ai (Kφ_b)_i| (the
  // pairwise sum's depth m), likewise with M.
  Projection project(const MatrixX& Phi) const {
    return projection(Phi, (norms_.width + 1) * eps, (detail::pairwise_depth(size()) + 1) * eps,
                      [&](const VectorX& x) { return detail::symmetric_product(K_, x); },
                      [&](const VectorX& x) { return VectorX(M_ * x); },
                      [&](const VectorX& a) { return absolute_product(K_, a); },
                      [&](const VectorX& a) { return absolute_product(M_, a); },
                      [](const auto& x, const auto& y) { return detail::pairwise_dot(x, y); });
  }
  // The largest 4ε φᵀFφ over M-orthonormal columns φ of Phi (F =
  // K_rounding_form: how far the data's rounding may move their λ); +∞
  // without F.
  double data_level(const MatrixX& Phi) const {
    if (rounding_form_.rows() != size() || Phi.rows() != size()) return std::numeric_limits<double>::infinity();
    return 4 * eps * std::max(0.0, (Phi.transpose() * (rounding_form_ * Phi)).diagonal().maxCoeff());
  }

 private:
  static const SparseMatrix& common(SparseMatrix& K, SparseMatrix& M) {
    to_common_pattern(K, M);
    return K;
  }
  SparseMatrix K_, M_;
  const SparseMatrix& systematic_;
  const SparseMatrix& shift_;
  const SparseMatrix& term_sizes_;  // Σ|terms| of K's entries, or empty
  const SparseMatrix& rounding_form_;  // SparseModalOptions::K_rounding_form, or empty
  const detail::ScaledSprings& springs_;  // SparseModalOptions::K_spring_rounding as scaled, or none
  std::unique_ptr<CholmodFactor> mass_;
  Norms norms_;
  MassProduct mass_op_;  // on M's own pattern, before the common one
  ShiftedFactor factor_;
};

// The modes of the equilibrated pencil in the model's units: eigenvalues and
// estimates by the magnitudes, then the cluster notes, shapes φ = Sφ̃ with
// their largest component positive.
void finish_scaled(ModalResult& result, const detail::Magnitudes& magnitude, const VectorX& scale) {
  detail::restore_magnitudes(result, magnitude, true);
  add_cluster_notes(result.modes, true, result.notes);
  for (Mode& mode : result.modes) {
    mode.shape = scale.cast<std::complex<double>>().cwiseProduct(mode.shape);
    if (mode.shape(detail::dominant_index(mode.shape)).real() < 0) mode.shape = -mode.shape;
  }
}

// The Lanczos path of solve_sparse_modes and solve_tree_modes for an
// equilibrated pencil (n > dense_limit, k < n − 1). Shapes are those of the
// scaled pencil.
template <class Pencil>
ModalResult lanczos_modes(Pencil& pencil, Index k, const SparseModalOptions& options, const Units& units);

}  // namespace

// equilibrated_floor for the tree's M, with its factor `mass`: Gershgorin's
// bound of A through the magnitude recursion (tree_gershgorin), else LDLᵀ
// factorizations through the tree of M − μD (the pencil with μD_kk taken
// from every armature term) without a negative pivot.
double detail::tree_mass_floor(const TreePencil& p, const TreeFactor& mass, const VectorX& dM) {
  const VectorX d = dM.cwiseSqrt().cwiseInverse();
  const double gershgorin = p.size() > 0 ? tree_gershgorin(p, 0.0, 1.0, dM, d) : 1.0;
  return equilibrated_floor(
      gershgorin, d, [&](const VectorX& y) { return mass.solve(y); },
      [&](double mu) {
        TreePencil shifted = p;
        shifted.M_diagonal -= mu * dM;
        TreeFactor f;
        return f.factor(shifted, 0.0, 1.0) && f.negative_pivots() == 0;
      });
}

Mode sparse_mode(VectorX phi, double lambda, double error, double rounding, double systematic, double zero_level) {
  Mode mode;
  const double estimate = error + rounding + eps * std::abs(lambda) + systematic;
  if (std::abs(lambda) <= std::max({error + systematic, rounding, zero_level})) {
    mode = detail::make_mode(0.0, std::max(estimate, zero_level), ModeKind::zero);
  } else if (lambda < 0) {  // divergent: s = +√(−λ) real
    mode = detail::make_mode(std::sqrt(-lambda), estimate, ModeKind::divergent);
  } else {
    mode = detail::make_mode({0.0, std::sqrt(lambda)}, estimate, ModeKind::oscillatory);
    mode.damping_ratio = 0;
  }
  mode.omega2 = lambda;
  mode.residual_bound = error + rounding + eps * std::abs(lambda);
  mode.systematic_error = systematic;
  if (phi(detail::dominant_index(phi.cast<std::complex<double>>())) < 0) phi = -phi;
  mode.shape = phi.cast<std::complex<double>>();
  return mode;
}

Mode quotient_mode(VectorX phi, double lambda, const QuotientSums& sums) {
  const double rounding = detail::typical_quotient_rounding(sums.width, sums.n, sums.rows, sums.sums_K, 4 * eps * sums.entries);
  Mode mode = sparse_mode(std::move(phi), lambda, sums.residual, rounding, sums.systematic,
                          sums.residual + sums.systematic + 4 * eps * sums.data);
  mode.residual_bound = sums.residual_worst + (sums.width + 1) * eps * sums.quotient_terms +
                        (sums.n + 1) * eps * (sums.sums_K + std::abs(lambda) * sums.sums_M) + eps * std::abs(lambda);
  return mode;
}

std::vector<double> kato_temple(std::vector<Mode>& modes, const std::vector<double>& bound,
                                const std::vector<double>& typical, double complete_below) {
  if (bound.size() != modes.size() || typical.size() != modes.size())
    throw std::invalid_argument("kato_temple: " + std::to_string(modes.size()) + " modes but " +
                                std::to_string(bound.size()) + " bounds and " + std::to_string(typical.size()) +
                                " typical residuals");
  std::vector<double> parts(modes.size(), nan);
  for (std::size_t j = 0; j < modes.size(); ++j) {
    Mode& mode = modes[j];
    if (!std::isfinite(bound[j]) || !(mode.omega2 < complete_below) || mode.kind == ModeKind::zero) continue;
    double gap_bound = complete_below - mode.omega2, gap_typical = gap_bound;
    for (std::size_t i = 0; i < modes.size(); ++i) {
      if (i == j) continue;
      const double d = std::abs(modes[i].omega2 - mode.omega2);
      gap_bound = std::min(gap_bound, d - bound[i]);
      gap_typical = std::min(gap_typical, d - typical[i]);
    }
    if (gap_bound > bound[j]) mode.residual_bound -= bound[j] - bound[j] * bound[j] / gap_bound;
    if (gap_typical > typical[j]) {
      parts[j] = typical[j] * typical[j] / gap_typical;
      mode.error_estimate -= typical[j] - parts[j];
    }
  }
  return parts;
}

CompletenessCheck check_completeness(long k, long n, double s0, double zeta,
                                     const std::function<std::vector<double>(long nev)>& solve,
                                     const std::function<long(double& b, bool expect_indefinite)>& count_below) {
  CompletenessCheck check;
  check.nev = k;
  for (int attempt = 0;; ++attempt) {
    std::vector<double> lambdas = solve(check.nev);
    if (static_cast<long>(lambdas.size()) < k)
      throw NumericalError("check_completeness: the solver returned " + std::to_string(lambdas.size()) +
                           " eigenvalues, fewer than the " + std::to_string(k) + " wanted");
    std::sort(lambdas.begin(), lambdas.end());
    const double lambda_k = lambdas[static_cast<std::size_t>(k - 1)];
    check.bound = lambda_k - 1e-6 * std::abs(lambda_k) - completeness_margin * zeta;
    check.top = lambda_k;
    if (!(lambda_k > 0 || lambda_k < -completeness_margin * zeta) || !(check.bound > s0)) {
      check.outcome = CompletenessCheck::Outcome::not_needed;
      return check;
    }
    const auto found_below = [&](double b) {
      return static_cast<long>(std::count_if(lambdas.begin(), lambdas.end(), [&](double l) { return l < b; }));
    };
    // Ritz values below b: K − bM is indefinite.
    check.count = count_below(check.bound, found_below(check.bound) > 0);
    check.found = found_below(check.bound);  // b may have moved
    if (check.count < 0) {
      check.outcome = CompletenessCheck::Outcome::unavailable;
      return check;
    }
    if (check.count <= check.found || check.nev + 1 >= n - 1 || attempt == 4) {
      check.outcome = check.count <= check.found ? CompletenessCheck::Outcome::complete
                                                 : CompletenessCheck::Outcome::incomplete;
      return check;
    }
    check.nev = std::min(n - 2, check.nev + (check.count - check.found) + 2);
  }
}

std::string completeness_note(const CompletenessCheck& check, const std::string& bound_text,
                              const std::string& iteration) {
  switch (check.outcome) {
    case CompletenessCheck::Outcome::complete:
      return "completeness checked by the inertia of K − σM at σ = " + bound_text +
             ", just below the highest returned eigenvalue: exactly " + std::to_string(check.count) +
             " eigenvalues lie below it, as found";
    case CompletenessCheck::Outcome::incomplete:
      return "the inertia counts " + std::to_string(check.count) + " eigenvalues below " + bound_text + " but " +
             iteration + " found " + std::to_string(check.found) + ": some modes in this range may be missing";
    case CompletenessCheck::Outcome::unavailable:
      return "completeness not checked: K − σM could not be factored near σ = " + bound_text +
             ", just below the highest returned eigenvalue, so its inertia could not count the eigenvalues below "
             "it; a copy of a repeated eigenvalue among the returned modes may be missing";
    case CompletenessCheck::Outcome::not_needed:
      break;
  }
  return {};
}

void replace_note(std::vector<std::string>& notes, std::size_t at, std::string note) {
  if (note.empty())
    notes.erase(notes.begin() + static_cast<std::ptrdiff_t>(at));
  else
    notes[at] = std::move(note);
}

std::string copies_check_note(int runs, int added, long k, bool spanned, bool short_run, int unresolved,
                              const std::string& iteration) {
  const std::string found =
      added == 0 ? std::string()
                 : std::to_string(added) + " more below the highest returned eigenvalue, which the first run had " +
                       "missed (the lowest " + std::to_string(k) + " of all are reported); ";
  std::string last;
  if (spanned)
    last = "the last run found no direction below the highest returned eigenvalue outside the span of the modes found";
  else
    last = std::string("the last run ") +
           (short_run ? "did not converge every pair it asked for"
            : unresolved > 0
                ? "found " + std::to_string(unresolved) + " direction" + (unresolved == 1 ? "" : "s") +
                      " outside the span of the modes found that it could not resolve"
                : std::string("still added some")) +
           ": a mode below the highest returned may be missing";
  return "completeness not checked by the inertia for the returned eigenvalues within its margin (η plus 1e-6 of the "
         "highest returned) of zero or of the highest returned, where a count below a shift cannot separate them from "
         "either; copies of repeated eigenvalues checked instead by " +
         std::to_string(runs) + " more " + iteration + " run" + (runs == 1 ? "" : "s") + " from random start vectors: " +
         found + last;
}

long uncovered_modes(const CompletenessCheck& check, const std::vector<Mode>& modes) {
  if (check.outcome != CompletenessCheck::Outcome::complete || modes.empty()) return 0;
  const auto top = std::max_element(modes.begin(), modes.end(),
                                    [](const Mode& a, const Mode& b) { return a.omega2 < b.omega2; });
  return static_cast<long>(std::count_if(modes.begin(), modes.end(), [&](const Mode& mode) {
    return mode.kind != ModeKind::zero && mode.omega2 >= check.bound &&
           top->omega2 - mode.omega2 > mode.error_estimate + top->error_estimate;
  }));
}

bool leaves_modes_unchecked(const CompletenessCheck& check, std::vector<Mode> modes, long k) {
  if (check.outcome != CompletenessCheck::Outcome::complete) return false;
  std::sort(modes.begin(), modes.end(), [](const Mode& a, const Mode& b) { return a.omega2 < b.omega2; });
  modes.resize(std::min(modes.size(), static_cast<std::size_t>(std::max(k, 0L))));
  if (!check.near_zero()) return uncovered_modes(check, modes) > 0;
  return std::any_of(modes.begin(), modes.end(),
                     [&](const Mode& mode) { return mode.kind != ModeKind::zero && mode.omega2 >= check.bound; });
}

std::optional<std::string> unchecked_completeness_note(const CompletenessCheck& check, const std::vector<Mode>& modes,
                                                       const std::string& margin_text, const std::string& bound_text) {
  if (check.outcome != CompletenessCheck::Outcome::complete || modes.empty()) return std::nullopt;
  if (!check.near_zero()) {
    const long between = uncovered_modes(check, modes);
    if (between == 0) return std::nullopt;
    return "completeness checked by the inertia of K − σM at σ = " + bound_text + ": exactly " +
           std::to_string(check.count) + " eigenvalues lie below it, as found; but " +
           plural(between, "returned eigenvalue lies", "returned eigenvalues lie") +
           " between σ and the highest returned, within the check's margin of it (1e-6 of it plus η = " + margin_text +
           ", the inertia's resolution near zero), so a copy of a repeated eigenvalue among " +
           (between == 1 ? std::string("it") : "them") + " may be missing";
  }
  const auto resolved = std::count_if(modes.begin(), modes.end(), [&](const Mode& mode) {
    return mode.kind != ModeKind::zero && mode.omega2 >= check.bound;
  });
  if (resolved == 0) return std::string();  // zero modes only: count_by_inertia's count speaks of them
  return "completeness not checked: the returned eigenvalues at or above σ = " + bound_text +
         " all lie within η = " + margin_text + " of zero (" +
         detail::format_number(completeness_margin * zero_margin, 2) +
         " of the largest K_ii/M_ii), closer than the inertia of K − σM can tell them from rounding (" +
         std::to_string(check.count) + " below σ, as found), so a copy of a repeated eigenvalue among the " +
         std::to_string(resolved) + " returned modes there that are not zero modes may be missing";
}

void count_by_inertia(ModalResult& result, const InertiaAccount& account,
                      const std::function<long(double& sigma, const char* what, bool expect_indefinite)>& count_below) {
  const auto format = [&](double sigma, int digits) { return detail::format_number(account.unit * sigma, digits); };
  const double s0 = account.s0;
  long resolved_small_negative = 0;
  result.zero_modes = 0;
  for (const Mode& mode : result.modes) {
    if (mode.kind == ModeKind::zero) ++result.zero_modes;
    if (mode.kind == ModeKind::divergent && mode.omega2 >= s0) ++resolved_small_negative;
  }
  result.morse_index = static_cast<int>(account.below_s0 + resolved_small_negative);
  // Zero modes beyond the k returned: when the highest returned mode is
  // itself a zero mode, more may follow (a free body has 6, --modes 3 returns
  // 3). The inertia at t, the largest error estimate of a returned zero mode,
  // counts the eigenvalues in [σ₀, t): every one of them is a zero mode at
  // that accuracy, returned or not, except the returned modes resolved as
  // oscillatory below t (where the lowest ω² are within a few decades of
  // the rounding level, zero and resolved modes interleave: a net at
  // prestrain 1e-13 had been called "11 zero modes in all" with 5 of them
  // returned as oscillatory).
  if (!account.shift && !result.modes.empty() && result.modes.back().kind == ModeKind::zero) {
    double t = 0;
    for (const Mode& mode : result.modes)
      if (mode.kind == ModeKind::zero) t = std::max(t, mode.error_estimate);
    t = std::max(t, std::nextafter(result.modes.back().omega2, std::numeric_limits<double>::infinity()));
    const auto resolved_below_t = std::count_if(result.modes.begin(), result.modes.end(), [&](const Mode& mode) {
      return mode.kind == ModeKind::oscillatory && mode.omega2 < t;
    });
    const long below_t = count_below(t, "zero-mode count", true);
    const long counted = below_t - account.below_s0 - resolved_small_negative;
    const long near_zero = counted - resolved_below_t;
    if (below_t < 0) {
      result.notes.push_back("zero modes beyond the " + std::to_string(result.zero_modes) +
                             " returned were not counted: K − σM could not be factored near σ = " + format(t, 3));
    } else if (near_zero > result.zero_modes) {
      result.notes.push_back(
          "the inertia of K − σM at σ = " + format(t, 3) + " counts " +
          (resolved_below_t > 0 ? plural(counted, "eigenvalue", "eigenvalues") + " from σ₀ up to it; besides the " +
                                      std::to_string(resolved_below_t) + " returned as oscillatory, " +
                                      std::to_string(near_zero)
                                : plural(near_zero, "eigenvalue", "eigenvalues")) +
          " within the zero modes' error estimates of zero, " + std::to_string(result.zero_modes) +
          " of them returned (--modes): " + std::to_string(near_zero) + " zero modes in all");
      result.zero_modes = static_cast<int>(near_zero);
    }
  }
  // Negative eigenvalues beyond the k returned: when the highest returned
  // mode is itself divergent, more may lie between it and zero, which
  // neither the inertia at σ₀ nor the returned modes count (a flat net under
  // compression 1e-9, its 324 out-of-plane λ all in [−4.0e-3, −2.7e-5] and
  // so above σ₀ = −ζ = −0.02, has Morse index 10 by that count, its 10
  // returned modes). The inertia at −η (η = completeness_margin·ζ) counts
  // them, but not as negative beyond the data's rounding: where the scene's
  // zero modes are rounded by more than η (a rest-length lattice far from
  // the origin, its zero modes at ±5e-5 against η = 1e-6), that count took
  // 56 of them (Morse index 72 for 16). So a note gives the count and the
  // Morse index stays what is known. No note where K + ηM cannot be
  // factored at −η itself (count_below moves σ off a zero pivot by 1e-6 s,
  // far above −η: that count would take zero and positive eigenvalues).
  if (!account.shift && !result.modes.empty() && result.modes.back().kind == ModeKind::divergent) {
    const double level = -completeness_margin * account.zeta;
    if (result.modes.back().omega2 < level) {
      const std::size_t notes = result.notes.size();
      double minus_eta = level;
      long below = count_below(minus_eta, "count of negative eigenvalues", true);
      if (minus_eta != level) below = -1;
      result.notes.resize(notes);  // a move's note, if any: no count is reported then
      if (below > result.morse_index)
        result.notes.push_back(
            "the inertia of K − σM at σ = −η = " + format(minus_eta, 3) + " counts " +
            plural(below, "eigenvalue", "eigenvalues") + " below it, " + std::to_string(result.morse_index) +
            " of them below −ζ = " + format(s0, 3) + " or returned as divergent (the Morse index); the other " +
            std::to_string(below - result.morse_index) +
            " are negative as formed but not counted: closer to zero than ζ, they may lie within the data's "
            "rounding of it (zero modes), which was not measured for modes not returned (--modes)");
    }
  }
  result.stability = result.morse_index > 0 ? Stability::divergence : classify(result.modes);
  // With a shift, zero modes among the eigenvalues not returned: the count in [−ζ, ζ).
  if (account.shift && result.morse_index == 0 && result.zero_modes == 0) {
    double plus = account.zeta;
    const long below_plus = count_below(plus, "zero-mode check", false);
    if (below_plus < 0)
      result.notes.push_back("zero modes among the eigenvalues not returned were not looked for: K − σM could not "
                             "be factored near σ = ζ = " + format(plus, 3));
    const auto returned_near_zero = std::count_if(result.modes.begin(), result.modes.end(), [&](const Mode& mode) {
      return mode.omega2 >= s0 && mode.omega2 < plus;
    });
    if (below_plus >= 0 && below_plus - account.below_s0 > returned_near_zero) {
      result.stability = Stability::marginal;
      result.notes.push_back(plural(below_plus - account.below_s0 - returned_near_zero, "eigenvalue", "eigenvalues") +
                             " within ζ = " + format(account.zeta, 3) +
                             " of zero (a zero mode) lie outside the returned modes; stability is marginal");
    }
  }
}

ModalResult solve_sparse_modes(const SparseMatrix& K_in, const SparseMatrix& M_in, const SparseModalOptions& options) {
  // ---- validation
  if (K_in.rows() != K_in.cols() || M_in.rows() != M_in.cols() || K_in.rows() != M_in.rows())
    throw std::invalid_argument("solve_sparse_modes: K and M must be square and of the same size (K is " +
                                std::to_string(K_in.rows()) + "×" + std::to_string(K_in.cols()) + ", M " +
                                std::to_string(M_in.rows()) + "×" + std::to_string(M_in.cols()) + ")");
  check_options(options, "solve_sparse_modes");
  const Index n = K_in.rows();
  if (n == 0) return no_coordinates();
  require_finite(M_in, "mass matrix M");
  require_finite(K_in, "stiffness matrix K");
  std::optional<SparseMatrix> M_sym = symmetric_part(M_in);
  if (!M_sym) throw std::invalid_argument("solve_sparse_modes: the mass matrix is not symmetric");
  std::optional<SparseMatrix> K_sym = symmetric_part(K_in);
  if (!K_sym)
    throw std::invalid_argument("solve_sparse_modes: the stiffness matrix is not symmetric (circulatory forces need "
                                "the dense first-order solver, solve_modes)");
  SparseMatrix M = std::move(*M_sym), K = std::move(*K_sym);
  const Index k = std::min<Index>(options.modes, n);

  // ---- equilibration: the pencil (SKS, SMS) with S = diag(s) of powers of two
  // (detail::equilibrating_scale: exact, the same eigenvalues and residual
  // bounds); unscaled only where that would overflow or underflow.
  VectorX scale = detail::coordinate_scale(options.inertia_scale, n);
  SparseMatrix systematic = options.K_systematic_error;
  SparseMatrix shift = options.K_equilibrium_shift;
  SparseMatrix term_sizes = options.K_magnitude, rounding_form = options.K_rounding_form;
  for (const auto& [A, name] : {std::pair<const SparseMatrix*, const char*>{&term_sizes, "K_magnitude"},
                                {&rounding_form, "K_rounding_form"}})
    if (A->size() > 0 && (A->rows() != n || A->cols() != n))
      throw std::invalid_argument(std::string("solve_sparse_modes: ") + name + " is " + std::to_string(A->rows()) +
                                  "×" + std::to_string(A->cols()) + ", K " + std::to_string(n) + "×" +
                                  std::to_string(n));
  const SpringRounding& given = options.K_spring_rounding;
  detail::ScaledSprings springs{&given, VectorX(), 1.0};
  if (!given.empty() && !springs.fits(n))
    throw std::invalid_argument("solve_sparse_modes: K_spring_rounding has " + std::to_string(given.G.rows()) +
                                " rows, " + std::to_string(given.G.cols()) + " columns and " +
                                std::to_string(given.others.size()) + " other terms for " +
                                std::to_string(given.blocks.cols()) + " springs; K is " + std::to_string(n) + "×" +
                                std::to_string(n));
  {
    const VectorX inverse = scale.cwiseInverse();
    if (exactly_scalable(M, scale, inverse) && exactly_scalable(K, scale, inverse)) {
      scale_in_place(M, scale);
      scale_in_place(K, scale);
      if (systematic.rows() == n && systematic.cols() == n) scale_in_place(systematic, scale);
      if (shift.rows() == n && shift.cols() == n) scale_in_place(shift, scale);
      if (term_sizes.rows() == n) scale_in_place(term_sizes, scale);
      if (rounding_form.rows() == n) scale_in_place(rounding_form, scale);
      springs.scale = scale;
    } else {
      scale = VectorX::Ones(n);
    }
  }
  // Magnitudes (as solve_modes: detail::Magnitudes): M and K scaled by
  // powers of four so that their largest entries are near 1. Exact, undone
  // on the modes; shifts in the notes are shown in the model's units. Besides
  // keeping the estimates inside the range of double precision (λ² at
  // ω² = 1e160), it keeps the shift-invert eigenvalues 1/(λ − σ) of order
  // one or more: Spectra's convergence test compares residuals with
  // max(ε^(2/3), |θ|), so with θ ≈ 1e-26 (a chain with K ≈ 1e30) it accepted
  // unconverged Ritz values, 2× off and classed zero.
  detail::Magnitudes magnitude;
  SparseModalOptions scaled_options = without_matrices(options);
  {
    auto largest = [](const SparseMatrix& A) {
      return A.nonZeros() > 0 ? Eigen::Map<const VectorX>(A.valuePtr(), A.nonZeros()).cwiseAbs().maxCoeff() : 0.0;
    };
    magnitude = detail::magnitudes(largest(M), largest(K));
    const int a = 2 * magnitude.a, b = 2 * magnitude.b;
    if (exactly_scalable(M, a) && exactly_scalable(K, b) && exactly_scalable(systematic, b) &&
        exactly_scalable(shift, b) && exactly_scalable(term_sizes, b) && exactly_scalable(rounding_form, b)) {
      scale_in_place(M, a);
      for (SparseMatrix* A : {&K, &systematic, &shift, &term_sizes, &rounding_form}) scale_in_place(*A, b);
      springs.factor = std::ldexp(1.0, b);
      if (options.shift) scaled_options.shift = std::ldexp(*options.shift, 2 * (magnitude.b - magnitude.a));
    } else {
      magnitude = {};
    }
  }
  const Units units{std::ldexp(1.0, 2 * (magnitude.a - magnitude.b))};
  ModalResult result = n <= dense_limit || k >= n - 1
                           ? solve_dense_fallback(K, M, k, scaled_options,
                                                  shift.rows() == n ? SparseMatrix(systematic.rows() == n
                                                                                       ? SparseMatrix(systematic + shift.cwiseAbs())
                                                                                       : SparseMatrix(shift.cwiseAbs()))
                                                                    : systematic,
                                                  term_sizes, rounding_form, scale, units)
                           : [&] {
                               SparsePencil pencil(std::move(K), std::move(M), scaled_options, systematic, shift,
                                                   term_sizes, rounding_form, springs, scale);
                               return lanczos_modes(pencil, k, scaled_options, units);
                             }();
  finish_scaled(result, magnitude, scale);
  return result;
}

namespace {

// Groups of 2–8 consecutive modes whose intervals λ_j ± δ_j overlap (δ_j
// the residual bound's δ, ModeResidual::bound), where no mode has a gap of
// its own and Kato–Temple leaves each the linear δ_j, however far the group
// lies from the rest of the spectrum: the repeated pairs of a symmetric net
// kept bounds 10⁵ × their true errors (models/net.toml, modes 2–3). For a
// group C with shapes Φ_C, the projected pencil (A, B) = (Φ_CᵀKΦ_C,
// Φ_CᵀMΦ_C) has eigenvalues μ; with β ≥ ‖B − I‖₂ < ½ and δ_C² = Σ_C δ_k² /
// (1 − β) (≥ the squared 2-norm of the block residual of Φ_C B^{-½} after
// Rayleigh–Ritz, which the diagonal λ_k cannot better), the μ lie within
// δ_C²/η of the group's eigenvalues in order, η the separation of the μ
// from every eigenvalue outside C (the other modes' intervals and the
// verified bound b, as for Kato–Temple) where η² > δ_C² (the quadratic
// residual bound for a cluster: Mathias, SIAM J. Matrix Anal. Appl. 19,
// 1998). So |λ_k − λ| ≤ |λ_k − μ_k| + δ_C²/η + μ_k's own error + ε|λ_k|:
// λ_k itself is the number compared, so its own rounding does not enter.
// μ's error: A's and B's rounding (Projection) moves a Rayleigh quotient
// xᵀAx/xᵀBx by at most (‖ΔA‖ + |μ|‖ΔB‖)/(1 − 2β) to first order (|xᵀΔAx|
// ≤ ‖ΔA‖xᵀx ≤ ‖ΔA‖xᵀBx/(1 − β); min–max), taken with |μ| + ‖ΔA‖ for the
// second-order term, and the small solver's own, 8gε(‖A‖ + |μ|‖B‖). The residual bound takes it where
// smaller; the estimate likewise with the typical δ (its residual part,
// ModeResidual::typical_part).
template <class Pencil>
void cluster_bounds(std::vector<std::pair<Mode, ModeResidual>>& built, double complete_below, const Pencil& pencil) {
  const std::size_t count = built.size();
  const auto eligible = [&](std::size_t j) {
    const Mode& mode = built[j].first;
    return std::isfinite(built[j].second.bound) && mode.omega2 < complete_below && mode.kind != ModeKind::zero &&
           mode.shape.size() == pencil.size();
  };
  const auto linked = [&](std::size_t j) {  // j and j + 1 overlap
    return built[j + 1].first.omega2 - built[j].first.omega2 <= built[j].second.bound + built[j + 1].second.bound;
  };
  constexpr std::size_t largest = 8;
  for (std::size_t first = 0; first < count;) {
    std::size_t last = first;
    while (last + 1 < count && linked(last)) ++last;
    const std::size_t g = last - first + 1;
    const std::size_t begin = first;
    first = last + 1;
    if (g < 2 || g > largest) continue;
    bool all = true;
    for (std::size_t j = begin; j <= last; ++j) all = all && eligible(j);
    if (!all) continue;
    MatrixX Phi(pencil.size(), static_cast<Index>(g));
    for (std::size_t a = 0; a < g; ++a) Phi.col(static_cast<Index>(a)) = built[begin + a].first.shape.real();
    const Projection p = pencil.project(Phi);
    const Index G = static_cast<Index>(g);
    const double beta = (p.B - MatrixX::Identity(G, G)).norm() + p.B_rounding.norm();  // Frobenius ≥ 2-norm
    if (!(beta < 0.5)) continue;
    Eigen::GeneralizedSelfAdjointEigenSolver<MatrixX> ritz(p.A, p.B, Eigen::EigenvaluesOnly);
    if (ritz.info() != Eigen::Success) continue;
    const VectorX& mu = ritz.eigenvalues();  // ascending, as the group's λ
    VectorX mu_error(G);
    double low = std::numeric_limits<double>::infinity(), high = -low;
    for (Index a = 0; a < G; ++a) {
      const double m = std::abs(mu(a));
      mu_error(a) = (p.A_rounding.norm() + (m + p.A_rounding.norm()) * p.B_rounding.norm()) / (1 - 2 * beta) +
                    8 * static_cast<double>(g) * eps * (p.A.norm() + m * p.B.norm());
      low = std::min(low, mu(a) - mu_error(a));
      high = std::max(high, mu(a) + mu_error(a));
    }
    if (!(std::isfinite(low) && std::isfinite(high))) continue;
    double d2_bound = 0, d2_typical = 0;
    for (std::size_t j = begin; j <= last; ++j) {
      d2_bound += built[j].second.bound * built[j].second.bound;
      d2_typical += built[j].second.typical * built[j].second.typical;
    }
    d2_bound /= 1 - beta;
    d2_typical /= 1 - beta;
    double eta_bound = complete_below - high, eta_typical = eta_bound;
    for (std::size_t i = 0; i < count; ++i) {
      if (i >= begin && i <= last) continue;
      const double lambda = built[i].first.omega2;
      const double d = lambda < low ? low - lambda : lambda > high ? lambda - high : 0.0;
      eta_bound = std::min(eta_bound, d - built[i].second.bound);
      eta_typical = std::min(eta_typical, d - built[i].second.typical);
    }
    for (Index a = 0; a < G; ++a) {
      Mode& mode = built[begin + static_cast<std::size_t>(a)].first;
      ModeResidual& own = built[begin + static_cast<std::size_t>(a)].second;
      const double apart = std::abs(mode.omega2 - mu(a)) + mu_error(a) + eps * std::abs(mode.omega2);
      if (eta_bound > 0 && eta_bound * eta_bound > d2_bound)
        mode.residual_bound = std::min(mode.residual_bound, apart + d2_bound / eta_bound);
      if (eta_typical > 0 && eta_typical * eta_typical > d2_typical && std::isfinite(own.typical_part)) {
        const double part = apart + d2_typical / eta_typical;
        if (part < own.typical_part) {
          mode.error_estimate -= own.typical_part - part;
          own.typical_part = part;
        }
      }
    }
  }
}

template <class Pencil>
ModalResult lanczos_modes(Pencil& pencil, Index k, const SparseModalOptions& options, const Units& units) {
  const Index n = pencil.size();
  const auto [scale, gershgorin] = pencil.scale_and_gershgorin();
  const double zeta = zero_margin * scale;
  const double sigma0 = -zeta;

  auto& mass_op = pencil.mass_op();
  auto& factor = pencil.factor();
  ModalResult result;
  std::vector<std::string> runs;

  // Factors at σ, moving σ by 1e-6·max(|σ|, s) (at most 3 times) when the
  // LDLᵀ factorization breaks down; returns the count below the final σ.
  auto factor_at = [&](double& sigma, const char* what, bool expect_indefinite = false, bool normwise_null = false) {
    for (int attempt = 0; attempt < 4; ++attempt) {
      if (const std::optional<Index> below = factor.factor(sigma, true, expect_indefinite, normwise_null)) return *below;
      const double moved = sigma + 1e-6 * std::max(std::abs(sigma), scale);
      result.notes.push_back(std::string("K − σM has no LDLᵀ factorization without pivoting at the ") + what +
                             " σ = " + units(sigma, 10) + " (a zero pivot); moved to σ = " +
                             units(moved, 10));
      sigma = moved;
    }
    throw NumericalError(std::string("solve_sparse_modes: K − σM cannot be factored near the ") + what + " σ = " +
                         units(sigma, 10));
  };
  // The inertia's count below b for the completeness checks and
  // count_by_inertia, or −1 with b as given where K − bM cannot be factored
  // near b (the moves' notes dropped: the caller's note says the count was
  // not made).
  // Not fatal: on an inverted chain of 400 links (joint angles) the LDLᵀ of
  // K − bM failed at every shift tried, where the run from σ_L had succeeded.
  const auto count_near = [&](double& b, bool expect_indefinite, const char* what = "completeness check") -> long {
    const std::size_t notes = result.notes.size();
    const double given = b;
    try {
      return static_cast<long>(factor_at(b, what, expect_indefinite));
    } catch (const NumericalError&) {
      result.notes.resize(notes);
      b = given;  // the notes name the σ asked for, not the last one tried
      return -1;
    }
  };

  double s0 = sigma0;
  const auto started = std::chrono::steady_clock::now();
  const Index m = factor_at(s0, "default shift");  // eigenvalues below −ζ (Sylvester)
  const auto factored = std::chrono::steady_clock::now();

  std::vector<std::pair<double, VectorX>> pairs;  // (λ, φ)
  auto take = [&](const LanczosRun& run, auto&& keep) {
    for (Index j = 0; j < run.lambda.size(); ++j)
      if (keep(run.lambda(j))) pairs.emplace_back(run.lambda(j), run.Phi.col(j));
  };
  Index below_user_shift = -1;
  double user_sigma = nan;
  // Every eigenvalue below this was returned (the completeness check passed
  // with none below σ₀); NaN when that is not known.
  double complete_below = nan;
  std::optional<std::pair<CompletenessCheck, std::size_t>> completeness;  // the check and its note's index
  std::string copies_note;  // the copies check's (below), which replaces the completeness note

  // A run of `nev` from σ₀, probed (the first run of each case without a
  // user shift that wants modes at or above σ₀): each run given up moves the
  // shift to its −λ̃_nev or 2λ̃_1 (probe_move; nearer 0 by
  // 1/near_zero_fraction), which must lie above the rounding of
  // λ̃ = σ + 1/θ itself (16 ε|σ|): a zero mode's Ritz value is rounding, and
  // its data level (φᵀFφ) may be 0. The moved shift goes back towards the
  // last by factors of 8 until `usable` accepts it: K − σM has the inertia
  // of σ₀ there (positive definite where m = 0; m eigenvalues below it
  // where m > 0, none between σ₀ and it). `sigma_run` is left at the kept
  // run's shift; a run at a moved shift is refined (refine_run).
  const auto probed_run = [&](long nev, double& sigma_run, const auto& usable) {
    double sigma_j = s0;
    sigma_run = s0;
    LanczosRun run;
    for (int move = 0;; ++move) {
      double moved = nan, floor = nan;
      auto stop = [&](const VectorX& values, const MatrixX& vectors) {
        // First with no floor: the data's level costs products with the
        // Ritz vectors, made only for a run the probe would give up.
        if (!probe_move(values.minCoeff(), values.maxCoeff(), sigma_j, 0)) return false;
        floor = std::max(std::min(near_zero_floor * scale, pencil.data_level(vectors)), 16 * eps * std::abs(sigma_j));
        const std::optional<double> to = probe_move(values.minCoeff(), values.maxCoeff(), sigma_j, floor);
        if (!to) return false;
        moved = *to;
        return true;
      };
      const Probe probe{move == 0 ? near_zero_probe : moved_probe, stop};
      run = run_lanczos(factor, mass_op, sigma_j, nev, options, units, move < near_zero_moves ? &probe : nullptr);
      if (!run.stopped) break;
      runs.push_back(describe_run(run, nev, units) + ", stopped: its " + std::to_string(nev) +
                     (run.lambda.maxCoeff() > 0
                          ? " Ritz values lie at or below " + units(run.lambda.maxCoeff(), 3) + ", under " +
                                detail::format_number(near_zero_fraction, 1) + " |σ| and above their data's level "
                          : " Ritz values lie in [" + units(run.lambda.minCoeff(), 3) + ", " +
                                units(run.lambda.maxCoeff(), 3) + "], within " +
                                detail::format_number(near_zero_fraction, 1) +
                                " |σ| of zero and beyond their data's level −") +
                     units(floor, 3) + ", where σ separates them poorly");
      double sigma = moved;
      while (sigma < 0 && sigma > sigma_j && !usable(sigma)) sigma *= 8;
      if (!(sigma < 0 && sigma > sigma_j)) {
        run = run_lanczos(factor, mass_op, sigma_j, nev, options, units);
        break;
      }
      sigma_j = sigma_run = sigma;
    }
    if (sigma_run != s0) refine_run(run, factor, mass_op);
    return run;
  };
  // A probed run's repeat, wanting `nev`, at the shift it kept (refined
  // where that moved).
  const auto rerun = [&](long nev, double sigma_run) {
    LanczosRun run = run_lanczos(factor, mass_op, sigma_run, nev, options, units);
    if (sigma_run != s0) refine_run(run, factor, mass_op);
    return run;
  };

  // The copies check, for copies the inertia cannot check: where the shift
  // moved (to sigma_run) and every
  // returned eigenvalue lies within η of zero (some of them resolved, not
  // zero modes), a run from one start vector finds one direction of each
  // eigenspace in exact arithmetic, others only through rounding:
  // generated chains of 343 particles, masses over 12 decades, every
  // eigenvalue across the chain double (y and z), came back with every
  // copy missing (5.724e-14, 2.920e-13, … each once, the lowest 10 a
  // plausible wrong spectrum under "completeness not checked"). So runs
  // from random start vectors follow, as on the distributed backend (see
  // there, and docs/design.md): of each of their pairs below the k-th
  // eigenvalue, the part M-orthogonal to every vector found (Gram–Schmidt
  // twice) that keeps over 1e-3 of its M-norm is added when, as a mode,
  // its estimate is within copies_resolution of its λ and it lies wholly
  // below the k-th, else counted unresolved; until a run finds no new direction and
  // converges (its direction in each eigenspace then lies in the span
  // found), at most 4 runs; then the lowest k are kept.
  // Also where b > 0 but returned modes resolved from λ_k lie in [b, λ_k)
  // (uncovered_modes): a net at p = 7e-12 had 7 there, within η of λ_k.
  // With m > 0 (k > m) the same, the runs at the moved shift beside the
  // merged set (the m negatives among the pairs found).
  const auto check_copies = [&](double sigma_run, const CompletenessCheck& check) {
    if (sigma_run == s0 || check.outcome != CompletenessCheck::Outcome::complete ||
        static_cast<Index>(pairs.size()) + k >= n)
      return;
    {
      std::vector<Mode> modes;  // each mode costs products: made last
      for (const auto& pair : pairs) {
        ModeResidual unused;
        modes.push_back(pencil.make_mode(pair.second, unused));
      }
      if (!leaves_modes_unchecked(check, std::move(modes), k)) return;
    }
    std::vector<VectorX> mass_found;  // Mφ of each pair
    VectorX Md(n);
    for (const auto& pair : pairs) {
      mass_op.perform_op(pair.second.data(), Md.data());
      mass_found.push_back(Md);
    }
    std::mt19937_64 random(2026);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    int extra_runs = 0, added = 0, added_last = 0, unresolved_last = 0;
    bool short_run = false;
    do {
      std::vector<double> lambdas;
      for (const auto& pair : pairs) lambdas.push_back(pair.first);
      std::nth_element(lambdas.begin(), lambdas.begin() + (k - 1), lambdas.end());
      const double kth = lambdas[static_cast<std::size_t>(k - 1)];
      VectorX start(n);
      for (Index i = 0; i < n; ++i) start(i) = uniform(random);
      added_last = unresolved_last = 0;
      short_run = false;
      ++extra_runs;
      // A check run that does not converge does not fail the analysis (its
      // converged pairs are taken, and the note says a mode may be missing).
      LanczosRun extra = run_lanczos(factor, mass_op, sigma_run, k, options, units, nullptr, &start, false);
      short_run = !extra.converged;
      refine_run(extra, factor, mass_op);
      runs.push_back(describe_run(extra, k, units) + ", from a random start vector (the copies check" +
                     (short_run ? ", not converged)" : ")"));
      for (Index j = 0; j < extra.lambda.size(); ++j) {
        if (!(extra.lambda(j) < kth)) continue;
        VectorX d = extra.Phi.col(j);
        mass_op.perform_op(d.data(), Md.data());
        const double before = std::sqrt(std::max(0.0, d.dot(Md)));
        for (int pass = 0; pass < 2; ++pass) {
          VectorX c(static_cast<Index>(pairs.size()));
          for (std::size_t i = 0; i < pairs.size(); ++i) c(static_cast<Index>(i)) = mass_found[i].dot(d);
          for (std::size_t i = 0; i < pairs.size(); ++i) d -= c(static_cast<Index>(i)) * pairs[i].second;
        }
        mass_op.perform_op(d.data(), Md.data());
        const double norm = std::sqrt(std::max(0.0, d.dot(Md)));
        if (!(norm > 1e-3 * before)) continue;
        d /= norm;
        ModeResidual unused;
        const Mode mode = pencil.make_mode(d, unused);
        if (!(mode.error_estimate <= copies_resolution * std::abs(mode.omega2) &&
              mode.omega2 + mode.error_estimate < kth)) {
          ++unresolved_last;
          continue;
        }
        mass_op.perform_op(d.data(), Md.data());
        mass_found.push_back(Md);
        pairs.emplace_back(mode.omega2, std::move(d));
        ++added_last;
      }
      added += added_last;
    } while (extra_runs < 4 && (added_last > 0 || unresolved_last > 0 || short_run) &&
             static_cast<Index>(pairs.size()) + k < n);
    std::stable_sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    pairs.resize(static_cast<std::size_t>(k));
    // The factor back at b, where the check left it: the second-order
    // estimates below need it (without, every mode of these scenes kept
    // its linear residual term, looser, even where nothing was added).
    factor.factor(check.bound, true, check.count > 0);
    copies_note = copies_check_note(extra_runs, added, static_cast<long>(k), added_last == 0 && unresolved_last == 0 && !short_run,
                                    short_run, unresolved_last, "Lanczos");
  };

  if (options.shift) {
    user_sigma = *options.shift;
    below_user_shift = factor_at(user_sigma, "requested", false, true);  // σ may be an eigenvalue: moved off
    const LanczosRun run = run_lanczos(factor, mass_op, user_sigma, k, options, units);
    runs.push_back(describe_run(run, k, units));
    take(run, [](double) { return true; });
  } else if (m == 0) {
    // Completeness by inertia: a single-vector Lanczos run can skip a copy of
    // a repeated eigenvalue. With b = λ_k − δ (δ = 1e-6|λ_k| + η) below the
    // k-th Ritz value, the number of eigenvalues below b must equal the number
    // of Ritz values found below b; then the k returned are the k lowest (the
    // true λ_k lies in [b, λ_k]; copies of the k-th eigenvalue that were not
    // returned are equally valid k-th modes). If more lie below b, the run is
    // repeated with more wanted (check_completeness, shared with the
    // distributed backend).
    //
    // The runs' shift. At σ₀ = −ζ the wanted ν = 1/(λ − σ₀) of eigenvalues
    // far closer to 0 than ζ differ by (λ_i − λ_j)/ζ relative: a net at
    // prestrain 1e-12 (its 784 lowest λ within 4e-12 s) took 1001 solves, and
    // the last vectors, poorly converged, turned modes of one double
    // eigenvalue into one oscillatory and one "zero" mode, and a zero mode's
    // estimate of 4e-5 counted 775 oscillatory modes as zero modes. So the
    // first run is probed after near_zero_probe restarts (5–9 suffice on the
    // nets and lattices of bench/): whether it has converged or not (a run
    // converged at σ₀ this far from its eigenvalues can miss copies of a
    // double one: a net at p = 2.7e-14 had its 8th mode called oscillatory,
    // 3.6 × its estimate from the closed form), if its Ritz
    // values λ̃_i, upper bounds of the lowest eigenvalues (ShiftInvertSolver),
    // all lie below near_zero_fraction·ζ but not all below their data's
    // level, it is given up and the runs are made at σ₁ = −λ̃_nev instead
    // (where all are negative, within near_zero_fraction·ζ of zero and
    // beyond their data's level, at σ₁ = 2λ̃_1: probe_move),
    // moved down by factors of 8 until K − σ₁M is positive definite (some
    // eigenvalue in [σ₀, 0) may lie below the first σ₁), or at σ₀ if none is
    // found above it; each run at σ₁ is refined (refine_run). At σ₁ the
    // wanted ν are spread by a fraction of 1 or more, unless the probe's
    // values were themselves far above the eigenvalues: the run at σ₁ is
    // probed the same way against |σ₁| (moved_probe restarts), and so on
    // down (at most near_zero_moves). The data's level: the smaller of
    // near_zero_floor·s (10 ε·s: there a net's eigenvalues are within the
    // factorization's own rounding, a few ε·s, of zero, and a nearer shift
    // gains nothing; with 100 ε·s a 100 × 100 net at p = 1e-13 was not moved
    // and took 1948 solves instead of 420, results/near_slack.md) and the
    // largest 4ε φᵀFφ of the Ritz vectors (SparsePencil::data_level): a
    // chain of particles with masses over 12 decades has its lowest λ some
    // 1e-22 s, resolved to full relative accuracy, and with 10 ε·s alone its
    // run at σ₀ "did not converge" after 1000 restarts (5 moves now).
    // Otherwise the run is made afresh at σ₀ with the whole budget
    // (run_lanczos). The Morse index and the zero modes still come from the
    // inertia at σ₀.
    double run_sigma = s0;
    std::optional<LanczosRun> last;
    const CompletenessCheck check = check_completeness(
        k, n, s0, zeta,
        [&](long nev) {
          if (last) {
            last = rerun(nev, run_sigma);
          } else {
            last = probed_run(nev, run_sigma, [&](double sigma) { return factor.positive_definite_at(sigma); });
          }
          runs.push_back(describe_run(*last, nev, units));
          return std::vector<double>(last->lambda.data(), last->lambda.data() + last->lambda.size());
        },
        count_near);
    if (check.outcome == CompletenessCheck::Outcome::complete) complete_below = check.bound;
    if (check.outcome != CompletenessCheck::Outcome::not_needed) {
      completeness = {check, result.notes.size()};
      result.notes.push_back(completeness_note(check, units(check.bound, 8), "the Lanczos iteration"));
    }
    Index kept = 0;
    take(*last, [&](double) { return kept++ < k; });
    check_copies(run_sigma, check);
  } else {
    // Divergent: m eigenvalues below σ₀. The lowest come from a shift σ_L
    // below the whole spectrum, close to λ₁ (placed once, by the inertia,
    // when first needed); with k > m, the k − m lowest at or above σ₀ from
    // runs at σ₀ (the k nearest σ₀, of which those at or above it are the
    // lowest there; the ones below it are the negatives themselves where
    // the run found all m).
    double sigma_low = nan;
    const auto place_low = [&] {
      // Distances below σ₀. The first a quarter beyond the Gershgorin bound:
      // the bound itself can be λ₁ exactly (a compressed net of side 4, each
      // free particle with two free neighbours: the uniform vector attains
      // it), where the factorization passed as positive definite, nothing
      // moved σ_L off it, and the run from a singular K − σ_L M returned
      // Ritz values equal to σ_L with vectors of no meaning.
      double d_hi = std::max(2 * zeta, 1.25 * (s0 - gershgorin));
      double d_lo = 0;
      int tries = 0;
      while (!factor.positive_definite_at(s0 - d_hi)) {
        d_lo = d_hi;
        d_hi *= 4;
        if (++tries > 200 || !std::isfinite(d_hi))
          throw NumericalError("solve_sparse_modes: found no shift below the spectrum (K − σM is indefinite down to σ = " +
                               units(s0 - d_hi, 3) + ")");
      }
      // Up towards λ₁ (at most 200 factorizations in all: λ₁ can only be
      // closer to σ₀ than that if it is within rounding of σ₀).
      auto no_shift = [&] {
        return NumericalError("solve_sparse_modes: could not place a shift just below the lowest eigenvalue "
                              "(it lies within rounding of −ζ = " + units(s0, 3) + ")");
      };
      if (d_lo == 0) {
        for (;;) {
          const double trial = d_hi / 8;
          if (++tries > 200 || !(trial > 0)) throw no_shift();
          if (!factor.positive_definite_at(s0 - trial)) {
            d_lo = trial;
            break;
          }
          d_hi = trial;
        }
      }
      while (d_hi - d_lo > 0.25 * d_hi) {
        if (++tries > 200) throw no_shift();
        const double mid = 0.5 * (d_lo + d_hi);
        if (factor.positive_definite_at(s0 - mid)) d_hi = mid;
        else d_lo = mid;
      }
      sigma_low = s0 - d_hi;
      if (!(factor.positive_definite() && factor.sigma() == sigma_low) && !factor.positive_definite_at(sigma_low))
        throw std::logic_error("solve_sparse_modes: the shift below the spectrum lost its factor");
    };
    // The `want` lowest from σ_L.
    std::optional<LanczosRun> low;
    const auto run_low = [&](long want) {
      if (std::isnan(sigma_low)) place_low();
      low = run_lanczos(factor, mass_op, sigma_low, want, options, units);
      runs.push_back(describe_run(*low, want, units));
      return std::vector<double>(low->lambda.data(), low->lambda.data() + low->lambda.size());
    };
    const auto below_s0 = [&] { return static_cast<Index>((low->lambda.array() < s0).count()); };
    // The lowest `lowest` of the last run from σ_L must all lie below σ₀.
    const auto verify_low = [&](Index lowest) {
      const Index below = (low->lambda.head(std::min<Index>(lowest, low->lambda.size())).array() < s0).count();
      if (below != lowest)
        throw NumericalError("solve_sparse_modes: the inertia of K − σM at σ = " + units(s0, 6) +
                             " counts " + std::to_string(m) + " eigenvalues below it, but the Lanczos iteration from σ = " +
                             units(sigma_low, 6) + " found only " + std::to_string(below) + " of the " +
                             std::to_string(lowest) + " lowest there; try a larger max_iterations or a user shift");
    };
    // With k > m, all m: a run that skips a copy of a repeated negative
    // eigenvalue finds fewer below σ₀ than the inertia counts there, and is
    // repeated wanting the shortfall plus 2 more (at most 4 repeats), as
    // check_completeness repeats its runs (a compressed net whose −7.546
    // has four copies: 15 of its 16 found wanting 16, all wanting 20).
    const auto find_negatives = [&] {
      long want = static_cast<long>(m);
      for (int attempt = 0;; ++attempt) {
        run_low(want);
        const Index below = below_s0();
        if (below >= m || attempt == 4 || want >= n - 2) break;
        want = std::min<long>(static_cast<long>(n) - 2, want + static_cast<long>(m - below) + 2);
      }
      verify_low(m);
    };
    // Each set of modes returned is checked for completeness as the lowest
    // modes at σ₀ are (check_completeness): a run from one start vector
    // can skip a copy of a repeated eigenvalue, negative (a compressed net
    // returned its 9th, double, eigenvalue once and the 11th as its 10th)
    // or not (a compressed net of side 6 beside a nearly slack one, 20
    // modes wanted: the 16 negative ones and 8.83e-7, double, once). With
    // k ≤ m, the runs from σ_L (nothing below it); with k > m, the merged
    // set (nothing below σ₀ unreturned: the inertia there counts m, all
    // returned), the runs at σ₀ (or the probe's moved shift) repeated. The
    // factor left at b serves the estimates below.
    std::optional<LanczosRun> upper;
    double upper_sigma = s0;     // its shift: σ₀, or where the probe moved it
    bool upper_has_all = false;  // the run near σ₀ found all m below σ₀
    // The merged set ascending, as (λ, run, column): the runs' vectors are
    // copied once, for the pairs kept, not at every check.
    struct Pick {
      double lambda;
      const LanczosRun* run;
      Index column;
    };
    const auto merged = [&] {
      std::vector<Pick> all;
      for (Index j = 0; j < upper->lambda.size(); ++j)
        if (upper_has_all || upper->lambda(j) >= s0) all.push_back({upper->lambda(j), &*upper, j});
      if (!upper_has_all)
        for (Index j = 0; j < m; ++j) all.push_back({low->lambda(j), &*low, j});
      std::stable_sort(all.begin(), all.end(), [](const Pick& a, const Pick& b) { return a.lambda < b.lambda; });
      return all;
    };
    if (k <= m) place_low();
    const CompletenessCheck check =
        k <= m ? check_completeness(k, n, sigma_low, zeta, run_low, count_near)
               : check_completeness(
                     k, n, s0, zeta,
                     [&](long nev) {
                       if (upper) {
                         upper = rerun(nev, upper_sigma);
                       } else {
                         // Probed as where m = 0, a moved shift kept only where
                         // the inertia there is still m (the modes within η of
                         // zero beside a compressed net had been returned as
                         // "zero" at 1.1e-7 … 1.0e-6 from σ₀, or once with a
                         // copy missing: tests/distributed/prestrained_nets.py --mixed)
                         upper = probed_run(nev, upper_sigma, [&](double sigma) {
                           const std::optional<Index> below = factor.factor(sigma, true, true);
                           return below && *below == m;
                         });
                       }
                       runs.push_back(describe_run(*upper, nev, units));
                       upper_has_all = (upper->lambda.array() < s0).count() == m;
                       if (!upper_has_all && !low) find_negatives();
                       const Index above = (upper->lambda.array() >= s0).count();
                       if (above < k - m)
                         throw NumericalError("solve_sparse_modes: the Lanczos iteration at σ = " + units(upper_sigma, 3) +
                                              " returned " + std::to_string(above) + " eigenvalues at or above σ₀ = " +
                                              units(s0, 3) + ", fewer than the " + std::to_string(k - m) +
                                              " that the inertia guarantees");
                       std::vector<double> values;
                       for (const Pick& pick : merged()) values.push_back(pick.lambda);
                       return values;
                     },
                     count_near);
    if (check.outcome == CompletenessCheck::Outcome::complete) complete_below = check.bound;
    if (check.outcome != CompletenessCheck::Outcome::not_needed) {
      completeness = {check, result.notes.size()};
      result.notes.push_back(completeness_note(check, units(check.bound, 8), "the Lanczos iteration"));
    }
    if (k <= m) {
      verify_low(k);
      Index kept = 0;  // the k lowest (a repeated run wanted more; run.lambda is ascending)
      take(*low, [&](double) { return kept++ < k; });
    } else {
      std::vector<Pick> picks = merged();
      picks.resize(static_cast<std::size_t>(k));
      pairs.clear();
      for (const Pick& pick : picks) pairs.emplace_back(pick.lambda, pick.run->Phi.col(pick.column));
      check_copies(upper_sigma, check);
    }
    if (k < m)
      result.notes.push_back("the equilibrium has " + plural(m, "negative eigenvalue", "negative eigenvalues") +
                             " below −ζ = " + units(s0, 3) + "; only the " + std::to_string(k) +
                             " most negative are returned (morse_index counts all of them)");
  }

  // ---- modes (λ: Rayleigh quotients, which may reorder nearly equal Ritz values)
  std::vector<std::pair<Mode, ModeResidual>> built;  // mode, its residuals
  for (auto& pair : pairs) {
    ModeResidual residual;
    Mode mode = pencil.make_mode(std::move(pair.second), residual);
    built.emplace_back(std::move(mode), residual);
  }
  std::stable_sort(built.begin(), built.end(),
                   [](const auto& a, const auto& b) { return a.first.omega2 < b.first.omega2; });
  // Where every other eigenvalue near λ_j is known — the returned ones, each
  // within its δ of an exact one, and nothing unreturned below the verified
  // bound b — the Rayleigh quotient's error is quadratic: |λ_j − λ| ≤ δ_j²/g_j
  // with g_j = min(b − λ_j, min_i |λ_i − λ_j| − δ_i) > δ_j (Kato–Temple;
  // Parlett, thm 11.7.1), as the dense solver does. The loose equilibrium's
  // δ_Δ (ModeResidual) likewise. Otherwise the linear δ stays.
  if (std::isfinite(complete_below)) {
    std::vector<Mode> modes;
    std::vector<double> bound, typical;
    for (auto& [mode, own] : built) {
      modes.push_back(std::move(mode));
      bound.push_back(own.bound);
      typical.push_back(own.typical);
    }
    const std::vector<double> parts = kato_temple(modes, bound, typical, complete_below);
    for (std::size_t j = 0; j < built.size(); ++j) {
      built[j].first = std::move(modes[j]);
      if (std::isfinite(parts[j])) built[j].second.typical_part = parts[j];
    }
    cluster_bounds(built, complete_below, pencil);
  }
  // Second order, where the check left the factor at b: a vector v with
  // φ_jᵀv = 0 (the residual r, or d below) moves λ_j by Σ_i c_i²/(λ_j − λ_i),
  // c_i = φ_iᵀv over all eigenvectors φ_i (Σ_i c_i Mφ_i = v). Over the
  // returned modes each term as is, or |c_i| where c_i exceeds the gap (a
  // cluster splits by about |c_i|); over the others, all above b > λ_j:
  // Σ c_i²/(λ_i − λ_j) ≤ v⊥ᵀ(K − bM)⁻¹v⊥, v⊥ = v − Σ_returned c_i Mφ_i (for
  // the modes at or above b, the highest, an estimate only: unreturned
  // copies of λ_k in [b, λ_k] would make it larger).
  const bool factor_at_b = std::isfinite(complete_below) && factor.valid() && factor.sigma() == complete_below;
  // The vectors of the loop below, v = r_j and v = d_j of each mode that is
  // not zero, are taken together: their v⊥ solved with the factor at b
  // several right-hand sides at a time (a block solve costs a fraction of
  // one vector's per vector), at most 8 at once (2·8 n-vectors of memory).
  std::vector<double> second_r(built.size(), nan), second_d(built.size(), nan);
  if (factor_at_b) {
    struct Wanted {
      const VectorX* v;
      std::size_t j;
      double* into;
    };
    std::vector<Wanted> wanted;
    for (std::size_t j = 0; j < built.size(); ++j) {
      const ModeResidual& own = built[j].second;
      if (built[j].first.kind == ModeKind::zero) continue;
      if (own.r.size() == n && std::isfinite(own.typical_part)) wanted.push_back({&own.r, j, &second_r[j]});
      if (own.shift_direction.size() == n) wanted.push_back({&own.shift_direction, j, &second_d[j]});
    }
    // The signs of φ_iᵀMφ_i (shapes may have been flipped after Mφ was taken).
    std::vector<double> sign(built.size());
    for (std::size_t i = 0; i < built.size(); ++i)
      sign[i] = std::copysign(1.0, built[i].first.shape.real().dot(built[i].second.Mphi));
    constexpr std::size_t block = 8;
    MatrixX rest, solved;
    std::vector<double> sums;
    for (std::size_t first = 0; first < wanted.size(); first += block) {
      const std::size_t count = std::min(block, wanted.size() - first);
      rest.resize(n, static_cast<Index>(count));
      solved.resize(n, static_cast<Index>(count));
      sums.assign(count, 0.0);
      for (std::size_t w = 0; w < count; ++w) {
        const Wanted& item = wanted[first + w];
        auto column = rest.col(static_cast<Index>(w));
        column = *item.v;
        const double lambda_j = built[item.j].first.omega2;
        for (std::size_t i = 0; i < built.size(); ++i) {
          const double c = built[i].first.shape.real().dot(*item.v), gap = std::abs(built[i].first.omega2 - lambda_j);
          if (i != item.j) sums[w] += std::abs(c) >= gap ? std::abs(c) : c * c / gap;
          column -= (c * sign[i]) * built[i].second.Mphi;
        }
      }
      factor.solve(rest.data(), solved.data(), static_cast<int>(count));
      for (std::size_t w = 0; w < count; ++w)
        *wanted[first + w].into =
            sums[w] + std::abs(rest.col(static_cast<Index>(w)).dot(solved.col(static_cast<Index>(w))));
    }
  }
  // The estimate's residual part: 2× the second-order size of r where it is
  // smaller than Kato–Temple's δ²/g (whose nearest-neighbour gap ignores that
  // most of r lies along modes far above λ_j: on a net, 1e3× smaller).
  // The loose equilibrium's share (SparseModalOptions::K_equilibrium_shift):
  // λ moves by φᵀΔKφ to first order, and by the second-order size of d; δ_Δ
  // where the factor at b is not at hand. Doubled for the Newton step's own
  // error; a mode whose λ it covers becomes a zero mode.
  for (std::size_t j = 0; j < built.size(); ++j) {
    Mode& mode = built[j].first;
    const ModeResidual& own = built[j].second;
    if (mode.kind == ModeKind::zero) continue;
    if (factor_at_b && own.r.size() == n && std::isfinite(own.typical_part))
      mode.error_estimate -= own.typical_part - std::min(own.typical_part, 2 * second_r[j]);
    if (own.shift_direction.size() != n) continue;
    const double second = factor_at_b ? std::min(own.shift_residual, second_d[j]) : own.shift_residual;
    mode.error_estimate += 2 * (own.shift_first + second);
    mode.systematic_error += 2 * (own.shift_first + second);
    if (std::abs(mode.omega2) <= mode.error_estimate) {
      Mode zero = detail::make_mode(0.0, mode.error_estimate, ModeKind::zero);
      zero.omega2 = mode.omega2;
      zero.residual_bound = mode.residual_bound;
      zero.systematic_error = mode.systematic_error;
      zero.shape = std::move(mode.shape);
      mode = std::move(zero);
    }
  }
  double worst_relative_residual = 0;
  std::size_t worst = 0;
  for (std::size_t j = 0; j < built.size(); ++j) {
    if (built[j].second.relative > worst_relative_residual) {
      worst_relative_residual = built[j].second.relative;
      worst = j;
    }
    result.modes.push_back(std::move(built[j].first));
  }
  // The Lanczos iteration stops at a residual of about `tolerance` relative
  // to ‖K − σM‖; well above that, something is ill-conditioned.
  if (worst_relative_residual > std::max(1e-10, 10 * options.tolerance))
    result.notes.push_back("mode " + std::to_string(worst + 1) +
                           " has a relative residual ‖Kφ − λMφ‖/((‖K‖₁ + |λ|‖M‖₁)‖φ‖) of " +
                           detail::format_number(worst_relative_residual, 2) +
                           ", far above the Lanczos tolerance (ill-conditioned M or K − σM); trust its error estimate");

  if (completeness && !copies_note.empty())
    replace_note(result.notes, completeness->second, copies_note);
  else if (completeness)
    if (auto note = unchecked_completeness_note(completeness->first, result.modes, units(completeness_margin * zeta, 3),
                                                units(completeness->first.bound, 8)))
      replace_note(result.notes, completeness->second, std::move(*note));
  if (options.shift) {
    const auto returned_below = std::count_if(result.modes.begin(), result.modes.end(),
                                              [&](const Mode& mode) { return mode.omega2 < user_sigma; });
    result.notes.push_back("the " + plural(k, "mode", "modes") + " nearest the shift σ = " +
                           units(user_sigma, 8) + "; " +
                           plural(below_user_shift, "eigenvalue lies", "eigenvalues lie") +
                           " below σ (inertia of K − σM)");
    if (returned_below > below_user_shift)
      result.notes.push_back("inconsistent: " + std::to_string(returned_below) +
                             " returned eigenvalues lie below σ but the inertia counts " +
                             std::to_string(below_user_shift) + "; the LDLᵀ factorization may be inaccurate");
  }
  InertiaAccount account;
  account.below_s0 = m;
  account.s0 = s0;
  account.zeta = zeta;
  if (options.shift) account.shift = user_sigma;
  account.unit = units.lambda;
  count_by_inertia(result, account, [&](double& sigma, const char* what, bool expect_indefinite) {
    return count_near(sigma, expect_indefinite, what);
  });
  result.solver = "sparse shift-invert Lanczos (Spectra SymGEigsShiftSolver; ";
  for (std::size_t i = 0; i < runs.size(); ++i) result.solver += (i ? "; then " : "") + runs[i];
  result.solver += "; inertia of K − σM at σ₀ = −ζ = " + units(s0, 3) + ": " +
                   plural(m, "eigenvalue", "eigenvalues") + " below)";
  result.timings = {{"factorization", std::chrono::duration<double>(factored - started).count()},
                    {"eigen-solution", std::chrono::duration<double>(std::chrono::steady_clock::now() - factored).count()}};
  return result;
}

// ------------------------------------------------------------ matrix-free

// K − σM of a tree factored by the articulated-body recursion (TreeFactor),
// with the calls of ShiftedFactor. No pivoting: where K − σM is indefinite
// each solve gets one step of iterative refinement (a product, O(n)).
class TreeShiftedFactor {
 public:
  explicit TreeShiftedFactor(const TreePencil& p) : p_(p) {}
  Index size() const { return p_.size(); }
  double sigma() const { return sigma_; }
  bool valid() const { return valid_; }
  bool positive_definite() const { return valid_ && negative_ == 0; }
  std::optional<Index> factor(double sigma, bool /*inertia*/ = true, bool /*expect_indefinite*/ = false,
                              bool /*normwise_null*/ = false) {
    sigma_ = sigma;
    valid_ = factor_.factor(p_, 1.0, -sigma);
    if (!valid_) return std::nullopt;
    negative_ = factor_.negative_pivots();
    return negative_;
  }
  bool positive_definite_at(double sigma) {
    const std::optional<Index> below = factor(sigma);
    return below && *below == 0;
  }
  // Y = (K − σM)⁻¹ X for `columns` vectors (n × columns), one at a time
  // (the recursion is O(n) per vector already).
  void solve(const double* in, double* out, int columns = 1) const {
    if (!valid_) throw std::logic_error("solve_tree_modes: solve without a factorization");
    for (int c = 0; c < columns; ++c) {
      const double* x_in = in + static_cast<std::ptrdiff_t>(c) * size();
      double* y_out = out + static_cast<std::ptrdiff_t>(c) * size();
      factor_.solve(x_in, y_out);
      if (negative_ > 0) {
        const Eigen::Map<const VectorX> x(x_in, size());
        Eigen::Map<VectorX> y(y_out, size());
        const VectorX residual = x - tree_product(p_, 1.0, -sigma_, y);
        y += factor_.solve(residual);
      }
    }
  }
  std::string describe() const { return "LDLᵀ by the articulated-body recursion (O(n))"; }

 private:
  const TreePencil& p_;
  TreeFactor factor_;
  double sigma_ = nan;
  bool valid_ = false;
  Index negative_ = 0;
};

// y = M x through the tree, for Spectra's B-inner products.
class TreeMassProduct {
 public:
  using Scalar = double;
  explicit TreeMassProduct(const TreePencil& p) : n_(p.size()), product_(p, 0.0, 1.0) {}
  Index rows() const { return n_; }
  Index cols() const { return n_; }
  void perform_op(const Scalar* x_in, Scalar* y_out) const { product_.apply(x_in, y_out); }

 private:
  Index n_;
  TreeProduct product_;
};

// The pencil of solve_tree_modes for lanczos_modes. Norms and the rounding
// of φᵀKφ come from the magnitude recursion (tree_product with magnitude):
// Σ|terms| of each entry, which bounds |K| entrywise, and the rounding of a
// sum of depth·6 products grows with the tree's depth, hence the factor.
class TreeLanczosPencil {
 public:
  TreeLanczosPencil(const TreePencil& p, const std::vector<std::string>& names) : p_(p), factor_(p), mass_op_(p) {
    const VectorX ones = VectorX::Ones(p.size());
    norms_.K1 = tree_product(p, 1.0, 0.0, ones, true).maxCoeff();
    norms_.M1 = tree_product(p, 0.0, 1.0, ones, true).maxCoeff();
    const VectorX dM = tree_diagonal(p, 0.0, 1.0);
    if (!mass_.factor(p, 0.0, 1.0) || mass_.negative_pivots() > 0) throw mass_failure(dM, names);
    norms_.inverse_root_diagonal = dM.cwiseSqrt().cwiseInverse();
    norms_.mass_floor = detail::tree_mass_floor(p, mass_, dM);
    rounding_factor_ = 4 * eps * (1 + 2 * std::sqrt(static_cast<double>(p.depth)));
  }
  Index size() const { return p_.size(); }
  TreeShiftedFactor& factor() { return factor_; }
  // Where M's factorization through the tree broke down, in words that are
  // true whether M is singular, indefinite or positive definite but graded
  // beyond double precision (a light body carrying a heavy one: in exact
  // arithmetic its pivot is its own tiny inertia, in rounding any sign).
  // Named: the first coordinate, leaves first, whose pivot is not positive,
  // and where it is below √ε of its diagonal entry of M, the smallest
  // positive pivot relative to that entry (the relative inertia left to that
  // coordinate); not the least diagonal entry, which the coordinates'
  // scaling makes about 1 everywhere.
  SingularMassMatrix mass_failure(const VectorX& dM, const std::vector<std::string>& names) const {
    const VectorX& d = mass_.pivots();
    const int first = mass_.first_nonpositive();
    Index least = -1;
    for (Index k = 0; k < d.size(); ++k)
      if (d[k] > 0 && dM[k] > 0 && (least < 0 || d[k] / dM[k] < d[least] / dM[least])) least = k;
    std::string text =
        "the mass matrix cannot be factored in double precision in these coordinates: its LDLᵀ factorization "
        "through the tree (leaves first) meets a pivot that is not positive";
    if (first >= 0)
      text += " at coordinate " + names[static_cast<std::size_t>(first)] +
              (dM[first] > 0 ? " (its pivot " + detail::format_number(d[first] / dM[first], 2) +
                                   " × its diagonal entry of M)"
                             : " (its diagonal entry of M is " + detail::format_number(dM[first], 2) + ")");
    // Only where it lost half the digits or more (√ε of its entry): else it
    // says nothing about where the inertia runs out.
    if (least >= 0 && d[least] / dM[least] < std::sqrt(eps))
      text += "; the smallest positive pivot relative to its diagonal entry is " +
              names[static_cast<std::size_t>(least)] + "'s (" + detail::format_number(d[least] / dM[least], 2) + " ×)";
    text += ": M is singular or not positive definite there, or positive "
            "definite but too ill-conditioned for double precision in these coordinates (inertias graded over many "
            "decades, e.g. light bodies carrying heavy ones)";
    return SingularMassMatrix(text);
  }
  TreeMassProduct& mass_op() { return mass_op_; }
  std::pair<double, double> scale_and_gershgorin() const {
    const VectorX dK = tree_diagonal(p_, 1.0, 0.0), dM = tree_diagonal(p_, 0.0, 1.0);
    return {spectrum_scale(dK, dM, norms_.K1), tree_gershgorin(p_, 1.0, 0.0, dK, dM.cwiseSqrt().cwiseInverse())};
  }
  // As SparsePencil::project, with an entry of Kφ_b a chain of 2·depth + 12
  // rounded operations (make_mode) and a plain sum of n terms after it.
  Projection project(const MatrixX& Phi) const {
    return projection(Phi, (2.0 * p_.depth + 13) * eps, (static_cast<double>(size()) + 1) * eps,
                      [&](const VectorX& x) { return tree_product(p_, 1.0, 0.0, x); },
                      [&](const VectorX& x) { return tree_product(p_, 0.0, 1.0, x); },
                      [&](const VectorX& a) { return tree_product(p_, 1.0, 0.0, a, true); },
                      [&](const VectorX& a) { return tree_product(p_, 0.0, 1.0, a, true); },
                      [](const auto& x, const auto& y) { return x.dot(y); });
  }
  // No rounding form on trees (SparsePencil::data_level).
  double data_level(const MatrixX&) const { return std::numeric_limits<double>::infinity(); }
  Mode make_mode(VectorX phi, ModeResidual& residual) const {
    VectorX Mphi = tree_product(p_, 0.0, 1.0, phi);
    const double scale_phi = 1.0 / std::sqrt(phi.dot(Mphi));
    phi *= scale_phi;
    Mphi *= scale_phi;
    const VectorX Kphi = tree_product(p_, 1.0, 0.0, phi);
    const double lambda = phi.dot(Kphi);
    const VectorX r = Kphi - lambda * Mphi;
    const VectorX a = phi.cwiseAbs();
    const VectorX aK = tree_product(p_, 1.0, 0.0, a, true), aM = tree_product(p_, 0.0, 1.0, a, true);
    const double rounding = rounding_factor_ * (a.dot(aK) + std::abs(lambda) * a.dot(aM));
    const double scale = (norms_.K1 + std::abs(lambda) * norms_.M1) * phi.norm();
    residual.relative = scale > 0 ? r.norm() / scale : 0.0;
    // r's own rounding, through M⁻¹ as r itself: an entry of Kφ (Mφ) is a
    // chain of at most 2·depth additions of path and subtree sums and two
    // products of 6 terms (width), of terms bounded by the magnitude
    // recursion; worst case in δ (bound), at its typical size √width in the
    // estimate. With it the pass of lanczos_modes applies Kato–Temple's
    // δ²/g and the second-order size of r, as on the matrix path: the
    // linear δ had made the lowest modes of a 2000-link chain 10³–10⁴ ×
    // their true error.
    set_residual(residual, mass_, r, Mphi, aK + std::abs(lambda) * aM, 2.0 * p_.depth + 12, norms_);
    Mode mode = sparse_mode(std::move(phi), lambda, residual.typical, rounding, 0.0);
    mode.residual_bound = residual.bound + rounding + eps * std::abs(lambda);  // the worst case of r's rounding
    return mode;
  }

 private:
  const TreePencil& p_;
  TreeShiftedFactor factor_;
  TreeMassProduct mass_op_;
  TreeFactor mass_;
  Norms norms_;
  double rounding_factor_ = 0;
};

}  // namespace

ModalResult solve_tree_modes(TreePencil p, const SparseModalOptions& options) {
  check_options(options, "solve_tree_modes");
  const Index n = p.size();
  if (n == 0) return no_coordinates();
  for (std::size_t b = 0; b < p.parent.size(); ++b)
    if (!p.K[b].allFinite() || !p.M[b].allFinite() || !p.twist[b].allFinite() || !p.offset[b].allFinite())
      throw NumericalError("solve_tree_modes: the pencil has a non-finite entry (body " + std::to_string(b + 1) +
                           "): the problem cannot be solved");
  const Index k = std::min<Index>(options.modes, n);
  // A hanging point-mass chain (TreePencil::chain): its lowest modes from the
  // O(n) data in absolute angles, exact where the general path's relative
  // angles lose digits (cond M ≈ n⁴ there); below the spectrum only.
  if (!p.chain.empty() && !options.shift)
    if (std::optional<ModalResult> chain = detail::solve_chain_modes(p.chain, p.chain_K, p.chain_K_terms, k))
      return std::move(*chain);
  if (n <= dense_limit || k >= n - 1) {  // small: the matrices themselves, as solve_sparse_modes does
    MatrixX K(n, n), M(n, n);
    for (Index j = 0; j < n; ++j) {
      const VectorX e = VectorX::Unit(n, j);
      K.col(j) = tree_product(p, 1.0, 0.0, e);
      M.col(j) = tree_product(p, 0.0, 1.0, e);
    }
    K = (0.5 * (K + K.transpose())).eval();
    M = (0.5 * (M + M.transpose())).eval();
    return solve_sparse_modes(K.sparseView(), M.sparseView(), options);
  }
  // Equilibration as solve_sparse_modes: coordinates by powers of two
  // (twists and the joints' own terms), K and M by powers of four (the
  // composite forms); exact, undone on the modes.
  VectorX scale = detail::coordinate_scale(options.inertia_scale, n);
  {
    TreePencil scaled = p;
    for (std::size_t b = 0; b < p.parent.size(); ++b) {
      const int c = p.coordinate[b];
      if (c < 0) continue;
      scaled.twist[b] *= scale[c];
      scaled.K_diagonal[c] *= scale[c] * scale[c];
      scaled.M_diagonal[c] *= scale[c] * scale[c];
    }
    bool exact = scaled.K_diagonal.allFinite() && scaled.M_diagonal.allFinite();
    for (std::size_t b = 0; b < p.parent.size() && exact; ++b) exact = scaled.twist[b].allFinite();
    if (exact) p = std::move(scaled);
    else scale = VectorX::Ones(n);
  }
  detail::Magnitudes magnitude =
      detail::magnitudes(tree_diagonal(p, 0.0, 1.0).cwiseAbs().maxCoeff(), tree_diagonal(p, 1.0, 0.0).cwiseAbs().maxCoeff());
  SparseModalOptions scaled_options = without_matrices(options);
  {
    TreePencil scaled = p;
    bool exact = true;
    for (std::size_t b = 0; b < p.parent.size() && exact; ++b) {
      scaled.M[b] = scaled.M[b].unaryExpr([&](double x) { return std::ldexp(x, 2 * magnitude.a); });
      scaled.K[b] = scaled.K[b].unaryExpr([&](double x) { return std::ldexp(x, 2 * magnitude.b); });
      exact = scaled.M[b].allFinite() && scaled.K[b].allFinite();
    }
    scaled.M_diagonal = scaled.M_diagonal.unaryExpr([&](double x) { return std::ldexp(x, 2 * magnitude.a); });
    scaled.K_diagonal = scaled.K_diagonal.unaryExpr([&](double x) { return std::ldexp(x, 2 * magnitude.b); });
    exact = exact && scaled.M_diagonal.allFinite() && scaled.K_diagonal.allFinite();
    if (exact) {
      p = std::move(scaled);
      if (options.shift) scaled_options.shift = std::ldexp(*options.shift, 2 * (magnitude.b - magnitude.a));
    } else {
      magnitude = {};
    }
  }
  const Units units{std::ldexp(1.0, 2 * (magnitude.a - magnitude.b))};
  TreeLanczosPencil pencil(p, coordinate_names(options, n));
  ModalResult result = lanczos_modes(pencil, k, scaled_options, units);
  finish_scaled(result, magnitude, scale);
  result.solver = "matrix-free " + result.solver;
  return result;
}

}  // namespace modal
