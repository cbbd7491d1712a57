// The long double reference of a tree's modes (tests/test_graded.cpp,
// tests/test_tree.cpp): M and ∇∇V of the same templated model evaluated in
// long double by forward-mode AD, and the pencil solved by Eigen in long
// double, never by modal's double path.
#pragma once
#include "core/model.hpp"
#include "modal/ad.hpp"
#include "modal/core.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <vector>

namespace {

using namespace modal;
using LD = long double;
using MatLD = Eigen::Matrix<LD, Eigen::Dynamic, Eigen::Dynamic>;
using VecLD = Eigen::Matrix<LD, Eigen::Dynamic, 1>;

// The reference basis θ, q = Tθ (T an integer matrix, exact): a rotational
// coordinate (hinge or rotation-vector component; the generated bodies have
// no orientation, so at q = 0 the world axes are the joints' own) is measured
// from the nearest coordinate above its body turning about the same axis,
// q_k = θ_k − θ_j, whatever joints lie between. In relative angles a short
// link before a long one makes M singular to (l_short/l_long)² — below long
// double's ε too (1e-24 for the families below) — while in θ the pencil is as
// well conditioned as the links. Decided here from the scene description, not
// by modal.
inline MatLD reference_basis(const System& s) {
  const int n = s.size();
  MatLD T = MatLD::Identity(n, n);
  auto axes = [&](int b) {  // world rotation axis of each coordinate of body b at q = 0 (zero: a translation)
    const Body& body = s.bodies()[static_cast<std::size_t>(b)];
    std::vector<Vec3> a;
    if (body.joint == JointType::hinge) a.push_back(body.axis);
    if (body.joint == JointType::slide) a.push_back(Vec3::Zero());
    if (body.joint == JointType::ball)
      for (int i = 0; i < 3; ++i) a.push_back(Vec3::Unit(i));
    return a;
  };
  for (int b = 0; b < static_cast<int>(s.bodies().size()); ++b) {
    const auto mine = axes(b);
    for (std::size_t i = 0; i < mine.size(); ++i) {
      if (mine[i].isZero()) continue;
      bool found = false;
      for (int p = s.bodies()[static_cast<std::size_t>(b)].parent; p >= 0 && !found;
           p = s.bodies()[static_cast<std::size_t>(p)].parent) {
        const auto theirs = axes(p);
        for (std::size_t j = 0; j < theirs.size() && !found; ++j)
          if (mine[i] == theirs[j]) {
            T(s.first_coordinate(b) + static_cast<int>(i), s.first_coordinate(p) + static_cast<int>(j)) = -1;
            found = true;
          }
      }
    }
  }
  return T;
}

// M and ∇∇V at q in the basis θ (q = Tθ), in long double. M = Σ_b m J_vᵀJ_v
// + J_ωᵀ(R I Rᵀ)J_ω from the Jacobians of each body's centre of mass and
// rotation, obtained by forward-mode AD of the templated forward kinematics
// with the seeds Tθ (independent of modal's composite-inertia mass matrix);
// ∇∇V by nested duals of the templated potential with the same seeds.
inline void reference_pencil(const System& s, const VectorX& q, const MatLD& T, MatLD& M, MatLD& K) {
  const int n = s.size();
  const auto nb = s.bodies().size();
  using D1 = Dual<LD, 1>;
  std::vector<MatLD> Jv(nb, MatLD::Zero(3, n)), Jw(nb, MatLD::Zero(3, n));
  model::TreeState<D1> st;
  for (int i = 0; i < n; ++i) {
    std::vector<D1> qd(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) {
      qd[static_cast<std::size_t>(k)] = D1(static_cast<LD>(q[k]));
      qd[static_cast<std::size_t>(k)].d[0] = T(k, i);
    }
    model::forward_kinematics(s, qd.data(), st);
    for (std::size_t b = 0; b < nb; ++b) {
      const model::V3<D1> x = st.position[b] + st.rotation[b] * model::cast3<D1>(s.bodies()[b].com);
      model::M3<LD> R, Rdot;
      for (int r = 0; r < 3; ++r) {
        Jv[b](r, i) = x[r].d[0];
        for (int c = 0; c < 3; ++c) {
          R(r, c) = st.rotation[b](r, c).v;
          Rdot(r, c) = st.rotation[b](r, c).d[0];
        }
      }
      const model::M3<LD> W = Rdot * R.transpose();  // ω̂
      Jw[b](0, i) = W(2, 1);
      Jw[b](1, i) = W(0, 2);
      Jw[b](2, i) = W(1, 0);
    }
  }
  std::vector<LD> ql(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) ql[static_cast<std::size_t>(i)] = q[i];
  model::TreeState<LD> sl;
  model::forward_kinematics(s, ql.data(), sl);
  M = MatLD::Zero(n, n);
  for (std::size_t b = 0; b < nb; ++b) {
    const Body& body = s.bodies()[b];
    MatLD I(3, 3);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) I(r, c) = body.inertia(r, c);
    const MatLD R = sl.rotation[b];
    M += static_cast<LD>(body.mass) * Jv[b].transpose() * Jv[b] + Jw[b].transpose() * (R * I * R.transpose()) * Jw[b];
  }
  MatLD A = MatLD::Zero(n, n);  // joint armatures: ½a|q̇_joint|² (J_l = I at φ = 0)
  for (std::size_t b = 0; b < nb; ++b)
    for (int i = 0; i < s.joint_size(static_cast<int>(b)); ++i)
      A(s.first_coordinate(static_cast<int>(b)) + i, s.first_coordinate(static_cast<int>(b)) + i) =
          s.bodies()[b].armature;
  M += T.transpose() * A * T;
  using D = Dual<Dual<LD, 1>, 1>;
  K.resize(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j <= i; ++j) {
      model::VX<D> qd(n);
      for (int k = 0; k < n; ++k) {
        qd[k] = D(Dual<LD, 1>(ql[static_cast<std::size_t>(k)]));
        qd[k].v.d[0] = T(k, i);
        qd[k].d[0].v = T(k, j);
      }
      model::TreeState<D> sd;
      model::forward_kinematics(s, qd.data(), sd);
      K(i, j) = K(j, i) = model::potential(s, sd, qd.data()).d[0].d[0];
    }
}

// The ω² of K φ = λ M φ in the reference basis, solved in long double by
// Eigen. The pencil is scaled by diag(M)^{-1/2} before the solve.
inline std::vector<LD> reference_omega2(const System& s, const VectorX& q) {
  const int n = s.size();
  MatLD M, K;
  reference_pencil(s, q, reference_basis(s), M, K);
  VecLD d(n);
  for (int i = 0; i < n; ++i) d[i] = 1 / std::sqrt(M(i, i));
  const MatLD Ms = d.asDiagonal() * M * d.asDiagonal(), Ks = d.asDiagonal() * K * d.asDiagonal();
  // The solver's eigenvalues are accurate normwise, to ε_LD·‖λ‖_max: 1e-14
  // absolute when ω² spans 1e-6 … 1e5, a relative 5e-9 on the small root
  // (measured: a ball-and-slide chain, 2.79186494793e-6 against the closed
  // form 2.79186494123397e-6, which modal's double path matched). Each pair
  // is refined by inverse iteration in long double with the Rayleigh
  // quotient as shift (whose error is the square of the vector's) until the
  // quotient settles (16 ε_LD relative; at least two steps, at most twelve).
  // Two fixed steps left a close pair of a graded ball chain mixed (on
  // disjoint coordinates, 7.74467e-3 and 7.77425e-3: 7.74758e-3 for the
  // first), where the solver's normwise error (ε_LD × 7e21) had scrambled
  // the start. Before each solve the iterate is made M-orthogonal to the
  // vectors already refined (as LAPACK's dstein does within a cluster):
  // without it, two starts of a graded spring chain converged to one
  // eigenvalue, 5.1146e-11 twice, and the lowest, 9.5588e-13 (mpmath at 60
  // digits on the same masses and springs), was missing.
  Eigen::GeneralizedSelfAdjointEigenSolver<MatLD> eig(Ks, Ms, Eigen::ComputeEigenvectors);
  std::vector<LD> out(static_cast<std::size_t>(n));
  std::vector<VecLD> found, found_M;  // the refined vectors so far, M-normalized, and M times them
  for (int j = 0; j < n; ++j) {
    VecLD x = eig.eigenvectors().col(j);
    LD lambda = eig.eigenvalues()[j];
    for (int step = 0; step < 12; ++step) {
      for (int pass = 0; pass < 2; ++pass)
        for (std::size_t k = 0; k < found.size(); ++k) x -= found_M[k].dot(x) * found[k];
      const Eigen::PartialPivLU<MatLD> lu(Ks - lambda * Ms);  // no rank decision: a huge y is the point
      const VecLD y = lu.solve(VecLD(Ms * x));
      if (!y.allFinite() || y.norm() == 0) break;
      x = y / y.norm();
      const LD next = x.dot(Ks * x) / x.dot(Ms * x);
      const bool settled = std::abs(next - lambda) <= 16 * std::numeric_limits<LD>::epsilon() * std::abs(next);
      lambda = next;
      if (step >= 1 && settled) break;
    }
    found.push_back(x / std::sqrt(x.dot(Ms * x)));
    found_M.push_back(Ms * found.back());
    out[static_cast<std::size_t>(j)] = lambda;
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The eigenvalues s of (s²M + sD + K)x = 0 (M, K symmetric, M positive
// definite; D any real matrix: dampers, and gyroscopic terms as its skew
// part), solved in long double: 2n values, complex pairs given once
// (Im s > 0), real ones each. Start: the companion matrix in the basis
// z = [x; s x / w] (w = √‖M⁻¹K‖, balancing its blocks), by Eigen's real
// Schur solver in long double, after scaling the pencil by diag(M)^{-1/2}.
// Its error is normwise (ε_LD‖A‖), too large for the small |s| of a graded
// scene, so each start is refined in complex long double: inverse iteration
// x ← Q(σ)⁻¹Q'(σ)x on the right and l ← Q(σ)⁻ᵀQ'(σ)ᵀl on the left, and σ
// the root nearest σ of lᵀQ(p)x = 0 (the two-sided Rayleigh functional),
// until σ settles (16 ε_LD relative, at most 12 steps). l starts as Q's left
// null vector from the companion's left eigenvector y (yᵀA = s yᵀ gives
// lᵀQ(s) = 0 for l = M⁻¹y_velocity), not as x: with a skew (gyroscopic) D,
// Q(p) is not symmetric, and from l = x the two vectors of a close pair (a
// splitting of 2Ω) converged to different members and σ went astray. The refined
// values must be distinct: two starts that converged to one eigenvalue
// return an empty vector (the caller fails).
inline std::vector<std::complex<LD>> reference_quadratic(const MatLD& M_in, const MatLD& K_in, const MatLD& D_in) {
  using C = std::complex<LD>;
  using MatC = Eigen::Matrix<C, Eigen::Dynamic, Eigen::Dynamic>;
  using VecC = Eigen::Matrix<C, Eigen::Dynamic, 1>;
  const Eigen::Index n = M_in.rows();
  VecLD d(n);
  for (Eigen::Index i = 0; i < n; ++i) d[i] = 1 / std::sqrt(M_in(i, i));
  const MatLD M = d.asDiagonal() * M_in * d.asDiagonal(), K = d.asDiagonal() * K_in * d.asDiagonal(),
              D = d.asDiagonal() * D_in * d.asDiagonal();
  const Eigen::LLT<MatLD> llt(M);
  const MatLD MinvK = llt.solve(K), MinvD = llt.solve(D);
  LD w = std::sqrt(MinvK.norm());
  if (!(w > 0) || !std::isfinite(w)) w = 1;
  MatLD A = MatLD::Zero(2 * n, 2 * n);
  A.topRightCorner(n, n).diagonal().setConstant(w);
  A.bottomLeftCorner(n, n) = -MinvK / w;
  A.bottomRightCorner(n, n) = -MinvD;
  // Balanced (Parlett and Reinsch: a diagonal similarity by powers of two
  // that evens each row's and column's off-diagonal norms), so that the
  // solver's normwise error is that of a graded scene's own scales.
  VecLD balance = VecLD::Ones(2 * n);
  for (int sweep = 0, changed = 1; changed && sweep < 100; ++sweep) {
    changed = 0;
    for (Eigen::Index i = 0; i < 2 * n; ++i) {
      const LD c = A.col(i).cwiseAbs().sum() - std::abs(A(i, i)), r = A.row(i).cwiseAbs().sum() - std::abs(A(i, i));
      if (!(c > 0) || !(r > 0)) continue;
      int e = 0;
      std::frexp(std::sqrt(r / c), &e);
      const LD f = std::ldexp(LD(1), e);
      if (!((c * f + r / f) < LD(0.95) * (c + r))) continue;  // only a clear gain (it ends)
      A.col(i) *= f;
      A.row(i) /= f;
      balance[i] *= f;
      changed = 1;
    }
  }
  const Eigen::EigenSolver<MatLD> eig(A, true);
  const MatC Mc = M.cast<C>(), Kc = K.cast<C>(), Dc = D.cast<C>();
  const MatC left = eig.eigenvectors().partialPivLu().inverse();  // rows: the balanced A's left eigenvectors
  const MatC Minv = llt.solve(MatLD::Identity(n, n)).cast<C>();
  std::vector<C> out;
  for (Eigen::Index j = 0; j < 2 * n; ++j) {
    C s = eig.eigenvalues()[j];
    if (s.imag() < 0) continue;
    VecC x = (balance.cast<C>().asDiagonal() * eig.eigenvectors().col(j)).head(n);
    VecC l = Minv * VecC((balance.cast<C>().cwiseInverse().asDiagonal() * left.row(j).transpose()).tail(n));
    for (int step = 0; step < 12; ++step) {
      const Eigen::PartialPivLU<MatC> lu(MatC(s * s * Mc + s * Dc + Kc));
      const MatC dQ = LD(2) * s * Mc + Dc;
      const VecC y = lu.solve(VecC(dQ * x)), z = lu.transpose().solve(VecC(dQ.transpose() * l));
      if (!y.allFinite() || y.norm() == 0 || !z.allFinite() || z.norm() == 0) break;
      x = y / y.norm();
      l = z / z.norm();
      const C a = l.transpose() * Mc * x, b = l.transpose() * Dc * x, c = l.transpose() * Kc * x;
      const C root = std::sqrt(b * b - LD(4) * a * c);
      // The two roots without cancellation: q = −(b + sign·root)/2, p₁ = q/a, p₂ = c/q.
      const C q = -(b + (std::real(std::conj(b) * root) >= 0 ? root : -root)) / LD(2);
      const C p1 = q / a, p2 = q != C(0) ? c / q : p1;
      const C next = std::abs(p1 - s) <= std::abs(p2 - s) ? p1 : p2;
      const bool settled = std::abs(next - s) <= 16 * std::numeric_limits<LD>::epsilon() * std::abs(next);
      s = next;
      if (step >= 1 && settled) break;
    }
    if (eig.eigenvalues()[j].imag() == 0) s = s.real();  // a real start stays real (real Q: its null vector is real)
    out.push_back(s);
  }
  for (std::size_t i = 0; i < out.size(); ++i)
    for (std::size_t k = 0; k < i; ++k)
      if (std::abs(out[i] - out[k]) <= 1e-12L * std::abs(out[i])) return {};
  return out;
}

}  // namespace
