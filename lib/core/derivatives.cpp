// Evaluation of a System and its exact derivatives.
//
// Gradient and Hessian of V by tree-structured accumulation. Every element
// (gravity on a body, a dead load, a spring) depends on world points x attached
// to bodies; forward-mode AD of the element's templated energy gives its local
// cotangent e = ∂V_e/∂x and local Hessian. The chain rule through the tree uses
// the world twists (ω_k, v_k) of the coordinates (∂x/∂q_k = ω_k × x + v_k):
//
//   ∂V/∂q_k        = ω_k·τ + v_k·F                       (τ = Σ x × e, F = Σ e over the subtree of k)
//   Σ e·∂²x/∂q_j∂q_k = ω_j·(P ω_k − tr(P) ω_k + v_k × F)  (P = Σ x eᵀ; j at or above k, j before k in the joint)
//
// The second line follows from ∂ξ_k/∂q_j = [ξ_j, ξ_k] (the twist of a joint is
// carried by every joint above it) and the Jacobi identity. Inside one
// rotation-vector joint the twists depend on the joint's own coordinates
// through the left Jacobian J_l(φ); that derivative comes from AD of J_l.
// Elements with a local Hessian add Jᵀ H J. Cost: O(n·depth) for the Hessian.
//
// Rotating frame (Ω ≠ 0): the centrifugal potential −T₀ is two elements per
// body. The centre of mass is a point element, −½m|Ω × x|². The rotational
// inertia, −½ Σ_ij I_ij (Ω·u_i)(Ω·u_j), depends on the body-fixed world
// directions u_i = R_b e_i, which turn but do not translate: ∂u/∂q_k = ω_k × u.
// A direction's cotangent e_u is deposited like a point at x = u that adds
// u × e_u to τ and u e_uᵀ to P but nothing to F: the formulas above then hold
// unchanged (every term in them without x is a multiple of F). Both elements
// get their cotangents and local Hessians from AD of model::centrifugal_*_energy.
//
// Follower loads (f = R_b f_body at x) use the same accumulation with the
// cotangent e = f: the tree gradient is then Q_j = f·∂x/∂q_j and the tree
// Hessian f·∂²x/∂q_j∂q_k, the first part of ∂Q/∂q; the second part,
// (ω_k × f)·∂x/∂q_j, comes from the point Jacobian of the load's path.
#include "modal/core.hpp"

#include "core/map.hpp"
#include "core/map_eval.hpp"
#include "core/model.hpp"
#include "core/in_parts.hpp"
#include "core/sums.hpp"
#include "core/text.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <tuple>
#include <type_traits>
#include <limits>
#include <optional>
#include <string_view>

namespace modal {

// Per body: subtree sums of element cotangents e (F), of their moments x × e
// (tau) and of x eᵀ (P), in the scalar R (double; Complex for complex steps).
template <class R> struct SubtreeSums {
  std::vector<model::V3<R>> F, tau;
  std::vector<model::M3<R>> P;
  // With held children (absolute angles, model::region_inertias): F and P
  // over the body's region, each held child c counted by its translation
  // only (d F_cᵀ in P); filled by accumulate_sums when asked.
  std::vector<model::V3<R>> region_F;
  std::vector<model::M3<R>> region_P;
  // The rounding errors of F, τ and P's sums, carried up the tree beside
  // them (sum_subtrees, in double); kept here so that a repeated evaluation
  // does not allocate them again.
  std::vector<model::V3<R>> carried_F, carried_tau;
  std::vector<model::M3<R>> carried_P;
  void resize(std::size_t bodies) {
    F.resize(bodies);
    tau.resize(bodies);
    P.resize(bodies);
  }
};

struct KinematicsCache : SubtreeSums<double> {
  model::TreeState<double> st;
  // The second part's scratch where a large scene's elements are evaluated
  // in two parts (element_parts): its subtree sums and its share of the
  // sparse Hessian's values. Allocated on first use, kept for the next call.
  SubtreeSums<double> second;
  std::vector<double> second_values;
};

Workspace::Workspace(const System& system) : cache_(new KinematicsCache) {
  cache_->st.resize(system);
  cache_->resize(system.bodies().size());
}
Workspace::~Workspace() { delete cache_; }
Workspace::Workspace(Workspace&& o) noexcept
    : gradient(std::move(o.gradient)), hessian(std::move(o.hessian)), mass(std::move(o.mass)), cache_(o.cache_) {
  o.cache_ = nullptr;
}
Workspace& Workspace::operator=(Workspace&& o) noexcept {
  if (this != &o) {
    delete cache_;
    cache_ = o.cache_;
    o.cache_ = nullptr;
    gradient = std::move(o.gradient);
    hessian = std::move(o.hessian);
    mass = std::move(o.mass);
  }
  return *this;
}

namespace {

using model::TreeState;

void check_size(const System& s, const VectorX& q, const char* what) {
  if (q.size() != s.size())
    throw std::invalid_argument(std::string(what) + ": expected " + std::to_string(s.size()) +
                                " coordinates, got " + std::to_string(q.size()));
}

// Large scenes' elements in two parts, the second on a thread of its own
// (docs/design.md, "Threads for the elements"): from `parallel_springs`
// springs on, the springs are cut in two halves; part 0 also takes the
// bodies' weights, the dead loads and the centrifugal elements. Each part
// deposits into subtree sums (and Hessian values) of its own, added after
// both have finished, so the result depends on the scene only, never on the
// machine's cores or on timing. Below it, one part: no thread is started
// and every sum is taken in the order written.
constexpr std::size_t parallel_springs = 16384;

std::size_t element_parts(const System& s) { return s.springs().size() >= parallel_springs ? 2 : 1; }

// The springs of `part` (of `parts`): [first, last).
std::pair<std::size_t, std::size_t> spring_range(const System& s, std::size_t part, std::size_t parts) {
  const std::size_t count = s.springs().size();
  return {count * part / parts, count * (part + 1) / parts};
}

using detail::in_parts;

const TreeState<double>& kinematics(const System& s, Workspace& w, const VectorX& q) {
  check_size(s, q, "kinematics");
  model::forward_kinematics(s, q.data(), w.cache().st);
  return w.cache().st;
}

// What an element depends on: a world point x moved with `body`, or a world
// direction x fixed in `body` (∂x/∂q_k = ω_k × x); body -1: fixed in the
// world. r is x relative to the body's joint centre, computed directly (R_b·
// point; a direction: x itself): the tree sums and Jacobians use r, the
// elements' energies x.
template <class R> struct SiteT {
  int body = -1;
  model::V3<R> x = model::V3<R>::Zero();
  model::V3<R> r = model::V3<R>::Zero();
  bool direction = false;
};
using Site = SiteT<double>;

// The site of an attachment (a point of its body, or of the world).
template <class R> SiteT<R> attachment_site(const TreeState<R>& st, const Attachment& a) {
  const model::V3<R> r = model::relative_point(st, a);
  if (a.body < 0) return SiteT<R>{a.body, r, r, false};
  return SiteT<R>{a.body, model::V3<R>(st.position[static_cast<std::size_t>(a.body)] + r), r, false};
}

// ∂x/∂q_k for a site moved by coordinate k of the body a, the site lying at
// `lever` = x − p_a from a's joint centre: ω_k × (x − p_a) + u_k.
Vec3 site_velocity(const TreeState<double>& st, int k, const Vec3& lever, bool direction) {
  const auto kk = static_cast<std::size_t>(k);
  const Vec3 turn = st.omega[kk].cross(lever);
  return direction ? turn : Vec3(turn + st.centre_velocity[kk]);
}

// Calls f(k, lever) for every coordinate k that moves the site, with lever =
// x − p_a for k's body a, accumulated from r and the offsets on the way up
// (a direction keeps lever = x: it turns but does not translate). With
// `held` (absolute angles, model::region_inertias): the angle of a parent a
// reached through a held child c translates the site by ω × offset[c] (f
// gets lever = offset[c]), and turns no direction (f is not called).
template <class F>
void for_each_site_coordinate(const System& s, const TreeState<double>& st, const Site& site, F&& f,
                              const std::vector<char>* held = nullptr) {
  Vec3 lever = site.r;
  for (int a = site.body, from = -1; a >= 0; from = a, a = s.bodies()[static_cast<std::size_t>(a)].parent) {
    const int a0 = s.first_coordinate(a);
    if (held && from >= 0 && (*held)[static_cast<std::size_t>(from)]) {
      if (!site.direction) f(a0, st.offset[static_cast<std::size_t>(from)]);
    } else {
      for (int j = a0; j < a0 + s.joint_size(a); ++j) f(j, lever);
    }
    if (!site.direction) lever += st.offset[static_cast<std::size_t>(a)];
  }
}

// Sparse Jacobian of a site: the columns of the coordinates that move it.
struct PointJacobian {
  std::vector<int> index;
  std::vector<Vec3> column;
};
// Into J, whose capacity is reused: the per-element paths of an assembly then
// allocate nothing (a 10⁶-coordinate net assembles 1.3·10⁶ site Jacobians).
void site_jacobian(const System& s, const TreeState<double>& st, const Site& site, PointJacobian& J,
                   const std::vector<char>* held = nullptr) {
  J.index.clear();
  J.column.clear();
  for_each_site_coordinate(
      s, st, site,
      [&](int k, const Vec3& lever) {
        J.index.push_back(k);
        J.column.push_back(site_velocity(st, k, lever, site.direction));
      },
      held);
}
PointJacobian point_jacobian(const System& s, const TreeState<double>& st, const Attachment& a) {
  PointJacobian J;
  site_jacobian(s, st, attachment_site(st, a), J);
  return J;
}
// Frobenius norms of point Jacobians for every attachment at once, in O(n)
// for the whole tree (summing each site's path would be O(n·depth): O(n²) for
// a chain, over a minute for 10⁵ links). For coordinate k of body a a point
// moves with ∂x/∂q_k = ω_k × (x − p_a) + u_k, so over the path of body b, with
// y = x − p_b,
//   Σ_k |ω_k × (y + p_b − p_a) + u_k|² = c_b + 2 g_b·y + yᵀ A_b y,
// a quadratic form carried down the tree: a child's is its parent's moved by
// d = p_b − p_parent (c + 2 g·d + dᵀA d, g + A d, A), plus its own joint's
// |u|², u × ω and |ω|²I − ωωᵀ. Each body keeps it about its own joint
// centre, so the terms stay on the scale of the tree's lengths.
class PathJacobianNorms {
 public:
  PathJacobianNorms(const System& s, const TreeState<double>& st) : st_(st) {
    const auto nb = s.bodies().size();
    forms_.resize(nb);
    for (std::size_t b = 0; b < nb; ++b) {
      Form& f = forms_[b];
      const int parent = s.bodies()[b].parent;
      if (parent >= 0) {
        const Form& p = forms_[static_cast<std::size_t>(parent)];
        const Vec3& d = st.offset[b];
        const Vec3 Ad = p.A * d;
        f.c = p.c + 2 * p.g.dot(d) + d.dot(Ad);
        f.g = p.g + Ad;
        f.A = p.A;
        f.turn2 = p.turn2;
      }
      const int k0 = s.first_coordinate(static_cast<int>(b));
      for (int k = k0; k < k0 + s.joint_size(static_cast<int>(b)); ++k) {
        const Vec3& w = st.omega[static_cast<std::size_t>(k)];
        const Vec3& u = st.centre_velocity[static_cast<std::size_t>(k)];
        f.c += u.squaredNorm();
        f.g += u.cross(w);
        f.A += w.squaredNorm() * Mat3::Identity() - w * w.transpose();
        f.turn2 += w.squaredNorm();
      }
    }
  }
  // ‖∂x/∂q‖_F of the attachment's point (0 for a point of the world).
  double point(const Attachment& a) const {
    if (a.body < 0) return 0;
    const Form& f = forms_[static_cast<std::size_t>(a.body)];
    const Vec3 y = model::relative_point(st_, a);
    return std::sqrt(std::max(0.0, f.c + 2 * f.g.dot(y) + y.dot(f.A * y)));
  }
  // Σ |ω_k|² over the coordinates that turn `body`.
  double turn2(int body) const { return forms_[static_cast<std::size_t>(body)].turn2; }

 private:
  struct Form {
    double c = 0;
    Vec3 g = Vec3::Zero();
    Mat3 A = Mat3::Zero();
    double turn2 = 0;
  };
  const TreeState<double>& st_;
  std::vector<Form> forms_;
};

// Hands an element's cotangents (and, for second order, its local Hessian) on:
// `energy` of the stacked site coordinates (3N), templated on the scalar.
// Sites of a complex scalar (complex steps) have first order only.
template <int N, class R, class Energy, class Deposit, class LocalHessian>
void deposit_element(const std::array<SiteT<R>, N>& sites, Energy&& energy, Deposit&& deposit,
                     LocalHessian&& local_hessian, bool second_order) {
  Eigen::Matrix<R, 3 * N, 1> x;
  for (int i = 0; i < N; ++i) x.template segment<3>(3 * i) = sites[static_cast<std::size_t>(i)].x;
  Eigen::Matrix<R, 3 * N, 1> g;
  if constexpr (std::is_same_v<R, double>) {
    if (second_order) {
      const auto r = ad::hessian<3 * N>(energy, x);
      g = r.gradient;
      local_hessian(sites, r.hessian);
    } else {
      g = ad::gradient<3 * N>(energy, x).gradient;
    }
  } else {
    g = ad::gradient<3 * N>(energy, x).gradient;
  }
  for (int i = 0; i < N; ++i)
    if (sites[static_cast<std::size_t>(i)].body >= 0)
      deposit(sites[static_cast<std::size_t>(i)], model::V3<R>(g.template segment<3>(3 * i)));
}

// Hands on a two-site element whose energy depends on the sites only through
// d = x_a − x_b (a spring; `energy` of d, templated on the scalar). Its exact
// derivatives are taken in the 3 components of d, not the 6 of (x_a, x_b):
// ∂V/∂x_a = ∂V/∂d = −∂V/∂x_b, and the 6×6 local Hessian is
// [H −H; −H H] with H = ∂²V/∂d². Exact like deposit_element<2> (∂d/∂x is
// ±I exactly), for a quarter of the second-order AD work.
template <class R, class Energy, class Deposit, class LocalHessian>
void deposit_difference_element(const std::array<SiteT<R>, 2>& sites, Energy&& energy, Deposit&& deposit,
                                LocalHessian&& local_hessian, bool second_order) {
  const Eigen::Matrix<R, 3, 1> d = sites[0].x - sites[1].x;
  Eigen::Matrix<R, 3, 1> g;
  if constexpr (std::is_same_v<R, double>) {
    if (second_order) {
      const auto r = ad::hessian<3>(energy, d);
      g = r.gradient;
      Eigen::Matrix<double, 6, 6> H;
      H << r.hessian, -r.hessian, -r.hessian, r.hessian;
      local_hessian(sites, H);
    } else {
      g = ad::gradient<3>(energy, d).gradient;
    }
  } else {
    g = ad::gradient<3>(energy, d).gradient;
  }
  if (sites[0].body >= 0) deposit(sites[0], model::V3<R>(g));
  if (sites[1].body >= 0) deposit(sites[1], model::V3<R>(-g));
}

// The centrifugal elements of −T₀ (module comment) of every body.
template <class R, class Deposit, class LocalHessian>
void for_each_centrifugal_cotangent(const System& s, const TreeState<R>& st, Deposit&& deposit,
                                    LocalHessian&& local_hessian, bool second_order) {
  const auto& bodies = s.bodies();
  const Vec3& Omega = s.frame_rotation();
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const Body& body = bodies[b];
    const int bi = static_cast<int>(b);
    if (body.mass != 0.0) {
      auto energy = [&](const auto& x) {
        using S = std::decay_t<decltype(x[0])>;
        return model::centrifugal_point_energy<S>(body.mass, Omega, model::V3<S>(x[0], x[1], x[2]));
      };
      const std::array<SiteT<R>, 1> com{attachment_site(st, Attachment{bi, body.com})};
      deposit_element<1>(com, energy, deposit, local_hessian, second_order);
    }
    if (!body.inertia.isZero(0.0)) {
      auto energy = [&](const auto& x) {
        using S = std::decay_t<decltype(x[0])>;
        const model::V3<S> u[3] = {{x[0], x[1], x[2]}, {x[3], x[4], x[5]}, {x[6], x[7], x[8]}};
        return model::centrifugal_rotation_energy<S>(body.inertia, Omega, u);
      };
      const std::array<SiteT<R>, 3> axes{SiteT<R>{bi, st.rotation[b].col(0), st.rotation[b].col(0), true},
                                         SiteT<R>{bi, st.rotation[b].col(1), st.rotation[b].col(1), true},
                                         SiteT<R>{bi, st.rotation[b].col(2), st.rotation[b].col(2), true}};
      deposit_element<3>(axes, energy, deposit, local_hessian, second_order);
    }
  }
}

// The element cotangents e = ∂V_e/∂x at sites, handed to `deposit(site, e)`;
// elements with a local Hessian (springs: 6×6 in (xa, xb); centrifugal
// elements) hand it to `local_hessian(sites, H)` when second_order.
// With `parts`, only those of `part` (element_parts).
template <class R, class Deposit, class LocalHessian>
void for_each_cotangent(const System& s, const TreeState<R>& st, Deposit&& deposit, LocalHessian&& local_hessian,
                        bool second_order, std::size_t part = 0, std::size_t parts = 1) {
  using V = model::V3<R>;
  const auto& bodies = s.bodies();
  if (part == 0) {
    for (std::size_t b = 0; b < bodies.size(); ++b) {
      const Body& body = bodies[b];
      if (body.mass == 0.0) continue;
      deposit(attachment_site(st, Attachment{static_cast<int>(b), body.com}), V((-body.mass * s.gravity()).cast<R>()));
    }
    for (const DeadLoad& l : s.loads())
      deposit(attachment_site(st, l.at), V((-l.force).cast<R>()));
    if (s.rotating()) for_each_centrifugal_cotangent(s, st, deposit, local_hessian, second_order);
  }
  const auto [first, last] = spring_range(s, part, parts);
  for (std::size_t i = first; i < last; ++i) {
    const Spring& sp = s.springs()[i];
    const SiteT<R> a = attachment_site(st, sp.a), b = attachment_site(st, sp.b);
    if (sp.rest_length != 0.0 && value((a.x - b.x).squaredNorm()) == 0.0)
      throw NumericalError(describe_meeting_ends(s, MeetingEnds{i, 0.0}));
    auto energy = [&sp](const auto& d) {
      using S = std::decay_t<decltype(d[0])>;
      return model::spring_stretch_energy<S>(sp, model::V3<S>(d[0], d[1], d[2]));
    };
    const std::array<SiteT<R>, 2> ends{a, b};
    deposit_difference_element(ends, energy, deposit, local_hessian, second_order);
  }
}

// Subtree sums: zeroed for `bodies` bodies; the depositor of a site's
// cotangent e (a direction adds nothing to F), adding r × e to τ and r eᵀ to P
// about the site's body's joint centre; and the shift of every child c into
// its parent with its offset d: τ += τ_c + d × F_c, P += P_c + d F_cᵀ.
template <class R> void zero_sums(SubtreeSums<R>& c, std::size_t bodies) {
  c.resize(bodies);
  for (std::size_t b = 0; b < bodies; ++b) {
    c.F[b].setZero();
    c.tau[b].setZero();
    c.P[b].setZero();
  }
}

template <class R> auto depositor(SubtreeSums<R>& c, bool second_order) {
  return [&c, second_order](const SiteT<R>& site, const model::V3<R>& e) {
    if (site.body < 0) return;
    const auto b = static_cast<std::size_t>(site.body);
    if (!site.direction) c.F[b] += e;
    c.tau[b] += site.r.cross(e);
    if (second_order) c.P[b] += site.r * e.transpose();
  };
}

// a += b entry by entry with compensation (Neumaier): each sum's rounding
// error added to `carried`.
template <class A, class B> void add_compensated(A& a, const B& b, A& carried) {
  for (Eigen::Index i = 0; i < a.size(); ++i) {
    const double x = a(i), y = b(i), sum = x + y;
    carried(i) += std::abs(x) >= std::abs(y) ? (x - sum) + y : (y - sum) + x;
    a(i) = sum;
  }
}

// In double, the shifts into the parents are summed with compensation: a
// body's F, τ and P are sums over its whole subtree (a hanging chain's F_j
// over the n − j bodies below), which plainly summed lost up to 17ε
// relative at n = 300 and 42ε at n = 1000 on equal links (the roundings of
// equal terms add up alike) in K_jj = g l_j Σ_{b≥j} m_b, above the
// 4ε Σ|terms| that K_magnitude stands for (LinearModel::K_error). Each
// sum's rounding errors travel up the tree beside it (carried, added to a
// parent's with the child's sum; the child's sum and the offset's product
// added as two terms) and are added once the loop is done; a child's sums
// where they are used (the offset's products, the regions) are taken with
// its errors added, so each is the exact sum of its terms rounded about
// once and what is left is the terms' own rounding.
template <class R>
void sum_subtrees(const System& s, const TreeState<R>& st, SubtreeSums<R>& c, bool second_order,
                  const std::vector<char>* held) {
  const auto nb = s.bodies().size();
  if (held) {
    c.region_F = c.F;
    c.region_P = c.P;
  }
  // Nothing to sum where no body has a parent (a net of particles).
  if (std::none_of(s.bodies().begin(), s.bodies().end(), [](const Body& body) { return body.parent >= 0; })) return;
  constexpr bool compensated = std::is_same_v<R, double>;
  if constexpr (compensated) {
    c.carried_F.assign(nb, model::V3<R>::Zero());
    c.carried_tau.assign(nb, model::V3<R>::Zero());
    if (second_order) c.carried_P.assign(nb, model::M3<R>::Zero());
  }
  for (std::size_t b = nb; b-- > 0;) {
    const int p = s.bodies()[b].parent;
    if (p < 0) continue;
    const auto pp = static_cast<std::size_t>(p);
    const model::V3<R>& d = st.offset[b];
    if constexpr (compensated) {  // b's subtree is complete: its sums with their errors
      const model::V3<R> F = c.F[b] + c.carried_F[b];
      const model::M3<R> shifted = d * F.transpose();
      if (held && (*held)[b]) {
        c.region_P[pp] += shifted;
      } else if (held) {
        c.region_F[pp] += F;
        c.region_P[pp] += (second_order ? model::M3<R>(c.P[b] + c.carried_P[b]) : c.P[b]) + shifted;
      }
      add_compensated(c.F[pp], c.F[b], c.carried_F[pp]);
      c.carried_F[pp] += c.carried_F[b];
      add_compensated(c.tau[pp], c.tau[b], c.carried_tau[pp]);
      add_compensated(c.tau[pp], model::V3<R>(d.cross(F)), c.carried_tau[pp]);
      c.carried_tau[pp] += c.carried_tau[b];
      if (second_order) {
        add_compensated(c.P[pp], c.P[b], c.carried_P[pp]);
        add_compensated(c.P[pp], shifted, c.carried_P[pp]);
        c.carried_P[pp] += c.carried_P[b];
      }
    } else {
      if (held && (*held)[b]) {
        c.region_P[pp] += d * c.F[b].transpose();
      } else if (held) {
        c.region_F[pp] += c.F[b];
        c.region_P[pp] += c.P[b] + d * c.F[b].transpose();
      }
      c.F[pp] += c.F[b];
      c.tau[pp] += c.tau[b] + d.cross(c.F[b]);
      if (second_order) c.P[pp] += c.P[b] + d * c.F[b].transpose();
    }
  }
  if constexpr (compensated)
    for (std::size_t b = 0; b < nb; ++b) {
      c.F[b] += c.carried_F[b];
      c.tau[b] += c.carried_tau[b];
      if (second_order) c.P[b] += c.carried_P[b];
    }
}

// Fills the subtree sums F, τ, P of the cotangents that `source(deposit)` hands
// to deposit(site, e) (zero_sums, depositor, sum_subtrees).
template <class R, class Source>
void accumulate_sums(const System& s, const TreeState<R>& st, SubtreeSums<R>& c, bool second_order, Source&& source,
                     const std::vector<char>* held = nullptr) {
  zero_sums(c, s.bodies().size());
  source(depositor(c, second_order));
  sum_subtrees(s, st, c, second_order, held);
}

// The same in `parts` parts (element_parts, in_parts): `source(deposit,
// part)`, part 1 into `second`, whose deposits are added to c's before the
// subtree sums.
template <class Source>
void accumulate_sums_in_parts(const System& s, const TreeState<double>& st, SubtreeSums<double>& c,
                              SubtreeSums<double>& second, bool second_order, std::size_t parts, Source&& source,
                              const std::vector<char>* held = nullptr) {
  const auto nb = s.bodies().size();
  in_parts(parts, [&](std::size_t part) {
    SubtreeSums<double>& mine = part == 0 ? c : second;
    zero_sums(mine, nb);
    source(depositor(mine, second_order), part);
  });
  if (parts > 1)
    for (std::size_t b = 0; b < nb; ++b) {
      c.F[b] += second.F[b];
      c.tau[b] += second.tau[b];
      if (second_order) c.P[b] += second.P[b];
    }
  sum_subtrees(s, st, c, second_order, held);
}

// The subtree sums of the potential's element cotangents e = ∂V_e/∂x, in
// `parts` parts (element_parts); `local_hessian_of(part)` is the local-Hessian
// callback of that part's elements.
template <class LocalHessianOf>
void accumulate(const System& s, Workspace& w, bool second_order, LocalHessianOf&& local_hessian_of,
                const std::vector<char>* held = nullptr, std::size_t parts = 1) {
  KinematicsCache& c = w.cache();
  accumulate_sums_in_parts(
      s, c.st, c, c.second, second_order, parts,
      [&](auto&& deposit, std::size_t part) {
        for_each_cotangent(s, c.st, deposit, local_hessian_of(part), second_order, part, parts);
      },
      held);
}

// World force of a follower load at the current kinematics: R_b · (body-frame force).
template <class R> model::V3<R> follower_force(const TreeState<R>& st, const FollowerLoad& l) {
  return st.rotation[static_cast<std::size_t>(l.at.body)] * l.force.cast<R>();
}

// The subtree sums of the follower forces themselves (cotangent e = f): then
// the tree gradient below is Q_j = f·∂x/∂q_j and the tree Hessian is f·∂²x/∂q_j∂q_k.
void accumulate_followers(const System& s, Workspace& w, bool second_order) {
  const TreeState<double>& st = w.cache().st;
  accumulate_sums(s, st, w.cache(), second_order, [&](auto&& deposit) {
    for (const FollowerLoad& l : s.followers())
      deposit(attachment_site(st, l.at), follower_force(st, l));
  });
}

bool is_rotation_vector(const Body& body, int local) {
  return body.joint == JointType::ball || (body.joint == JointType::free && local >= 3);
}

// g_k = ω_k·τ + u_k·F with the subtree sums of the body that coordinate k moves:
// Σ e·∂x/∂q_k over the deposited cotangents (n entries, g resized).
template <class R>
void tree_gradient(const System& s, const TreeState<R>& st, const SubtreeSums<R>& c, model::VX<R>& g) {
  g.setZero(s.size());
  for (std::size_t b = 0; b < s.bodies().size(); ++b) {
    const int k0 = s.first_coordinate(static_cast<int>(b));
    for (int k = k0; k < k0 + s.joint_size(static_cast<int>(b)); ++k) {
      const auto kk = static_cast<std::size_t>(k);
      g[k] = st.omega[kk].dot(c.tau[b]) + st.centre_velocity[kk].dot(c.F[b]);
    }
  }
}

// The gradient of the potential plus whatever `extra(deposit)` deposits, at
// the kinematics st of q (scalar R): one accumulation of every cotangent, the
// tree gradient, and the joint springs ½k(q − rest)².
// In double, with two `parts` (element_parts), part 1 into `second`; `extra`
// deposits with part 0.
template <class R, class Extra>
void gradient_with(const System& s, const TreeState<R>& st, const R* q, SubtreeSums<R>& c, model::VX<R>& g,
                   Extra&& extra, std::size_t parts = 1, SubtreeSums<R>* second = nullptr) {
  if (!std::is_same_v<R, double> || second == nullptr) parts = 1;  // two parts need the second's sums
  auto source = [&](auto&& deposit, std::size_t part) {
    for_each_cotangent(s, st, deposit, [](auto&&...) {}, false, part, parts);
    if (part == 0) extra(deposit);
  };
  if constexpr (std::is_same_v<R, double>) {
    if (parts > 1) {
      accumulate_sums_in_parts(s, st, c, *second, false, parts, source);
    } else {
      accumulate_sums(s, st, c, false, [&](auto&& deposit) { source(deposit, 0); });
    }
  } else {
    accumulate_sums(s, st, c, false, [&](auto&& deposit) { source(deposit, 0); });
  }
  tree_gradient(s, st, c, g);
  const auto& bodies = s.bodies();
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    if (bodies[b].stiffness == 0.0) continue;
    const int k0 = s.first_coordinate(static_cast<int>(b));
    model::joint_spring_gradient(bodies[b], q + k0, s.joint_size(static_cast<int>(b)),
                                 [&](int i, const R& v) { g[k0 + i] += v; });
  }
}

// add(j, k, h) for H_jk += Σ e·∂²x/∂q_j∂q_k over the deposited cotangents
// (both triangles; the formulas of the header comment, O(n·depth)).
// With `held` (absolute angles; the region sums filled): in the basis θ, q =
// Tθ. Column k of T is e_k − Σ e_c over k's held children c (ω_c = ω_k), so
// (TᵀHT)_jk = (ω_j − Σ ω_c)·(w_k − Σ_c w_c) with w from the region sums of
// k's body (P − Σ_c P_c, F − Σ_c F_c, formed directly), and the first factor
// is zero exactly when k's body lies below a held child of j's: such pairs
// are skipped.
template <class Add>
void tree_hessian(const System& s, const TreeState<double>& st, const KinematicsCache& c, const VectorX& q, Add&& add,
                  const std::vector<char>* held = nullptr) {
  const auto& bodies = s.bodies();
  // With `held`, per body the first body on its path up (itself included)
  // that is not held: the walk up below skips a run of held links in one
  // step, so that a chain of held hinges costs O(n), not O(n²).
  std::vector<int> unheld;
  if (held) {
    unheld.resize(bodies.size());
    for (std::size_t b = 0; b < bodies.size(); ++b)
      unheld[b] = (*held)[b] && bodies[b].parent >= 0 ? unheld[static_cast<std::size_t>(bodies[b].parent)]
                                                      : static_cast<int>(b);
  }
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const Body& body = bodies[b];
    const int k0 = s.first_coordinate(static_cast<int>(b));
    const int nq = s.joint_size(static_cast<int>(b));
    const Vec3& F = held ? c.region_F[b] : c.F[b];
    const Mat3& P = held ? c.region_P[b] : c.P[b];
    const double trP = P.trace();
    // Rotation-vector joints: derivative of the twists with respect to the joint's own coordinates.
    Eigen::Matrix<double, 3, 9> dW;  // columns 3i..3i+2: ∂(R_p J_l e_k)/∂φ_i for k = 0..2
    int r0 = -1;
    if (body.joint == JointType::ball || body.joint == JointType::free) {
      r0 = k0 + (body.joint == JointType::free ? 3 : 0);
      const Mat3 Rp = (body.parent >= 0 ? st.rotation[static_cast<std::size_t>(body.parent)] : Mat3::Identity()) *
                      body.orientation;  // the frame the joint acts in
      using D3 = Dual<double, 3>;
      const model::V3<D3> phi(D3(q[r0], 0), D3(q[r0 + 1], 1), D3(q[r0 + 2], 2));
      const model::M3<D3> Jl = model::rotation_left_jacobian(phi);
      for (int i = 0; i < 3; ++i) {
        Mat3 dJ;
        for (int a = 0; a < 3; ++a)
          for (int e = 0; e < 3; ++e) dJ(a, e) = Jl(a, e).d[static_cast<std::size_t>(i)];
        dW.block<3, 3>(0, 3 * i) = Rp * dJ;
      }
    }
    for (int k = k0; k < k0 + nq; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      const Vec3 wk = P * st.omega[kk] - trP * st.omega[kk] + st.centre_velocity[kk].cross(F);
      auto pair = [&](int j) {
        const double h = st.omega[static_cast<std::size_t>(j)].dot(wk);
        if (h == 0.0) return;  // translations (ω_j = 0): nothing, and no sparse entry
        add(j, k, h);
        if (j != k) add(k, j, h);
      };
      const bool rot_k = is_rotation_vector(body, k - k0);
      for (int j = k0; j <= k; ++j) {
        if (rot_k && is_rotation_vector(body, j - k0)) continue;  // handled below
        pair(j);
      }
      // Each ancestor a, entered from its child `from` on the path, unless
      // `from` is held.
      for (int from = held ? unheld[b] : static_cast<int>(b); bodies[static_cast<std::size_t>(from)].parent >= 0;) {
        const int a = bodies[static_cast<std::size_t>(from)].parent;
        const int a0 = s.first_coordinate(a);
        for (int j = a0; j < a0 + s.joint_size(a); ++j) pair(j);
        from = held ? unheld[static_cast<std::size_t>(a)] : a;
      }
    }
    if (r0 >= 0) {
      // Σ e·∂²x/∂φ_j∂φ_k = (∂ω_k/∂φ_j)·τ + ω_k·(P ω_j − tr(P) ω_j), τ and P about the joint centre.
      const Mat3& Pc = P;
      const double trPc = trP;
      const Vec3& tc = c.tau[b];
      Mat3 h;
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) {
          const Vec3& wj = st.omega[static_cast<std::size_t>(r0 + j)];
          const Vec3& wk = st.omega[static_cast<std::size_t>(r0 + k)];
          const Vec3 dwk = dW.block<3, 3>(0, 3 * j).col(k);
          h(j, k) = dwk.dot(tc) + wk.dot(Pc * wj - trPc * wj);
        }
      const Mat3 sym = 0.5 * (h + h.transpose());
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) add(r0 + j, r0 + k, sym(j, k));
    }
  }
}

// A spring's local Hessian [h −h; −h h] (h = ∂²V/∂d², d = x_a − x_b, 3×3
// symmetric) with h replaced by its positive semidefinite part: h's negative
// eigenvalues set to 0. For a spring h = k[uuᵀ + (1 − L₀/L)(I − uuᵀ)], so
// that is the compressed spring's negative transverse stiffness left out
// (k uuᵀ kept); a stretched spring is returned as it is (one at its rest
// length, whose transverse eigenvalues are 0, to rounding).
Eigen::Matrix<double, 6, 6> positive_spring_block(const Eigen::Matrix<double, 6, 6>& He) {
  const Mat3 h = He.topLeftCorner<3, 3>();
  Eigen::SelfAdjointEigenSolver<Mat3> e;
  e.computeDirect(h);
  if (!(e.eigenvalues().minCoeff() < 0)) return He;
  const Mat3 p = e.eigenvectors() * e.eigenvalues().cwiseMax(0.0).asDiagonal() * e.eigenvectors().transpose();
  Eigen::Matrix<double, 6, 6> P;
  P << p, -p, -p, p;
  return P;
}

// The sizes of the terms of a spring's local Hessian, for the rounding bound
// of ∇∇V (potential_hessian_magnitude): h = k I − k(L₀/L)(I − uuᵀ) with u
// along d = x_a − x_b, so k uᵀhu = k and the transverse eigenvalue t = k(1 −
// L₀/L); the block [m −m; −m m] with m = |k| I + |k − t| |I − uuᵀ|. The
// computed h is their difference: at a small prestrain p (L₀ = (1 − p)L) its
// transverse k p carries the rounding of k and of k L₀/L, ε/p of itself,
// which the entries of h alone (≈ k p) did not count: a net at p = 1e-9 had
// ω² off by 2.8e-8 relative with estimates of 2e-14.
// A spring's axes from its local Hessian He: u along d = x_a − x_b, the
// axial stiffness k = uᵀhu and the transverse t = (tr h − k)/2 of its
// block h; false where the ends coincide (no direction).
struct SpringAxes {
  Vec3 u;
  double length = 0, k = 0, t = 0;
};
bool spring_axes(const std::array<Site, 2>& sites, const Eigen::Matrix<double, 6, 6>& He, SpringAxes& axes) {
  const Vec3 d = sites[0].x - sites[1].x;
  axes.length = d.norm();
  if (!(axes.length > 0)) return false;
  const Mat3 h = He.topLeftCorner<3, 3>();
  axes.u = d / axes.length;
  axes.k = axes.u.dot(h * axes.u);
  axes.t = 0.5 * (h.trace() - axes.k);
  return true;
}

// [b −b; −b b] for a 3 × 3 block b.
Eigen::Matrix<double, 6, 6> two_point_block(const Mat3& b) {
  Eigen::Matrix<double, 6, 6> B;
  B << b, -b, -b, b;
  return B;
}

Eigen::Matrix<double, 6, 6> spring_term_sizes(const std::array<Site, 2>& sites, const Eigen::Matrix<double, 6, 6>& He) {
  SpringAxes a;
  if (!spring_axes(sites, He, a)) return He.cwiseAbs();
  return two_point_block(std::abs(a.k) * Mat3::Identity() +
                         std::abs(a.k - a.t) * (Mat3::Identity() - a.u * a.u.transpose()).cwiseAbs());
}

// The sizes of a spring's rounding (SpringRounding's column): with d = x_a −
// x_b, L = |d|, u = d/L, the computed h = k uuᵀ + t(I − uuᵀ) errs by δk uuᵀ
// + δt(I − uuᵀ) + (k − t)(δu uᵀ + uδuᵀ) with |δk| ≤ ε|k| (k is a term),
// |δt| ≤ ε(|k| + (1 + ρ)|k − t|) (t = k − kL₀/L: two terms, and L's
// rounding, ρε relative, with ρ = (‖x_a‖ + ‖x_b‖)/L: the ends' positions
// are rounded to ε of their size) and |δu| ≤ ρε; for the end points'
// difference v, |vᵀδh v| ≤ ε vᵀ s v with s = a uuᵀ + (a + b)(I − uuᵀ) +
// r(uuᵀ + 2(I − uuᵀ)), a = |k|, b = |k − t|, r = ρb (2|x||y| ≤ x² + y² for
// the direction's term). Where the ends coincide (no axis), u = 0, b = r = 0
// and a = the largest row sum of |h| (|v|ᵀ|h||v| ≤ a|v|²).
Eigen::Matrix<double, 6, 1> spring_rounding_sizes(const std::array<Site, 2>& sites, const Eigen::Matrix<double, 6, 6>& He) {
  Eigen::Matrix<double, 6, 1> sizes = Eigen::Matrix<double, 6, 1>::Zero();
  SpringAxes a;
  if (spring_axes(sites, He, a)) {
    const double rho = (sites[0].x.norm() + sites[1].x.norm()) / a.length;
    sizes << a.u, std::abs(a.k), std::abs(a.k - a.t), rho * std::abs(a.k - a.t);
  } else {
    sizes(3) = He.topLeftCorner<3, 3>().cwiseAbs().rowwise().sum().maxCoeff();
  }
  return sizes;
}

// A bound of a spring's rounding as a positive semidefinite block, for
// sparse_rounding_form: [s −s; −s s] with s as spring_rounding_sizes, in
// units of ε (without an axis, a I: |v|ᵀ|h||v| ≤ Σ_i (Σ_j |h_ij|) v_i² ≤ a|v|²
// is kept as the row sums themselves, the tighter diagonal).
Eigen::Matrix<double, 6, 6> spring_rounding_form(const std::array<Site, 2>& sites, const Eigen::Matrix<double, 6, 6>& He) {
  const Eigen::Matrix<double, 6, 1> z = spring_rounding_sizes(sites, He);
  const Vec3 u = z.head<3>();
  if (u.squaredNorm() == 0.0)  // no axis
    return two_point_block(He.topLeftCorner<3, 3>().cwiseAbs().rowwise().sum().asDiagonal());
  const Mat3 along = u * u.transpose(), across = Mat3::Identity() - along;
  return two_point_block(z(3) * along + (z(3) + z(4)) * across + z(5) * (along + 2 * across));
}

// An adder that bounds each term |v φ_j φ_k| by |v|(φ_j² + φ_k²)/2: the
// term's magnitude, halved onto the two diagonal entries (a positive
// semidefinite diagonal bound of the terms' entrywise form).
template <class Add>
struct DiagonalHalves {
  Add add;  // a reference where the caller's adder is one
  void operator()(int j, int k, double v) {
    add(j, j, 0.5 * std::abs(v));
    add(k, k, 0.5 * std::abs(v));
  }
};

// H += Jᵀ H_e J for an element's local Hessian H_e (3N×3N in its N sites).
template <std::size_t N, class Block, class Add>
void add_local_hessian(const System& s, const TreeState<double>& st, const std::array<Site, N>& sites, const Block& He,
                       Add&& add, const std::vector<char>* held = nullptr) {
  thread_local std::array<PointJacobian, N> J;  // capacity kept from element to element
  for (std::size_t u = 0; u < N; ++u) site_jacobian(s, st, sites[u], J[u], held);
  for (std::size_t u = 0; u < N; ++u)
    for (std::size_t v = 0; v < N; ++v) {
      const Mat3 block = He.template block<3, 3>(3 * static_cast<Eigen::Index>(u), 3 * static_cast<Eigen::Index>(v));
      // Column by column, rows in order within one (what the in-place
      // sparse adder's hint follows).
      for (std::size_t j = 0; j < J[v].index.size(); ++j) {
        const Vec3 right = block * J[v].column[j];
        for (std::size_t i = 0; i < J[u].index.size(); ++i) add(J[u].index[i], J[v].index[j], J[u].column[i].dot(right));
      }
    }
}

// Adders of Hessian entries: into a dense matrix, or as sparse triplets.
auto dense_adder(MatrixX& H) {
  return [&H](int j, int k, double v) { H(j, k) += v; };
}
auto triplet_adder(std::vector<Eigen::Triplet<double>>& t) {
  return [&t](int j, int k, double v) { t.emplace_back(j, k, v); };
}

// The terms of ∇∇V besides the elements' local Hessians: the tree terms and
// the joint springs.
template <class Add>
void other_hessian_terms(const System& s, const TreeState<double>& st, Workspace& w, const VectorX& q, Add&& add,
                         const std::vector<char>* held) {
  tree_hessian(s, st, w.cache(), q, add, held);
  const auto& bodies = s.bodies();
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    if (bodies[b].stiffness == 0.0) continue;
    const int k0 = s.first_coordinate(static_cast<int>(b));
    model::joint_spring_hessian(bodies[b], q.data() + k0, s.joint_size(static_cast<int>(b)),
                                [&](int i, int j, double v) { add(k0 + i, k0 + j, v); });
    if (held && (*held)[b]) {  // a hinge under a parallel hinge (one coordinate)
      const int p = s.first_coordinate(bodies[b].parent);
      add(p, p, bodies[b].stiffness);
      add(p, k0, -bodies[b].stiffness);
      add(k0, p, -bodies[b].stiffness);
    }
  }
}

// ∇∇V of a tree, entry by entry into add(j, k, v): the elements' local
// Hessians (Jᵀ H_e J), the tree terms, and the joint springs. With `held`:
// Tᵀ∇∇V T in the absolute angles of parallel hinges (a held body's spring
// acts on θ_b − θ_parent).
// In `parts` parts (element_parts): `add_of(part)` is the adder of that
// part's elements; the tree terms and joint springs go to add_of(0).
// With SpringBlocks::convex, a spring's local Hessian goes in as its positive
// semidefinite part (positive_spring_block); with ::term_sizes, as the sizes
// of its terms (spring_term_sizes: for the magnitudes of ∇∇V's entries).
// With ::rounding_form, springs as spring_rounding_form and every other
// term as its magnitude halved onto the diagonal (DiagonalHalves).
enum class SpringBlocks { as_computed, convex, term_sizes, rounding_form };
template <class AddOf>
void assemble_potential_hessian_in_parts(const System& s, Workspace& w, const VectorX& q, AddOf&& add_of,
                                         std::size_t parts, const std::vector<char>* held = nullptr,
                                         SpringBlocks blocks = SpringBlocks::as_computed) {
  const TreeState<double>& st = kinematics(s, w, q);
  accumulate(
      s, w, true,
      [&](std::size_t part) {
        return [&, part](const auto& sites, const auto& He) {
          if constexpr (std::tuple_size_v<std::decay_t<decltype(sites)>> == 2) {  // a spring
            if (blocks == SpringBlocks::convex) {
              add_local_hessian(s, st, sites, positive_spring_block(He), add_of(part), held);
              return;
            }
            if (blocks == SpringBlocks::term_sizes) {
              add_local_hessian(s, st, sites, spring_term_sizes(sites, He), add_of(part), held);
              return;
            }
            if (blocks == SpringBlocks::rounding_form) {
              add_local_hessian(s, st, sites, spring_rounding_form(sites, He), add_of(part), held);
              return;
            }
          }
          if (blocks == SpringBlocks::rounding_form) {
            DiagonalHalves<decltype(add_of(part))> halves{add_of(part)};
            add_local_hessian(s, st, sites, He, halves, held);
            return;
          }
          add_local_hessian(s, st, sites, He, add_of(part), held);
        };
      },
      held, parts);
  if (blocks == SpringBlocks::rounding_form) {
    DiagonalHalves<decltype(add_of(0))> halves{add_of(0)};
    other_hessian_terms(s, st, w, q, halves, held);
    return;
  }
  other_hessian_terms(s, st, w, q, add_of(0), held);
}

// An adder of terms (j, k, v) into `values`, laid out on the pattern of the
// compressed `pattern`; `fits` turns false when an entry is not in it. Terms
// come in runs down one column (add_local_hessian): the entry after the last
// one found is tried before a binary search.
inline auto in_place_adder(const SparseMatrix& pattern, double* values, bool& fits) {
  return [outer = pattern.outerIndexPtr(), inner = pattern.innerIndexPtr(), values, &fits, last_column = -1,
          last = std::ptrdiff_t{0}](int j, int k, double v) mutable {
    const std::ptrdiff_t next = last + 1;
    if (k == last_column && next < outer[k + 1] && inner[next] == j) {
      values[next] += v;
      last = next;
      return;
    }
    const auto* begin = inner + outer[k];
    const auto* end = inner + outer[k + 1];
    const auto* at = std::lower_bound(begin, end, j);
    if (at != end && *at == j) {
      values[at - inner] += v;
      last_column = k;
      last = at - inner;
    } else {
      fits = false;
    }
  };
}

// In one part: every term to `add`.
template <class Add>
void assemble_potential_hessian(const System& s, Workspace& w, const VectorX& q, Add&& add,
                                const std::vector<char>* held = nullptr,
                                SpringBlocks blocks = SpringBlocks::as_computed) {
  assemble_potential_hessian_in_parts(s, w, q, [&add](std::size_t) -> auto& { return add; }, 1, held, blocks);
}

// A sparse matrix (n×n) of terms that `assemble(add)` hands to add(j, k, v),
// duplicates summed in the order of the terms. A counting pass sizes each
// column (terms, duplicates included), a second pass files every term under
// its column, and each column is then sorted and its duplicates summed. This
// replaces triplets (36 per spring) with Eigen's setFromTriplets, whose
// row-major detour scatters over the whole matrix and touches about three
// times as much fresh memory: 5.8 s for a 10⁶-coordinate net's ∇∇V against
// 0.5 s for an assembly in place (bench_core SparseHessianNetFirst). The
// counting pass evaluates every term too (the elements' AD), so a first
// assembly costs about two in place; it happens once per workspace.
// `assemble` must hand the same (j, k) pairs on both passes.
template <class Assemble>
void assemble_by_columns(int n, Assemble&& assemble, SparseMatrix& H) {
  std::vector<Eigen::Index> start(static_cast<std::size_t>(n) + 1, 0);
  assemble([&start](int, int k, double) { ++start[static_cast<std::size_t>(k) + 1]; });
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<int> rows(static_cast<std::size_t>(start.back()));
  std::vector<double> terms(rows.size());
  std::vector<Eigen::Index> next(start.begin(), start.end() - 1);
  bool counted = true;  // the second pass visits the same (row, column) pairs
  assemble([&](int j, int k, double v) {
    Eigen::Index& at = next[static_cast<std::size_t>(k)];
    if (at == start[static_cast<std::size_t>(k) + 1]) {
      counted = false;
      return;
    }
    rows[static_cast<std::size_t>(at)] = j;
    terms[static_cast<std::size_t>(at)] = v;
    ++at;
  });
  for (std::size_t k = 0; counted && k < next.size(); ++k) counted = next[k] == start[k + 1];
  if (!counted) throw std::logic_error("assemble_by_columns: the two assembly passes differ");
  // Sorted and summed column by column, compacted in place (a column's
  // entries never move past its terms).
  std::vector<std::pair<int, double>> column;
  Eigen::Index kept = 0;
  std::vector<Eigen::Index> outer(static_cast<std::size_t>(n) + 1, 0);
  for (std::size_t k = 0; k < static_cast<std::size_t>(n); ++k) {
    column.clear();
    for (Eigen::Index i = start[k]; i < start[k + 1]; ++i)
      column.emplace_back(rows[static_cast<std::size_t>(i)], terms[static_cast<std::size_t>(i)]);
    // Stable: duplicates are summed in the order of the terms, as in place.
    // A short column (a net's: 24 terms) by insertion, which needs no buffer
    // (std::stable_sort allocates one per call: a million at 10⁶
    // coordinates); a long one (a chain's dense ∇∇V) by merging.
    if (column.size() <= 64) {
      for (std::size_t i = 1; i < column.size(); ++i) {
        const std::pair<int, double> term = column[i];
        std::size_t j = i;
        for (; j > 0 && column[j - 1].first > term.first; --j) column[j] = column[j - 1];
        column[j] = term;
      }
    } else {
      std::stable_sort(column.begin(), column.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    }
    for (std::size_t i = 0; i < column.size(); ++i) {
      if (i > 0 && column[i].first == column[i - 1].first) {
        terms[static_cast<std::size_t>(kept - 1)] += column[i].second;
        continue;
      }
      rows[static_cast<std::size_t>(kept)] = column[i].first;
      terms[static_cast<std::size_t>(kept)] = column[i].second;
      ++kept;
    }
    outer[k + 1] = kept;
  }
  H.resize(n, n);
  H.resizeNonZeros(kept);
  std::copy(outer.begin(), outer.end(), H.outerIndexPtr());
  std::copy_n(rows.begin(), kept, H.innerIndexPtr());
  std::copy_n(terms.begin(), kept, H.valuePtr());
}

}  // namespace

std::optional<MeetingEnds> spring_with_meeting_ends(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map() || s.springs().empty()) return std::nullopt;
  const TreeState<double>& st = kinematics(s, w, q);
  const double tolerance = std::sqrt(std::numeric_limits<double>::epsilon());
  for (std::size_t i = 0; i < s.springs().size(); ++i) {
    const Spring& sp = s.springs()[i];
    if (sp.rest_length == 0.0) continue;
    const Vec3 xa = model::world_point(st, sp.a), xb = model::world_point(st, sp.b);
    const double distance = (xa - xb).norm();
    const double rounding = 8 * std::numeric_limits<double>::epsilon() * (xa.norm() + xb.norm());
    if (distance <= std::max(tolerance * sp.rest_length, rounding)) return MeetingEnds{i, distance};
  }
  return std::nullopt;
}

std::string describe_meeting_ends(const System& s, const MeetingEnds& meet) {
  const Spring& sp = s.springs().at(meet.spring);
  auto end = [&](const Attachment& a) {
    return a.body < 0 ? std::string("the world") : "'" + s.bodies()[static_cast<std::size_t>(a.body)].name + "'";
  };
  using text::format_number;
  return "the ends of the spring between " + end(sp.a) + " and " + end(sp.b) + " (rest length " +
         format_number(sp.rest_length, 4) + " m) meet at this configuration (" + format_number(meet.distance, 3) +
         " m apart): V is not differentiable there (the spring's force has no direction)";
}

double potential(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map()) {
    check_size(s, q, "potential");
    return map_eval::potential(s, q);
  }
  return model::potential(s, kinematics(s, w, q), q.data());
}

const VectorX& potential_gradient(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map()) {
    check_size(s, q, "potential_gradient");
    map_eval::gradient(s, q, w.gradient);
    return w.gradient;
  }
  const TreeState<double>& st = kinematics(s, w, q);
  gradient_with(s, st, q.data(), w.cache(), w.gradient, [](auto&&) {}, element_parts(s), &w.cache().second);
  return w.gradient;
}

const MatrixX& potential_hessian(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map()) {
    check_size(s, q, "potential_hessian");
    map_eval::hessian(s, q, w.hessian);
    return w.hessian;
  }
  MatrixX& H = w.hessian;
  H.setZero(s.size(), s.size());
  assemble_potential_hessian(s, w, q, dense_adder(H));
  return H;
}

MatrixX potential_hessian_magnitude(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map()) return potential_hessian(s, w, q).cwiseAbs();  // one expression per entry: no terms to separate
  MatrixX E = MatrixX::Zero(s.size(), s.size());
  assemble_potential_hessian(s, w, q, [&E](int j, int k, double v) { E(j, k) += std::abs(v); }, nullptr,
                             SpringBlocks::term_sizes);
  return E;
}

namespace {
// An adder that hands on each term's |value| (the magnitudes' assembly).
template <class Add>
struct SizeAdder {
  Add& add;
  void operator()(int j, int k, double v) { add(j, k, std::abs(v)); }
};

// ∇∇V into H (with springs' blocks as `blocks` says; ::term_sizes: the
// magnitudes, every term added as its |value|): in place on H's pattern
// where H has one that holds every term, else by columns (the first
// assembly, which finds the pattern).
void assemble_sparse_hessian(const System& s, Workspace& w, const VectorX& q, SparseMatrix& H, SpringBlocks blocks) {
  const bool absolute = blocks == SpringBlocks::term_sizes;
  // The entries touched depend on the system only, not on q: after the first
  // assembly each entry is added in place (binary search in its column),
  // which avoids sorting one triplet per term (36 per spring) every time.
  if (H.rows() == s.size() && H.cols() == s.size() && H.isCompressed() && H.nonZeros() > 0) {
    const std::size_t parts = element_parts(s);
    const auto nonzeros = static_cast<std::size_t>(H.nonZeros());
    std::fill_n(H.valuePtr(), nonzeros, 0.0);
    std::vector<double>& second = w.cache().second_values;  // part 1's terms (element_parts)
    if (parts > 1) second.assign(nonzeros, 0.0);
    bool fits = true, second_fits = true;
    auto add = in_place_adder(H, H.valuePtr(), fits);
    auto add_second = in_place_adder(H, second.data(), second_fits);
    SizeAdder<decltype(add)> add_size{add}, add_second_size{add_second};
    if (absolute)
      assemble_potential_hessian_in_parts(
          s, w, q, [&](std::size_t part) -> auto& { return part == 0 ? add_size : add_second_size; }, parts, nullptr,
          blocks);
    else
      assemble_potential_hessian_in_parts(
          s, w, q, [&](std::size_t part) -> auto& { return part == 0 ? add : add_second; }, parts, nullptr, blocks);
    if (parts > 1) {
      double* values = H.valuePtr();
      for (std::size_t i = 0; i < nonzeros; ++i) values[i] += second[i];
    }
    if (fits && second_fits) return;
  }
  assemble_by_columns(
      s.size(),
      [&](auto&& add) {
        SizeAdder<std::remove_reference_t<decltype(add)>> add_size{add};
        if (absolute)
          assemble_potential_hessian_in_parts(s, w, q, [&add_size](std::size_t) -> auto& { return add_size; }, 1,
                                              nullptr, blocks);
        else
          assemble_potential_hessian_in_parts(s, w, q, [&add](std::size_t) -> auto& { return add; }, 1, nullptr,
                                              blocks);
      },
      H);
}
}  // namespace

const SparseMatrix& sparse_potential_hessian(const System& s, Workspace& w, const VectorX& q) {
  SparseMatrix& H = w.sparse_hessian;
  if (s.is_map()) {
    H = potential_hessian(s, w, q).sparseView();
    return H;
  }
  assemble_sparse_hessian(s, w, q, H, SpringBlocks::as_computed);
  return H;
}

const SparseMatrix& sparse_convex_potential_hessian(const System& s, Workspace& w, const VectorX& q) {
  SparseMatrix& C = w.sparse_convex_hessian;
  if (s.is_map()) {
    C = sparse_potential_hessian(s, w, q);
    return C;
  }
  // On ∇∇V's pattern (the same terms), taken from the workspace's.
  const SparseMatrix& H = w.sparse_hessian;
  const bool patterned = H.rows() == s.size() && H.isCompressed() && H.nonZeros() > 0;
  if (patterned && !(C.rows() == H.rows() && C.nonZeros() == H.nonZeros() && C.isCompressed())) C = H;
  assemble_sparse_hessian(s, w, q, C, SpringBlocks::convex);
  return C;
}

SparseMatrix sparse_potential_hessian_magnitude(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map()) {  // one expression per entry: no terms to separate
    SparseMatrix E = sparse_potential_hessian(s, w, q).cwiseAbs();
    E.makeCompressed();
    return E;
  }
  // On ∇∇V's pattern (every term's entry), taken from the workspace's.
  const SparseMatrix& H = w.sparse_hessian;
  SparseMatrix E;
  if (H.rows() == s.size() && H.isCompressed() && H.nonZeros() > 0) E = H;
  assemble_sparse_hessian(s, w, q, E, SpringBlocks::term_sizes);
  return E;
}

SparseMatrix sparse_rounding_form(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map() || s.springs().empty()) return {};
  // On ∇∇V's pattern (the springs' blocks and the diagonal), taken from the
  // workspace's.
  const SparseMatrix& H = w.sparse_hessian;
  SparseMatrix F;
  if (H.rows() == s.size() && H.isCompressed() && H.nonZeros() > 0) F = H;
  assemble_sparse_hessian(s, w, q, F, SpringBlocks::rounding_form);
  return F;
}

SpringRounding spring_rounding(const System& s, Workspace& w, const VectorX& q) {
  SpringRounding out;
  if (s.is_map() || s.springs().empty()) return out;
  const int n = s.size();
  const TreeState<double>& st = kinematics(s, w, q);
  out.others = VectorX::Zero(n);
  auto add_other = [&out](int j, int k, double v) {
    out.others(j) += 0.5 * std::abs(v);
    out.others(k) += 0.5 * std::abs(v);
  };
  std::vector<Eigen::Triplet<double>> rows;
  std::vector<Eigen::Matrix<double, 6, 1>> blocks;
  blocks.reserve(s.springs().size());
  std::array<PointJacobian, 2> J;
  accumulate(
      s, w, true,
      [&](std::size_t) {
        return [&](const auto& sites, const auto& He) {
          if constexpr (std::tuple_size_v<std::decay_t<decltype(sites)>> == 2) {
            const int e = static_cast<int>(blocks.size());
            for (std::size_t end = 0; end < 2; ++end) {
              site_jacobian(s, st, sites[end], J[end]);
              const double sign = end == 0 ? 1.0 : -1.0;  // v = ẋ_a − ẋ_b
              for (std::size_t i = 0; i < J[end].index.size(); ++i)
                for (int c = 0; c < 3; ++c)
                  if (J[end].column[i](c) != 0.0) rows.emplace_back(3 * e + c, J[end].index[i], sign * J[end].column[i](c));
            }
            blocks.push_back(spring_rounding_sizes(sites, He));
            return;
          }
          DiagonalHalves<decltype(add_other)&> halves{add_other};
          add_local_hessian(s, st, sites, He, halves);
        };
      },
      nullptr, 1);
  DiagonalHalves<decltype(add_other)&> halves{add_other};
  other_hessian_terms(s, st, w, q, halves, nullptr);
  out.G.resize(3 * static_cast<Eigen::Index>(blocks.size()), n);
  out.G.setFromTriplets(rows.begin(), rows.end());
  out.blocks.resize(6, static_cast<Eigen::Index>(blocks.size()));
  for (std::size_t e = 0; e < blocks.size(); ++e) out.blocks.col(static_cast<Eigen::Index>(e)) = blocks[e];
  return out;
}

SparseMatrix sparse_tension_metric(const System& s, Workspace& w, const VectorX& q) {
  const int n = s.size();
  SparseMatrix D(n, n);
  if (s.is_map()) {
    D.setIdentity();
    return D;
  }
  const TreeState<double>& st = kinematics(s, w, q);
  auto terms = [&](auto&& add) {
    for (int k = 0; k < n; ++k) add(k, k, 0.0);  // the diagonal, always in the pattern
    Eigen::Matrix<double, 6, 6> He;
    for (const Spring& sp : s.springs()) {
      He.setZero();
      for (int i = 0; i < 3; ++i) {
        He(i, i) = He(i + 3, i + 3) = sp.stiffness;
        He(i, i + 3) = He(i + 3, i) = -sp.stiffness;
      }
      const std::array<Site, 2> ends{attachment_site(st, sp.a), attachment_site(st, sp.b)};
      add_local_hessian(s, st, ends, He, add);
    }
    const auto& bodies = s.bodies();
    for (std::size_t b = 0; b < bodies.size(); ++b) {
      if (bodies[b].stiffness == 0.0) continue;
      const int k0 = s.first_coordinate(static_cast<int>(b));
      for (int i = 0; i < s.joint_size(static_cast<int>(b)); ++i) add(k0 + i, k0 + i, bodies[b].stiffness);
    }
  };
  // On the pattern of ∇∇V where the workspace has one that holds every term
  // (a net's: the same springs' blocks and the diagonal), in place, which
  // spares the sorting of assemble_by_columns and gives H + μD one pattern.
  const SparseMatrix& H = w.sparse_hessian;
  if (H.rows() == n && H.cols() == n && H.isCompressed() && H.nonZeros() > 0) {
    D = H;
    std::fill_n(D.valuePtr(), D.nonZeros(), 0.0);
    bool fits = true;
    terms(in_place_adder(D, D.valuePtr(), fits));
    if (fits) return D;
  }
  assemble_by_columns(n, terms, D);
  return D;
}

double force_scale(const System& s, Workspace& w, const VectorX& q) { return force_scales(s, w, q).full; }

namespace {

// Visits every element that produces a generalized force at q, with the
// magnitudes the force scales count (units of force, or of moment for a turn):
//   v.point_load(at, f)                     a force through a point (gravity, a
//                                            dead or follower load, a centrifugal force)
//   v.turn_load(body, m)                    a moment on a body's rotations (|Ω|²‖I‖)
//   v.joint_spring(k, full, acting, round, stiffness)  on coordinate k itself (a
//                                            moment, or a force for a length)
//   v.spring(a, b, full, acting, round, stiffness)  a spring's force through its
//                                            two ends, and its stiffness (N/m)
// full: the spring at 100 % strain (a joint spring at 1 rad or the length
// scale) beyond its actual strain; acting: the force at q; round: the size
// its rounding is relative to (for a spring, with the distances of its ends
// from the origin, from which its length is computed).
template <class Visitor>
void visit_force_elements(const System& s, const TreeState<double>& st, const VectorX& q, Visitor& v) {
  const auto& bodies = s.bodies();
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const Body& body = bodies[b];
    const Attachment com{static_cast<int>(b), body.com};
    if (body.mass != 0.0) v.point_load(com, body.mass * s.gravity().norm());
    if (s.rotating()) {
      // Centrifugal forces: m|Ω|²|x| at the centre of mass, |Ω|²‖I‖ on the body's rotations.
      const double w2 = s.frame_rotation().squaredNorm();
      if (body.mass != 0.0) v.point_load(com, body.mass * w2 * model::world_point(st, com).norm());
      v.turn_load(static_cast<int>(b), w2 * body.inertia.norm());
    }
    if (body.stiffness == 0.0) continue;
    const int k0 = s.first_coordinate(static_cast<int>(b));
    model::joint_spring_gradient(body, q.data() + k0, s.joint_size(static_cast<int>(b)), [&](int i, double force) {
      const double unit = s.coordinates()[static_cast<std::size_t>(k0 + i)].kind == CoordinateKind::length ? s.length_scale() : 1.0;
      const double strain = std::abs(force) / body.stiffness;
      const double full = body.stiffness * (strain + unit);
      v.joint_spring(k0 + i, full, body.stiffness * strain, full, body.stiffness);
    });
  }
  for (const DeadLoad& l : s.loads()) v.point_load(l.at, l.force.norm());
  for (const FollowerLoad& l : s.followers()) v.point_load(l.at, l.force.norm());
  for (const Spring& sp : s.springs()) {
    const Vec3 xa = model::world_point(st, sp.a), xb = model::world_point(st, sp.b);
    const double len = (xa - xb).norm();
    const double stretch = std::abs(len - sp.rest_length), longest = std::max(sp.rest_length, len);
    v.spring(sp.a, sp.b, sp.stiffness * (stretch + longest), sp.stiffness * stretch,
             sp.stiffness * (stretch + longest + xa.norm() + xb.norm()), sp.stiffness);
  }
}

}  // namespace

ForceScales force_scales(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map()) {
    check_size(s, q, "force_scale");
    const double full = map_eval::force_scale(s, q);
    return {full, full, full};
  }
  const TreeState<double>& st = kinematics(s, w, q);
  struct Sums {
    const PathJacobianNorms jacobian;
    double loads = 0;                           // which every scale counts
    double full = 0, acting = 0, rounding = 0;  // the springs' part of each; rounding: Σ (element's)²
    void point_load(const Attachment& at, double f) { loads += f * jacobian.point(at); }
    void turn_load(int body, double m) { loads += m * std::sqrt(jacobian.turn2(body)); }
    void joint_spring(int, double f, double a, double r, double) {
      full += f;
      acting += a;
      rounding += r * r;
    }
    void spring(const Attachment& a, const Attachment& b, double f, double act, double r, double) {
      const double reach = jacobian.point(a) + jacobian.point(b);
      full += f * reach;
      acting += act * reach;
      rounding += std::pow(r * reach, 2);
    }
  } sums{PathJacobianNorms(s, st)};
  visit_force_elements(s, st, q, sums);
  return {sums.loads + sums.full, sums.loads + sums.acting, std::sqrt(sums.rounding) + sums.loads};
}

CoordinateForceScales coordinate_force_scales(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map()) {
    check_size(s, q, "coordinate_force_scales");
    return {};
  }
  const TreeState<double>& st = kinematics(s, w, q);
  const auto nb = s.bodies().size();
  // Per body b and scale (full, acting, rounding): F, the forces acting on
  // points of b's subtree, and D, each times its point's distance from b's
  // joint centre (the moment arm about it), summed from the leaves up with
  // |x − p_a| ≤ |x − p_b| + |p_b − p_a|; T, the turn loads of the subtree.
  // Coordinate k of body b then moves them by at most |ω_k| D + |u_k| F.
  // Likewise K = (Σ k, Σ k·arm, Σ k·arm²) of the springs' ends, for the
  // stiffness scale |ω_k|² K₂ + 2|ω_k||u_k| K₁ + |u_k|² K₀ (the springs,
  // Σ k |∂x/∂q_k|² bounded) + |ω_k|² (D_acting + T) (the loads' curvature).
  struct Sums {
    const System& s;
    const TreeState<double>& st;
    std::vector<std::array<double, 3>> F, D, K;
    std::vector<double> T;
    CoordinateForceScales out;
    void add(const Attachment& at, const std::array<double, 3>& f) {
      if (at.body < 0) return;
      const auto b = static_cast<std::size_t>(at.body);
      const double arm = model::relative_point(st, at).norm();
      for (std::size_t c = 0; c < 3; ++c) {
        F[b][c] += f[c];
        D[b][c] += f[c] * arm;
      }
    }
    void point_load(const Attachment& at, double f) { add(at, {f, f, f}); }
    void turn_load(int body, double m) { T[static_cast<std::size_t>(body)] += m; }
    void joint_spring(int k, double f, double a, double r, double stiffness) {
      out.full[k] += f;
      out.acting[k] += a;
      out.rounding[k] += r;
      out.stiffness[k] += stiffness;
    }
    void spring_end(const Attachment& at, double stiffness) {
      if (at.body < 0) return;
      const auto b = static_cast<std::size_t>(at.body);
      const double arm = model::relative_point(st, at).norm();
      K[b][0] += stiffness;
      K[b][1] += stiffness * arm;
      K[b][2] += stiffness * arm * arm;
    }
    void spring(const Attachment& a, const Attachment& b, double f, double act, double r, double stiffness) {
      add(a, {f, act, r});
      add(b, {f, act, r});
      spring_end(a, stiffness);
      spring_end(b, stiffness);
    }
  } sums{s, st, std::vector<std::array<double, 3>>(nb, {0.0, 0.0, 0.0}),
         std::vector<std::array<double, 3>>(nb, {0.0, 0.0, 0.0}), std::vector<std::array<double, 3>>(nb, {0.0, 0.0, 0.0}),
         std::vector<double>(nb, 0.0),
         CoordinateForceScales{VectorX::Zero(s.size()), VectorX::Zero(s.size()), VectorX::Zero(s.size()),
                               VectorX::Zero(s.size())}};
  visit_force_elements(s, st, q, sums);
  for (std::size_t b = nb; b-- > 0;) {
    const int k0 = s.first_coordinate(static_cast<int>(b));
    for (int k = k0; k < k0 + s.joint_size(static_cast<int>(b)); ++k) {
      const double turn = st.omega[static_cast<std::size_t>(k)].norm();
      const double move = st.centre_velocity[static_cast<std::size_t>(k)].norm();
      const double loads = turn * sums.T[b];
      sums.out.full[k] += turn * sums.D[b][0] + move * sums.F[b][0] + loads;
      sums.out.acting[k] += turn * sums.D[b][1] + move * sums.F[b][1] + loads;
      sums.out.rounding[k] += turn * sums.D[b][2] + move * sums.F[b][2] + loads;
      const std::array<double, 3>& K = sums.K[b];
      sums.out.stiffness[k] += turn * turn * K[2] + 2 * turn * move * K[1] + move * move * K[0] +
                               turn * turn * (sums.D[b][1] + sums.T[b]);
    }
    const int parent = s.bodies()[b].parent;
    if (parent < 0) continue;
    const auto p = static_cast<std::size_t>(parent);
    const double d = st.offset[b].norm();
    for (std::size_t c = 0; c < 3; ++c) {
      sums.F[p][c] += sums.F[b][c];
      sums.D[p][c] += sums.D[b][c] + sums.F[b][c] * d;
    }
    const std::array<double, 3>& K = sums.K[b];
    sums.K[p][0] += K[0];
    sums.K[p][1] += K[1] + d * K[0];
    sums.K[p][2] += K[2] + 2 * d * K[1] + d * d * K[0];
    sums.T[p] += sums.T[b];
  }
  return sums.out;
}

namespace {

// The rounding level of a computed force against its rounding scale
// (ForceScales::rounding, CoordinateForceScales::rounding).
constexpr double rounding_level = 8 * std::numeric_limits<double>::epsilon();

// relative_residual(s, w, q, r) with the whole-scene scales at hand.
double relative_residual_with(const System& s, Workspace& w, const VectorX& q, const VectorX& r, const ForceScales& scales,
                              const CoordinateForceScales* given) {
  double relative = relative_residual(r.norm(), scales);
  if (s.is_map() || s.has_constraints()) return relative;
  const CoordinateForceScales computed = given ? CoordinateForceScales{} : coordinate_force_scales(s, w, q);
  const CoordinateForceScales& each = given ? *given : computed;
  // A coordinate whose residual is within its rounding level (8ε × its
  // rounding scale, which counts the springs' world points' distances from
  // the origin) adds nothing: a net 3 km from the origin carries 1e-11 of a
  // node's own forces as rounding, which the whole-scene measure hides.
  for (Eigen::Index k = 0; k < r.size(); ++k)
    if (each.full[k] > 0 && std::abs(r[k]) > rounding_level * each.rounding[k])
      relative = std::max(relative, relative_residual(std::abs(r[k]), {each.full[k], each.acting[k], each.rounding[k]}));
  return relative;
}

}  // namespace

double relative_residual(const System& s, Workspace& w, const VectorX& q, const VectorX& r) {
  return relative_residual_with(s, w, q, r, force_scales(s, w, q), nullptr);
}

std::optional<double> relative_residual_if_scaled(const System& s, Workspace& w, const VectorX& q, const VectorX& r,
                                                  const CoordinateForceScales* each) {
  const ForceScales scales = force_scales(s, w, q);
  if (!(scales.full > 0)) return std::nullopt;
  return relative_residual_with(s, w, q, r, scales, each);
}

std::optional<ResidualRounding> residual_rounding(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map() || s.has_constraints()) return std::nullopt;
  const ForceScales scales = force_scales(s, w, q);
  if (!(scales.full > 0) || !std::isfinite(scales.rounding)) return std::nullopt;
  return ResidualRounding{rounding_level * scales.rounding, rounding_level * coordinate_force_scales(s, w, q).rounding};
}

double relative_residual(double residual_norm, const ForceScales& scales) {
  if (residual_norm == 0) return 0;
  if (!(scales.full > 0) || !std::isfinite(scales.full)) return std::numeric_limits<double>::infinity();
  const double relative = residual_norm / scales.full;
  const double level = scales.rounding > 0 ? scales.rounding : scales.full;
  const double beyond_rounding = residual_norm - rounding_level * level;
  if (!(beyond_rounding > 0)) return relative;
  if (!(scales.acting > 0)) return std::numeric_limits<double>::infinity();
  return std::max(relative, beyond_rounding / scales.acting);
}

const MatrixX& mass_matrix(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map()) {
    check_size(s, q, "mass_matrix");
    map_eval::mass_matrix(s, q, w.mass);
    return w.mass;
  }
  model::mass_matrix(s, kinematics(s, w, q), w.mass);
  return w.mass;
}

VectorX inertia_scale(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map()) {
    check_size(s, q, "inertia_scale");
    return VectorX();
  }
  const TreeState<double>& st = kinematics(s, w, q);
  const model::Inertias<double> Ic = model::composite_inertias(s, st);
  VectorX scale(s.size());
  for (std::size_t b = 0; b < s.bodies().size(); ++b) {
    const int k0 = s.first_coordinate(static_cast<int>(b));
    for (int k = k0; k < k0 + s.joint_size(static_cast<int>(b)); ++k)  // ‖ω_k‖ ≤ 1, ‖u_k‖ = 1; and the armature
      scale[k] = (st.omega[static_cast<std::size_t>(k)].isZero(0.0) ? Ic[b](3, 3) : Ic[b].block<3, 3>(0, 0).trace()) +
                 s.bodies()[b].armature;
  }
  return scale;
}

namespace {

// Σ_b (coordinates on b's path)²: the cost of assembling M body by body in a
// basis whose columns reach beyond a parent (absolute_mass_matrix).
double path_coordinate_work(const System& s) {
  const auto& bodies = s.bodies();
  std::vector<double> on_path(bodies.size(), 0.0);
  double work = 0;
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    on_path[b] = s.joint_size(static_cast<int>(b)) +
                 (bodies[b].parent >= 0 ? on_path[static_cast<std::size_t>(bodies[b].parent)] : 0.0);
    work += on_path[b] * on_path[b];
  }
  return work;
}

// Above this work (a chain of about 390 coordinates) only hinges under a
// parallel parent hinge are linked, as their assembly (model::region_inertias)
// is O(n·depth); the general assembly is O(Σ path²).
constexpr double general_link_work = 2e7;

bool is_held(const System& s, const std::vector<int>& parents, std::size_t b) {
  const int a = s.bodies()[b].parent;
  if (a < 0 || s.bodies()[b].joint != JointType::hinge || s.bodies()[static_cast<std::size_t>(a)].joint != JointType::hinge)
    return false;
  return parents[static_cast<std::size_t>(s.first_coordinate(static_cast<int>(b)))] == s.first_coordinate(a);
}

// M in the basis θ (q = Tθ, q_k = θ_k − θ_parent(k)) assembled body by body
// from the twists of T's columns, and the coordinates' natural inertia
// scales. Column j turns the subtree of j's body about p_j and turns back the
// subtree of every k linked to it (parent[k] = j), so that subtree moves by
// ξ_j − ξ_k: formed as (δω, δω × (x − p_k) + ω_j × d_k + u_j − u_k) with δω =
// ω_j − ω_k and d_k = p_k − p_j summed from the offsets between, nothing
// cancels. δω is dropped for a held hinge (model::region_inertias makes the
// same choice in ∇∇V).
void absolute_mass_matrix(const System& s, const TreeState<double>& st, const std::vector<int>& parent, MatrixX& M,
                          VectorX& scale) {
  const int n = s.size();
  const auto& bodies = s.bodies();
  std::vector<int> body_of(static_cast<std::size_t>(n));
  for (std::size_t b = 0; b < bodies.size(); ++b)
    for (int i = 0; i < s.joint_size(static_cast<int>(b)); ++i)
      body_of[static_cast<std::size_t>(s.first_coordinate(static_cast<int>(b)) + i)] = static_cast<int>(b);
  std::vector<Vec3> d(static_cast<std::size_t>(n), Vec3::Zero());  // p_k − p_parent(k)
  std::vector<char> exact(static_cast<std::size_t>(n), 0);         // δω kept
  for (int k = 0; k < n; ++k) {
    const int j = parent[static_cast<std::size_t>(k)];
    if (j < 0) continue;
    const auto bk = static_cast<std::size_t>(body_of[static_cast<std::size_t>(k)]);
    exact[static_cast<std::size_t>(k)] = !is_held(s, parent, bk);
    for (int c = static_cast<int>(bk); c != body_of[static_cast<std::size_t>(j)]; c = bodies[static_cast<std::size_t>(c)].parent)
      d[static_cast<std::size_t>(k)] += st.offset[static_cast<std::size_t>(c)];
  }
  M.setZero(n, n);
  scale.setZero(n);
  std::vector<int> cols;
  std::vector<Vec3> lever;  // per path coordinate: p_b − p of its body
  Eigen::Matrix<double, 6, Eigen::Dynamic> J, J_q;  // θ's and q's columns
  std::vector<char> replaced;
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    cols.clear();
    lever.clear();
    Vec3 l = Vec3::Zero();
    for (int a = static_cast<int>(b); a >= 0; a = bodies[static_cast<std::size_t>(a)].parent) {
      for (int c = s.first_coordinate(a) + s.joint_size(a); c-- > s.first_coordinate(a);) {
        cols.push_back(c);
        lever.push_back(l);
      }
      l += st.offset[static_cast<std::size_t>(a)];
    }
    const auto m = static_cast<Eigen::Index>(cols.size());
    if (m == 0) continue;
    J.resize(6, m);
    for (Eigen::Index i = 0; i < m; ++i) {
      const auto c = static_cast<std::size_t>(cols[static_cast<std::size_t>(i)]);
      J.col(i) << st.omega[c], st.omega[c].cross(lever[static_cast<std::size_t>(i)]) + st.centre_velocity[c];
    }
    J_q = J;
    // Links within the path: column j gains −ξ_k. The deepest such k (met
    // first) is combined with ξ_j as written above, any further one subtracted.
    replaced.assign(static_cast<std::size_t>(m), 0);
    for (Eigen::Index i = 0; i < m; ++i) {
      const auto k = static_cast<std::size_t>(cols[static_cast<std::size_t>(i)]);
      const int j = parent[k];
      if (j < 0) continue;
      const auto it = std::find(cols.begin() + i + 1, cols.end(), j);
      if (it == cols.end()) continue;
      const auto at = static_cast<std::size_t>(it - cols.begin());
      const auto jj = static_cast<std::size_t>(j);
      if (replaced[at]) {
        J.col(static_cast<Eigen::Index>(at)) -= J_q.col(i);
        continue;
      }
      replaced[at] = 1;
      const Vec3 dw = exact[k] ? Vec3(st.omega[jj] - st.omega[k]) : Vec3::Zero();
      J.col(static_cast<Eigen::Index>(at)) << dw,
          dw.cross(lever[static_cast<std::size_t>(i)]) + st.omega[jj].cross(d[k]) +
              (st.centre_velocity[jj] - st.centre_velocity[k]);
    }
    const Eigen::Matrix<double, 6, 6> I = model::spatial_inertia(bodies[b], st, b);
    const MatrixX IJ = I * J;
    const MatrixX B = J.transpose() * IJ;
    const double trace = I.block<3, 3>(0, 0).trace(), h = I.block<3, 3>(0, 3).norm(), mass = I(3, 3);
    for (Eigen::Index i = 0; i < m; ++i) {
      const auto ci = cols[static_cast<std::size_t>(i)];
      for (Eigen::Index r = 0; r < m; ++r) M(cols[static_cast<std::size_t>(r)], ci) += B(r, i);
      const double w = J.col(i).head<3>().norm(), v = J.col(i).tail<3>().norm();
      scale[ci] += w * w * trace + 2 * w * v * h + mass * v * v;
    }
  }
  // Armatures: ½a(|ω|² + |u|²) of each joint's own rate, q̇_c = θ̇_c − θ̇_parent(c).
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const double a = bodies[b].armature;
    if (a == 0.0) continue;
    const int k0 = s.first_coordinate(static_cast<int>(b)), nq = s.joint_size(static_cast<int>(b));
    for (int c = k0; c < k0 + nq; ++c)
      for (int e = k0; e < k0 + nq; ++e) {
        const auto cc = static_cast<std::size_t>(c), ee = static_cast<std::size_t>(e);
        const double v = a * (st.omega[cc].dot(st.omega[ee]) + st.centre_velocity[cc].dot(st.centre_velocity[ee]));
        const int pc = parent[cc], pe = parent[ee];
        M(c, e) += v;
        if (pc >= 0) M(pc, e) -= v;
        if (pe >= 0) M(c, pe) -= v;
        if (pc >= 0 && pe >= 0) M(pc, pe) += v;
        if (c == e) {
          scale[c] += std::abs(v);
          if (pc >= 0) scale[pc] += std::abs(v);
        }
      }
  }
  M = 0.5 * (M + M.transpose()).eval();
}

// X ← T₂ᵀ X T₂ with T₂ = I − Σ e_k e_{m(k)}ᵀ; with `magnitude`, |T₂|ᵀ X |T₂|.
void congruence(MatrixX& X, const std::vector<int>& m, bool magnitude) {
  const double sign = magnitude ? 1.0 : -1.0;
  const MatrixX A = X;
  for (std::size_t k = 0; k < m.size(); ++k)
    if (m[k] >= 0) X.col(m[k]) += sign * A.col(static_cast<Eigen::Index>(k));
  const MatrixX B = X;
  for (std::size_t k = 0; k < m.size(); ++k)
    if (m[k] >= 0) X.row(m[k]) += sign * B.row(static_cast<Eigen::Index>(k));
}

}  // namespace

std::vector<int> absolute_angle_parents(const System& s, Workspace& w, const VectorX& q) {
  std::vector<int> parent(static_cast<std::size_t>(s.size()), -1);
  if (s.is_map()) return parent;
  const TreeState<double>& st = kinematics(s, w, q);
  const auto& bodies = s.bodies();
  constexpr double tolerance = 8 * std::numeric_limits<double>::epsilon();  // both unit vectors
  const bool general = path_coordinate_work(s) <= general_link_work;
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const int k0 = s.first_coordinate(static_cast<int>(b));
    for (int k = k0; k < k0 + s.joint_size(static_cast<int>(b)); ++k) {
      const Vec3& wk = st.omega[static_cast<std::size_t>(k)];
      if (wk.isZero(0.0)) continue;  // a translation
      // The nearest coordinate above k's body turning about the same world axis.
      for (int a = bodies[b].parent, steps = 0; a >= 0 && parent[static_cast<std::size_t>(k)] < 0;
           a = bodies[static_cast<std::size_t>(a)].parent, ++steps) {
        if (!general && (steps > 0 || bodies[b].joint != JointType::hinge ||
                         bodies[static_cast<std::size_t>(a)].joint != JointType::hinge))
          break;
        for (int j = s.first_coordinate(a) + s.joint_size(a); j-- > s.first_coordinate(a);)
          if ((wk - st.omega[static_cast<std::size_t>(j)]).norm() <= tolerance) {
            parent[static_cast<std::size_t>(k)] = j;
            break;
          }
      }
    }
  }
  return parent;
}

void keep_favourable_links(const System& s, const MatrixX& M, const MatrixX& K, std::vector<int>& parents) {
  const Eigen::Index n = M.rows();
  if (n != s.size() || M.cols() != n || K.rows() != n || K.cols() != n ||
      static_cast<Eigen::Index>(parents.size()) != n)
    throw std::invalid_argument("keep_favourable_links: M, K (n×n) and one parent entry per coordinate are required");
  // Links with a hinge at one end or both: a ball's component measured from
  // a ball's (a ball chain's spin from the ball above) lost digits of M in
  // relative angles that the estimates did not state, even at these
  // margins. A hinge under a ball's component is decided like one under a
  // hinge: left absolute, a stiff light tip under a ball pendulum made one
  // of the pendulum's swing modes "zero".
  std::vector<char> hinge(static_cast<std::size_t>(n), 0);
  for (std::size_t b = 0; b < s.bodies().size(); ++b)
    if (s.bodies()[b].joint == JointType::hinge) hinge[static_cast<std::size_t>(s.first_coordinate(static_cast<int>(b)))] = 1;
  constexpr double eps = std::numeric_limits<double>::epsilon();
  // The digits of the pair's Schur complement onto j lost in each basis: the
  // diagonal entry there over |S|, at most 1/ε (S below ε of the entry: all).
  auto losses = [](const MatrixX& X, Eigen::Index j, Eigen::Index k) -> std::pair<double, double> {
    const double relative = std::abs(X(j, j)), absolute = std::abs(X(j, j) - 2 * X(j, k) + X(k, k));
    if (X(k, k) == 0 || !std::isfinite(relative) || !std::isfinite(absolute)) return {1.0, 1.0};
    const double schur = std::abs(X(j, j) - X(j, k) * X(j, k) / X(k, k));
    auto loss = [&](double entry) {
      if (entry == 0) return 1.0;
      return schur > eps * entry ? std::max(1.0, entry / schur) : 1 / eps;
    };
    return {loss(relative), loss(absolute)};
  };
  for (Eigen::Index k = 0; k < n; ++k) {
    const int j = parents[static_cast<std::size_t>(k)];
    if (j < 0 || !(hinge[static_cast<std::size_t>(j)] || hinge[static_cast<std::size_t>(k)])) continue;
    const auto [mass_relative, mass_absolute] = losses(M, j, k);
    const auto [stiffness_relative, stiffness_absolute] = losses(K, j, k);
    const double relative = std::max(mass_relative, stiffness_relative);
    if (relative <= 1e2 && std::max(mass_absolute, stiffness_absolute) >= 1e4 * relative)
      parents[static_cast<std::size_t>(k)] = -1;
  }
}

namespace {

// The proof of point_mass_chain_mass below (all of it but writing M) and
// the chain's signed lengths l_b and masses m_b (n each); false, the two
// unspecified, where the bodies do not prove a chain. With `held` null, all
// but the hinges' being held (the caller's to check).
bool chain_levers(const System& s, const TreeState<double>& st, const std::vector<char>* held, VectorX& lever,
                  VectorX& mass) {
  const int n = s.size();
  const auto& bodies = s.bodies();
  if (s.is_map() || n < 2 || static_cast<int>(bodies.size()) != n) return false;
  lever.resize(n);
  mass.resize(n);
  Vec3 first = Vec3::Zero();
  for (int b = 0; b < n; ++b) {
    const Body& body = bodies[static_cast<std::size_t>(b)];
    if (body.joint != JointType::hinge || s.joint_size(b) != 1 || s.first_coordinate(b) != b || body.parent != b - 1 ||
        (b > 0 && held && !(*held)[static_cast<std::size_t>(b)]) || !(body.mass > 0) || !body.inertia.isZero(0.0) ||
        body.armature != 0 || (b + 1 < n && body.com != bodies[static_cast<std::size_t>(b) + 1].origin))
      return false;
    const auto u = static_cast<std::size_t>(b);
    const Vec3 across = st.omega[u].cross(st.rotation[u] * body.com);
    const double size = across.norm();
    if (!(size > 0) || !std::isfinite(size)) return false;
    if (b == 0) {
      first = across;
      lever(b) = size;
    } else {
      const double sine2 = across.cross(first).squaredNorm(), scale = across.squaredNorm() * first.squaredNorm();
      if (!(sine2 <= std::numeric_limits<double>::epsilon() / 16 * scale)) return false;
      lever(b) = across.dot(first) < 0 ? -size : size;
    }
    mass(b) = body.mass;
  }
  return true;
}

// M in absolute angles written out where the bodies themselves prove the
// scene a point-mass chain (PointMassChain): body b the child of b − 1 with
// a hinge parallel to its parent's (held, all of them), no rotational
// inertia and no armature, each centre of mass exactly at the child's joint
// (com_b == origin_{b+1}, both in b's frame), and the chain straight at q
// (the levers' parts across the axis, ω_b × R_b com_b in the world,
// parallel to sin² ≤ ε/16, so that the entries' factor cos(θ_i − θ_j) is
// ±1 to within ε/16). Then M_ij = l_i l_j μ_max(i,j) exactly, l_b =
// |ω_b × R_b com_b| (in the world, as the scene's kinematics make it: a
// body's orientation need be orthogonal only to 1e-12, and the body frame's
// lengths would then differ from the world's) signed by the lever's
// direction against body 0's, and formed so each entry is within three
// roundings and μ's (compensated_suffix_sums) of the M of the scene's kinematics
// (R_b com_b exact where the orientations are the identity and q = 0, a
// few roundings per level else), where the tree's assembly (composite
// inertias, plainly summed)
// left up to 18ε on a chain of 300 equal links: the pencil such a chain
// solves (ChainMass, with l from M's diagonal) then carries the scene's
// lengths to a few ε. Returns whether it applied; M is left as it was if not.
bool point_mass_chain_mass(const System& s, const TreeState<double>& st, const std::vector<char>& held, MatrixX& M) {
  const int n = s.size();
  VectorX lever, mass;
  if (M.rows() != n || M.cols() != n || !chain_levers(s, st, &held, lever, mass)) return false;
  const VectorX below = sums::compensated_suffix_sums(mass);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i <= j; ++i) M(i, j) = M(j, i) = lever(i) * lever(j) * below(j);
  return true;
}

}  // namespace

AbsoluteAngleModel absolute_angle_model(const System& s, Workspace& w, const VectorX& q,
                                        const std::vector<int>& parents) {
  const int n = s.size();
  if (s.is_map() || static_cast<int>(parents.size()) != n)
    throw std::invalid_argument("absolute_angle_model: a tree and one parent entry per coordinate are required");
  std::vector<char> held(s.bodies().size(), 0);
  for (std::size_t b = 0; b < s.bodies().size(); ++b) held[b] = is_held(s, parents, b) ? 1 : 0;
  // The links that are not a hinge under its parent hinge: T = T₁T₂, T₁ of
  // the held hinges (assembled below in θ₁ = T₁⁻¹q by region sums), T₂ = I −
  // Σ e_k e_{m(k)}ᵀ, m(k) the coordinate the chain of held links above k
  // starts from.
  std::vector<int> m2(static_cast<std::size_t>(n), -1);
  bool general = false;
  for (std::size_t b = 0; b < s.bodies().size(); ++b)
    for (int k = s.first_coordinate(static_cast<int>(b)); k < s.first_coordinate(static_cast<int>(b)) + s.joint_size(static_cast<int>(b)); ++k) {
      const int j = parents[static_cast<std::size_t>(k)];
      if (j < 0) continue;
      if (held[b]) {
        m2[static_cast<std::size_t>(k)] = m2[static_cast<std::size_t>(j)];
      } else {
        m2[static_cast<std::size_t>(k)] = j;
        general = true;
      }
    }
  AbsoluteAngleModel m;
  m.parent = parents;
  const TreeState<double>& st = kinematics(s, w, q);
  const model::Inertias<double> Ic = model::composite_inertias(s, st);
  if (general) {
    absolute_mass_matrix(s, st, parents, m.M, m.inertia_scale);
  } else {
    model::mass_matrix(s, st, Ic, m.M, &held);
    // Natural scales as inertia_scale: the region's rotational trace plus the
    // held children's translation, m_c |offset_c|² (≥ M_kk for a unit ω).
    const model::Inertias<double> region = model::region_inertias(s, st, Ic, held);
    m.inertia_scale.resize(n);
    for (std::size_t b = 0; b < s.bodies().size(); ++b) {
      const int k0 = s.first_coordinate(static_cast<int>(b));
      for (int k = k0; k < k0 + s.joint_size(static_cast<int>(b)); ++k)
        m.inertia_scale[k] = (st.omega[static_cast<std::size_t>(k)].isZero(0.0) ? Ic[b](3, 3)
                                                                                 : region[b].block<3, 3>(0, 0).trace()) +
                             s.bodies()[b].armature;
    }
    for (std::size_t c = 0; c < s.bodies().size(); ++c)
      if (held[c]) {
        const int k = s.first_coordinate(s.bodies()[c].parent);
        m.inertia_scale[k] += Ic[c](3, 3) * st.offset[c].squaredNorm() + s.bodies()[c].armature;
      }
  }
  if (!general) point_mass_chain_mass(s, st, held, m.M);
  m.K.setZero(n, n);
  assemble_potential_hessian(s, w, q, dense_adder(m.K), &held);
  m.K = 0.5 * (m.K + m.K.transpose()).eval();
  m.K_magnitude.setZero(n, n);
  assemble_potential_hessian(s, w, q, [&m](int j, int k, double v) { m.K_magnitude(j, k) += std::abs(v); }, &held,
                             SpringBlocks::term_sizes);
  if (general) {  // ∇∇V has no second-order lengths to lose: T₂ᵀ(T₁ᵀ∇∇V T₁)T₂ keeps ε|T₂|ᵀ|K||T₂|
    congruence(m.K, m2, false);
    congruence(m.K_magnitude, m2, true);
  }
  m.chain = point_mass_chain(s, m.M, parents);
  return m;
}

PointMassChain point_mass_chain(const System& s, const MatrixX& M, const std::vector<int>& parents) {
  const int n = s.size();
  const auto& bodies = s.bodies();
  if (s.is_map() || n < 2 || M.rows() != n || M.cols() != n || static_cast<int>(parents.size()) != n ||
      static_cast<int>(bodies.size()) != n)
    return {};
  for (int b = 0; b < n; ++b)
    if (s.joint_size(b) != 1 || s.first_coordinate(b) != b || bodies[static_cast<std::size_t>(b)].parent != b - 1 ||
        parents[static_cast<std::size_t>(b)] != b - 1 || !(bodies[static_cast<std::size_t>(b)].mass > 0))
      return {};
  PointMassChain c;
  c.mass.resize(n);
  for (int j = 0; j < n; ++j) c.mass(j) = bodies[static_cast<std::size_t>(j)].mass;
  const VectorX below = sums::compensated_suffix_sums(c.mass);
  // M_jj = l_j² μ_j, M_0j = l_0 l_j μ_j: |l_j| from the diagonal, its sign
  // from the first row (l_0 > 0: the chain's direction is a convention).
  c.lever.resize(n);
  for (int j = 0; j < n; ++j) {
    const double size = std::sqrt(M(j, j) / below(j));
    if (!(size > 0) || !std::isfinite(size) || (j > 0 && M(0, j) == 0)) return {};
    c.lever(j) = j > 0 && M(0, j) < 0 ? -size : size;
  }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i <= j; ++i) {
      const double model = c.lever(i) * c.lever(j) * below(j);
      c.mismatch = std::max(c.mismatch, std::abs(M(i, j) - model) / std::abs(model));
      if (!(c.mismatch <= 1e-11)) return {};
    }
  return c;
}

std::optional<std::string> tree_pencil_unsupported(const System& s) {
  if (s.is_map()) return "it is a kinematic map, not a tree of bodies";
  if (!s.springs().empty()) return "its springs between points couple bodies across the tree";
  if (s.has_constraints()) return "it has constraints";
  if (s.has_follower_loads()) return "it has follower loads";
  if (s.has_damping()) return "it has dampers";
  if (s.rotating()) return "its frame rotates";
  for (const Body& b : s.bodies())
    if (b.joint != JointType::hinge && b.joint != JointType::slide && b.joint != JointType::fixed)
      return std::string("body '") + b.name + "' has a " + to_string(b.joint) + " joint (only hinges, slides and fixed joints)";
  return std::nullopt;
}

namespace {

// TreePencil::chain and its K: where the bodies prove a point-mass chain of
// parallel hinges (chain_levers) and ∇∇V in its absolute angles has no
// entry off the diagonal (no joint springs), O(n) in all (tree_hessian skips
// the held links' runs).
void fill_absolute_chain(const System& s, Workspace& w, const VectorX& q, TreePencil& p) {
  const int n = s.size();
  if (s.is_map() || n < 2 || static_cast<int>(s.bodies().size()) != n) return;
  // (tree_pencil runs at every matrix-free Newton step: the bodies' own
  // test first, which any other tree fails at once.)
  PointMassChain chain;
  if (!chain_levers(s, kinematics(s, w, q), nullptr, chain.lever, chain.mass)) return;
  const std::vector<int> parents = absolute_angle_parents(s, w, q);
  std::vector<char> held(s.bodies().size(), 0);
  for (std::size_t b = 0; b < held.size(); ++b) {
    held[b] = is_held(s, parents, b) ? 1 : 0;
    if (b > 0 && !held[b]) return;
  }
  VectorX K = VectorX::Zero(n), terms = VectorX::Zero(n);
  bool diagonal = true;
  assemble_potential_hessian(
      s, w, q,
      [&](int j, int k, double v) {
        if (j == k) K(j) += v;
        else if (v != 0) diagonal = false;
      },
      &held);
  if (!diagonal) return;
  assemble_potential_hessian(
      s, w, q, [&](int j, int k, double v) { if (j == k) terms(j) += std::abs(v); }, &held,
      SpringBlocks::term_sizes);
  p.chain = std::move(chain);
  p.chain_K = std::move(K);
  p.chain_K_terms = std::move(terms);
}

}  // namespace

TreePencil tree_pencil(const System& s, Workspace& w, const VectorX& q) {
  if (const auto why = tree_pencil_unsupported(s)) throw std::invalid_argument("tree_pencil: " + *why);
  const TreeState<double>& st = kinematics(s, w, q);
  accumulate(s, w, true, [](std::size_t) { return [](auto&&...) {}; });  // gravity and dead loads: no local Hessians
  const auto& bodies = s.bodies();
  const std::size_t nb = bodies.size();
  const model::Inertias<double> Ic = model::composite_inertias(s, st);
  TreePencil p;
  p.parent.resize(nb);
  p.coordinate.resize(nb);
  p.twist.resize(nb);
  p.offset.resize(nb);
  p.K.resize(nb);
  p.M.resize(nb);
  p.K_diagonal = VectorX::Zero(s.size());
  p.M_diagonal = VectorX::Zero(s.size());
  std::vector<int> depth(nb, 0);
  for (std::size_t b = 0; b < nb; ++b) {
    const Body& body = bodies[b];
    p.parent[b] = body.parent;
    depth[b] = 1 + (body.parent >= 0 ? depth[static_cast<std::size_t>(body.parent)] : 0);
    p.depth = std::max(p.depth, depth[b]);
    p.offset[b] = st.offset[b];
    p.M[b] = Ic[b];
    const Mat3& P = w.cache().P[b];
    const Vec3& F = w.cache().F[b];
    p.K[b].setZero();
    p.K[b].block<3, 3>(0, 0) = P - P.trace() * Mat3::Identity();
    p.K[b].block<3, 3>(0, 3) = -model::hat(F);
    if (s.joint_size(static_cast<int>(b)) == 0) {
      p.coordinate[b] = -1;
      p.twist[b].setZero();
      continue;
    }
    const int k = s.first_coordinate(static_cast<int>(b));
    p.coordinate[b] = k;
    p.twist[b] = model::coordinate_twist(st, k);
    p.K_diagonal[k] = body.stiffness;
    p.M_diagonal[k] = body.armature;  // a·(|ω|² + |u|²) = a for a hinge or slide
  }
  fill_absolute_chain(s, w, q, p);
  return p;
}

double kinetic_energy(const System& s, Workspace& w, const VectorX& q, const VectorX& qd) {
  check_size(s, qd, "kinetic_energy");
  return 0.5 * qd.dot(mass_matrix(s, w, q) * qd);
}

double energy(const System& s, Workspace& w, const VectorX& q, const VectorX& qd) {
  return kinetic_energy(s, w, q, qd) + potential(s, w, q);
}

namespace {

// D(q) entry by entry into add(j, k, v) (both triangles): joint dampers, and
// spring dampers c (uᵀ(J_a − J_b))ᵀ(uᵀ(J_a − J_b)), a rank-one term on the
// coordinates that move either end.
template <class Add> void assemble_damping(const System& s, Workspace& w, const VectorX& q, Add&& add) {
  const TreeState<double>& st = kinematics(s, w, q);
  const auto& bodies = s.bodies();
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const Body& body = bodies[b];
    if (body.damping == 0.0) continue;
    const int k0 = s.first_coordinate(static_cast<int>(b));
    const int nq = s.joint_size(static_cast<int>(b));
    for (int i = 0; i < nq; ++i)
      if (!is_rotation_vector(body, i)) add(k0 + i, k0 + i, body.damping);
    if (body.joint == JointType::ball || body.joint == JointType::free) {
      // The damper resists the relative angular velocity J_l(φ) φ̇.
      const int r0 = k0 + (body.joint == JointType::free ? 3 : 0);
      const Mat3 Jl = model::rotation_left_jacobian<double>(q.segment<3>(r0));
      const Mat3 block = body.damping * Jl.transpose() * Jl;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) add(r0 + i, r0 + j, block(i, j));
    }
  }
  for (const Spring& sp : s.springs()) {
    if (sp.damping == 0.0) continue;
    const Vec3 xa = model::world_point(st, sp.a), xb = model::world_point(st, sp.b);
    const double len = (xa - xb).norm();
    if (len == 0.0)
      throw NumericalError("a damped spring has coincident end points: the damper's direction is undefined");
    const Vec3 u = (xa - xb) / len;
    std::vector<std::pair<int, double>> row;  // uᵀ (J_a − J_b), by coordinate
    const PointJacobian Ja = point_jacobian(s, st, sp.a), Jb = point_jacobian(s, st, sp.b);
    for (std::size_t i = 0; i < Ja.index.size(); ++i) row.emplace_back(Ja.index[i], u.dot(Ja.column[i]));
    for (std::size_t i = 0; i < Jb.index.size(); ++i) row.emplace_back(Jb.index[i], -u.dot(Jb.column[i]));
    for (const auto& [i, a] : row)
      for (const auto& [j, b] : row) add(i, j, sp.damping * a * b);
  }
}

}  // namespace

MatrixX damping_matrix(const System& s, Workspace& w, const VectorX& q) {
  MatrixX D = MatrixX::Zero(s.size(), s.size());
  assemble_damping(s, w, q, dense_adder(D));
  return D;
}

SparseMatrix sparse_damping_matrix(const System& s, Workspace& w, const VectorX& q) {
  std::vector<Eigen::Triplet<double>> t;
  assemble_damping(s, w, q, triplet_adder(t));
  SparseMatrix D(s.size(), s.size());
  D.setFromTriplets(t.begin(), t.end());
  return D;
}

SparseMatrix sparse_mass_matrix(const System& s, Workspace& w, const VectorX& q) {
  if (s.is_map()) return mass_matrix(s, w, q).sparseView();
  const TreeState<double>& st = kinematics(s, w, q);
  std::vector<Eigen::Triplet<double>> t;
  model::mass_matrix_entries(s, st, model::composite_inertias(s, st), [&t](int j, int k, double v) {
    if (v == 0.0) return;
    t.emplace_back(j, k, v);
    if (j != k) t.emplace_back(k, j, v);
  });
  SparseMatrix M(s.size(), s.size());
  M.setFromTriplets(t.begin(), t.end());
  return M;
}

VectorX generalized_forces(const System& s, Workspace& w, const VectorX& q, const VectorX& qd) {
  check_size(s, qd, "generalized_forces");
  VectorX Q = VectorX::Zero(s.size());
  if (s.has_follower_loads()) {
    // Q_j = f·∂x/∂q_j: the tree gradient of the cotangents e = f.
    kinematics(s, w, q);
    accumulate_followers(s, w, false);
    tree_gradient(s, w.cache().st, w.cache(), Q);
  }
  if (s.has_damping()) Q -= damping_matrix(s, w, q) * qd;
  return Q;
}

// ∂Q_j/∂q_k = f·∂²x/∂q_j∂q_k + (ω_k × f)·∂x/∂q_j for f = R_b f_body at x = p_b + R_b r
// (∂f/∂q_k = ω_k × f; slides and coordinates off b's path leave f unchanged).
// The first term is the tree Hessian of the cotangents e = f (minus the
// geometric stiffness of a dead load equal to the current force); the second
// is a product of the path's point-Jacobian columns and rotated forces.
MatrixX generalized_force_jacobian(const System& s, Workspace& w, const VectorX& q) {
  const int n = s.size();
  MatrixX A = MatrixX::Zero(n, n);
  if (!s.has_follower_loads()) {
    check_size(s, q, "generalized_force_jacobian");
    return A;
  }
  const TreeState<double>& st = kinematics(s, w, q);
  accumulate_followers(s, w, true);
  tree_hessian(s, st, w.cache(), q, dense_adder(A));
  for (const FollowerLoad& l : s.followers()) {
    const Vec3 f = follower_force(st, l);
    const PointJacobian J = point_jacobian(s, st, l.at);
    for (std::size_t c = 0; c < J.index.size(); ++c) {
      const int k = J.index[c];
      const Vec3 df = st.omega[static_cast<std::size_t>(k)].cross(f);  // ∂f/∂q_k
      if (df.isZero(0.0)) continue;
      for (std::size_t r = 0; r < J.index.size(); ++r) A(J.index[r], k) += df.dot(J.column[r]);
    }
  }
  return A;
}

namespace {

// Directional derivatives of M (into *dM when given) and of the frame coupling g
// (into *dg when given) along up to B directions at once (forward-mode AD).
template <int B>
void kinetic_directional(const System& s, const VectorX& q, const std::vector<VectorX>& dirs, std::size_t first,
                         std::vector<MatrixX>* dM, std::vector<VectorX>* dg) {
  using D = Dual<double, B>;
  const int n = s.size();
  model::VX<D> qd(n);
  for (int i = 0; i < n; ++i) {
    qd[i] = D(q[i]);
    for (int d = 0; d < B && first + static_cast<std::size_t>(d) < dirs.size(); ++d)
      qd[i].d[static_cast<std::size_t>(d)] = dirs[first + static_cast<std::size_t>(d)][i];
  }
  model::MX<D> M;
  model::VX<D> g;
  if (s.is_map()) {
    kmap::Reduced<D> r = kmap::reduced<D>(s, qd.data(), dM != nullptr, dg != nullptr, false);
    M = std::move(r.M);
    g = std::move(r.g);
  } else {
    TreeState<D> st;
    model::forward_kinematics(s, qd.data(), st);
    const model::Inertias<D> Ic = model::composite_inertias(s, st);
    if (dM != nullptr) model::mass_matrix(s, st, Ic, M);
    if (dg != nullptr) model::frame_coupling(s, st, Ic, g);
  }
  for (int d = 0; d < B && first + static_cast<std::size_t>(d) < dirs.size(); ++d) {
    const std::size_t o = first + static_cast<std::size_t>(d);
    const auto dd = static_cast<std::size_t>(d);
    if (dM != nullptr) {
      (*dM)[o].resize(n, n);
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) (*dM)[o](i, j) = M(i, j).d[dd];
    }
    if (dg != nullptr) {
      (*dg)[o].resize(n);
      for (int i = 0; i < n; ++i) (*dg)[o][i] = g[i].d[dd];
    }
  }
}

// ∂M along every direction (when dM) and ∂g along every direction (when dg), sized here.
void kinetic_along(const System& s, const VectorX& q, const std::vector<VectorX>& dirs, std::vector<MatrixX>* dM,
                   std::vector<VectorX>* dg) {
  constexpr int B = 4;
  if (dM != nullptr) dM->assign(dirs.size(), MatrixX());
  if (dg != nullptr) dg->assign(dirs.size(), VectorX());
  for (std::size_t first = 0; first < dirs.size(); first += B) kinetic_directional<B>(s, q, dirs, first, dM, dg);
}

std::vector<MatrixX> mass_matrix_along(const System& s, const VectorX& q, const std::vector<VectorX>& dirs) {
  std::vector<MatrixX> out;
  kinetic_along(s, q, dirs, &out, nullptr);
  return out;
}

std::vector<VectorX> unit_directions(int n) {
  std::vector<VectorX> dirs;
  for (int k = 0; k < n; ++k) dirs.push_back(VectorX::Unit(n, k));
  return dirs;
}

}  // namespace

std::vector<MatrixX> mass_matrix_derivatives(const System& s, Workspace& /*w*/, const VectorX& q) {
  check_size(s, q, "mass_matrix_derivatives");
  return mass_matrix_along(s, q, unit_directions(s.size()));
}

VectorX frame_coupling(const System& s, Workspace& w, const VectorX& q) {
  check_size(s, q, "frame_coupling");
  if (s.is_map()) return map_eval::frame_coupling(s, q);
  if (!s.rotating()) return VectorX::Zero(s.size());
  VectorX g;
  model::frame_coupling(s, kinematics(s, w, q), g);
  return g;
}

MatrixX gyroscopic_matrix(const System& s, Workspace& /*w*/, const VectorX& q) {
  check_size(s, q, "gyroscopic_matrix");
  const int n = s.size();
  if (!s.has_frame_coupling()) return MatrixX::Zero(n, n);
  std::vector<VectorX> dg;  // dg[k] = ∂g/∂q_k
  kinetic_along(s, q, unit_directions(n), nullptr, &dg);
  MatrixX J(n, n);  // J_ik = ∂g_i/∂q_k
  for (int k = 0; k < n; ++k) J.col(k) = dg[static_cast<std::size_t>(k)];
  return J - J.transpose();
}

std::vector<MatrixX> christoffel(const System& s, Workspace& w, const VectorX& q) {
  const std::vector<MatrixX> dM = mass_matrix_derivatives(s, w, q);
  const int n = s.size();
  std::vector<MatrixX> G(static_cast<std::size_t>(n), MatrixX(n, n));
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k)
        G[static_cast<std::size_t>(i)](j, k) =
            0.5 * (dM[static_cast<std::size_t>(k)](i, j) + dM[static_cast<std::size_t>(j)](i, k) - dM[static_cast<std::size_t>(i)](j, k));
  return G;
}

MatrixX coriolis(const System& s, Workspace& w, const VectorX& q, const VectorX& qd) {
  check_size(s, qd, "coriolis");
  const std::vector<MatrixX> G = christoffel(s, w, q);
  const int n = s.size();
  MatrixX C(n, n);
  for (int i = 0; i < n; ++i) C.row(i) = (G[static_cast<std::size_t>(i)] * qd).transpose();
  return C;
}

VectorX accelerations(const System& s, Workspace& w, const VectorX& q, const VectorX& qd) {
  check_size(s, qd, "accelerations");
  // C q̇ = Ṁ q̇ − ½ ∂(q̇ᵀ M q̇)/∂q: one directional derivative along q̇ and n along the axes.
  // Rotating frame, in the same pass: G q̇ = (∂g/∂q) q̇ − (∂g/∂q)ᵀ q̇ (entry k of the last: ∂g/∂q_k · q̇).
  const int n = s.size();
  std::vector<VectorX> dirs{qd};
  for (int k = 0; k < n; ++k) dirs.push_back(VectorX::Unit(n, k));
  std::vector<MatrixX> dM;
  std::vector<VectorX> dg;
  kinetic_along(s, q, dirs, &dM, s.has_frame_coupling() ? &dg : nullptr);
  VectorX cqd = dM[0] * qd;
  for (int k = 0; k < n; ++k) cqd[k] -= 0.5 * qd.dot(dM[static_cast<std::size_t>(k + 1)] * qd);
  if (s.has_frame_coupling()) {
    cqd += dg[0];
    for (int k = 0; k < n; ++k) cqd[k] -= dg[static_cast<std::size_t>(k + 1)].dot(qd);
  }
  VectorX rhs = generalized_forces(s, w, q, qd) - cqd - potential_gradient(s, w, q);
  const MatrixX M = mass_matrix(s, w, q);
  if (!s.has_constraints()) {
    const Eigen::LLT<MatrixX> llt(M);
    if (llt.info() != Eigen::Success)
      throw NumericalError("the mass matrix is not positive definite at this configuration: accelerations are undefined");
    return llt.solve(rhs);
  }
  // Null-space method: q̈ = q̈_p + N z with A_I q̈_p = −q̇ᵀ∇∇c_I q̇ (minimum norm)
  // and NᵀMN z = Nᵀ(rhs − M q̈_p); the constraint forces ∇c s drop out (Nᵀ∇c_I = 0).
  const MatrixX A = constraint_jacobian(s, w, q);
  const ConstraintBasis basis = constraint_basis(A);
  const VectorX curvature = constraint_curvature(s, w, q, qd);
  MatrixX AI(basis.rank, n);
  VectorX gamma(basis.rank);
  for (int i = 0; i < basis.rank; ++i) {
    AI.row(i) = A.row(basis.independent[static_cast<std::size_t>(i)]);
    gamma[i] = -curvature[basis.independent[static_cast<std::size_t>(i)]];
  }
  const VectorX particular = basis.rank > 0 ? VectorX(AI.completeOrthogonalDecomposition().solve(gamma)) : VectorX::Zero(n);
  const MatrixX& N = basis.null_space;
  const Eigen::LLT<MatrixX> llt(N.transpose() * M * N);
  if (llt.info() != Eigen::Success)
    throw NumericalError("the mass matrix projected onto the constraint manifold (NᵀMN) is not positive definite at "
                         "this configuration: accelerations are undefined");
  return particular + N * llt.solve(N.transpose() * (rhs - M * particular));
}

// --- constraints ------------------------------------------------------------------
//
// c_i(q) depends on q through the world points x_a, x_b of its attachments, so
// ∇c_i = J_aᵀ ∂c/∂x_a + J_bᵀ ∂c/∂x_b (point Jacobians), and Σ s_i ∇∇c_i is the
// Hessian of the scalar sᵀc(q): an element energy like a spring's, whose
// cotangents at x_a, x_b go through the same tree accumulation (tree_hessian)
// and whose local Hessian (zero for a point constraint, linear in the points;
// s (I − uuᵀ)/|d| for a distance) adds Jᵀ H_e J.

namespace {

// The end points of a constraint at the current kinematics; a distance
// constraint needs them apart (its direction is undefined otherwise).
template <class R>
std::pair<model::V3<R>, model::V3<R>> constraint_ends(const TreeState<R>& st, const Constraint& k) {
  const model::V3<R> xa = model::world_point(st, k.a), xb = model::world_point(st, k.b);
  if (k.type == Constraint::Type::distance && value((xa - xb).squaredNorm()) == 0.0)
    throw NumericalError("the distance constraint '" + k.name +
                         "' has coincident end points here: its direction (and its force) is undefined");
  return {xa, xb};
}

// The generalized force ∇(sᵀc) of constraint multipliers s (m) as element
// cotangents: a point constraint sᵀ(x_a − x_b) deposits ±s (no local
// Hessian); a distance constraint s (|x_a − x_b| − length) is an element
// whose cotangents and local Hessian come from AD.
// The couplings' share of ∇c s (their force acts on coordinates, not at
// sites): sign·s on q_a and −sign·s·p'(q_b) on q_b, added to f (n).
template <class R>
void add_coupling_forces(const System& s, const R* q, const VectorX& multipliers, double sign, model::VX<R>& f) {
  Eigen::Index row = 0;
  for (const Constraint& k : s.constraints()) {
    if (k.type == Constraint::Type::coupling) {
      const double sk = sign * multipliers[row];
      f[s.first_coordinate(k.a.body)] += sk;
      if (k.b.body >= 0) {
        const int b = s.first_coordinate(k.b.body);
        f[b] -= sk * coupling_polynomial(k.polynomial, q[b])[1];
      }
    }
    row += k.equations();
  }
}

template <class R, class Deposit, class LocalHessian>
void for_each_constraint_cotangent(const System& s, const TreeState<R>& st, const VectorX& multipliers,
                                   Deposit&& deposit, LocalHessian&& local_hessian, bool second_order) {
  using V = model::V3<R>;
  Eigen::Index row = 0;
  for (const Constraint& k : s.constraints()) {
    if (k.type == Constraint::Type::coupling) {  // acts on coordinates, not at sites: add_coupling_forces
      row += 1;
      continue;
    }
    constraint_ends(st, k);  // throws where a distance is undefined
    if (k.type == Constraint::Type::point) {
      const V f = multipliers.segment<3>(row).cast<R>();
      deposit(attachment_site(st, k.a), f);
      deposit(attachment_site(st, k.b), V(-f));
    } else {
      const double sk = multipliers[row];
      const double length = k.length;
      auto energy = [sk, length](const auto& x) {
        using S = std::decay_t<decltype(x[0])>;
        using std::sqrt;
        const model::V3<S> d(x[0], x[1], x[2]);  // x_a − x_b
        return sk * (sqrt(d.squaredNorm()) - length);
      };
      const std::array<SiteT<R>, 2> ends{attachment_site(st, k.a), attachment_site(st, k.b)};
      deposit_difference_element(ends, energy, deposit, local_hessian, second_order);
    }
    row += k.equations();
  }
}

}  // namespace

double movable_mass(const System& s, const VectorX& q, const Vec3& d) {
  if (s.is_map()) throw std::invalid_argument("movable_mass: a kinematic map has no bodies");
  check_size(s, q, "movable_mass");
  TreeState<double> st;
  model::forward_kinematics(s, q.data(), st);
  double mass = 0;
  for (std::size_t b = 0; b < s.bodies().size(); ++b) {
    const Body& body = s.bodies()[b];
    if (body.mass == 0.0) continue;
    bool moves = false;
    for_each_site_coordinate(s, st, attachment_site(st, Attachment{static_cast<int>(b), body.com}),
                             [&](int k, const Vec3& lever) {
                               const Vec3 J = site_velocity(st, k, lever, false);
                               if (std::abs(d.dot(J)) > 1e-9 * J.norm()) moves = true;
                             });
    if (moves) mass += body.mass;
  }
  return mass;
}

VectorX constraint_values(const System& s, Workspace& w, const VectorX& q) {
  VectorX c(s.constraint_equations());
  if (c.size() == 0) return c;
  const TreeState<double>& st = kinematics(s, w, q);
  for (const Constraint& k : s.constraints()) constraint_ends(st, k);  // throws where a distance is undefined
  model::constraint_values(s, st, c);
  return c;
}

VectorX constraint_curvature(const System& s, Workspace& w, const VectorX& q, const VectorX& qd) {
  check_size(s, qd, "constraint_curvature");
  const VectorX c = constraint_values(s, w, q);  // sizes, and the distance constraints defined
  if (c.size() == 0) return c;
  // c(q + τ q̇) with second-order duals in τ: its second derivative is q̇ᵀ∇∇c q̇.
  using D1 = Dual<double, 1>;
  using D2 = Dual<D1, 1>;
  std::vector<D2> x(static_cast<std::size_t>(s.size()));
  for (int i = 0; i < s.size(); ++i) {
    D2& xi = x[static_cast<std::size_t>(i)];
    xi.v = D1(q[i]);
    xi.v.d[0] = qd[i];
    xi.d[0] = D1(qd[i]);
  }
  TreeState<D2> st;
  model::forward_kinematics(s, x.data(), st);
  model::VX<D2> cd;
  model::constraint_values(s, st, cd);
  VectorX out(cd.size());
  for (Eigen::Index i = 0; i < cd.size(); ++i) out[i] = cd[i].d[0].d[0];
  return out;
}

MatrixX constraint_jacobian(const System& s, Workspace& w, const VectorX& q) {
  MatrixX A = MatrixX::Zero(s.constraint_equations(), s.size());
  if (A.rows() == 0) {
    check_size(s, q, "constraint_jacobian");
    return A;
  }
  const TreeState<double>& st = kinematics(s, w, q);
  Eigen::Index row = 0;
  for (const Constraint& k : s.constraints()) {
    if (k.type == Constraint::Type::coupling) {
      A(row, s.first_coordinate(k.a.body)) = 1;
      if (k.b.body >= 0) {
        const int b = s.first_coordinate(k.b.body);
        A(row, b) = -coupling_polynomial(k.polynomial, q[b])[1];
      }
      row += 1;
      continue;
    }
    const auto [xa, xb] = constraint_ends(st, k);
    const PointJacobian Ja = point_jacobian(s, st, k.a), Jb = point_jacobian(s, st, k.b);
    const Vec3 axis = (xa - xb).normalized();  // distance constraints: the direction between the ends
    auto add = [&](const PointJacobian& J, double sign) {
      for (std::size_t i = 0; i < J.index.size(); ++i) {
        if (k.type == Constraint::Type::point)
          A.block<3, 1>(row, J.index[i]) += sign * J.column[i];
        else
          A(row, J.index[i]) += sign * axis.dot(J.column[i]);
      }
    };
    add(Ja, 1.0);
    add(Jb, -1.0);
    row += k.equations();
  }
  return A;
}

MatrixX constraint_hessian(const System& s, Workspace& w, const VectorX& q, const VectorX& multipliers) {
  const int n = s.size();
  if (multipliers.size() != s.constraint_equations())
    throw std::invalid_argument("constraint_hessian: expected " + std::to_string(s.constraint_equations()) +
                                " multipliers, got " + std::to_string(multipliers.size()));
  MatrixX H = MatrixX::Zero(n, n);
  if (multipliers.size() == 0) {
    check_size(s, q, "constraint_hessian");
    return H;
  }
  const TreeState<double>& st = kinematics(s, w, q);
  auto local_hessian = [&](const auto& sites, const auto& He) { add_local_hessian(s, st, sites, He, dense_adder(H)); };
  accumulate_sums(s, st, w.cache(), true, [&](auto&& deposit) {
    for_each_constraint_cotangent(s, st, multipliers, deposit, local_hessian, true);
  });
  tree_hessian(s, st, w.cache(), q, dense_adder(H));
  Eigen::Index row = 0;  // couplings: ∇∇(s c) = −s p''(q_b) on q_b's diagonal
  for (const Constraint& k : s.constraints()) {
    if (k.type == Constraint::Type::coupling && k.b.body >= 0) {
      const int b = s.first_coordinate(k.b.body);
      H(b, b) -= multipliers[row] * coupling_polynomial(k.polynomial, q[b])[2];
    }
    row += k.equations();
  }
  return 0.5 * (H + H.transpose());
}

std::vector<Pose> body_poses(const System& s, Workspace& w, const VectorX& q) {
  const TreeState<double>& st = kinematics(s, w, q);
  std::vector<Pose> poses(s.bodies().size());
  for (std::size_t b = 0; b < poses.size(); ++b) poses[b] = {st.rotation[b], st.position[b]};
  return poses;
}

std::vector<PoseRate> body_pose_rates(const System& s, const VectorX& q, const VectorX& dq) {
  std::vector<PoseRate> rates;
  if (s.is_map()) return rates;
  check_size(s, q, "body_pose_rates");
  check_size(s, dq, "body_pose_rates");
  using D1 = Dual<double, 1>;
  std::vector<D1> x(static_cast<std::size_t>(s.size()));
  for (int i = 0; i < s.size(); ++i) {
    x[static_cast<std::size_t>(i)] = D1(q[i]);
    x[static_cast<std::size_t>(i)].d[0] = dq[i];
  }
  TreeState<D1> st;
  model::forward_kinematics(s, x.data(), st);
  rates.resize(s.bodies().size());
  for (std::size_t b = 0; b < rates.size(); ++b) {
    Mat3 R, Rdot;
    for (int r = 0; r < 3; ++r) {
      rates[b].velocity[r] = st.position[b][r].d[0];
      for (int c = 0; c < 3; ++c) {
        R(r, c) = st.rotation[b](r, c).v;
        Rdot(r, c) = st.rotation[b](r, c).d[0];
      }
    }
    const Mat3 W = Rdot * R.transpose();  // [ω]× (skew up to rounding)
    rates[b].angular = 0.5 * Vec3(W(2, 1) - W(1, 2), W(0, 2) - W(2, 0), W(1, 0) - W(0, 1));
  }
  return rates;
}

// --- derivatives by differences (DerivativeMethod) ------------------------------

const char* to_string(DerivativeMethod method) {
  switch (method) {
    case DerivativeMethod::exact: return "exact";
    case DerivativeMethod::central: return "central";
    case DerivativeMethod::forward: return "forward";
    case DerivativeMethod::complex_step: return "complex-step";
  }
  return "?";
}

std::optional<DerivativeMethod> parse_derivative_method(std::string_view word) {
  for (const DerivativeMethod m : {DerivativeMethod::exact, DerivativeMethod::central, DerivativeMethod::forward,
                                   DerivativeMethod::complex_step})
    if (word == to_string(m)) return m;
  return std::nullopt;
}

double default_step_factor(DerivativeMethod method) {
  switch (method) {
    case DerivativeMethod::forward: return std::sqrt(std::numeric_limits<double>::epsilon());
    case DerivativeMethod::central: return std::cbrt(std::numeric_limits<double>::epsilon());
    case DerivativeMethod::complex_step: return 1e-20;
    case DerivativeMethod::exact: return 0.0;
  }
  return 0.0;
}

namespace {

// The step factor to use: the method's default for 0, else `factor`, which
// must lie in (0, max_step_factor].
double checked_step_factor(DerivativeMethod method, double factor, const char* what) {
  if (factor == 0) return default_step_factor(method);
  const double least = method == DerivativeMethod::complex_step ? 0.0 : min_difference_step_factor;
  if (!(factor > least && factor <= max_step_factor) && !(factor == least && least > 0)) {
    char text[200];
    std::snprintf(text, sizeof text, "%s: the step factor must be %s %g and at most %g, got %g", what,
                  least > 0 ? "at least" : "above", least, max_step_factor, factor);
    throw std::invalid_argument(text);
  }
  return factor;
}

void check_method_applies(const System& s, DerivativeMethod method, const char* what) {
  if (method == DerivativeMethod::complex_step && s.is_map())
    throw std::invalid_argument(std::string(what) +
                                ": complex-step derivatives are not available for kinematic maps (their expressions "
                                "are evaluated in real arithmetic); use exact, central or forward");
}

// The step of coordinate j: factor × max(|q_j|, its unit), the unit being
// 1 rad or the scene's length scale; for differences made exactly
// representable ((q + h) − q = h), so that the quotient divides by the step
// actually taken.
double coordinate_step(const System& s, const VectorX& q, int j, DerivativeMethod method, double factor) {
  const double unit =
      s.coordinates()[static_cast<std::size_t>(j)].kind == CoordinateKind::length ? s.length_scale() : 1.0;
  if (method == DerivativeMethod::complex_step) return factor * unit;
  const double h = factor * std::max(std::abs(q[j]), unit);
  const double shifted = q[j] + h;
  return shifted - q[j];
}

// The columns ∂f/∂q_j (n×n) of a vector function f(q) (n) by `method`:
// central or forward differences of f evaluated through `f(x, out)` (x: n
// doubles), or complex steps Im f(q + i h e_j)/h through `fc(x, out)` (x: n
// Complex values). With `error`: 2 max(|J_h − J_2h|, |J_2h − J_4h|/2^p)
// entrywise, p the order of the method (1 forward, 2 central and complex).
// The asymptotic truncation error of J_h is all of |J_h − J_2h| for forward
// differences (O(h)) and a third of it for central ones (O(h²)); the rounding
// noise of the two sets is independent, so one difference can understate it:
// the factor 2 covers both. The third set (4h) checks that h is in the
// asymptotic range, where |J_2h − J_4h| ≈ 2^p |J_h − J_2h|: where it is not
// (a step so large that higher terms dominate, or a force nearly periodic
// over the steps, whose differences at h and 2h agree by accident) the
// larger difference at 2h and 4h, scaled back to h, is taken instead, so a
// difference error that only looks small is not trusted.
template <class F, class FC>
MatrixX jacobian_by(const System& s, const VectorX& q, DerivativeMethod method, double factor, MatrixX* error, F&& f,
                    FC&& fc) {
  const int n = s.size();
  auto columns = [&](double scale) {
    MatrixX J(n, n);
    if (method == DerivativeMethod::complex_step) {
      std::vector<Complex> x(q.data(), q.data() + n);
      model::VX<Complex> out;
      for (int j = 0; j < n; ++j) {
        const double h = scale * coordinate_step(s, q, j, method, factor);
        x[static_cast<std::size_t>(j)].im = h;
        fc(x.data(), out);
        for (int i = 0; i < n; ++i) J(i, j) = out[i].im / h;
        x[static_cast<std::size_t>(j)].im = 0.0;
      }
      return J;
    }
    VectorX f0, fp, fm;
    if (method == DerivativeMethod::forward) f(q, f0);
    VectorX x = q;
    for (int j = 0; j < n; ++j) {
      const double h = coordinate_step(s, q, j, method, scale * factor);
      x[j] = q[j] + h;
      f(x, fp);
      if (method == DerivativeMethod::central) {
        x[j] = q[j] - h;
        f(x, fm);
        J.col(j) = (fp - fm) / (2 * h);
      } else {
        J.col(j) = (fp - f0) / h;
      }
      x[j] = q[j];
    }
    return J;
  };
  MatrixX J = columns(1.0);
  if (error) {
    const MatrixX J2 = columns(2.0);
    const double order = method == DerivativeMethod::forward ? 2.0 : 4.0;  // 2^p
    *error = 2 * (J - J2).cwiseAbs().cwiseMax((J2 - columns(4.0)).cwiseAbs() / order);
  }
  return J;
}

// f(q) = ∇V − Q(q, 0) − ∇c s at the kinematics st (scalar R).
template <class R>
void rest_force_at(const System& s, const TreeState<R>& st, const R* q, const VectorX& multipliers,
                   SubtreeSums<R>& c, model::VX<R>& f) {
  gradient_with(s, st, q, c, f, [&](auto&& deposit) {
    for (const FollowerLoad& l : s.followers())
      deposit(attachment_site(st, l.at), model::V3<R>(-follower_force(st, l)));
    if (multipliers.size() > 0)
      for_each_constraint_cotangent(
          s, st, multipliers,
          [&](const SiteT<R>& site, const model::V3<R>& e) { deposit(site, model::V3<R>(-e)); },
          [](auto&&...) {}, false);
  });
  if (multipliers.size() > 0) add_coupling_forces(s, q, multipliers, -1.0, f);
}

void check_multipliers(const System& s, const VectorX& multipliers, const char* what) {
  if (multipliers.size() != 0 && multipliers.size() != s.constraint_equations())
    throw std::invalid_argument(std::string(what) + ": expected " + std::to_string(s.constraint_equations()) +
                                " multipliers (or none), got " + std::to_string(multipliers.size()));
}

}  // namespace

VectorX rest_force(const System& s, Workspace& w, const VectorX& q, const VectorX& multipliers) {
  check_multipliers(s, multipliers, "rest_force");
  if (s.is_map()) return potential_gradient(s, w, q);  // maps have no loads or constraints
  const TreeState<double>& st = kinematics(s, w, q);
  VectorX f;
  rest_force_at(s, st, q.data(), multipliers, w.cache(), f);
  return f;
}

MatrixX rest_force_jacobian(const System& s, Workspace& w, const VectorX& q, DerivativeMethod method,
                            const VectorX& multipliers, double step_factor, MatrixX* error) {
  check_size(s, q, "rest_force_jacobian");
  check_multipliers(s, multipliers, "rest_force_jacobian");
  check_method_applies(s, method, "rest_force_jacobian");
  const double factor = checked_step_factor(method, step_factor, "rest_force_jacobian");
  switch (method) {
    case DerivativeMethod::exact: {
      MatrixX K = potential_hessian(s, w, q);
      if (s.has_follower_loads()) K -= generalized_force_jacobian(s, w, q);
      if (multipliers.size() > 0) K -= constraint_hessian(s, w, q, multipliers);
      return K;
    }
    default: {
      TreeState<Complex> st;
      SubtreeSums<Complex> sums;
      return jacobian_by(
          s, q, method, factor, error, [&](const VectorX& x, VectorX& out) { out = rest_force(s, w, x, multipliers); },
          [&](const Complex* x, model::VX<Complex>& out) {
            model::forward_kinematics(s, x, st);
            rest_force_at(s, st, x, multipliers, sums, out);
          });
    }
  }
}

MatrixX gyroscopic_matrix(const System& s, Workspace& w, const VectorX& q, DerivativeMethod method, double step_factor,
                          MatrixX* error) {
  if (method == DerivativeMethod::exact) return gyroscopic_matrix(s, w, q);
  check_size(s, q, "gyroscopic_matrix");
  check_method_applies(s, method, "gyroscopic_matrix");
  const int n = s.size();
  if (!s.has_frame_coupling()) {
    if (error) *error = MatrixX::Zero(n, n);
    return MatrixX::Zero(n, n);
  }
  const double factor = checked_step_factor(method, step_factor, "gyroscopic_matrix");
  TreeState<Complex> st;
  MatrixX J_error;
  const MatrixX J = jacobian_by(  // J_ij = ∂g_i/∂q_j
      s, q, method, factor, error ? &J_error : nullptr,
      [&](const VectorX& x, VectorX& out) { out = frame_coupling(s, w, x); },
      [&](const Complex* x, model::VX<Complex>& out) {
        model::forward_kinematics(s, x, st);
        model::frame_coupling(s, st, out);
      });
  if (error) *error = J_error + J_error.transpose();  // G = J − Jᵀ
  return J - J.transpose();
}

}  // namespace modal
