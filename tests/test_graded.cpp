// Graded scenes (issue 15): masses and lengths over many decades in one tree.
// The class, not the case: generated double pendulums and chains (fixed-seed
// RNG) with masses and lengths log-uniform over up to 10¹², both orderings,
// hinge, slide and ball joints, some with joint springs, one family with a
// distance constraint. References: the double pendulum's closed form, else M
// and ∇∇V of the same templated model evaluated in long double (nested duals
// for the Hessian) and the generalized eigenproblem solved in long double by
// Eigen, never by modal's double path.
#include "core/model.hpp"
#include "modal/linearize.hpp"
#include "modal/modes.hpp"
#include "modal/pipeline.hpp"
#include "program.hpp"
#include "reference_ld.hpp"
#include "systems.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace {

using namespace modal;
using test::slide;

double log_uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::exp(std::uniform_real_distribution<double>(std::log(lo), std::log(hi))(rng));
}

// A body hanging along −z from its joint: point-like mass m at (0, 0, −l) with
// a small sphere's inertia (radius l/10) so that a ball joint's spin has inertia.
Body link(int parent, JointType joint, const Vec3& origin, double m, double l) {
  Body b;
  b.name = "b" + std::to_string(parent + 1);
  b.parent = parent;
  b.joint = joint;
  b.axis = joint == JointType::slide ? Vec3::UnitX() : Vec3::UnitY();
  b.origin = origin;
  b.mass = m;
  b.com = Vec3(0, 0, -l);
  b.inertia = (0.4 * m * 0.01 * l * l) * Mat3::Identity();
  return b;
}

// A hanging chain of hinges about y, body i's whole mass a point at the
// next hinge (link() without inertia): a point-mass chain (PointMassChain).
SystemDescription point_mass_chain_scene(const std::vector<double>& masses, const std::vector<double>& lengths) {
  SystemDescription d;
  d.gravity = Vec3(0, 0, -9.81);
  Vec3 origin = Vec3::Zero();
  for (std::size_t i = 0; i < masses.size(); ++i) {
    Body b = link(static_cast<int>(i) - 1, JointType::hinge, origin, masses[i], lengths[i]);
    b.inertia.setZero();
    d.bodies.push_back(b);
    origin = Vec3(0, 0, -lengths[i]);
  }
  return d;
}

// ω² of the closed form: m1 l1 l2 x² − g (m1+m2)(l1+l2) x + g²(m1+m2) = 0,
// the small root as product / large root.
std::pair<double, double> double_pendulum_roots(LD m1, LD m2, LD l1, LD l2, LD g) {
  const LD a = m1 * l1 * l2, b = -g * (m1 + m2) * (l1 + l2), c = g * g * (m1 + m2);
  const LD big = (-b + std::sqrt(b * b - 4 * a * c)) / (2 * a);
  return {static_cast<double>(c / a / big), static_cast<double>(big)};
}

struct Figures {
  double worst_error = 0;     // largest |ω² − reference| / |reference|
  double worst_looseness = 0; // largest estimate / max(true error, 1e-12 |reference|)
  int cases = 0, modes = 0;
  int loose = 0;  // estimates over 1e3 × max(error, 1e-12 rel)
  int refused = 0;
};

// modal's ω² against the references. Every mode must lie within its error
// estimate of a reference eigenvalue of its own, one to one: the reference
// eigenvalues, ascending, are each given to the unpaired mode whose interval
// [ω² − estimate, ω² + estimate] contains it and ends first (the greedy
// matching of points to intervals, which pairs all whenever a pairing
// exists). Where no intervals overlap this is the pairing in sorted order;
// where a mode whose estimate says it is unknown (estimate ≫ ω², e.g. ω² 14.6
// ± 5.7e5 in a ball chain) lies above a well determined one (0.2027 ± 1e-10),
// sorted order would pair the latter with the eigenvalue below it. With
// `looseness`, each estimate must also be within 1e3 times its pair's true
// error (or 1e-12 relative when the error is below that).
void check_modes(const ModalResult& r, const std::vector<LD>& reference, const std::string& what, Figures& f,
                 bool looseness = true) {
  ASSERT_EQ(r.modes.size(), reference.size()) << what;
  ++f.cases;
  const std::size_t n = reference.size();
  std::vector<int> pair(n, -1);  // mode k → reference index
  std::vector<LD> sorted = reference;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < n; ++i) {
    int best = -1;
    for (std::size_t k = 0; k < n; ++k) {
      const Mode& m = r.modes[k];
      const LD lo = static_cast<LD>(m.omega2) - static_cast<LD>(m.error_estimate);
      const LD hi = static_cast<LD>(m.omega2) + static_cast<LD>(m.error_estimate);
      if (pair[k] >= 0 || sorted[i] < lo || sorted[i] > hi) continue;
      if (best < 0 || hi < static_cast<LD>(r.modes[static_cast<std::size_t>(best)].omega2) +
                               static_cast<LD>(r.modes[static_cast<std::size_t>(best)].error_estimate))
        best = static_cast<int>(k);
    }
    if (best >= 0) pair[static_cast<std::size_t>(best)] = static_cast<int>(i);
  }
  for (std::size_t k = 0; k < n; ++k) {
    const Mode& m = r.modes[k];
    const std::size_t i = pair[k] >= 0 ? static_cast<std::size_t>(pair[k]) : k;  // unpaired: its sorted place
    const double ref = static_cast<double>(sorted[i]);
    const double err = static_cast<double>(std::abs(static_cast<LD>(m.omega2) - sorted[i]));
    EXPECT_GE(pair[k], 0) << what << " mode " << k + 1 << ": ω² " << m.omega2 << " ± " << m.error_estimate
                          << " holds no reference eigenvalue of its own; in sorted order " << ref;
    const double floor = std::max(err, 1e-12 * std::abs(ref));
    if (looseness) {
      EXPECT_LE(m.error_estimate, 1e3 * floor) << what << " mode " << k + 1 << ": ω² " << m.omega2 << ", reference "
                                               << ref << ", true error " << err;
    }
    f.worst_error = std::max(f.worst_error, err / std::abs(ref));
    f.worst_looseness = std::max(f.worst_looseness, m.error_estimate / floor);
    f.loose += m.error_estimate > 1e3 * floor ? 1 : 0;
    ++f.modes;
  }
}

// Both orderings: l1 ≪ l2 is solved in the absolute angles of the two
// parallel hinges (LinearModel::absolute; in relative angles M is singular to
// (l1/l2)² and was refused), l1 ≫ l2 in relative angles equilibrated. Measured:
// worst relative error 2.5e-11, worst estimate / max(error, 1e-12 rel) 57
// (before: 30 of 60 refused as singular, small-root estimates up to 3.4e7
// times the floor from the normwise term in symmetric.cpp).
TEST(Graded, DoublePendulumsMatchTheClosedFormOverTwelveDecades) {
  std::mt19937_64 rng(15);
  Figures f;
  for (int trial = 0; trial < 60; ++trial) {
    double l1 = log_uniform(rng, 1e-6, 1e6), l2 = log_uniform(rng, 1e-6, 1e6);
    if ((trial % 2 == 0) != (l1 > l2)) std::swap(l1, l2);  // both orderings
    const double m1 = log_uniform(rng, 1e-3, 1e3), m2 = log_uniform(rng, 1e-3, 1e3), g = 9.81;
    SystemDescription d;
    d.gravity = Vec3(0, 0, -g);
    d.bodies.push_back(link(-1, JointType::hinge, Vec3::Zero(), m1, l1));
    d.bodies.back().inertia.setZero();
    d.bodies.push_back(link(0, JointType::hinge, Vec3(0, 0, -l1), m2, l2));
    d.bodies.back().inertia.setZero();
    const System s(d);
    const ModalResult r = solve_modes(linearize(s, Eigen::Vector2d::Zero()));
    const auto [small, big] = double_pendulum_roots(m1, m2, l1, l2, g);
    check_modes(r, {small, big}, "l1 " + std::to_string(l1) + " l2 " + std::to_string(l2), f);
  }
  std::printf("double pendulums: %d cases, worst relative error %.1e, worst estimate / max(error, 1e-12 rel) %.1f\n",
              f.cases, f.worst_error, f.worst_looseness);
}

// N-link chains, N = 2..8, joints hinge / slide (sprung) / ball (sprung),
// lengths and masses log-uniform over [1e-6, 1e6], ascending, descending or
// shuffled along the chain.
// Lengths and masses of a generated chain, log-uniform over [1e-6, 1e6], the
// lengths ascending, descending or shuffled along the chain by trial.
void graded_links(std::mt19937_64& rng, int trial, int links, std::vector<double>& lengths,
                  std::vector<double>& masses) {
  for (int i = 0; i < links; ++i) {
    lengths.push_back(log_uniform(rng, 1e-6, 1e6));
    masses.push_back(log_uniform(rng, 1e-6, 1e6));
  }
  if (trial % 3 == 0) std::sort(lengths.begin(), lengths.end());
  if (trial % 3 == 1) std::sort(lengths.rbegin(), lengths.rend());
}

// modal's modes of s at q with `options`; a refusal (e.g. singular M) is a
// failure (false).
bool modes_at(const System& s, const VectorX& q, const ModalOptions& options, const std::string& what,
              ModalResult& r) {
  try {
    r = solve_modes(linearize(s, q), options);
    return true;
  } catch (const std::exception& e) {
    ADD_FAILURE() << what << ": " << e.what();
    return false;
  }
}

// The same at q = 0 with the default options.
bool modes_at_rest(const System& s, const std::string& what, ModalResult& r) {
  return modes_at(s, VectorX::Zero(s.size()), ModalOptions{}, what, r);
}

// The chain's modes at q = 0 against the long double reference.
void check_chain(const System& s, const std::string& what, Figures& f, bool looseness) {
  ModalResult r;
  if (!modes_at_rest(s, what, r)) {
    ++f.refused;
    return;
  }
  check_modes(r, reference_omega2(s, VectorX::Zero(s.size())), what, f, looseness);
}

void print_figures(const char* what, const Figures& f) {
  std::printf("%s: %d cases (%d modes), %d refused, worst relative error %.1e, %d estimates over 1e3 x max(error, "
              "1e-12 rel), worst by %.1e\n",
              what, f.cases, f.modes, f.refused, f.worst_error, f.loose, f.worst_looseness);
}

// Chains of hinges (x or y), slides and balls. Before the general links of
// absolute_angle_parents, 14 of these 60 were refused as singular (a ball
// next to a hinge or ball with a parallel axis); now none is, and every mode
// holds its reference eigenvalue within its estimate (check_modes). The
// estimates' looseness is measured, not bounded, here (printed; bounded by
// the DISABLED_ test below).
void graded_chains(bool looseness) {
  std::mt19937_64 rng(1512);
  Figures f;
  for (int trial = 0; trial < 60; ++trial) {
    const int links = 2 + trial % 7;
    std::vector<double> lengths, masses;
    graded_links(rng, trial, links, lengths, masses);
    SystemDescription d;
    d.gravity = Vec3(0, 0, -9.81);
    Vec3 origin = Vec3::Zero();
    std::string joints;
    for (int i = 0; i < links; ++i) {
      const int pick = std::uniform_int_distribution<int>(0, 3)(rng);
      const JointType joint = pick == 2 ? JointType::slide : pick == 3 ? JointType::ball : JointType::hinge;
      Body b = link(i - 1, joint, origin, masses[static_cast<std::size_t>(i)], lengths[static_cast<std::size_t>(i)]);
      if (joint == JointType::hinge && pick == 1) b.axis = Vec3::UnitX();
      const double weight = masses[static_cast<std::size_t>(i)] * 9.81 * lengths[static_cast<std::size_t>(i)];
      if (joint == JointType::slide) b.stiffness = masses[static_cast<std::size_t>(i)] * log_uniform(rng, 1e-3, 1e3);
      if (joint == JointType::ball) b.stiffness = weight * log_uniform(rng, 1e-2, 1e2);
      if (joint == JointType::hinge && trial % 4 == 0) b.stiffness = weight * log_uniform(rng, 1e-2, 1e2);
      if (b.stiffness != 0) b.rest = VectorX::Zero(joint_coordinate_count(b));
      joints += joint == JointType::slide ? 's' : joint == JointType::ball ? 'b' : 'h';
      if (std::getenv("MODAL_GRADED_VERBOSE"))  // the scene, to reproduce a failure elsewhere
        std::printf("trial %d body %d %c axis %g %g %g m %.17g l %.17g k %.17g\n", trial, i, joints.back(), b.axis.x(),
                    b.axis.y(), b.axis.z(), b.mass, lengths[static_cast<std::size_t>(i)], b.stiffness);
      d.bodies.push_back(b);
      origin = Vec3(0, 0, -lengths[static_cast<std::size_t>(i)]);
    }
    check_chain(System(d), "chain " + joints + " trial " + std::to_string(trial), f, looseness);
  }
  print_figures("chains", f);
  EXPECT_LE(f.worst_error, 0.1);
}

// Every mode within its estimate of the reference, and none off by more than
// 10 % of itself: before the unresolved modes were refined by inverse
// iteration (lib/modal/symmetric.cpp, refine_unresolved), a ball chain's ω²
// spanning 1e-10 … 7e21 had its low modes off by up to 4.1e6 × themselves
// (within their estimates: the eigen-solver's normwise error), although K
// and M determine them to many digits. Measured now: 4.6e-2, a mode of
// 7e-14 whose estimate (8e-13) is the data's: ∇∇V in θ formed by a
// congruence (docs/design.md, "General links").
TEST(Graded, ChainsMatchTheLongDoubleReference) { graded_chains(false); }

// DISABLED (issue 15 open): the estimates within 1e3 of the true error.
// Measured on this commit: 10 of 438 modes (41 before the refinement of
// unresolved modes, 59 before close groups got their quadratic bound) over
// 1e3 × max(error, 1e-12 rel), worst by 3.5e14: modes whose estimate is the
// data's, a ∇∇V in θ formed by a congruence (docs/design.md, "General
// links"), e.g. ω² 5.7e-18 ± 3e-6.
TEST(Graded, DISABLED_ChainEstimatesAreWithinAThousandTimesTheError) { graded_chains(true); }

// Hinge chains, N = 2..8, the axes y (parallel: solved in absolute angles)
// or, on some joints, x, lengths and masses log-uniform over [1e-6, 1e6] in
// the three orders; joint springs, armatures and a horizontal spring at the
// last body's centre of mass (at its rest length: q = 0 stays the
// equilibrium) on some trials: every term of the absolute-angle assembly.
// Same reference and tolerances as the chains above.
// Before the general links, 2 of these 60 were refused (x hinges separated
// by y hinges, xyyx…: parallel axes that are not parent and child); now
// none is, and every mode holds its reference eigenvalue within its estimate.
void graded_hinge_chains(bool looseness) {
  std::mt19937_64 rng(1515);
  Figures f;
  for (int trial = 0; trial < 60; ++trial) {
    const int links = 2 + trial % 7;
    std::vector<double> lengths, masses;
    graded_links(rng, trial, links, lengths, masses);
    SystemDescription d;
    d.gravity = Vec3(0, 0, -9.81);
    Vec3 origin = Vec3::Zero();
    std::string axes;
    for (int i = 0; i < links; ++i) {
      const auto u = static_cast<std::size_t>(i);
      Body b = link(i - 1, JointType::hinge, origin, masses[u], lengths[u]);
      if (std::uniform_int_distribution<int>(0, 4)(rng) == 0) b.axis = Vec3::UnitX();
      const double weight = masses[u] * 9.81 * lengths[u];
      if (trial % 2 == 0) {
        b.stiffness = weight * log_uniform(rng, 1e-2, 1e2);
        b.rest = VectorX::Zero(1);
      }
      if (trial % 3 == 2) b.armature = masses[u] * lengths[u] * lengths[u] * log_uniform(rng, 1e-3, 1e-1);
      axes += b.axis.x() != 0 ? 'x' : 'y';
      d.bodies.push_back(b);
      origin = Vec3(0, 0, -lengths[u]);
    }
    if (trial % 4 == 1) {
      // From the second body's centre of mass, horizontally, at its rest
      // length. Its direction comes from world positions (xa − xb), so the
      // anchor is near the root and the spring at least as long as the
      // depth there: a long spring at the end of a deep chain would be tilted
      // by ε·depth/length, differently in double and in long double.
      const double z = -(lengths[0] + lengths[1]);  // both round it alike
      Spring sp;
      sp.a = {1, Vec3(0, 0, -lengths[1])};
      sp.rest_length = -2 * z;
      sp.b = {-1, Vec3(sp.rest_length, 0, z)};
      sp.stiffness = masses[1] * 9.81 / lengths[1] * log_uniform(rng, 1e-2, 1e2);
      d.springs.push_back(sp);
    }
    check_chain(System(d), "chain " + axes + " trial " + std::to_string(trial), f, looseness);
  }
  print_figures("hinge chains", f);
}

TEST(Graded, HingeChainsWithSpringsAndArmaturesMatchTheLongDoubleReference) { graded_hinge_chains(false); }

// The estimates within 1e3 of the true error (or of 1e-12 ω²). Measured: the
// worst 4.0e2 ×. Before the unresolved modes were refined by inverse
// iteration (lib/modal/symmetric.cpp, refine_unresolved) 5 of the 294 modes
// were over 1e3 ×, the worst 3.9e4 ×; before close groups got their
// quadratic bound, 15, the worst 5.2e9 ×.
TEST(Graded, HingeChainEstimatesAreWithinAThousandTimesTheError) { graded_hinge_chains(true); }

// Close pairs: two hinge chains hanging side by side from the world, the
// second a copy of the first with its lengths stretched by 1 + η (η
// log-uniform over [1e-10, 1e-4]), N = 2..5 links, lengths and masses
// log-uniform over [1e-6, 1e6]: every mode of the first chain has a partner
// η relative away. Each mode within its estimate of the long double reference
// and every estimate within 1e4 × max(error, 1e-12 ω²). The eigen-solver's
// vectors of such a pair are mixed, so each one's own residual, about ε‖C‖
// in the equilibrated pencil, is far above a low mode's error, and the pair's
// intervals overlap or nearly do: before the group's quadratic bound
// (lib/modal/symmetric.cpp, "Close pairs and small clusters") such pairs kept
// their linear residual, 22 of the 206 modes over 1e3 × and the worst
// 2.3e11 ×; with it 9 over 1e3 ×, the worst 2.5e5 × (pairs whose group
// residual is itself large); with the unresolved modes refined by inverse
// iteration (refine_unresolved) 1 over 1e3 ×, the worst 1.8e3 ×.
TEST(Graded, ClosePairsAreEstimatedAsAGroup) {
  std::mt19937_64 rng(1126);
  Figures f;
  for (int trial = 0; trial < 30; ++trial) {
    const int links = 2 + trial % 4;
    const double eta = log_uniform(rng, 1e-10, 1e-4);
    std::vector<double> lengths, masses;
    for (int i = 0; i < links; ++i) {
      lengths.push_back(log_uniform(rng, 1e-6, 1e6));
      masses.push_back(log_uniform(rng, 1e-6, 1e6));
    }
    SystemDescription d;
    d.gravity = Vec3(0, 0, -9.81);
    for (int copy = 0; copy < 2; ++copy) {
      Vec3 origin(copy == 0 ? 0.0 : 1.0, 0, 0);  // the two pivots 1 m apart along x
      for (int i = 0; i < links; ++i) {
        const auto u = static_cast<std::size_t>(i);
        const double l = copy == 0 ? lengths[u] : lengths[u] * (1 + eta);
        const int parent = i == 0 ? -1 : static_cast<int>(d.bodies.size()) - 1;
        d.bodies.push_back(link(parent, JointType::hinge, origin, masses[u], l));
        d.bodies.back().name = "c" + std::to_string(copy) + "b" + std::to_string(i);
        origin = Vec3(0, 0, -l);
      }
    }
    check_chain(System(d), "pair of chains, " + std::to_string(links) + " links, η " + std::to_string(eta) +
                               " trial " + std::to_string(trial), f, false);
  }
  print_figures("close pairs", f);
  EXPECT_LE(f.worst_looseness, 1e4);
}

// The basis of absolute angles against its definition: on ungraded trees
// (lengths and masses within a decade, where nothing cancels) with hinges
// about x, y and z, balls and slides at random q, M and ∇∇V assembled in θ
// must equal TᵀMT and Tᵀ∇∇V T formed from modal's M and ∇∇V in q, T built
// from the links (q_k = θ_k − θ_parent(k)), and every link must join two
// coordinates turning about the same world axis. Tolerance 1e-12 of the
// largest entry: the two sides round differently, by a few ε per term.
TEST(Graded, AbsoluteAnglesAreACongruenceOfTheRelativeOnes) {
  std::mt19937_64 rng(1519);
  int linked = 0, beyond_parent = 0;
  for (int trial = 0; trial < 40; ++trial) {
    SystemDescription d;
    d.gravity = Vec3(0, 0, -9.81);
    const int links = 2 + trial % 7;
    for (int i = 0; i < links; ++i) {
      const int pick = std::uniform_int_distribution<int>(0, 5)(rng);
      const JointType joint = pick == 4 ? JointType::slide : pick == 5 ? JointType::ball : JointType::hinge;
      const int parent = i == 0 ? -1 : std::uniform_int_distribution<int>(std::max(-1, i - 3), i - 1)(rng);
      const double l = log_uniform(rng, 0.3, 3);
      Body b = link(parent, joint, Vec3(0.1 * l, 0.2 * l, -l), log_uniform(rng, 0.3, 3), l);
      b.name = "b" + std::to_string(i);
      if (joint == JointType::hinge) b.axis = pick == 1 ? Vec3::UnitX() : pick == 2 ? Vec3::UnitZ() : Vec3::UnitY();
      b.armature = trial % 2 == 0 ? 0.1 * b.mass : 0.0;
      b.stiffness = 3.0;
      b.rest = VectorX::Zero(joint_coordinate_count(b));
      d.bodies.push_back(b);
    }
    const System s(d);
    Workspace w(s);
    const bool zero = trial % 3 != 0;  // parallel axes need q = 0 on most trials
    const VectorX q = zero ? VectorX::Zero(s.size()) : VectorX(0.3 * VectorX::Random(s.size()));
    const std::vector<int> parent = absolute_angle_parents(s, w, q);
    MatrixX T = MatrixX::Identity(s.size(), s.size());
    model::TreeState<double> st;
    model::forward_kinematics(s, q.data(), st);
    for (int k = 0; k < s.size(); ++k) {
      const int j = parent[static_cast<std::size_t>(k)];
      if (j < 0) continue;
      T(k, j) = -1;
      ++linked;
      EXPECT_LE((st.omega[static_cast<std::size_t>(k)] - st.omega[static_cast<std::size_t>(j)]).norm(), 1e-15);
      EXPECT_LT(j, k);
    }
    for (std::size_t b = 0; b < s.bodies().size(); ++b) {
      const int a = s.bodies()[b].parent;
      for (int k = s.first_coordinate(static_cast<int>(b)); k < s.first_coordinate(static_cast<int>(b)) + s.joint_size(static_cast<int>(b)); ++k)
        if (parent[static_cast<std::size_t>(k)] >= 0 &&
            (s.bodies()[b].joint != JointType::hinge || parent[static_cast<std::size_t>(k)] < s.first_coordinate(a)))
          ++beyond_parent;
    }
    const MatrixX M = mass_matrix(s, w, q), K = potential_hessian(s, w, q);
    const AbsoluteAngleModel m = absolute_angle_model(s, w, q, parent);
    const MatrixX TMT = T.transpose() * M * T, TKT = T.transpose() * K * T;
    EXPECT_LE((m.M - TMT).cwiseAbs().maxCoeff(), 1e-12 * TMT.cwiseAbs().maxCoeff()) << "trial " << trial << "\n"
                                                                                   << m.M << "\n\n"
                                                                                   << TMT;
    EXPECT_LE((m.K - TKT).cwiseAbs().maxCoeff(), 1e-12 * TKT.cwiseAbs().maxCoeff()) << "trial " << trial;
    for (int j = 0; j < s.size(); ++j) {
      EXPECT_GE(m.inertia_scale[j], (1 - 1e-12) * m.M(j, j)) << "trial " << trial << " coordinate " << j;
      EXPECT_GE(inertia_scale(s, w, q)[j], (1 - 1e-12) * M(j, j)) << "PLAIN trial " << trial << " coordinate " << j;
    }
  }
  EXPECT_GT(linked, 20);
  EXPECT_GT(beyond_parent, 5);  // links past a ball or across other axes, not only hinge under hinge
  std::printf("congruence: %d links, %d beyond a parent hinge\n", linked, beyond_parent);
}

// The degenerate side: a massless end body, aligned hinge axes (two hinges
// about y at the same point) are still refused, naming the coordinate.
TEST(Graded, TrulySingularMassMatricesAreStillRefused) {
  for (double l : {1e-6, 1.0, 1e6}) {
    SystemDescription d;
    d.gravity = Vec3(0, 0, -9.81);
    d.bodies.push_back(link(-1, JointType::hinge, Vec3::Zero(), 1e3, 1e3 * l));
    d.bodies.push_back(link(0, JointType::hinge, Vec3(0, 0, -1e3 * l), 0.0, l));
    d.bodies.back().name = "massless";
    try {
      (void)solve_modes(linearize(System(d), Eigen::Vector2d::Zero()));
      ADD_FAILURE() << "no error for a massless body, l " << l;
    } catch (const SingularMassMatrix& e) {
      EXPECT_NE(std::string(e.what()).find("massless"), std::string::npos) << e.what();
    }
    SystemDescription a;
    a.gravity = Vec3(0, 0, -9.81);
    a.bodies.push_back(link(-1, JointType::hinge, Vec3::Zero(), 0.0, 0.0));
    a.bodies.back().name = "first";
    a.bodies.back().inertia.setZero();
    a.bodies.push_back(link(0, JointType::hinge, Vec3::Zero(), 1.0, l));
    a.bodies.back().name = "second";
    try {
      (void)solve_modes(linearize(System(a), Eigen::Vector2d::Zero()));
      ADD_FAILURE() << "no error for aligned hinge axes, l " << l;
    } catch (const SingularMassMatrix& e) {
      EXPECT_NE(std::string(e.what()).find("first"), std::string::npos) << e.what();
    }
  }
}

// End to end: the scene of the issue.
class GradedProgram : public test::ProgramTest {
 protected:
  GradedProgram() : ProgramTest("modal_graded_") {}
};

TEST_F(GradedProgram, TheIssueSceneIsAnalyzedByTheCommand) {
  const test::Outcome run = test::run_modal(
      {"analyze", std::string(MODAL_SOURCE_DIR) + "/models/double_pendulum.toml", "--set", "l1=1e3", "--set", "l2=1e-6"},
      dir);
  ASSERT_EQ(run.status, 0) << run.out << run.err;
  EXPECT_NE(run.out.find("0.0009999999995"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("2000000.001"), std::string::npos) << run.out;
}

// Chains of sprung slides along one axis, N = 2..10, masses and joint
// stiffnesses log-uniform over [1e-6, 1e6] (stiffness per unit mass): ω²
// over up to 26 decades, M and K in relative coordinates (no change of
// basis for translations). Every mode within its estimate of the long
// double reference, and none off by more than 1e-3 of itself. Before the
// unresolved modes were refined (lib/modal/symmetric.cpp,
// refine_unresolved), the low modes of the stiffest chains were off by up
// to 5.7e4 × themselves (within their estimates), and 35 of the 351
// estimates were over 1e3 × max(error, 1e-12 ω²), the worst 8.4e13 ×.
// Measured now: worst relative error 6.6e-5 (a high mode, within its
// estimate: M in relative coordinates of graded masses); 6 estimates over
// 1e3 ×, the worst 2.6e3 ×.
// The lowest mode of one chain, 9.55877569203e-13, was checked against
// mpmath at 60 digits on the same masses and springs (in absolute
// positions: M diagonal, K tridiagonal).
// A chain of `links` sprung slides along x: masses and stiffness per unit
// mass log-uniform over [1e-6, 1e6]; with `D`, a damper of ratio ζ
// log-uniform over [1e-3, 3] at each joint (c = 2ζ√(k m)), D(i, i) = c.
SystemDescription spring_chain(std::mt19937_64& rng, int trial, int links, MatLD* D) {
  SystemDescription d;
  d.gravity = Vec3(0, 0, -9.81);
  if (D) *D = MatLD::Zero(links, links);
  for (int i = 0; i < links; ++i) {
    const double m = log_uniform(rng, 1e-6, 1e6);
    Body b = link(i - 1, JointType::slide, Vec3::Zero(), m, 1.0);
    b.stiffness = m * log_uniform(rng, 1e-6, 1e6);
    b.rest = VectorX::Zero(1);
    if (D) {
      b.damping = 2 * log_uniform(rng, 1e-3, 3) * std::sqrt(b.stiffness * m);
      (*D)(i, i) = b.damping;
    }
    if (std::getenv("MODAL_GRADED_VERBOSE"))  // the scene, to reproduce a failure elsewhere
      std::printf("trial %d body %d m %.17g k %.17g c %.17g\n", trial, i, m, b.stiffness, b.damping);
    d.bodies.push_back(b);
  }
  return d;
}

TEST(Graded, SpringChainsMatchTheLongDoubleReference) {
  std::mt19937_64 rng(77);
  Figures f;
  for (int trial = 0; trial < 60; ++trial)
    check_chain(System(spring_chain(rng, trial, 2 + trial % 9, nullptr)), "spring chain trial " + std::to_string(trial),
                f, false);
  print_figures("spring chains", f);
  EXPECT_LE(f.worst_error, 1e-3);
}

// Damped spring chains on the first-order path: sprung slides as above, each
// with a damper of ratio ζ log-uniform over [1e-3, 3] on its own joint
// (c = 2ζ√(k m)): s = σ ± iω with |s| over up to 13 decades, under- and
// overdamped modes in one chain. Reference: the quadratic eigenproblem
// s²M + sD + K in long double (reference_quadratic: companion start, refined
// by inverse iteration on Q(s)), M and K from reference_pencil, D = diag(c)
// (joint dampers act on the joint coordinates, which are the slides' own).
// Every mode must hold a reference eigenvalue of its own within its estimate
// (greedy: the reference values, by |s|, each to the unpaired mode whose disk
// holds it and is smallest); the worst relative error and the estimates'
// looseness are printed.
std::string complex_text(std::complex<double> z) {
  char text[64];
  std::snprintf(text, sizeof text, "%.12g%+.12gi", z.real(), z.imag());
  return text;
}

struct FirstOrderFigures {
  double worst_error = 0, worst_looseness = 0;
  int cases = 0, modes = 0, loose = 0;
  int over_ten = 0;  // estimates over 10 × max(error, ε|s|): issue 15's target, printed
};

void check_first_order(const ModalResult& r, const std::vector<std::complex<LD>>& reference, const std::string& what,
                       FirstOrderFigures& f) {
  ASSERT_FALSE(reference.empty()) << what << ": the reference's starts converged to one eigenvalue twice";
  // Both as the 2n eigenvalues of the first-order system: a pair reported
  // once (ω > 0) stands for s and s̄. modal may report a complex pair as two
  // real values within their estimates (a small |s| it does not resolve), so
  // the lists are compared value by value, not entry by entry.
  using CLD = std::complex<LD>;
  std::vector<CLD> values, refs;
  std::vector<double> estimate;
  for (const Mode& m : r.modes)
    for (const double sign : {1.0, -1.0}) {
      if (sign < 0 && m.s.imag() == 0) continue;
      values.emplace_back(m.s.real(), sign * m.s.imag());
      estimate.push_back(m.error_estimate);
    }
  for (const CLD& z : reference) {
    refs.push_back(z);
    if (z.imag() != 0) refs.push_back(std::conj(z));
  }
  if (values.size() != refs.size()) {
    std::string both = "\n modal:";
    for (const Mode& m : r.modes) both += " " + complex_text(m.s) + " ± " + std::to_string(m.error_estimate);
    both += "\n reference:";
    for (const auto& z : reference) both += " " + complex_text(std::complex<double>(z.real(), z.imag()));
    ADD_FAILURE() << what << ": " << values.size() << " eigenvalues, " << refs.size() << " reference values" << both;
    return;
  }
  ++f.cases;
  const std::size_t n = refs.size();
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return std::abs(refs[a]) < std::abs(refs[b]); });
  std::vector<int> pair(n, -1);
  for (const std::size_t i : order) {
    int best = -1;
    for (std::size_t k = 0; k < n; ++k) {
      if (pair[k] >= 0 || std::abs(values[k] - refs[i]) > static_cast<LD>(estimate[k])) continue;
      if (best < 0 || estimate[k] < estimate[static_cast<std::size_t>(best)]) best = static_cast<int>(k);
    }
    if (best >= 0) pair[static_cast<std::size_t>(best)] = static_cast<int>(i);
  }
  for (std::size_t k = 0; k < n; ++k) {
    if (values[k].imag() < 0) continue;  // its conjugate speaks for it
    std::size_t i = 0;  // unpaired: the nearest reference value, for the message
    if (pair[k] >= 0) {
      i = static_cast<std::size_t>(pair[k]);
    } else {
      for (std::size_t j = 1; j < n; ++j)
        if (std::abs(values[k] - refs[j]) < std::abs(values[k] - refs[i])) i = j;
    }
    const double err = static_cast<double>(std::abs(values[k] - refs[i]));
    const double ref = static_cast<double>(std::abs(refs[i]));
    const std::complex<double> s(static_cast<double>(values[k].real()), static_cast<double>(values[k].imag()));
    EXPECT_GE(pair[k], 0) << what << ": s " << complex_text(s) << " ± " << estimate[k]
                          << " holds no reference eigenvalue of its own; nearest "
                          << complex_text({static_cast<double>(refs[i].real()), static_cast<double>(refs[i].imag())})
                          << " (off by " << err << ")";
    const double floor = std::max(err, 1e-12 * ref);
    f.worst_error = std::max(f.worst_error, err / ref);
    f.worst_looseness = std::max(f.worst_looseness, estimate[k] / floor);
    f.loose += estimate[k] > 1e3 * floor ? 1 : 0;
    f.over_ten += estimate[k] > 10 * std::max(err, std::numeric_limits<double>::epsilon() * ref) ? 1 : 0;
    if (std::getenv("MODAL_GRADED_VERBOSE") && estimate[k] > 1e3 * floor)
      std::printf("%s: s %s ± %.3g, reference %s, error %.3g\n", what.c_str(), complex_text(s).c_str(), estimate[k],
                  complex_text({static_cast<double>(refs[i].real()), static_cast<double>(refs[i].imag())}).c_str(), err);
    ++f.modes;
  }
}

// One damped scene against the reference: D is the dampers' matrix in the
// joint coordinates q (joint dampers act on them), carried to the
// reference basis θ (q = Tθ) as TᵀDT.
void check_damped(const System& s, const MatLD& D, const std::string& what, FirstOrderFigures& f) {
  ModalResult r;
  if (!modes_at_rest(s, what, r)) return;
  const VectorX q = VectorX::Zero(s.size());
  MatLD M, K;
  const MatLD T = reference_basis(s);
  reference_pencil(s, q, T, M, K);
  check_first_order(r, reference_quadratic(M, K, T.transpose() * D * T), what, f);
}

void print_figures(const char* what, const FirstOrderFigures& f) {
  std::printf("%s: %d cases (%d eigenvalues), worst relative error %.1e, %d estimates over 1e3 x max(error, 1e-12 "
              "rel), worst by %.1e; %d over 10 x max(error, eps rel)\n",
              what, f.cases, f.modes, f.worst_error, f.loose, f.worst_looseness, f.over_ten);
}

// Measured: worst relative error 3.0e-5 (a high mode: M's rounding in
// relative coordinates, within its estimate), 2 of 454 estimates over
// 1e3 × the true error, the worst 1.6e3 ×. Before the data term, modes in
// most chains lay outside their estimates (−95397.68 ± 6.7e-9 against
// −95398.236, which mpmath at 60 digits confirms); before the refinement,
// the small |s| were off by up to 1.6e9 × themselves (within estimates).
TEST(Graded, DampedSpringChainsMatchTheLongDoubleReference) {
  std::mt19937_64 rng(78);
  FirstOrderFigures f;
  for (int trial = 0; trial < 60; ++trial) {
    MatLD D;
    const SystemDescription d = spring_chain(rng, trial, 2 + trial % 9, &D);
    check_damped(System(d), D, "damped spring chain trial " + std::to_string(trial), f);
  }
  print_figures("damped spring chains", f);
  EXPECT_LE(f.worst_error, 1e-3);
  EXPECT_LE(f.worst_looseness, 1e4);
}

// Damped pendulum chains: hinges about y (parallel) or x, lengths and masses
// log-uniform over [1e-4, 1e4] in the three orders, a damper of ratio ζ
// log-uniform over [1e-3, 3] at every joint (c = 2ζ m l² √(g/l)), some
// joints sprung. Reference as above, in absolute angles. Measured: all 60
// answered (11 were refused as "mass matrix singular" before dampers took
// the absolute angles), worst relative error 1.1e-8, 2 of 353 estimates over
// 1e3 × the true error, the worst 2.7e3 ×.
TEST(Graded, DampedHingeChainsMatchTheLongDoubleReference) {
  std::mt19937_64 rng(1516);
  FirstOrderFigures f;
  for (int trial = 0; trial < 60; ++trial) {
    const int links = 2 + trial % 7;
    std::vector<double> lengths, masses;
    for (int i = 0; i < links; ++i) {
      lengths.push_back(log_uniform(rng, 1e-4, 1e4));
      masses.push_back(log_uniform(rng, 1e-4, 1e4));
    }
    if (trial % 3 == 0) std::sort(lengths.begin(), lengths.end());
    if (trial % 3 == 1) std::sort(lengths.rbegin(), lengths.rend());
    SystemDescription d;
    d.gravity = Vec3(0, 0, -9.81);
    Vec3 origin = Vec3::Zero();
    MatLD D = MatLD::Zero(links, links);
    std::string axes;
    for (int i = 0; i < links; ++i) {
      const auto u = static_cast<std::size_t>(i);
      Body b = link(i - 1, JointType::hinge, origin, masses[u], lengths[u]);
      if (std::uniform_int_distribution<int>(0, 4)(rng) == 0) b.axis = Vec3::UnitX();
      if (trial % 2 == 0) {
        b.stiffness = masses[u] * 9.81 * lengths[u] * log_uniform(rng, 1e-2, 1e2);
        b.rest = VectorX::Zero(1);
      }
      b.damping = 2 * log_uniform(rng, 1e-3, 3) * masses[u] * lengths[u] * lengths[u] * std::sqrt(9.81 / lengths[u]);
      D(i, i) = b.damping;
      axes += b.axis.x() != 0 ? 'x' : 'y';
      d.bodies.push_back(b);
      origin = Vec3(0, 0, -lengths[u]);
    }
    check_damped(System(d), D, "damped chain " + axes + " trial " + std::to_string(trial), f);
  }
  print_figures("damped hinge chains", f);
  EXPECT_LE(f.worst_error, 1e-6);
  EXPECT_LE(f.worst_looseness, 1e4);
}

// Gyroscopic chains: point masses moving in x and y, each relative to the
// one before, in a frame turning at Ω about z: on a planar particle joint
// with an isotropic spring, or (every other trial) on a slide along x
// carrying a slide along y, springs k·a and k/a with a log-uniform over
// [1, 100] (the anisotropy that makes a speed range between two critical
// speeds unstable). Masses log-uniform over [1e-6, 1e6], stiffness per
// unit mass over [1e-6, 1e6], Ω a log-uniform multiple over [1e-3, 1e3] of
// the softest joint's √(k/m): from barely gyroscopic to centrifugally
// softened beyond divergence (gyroscopically stabilized or not), and in one
// trial of three a damper of ratio ζ over [1e-3, 3] on every joint. The
// reference is written down, not taken from modal: in the particles'
// absolute positions r = Tq (T: ones below the diagonal, per axis), T =
// ½Σm|ṙ + Ω×r|² gives M_r = diag(m), the gyroscopic 2mΩ[[0, −1], [1, 0]] per
// particle and the centrifugal −mΩ²I per particle in V − T₀; so M = TᵀM_rT,
// G = TᵀG_rT, K = diag(k) − Ω²TᵀM_rT, and s solves (s²M + s(D + G) + K)x = 0
// (G's sign does not change the eigenvalues: det Q(s)ᵀ = det Q(s) with the
// opposite G), solved in long double by reference_quadratic. Checked against
// mpmath's eig of the companion at 40–50 digits: trials 19 and 41 (divergent)
// agree in all 15 printed digits; in an earlier draw of the family, three
// chains with close pairs within 4e-13 relative (1.9e-9 for an overdamped
// s ≈ −7.1e8). The 60 chains: 35 gyroscopic and stable, 5 divergent
// (anisotropic, between critical speeds), 20 damped of which 12 unstable
// (damping in the rotating frame). Measured: every s within its estimate,
// worst relative error 9.8e-6, none of 450 estimates over 1e3 × the true
// error (worst 7.6e2 ×). Before the reference's left vector started from the
// companion's, it lost close pairs (splittings of 2Ω at |s| = 7e5) and
// reported flutter that mpmath does not.
TEST(Graded, GyroscopicParticleChainsMatchTheLongDoubleReference) {
  std::mt19937_64 rng(1517);
  FirstOrderFigures f;
  for (int trial = 0; trial < 60; ++trial) {
    const int particles = 1 + trial % 6, n = 2 * particles;
    std::vector<double> masses, stiffnesses, dampers, anisotropy;
    double softest = std::numeric_limits<double>::infinity();
    for (int i = 0; i < particles; ++i) {
      masses.push_back(log_uniform(rng, 1e-6, 1e6));
      stiffnesses.push_back(masses.back() * log_uniform(rng, 1e-6, 1e6));
      dampers.push_back(trial % 3 == 0 ? 2 * log_uniform(rng, 1e-3, 3) * std::sqrt(stiffnesses.back() * masses.back())
                                       : 0.0);
      anisotropy.push_back(trial % 2 == 1 ? log_uniform(rng, 1, 100) : 1.0);
      softest = std::min(softest, std::sqrt(stiffnesses.back() / masses.back()));
    }
    const double Omega = softest * log_uniform(rng, 1e-3, 1e3);
    SystemDescription d;
    d.gravity = Vec3(0, 0, -9.81);
    d.frame_rotation = Vec3(0, 0, Omega);
    MatLD Mr = MatLD::Zero(n, n), Gr = MatLD::Zero(n, n), T = MatLD::Zero(n, n), Kq = MatLD::Zero(n, n),
          Dq = MatLD::Zero(n, n);
    for (int i = 0; i < particles; ++i) {
      const auto u = static_cast<std::size_t>(i);
      // k_x = k a, k_y = k / a: one particle joint (a = 1), or a massless
      // slide along x carrying a slide along y with the mass (a > 1).
      const double kx = stiffnesses[u] * anisotropy[u], ky = stiffnesses[u] / anisotropy[u];
      Body b;
      b.name = "p" + std::to_string(i);
      b.parent = static_cast<int>(d.bodies.size()) - 1;
      b.mass = masses[u];
      b.damping = dampers[u];
      if (anisotropy[u] == 1) {
        b.joint = JointType::particle;
        b.particle_axes = {true, true, false};
        b.stiffness = stiffnesses[u];
        b.rest = VectorX::Zero(2);
      } else {
        Body x = b;
        x.name += "x";
        x.joint = JointType::slide;
        x.axis = Vec3::UnitX();
        x.mass = 0;
        x.stiffness = kx;
        x.rest = VectorX::Zero(1);
        d.bodies.push_back(x);
        b.parent = static_cast<int>(d.bodies.size()) - 1;
        b.joint = JointType::slide;
        b.axis = Vec3::UnitY();
        b.stiffness = ky;
        b.rest = VectorX::Zero(1);
      }
      if (std::getenv("MODAL_GRADED_VERBOSE"))
        std::printf("trial %d particle %d m %.17g kx %.17g ky %.17g c %.17g Omega %.17g\n", trial, i, b.mass, kx, ky,
                    b.damping, Omega);
      d.bodies.push_back(b);
      const LD m = static_cast<LD>(b.mass);
      for (int a = 0; a < 2; ++a) {
        const int r = 2 * i + a;
        Mr(r, r) = m;
        Kq(r, r) = static_cast<LD>(a == 0 ? kx : ky);
        Dq(r, r) = static_cast<LD>(b.damping);
        for (int j = 0; j <= i; ++j) T(r, 2 * j + a) = 1;
      }
      Gr(2 * i, 2 * i + 1) = -2 * m * static_cast<LD>(Omega);
      Gr(2 * i + 1, 2 * i) = 2 * m * static_cast<LD>(Omega);
    }
    const LD W = static_cast<LD>(Omega);
    const MatLD M = T.transpose() * Mr * T, K = Kq - W * W * M, C = Dq + T.transpose() * Gr * T;
    const std::string what = "gyroscopic chain of " + std::to_string(particles) + " trial " + std::to_string(trial);
    ModalResult r;
    if (!modes_at_rest(System(d), what, r)) continue;
    check_first_order(r, reference_quadratic(M, K, C), what, f);
  }
  print_figures("gyroscopic particle chains", f);
  EXPECT_EQ(f.cases, 60);
  EXPECT_LE(f.worst_error, 1e-3);
  EXPECT_LE(f.worst_looseness, 1e4);
}

}  // namespace

namespace {

// The eigenvalues of K φ = λ M φ (long double, n×n) that belong to the
// coordinates `own`, the others condensed exactly: λ is one of them iff the
// pencil's Schur complement onto `own`, A(λ) = (K_oo − λM_oo) − (K_or −
// λM_or)(K_rr − λM_rr)⁻¹(K_ro − λM_ro), is singular, i.e. a root of g_i(λ) =
// μ_i(λ) − λ, μ_i the i-th eigenvalue of (A(λ) + λM_oo, M_oo). Where `own` are
// the soft coordinates beside stiff links (ω² 1e10 … 1e25 × theirs), the
// condensed part is about their coupling² / the stiff K, and the small pencil
// is as well conditioned as the soft modes alone; where `own` are the stiff
// ones, the rest is condensed the other way. Each root by the secant method
// from the whole pencil's eigenvalue (Eigen in long double, diagonally
// scaled: normwise accurate, a start) until it settles to 64 ε_LD of the
// group's largest |λ| (a failure if not within 60 steps). `lowest`: `own`
// holds the lowest eigenvalues of the pencil, else the highest.
std::vector<LD> condensed_omega2(const MatLD& M, const MatLD& K, const std::vector<int>& own, bool lowest) {
  const int n = static_cast<int>(M.rows()), p = static_cast<int>(own.size());
  std::vector<int> rest;
  for (int i = 0; i < n; ++i)
    if (std::find(own.begin(), own.end(), i) == own.end()) rest.push_back(i);
  auto block = [](const MatLD& X, const std::vector<int>& a, const std::vector<int>& b) {
    MatLD Y(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i)
      for (std::size_t j = 0; j < b.size(); ++j)
        Y(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = X(a[i], b[j]);
    return Y;
  };
  const MatLD Koo = block(K, own, own), Moo = block(M, own, own), Kor = block(K, own, rest),
              Mor = block(M, own, rest), Krr = block(K, rest, rest), Mrr = block(M, rest, rest);
  auto mu = [&](LD lambda) {  // the eigenvalues of (K_oo − B(λ), M_oo), ascending
    MatLD A = Koo;
    if (!rest.empty()) {
      const MatLD C = Kor - lambda * Mor;
      A -= C * Eigen::PartialPivLU<MatLD>(Krr - lambda * Mrr).solve(MatLD(C.transpose()));
    }
    A = (0.5L * (A + A.transpose())).eval();
    const Eigen::GeneralizedSelfAdjointEigenSolver<MatLD> e(A, Moo, Eigen::EigenvaluesOnly);
    return VecLD(e.eigenvalues());
  };
  VecLD d(n);
  for (int i = 0; i < n; ++i) d[i] = 1 / std::sqrt(M(i, i));
  const Eigen::GeneralizedSelfAdjointEigenSolver<MatLD> whole(d.asDiagonal() * K * d.asDiagonal(),
                                                              d.asDiagonal() * M * d.asDiagonal(),
                                                              Eigen::EigenvaluesOnly);
  const VecLD start = lowest ? VecLD(whole.eigenvalues().head(p)) : VecLD(whole.eigenvalues().tail(p));
  const LD size = start.cwiseAbs().maxCoeff(), tolerance = 64 * std::numeric_limits<LD>::epsilon() * size;
  std::vector<LD> result;
  for (int i = 0; i < p; ++i) {
    LD a = start(i), b = start(i) + 1e-8L * size;
    LD ga = mu(a)(i) - a, gb = mu(b)(i) - b;
    int step = 0;
    for (; step < 60 && std::abs(b - a) > tolerance && gb != ga; ++step) {
      const LD c = b - gb * (b - a) / (gb - ga);
      a = b;
      ga = gb;
      b = c;
      gb = mu(b)(i) - b;
    }
    EXPECT_LT(step, 60) << "the condensed reference did not settle (eigenvalue " << i << ")";
    result.push_back(b);
  }
  return result;
}

}  // namespace

// Stiff joints beside soft modes (issue 15, part 1): a cart on a slide (free
// or sprung) carrying a chain of 1–3 pendulums, a light short link (1e-9 …
// 1e-3 kg, 1e-5 … 1e-2 m; on a third of the scenes a ball) at its end on a
// joint spring whose ω² is 1e10 …
// 1e25 × the pendulums', and on half the scenes the last pendulum's own
// joint as stiff (a locked elbow). K and M determine every soft ω² to about
// ε: the reference condenses the stiff coordinates exactly, in long double,
// from the templated model (condensed_omega2), and for the stiff modes the
// soft ones. Every mode must lie within its estimate of its reference, the soft
// ones within 1e-9 of it and each estimate within 1e-9 of ω², every free
// cart's zero mode a zero mode, every other an oscillation: Eigen's and
// LAPACK's dense paths, all modes or the soft ones only. Before the block
// step of refine_unresolved and the relative angle of a stiff hinge
// (keep_favourable_links), the scene of the issue's note (cart on 100 N/m,
// 1 kg pendulum of 1 m, 1.6e-7 kg link of 0.34 mm on 1.7e11 N·m/rad) had
// both soft modes off by 2.7e-3, estimated 1.1e3 and classed "zero": a
// stable scene reported marginal.
TEST(Graded, StiffJointsKeepTheSoftModes) {
  std::mt19937_64 rng(2711);
  int zero_modes = 0, elbows = 0, balls = 0;
  for (int trial = 0; trial < 24; ++trial) {
    const int pendulums = 1 + trial % 3;
    const bool free_cart = trial % 4 == 3, elbow = pendulums >= 2 && trial % 2 == 1;
    SystemDescription d;
    d.gravity = Vec3(0, 0, -9.81);
    Body cart = slide("cart", -1, Vec3::Zero(), log_uniform(rng, 0.1, 10));
    if (!free_cart) {
      cart.stiffness = cart.mass * log_uniform(rng, 1, 100);
      cart.rest = VectorX::Zero(1);
    }
    d.bodies.push_back(cart);
    Vec3 origin = Vec3::Zero();
    std::vector<int> stiff;
    double soft = 0;  // the last pendulum's g/l, the soft modes' size
    for (int i = 0; i < pendulums; ++i) {
      const double m = log_uniform(rng, 0.1, 10), l = log_uniform(rng, 0.1, 10);
      Body b = link(i, JointType::hinge, origin, m, l);
      b.inertia.setZero();
      soft = 9.81 / l;
      if (elbow && i == pendulums - 1) {
        b.stiffness = log_uniform(rng, 1e10, 1e25) * soft * m * l * l;
        b.rest = VectorX::Zero(1);
        stiff.push_back(1 + i);
      }
      d.bodies.push_back(b);
      origin = Vec3(0, 0, -l);
    }
    const double ms = log_uniform(rng, 1e-9, 1e-3), ls = log_uniform(rng, 1e-5, 1e-2);
    const bool ball = trial % 3 == 2;  // a ball tip: its y component measured from the last hinge, x and z its own
    Body tip = link(pendulums, ball ? JointType::ball : JointType::hinge, origin, ms, ls);
    tip.name = "tip";
    if (!ball) tip.inertia.setZero();
    tip.stiffness = log_uniform(rng, 1e10, 1e25) * soft * ms * ls * ls;
    tip.rest = VectorX::Zero(ball ? 3 : 1);
    for (int k = 0; k < (ball ? 3 : 1); ++k) stiff.push_back(1 + pendulums + k);
    d.bodies.push_back(tip);
    balls += ball ? 1 : 0;
    const System s(d);
    const int n = s.size();
    MatLD M, K;
    reference_pencil(s, VectorX::Zero(n), MatLD::Identity(n, n), M, K);
    std::vector<int> soft_coordinates;
    for (int i = 0; i < n; ++i)
      if (std::find(stiff.begin(), stiff.end(), i) == stiff.end()) soft_coordinates.push_back(i);
    std::vector<LD> reference = condensed_omega2(M, K, soft_coordinates, true);
    const std::vector<LD> high = condensed_omega2(M, K, stiff, false);
    reference.insert(reference.end(), high.begin(), high.end());
    const auto soft_count = soft_coordinates.size();
    elbows += elbow ? 1 : 0;
    const LinearModel model = linearize(s, VectorX::Zero(n));
    for (const DenseSolver solver : {DenseSolver::eigen, DenseSolver::lapack})
      for (const bool all : {true, false}) {
        ModalOptions options;
        options.dense_solver = solver;
        if (!all) options.modes = static_cast<int>(soft_count);
        const ModalResult r = solve_modes(model, options);
        const std::string what = "trial " + std::to_string(trial) + (solver == DenseSolver::eigen ? " eigen" : " lapack") +
                                 (all ? " all" : " soft only") + (free_cart ? ", free cart" : "") +
                                 (elbow ? ", stiff elbow" : "") + ", tip k " + std::to_string(tip.stiffness);
        ASSERT_EQ(r.modes.size(), all ? static_cast<std::size_t>(n) : soft_count) << what;
        for (std::size_t k = 0; k < r.modes.size(); ++k) {
          const Mode& mode = r.modes[k];
          const LD ref = reference[k];
          const double err = static_cast<double>(std::abs(static_cast<LD>(mode.omega2) - ref));
          EXPECT_LE(err, mode.error_estimate) << what << " mode " << k + 1 << ": ω² " << mode.omega2 << ", reference "
                                              << static_cast<double>(ref);
          const bool zero = free_cart && k == 0;
          EXPECT_EQ(mode.kind, zero ? ModeKind::zero : ModeKind::oscillatory) << what << " mode " << k + 1;
          if (k < soft_count && !zero) {
            EXPECT_LE(err, 1e-9 * static_cast<double>(ref)) << what << " mode " << k + 1;
            EXPECT_LE(mode.error_estimate, 1e-9 * static_cast<double>(ref)) << what << " mode " << k + 1;
          }
          zero_modes += zero ? 1 : 0;
        }
        EXPECT_EQ(r.stability, free_cart ? Stability::marginal : Stability::stable) << what;
      }
  }
  EXPECT_GT(zero_modes, 0);  // both kinds of cart, of pendulum joint and of tip were drawn
  EXPECT_GT(elbows, 0);
  EXPECT_GT(balls, 0);
}

// A stiff light hinge under a ball pendulum (or under a hinge pendulum
// hanging from it): the hinge turns about the ball's y component at rest,
// and in absolute angles its spring k enters that component's diagonal, so
// the pendulum's own stiffness was its rounding. keep_favourable_links
// decided only links measured from a hinge, and this one stayed absolute: a
// 1 kg ball pendulum of 1 m with a 1e-6 kg, 1 mm tip on 1e10 N·m/rad gave
// one swing mode 9.770916205 ± 11, "zero" (the eigenvalue, twice: 9.7709163639
// in 50 digits on the same matrices), and the scene "marginal: 2 zero-frequency
// modes". Now a link from a ball's component to a hinge is decided by the
// same measure. Generated: the ball sprung or not (its spin a zero mode),
// a hinge pendulum between it and the tip or not, axes x or y, the tip's
// spring 1e10 … 1e25 × the pendulum's g/l; reference: the long double pencil
// with the tip's coordinate condensed exactly (condensed_omega2). Every mode
// within its estimate, the soft ones within 1e-9 and their estimates within
// 1e-6 (a tip whose loss ratio stays below keep_favourable_links' 1e4 keeps
// its absolute angle, and its spring's rounding, 2e-9 relative on one
// scene, is then in the estimate), the spin a zero mode only where the ball
// has no spring, on Eigen's and LAPACK's paths. The spin's refined vector
// (Eigen's path, a hinge between) had a quotient of 2.7e-309 with its
// residual's norm underflowed to 0: "oscillatory" with a bound of 0, and on
// LAPACK's path the scene refused as below the range of double.
TEST(Graded, AStiffHingeUnderABallKeepsTheSwingModes) {
  std::mt19937_64 rng(1128);
  int free_spins = 0, middles = 0;
  for (int trial = 0; trial < 16; ++trial) {
    const bool sprung = trial % 2 == 0, middle = trial % 4 >= 2;
    SystemDescription d;
    d.gravity = Vec3(0, 0, -9.81);
    const double m = log_uniform(rng, 0.1, 10), l = log_uniform(rng, 0.1, 10);
    Body ball = link(-1, JointType::ball, Vec3::Zero(), m, l);
    if (sprung) {
      ball.stiffness = m * 9.81 * l * log_uniform(rng, 0.01, 100);
      ball.rest = VectorX::Zero(3);
    }
    d.bodies.push_back(ball);
    double soft = 9.81 / l, last = l;
    if (middle) {
      const double mh = log_uniform(rng, 0.1, 10), lh = log_uniform(rng, 0.1, 10);
      Body hinge = link(0, JointType::hinge, Vec3(0, 0, -l), mh, lh);
      hinge.inertia.setZero();
      if (rng() % 2 == 0) hinge.axis = Vec3::UnitX();
      d.bodies.push_back(hinge);
      soft = std::max(soft, 9.81 / lh);
      last = lh;
    }
    const double ms = log_uniform(rng, 1e-9, 1e-3), ls = log_uniform(rng, 1e-5, 1e-2);
    Body tip = link(static_cast<int>(d.bodies.size()) - 1, JointType::hinge, Vec3(0, 0, -last), ms, ls);
    tip.name = "tip";
    tip.inertia.setZero();
    if (rng() % 2 == 0) tip.axis = Vec3::UnitX();
    tip.stiffness = log_uniform(rng, 1e10, 1e25) * soft * ms * ls * ls;
    tip.rest = VectorX::Zero(1);
    d.bodies.push_back(tip);
    const System s(d);
    const int n = s.size(), stiff = n - 1;
    MatLD M, K;
    reference_pencil(s, VectorX::Zero(n), MatLD::Identity(n, n), M, K);
    std::vector<int> soft_coordinates;
    for (int i = 0; i < stiff; ++i) soft_coordinates.push_back(i);
    std::vector<LD> reference = condensed_omega2(M, K, soft_coordinates, true);
    reference.push_back(condensed_omega2(M, K, {stiff}, false)[0]);
    free_spins += sprung ? 0 : 1;
    middles += middle ? 1 : 0;
    const LinearModel model = linearize(s, VectorX::Zero(n));
    for (const DenseSolver solver : {DenseSolver::eigen, DenseSolver::lapack})
      for (const bool all : {true, false}) {
        ModalOptions options;
        options.dense_solver = solver;
        if (!all) options.modes = stiff;
        const ModalResult r = solve_modes(model, options);
        const std::string what = "trial " + std::to_string(trial) + (solver == DenseSolver::eigen ? " eigen" : " lapack") +
                                 (all ? " all" : " soft only") + (sprung ? ", sprung ball" : ", free spin") +
                                 (middle ? ", hinge between" : "") + ", tip k " + std::to_string(tip.stiffness);
        ASSERT_EQ(r.modes.size(), static_cast<std::size_t>(all ? n : stiff)) << what;
        for (std::size_t k = 0; k < r.modes.size(); ++k) {
          const Mode& mode = r.modes[k];
          const LD ref = reference[k];
          const bool zero = !sprung && k == 0;
          const double err = static_cast<double>(std::abs(static_cast<LD>(mode.omega2) - ref));
          EXPECT_EQ(mode.kind, zero ? ModeKind::zero : ModeKind::oscillatory) << what << " mode " << k + 1;
          if (zero) continue;  // its reference is 0 to the condensation's rounding
          EXPECT_LE(err, mode.error_estimate) << what << " mode " << k + 1 << ": ω² " << mode.omega2
                                              << ", reference " << static_cast<double>(ref);
          if (static_cast<int>(k) < stiff) {
            EXPECT_LE(err, 1e-9 * static_cast<double>(ref)) << what << " mode " << k + 1;
            EXPECT_LE(mode.error_estimate, 1e-6 * static_cast<double>(ref)) << what << " mode " << k + 1 << ": error " << err;
          }
        }
        EXPECT_EQ(r.stability, sprung ? Stability::stable : Stability::marginal) << what;
        EXPECT_EQ(r.zero_modes, sprung ? 0 : 1) << what;
      }
  }
  EXPECT_GT(free_spins, 0);
  EXPECT_GT(middles, 0);
}

// Long graded hinge chains (12–20 links, masses, lengths and joint springs
// log-uniform over 1e-6 … 1e6, three springs in ten absent; the first scene
// the one a user's generated family found). The refinement's block step
// took every run of consecutive unresolved modes as one, with the shift
// −2 max|λ| of the run: over a run whose quotients spanned 8 decades the
// projected pencil could not separate its lowest modes, two vectors turned
// to one eigenvalue, and on Eigen's path ω² 0.5432076918 and 1.428305609
// (mpmath at 80 digits on the same chain) came out 1.0998 ± 1.3e3, "zero",
// and 1.1691 ± 0.40: a stable chain "marginal", with a false note that
// modes 3–4 may be one eigenvalue. One application shrinks the stiff
// components by |σ|/λ_stiff (5.7e-7 there), whose square must fall below
// the run's lowest λ/λ_stiff; the block step is now three applications of
// its factorization with a Rayleigh–Ritz step after each. (Splitting runs
// by their vectors' quotients instead lost modes of other generated chains:
// the quotients of an arbitrary basis of a cluster say nothing of it.)
// Reference: reference_omega2 (long double); every mode within its estimate
// and oscillatory, the chain stable, on Eigen's and LAPACK's paths.
// Measured over 301 such chains (this generator, more trials): besides the
// first, 2 chains have modes whose error exceeds the estimate by 1.2–1.4 ×
// on both paths, before this change as after (not mended).
TEST(Graded, LongGradedHingeChainsKeepTheirKinds) {
  std::mt19937_64 rng(2011);
  const std::vector<double> found_masses{346.8404693545686, 222.67282808431722, 0.003845933118560489, 76.35898343106639, 0.25652329118924433, 0.0005265214499322952, 0.9872873829695626, 0.4102367965992889, 0.004199301999325907, 984.6131876237813, 80674.33620710741, 15.018071706866325, 1.8982255086315263e-06, 3.414549585233826, 37.18341804242999, 6108.295037425814, 0.004376797176846916, 0.000649835685203689, 0.030545864036270957, 8.459581906059598e-05}, found_lengths{2250.0940536828057, 2.114842225019241e-06, 5.990795411110254, 9968.057703009601, 2.447878554859079e-06, 9.410317995118909e-05, 800382.1656627912, 0.004904633039682981, 1638.9778072644683, 2.1926414034932683e-06, 0.4013558253392573, 3.27396767803316e-06, 0.0008820772791425734, 1.612174718907137e-06, 142.04923296197603, 0.281116080250018, 0.016750741753255926, 0.11109001011700403, 145.4258918772742, 0.0012780401460117594}, found_springs{0.0, 70.10894956819351, 0.0007428185828039485, 429076.8010301161, 1561.532403109916, 4.215924060878498, 237.20709383722306, 0.0, 0.612103905010762, 0.020724237662985378, 0.0, 9.357230886788804, 0.0, 670955.4570852162, 0.0, 0.0, 0.6270646113704895, 0.046448389741350814, 0.0002700852539271162, 15827.455498870062};
  for (int trial = 0; trial < 31; ++trial) {
    std::vector<double> masses, lengths, springs;
    if (trial == 0) {
      masses = found_masses;
      lengths = found_lengths;
      springs = found_springs;
    } else {
      const int links = 12 + trial % 9;
      for (int i = 0; i < links; ++i) {
        masses.push_back(log_uniform(rng, 1e-6, 1e6));
        lengths.push_back(log_uniform(rng, 1e-6, 1e6));
        springs.push_back(rng() % 10 < 3 ? 0.0 : log_uniform(rng, 1e-6, 1e6));
      }
    }
    SystemDescription d = point_mass_chain_scene(masses, lengths);
    for (std::size_t i = 0; i < masses.size(); ++i) {
      d.bodies[i].stiffness = springs[i];
      if (springs[i] != 0) d.bodies[i].rest = VectorX::Zero(1);
    }
    const System s(d);
    const std::vector<LD> reference = reference_omega2(s, VectorX::Zero(s.size()));
    const LinearModel model = linearize(s, VectorX::Zero(s.size()));
    for (const DenseSolver solver : {DenseSolver::eigen, DenseSolver::lapack}) {
      ModalOptions options;
      options.dense_solver = solver;
      const ModalResult r = solve_modes(model, options);
      const std::string what = "trial " + std::to_string(trial) + (solver == DenseSolver::eigen ? " eigen" : " lapack");
      ASSERT_EQ(r.modes.size(), reference.size()) << what;
      for (std::size_t k = 0; k < r.modes.size(); ++k) {
        const Mode& mode = r.modes[k];
        const double err = static_cast<double>(std::abs(static_cast<LD>(mode.omega2) - reference[k]));
        EXPECT_LE(err, mode.error_estimate) << what << " mode " << k + 1 << ": ω² " << mode.omega2 << " ± "
                                            << mode.error_estimate << ", reference " << static_cast<double>(reference[k]);
        EXPECT_EQ(mode.kind, ModeKind::oscillatory) << what << " mode " << k + 1 << ": ω² " << mode.omega2 << " ± "
                                                    << mode.error_estimate;
      }
      EXPECT_EQ(r.stability, Stability::stable) << what;
    }
  }
}

TEST(Graded, ALargeScenesRefinementKeepsAStiffJointsSoftPairWhole) {
  // The cart-pendulum with a stiff light tip (above) beside 250 … 450 sprung
  // beads, so that n is large and the refinement's budget small (about one
  // mode's worth). Its two soft modes are one run of unresolved modes; the
  // budget, cut per mode before the runs were formed, split it: the block
  // step took one vector of the pair, and both came out "zero" (43.6 and
  // 50.0 against 8.86 and 110.8, a stable scene "marginal"). The beads are
  // decoupled (slides from the world, springs to it), so the soft modes are
  // the subsystem's: reference, its long double pencil condensed exactly
  // (condensed_omega2); the beads' ω² = k/m, above the soft pair.
  std::mt19937_64 rng(3141);
  for (int trial = 0; trial < 8; ++trial) {
    SystemDescription d;
    d.gravity = Vec3(0, 0, -9.81);
    Body cart = slide("cart", -1, Vec3::Zero(), log_uniform(rng, 0.1, 10));
    cart.stiffness = cart.mass * log_uniform(rng, 1, 100);
    cart.rest = VectorX::Zero(1);
    d.bodies.push_back(cart);
    const double m = log_uniform(rng, 0.1, 10), l = log_uniform(rng, 0.1, 10);
    Body pendulum = link(0, JointType::hinge, Vec3::Zero(), m, l);
    pendulum.inertia.setZero();
    d.bodies.push_back(pendulum);
    const double ms = log_uniform(rng, 1e-9, 1e-3), ls = log_uniform(rng, 1e-5, 1e-2);
    Body tip = link(1, JointType::hinge, Vec3(0, 0, -l), ms, ls);
    tip.name = "tip";
    tip.inertia.setZero();
    tip.stiffness = log_uniform(rng, 1e16, 1e25) * (9.81 / l) * ms * ls * ls;
    tip.rest = VectorX::Zero(1);
    d.bodies.push_back(tip);
    const System small(d);
    MatLD M, K;
    reference_pencil(small, VectorX::Zero(3), MatLD::Identity(3, 3), M, K);
    const std::vector<LD> soft = condensed_omega2(M, K, {0, 1}, true);
    const double above = 100 * static_cast<double>(soft[1]);
    const int beads = 250 + static_cast<int>(rng() % 201);
    for (int i = 0; i < beads; ++i) {
      d.bodies.push_back(slide("bead" + std::to_string(i), -1, Vec3(1 + i, 5, 0), 1));
      Spring spring;
      spring.a = Attachment{-1, Vec3(i, 5, 0)};
      spring.b = Attachment{static_cast<int>(d.bodies.size()) - 1, Vec3::Zero()};
      spring.stiffness = above * (1 + 0.01 * i);
      spring.rest_length = 1;
      d.springs.push_back(spring);
    }
    const System s(d);
    const LinearModel model = linearize(s, VectorX::Zero(s.size()));
    for (const DenseSolver solver : {DenseSolver::eigen, DenseSolver::lapack})
      for (const int wanted : {-1, 3}) {
        ModalOptions options;
        options.dense_solver = solver;
        options.modes = wanted;
        const ModalResult r = solve_modes(model, options);
        const std::string what = "trial " + std::to_string(trial) + ", " + std::to_string(beads) + " beads" +
                                 (solver == DenseSolver::eigen ? ", eigen" : ", lapack") +
                                 (wanted > 0 ? ", 3 modes" : ", all modes") + ", tip k " + std::to_string(tip.stiffness);
        ASSERT_GE(r.modes.size(), 3u) << what;
        for (std::size_t k = 0; k < 2; ++k) {
          const double err = static_cast<double>(std::abs(static_cast<LD>(r.modes[k].omega2) - soft[k]));
          EXPECT_LE(err, r.modes[k].error_estimate) << what << " mode " << k + 1;
          EXPECT_LE(err, 1e-9 * static_cast<double>(soft[k])) << what << " mode " << k + 1;
          EXPECT_EQ(r.modes[k].kind, ModeKind::oscillatory) << what << " mode " << k + 1;
        }
        EXPECT_NEAR(r.modes[2].omega2, above, 1e-9 * above) << what;  // the first bead
        EXPECT_EQ(r.stability, Stability::stable) << what;
      }
  }
}

namespace {

// The eigenvalues of the pencil (K, M), K symmetric tridiagonal (diagonal
// `k_diag`, off-diagonal `k_off`), M positive definite: diag(`m`), or
// tridiagonal with off-diagonal `m_off` where given; K − σM definite for
// σ < 0, in __float128 (113-bit significand): Sturm counts of the LDLᵀ
// recurrence of K − σM (Sylvester's law), bisected to 1e-30 of each
// eigenvalue. Independent of modal's path (no LAPACK, no double). The
// lowest `wanted` (all where larger than n).
std::vector<LD> tridiagonal_pencil_eigenvalues(const std::vector<__float128>& k_diag,
                                               const std::vector<__float128>& k_off, const std::vector<__float128>& m,
                                               std::size_t wanted = std::numeric_limits<std::size_t>::max(),
                                               const std::vector<__float128>& m_off = {}) {
  const std::size_t n = m.size();
  auto below = [&](__float128 sigma) {  // eigenvalues < σ
    int count = 0;
    __float128 d = 1;
    for (std::size_t i = 0; i < n; ++i) {
      const __float128 off = i > 0 ? k_off[i - 1] - (m_off.empty() ? 0 : sigma * m_off[i - 1]) : 0;
      d = (k_diag[i] - sigma * m[i]) - (i > 0 ? off * off / d : 0);
      // A pivot exactly 0 taken as a tiny positive one: the count of a σ
      // nudged by that much, which the bisection cannot tell apart.
      if (d == 0) d = static_cast<__float128>(1e-300) * static_cast<__float128>(1e-300);
      if (d < 0) ++count;
    }
    return count;
  };
  __float128 top = 0;  // Gershgorin: every eigenvalue ≤ max_i (|K_ii| + Σ|K_ij|) / m_i (M diagonal)
  for (std::size_t i = 0; i < n; ++i) {
    __float128 row = k_diag[i] < 0 ? -k_diag[i] : k_diag[i];
    if (i > 0) row += k_off[i - 1] < 0 ? -k_off[i - 1] : k_off[i - 1];
    if (i + 1 < n) row += k_off[i] < 0 ? -k_off[i] : k_off[i];
    top = std::max(top, row / m[i]);
  }
  std::vector<LD> values;
  for (std::size_t j = 0; j < std::min(n, wanted); ++j) {  // the (j+1)-th eigenvalue: below(hi) > j ≥ below(lo)
    __float128 lo = 0, hi = 2 * top;
    for (int grow = 0; grow < 16384 && static_cast<std::size_t>(below(hi)) <= j; ++grow)
      hi *= 2;  // M tridiagonal: the bound above need not hold
    for (int step = 0; step < 400 && hi - lo > static_cast<__float128>(1e-30) * hi; ++step) {
      const __float128 mid = (lo + hi) / 2;  // from 2·top to 1e-20 of it and then 1e-30 relative: under 200 steps
      (static_cast<std::size_t>(below(mid)) > j ? hi : lo) = mid;
    }
    values.push_back(static_cast<LD>((lo + hi) / 2));
  }
  return values;
}

// Chains of 20–50 particles (by default) between two anchors along x (diagonal M: on the
// LAPACK path the reduction C = L⁻¹KL⁻ᵀ and the solves with L are scalings,
// not dsygst and triangular solves), masses log-uniform over [1e-6, 1e6] and
// stiffnesses over [1e-3, 1e3], ascending, descending or shuffled along the
// chain, each spring's rest length set so that all carry the same tension
// (the written positions are the equilibrium; no gravity). The reference:
// the pencil as written, in __float128 (along the chain K holds the springs'
// k, across it their tension over length k(1 − L₀/L), from the written
// double positions, rest lengths and stiffnesses; x, y and z decouple), its
// eigenvalues by Sturm bisection. `check` gets each scene's modes (all, and
// the lowest 5 alone, both forced onto the LAPACK path; on the sparse path,
// the lowest 10 from solve_sparse_modes with the options `modal analyze`
// gives it; on the command line's, the scene written as TOML and analyzed
// as `modal analyze` does, equilibrium first) and the reference.
enum class ChainPath { lapack, sparse, command_line };
template <class Check>
void graded_particle_chains(const Check& check, unsigned seed = 2026, int trials = 12, int fewest = 20, int most = 50,
                            ChainPath path = ChainPath::lapack) {
  std::mt19937_64 rng(seed);
  for (int trial = 0; trial < trials; ++trial) {
    const int particles = std::uniform_int_distribution<int>(fewest, most)(rng);
    std::vector<double> masses, stiffness;
    for (int i = 0; i < particles; ++i) masses.push_back(log_uniform(rng, 1e-6, 1e6));
    for (int i = 0; i <= particles; ++i) stiffness.push_back(log_uniform(rng, 1e-3, 1e3));
    if (trial % 3 == 0) std::sort(masses.begin(), masses.end());
    if (trial % 3 == 1) std::sort(masses.rbegin(), masses.rend());
    const double spacing = 0.1;  // a strain of 1e-3 … 0.5 in the softest spring
    const double tension = spacing * *std::min_element(stiffness.begin(), stiffness.end()) * log_uniform(rng, 1e-3, 0.5);
    SystemDescription d;
    d.gravity = Vec3::Zero();
    for (int i = 0; i < particles; ++i) {
      Body b;
      b.name = "p" + std::to_string(i);
      b.parent = -1;
      b.joint = JointType::particle;
      b.origin = Vec3(spacing * (i + 1), 0, 0);
      b.mass = masses[static_cast<std::size_t>(i)];
      d.bodies.push_back(b);
    }
    for (int i = 0; i <= particles; ++i) {
      Spring spring;
      spring.a = i == 0 ? Attachment{-1, Vec3::Zero()} : Attachment{i - 1, Vec3::Zero()};
      spring.b = i == particles ? Attachment{-1, Vec3(spacing * (particles + 1), 0, 0)} : Attachment{i, Vec3::Zero()};
      spring.stiffness = stiffness[static_cast<std::size_t>(i)];
      spring.rest_length = spacing - tension / spring.stiffness;  // k (L − L₀) = tension
      d.springs.push_back(spring);
    }
    const std::vector<__float128> m(masses.begin(), masses.end());
    const bool sparse = path == ChainPath::sparse;
    const std::size_t count = sparse ? 10 : m.size();  // enough of each for the lowest 10
    // The pencil at the particles' positions x (along the chain) and its
    // lowest `count` eigenvalues of each direction.
    auto reference_at = [&](const std::vector<__float128>& x) {
      std::vector<__float128> along_diag(static_cast<std::size_t>(particles)),
          along_off(static_cast<std::size_t>(particles - 1)), across_diag(static_cast<std::size_t>(particles)),
          across_off(static_cast<std::size_t>(particles - 1));
      for (int i = 0; i <= particles; ++i) {
        const Spring& spring = d.springs[static_cast<std::size_t>(i)];
        const __float128 xa = i == 0 ? 0 : x[static_cast<std::size_t>(i - 1)];
        const __float128 xb = i == particles ? spring.b.point.x() : x[static_cast<std::size_t>(i)];
        const __float128 length = xb - xa, k = spring.stiffness;
        const __float128 across = k * (1 - static_cast<__float128>(spring.rest_length) / length);
        for (const int end : {i - 1, i}) {
          if (end < 0 || end >= particles) continue;
          along_diag[static_cast<std::size_t>(end)] += k;
          across_diag[static_cast<std::size_t>(end)] += across;
        }
        if (i > 0 && i < particles) {
          along_off[static_cast<std::size_t>(i - 1)] = -k;
          across_off[static_cast<std::size_t>(i - 1)] = -across;
        }
      }
      std::vector<LD> values = tridiagonal_pencil_eigenvalues(along_diag, along_off, m, count);
      const std::vector<LD> across = tridiagonal_pencil_eigenvalues(across_diag, across_off, m, count);
      values.insert(values.end(), across.begin(), across.end());
      values.insert(values.end(), across.begin(), across.end());
      std::sort(values.begin(), values.end());
      return values;
    };
    std::vector<__float128> written;
    for (const Body& b : d.bodies) written.push_back(b.origin.x());
    const System s(d);
    const std::string chain = "trial " + std::to_string(trial) + ", " + std::to_string(particles) + " particles";
    if (path == ChainPath::command_line) {
      std::ostringstream toml;
      toml.precision(17);
      toml << "gravity = [0, 0, 0]\n";
      for (const Body& b : d.bodies)
        toml << "[[particle]]\nname = \"" << b.name << "\"\nposition = [" << b.origin.x() << ", 0, 0]\nmass = " << b.mass
             << "\n";
      for (int i = 0; i <= particles; ++i) {
        const Spring& spring = d.springs[static_cast<std::size_t>(i)];
        toml << "[[spring]]\na = \"" << (i == 0 ? std::string("world") : "p" + std::to_string(i - 1)) << "\"\nb = \""
             << (i == particles ? std::string("world") : "p" + std::to_string(i)) << "\"\n";
        if (i == particles) toml << "b_point = [" << spring.b.point.x() << ", 0, 0]\n";
        toml << "stiffness = " << spring.stiffness << "\nrest_length = " << spring.rest_length << "\n";
      }
      // The equilibrium moves the particles by rounding-level amounts, which
      // move the transverse stiffness k(1 − L₀/L) of a spring at a strain of
      // 1e-9 by 1e-5 of itself: the reference is the pencil at the
      // equilibrium's positions (written + q, in double as modal forms them;
      // modal's q: a wrong equilibrium is not this test's to catch, but a
      // moved one changes the reference only where the pencil moved too).
      const modal::Analysis a = modal::analyze(modal::model_from_text(toml.str(), "chain.toml"), {});
      const std::vector<std::string>& names = a.report.coordinates;
      std::vector<__float128> x = written;
      for (std::size_t j = 0; j < names.size(); ++j) {
        const double q = a.equilibrium().q(static_cast<Eigen::Index>(j));
        const std::size_t dot = names[j].find('.');
        const int i = std::atoi(names[j].c_str() + 1);
        if (names[j].substr(dot + 1) == "x")  // the position in double, as modal forms it
          x[static_cast<std::size_t>(i)] = d.bodies[static_cast<std::size_t>(i)].origin.x() + q;
        else EXPECT_EQ(q, 0.0) << chain << ": " << names[j];  // no force across the chain
      }
      check(a.result(), reference_at(x), chain + ", all modes (modal analyze)");
      continue;
    }
    const std::vector<LD> reference = reference_at(written);
    if (sparse) {
      const ModalResult r = test::sparse_modes_of(linearize_sparse(s, VectorX::Zero(s.size())), 10);
      EXPECT_NE(r.solver.find("Lanczos"), std::string::npos) << chain << ": " << r.solver;
      check(r, std::vector<LD>(reference.begin(), reference.begin() + 10), chain + ", lowest 10 (sparse)");
      continue;
    }
    const LinearModel model = linearize(s, VectorX::Zero(s.size()));
    for (const int wanted : {-1, 5}) {
      ModalOptions options;
      options.dense_solver = DenseSolver::lapack;
      options.modes = wanted;
      const ModalResult r = solve_modes(model, options);
      const std::string what = chain + (wanted > 0 ? ", lowest 5" : ", all modes");
      EXPECT_NE(r.solver.find("LAPACK"), std::string::npos) << what << ": " << r.solver;
      check(r, wanted > 0 ? std::vector<LD>(reference.begin(), reference.begin() + wanted) : reference, what);
    }
  }
}

// A stable chain: every mode oscillatory (none "zero", the class not "marginal").
void expect_stable_and_oscillatory(const ModalResult& r, const std::string& what) {
  EXPECT_EQ(r.stability, Stability::stable) << what;
  for (std::size_t k = 0; k < r.modes.size(); ++k)
    EXPECT_EQ(r.modes[k].kind, ModeKind::oscillatory) << what << " mode " << k + 1;
}

// Every mode within its estimate of a reference eigenvalue of its own, one
// to one (check_modes), all modes and the lowest 5 alone; the lowest 5
// within 1e-8 of themselves (measured: 2.3e-9 at worst). Before the runs of
// unresolved modes were joined across the modes between them
// (refine_unresolved), trial 3 (48 particles, ω² over 1e-12 … 1e9) came out
// with 4.786e-9 ± 9.3e-10 and 5.334e-9 ± 7.3e-9, both near the one
// eigenvalue 4.777e-9 there, and no mode near 1.0216e-7: each interval held
// an eigenvalue, but the spectrum as a whole was wrong (4 such modes in 9
// seeds of this family; 12 in 3 seeds of 100–250 particles; none now).
TEST(Graded, ParticleChainsOnTheLapackPathMatchTheReferenceOneToOne) {
  Figures all, lowest;
  graded_particle_chains([&](const ModalResult& r, const std::vector<LD>& reference, const std::string& what) {
    check_modes(r, reference, what, reference.size() <= 5 ? lowest : all, false);
  });
  print_figures("particle chains, all modes", all);
  print_figures("particle chains, lowest 5", lowest);
  EXPECT_LE(lowest.worst_error, 1e-8);
}

// Longer chains (150–200 particles, 450–600 coordinates), where the dense
// refinement budget (4n³ flops in LU factorizations) had covered one block
// step and one mode: their lowest modes came out "zero" with estimates 100 ×
// their ω² (a stable chain "marginal"; relative errors up to 12 in 3 seeds
// of 100–250 particles). With K and M mostly zero the refinement's solves
// are sparse LU factorizations and every unresolved mode is refined: the
// chain stable, every mode oscillatory, each one to one within its estimate,
// the lowest 5 within 1e-8 of themselves (measured 1e-13).
TEST(Graded, LongParticleChainsAreStableWithTheirLowestModesResolved) {
  Figures all, lowest;
  graded_particle_chains(
      [&](const ModalResult& r, const std::vector<LD>& reference, const std::string& what) {
        check_modes(r, reference, what, reference.size() <= 5 ? lowest : all, false);
        expect_stable_and_oscillatory(r, what);
      },
      7, 2, 150, 200);
  print_figures("long particle chains, all modes", all);
  print_figures("long particle chains, lowest 5", lowest);
  EXPECT_LE(lowest.worst_error, 1e-8);
}

// Chains of 280–320 particles (840–960 coordinates: the default path is
// still dense), written as TOML and analyzed as `modal analyze` does
// (equilibrium first; the reference at its positions). Before: the stable
// chain "marginal" with modes "zero" (trial 2 here, 311 particles, and of
// seed 2, 316; 5 of 9 such chains from the command line): a run of
// unresolved modes joined across resolved ones (refine_unresolved) had its
// block step replace the resolved modes' vectors too, which were not refined
// after it (2.8e-12 ± 1.5e-11), and a refined vector that turned towards an
// earlier refined one (two eigenvalues 1–13 % apart, the first refined
// partly converged to the other's) was discarded, keeping its unrefined
// vector. Now the former are refined after the candidates and the latter
// pair replaced by the Ritz vectors of their span. The same checks as above.
TEST(Graded, LongerParticleChainsKeepTheModesTheirRefinementPassedOver) {
  Figures all, lowest;
  graded_particle_chains(
      [&](const ModalResult& r, const std::vector<LD>& reference, const std::string& what) {
        check_modes(r, reference, what, all, false);
        expect_stable_and_oscillatory(r, what);
        ModalResult first = r;
        first.modes.resize(std::min<std::size_t>(5, r.modes.size()));
        check_modes(first, std::vector<LD>(reference.begin(), reference.begin() + 5), what + ", lowest 5", lowest,
                    false);
      },
      1, 3, 280, 320, ChainPath::command_line);
  print_figures("longer particle chains, all modes", all);
  print_figures("longer particle chains, lowest 5", lowest);
  EXPECT_LE(lowest.worst_error, 1e-8);
}

// The sparse path (solve_sparse_modes, as `modal analyze` takes it above
// 1000 coordinates) on chains of 340–420 particles (1020–1260 coordinates),
// the lowest 10 modes. Their ω² lie 20–25 decades below the largest K_ii/M_ii
// (λ₁ ≈ 3.7e-14 against 8e8 in one chain), far below ζ, the default shift's
// distance below 0: the run there was refused ("did not converge … raise
// max_iterations"), and once a moved shift converged, the normwise zero test
// (4ε‖K‖₁) called every mode zero and the chain marginal. Now the shift moves
// down while the probe's Ritz values lie far below it and above their data's
// level (4ε φᵀFφ, the springs' rounding form), and the kind is decided with
// that level: the chain stable, every mode oscillatory, each one to one
// within its estimate, the lowest 5 within 1e-6 of themselves (measured:
// 5.8e-9 at worst, within estimates of about 4e-6 relative).
TEST(Graded, ParticleChainsOnTheSparsePathAreStableWithTheirLowestModesResolved) {
  Figures lowest;
  graded_particle_chains(
      [&](const ModalResult& r, const std::vector<LD>& reference, const std::string& what) {
        check_modes(r, reference, what, lowest, false);
        expect_stable_and_oscillatory(r, what);
      },
      11, 4, 340, 420, ChainPath::sparse);
  print_figures("particle chains on the sparse path, lowest 10", lowest);
  EXPECT_LE(lowest.worst_error, 1e-6);
}

// The number of eigenvalues below σ of the pencil (K, M), K symmetric with
// half-bandwidth `band` (dense storage, n × n), M = diag(`m`), by the signs of
// an LDLᵀ of K − σM in __float128 (Sylvester's law; no pivoting, a zero
// pivot taken as a tiny positive one).
int banded_count_below(const std::vector<std::vector<__float128>>& K, const std::vector<__float128>& m, int band,
                       __float128 sigma) {
  const int n = static_cast<int>(m.size());
  std::vector<std::vector<__float128>> A = K;
  for (int i = 0; i < n; ++i) A[static_cast<std::size_t>(i)][static_cast<std::size_t>(i)] -= sigma * m[static_cast<std::size_t>(i)];
  int count = 0;
  for (int k = 0; k < n; ++k) {
    auto& row_k = A[static_cast<std::size_t>(k)];
    __float128 d = row_k[static_cast<std::size_t>(k)];
    if (d == 0) d = static_cast<__float128>(1e-300) * static_cast<__float128>(1e-300);
    if (d < 0) ++count;
    const int last = std::min(n - 1, k + band);
    for (int i = k + 1; i <= last; ++i) {
      const __float128 l = row_k[static_cast<std::size_t>(i)] / d;
      if (l == 0) continue;
      auto& row_i = A[static_cast<std::size_t>(i)];
      for (int j = i; j <= last; ++j) row_i[static_cast<std::size_t>(j)] -= l * row_k[static_cast<std::size_t>(j)];
      for (int j = i; j <= last; ++j) A[static_cast<std::size_t>(j)][static_cast<std::size_t>(i)] = row_i[static_cast<std::size_t>(j)];
    }
  }
  return count;
}

// Flat nets of N × N free particles (N = 10–16, 300–768 coordinates: the
// Lanczos path) inside a fixed square boundary, spacing 0.1, masses
// log-uniform over [1e-6, 1e6] in random places, stiffnesses over [1e-3,
// 1e3], every spring at one tension (rest lengths set for it; the written
// grid is the equilibrium, no gravity). The axis-aligned springs decouple x,
// y and z: each a weighted graph Laplacian (a spring's k along its axis, its
// tension over length k(1 − L₀/L) across), assembled in __float128 from the
// written double data. The reference is independent of modal's path: for
// the i-th returned mode, the count of eigenvalues below ω²_i − e_i must be
// at most i − 1 and below ω²_i + e_i at least i (e_i its error estimate), so
// the i-th eigenvalue lies within its estimate. Their lowest ω² lie 20
// decades and more below the largest K_ii/M_ii; the sparse path refused
// every one of 5 such nets of 20 × 20 ("did not converge", 232f1fe).
TEST(Graded, FlatNetsOnTheSparsePathHoldTheirEigenvaluesWithinTheirEstimates) {
  std::mt19937_64 rng(29112026);
  for (int trial = 0; trial < 4; ++trial) {
    const int N = std::uniform_int_distribution<int>(10, 16)(rng), n = N * N;
    const double spacing = 0.1;
    SystemDescription d;
    d.gravity = Vec3::Zero();
    std::vector<__float128> m;
    for (int i = 0; i < N; ++i)
      for (int j = 0; j < N; ++j) {
        Body b;
        b.name = "p" + std::to_string(i) + "_" + std::to_string(j);
        b.parent = -1;
        b.joint = JointType::particle;
        b.origin = Vec3(spacing * (i + 1), spacing * (j + 1), 0);
        b.mass = log_uniform(rng, 1e-6, 1e6);
        m.push_back(b.mass);
        d.bodies.push_back(b);
      }
    // Edges (a, b) along x (axis 0) or y (axis 1) between grid points 0 … N + 1
    // (0 and N + 1: the boundary, fixed).
    struct Edge {
      int i, j, axis;
      double k;
    };
    std::vector<Edge> edges;
    for (int i = 0; i <= N + 1; ++i)
      for (int j = 0; j <= N + 1; ++j)
        for (int axis = 0; axis < 2; ++axis) {
          const int i2 = i + (axis == 0), j2 = j + (axis == 1);
          if (i2 > N + 1 || j2 > N + 1) continue;
          const bool fixed_a = i == 0 || j == 0 || i == N + 1 || j == N + 1;
          const bool fixed_b = i2 == 0 || j2 == 0 || i2 == N + 1 || j2 == N + 1;
          if (fixed_a && fixed_b) continue;
          edges.push_back({i, j, axis, log_uniform(rng, 1e-3, 1e3)});
        }
    double k_min = edges.front().k;
    for (const Edge& e : edges) k_min = std::min(k_min, e.k);
    const double tension = spacing * k_min * log_uniform(rng, 1e-3, 0.5);
    auto node = [&](int i, int j) { return (i >= 1 && i <= N && j >= 1 && j <= N) ? (i - 1) * N + (j - 1) : -1; };
    std::vector<std::vector<std::vector<__float128>>> K(3, std::vector<std::vector<__float128>>(
                                                              static_cast<std::size_t>(n), std::vector<__float128>(static_cast<std::size_t>(n), 0)));
    for (const Edge& e : edges) {
      const int i2 = e.i + (e.axis == 0), j2 = e.j + (e.axis == 1);
      const int a = node(e.i, e.j), b = node(i2, j2);
      Spring spring;
      const Vec3 pa(spacing * e.i, spacing * e.j, 0), pb(spacing * i2, spacing * j2, 0);
      spring.a = a >= 0 ? Attachment{a, Vec3::Zero()} : Attachment{-1, pa};
      spring.b = b >= 0 ? Attachment{b, Vec3::Zero()} : Attachment{-1, pb};
      spring.stiffness = e.k;
      spring.rest_length = spacing - tension / e.k;
      d.springs.push_back(spring);
      const __float128 length = static_cast<__float128>(e.axis == 0 ? pb.x() : pb.y()) -
                                static_cast<__float128>(e.axis == 0 ? pa.x() : pa.y());
      const __float128 k = e.k, across = k * (1 - static_cast<__float128>(spring.rest_length) / length);
      for (int direction = 0; direction < 3; ++direction) {
        const __float128 w = direction == e.axis ? k : across;
        auto& Kd = K[static_cast<std::size_t>(direction)];
        for (const int v : {a, b})
          if (v >= 0) Kd[static_cast<std::size_t>(v)][static_cast<std::size_t>(v)] += w;
        if (a >= 0 && b >= 0) {
          Kd[static_cast<std::size_t>(a)][static_cast<std::size_t>(b)] -= w;
          Kd[static_cast<std::size_t>(b)][static_cast<std::size_t>(a)] -= w;
        }
      }
    }
    auto count_below = [&](LD sigma) {
      int count = 0;
      for (const auto& Kd : K) count += banded_count_below(Kd, m, N, static_cast<__float128>(sigma));
      return count;
    };
    const System s(d);
    const ModalResult r = test::sparse_modes_of(linearize_sparse(s, VectorX::Zero(s.size())), 10);
    const std::string what = "trial " + std::to_string(trial) + ", " + std::to_string(N) + " × " + std::to_string(N);
    EXPECT_NE(r.solver.find("Lanczos"), std::string::npos) << what << ": " << r.solver;
    EXPECT_EQ(r.stability, Stability::stable) << what;
    ASSERT_EQ(r.modes.size(), 10u) << what;
    for (std::size_t i = 0; i < r.modes.size(); ++i) {
      const Mode& mode = r.modes[i];
      EXPECT_EQ(mode.kind, ModeKind::oscillatory) << what << " mode " << i + 1;
      const LD lo = static_cast<LD>(mode.omega2) - static_cast<LD>(mode.error_estimate);
      const LD hi = static_cast<LD>(mode.omega2) + static_cast<LD>(mode.error_estimate);
      EXPECT_LE(count_below(lo), static_cast<int>(i)) << what << " mode " << i + 1 << ": ω² " << mode.omega2 << " ± "
                                                      << mode.error_estimate;
      EXPECT_GE(count_below(hi), static_cast<int>(i) + 1) << what << " mode " << i + 1 << ": ω² " << mode.omega2
                                                          << " ± " << mode.error_estimate;
    }
  }
}

// Point-mass chains (PointMassChain; docs/design.md, "Point-mass chains"):
// hinges on parallel axes, each body's whole mass a point at the next hinge
// (link() with no inertia), hanging straight. In absolute angles M =
// D_l Ĵᵀ D_m Ĵ D_l, whose inverse is the tridiagonal D_l⁻¹ Ĵ⁻¹ D_m⁻¹ Ĵ⁻ᵀ D_l⁻¹
// (Ĵ⁻¹ unit lower bidiagonal), and K = diag(g l_j Σ_{b≥j} m_b); so Kφ = λMφ
// is the pencil (M⁻¹, K⁻¹) (ψ = Mφ), tridiagonal and diagonal, whose
// eigenvalues tridiagonal_pencil_eigenvalues bisects in __float128 from the
// lengths and masses alone (no matrix modal formed).

// Masses and lengths of `links` links, each log-uniform over [1/spread, spread].
void graded_point_masses(std::mt19937_64& rng, int links, double spread, std::vector<double>& masses,
                         std::vector<double>& lengths) {
  for (int i = 0; i < links; ++i) {
    masses.push_back(log_uniform(rng, 1 / spread, spread));
    lengths.push_back(log_uniform(rng, 1 / spread, spread));
  }
}

// The eigenvalues of the pencil (diag k, D_l Ĵᵀ D_m Ĵ D_l) for given
// masses m, signed lengths l and positive k, as above.
std::vector<LD> chain_pencil_reference(const std::vector<__float128>& masses, const std::vector<__float128>& levers,
                                       const std::vector<__float128>& k) {
  const std::size_t n = masses.size();
  std::vector<__float128> diagonal(n), off(n > 0 ? n - 1 : 0), inverse_k(n);
  for (std::size_t i = 0; i < n; ++i) {
    inverse_k[i] = 1 / k[i];
    const __float128 l = levers[i];
    diagonal[i] = (1 / masses[i] + (i > 0 ? 1 / masses[i - 1] : 0)) / (l * l);
    if (i > 0) off[i - 1] = -1 / (masses[i - 1] * levers[i] * levers[i - 1]);
  }
  return tridiagonal_pencil_eigenvalues(diagonal, off, inverse_k);
}

// The chain of these masses and lengths hanging under g = 9.81: k_j =
// g l_j Σ_{b≥j} m_b, from the lengths and masses alone (no matrix modal
// formed).
std::vector<LD> point_mass_chain_reference(const std::vector<double>& masses, const std::vector<double>& lengths) {
  const std::size_t n = masses.size();
  std::vector<__float128> m(masses.begin(), masses.end()), l(lengths.begin(), lengths.end()), k(n);
  __float128 below = 0;
  for (std::size_t j = n; j-- > 0;) {
    below += m[j];
    k[j] = static_cast<__float128>(9.81) * l[j] * below;
  }
  return chain_pencil_reference(m, l, k);
}

// The pencil modal formed for a point-mass chain's model: K's diagonal as
// assembled and M as the chain's structure stands for it (the lengths it
// found in M), exactly (in __float128, from those doubles).
std::vector<LD> formed_chain_reference(const LinearModel& model) {
  const PointMassChain& c = model.absolute.chain;
  const auto n = static_cast<std::size_t>(c.lever.size());
  std::vector<__float128> m(n), l(n), k(n);
  for (std::size_t j = 0; j < n; ++j) {
    const auto e = static_cast<Eigen::Index>(j);
    m[j] = c.mass(e);
    l[j] = c.lever(e);
    k[j] = model.absolute.K(e, e);
  }
  return chain_pencil_reference(m, l, k);
}

// The structure is found where it holds and nowhere else: every generated
// point-mass chain (2–40 links, masses and lengths log-uniform over 1e-4 …
// 1e4) has it, with a mismatch at rounding level (within the 4(n + 4)ε
// that symmetric.cpp takes as such; measured at most 5.6e-16), also turned
// over at a joint;
// the same chain with rods' inertia, a mass half way along its link (but
// the last), an armature, bent at a joint (but the first, which turns it
// whole), a hinge turned to another axis, or a branch, has not.
TEST(PointMassChains, TheStructureIsFoundWhereItHoldsAndNowhereElse) {
  std::mt19937_64 rng(3011);
  double worst = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const int links = 2 + static_cast<int>(rng() % 39);
    std::vector<double> masses, lengths;
    graded_point_masses(rng, links, 1e4, masses, lengths);
    const SystemDescription chain = point_mass_chain_scene(masses, lengths);
    const std::string what = "trial " + std::to_string(trial) + ", " + std::to_string(links) + " links";
    auto found = [](const SystemDescription& d, const VectorX& q) {
      const System s(d);
      LinearizeOptions any_point;  // a bent chain is not an equilibrium; its M is what counts here
      any_point.tolerance = std::numeric_limits<double>::infinity();
      return !linearize(s, q.size() == 0 ? VectorX(VectorX::Zero(s.size())) : q, any_point).absolute.chain.empty();
    };
    const auto pick = static_cast<std::size_t>(rng() % static_cast<unsigned>(links));
    {
      const System s(chain);
      const LinearModel model = linearize(s, VectorX::Zero(s.size()));
      ASSERT_FALSE(model.absolute.chain.empty()) << what;
      EXPECT_LE(model.absolute.chain.mismatch, 4 * (links + 4) * std::numeric_limits<double>::epsilon()) << what;
      worst = std::max(worst, model.absolute.chain.mismatch);
      // Turned over at a joint: the links from it on stand up (still one
      // line, an equilibrium), their signed lengths negative.
      VectorX q = VectorX::Zero(s.size());
      q(static_cast<Eigen::Index>(pick)) = std::numbers::pi;
      const LinearModel turned = linearize(s, q);
      ASSERT_FALSE(turned.absolute.chain.empty()) << what << ": turned over at joint " << pick;
      for (std::size_t j = 0; j < static_cast<std::size_t>(links); ++j)
        EXPECT_EQ(turned.absolute.chain.lever(static_cast<Eigen::Index>(j)) < 0, pick > 0 && j >= pick)
            << what << ": turned over at joint " << pick << ", link " << j;
    }
    SystemDescription d = chain;
    d.bodies[pick].inertia = (masses[pick] * lengths[pick] * lengths[pick] / 12) * Mat3::Identity();
    EXPECT_FALSE(found(d, {})) << what << ": rod inertia on body " << pick;
    // The last body's mass may lie anywhere on its line (nothing hangs below
    // it); any other's must be at the next hinge.
    d = chain;
    d.bodies[pick].com *= 0.5;
    EXPECT_EQ(found(d, {}), pick + 1 == static_cast<std::size_t>(links))
        << what << ": the mass half way along link " << pick;
    d = chain;
    d.bodies[pick].armature = 1e-3 * masses[pick] * lengths[pick] * lengths[pick];
    EXPECT_FALSE(found(d, {})) << what << ": an armature on body " << pick;
    {
      const System s(chain);
      // Turning the first joint turns the chain whole: still straight.
      VectorX q = VectorX::Zero(s.size());
      q(static_cast<Eigen::Index>(pick)) = 0.3;
      EXPECT_EQ(found(chain, q), pick == 0) << what << ": turned at joint " << pick;
    }
    if (pick > 0) {
      d = chain;
      d.bodies[pick].axis = Vec3::UnitX();
      EXPECT_FALSE(found(d, {})) << what << ": joint " << pick << " about x";
    }
    if (links >= 3) {
      d = chain;
      d.bodies.back().parent = 0;  // a branch from the first body
      d.bodies.back().origin = Vec3(0, 0, -lengths[0]);
      EXPECT_FALSE(found(d, {})) << what << ": a branch";
    }
  }
  std::printf("point-mass chains: worst mismatch %.1e\n", worst);
}

// A point-mass chain's M written out from the kinematics, not from the
// bodies' frames: a body's orientation may be off orthogonal by up to the
// 1e-12 System accepts, and then its world length differs from the one in
// its frame by that much. Every ω² within its estimate (a few ε) of the
// long double reference of the scene's own kinematics (which shares nothing
// with the written-out M), the off-orthogonal body at each place in turn.
TEST(PointMassChains, TheWrittenOutMassMatrixIsTheKinematicsOwn) {
  const std::vector<double> masses{1.0, 2.0, 0.5}, lengths{1.0, 0.7, 1.3};
  for (std::size_t pick = 0; pick < masses.size(); ++pick) {
    SystemDescription d = point_mass_chain_scene(masses, lengths);
    d.bodies[pick].orientation = Vec3(1 + 3e-13, 1, 1 + 3e-13).asDiagonal();
    const System s(d);
    const VectorX q = VectorX::Zero(s.size());
    const LinearModel model = linearize(s, q);
    ASSERT_FALSE(model.absolute.chain.empty()) << "body " << pick;
    const ModalResult r = solve_modes(model);
    const std::vector<LD> reference = reference_omega2(s, q);
    ASSERT_EQ(r.modes.size(), reference.size());
    for (std::size_t k = 0; k < reference.size(); ++k)
      EXPECT_LE(std::abs(static_cast<LD>(r.modes[k].omega2) - reference[k]), r.modes[k].error_estimate)
          << "body " << pick << ", mode " << k + 1 << ": " << r.modes[k].omega2 << " against "
          << static_cast<double>(reference[k]);
  }
}

// Long graded point-mass chains on the default path (LAPACK from 150
// coordinates), every mode and the lowest 12 alone against the __float128
// reference: 150–320 links, masses and lengths log-uniform over 1e-4 … 1e4
// (lengths ascending; masses descending) and over 1e-2 … 1e2 (shuffled),
// and two uniform chains, of unit links and of links of 1/n (length and mass
// not representable: equal terms, whose roundings add up alike in plain
// sums). Every pair comes from the tridiagonal U⁻¹KU⁻ᵀ by MRRR, the lowest
// modes again from the bidiagonal U⁻¹K^½ where their estimates exceed 64ε
// (the ascending lengths: MRRR's quotients erred by up to 4.9e-8 relative
// there, within their estimates, and the accuracy asserted below failed);
// the lowest 12 alone from the bidiagonal. Every ω² within its estimate and its residual
// bound of its reference, and both measured against the true error
// (floored at ε relative, the double result's own rounding: the
// reference's is 1e-30). Issue 15's targets asserted: every estimate at
// most 10 × that error, every bound at most 100 ×. The data as formed
// against the scene's: M's entries within 4ε relative (the rounding the
// analysis takes for them; written out, point_mass_chain_mass), K's
// diagonal within K_error's 4ε Σ|terms| (compensated subtree sums). The
// reference shares nothing with the Sturm counts that certify the bounds:
// it bisects the pencil (M⁻¹, K⁻¹) in __float128, these LDLᵀ = BᵀB in long
// double.
TEST(PointMassChains, LongGradedChainsMatchTheQuadPrecisionReference) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  std::mt19937_64 rng(3017);
  double loosest_estimate = 0, loosest_bound = 0, worst_error = 0, worst_data = 0, worst_M = 0, worst_K = 0,
         worst_K_relative = 0;
  for (int trial = 0; trial < 5; ++trial) {
    const int links = std::uniform_int_distribution<int>(150, 320)(rng);
    std::vector<double> masses, lengths;
    graded_point_masses(rng, links, trial < 2 ? 1e4 : 1e2, masses, lengths);
    if (trial == 3) {  // uniform: unit masses and lengths (issue 15's chain, shorter)
      masses.assign(masses.size(), 1.0);
      lengths.assign(lengths.size(), 1.0);
    }
    if (trial == 4) {  // uniform, links of 1/n: a total length and mass of 1
      masses.assign(masses.size(), 1.0 / links);
      lengths.assign(lengths.size(), 1.0 / links);
    }
    if (trial == 0) std::sort(lengths.begin(), lengths.end());
    if (trial == 1) std::sort(masses.rbegin(), masses.rend());
    const System s(point_mass_chain_scene(masses, lengths));
    const LinearModel model = linearize(s, VectorX::Zero(s.size()));
    {  // the data as formed, against the scene's (M in absolute angles: l_i l_j Σ_{b≥max(i,j)} m_b)
      std::vector<__float128> below(static_cast<std::size_t>(links));
      __float128 sum = 0;
      for (std::size_t j = below.size(); j-- > 0;) below[j] = sum += masses[j];
      for (std::size_t j = 0; j < below.size(); ++j) {
        const auto e = static_cast<Eigen::Index>(j);
        const __float128 k = static_cast<__float128>(9.81) * lengths[j] * below[j];
        const __float128 k_difference = static_cast<__float128>(model.absolute.K(e, e)) - k;
        const double dk = static_cast<double>(k_difference < 0 ? -k_difference : k_difference);
        worst_K = std::max(worst_K, dk / static_cast<double>(k));
        EXPECT_LE(dk, model.absolute.K_magnitude(e, e)) << "trial " << trial << ": K_" << j << j;
        // In relative angles K_jj = g Σ_{b≥j} m_b (l_j + … + l_b): the subtree
        // sums P (the offsets' products carried too), within K_error.
        __float128 relative = 0, reach = 0;
        for (std::size_t b = j; b < below.size(); ++b) relative += static_cast<__float128>(masses[b]) * (reach += lengths[b]);
        relative *= static_cast<__float128>(9.81);
        const __float128 r_difference = static_cast<__float128>(model.K(e, e)) - relative;
        const double dr = static_cast<double>(r_difference < 0 ? -r_difference : r_difference);
        worst_K_relative = std::max(worst_K_relative, dr / static_cast<double>(relative));
        EXPECT_LE(dr, model.K_error(e, e)) << "trial " << trial << ": K_" << j << j << " in relative angles";
        for (std::size_t i = 0; i <= j; ++i) {
          const __float128 exact = static_cast<__float128>(lengths[i]) * lengths[j] * below[j];
          const __float128 m_difference =
              (static_cast<__float128>(model.absolute.M(static_cast<Eigen::Index>(i), e)) - exact) / exact;
          const double dm = static_cast<double>(m_difference < 0 ? -m_difference : m_difference);
          worst_M = std::max(worst_M, dm);
          EXPECT_LE(dm, 4 * eps) << "trial " << trial << ": M_" << i << "," << j;
        }
      }
    }
    const std::vector<LD> reference = point_mass_chain_reference(masses, lengths),
                          formed = formed_chain_reference(model);
    ASSERT_EQ(formed.size(), reference.size());
    for (const int wanted : {-1, 12}) {
      ModalOptions options;
      options.modes = wanted;
      const ModalResult r = solve_modes(model, options);
      const std::string what = "trial " + std::to_string(trial) + ", " + std::to_string(links) + " links" +
                               (wanted > 0 ? ", the lowest " + std::to_string(wanted) : std::string());
      EXPECT_NE(r.solver.find("point-mass chain"), std::string::npos) << what << ": " << r.solver;
      if (wanted > 0) {
        EXPECT_NE(r.solver.find("U⁻¹K^½"), std::string::npos) << what << ": " << r.solver;
      }
      ASSERT_EQ(r.modes.size(), wanted > 0 ? static_cast<std::size_t>(wanted) : reference.size()) << what;
      EXPECT_EQ(r.stability, Stability::stable) << what;
      for (std::size_t k = 0; k < r.modes.size(); ++k) {
        const Mode& m = r.modes[k];
        const double truth = static_cast<double>(reference[k]), as_formed = static_cast<double>(formed[k]);
        const double error = std::abs(m.omega2 - truth), floor = std::max(error, eps * truth);
        // The residual bound is of the pencil as formed (Mode::residual_bound).
        const double solver_error = std::abs(m.omega2 - as_formed);
        EXPECT_LE(error, m.error_estimate) << what << " mode " << k + 1 << ": " << m.omega2 << " against " << truth;
        EXPECT_LE(m.error_estimate, 10 * floor) << what << " mode " << k + 1 << ": " << m.omega2 << " against "
                                                << truth;
        EXPECT_LE(solver_error, m.residual_bound) << what << " mode " << k + 1 << ": " << m.omega2 << " against "
                                                  << as_formed << " (the pencil as formed)";
        loosest_estimate = std::max(loosest_estimate, m.error_estimate / floor);
        loosest_bound = std::max(loosest_bound, m.residual_bound / std::max(solver_error, eps * as_formed));
        worst_error = std::max(worst_error, error / truth);
        worst_data = std::max(worst_data, static_cast<double>(std::abs(formed[k] - reference[k]) / reference[k]));
      }
    }
  }
  std::printf("long point-mass chains: worst relative error %.1e, estimate / error up to %.1e, bound / error of the "
              "pencil as formed up to %.1e; that pencil's eigenvalues within %.1e relative of the exact ones, M's "
              "entries within %.2f ε, K's diagonal within %.2f ε (in relative angles %.2f ε)\n",
              worst_error, loosest_estimate, loosest_bound, worst_data, worst_M / eps, worst_K / eps,
              worst_K_relative / eps);
  // The tridiagonal form's accuracy (measured 1.0e-15): a solve that lost it
  // (the dense path in these angles, or a wrong transformation) stays within
  // the estimates above, but not within this.
  EXPECT_LE(worst_error, 1e-14);
  // The bounds come from the Sturm counts (ChainMass::certify): issue 15's
  // target for a bound, rigorous and within 100 × the true error (floored
  // at ε relative, the size of the double result's own rounding).
  EXPECT_LE(loosest_bound, 100.0);
}

// Short graded point-mass chains forced onto the LAPACK path (2–40 links,
// masses and lengths over 1e-4 … 1e4), some turned over at a joint
// (divergent modes: the Morse index and every kind checked), some with joint springs (K then
// tridiagonal in absolute angles: the products by the chain's structure, the
// pairs by dsygst and divide and conquer). The hanging ones (K diagonal and
// positive: estimates from the Sturm counts and the chain's data) against
// the __float128 reference, which the long double one below is not
// accurate enough to stand for (it is off by up to 5e-12 relative on these
// gradings, modal by 6e-16), with issue 15's target asserted: every
// estimate within 1 … 10 × the true error floored at ε relative. The others against the reference of
// test_graded (AD in long double, solved by Eigen), which shares nothing
// with the chain's structure.
TEST(PointMassChains, ShortGradedChainsMatchTheLongDoubleReference) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  std::mt19937_64 rng(3023);
  Figures f;
  double loosest = 0;
  int tridiagonal = 0, divergent = 0;
  for (int trial = 0; trial < 30; ++trial) {
    const int links = 2 + static_cast<int>(rng() % 39);
    std::vector<double> masses, lengths;
    graded_point_masses(rng, links, 1e4, masses, lengths);
    SystemDescription d = point_mass_chain_scene(masses, lengths);
    const bool springs = trial % 3 == 2;
    if (springs)
      for (std::size_t i = 0; i < d.bodies.size(); ++i) {
        d.bodies[i].stiffness = masses[i] * 9.81 * lengths[i] * log_uniform(rng, 1e-2, 1e2);
        d.bodies[i].rest = VectorX::Zero(1);
      }
    const System s(d);
    // Every third chain without springs turned over at a random joint: the
    // links from it on stand up (negative lengths along the line, negative
    // entries of K): divergent modes.
    VectorX q = VectorX::Zero(s.size());
    const bool turned = !springs && trial % 3 == 1;
    if (turned) q(static_cast<Eigen::Index>(rng() % static_cast<unsigned>(links))) = std::numbers::pi;
    ModalOptions options;
    options.dense_solver = DenseSolver::lapack;
    const ModalResult r = solve_modes(linearize(s, q), options);
    const std::string what = "trial " + std::to_string(trial) + ", " + std::to_string(links) + " links" +
                             (springs ? " with springs" : turned ? " turned over" : "");
    if (!springs) {
      EXPECT_NE(r.solver.find("point-mass chain"), std::string::npos) << what << ": " << r.solver;
      ++tridiagonal;
    }
    const bool hanging = !springs && !turned;
    const std::vector<LD> reference =
        hanging ? point_mass_chain_reference(masses, lengths) : reference_omega2(s, q);
    check_modes(r, reference, what, f, false);
    if (hanging)
      for (std::size_t k = 0; k < r.modes.size() && k < reference.size(); ++k) {
        const Mode& m = r.modes[k];
        const double truth = static_cast<double>(reference[k]), error = std::abs(m.omega2 - truth);
        loosest = std::max(loosest, m.error_estimate / std::max(error, eps * truth));
        EXPECT_LE(error, m.error_estimate) << what << " mode " << k + 1;
        EXPECT_LE(m.error_estimate, 10 * std::max(error, eps * truth)) << what << " mode " << k + 1;
      }
    const auto negative = std::count_if(reference.begin(), reference.end(), [](LD l) { return l < 0; });
    EXPECT_EQ(r.morse_index, negative) << what;
    divergent += negative > 0;
    for (const Mode& m : r.modes)
      EXPECT_EQ(m.kind, m.omega2 < 0 ? ModeKind::divergent : ModeKind::oscillatory) << what << ": ω² " << m.omega2;
  }
  print_figures("short point-mass chains", f);
  std::printf("  hanging ones: estimate / error (floored at ε) up to %.1f\n", loosest);
  EXPECT_GE(tridiagonal, 15);
  EXPECT_GE(divergent, 3);
}

// The eigenvalues of a hanging chain's pencil (diag k, D_l Ĵᵀ D_m Ĵ D_l),
// every k_j > 0, in __float128, for chains whose masses span many decades:
// C = U⁻¹KU⁻ᵀ = BBᵀ with B upper bidiagonal shares its eigenvalues with
// BᵀB = LDLᵀ, d_j = k_j/(l_j² m_j), e_j = L_{j+1,j}²d_j = k_{j+1}/(l_{j+1}² m_j),
// each a product (no cancellation), and the number below τ is that of
// negative pivots of the stationary recurrence p_j = d_j + s_j, s_{j+1} =
// e_j s_j/p_j − τ, which keeps each eigenvalue to a few units of __float128
// relative (Demmel and Kahan 1990; Parlett and Dhillon 2000), however wide
// the spectrum. (chain_pencil_reference forms M⁻¹'s tridiagonal, whose
// pivots cancel 1/m_j against 1/m_j: behind a link of 1e-20 of the tip's
// mass its error in the tip's swing exceeded double's rounding of it.)
// Bisected from the trace down
// to 1e-30 relative: the lowest `lowest` (all by default).
std::vector<LD> bidiagonal_chain_reference(const std::vector<__float128>& m, const std::vector<__float128>& l,
                                           const std::vector<__float128>& k,
                                           std::size_t lowest = std::numeric_limits<std::size_t>::max()) {
  const std::size_t n = m.size();
  std::vector<__float128> d(n), e(n, 0);
  __float128 trace = 0;
  for (std::size_t j = 0; j < n; ++j) {
    d[j] = k[j] / (l[j] * l[j] * m[j]);
    if (j + 1 < n) e[j] = k[j + 1] / (l[j + 1] * l[j + 1] * m[j]);
    trace += d[j] + e[j];
  }
  auto below = [&](__float128 tau) {
    std::size_t count = 0;
    __float128 t = -tau;
    for (std::size_t j = 0; j < n; ++j) {
      __float128 pivot = d[j] + t;
      if (pivot == 0) pivot = static_cast<__float128>(1e-300) * static_cast<__float128>(1e-300);
      if (pivot < 0) ++count;
      t = e[j] * (t / pivot) - tau;
    }
    return count;
  };
  std::vector<LD> values;
  for (std::size_t j = 0; j < std::min(n, lowest); ++j) {
    __float128 lo = 0, hi = 2 * trace;
    for (int step = 0; step < 400 && hi - lo > static_cast<__float128>(1e-30) * hi; ++step) {
      const __float128 mid = (lo + hi) / 2;
      (below(mid) > j ? hi : lo) = mid;
    }
    values.push_back(static_cast<LD>((lo + hi) / 2));
  }
  return values;
}

// Light links with a heavy tip: the links' masses 1e-20 … 1e-8 of the
// tip's, the tip 1e-2 … 1e2 kg, lengths over 1e-2 … 1e2, 2–40 links (all
// below lapack_threshold: the dense factor is tried first). In absolute
// angles M scaled to a unit diagonal is then near a matrix of ones: singular
// to the normwise test of a dense factor (factor_mass), which with Eigen's
// solver (--dense-solver eigen, no chain structure) refuses every one,
// while M = UUᵀ with U⁻¹ bidiagonal is definite by its structure and the
// eigenvalues (the tip's swing near g/L, the links' vibrations up to 1e22 ×
// that) are well defined by the data. Answered: every mode an oscillation,
// each ω² within its estimate of the __float128 reference of the scene
// (lengths and masses alone), the estimate within 10 × the error (floored
// at ε), and within its residual bound of the pencil as formed, which is
// within 10 × the distance to it. Before,
// refused ("has no inertia"), and once the refusal was lifted the links'
// vibrations were called zero modes: their residuals' rounding is 1e20 ×
// the error, and M's share of the data's rounding was taken entrywise.
TEST(PointMassChains, LightChainsWithAHeavyTipAreAnsweredNotCalledSingular) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  std::mt19937_64 rng(3041);
  int refused = 0;
  double loosest = 0, worst_bound = 0;
  for (int trial = 0; trial < 24; ++trial) {
    const int links = 2 + static_cast<int>(rng() % 39);
    const double tip = log_uniform(rng, 1e-2, 1e2);
    std::vector<double> masses, lengths;
    for (int i = 0; i < links; ++i) {
      masses.push_back(i + 1 < links ? tip * log_uniform(rng, 1e-20, 1e-8) : tip);
      lengths.push_back(log_uniform(rng, 1e-2, 1e2));
    }
    const System s(point_mass_chain_scene(masses, lengths));
    const LinearModel model = linearize(s, VectorX::Zero(s.size()));
    const std::string what = "trial " + std::to_string(trial) + ", " + std::to_string(links) + " links";
    {
      ModalOptions general;
      general.dense_solver = DenseSolver::eigen;
      try {
        (void)solve_modes(model, general);
      } catch (const SingularMassMatrix&) {
        ++refused;
      }
    }
    ModalResult r;
    ASSERT_NO_THROW(r = solve_modes(model, ModalOptions{})) << what;
    EXPECT_NE(r.solver.find("point-mass chain"), std::string::npos) << what << ": " << r.solver;
    EXPECT_EQ(r.stability, Stability::stable) << what;
    std::vector<__float128> m_scene(masses.begin(), masses.end()), l_scene(lengths.begin(), lengths.end()),
        k_scene(masses.size()), m_formed(masses.size()), l_formed(masses.size()), k_formed(masses.size());
    __float128 tail = 0;
    for (std::size_t j = masses.size(); j-- > 0;) {
      tail += m_scene[j];
      k_scene[j] = static_cast<__float128>(9.81) * l_scene[j] * tail;
      const auto e = static_cast<Eigen::Index>(j);
      m_formed[j] = model.absolute.chain.mass(e);
      l_formed[j] = model.absolute.chain.lever(e);
      k_formed[j] = model.absolute.K(e, e);
    }
    const std::vector<LD> reference = bidiagonal_chain_reference(m_scene, l_scene, k_scene);
    const std::vector<LD> formed = bidiagonal_chain_reference(m_formed, l_formed, k_formed);
    ASSERT_EQ(r.modes.size(), reference.size()) << what;
    for (std::size_t k = 0; k < r.modes.size(); ++k) {
      const Mode& m = r.modes[k];
      const double truth = static_cast<double>(reference[k]), error = std::abs(m.omega2 - truth);
      EXPECT_EQ(m.kind, ModeKind::oscillatory) << what << " mode " << k + 1 << ": ω² " << m.omega2;
      EXPECT_LE(error, m.error_estimate) << what << " mode " << k + 1;
      EXPECT_LE(m.error_estimate, 10 * std::max(error, eps * truth)) << what << " mode " << k + 1;
      loosest = std::max(loosest, m.error_estimate / std::max(error, eps * truth));
      const double formed_error = std::abs(static_cast<LD>(m.omega2) - formed[k]);
      EXPECT_LE(formed_error, m.residual_bound) << what << " mode " << k + 1;
      EXPECT_LE(m.residual_bound, 10 * std::max(formed_error, eps * truth)) << what << " mode " << k + 1;
      worst_bound = std::max(worst_bound, m.residual_bound / std::max(formed_error, eps * truth));
    }
  }
  std::printf("  light chains, heavy tip: %d of 24 refused by the general path; estimate / error up to %.1f, "
              "bound / error (pencil as formed) up to %.1f\n",
              refused, loosest, worst_bound);
  EXPECT_EQ(refused, 24);
}

// The matrix-free path (solve_tree_modes, the default above 1000 links) on
// point-mass chains: in relative angles cond M grows as n⁴ and its Lanczos
// solve had errors to 4e-12 relative at 2000 links with estimates 21 …
// 1.9e3 × and bounds to 6.9e8 × them. The pencil now carries the chain's
// O(n) data in absolute angles (TreePencil::chain): the singular values of
// the bidiagonal U⁻¹K^½ (dbdsvdx), refined and bracketed by Sturm counts. Generated chains, 2 … 2500
// links: graded over 1e-4 … 1e4 (masses and lengths), uniform, links of
// 1/n, light links (1e-20 … 1e-8) with a heavy tip; the lowest 1 … 20
// modes. Each against the __float128 reference of the scene (masses and
// lengths alone, bidiagonal_chain_reference): every ω² within its estimate,
// the estimate within 10 × the error floored at ε (issue 15's target), the
// bound within the distance to the pencil as formed and at most 100 × it;
// the shapes, in relative angles, M-normalized with a small residual in the
// scene's own pencil (__float128). Where the chain's path does not
// apply (joint springs: K not diagonal; turned over: K_jj < 0) the general
// path answers.
TEST(PointMassChains, TheMatrixFreePathSolvesThemInAbsoluteAngles) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  std::mt19937_64 rng(3049);
  double loosest = 0, tightest = 1e300, loosest_bound = 0, worst_error = 0, worst_shape = 0;
  int modes_checked = 0;
  for (int trial = 0; trial < 16; ++trial) {
    const int links = trial == 0 ? 2000 : trial == 1 ? 2500 : 2 + static_cast<int>(rng() % 300);
    std::vector<double> masses, lengths;
    const int family = trial % 4;
    if (family == 0) {  // uniform: unit links (issue 15's chain), or links of 1/n
      masses.assign(static_cast<std::size_t>(links), trial % 8 == 0 ? 1.0 : 1.0 / links);
      lengths = masses;
    } else if (family == 3) {  // light links, a heavy tip
      const double tip = log_uniform(rng, 1e-2, 1e2);
      for (int i = 0; i < links; ++i) {
        masses.push_back(i + 1 < links ? tip * log_uniform(rng, 1e-20, 1e-8) : tip);
        lengths.push_back(log_uniform(rng, 1e-2, 1e2));
      }
    } else {
      graded_point_masses(rng, links, 1e4, masses, lengths);
      if (family == 2) std::sort(lengths.begin(), lengths.end());
    }
    const int wanted = std::min(links, 1 + static_cast<int>(rng() % 20));
    const System s(point_mass_chain_scene(masses, lengths));
    Workspace w(s);
    const TreePencil p = tree_pencil(s, w, VectorX::Zero(s.size()));
    const std::string what = "trial " + std::to_string(trial) + ", " + std::to_string(links) + " links, " +
                             std::to_string(wanted) + " modes";
    ASSERT_FALSE(p.chain.empty()) << what;
    SparseModalOptions options;
    options.modes = wanted;
    const ModalResult r = solve_tree_modes(p, options);
    EXPECT_NE(r.solver.find("point-mass chain"), std::string::npos) << what << ": " << r.solver;
    EXPECT_EQ(r.stability, Stability::stable) << what;
    ASSERT_EQ(r.modes.size(), static_cast<std::size_t>(wanted)) << what;
    const auto n = static_cast<std::size_t>(links);
    std::vector<__float128> m_scene(masses.begin(), masses.end()), l_scene(lengths.begin(), lengths.end()),
        k_scene(n), m_formed(n), l_formed(n), k_formed(n);
    __float128 tail = 0;
    for (std::size_t j = n; j-- > 0;) {
      tail += m_scene[j];
      k_scene[j] = static_cast<__float128>(9.81) * l_scene[j] * tail;
      const auto e = static_cast<Eigen::Index>(j);
      m_formed[j] = p.chain.mass(e);
      l_formed[j] = p.chain.lever(e);
      k_formed[j] = p.chain_K(e);
    }
    std::vector<LD> reference = bidiagonal_chain_reference(m_scene, l_scene, k_scene, wanted);
    std::vector<LD> formed = bidiagonal_chain_reference(m_formed, l_formed, k_formed, wanted);
    for (std::size_t k = 0; k < r.modes.size(); ++k) {
      const Mode& m = r.modes[k];
      const double truth = static_cast<double>(reference[k]), error = std::abs(m.omega2 - truth);
      const double floor = std::max(error, eps * truth);
      EXPECT_EQ(m.kind, ModeKind::oscillatory) << what << " mode " << k + 1;
      EXPECT_LE(error, m.error_estimate) << what << " mode " << k + 1 << ": " << m.omega2 << " against " << truth;
      EXPECT_LE(m.error_estimate, 10 * floor) << what << " mode " << k + 1 << ": " << m.omega2 << " against " << truth;
      const double formed_error = static_cast<double>(std::abs(static_cast<LD>(m.omega2) - formed[k]));
      EXPECT_LE(formed_error, m.residual_bound) << what << " mode " << k + 1;
      EXPECT_LE(m.residual_bound, 100 * std::max(formed_error, eps * truth)) << what << " mode " << k + 1;
      loosest = std::max(loosest, m.error_estimate / floor);
      tightest = std::min(tightest, m.error_estimate / floor);
      loosest_bound = std::max(loosest_bound, m.residual_bound / std::max(formed_error, eps * truth));
      worst_error = std::max(worst_error, error / truth);
      // The shape, in relative angles, back to absolute ones (θ_j = Σ_{i≤j}
      // q_i) and checked against the scene's pencil in __float128: θᵀMθ = 1,
      // and Kθ − λMθ small against the size of its terms, |K||θ| + λ|M||θ|
      // (M = D_l Ĵᵀ D_m Ĵ D_l: prefix and suffix sums). Measured up to
      // 1.0e-7, on light links with a heavy tip, where a vector's error
      // along a lower mode (ε‖B‖/gap) is magnified by the ratio of the
      // singular values in φ (the dense path's shapes, by another solver,
      // measure up to 7.4e-8 on the same chains); a wrong sign or scale
      // would be O(1). The tree's own products in relative angles
      // lose too many digits on these gradings to tell.
      {
        std::vector<__float128> theta(n), Mtheta(n), Mabs(n);
        __float128 sum = 0;
        for (std::size_t j = 0; j < n; ++j) theta[j] = sum += static_cast<__float128>(m.shape(static_cast<Eigen::Index>(j)).real());
        for (int pass = 0; pass < 2; ++pass) {
          std::vector<__float128>& out = pass == 0 ? Mtheta : Mabs;
          std::vector<__float128> prefix(n);
          __float128 run = 0;
          for (std::size_t j = 0; j < n; ++j) {
            const __float128 term = l_scene[j] * theta[j];
            run += pass == 0 ? term : (term < 0 ? -term : term);
            prefix[j] = m_scene[j] * run;
          }
          run = 0;
          for (std::size_t j = n; j-- > 0;) {
            run += prefix[j];
            out[j] = (pass == 0 ? l_scene[j] : (l_scene[j] < 0 ? -l_scene[j] : l_scene[j])) * run;
          }
        }
        __float128 norm = 0, residual = 0, size = 0;
        const __float128 lambda = static_cast<__float128>(m.omega2);
        for (std::size_t j = 0; j < n; ++j) {
          norm += theta[j] * Mtheta[j];
          const __float128 r = k_scene[j] * theta[j] - lambda * Mtheta[j];
          const __float128 t = k_scene[j] * (theta[j] < 0 ? -theta[j] : theta[j]) + lambda * Mabs[j];
          residual += r * r;
          size += t * t;
        }
        const double shape_error = std::max(std::abs(static_cast<double>(norm) - 1),
                                            std::sqrt(static_cast<double>(residual / size)));
        worst_shape = std::max(worst_shape, shape_error);
        EXPECT_LE(shape_error, 1e-6) << what << " mode " << k + 1;
      }
      ++modes_checked;
    }
  }
  std::printf("  matrix-free path, point-mass chains: %d modes, worst relative error %.1e, estimate / error %.1f … "
              "%.1f, bound / error (pencil as formed) up to %.1f, shapes (relative angles) within %.1e\n",
              modes_checked, worst_error, tightest, loosest, loosest_bound, worst_shape);
  // Where the chain's path does not apply, the general one answers.
  {
    std::vector<double> masses(40, 1.0), lengths(40, 1.0);
    SystemDescription sprung = point_mass_chain_scene(masses, lengths);
    for (Body& b : sprung.bodies) b.stiffness = 5.0;
    SystemDescription over = point_mass_chain_scene(masses, lengths);
    over.gravity = -over.gravity;  // upside down: K_jj < 0 (divergent)
    for (const auto& [d, why] : {std::pair{sprung, "joint springs"}, std::pair{over, "turned over"}}) {
      const System s(d);
      Workspace w(s);
      const TreePencil p = tree_pencil(s, w, VectorX::Zero(s.size()));
      EXPECT_EQ(p.chain.empty(), std::string(why) == "joint springs") << why;
      const ModalResult r = solve_tree_modes(p, SparseModalOptions{});
      EXPECT_EQ(r.solver.find("point-mass chain"), std::string::npos) << why << ": " << r.solver;
      EXPECT_EQ(r.stability, std::string(why) == "joint springs" ? Stability::stable : Stability::divergence) << why;
    }
  }
}

// A chain whose M departs from the point-mass structure by more than the
// rounding of its assembly but within the 1e-11 the structure allows (each
// body a rotational inertia of 1e-12 … 1e-13 × m l²): still solved as a
// chain, whose products then stand for M̃ (l fitted to M's diagonal), not M.
// That departure counts at its worst in the systematic part: every ω² lies
// within its systematic_error and its residual bound (rigorous for the
// pencil as formed) of the long double reference of the scene as it is, up
// to K's own rounding (taken as 1e-14 relative: these chains are graded
// over 1e-2 … 1e2 only); and on some modes the departure is what the error
// is made of (beyond the residual bound and K's rounding: without the
// systematic part the bound would fail there).
TEST(PointMassChains, ADepartureAboveRoundingCountsInTheSystematicPart) {
  std::mt19937_64 rng(3037);
  Figures f;
  int above_rounding = 0, departure_dominant = 0;
  double widest = 0;
  for (int trial = 0; trial < 12; ++trial) {
    const int links = 2 + static_cast<int>(rng() % 19);
    std::vector<double> masses, lengths;
    graded_point_masses(rng, links, 1e2, masses, lengths);
    SystemDescription d = point_mass_chain_scene(masses, lengths);
    for (std::size_t i = 0; i < d.bodies.size(); ++i)
      d.bodies[i].inertia = (log_uniform(rng, 1e-13, 1e-12) * masses[i] * lengths[i] * lengths[i]) * Mat3::Identity();
    const System s(d);
    const VectorX q = VectorX::Zero(s.size());
    ModalOptions options;
    options.dense_solver = DenseSolver::lapack;
    const LinearModel model = linearize(s, q);
    const std::string what = "trial " + std::to_string(trial) + ", " + std::to_string(links) + " links";
    ASSERT_FALSE(model.absolute.chain.empty()) << what;
    above_rounding += model.absolute.chain.mismatch > 4 * (links + 4) * std::numeric_limits<double>::epsilon();
    const ModalResult r = solve_modes(model, options);
    EXPECT_NE(r.solver.find("point-mass chain"), std::string::npos) << what << ": " << r.solver;
    const std::vector<LD> reference = reference_omega2(s, q);
    check_modes(r, reference, what, f, false);
    for (std::size_t k = 0; k < reference.size(); ++k) {
      const Mode& m = r.modes[k];
      const double truth = static_cast<double>(reference[k]), error = std::abs(m.omega2 - truth);
      const double rounding = m.residual_bound + 1e-14 * std::abs(truth);
      EXPECT_LE(error, m.systematic_error + rounding) << what << " mode " << k + 1 << ": " << m.omega2 << " against "
                                                      << truth << ", systematic " << m.systematic_error;
      departure_dominant += error > rounding;
      widest = std::max(widest, m.systematic_error / std::max(error, 1e-16 * std::abs(truth)));
    }
  }
  print_figures("point-mass chains with small inertias", f);
  std::printf("  %d modes whose error exceeds their rounding bound; systematic part / error up to %.1e\n",
              departure_dominant, widest);
  EXPECT_EQ(above_rounding, 12);
  EXPECT_GE(departure_dominant, 1);
}

// Link i (0-based) of a planar chain of rigid links hanging along −z from
// `origin`: a hinge about y, mass m, its centre of mass c·l below the
// hinge, the moment of inertia `inertia` about every axis through it.
Body chain_link(int i, const Vec3& origin, double m, double l, double c, double inertia) {
  Body b;
  b.name = "b" + std::to_string(i + 1);
  b.parent = i - 1;
  b.joint = JointType::hinge;
  b.axis = Vec3::UnitY();
  b.origin = origin;
  b.mass = m;
  b.com = Vec3(0, 0, -c * l);
  b.inertia = inertia * Mat3::Identity();
  return b;
}

// Chains of rigid links (docs/design.md, "Chains of rigid links"): hinges
// about one axis, each link's centre of mass on the line to the next hinge
// at a random fraction c of its length, with a rotational inertia about its
// centre of mass (uniform rods among them: c = ½, I = ml²/12). In absolute
// angles M = UUᵀ + R (U as a point-mass chain's, R diagonal) and K is
// diagonal, so that on LAPACK's path the pairs come from the tridiagonal
// pencil (U⁻¹KU⁻ᵀ, I + U⁻¹RU⁻ᵀ) (dsbgst, dstemr). Generated: 3–60 links;
// masses and lengths graded over 1e±2, or a light chain (masses 1e-8 …
// 1e-4) over a heavy tip with lengths over 1e±3 (the degenerate variant);
// every third chain turned over at a random joint (the links from there on
// stand: divergent modes). Reference: the scene's own pencil in long double
// (reference_omega2), every mode within its estimate of a reference
// eigenvalue of its own, the Morse index and the kinds exact; and the
// lowest 1–5 modes alone (`modes`) within their estimates of the lowest
// reference eigenvalues, with the same stability. Measured: all 36 on the
// path both ways (31 of the 36 subsets analyzing only a prefix; the other
// 5, light chains or turned over, had kinds in doubt up to the last mode);
// worst relative error 2.2e-6 (a light chain's mode, within
// its estimate); estimates up to 8.3e3 × the error floored at 1e-12
// relative (the general path on the same chains: 1.2e4 ×). Residual bounds
// are not compared here (the reference is the scene's, not the pencil as
// formed).
TEST(LinkChains, GradedChainsOfRigidLinksMatchTheLongDoubleReference) {
  std::mt19937_64 rng(4111);
  Figures f;
  int structured = 0, subsets = 0, from_values = 0, divergent = 0, iterated = 0;
  double worst_ratio = 0;  // estimate / max(error, ε|λ|) over the hanging chains' modes
  for (int trial = 0; trial < 36; ++trial) {
    const int links = 3 + static_cast<int>(rng() % 58);
    const bool light = trial % 4 == 3, turned = trial % 3 == 1;
    SystemDescription d;
    d.gravity = Vec3(0, 0, -9.81);
    Vec3 origin = Vec3::Zero();
    for (int i = 0; i < links; ++i) {
      const bool tip = i + 1 == links;
      const double m = light && !tip ? log_uniform(rng, 1e-8, 1e-4) : log_uniform(rng, 1e-2, 1e2);
      const double l = light ? log_uniform(rng, 1e-3, 1e3) : log_uniform(rng, 1e-2, 1e2);
      const bool rod = trial % 5 == 0;
      const double c = rod ? 0.5 : std::uniform_real_distribution<double>(0.05, 1.0)(rng);
      const double inertia = rod ? m * l * l / 12 : m * l * l * log_uniform(rng, 1e-4, 0.2);
      d.bodies.push_back(chain_link(i, origin, m, l, c, inertia));
      origin = Vec3(0, 0, -l);
    }
    const System s(d);
    VectorX q = VectorX::Zero(s.size());
    if (turned) q(static_cast<Eigen::Index>(rng() % static_cast<unsigned>(links))) = std::numbers::pi;
    ModalOptions options;
    options.dense_solver = DenseSolver::lapack;
    const std::string what = "trial " + std::to_string(trial) + ", " + std::to_string(links) + " links" +
                             (light ? ", light over a heavy tip" : "") + (turned ? ", turned over" : "");
    ModalResult r;
    if (!modes_at(s, q, options, what, r)) continue;
    structured += r.solver.find("chain of rigid links") != std::string::npos;
    iterated += r.solver.find("inverse iteration") != std::string::npos;
    const std::vector<LD> reference = reference_omega2(s, q);
    check_modes(r, reference, what, f, false);
    // The lowest few alone (every eigenvalue from the standard form by
    // dsterf, the analyzed modes' vectors by MRRR, the others' kinds by the
    // cheap estimate): the same reference's lowest.
    {
      ModalOptions few = options;
      few.modes = 1 + trial % std::min(5, links - 1);
      const ModalResult lowest = solve_modes(linearize(s, q), few);
      std::vector<LD> sorted = reference;
      std::sort(sorted.begin(), sorted.end());
      sorted.resize(static_cast<std::size_t>(few.modes));
      subsets += lowest.solver.find("chain of rigid links") != std::string::npos;
      // (where the cheap estimate leaves a kind in doubt up to the last
      // mode, every pair is analyzed: a light chain's spectrum over many
      // decades)
      from_values += lowest.solver.find("the lowest modes' vectors") != std::string::npos;
      iterated += lowest.solver.find("inverse iteration") != std::string::npos;
      check_modes(lowest, sorted, what + ", lowest " + std::to_string(few.modes), f, false);
      EXPECT_EQ(lowest.morse_index, r.morse_index) << what;
      EXPECT_EQ(lowest.stability, r.stability) << what;
    }
    const auto negative = std::count_if(reference.begin(), reference.end(), [](LD v) { return v < 0; });
    EXPECT_EQ(r.morse_index, negative) << what;
    divergent += negative > 0;
    for (const Mode& m : r.modes)
      EXPECT_EQ(m.kind, m.omega2 < 0 ? ModeKind::divergent : ModeKind::oscillatory) << what << ": ω² " << m.omega2;
    if (!turned)
      for (std::size_t k = 0; k < r.modes.size() && k < reference.size(); ++k) {
        const double truth = static_cast<double>(reference[k]);
        const double error = std::abs(r.modes[k].omega2 - truth);
        const double ratio = r.modes[k].error_estimate / std::max(error, std::numeric_limits<double>::epsilon() * truth);
        worst_ratio = std::max(worst_ratio, ratio);
      }
  }
  print_figures("chains of rigid links", f);
  std::printf("  %d of 36 on the rigid links' path (%d with the lowest few alone, %d of those analyzing only a "
              "prefix); %d of the 72 solves' vectors by inverse iteration on the pencil; hanging: estimate / "
              "max(error, ε|λ|) up to %.1f\n",
              structured, subsets, from_values, iterated, worst_ratio);
  EXPECT_EQ(structured, 36);
  EXPECT_EQ(subsets, 36);
  EXPECT_GE(from_values, 24);
  EXPECT_GE(divergent, 6);
}

// Longer chains of rigid links (66–90 links), where the rigid links' path
// takes its vectors from the tridiagonal pencil by inverse iteration
// (LinkChainMass::pencil_vectors), or, where a cluster of more than 64
// eigenvalues lies within √ε(‖C‖ + |λ|‖B‖) of each other (a light chain's
// lowest modes under a heavy tip), from dsbgst's transformation and MRRR.
// Generated: identical uniform rods, rods graded over 1e±2, and light chains
// (masses 1e-8 … 1e-4, lengths 1e±3) over a heavy tip; every other chain
// turned over at a random joint; and identical rods but for one link a
// thousand millionth as long (g/l ≈ 1e10 dominates ‖C‖, so the others' ω²,
// a few hundred apart at most, are one cluster at √ε‖C‖ ≈ 150: the route
// through the transformation). Reference: the scene's pencil in long
// double (reference_omega2); every mode within its estimate of a reference
// eigenvalue of its own, the Morse index exact, every pair and the lowest
// three alone. The random families' light chains do not reach a cluster of
// 65 (measured: their vectors all came by inverse iteration), so the last
// family is the one that takes the other route.
TEST(LinkChains, LongChainsOfRigidLinksByEitherRouteMatchTheLongDoubleReference) {
  std::mt19937_64 rng(90210);
  Figures f;
  int iterated = 0, rotated = 0;
  for (int trial = 0; trial < 8; ++trial) {
    const int links = 66 + static_cast<int>(rng() % 25);
    const int family = trial / 2;  // 0 identical rods, 1 graded rods, 2 light over a heavy tip, 3 one short link
    const int short_link = static_cast<int>(rng() % static_cast<unsigned>(links));
    const bool turned = trial % 2 == 1;
    SystemDescription d;
    d.gravity = Vec3(0, 0, -9.81);
    Vec3 origin = Vec3::Zero();
    for (int i = 0; i < links; ++i) {
      const bool tip = i + 1 == links;
      const double m = family == 0 || family == 3 ? 1.0
                       : family == 1 || tip       ? log_uniform(rng, 1e-2, 1e2)
                                                  : log_uniform(rng, 1e-8, 1e-4);
      const double l = family == 0   ? 1.0
                       : family == 1 ? log_uniform(rng, 1e-2, 1e2)
                       : family == 2 ? log_uniform(rng, 1e-3, 1e3)
                                     : (i == short_link ? 1e-9 : 1.0);
      d.bodies.push_back(chain_link(i, origin, m, l, 0.5, m * l * l / 12));
      origin = Vec3(0, 0, -l);
    }
    const System s(d);
    VectorX q = VectorX::Zero(s.size());
    if (turned) q(static_cast<Eigen::Index>(rng() % static_cast<unsigned>(links))) = std::numbers::pi;
    const std::string what = "trial " + std::to_string(trial) + ", " + std::to_string(links) + " links" +
                             (family == 0   ? ", identical rods"
                              : family == 1 ? ", graded rods"
                              : family == 2 ? ", light over a heavy tip"
                                            : ", one link 1e-9 long") +
                             (turned ? ", turned over" : "");
    const std::vector<LD> reference = reference_omega2(s, q);
    std::vector<LD> sorted = reference;
    std::sort(sorted.begin(), sorted.end());
    const auto negative = std::count_if(reference.begin(), reference.end(), [](LD v) { return v < 0; });
    for (const int wanted : {-1, 3}) {
      ModalOptions options;
      options.dense_solver = DenseSolver::lapack;
      options.modes = wanted;
      ModalResult r;
      if (!modes_at(s, q, options, what, r)) continue;
      EXPECT_NE(r.solver.find("chain of rigid links"), std::string::npos) << what << ": " << r.solver;
      iterated += r.solver.find("inverse iteration") != std::string::npos;
      rotated += r.solver.find("dsbgst's transformation") != std::string::npos;
      std::vector<LD> expected = sorted;
      if (wanted > 0) expected.resize(static_cast<std::size_t>(wanted));
      check_modes(r, wanted > 0 ? expected : reference, what + (wanted > 0 ? ", lowest 3" : ""), f, false);
      EXPECT_EQ(r.morse_index, negative) << what;
    }
  }
  print_figures("longer chains of rigid links", f);
  std::printf("  %d of 16 solves' vectors by inverse iteration, %d by dsbgst's transformation\n", iterated, rotated);
  EXPECT_EQ(iterated + rotated, 16);
  EXPECT_GE(iterated, 12);
  EXPECT_GE(rotated, 2);
}

}  // namespace

// Long planar chains of rigid links, graded, above large_system_coordinates
// (where the automatic choice is the matrix-free path), written as a scene
// file and analyzed as a user would (model_from_text, analyze, defaults but
// --modes 3). Link j: length L_j, mass m_j, centre of mass at f_j L_j below
// its hinge, rotational inertia u_j m_j L_j² about it; lengths and masses
// log-uniform over `length_decades` and `mass_decades`. The matrix-free
// path factors M through the tree in the relative joint angles, where such
// a chain's M loses its definiteness in rounding (a pivot ≤ 0 though M is
// positive definite); the automatic choice then solves on the dense path
// (absolute angles, equilibrated), and --solver tree still refuses, in
// words that say M may be definite but too ill-conditioned there.
// Reference: the same chain in the lateral displacements y_1 … y_n of its
// hinges (y_0 = 0 at the pivot), where M and K are tridiagonal (link j
// couples y_j and y_{j+1} only: θ_j = (y_{j+1} − y_j)/L_j, its centre of mass
// at (1 − f_j) y_j + f_j y_{j+1}; hanging, ∇∇V in θ is diag(g(m_j f_j L_j +
// L_j Σ_{b>j} m_b))), bisected by Sturm counts in __float128 from the very
// doubles of the file: another basis, another algorithm, another precision.
// Each of the three lowest ω² must lie within its error estimate of it.
TEST(Graded, LongGradedChainsOfRigidLinksAreAnsweredByTheDefaultPath) {
  std::mt19937_64 rng(20261202);
  int by_dense = 0;
  double worst = 0;
  const struct {
    double length_decades, mass_decades;
  } families[] = {{3, 6}, {4, 4}, {2, 8}};
  for (const auto& family : families) {
    const int n = std::uniform_int_distribution<int>(1001, 1040)(rng);
    std::vector<double> L(n), m(n), f(n), u(n);
    std::ostringstream toml;
    toml.precision(17);
    toml << "gravity = [0, 0, -9.81]\n";
    for (int j = 0; j < n; ++j) {
      L[j] = std::pow(10.0, std::uniform_real_distribution<double>(-0.5, 0.5)(rng) * family.length_decades);
      m[j] = std::pow(10.0, std::uniform_real_distribution<double>(-0.5, 0.5)(rng) * family.mass_decades);
      f[j] = std::uniform_real_distribution<double>(0.1, 0.9)(rng);
      u[j] = std::uniform_real_distribution<double>(0.01, 0.2)(rng);
      // The numbers as the file gives them (17 digits: the same doubles).
      const double c = f[j] * L[j], J = u[j] * m[j] * L[j] * L[j];
      toml << "[[body]]\nname = \"l" << j << "\"\n";
      if (j > 0) toml << "parent = \"l" << j - 1 << "\"\norigin = [0, 0, " << -L[j - 1] << "]\n";
      toml << "joint = \"hinge\"\naxis = [0, 1, 0]\nmass = " << m[j] << "\ncom = [0, 0, " << -c
           << "]\ninertia = [" << J << ", " << J << ", " << J * 1e-3 << ", 0, 0, 0]\n";
      f[j] = c / L[j];  // the centre of mass as given (c), J as given
      u[j] = J;
    }
    using Q = __float128;
    std::vector<Q> k_diag(n, 0), k_off(n - 1, 0), m_diag(n, 0), m_off(n - 1, 0);
    Q beyond = 0;  // Σ_{b>j} m_b
    for (int j = n - 1; j >= 0; --j) {
      const Q Lj = L[j], mj = m[j], c = static_cast<Q>(f[j]) * Lj, J = u[j], F = c / Lj;
      const Q k = static_cast<Q>(9.81) * (mj * c + Lj * beyond), s = k / (Lj * Lj), r = J / (Lj * Lj);
      beyond += mj;
      // y_j is unknown j − 1 (y_0 = 0 is the pivot), y_{j+1} unknown j.
      m_diag[j] += mj * F * F + r;
      k_diag[j] += s;
      if (j > 0) {
        m_diag[j - 1] += mj * (1 - F) * (1 - F) + r;
        m_off[j - 1] += mj * F * (1 - F) - r;
        k_diag[j - 1] += s;
        k_off[j - 1] -= s;
      }
    }
    const std::vector<LD> reference = tridiagonal_pencil_eigenvalues(k_diag, k_off, m_diag, 3, m_off);
    const modal::Model model = modal::model_from_text(toml.str(), "rods.toml");
    modal::AnalysisOptions options;
    options.modes = 3;
    const modal::Analysis a = modal::analyze(model, options);
    const ModalResult& r = a.report.equilibria.at(0).result;
    ASSERT_GE(r.modes.size(), 3u);
    bool dense = false;
    for (const std::string& note : r.notes) dense = dense || note.rfind("solved on the dense path", 0) == 0;
    by_dense += dense ? 1 : 0;
    for (int i = 0; i < 3; ++i) {
      const Mode& mode = r.modes[static_cast<std::size_t>(i)];
      const double error = std::abs(static_cast<double>(static_cast<LD>(mode.omega2) - reference[i]));
      EXPECT_LE(error, mode.error_estimate) << "n = " << n << ", mode " << i + 1 << ": " << mode.omega2 << " against "
                                            << static_cast<double>(reference[i]);
      worst = std::max(worst, error / static_cast<double>(reference[i]));
    }
    if (dense) {
      options.solver = SolverChoice::tree;
      EXPECT_THROW(modal::analyze(model, options), SingularMassMatrix) << "n = " << n;
    }
  }
  std::printf("long graded chains of rigid links: %d of 3 solved on the dense path; worst relative error %.2g\n",
              by_dense, worst);
  EXPECT_GE(by_dense, 1);  // the case this test is for: the matrix-free path refused
}
