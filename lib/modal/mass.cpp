// lib/modal/mass.cpp — Cholesky factor of the mass matrix, and the diagnosis of
// a mass matrix that has none.
//
// A mass matrix that is singular at a configuration means a coordinate
// combination moves nothing with inertia: a coordinate singularity (a rotation
// vector at a gimbal-lock point, two hinge axes aligned) or a body without mass
// or inertia. The user can act only if told which coordinates, so the
// diagnosis eigen-decomposes M and describes each (near-)null eigenvector in
// coordinate names.
#include "detail.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

// LAPACK's Cholesky factorization (OpenBLAS where installed: blocked and
// threaded); the trailing argument is the length of `uplo` (gfortran).
extern "C" void dpotrf_(const char* uplo, const int* n, double* a, const int* lda, int* info, std::size_t uplo_length);

namespace modal::detail {
namespace {

constexpr double eps = std::numeric_limits<double>::epsilon();

// Eigen's LLT with its factor computed by LAPACK dpotrf: the same L in the
// same storage (lower triangle; the strict upper one keeps A's entries, as
// Eigen's own leaves them), with the L1 norm Eigen keeps for rcond(). On a
// 1000×1000 mass matrix Eigen's single-threaded factorization took 20–35 ms,
// a tenth of the whole eigen phase; dpotrf a few. Used where LAPACK solves
// the pencil anyway (lapack_wins), so a small scene never loads it.
class LapackCholesky : public Cholesky {
 public:
  explicit LapackCholesky(const MatrixX& A) : Cholesky(A.rows()) {
    m_matrix = A;
    const int n = static_cast<int>(A.rows());
    int info = 0;
    if (n > 0) dpotrf_("L", &n, m_matrix.data(), &n, &info, 1);
    m_l1_norm = n > 0 ? A.cwiseAbs().colwise().sum().maxCoeff() : 0.0;  // A symmetric: its columns' L1 norms
    m_isInitialized = true;
    m_info = info == 0 ? Eigen::Success : Eigen::NumericalIssue;
  }
};

// Eigen's LLT of a diagonal A (particles, equilibrated): L = diag(√A_ii),
// O(n) work beside the copy, where a dense factorization costs n³/3 (a
// tenth of a 540-particle lattice's eigen phase). NumericalIssue where an
// entry is not positive and finite, as the dense factorization's.
class DiagonalCholesky : public Cholesky {
 public:
  explicit DiagonalCholesky(const MatrixX& A) : Cholesky(A.rows()) {
    m_matrix = A;
    const VectorX d = A.diagonal();
    const bool positive = (d.array() > 0).all() && d.allFinite();
    m_matrix.diagonal() = d.cwiseMax(0.0).cwiseSqrt();
    m_l1_norm = d.size() > 0 ? d.cwiseAbs().maxCoeff() : 0.0;
    m_isInitialized = true;
    m_info = positive ? Eigen::Success : Eigen::NumericalIssue;
  }
};

// Throws SingularMassMatrix describing every eigenvector of M whose eigenvalue
// is at most `tolerance` (at least the smallest one), as the direction S v in
// the original coordinates when M is scaled (`scale` = s, or empty).
[[noreturn]] void diagnose_singular_mass(const MatrixX& M, const std::vector<std::string>& names,
                                         double tolerance, const VectorX& scale, const std::vector<int>& absolute) {
  Eigen::SelfAdjointEigenSolver<MatrixX> eig(M);
  if (eig.info() != Eigen::Success)
    throw SingularMassMatrix("the mass matrix has no Cholesky factor and its eigen-decomposition failed: "
                             "it contains non-finite or enormous entries");
  const VectorX& values = eig.eigenvalues();  // ascending
  const double largest = values.cwiseAbs().maxCoeff();

  std::ostringstream out;
  // Negative beyond the eigen-solver's own error (O(nε‖M‖)): indefinite.
  // Within it, a computed eigenvalue's sign says nothing.
  const double solver_error = tolerance * std::max<double>(1.0, static_cast<double>(values.size()));
  const bool indefinite = values(0) < -solver_error;
  // "Singular" only as far as double precision can tell: an eigenvalue at
  // or below the tolerance may be positive (graded inertias: a light body
  // beside a heavy one), and the message says so rather than "no inertia".
  out << "the mass matrix is " << (indefinite ? "not positive definite" : "singular to double precision")
      << " at this configuration: ";
  Eigen::Index null_dimension = 1;
  while (null_dimension < values.size() && values(null_dimension) <= tolerance) ++null_dimension;
  // Where a computed eigenvalue stands against the tolerance (the refusal
  // also comes from a failed factorization, or an upper bound of λ_min
  // within the tolerance while the computed eigenvalue lies above it).
  auto standing = [&](double value) -> std::string {
    if (std::abs(value) <= tolerance) return ", within the tolerance 16ε‖M‖_F = " + format_number(tolerance, 2) + " of zero";
    if (value < 0)
      return ", within the eigen-solver's error 16nε‖M‖_F = " + format_number(solver_error, 2) + " of zero";
    return ", above the tolerance 16ε‖M‖_F = " + format_number(tolerance, 2) +
           ", but M's Cholesky factorization failed or an upper bound of its smallest eigenvalue fell within it";
  };
  const Eigen::Index listed = std::min<Eigen::Index>(null_dimension, 3);
  const bool scaled = scale.size() == M.rows() && (scale.array() != 1.0).any();
  for (Eigen::Index j = 0; j < listed; ++j) {
    if (j > 0) out << "; ";
    VectorX v = scaled ? VectorX(scale.cwiseProduct(eig.eigenvectors().col(j))) : VectorX(eig.eigenvectors().col(j));
    if (static_cast<Eigen::Index>(absolute.size()) == v.size()) {  // q = Tθ
      const VectorX theta = v;
      for (std::size_t c = 0; c < absolute.size(); ++c)
        if (absolute[c] >= 0) v(static_cast<Eigen::Index>(c)) -= theta(absolute[c]);
    }
    v.normalize();
    const bool negative = values(j) < -solver_error;
    out << describe_combination(v, names)
        << (negative ? " has negative inertia" : " has no inertia that double precision resolves")
        << " (computed eigenvalue " << format_number(values(j), 2) << " of largest " << format_number(largest, 3)
        << (negative ? "" : standing(values(j)))
        << (scaled ? "; M scaled by the coordinates' inertia" : "") << ")";
  }
  if (null_dimension > listed) out << "; and " << null_dimension - listed << " more such directions";
  if (null_dimension > 1)
    out << " (a " << null_dimension << "-dimensional null space: any basis of it describes it equally well)";
  out << (indefinite ? "; negative mass or inertia in the model, which is inconsistent"
                     : "; a coordinate singularity (e.g. a rotation vector at a gimbal-lock point, "
                       "aligned hinge axes), a body without mass or inertia, or inertias so graded that M, though "
                       "perhaps positive definite, is too ill-conditioned for double precision in these coordinates "
                       "(condition number near 1/ε even after scaling by the coordinates' inertia)");
  throw SingularMassMatrix(out.str());
}

}  // namespace

std::vector<std::string> names_or_default(const std::vector<std::string>& names, Eigen::Index n) {
  if (static_cast<Eigen::Index>(names.size()) == n) return names;
  std::vector<std::string> q;
  for (Eigen::Index i = 0; i < n; ++i) q.push_back("q" + std::to_string(i + 1));
  return q;
}

std::string describe_combination(VectorX v, const std::vector<std::string>& names) {
  Eigen::Index top = 0;
  v.cwiseAbs().maxCoeff(&top);
  if (v(top) < 0) v = -v;
  const double largest = v(top);
  if (largest > 0.995) return "the coordinate " + names[static_cast<std::size_t>(top)];

  std::vector<Eigen::Index> terms;
  for (Eigen::Index i = 0; i < v.size(); ++i)
    if (std::abs(v(i)) >= 0.1 * largest) terms.push_back(i);
  std::stable_sort(terms.begin(), terms.end(),
                   [&](Eigen::Index a, Eigen::Index b) { return std::abs(v(a)) > std::abs(v(b)); });
  std::ostringstream out;
  out << "the combination ";
  bool first = true;
  const std::size_t shown = std::min<std::size_t>(terms.size(), 6);  // a message, not a dump
  for (Eigen::Index i : std::vector<Eigen::Index>(terms.begin(), terms.begin() + static_cast<std::ptrdiff_t>(shown))) {
    const double c = v(i);
    if (!first) out << (c < 0 ? " − " : " + ");
    else if (c < 0) out << "−";
    out << format_number(std::abs(c), 2) << "·" << names[static_cast<std::size_t>(i)];
    first = false;
  }
  if (terms.size() > shown) out << " + … (" << terms.size() - shown << " more coordinates)";
  return out.str();
}

// Upper bound on the smallest eigenvalue of the SPD matrix factored in `llt`
// (n×n): 1/ρ where ρ = xᵀM⁻¹x is the Rayleigh quotient of M⁻¹ after a few
// steps of inverse iteration. Always ρ ≤ 1/λ_min, hence 1/ρ ≥ λ_min; the gap
// that matters here (λ_min near rounding level, the others not) makes a few
// steps enough for 1/ρ to reach λ_min within a small factor.
double smallest_eigenvalue_bound(const Cholesky& llt, Eigen::Index n) {
  return smallest_eigenvalue_bound([&llt](VectorX& x) { x = llt.solve(x); }, n);
}

double smallest_eigenvalue_bound(const std::function<void(VectorX&)>& solve, Eigen::Index n) {
  VectorX x(n);
  // A start with components along every direction of interest: no simple
  // pattern (all ones, alternating signs) that a null vector such as
  // (1, −1)/√2 could be orthogonal to.
  for (Eigen::Index i = 0; i < n; ++i) x(i) = 1.0 + 0.5 * std::cos(2.399963 * static_cast<double>(i + 1));
  x.normalize();
  double rho = 0;
  for (int it = 0; it < 8; ++it) {
    VectorX y = x;
    solve(y);
    rho = x.dot(y);
    const double norm = y.norm();
    if (!(norm > 0) || !std::isfinite(norm)) return 0;  // M⁻¹ blew up: singular
    x = y / norm;
  }
  return rho > 0 ? 1.0 / rho : 0.0;
}

VectorX equilibrating_scale(const VectorX& diagonal) {
  const Eigen::Index n = diagonal.size();
  // s_i = 2^k_i with k_i = −⌊(e_i + 1)/2⌋, e_i = ⌊log₂|M_ii|⌋: s_i²|M_ii| in [½, 2).
  std::vector<int> k(static_cast<std::size_t>(n), 0);
  std::vector<bool> has(static_cast<std::size_t>(n), false);
  double sum = 0;
  int count = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double a = std::abs(diagonal(i));
    if (!(a > 0) || !std::isfinite(a)) continue;
    const int e = std::ilogb(a);
    const auto u = static_cast<std::size_t>(i);
    k[u] = -static_cast<int>(std::floor((e + 1) / 2.0));
    has[u] = true;
    sum += k[u];
    ++count;
  }
  const int neutral = count > 0 ? static_cast<int>(std::lround(sum / count)) : 0;
  VectorX s(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    s(i) = std::ldexp(1.0, has[u] ? k[u] : neutral);
  }
  return s;
}

VectorX coordinate_scale(const VectorX& inertia, Eigen::Index n) {
  return inertia.size() == n ? equilibrating_scale(inertia) : VectorX(VectorX::Ones(n));
}

MatrixX scale_symmetric(const MatrixX& A, const VectorX& s) { return s.asDiagonal() * A * s.asDiagonal(); }

void scale_symmetric_in_place(MatrixX& A, const VectorX& s) {
  for (Eigen::Index j = 0; j < A.cols(); ++j)
    for (Eigen::Index i = 0; i < A.rows(); ++i) A(i, j) = s(i) * A(i, j) * s(j);
}

bool scales_exactly(const MatrixX& A, const VectorX& s) {
  // For powers of two (equilibrating_scale's), a product with the reciprocal
  // is the division, exactly, and several times faster.
  const bool powers = std::all_of(s.begin(), s.end(), [](double x) {
    int e = 0;
    return std::isfinite(x) && std::frexp(x, &e) == 0.5 && std::abs(e) < 1000;
  });
  const VectorX r = powers ? VectorX(s.cwiseInverse()) : VectorX();
  for (Eigen::Index j = 0; j < A.cols(); ++j)
    for (Eigen::Index i = 0; i < A.rows(); ++i) {
      const double v = s(i) * A(i, j) * s(j);
      if (!std::isfinite(v) || (powers ? v * r(j) * r(i) : v / s(j) / s(i)) != A(i, j)) return false;
    }
  return true;
}

Cholesky factor_mass(const MatrixX& M, const std::vector<std::string>& names, const VectorX& scale,
                     const std::vector<int>& absolute) {
  const Eigen::Index n = M.rows();
  if (!std::isfinite(M.norm()))
    throw SingularMassMatrix("the mass matrix overflows double precision (largest entry " +
                             format_number(M.cwiseAbs().maxCoeff(), 3) +
                             "): masses or lengths too large for the scene's units; rescale them");
  // Relative tolerance for "singular": an eigenvalue below 16·ε·‖M‖ is at the
  // level of the rounding in M's entries, so it cannot be told from zero. Not
  // n·ε: a long chain's M is genuinely positive definite with condition
  // numbers of 1e12 and more (link masses and lengths shrink as 1/N), and
  // Cholesky factors it stably; the error estimates of the modes then say how
  // much accuracy the conditioning costs. ‖M‖_F ≥ ‖M‖₂ keeps the test safe.
  // Normwise, so it is meant for the equilibrated M (equilibrating_scale):
  // there an entry's rounding is of the size of the entry relative to its
  // row's and column's diagonal, as it is in M itself.
  const double tolerance = 16 * eps * M.norm();
  // A diagonal M's factor and smallest eigenvalue exactly, in O(n).
  const bool diagonal = is_diagonal(M);
  const Cholesky llt = diagonal ? Cholesky(DiagonalCholesky(M))
                       : lapack_wins(n) ? Cholesky(LapackCholesky(M))
                                        : Cholesky(M);
  if (llt.info() != Eigen::Success || !(M.norm() > 0) ||
      (diagonal ? M.diagonal().minCoeff() : smallest_eigenvalue_bound(llt, n)) <= tolerance)
    diagnose_singular_mass(M, names, tolerance, scale, absolute);
  return llt;
}

bool is_diagonal(const MatrixX& A) {
  for (Eigen::Index j = 0; j < A.cols(); ++j)
    for (Eigen::Index i = 0; i < A.rows(); ++i)
      if (i != j && A(i, j) != 0) return false;
  return true;
}

}  // namespace modal::detail
