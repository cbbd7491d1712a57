// lib/modal/symmetric.cpp — the symmetric-definite pencil K φ = λ M φ.
//
// Method: with the Cholesky factor M = L Lᵀ the pencil is equivalent to the
// standard symmetric problem C y = λ y, C = L⁻¹ K L⁻ᵀ, y = Lᵀ φ. C is
// eigen-decomposed by Eigen's SelfAdjointEigenSolver (tridiagonalization +
// implicit QR); the modes φ = L⁻ᵀ y are then M-orthonormal by construction
// (ΦᵀMΦ = YᵀY = I) up to rounding.
//
// Error estimate of each eigenvalue λ (absolute, rad²/s²), the sum of two terms:
//
//  1. What the solver left over. For the computed pair (λ, x), r = K x − λ M x.
//     In the standard form, C y − λ y = L⁻¹ r with y = Lᵀ x, and for a symmetric
//     matrix some eigenvalue lies within ‖C y − λ y‖₂ / ‖y‖₂ of λ (the residual
//     bound, e.g. Parlett, The Symmetric Eigenvalue Problem, thm 4.5.1). Hence
//     |λ − λ_true| ≤ ‖L⁻¹ r‖₂ / ‖Lᵀ x‖₂, to which the rounding of forming r
//     in floating point ((w + 2)ε(|K||x| + |λ||M||x|) componentwise, w the
//     most nonzeros in a row of K or M (n for a chain's products), through
//     L⁻¹) and of λ itself (ε|λ|) are added: Mode::residual_bound, rigorous
//     for the matrices as formed (to first order in ε; for a hanging
//     point-mass chain, Sturm counts bracket λ more narrowly and without
//     that proviso: ChainMass::certify). The estimate takes
//     the rounding of r at its typical size, √(w + 2)ε instead of the worst
//     case (w + 2)ε: rounding errors of a sum of w terms grow as √w unless
//     they conspire. Where M is ill-conditioned this term dominates (a
//     320-link cantilever in relative angles, cond M ≈ 1e10: the bound is
//     1e-3 on λ₁ = 12.3, the estimate 6e-5, the actual error of the two
//     dense solvers 1.8e-6 and 8e-6 against the sparse solver's λ₁, itself
//     within 2e-8).
//  2. What the data carry. M and K are assembled in floating point, entry by
//     entry, so their errors are componentwise: |δK_ij| ≤ E_ij with E =
//     LinearModel::K_error (4ε × Σ|terms| of the entry: an entry that is
//     itself the result of cancellation, a joint spring balancing gravity at
//     its buckling load, carries the error of the terms that cancelled, not
//     of |K_ij|), and |δM_ij| ≤ 4ε|M_ij|. For an M-normalized x, first-order
//     perturbation of the pencil gives δλ = xᵀ(δK − λ δM)x, hence
//     |δλ| ≤ |x|ᵀE|x| + 4ε|λ| |x|ᵀ|M||x|,
//     rigorous to first order for these entry errors. It is the same number
//     for the equilibrated pencil (SKS, SMS) and its shape S⁻¹x (E scales
//     with K), so graded coordinates cost nothing here. It replaces a
//     normwise floor 4ε(‖E‖ + |λ|‖M‖)‖x‖² (always larger: |x|ᵀE|x| ≤
//     ‖E‖₂‖x‖²) that made the estimate of the small root of a graded double
//     pendulum 1e7 times its true error (the floor is ε times the LARGE
//     root), and a statistical term that this bound always exceeds. A zero
//     mode whose stiffness terms cancel exactly (the spin of a body) keeps
//     an estimate at the size of the cancelled terms through E.
//     When K comes from differences (--derivatives), their measured error D
//     (from K at h, 2h, 4h) is systematic and is added as |x|ᵀD|x| (E then
//     holds the rounding part only).
//
// A zero mode is one with |λ| ≤ the sum of 1 and 2 (its residual part at the
// typical size, the data at their worst): it cannot be told from 0, and that
// sum is its estimate. Where the rounding form F is given
// (LinearModel::K_rounding_form: the springs' rounding, the positions'
// included, as a positive semidefinite form), the data's worst case is
// 4ε φᵀFφ + 4ε|λ||φ|ᵀ|M||φ| instead of |φ|ᵀE|φ| + …, which has no share of
// the positions' rounding (a rest-length net 100 m from the origin had been
// called divergent) and on a smooth mode of a net is far larger. The estimate of any other mode takes the data's
// rounding and the rounding of its Rayleigh quotient at their typical size
// instead, as the sparse path does (detail::typical_quotient_rounding: the
// rounding errors of different entries independent, doubled), with the
// entries' part bounded without another product, (Σ_ij (E_ij x_i x_j)²)^½ ≤
// ‖x∘(E|x|)‖₂ and (Σ_ij (M_ij x_i x_j)²)^½ ≤ min(‖x∘(|M||x|)‖₂, Σ_i M_ii x_i²)
// (M_ij² ≤ M_ii M_jj), or the sum above where that is smaller. On a hanging
// chain in absolute angles, M dense and positive, |x|ᵀ|M||x| is up to N² ×
// xᵀMx on the high modes, and the worst case made their estimates up to
// 5.5e5 × the true error at N = 300–400; the typical size, 8.8e4 ×
// (tests/test_tree.cpp, TreeModes.DenseChainEstimatesAreTypicalNotWorstCase).
// What is left there is the typical size of the products' rounding itself
// (√n ε‖x∘(|M||x|)‖₂ |λ|): the partial sums of an oscillating mode cancel,
// and no bound that ignores them is tighter. A hanging point-mass chain
// (K diagonal and positive, M of the chain's structure) has a narrower
// estimate from that structure and its Sturm counts (chain_estimate, in
// the analysis below).
#include "detail.hpp"

#include "core/pairwise_dot.hpp"
#include "core/sums.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SparseCore>
#include <Eigen/SparseLU>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <string>
#include <utility>
#include <vector>

// LAPACK (Debian's liblapack3 interface; OpenBLAS's implementation where it is
// installed): the pieces of dsygvd, with the Cholesky factor of M the caller
// already has (factor_mass): the reduction to standard form C = L⁻¹KL⁻ᵀ
// (dsygst), then for every pair the symmetric eigenproblem of C by divide and
// conquer (dsyevd) and Φ = L⁻ᵀY (dtrsm); for the lowest eigenvectors alone
// (solve_symmetric with `wanted`), C to tridiagonal form (dsytrd), every
// eigenvalue of the tridiagonal matrix (dsterf, no vectors), the lowest ones'
// vectors (dstemr, MRRR), and the back-transformation (dormtr). Character
// arguments carry their lengths as trailing hidden arguments (gfortran's
// convention).
extern "C" void dsyevd_(const char* jobz, const char* uplo, const int* n, double* a, const int* lda, double* w,
                        double* work, const int* lwork, int* iwork, const int* liwork, int* info,
                        std::size_t jobz_length, std::size_t uplo_length);
extern "C" void dsygst_(const int* itype, const char* uplo, const int* n, double* a, const int* lda, const double* b,
                        const int* ldb, int* info, std::size_t uplo_length);
extern "C" void dsytrd_(const char* uplo, const int* n, double* a, const int* lda, double* d, double* e, double* tau,
                        double* work, const int* lwork, int* info, std::size_t uplo_length);
extern "C" void dsterf_(const int* n, double* d, double* e, int* info);
extern "C" void dstemr_(const char* jobz, const char* range, const int* n, double* d, double* e, const double* vl,
                        const double* vu, const int* il, const int* iu, int* m, double* w, double* z, const int* ldz,
                        const int* nzc, int* isuppz, int* tryrac, double* work, const int* lwork, int* iwork,
                        const int* liwork, int* info, std::size_t jobz_length, std::size_t range_length);
extern "C" void dbdsvdx_(const char* uplo, const char* jobz, const char* range, const int* n, double* d, double* e,
                         const double* vl, const double* vu, const int* il, const int* iu, int* ns, double* s,
                         double* z, const int* ldz, double* work, int* iwork, int* info, std::size_t uplo_length,
                         std::size_t jobz_length, std::size_t range_length);
extern "C" void dpbstf_(const char* uplo, const int* n, const int* kd, double* ab, const int* ldab, int* info,
                        std::size_t uplo_length);
extern "C" void dsbgst_(const char* vect, const char* uplo, const int* n, const int* ka, const int* kb, double* ab,
                        const int* ldab, const double* bb, const int* ldbb, double* x, const int* ldx, double* work,
                        int* info, std::size_t vect_length, std::size_t uplo_length);
// LAPACK's tridiagonal LU with partial pivoting (dlagtf) and its solve
// (dlagts; JOB −1 perturbs a pivot that would overflow the solution, as
// inverse iteration needs where the shift is an eigenvalue to working
// precision): the auxiliary routines of its dstein.
extern "C" void dlagtf_(const int* n, double* a, const double* lambda, double* b, double* c, const double* tol,
                        double* d, int* in, int* info);
extern "C" void dlagts_(const int* job, const int* n, const double* a, const double* b, const double* c,
                        const double* d, const int* in, double* y, double* tol, int* info);
extern "C" void dormtr_(const char* side, const char* uplo, const char* trans, const int* m, const int* n,
                        const double* a, const int* lda, const double* tau, double* c, const int* ldc, double* work,
                        const int* lwork, int* info, std::size_t side_length, std::size_t uplo_length,
                        std::size_t trans_length);

// BLAS (OpenBLAS where installed, threaded for large products): the n×n
// products and triangular solves of the error estimates below, which with
// Eigen's single-threaded kernels took several times as long as dsygvd itself
// on a 1000-link chain.
extern "C" void dgemm_(const char* transa, const char* transb, const int* m, const int* n, const int* k,
                       const double* alpha, const double* a, const int* lda, const double* b, const int* ldb,
                       const double* beta, double* c, const int* ldc, std::size_t transa_length,
                       std::size_t transb_length);
extern "C" void dtrtri_(const char* uplo, const char* diag, const int* n, double* a, const int* lda, int* info,
                        std::size_t uplo_length, std::size_t diag_length);
extern "C" void dtrsm_(const char* side, const char* uplo, const char* transa, const char* diag, const int* m,
                       const int* n, const double* alpha, const double* a, const int* lda, double* b, const int* ldb,
                       std::size_t side_length, std::size_t uplo_length, std::size_t transa_length,
                       std::size_t diag_length);

namespace modal::detail {
namespace {
constexpr double eps = std::numeric_limits<double>::epsilon();

// Whether A is sparse enough (at most one entry in 16 nonzero) that a sparse
// product beats BLAS: K, |K| and its error bound E in absolute angles of a
// chain are diagonal, those of nets and lattices banded.
bool mostly_zero(const MatrixX& A) {
  Eigen::Index nonzeros = 0;
  const Eigen::Index limit = A.size() / 16;
  for (Eigen::Index j = 0; j < A.cols(); ++j)
    for (Eigen::Index i = 0; i < A.rows(); ++i)
      if (A(i, j) != 0 && ++nonzeros > limit) return false;
  return true;
}

// Whether the lower triangle of L is diagonal (the factor of a diagonal M:
// particles, point masses): its solves are then scalings, O(n) per vector.
// Stops at the first entry below the diagonal that is not zero.
bool diagonal_lower(const MatrixX& L) {
  for (Eigen::Index j = 0; j < L.cols(); ++j)
    for (Eigen::Index i = j + 1; i < L.rows(); ++i)
      if (L(i, j) != 0) return false;
  return true;
}

// Products of fewer than 128³ multiply–adds are left to Eigen: BLAS pays only
// for larger ones, and a small scene then never loads it (the program
// `modal` loads OpenBLAS on its first call).
bool small_product(int m, int n, int k) {
  return static_cast<double>(m) * static_cast<double>(n) * static_cast<double>(k) < 128.0 * 128.0 * 128.0;
}

// M = D_l Ĵᵀ D_m Ĵ D_l of a point-mass chain (PointMassChain, in the
// units of the pencil solved): products with M, |M| and U⁻¹, U⁻ᵀ (M = UUᵀ,
// U = D_l Ĵᵀ D_m^½) in O(n) per column, and the tridiagonal U⁻¹KU⁻ᵀ of a
// diagonal K. Row i of U⁻¹ is (e_i/l_i − e_{i+1}/l_{i+1})/√m_i.
class ChainMass {
 public:
  explicit ChainMass(const PointMassChain& c) : lever_(c.lever), mass_(c.mass), root_(c.mass.cwiseSqrt()) {}
  Eigen::Index size() const { return lever_.size(); }
  // C ← beta C + op B, op = M or |M| (= D_|l| Ĵᵀ D_m Ĵ D_|l|): a prefix sum
  // and a suffix sum per column, each rounded as a sum of at most n terms.
  void multiply(const MatrixX& B, bool absolute, double beta, MatrixX& C) const {
    const Eigen::Index n = size();
    if (beta == 0) C.setZero(n, B.cols());
    const VectorX l = absolute ? VectorX(lever_.cwiseAbs()) : lever_;
    VectorX v(n);
    for (Eigen::Index c = 0; c < B.cols(); ++c) {
      double sum = 0;
      for (Eigen::Index i = 0; i < n; ++i) {
        sum += l(i) * B(i, c);
        v(i) = mass_(i) * sum;
      }
      sum = 0;
      for (Eigen::Index i = n - 1; i >= 0; --i) {
        sum += v(i);
        C(i, c) += l(i) * sum;
      }
    }
  }
  // B ← U⁻¹B (the standard form's residuals: ‖U⁻¹r‖ = ‖r‖_{M⁻¹}).
  void solve(MatrixX& B) const {
    const Eigen::Index n = size();
    for (Eigen::Index c = 0; c < B.cols(); ++c)
      for (Eigen::Index i = 0; i < n; ++i) {
        const double next = i + 1 < n ? B(i + 1, c) / lever_(i + 1) : 0.0;
        B(i, c) = (B(i, c) / lever_(i) - next) / root_(i);
      }
  }
  // B ← U⁻ᵀB (the pencil's vectors from the standard form's).
  void solve_transposed(MatrixX& B) const {
    const Eigen::Index n = size();
    for (Eigen::Index c = 0; c < B.cols(); ++c)
      for (Eigen::Index i = n - 1; i >= 0; --i) {
        const double previous = i > 0 ? B(i - 1, c) / root_(i - 1) : 0.0;
        B(i, c) = (B(i, c) / root_(i) - previous) / lever_(i);
      }
  }
  // ‖|U⁻¹|‖₂ ≤ (‖U⁻¹‖₁‖U⁻¹‖∞)^½.
  double inverse_norm() const {
    const Eigen::Index n = size();
    double rows = 0, columns = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double after = i + 1 < n ? 1 / std::abs(lever_(i + 1)) : 0.0;
      rows = std::max(rows, (1 / std::abs(lever_(i)) + after) / root_(i));
      const double above = i > 0 ? 1 / root_(i - 1) : 0.0;
      columns = std::max(columns, (1 / root_(i) + above) / std::abs(lever_(i)));
    }
    return std::sqrt(rows * columns);
  }
  // U⁻¹KU⁻ᵀ for the diagonal k of K: diagonal d and subdiagonal e (n, the
  // last entry 0), C_ii = (k_i/l_i² + k_{i+1}/l_{i+1}²)/m_i and C_{i+1,i} =
  // −k_{i+1}/(l_{i+1}²√(m_i m_{i+1})): no cancellation where K ≥ 0.
  void tridiagonal(const VectorX& k, VectorX& d, VectorX& e) const {
    const Eigen::Index n = size();
    d.resize(n);
    e.setZero(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double own = k(i) / lever_(i) / lever_(i);
      const double next = i + 1 < n ? k(i + 1) / lever_(i + 1) / lever_(i + 1) : 0.0;
      d(i) = (own + next) / mass_(i);
      if (i + 1 < n) e(i) = -next / root_(i) / root_(i + 1);
    }
  }
  // The upper bidiagonal B = U⁻¹K^½ (C = U⁻¹KU⁻ᵀ = BBᵀ) for the diagonal k
  // > 0 of K: diagonal d and superdiagonal e (n, the last entry 0), B_ii =
  // √k_i/(l_i√m_i) and B_{i,i+1} = −√k_{i+1}/(l_{i+1}√m_i), each formed
  // from the data in a few roundings. Its entries define its singular
  // values to high relative accuracy (Demmel and Kahan 1990), C's entries do
  // not define C's small eigenvalues so (MRRR on C was off by up to 25 % on
  // the lowest modes of a 2500-link chain graded over 1e-4 … 1e4, where C's
  // diagonal spans 21 decades, and dstemr failed outright on one of 1051
  // links, lengths sorted over 1e-4 … 1e4). False where an entry is not a
  // normal number (under- or overflowed) or a k_i is not positive.
  bool bidiagonal(const VectorX& k, VectorX& d, VectorX& e) const {
    const Eigen::Index n = size();
    d.resize(n);
    e.setZero(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      if (!(k(i) > 0)) return false;
      d(i) = std::sqrt(k(i)) / (lever_(i) * root_(i));
      if (i + 1 < n) e(i) = -std::sqrt(k(i + 1)) / (lever_(i + 1) * root_(i));
      if (!std::isnormal(d(i)) || (i + 1 < n && !std::isnormal(e(i)))) return false;
    }
    return true;
  }

  // A value τ with exactly p eigenvalues below it as counted (0 < p < n,
  // k_i > 0 all), none within a factor 1 ± 1e-6 of it: the p-th and
  // (p + 1)-th lowest located by the counts of certify on a log scale (from
  // the trace down by 2¹⁶⁰⁰⁰) to 1e-3 relative, τ the geometric mean of the
  // first's upper end and the second's lower end. A count accurate to far
  // better than 1e-6 (dbdsvdx's, of the singular values, included: O(n)ε
  // at worst) finds the same p below. Nothing where those two lie within
  // 1e-5 of each other, or no count is possible.
  std::optional<double> separating_value(const VectorX& k, Eigen::Index p) const {
    using Wide = long double;
    if constexpr (std::numeric_limits<Wide>::max_exponent < 16384) return std::nullopt;
    if (p <= 0 || p >= size() || k.size() != size() || !(k.array() > 0).all() || !k.allFinite()) return std::nullopt;
    const SturmCounts below(k, lever_, mass_);
    Wide trace = 0;
    for (std::size_t i = 0; i < below.d.size(); ++i) trace += below.d[i] + below.e[i];
    if (!(trace > 0) || !std::isfinite(trace)) return std::nullopt;
    // [lo_r, hi_r) brackets the r-th lowest (r = p, p + 1): fewer than r
    // below lo_r, at least r below hi_r.
    Wide lo[2] = {std::ldexp(trace, -16000), std::ldexp(trace, -16000)}, hi[2] = {2 * trace, 2 * trace};
    for (int step = 0; step < 200 && (hi[0] > lo[0] * 1.001L || hi[1] > lo[1] * 1.001L); ++step) {
      const Wide mid0 = std::sqrt(lo[0]) * std::sqrt(hi[0]), mid1 = std::sqrt(lo[1]) * std::sqrt(hi[1]);
      const auto [a, b] = below(mid0, mid1);
      if (a < 0 || b < 0) return std::nullopt;
      (a >= p ? hi[0] : lo[0]) = mid0;
      (b >= p + 1 ? hi[1] : lo[1]) = mid1;
    }
    if (!(lo[1] >= hi[0] * (1 + 1e-5L))) return std::nullopt;
    const Wide tau = std::sqrt(hi[0]) * std::sqrt(lo[1]), margin = 1 + 1e-6L;
    const auto [a, b] = below(tau / margin, tau * margin);
    if (a != p || b != p) return std::nullopt;
    return static_cast<double>(tau);
  }

  // Each λ_i (i-th lowest, as computed; k_i > 0 all) moved to the middle
  // of a bracket [lo, hi] of the (i + 1)-th lowest eigenvalue that the
  // Sturm counts of certify (below) verify, cut to a third per step (two
  // counts) until hi − lo ≤ ε|λ|/4 (ε of double): the counts' rounding,
  // some √n ε of long double typically, is then below double's. From the
  // first bracket λ(1 ± δ) verified (δ from ε up by factors of 4): at most
  // 34 steps, some 6 where λ came within 64ε (singular values by bisection
  // on the Golub–Kahan form of a 2000-link chain: 16–64ε, the worst case
  // of their counts being O(n)ε). λ_i unchanged where no bracket is
  // verified.
  void refine(const VectorX& k, VectorX& lambda) const {
    using Wide = long double;
    if constexpr (std::numeric_limits<Wide>::digits < 64 || !std::numeric_limits<Wide>::is_iec559) return;
    if (k.size() != size() || !(k.array() > 0).all() || !k.allFinite()) return;
    const SturmCounts below(k, lever_, mass_);
    for (Eigen::Index i = 0; i < lambda.size(); ++i) {
      const Wide l = lambda(i);
      if (!(l > 0) || !std::isfinite(lambda(i))) continue;
      Wide lo = 0, hi = 0;
      for (Wide delta = std::numeric_limits<double>::epsilon(); delta <= 0.25L; delta *= 4) {
        const auto [a, b] = below(l * (1 - delta), l * (1 + delta));
        if (a < 0 || b < 0) break;
        if (a <= i && b >= i + 1) {
          lo = l * (1 - delta);
          hi = l * (1 + delta);
          break;
        }
      }
      if (!(hi > 0)) continue;
      for (int step = 0; step < 60 && hi - lo > std::numeric_limits<double>::epsilon() / 4 * l; ++step) {
        const Wide third = (hi - lo) / 3;
        const auto [a, b] = below(lo + third, hi - third);  // two points a step: a third each side
        if (a < 0 || b < 0) break;
        if (a >= i + 1) hi = lo + third;
        else if (b <= i) lo = hi - third;
        else {
          lo += third;
          hi -= third;
        }
      }
      lambda(i) = static_cast<double>((lo + hi) / 2);
    }
  }

  // Rigorous brackets of the pencil's eigenvalues by Sturm counts, where
  // every k_i > 0 (a hanging chain under gravity): C = U⁻¹KU⁻ᵀ = BBᵀ with
  // B = U⁻¹K^½ upper bidiagonal, and BᵀB = LDLᵀ with d_i = k_i/(l_i² m_i)
  // and e_i = L_{i+1,i}² d_i = k_{i+1}/(l_{i+1}² m_i) (L unit lower
  // bidiagonal; l the signed lengths as elsewhere).
  // below(τ) counts the negative pivots of LDLᵀ − τI by the recurrence of
  // LAPACK's dlaneg (p_i = d_i + s_i, s_{i+1} = e_i(s_i/p_i) − τ), in long
  // double. Its rounding is that of exact arithmetic on d_i perturbed by
  // one rounding and e_i by three (each rounding absorbed into the next
  // pivot, signs kept), and forming d and e takes three more each: d_i and
  // e_i within 6ε relative (ε of long double), B's entries within 3ε, so
  // the count is exact for a bidiagonal whose entries differ from B's by a
  // factor within 1 ± η, η = 4ε with a margin. Such a B̃ is D₁BD₂ (D₁, D₂
  // diagonal, products of at most 2n − 1 of those factors), so its singular
  // values lie within (1 − η)^{∓(2n − 1)} of B's (Demmel and Kahan, SIAM J.
  // Sci. Stat. Comput. 11, 1990): the eigenvalues within a factor 1 ± ρ,
  // ρ = 1.01·2(2n − 1)η (the 1.01 for the higher orders while ρ ≤ 0.01).
  // For mode i, the (i + 1)-th lowest, with computed λ: if at most i
  // eigenvalues lie below λ(1 − δ) and at least i + 1 below λ(1 + δ), as
  // counted, the exact one lies in [λ(1 − δ)/(1 + ρ), λ(1 + δ)(1 + ρ)]; δ
  // from ε of double up by factors of 4 to the first bracket the counts
  // verify (without `spread`, only while the radius stays below limit(i)).
  // The radius per mode where it is below limit(i), else ∞; in
  // `spread` (where given), δ|λ| of the same bracket, the half width that
  // the counts themselves resolved (without ρ, the worst case of their
  // rounding, about 16nε of long double, 8ε of double at n = 1000: their
  // rounding errors are independent, so at their typical size some √n
  // times smaller), for the error estimate. Each count is O(n): at most 52
  // counts per mode (δ takes at most 26 values), two to four in practice.
  // The analysis needs a long double of 64 bits with IEEE rounding (x86's);
  // elsewhere no bracket is claimed.
  VectorX certify(const VectorX& k, const VectorX& lambda, const VectorX& limit, VectorX* spread = nullptr) const {
    using Wide = long double;
    const Eigen::Index n = size(), m = lambda.size();
    VectorX radius = VectorX::Constant(m, std::numeric_limits<double>::infinity());
    if (spread != nullptr) *spread = radius;
    if constexpr (std::numeric_limits<Wide>::digits < 64 || !std::numeric_limits<Wide>::is_iec559) return radius;
    if (k.size() != n || !(k.array() > 0).all() || !k.allFinite()) return radius;
    const Wide eta = 4 * std::numeric_limits<Wide>::epsilon();
    const Wide rho = 1.01L * 2 * static_cast<Wide>(2 * n - 1) * eta;
    if (!(rho <= 0.01L)) return radius;
    const SturmCounts below(k, lever_, mass_);
    // The rounding of the radius (lo/(1 + ρ) and the products: a few ε of
    // long double relative to λ) is covered by η's margin (8 units of
    // rounding taken where the counts need 3); `up` covers the last steps.
    const Wide up = 1 + 8 * std::numeric_limits<Wide>::epsilon();
    for (Eigen::Index i = 0; i < m; ++i) {
      const Wide l = lambda(i);
      if (!(l > 0) || !std::isfinite(lambda(i))) continue;
      for (Wide delta = std::numeric_limits<double>::epsilon(); delta <= 0.25L; delta *= 4) {
        const Wide lo = l * (1 - delta), hi = l * (1 + delta);
        const Wide r = std::max(l - lo / (1 + rho), hi * (1 + rho) - l) * up;
        const double r_double = std::nextafter(static_cast<double>(r), std::numeric_limits<double>::infinity());
        const bool narrower = r_double < limit(i);
        if (!narrower && spread == nullptr) break;
        const auto [a, b] = below(lo, hi);
        if (a < 0 || b < 0) break;
        if (a <= i && b >= i + 1) {
          if (narrower) radius(i) = r_double;
          if (spread != nullptr) (*spread)(i) = static_cast<double>(delta * l);
          break;
        }
      }
    }
    return radius;
  }

 private:
  // The negative pivots of LDLᵀ − τI (certify's recurrence, in long double)
  // for BᵀB of diagonal k: below(τ₁, τ₂) counts below both, or −1 where a
  // pivot is zero or not finite; the two recurrences run side by side (each
  // step's division waits on the one before, so two chains in one loop
  // take about the time of one).
  struct SturmCounts {
    using Wide = long double;
    std::vector<Wide> d, e;
    SturmCounts(const VectorX& k, const VectorX& lever, const VectorX& mass)
        : d(static_cast<std::size_t>(k.size())), e(static_cast<std::size_t>(k.size()), 0) {
      const Eigen::Index n = k.size();
      for (Eigen::Index i = 0; i < n; ++i) {
        const auto u = static_cast<std::size_t>(i);
        d[u] = static_cast<Wide>(k(i)) / (static_cast<Wide>(lever(i)) * lever(i) * mass(i));
        if (i + 1 < n) e[u] = static_cast<Wide>(k(i + 1)) / (static_cast<Wide>(lever(i + 1)) * lever(i + 1) * mass(i));
      }
    }
    std::pair<Eigen::Index, Eigen::Index> operator()(Wide tau1, Wide tau2) const {
      Wide t1 = -tau1, t2 = -tau2;
      Eigen::Index count1 = 0, count2 = 0;
      for (std::size_t i = 0; i < d.size(); ++i) {
        const Wide pivot1 = d[i] + t1, pivot2 = d[i] + t2;
        if (!(pivot1 != 0) || !std::isfinite(pivot1) || !(pivot2 != 0) || !std::isfinite(pivot2)) return {-1, -1};
        count1 += pivot1 < 0 ? 1 : 0;
        count2 += pivot2 < 0 ? 1 : 0;
        t1 = e[i] * (t1 / pivot1) - tau1;
        t2 = e[i] * (t2 / pivot2) - tau2;
      }
      return {count1, count2};
    }
  };
  VectorX lever_, mass_, root_;
};

// ‖T‖₁ = ‖T‖∞ of the symmetric tridiagonal T with diagonal d and
// subdiagonal e (as long as d, the last entry unused).
double tridiagonal_norm(const VectorX& d, const VectorX& e) {
  const Eigen::Index n = d.size();
  double norm = 0;
  for (Eigen::Index i = 0; i < n; ++i)
    norm = std::max(norm, std::abs(d(i)) + (i + 1 < n ? std::abs(e(i)) : 0.0) + (i > 0 ? std::abs(e(i - 1)) : 0.0));
  return norm;
}

// M = UUᵀ + R of a chain of rigid links (LinkChain, in the units of the
// pencil solved), UUᵀ a point-mass chain's (ChainMass) and R diagonal: with
// B = I + U⁻¹RU⁻ᵀ = L_B L_Bᵀ (tridiagonal, L_B lower bidiagonal), M = FFᵀ
// for F = U L_B. Products with M and |M| (≤ |UUᵀ| + |R| entrywise), F⁻¹
// and F⁻ᵀ cost O(n) per column; and for a diagonal K the pencil (K, M) is
// congruent to the tridiagonal pencil (C, B), C = U⁻¹KU⁻ᵀ, which LAPACK
// dsbgst reduces to a tridiagonal standard form T = XᵀCX (XᵀBX = I, X dense:
// T in O(n²), X's plane rotations in Θ(n³) of vector work): an eigenvector y
// of T gives φ = U⁻ᵀXy.
class LinkChainMass {
 public:
  // Nothing where B's Cholesky meets a pivot below 1e-8 of its diagonal
  // entry (M then far from UUᵀ's definiteness: the general path decides).
  static std::optional<LinkChainMass> make(const LinkChain& c) {
    const Eigen::Index n = c.remainder.size();
    if (n < 2 || c.generators.lever.size() != n || c.generators.mass.size() != n || !c.remainder.allFinite())
      return std::nullopt;
    LinkChainMass m(c);
    m.chain_.tridiagonal(c.remainder, m.bd_, m.be_);
    m.bd_.array() += 1;
    m.ld_.resize(n);
    m.le_.setZero(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double pivot = m.bd_(i) - (i > 0 ? m.le_(i - 1) * m.le_(i - 1) : 0.0);
      if (!(pivot > 1e-8 * m.bd_(i)) || !std::isfinite(pivot)) return std::nullopt;
      m.ld_(i) = std::sqrt(pivot);
      if (i + 1 < n) m.le_(i) = m.be_(i) / m.ld_(i);
    }
    if (!m.be_.allFinite() || !m.le_.allFinite()) return std::nullopt;
    return m;
  }
  Eigen::Index size() const { return chain_.size(); }
  // C ← beta C + op B, op = M or |M| (its bound |UUᵀ| + |R|).
  void multiply(const MatrixX& B, bool absolute, double beta, MatrixX& C) const {
    chain_.multiply(B, absolute, beta, C);
    if (absolute) C.noalias() += remainder_.cwiseAbs().asDiagonal() * B;
    else C.noalias() += remainder_.asDiagonal() * B;
  }
  // B ← F⁻¹B = L_B⁻¹U⁻¹B (‖F⁻¹r‖ = ‖r‖_{M⁻¹}).
  void solve(MatrixX& B) const {
    chain_.solve(B);
    const Eigen::Index n = size();
    for (Eigen::Index c = 0; c < B.cols(); ++c)
      for (Eigen::Index i = 0; i < n; ++i)
        B(i, c) = (B(i, c) - (i > 0 ? le_(i - 1) * B(i - 1, c) : 0.0)) / ld_(i);
  }
  // B ← F⁻ᵀB = U⁻ᵀL_B⁻ᵀB.
  void solve_transposed(MatrixX& B) const {
    const Eigen::Index n = size();
    for (Eigen::Index c = 0; c < B.cols(); ++c)
      for (Eigen::Index i = n - 1; i >= 0; --i)
        B(i, c) = (B(i, c) - (i + 1 < n ? le_(i) * B(i + 1, c) : 0.0)) / ld_(i);
    chain_.solve_transposed(B);
  }
  // ‖|F⁻¹|‖₂ ≤ ‖|L_B⁻¹|‖₂ ‖|U⁻¹|‖₂ (|F⁻¹| ≤ |L_B⁻¹||U⁻¹| entrywise), the
  // first ≤ (‖L_B⁻¹‖₁‖L_B⁻¹‖∞)^½, whose row and column sums are those of
  // the comparison matrix's inverse (L_B bidiagonal: |L_B⁻¹| = ⟨L_B⟩⁻¹).
  double inverse_norm() const { return factor_inverse_norm() * chain_.inverse_norm(); }

  // The standard form of (C, B) for the diagonal k of K: T's diagonal d and
  // subdiagonal e (n, the last entry unused) by LAPACK dpbstf (B's split
  // Cholesky factor) and dsbgst, with X (n×n) where asked for (VECT 'V':
  // Θ(n³) of plane rotations; without it, O(n²)). False where either
  // routine fails.
  bool reduce(const VectorX& k, VectorX& d, VectorX& e, MatrixX* X) const {
    const int n = static_cast<int>(size()), one = 1, two = 2;
    VectorX cd, ce;
    chain_.tridiagonal(k, cd, ce);
    MatrixX ab(2, n), bb(2, n);  // upper band storage: row 0 the superdiagonal (column j: entry (j − 1, j)), row 1 the diagonal
    ab.setZero();
    bb.setZero();
    for (int j = 0; j < n; ++j) {
      ab(1, j) = cd(j);
      bb(1, j) = bd_(j);
      if (j > 0) {
        ab(0, j) = ce(j - 1);
        bb(0, j) = be_(j - 1);
      }
    }
    int info = 0;
    dpbstf_("U", &n, &one, bb.data(), &two, &info, 1);
    if (info != 0) return false;
    VectorX work(2 * n);
    MatrixX none(1, 1);
    if (X != nullptr) X->resize(n, n);
    double* x = X != nullptr ? X->data() : none.data();
    const int ldx = X != nullptr ? n : 1;
    dsbgst_(X != nullptr ? "V" : "N", "U", &n, &one, &one, ab.data(), &two, bb.data(), &two, x, &ldx, work.data(),
            &info, 1, 1);
    if (info != 0 || !ab.allFinite() || (X != nullptr && !X->allFinite())) return false;
    d = ab.row(1).transpose();
    e.setZero(n);
    for (int j = 1; j < n; ++j) e(j - 1) = ab(0, j);
    return true;
  }
  // The pencil's vectors Z (n×p, zᵀBz = 1) for the ascending eigenvalues
  // `values` of (C, B), C for the diagonal k of K (those of T from reduce
  // with the same k), by inverse
  // iteration on the tridiagonal C − λB (dlagtf once per eigenvalue, then
  // dlagts and the products with B and C: O(n) per step, so O(pn) in all,
  // against X's Θ(n³) rotations and the product XY). Each start is a fixed
  // pseudo-random vector; a vector is taken once its residual against its
  // Rayleigh quotient, ‖(C − ρB)z‖₂, is within 4nε(‖C‖₁ + |ρ|‖B‖₁)‖z‖₂ (a
  // backward error of the pencil's own rounding) after at least two steps,
  // at most six. Eigenvalues closer than √ε(‖C‖₁ + |λ|‖B‖₁), where the shift's
  // error could leave two steps on the same vector, form a cluster, within
  // which each iterate is made B-orthogonal to the ones before it (twice:
  // Kahan, in Parlett §6.9), as LAPACK's dstein does. False, and the caller
  // forms X instead, where a step fails, a vector does not converge, or a
  // cluster holds more than 64 eigenvalues (its orthogonalization would
  // cost more than X: a strongly graded chain's lowest modes).
  bool pencil_vectors(const VectorX& k, const VectorX& values, MatrixX& Z) const {
    const Eigen::Index n = size(), p = values.size();
    const int m = static_cast<int>(n);
    VectorX cd, ce;  // C = U⁻¹KU⁻ᵀ: diagonal and subdiagonal
    chain_.tridiagonal(k, cd, ce);
    const double normC = tridiagonal_norm(cd, ce), normB = tridiagonal_norm(bd_, be_);
    auto product = [n](const VectorX& diagonal, const VectorX& sub, const VectorX& x, VectorX& y) {
      for (Eigen::Index i = 0; i < n; ++i)
        y(i) = diagonal(i) * x(i) + (i + 1 < n ? sub(i) * x(i + 1) : 0.0) + (i > 0 ? sub(i - 1) * x(i - 1) : 0.0);
    };
    Z.resize(n, p);
    MatrixX BZ(n, p);
    VectorX a(n), b(std::max<Eigen::Index>(n - 1, 1)), c(std::max<Eigen::Index>(n - 1, 1)),
        fill(std::max<Eigen::Index>(n - 2, 1)), x(n), y(n), Bx(n), Cx(n);
    std::vector<int> pivots(static_cast<std::size_t>(n));
    std::uint64_t state = 0x9E3779B97F4A7C15ULL;  // the starts' generator (splitmix64)
    auto uniform = [&state] {
      std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
      z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
      z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
      z ^= z >> 31;
      return static_cast<double>(z >> 11) * 0x1.0p-52 - 1.0;  // in [−1, 1)
    };
    const double tolerance = 4 * static_cast<double>(n) * eps;
    Eigen::Index cluster = 0;  // the first column of the current cluster
    for (Eigen::Index j = 0; j < p; ++j) {
      const double lambda = values(j);
      if (!std::isfinite(lambda)) return false;
      if (j == 0 || !(lambda - values(j - 1) <= std::sqrt(eps) * (normC + std::abs(lambda) * normB))) cluster = j;
      if (j - cluster >= 64) return false;
      for (Eigen::Index i = 0; i < n; ++i) {
        a(i) = cd(i) - lambda * bd_(i);
        if (i + 1 < n) b(i) = c(i) = ce(i) - lambda * be_(i);
      }
      const double zero = 0, factor_tolerance = 0;
      int info = 0;
      dlagtf_(&m, a.data(), &zero, b.data(), c.data(), &factor_tolerance, fill.data(), pivots.data(), &info);
      if (info != 0) return false;
      for (Eigen::Index i = 0; i < n; ++i) x(i) = uniform();
      bool converged = false;
      for (int step = 0; step < 6 && !converged; ++step) {
        product(bd_, be_, x, y);
        const int job = -1;
        double solve_tolerance = 0;
        dlagts_(&job, &m, a.data(), b.data(), c.data(), fill.data(), pivots.data(), y.data(), &solve_tolerance,
                &info);
        if (info != 0 || !y.allFinite()) return false;
        for (int pass = 0; pass < 2; ++pass)
          for (Eigen::Index k = cluster; k < j; ++k) y -= BZ.col(k).dot(y) * Z.col(k);
        product(bd_, be_, y, Bx);
        const double norm = std::sqrt(std::max(y.dot(Bx), 0.0));
        if (!(norm > 0) || !std::isfinite(norm)) return false;
        x = y / norm;
        Bx /= norm;
        product(cd, ce, x, Cx);
        const double rho = x.dot(Cx);
        converged =
            step >= 1 && (Cx - rho * Bx).norm() <= tolerance * (normC + std::abs(rho) * normB) * x.norm();
      }
      if (!converged) return false;
      Z.col(j) = x;
      BZ.col(j) = Bx;
    }
    return true;
  }
  // ‖abs(L_B⁻¹)‖₂² ‖B‖∞ ≥ κ₂(B): the size of dsbgst's error relative to ε
  // (its standard form's error is about ε‖C‖‖B⁻¹‖).
  double condition() const {
    const double l = factor_inverse_norm();
    return tridiagonal_norm(bd_, be_) * l * l;
  }
  // Y ← U⁻ᵀY: the pencil's vectors φ = U⁻ᵀXy from the vectors Xy of (C, B).
  void to_coordinates(MatrixX& Y) const { chain_.solve_transposed(Y); }
  // Whether M itself is definite where it differs from M̃ = FFᵀ by at most
  // gap·(abs(UUᵀ) + abs(R)) entrywise: F⁻¹MF⁻ᵀ = I + F⁻¹(M − M̃)F⁻ᵀ, whose
  // second term is at most gap ‖abs(F⁻¹)‖₂² ‖abs(UUᵀ) + abs(R)‖∞ in norm
  // (the last a symmetric matrix's 2-norm bound); definite where that is
  // below ½. One product with a vector of ones.
  bool definite_within(double gap) const {
    MatrixX ones = MatrixX::Ones(size(), 1), row_sums;
    multiply(ones, true, 0, row_sums);
    const double l = inverse_norm();
    return gap * l * l * row_sums.maxCoeff() < 0.5;
  }

 private:
  explicit LinkChainMass(const LinkChain& c) : chain_(c.generators), remainder_(c.remainder) {}
  // ‖abs(L_B⁻¹)‖₂ ≤ (‖L_B⁻¹‖₁‖L_B⁻¹‖∞)^½.
  double factor_inverse_norm() const {
    const Eigen::Index n = size();
    double x = 0, y = 0, rows = 0, columns = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      x = (1 + (i > 0 ? std::abs(le_(i - 1)) * x : 0.0)) / ld_(i);
      rows = std::max(rows, x);
    }
    for (Eigen::Index i = n - 1; i >= 0; --i) {
      y = (1 + (i + 1 < n ? std::abs(le_(i)) * y : 0.0)) / ld_(i);
      columns = std::max(columns, y);
    }
    return std::sqrt(rows * columns);
  }
  ChainMass chain_;
  VectorX remainder_;
  VectorX bd_, be_;  // B = I + U⁻¹RU⁻ᵀ: diagonal and subdiagonal (the last entry 0)
  VectorX ld_, le_;  // its Cholesky factor L_B: diagonal and subdiagonal
};

// A matrix the analysis multiplies by, in the form decided once for all its
// products (both analyses): sparse where mostly_zero, with |A| made beside A
// once, else dense, |A| made for each product that asks for it and freed. Deciding per product had scanned and converted a 1000-link chain's
// diagonal K, |K| and E (n² entries each, twice over with the refinement)
// for longer than the sparse products took. It refers to the matrix it is
// given, or owns one made for it; neither copied nor moved.
class Operand {
 public:
  explicit Operand(const MatrixX& A) : dense_(&A) { decide(); }
  // A point-mass chain's M: products by its structure (ChainMass), never dense.
  Operand(const MatrixX& A, const ChainMass& chain) : dense_(&A), chain_(&chain) {
    rows_ = A.rows();
    cols_ = A.cols();
  }
  // A chain of rigid links' M: products by its structure (LinkChainMass).
  Operand(const MatrixX& A, const LinkChainMass& links) : dense_(&A), links_(&links) {
    rows_ = A.rows();
    cols_ = A.cols();
  }
  explicit Operand(MatrixX&& A) : owned_(std::move(A)), dense_(&owned_) { decide(); }
  Operand(const Operand&) = delete;
  Operand& operator=(const Operand&) = delete;

  // C ← beta C + op B, op = A or |A| (column-major; beta 0 or 1).
  void multiply(const MatrixX& B, bool absolute, double beta, MatrixX& C) const {
    const int m = static_cast<int>(rows_), n = static_cast<int>(B.cols()), k = static_cast<int>(cols_);
    if (beta == 0) C.resize(m, n);
    if (m == 0 || n == 0) return;
    if (k == 0) {
      if (beta == 0) C.setZero();
      return;
    }
    if (chain_ != nullptr) {
      chain_->multiply(B, absolute, beta, C);
      return;
    }
    if (links_ != nullptr) {
      links_->multiply(B, absolute, beta, C);
      return;
    }
    if (sparse_) {
      const Eigen::SparseMatrix<double>& S = absolute ? absolute_ : sparse_matrix_;
      if (beta == 0) C.noalias() = S * B;
      else C.noalias() += S * B;
      return;
    }
    MatrixX made;  // |A|, freed on return (fresh pages cost more to touch than to keep few)
    if (absolute) made = dense_->cwiseAbs();
    const MatrixX& A = absolute ? made : *dense_;
    if (small_product(m, n, k)) {  // Eigen's own kernel: no BLAS to load or start (docs/design.md, "Start-up")
      if (beta == 0) C.noalias() = A * B;
      else C.noalias() += A * B;
      return;
    }
    const double one = 1;
    dgemm_("N", "N", &m, &n, &k, &one, A.data(), &m, B.data(), &k, &beta, C.data(), &m, 1, 1);
  }
  MatrixX product(const MatrixX& B, bool absolute = false) const {
    MatrixX C;
    multiply(B, absolute, 0, C);
    return C;
  }
  // The sparse form, or nullptr where the operand is dense.
  const Eigen::SparseMatrix<double>* sparse() const { return sparse_ ? &sparse_matrix_ : nullptr; }

 private:
  void decide() {
    rows_ = dense_->rows();
    cols_ = dense_->cols();
    sparse_ = mostly_zero(*dense_);
    if (!sparse_) return;
    sparse_matrix_ = dense_->sparseView();
    absolute_ = sparse_matrix_.cwiseAbs();
    owned_.resize(0, 0);  // the sparse forms hold everything now
  }
  MatrixX owned_;
  const MatrixX* dense_;
  const ChainMass* chain_ = nullptr;
  const LinkChainMass* links_ = nullptr;
  Eigen::Index rows_ = 0, cols_ = 0;
  bool sparse_ = false;
  Eigen::SparseMatrix<double> sparse_matrix_, absolute_;
};

// B ← L⁻¹ B for the lower triangle L of `L` (n×n; the upper triangle is not
// read): rows scaled where L is diagonal.
void solve_lower(const MatrixX& L, MatrixX& B) {
  const int n = static_cast<int>(L.rows()), m = static_cast<int>(B.cols());
  if (n == 0 || m == 0) return;
  if (diagonal_lower(L)) {
    B.array().colwise() /= L.diagonal().array();
    return;
  }
  if (small_product(n, m, n)) {
    L.triangularView<Eigen::Lower>().solveInPlace(B);
    return;
  }
  const double one = 1;
  dtrsm_("L", "L", "N", "N", &n, &m, &one, L.data(), &n, B.data(), &n, 1, 1, 1, 1);
}

// B ← L⁻ᵀ B for the lower triangle L of `L` (BLAS dtrsm; rows scaled where L
// is diagonal).
void solve_upper(const MatrixX& L, MatrixX& B) {
  const int n = static_cast<int>(L.rows()), m = static_cast<int>(B.cols());
  if (n == 0 || m == 0) return;
  if (diagonal_lower(L)) {
    B.array().colwise() /= L.diagonal().array();
    return;
  }
  const double one = 1;
  dtrsm_("L", "L", "T", "N", &n, &m, &one, L.data(), &n, B.data(), &n, 1, 1, 1, 1);
}

// Eigen: C = L⁻¹ K L⁻ᵀ = L⁻¹ (L⁻¹ K)ᵀ for symmetric K, symmetrized exactly,
// tridiagonalized and solved by implicit QR; Φ = L⁻ᵀ Y.
void eigen_pairs(const MatrixX& K, const Cholesky& mass, VectorX& lambda, MatrixX& Phi) {
  const auto L = mass.matrixL();
  MatrixX C = L.solve(K);
  C = L.solve(MatrixX(C.transpose()));
  C = 0.5 * (C + C.transpose()).eval();
  Eigen::SelfAdjointEigenSolver<MatrixX> eig(C);
  if (eig.info() != Eigen::Success)
    throw NumericalError("the symmetric eigen-solver did not converge (Eigen SelfAdjointEigenSolver)");
  lambda = eig.eigenvalues();  // ascending
  Phi = mass.matrixU().solve(eig.eigenvectors());
}

// C = L⁻¹KL⁻ᵀ in place of K (n×n; its lower triangle is written), with the
// factor L of M in the lower triangle of L (LAPACK dsygst; scalings where L
// is diagonal).
void reduce_to_standard(MatrixX& K, const MatrixX& L) {
  if (diagonal_lower(L)) {  // C_ij = K_ij / (l_i l_j): O(n²), not dsygst's n³
    const VectorX& l = L.diagonal();
    for (Eigen::Index j = 0; j < K.cols(); ++j)
      for (Eigen::Index i = j; i < K.rows(); ++i) K(i, j) = K(i, j) / l(i) / l(j);
    return;
  }
  const int n = static_cast<int>(K.rows()), itype = 1;
  int info = 0;
  dsygst_(&itype, "L", &n, K.data(), &n, L.data(), &n, &info, 1);
  if (info != 0) throw NumericalError("LAPACK dsygst failed (info " + std::to_string(info) + ")");
}

// L⁻¹ of the lower triangle of L (n×n, lower triangular, zero above): LAPACK
// dtrtri (n³/3 flops) where BLAS pays (small_product), else Eigen's
// triangular solve with the identity.
MatrixX lower_inverse(const MatrixX& L) {
  const int n = static_cast<int>(L.rows());
  if (n == 0 || small_product(n, n, n)) {
    MatrixX inverse = MatrixX::Identity(n, n);
    L.triangularView<Eigen::Lower>().solveInPlace(inverse);
    return inverse;
  }
  MatrixX inverse = L.triangularView<Eigen::Lower>();
  int info = 0;
  dtrtri_("L", "N", &n, inverse.data(), &n, &info, 1, 1);
  if (info != 0)
    throw NumericalError("LAPACK dtrtri: the factor of M has a zero pivot (info " + std::to_string(info) + ")");
  return inverse;
}

// Every pair of K φ = λ M φ (ΦᵀMΦ = I) by LAPACK, as dsygvd computes them
// but with the caller's factor L of M (dsygvd would factor M again): C =
// L⁻¹KL⁻ᵀ (dsygst, or scalings where L is diagonal), CY = YΛ by divide and
// conquer (dsyevd), Φ = L⁻ᵀY.
void lapack_pairs(const MatrixX& K, const Cholesky& mass, VectorX& lambda, MatrixX& Phi) {
  const int n = static_cast<int>(K.rows());
  const MatrixX& L = mass.matrixLLT();  // its lower triangle is L
  Phi = K;  // C, then Y, then Φ
  lambda.resize(n);
  reduce_to_standard(Phi, L);
  int info = 0;
  int lwork = -1, liwork = -1, iwork_size = 0;
  double work_size = 0;
  dsyevd_("V", "L", &n, Phi.data(), &n, lambda.data(), &work_size, &lwork, &iwork_size, &liwork, &info, 1,
          1);  // workspace query
  lwork = std::max(1, static_cast<int>(work_size));
  liwork = std::max(1, iwork_size);
  // Not value-initialized: dsyevd writes before it reads, and zeroing 2n² doubles touched every page first.
  const std::unique_ptr<double[]> work(new double[static_cast<std::size_t>(lwork)]);
  const std::unique_ptr<int[]> iwork(new int[static_cast<std::size_t>(liwork)]);
  dsyevd_("V", "L", &n, Phi.data(), &n, lambda.data(), work.get(), &lwork, iwork.get(), &liwork, &info, 1, 1);
  if (info != 0) throw NumericalError("LAPACK dsyevd did not converge (info " + std::to_string(info) + ")");
  solve_upper(L, Phi);  // Φ = L⁻ᵀY
}

// Every eigenvalue of the symmetric tridiagonal matrix with diagonal d and
// subdiagonal e (n each, e's last entry unused), ascending (LAPACK dsterf:
// implicit QL/QR without vectors).
VectorX tridiagonal_eigenvalues(VectorX d, VectorX e) {
  const int n = static_cast<int>(d.size());
  int info = 0;
  dsterf_(&n, d.data(), e.data(), &info);
  if (info != 0) throw NumericalError("LAPACK dsterf did not converge (info " + std::to_string(info) + ")");
  return d;
}

// The orthonormal eigenvectors of its p lowest eigenvalues (n×p) by MRRR
// (LAPACK dstemr, which keeps the relative accuracy a matrix may define:
// tryrac), and in `values` those eigenvalues; an empty matrix where dstemr
// fails (the caller then solves otherwise).
MatrixX tridiagonal_lowest(VectorX d, VectorX e, int p, VectorX* values = nullptr) {
  const int n = static_cast<int>(d.size());
  if (p <= 0) return MatrixX(n, 0);
  VectorX w(n);
  MatrixX Z(n, p);
  const int il = 1, iu = p;
  const double vl = 0, vu = 0;
  int found = 0, tryrac = 1, info = 0, lwork = -1, liwork = -1, isize = 0;
  double size = 0;
  std::vector<int> isuppz(static_cast<std::size_t>(2 * p));
  const char* range = p == n ? "A" : "I";
  dstemr_("V", range, &n, d.data(), e.data(), &vl, &vu, &il, &iu, &found, w.data(), Z.data(), &n, &p,
          isuppz.data(), &tryrac, &size, &lwork, &isize, &liwork, &info, 1, 1);
  if (info != 0) return {};
  lwork = std::max(1, static_cast<int>(size));
  liwork = std::max(1, isize);
  std::vector<double> work(static_cast<std::size_t>(lwork));
  std::vector<int> iwork(static_cast<std::size_t>(liwork));
  dstemr_("V", range, &n, d.data(), e.data(), &vl, &vu, &il, &iu, &found, w.data(), Z.data(), &n, &p,
          isuppz.data(), &tryrac, work.data(), &lwork, iwork.data(), &liwork, &info, 1, 1);
  if (info != 0 || found != p) return {};
  if (values != nullptr) *values = w.head(p);
  return Z;
}

// The p smallest singular values σ (ascending) of the upper bidiagonal
// matrix with diagonal d and superdiagonal e (n each, e's last entry
// unused), and their right singular vectors (n×p, unit columns), by LAPACK
// dbdsvdx (bisection on the Golub–Kahan tridiagonal, which keeps the
// relative accuracy a bidiagonal defines, and inverse iteration): all n
// where p = n, else those below `below` (exactly p of them, as the caller
// has counted: RANGE 'V'; its RANGE 'I' widens the interval by 2n·ulp·σ_max
// on both sides, finds more than asked where the next singular value lies
// that close, and then drops the smallest, while writing a column of Z for
// each found); false where it fails or finds another number.
bool bidiagonal_lowest(VectorX d, VectorX e, int p, double below, VectorX& sigma, MatrixX& right) {
  const int n = static_cast<int>(d.size());
  if (p <= 0 || p > n || (p < n && !(below > 0 && std::isfinite(below)))) return false;
  const int il = 0, iu = 0, ldz = 2 * n;
  const double vl = 0, vu = p < n ? below : 0;
  int found = 0, info = 0;
  // S of 2n: with RANGE 'A' and a smallest singular value below dbdsvdx's
  // absolute threshold it asks its Golub–Kahan solve for n + 1 values.
  VectorX s(2 * n);
  MatrixX Z(ldz, std::min(n, p + 1) + 1);  // NS + 1 columns at least (one spare)
  std::vector<double> work(static_cast<std::size_t>(14) * static_cast<std::size_t>(n));
  std::vector<int> iwork(static_cast<std::size_t>(12) * static_cast<std::size_t>(n));
  dbdsvdx_("U", "V", p < n ? "V" : "A", &n, d.data(), e.data(), &vl, &vu, &il, &iu, &found, s.data(), Z.data(),
           &ldz, work.data(), iwork.data(), &info, 1, 1, 1);
  if (info != 0 || found != p) return false;
  // Returned from the largest down: reversed, with their vectors.
  sigma.resize(p);
  right.resize(n, p);
  for (int j = 0; j < p; ++j) {
    sigma(j) = s(p - 1 - j);
    right.col(j) = Z.col(p - 1 - j).segment(n, n);
  }
  for (int j = 0; j + 1 < p; ++j)
    if (!(sigma(j) <= sigma(j + 1))) return false;
  return sigma.allFinite() && right.allFinite();
}

// The p lowest singular values σ (ascending) of a hanging chain's
// bidiagonal B = U⁻¹K^½ (ChainMass::bidiagonal: k the diagonal of K, every
// entry positive) and their right vectors V (n×p, unit columns), asked of
// bidiagonal_lowest by value: below a τ that the chain's long double Sturm
// counts place between λ_p and λ_{p+1} (ChainMass::separating_value), or,
// where those two lie within 1e-5 of each other, between λ_q and λ_{q+1}
// for the first q ≤ p + 16 where they do not (the extra ones dropped;
// every one where that reaches n). False where B is not formed, no such q
// exists or dbdsvdx fails.
bool chain_lowest_singular(const ChainMass& U, const VectorX& k, Eigen::Index p, VectorX& sigma, MatrixX& V) {
  const Eigen::Index n = U.size();
  VectorX diagonal, upper;
  if (p <= 0 || p > n || !U.bidiagonal(k, diagonal, upper)) return false;
  std::optional<double> separation;
  Eigen::Index solved = p;
  for (; solved < n && solved <= p + 16; ++solved)
    if ((separation = U.separating_value(k, solved))) break;
  if (solved < n && !separation) return false;
  if (!bidiagonal_lowest(diagonal, upper, static_cast<int>(solved), separation ? std::sqrt(*separation) : 0.0,
                         sigma, V))
    return false;
  sigma.conservativeResize(p);
  V.conservativeResize(Eigen::NoChange, p);
  return true;
}

// The pencil's vectors of a hanging chain from B's right vectors v: φ =
// σK^{-½}v (Kφ = λMφ with u = Uᵀφ, Bᵀu = σv), formed entry by entry
// without cancellation (U⁻ᵀy cancels); φᵀMφ = ‖u‖² = 1 for exact vectors
// of unit norm. A computed v errs along a lower mode j by about
// ε‖B‖/gap, which φ magnifies by σ_i/σ_j: on chains with light links of
// 1e-20 … 1e-8 of a heavy tip's mass φᵀMφ − 1 and the shapes' residual
// reach 1e-7.
MatrixX chain_shapes(const VectorX& k, const VectorX& sigma, const MatrixX& V) {
  MatrixX Phi(V.rows(), V.cols());
  const VectorX root_k = k.cwiseSqrt();
  for (Eigen::Index i = 0; i < V.cols(); ++i)
    Phi.col(i) = (sigma(i) / V.col(i).norm()) * V.col(i).cwiseQuotient(root_k);
  return Phi;
}

// K φ = λ M φ reduced to a symmetric tridiagonal matrix T = QᵀCQ,
// C = L⁻¹KL⁻ᵀ, with the factor L of M that the caller already has (LAPACK
// dsygst, or scalings where L is diagonal, then dsytrd: the first half of
// dsygvd's work). Every eigenvalue comes
// from T alone (O(n²)); a vector of T is one of the pencil after Q and L⁻ᵀ.
class TridiagonalPencil {
 public:
  TridiagonalPencil(const MatrixX& K, const Cholesky& mass) : L_(mass.matrixLLT()), A_(K) {
    reduce_to_standard(A_, L_);
    int info = 0;
    d_.resize(n_);
    e_.resize(n_);  // e_(n − 1) is dstemr's workspace
    tau_.resize(std::max(n_ - 1, 1));
    double size = 0;
    int lwork = -1;
    dsytrd_("L", &n_, A_.data(), &n_, d_.data(), e_.data(), tau_.data(), &size, &lwork, &info, 1);
    lwork = std::max(1, static_cast<int>(size));
    std::vector<double> work(static_cast<std::size_t>(lwork));
    dsytrd_("L", &n_, A_.data(), &n_, d_.data(), e_.data(), tau_.data(), work.data(), &lwork, &info, 1);
    if (info != 0) throw NumericalError("LAPACK dsytrd failed (info " + std::to_string(info) + ")");
    e_(n_ - 1) = 0;
  }
  // Every eigenvalue, ascending.
  VectorX eigenvalues() const { return tridiagonal_eigenvalues(d_, e_); }
  // The pencil's vectors of its p lowest eigenvalues (n×p, ΦᵀMΦ = I to
  // rounding), or an empty matrix when dstemr fails (the caller then takes
  // every vector by lapack_pairs).
  MatrixX lowest_vectors(int p) const {
    if (p <= 0) return MatrixX(n_, 0);
    MatrixX Z = tridiagonal_lowest(d_, e_, p);
    if (Z.cols() != p) return {};
    int info = 0, lwork = -1;
    double size = 0;
    std::vector<double> work;
    dormtr_("L", "L", "N", &n_, &p, A_.data(), &n_, tau_.data(), Z.data(), &n_, &size, &lwork, &info, 1, 1, 1);
    lwork = std::max(1, static_cast<int>(size));
    work.assign(static_cast<std::size_t>(lwork), 0.0);
    dormtr_("L", "L", "N", &n_, &p, A_.data(), &n_, tau_.data(), Z.data(), &n_, work.data(), &lwork, &info, 1, 1, 1);
    if (info != 0) return {};
    solve_upper(L_, Z);  // Φ = L⁻ᵀ Y
    return Z;
  }

 private:
  const MatrixX& L_;  // its lower triangle is L
  int n_ = static_cast<int>(L_.rows());
  MatrixX A_;         // C, then T's Householder vectors (dsytrd)
  VectorX d_, e_, tau_;
};

// Solves with K − σM for refine_unresolved: a dense LU with partial
// pivoting, or, where K and M are both mostly zero (particles and springs:
// Operand's sparse forms given), a sparse LU (Eigen's SparseLU, COLAMD
// order), whose cost on such a pencil is far below the dense one's 2n³/3.
// `solve` returns a non-finite block where the matrix is singular to
// working precision (σ an eigenvalue), as the dense LU's solve does.
class ShiftedSolver {
 public:
  ShiftedSolver(const MatrixX& K, const MatrixX& M, double sigma, const Eigen::SparseMatrix<double>* K_sparse,
                const Eigen::SparseMatrix<double>* M_sparse) {
    if (K_sparse != nullptr && M_sparse != nullptr) {
      sparse_.emplace();
      Eigen::SparseMatrix<double> A = *K_sparse - sigma * *M_sparse;
      A.makeCompressed();
      sparse_->compute(A);
      singular_ = sparse_->info() != Eigen::Success;
    } else {
      dense_.emplace(K - sigma * M);
    }
  }
  MatrixX solve(const MatrixX& B) const {
    if (singular_) return MatrixX::Constant(B.rows(), B.cols(), std::numeric_limits<double>::quiet_NaN());
    if (sparse_) {
      MatrixX X = sparse_->solve(B);
      if (sparse_->info() != Eigen::Success) X.setConstant(std::numeric_limits<double>::quiet_NaN());
      return X;
    }
    return dense_->solve(B);
  }
  // Whether its factorizations are sparse (refine_unresolved's budget then
  // covers every candidate).
  static bool sparse(const Eigen::SparseMatrix<double>* K_sparse, const Eigen::SparseMatrix<double>* M_sparse) {
    return K_sparse != nullptr && M_sparse != nullptr;
  }

 private:
  // SparseLU is neither copyable nor movable: made in place.
  std::optional<Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>>> sparse_;
  std::optional<Eigen::PartialPivLU<MatrixX>> dense_;
  bool singular_ = false;
};

// Refinement of the modes the eigen-solver left unresolved. The solver's
// error is normwise, about ε‖C‖ for C = L⁻¹KL⁻ᵀ, so in a stiff scene (ω²
// over 30 decades: a graded chain of balls and slides) the low modes' λ are
// off by more than themselves although K and M, entry by entry, determine
// them to many digits: the vectors are right normwise, but their tiny
// components along the stiff directions are not, and those dominate φᵀKφ.
// Inverse iteration, x ← (K − σM)⁻¹Mx with σ its Rayleigh quotient, damps
// exactly those components (the solve is graded like K), and the quotient
// of the new vector is then accurate to what the data allow. Applied to the
// modes whose estimate is more than 10 × what their data and quotient
// justify (unresolved, from the analysis), the worst first, within a budget
// of about 4n³ flops (at least 3e8: every mode of a small scene); three steps
// each, one LU factorization (partial pivoting) per step (details below).
// The budget counts factorizations: one for each run's block step (below),
// given to whole runs first, the worst first, so no run is split; then three
// per mode, the worst mode first. Where K and M are both mostly zero the
// factorizations are sparse (ShiftedSolver) and the budget covers every run
// and every candidate.
// Where the solver's error exceeds the low eigenvalues themselves (a stiff
// link 1e23 × softer than its pendulum), its vectors of those modes are an
// arbitrary basis of their subspace (a cart-pendulum's: the coordinate
// vectors, quotients 50 and 9.8 where the eigenvalues are 8.86 and 110.8),
// and three steps of inverse iteration from each stop between two
// eigenvalues. So each run of consecutive unresolved modes is first replaced
// by the Ritz vectors of one block step, Y = (K − σM)⁻¹MX over the run's
// vectors X, with σ = −2 max|λ| over the run's quotients: below each of the
// run's eigenvalues by at most 3 max|λ|, so the components along the stiff
// modes shrink by that over their λ while the run's own keep their shares,
// and the projected pencil (YᵀKY, YᵀMY) separates the run's modes; three
// such steps on the one factorization (subspace iteration), since a run
// whose quotients span many decades needs the stiff components shrunk by
// more than one step gives. A run reaches across resolved modes to the next
// one where the gap in λ is within the largest estimate of their unresolved
// modes (`lambda`, `estimate`: the analysis's, per analyzed mode; below).
// The analysis is then repeated on the vectors; its
// bounds hold for whatever vectors it is given. Returns whether any vector
// changed.
bool refine_unresolved(const MatrixX& M, const MatrixX& K, const Eigen::SparseMatrix<double>* M_sparse,
                       const Eigen::SparseMatrix<double>* K_sparse, const VectorX& unresolved, const VectorX& lambda,
                       const VectorX& estimate, MatrixX& Phi) {
  const Eigen::Index n = M.rows(), m = Phi.cols();
  std::vector<Eigen::Index> candidates;
  for (Eigen::Index i = 0; i < m && i < unresolved.size(); ++i)
    if (unresolved(i) > 10) candidates.push_back(i);
  if (candidates.empty()) return false;
  constexpr int steps = 3;
  // The budget in LU factorizations (2n³/3 flops each): one per run's block
  // step, given to the runs first (each whole, however long: it is one
  // factorization), the worst run first; then `steps` per mode, the worst
  // mode first.
  const double nd = static_cast<double>(n);
  auto budget = std::max(1L, static_cast<long>(std::max(3e8, 4 * nd * nd * nd) / ((2.0 / 3.0) * nd * nd * nd)));
  if (ShiftedSolver::sparse(K_sparse, M_sparse))  // sparse factorizations: every run and every candidate
    budget = std::max(budget, static_cast<long>(m) * (steps + 1));
  struct Run {
    Eigen::Index start, size;
    double worst;
  };
  std::vector<Run> runs;
  for (std::size_t first = 0; first < candidates.size();) {  // candidates ascend here
    std::size_t last = first;
    while (last + 1 < candidates.size() && candidates[last + 1] == candidates[last] + 1) ++last;
    Run run{candidates[first], static_cast<Eigen::Index>(last - first + 1), 0.0};
    for (std::size_t c = first; c <= last; ++c) run.worst = std::max(run.worst, unresolved(candidates[c]));
    // Two runs whose gap in λ is within the largest estimate of their
    // unresolved modes are one: the modes between them lie within that
    // uncertainty, and their vectors are as mixed as the runs' (a resolved
    // mode among unresolved ones is no separation); a block step over one
    // run alone cannot recover what the other holds. Separate block steps
    // over 16 runs of a graded particle chain had left two of its vectors on
    // one eigenvalue and none on another.
    if (!runs.empty()) {
      Run& previous = runs.back();
      const Eigen::Index end = previous.start + previous.size - 1, stop = run.start + run.size - 1;
      double reach = 0;
      for (Eigen::Index k = previous.start; k <= stop; ++k)
        if (unresolved(k) > 10) reach = std::max(reach, estimate(k));
      if (lambda(run.start) - lambda(end) <= reach) {
        previous.size = stop - previous.start + 1;
        previous.worst = std::max(previous.worst, run.worst);
        first = last + 1;
        continue;
      }
    }
    runs.push_back(run);
    first = last + 1;
  }
  std::stable_sort(runs.begin(), runs.end(), [](const Run& a, const Run& b) { return a.worst > b.worst; });
  runs.resize(std::min(runs.size(), static_cast<std::size_t>(budget)));
  budget -= static_cast<long>(runs.size());
  std::stable_sort(candidates.begin(), candidates.end(),
                   [&](Eigen::Index a, Eigen::Index b) { return unresolved(a) > unresolved(b); });
  candidates.resize(std::min(candidates.size(), static_cast<std::size_t>(budget / steps)));
  MatrixX MPhi = M * Phi;
  bool changed = false;
  std::vector<Eigen::Index> joined;  // resolved modes inside a run that was replaced
  {  // The block step over each run of consecutive candidates (see above).
    for (const Run& run : runs) {
      const Eigen::Index start = run.start, size = run.size;
      const auto X = Phi.middleCols(start, size);
      double largest = 0;
      for (Eigen::Index k = 0; k < size; ++k)
        largest = std::max(largest, std::abs(X.col(k).dot(K * X.col(k)) / X.col(k).dot(MPhi.col(start + k))));
      const double sigma = -2 * largest;
      if (!(sigma < 0) || !std::isfinite(sigma)) continue;  // every quotient 0: the steps below alone
      // Three applications of the one factorization, each followed by the
      // Rayleigh–Ritz step (subspace iteration): one shrinks the stiff
      // components by |σ|/λ_stiff only, and a run whose quotients span many
      // decades needs that squared below its lowest λ/λ_stiff (a graded
      // 20-link chain's run over 12 decades: after one application two of
      // its modes came out 1.0998 ± 1.3e3, "zero", and 1.1691 ± 0.40 for
      // 0.5432 and 1.4283).
      const ShiftedSolver lu(K, M, sigma, K_sparse, M_sparse);
      MatrixX X_run, MX = MPhi.middleCols(start, size);  // X_run: set by each Ritz step
      bool done = false;
      for (int application = 0; application < 3; ++application) {
        MatrixX Y = lu.solve(MX);
        for (Eigen::Index k = 0; k < size; ++k) {
          const double norm = Y.col(k).norm();
          if (norm > 0 && std::isfinite(norm)) Y.col(k) /= norm;
        }
        if (!Y.allFinite()) break;
        MatrixX A = Y.transpose() * (K * Y), B = Y.transpose() * (M * Y);
        A = 0.5 * (A + A.transpose()).eval();
        B = 0.5 * (B + B.transpose()).eval();
        const Eigen::GeneralizedSelfAdjointEigenSolver<MatrixX> ritz(A, B);
        if (ritz.info() != Eigen::Success || !ritz.eigenvectors().allFinite()) break;
        X_run = Y * ritz.eigenvectors();  // M-orthonormal to rounding, ascending
        MX = M * X_run;
        done = true;
      }
      if (!done) continue;
      Phi.middleCols(start, size) = X_run;
      MPhi.middleCols(start, size) = MX;
      changed = true;
      // A run joined across resolved modes replaced their vectors too: they
      // are refined below as well, after the candidates, within the budget (a
      // graded chain of 300 particles had two of them come out of its block
      // step "zero", 2.8e-12 ± 1.5e-11, and the chain "marginal").
      for (Eigen::Index k = start; k < start + size; ++k)
        if (!(unresolved(k) > 10)) joined.push_back(k);
    }
  }
  std::stable_sort(joined.begin(), joined.end(),
                   [&](Eigen::Index a, Eigen::Index b) { return unresolved(a) > unresolved(b); });
  const long room = std::max(0L, budget / steps - static_cast<long>(candidates.size()));
  joined.resize(std::min(joined.size(), static_cast<std::size_t>(room)));
  candidates.insert(candidates.end(), joined.begin(), joined.end());
  VectorX norms(m);  // ‖φ_k‖_M
  for (Eigen::Index k = 0; k < m; ++k) norms(k) = std::sqrt(std::max(Phi.col(k).dot(MPhi.col(k)), 0.0));
  // Before each solve, the iterate is made M-orthogonal to the vectors
  // refined before it (the solve then finds the eigenvector nearest σ among
  // those not yet taken, as LAPACK's dstein does within a cluster; only
  // refined vectors are subtracted, whose components along the stiff
  // directions are as small as the iterate's). A refined vector that still
  // turns towards another mode's (M-cosine over 0.5: from a badly wrong σ,
  // a neighbour's eigenvalue) is discarded where that mode is resolved, so
  // no eigenvalue is claimed twice, and shares a Rayleigh–Ritz step with it
  // where it was refined (below).
  std::vector<Eigen::Index> refined;
  std::vector<char> waiting(static_cast<std::size_t>(m), 0);
  for (const Eigen::Index i : candidates) waiting[static_cast<std::size_t>(i)] = 1;
  for (const Eigen::Index i : candidates) {
    waiting[static_cast<std::size_t>(i)] = 0;
    VectorX x = Phi.col(i);
    double sigma = x.dot(K * x) / x.dot(MPhi.col(i));
    bool ok = std::isfinite(sigma);
    for (int step = 0; step < steps && ok; ++step) {
      for (int pass = 0; pass < 2; ++pass)  // twice is enough (Kahan, in Parlett §6.9)
        for (const Eigen::Index k : refined) x -= MPhi.col(k).dot(x) * Phi.col(k);
      const ShiftedSolver lu(K, M, sigma, K_sparse, M_sparse);
      const VectorX y = lu.solve(VectorX(M * x));
      const double size = y.norm();
      if (!y.allFinite() || !(size > 0) || !std::isfinite(size)) break;  // σ an eigenvalue to working precision
      x = y / size;
      sigma = x.dot(K * x) / x.dot(M * x);
      ok = std::isfinite(sigma);
    }
    const VectorX Mx = M * x;
    const double norm = std::sqrt(x.dot(Mx));
    if (!ok || !(norm > 0)) continue;
    // The vector it turns towards most (M-cosine over 0.5), among the
    // resolved and the refined ones (not those still waiting).
    Eigen::Index toward = -1;
    double closest = 0.5;
    for (Eigen::Index k = 0; k < m; ++k) {
      if (k == i || waiting[static_cast<std::size_t>(k)] || !(norms(k) > 0)) continue;
      const double cosine = std::abs(Phi.col(k).dot(Mx)) / (norm * norms(k));
      if (cosine > closest) {
        closest = cosine;
        toward = k;
      }
    }
    if (toward >= 0) {
      // Towards a refined vector: the two are mixtures of two close
      // eigenvectors (of a graded chain, 1–13 % apart, where the first one
      // refined had converged partly to the other's): both are replaced by
      // the Ritz vectors of their span, in the order of their modes.
      // Towards a resolved one, or nearly parallel to the refined one (an
      // M-cosine over 0.9999: the second Ritz vector, (x − cφ)/sin θ, would
      // magnify the stiff rounding the steps removed by over 70; with 0.99
      // a chain's double eigenvalue, both vectors in its plane at cosines
      // 0.99–0.9999, kept a "zero" mode): discarded, so no eigenvalue is
      // claimed twice. (The pair is not made M-orthogonal to
      // the other refined vectors again: doing so took from x the direction
      // its pair lacked in one chain, which came out "zero"; the analysis
      // that follows bounds whatever vectors it is given.)
      if (closest > 0.9999 || std::find(refined.begin(), refined.end(), toward) == refined.end()) continue;
      MatrixX X(n, 2), MX(n, 2);
      X << Phi.col(toward), x / norm;
      MX << MPhi.col(toward), Mx / norm;
      MatrixX A = X.transpose() * (K * X), B = X.transpose() * MX;
      A = 0.5 * (A + A.transpose()).eval();
      B = 0.5 * (B + B.transpose()).eval();
      const Eigen::GeneralizedSelfAdjointEigenSolver<MatrixX> ritz(A, B);
      if (ritz.info() != Eigen::Success || !ritz.eigenvectors().allFinite()) continue;
      const MatrixX Y = X * ritz.eigenvectors(), MY = MX * ritz.eigenvectors();  // ascending
      const Eigen::Index low = std::min(toward, i), high = std::max(toward, i);
      Phi.col(low) = Y.col(0);
      MPhi.col(low) = MY.col(0);
      Phi.col(high) = Y.col(1);
      MPhi.col(high) = MY.col(1);
      norms(i) = norms(toward) = 1;
      refined.push_back(i);
      changed = true;
      continue;
    }
    Phi.col(i) = x / norm;
    MPhi.col(i) = Mx / norm;
    norms(i) = 1;
    refined.push_back(i);
    changed = true;
  }
  return changed;
}

}  // namespace

bool lapack_wins(Eigen::Index n) { return n >= lapack_threshold; }

ModalResult solve_symmetric(const MatrixX& M, const MatrixX& K, const MassFactor& mass, const MatrixX& K_error,
                            const MatrixX& K_systematic_error, DenseSolver solver, Eigen::Index wanted,
                            const SparseMatrix& K_rounding_form, const PointMassChain* chain,
                            const LinkChain* links, const ScaledSprings* springs) {
  const Eigen::Index n = M.rows();
  const bool given = K_error.rows() == n && K_error.cols() == n;  // K's entries' error bounds given (else 4ε|K|)
  const bool lapack = solver == DenseSolver::lapack || (solver == DenseSolver::automatic && lapack_wins(n));
  VectorX lambda_all;
  MatrixX Phi;
  // A point-mass chain (PointMassChain): the analysis's products with M and
  // M⁻¹ by its structure; where K is also diagonal, the pairs from the
  // tridiagonal C = U⁻¹KU⁻ᵀ (dsterf, dstemr) and Φ = U⁻ᵀY, or from the
  // bidiagonal B = U⁻¹K^½ where the chain hangs (below), all O(n²), in
  // place of dsygst and divide and conquer (n³), where LAPACK solves (from
  // lapack_threshold coordinates, or asked for); not with --dense-solver
  // eigen, which asks for Eigen's own solver throughout.
  std::optional<ChainMass> chain_mass;
  if (chain != nullptr && solver != DenseSolver::eigen && chain->lever.size() == n && chain->mass.size() == n &&
      chain->lever.allFinite() && (chain->lever.array() != 0).all() && chain->mass.allFinite() &&
      (chain->mass.array() > 0).all())
    chain_mass.emplace(*chain);
  VectorX chain_d, chain_e;  // C's diagonal and subdiagonal, where the pairs come from it
  // A chain of rigid links (below) is tried only where no point-mass chain is.
  const bool link_candidate = !chain_mass && links != nullptr && lapack && links->remainder.size() == n;
  // K diagonal, scanned once: a chain's C tridiagonal (and certify below); a
  // chain of rigid links' tridiagonal pencil (below).
  const bool K_is_diagonal = (chain_mass || link_candidate) && is_diagonal(K);
  const bool diagonal_K = chain_mass.has_value() && K_is_diagonal;
  // LAPACK: not loaded for a small scene, unless M's dense factor fails
  // (a light chain with a heavy tip: M scaled to a unit diagonal is then near
  // a matrix of ones, and singular to the normwise test, while its structure
  // makes it definite).
  bool chain_solve = diagonal_K && (lapack || !mass.definite());
  if (chain_solve) chain_mass->tridiagonal(K.diagonal(), chain_d, chain_e);
  // A hanging chain (every K_jj > 0) also has the bidiagonal B = U⁻¹K^½
  // (C = BBᵀ; ChainMass::bidiagonal), whose entries define its singular
  // values to high relative accuracy where C's entries do not define C's
  // small eigenvalues so.
  const bool hanging = chain_solve && (K.diagonal().array() > 0).all();
  bool from_bidiagonal = false;  // whether B's vectors answered (the solver's name, below)
  // The pencil's vectors of the p lowest modes by the chain's structure (and
  // with `values` their eigenvalues), empty where every way fails:
  // - p < n (the modes analyzed with `wanted`) and p²n ≤ 2e8: from B's
  //   lowest singular values and right vectors (chain_lowest_singular,
  //   chain_shapes) where the chain hangs, else, or where that fails, from
  //   C by MRRR (dstemr, Φ = U⁻ᵀY);
  // - otherwise from C by MRRR first, since B's vectors cost O(p²n)
  //   (dbdsvdx's inverse iteration reorthogonalizes the low singular
  //   values as one cluster: all of a 1000-link chain's 1.8 s, of 2000
  //   links 21 s, against MRRR's 0.27 and 1.0 s); B where dstemr fails (it
  //   did on a 1051-link chain, lengths sorted over 1e-4 … 1e4, and
  //   Cholesky and dsygst then lost the lowest eigenvalues to 2e-4). The
  //   analysis below replaces either's λ by the vectors' Rayleigh quotients.
  auto chain_vectors = [&](Eigen::Index p, VectorX* values) -> MatrixX {
    auto from_b = [&]() -> MatrixX {
      VectorX sigma;
      MatrixX V;
      if (!hanging || !chain_lowest_singular(*chain_mass, K.diagonal(), p, sigma, V)) return {};
      if (values != nullptr) *values = sigma.cwiseAbs2();
      return chain_shapes(K.diagonal(), sigma, V);
    };
    auto from_c = [&]() -> MatrixX {
      MatrixX Y = tridiagonal_lowest(chain_d, chain_e, static_cast<int>(p), values);
      if (Y.cols() == p) chain_mass->solve_transposed(Y);
      return Y;
    };
    const bool b_first = p < n && static_cast<double>(p) * static_cast<double>(p) * static_cast<double>(n) <= 2e8;
    MatrixX Phi_p = b_first ? from_b() : from_c();
    from_bidiagonal = b_first && Phi_p.cols() == p;
    if (Phi_p.cols() != p) {
      Phi_p = b_first ? from_c() : from_b();
      from_bidiagonal = !b_first && Phi_p.cols() == p;
    }
    return Phi_p;
  };
  // A chain of rigid links (LinkChain), where LAPACK solves and K is
  // diagonal: the tridiagonal pencil (C, B) = (U⁻¹KU⁻ᵀ, I + U⁻¹RU⁻ᵀ) in
  // standard form T = XᵀCX (LinkChainMass::reduce without X: O(n²)), every
  // eigenvalue from T (dsterf), the wanted vectors of (C, B) by inverse
  // iteration on the tridiagonal C − λB (LinkChainMass::pencil_vectors:
  // O(n) per step) and Φ = U⁻ᵀZ, in place of M's Cholesky factor, dsygst
  // and the dense tridiagonal reduction (n³ each); the analysis's products
  // and solves with M by the structure. Where the inverse iteration declines
  // (a cluster of over 64 eigenvalues, a vector that does not converge),
  // T's vectors by MRRR (dstemr) and Φ = U⁻ᵀXY (X's plane rotations: Θ(n³)
  // of vector work, and one product, 2n²p); where dsbgst or dstemr fails,
  // the general path.
  std::optional<LinkChainMass> link_mass;
  VectorX link_d, link_e;  // T's diagonal and subdiagonal
  bool link_rotations = false;  // whether the vectors came from X (MRRR on T)
  if (link_candidate) {
    if (K_is_diagonal) link_mass = LinkChainMass::make(*links);
    // M̃ = FFᵀ is definite by B's factor; M, within the mismatch and the
    // comparison's rounding of it, where definite_within says so (else the
    // general path, whose factor and singularity test decide).
    if (link_mass && !link_mass->definite_within(links->generators.mismatch + 6 * eps)) link_mass.reset();
    if (link_mass && !link_mass->reduce(K.diagonal(), link_d, link_e, nullptr)) link_mass.reset();
  }
  // The lowest p pairs' vectors (and, with `values`, every eigenvalue into
  // it; else lambda_all holds them already).
  auto link_vectors = [&](Eigen::Index p, VectorX* values) -> MatrixX {
    if (values != nullptr) *values = tridiagonal_eigenvalues(link_d, link_e);
    const VectorX& all = values != nullptr ? *values : lambda_all;
    MatrixX Phi_p;
    if (!link_mass->pencil_vectors(K.diagonal(), all.head(p), Phi_p)) {
      MatrixX X;
      if (!link_mass->reduce(K.diagonal(), link_d, link_e, &X)) return {};
      const MatrixX Y = tridiagonal_lowest(link_d, link_e, static_cast<int>(p));
      if (Y.cols() != p) return {};
      Phi_p = Operand(X).product(Y);
      link_rotations = true;
    }
    link_mass->to_coordinates(Phi_p);
    return Phi_p;
  };
  // With `wanted`, LAPACK's path takes every eigenvalue but only the vectors
  // analyzed below (TridiagonalPencil: no divide and conquer over all n
  // vectors, no back-transformation of them).
  std::optional<TridiagonalPencil> reduced;
  if (chain_solve) {
    if (wanted >= 0 && wanted < n) {
      lambda_all = tridiagonal_eigenvalues(chain_d, chain_e);
    } else {
      Phi = chain_vectors(n, &lambda_all);
      if (Phi.cols() != n) {  // every way failed: the dense solver
        chain_solve = false;
        lapack_pairs(K, mass(), lambda_all, Phi);
      }
    }
  } else if (link_mass) {
    if (wanted >= 0 && wanted < n) {
      lambda_all = tridiagonal_eigenvalues(link_d, link_e);
    } else {
      Phi = link_vectors(n, &lambda_all);
      if (Phi.cols() != n) {  // dsbgst or dstemr failed: the general path
        link_mass.reset();
        lapack_pairs(K, mass(), lambda_all, Phi);
      }
    }
  } else if (lapack && wanted >= 0 && wanted < n) {
    reduced.emplace(K, mass());
    lambda_all = reduced->eigenvalues();
  } else if (lapack) {
    lapack_pairs(K, mass(), lambda_all, Phi);
  } else {
    eigen_pairs(K, mass(), lambda_all, Phi);
  }

  // The modes analyzed below (residuals, rounding, data terms: O(n²) each, so
  // O(n³) for all): every mode, or, when only the lowest `wanted` are asked
  // for, those and every lower one whose kind is in doubt under a cheap
  // normwise estimate of its error, cheap_j = nε(‖K‖_F + |λ_j|‖M‖_F)/λ_min(M)
  // (the size of a backward-stable solver's error on the pencil, with λ_min
  // from inverse iteration): doubtful when λ_j ≤ 100·cheap_j, a margin for
  // λ_min's estimate. The others are oscillatory beyond doubt; they count in
  // the stability class with the cheap estimate, and are not returned
  // (solve_modes keeps the wanted ones).
  // Doubtful modes lie at the bottom of the spectrum (cheap_j grows with
  // |λ_j|), so the analyzed ones are a prefix; one more than needed, so that
  // the gaps of the last one (Kato–Temple, below) see an analyzed neighbour.
  VectorX cheap;
  Eigen::Index prefix = n;
  if (wanted >= 0 && wanted < n) {
    // (a chain's by its structure: U⁻ᵀU⁻¹ in O(n), no dense factor)
    const double lambda_min =
        chain_mass ? smallest_eigenvalue_bound(
                         [&](VectorX& x) {
                           MatrixX y = x;
                           chain_mass->solve(y);
                           chain_mass->solve_transposed(y);
                           x = y.col(0);
                         },
                         n)
        : link_mass ? smallest_eigenvalue_bound(
                          [&](VectorX& x) {
                            MatrixX y = x;
                            link_mass->solve(y);
                            link_mass->solve_transposed(y);
                            x = y.col(0);
                          },
                          n)
                    : smallest_eigenvalue_bound(mass(), n);
    const double normK = K.norm(), normM = M.norm();
    // A chain of rigid links' eigenvalues come from dsbgst's standard form,
    // whose error is about ε‖C‖‖B⁻¹‖: nε times B's condition, and the
    // mismatch of M̃ = FFᵀ against M with its comparison's 6ε.
    const double relative = link_mass ? static_cast<double>(n) * eps * link_mass->condition() +
                                            links->generators.mismatch + 6 * eps
                                      : static_cast<double>(n) * eps;
    // A chain in absolute angles (M definite by its structure's test, K
    // diagonal) whose every K_jj exceeds its entry's error bound: every
    // eigenvalue is positive for any data within those errors, so no mode's
    // kind is in doubt, whatever the normwise estimate says (on a chain
    // graded over decades it exceeds every λ_j: all n vectors and an n³
    // analysis for --modes 3).
    bool kinds_certain = (chain_mass || link_mass) && K_is_diagonal;
    for (Eigen::Index j = 0; j < n && kinds_certain; ++j)
      kinds_certain = K(j, j) > (given ? K_error(j, j) : 4 * eps * std::abs(K(j, j)));
    cheap.resize(n);
    Eigen::Index needed = wanted;
    for (Eigen::Index j = 0; j < n; ++j) {
      cheap(j) = relative * (normK + std::abs(lambda_all(j)) * normM) / lambda_min;
      if (!kinds_certain && !(lambda_all(j) > 100 * cheap(j))) needed = std::max(needed, j + 1);
    }
    prefix = std::min(n, needed + 1);
  }
  std::vector<Eigen::Index> analyzed(static_cast<std::size_t>(prefix));
  std::iota(analyzed.begin(), analyzed.end(), Eigen::Index{0});
  if (prefix == n) cheap.resize(0);
  if (reduced) {
    Phi = reduced->lowest_vectors(static_cast<int>(prefix));
    if (Phi.cols() != prefix) {  // dstemr failed: every pair by divide and conquer
      lapack_pairs(K, mass(), lambda_all, Phi);
      reduced.reset();
    }
  } else if (chain_solve && Phi.cols() == 0 && prefix > 0) {
    Phi = chain_vectors(prefix, nullptr);
    if (Phi.cols() != prefix) {  // both failed: every pair by the dense solver
      chain_solve = false;
      lapack_pairs(K, mass(), lambda_all, Phi);
    }
  } else if (link_mass && Phi.cols() == 0 && prefix > 0) {
    Phi = link_vectors(prefix, nullptr);
    if (Phi.cols() != prefix) {  // dsbgst or dstemr failed: every pair by the dense solver
      link_mass.reset();
      lapack_pairs(K, mass(), lambda_all, Phi);
    }
  }
  if (Phi.cols() > prefix) Phi.conservativeResize(Eigen::NoChange, prefix);
  // The analysis of the computed pairs (Φ, λ_all): residuals, bounds,
  // estimates, kinds. unresolved(i): the estimate of analyzed mode i over
  // what its data and quotient alone justify (refinement, below).
  VectorX unresolved;
  // chain_spread(i): the half width of the Sturm-count bracket around
  // analyzed mode i's λ (ChainMass::certify; ∞ where none was verified),
  // for a hanging chain (below).
  VectorX chain_spread;
  // ‖|L⁻¹|‖₂ ≤ (‖L⁻¹‖₁‖L⁻¹‖∞)^½ (the 1- and ∞-norms of |A| are A's), from L⁻¹
  // formed once (lower_inverse: n³/3 flops; max 1/l_ii where L is diagonal):
  // the residual bound's worst case of rounding.
  const bool diagonal_factor = !chain_mass && !link_mass && diagonal_lower(mass().matrixLLT());
  const double inverse_norm = [&] {
    if (chain_mass) return chain_mass->inverse_norm();  // of U⁻¹ (M = UUᵀ)
    if (link_mass) return link_mass->inverse_norm();    // of F⁻¹ (M = FFᵀ)
    if (diagonal_factor) return mass().matrixLLT().diagonal().cwiseAbs().cwiseInverse().maxCoeff();
    const MatrixX inverse = lower_inverse(mass().matrixLLT()).cwiseAbs();
    return std::sqrt(inverse.colwise().sum().maxCoeff() * inverse.rowwise().sum().maxCoeff());
  }();
  // The analysis's matrices, each in the form of its products (Operand),
  // decided once for both analyses. E: the rounding part of the entries'
  // error (K_error, less the measured error of differences where that is
  // given; else 4ε|K|); D: the measured error of differences.
  const bool differences = K_systematic_error.rows() == n && K_systematic_error.cols() == n;
  const Operand K_op(K), M_op = chain_mass  ? Operand(M, *chain_mass)
                                : link_mass ? Operand(M, *link_mass)
                                            : Operand(M);
  // The residuals in the standard form: L⁻¹R, or U⁻¹R for a chain (either
  // way ‖·‖ is the M⁻¹-norm of R).
  auto to_standard = [&](MatrixX& B) {
    if (chain_mass) chain_mass->solve(B);
    else if (link_mass) link_mass->solve(B);
    else solve_lower(mass().matrixLLT(), B);  // its lower triangle is L
  };
  // The rounding of a residual's entries: (w + 2)ε(|K||φ| + |λ||M||φ|) with
  // the products of K and M as stored (Higham, §3.5; w below); a chain's product with M is two running
  // sums of up to n terms each and three scalings, (2n + 3)ε|M||φ|.
  // A chain of rigid links' products stand for M̃ = UUᵀ + R (LinkChainMass:
  // the chain's running sums, then a scaled addition, within (2n + 3)ε
  // (|UUᵀ| + |R|)|φ|, and the residual's scaling by λ and subtraction: 2n +
  // 5; the quotient's dot product: 3n + 5), which differs from M entrywise by at most its
  // mismatch (LinkChain) and the comparison's rounding, 6ε, times that bound
  // of |M̃|: link_gap, added to the rounding factors nn and nq (which then
  // cover it on |λ||M̃||φ|, and on |K||φ| too: conservative).
  const double link_gap = link_mass ? links->generators.mismatch + 6 * eps : 0.0;
  // Products with K and M as stored (dense or sparse, by BLAS or Eigen)
  // round only on their nonzero terms: a zero entry's product is an exact
  // zero, and adding it is exact. So a residual's entry is within (w + 2)ε
  // of its terms, w the most nonzeros in a row of K or M (`width`), not n:
  // 15 instead of 192 for a 10 × 10 net. The quotient's dot products φᵀ(Kφ)
  // and φᵀ(Mφ) are summed pairwise (detail::pairwise_dot), within
  // (m + 1)ε of their terms, m = pairwise_depth(n) (before: n terms, and
  // the bound had left the dot product out).
  const double width = [&] {
    if (chain_mass || link_mass) return static_cast<double>(n);
    std::vector<Eigen::Index> k(static_cast<std::size_t>(n), 0), mass(static_cast<std::size_t>(n), 0);
    for (Eigen::Index j = 0; j < n; ++j)  // down the columns (column-major)
      for (Eigen::Index i = 0; i < n; ++i) {
        k[static_cast<std::size_t>(i)] += K(i, j) != 0.0;
        mass[static_cast<std::size_t>(i)] += M(i, j) != 0.0;
      }
    Eigen::Index most = 1;
    for (std::size_t i = 0; i < k.size(); ++i) most = std::max({most, k[i], mass[i]});
    return static_cast<double>(most);
  }();
  const double depth = pairwise_depth(n);
  const double nn = (chain_mass  ? 2 * static_cast<double>(n) + 3
                     : link_mass ? 2 * static_cast<double>(n) + 5
                                 : width + 2) +
                    link_gap / eps;
  // The rounding of the Rayleigh quotient φᵀKφ/φᵀMφ: as nn, and for a chain
  // the dot product φᵀ(Mφ) adds nε to the product's (2n + 1)ε; elsewhere
  // the pairwise dot product's (m + 1)ε.
  const double nq = (chain_mass  ? 3 * static_cast<double>(n) + 3
                     : link_mass ? 3 * static_cast<double>(n) + 5
                                 : width + 3 + depth) +
                    link_gap / eps;
  // The entries' relative error of M as assembled: 4ε. A chain's products
  // stand for M̃ = D_l Ĵᵀ D_m Ĵ D_l, which differs from M entrywise by its
  // mismatch (PointMassChain) as measured, and at worst by that and the
  // comparison's own rounding against the exact l_i l_j μ_j (μ_j summed with
  // compensation, 2ε; the two products, 2ε; the difference, ε: 6ε in all
  // added). Up to the rounding that assembling M's entries leaves (sums of
  // up to n products: 4(n + 4)ε, far above the ≤ 6e-16 measured on
  // generated chains), the mismatch is of that kind: it counts in the
  // lengths' relative error (length_error, typical; length_worst with the
  // 6ε, which decides the kinds; below). Above it (up to the
  // 1e-11 the structure allows: a chain bent by 1e-6 rad, small rotational
  // inertias) it is one smooth pattern, not independent roundings, so its
  // effect, (mismatch + 6ε)·|λ||φ|ᵀ|M||φ|, counts at its worst, with the
  // systematic part.
  const double chain_mismatch = chain_mass ? chain->mismatch : link_mass ? links->generators.mismatch : 0.0,
               comparison = chain_mass || link_mass ? 6 * eps : 0.0;
  const bool rounding_mismatch = chain_mismatch <= 4 * (static_cast<double>(n) + 4) * eps;
  // M's entries' rounding where no chain stands for M (a chain of rigid
  // links': with its mismatch where that is of rounding's size; above, it
  // counts at its worst in the systematic part, `mismatch`, as a chain's).
  const double rM = 4 * eps + (link_mass && rounding_mismatch ? chain_mismatch : 0.0);
  const double mismatch = rounding_mismatch ? 0.0 : chain_mismatch + comparison;
  // What a chain's products stand for has no entrywise rounding of M: its
  // data are the lengths (and the scene's own masses), and a relative error
  // δ_j of l_j moves φᵀM̃φ by 2 Σ_j δ_j φ_j (M̃φ)_j, so λ by at most
  // 2 max|δ| |λ| Σ_j |φ_j (M̃φ)_j| / φᵀMφ to first order: M's share of the
  // data's rounding in that form (not |λ||φ|ᵀ|M||φ|, which the cancelling
  // signs of a chain's high modes make up to 1e20 × larger: a light chain
  // with a heavy tip had its vibrations called "zero"). The lengths'
  // relative error: typically half of ε and of the rounding-level mismatch,
  // which measures how far M's other entries disagree with the lengths
  // (the lengths within 0.83ε measured where the scene's M is written out,
  // point_mass_chain_mass; the mismatch is then 1–2ε); at worst 2ε, the
  // mismatch and the comparison's rounding.
  const double length_error = 0.5 * (eps + (rounding_mismatch ? chain_mismatch : 0.0));
  const double length_worst = 2 * eps + (rounding_mismatch ? chain_mismatch + comparison : 0.0);
  std::optional<Operand> E_op, D_op;  // E: none where it is 4ε|K| (products with |K|, scaled)
  if (given && !differences) E_op.emplace(K_error);
  if (given && differences) E_op.emplace(MatrixX((K_error - K_systematic_error).cwiseMax(0.0)));
  if (differences) D_op.emplace(K_systematic_error);
  // M's diagonal as the rounding terms see it: a chain of rigid links'
  // products round on abs(UUᵀ) + abs(R), whose diagonal M_jj − R_jj +
  // abs(R_jj) exceeds M_jj where R_jj < 0.
  const VectorX M_diagonal =
      link_mass ? VectorX(M.diagonal() - 2 * links->remainder.cwiseMin(0.0)) : VectorX(M.diagonal());
  auto analyze = [&]() -> ModalResult {
    const auto m = static_cast<Eigen::Index>(analyzed.size());
    VectorX lambda = lambda_all(analyzed);
    unresolved = VectorX::Zero(m);

    // The Rayleigh quotients λ = φᵀKφ/φᵀMφ of the computed vectors replace the
    // solver's values: they are accurate to the square of the vectors' error
    // for the matrices as formed, while the solver's λ carries the error of its
    // transformation (L⁻¹KL⁻ᵀ, or LAPACK's, with an ill-conditioned M: 5e-7
    // relative on a 320-link cantilever in relative angles). Re-sorted.
    // The n×n work matrices below are few and freed as soon as they are used:
    // fresh pages cost more to touch than the products cost to compute.
    MatrixX R = K_op.product(Phi);  // KΦ, then the residuals KΦ − MΦΛ
    VectorX phiMphi(m);           // φᵀMφ = ‖Lᵀφ‖² per column
    VectorX sums(m), diagonal_terms(m);  // for the typical rounding of the quotient, below
    VectorX mass_terms(m);               // Σ_i |φ_i (Mφ)_i|
    // The pencil projected on neighbouring vectors, for the close pairs and
    // clusters below (groups of at most `group` consecutive modes), taken
    // while KΦ and MΦ are at hand: band(w, j) = ½(φ_jᵀKφ_{j+w} + φ_{j+w}ᵀKφ_j),
    // and the same with M (O(n·m·group), not a product with K per group: a
    // lattice's many repeated eigenvalues made those a third of its phase).
    constexpr Eigen::Index group = 8;
    MatrixX bandK = MatrixX::Zero(group, m), bandM = MatrixX::Zero(group, m);
    {
      MatrixX MPhi = M_op.product(Phi);
      VectorX rq(m);
      for (Eigen::Index j = 0; j < m; ++j) {
        phiMphi(j) = pairwise_dot(Phi.col(j), MPhi.col(j));
        rq(j) = pairwise_dot(Phi.col(j), R.col(j)) / phiMphi(j);
      }
      std::vector<Eigen::Index> order(static_cast<std::size_t>(m));
      std::iota(order.begin(), order.end(), Eigen::Index{0});
      std::stable_sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) { return rq(a) < rq(b); });
      if (!std::is_sorted(order.begin(), order.end())) {
        Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, Eigen::Index> P(m);
        for (Eigen::Index k = 0; k < m; ++k) P.indices()(k) = order[static_cast<std::size_t>(k)];
        Phi = Phi * P;  // column k ← column order[k] (in place)
        R = R * P;
        MPhi = MPhi * P;
        rq = P.transpose() * rq;
        phiMphi = P.transpose() * phiMphi;
      }
      lambda = rq;
      for (Eigen::Index j = 0; j < m; ++j) {
        mass_terms(j) = Phi.col(j).cwiseProduct(MPhi.col(j)).cwiseAbs().sum();
        sums(j) = Phi.col(j).cwiseProduct(R.col(j)).cwiseAbs().sum() +  // Σ|φ_i (Kφ)_i| + |λ| Σ|φ_i (Mφ)_i|
                  std::abs(lambda(j)) * mass_terms(j);
        diagonal_terms(j) = M_diagonal.dot(Phi.col(j).cwiseAbs2());   // Σ M_ii φ_i²
      }
      for (Eigen::Index j = 0; j < m; ++j)
        for (Eigen::Index w = 0; w < group && j + w < m; ++w) {
          bandK(w, j) = 0.5 * (Phi.col(j).dot(R.col(j + w)) + Phi.col(j + w).dot(R.col(j)));
          bandM(w, j) = 0.5 * (Phi.col(j).dot(MPhi.col(j + w)) + Phi.col(j + w).dot(MPhi.col(j)));
        }
      R -= MPhi * lambda.asDiagonal();
    }
    lambda_all(analyzed) = lambda;

    // Beside the residuals R = KΦ − MΦΛ, the rounding of R itself, |fl(R) − R|
    // ≤ nn ε (|K||Φ| + |M||Φ||Λ|) componentwise (Higham, Accuracy and
    // Stability, §3.5): both carried through L⁻¹ by triangular solves.
    const MatrixX absPhi = Phi.cwiseAbs();
    MatrixX absMPhi, rounding;  // |M||Φ| (also for the data term below); |K||Φ| + |M||Φ||Λ|
    M_op.multiply(absPhi, true, 0, absMPhi);
    rounding = absMPhi * lambda.cwiseAbs().asDiagonal();
    K_op.multiply(absPhi, true, 1, rounding);
    VectorX residual_norm(m), absKM_dot(m), rows(m);  // ‖R_j‖ (for the relative residual below);
    VectorX rounding_norm(m);                            // |φ|ᵀ(|K| + |λ||M|)|φ|; ‖φ∘(|K||φ| + |λ||M||φ|)‖₂; ‖rounding_j‖₂
    // Column norms by stableNorm: a refined zero mode's residual (1e-165)
    // squared to 0 in norm(), a rigorous bound of 0 for a quotient of 2.7e-309.
    for (Eigen::Index j = 0; j < m; ++j) {
      residual_norm(j) = R.col(j).stableNorm();
      rounding_norm(j) = rounding.col(j).stableNorm();
      absKM_dot(j) = absPhi.col(j).dot(rounding.col(j));
      rows(j) = absPhi.col(j).cwiseProduct(rounding.col(j)).stableNorm();
    }
    to_standard(R);
    to_standard(rounding);

    // Per mode, the linear residual bound δ (rigorous for the matrices as
    // formed) and its typical-size counterpart (see the header comment), then
    // the quadratic one for the Rayleigh quotient: where the intervals λ_k ± δ_k
    // of the other eigenvalues leave a gap g_j = min_k (|λ_k − λ_j| − δ_k) > δ_j
    // around λ_j, |λ_j − λ_true| ≤ δ_j²/g_j (Kato–Temple; Parlett, thm 11.7.1),
    // plus the rounding of evaluating the quotient, nq ε|φ|ᵀ(|K| + |λ||M|)|φ|/φᵀMφ.
    // bound and typical are indexed by all modes: the cheap estimate stands for
    // the modes not analyzed.
    VectorX bound = cheap.size() == n ? cheap : VectorX(VectorX::Zero(n)), typical = bound, quotient_rounding(m);
    for (Eigen::Index i = 0; i < m; ++i) {
      const Eigen::Index j = analyzed[static_cast<std::size_t>(i)];
      const double norm = std::sqrt(phiMphi(i));
      const double residual = R.col(i).stableNorm() / norm, rounded = eps * rounding.col(i).stableNorm() / norm;
      // The bound takes the worst case of the rounding e (|e| ≤ nn ε rounding_j):
      // ‖L⁻¹e‖ ≤ ‖|L⁻¹|‖₂ ‖e‖₂, not ‖L⁻¹ rounding_j‖, which the signs of L⁻¹
      // make up to 1.2e3 × smaller (a 1000-link chain in absolute angles).
      const double worst = std::max(rounded, eps * inverse_norm * rounding_norm(i) / norm);
      bound(j) = residual + nn * worst;
      typical(j) = residual + std::sqrt(nn) * rounded;
      quotient_rounding(i) = eps * absKM_dot(i) / phiMphi(i);
    }
    R.resize(0, 0);
    rounding.resize(0, 0);
    // The nearest other eigenvalue's interval: λ is sorted, so the minimum of
    // |λ_k − λ_j| − δ_k is attained among the neighbours until |λ_k − λ_j|
    // alone exceeds the best gap found plus the largest δ (a scan outwards,
    // O(n) in all for well separated spectra, not O(n²)).
    const double largest_delta = n > 0 ? std::max(bound.maxCoeff(), typical.maxCoeff()) : 0.0;
    // The distance from [λ_first, λ_last] to the nearest interval λ_k ± δ_k
    // of a mode outside first…last.
    auto separation = [&](const VectorX& delta, Eigen::Index first, Eigen::Index last) {
      double gap = std::numeric_limits<double>::infinity();
      for (Eigen::Index k = first - 1; k >= 0; --k) {
        const double d = std::abs(lambda_all(first) - lambda_all(k));
        if (d - largest_delta > gap) break;
        gap = std::min(gap, d - delta(k));
      }
      for (Eigen::Index k = last + 1; k < n; ++k) {
        const double d = std::abs(lambda_all(k) - lambda_all(last));
        if (d - largest_delta > gap) break;
        gap = std::min(gap, d - delta(k));
      }
      return gap;
    };
    auto with_gap = [&](const VectorX& delta, double quotient, Eigen::Index i,
                        double clustered = std::numeric_limits<double>::infinity()) {
      const Eigen::Index j = analyzed[static_cast<std::size_t>(i)];
      const double gap = separation(delta, j, j);
      const double linear = delta(j);
      // linear · (linear / gap): linear² alone underflows below 1.5e-154 (a
      // refined zero mode's residual of 1e-165 squared to 0 claimed its
      // quotient, 2.7e-309, exact and the mode an oscillation).
      const double quadratic = gap > linear ? linear * (linear / gap) : linear;
      return std::min({linear, quadratic, clustered}) + quotient + eps * std::abs(lambda_all(j));
    };
    // Close pairs and small clusters (for the estimate). Where the intervals
    // λ_k ± δ_k (typical) of consecutive analyzed modes overlap, no single
    // mode has a gap and each kept its linear δ, however far the group lies
    // from the rest of the spectrum: two modes 7e-5 apart relative, of a
    // graded chain, kept an estimate of 5e-3 relative where their true errors
    // were 1e-19. For a group C of 2–8 modes whose range [λ_first, λ_last] is
    // separated from the other modes' intervals by η > δ_C = (Σ_C δ_k²)^½
    // (≥ the 2-norm of the block residual L⁻¹R_C), the Ritz values μ of the
    // group's projected pencil (Φ_CᵀKΦ_C, Φ_CᵀMΦ_C) lie within δ_C²/η of the
    // group's eigenvalues (the quadratic residual bound for a cluster:
    // Mathias, SIAM J. Matrix Anal. Appl. 19, 1998; here with the other modes'
    // intervals for the rest of the spectrum, as the single-mode gap above);
    // each mode's Rayleigh quotient then lies within |λ_k − μ_k| + δ_C²/η of its
    // eigenvalue, matched in order. The residual bound and the kind keep the
    // single-mode form.
    VectorX clustered = VectorX::Constant(m, std::numeric_limits<double>::infinity());
    auto spacing = [&](Eigen::Index k) {  // λ_{k+1} − λ_k, ∞ beyond the ends
      return k >= 0 && k + 1 < n ? lambda_all(k + 1) - lambda_all(k) : std::numeric_limits<double>::infinity();
    };
    auto linked = [&](Eigen::Index k) {  // k and k + 1 in one group: overlapping, or 10 × closer than to the others
      return spacing(k) <= typical(k) + typical(k + 1) || 10 * spacing(k) <= std::min(spacing(k - 1), spacing(k + 1));
    };
    for (Eigen::Index first = 0; first < m;) {
      Eigen::Index last = first;
      while (last + 1 < m && linked(last)) ++last;
      const Eigen::Index size = last - first + 1;
      if (size >= 2 && size <= group) {
        const double eta = separation(typical, first, last);
        double delta2 = 0;
        for (Eigen::Index k = first; k <= last; ++k) delta2 += typical(k) * typical(k);
        if (eta > 0 && eta * eta > delta2) {
          MatrixX A(size, size), B(size, size);  // X_CᵀKX_C and X_CᵀMX_C, symmetric
          for (Eigen::Index a = 0; a < size; ++a)
            for (Eigen::Index b = a; b < size; ++b) {
              A(a, b) = A(b, a) = bandK(b - a, first + a);
              B(a, b) = B(b, a) = bandM(b - a, first + a);
            }
          Eigen::GeneralizedSelfAdjointEigenSolver<MatrixX> ritz(A, B, Eigen::EigenvaluesOnly);
          if (ritz.info() == Eigen::Success)
            for (Eigen::Index k = first; k <= last; ++k)
              clustered(k) = std::abs(lambda_all(k) - ritz.eigenvalues()(k - first)) + delta2 / eta;
        }
      }
      first = last + 1;
    }
    // E|Φ| and D|Φ| (D systematic: added as |φ|ᵀD|φ|, no cancellation assumed).
    const MatrixX EabsPhi = E_op ? E_op->product(absPhi) : MatrixX(4 * eps * K_op.product(absPhi, true));
    const double normM = M.norm(), normK = K.norm();  // Frobenius ≥ 2-norm
    const MatrixX DabsPhi = differences ? D_op->product(absPhi) : MatrixX();
    // φᵀFφ per mode where the rounding form is given (a positive
    // semidefinite bound of the data's rounding, the positions' included,
    // that keeps the springs' Laplacian structure: sparse_rounding_form).
    const bool form = K_rounding_form.rows() == n && K_rounding_form.cols() == n;
    VectorX structured = VectorX::Constant(m, std::numeric_limits<double>::infinity());
    if (form) {
      const MatrixX FPhi = K_rounding_form * Phi;
      for (Eigen::Index i = 0; i < m; ++i) structured(i) = 4 * eps * std::max(0.0, Phi.col(i).dot(FPhi.col(i)));
    }
    // The springs' rounding at its typical size, spring by spring
    // (spring_by_spring), where given: for the estimates.
    VectorX by_spring = VectorX::Constant(m, std::numeric_limits<double>::infinity());
    if (springs != nullptr && springs->fits(n))
      for (Eigen::Index i = 0; i < m; ++i) by_spring(i) = 4 * eps * spring_by_spring(*springs, Phi.col(i));

    ModalResult result;
    const char* reduction = diagonal_factor ? "M diagonal, L⁻¹KL⁻ᵀ by scaling" : "Cholesky of M, dsygst";
    result.solver = chain_solve && from_bidiagonal
                        ? std::string("dense symmetric-definite (LAPACK: point-mass chain, M = UUᵀ with U⁻¹ "
                                      "bidiagonal, tridiagonal U⁻¹KU⁻ᵀ = BBᵀ, ") +
                              (cheap.size() == n ? "every eigenvalue by dsterf, the lowest modes' vectors from the "
                                                   "singular values of the bidiagonal B = U⁻¹K^½ by dbdsvdx)"
                                                 : "every pair from the singular values of the bidiagonal B = "
                                                   "U⁻¹K^½ by dbdsvdx, MRRR dstemr having failed)")
                    : chain_solve
                        ? std::string("dense symmetric-definite (LAPACK: point-mass chain, M = UUᵀ with U⁻¹ "
                                      "bidiagonal, tridiagonal U⁻¹KU⁻ᵀ, ") +
                              (cheap.size() == n ? "every eigenvalue by dsterf, the lowest modes' vectors by MRRR dstemr)"
                                                 : "every pair by MRRR dstemr)")
                    : link_mass
                        ? std::string("dense symmetric-definite (LAPACK: chain of rigid links, M = UUᵀ + R with U⁻¹ "
                                      "bidiagonal and R diagonal, the tridiagonal pencil (U⁻¹KU⁻ᵀ, I + U⁻¹RU⁻ᵀ) to "
                                      "standard form by dsbgst, every eigenvalue by dsterf, ") +
                              (cheap.size() == n ? "the lowest modes' vectors " : "every vector ") +
                              (link_rotations ? "by MRRR dstemr and dsbgst's transformation)"
                                              : "by inverse iteration on the tridiagonal pencil)")
                    : reduced ? std::string("dense symmetric-definite (LAPACK: ") + reduction +
                                  ", tridiagonal reduction, every eigenvalue by dsterf, the lowest modes' vectors by "
                                  "MRRR dstemr)"
                   : lapack ? std::string("dense symmetric-definite (LAPACK: ") + reduction +
                                  ", divide and conquer dsyevd)"
                            : std::string("dense symmetric-definite (Eigen: Cholesky of M, L⁻¹KL⁻ᵀ, self-adjoint QR)");
    // A hanging point-mass chain's eigenvalues bracketed by Sturm counts
    // (ChainMass::certify): rigorous for the pencil as formed, and free of
    // the worst case of the products' rounding, which makes the residual
    // bound of a chain's high modes up to 1e8 × its true error.
    // residual_bounds: rigorous for the matrices as formed, to first order
    // in ε (a chain's certified bracket: without that proviso).
    VectorX residual_bounds(m);
    for (Eigen::Index i = 0; i < m; ++i) residual_bounds(i) = with_gap(bound, nq * quotient_rounding(i), i);
    // The estimate of a bracketed mode (chain_estimate; ∞ where none): the
    // counts' half width δ|λ| for the solver's part, and the data's part
    // from the chain's structure. With K diagonal and M = D_l Ĵᵀ D_m Ĵ D_l,
    // the data enter as relative errors of the k_j and the lengths l_j (the
    // masses are the scene's own): to first order δλ = Σ_j φ_j² k_j (δk_j/k_j
    // − 2δl_j/l_j) / φᵀMφ, a mean of the entries' relative errors weighted by
    // φ_j² k_j (of sum λφᵀMφ), not a sum over |M|'s entries, which is up to
    // n² × φᵀMφ on a chain's high modes (what made these estimates up to
    // 2.6e6 × the error). Each relative error is taken at its typical size,
    // about a quarter of its bound: E_jj/4 for k_j (E: K_error, 4ε Σ|terms|,
    // eight units of rounding for an entry of a few operations, which with
    // compensated subtree sums, sum_subtrees, is measured within 1.5ε), and
    // for the lengths length_error (above). The mean, not a root mean
    // square: equal links round alike, and their errors do not average out.
    // certified: the counts' rigorous radius where it is below the residual
    // bound (∞ elsewhere), which also stands for the solver's part where the
    // kind is decided.
    VectorX chain_estimate = VectorX::Constant(m, std::numeric_limits<double>::infinity()), certified = chain_estimate;
    if (diagonal_K) {
      VectorX analyzed_lambda(m), spread;
      for (Eigen::Index i = 0; i < m; ++i) analyzed_lambda(i) = lambda_all(analyzed[static_cast<std::size_t>(i)]);
      certified = chain_mass->certify(K.diagonal(), analyzed_lambda, residual_bounds, &spread);
      chain_spread = spread;
      residual_bounds = residual_bounds.cwiseMin(certified);
      const VectorX k_error =
          !given ? VectorX(4 * eps * K.diagonal().cwiseAbs())
          : differences ? VectorX((K_error.diagonal() - K_systematic_error.diagonal()).cwiseMax(0.0))
                        : VectorX(K_error.diagonal());
      const VectorX weight = 0.25 * k_error + 2 * length_error * K.diagonal().cwiseAbs();
      for (Eigen::Index i = 0; i < m; ++i)
        if (std::isfinite(spread(i)))
          chain_estimate(i) = spread(i) + Phi.col(i).cwiseAbs2().dot(weight) / phiMphi(i);
    }
    double worst_relative_residual = 0;
    Eigen::Index worst = 0;
    for (Eigen::Index j = 0, i = 0; j < n; ++j) {
      const double l = lambda_all(j);
      Mode mode;
      if (i == m || analyzed[static_cast<std::size_t>(i)] != j) {  // not analyzed: oscillatory beyond doubt
        mode = make_mode({0.0, std::sqrt(l)}, cheap(j), ModeKind::oscillatory);
        mode.damping_ratio = 0;
        mode.omega2 = l;
        mode.residual_bound = cheap(j);
        result.modes.push_back(std::move(mode));
        continue;
      }
      const double x2 = Phi.col(i).squaredNorm();
      const double residual_bound = residual_bounds(i);
      // The systematic part (Mode::systematic_error): the measured error of
      // differences, |φ|ᵀD|φ|, and a chain's mismatch (above).
      const double difference_bound = (differences ? absPhi.col(i).dot(DabsPhi.col(i)) : 0.0) +
                                      mismatch * std::abs(l) * absPhi.col(i).dot(absMPhi.col(i));
      // The kind is decided with the worst case of the data's rounding, first
      // order, |φ|ᵀE|φ| + 4ε|λ||φ|ᵀ|M||φ| (a chain's M: through its lengths,
      // mass_rounding), and the single-mode residual part or a chain's
      // certified radius where narrower (a mode is zero when |λ| is within
      // it: a group's bound never turns a zero
      // mode of a free body into a vibration); the estimate of a mode that is
      // not zero takes the quotient's and the entries' rounding at their
      // typical size (typical_quotient_rounding, as the sparse path), the
      // entries' through bounds that need no further
      // product: (Σ_ij (E_ij φ_i φ_j)²)^½ ≤ ‖φ∘(E|φ|)‖₂ (Cauchy–Schwarz by
      // rows), and (Σ_ij (M_ij φ_i φ_j)²)^½ ≤ Σ_i M_ii φ_i² as well (M is
      // positive definite: M_ij² ≤ M_ii M_jj). The systematic part stays at
      // its worst, |φ|ᵀD|φ|.
      // The data's rounding at its worst: 4ε φᵀFφ where the rounding form is
      // given (on a flat net at its rest length 44 × 44, the entrywise form
      // called rounding-level λ of −9e-15 s "divergent": it has no share of
      // the positions' rounding), else |φ|ᵀE|φ|.
      const double data_rounding = form ? structured(i) : absPhi.col(i).dot(EabsPhi.col(i));
      const double mass_rounding = chain_mass ? 2 * length_worst * std::abs(l) * mass_terms(i)
                                              : rM * std::abs(l) * absPhi.col(i).dot(absMPhi.col(i));
      const double data_bound = data_rounding + mass_rounding + difference_bound;
      // (A certified bracket's radius is rigorous: where it is narrower, it
      // stands for the residual's part. A light chain with a heavy tip has
      // residuals whose rounding is 1e20 × its eigenvalues' error.)
      const double decision =
          std::min(with_gap(typical, std::sqrt(nq) * quotient_rounding(i), i), certified(i)) + data_bound;
      const double phi2 = phiMphi(i);  // Φ's columns are M-normalized only to rounding
      const double entries =
          std::min({absPhi.col(i).cwiseProduct(EabsPhi.col(i)).stableNorm(), structured(i), by_spring(i)}) / phi2 +
          (chain_mass ? 2 * length_error * std::abs(l) * mass_terms(i)
                      : rM * std::abs(l) *
                            std::min(absPhi.col(i).cwiseProduct(absMPhi.col(i)).stableNorm(), diagonal_terms(i))) /
              phi2;
      const double quotient = typical_quotient_rounding(chain_mass || link_mass ? static_cast<double>(n) : width,
                                                        chain_mass || link_mass ? static_cast<double>(n) : depth,
                                                        rows(i) / phi2, sums(i) / phi2, entries);
      // A mode is zero where |λ| is within the decision's value, or below
      // the normal range of double (the pencil is scaled so that its largest
      // entries are near 1): there λ, its residual and their rounding have
      // lost their relative precision, and a refined zero mode's quotient
      // (2.7e-309 where the eigenvalue is exactly 0) is no evidence of a
      // vibration. Its estimate then covers |λ|.
      const bool zero = std::abs(l) <= decision || std::abs(l) < std::numeric_limits<double>::min();
      // Where that typical size (doubled) exceeds the decision's value, as it
      // may for a few coordinates, the smaller of the two.
      const double error = zero ? std::max(decision, std::abs(l))
                           : std::isfinite(chain_estimate(i))
                               ? chain_estimate(i) + difference_bound
                               : std::min(decision, with_gap(typical, quotient, i, clustered(i)) + difference_bound);
      // The solver's share of the estimate against what the data and the
      // quotient's rounding alone justify.
      const double solver_part = with_gap(typical, 0.0, i, clustered(i)) - eps * std::abs(l);
      const double justified =
          quotient + difference_bound + eps * std::abs(l) + (zero ? data_bound : 0.0);
      unresolved(i) = justified > 0 ? solver_part / justified : (solver_part > 0 ? 1e300 : 0.0);

      const double scale = (normK + std::abs(l) * normM) * std::sqrt(x2);
      const double relative_residual = scale > 0 ? residual_norm(i) / scale : 0.0;
      if (relative_residual > worst_relative_residual) {
        worst_relative_residual = relative_residual;
        worst = j;
      }

      if (zero) {
        mode = make_mode(0.0, error, ModeKind::zero);
      } else if (l < 0) {  // divergent: δq ∝ e^{st} with s = +√(−λ) real
        mode = make_mode(std::sqrt(-l), error, ModeKind::divergent);
      } else {             // oscillatory: s = i√λ
        mode = make_mode({0.0, std::sqrt(l)}, error, ModeKind::oscillatory);
        mode.damping_ratio = 0;
      }
      mode.omega2 = l;  // the computed λ, sign and all, whatever the kind
      mode.residual_bound = residual_bound;
      mode.systematic_error = difference_bound;
      if (mode.kind == ModeKind::divergent) ++result.morse_index;
      if (mode.kind == ModeKind::zero) ++result.zero_modes;

      VectorX shape = Phi.col(i) / std::sqrt(phiMphi(i));  // M-normalized to rounding
      if (shape(dominant_index(shape.cast<std::complex<double>>())) < 0) shape = -shape;
      mode.shape = shape.cast<std::complex<double>>();
      result.modes.push_back(std::move(mode));
      ++i;
    }
    if (worst_relative_residual > 1e-10)
      result.notes.push_back("mode " + std::to_string(worst + 1) + " has a relative residual ‖Kφ − λMφ‖/((‖K‖ + |λ|‖M‖)‖φ‖) of " +
                             format_number(worst_relative_residual, 2) +
                             ", far above rounding level: M is probably ill-conditioned; trust its error estimate");
    return result;
  };
  ModalResult result = analyze();
  const auto analyzed_count = static_cast<Eigen::Index>(analyzed.size());
  // A hanging chain's pairs from C by MRRR (every pair: the fast way) are
  // accurate normwise only: on a chain whose lengths rise over 1e-4 … 1e4
  // their quotients erred by up to 5e-8 relative (within their estimates),
  // where the data define each ω² to a few ε. The lowest modes up to the
  // last whose quotient the Sturm counts bracket no closer than 16ε|λ| (or
  // not at all) are then solved again from B (chain_lowest_singular),
  // within a budget of p²n ≤ 2e8 (dbdsvdx reorthogonalizes them as one
  // cluster), and analyzed again; kept unless their estimates sum to more
  // than before (B's shapes on light links are not always better).
  // What analyze() reads and writes besides its result: kept before a
  // second attempt at the vectors, put back when the attempt is refused.
  struct State {
    MatrixX Phi;
    VectorX lambda_all, unresolved, chain_spread;
  };
  auto save = [&] { return State{Phi, lambda_all, unresolved, chain_spread}; };
  auto restore = [&](State&& saved) {
    Phi = std::move(saved.Phi);
    lambda_all = std::move(saved.lambda_all);
    unresolved = std::move(saved.unresolved);
    chain_spread = std::move(saved.chain_spread);
  };
  Eigen::Index again = 0;  // how many were solved again (the solver's name)
  auto name_again = [&](ModalResult& r) {
    if (again > 0 && !r.solver.empty() && r.solver.back() == ')')
      r.solver.insert(r.solver.size() - 1, "; the lowest " + std::to_string(again) +
                                                " modes' vectors again from the singular values of the bidiagonal "
                                                "B = U⁻¹K^½ by dbdsvdx");
  };
  if (chain_solve && hanging && !from_bidiagonal && chain_spread.size() == analyzed_count) {
    Eigen::Index p = 0;
    for (Eigen::Index i = 0; i < analyzed_count; ++i)
      if (!(chain_spread(i) <= 16 * eps * std::abs(result.modes[static_cast<std::size_t>(i)].omega2))) p = i + 1;
    VectorX sigma;
    MatrixX V;
    if (p > 0 && static_cast<double>(p) * static_cast<double>(p) * static_cast<double>(n) <= 2e8 &&
        chain_lowest_singular(*chain_mass, K.diagonal(), p, sigma, V)) {
      auto sum = [p](const ModalResult& r) {
        double total = 0;
        for (Eigen::Index i = 0; i < p; ++i) total += r.modes[static_cast<std::size_t>(i)].error_estimate;
        return total;
      };
      State before = save();
      Phi.leftCols(p) = chain_shapes(K.diagonal(), sigma, V);
      ModalResult again_result = analyze();
      if (sum(again_result) <= sum(result)) {
        result = std::move(again_result);
        again = p;
        name_again(result);
      } else {
        restore(std::move(before));
      }
    }
  }
  // Refinement in rounds: a round that left fewer modes unresolved is
  // followed by another from its vectors (a graded particle chain of 320
  // particles kept mode 2 at 1.57e-14 ± 2.9e-15 for 1.31e-14 after one round,
  // its 3 inverse-iteration steps having started from a vector mixed with its
  // double neighbour's; the second round resolved it to 4e-6 relative
  // estimate), at most 3 rounds. A later round that leaves more unresolved
  // than the one before is undone.
  auto count_unresolved = [&] {
    Eigen::Index count = 0;
    for (Eigen::Index i = 0; i < analyzed_count && i < unresolved.size(); ++i) count += unresolved(i) > 10 ? 1 : 0;
    return count;
  };
  VectorX lambda(analyzed_count), estimate(analyzed_count);  // of the analyzed modes, a prefix of result.modes
  for (Eigen::Index left = count_unresolved(), round = 0; round < 3 && left > 0; ++round) {
    for (Eigen::Index i = 0; i < analyzed_count; ++i) {
      lambda(i) = result.modes[static_cast<std::size_t>(i)].omega2;
      estimate(i) = result.modes[static_cast<std::size_t>(i)].error_estimate;
    }
    State before = round > 0 ? save() : State{};
    if (!refine_unresolved(M, K, M_op.sparse(), K_op.sparse(), unresolved, lambda, estimate, Phi)) break;
    ModalResult refined = analyze();
    name_again(refined);
    const Eigen::Index now = count_unresolved();
    if (round > 0 && now > left) {
      restore(std::move(before));
      break;
    }
    result = std::move(refined);
    if (now >= left) break;
    left = now;
  }
  return result;
}

std::optional<ModalResult> solve_chain_modes(const PointMassChain& chain, const VectorX& K, const VectorX& K_terms,
                                             Eigen::Index wanted) {
  const Eigen::Index n = K.size();
  const Eigen::Index p = wanted > 0 && wanted < n ? wanted : n;
  if (n < 2 || chain.lever.size() != n || chain.mass.size() != n || K_terms.size() != n || !K.allFinite() ||
      !(K.array() > 0).all() || !K_terms.allFinite() || !chain.lever.allFinite() ||
      !(chain.lever.array() != 0).all() || !chain.mass.allFinite() || !(chain.mass.array() > 0).all())
    return std::nullopt;
  // The lowest σ of the bidiagonal B = U⁻¹K^½ (ChainMass::bidiagonal: its
  // entries define them to high relative accuracy, C = BBᵀ's do not) by
  // bisection on its Golub–Kahan form and their right vectors v by inverse
  // iteration (LAPACK dbdsvdx; chain_lowest_singular), λ = σ², and φ =
  // σK^{-½}v (chain_shapes).
  const ChainMass U(chain);
  VectorX sigma;
  MatrixX V;
  if (!chain_lowest_singular(U, K, p, sigma, V)) return std::nullopt;
  VectorX lambda = sigma.cwiseAbs2();
  if (!lambda.allFinite() || !(lambda.array() > 0).all()) return std::nullopt;
  // λ refined by the Sturm counts to ε/4 (ChainMass::refine), which then
  // bracket each as the eigenvalue of its rank (none missed below the
  // highest returned); rigorous for the pencil as formed. A value that
  // moved by more than the bisection's O(n)ε would no longer be its
  // vector's: the general path then answers.
  const VectorX computed = lambda;
  U.refine(K, lambda);
  for (Eigen::Index i = 0; i < p; ++i)
    if (!(std::abs(lambda(i) - computed(i)) <= 1e3 * static_cast<double>(n) * eps * computed(i))) return std::nullopt;
  VectorX spread;
  const VectorX radius =
      U.certify(K, lambda, VectorX::Constant(p, std::numeric_limits<double>::infinity()), &spread);
  if (!radius.allFinite() || !spread.allFinite()) return std::nullopt;
  // The estimate as the dense path's chain (solve_symmetric): the counts'
  // half width plus the data's relative errors weighted by φ_j²k_j = λv_j²,
  // K_jj's at a quarter of its bound 4ε Σ|terms| and the lengths' at ε/2
  // (twice, as l_j² enters): the lengths come from the kinematics (no
  // assembled M to disagree with them). Every K_jj > 0 and M = UUᵀ
  // definite: every eigenvalue is positive, and stays so under any
  // relative change of the data (each mode an oscillation, the scene
  // stable).
  const VectorX relative = (eps * K_terms).cwiseQuotient(K) + VectorX::Constant(n, eps);
  ModalResult result;
  result.solver =
      "matrix-free point-mass chain (absolute angles: M = UUᵀ with U⁻¹ bidiagonal, K diagonal; the lowest "
      "singular values of the bidiagonal U⁻¹K^½ by LAPACK dbdsvdx, bracketed by Sturm counts)";
  std::vector<int> parent(static_cast<std::size_t>(n));
  std::iota(parent.begin(), parent.end(), -1);
  for (Eigen::Index i = 0; i < p; ++i) {
    const double l = lambda(i), v2 = V.col(i).squaredNorm();
    Mode mode = make_mode({0.0, std::sqrt(l)}, spread(i) + l * V.col(i).cwiseAbs2().dot(relative) / v2,
                          ModeKind::oscillatory);
    mode.damping_ratio = 0;
    mode.omega2 = l;
    mode.residual_bound = radius(i);
    mode.systematic_error = 0;
    result.modes.push_back(std::move(mode));
  }
  const MatrixX Phi = chain_shapes(K, lambda.cwiseSqrt(), V);
  for (Eigen::Index i = 0; i < p; ++i) result.modes[static_cast<std::size_t>(i)].shape = Phi.col(i).cast<std::complex<double>>();
  absolute_to_relative(parent, true, result.modes);
  result.stability = Stability::stable;
  if (p < n)
    result.notes.push_back("completeness checked by Sturm counts of the chain's bidiagonal form: each returned "
                           "eigenvalue is bracketed as the one of its rank, so none below " +
                           format_number(lambda(p - 1), 8) +
                           " is missing; in absolute angles K is diagonal and positive, so every eigenvalue is "
                           "positive (stable)");
  add_cluster_notes(result.modes, true, result.notes);
  return result;
}

std::optional<LinkChain> link_chain(const MatrixX& M) {
  const Eigen::Index n = M.rows();
  if (n < 3 || M.cols() != n) return std::nullopt;
  // M_ij = l_i a_j (i < j), l_0 = 1: a from row 0, l from column n − 1;
  // the two generators no entry above the diagonal fixes, a_0 and
  // l_{n−1}, make R_00 = R_{n−1,n−1} = 0 (a point-mass chain's R is 0).
  VectorX l(n), a(n);
  l(0) = 1;
  a = M.row(0).transpose();
  for (Eigen::Index i = 1; i + 1 < n; ++i) l(i) = M(i, n - 1) / a(n - 1);
  l(n - 1) = M(n - 1, n - 1) / a(n - 1);
  if (!l.allFinite() || !a.allFinite() || !(l.array() != 0).all() || !(a.array() != 0).all()) return std::nullopt;
  LinkChain c;
  VectorX& mu = c.generators.mass;
  mu.resize(n);
  for (Eigen::Index j = 0; j < n; ++j) mu(j) = a(j) / l(j) - (j + 1 < n ? a(j + 1) / l(j + 1) : 0.0);
  if (!mu.allFinite() || !(mu.array() > 0).all()) return std::nullopt;
  // W_j = Σ_{b≥j} μ_b as ChainMass's running sums stand for it (exactly),
  // summed with compensation so that each W_j is within 2ε.
  const VectorX W = sums::compensated_suffix_sums(mu);
  double& mismatch = c.generators.mismatch;
  for (Eigen::Index j = 1; j < n; ++j)
    for (Eigen::Index i = 0; i < j; ++i) {
      const double model = l(i) * l(j) * W(j), departure = std::abs(M(i, j) - model) / std::abs(model);
      if (!(departure <= 1e-12)) return std::nullopt;  // NaN included
      mismatch = std::max(mismatch, departure);
    }
  c.generators.lever = l;
  c.remainder.resize(n);
  for (Eigen::Index j = 0; j < n; ++j) c.remainder(j) = M(j, j) - l(j) * l(j) * W(j);
  if (!c.remainder.allFinite()) return std::nullopt;
  return c;
}

}  // namespace modal::detail
