// Ziegler's destabilization paradox, checked against a closed form derived
// independently of the code (Routh–Hurwitz on the characteristic polynomial).
//
// models/ziegler_damped.toml is R6 with equal dampers c at both hinges. In
// absolute angles, with m = l = k = 1 (time in units of sqrt(m l²/k), damping
// c̃ = c / sqrt(k m l²), load p = P l / k):
//   M = [[3,1],[1,1]], D = c̃ [[2,−1],[−1,1]], K(p) = [[2 − p, p − 1], [−1, 1]],
//   det(s²M + sD + K) = 2s⁴ + 7c̃ s³ + (7 − 2p + c̃²) s² + 2c̃ s + 1.
// (At c̃ = 0 this is 2λ² + (2p − 7)λ + 1 = 0 with s² = −λ: R6.) All
// coefficients are positive for p < 7/2, and the quartic is Hurwitz iff
// a₃a₂a₁ − a₄a₁² − a₀a₃² > 0, i.e. 14c̃²(7 − 2p + c̃²) − 8c̃² − 49c̃² > 0:
//   p_cr(c̃) = 41/28 + c̃²/2,
// where a pair of roots crosses the imaginary axis at s = ±iω, ω² = a₁/a₃ = 2/7.
// As c̃ → 0, p_cr → 41/28 ≈ 1.4643 (Ziegler 1952), well below the undamped
// flutter load 7/2 − √2 ≈ 2.0858: vanishing damping does not recover the
// undamped critical load.
#include "modal/sweep.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

namespace {

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

const std::string kFile = std::string(MODAL_SOURCE_DIR) + "/models/ziegler_damped.toml";
const std::string kColumn = std::string(MODAL_SOURCE_DIR) + "/models/euler_column.toml";

// The critical value is refined to 1e-10 relative (the requirement);
// the closed form is exact, so the test allows 2e-10 relative.
TEST(Paradox, DampedCriticalLoadMatchesRouthHurwitz) {
  const std::string text = read(kFile);
  for (const double c : {0.2, 0.05, 0.01, 0.001}) {
    const modal::SweepResult r =
        modal::sweep(text, kFile, {{"c", std::to_string(c)}}, modal::parse_vary("P=0:3:31"));
    ASSERT_FALSE(r.critical.empty()) << "c = " << c;
    const modal::CriticalValue& cv = r.critical.front();
    const double expected = 41.0 / 28.0 + c * c / 2;
    EXPECT_EQ(cv.kind, modal::CriticalKind::flutter) << "c = " << c;
    EXPECT_EQ(cv.before, modal::Stability::asymptotically_stable) << "c = " << c;
    EXPECT_EQ(cv.after, modal::Stability::flutter) << "c = " << c;
    EXPECT_NEAR(cv.value, expected, 2e-10 * expected) << "c = " << c;
    EXPECT_LE(std::abs(cv.value - expected), cv.error + 1e-14) << "the reported bracket must contain it";
    EXPECT_NEAR(cv.omega, std::sqrt(2.0 / 7.0), 1e-6) << "c = " << c;  // ω at a bracket end: O(√tol) off
  }
}

TEST(Paradox, VanishingDampingDoesNotRecoverTheUndampedLoad) {
  const std::string text = read(kFile);
  const double undamped = 3.5 - std::sqrt(2.0);
  const modal::SweepResult r = modal::sweep(text, kFile, {{"c", "0"}}, modal::parse_vary("P=0:3:31"));
  ASSERT_FALSE(r.critical.empty());
  EXPECT_NEAR(r.critical.front().value, undamped, 2e-10 * undamped);
  const modal::SweepResult small = modal::sweep(text, kFile, {{"c", "1e-4"}}, modal::parse_vary("P=0:3:31"));
  ASSERT_FALSE(small.critical.empty());
  EXPECT_NEAR(small.critical.front().value, 41.0 / 28.0, 1e-8);  // c̃²/2 = 5e-9
  EXPECT_LT(small.critical.front().value, undamped - 0.6);
}

// The dead-loaded column of N links with springs k = EI/a (a = L/N) buckles at
// P_N = (4k/a) sin²(π/(4N+2)) (the discrete model's closed form; N = 2 is R5's
// two-link column), and P_N → π²EI/(4L²) (R5, Euler) with error O(1/N):
// P_N = (4EI/a²)(π/(4N+2))²(1 − O(1/N²)) = π²EI/(4L²)·(1 + 1/(2N))⁻²(1 − …).
// The sweep must find each P_N to 1e-10 (its reported error must cover the
// difference) and the errors must halve per doubling of N (here EI = L = 1).
TEST(Paradox, DeadLoadedColumnConvergesToEulersLoad) {
  const std::string text = read(kColumn);
  const double euler = std::acos(-1.0) * std::acos(-1.0) / 4;
  double previous_error = 0;
  for (const int N : {10, 20, 40, 80}) {
    const modal::SweepResult r =
        modal::sweep(text, kColumn, {{"N", std::to_string(N)}}, modal::parse_vary("P=1.5:2.5:5"));
    ASSERT_EQ(r.critical.size(), 1u) << "N = " << N;
    const modal::CriticalValue& cv = r.critical.front();
    EXPECT_EQ(cv.kind, modal::CriticalKind::divergence);
    const double a = 1.0 / N, k = 1.0 / a;
    const double s = std::sin(std::acos(-1.0) / (4 * N + 2));
    const double closed = 4 * k / a * s * s;
    // The reported error always covers the closed form. Where the tool claims
    // 1e-10 (N ≤ 20 here) the value must be that good; for longer columns the
    // graded mass matrix leaves the smallest eigenvalue zero within its error
    // estimate over a wider band, and the tool widens its error accordingly.
    EXPECT_LE(std::abs(cv.value - closed), cv.error + 1e-15 * closed) << "N = " << N;
    if (N <= 20) {
      EXPECT_NEAR(cv.value, closed, 2e-10 * closed) << "N = " << N;
    }
    EXPECT_LE(cv.error, 1e-6 * closed) << "N = " << N;
    const double error = euler - cv.value;
    EXPECT_GT(error, 0.0);
    if (previous_error > 0) {
      EXPECT_GT(previous_error / error, 1.8) << "N = " << N;
      EXPECT_LT(previous_error / error, 2.2) << "N = " << N;
    }
    previous_error = error;
  }
}

}  // namespace
