// Equilibria: residual, Newton polish, local (Levenberg–Marquardt) search.
//
// Cost model: one residual evaluation is a tree pass for ∇V (O(n·depth)); one
// Jacobian is the exact tree-structured Hessian (O(n·depth) plus O(n²) to
// store); one Newton step is O(n³) (Cholesky for large well-conditioned
// positive definite J, else a symmetric eigen-decomposition). Newton converges
// quadratically at a regular equilibrium, so a polish costs a few Jacobians.
#include "equilibrium/problem.hpp"
#include "core/model.hpp"
#include "core/text.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numbers>
#include <numeric>
#include <sstream>

namespace modal {
namespace equilibrium_detail {
namespace {

// The one place where non-conservative generalized forces at rest enter the
// equilibrium condition: r −= Q(q, 0) and J −= ∂Q/∂q(q, 0). Dampers, Q = −D(q) q̇,
// vanish at rest with their q-derivative; follower loads do not, and make J
// non-symmetric (see Problem::symmetric_jacobian).
void add_forces_at_rest(const System& s, Workspace& w, const VectorX& q, VectorX& r) {
  if (s.has_follower_loads()) r -= generalized_forces(s, w, q, VectorX::Zero(s.size()));
}
void add_force_jacobian_at_rest(const System& s, Workspace& w, const VectorX& q, MatrixX& j) {
  if (s.has_follower_loads()) j -= generalized_force_jacobian(s, w, q);
}

bool finite(const VectorX& v) { return v.allFinite(); }

// Coordinates scaled to comparable units: angles in rad, lengths in units of
// the scene's length scale.
VectorX coordinate_scales(const System& s) {
  VectorX d(s.size());
  for (int i = 0; i < s.size(); ++i)
    d[i] = s.coordinates()[static_cast<std::size_t>(i)].kind == CoordinateKind::length ? s.length_scale() : 1.0;
  return d;
}

Equilibrium record(Problem& p, const VectorX& q, double rnorm, double rel, int iterations) {
  Equilibrium e;
  e.q = q;
  e.limits = joint_limits(p.system(), q);
  e.potential = p.potential(q);
  e.residual = rel;
  e.residual_norm = rnorm;
  e.iterations = iterations;
  return e;
}

}  // namespace

const VectorX& Problem::residual(const VectorX& q) {
  ++residual_evaluations;
  try {
    r_ = potential_gradient(s_, w_, q);
    add_forces_at_rest(s_, w_, q, r_);
  } catch (const NumericalError&) {
    // A singular configuration of the model (a spring with coincident ends):
    // reported as a non-finite residual, which every solver here rejects.
    r_.setConstant(s_.size(), std::numeric_limits<double>::quiet_NaN());
  }
  return r_;
}

const MatrixX& Problem::jacobian(const VectorX& q) {
  ++jacobian_evaluations;
  try {
    j_ = potential_hessian(s_, w_, q);
    add_force_jacobian_at_rest(s_, w_, q, j_);
  } catch (const NumericalError&) {
    j_.setConstant(s_.size(), s_.size(), std::numeric_limits<double>::quiet_NaN());
  }
  return j_;
}

const CoordinateForceScales& Problem::coordinate_scales(const VectorX& q) {
  if (scales_q_.size() != q.size() || scales_q_ != q) {
    scales_ = coordinate_force_scales(s_, w_, q);
    scales_q_ = q;
  }
  return scales_;
}

double Problem::relative_residual(const VectorX& q, const VectorX& r) {
  if (const std::optional<double> relative =
          modal::relative_residual_if_scaled(s_, w_, q, r, s_.is_map() ? nullptr : &coordinate_scales(q)))
    return *relative;
  const double residual_norm = r.norm();
  if (residual_norm == 0) return 0;
  const MatrixX& j = jacobian(q);
  return residual_norm / (j.norm() + DBL_MIN);
}

namespace {

// v with its entries that are not positive (or not finite) set to its
// largest; empty if none is positive.
VectorX positive_or_largest(VectorX v) {
  double largest = 0;
  for (Eigen::Index i = 0; i < v.size(); ++i)
    if (std::isfinite(v[i])) largest = std::max(largest, v[i]);
  if (!(largest > 0)) return VectorX();
  for (Eigen::Index i = 0; i < v.size(); ++i)
    if (!(v[i] > 0) || !std::isfinite(v[i])) v[i] = largest;
  return v;
}

}  // namespace

VectorX Problem::stiffness_scales(const VectorX& q) {
  if (s_.is_map()) return VectorX();
  return positive_or_largest(coordinate_scales(q).stiffness);
}

VectorX Problem::residual_weights(const VectorX& q) {
  const VectorX full = s_.is_map() ? VectorX() : positive_or_largest(coordinate_scales(q).full);
  if (full.size() != s_.size()) return VectorX::Ones(s_.size());
  return full.cwiseInverse();
}

VectorX newton_step(const MatrixX& j, const VectorX& r, bool symmetric, const VectorX& stiffness) {
  const Eigen::Index n = j.rows();
  if (n == 0) return VectorX(0);
  // Solved as (S J S)(S⁻¹ d) = −S r with S = diag(stiffness)^-½: the cutoffs
  // below are then relative to each coordinate's own stiffness, not to the
  // stiffest coordinate's. Unscaled, a slide of 1e14 N/m made the pendulums
  // beside it "zero modes" (9.8 N·m/rad, below 1000 ε × 1e14) and Newton took
  // no step at all.
  VectorX scale = VectorX::Ones(n);
  if (stiffness.size() == n) {
    // Scales raised to what the couplings demand, k_a k_b ≥ J_ab², so that
    // no scaled entry exceeds 1: a slide of 7.7e-4 N/m carrying 58 t
    // is coupled to the ball above it by 5.8e5 N/rad, and at its own spring's
    // scale the scaled matrix reached ±6.5e3, which lifted the cutoff above
    // the ball's yaw (its weak spring, 6.6e-11 of the scaled tilts): the yaw
    // was dropped from every step and the polish stalled at a relative
    // residual of 2.6e-12. A coupling of rounding size raises nothing.
    VectorX k = stiffness;
    for (Eigen::Index a = 0; a < n; ++a)
      for (Eigen::Index b = a + 1; b < n; ++b) {
        const double c = std::max(std::abs(j(a, b)), std::abs(j(b, a)));  // J may be non-symmetric
        if (!(c * c > k[a] * k[b])) continue;
        // The softer one is raised (raising the stiffer would scale its own
        // terms away); scales only grow, so earlier pairs stay within 1.
        if (k[a] <= k[b]) k[a] = c * c / k[b];
        else k[b] = c * c / k[a];
      }
    scale = k.cwiseSqrt().cwiseInverse();
  }
  const MatrixX js = scale.asDiagonal() * j * scale.asDiagonal();
  const VectorX rs = scale.cwiseProduct(r);
  if (!symmetric) {
    Eigen::CompleteOrthogonalDecomposition<MatrixX> cod(js);
    cod.setThreshold(1e3 * std::numeric_limits<double>::epsilon());
    return -scale.cwiseProduct(cod.solve(rs));
  }
  if (n > 24) {  // fast path: the usual stable equilibrium of a large scene
    const Eigen::LLT<MatrixX> llt(js);
    if (llt.info() == Eigen::Success && llt.rcond() > 1e-10) return -scale.cwiseProduct(llt.solve(rs));
  }
  const Eigen::SelfAdjointEigenSolver<MatrixX> es(js);
  if (es.info() != Eigen::Success) return VectorX::Zero(n);
  const VectorX& lambda = es.eigenvalues();
  // Zero modes (ignorable coordinates) come out as rounding-size eigenvalues:
  // dropped below 1000 ε of the largest, giving the step of least scaled norm.
  const double cutoff = 1e3 * std::numeric_limits<double>::epsilon() * lambda.cwiseAbs().maxCoeff();
  VectorX c = es.eigenvectors().transpose() * rs;
  for (Eigen::Index i = 0; i < n; ++i) c[i] = std::abs(lambda[i]) > cutoff ? c[i] / lambda[i] : 0.0;
  return -scale.cwiseProduct(es.eigenvectors() * c);
}

namespace {

// Newton steps of ball and free joints taken in the joint frame's own
// rotation increments δ, R = R_frame exp(δ̂) exp(φ̂), instead of along a
// straight line in the rotation vector φ. A rotation about a fixed axis of
// the joint's frame is then a straight line of the step: a heavy bob hanging
// from a ball joint with a weak spring (yaw held by 1e-6 N·m/rad against
// 10 N·m/rad of gravity in tilt) lies in a valley that is a circle of such
// rotations, curved in φ; Newton's straight steps in φ left the valley at
// every yaw correction, the line search cut them to nothing and the polish
// stalled ("no equilibrium found" at a relative residual of 4e-8, review).
// dφ = J_l(φ)⁻¹ dδ (model::rotation_left_jacobian); the step is retracted
// along exp(tδ̂) exp(φ̂), whose rotation vector is taken nearest φ + t dφ (a
// sprung ball's φ beyond π stays on its branch).
class RotationChart {
 public:
  RotationChart(const System& s, const VectorX& q) {
    const auto& c = s.coordinates();
    for (int i = 0; i + 2 < s.size(); ++i) {
      const auto k = static_cast<std::size_t>(i);
      if (c[k].kind != CoordinateKind::rotation || (i > 0 && c[k - 1].kind == CoordinateKind::rotation && c[k - 1].body == c[k].body))
        continue;
      const Vec3 phi = q.segment<3>(i);
      // J_l is singular at |φ| = 2π: its inverse is used well inside.
      if (!(phi.norm() < 1.5 * std::numbers::pi)) continue;
      first_.push_back(i);
      inverse_.push_back(model::rotation_left_jacobian<double>(phi).inverse());
    }
  }
  bool empty() const { return first_.empty(); }
  // dφ/dδ applied to δ: T δ.
  VectorX tangent(const VectorX& delta) const {
    VectorX d = delta;
    for (std::size_t b = 0; b < first_.size(); ++b) d.segment<3>(first_[b]) = inverse_[b] * delta.segment<3>(first_[b]);
    return d;
  }
  // T A (columns), Tᵀ A (rows).
  MatrixX right(MatrixX a) const {
    for (std::size_t b = 0; b < first_.size(); ++b) a.middleCols<3>(first_[b]) = (a.middleCols<3>(first_[b]) * inverse_[b]).eval();
    return a;
  }
  MatrixX left_transposed(MatrixX a) const {
    for (std::size_t b = 0; b < first_.size(); ++b)
      a.middleRows<3>(first_[b]) = (inverse_[b].transpose() * a.middleRows<3>(first_[b])).eval();
    return a;
  }
  VectorX left_transposed(VectorX v) const {
    for (std::size_t b = 0; b < first_.size(); ++b) v.segment<3>(first_[b]) = inverse_[b].transpose() * v.segment<3>(first_[b]);
    return v;
  }
  // The configuration t δ away: q + t δ off the rotations, exp(tδ̂) exp(φ̂) on them.
  VectorX retract(const VectorX& q, const VectorX& delta, double t) const {
    VectorX out = q + t * delta;
    for (std::size_t b = 0; b < first_.size(); ++b) {
      const int i = first_[b];
      const Vec3 phi = q.segment<3>(i);
      const Eigen::Quaterniond r = quaternion(t * delta.segment<3>(i)) * quaternion(phi);
      out.segment<3>(i) = rotation_vector_near(r, phi + t * (inverse_[b] * delta.segment<3>(i)));
    }
    return out;
  }

 private:
  static Eigen::Quaterniond quaternion(const Vec3& phi) {
    const double t = phi.norm();
    return t > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(t, phi / t)) : Eigen::Quaterniond::Identity();
  }
  // The rotation vector of r (angle θ + 2πm along its axis u, any integer m)
  // nearest `near`.
  static Vec3 rotation_vector_near(const Eigen::Quaterniond& r, const Vec3& near) {
    const double sv = r.vec().norm();
    const double turn = 2 * std::numbers::pi;
    if (!(sv > 0)) {  // a whole number of turns
      const double n = near.norm();
      return n > 0 ? Vec3(near * (turn * std::round(n / turn) / n)) : Vec3::Zero();
    }
    const Vec3 u = r.vec() / sv;
    const double theta = 2 * std::atan2(sv, r.w());
    return u * (theta + turn * std::round((u.dot(near) - theta) / turn));
  }
  std::vector<int> first_;
  std::vector<Mat3> inverse_;
};

// A Newton step in the chart's increments: Tᵀ J T δ = −Tᵀ r where J is
// symmetric (the Hessian in δ up to a term in r, which vanishes at the
// equilibrium), J T δ = −r otherwise.
VectorX chart_newton_step(const RotationChart& chart, const MatrixX& j, const VectorX& r, bool symmetric,
                          const VectorX& stiffness) {
  if (chart.empty()) return newton_step(j, r, symmetric, stiffness);
  const MatrixX jt = chart.right(j);
  if (!symmetric) return newton_step(jt, r, false, stiffness);
  MatrixX h = chart.left_transposed(jt);
  h = (0.5 * (h + h.transpose())).eval();
  return newton_step(h, chart.left_transposed(r), true, stiffness);
}

}  // namespace

Polished polish(Problem& p, const VectorX& q0, const EquilibriumOptions& options) {
  const System& s = p.system();
  Polished out;
  VectorX q = canonical_coordinates(s, q0);
  double best_rel = std::numeric_limits<double>::infinity();
  int refinements = 0;
  for (int it = 0;; ++it) {
    q = canonical_coordinates(s, q);  // the same configuration; keeps rotation vectors away from |φ| = 2π
    const VectorX r = p.residual(q);
    if (!finite(r)) return out;
    const double rnorm = r.norm();
    const double rel = p.relative_residual(q, r);
    if (rel < best_rel) {
      best_rel = rel;
      out.best = record(p, q, rnorm, rel, it);
    }
    if (rel <= options.tolerance && !out.converged) {
      // Where a compressed spring's ends meet, V is not differentiable: the
      // "balance" there is of a force without direction, no equilibrium
      // (models/spring_chain.toml listed three coincident masses as stable).
      if (!p.differentiable_at(q)) return out;
      out.converged = true;
      out.best = record(p, q, rnorm, rel, it);
    }
    if (out.converged) {
      // Accepted. At a regular equilibrium Newton converges quadratically, so
      // one or two more full steps bring the residual to rounding level and
      // the next fails to halve it: the refinement stops there. At a
      // degenerate one (λ = 0: a bifurcation point) Newton converges only
      // linearly — the residual ∝ θ³ of a pitchfork passes the tolerance at
      // θ ≈ 1e-5 while K ∝ θ² is still 1e-10 off zero — and the refinement
      // goes on while each step halves the residual (a pitchfork: × 0.30
      // per step; a fold: × 0.25), up to the rounding level. The cap only
      // bounds the cost: 60 steps of × 0.5 span 18 orders of magnitude.
      if (refinements++ == 60 || rnorm == 0.0) return out;
      const MatrixX& j = p.jacobian(q);
      const VectorX weight = p.residual_weights(q);
      const RotationChart chart(s, q);
      const VectorX d = chart_newton_step(chart, j, r, p.symmetric_jacobian(), p.stiffness_scales(q));
      if (!finite(d)) return out;
      const VectorX qt = chart.retract(q, d, 1.0);
      const VectorX& rt = p.residual(qt);
      if (!finite(rt) || weight.cwiseProduct(rt).norm() > 0.5 * weight.cwiseProduct(r).norm()) return out;
      q = qt;
      continue;
    }
    if (it >= options.max_iterations) return out;
    const MatrixX& j = p.jacobian(q);
    if (!j.allFinite()) return out;
    const VectorX weight = p.residual_weights(q);
    const RotationChart chart(s, q);
    const VectorX d = chart_newton_step(chart, j, r, p.symmetric_jacobian(), p.stiffness_scales(q));
    // Backtracking (Armijo) on f = ½‖W r‖², whose gradient is JᵀW²r, along
    // the chart's curve (tangent T d at t = 0).
    const VectorX wr = weight.cwiseProduct(r);
    const double f0 = 0.5 * wr.squaredNorm();
    const double slope = (weight.asDiagonal() * (j * chart.tangent(d))).dot(wr);
    if (!(slope < 0) || !finite(d)) return out;  // no descent left: stalled
    double t = 1;
    bool accepted = false;
    for (int k = 0; k < 40; ++k, t *= 0.5) {
      const VectorX qt = chart.retract(q, d, t);
      const VectorX& rt = p.residual(qt);
      if (!finite(rt)) continue;
      if (0.5 * weight.cwiseProduct(rt).squaredNorm() <= f0 + 1e-4 * t * slope) {
        q = qt;
        accepted = true;
        break;
      }
    }
    if (!accepted) return out;  // stalled: the residual cannot be reduced along the Newton direction
  }
}

namespace {

// Levenberg–Marquardt on r(q) = 0 from `start`, in scaled coordinates
// (lengths / length scale), with each step also limited to 0.5 (rad or length
// scales) so the iteration stays near the start and converges to the nearby
// equilibrium whatever its stability (it solves r = 0; it does not minimize V).
// Its residual is weighted per coordinate (Problem::residual_weights: each
// entry against its coordinate's own forces), and its damping is Marquardt's,
// μ × each column's own diagonal of the normal equations: unweighted and
// damped by μ × the largest diagonal, a slide of 1e14 N/m damped the
// pendulums beside it by 1e20 (no step taken), a bead 1e9 m out (a length
// column of 1e12) did the same to a chain, and a graded chain's light link
// was lost in JᵀJ. Returns the point reached, and in `steps` the steps
// taken; the caller polishes it.
VectorX levenberg_marquardt(Problem& p, const VectorX& start, const EquilibriumOptions& options, int& steps) {
  steps = 0;
  const System& s = p.system();
  const VectorX scale = coordinate_scales(s);
  VectorX q = canonical_coordinates(s, start);
  double mu = -1;
  for (int it = 0; it < 2 * options.max_iterations; ++it) {
    const VectorX r = p.residual(q);
    if (!finite(r)) break;
    if (p.relative_residual(q, r) <= std::max(options.tolerance, 1e-8)) break;  // Newton polish takes over
    const VectorX weight = p.residual_weights(q);
    const RotationChart chart(s, q);  // rotations stepped in their frames' increments, as Newton's
    const MatrixX js = weight.asDiagonal() * chart.right(p.jacobian(q)) * scale.asDiagonal();  // ∂(W r)/∂(δ/scale)
    if (!js.allFinite()) break;
    const VectorX rs = weight.cwiseProduct(r);
    const MatrixX a = js.transpose() * js;
    const VectorX g = js.transpose() * rs;
    // A column of rounding only (a zero mode) is damped at 1e-16 of the largest.
    const VectorX damping = a.diagonal().cwiseMax(1e-16 * std::max(a.diagonal().maxCoeff(), DBL_MIN));
    if (mu < 0) mu = 1e-8;
    bool accepted = false;
    for (int k = 0; k < 30; ++k) {
      MatrixX am = a;
      am.diagonal() += mu * damping;
      const Eigen::LLT<MatrixX> llt(am);
      VectorX dx = llt.info() == Eigen::Success ? VectorX(-llt.solve(g)) : VectorX::Zero(s.size());
      const double len = dx.norm();
      if (len > 0.5) dx *= 0.5 / len;
      const VectorX qt = chart.retract(q, scale.cwiseProduct(dx), 1.0);
      const VectorX& rt = p.residual(qt);
      if (finite(rt) && weight.cwiseProduct(rt).norm() < rs.norm()) {
        q = canonical_coordinates(s, qt);
        mu = std::max(mu / 4, 1e-300);
        accepted = true;
        ++steps;
        break;
      }
      mu *= 4;
    }
    if (!accepted) break;
  }
  return q;
}

using text::force_unit;

}  // namespace

// Below this relative residual the message says the search stalled near a
// balance, not that nothing can balance the forces.
constexpr double stalled_near_balance = 1e-6;

std::string no_equilibrium_message(Problem& p, const Equilibrium& best, int starts) {
  const System& s = p.system();
  std::ostringstream m;
  m << std::setprecision(3);
  m << "no equilibrium found: the residual ‖∇V − Q‖ could not be reduced below " << best.residual_norm
    << " (relative " << best.residual << ") from " << starts << " start" << (starts == 1 ? "" : "s");
  Workspace w(s);
  std::optional<ResidualRounding> rounding;
  Eigen::Index worst = -1;
  if (best.q.size() == s.size() && s.size() > 0) {
    const VectorX r = p.residual(best.q);
    rounding = residual_rounding(s, w, best.q);
    if (rounding && !(r.norm() <= rounding->whole)) rounding.reset();
    std::vector<int> order(static_cast<std::size_t>(s.size()));
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return std::abs(r[a]) > std::abs(r[b]); });
    const double largest = std::abs(r[order[0]]);
    worst = order[0];
    m << "; the unbalanced generalized force is largest on coordinate ";
    int named = 0;
    for (int i : order) {
      if (named == 3 || std::abs(r[i]) < 0.1 * largest || (named > 0 && r[i] == 0)) break;
      const Coordinate& c = s.coordinates()[static_cast<std::size_t>(i)];
      m << (named == 0 ? "" : ", then ") << c.name << " (" << r[i] << " " << force_unit(c.kind) << ")";
      if (rounding && !(std::abs(r[i]) <= rounding->each[i])) rounding.reset();  // one named beyond its rounding
      ++named;
    }
  }
  if (rounding) {
    // Not an unbalanced load: the forces themselves are computed no closer
    // than this (world points rounded to ε of their distance from the origin).
    const Coordinate& c = s.coordinates()[static_cast<std::size_t>(worst)];
    m << " — within the rounding of the forces computed at these positions (±" << rounding->each[worst] << " "
      << force_unit(c.kind) << " on " << c.name
      << ": 8ε × each of its springs' stiffness times its length and its ends' distances from the origin, to ε of "
         "which they are rounded), so it cannot be told from zero: double precision resolves these forces no closer";
    if (const std::optional<MeetingEnds> meet = spring_with_meeting_ends(s, w, best.q))
      m << "; and " << describe_meeting_ends(s, *meet) << ", so no tolerance accepts this point";
    else if (best.residual <= 1e-2)
      m << "; a tolerance of " << std::pow(10.0, std::ceil(std::log10(best.residual)))
        << " (`modal analyze --eq-tol`, EquilibriumOptions::tolerance) accepts this point";
    m << "; without a rotating frame, the same scene moved nearer the origin has the same modes and is computed "
         "more closely";
    return m.str();
  }
  if (best.residual <= stalled_near_balance) {
    // Not unbalanced: the forces balance to a millionth of their size or
    // better, and the search stalled there (two weak ball-joint springs in
    // series under a 58 kg body, held to 4e-9: "nothing in the scene can
    // balance it" had been said of it).
    m << " — the forces balance to " << best.residual
      << " of their size here, so an equilibrium may lie close by that the search did not reach (directions held "
         "only by springs far weaker than the loads they turn, such as a weak ball-joint spring under a heavy body, "
         "make it hard to find); the search may accept a point this near a balance at a tolerance of "
      << std::pow(10.0, std::ceil(std::log10(best.residual)))
      << " (`modal analyze --eq-tol`, EquilibriumOptions::tolerance; each coordinate's balance is checked too), "
         "and the error estimates then include what the looser balance costs";
    return m.str();
  }
  // Said as what is known: the search found no balance. That nothing can
  // balance the forces is one reason; a search that did not reach a balance
  // from this start is the other (a chain of 400 links on ball joints,
  // started coiled, stalled at a relative residual of 0.36, and had been told
  // nothing could balance it).
  m << " — either nothing in the scene can balance it (e.g. a body that can fall freely under gravity, or a load no "
       "spring or joint resists), or the search did not reach a balance from this start";
  return m.str();
}

}  // namespace equilibrium_detail

std::string active_limit(const System& s, const Equilibrium& e) {
  for (const JointLimitState& l : e.limits) {
    if (!l.active()) continue;
    const Body& body = s.bodies()[static_cast<std::size_t>(l.body)];
    const char* unit = body.joint == JointType::hinge ? " rad" : " m";
    std::ostringstream out;
    out << std::setprecision(10) << "the joint of '" << body.name << "' is at " << l.value << unit
        << " in the equilibrium found, " << (l.value == l.lower || l.value == l.upper ? "at the end of" : "outside")
        << " its range [" << l.lower << ", " << l.upper << "]" << unit
        << ": the stop would push there, and a limit has no linear model";
    return out.str();
  }
  return "";
}

std::vector<JointLimitState> joint_limits(const System& s, const VectorX& q) {
  std::vector<JointLimitState> out;
  const std::vector<Body>& bodies = s.bodies();
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const Body& body = bodies[b];
    if (body.lower == -std::numeric_limits<double>::infinity() && body.upper == std::numeric_limits<double>::infinity())
      continue;
    const int i = s.first_coordinate(static_cast<int>(b));
    JointLimitState state{static_cast<int>(b), i, q[i], body.lower, body.upper};
    // A hinge angle is found modulo 2π (canonical coordinates); a stop makes
    // it an angle on the line: the turn that lies inside the range, if any.
    if (body.joint == JointType::hinge && state.active() && std::isfinite(q[i])) {
      const double turn = 2 * std::numbers::pi;
      const double inside = q[i] + turn * std::ceil((body.lower - q[i]) / turn);
      if (inside > body.lower && inside < body.upper) state.value = inside;  // the smallest turn ≥ lower
    }
    out.push_back(state);
  }
  return out;
}

using namespace equilibrium_detail;

VectorX equilibrium_residual(const System& s, Workspace& w, const VectorX& q) {
  VectorX r = potential_gradient(s, w, q);
  add_forces_at_rest(s, w, q, r);
  return r;
}

std::optional<Equilibrium> polish_equilibrium(const System& s, const VectorX& q, const EquilibriumOptions& options) {
  if (q.size() != s.size()) throw std::invalid_argument("polish_equilibrium: q has the wrong size");
  if (s.has_constraints()) return polish_constrained(s, q, options);
  if (prefers_sparse_equilibrium(s, q)) {
    try {
      return find_large_equilibrium(s, q, options);
    } catch (const NumericalError&) {
      return std::nullopt;
    }
  }
  Problem p(s);
  Polished r = polish(p, q, options);
  if (!r.converged) return std::nullopt;
  return r.best;
}

namespace {

// Overflow is not "no equilibrium": say so before searching. Returns false
// where ∇V cannot be evaluated at q because a spring's ends coincide there
// (modal::spring_with_meeting_ends): no start for a local search, though the
// multi-start search's other starts are.
bool require_finite_energy(const System& s, const VectorX& q) {
  Workspace w(s);
  const double v = potential(s, w, q);
  bool gradient_finite = true;
  try {
    gradient_finite = potential_gradient(s, w, q).allFinite();
  } catch (const NumericalError&) {
    if (!spring_with_meeting_ends(s, w, q)) throw;
    if (std::isfinite(v)) return false;
  }
  if (std::isfinite(v) && gradient_finite) return true;
  throw NumericalError("the potential energy" + std::string(std::isfinite(v) ? "'s gradient" : "") +
                       " is not finite at the initial configuration: it overflows double precision "
                       "(a mass, stiffness, load or length too large, e.g. beyond 1e150 in SI units); "
                       "rescale the scene's units");
}

// The last resort of find_equilibrium for a conservative scene, after the
// residual's searches (Levenberg–Marquardt from the start, L-BFGS on ½‖r‖²
// from many starts) stalled: the large-scene search from the start (damped
// Newton on V, then L-BFGS on V if that stalls, modal::find_large_equilibrium),
// which descends V instead of ‖r‖, then the dense polish. A chain of 20 or
// 30 links on ball joints, each started up to 0.3 rad from the written
// configuration, had been refused ("no equilibrium found" at a relative
// residual of 0.006 … 0.02: ‖r‖ has valleys that are not balances between a
// coil and the hanging chain, and every descent of ‖r‖ ended in one); this
// search reaches the hanging chain in 9–11 damped steps.
std::optional<Equilibrium> descend_energy(Problem& p, const VectorX& start, const EquilibriumOptions& options) {
  const System& s = p.system();
  if (s.is_map() || s.has_constraints() || s.has_follower_loads()) return std::nullopt;
  Equilibrium reached;
  try {
    reached = find_large_equilibrium(s, start, options);
  } catch (const NumericalError&) {
    return std::nullopt;
  }
  Polished pol = polish(p, reached.q, options);
  if (!pol.converged) return std::nullopt;
  pol.best.method = reached.method + " (descending V from the start, where Levenberg–Marquardt stalled), then Newton";
  return pol.best;
}

}  // namespace

Equilibrium find_equilibrium(const System& s, const VectorX& start, const EquilibriumOptions& options) {
  if (start.size() != s.size()) throw std::invalid_argument("find_equilibrium: start has the wrong size");
  const bool differentiable = require_finite_energy(s, start);
  if (s.has_constraints()) return find_constrained_equilibrium(s, start, options);
  if (!differentiable && is_large_system(s)) {
    // The large-scene search's Newton steps start from ∇V there, and the
    // multi-start search (which can start elsewhere, as the dense path's
    // fallback does below) is for at most large_system_coordinates.
    Workspace w(s);
    throw NumericalError("the initial configuration is no start for the search of the nearest equilibrium: " +
                         describe_meeting_ends(s, *spring_with_meeting_ends(s, w, start)) +
                         "; move one of its ends in the scene");
  }
  if (prefers_sparse_equilibrium(s, start)) return find_large_equilibrium(s, start, options);
  Problem p(s);
  int steps = 0;
  const VectorX local = levenberg_marquardt(p, start, options, steps);
  Polished pol = polish(p, local, options);
  if (pol.converged) {
    // Newton's iterations are counted by the polish; say what moved the start before it.
    if (steps > 0)
      pol.best.method = "Levenberg–Marquardt on the residual (" + std::to_string(steps) + " step" +
                        (steps == 1 ? "" : "s") + "), then Newton";
    return pol.best;
  }
  if (std::optional<Equilibrium> downhill = descend_energy(p, start, options)) return *downhill;
  SearchResult all = search(p, options);
  if (all.found.empty()) {
    Equilibrium best = pol.best;
    if (all.have_failure && all.best_failure.residual < best.residual) best = all.best_failure;
    throw NumericalError(no_equilibrium_message(p, best, all.starts + 1));
  }
  deduplicate_and_sort(s, options, all.found);
  const std::size_t count = all.found.size();
  std::size_t nearest = 0;
  double dmin = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < all.found.size(); ++i) {
    const double d = configuration_distance(s, all.found[i].q, start);
    if (d < dmin) {
      dmin = d;
      nearest = i;
    }
  }
  Equilibrium& e = all.found[nearest];
  e.method = "a multi-start search (the nearest to the start of " + std::to_string(count) + " equilibri" +
             (count == 1 ? "um" : "a") + " found from " + std::to_string(all.starts) +
             " starts, each moved by NLopt's L-BFGS on ½‖∇V − Q‖²), then Newton";
  return e;
}

std::vector<Equilibrium> find_equilibria(const System& s, const EquilibriumOptions& options) {
  require_finite_energy(s, s.initial_configuration());
  if (s.has_constraints()) return find_constrained_equilibria(s, options);
  if (s.size() > large_system_coordinates)
    throw NumericalError("the multi-start search for all equilibria is for systems of at most " +
                         std::to_string(large_system_coordinates) + " coordinates (its Newton steps are dense); this one has " +
                         std::to_string(s.size()) + ": use `modal analyze` (the equilibrium nearest the initial "
                         "configuration, found with sparse matrices)");
  Problem p(s);
  SearchResult all = search(p, options);
  if (all.found.empty()) throw NumericalError(no_equilibrium_message(p, all.best_failure, all.starts));
  deduplicate_and_sort(s, options, all.found);
  return all.found;
}

}  // namespace modal
