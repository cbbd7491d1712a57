// lib/core/model.hpp — the model written once, templated on the scalar.
//
// Everything a System computes comes from the functions here: the joint maps,
// the forward kinematics of the tree, the elements' energies, the mass matrix.
// With S = double they evaluate; with S = Dual (modal/ad.hpp) the same code gives
// exact derivatives. Internal header (used by lib/core and by the tests).
#pragma once

#include "modal/ad.hpp"
#include "modal/core.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <numbers>
#include <vector>

namespace modal::model {

template <class S> using V3 = Eigen::Matrix<S, 3, 1>;
template <class S> using M3 = Eigen::Matrix<S, 3, 3>;
template <class S> using VX = Eigen::Matrix<S, Eigen::Dynamic, 1>;
template <class S> using MX = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic>;

template <class S> M3<S> hat(const V3<S>& w) {
  M3<S> h;
  h << S(0.0), -w.z(), w.y(), w.z(), S(0.0), -w.x(), -w.y(), w.x(), S(0.0);
  return h;
}

template <class S, class Derived> V3<S> cast3(const Eigen::MatrixBase<Derived>& v) {
  return V3<S>(S(v[0]), S(v[1]), S(v[2]));
}
template <class S> M3<S> cast33(const Mat3& m) {
  M3<S> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = S(m(i, j));
  return r;
}

// Coefficients of the rotation-vector maps as functions of θ² = |φ|², smooth
// at 0 (series below a small θ², so that nested AD stays exact there):
//   a = sin θ / θ,  b = (1 − cos θ) / θ²,  c = (θ − sin θ) / θ³
template <class S> void rotation_coefficients(const S& t2, S& a, S& b, S& c) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  if (value(t2) < 1e-4) {  // truncation error below θ⁸/9! ≈ 3e-22
    a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0));
    b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0 * (1.0 - t2 / 56.0));
    c = 1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0));
  } else {
    const S t = sqrt(t2);
    const S s = sin(t);
    a = s / t;
    b = (1.0 - cos(t)) / t2;
    c = (t - s) / (t2 * t);
  }
}

// exp(φ̂): the rotation by angle |φ| about φ/|φ| (Rodrigues).
template <class S> M3<S> rotation_exp(const V3<S>& phi) {
  S a, b, c;
  rotation_coefficients(phi.squaredNorm(), a, b, c);
  const M3<S> h = hat(phi);
  return M3<S>::Identity() + a * h + b * (h * h);
}

// Left Jacobian of SO(3): d exp(φ̂) = (J_l(φ) dφ)^ exp(φ̂).
template <class S> M3<S> rotation_left_jacobian(const V3<S>& phi) {
  S a, b, c;
  rotation_coefficients(phi.squaredNorm(), a, b, c);
  const M3<S> h = hat(phi);
  return M3<S>::Identity() + b * h + c * (h * h);
}

// Rotation by angle q about the unit axis u.
template <class S> M3<S> rotation_axis_angle(const Vec3& u, const S& q) {
  using std::cos;
  using std::sin;
  const M3<S> h = hat(cast3<S>(u));
  return M3<S>::Identity() + sin(q) * h + (1.0 - cos(q)) * (h * h);
}

// Kinematics of the tree at q. Every body b has a reference point, its joint
// centre p_b = position[b] (the origin of its frame), and the spatial algebra
// below works about these points with RELATIVE vectors computed directly
// (offset[b] = p_b − p_parent, R_b·point for a point of the body), never as
// differences of world positions: in a graded tree (a micrometre body at the
// end of a kilometre rod) a difference of world positions would lose every
// digit of the small body's geometry (docs/design.md, "Scaling").
// For a coordinate k of body b, ∂x/∂q_k = ω_k × (x − p_b) + u_k for any point
// x moved by it, u_k = centre_velocity[k] the velocity of p_b itself (zero for
// hinges and rotation vectors, the axis for translations).
template <class S> struct TreeState {
  std::vector<M3<S>> rotation;         // per body: body → world
  std::vector<V3<S>> position;         // per body: frame origin = joint centre p_b, world
  std::vector<V3<S>> offset;           // per body: p_b − p_parent (roots: p_b), computed directly
  std::vector<V3<S>> omega;            // per coordinate
  std::vector<V3<S>> centre_velocity;  // per coordinate: u_k, the velocity of its body's p_b
  std::vector<S> q;                    // the coordinates the state was computed at (n)

  void resize(const System& sys) {
    const auto nb = sys.bodies().size();
    rotation.resize(nb);
    position.resize(nb);
    offset.resize(nb);
    omega.resize(static_cast<std::size_t>(sys.size()));
    centre_velocity.resize(static_cast<std::size_t>(sys.size()));
  }
};

template <class S> void forward_kinematics(const System& sys, const S* q, TreeState<S>& st) {
  st.resize(sys);
  st.q.assign(q, q + sys.size());
  const auto& bodies = sys.bodies();
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const Body& body = bodies[b];
    M3<S> Rp = M3<S>::Identity();
    V3<S> pp = V3<S>::Zero();
    if (body.parent >= 0) {
      Rp = st.rotation[static_cast<std::size_t>(body.parent)];
      pp = st.position[static_cast<std::size_t>(body.parent)];
    }
    const int k0 = sys.first_coordinate(static_cast<int>(b));
    const auto k = static_cast<std::size_t>(k0);
    V3<S> origin = cast3<S>(body.origin);
    // The parent frame turned by the body's fixed orientation: the frame the
    // joint acts in (Rp itself when the orientation is the identity).
    const bool turned = !body.orientation.isIdentity(0.0);
    const M3<S> Rq = turned ? M3<S>(Rp * cast33<S>(body.orientation)) : Rp;
    V3<S>& d = st.offset[b];
    switch (body.joint) {
      case JointType::fixed:
        st.rotation[b] = Rq;
        d = Rp * origin;
        break;
      case JointType::hinge: {
        st.rotation[b] = Rq * rotation_axis_angle(body.axis, q[k0]);
        d = Rp * origin;
        st.omega[k] = Rq * cast3<S>(body.axis);
        st.centre_velocity[k] = V3<S>::Zero();
        break;
      }
      case JointType::slide: {
        const V3<S> axis = Rq * cast3<S>(body.axis);
        st.rotation[b] = Rq;
        d = Rp * origin + axis * q[k0];
        st.omega[k] = V3<S>::Zero();
        st.centre_velocity[k] = axis;
        break;
      }
      case JointType::particle: {
        st.rotation[b] = Rp;
        d = Rp * origin;
        std::size_t i = k;
        for (int a = 0; a < 3; ++a) {
          if (!body.particle_axes[static_cast<std::size_t>(a)]) continue;
          const V3<S> axis = Rp.col(a);
          d += axis * q[i];
          st.omega[i] = V3<S>::Zero();
          st.centre_velocity[i] = axis;
          ++i;
        }
        break;
      }
      case JointType::ball:
      case JointType::free: {
        std::size_t r = k;  // first rotation-vector coordinate
        if (body.joint == JointType::free) {
          origin += V3<S>(q[k0], q[k0 + 1], q[k0 + 2]);
          for (std::size_t i = 0; i < 3; ++i) {
            st.omega[k + i] = V3<S>::Zero();
            st.centre_velocity[k + i] = Rp.col(static_cast<Eigen::Index>(i));
          }
          r = k + 3;
        }
        const V3<S> phi(q[r], q[r + 1], q[r + 2]);
        st.rotation[b] = Rq * rotation_exp(phi);
        d = Rp * origin;
        const M3<S> W = Rq * rotation_left_jacobian(phi);
        for (std::size_t i = 0; i < 3; ++i) {
          st.omega[r + i] = W.col(static_cast<Eigen::Index>(i));
          st.centre_velocity[r + i] = V3<S>::Zero();
        }
        break;
      }
    }
    st.position[b] = pp + d;
  }
}

// Position of an attachment relative to its body's joint centre, R_b·point
// (world attachments: the point itself).
template <class S> V3<S> relative_point(const TreeState<S>& st, const Attachment& a) {
  if (a.body < 0) return cast3<S>(a.point);
  return st.rotation[static_cast<std::size_t>(a.body)] * cast3<S>(a.point);
}

// World position of an attachment.
template <class S> V3<S> world_point(const TreeState<S>& st, const Attachment& a) {
  if (a.body < 0) return cast3<S>(a.point);
  const auto b = static_cast<std::size_t>(a.body);
  return st.position[b] + st.rotation[b] * cast3<S>(a.point);
}

// The constraint equations c(q) stacked (m; see Constraint).
template <class S> void constraint_values(const System& sys, const TreeState<S>& st, VX<S>& c) {
  using std::sqrt;
  c.resize(sys.constraint_equations());
  Eigen::Index row = 0;
  for (const Constraint& k : sys.constraints()) {
    if (k.type == Constraint::Type::coupling) {
      const S qa = st.q[static_cast<std::size_t>(sys.first_coordinate(k.a.body))];
      const S qb = k.b.body >= 0 ? st.q[static_cast<std::size_t>(sys.first_coordinate(k.b.body))] : S(0.0);
      c[row] = qa - coupling_polynomial(k.polynomial, qb)[0];
      row += 1;
      continue;
    }
    const V3<S> d = world_point(st, k.a) - world_point(st, k.b);
    if (k.type == Constraint::Type::point)
      c.template segment<3>(row) = d;
    else
      c[row] = sqrt(d.squaredNorm()) - k.length;
    row += k.equations();
  }
}

// --- elements -------------------------------------------------------------------

// Spring energy ½k(|xa − xb| − L)²; for L = 0 written as ½k|d|² (smooth at d = 0).
// The energy depends on the end points only through d = xa − xb
// (spring_stretch_energy), which is what its exact derivatives are taken in.
template <class S> S spring_stretch_energy(const Spring& sp, const V3<S>& d) {
  using std::sqrt;
  if (sp.rest_length == 0.0) return 0.5 * sp.stiffness * d.squaredNorm();
  const S ext = sqrt(d.squaredNorm()) - sp.rest_length;
  return 0.5 * sp.stiffness * ext * ext;
}
template <class S> S spring_energy(const Spring& sp, const V3<S>& xa, const V3<S>& xb) {
  return spring_stretch_energy<S>(sp, V3<S>(xa - xb));
}

// A ball joint's spring with rest exactly 0 is the geodesic ½kθ², θ ∈ [0, π]
// the angle of the rotation exp(φ) (MuJoCo's, which takes the angle of the
// relative quaternion): ½k(‖φ‖ − 2πn)² with n the whole number of turns
// nearest ‖φ‖, so ½k‖φ‖² wherever ‖φ‖ ≤ π. A function of the rotation alone:
// φ and φ(1 − 2π/‖φ‖) have the same energy, and the coordinates are periodic
// (System: canonical chart ‖φ‖ ≤ π). Any other joint spring: ½k|q − rest|².
inline bool geodesic_joint_spring(const Body& body) {
  return body.joint == JointType::ball && body.stiffness != 0.0 && body.rest.size() == 3 && body.rest.isZero(0.0);
}
// The whole turns n of the geodesic spring at rotation-vector length t.
inline double spring_turns(double t) { return std::round(t / (2 * std::numbers::pi)); }

// ∂/∂q of the joint spring energy at the joint's coordinates qj (nq of
// them): add(i, ∂V/∂q_i) for each. For any scalar (exact derivatives).
template <class R, class Add> void joint_spring_gradient(const Body& body, const R* qj, int nq, Add&& add) {
  using std::sqrt;
  if (geodesic_joint_spring(body)) {
    const R t = sqrt(qj[0] * qj[0] + qj[1] * qj[1] + qj[2] * qj[2]);
    if (const double n = spring_turns(value(t)); n != 0) {
      const R ratio = (t - 2 * std::numbers::pi * n) / t;  // θ/‖φ‖
      for (int i = 0; i < 3; ++i) add(i, R(body.stiffness * ratio * qj[i]));
      return;
    }
  }
  for (int i = 0; i < nq; ++i) add(i, R(body.stiffness * (qj[i] - body.rest[i])));
}

// ∂²/∂q² of the joint spring energy: add(i, j, value) for each nonzero entry;
// for the geodesic spring beyond ‖φ‖ = π, k((θ/t) I + (1 − θ/t) uuᵀ) with
// t = ‖φ‖, u = φ/t.
template <class Add> void joint_spring_hessian(const Body& body, const double* qj, int nq, Add&& add) {
  if (geodesic_joint_spring(body)) {
    const double t = std::sqrt(qj[0] * qj[0] + qj[1] * qj[1] + qj[2] * qj[2]);
    if (const double n = spring_turns(t); n != 0) {
      const double ratio = (t - 2 * std::numbers::pi * n) / t;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          add(i, j, body.stiffness * ((i == j ? ratio : 0.0) + (1 - ratio) * (qj[i] / t) * (qj[j] / t)));
      return;
    }
  }
  for (int i = 0; i < nq; ++i) add(i, i, body.stiffness);
}

// Joint spring energy (above): ½k|q − rest|² over the joint's coordinates, or
// a ball's geodesic ½kθ².
template <class S> S joint_spring_energy(const Body& body, const S* qj, int nq) {
  using std::sqrt;
  if (geodesic_joint_spring(body)) {
    const S t2 = qj[0] * qj[0] + qj[1] * qj[1] + qj[2] * qj[2];
    if (const double n = spring_turns(std::sqrt(value(t2))); n != 0) {
      const S theta = sqrt(t2) - 2 * std::numbers::pi * n;
      return 0.5 * body.stiffness * theta * theta;
    }
  }
  S e(0.0);
  for (int i = 0; i < nq; ++i) {
    const S d = qj[i] - body.rest[i];
    e += d * d;
  }
  return 0.5 * body.stiffness * e;
}

// --- rotating frame (System::frame_rotation() = Ω, constant, about the world origin) ---
// T₀ = ½ ξ_Ωᵀ I6 ξ_Ω with ξ_Ω = (Ω, 0) for every body; the potential carries −T₀,
// split into the part of the centre of mass (a point element) and the part of
// the rotational inertia (an element on the body-fixed directions u_i = R e_i).

// −½ m |Ω × x|²: the centrifugal potential of a point mass m at world point x.
template <class S> S centrifugal_point_energy(double m, const Vec3& Omega, const V3<S>& x) {
  return -0.5 * m * cast3<S>(Omega).cross(x).squaredNorm();
}

// −½ Ωᵀ R I Rᵀ Ω = −½ Σ_ij I_ij (Ω·u_i)(Ω·u_j) for the inertia I about the centre
// of mass (body frame) and the body-fixed world directions u_i = R e_i.
template <class S> S centrifugal_rotation_energy(const Mat3& I, const Vec3& Omega, const V3<S>* u) {
  V3<S> w;  // Rᵀ Ω: components of Ω along the body axes
  for (int i = 0; i < 3; ++i) w[i] = u[i].dot(cast3<S>(Omega));
  return -0.5 * w.dot(cast33<S>(I) * w);
}

// The terms of V one by one, in a fixed order: for each body its gravity
// (mass ≠ 0) and its joint spring (stiffness ≠ 0), then the springs, the dead
// loads and, in a rotating frame, each body's centrifugal terms (centre of mass
// and rotational inertia: two calls with the same body). term(kind, index,
// value) gets the term's kind, the index of its body, spring or load, and its
// energy (J). potential() is their sum; the energy distribution
// (modal/energy.hpp) takes them one by one.
enum class PotentialTerm { gravity, joint_spring, spring, load, centrifugal };
template <class S, class Term> void for_each_potential_term(const System& sys, const TreeState<S>& st, const S* q, Term&& term) {
  const auto& bodies = sys.bodies();
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const Body& body = bodies[b];
    if (body.mass != 0.0) {
      const V3<S> x = st.position[b] + st.rotation[b] * cast3<S>(body.com);
      term(PotentialTerm::gravity, b, S(-body.mass * x.dot(cast3<S>(sys.gravity()))));
    }
    if (body.stiffness != 0.0) {
      const int k0 = sys.first_coordinate(static_cast<int>(b));
      term(PotentialTerm::joint_spring, b, joint_spring_energy(body, q + k0, sys.joint_size(static_cast<int>(b))));
    }
  }
  for (std::size_t i = 0; i < sys.springs().size(); ++i) {
    const Spring& sp = sys.springs()[i];
    term(PotentialTerm::spring, i, spring_energy(sp, world_point(st, sp.a), world_point(st, sp.b)));
  }
  for (std::size_t i = 0; i < sys.loads().size(); ++i) {
    const DeadLoad& ld = sys.loads()[i];
    term(PotentialTerm::load, i, S(-world_point(st, ld.at).dot(cast3<S>(ld.force))));
  }
  if (sys.rotating())
    for (std::size_t b = 0; b < bodies.size(); ++b) {
      const Body& body = bodies[b];
      if (body.mass != 0.0)
        term(PotentialTerm::centrifugal, b,
             centrifugal_point_energy(body.mass, sys.frame_rotation(), V3<S>(st.position[b] + st.rotation[b] * cast3<S>(body.com))));
      if (!body.inertia.isZero(0.0)) {
        const V3<S> u[3] = {st.rotation[b].col(0), st.rotation[b].col(1), st.rotation[b].col(2)};
        term(PotentialTerm::centrifugal, b, centrifugal_rotation_energy(body.inertia, sys.frame_rotation(), u));
      }
    }
}

// V(q) in J; in a rotating frame V_eff = V − T₀ (docs/design.md, "Energies and forces").
template <class S> S potential(const System& sys, const TreeState<S>& st, const S* q) {
  S v(0.0);
  // v + (−a) is v − a exactly (IEEE), so the sum is the same as written term by term
  for_each_potential_term(sys, st, q, [&v](PotentialTerm, std::size_t, const S& e) { v += e; });
  return v;
}

// Spatial inertia (6×6, twist order (ω, v)) of one body about its joint
// centre p_b: ½ξᵀIξ is its kinetic energy for the twist ξ = (ω, v) with v the
// velocity of p_b. Blocks [[I_p, ĥ], [−ĥ, m]] with h = m c, c = R_b·com the
// centre of mass relative to p_b, I_p the rotational inertia about p_b.
template <class S> Eigen::Matrix<S, 6, 6> spatial_inertia(const Body& body, const TreeState<S>& st, std::size_t b) {
  Eigen::Matrix<S, 6, 6> I = Eigen::Matrix<S, 6, 6>::Zero();
  const V3<S> c = st.rotation[b] * cast3<S>(body.com);
  const M3<S> Iw = st.rotation[b] * cast33<S>(body.inertia) * st.rotation[b].transpose();
  const M3<S> ch = hat(c);
  const S m(body.mass);
  I.template block<3, 3>(0, 0) = Iw - m * (ch * ch);
  I.template block<3, 3>(0, 3) = m * ch;
  I.template block<3, 3>(3, 0) = -m * ch;
  I.template block<3, 3>(3, 3) = m * M3<S>::Identity();
  return I;
}

// A spatial inertia about a point p (blocks as above) moved to the point
// p − d: h' = h + m d, I' = I − ĥd̂ − d̂ĥ − m d̂d̂ (the parallel-axis shift
// written with the offset d itself, so nothing cancels).
template <class S> void add_shifted_inertia(const Eigen::Matrix<S, 6, 6>& I, const V3<S>& d, Eigen::Matrix<S, 6, 6>& out) {
  const S m = I(3, 3);
  const M3<S> hh = I.template block<3, 3>(0, 3);
  const M3<S> dh = hat(d);
  const M3<S> hs = hh + m * dh;
  out.template block<3, 3>(0, 0) += I.template block<3, 3>(0, 0) - hh * dh - dh * hh - m * (dh * dh);
  out.template block<3, 3>(0, 3) += hs;
  out.template block<3, 3>(3, 0) -= hs;
  out.template block<3, 3>(3, 3) += m * M3<S>::Identity();
}

template <class S> using Inertias = std::vector<Eigen::Matrix<S, 6, 6>>;

// Composite spatial inertias: Ic(b) = the inertia of b's subtree about b's
// joint centre p_b (children shifted in by their offsets).
template <class S> Inertias<S> composite_inertias(const System& sys, const TreeState<S>& st) {
  const auto& bodies = sys.bodies();
  const std::size_t nb = bodies.size();
  Inertias<S> Ic(nb);
  for (std::size_t b = 0; b < nb; ++b) Ic[b] = spatial_inertia(bodies[b], st, b);
  for (std::size_t b = nb; b-- > 0;)
    if (bodies[b].parent >= 0) add_shifted_inertia(Ic[b], st.offset[b], Ic[static_cast<std::size_t>(bodies[b].parent)]);
  return Ic;
}

// Absolute angles of parallel hinges (docs/design.md, "Graded scenes"). A
// body b is `held` (held[b] != 0) when its joint and its parent's are hinges
// about the same world axis: its coordinate is then replaced by the absolute
// angle θ_b = θ_parent + q_b (q = Tθ, T unit lower triangular). Moving θ_a
// with every other θ fixed turns a's body about p_a and TRANSLATES the
// subtree of each held child c by ω_a × offset[c] (the child's own angle
// stays), so every column of the new basis is formed from relative offsets
// and nothing cancels: in relative angles a short link before a long one
// makes M singular to (l_short/l_long)² and T applied afterwards cannot
// recover the lost digits. Region inertia: b's own body and the subtrees of
// its children that are not held, about p_b.
template <class S> Inertias<S> region_inertias(const System& sys, const TreeState<S>& st, const Inertias<S>& Ic,
                                               const std::vector<char>& held) {
  const auto& bodies = sys.bodies();
  Inertias<S> region(bodies.size());
  for (std::size_t b = 0; b < bodies.size(); ++b) region[b] = spatial_inertia(bodies[b], st, b);
  for (std::size_t b = 0; b < bodies.size(); ++b)
    if (bodies[b].parent >= 0 && !held[b])
      add_shifted_inertia(Ic[b], st.offset[b], region[static_cast<std::size_t>(bodies[b].parent)]);
  return region;
}

// Twist of coordinate k about its own body's joint centre, (ω_k, u_k).
template <class S> Eigen::Matrix<S, 6, 1> coordinate_twist(const TreeState<S>& st, int k) {
  Eigen::Matrix<S, 6, 1> xk;
  xk << st.omega[static_cast<std::size_t>(k)], st.centre_velocity[static_cast<std::size_t>(k)];
  return xk;
}

// Frame coupling g(q) (n) of T = ½q̇ᵀMq̇ + q̇ᵀg + T₀ in a frame rotating at Ω:
// g_k = ξ_kᵀ Ic(b(k)) ξ_Ω with ξ_Ω the frame's twist about p_b, (Ω, Ω × p_b)
// (the frame turns about the world origin), the cross term of the bodies'
// inertial twists Σ_k ξ_k q̇_k + ξ_Ω. Units kg·m²/s (angles) or kg·m/s (lengths).
template <class S> void frame_coupling(const System& sys, const TreeState<S>& st, const Inertias<S>& Ic, VX<S>& g) {
  g.setZero(sys.size());
  const V3<S> Omega = cast3<S>(sys.frame_rotation());
  for (std::size_t b = 0; b < sys.bodies().size(); ++b) {
    const int k0 = sys.first_coordinate(static_cast<int>(b));
    if (sys.joint_size(static_cast<int>(b)) == 0) continue;
    const Eigen::Matrix<S, 6, 1> xi = (Eigen::Matrix<S, 6, 1>() << Omega, Omega.cross(st.position[b])).finished();
    const Eigen::Matrix<S, 6, 1> u = Ic[b] * xi;
    for (int k = k0; k < k0 + sys.joint_size(static_cast<int>(b)); ++k) g[k] = coordinate_twist(st, k).dot(u);
  }
}
template <class S> void frame_coupling(const System& sys, const TreeState<S>& st, VX<S>& g) {
  frame_coupling(sys, st, composite_inertias(sys, st), g);
}

// M(q) by composite inertias about the joint centres: M_jk = ξ_j(p_b)ᵀ Ic(b)
// ξ_k(p_b) for k of body b and j at or above k, with ξ_j(p_b) = (ω_j, ω_j ×
// (p_b − p_a) + u_j) for j of an ancestor a (p_b − p_a accumulated from the
// offsets), handed to set(j, k, M_jk) once per pair with j at or above k (the
// caller mirrors it); pairs off a common path are zero and never visited.
// With `held` (region_inertias): M in the absolute angles of parallel hinges,
// TᵀMT assembled directly. The momentum of θ_k is then that of its region
// turning plus, for each held child c, the subtree of c translated by
// t = ω_k × offset[c]; its own diagonal is ξ_kᵀ Region ξ_k + Σ_c m_c|t|² (+ the
// armatures a_c of the held children, whose relative rate is θ̇_c − θ̇_k); and
// an ancestor a reached through a held child c moves b's subtree by the
// translation ω_a × offset[c] only.
template <class S, class Set>
void mass_matrix_entries(const System& sys, const TreeState<S>& st, const Inertias<S>& Ic, Set&& set,
                         const std::vector<char>* held = nullptr) {
  const auto& bodies = sys.bodies();
  const std::size_t nb = bodies.size();
  Inertias<S> region;
  std::vector<std::vector<std::size_t>> held_children;
  if (held) {
    region = region_inertias(sys, st, Ic, *held);
    held_children.resize(nb);
    for (std::size_t c = 0; c < nb; ++c)
      if ((*held)[c]) held_children[static_cast<std::size_t>(bodies[c].parent)].push_back(c);
  }
  auto c0 = [&](std::size_t c) { return static_cast<std::size_t>(sys.first_coordinate(static_cast<int>(c))); };
  for (std::size_t b = 0; b < nb; ++b) {
    const int k0 = sys.first_coordinate(static_cast<int>(b));
    const bool holds = held && !held_children[b].empty();  // a hinge: one coordinate
    for (int k = k0; k < k0 + sys.joint_size(static_cast<int>(b)); ++k) {
      const Eigen::Matrix<S, 6, 1> own = (held ? region[b] : Ic[b]) * coordinate_twist(st, k);
      Eigen::Matrix<S, 6, 1> u = own;
      S translation(0.0);  // Σ_c m_c|t_c|² over the held children
      if (holds)
        for (const std::size_t c : held_children[b]) {
          const V3<S> t = st.omega[static_cast<std::size_t>(k)].cross(st.offset[c]);
          const S m = Ic[c](3, 3);
          const V3<S> force = m * t;
          u.template head<3>() += Ic[c].template block<3, 3>(0, 3) * t + st.offset[c].cross(force);
          u.template tail<3>() += force;
          translation += m * t.squaredNorm() + bodies[c].armature * st.omega[c0(c)].squaredNorm();
        }
      // coordinates of this joint up to k, then of every ancestor
      auto visit = [&](int j, const V3<S>& lever) {  // lever = p_b − p_a
        const auto jj = static_cast<std::size_t>(j);
        const V3<S> v = st.omega[jj].cross(lever) + st.centre_velocity[jj];
        if (holds && j == k)
          set(j, k, S(st.omega[jj].dot(own.template head<3>()) + v.dot(own.template tail<3>()) + translation +
                      bodies[b].armature * st.omega[jj].squaredNorm()));
        else
          set(j, k, S(st.omega[jj].dot(u.template head<3>()) + v.dot(u.template tail<3>())));
      };
      V3<S> lever = V3<S>::Zero();
      const double armature = bodies[b].armature;
      for (int j = k0; j <= k; ++j) {
        if (armature == 0.0 || holds) {
          visit(j, lever);
          continue;
        }
        // The joint's armature (rotor inertia a): kinetic energy ½a(|ω|² + |v|²) of
        // the joint's own relative motion, so a on the diagonal of a hinge or
        // slide and a·J_lᵀJ_l on a rotation vector's block.
        const auto jj = static_cast<std::size_t>(j), kk = static_cast<std::size_t>(k);
        const V3<S> v = st.centre_velocity[jj];
        set(j, k, S(st.omega[jj].dot(u.template head<3>()) + v.dot(u.template tail<3>()) +
                    armature * (st.omega[jj].dot(st.omega[kk]) + v.dot(st.centre_velocity[kk]))));
      }
      for (std::size_t c = b; bodies[c].parent >= 0; c = static_cast<std::size_t>(bodies[c].parent)) {
        lever += st.offset[c];
        const int a = bodies[c].parent;
        const int a0 = sys.first_coordinate(a);
        for (int j = a0; j < a0 + sys.joint_size(a); ++j) {
          if (held && (*held)[c])  // the armature of b's own joint, q_b = θ_b − θ_a: −a
            set(j, k, S(st.omega[static_cast<std::size_t>(j)].cross(st.offset[c]).dot(u.template tail<3>()) -
                        (c == b ? armature * st.omega[static_cast<std::size_t>(k)].squaredNorm() : S(0.0))));
          else
            visit(j, lever);
        }
      }
    }
  }
}

// M(q) (n×n, dense).
// With `held`: in the absolute angles of parallel hinges (mass_matrix_entries).
template <class S>
void mass_matrix(const System& sys, const TreeState<S>& st, const Inertias<S>& Ic, MX<S>& M,
                 const std::vector<char>* held = nullptr) {
  M.setZero(sys.size(), sys.size());
  mass_matrix_entries(
      sys, st, Ic,
      [&M](int j, int k, const S& v) {
        M(j, k) = v;
        M(k, j) = v;
      },
      held);
}

template <class S> void mass_matrix(const System& sys, const TreeState<S>& st, MX<S>& M) {
  mass_matrix(sys, st, composite_inertias(sys, st), M);
}

}  // namespace modal::model
