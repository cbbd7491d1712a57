// Multi-start search for all equilibria.
//
// Deterministic starts: the initial configuration; the corners {0, π}^h of the
// h hinge angles when 2^h ≤ 256 (other coordinates at their initial values);
// then `starts` points of a Halton sequence (bases: the first n primes) over
// the box angles ∈ [−π, π), rotation-vector components ∈ [−π, π) (vectors
// longer than π scaled back to π), lengths ∈ initial ± 2·length_scale.
// From each start f(q) = ½‖r(q)‖² is minimized with NLopt's LD_LBFGS (exact
// gradient Jᵀr; stops at a relative residual of 1e-8 or after 50 + 5 n
// evaluations, at most 200), then the point reached is Newton-polished. Only
// polished points are kept.
//
// Cost: (1 + corners + starts) × (≤ 50 + 5 n evaluations of r and J, each
// O(n·depth + n²)) + the polishes (a few O(n³) steps each).
#include "equilibrium/problem.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <nlopt.hpp>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <numbers>
#include <optional>

namespace modal::equilibrium_detail {
namespace {

std::vector<int> first_primes(int count) {
  std::vector<int> primes;
  for (int c = 2; static_cast<int>(primes.size()) < count; ++c) {
    bool prime = true;
    for (int p : primes) {
      if (p * p > c) break;
      if (c % p == 0) {
        prime = false;
        break;
      }
    }
    if (prime) primes.push_back(c);
  }
  return primes;
}

// Van der Corput radical inverse of i in the given base, in [0, 1).
double radical_inverse(long long i, int base) {
  double result = 0, f = 1.0 / base;
  while (i > 0) {
    result += f * static_cast<double>(i % base);
    i /= base;
    f /= base;
  }
  return result;
}

bool starts_rotation_vector(const System& s, int i) {
  const auto& c = s.coordinates();
  const auto k = static_cast<std::size_t>(i);
  return c[k].kind == CoordinateKind::rotation &&
         (i == 0 || c[k - 1].kind != CoordinateKind::rotation || c[k - 1].body != c[k].body);
}

}  // namespace

int halton_starts(const System& s, const EquilibriumOptions& options) {
  return options.starts >= 0 ? options.starts : default_equilibrium_starts(s);
}

std::vector<VectorX> starting_points(const System& s, int halton_count) {
  const int n = s.size();
  const VectorX q0 = s.initial_configuration();
  std::vector<VectorX> starts{q0};
  std::vector<int> hinges;
  for (int i = 0; i < n; ++i)
    if (s.coordinates()[static_cast<std::size_t>(i)].kind == CoordinateKind::angle) hinges.push_back(i);
  const int h = static_cast<int>(hinges.size());
  if (h > 0 && h <= 8) {
    for (int mask = 0; mask < (1 << h); ++mask) {
      VectorX q = q0;
      for (int k = 0; k < h; ++k) q[hinges[static_cast<std::size_t>(k)]] = (mask >> k) & 1 ? std::numbers::pi : 0.0;
      starts.push_back(q);
    }
  }
  const std::vector<int> primes = first_primes(n);
  for (int j = 1; j <= halton_count; ++j) {
    VectorX q(n);
    for (int i = 0; i < n; ++i) {
      const double u = radical_inverse(j, primes[static_cast<std::size_t>(i)]);
      const Coordinate& c = s.coordinates()[static_cast<std::size_t>(i)];
      // Periodic angles cover one turn; angles of joints with springs two
      // turns each way (their equilibria need not lie within one turn).
      q[i] = c.kind == CoordinateKind::length ? c.initial + (2 * u - 1) * 2 * s.length_scale()
             : c.periodic                     ? (2 * u - 1) * std::numbers::pi
                                              : (2 * u - 1) * 2 * std::numbers::pi;
    }
    for (int i = 0; i < n; ++i) {
      if (!starts_rotation_vector(s, i) || !s.coordinates()[static_cast<std::size_t>(i)].periodic) continue;
      const double len = q.segment<3>(i).norm();
      if (len > std::numbers::pi) q.segment<3>(i) *= std::numbers::pi / len;
    }
    starts.push_back(q);
  }
  return starts;
}

namespace {

struct Objective {
  Problem* p = nullptr;
  double best_f = std::numeric_limits<double>::infinity();
  VectorX best_x;
  VectorX q;  // scratch
};

// f = ½‖r‖², ∇f = Jᵀr. Remembers the best point seen, so that whatever way
// NLopt ends (including by an exception) the search carries on from there.
double objective(unsigned n, const double* x, double* grad, void* data) {
  auto* o = static_cast<Objective*>(data);
  o->q = Eigen::Map<const VectorX>(x, static_cast<Eigen::Index>(n));
  const VectorX r = o->p->residual(o->q);
  if (!r.allFinite()) {
    if (grad != nullptr) Eigen::Map<VectorX>(grad, static_cast<Eigen::Index>(n)).setZero();
    return 1e300;
  }
  const double f = 0.5 * r.squaredNorm();
  if (grad != nullptr) Eigen::Map<VectorX>(grad, static_cast<Eigen::Index>(n)) = o->p->jacobian(o->q).transpose() * r;
  if (f < o->best_f) {
    o->best_f = f;
    o->best_x = o->q;
  }
  return f;
}

VectorX minimize_residual(Problem& p, const VectorX& start) {
  const int n = p.size();
  Objective o;
  o.p = &p;
  o.best_x = start;
  nlopt::opt opt(nlopt::LD_LBFGS, static_cast<unsigned>(n));
  opt.set_min_objective(objective, &o);
  const VectorX r0 = p.residual(start);
  // Stop once the relative residual is 1e-8: Newton's quadratic convergence
  // does the rest far more cheaply than L-BFGS on the squared residual.
  const double rel0 = p.relative_residual(start, r0);
  const double target = rel0 > 0 ? 1e-8 * r0.norm() / rel0 : 0.0;  // 1e-8 × the force scale
  opt.set_stopval(0.5 * target * target);
  opt.set_ftol_rel(1e-12);
  opt.set_xtol_rel(1e-10);
  opt.set_maxeval(std::min(200, 50 + 5 * n));
  std::vector<double> x(start.data(), start.data() + n);
  double f = 0;
  try {
    opt.optimize(x, f);
  } catch (const std::exception&) {
    // roundoff_limited, forced_stop, failure: carry on from the best point reached.
  }
  return o.best_x;
}

}  // namespace

namespace {

// World positions of every point the potential depends on: centres of mass of
// bodies with mass, spring ends, load points (and follower load directions;
// body axes in a rotating frame). Two configurations that agree on
// all of them have the same V everywhere nearby up to a motion V cannot see
// (spin of a point mass about its rod, rotation of a balanced wheel): they are
// one equilibrium of a continuous family, reported once.
// With `arms`, also each body-fixed point's arm (3 each, in the same order):
// its offset from its body's frame origin, in world axes (R × the point in
// body axes), then every length coordinate's value with the rounding of its
// body's world position (2 each), for a comparison at their own scales
// (arms_agree).
VectorX potential_points(const System& s, Workspace& w, const VectorX& q, VectorX* arms = nullptr) {
  const std::vector<Pose> poses = body_poses(s, w, q);
  // A map's points (and body axes); its potential expression and Routh terms
  // may see any coordinate, so the coordinates join as for joint springs.
  std::vector<Vec3> pts = map_point_positions(s, q);
  // A coordinate the energy sees directly joins as its value scaled to a
  // length comparable with L (not modulo 2π unless periodic).
  const VectorX c = canonical_coordinates(s, q);
  auto coordinate = [&](int i) {
    const CoordinateKind kind = s.coordinates()[static_cast<std::size_t>(i)].kind;
    pts.emplace_back(kind == CoordinateKind::length ? c[i] : s.length_scale() * c[i], 0.0, 0.0);
  };
  if (s.is_map())
    for (int i = 0; i < s.size(); ++i) coordinate(i);
  std::vector<Vec3> offsets;
  auto at = [&](const Attachment& a) {
    if (a.body < 0) return;  // fixed in the world: the same for every configuration
    const Pose& p = poses[static_cast<std::size_t>(a.body)];
    offsets.push_back(p.rotation * a.point);
    pts.push_back(p.position + offsets.back());
  };
  for (std::size_t b = 0; b < s.bodies().size(); ++b)
    if (s.bodies()[b].mass != 0.0) at({static_cast<int>(b), s.bodies()[b].com});
  // In a rotating frame the centrifugal potential sees the orientation of a
  // body with rotational inertia: the tips of its axes join the signature.
  if (s.rotating())
    for (std::size_t b = 0; b < s.bodies().size(); ++b) {
      const Body& body = s.bodies()[b];
      if (body.inertia.isZero(0.0)) continue;
      for (int i = 0; i < 3; ++i) at({static_cast<int>(b), Vec3(body.com + s.length_scale() * Vec3::Unit(i))});
    }
  for (const Spring& sp : s.springs()) {
    at(sp.a);
    at(sp.b);
  }
  for (const DeadLoad& l : s.loads()) at(l.at);
  // A follower load's force turns with its body: its point and the tip of its
  // force direction (one length scale along it) both join the signature.
  for (const FollowerLoad& l : s.followers()) {
    at(l.at);
    if (l.force.norm() > 0) at({l.at.body, Vec3(l.at.point + s.length_scale() * l.force.normalized())});
  }
  // A joint spring sees the joint value itself (a joint with a spring is not
  // periodic), except a ball's geodesic spring, which sees the rotation.
  for (std::size_t b = 0; b < s.bodies().size(); ++b) {
    const int k0 = s.first_coordinate(static_cast<int>(b));
    if (s.bodies()[b].stiffness == 0.0 || s.joint_size(static_cast<int>(b)) == 0 ||
        s.coordinates()[static_cast<std::size_t>(k0)].periodic)
      continue;
    for (int i = k0; i < k0 + s.joint_size(static_cast<int>(b)); ++i) coordinate(i);
  }
  auto stacked = [](const std::vector<Vec3>& list) {
    VectorX v(3 * static_cast<Eigen::Index>(list.size()));
    for (std::size_t i = 0; i < list.size(); ++i) v.segment<3>(3 * static_cast<Eigen::Index>(i)) = list[i];
    return v;
  };
  if (arms) {
    std::vector<std::pair<double, double>> lengths;
    if (!s.is_map())
      for (std::size_t b = 0; b < s.bodies().size(); ++b) {
        const int k0 = s.first_coordinate(static_cast<int>(b));
        for (int k = k0; k < k0 + s.joint_size(static_cast<int>(b)); ++k)
          if (s.coordinates()[static_cast<std::size_t>(k)].kind == CoordinateKind::length)
            lengths.emplace_back(q[k], 64 * std::numeric_limits<double>::epsilon() * poses[b].position.norm());
      }
    const VectorX rotated = stacked(offsets);
    arms->resize(rotated.size() + 2 * static_cast<Eigen::Index>(lengths.size()));
    arms->head(rotated.size()) = rotated;
    for (std::size_t i = 0; i < lengths.size(); ++i) {
      (*arms)[rotated.size() + 2 * static_cast<Eigen::Index>(i)] = lengths[i].first;
      (*arms)[rotated.size() + 2 * static_cast<Eigen::Index>(i) + 1] = lengths[i].second;
    }
  }
  return stacked(pts);
}

// Whether two configurations' arms (potential_points) agree, each to 1e-4 of
// its own length (an angle of 1e-4 rad): the world points alone are compared
// to 1e-6 of the scene's length scale, which in a graded scene is more than a
// short link's whole length (a link of 1e-9 m below one of 1 km: its hanging
// and inverted states, 2e-9 m apart, were taken for one family, and two of a
// graded double pendulum's four equilibria were not listed; an 8-link chain
// beside a bead 1e10 m out was listed as 1 of its 2⁸). Not tighter: where
// large cancelling forces limit the angles' accuracy (a beam balanced by
// counterweights of 1e10 kg), copies of one equilibrium differ by 1e-6 rad.
// Length coordinates likewise, to 1e-4 of their values or the rounding of
// their body's world position (a slide's point has no arm: a bead flipped
// through its spring's anchor, 2 mm from its other state 1e10 m out, was
// merged with it).
bool arms_agree(const VectorX& a, const VectorX& b, Eigen::Index rotated) {
  if (a.size() != b.size()) return false;
  for (Eigen::Index i = 0; i + 3 <= rotated; i += 3) {
    const double length = std::max(a.segment<3>(i).norm(), b.segment<3>(i).norm());
    if (!((a.segment<3>(i) - b.segment<3>(i)).norm() <= 1e-4 * length)) return false;
  }
  for (Eigen::Index i = rotated; i + 2 <= a.size(); i += 2) {
    const double allowed = std::max({1e-4 * std::max(std::abs(a[i]), std::abs(b[i])), a[i + 1], b[i + 1]});
    if (!(std::abs(a[i] - b[i]) <= allowed)) return false;
  }
  return true;
}

// The scale against which two equilibria's potentials are compared.
double potential_scale(const System& s, Workspace& w, const Equilibrium& a, const Equilibrium& b) {
  return std::max({std::abs(a.potential), std::abs(b.potential), force_scale(s, w, a.q)});
}

// Whether a and b, of equal potential, lie on one straight family of
// equilibria (a free translation, a neutral slide, a rotation about a
// symmetry axis written as a hinge): the segment between them (angles the
// short way round) is made of equilibria. A curved family fails the segment
// test and is left to same_curved_family; the cost is three residuals per pair.
bool same_straight_family(const System& s, Workspace& w, Problem& p, const Equilibrium& a, const Equilibrium& b) {
  VectorX d = b.q - a.q;
  for (int i = 0; i < s.size(); ++i)
    if (s.coordinates()[static_cast<std::size_t>(i)].periodic &&
        s.coordinates()[static_cast<std::size_t>(i)].kind == CoordinateKind::angle)
      d[i] = std::remainder(d[i], 2 * std::numbers::pi);
  // Along a family r(a + t d) = 0 for every t, so J(a) d = 0: row by row, to
  // the rounding of |J||d|. Row by row, because one stiff element (a slide of
  // 1e9 N/m) can make the scene's whole force scale a billion times larger
  // than the forces on the coordinates that move (two pendulums' up-down and
  // down-up states, both of potential 0, with horizontal pendulums on the
  // segment between: merged, one equilibrium lost). The entries of d at the
  // rounding level of their coordinate (64ε of its values, of 1 rad or of
  // the length scale) are each member's rounding, not the family's
  // direction, and are left out: a stiff joint at 1e-40 rad in one member
  // and 0 in another made its stiffness times 1e-40 all of |J||d| in rows
  // the family does not move (a cart and a neutral bead beside a pendulum
  // with a stiff light link: its two families listed as 44 rows). (Not a
  // floor of the row's own forces, which count a counterweight's cancelling
  // torques: two balanced beams' up-down and down-up states merged again.)
  // With constraints the family's direction is a null direction of the
  // projected problem, not of J: not tested.
  if (!s.has_constraints()) {
    constexpr double rounding = 64 * std::numeric_limits<double>::epsilon();
    for (int i = 0; i < s.size(); ++i) {
      const double unit =
          s.coordinates()[static_cast<std::size_t>(i)].kind == CoordinateKind::length ? s.length_scale() : 1.0;
      if (std::abs(d[i]) <= rounding * std::max({std::abs(a.q[i]), std::abs(b.q[i]), unit})) d[i] = 0;
    }
    const MatrixX& j = p.jacobian(a.q);
    const VectorX moved = j * d;
    const VectorX size = j.cwiseAbs() * d.cwiseAbs();
    for (Eigen::Index i = 0; i < moved.size(); ++i)
      if (!(std::abs(moved[i]) <= 1e-8 * size[i])) return false;
  }
  // The segment's points are equilibria: each coordinate's residual against
  // its own forces as well as the scene's (modal::relative_residual); with
  // constraints, whose reactions the residual leaves out, ‖r‖ against the
  // scene's whole force scale.
  for (const double t : {0.25, 0.5, 0.75}) {
    const VectorX q = a.q + t * d;
    const VectorX r = equilibrium_residual(s, w, q);
    const bool on = s.has_constraints() ? r.norm() <= 1e-9 * std::max(force_scale(s, w, q), 1e-300)
                                        : relative_residual(s, w, q, r) <= 1e-9;
    if (!on) return false;
  }
  return true;
}

// Whether a and b lie on one curved family of equilibria (a turn about the
// vertical through a pivot that swings a body off the axis round a circle,
// which is no straight line in the coordinates): the family is traced from a,
// each way, by steps along the null direction of the Jacobian (the tangent
// of the family) each polished back onto the equilibria, until b is reached.
// Steps are measured and their sense kept in the positions of the points the
// potential sees (potential_points), which do not change with a rotation
// vector's chart: a sixteenth of the distance from a to b, and within two
// such steps of b, a step of the whole remaining distance towards it, which
// on b's own family lands at b up to the family's curvature (the distance
// falls quadratically, to a millionth of the coordinates' scale). A family
// that only passes near b (another family of the same potential, a long
// boom's sweep past a short pendulum's) does not bring the distance down by
// half a step, and the trace gives up. It also gives up where the Jacobian
// has no null direction (an isolated equilibrium), a polish fails or lands
// at another potential or far from its target, the family closes on itself,
// after 100 steps each way, or when `budget` (steps, each an n × n
// decomposition, shared by one deduplication) runs out.
bool same_curved_family(const System& s, Workspace& w, Problem& p, const EquilibriumOptions& options,
                        const Equilibrium& a, const Equilibrium& b, double scale, long& budget) {
  if (s.has_constraints()) return false;  // the null direction of J would leave the constraint manifold
  const VectorX pa = potential_points(s, w, a.q);
  const VectorX pb = potential_points(s, w, b.q);
  const double h = (pb - pa).norm() / 16;
  if (!(h > 0)) return false;
  // The tangent: the singular (eigen-)vector of the least singular value (|eigenvalue|), if J is singular.
  auto null_direction = [&](const VectorX& q) -> std::optional<VectorX> {
    const MatrixX& j = p.jacobian(q);
    if (p.symmetric_jacobian()) {
      const Eigen::SelfAdjointEigenSolver<MatrixX> es(j);
      if (es.info() != Eigen::Success || es.eigenvalues().size() == 0) return std::nullopt;
      Eigen::Index least = 0;
      const double smallest = es.eigenvalues().cwiseAbs().minCoeff(&least);
      if (!(smallest <= 1e-6 * es.eigenvalues().cwiseAbs().maxCoeff())) return std::nullopt;
      return VectorX(es.eigenvectors().col(least));
    }
    const Eigen::JacobiSVD<MatrixX> svd(j, Eigen::ComputeFullV);
    const VectorX& sigma = svd.singularValues();
    if (sigma.size() == 0 || !(sigma(sigma.size() - 1) <= 1e-6 * sigma(0))) return std::nullopt;
    return VectorX(svd.matrixV().col(sigma.size() - 1));
  };
  for (const double sense : {1.0, -1.0}) {
    VectorX q = a.q;
    VectorX pq = pa;
    VectorX last_step;  // of the points
    for (int step = 0; step < 100 && budget > 0; ++step, --budget) {
      const std::optional<VectorX> z = null_direction(q);
      if (!z) break;
      // The points' motion along z, by a difference of a millionth of a step.
      const double eps = 1e-6 * h;
      const VectorX dp = (potential_points(s, w, q + eps * *z) - pq) / eps;
      if (!(dp.norm() > 0)) break;  // z moves nothing V sees
      const double to_b = (pb - pq).norm();
      const bool approach = to_b < 2 * h;
      double direction = last_step.size() == 0 ? sense : (dp.dot(last_step) >= 0 ? 1.0 : -1.0);
      if (approach) direction = dp.dot(pb - pq) >= 0 ? 1.0 : -1.0;
      const double length = approach ? to_b : h;
      Polished next = polish(p, q + direction * (length / dp.norm()) * *z, options);
      if (!next.converged || !(std::abs(next.best.potential - a.potential) <= 1e-10 * scale)) break;
      const VectorX pn = potential_points(s, w, next.best.q);
      if (!((pn - pq).norm() <= 3 * h)) break;
      last_step = pn - pq;
      q = next.best.q;
      pq = pn;
      if (configuration_distance(s, q, b.q) < 1e-6) return true;  // b itself (deduplicate_and_sort's test)
      if (approach && !((pb - pq).norm() <= 0.5 * to_b)) break;  // passing near b, not onto it
      if (step > 2 && (pq - pa).norm() <= h / 2) break;  // round the family and back to a without meeting b
    }
  }
  return false;
}

// Equal potential, and same_straight_family or same_curved_family. A point between them where the
// model cannot be evaluated (a spring whose ends meet, on the segment from
// one compressed-through chain to another) makes them two rows, not a failed
// survey (the straight test's residuals threw "coincident end points" on
// models/spring_chain.toml).
bool one_family(const System& s, Workspace& w, Problem& p, const EquilibriumOptions& options, const Equilibrium& a,
                const Equilibrium& b, long& budget) {
  try {
    const double scale = potential_scale(s, w, a, b);
    if (!(std::abs(a.potential - b.potential) <= 1e-10 * scale)) return false;
    return same_straight_family(s, w, p, a, b) || same_curved_family(s, w, p, options, a, b, scale, budget);
  } catch (const NumericalError&) {
    return false;
  }
}

}  // namespace

void deduplicate_and_sort(const System& s, const EquilibriumOptions& options, std::vector<Equilibrium>& list) {
  Workspace w(s);
  Problem p(s);
  const VectorX q0 = s.initial_configuration();
  std::vector<Equilibrium> kept;
  std::vector<VectorX> kept_points, kept_arms;
  std::size_t length_coordinates = 0;
  if (!s.is_map())
    for (const Coordinate& c : s.coordinates()) length_coordinates += c.kind == CoordinateKind::length;
  // Steps of the curved-family traces for this list, each an n × n
  // decomposition: about 1e10 flops in all (20000 steps up to 37
  // coordinates, 4630 at 60, 100 at 215, one at 1000).
  const double n = std::max(1, s.size());
  long budget = static_cast<long>(std::min(20000.0, 1e10 / (10 * n * n * n)));
  for (Equilibrium& e : list) {
    VectorX arms;
    const VectorX points = potential_points(s, w, e.q, &arms);
    const Eigen::Index rotated = arms.size() - 2 * static_cast<Eigen::Index>(length_coordinates);
    bool duplicate = false;
    for (std::size_t i = 0; i < kept.size(); ++i) {
      Equilibrium& k = kept[i];
      if (configuration_distance(s, e.q, k.q) < 1e-6) {  // the same point (angles modulo 2π)
        if (e.residual < k.residual) k = e;
        duplicate = true;
      } else if (((points - kept_points[i]).lpNorm<Eigen::Infinity>() <= 1e-6 * s.length_scale() &&
                  arms_agree(arms, kept_arms[i], rotated)) ||
                 one_family(s, w, p, options, e, k, budget)) {
        // Another member of the same continuous family: keep the representative
        // nearest the initial configuration.
        if (configuration_distance(s, e.q, q0) < configuration_distance(s, k.q, q0)) {
          k = e;
          kept_points[i] = points;
          kept_arms[i] = arms;
        }
        duplicate = true;
      }
      if (duplicate) break;
    }
    if (!duplicate) {
      kept.push_back(e);
      kept_points.push_back(points);
      kept_arms.push_back(arms);
    }
  }
  std::stable_sort(kept.begin(), kept.end(), [](const Equilibrium& a, const Equilibrium& b) {
    if (a.potential != b.potential) return a.potential < b.potential;
    return std::lexicographical_compare(a.q.data(), a.q.data() + a.q.size(), b.q.data(), b.q.data() + b.q.size());
  });
  list = std::move(kept);
}

SearchResult search(Problem& p, const EquilibriumOptions& options) {
  const System& s = p.system();
  SearchResult out;
  const std::vector<VectorX> starts = starting_points(s, halton_starts(s, options));
  out.starts = static_cast<int>(starts.size());
  if (s.size() == 0) {  // nothing can move: the one configuration is the equilibrium
    Polished pol = polish(p, VectorX(0), options);
    out.found.push_back(pol.best);
    return out;
  }
  int done = 0;
  for (const VectorX& start : starts) {
    if (options.progress) options.progress(done++, out.starts);
    const VectorX reached = minimize_residual(p, start);
    Polished pol = polish(p, reached, options);
    if (pol.converged) {
      out.found.push_back(pol.best);
    } else if (pol.best.q.size() == s.size() && (!out.have_failure || pol.best.residual < out.best_failure.residual)) {
      out.best_failure = pol.best;
      out.have_failure = true;
    }
  }
  return out;
}

}  // namespace modal::equilibrium_detail

namespace modal {
int default_equilibrium_starts(const System& system) {
  constexpr double full = 64, small = 30;
  constexpr int least = 2;
  const double n = system.size();
  if (n <= small) return static_cast<int>(full);
  return std::max(least, static_cast<int>(full * (small / n) * (small / n)));
}
}  // namespace modal
