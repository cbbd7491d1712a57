// lib/modal/first_order.cpp — M q̈ + C q̇ + K q = 0 (C = D + G; K possibly
// non-symmetric) as the 2n first-order system ż = A z.
//
// Method: with M⁻¹ applied by Cholesky solves, and the velocity half of the
// state scaled by w = √‖M⁻¹K‖_F (z = [q; q̇/w], a diagonal similarity that
// leaves the eigenvalues unchanged and balances the two blocks when stiffness
// and mass have very different units or sizes),
//
//     A = [ 0          w·I    ]
//         [ −M⁻¹K / w  −M⁻¹C  ]      (2n×2n),
//
// Eigen's EigenSolver (Hessenberg reduction + real Schur form) gives s and the
// right eigenvectors z. Working in real arithmetic keeps complex pairs exactly
// conjugate and real eigenvalues exactly real, so each pair is reported once
// (ω > 0) and each real eigenvalue individually.
//
// Error estimate of each s (absolute, rad/s). First-order perturbation theory
// for a simple eigenvalue: a perturbation δA moves s by about
// |yᴴ δA z| / |yᴴ z| ≤ κ ‖δA‖ with κ = ‖y‖‖z‖/|yᴴz|, y the left eigenvector.
// The left eigenvectors are the rows of Z⁻¹ (Z = [z₁ … z₂ₙ], yᵢᴴ = row i, so
// yᵢᴴzᵢ = 1). The size of δA is taken as η·‖A‖_F with η the largest of
//   - the backward error of the computed pair for A, ‖Az − sz‖ / (‖A‖‖z‖),
//   - the backward error for the original quadratic problem,
//     ‖(s²M + sC + K)x‖ / ((|s|²‖M‖ + |s|‖C‖ + ‖K‖)‖x‖), x = displacement part
//     of z (it sees the rounding in forming M⁻¹K and M⁻¹C, which the first
//     does not),
//   - 2n·ε, the rounding of the data themselves (as in symmetric.cpp).
// So estimate = η‖A‖κ. At a defective eigenvalue (modes coalescing: critical
// damping, onset of flutter, an undamped rigid-body motion) κ is infinite and
// the true error is of the order of the Hölder bound √(η)·‖A‖ for a Jordan
// block of size 2; the estimate is the smaller of the two.
// Measured, systematic errors of K and C (differences, a loose equilibrium:
// entrywise bounds E_K, E_C ≥ 0) move A's lower blocks by
// −M⁻¹(δK x + δC s x)/w on an eigenvector z = [x; s x/w]; with u = M⁻¹y_v
// (y_v the velocity half of the left eigenvector) this moves s by at most
//     |u|ᵀ(E_K|x| + |s| E_C|x|) / (w |yᴴz|)
// to first order, added to the estimate (for a defective eigenvalue, where
// that is infinite, its Hölder counterpart √(‖δA‖_F ‖A‖_F)).
//
// Kinds: an eigenvalue is zero when |s| ≤ its estimate; real (within error)
// when ω ≤ its estimate, then divergent if σ > 0, damped if σ < 0; complex
// otherwise, flutter if σ > its estimate, damped if σ < −estimate, oscillatory
// in between. morse_index and zero_modes count eigenvalues of the 2n system
// (a pair that is real within error counts twice; an undamped rigid-body
// motion gives two zero eigenvalues).
#include "detail.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <limits>

namespace modal::detail {
namespace {
constexpr double eps = std::numeric_limits<double>::epsilon();
using Complex = std::complex<double>;

ModeKind kind_of(Complex s, double error) {
  if (std::abs(s) <= error) return ModeKind::zero;
  if (std::abs(s.imag()) <= error) return s.real() > 0 ? ModeKind::divergent : ModeKind::damped;
  if (s.real() > error) return ModeKind::flutter;
  if (s.real() < -error) return ModeKind::damped;
  return ModeKind::oscillatory;
}
}  // namespace

ModalResult solve_first_order(const MatrixX& M, const MatrixX& K, const MatrixX& C, const Cholesky& mass,
                              const MatrixX& K_systematic_error, const MatrixX& C_error) {
  const Eigen::Index n = M.rows();
  const MatrixX MinvK = mass.solve(K);
  const MatrixX MinvC = mass.solve(C);
  const double stiffness_scale = std::sqrt(MinvK.norm());
  const double w = stiffness_scale > 0 && std::isfinite(stiffness_scale) ? stiffness_scale : 1.0;

  MatrixX A = MatrixX::Zero(2 * n, 2 * n);
  A.topRightCorner(n, n).diagonal().setConstant(w);
  A.bottomLeftCorner(n, n) = -MinvK / w;
  A.bottomRightCorner(n, n) = -MinvC;
  const double normA = A.norm();

  Eigen::EigenSolver<MatrixX> eig(A, true);
  if (eig.info() != Eigen::Success)
    throw NumericalError("the first-order eigen-solver did not converge (Eigen EigenSolver on the 2n×2n state matrix)");
  const Eigen::VectorXcd values = eig.eigenvalues();
  const Eigen::MatrixXcd Z = eig.eigenvectors();
  const Eigen::MatrixXcd Y = Z.partialPivLu().inverse();  // rows: left eigenvectors yᴴ
  const Eigen::MatrixXcd Ac = A.cast<Complex>();
  const Eigen::MatrixXcd Mc = M.cast<Complex>(), Kc = K.cast<Complex>(), Cc = C.cast<Complex>();
  const double normM = M.norm(), normK = K.norm(), normC = C.norm();
  const double data_rounding = 2.0 * static_cast<double>(n) * eps;
  // Measured errors of K and C (see the header comment): U = M⁻¹ Y_vᵀ, one
  // column per eigenvalue, and the Frobenius norm of δA for the Hölder form.
  const bool has_K_error = K_systematic_error.rows() == n && K_systematic_error.cols() == n;
  const bool has_C_error = C_error.rows() == n && C_error.cols() == n;
  Eigen::MatrixXcd U;
  double delta_A = 0;
  if (has_K_error || has_C_error) {
    const Eigen::MatrixXcd Yv = Y.rightCols(n).transpose();  // n × 2n
    U.resize(n, 2 * n);
    U.real() = mass.solve(MatrixX(Yv.real()));
    U.imag() = mass.solve(MatrixX(Yv.imag()));
    if (has_K_error) delta_A += mass.solve(K_systematic_error).norm() / w;
    if (has_C_error) delta_A += mass.solve(C_error).norm();
  }

  ModalResult result;
  result.solver = "dense first-order 2n×2n (Eigen: Cholesky solves with M, real Schur EigenSolver, "
                  "left eigenvectors from the inverse eigenvector matrix)";
  double worst_backward = 0;
  for (Eigen::Index i = 0; i < 2 * n; ++i) {
    const Complex s = values(i);
    if (s.imag() < 0) continue;  // the conjugate of a reported pair
    const Eigen::VectorXcd z = Z.col(i);
    const Eigen::VectorXcd x = z.head(n);

    const double eta_A = (Ac * z - s * z).norm() / (normA * z.norm());
    const double q_scale = (std::norm(s) * normM + std::abs(s) * normC + normK) * x.norm();
    const double eta_Q = q_scale > 0 ? ((s * s) * (Mc * x) + s * (Cc * x) + Kc * x).norm() / q_scale : 0.0;
    const double eta = std::max({eta_A, eta_Q, data_rounding});
    worst_backward = std::max(worst_backward, std::max(eta_A, eta_Q));

    const Complex yz = (Y.row(i) * z).value();  // yᴴz: row i of Z⁻¹ times z (1 up to rounding)
    const double kappa = Y.row(i).norm() * z.norm() / std::abs(yz);
    const double first_order = eta * normA * kappa;
    const double holder = std::sqrt(eta) * normA;
    double error = std::isfinite(first_order) ? std::min(first_order, holder) : holder;
    double systematic_part = 0;
    if (U.size() > 0) {
      const VectorX absx = x.cwiseAbs();
      VectorX moved = VectorX::Zero(n);
      if (has_K_error) moved += K_systematic_error * absx;
      if (has_C_error) moved += std::abs(s) * (C_error * absx);
      const double systematic = U.col(i).cwiseAbs().dot(moved) / (w * std::abs(yz));
      systematic_part = std::isfinite(systematic) ? std::min(systematic, std::sqrt(delta_A * normA))
                                                  : std::sqrt(delta_A * normA);
      error += systematic_part;
    }

    const ModeKind kind = kind_of(s, error);
    Mode mode = make_mode(s, error, kind);
    mode.systematic_error = systematic_part;
    const int multiplicity = s.imag() > 0 ? 2 : 1;  // eigenvalues of A this entry stands for
    if (kind == ModeKind::divergent) result.morse_index += multiplicity;
    if (kind == ModeKind::zero) result.zero_modes += multiplicity;

    Eigen::VectorXcd shape = x;
    shape /= shape(dominant_index(shape));
    mode.shape = std::move(shape);
    result.modes.push_back(std::move(mode));
  }
  std::stable_sort(result.modes.begin(), result.modes.end(), [](const Mode& a, const Mode& b) {
    return a.omega != b.omega ? a.omega < b.omega : a.growth_rate < b.growth_rate;
  });
  if (worst_backward > 1e-10)
    result.notes.push_back("the largest backward error of an eigenpair is " + format_number(worst_backward, 2) +
                           ", far above rounding level: M is probably ill-conditioned; trust the error estimates");
  return result;
}

}  // namespace modal::detail
