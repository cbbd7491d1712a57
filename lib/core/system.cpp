// System: validation and coordinate layout of the constant model.
#include "modal/core.hpp"

#include "core/model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace modal {
int joint_coordinate_count(JointType t) {
  switch (t) {
    case JointType::hinge:
    case JointType::slide: return 1;
    case JointType::ball: return 3;
    case JointType::free: return 6;
    case JointType::fixed: return 0;
    case JointType::particle: return 3;
  }
  return 0;
}

int joint_coordinate_count(const Body& body) {
  if (body.joint != JointType::particle) return joint_coordinate_count(body.joint);
  return static_cast<int>(std::count(body.particle_axes.begin(), body.particle_axes.end(), true));
}

const char* to_string(JointType t) {
  switch (t) {
    case JointType::hinge: return "hinge";
    case JointType::slide: return "slide";
    case JointType::ball: return "ball";
    case JointType::free: return "free";
    case JointType::fixed: return "fixed";
    case JointType::particle: return "particle";
  }
  return "?";
}

const char* to_string(CoordinateKind k) {
  switch (k) {
    case CoordinateKind::angle: return "angle";
    case CoordinateKind::length: return "length";
    case CoordinateKind::rotation: return "rotation";
  }
  return "?";
}

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("System: " + what);
}

bool finite(const Eigen::Ref<const Eigen::MatrixXd>& m) { return m.allFinite(); }

}  // namespace

System::System(SystemDescription description) : d_(std::move(description)) {
  const auto nb = d_.bodies.size();
  q_index_.resize(nb);
  nq_.resize(nb);
  children_.assign(nb, {});
  require(finite(d_.gravity), "gravity is not finite");
  require(finite(d_.frame_rotation), "frame rotation is not finite");
  for (std::size_t b = 0; b < nb; ++b) {
    Body& body = d_.bodies[b];
    const std::string who = "body '" + body.name + "': ";
    require(body.parent < static_cast<int>(b), who + "its parent must precede it");
    if (body.parent >= 0) children_[static_cast<std::size_t>(body.parent)].push_back(static_cast<int>(b));
    require(std::isfinite(body.mass) && body.mass >= 0, who + "mass must be finite and non-negative");
    require(finite(body.origin) && finite(body.com) && finite(body.inertia), who + "non-finite geometry");
    require(std::isfinite(body.stiffness) && body.stiffness >= 0, who + "stiffness must be non-negative");
    require(std::isfinite(body.damping) && body.damping >= 0, who + "damping must be non-negative");
    require(std::isfinite(body.armature) && body.armature >= 0, who + "armature must be non-negative");
    require(finite(body.orientation) &&
                (body.orientation.transpose() * body.orientation - Mat3::Identity()).norm() < 1e-12 &&
                body.orientation.determinant() > 0,
            who + "orientation must be a rotation matrix");
    require(body.orientation.isIdentity(0.0) || body.joint != JointType::particle,
            who + "a particle has no orientation");
    if (body.joint == JointType::hinge || body.joint == JointType::slide)
      require(std::abs(body.axis.norm() - 1.0) < 1e-12, who + "axis must be a unit vector");
    const bool limited = body.lower != -std::numeric_limits<double>::infinity() ||
                         body.upper != std::numeric_limits<double>::infinity();
    require(!limited || body.joint == JointType::hinge || body.joint == JointType::slide,
            who + "only hinge and slide joints take a range");
    require(!std::isnan(body.lower) && !std::isnan(body.upper) && body.lower < body.upper,
            who + "a joint range needs lower < upper");
    const int nq = joint_coordinate_count(body);
    if (body.rest.size() == 0) body.rest = VectorX::Zero(nq);
    if (body.initial.size() == 0) body.initial = VectorX::Zero(nq);
    require(body.rest.size() == nq && body.initial.size() == nq, who + "rest/initial size does not match the joint");
    require(finite(body.rest) && finite(body.initial), who + "non-finite rest or initial value");
    q_index_[b] = n_;
    nq_[b] = nq;
    n_ += nq;
    if (body.damping > 0) has_damping_ = true;

    auto add = [&](const std::string& suffix, CoordinateKind kind, int i) {
      // A joint spring makes θ and θ + 2π different, except a ball's
      // geodesic spring (a function of the rotation: model.hpp).
      const bool periodic = kind != CoordinateKind::length && (body.stiffness == 0.0 || model::geodesic_joint_spring(body));
      coords_.push_back({body.name + suffix, kind, static_cast<int>(b), body.initial[i], periodic});
    };
    switch (body.joint) {
      case JointType::hinge: add("", CoordinateKind::angle, 0); break;
      case JointType::slide: add("", CoordinateKind::length, 0); break;
      case JointType::ball:
        add(".rx", CoordinateKind::rotation, 0);
        add(".ry", CoordinateKind::rotation, 1);
        add(".rz", CoordinateKind::rotation, 2);
        break;
      case JointType::free:
        add(".x", CoordinateKind::length, 0);
        add(".y", CoordinateKind::length, 1);
        add(".z", CoordinateKind::length, 2);
        add(".rx", CoordinateKind::rotation, 3);
        add(".ry", CoordinateKind::rotation, 4);
        add(".rz", CoordinateKind::rotation, 5);
        break;
      case JointType::particle: {
        static constexpr const char* axes[3] = {".x", ".y", ".z"};
        int i = 0;
        for (int a = 0; a < 3; ++a)
          if (body.particle_axes[static_cast<std::size_t>(a)]) add(axes[a], CoordinateKind::length, i++);
        break;
      }
      case JointType::fixed: break;
    }
  }
  auto check_attachment = [&](const Attachment& a, const std::string& who) {
    require(a.body >= -1 && a.body < static_cast<int>(nb), who + ": attachment to a body that does not exist");
    require(finite(a.point), who + ": non-finite attachment point");
  };
  for (const Spring& s : d_.springs) {
    check_attachment(s.a, "spring");
    check_attachment(s.b, "spring");
    require(std::isfinite(s.stiffness) && s.stiffness >= 0, "spring stiffness must be non-negative");
    require(std::isfinite(s.rest_length) && s.rest_length >= 0, "spring rest length must be non-negative");
    require(std::isfinite(s.damping) && s.damping >= 0, "spring damping must be non-negative");
    if (s.damping > 0) has_damping_ = true;
  }
  for (const DeadLoad& l : d_.loads) {
    check_attachment(l.at, "load");
    require(l.at.body >= 0, "a load must act on a body");
    require(finite(l.force), "load force is not finite");
  }
  for (const FollowerLoad& l : d_.followers) {
    check_attachment(l.at, "follower load");
    require(l.at.body >= 0, "a follower load must act on a body");
    require(finite(l.force), "follower load force is not finite");
  }
  for (std::size_t c = 0; c < d_.constraints.size(); ++c) {
    const Constraint& k = d_.constraints[c];
    const std::string who = "constraint '" + k.name + "'";
    check_attachment(k.a, who);
    check_attachment(k.b, who);
    require(k.a.body >= 0 || k.b.body >= 0, who + ": both ends are fixed in the world");
    if (k.type == Constraint::Type::coupling) {
      auto scalar_joint = [&](int b) {
        const JointType t = d_.bodies[static_cast<std::size_t>(b)].joint;
        return t == JointType::hinge || t == JointType::slide;
      };
      require(k.a.body >= 0 && scalar_joint(k.a.body), who + ": a coupling's body a must have a hinge or slide joint");
      require(k.b.body < 0 || (scalar_joint(k.b.body) && k.b.body != k.a.body),
              who + ": a coupling's body b must be another body with a hinge or slide joint, or none");
      for (const double c : k.polynomial) require(std::isfinite(c), who + ": the coupling polynomial is not finite");
    }
    if (k.type == Constraint::Type::distance)
      require(std::isfinite(k.length) && k.length > 0, who + ": the distance must be positive");
    m_ += k.equations();
    for (int i = 0; i < k.equations(); ++i) equation_owner_.push_back(static_cast<int>(c));
  }
  require(!(is_map() && !d_.constraints.empty()), "constraints join bodies and particles; a kinematic map has none");

  // Length scale: farthest joint, centre of mass or attachment from the origin at q = 0.
  std::vector<Vec3> origin_at_zero(nb);
  std::vector<Mat3> rotation_at_zero(nb);
  double scale = 0;
  for (std::size_t b = 0; b < nb; ++b) {
    const Body& body = d_.bodies[b];
    const auto p = static_cast<std::size_t>(body.parent);
    origin_at_zero[b] = (body.parent >= 0 ? Vec3(origin_at_zero[p] + rotation_at_zero[p] * body.origin) : body.origin);
    rotation_at_zero[b] = (body.parent >= 0 ? rotation_at_zero[p] : Mat3::Identity()) * body.orientation;
    scale = std::max({scale, origin_at_zero[b].norm(), (origin_at_zero[b] + rotation_at_zero[b] * body.com).norm()});
  }
  auto point_at_zero = [&](const Attachment& a) {
    const auto b = static_cast<std::size_t>(a.body);
    return a.body < 0 ? a.point : Vec3(origin_at_zero[b] + rotation_at_zero[b] * a.point);
  };
  for (const Spring& s : d_.springs)
    scale = std::max({scale, point_at_zero(s.a).norm(), point_at_zero(s.b).norm(), s.rest_length});
  for (const DeadLoad& l : d_.loads) scale = std::max(scale, point_at_zero(l.at).norm());
  for (const FollowerLoad& l : d_.followers) scale = std::max(scale, point_at_zero(l.at).norm());
  for (const Constraint& k : d_.constraints)
    if (k.type != Constraint::Type::coupling)
      scale = std::max({scale, point_at_zero(k.a).norm(), point_at_zero(k.b).norm(), k.length});
  length_scale_ = std::max(scale, 1e-3);
  if (is_map()) build_map();
}

std::vector<std::string> System::coordinate_names() const {
  std::vector<std::string> names;
  names.reserve(coords_.size());
  for (const auto& c : coords_) names.push_back(c.name);
  return names;
}

const char* to_string(Constraint::Type type) {
  switch (type) {
    case Constraint::Type::point: return "point";
    case Constraint::Type::distance: return "distance";
    case Constraint::Type::coupling: return "coupling";
  }
  return "?";
}

std::vector<std::string> System::constraint_equation_names() const {
  std::vector<std::string> names;
  for (const Constraint& k : d_.constraints) {
    if (k.type != Constraint::Type::point) {
      names.push_back(k.name);
    } else {
      for (const char* axis : {".x", ".y", ".z"}) names.push_back(k.name + axis);
    }
  }
  return names;
}

VectorX System::initial_configuration() const {
  VectorX q(n_);
  for (int i = 0; i < n_; ++i) q[i] = coords_[static_cast<std::size_t>(i)].initial;
  return q;
}

namespace {

// Angle brought to (−π, π].
double wrap_angle(double a) {
  constexpr double two_pi = 2 * std::numbers::pi;
  double r = std::remainder(a, two_pi);  // in [−π, π]
  if (r <= -std::numbers::pi) r += two_pi;
  return r;
}

// Rotation vector of the same rotation with length ≤ π.
Vec3 wrap_rotation(const Vec3& phi) {
  const double t = phi.norm();
  if (t <= std::numbers::pi || !std::isfinite(t)) return phi;
  return phi * (wrap_angle(t) / t);
}

}  // namespace

VectorX canonical_coordinates(const System& s, const VectorX& q) {
  VectorX r = q;
  const auto& coords = s.coordinates();
  for (int i = 0; i < s.size(); ++i) {
    const auto& c = coords[static_cast<std::size_t>(i)];
    if (!c.periodic) continue;
    if (c.kind == CoordinateKind::angle) {
      r[i] = wrap_angle(q[i]);
    } else if (c.kind == CoordinateKind::rotation && (i == 0 || coords[static_cast<std::size_t>(i - 1)].kind != CoordinateKind::rotation ||
                                                      coords[static_cast<std::size_t>(i - 1)].body != c.body)) {
      r.segment<3>(i) = wrap_rotation(q.segment<3>(i));
    }
  }
  return r;
}

double configuration_distance(const System& s, const VectorX& a, const VectorX& b) {
  const VectorX ca = canonical_coordinates(s, a), cb = canonical_coordinates(s, b);
  const auto& coords = s.coordinates();
  double d2 = 0;
  for (int i = 0; i < s.size();) {
    const auto& c = coords[static_cast<std::size_t>(i)];
    if (c.kind == CoordinateKind::angle || (c.kind == CoordinateKind::rotation && !c.periodic)) {
      const double d = c.periodic ? wrap_angle(ca[i] - cb[i]) : ca[i] - cb[i];
      d2 += d * d;
      ++i;
    } else if (c.kind == CoordinateKind::length) {
      const double d = (ca[i] - cb[i]) / s.length_scale();
      d2 += d * d;
      ++i;
    } else {  // a rotation vector: geodesic angle between the two rotations
      const Mat3 Ra = model::rotation_exp<double>(ca.segment<3>(i));
      const Mat3 Rb = model::rotation_exp<double>(cb.segment<3>(i));
      const double c2 = std::clamp(((Ra.transpose() * Rb).trace() - 1.0) / 2.0, -1.0, 1.0);
      // acos loses accuracy near 0: use the skew part for small angles.
      const Mat3 Rrel = Ra.transpose() * Rb;
      const double sn = 0.5 * Vec3(Rrel(2, 1) - Rrel(1, 2), Rrel(0, 2) - Rrel(2, 0), Rrel(1, 0) - Rrel(0, 1)).norm();
      const double angle = std::atan2(sn, c2);
      d2 += angle * angle;
      i += 3;
    }
  }
  return std::sqrt(d2);
}

}  // namespace modal
