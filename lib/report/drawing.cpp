// lib/report/drawing.cpp — what an HTML report draws of a scene: points at the
// equilibrium, segments between them and each mode's displacement of the
// points (modal/report.hpp, SceneDrawing; docs/design.md, "HTML reports").
#include "modal/report.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>
#include <vector>

namespace modal {
namespace {

// Where the drawn points are at a configuration: body frame origins (the
// joints), centres of mass away from them and spring ends away from both;
// or a kinematic map's points.
struct PointLayout {
  std::vector<std::array<int, 2>> segments;
  std::size_t count = 0;
};

class Points {
 public:
  explicit Points(const System& s) : s_(s), w_(s) { layout(); }

  const PointLayout& layout_of() const { return layout_; }

  // Every point's first-order motion along dq at q (as `at` lists the points),
  // exact: a body point x = p + R r moves by ṗ + ω × R r.
  std::vector<Vec3> rates(const VectorX& q, const VectorX& dq) {
    if (s_.is_map()) return map_point_rates(s_, q, dq);
    const std::vector<Pose> poses = body_poses(s_, w_, q);
    const std::vector<PoseRate> rate = body_pose_rates(s_, q, dq);
    auto moved = [&](int body, const Vec3& local) {
      if (body < 0) return Vec3(Vec3::Zero());
      const auto b = static_cast<std::size_t>(body);
      return Vec3(rate[b].velocity + rate[b].angular.cross(poses[b].rotation * local));
    };
    std::vector<Vec3> u;
    u.reserve(layout_.count);
    for (std::size_t b = 0; b < poses.size(); ++b) {
      u.push_back(rate[b].velocity);
      if (has_com_[b]) u.push_back(moved(static_cast<int>(b), s_.bodies()[b].com));
    }
    for (const Attachment* a : extra_ends_) u.push_back(moved(a->body, a->point));
    return u;
  }

  std::vector<Vec3> at(const VectorX& q) {
    if (s_.is_map()) return map_point_positions(s_, q);
    const std::vector<Pose> poses = body_poses(s_, w_, q);
    std::vector<Vec3> x;
    x.reserve(layout_.count);
    for (std::size_t b = 0; b < poses.size(); ++b) {
      x.push_back(poses[b].position);
      if (has_com_[b]) x.push_back(poses[b].position + poses[b].rotation * s_.bodies()[b].com);
    }
    for (const Attachment* a : extra_ends_)
      x.push_back(a->body < 0 ? a->point
                              : Vec3(poses[static_cast<std::size_t>(a->body)].position +
                                     poses[static_cast<std::size_t>(a->body)].rotation * a->point));
    return x;
  }

 private:
  void layout() {
    if (s_.is_map()) {
      layout_.count = map_point_positions(s_, s_.initial_configuration()).size();
      return;
    }
    const std::vector<Body>& bodies = s_.bodies();
    std::vector<int> origin(bodies.size());
    int next = 0;
    for (std::size_t b = 0; b < bodies.size(); ++b) {
      origin[b] = next++;
      has_com_.push_back(bodies[b].com.norm() > 0);
      if (has_com_[b]) layout_.segments.push_back({origin[b], next++});
      if (bodies[b].parent >= 0) layout_.segments.push_back({origin[static_cast<std::size_t>(bodies[b].parent)], origin[b]});
    }
    // A spring end at a body's frame origin is that point; others are added.
    auto end_point = [&](const Attachment& a) {
      if (a.body >= 0 && a.point.isZero(0.0)) return origin[static_cast<std::size_t>(a.body)];
      extra_ends_.push_back(&a);
      return next++;
    };
    for (const Spring& spring : s_.springs()) {
      const int a = end_point(spring.a);
      const int b = end_point(spring.b);
      layout_.segments.push_back({a, b});
    }
    layout_.count = static_cast<std::size_t>(next);
  }

  const System& s_;
  Workspace w_;
  PointLayout layout_;
  std::vector<bool> has_com_;
  std::vector<const Attachment*> extra_ends_;
};

}  // namespace

std::optional<SceneDrawing> scene_drawing(const System& system, const VectorX& q, const ModalResult& result,
                                          const DrawingLimits& limits) {
  Points points(system);
  const PointLayout& layout = points.layout_of();
  if (layout.count == 0) return std::nullopt;
  const std::vector<Vec3> x0 = points.at(q);

  // Every k-th point beyond the limit; segments only between kept points.
  const std::size_t stride = std::max<std::size_t>(1, (x0.size() + limits.points - 1) / std::max<std::size_t>(limits.points, 1));
  std::vector<int> kept_index(x0.size(), -1);
  SceneDrawing d;
  d.total_points = x0.size();
  for (std::size_t i = 0; i < x0.size(); i += stride) {
    kept_index[i] = static_cast<int>(d.points.size());
    d.points.push_back(x0[i]);
  }
  std::size_t segments_left = 0;
  for (const auto& [a, b] : layout.segments) {
    const int ka = kept_index[static_cast<std::size_t>(a)], kb = kept_index[static_cast<std::size_t>(b)];
    if (ka >= 0 && kb >= 0) d.segments.push_back({ka, kb});
    else ++segments_left;
  }
  std::vector<std::string> notes;
  if (stride > 1)
    notes.push_back("every " + std::to_string(stride) + "th of the " + std::to_string(x0.size()) +
                    " points is drawn (" + std::to_string(d.points.size()) + "), with the " +
                    std::to_string(d.segments.size()) + " segments between drawn points");
  if (d.segments.size() > limits.segments) {
    notes.push_back("the " + std::to_string(d.segments.size()) + " segments are not drawn (more than " +
                    std::to_string(limits.segments) + ")");
    d.segments.clear();
  }

  // Linearized displacement J φ of every drawn point, exact (Points::rates):
  // J Re φ and, for a complex shape (first-order problems), J Im φ, so that
  // the page draws the motion Re(J φ e^{iωt}) = J Re φ cos ωt − J Im φ sin ωt.
  // Both are scaled by the largest displacement amplitude over a period.
  std::size_t animated = 0;
  for (std::size_t m = 0; m < result.modes.size() && animated < limits.modes; ++m) {
    const Mode& mode = result.modes[m];
    if (mode.shape.size() != q.size()) continue;
    const VectorX re = mode.shape.real(), im = mode.shape.imag();
    const bool complex = im.cwiseAbs().maxCoeff() > 1e-12 * mode.shape.cwiseAbs().maxCoeff();
    const std::vector<Vec3> all_re = points.rates(q, re);
    const std::vector<Vec3> all_im = complex ? points.rates(q, im) : std::vector<Vec3>();
    std::vector<Vec3> u, v;
    u.reserve(d.points.size());
    double norm = 0;
    for (std::size_t i = 0; i < x0.size(); i += stride) {
      u.push_back(all_re[i]);
      if (complex) v.push_back(all_im[i]);
      // max over t of |a cos t − b sin t| = the larger semi-axis of the ellipse a, b.
      const Vec3& a = u.back();
      const Vec3 b = complex ? v.back() : Vec3(Vec3::Zero());
      const double aa = a.squaredNorm(), bb = b.squaredNorm(), ab = a.dot(b);
      norm = std::max(norm, std::sqrt(0.5 * (aa + bb) + std::sqrt(0.25 * (aa - bb) * (aa - bb) + ab * ab)));
    }
    if (!(norm > 0) || !std::isfinite(norm)) continue;
    for (Vec3& x : u) x /= norm;
    for (Vec3& x : v) x /= norm;
    d.modes.push_back(static_cast<int>(m + 1));
    d.displacements.push_back(std::move(u));
    d.displacements_imag.push_back(std::move(v));
    ++animated;
  }
  if (animated < result.modes.size())
    notes.push_back("the lowest " + std::to_string(animated) + " of the " + std::to_string(result.modes.size()) +
                    " modes are animated");

  // A plane when every point and displacement has one world coordinate in common.
  for (int axis = 2; axis >= 0; --axis) {
    double lo = d.points.front()[axis], hi = lo, moved = 0;
    for (const Vec3& p : d.points) {
      lo = std::min(lo, p[axis]);
      hi = std::max(hi, p[axis]);
    }
    for (const std::vector<Vec3>& u : d.displacements)
      for (const Vec3& v : u) moved = std::max(moved, std::abs(v[axis]));
    if (hi - lo <= 1e-9 * system.length_scale() && moved <= 1e-9) {
      d.dimensions = 2;
      d.plane = axis == 0 ? std::array<int, 2>{1, 2} : axis == 1 ? std::array<int, 2>{0, 2} : std::array<int, 2>{0, 1};
      break;
    }
  }
  for (std::size_t i = 0; i < notes.size(); ++i) d.note += (i ? "; " : "") + notes[i];
  if (!d.note.empty()) d.note[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(d.note[0])));
  return d;
}

}  // namespace modal
