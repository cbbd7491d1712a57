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
//   - ε (the data's own rounding is the data term below: a floor of 2nε
//     here as well made the estimates of the bundled damped and gyroscopic
//     scenes up to 65 × their true errors; results/estimate_honesty.md).
// So estimate = η‖A‖κ. At a defective eigenvalue (modes coalescing: critical
// damping, onset of flutter, an undamped rigid-body motion) κ is infinite and
// the true error is of the order of the Hölder bound √(η)·‖A‖ for a Jordan
// block of size 2; the estimate is the smaller of the two.
// What the data carry. Entrywise errors δK, δC, δM (|δK| ≤ E_K: the
// rounding part of LinearModel::K_error, else 4ε|K|; |δC| ≤ 4ε|C|; |δM| ≤
// 4ε|M|, as in symmetric.cpp; C's own bound where C came by a congruence)
// move A's lower blocks; on an eigenvector
// z = [x; s x/w], using (K + sC)x = −s²Mx, δA z = −[0; M⁻¹(δK + s δC +
// s² δM)x / w]. With l = M⁻¹ȳ_v (y_v the velocity half of the left
// eigenvector; lᵀQ(s) = 0 for Q(s) = s²M + sC + K, and w yᴴz = lᵀQ'(s)x)
// this moves s by at most
//     |l|ᵀ(E_K + |s|E_C + |s|²E_M)|x| / |lᵀQ'(s)x|
// to first order; the estimate adds it at its typical size (in `terms`). It is the same number for the
// equilibrated pencil, so graded coordinates cost nothing here; without it
// the estimates of graded damped chains were up to 1e5 × below their true
// errors (a chain of slides in relative coordinates: M's entries are sums of
// masses over 12 decades, and the high modes see their rounding).
// Measured, systematic errors of K and C (differences, a loose equilibrium:
// entrywise bounds E'_K, E'_C ≥ 0) are added the same way, and reported as
// the systematic part. For a defective eigenvalue, where these are
// infinite, their Hölder counterpart √(‖δA‖_F ‖A‖_F).
//
// Refinement of unresolved modes. The solver's share above is normwise,
// ε‖A‖κ: in a graded scene (|s| over 13 decades) the small |s| come out with
// estimates far above themselves (0.038 ± 2e3 for a pair that is
// −2e-9 ± 3.4e-6 i), a lightly damped pair of small |s| even as two real
// values ±a. Where that share is over 10 × the data's (or a mode's estimate
// is over 1e6 ε|s|), the pair is refined by inverse iteration on Q
// (refine_pair), worst first within about max(3e8, 4n³) flops; the refined
// pair's solver share is the next Newton step plus the rounding of the
// residual (analyze_refined). A refinement is kept when its estimate is
// smaller, its value lies within both estimates of the old one, and no pair
// kept before holds it. What is still unresolved after that is replaced as
// a group by the eigenvalues of the reversed problem μ²K + μC + M = 0
// (μ = 1/s; its normwise error is relative to the largest 1/|s|) that no
// other pair claims, refined the same way, when all lie within the group's
// estimates, refine to distinct values and are as many (a split pair
// becomes one pair again). Measured on generated damped chains of slides
// (masses and stiffnesses over 1e-6 … 1e6, tests/test_graded.cpp): worst
// relative error 6.2e4 → 3.0e-5, estimates over 1e3 × the true error
// 108 → 2 of 454. Before that group step, isolated pairs whose normwise
// share is merely over 2ε|s| are refined too, within about the eigen-
// solve's cost (below): the bundled
// damped, follower and gyroscopic scenes' estimates 6.9 … 27 → 2.7 … 7.9 ×
// the true error against their closed forms (with the typical data share).
//
// Kinds are decided with the data's share at its worst (|l|ᵀ(…)|x|, not its
// typical size), as in symmetric.cpp, and, where the rounding form F is given
// (LinearModel::K_rounding_form), K's part of it as 4ε times F's bilinear
// bound: the entrywise E_K leaves out the positions' rounding, and damped
// rest-length nets 10²–10⁴ spacings from the origin had rounding-level real
// values called "divergence" (3 of 5 generated ones, tests/
// test_extremes.cpp). With that level d: an eigenvalue is zero when
// |s| ≤ d (and d is its estimate); real (within error) when ω ≤ d, then
// divergent if σ > 0, damped if σ < 0; complex otherwise, flutter if σ > d,
// damped if σ < −d, oscillatory in between. morse_index and zero_modes
// count eigenvalues of the 2n system (a pair that is real within error
// counts twice; an undamped rigid-body motion gives two zero eigenvalues).
#include "detail.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

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

// Q(s) = s²M + sC + K and Q'(s) = 2sM + C, in complex arithmetic.
Eigen::MatrixXcd quadratic(const Eigen::MatrixXcd& M, const Eigen::MatrixXcd& C, const Eigen::MatrixXcd& K, Complex s) {
  return (s * s) * M + s * C + K;
}
Eigen::MatrixXcd derivative(const Eigen::MatrixXcd& M, const Eigen::MatrixXcd& C, Complex s) { return (2.0 * s) * M + C; }

// The data of Q as complex matrices and their magnitudes (for the rounding
// of Q(s)x).
struct Quadratic {
  Eigen::MatrixXcd M, C, K;
  MatrixX absM, absC, absK;
  // ε‖(|K| + |s||C| + |s|²|M|)|x|‖ (vector) and ε|l|ᵀ(…)|x| (the rounding of lᵀQ(s)x)
  VectorX rounding(Complex s, const Eigen::VectorXcd& x) const {
    const VectorX absx = x.cwiseAbs();
    const double a = std::abs(s);
    return eps * (absK * absx + a * (absC * absx) + (a * a) * (absM * absx));
  }
};

// Inverse iteration on Q for one eigenvalue (the header's "Refinement of
// unresolved modes"): right x ← Q(σ)⁻¹Q'(σ)x, left l ← Q(σ)⁻ᵀQ'(σ)ᵀl (l is
// the conjugate of the left eigenvector: lᵀQ(s) = 0), and σ ← σ − lᵀQ(σ)x /
// lᵀQ'(σ)x, the two-sided Rayleigh functional's Newton step, until the step
// is within 4ε|σ| or the rounding of lᵀQ(σ)x (whichever is larger), at most
// 8 steps. `real`: σ, x and l kept real (Q is real there; complex rounding
// would leave an imaginary part of 1e-39). False when it does not settle.
bool refine_pair(const Quadratic& q, bool real, Complex& s, Eigen::VectorXcd& x, Eigen::VectorXcd& l) {
  for (int step = 0; step < 8; ++step) {
    const Eigen::MatrixXcd dQ = derivative(q.M, q.C, s);
    Eigen::VectorXcd xn, ln;
    // No rank decision: a huge x is the point. Where s ≠ 0 is an eigenvalue
    // of Q as rounded (a pivot exactly 0, as on small scenes with round
    // data), the iteration's vectors come from Q at s moved by 16ε|s|, far
    // closer to s than any other eigenvalue that inverse iteration would need
    // to reject; s's own step below still uses Q(s). (The budget below counts
    // one factorization per step; the retry is rare.)
    for (const double shift : {0.0, 16 * eps}) {
      if (shift > 0 && s == Complex(0)) break;
      const Eigen::PartialPivLU<Eigen::MatrixXcd> lu(quadratic(q.M, q.C, q.K, s + shift * std::abs(s)));
      xn = lu.solve(dQ * x);
      ln = lu.transpose().solve(dQ.transpose() * l);
      if (xn.allFinite() && ln.allFinite() && xn.norm() > 0 && ln.norm() > 0) break;
    }
    if (!xn.allFinite() || !ln.allFinite() || xn.norm() == 0 || ln.norm() == 0) return false;
    x = xn / xn.norm();
    l = ln / ln.norm();
    if (real) {
      x = x.real().cast<Complex>();
      l = l.real().cast<Complex>();
    }
    const Complex den = (l.transpose() * (dQ * x)).value();
    const Complex num = (l.transpose() * (quadratic(q.M, q.C, q.K, s) * x)).value();
    if (den == Complex(0)) return false;
    const Complex next = real ? Complex((s - num / den).real(), 0.0) : s - num / den;
    if (!std::isfinite(next.real()) || !std::isfinite(next.imag())) return false;
    const double noise = l.cwiseAbs().dot(q.rounding(s, x)) / std::abs(den);
    const bool settled = std::abs(next - s) <= std::max(4 * eps * std::abs(next), 4 * noise);
    s = next;
    if (settled) return true;
  }
  return false;
}
}  // namespace

ModalResult solve_first_order(const MatrixX& M, const MatrixX& K, const MatrixX& C, const Cholesky& mass,
                              const MatrixX& K_error, const MatrixX& K_systematic_error, const MatrixX& C_error,
                              const MatrixX& C_rounding, const SparseMatrix& K_rounding_form) {
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
  // The rounding of the data is the data term's (below), not a floor of η:
  // η is the computed pair's backward error only, at least ε.
  // L = M⁻¹ Y_vᵀ, one column per eigenvalue: l with lᵀQ(s) = 0 (the
  // conjugate of Q's left eigenvector; lᵀQ'(s)x = w yᴴz). The data's
  // entrywise errors: E_K (the rounding part of K_error, or 4ε|K|), 4ε|C|,
  // 4ε|M|; the measured, systematic ones of K and C; and the Frobenius norm
  // of the δA each makes, for the Hölder form at a defective eigenvalue.
  const Eigen::MatrixXcd Yv = Y.rightCols(n).transpose();  // n × 2n
  Eigen::MatrixXcd L(n, 2 * n);
  L.real() = mass.solve(MatrixX(Yv.real()));
  L.imag() = mass.solve(MatrixX(Yv.imag()));
  const bool has_K_systematic = K_systematic_error.rows() == n && K_systematic_error.cols() == n;
  const bool has_C_error = C_error.rows() == n && C_error.cols() == n;
  const bool has_K_error = K_error.rows() == n && K_error.cols() == n;
  const MatrixX EK = has_K_error ? (has_K_systematic ? MatrixX((K_error - K_systematic_error).cwiseMax(0.0)) : K_error)
                                 : MatrixX(4 * eps * K.cwiseAbs());
  const MatrixX EC = C_rounding.rows() == n && C_rounding.cols() == n ? C_rounding : MatrixX(4 * eps * C.cwiseAbs());
  const MatrixX EM = 4 * eps * M.cwiseAbs();
  double systematic_A = 0;
  if (has_K_systematic) systematic_A += mass.solve(K_systematic_error).norm() / w;
  if (has_C_error) systematic_A += mass.solve(C_error).norm();
  double data_A = -1;  // computed where first needed (three solves with M)
  auto holder_data = [&] {
    if (data_A < 0)
      data_A = mass.solve(EK).norm() / w + mass.solve(EC).norm() + mass.solve(EM).norm() * (MinvK.norm() / w + MinvC.norm());
    return std::sqrt(data_A * normA);
  };

  // |l|ᵀ(E_K + |s|E_C + |s|²E_M)|x| / |lᵀQ'(s)x|: how far the entries'
  // errors can move s, to first order; `systematic` the same for the
  // measured errors. Infinite (a defective eigenvalue) → the Hölder form.
  // `decision`: the data's share at its worst, for the kinds (the header's
  // "Kinds"); K's part through the rounding form F where given.
  struct Terms {
    double data = 0, systematic = 0, decision = 0;
  };
  const bool form = K_rounding_form.rows() == n && K_rounding_form.cols() == n;
  // √(vᵀFv), F positive semidefinite up to rounding.
  auto form_root = [&](const VectorX& v) { return std::sqrt(std::max(0.0, v.dot(K_rounding_form * v))); };
  auto terms = [&](Complex s, const Eigen::VectorXcd& x, const Eigen::VectorXcd& l, double den) {
    const VectorX absx = x.cwiseAbs(), absl = l.cwiseAbs();
    const double a = std::abs(s);
    Terms t;
    // At the typical size of independent entry errors, doubled (as
    // symmetric.cpp's typical_quotient_rounding): (Σ_ij (l_i e_ij x_j)²)^½ ≤
    // ‖|l|∘(e|x|)‖₂, Cauchy–Schwarz by rows, with e = E/4, an entry's
    // typical error a quarter of its bound (ε, two units of rounding, where
    // the bound is 4ε; the point-mass chain's estimate also takes K_error/4
    // per entry). Never below a quarter of the worst case, the errors'
    // linear sum at that size: entries computed alike round alike and need
    // not average out (symmetric.cpp's chain estimate).
    const VectorX moved_by_rest = a * (EC * absx) + (a * a) * (EM * absx);
    const VectorX moved_by_data = EK * absx + moved_by_rest;
    const double worst = absl.dot(moved_by_data);
    t.data = std::max(0.25 * worst, 0.5 * absl.cwiseProduct(moved_by_data).norm()) / den;
    t.decision = worst / den;
    if (form) {
      // −4εF ≤ δK ≤ 4εF makes |uᵀδKv| ≤ 4ε√(uᵀFu · vᵀFv) for real u, v;
      // with l = l_r + i l_i and x = x_r + i x_i, |lᵀδKx| ≤ 4ε(√(l_rᵀFl_r) +
      // √(l_iᵀFl_i))(√(x_rᵀFx_r) + √(x_iᵀFx_i)). It holds the positions'
      // rounding, which the entrywise E_K does not.
      const double K_part = 4 * eps * (form_root(l.real()) + form_root(l.imag())) *
                            (form_root(x.real()) + form_root(x.imag()));
      t.decision = (K_part + absl.dot(moved_by_rest)) / den;
      t.data = std::min(t.data, t.decision);
    }
    if (!std::isfinite(t.data)) t.data = holder_data();
    if (!std::isfinite(t.decision)) t.decision = holder_data();
    if (has_K_systematic || has_C_error) {
      VectorX moved = VectorX::Zero(n);
      if (has_K_systematic) moved += K_systematic_error * absx;
      if (has_C_error) moved += a * (C_error * absx);
      t.systematic = absl.dot(moved) / den;
      t.systematic = std::isfinite(t.systematic) ? std::min(t.systematic, std::sqrt(systematic_A * normA))
                                                 : std::sqrt(systematic_A * normA);
    }
    return t;
  };

  struct Pair {
    Complex s;
    Eigen::VectorXcd x, l;
    double solver = 0;  // the eigen-solver's share of the estimate
    Terms t;
    bool holder = false;  // the solver's share is the Hölder form (κ infinite or that smaller)
  };
  std::vector<Pair> pairs;
  double worst_backward = 0;
  for (Eigen::Index i = 0; i < 2 * n; ++i) {
    const Complex s = values(i);
    if (s.imag() < 0) continue;  // the conjugate of a reported pair
    const Eigen::VectorXcd z = Z.col(i);
    Pair p{s, z.head(n), L.col(i), 0, {}, false};

    const double eta_A = (Ac * z - s * z).norm() / (normA * z.norm());
    const double q_scale = (std::norm(s) * normM + std::abs(s) * normC + normK) * p.x.norm();
    const double eta_Q = q_scale > 0 ? quadratic(Mc, Cc, Kc, s).lazyProduct(p.x).norm() / q_scale : 0.0;
    const double eta = std::max({eta_A, eta_Q, eps});
    worst_backward = std::max(worst_backward, std::max(eta_A, eta_Q));

    const Complex yz = (Y.row(i) * z).value();  // yᴴz: row i of Z⁻¹ times z (1 up to rounding)
    const double kappa = Y.row(i).norm() * z.norm() / std::abs(yz);
    const double first_order = eta * normA * kappa;
    const double holder = std::sqrt(eta) * normA;
    p.holder = !(std::isfinite(first_order) && first_order <= holder);
    p.solver = p.holder ? holder : first_order;
    p.t = terms(s, p.x, p.l, w * std::abs(yz));
    pairs.push_back(std::move(p));
  }

  // Refinement of unresolved modes (see the header): where the eigen-
  // solver's share exceeds 10 × what the data justify, inverse iteration on
  // Q from the computed pair (refine_pair), worst first, within about
  // max(3e8, 4n³) flops (8 complex LU factorizations per mode). The refined
  // pair's solver share is its residual's, ‖l‖(‖Q(s)x‖ + ε‖(|K| + |s||C| +
  // |s|²|M|)|x|‖) / |lᵀQ'(s)x| (a backward error moves s by at most that, to
  // first order). Kept only when that is smaller than before, the new value
  // lies within both estimates of the old one, and no pair kept before holds
  // it within their estimates. A real value that does not refine as a real
  // one is tried as a complex pair (start s + i|s|): the solver can split a
  // lightly damped pair of small |s| into two real values ±a within their
  // estimates; the pair then replaces both, the other being the nearest
  // unresolved real value whose estimate holds it.
  {
    Quadratic q{Mc, Cc, Kc, M.cwiseAbs(), C.cwiseAbs(), K.cwiseAbs()};
    auto error_of = [](const Pair& p) { return p.solver + p.t.data + p.t.systematic; };
    // Two pairs are told apart when their values lie further apart than their estimates together.
    auto apart = [&](const Pair& a, const Pair& b) { return std::abs(a.s - b.s) > error_of(a) + error_of(b); };
    std::vector<std::size_t> candidates, tighten;
    // Unresolved: the solver's share over 10 × the data's. Also tried (with
    // their own start only): estimates over 1e6 ε|s|, whose data term came
    // from the solver's vectors (A's left ones are not accurate in a graded
    // scene) and falls with accurate ones. Then, within about the eigen-
    // solve's own cost (25(2n)³ flops for A's Schur form and vectors, 9 modes
    // at 8 factorizations each; at least 3e6 flops, every mode of a scene of
    // up to about 16 coordinates), isolated modes whose normwise share η‖A‖κ is merely
    // over 2ε|s|: a refined pair's share is its own residual's, nearer what
    // the solver left (the bundled damped, follower and gyroscopic scenes:
    // 2.5–16 ε|s| normwise against true errors of at most 2ε|s|).
    auto solver_bound = [&](const Pair& p) {
      return p.solver > 10 * (p.t.data + p.t.systematic + eps * std::abs(p.s));
    };
    // A pair near another (within 100 × its estimate) or at a defective
    // eigenvalue (the Hölder form) is not tightened: a refined pair's share,
    // its residual's to first order, needs a simple, separated eigenvalue.
    auto isolated = [&](std::size_t k) {
      for (std::size_t j = 0; j < pairs.size(); ++j)
        if (j != k && std::abs(pairs[j].s - pairs[k].s) <= 100 * error_of(pairs[k])) return false;
      return !pairs[k].holder;
    };
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      const double size = eps * std::abs(pairs[k].s);
      if (solver_bound(pairs[k]) || error_of(pairs[k]) > 1e6 * size)
        candidates.push_back(k);
      else if (pairs[k].solver > 2 * size && isolated(k))
        tighten.push_back(k);
    }
    auto excess = [&](std::size_t k) {
      const Pair& p = pairs[k];
      return p.solver / (p.t.data + p.t.systematic + eps * std::abs(p.s) + std::numeric_limits<double>::min());
    };
    auto by_excess = [&](std::size_t a, std::size_t b) { return excess(a) > excess(b); };
    std::stable_sort(candidates.begin(), candidates.end(), by_excess);
    std::stable_sort(tighten.begin(), tighten.end(), by_excess);
    const double nd = static_cast<double>(n), per_mode = 8 * 4 * (2.0 / 3.0) * nd * nd * nd;
    const auto budget = static_cast<std::size_t>(std::max(1.0, std::max(3e8, 4 * nd * nd * nd) / per_mode));
    if (candidates.size() > budget) candidates.resize(budget);
    const auto tighten_budget = static_cast<std::size_t>(std::max(3e6, 25 * 8 * nd * nd * nd) / per_mode);
    if (tighten.size() > tighten_budget) tighten.resize(tighten_budget);
    std::vector<std::size_t> kept;
    std::vector<bool> removed(pairs.size(), false), unresolved(pairs.size(), false);
    for (const std::size_t k : candidates) unresolved[k] = solver_bound(pairs[k]);
    // A refined pair's shares: s is an exact eigenvalue of Q − r xᴴ/‖x‖²
    // (r = Q(s)x), which moves it by lᵀr / lᵀQ'(s)x to first order (the
    // next Newton step); to that, the rounding of lᵀr, |l|ᵀε(|K| + |s||C| +
    // |s|²|M|)|x| / |lᵀQ'(s)x|. Not ‖l‖‖r‖: the solves are accurate
    // normwise, so r is of the size of ε × the largest entries of Q, nearly
    // all of it along directions l does not see.
    auto analyze_refined = [&](Pair& r) {
      const double den = std::abs((r.l.transpose() * (derivative(Mc, Cc, r.s) * r.x)).value());
      const Eigen::VectorXcd residual = quadratic(Mc, Cc, Kc, r.s).lazyProduct(r.x);
      r.solver = (std::abs((r.l.transpose() * residual).value()) + r.l.cwiseAbs().dot(q.rounding(r.s, r.x))) / den;
      r.t = terms(r.s, r.x, r.l, den);
    };
    // The refined pair from the start s (vectors x and l), if it is kept by
    // the rules above. While tightening, apart from every other pair, not
    // only the refined ones: the others' estimates are small there too, and
    // inverse iteration must not have moved to a neighbour.
    bool tightening = false;
    auto attempt = [&](std::size_t k, Complex s, bool real, const Eigen::VectorXcd& x,
                       const Eigen::VectorXcd& l) -> std::optional<Pair> {
      Pair r{s, x, l, 0, {}, false};
      if (!refine_pair(q, real, r.s, r.x, r.l)) return std::nullopt;  // a real start stays real
      analyze_refined(r);
      const double new_error = error_of(r);
      if (!(new_error < error_of(pairs[k])) || !(std::abs(r.s - pairs[k].s) <= error_of(pairs[k]) + new_error))
        return std::nullopt;
      if (pairs[k].s.imag() > 0 && !(r.s.imag() > 0)) return std::nullopt;  // a pair stays a pair
      for (const std::size_t j : kept)
        if (!apart(r, pairs[j])) return std::nullopt;
      if (tightening)
        for (std::size_t j = 0; j < pairs.size(); ++j)
          if (j != k && !removed[j] && !apart(r, pairs[j])) return std::nullopt;
      return r;
    };
    // Refines mode k from a start; a real mode refined to a complex pair
    // takes its partner (above) with it. True when kept.
    auto refine = [&](std::size_t k, Complex start, const Eigen::VectorXcd& x, const Eigen::VectorXcd& l) {
      std::optional<Pair> r = attempt(k, start, start.imag() == 0, x, l);
      if (!r) return false;
      std::size_t partner = pairs.size();
      if (pairs[k].s.imag() == 0 && r->s.imag() > 0) {
        for (std::size_t j = 0; j < pairs.size(); ++j)
          if (j != k && !removed[j] && unresolved[j] && pairs[j].s.imag() == 0 &&
              std::abs(pairs[j].s - r->s) <= error_of(pairs[j]) &&
              (partner == pairs.size() || std::abs(pairs[j].s - r->s) < std::abs(pairs[partner].s - r->s)))
            partner = j;
        if (partner == pairs.size()) return false;
        removed[partner] = true;
      }
      pairs[k] = std::move(*r);
      kept.push_back(k);
      return true;
    };
    for (const std::size_t k : candidates)
      if (!removed[k]) refine(k, pairs[k].s, pairs[k].x, pairs[k].l);
    tightening = true;
    for (const std::size_t k : tighten)
      if (!removed[k]) refine(k, pairs[k].s, pairs[k].x, pairs[k].l);
    tightening = false;
    // What is left, as a group: the reversed problem μ²K + μC + M = 0
    // (μ = 1/s), solved the same way, has a normwise error relative to the
    // largest 1/|s|, so it resolves the small |s| that A's cannot. Its values
    // that lie within the group's estimates and near no other pair replace
    // the group, refined as above, when they are as many (conjugates
    // counted) and all refine to distinct values: the solver may have split
    // a lightly damped pair of small |s| into two real values ±a, or merged
    // two, so the group is replaced whole.
    std::vector<std::size_t> group;
    for (const std::size_t k : candidates)
      if (!removed[k] && unresolved[k] && std::find(kept.begin(), kept.end(), k) == kept.end()) group.push_back(k);
    if (!group.empty()) {
      const Eigen::PartialPivLU<MatrixX> stiffness(K);
      const MatrixX KinvM = stiffness.solve(M), KinvC = stiffness.solve(C);
      const double v0 = std::sqrt(KinvM.norm());
      if (KinvM.allFinite() && KinvC.allFinite() && v0 > 0 && std::isfinite(v0)) {
        MatrixX B = MatrixX::Zero(2 * n, 2 * n);
        B.topRightCorner(n, n).diagonal().setConstant(v0);
        B.bottomLeftCorner(n, n) = -KinvM / v0;
        B.bottomRightCorner(n, n) = -KinvC;
        const Eigen::EigenSolver<MatrixX> reversed(B, true);
        // Every other pair claims the reversed value nearest it (a complex
        // pair also the one nearest its conjugate); what is left must lie
        // within the group's estimates.
        std::vector<Complex> values(static_cast<std::size_t>(2 * n));
        std::vector<bool> claimed(values.size(), reversed.info() != Eigen::Success);
        for (Eigen::Index j = 0; j < 2 * n; ++j) {
          const Complex mu = reversed.eigenvalues()(j);
          values[static_cast<std::size_t>(j)] = mu.imag() == 0 ? Complex(1.0 / mu.real(), 0.0) : 1.0 / mu;
        }
        // The reversed values are accurate where ε‖B‖|s| is small (δμ ≈
        // ε‖B‖, δs = |s|²δμ); the large ones are noise. Matching, closest
        // (relative) first: the other pairs take (1) accurate values within
        // 1e-3 of themselves, then (2) noise and values outside the group's
        // estimates, then (3) whatever is left.
        {
          const double normB = B.norm();
          auto inside_group = [&](Complex v) {
            for (const std::size_t k : group)
              if (std::abs(Complex(v.real(), std::abs(v.imag())) - pairs[k].s) <= error_of(pairs[k])) return true;
            return false;
          };
          std::vector<Complex> others;
          for (std::size_t k = 0; k < pairs.size(); ++k) {
            if (removed[k] || std::find(group.begin(), group.end(), k) != group.end()) continue;
            others.push_back(pairs[k].s);
            if (pairs[k].s.imag() > 0) others.push_back(std::conj(pairs[k].s));
          }
          std::vector<std::pair<double, std::pair<std::size_t, std::size_t>>> distances;
          for (std::size_t i = 0; i < others.size(); ++i)
            for (std::size_t j = 0; j < values.size(); ++j)
              distances.push_back({std::abs(values[j] - others[i]) / std::max(std::abs(others[i]), std::abs(values[j])),
                                   {i, j}});
          std::sort(distances.begin(), distances.end());
          // Phase 3 by the distance of magnitudes, |log|v| − log|s||: noise
          // keeps the order of magnitude better than the value.
          auto magnitudes = distances;
          for (auto& [d, ij] : magnitudes)
            d = std::abs(std::log(std::abs(values[ij.second]) + std::numeric_limits<double>::min()) -
                         std::log(std::abs(others[ij.first]) + std::numeric_limits<double>::min()));
          std::sort(magnitudes.begin(), magnitudes.end());
          std::vector<bool> matched(others.size(), false);
          for (int phase = 1; phase <= 3; ++phase)
            for (const auto& [d, ij] : phase == 3 ? magnitudes : distances) {
              if (matched[ij.first] || claimed[ij.second]) continue;
              const Complex v = values[ij.second];
              const bool accurate = eps * normB * std::abs(v) < 1e-4;
              if (phase == 1 && !(accurate && d < 1e-3)) continue;
              if (phase == 2 && accurate && inside_group(v)) continue;
              matched[ij.first] = claimed[ij.second] = true;
            }
        }
        std::vector<Eigen::Index> starts;  // Im s ≥ 0
        bool inside_all = true;
        for (std::size_t j = 0; j < values.size(); ++j) {
          if (claimed[j]) continue;
          bool inside = false;
          for (const std::size_t k : group)
            inside = inside || std::abs(Complex(values[j].real(), std::abs(values[j].imag())) - pairs[k].s) <= error_of(pairs[k]);
          inside_all = inside_all && inside && std::isfinite(std::abs(values[j]));
          if (values[j].imag() >= 0) starts.push_back(static_cast<Eigen::Index>(j));
        }
        std::vector<Pair> replacement;
        bool whole = inside_all && reversed.info() == Eigen::Success;
        for (std::size_t i = 0; whole && i < starts.size(); ++i) {
          const Complex start = values[static_cast<std::size_t>(starts[i])];
          const bool real = start.imag() == 0;
          Pair r{start, reversed.eigenvectors().col(starts[i]).head(n), {}, 0, {}, false};
          r.l = r.x;
          whole = refine_pair(q, real, r.s, r.x, r.l) && (real || r.s.imag() > 0);
          if (!whole) {  // a member the solver had as this value already keeps its own pair
            for (const std::size_t k : group)
              if (!whole && (real ? pairs[k].s.imag() == 0 : pairs[k].s.imag() > 0) &&
                  std::abs(start - pairs[k].s) <= error_of(pairs[k])) {
                r = pairs[k];
                whole = true;
              }
          }
          if (!whole) break;
          analyze_refined(r);
          for (const Pair& o : replacement) whole = whole && apart(r, o);
          for (std::size_t j = 0; j < pairs.size(); ++j)  // distinct from every other pair, and within the group's estimates
            if (!removed[j] && std::find(group.begin(), group.end(), j) == group.end()) whole = whole && apart(r, pairs[j]);
          bool inside = false;
          for (const std::size_t k : group) inside = inside || std::abs(r.s - pairs[k].s) <= error_of(pairs[k]);
          whole = whole && inside;
          replacement.push_back(std::move(r));
        }
        if (whole && !replacement.empty()) {
          for (const std::size_t k : group) removed[k] = true;
          for (Pair& r : replacement) {
            pairs.push_back(std::move(r));
            removed.push_back(false);
          }
        }
      }
    }
    std::vector<Pair> left;
    for (std::size_t k = 0; k < pairs.size(); ++k)
      if (!removed[k]) left.push_back(std::move(pairs[k]));
    pairs = std::move(left);
  }

  ModalResult result;
  result.solver = "dense first-order 2n×2n (Eigen: Cholesky solves with M, real Schur EigenSolver, "
                  "left eigenvectors from the inverse eigenvector matrix)";
  for (Pair& p : pairs) {
    // Kinds with the data's share at its worst; a zero mode's estimate is
    // that level, every other mode's the typical one.
    const double decision = p.solver + p.t.decision + p.t.systematic;
    const ModeKind kind = kind_of(p.s, decision);
    const double error = kind == ModeKind::zero ? decision : p.solver + p.t.data + p.t.systematic;
    Mode mode = make_mode(p.s, error, kind);
    mode.systematic_error = p.t.systematic;
    const int multiplicity = p.s.imag() > 0 ? 2 : 1;  // eigenvalues of A this entry stands for
    if (kind == ModeKind::divergent) result.morse_index += multiplicity;
    if (kind == ModeKind::zero) result.zero_modes += multiplicity;

    Eigen::VectorXcd shape = std::move(p.x);
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
