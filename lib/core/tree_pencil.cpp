// Products and LDLᵀ factorizations of αK + βM + γI of a tree in O(bodies)
// (modal/core.hpp, TreePencil; docs/design.md, "Matrix-free path").
//
// Notation: for a coordinate j at or above k (k of body b), H_jk = ξ_jᵀ A_b ξ_k
// with both twists about p_b and A_b = αK_b + βM_b (composite). A twist about
// the parent's joint centre moves to p_b by X(d) = [[I, 0], [−d̂, I]] (d the
// body's offset: u' = u + ω × d), and a wrench-like vector back up by
// X(d)ᵀ = [[I, d̂], [0, I]] (τ' = τ + d × f); a 6×6 form A by X(d)ᵀ A X(d).
//
// Product y = Hx: leaves to root, Z_b = A_b ξ_b x_b + Σ_children X_cᵀ Z_c
// (the part of row k from the coordinates at or below it is ξ_kᵀ Z_b); root to
// leaves, the parent's twist sum V carried down (V_b = X_b V_parent + ξ_b x_b),
// and the part from the coordinates above k is (A_b ξ_k)ᵀ X_b V_parent.
//
// Factorization (the articulated-body recursion, for any symmetric H of the
// ordered form): eliminating a leaf coordinate k with pivot d = ξ_kᵀ A ξ_k
// (+ its diagonal term) changes H_ij of two coordinates above it by
// −(ξ_iᵀU)(ξ_jᵀU)/d, U = Aξ_k: a symmetric form U Uᵀ/d that joins A of the
// deeper of i, j, i.e. of every ancestor, as the composite parts do. So with
// C_b = Σ_children X_cᵀ (C_c + U_c U_cᵀ/d_c) X_c the articulated A_b − C_b
// gives U_b and d_b, leaves first. Solves: the same elimination of the
// right-hand side (a bias β carried up), then back substitution root first.
#include "modal/core.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <stdexcept>

namespace modal {
namespace {

Mat3 hat3(const Vec3& v) {
  Mat3 h;
  h << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return h;
}

// X(d) ξ: a twist about the parent's joint centre, about the child's.
Vec6 twist_down(const Vec6& xi, const Vec3& d) {
  Vec6 out = xi;
  out.tail<3>() += xi.head<3>().cross(d);
  return out;
}
// X(d)ᵀ z: a wrench-like vector about the child's joint centre, about the parent's.
Vec6 wrench_up(const Vec6& z, const Vec3& d) {
  Vec6 out = z;
  out.head<3>() += d.cross(z.tail<3>());
  return out;
}
// X(d)ᵀ A X(d).
Mat6 form_up(const Mat6& A, const Vec3& d) {
  Eigen::Matrix<double, 6, 6> X = Eigen::Matrix<double, 6, 6>::Identity();
  X.block<3, 3>(3, 0) = -hat3(d);
  return X.transpose() * A * X;
}
// Magnitude versions: every term counted positive.
Vec6 twist_down_abs(const Vec6& xi, const Vec3& d) {
  Vec6 out = xi;
  out.tail<3>() += hat3(d).cwiseAbs() * xi.head<3>();
  return out;
}
Vec6 wrench_up_abs(const Vec6& z, const Vec3& d) {
  Vec6 out = z;
  out.head<3>() += hat3(d).cwiseAbs() * z.tail<3>();
  return out;
}

void check(const TreePencil& p) {
  const std::size_t nb = p.parent.size();
  if (p.coordinate.size() != nb || p.twist.size() != nb || p.offset.size() != nb || p.K.size() != nb ||
      p.M.size() != nb || p.M_diagonal.size() != p.K_diagonal.size())
    throw std::invalid_argument("TreePencil: inconsistent sizes");
}

}  // namespace

namespace {

// The product recursion (header comment) for the columns u_b = A_b ξ_b and
// the joints' own terms; with `magnitude` every term counted positive (the
// caller passes |ξ|, |u|, |x|).
void product(const TreePencil& p, const std::vector<Vec6>& twist, const std::vector<Vec6>& u,
             const VectorX& diagonal, const double* x, double* y, std::vector<Vec6>& Z, std::vector<Vec6>& V,
             bool magnitude) {
  const std::size_t nb = p.parent.size();
  Z.assign(nb, Vec6::Zero());
  V.resize(nb);
  for (std::size_t c = nb; c-- > 0;) {
    const int k = p.coordinate[c];
    if (k >= 0) Z[c] += u[c] * x[k];
    if (p.parent[c] >= 0) {
      const auto up = static_cast<std::size_t>(p.parent[c]);
      Z[up] += magnitude ? wrench_up_abs(Z[c], p.offset[c]) : wrench_up(Z[c], p.offset[c]);
    }
  }
  for (std::size_t c = 0; c < nb; ++c) {
    Vec6 above = Vec6::Zero();
    if (p.parent[c] >= 0) {
      const Vec6& Vp = V[static_cast<std::size_t>(p.parent[c])];
      above = magnitude ? twist_down_abs(Vp, p.offset[c]) : twist_down(Vp, p.offset[c]);
    }
    const int k = p.coordinate[c];
    if (k >= 0) {
      y[k] = twist[c].dot(Z[c]) + u[c].dot(above) + diagonal[k] * x[k];
      above += twist[c] * x[k];
    }
    V[c] = above;
  }
}

// u_b = A_b ξ_b and the joints' own terms of αK + βM; with `magnitude`
// |α||K_b| + |β||M_b| times |ξ_b| and |α||k| + |β||a|.
void columns(const TreePencil& p, double alpha, double beta, bool magnitude, std::vector<Vec6>& u,
             VectorX& diagonal) {
  const std::size_t nb = p.parent.size();
  u.assign(nb, Vec6::Zero());
  diagonal.setZero(p.size());
  for (std::size_t c = 0; c < nb; ++c) {
    const int k = p.coordinate[c];
    if (k < 0) continue;
    if (magnitude) {
      u[c] = (std::abs(alpha) * p.K[c].cwiseAbs() + std::abs(beta) * p.M[c].cwiseAbs()) * p.twist[c].cwiseAbs();
      diagonal[k] = std::abs(alpha) * std::abs(p.K_diagonal[k]) + std::abs(beta) * std::abs(p.M_diagonal[k]);
    } else {
      u[c] = (alpha * p.K[c] + beta * p.M[c]) * p.twist[c];
      diagonal[k] = alpha * p.K_diagonal[k] + beta * p.M_diagonal[k];
    }
  }
}

}  // namespace

VectorX tree_product(const TreePencil& p, double alpha, double beta, const VectorX& x, bool magnitude) {
  check(p);
  if (x.size() != p.size()) throw std::invalid_argument("tree_product: x has the wrong size");
  std::vector<Vec6> u, Z, V;
  VectorX diagonal;
  columns(p, alpha, beta, magnitude, u, diagonal);
  VectorX y(p.size());
  if (!magnitude) {
    product(p, p.twist, u, diagonal, x.data(), y.data(), Z, V, false);
    return y;
  }
  std::vector<Vec6> twist(p.twist.size());
  for (std::size_t c = 0; c < twist.size(); ++c) twist[c] = p.twist[c].cwiseAbs();
  const VectorX a = x.cwiseAbs();
  product(p, twist, u, diagonal, a.data(), y.data(), Z, V, true);
  return y;
}

TreeProduct::TreeProduct(const TreePencil& p, double alpha, double beta) : p_(p) {
  check(p);
  columns(p, alpha, beta, false, u_, diagonal_);
}

void TreeProduct::apply(const double* x, double* y) const { product(p_, p_.twist, u_, diagonal_, x, y, z_, v_, false); }

VectorX tree_diagonal(const TreePencil& p, double alpha, double beta) {
  check(p);
  VectorX d(p.size());
  for (std::size_t b = 0; b < p.parent.size(); ++b) {
    const int k = p.coordinate[b];
    if (k < 0) continue;
    d[k] = p.twist[b].dot((alpha * p.K[b] + beta * p.M[b]) * p.twist[b]) + alpha * p.K_diagonal[k] +
           beta * p.M_diagonal[k];
  }
  return d;
}

bool TreeFactor::factor(const TreePencil& p, double alpha, double beta, double gamma) {
  check(p);
  p_ = &p;
  const std::size_t nb = p.parent.size();
  u_.assign(nb, Vec6::Zero());
  d_.setZero(p.size());
  negative_ = 0;
  first_nonpositive_ = -1;
  std::vector<Mat6> C(nb, Mat6::Zero());
  bool ok = true;
  for (std::size_t c = nb; c-- > 0;) {
    const int k = p.coordinate[c];
    Mat6 pass = C[c];
    if (k >= 0) {
      const Mat6 A = alpha * p.K[c] + beta * p.M[c] - C[c];
      u_[c] = A * p.twist[c];
      const double d = p.twist[c].dot(u_[c]) + alpha * p.K_diagonal[k] + beta * p.M_diagonal[k] + gamma;
      d_[k] = d;
      if (!(d > 0 && std::isfinite(d)) && first_nonpositive_ < 0) first_nonpositive_ = k;
      if (!(d != 0) || !std::isfinite(d)) {
        ok = false;
        break;
      }
      if (d < 0) ++negative_;
      pass += u_[c] * (u_[c].transpose() / d);
    }
    if (p.parent[c] >= 0) C[static_cast<std::size_t>(p.parent[c])] += form_up(pass, p.offset[c]);
  }
  if (!ok) p_ = nullptr;
  return ok;
}

void TreeFactor::solve(const double* b, double* x) const {
  if (p_ == nullptr) throw std::logic_error("TreeFactor::solve without a factorization");
  const TreePencil& p = *p_;
  const std::size_t nb = p.parent.size();
  work_.assign(nb, Vec6::Zero());  // the bias β, then the twist sums V
  // Elimination of the right-hand side, leaves first: x holds r̃ for now.
  for (std::size_t c = nb; c-- > 0;) {
    const int k = p.coordinate[c];
    Vec6 pass = work_[c];
    if (k >= 0) {
      x[k] = b[k] - p.twist[c].dot(work_[c]);
      pass += u_[c] * (x[k] / d_[k]);
    }
    if (p.parent[c] >= 0) work_[static_cast<std::size_t>(p.parent[c])] += wrench_up(pass, p.offset[c]);
  }
  // Back substitution, root first.
  for (std::size_t c = 0; c < nb; ++c) {
    Vec6 above = Vec6::Zero();
    if (p.parent[c] >= 0) above = twist_down(work_[static_cast<std::size_t>(p.parent[c])], p.offset[c]);
    const int k = p.coordinate[c];
    if (k >= 0) {
      x[k] = (x[k] - u_[c].dot(above)) / d_[k];
      above += p.twist[c] * x[k];
    }
    work_[c] = above;
  }
}

VectorX TreeFactor::solve(const VectorX& b) const {
  VectorX x(b.size());
  solve(b.data(), x.data());
  return x;
}

}  // namespace modal
