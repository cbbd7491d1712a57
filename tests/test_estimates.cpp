// tests/test_estimates.cpp — are solve_sparse_modes' error estimates true in
// both directions (issue 15, part 3)? A generated family, not a case: spring
// chains fixed at both ends with random sizes (300 … 1500 masses, so that the
// Lanczos path runs), masses and stiffnesses log-uniform over up to 10⁴,
// and a loose-equilibrium variant where K is off by a random symmetric ΔK
// (SparseModalOptions::K_equilibrium_shift) of relative size 1e-7 … 1e-3.
//
// Reference: the pencil (K, M), M diagonal, as the symmetric tridiagonal
// M^(-1/2) K M^(-1/2) in long double, its lowest eigenvalues by bisection on
// Sturm counts to long double's rounding — never modal's double path.
//
// Asserted, per mode: estimate ≥ true error (an estimate below it is a false
// statement); residual_bound ≥ true error of the matrices as given (the
// rounding family); estimate ≤ 10× max(true error, 16ε|λ|) on the loose
// family (the floor: the estimate also carries K's rounding, which the
// 1e-7 shifts dwarf but a lucky mode's error can undercut), and ≤ 1e4× that
// on the rounding family, where the true error is at rounding level and the
// estimate takes the rounding of the Rayleigh quotient and of K's entries at
// their typical size (measured worst 2.2e3, printed; with the worst-case
// componentwise sums it was 1.0e5).
#include "modal/modes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace {

using LD = long double;
using modal::SparseMatrix;
using modal::VectorX;

struct Chain {
  std::vector<double> mass, spring;  // n masses, n + 1 springs (both ends fixed)
  std::vector<double> shift;         // ΔK as a change of the springs (empty: none)
};

double log_uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::exp(std::uniform_real_distribution<double>(std::log(lo), std::log(hi))(rng));
}

// K of springs s (n + 1 of them) on n masses, both triangles.
SparseMatrix stiffness(const std::vector<double>& s) {
  const auto n = static_cast<Eigen::Index>(s.size() - 1);
  std::vector<Eigen::Triplet<double>> t;
  for (Eigen::Index i = 0; i < n; ++i) {
    t.emplace_back(i, i, s[static_cast<std::size_t>(i)] + s[static_cast<std::size_t>(i) + 1]);
    if (i + 1 < n) {
      t.emplace_back(i, i + 1, -s[static_cast<std::size_t>(i) + 1]);
      t.emplace_back(i + 1, i, -s[static_cast<std::size_t>(i) + 1]);
    }
  }
  SparseMatrix K(n, n);
  K.setFromTriplets(t.begin(), t.end());
  return K;
}

// The k lowest eigenvalues of K φ = λ M φ for springs s (+ ds) and diagonal
// masses m, in long double: the tridiagonal C = M^(-1/2) K M^(-1/2) by
// bisection on Sturm counts (the number of negative pivots of C − x I).
std::vector<LD> reference(const std::vector<double>& m, const std::vector<double>& s, const std::vector<double>& ds,
                          int k) {
  const std::size_t n = m.size();
  std::vector<LD> spring(n + 1), diagonal(n), off(n);
  for (std::size_t i = 0; i <= n; ++i) spring[i] = static_cast<LD>(s[i]) + (ds.empty() ? 0 : static_cast<LD>(ds[i]));
  for (std::size_t i = 0; i < n; ++i) {
    diagonal[i] = (spring[i] + spring[i + 1]) / static_cast<LD>(m[i]);
    if (i + 1 < n) off[i] = -spring[i + 1] / std::sqrt(static_cast<LD>(m[i]) * static_cast<LD>(m[i + 1]));
  }
  auto below = [&](LD x) {
    int count = 0;
    LD d = 1;
    for (std::size_t i = 0; i < n; ++i) {
      d = diagonal[i] - x - (i > 0 ? off[i - 1] * off[i - 1] / d : 0);
      if (d == 0) d = -1e-4000L;
      if (d < 0) ++count;
    }
    return count;
  };
  LD top = 0;
  for (std::size_t i = 0; i < n; ++i) top = std::max(top, diagonal[i] + 2 * std::abs(off[i]) + 2 * std::abs(i > 0 ? off[i - 1] : 0));
  std::vector<LD> out;
  for (int j = 0; j < k; ++j) {
    LD lo = 0, hi = top;
    for (int it = 0; it < 400 && hi - lo > 4 * std::numeric_limits<LD>::epsilon() * hi; ++it) {
      const LD mid = (lo + hi) / 2;
      (below(mid) > j ? hi : lo) = mid;
    }
    out.push_back((lo + hi) / 2);
  }
  return out;
}

Chain generate(std::mt19937_64& rng, int trial, bool loose) {
  const int n = std::uniform_int_distribution<int>(300, 1500)(rng);
  const double grading = trial % 2 == 0 ? 1e2 : 1e4;
  Chain c;
  for (int i = 0; i < n; ++i) c.mass.push_back(log_uniform(rng, 1, grading));
  for (int i = 0; i <= n; ++i) c.spring.push_back(log_uniform(rng, 1, grading));
  if (loose) {
    const double size = log_uniform(rng, 1e-7, 1e-3);
    for (int i = 0; i <= n; ++i)
      c.shift.push_back(size * c.spring[static_cast<std::size_t>(i)] *
                        std::uniform_real_distribution<double>(-1, 1)(rng));
  }
  return c;
}

struct Worst {
  double looseness = 0, bound_looseness = 0;
  int modes = 0;
};

void check(const Chain& c, int trial, double factor, Worst& w) {
  const int k = 6;
  const auto n = static_cast<Eigen::Index>(c.mass.size());
  const SparseMatrix K = stiffness(c.spring);
  SparseMatrix M(n, n);
  for (Eigen::Index i = 0; i < n; ++i) M.insert(i, i) = c.mass[static_cast<std::size_t>(i)];
  modal::SparseModalOptions options;
  options.modes = k;
  if (!c.shift.empty()) options.K_equilibrium_shift = stiffness(c.shift);
  const modal::ModalResult r = modal::solve_sparse_modes(K, M, options);
  const std::vector<LD> exact = reference(c.mass, c.spring, c.shift, k);
  ASSERT_EQ(r.modes.size(), static_cast<std::size_t>(k)) << "trial " << trial;
  for (int j = 0; j < k; ++j) {
    const modal::Mode& mode = r.modes[static_cast<std::size_t>(j)];
    const double truth = static_cast<double>(std::abs(static_cast<LD>(mode.omega2) - exact[static_cast<std::size_t>(j)]));
    const double floor = std::max(truth, 16 * std::numeric_limits<double>::epsilon() * std::abs(mode.omega2));
    EXPECT_GE(mode.error_estimate, truth) << "trial " << trial << " (n " << n << ") mode " << j + 1;
    EXPECT_LE(mode.error_estimate, factor * floor) << "trial " << trial << " (n " << n << ") mode " << j + 1
                                                   << ": true error " << truth;
    if (c.shift.empty()) {
      EXPECT_GE(mode.residual_bound, truth) << "trial " << trial << " mode " << j + 1;
      w.bound_looseness = std::max(w.bound_looseness, mode.residual_bound / floor);
    }
    w.looseness = std::max(w.looseness, mode.error_estimate / floor);
    ++w.modes;
  }
}

TEST(Estimates, GradedSpringChainsAreCoveredAndNotFarAbove) {
  std::mt19937_64 rng(153);
  Worst w;
  for (int trial = 0; trial < 12; ++trial) check(generate(rng, trial, false), trial, 1e4, w);
  std::printf("rounding family: %d modes, worst estimate / max(true, 16ε|λ|) %.3g, worst bound / that %.3g\n",
              w.modes, w.looseness, w.bound_looseness);
}

TEST(Estimates, LooseEquilibriumShiftIsCoveredWithinTenTimes) {
  std::mt19937_64 rng(1531);
  Worst w;
  for (int trial = 0; trial < 12; ++trial) check(generate(rng, trial, true), trial, 10, w);
  std::printf("loose family: %d modes, worst estimate / max(true, 16ε|λ|) %.3g\n", w.modes, w.looseness);
}

}  // namespace
