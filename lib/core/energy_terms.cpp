// Energy by element: the quadratic forms vᵀM_b v and vᵀK_t v of every body
// and potential term along one direction v (modal/core.hpp, "energy by
// element"), from the model's own templated elements (model.hpp) with forward
// AD along v, so that no element formula is written twice.
#include "core/model.hpp"
#include "modal/core.hpp"

#include <stdexcept>
#include <string>

namespace modal {

namespace {

using D1 = Dual<double, 1>;
using D2 = Dual<D1, 1>;

void check_sizes(const System& s, const VectorX& q, const VectorX& v, const VectorX& multipliers) {
  if (s.is_map()) throw std::invalid_argument("element_quadratics: a kinematic map has no elements");
  if (q.size() != s.size() || v.size() != s.size())
    throw std::invalid_argument("element_quadratics: expected " + std::to_string(s.size()) + " coordinates");
  if (multipliers.size() != 0 && multipliers.size() != s.constraint_equations())
    throw std::invalid_argument("element_quadratics: expected " + std::to_string(s.constraint_equations()) +
                                " multipliers");
}

// Numbers the terms of model::for_each_potential_term: consecutive calls for
// the same (kind, index) (a body's two centrifugal terms) are one term.
class TermSlots {
 public:
  // Whether the call starts a new term.
  bool starts(model::PotentialTerm kind, std::size_t index) {
    const bool same = static_cast<int>(kind) == kind_ && index == index_;
    kind_ = static_cast<int>(kind);
    index_ = index;
    return !same;
  }

 private:
  int kind_ = -1;
  std::size_t index_ = 0;
};

}  // namespace

std::vector<std::string> potential_terms(const System& s) {
  if (s.is_map()) throw std::invalid_argument("potential_terms: a kinematic map has no elements");
  std::vector<std::string> names;
  model::TreeState<double> st;
  const VectorX q = VectorX::Zero(s.size());
  model::forward_kinematics(s, q.data(), st);
  TermSlots slots;
  model::for_each_potential_term(s, st, q.data(), [&](model::PotentialTerm kind, std::size_t i, double) {
    if (!slots.starts(kind, i)) return;
    switch (kind) {
      case model::PotentialTerm::gravity: names.push_back(s.bodies()[i].name + ".gravity"); break;
      case model::PotentialTerm::joint_spring: names.push_back(s.bodies()[i].name + ".joint"); break;
      case model::PotentialTerm::spring: names.push_back("spring" + std::to_string(i + 1)); break;
      case model::PotentialTerm::load: names.push_back("load" + std::to_string(i + 1)); break;
      case model::PotentialTerm::centrifugal: names.push_back(s.bodies()[i].name + ".centrifugal"); break;
    }
  });
  for (std::size_t i = 0; i < s.followers().size(); ++i) names.push_back("follower" + std::to_string(i + 1));
  for (const Constraint& c : s.constraints()) names.push_back(c.name);
  return names;
}

ElementQuadratics element_quadratics(const System& s, const VectorX& q, const VectorX& v, const VectorX& multipliers) {
  check_sizes(s, q, v, multipliers);
  const auto n = static_cast<std::size_t>(s.size());
  const auto& bodies = s.bodies();
  ElementQuadratics out;

  // Kinetic: velocities along v by first-order AD of the kinematics.
  {
    std::vector<D1> x(n);
    for (std::size_t i = 0; i < n; ++i) {
      x[i] = D1(q[static_cast<Eigen::Index>(i)]);
      x[i].d[0] = v[static_cast<Eigen::Index>(i)];
    }
    model::TreeState<D1> st;
    model::forward_kinematics(s, x.data(), st);
    out.kinetic.setZero(static_cast<Eigen::Index>(bodies.size()));
    for (std::size_t b = 0; b < bodies.size(); ++b) {
      const Body& body = bodies[b];
      const model::V3<D1> c = st.position[b] + st.rotation[b] * model::cast3<D1>(body.com);
      const Vec3 vc(c[0].d[0], c[1].d[0], c[2].d[0]);
      Mat3 R, Rdot;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          R(i, j) = st.rotation[b](i, j).v;
          Rdot(i, j) = st.rotation[b](i, j).d[0];
        }
      const Mat3 W = Rdot * R.transpose();  // ω̂ (skew to rounding)
      const Vec3 omega_body = R.transpose() * Vec3(0.5 * (W(2, 1) - W(1, 2)), 0.5 * (W(0, 2) - W(2, 0)),
                                                   0.5 * (W(1, 0) - W(0, 1)));
      double twice = body.mass * vc.squaredNorm() + omega_body.dot(body.inertia * omega_body);
      if (body.armature != 0.0) {  // ½a(|Σ ω_k v_k|² + |Σ u_k v_k|²) over the joint's coordinates
        Vec3 w = Vec3::Zero(), u = Vec3::Zero();
        const int k0 = s.first_coordinate(static_cast<int>(b));
        for (int k = k0; k < k0 + s.joint_size(static_cast<int>(b)); ++k) {
          const auto kk = static_cast<std::size_t>(k);
          for (int i = 0; i < 3; ++i) {
            w[i] += st.omega[kk][i].v * v[k];
            u[i] += st.centre_velocity[kk][i].v * v[k];
          }
        }
        twice += body.armature * (w.squaredNorm() + u.squaredNorm());
      }
      out.kinetic[static_cast<Eigen::Index>(b)] = twice;
      out.momentum += body.mass * vc;
    }
  }

  // Potential: second derivatives along q + τv by second-order AD.
  std::vector<D2> x(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    x[i].v = D1(q[ii]);
    x[i].v.d[0] = v[ii];
    x[i].d[0] = D1(v[ii]);
  }
  model::TreeState<D2> st;
  model::forward_kinematics(s, x.data(), st);
  std::vector<double> terms;
  TermSlots slots;
  model::for_each_potential_term(s, st, x.data(), [&](model::PotentialTerm kind, std::size_t i, const D2& e) {
    if (slots.starts(kind, i))
      terms.push_back(e.d[0].d[0]);
    else
      terms.back() += e.d[0].d[0];
  });
  // A follower load's stiffness: −vᵀ(∂Q/∂q)v = −d/dτ (ẋ·f) = −(ẍ·f + ẋ·ḟ), x its
  // point and f = R_b force its world force along q + τv.
  for (const FollowerLoad& l : s.followers()) {
    const model::V3<D2> p = model::world_point(st, l.at);
    const model::V3<D2> f = st.rotation[static_cast<std::size_t>(l.at.body)] * model::cast3<D2>(l.force);
    double t = 0;
    for (int i = 0; i < 3; ++i) t += p[i].d[0].d[0] * f[i].v.v + p[i].d[0].v * f[i].v.d[0];
    terms.push_back(-t);
  }
  // A constraint's multiplier term: −Σ s_i vᵀ∇∇c_i v.
  if (s.has_constraints()) {
    model::VX<D2> c;
    model::constraint_values(s, st, c);
    Eigen::Index row = 0;
    for (const Constraint& k : s.constraints()) {
      double t = 0;
      if (multipliers.size() != 0)
        for (int i = 0; i < k.equations(); ++i) t -= multipliers[row + i] * c[row + i].d[0].d[0];
      terms.push_back(t);
      row += k.equations();
    }
  }
  out.potential = Eigen::Map<const VectorX>(terms.data(), static_cast<Eigen::Index>(terms.size()));
  return out;
}

}  // namespace modal
