// tests/test_modes.cpp — solve_modes() against closed-form references.
//
// Every expected value is derived by hand or taken from docs/design.md, section 2 (reference cases R1–R8)
// (section cited at each test), never from the solver's own output. The linear
// models are built directly from matrices, so these tests exercise the modal
// stage alone.
//
// Tolerances. The problems are small (n ≤ 3, or a chain with n = 50) and well
// conditioned, so the eigenvalues come out within a few ε·n of the truth
// (ε ≈ 2.2e-16). Frequencies are checked to 1e-12 relative: three orders of
// magnitude above what is expected, far below any modelling error worth
// catching. Orthonormality and residuals are checked to 1e-13 (a few hundred ε
// for sums of n terms). Where a reference is itself computed, it is computed
// in long double from the closed form.
#include "modal/modes.hpp"
#include "modal/scene.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

namespace {

using modal::LinearModel;
using modal::MatrixX;
using modal::ModalResult;
using modal::Mode;
using modal::ModeKind;
using modal::Stability;
using modal::VectorX;
using Complex = std::complex<double>;
using Long = long double;

constexpr double frequency_tolerance = 1e-12;   // relative, see the header comment
constexpr double orthonormal_tolerance = 1e-13;

LinearModel make_model(const MatrixX& M, const MatrixX& K, std::vector<std::string> names = {}) {
  LinearModel model;
  const auto n = M.rows();
  model.q = VectorX::Zero(n);
  model.coordinates = std::move(names);
  model.M = M;
  model.K = K;
  model.D = MatrixX::Zero(n, n);
  model.G = MatrixX::Zero(n, n);
  return model;
}

MatrixX mat2(double a, double b, double c, double d) {
  MatrixX A(2, 2);
  A << a, b, c, d;
  return A;
}

// Φ (n×m, real parts) of the modes.
MatrixX shapes(const ModalResult& r) {
  MatrixX Phi(r.modes.front().shape.size(), static_cast<Eigen::Index>(r.modes.size()));
  for (std::size_t j = 0; j < r.modes.size(); ++j) Phi.col(static_cast<Eigen::Index>(j)) = r.modes[j].shape.real();
  return Phi;
}

// ΦᵀMΦ = I and ‖KΦ − MΦΛ‖_F small relative to ‖K‖ + |λ|max ‖M‖; the shapes are real.
void expect_m_orthonormal_eigenpairs(const LinearModel& model, const ModalResult& r) {
  const MatrixX Phi = shapes(r);
  VectorX lambda(Phi.cols());
  double largest = 0;
  for (Eigen::Index j = 0; j < Phi.cols(); ++j) {
    lambda(j) = r.modes[static_cast<std::size_t>(j)].omega2;
    largest = std::max(largest, std::abs(lambda(j)));
    EXPECT_EQ(r.modes[static_cast<std::size_t>(j)].shape.imag().norm(), 0.0);
  }
  const MatrixX gram = Phi.transpose() * model.M * Phi;
  EXPECT_LE((gram - MatrixX::Identity(Phi.cols(), Phi.cols())).norm(), orthonormal_tolerance) << gram;
  const double residual = (model.K * Phi - model.M * Phi * lambda.asDiagonal()).norm();
  EXPECT_LE(residual, orthonormal_tolerance * (model.K.norm() + largest * model.M.norm()));
}

// Largest-|component| entry of every symmetric mode is positive.
void expect_sign_convention(const ModalResult& r) {
  for (const Mode& m : r.modes) {
    Eigen::Index top = 0;
    m.shape.real().cwiseAbs().maxCoeff(&top);
    EXPECT_GT(m.shape.real()(top), 0.0);
  }
}

// R1 in absolute angles about the hanging equilibrium (docs/design.md R1).
struct DoublePendulum {
  double m1, m2, l1, l2, g;
  MatrixX M() const { return mat2((m1 + m2) * l1 * l1, m2 * l1 * l2, m2 * l1 * l2, m2 * l2 * l2); }
  MatrixX K() const { return mat2((m1 + m2) * g * l1, 0, 0, m2 * g * l2); }
  // Kibble & Berkshire eq. 11.21: ω²∓ = g/(2 m1 l1 l2)·[(m1+m2)(l1+l2) ∓ √((m1+m2)((m1+m2)(l1+l2)² − 4 m1 l1 l2))].
  Long omega2(int sign) const {
    const Long M12 = Long(m1) + m2, L12 = Long(l1) + l2;
    const Long root = std::sqrt(M12 * (M12 * L12 * L12 - 4 * Long(m1) * l1 * l2));
    return Long(g) / (2 * Long(m1) * l1 * l2) * (M12 * L12 + sign * root);
  }
};

// ---------------------------------------------------------------------------
// R1: all four rows of the table, g = 1.
TEST(SymmetricModes, DoublePendulumMatchesKibbleBerkshire) {
  struct Row { DoublePendulum p; double omega1, omega2; Long exact1, exact2; };
  const Long r2 = std::sqrt(Long(2)), r3 = std::sqrt(Long(3)), r5 = std::sqrt(Long(5)), r6 = std::sqrt(Long(6));
  const std::vector<Row> rows = {
      {{1, 1, 1, 1, 1}, 0.7653668647, 1.8477590650, std::sqrt(2 - r2), std::sqrt(2 + r2)},
      {{2, 1, 1, 1, 1}, 0.7962252170, 1.5381890013, std::sqrt((3 - r3) / 2), std::sqrt((3 + r3) / 2)},
      {{1, 2, 1, 1, 1}, 0.7419637843, 2.3344142183, std::sqrt(3 - r6), std::sqrt(3 + r6)},
      {{1, 1, 1, 2, 1}, 0.6180339887, 1.6180339887, (r5 - 1) / 2, (r5 + 1) / 2},
  };
  for (const Row& row : rows) {
    SCOPED_TRACE("m1=" + std::to_string(row.p.m1) + " m2=" + std::to_string(row.p.m2) +
                 " l2=" + std::to_string(row.p.l2));
    // The general formula and the simplified exact forms agree (guards the transcription).
    EXPECT_NEAR(double(std::sqrt(row.p.omega2(-1))), double(row.exact1), 1e-15);
    EXPECT_NEAR(double(std::sqrt(row.p.omega2(+1))), double(row.exact2), 1e-15);

    const LinearModel model = make_model(row.p.M(), row.p.K(), {"upper", "lower"});
    const ModalResult r = modal::solve_modes(model);
    ASSERT_EQ(r.modes.size(), 2u);
    EXPECT_EQ(r.stability, Stability::stable);
    EXPECT_EQ(r.morse_index, 0);
    EXPECT_EQ(r.zero_modes, 0);
    const Long exact[2] = {row.exact1, row.exact2};
    const double table[2] = {row.omega1, row.omega2};
    for (int j = 0; j < 2; ++j) {
      const Mode& m = r.modes[static_cast<std::size_t>(j)];
      EXPECT_EQ(m.kind, ModeKind::oscillatory);
      EXPECT_NEAR(m.omega, double(exact[j]), frequency_tolerance * double(exact[j]));
      EXPECT_NEAR(m.omega, table[j], 6e-11);  // the table has 10 decimals
      EXPECT_DOUBLE_EQ(m.omega2, m.omega * m.omega);
      EXPECT_EQ(m.s, Complex(0, m.omega));
      EXPECT_EQ(m.growth_rate, 0.0);
      EXPECT_EQ(m.damping_ratio, 0.0);
      EXPECT_DOUBLE_EQ(m.frequency_hz, m.omega / (2 * std::numbers::pi));
      EXPECT_DOUBLE_EQ(m.period, 2 * std::numbers::pi / m.omega);
      // The error estimate bounds the actual error of λ.
      EXPECT_LE(std::abs(Long(m.omega2) - exact[j] * exact[j]), Long(m.error_estimate));
      EXPECT_LT(m.error_estimate, 2e-13);  // and is not vacuous (λ of order 1 to 10: below 200 ε|λ|)
    }
    expect_m_orthonormal_eigenpairs(model, r);
    expect_sign_convention(r);
    EXPECT_NE(r.solver.find("symmetric"), std::string::npos);
  }
}

// R2: spring–mass chain, N = 3, both ends fixed; k = 4, m = 2 so √(k/m) = √2.
TEST(SymmetricModes, SpringChainFrequenciesAndShapes) {
  const int N = 3;
  const double k = 4, m = 2;
  MatrixX K = MatrixX::Zero(N, N);
  for (int i = 0; i < N; ++i) {
    K(i, i) = 2 * k;
    if (i + 1 < N) K(i, i + 1) = K(i + 1, i) = -k;
  }
  const MatrixX M = m * MatrixX::Identity(N, N);
  const LinearModel model = make_model(M, K);
  const ModalResult r = modal::solve_modes(model);
  ASSERT_EQ(r.modes.size(), 3u);
  const double table[3] = {0.7653668647, 1.4142135624, 1.8477590650};  // · √(k/m)
  for (int j = 1; j <= N; ++j) {
    const Mode& mode = r.modes[static_cast<std::size_t>(j - 1)];
    const double exact = 2 * std::sqrt(k / m) * std::sin(j * std::numbers::pi / (2 * (N + 1)));
    EXPECT_NEAR(mode.omega, exact, frequency_tolerance * exact);
    EXPECT_NEAR(mode.omega / std::sqrt(k / m), table[j - 1], 6e-11);
    // φ_j(n) = sin(n j π/(N+1)), M-normalized, largest |component| made positive
    // (for j = 2, (1, 0, −1) ties: the first of the tied entries is taken).
    // (Fixed-size vector: GCC 12 at -O3 warns falsely on a 3-element dynamic one.)
    Eigen::Vector3d phi;
    for (int n = 1; n <= N; ++n) phi(n - 1) = std::sin(n * j * std::numbers::pi / (N + 1));
    phi /= std::sqrt(m * phi.squaredNorm());  // M = m I
    Eigen::Index top = 0;
    phi.cwiseAbs().maxCoeff(&top);
    if (j == 2) top = 0;
    if (phi(top) < 0) phi = -phi;
    EXPECT_LE((mode.shape.real() - phi).norm(), 1e-13) << "mode " << j << ": " << mode.shape.real().transpose();
  }
  expect_m_orthonormal_eigenpairs(model, r);
}

// The error estimate bounds the true error on a larger problem, and is tight
// enough to be useful: R2 with N = 50, k = 1e6 N/m, m = 1e-2 kg.
TEST(SymmetricModes, ErrorEstimateBoundsErrorOnLongChain) {
  const int N = 50;
  const double k = 1e6, m = 1e-2;
  MatrixX K = MatrixX::Zero(N, N);
  for (int i = 0; i < N; ++i) {
    K(i, i) = 2 * k;
    if (i + 1 < N) K(i, i + 1) = K(i + 1, i) = -k;
  }
  const ModalResult r = modal::solve_modes(make_model(m * MatrixX::Identity(N, N), K));
  ASSERT_EQ(r.modes.size(), static_cast<std::size_t>(N));
  const Long lambda_max = 4 * Long(k) / m;
  for (int j = 1; j <= N; ++j) {
    const Long s = std::sin(j * std::numbers::pi_v<Long> / (2 * (N + 1)));
    const Long exact = 4 * Long(k) / m * s * s;
    const Mode& mode = r.modes[static_cast<std::size_t>(j - 1)];
    EXPECT_LE(std::abs(Long(mode.omega2) - exact), Long(mode.error_estimate)) << "mode " << j;
    // Useful: below 1e-12 of the largest eigenvalue (the estimate is O(n ε ‖K‖)).
    EXPECT_LE(Long(mode.error_estimate), 1e-12L * lambda_max) << "mode " << j;
  }
}

// Divergence: R1 about its unstable equilibria (K = diag((m1+m2) g l1 cos θ1,
// m2 g l2 cos θ2), M₁₂ = m2 l1 l2 cos(θ1 − θ2)), m = l = g = 1.
//  both rods up (π, π): M as hanging, K = −K_hanging, so λ = −(2 ± √2);
//  one rod up: M = [[2, −1], [−1, 1]], K = diag(±2, ∓1): det(K − λM) = λ² − 2,
//  so λ = ±√2. Morse indices 2, 1, 1 (docs/design.md R1).
TEST(SymmetricModes, NegativeEigenvaluesAreDivergentAndCounted) {
  const DoublePendulum p{1, 1, 1, 1, 1};
  {
    const ModalResult r = modal::solve_modes(make_model(p.M(), -p.K()));
    ASSERT_EQ(r.modes.size(), 2u);
    EXPECT_EQ(r.stability, Stability::divergence);
    EXPECT_EQ(r.morse_index, 2);
    const double exact[2] = {-(2 + std::sqrt(2.0)), -(2 - std::sqrt(2.0))};  // ascending
    for (int j = 0; j < 2; ++j) {
      const Mode& m = r.modes[static_cast<std::size_t>(j)];
      EXPECT_EQ(m.kind, ModeKind::divergent);
      EXPECT_NEAR(m.omega2, exact[j], frequency_tolerance * std::abs(exact[j]));  // negative, not |λ|
      EXPECT_NEAR(m.growth_rate, std::sqrt(-exact[j]), frequency_tolerance * std::sqrt(-exact[j]));
      EXPECT_EQ(m.s, Complex(m.growth_rate, 0));
      EXPECT_EQ(m.omega, 0.0);
      EXPECT_EQ(m.frequency_hz, 0.0);
      EXPECT_TRUE(std::isinf(m.period));
      EXPECT_EQ(m.damping_ratio, -1.0);  // −σ/|s| with s real positive
    }
  }
  for (double c : {1.0, -1.0}) {
    const ModalResult r = modal::solve_modes(make_model(mat2(2, -1, -1, 1), mat2(2 * c, 0, 0, -c)));
    ASSERT_EQ(r.modes.size(), 2u);
    EXPECT_EQ(r.stability, Stability::divergence);
    EXPECT_EQ(r.morse_index, 1);
    EXPECT_EQ(r.modes[0].kind, ModeKind::divergent);
    EXPECT_NEAR(r.modes[0].omega2, -std::sqrt(2.0), 1e-12);
    EXPECT_EQ(r.modes[1].kind, ModeKind::oscillatory);
    EXPECT_NEAR(r.modes[1].omega2, std::sqrt(2.0), 1e-12);
  }
}

// A free body: nothing holds it, K = 0, every mode is a zero mode.
TEST(SymmetricModes, FreeBodyHasExactZeroModes) {
  MatrixX M(3, 3);
  M << 2, 0.5, 0, 0.5, 3, 0.2, 0, 0.2, 1;
  const ModalResult r = modal::solve_modes(make_model(M, MatrixX::Zero(3, 3)));
  EXPECT_EQ(r.stability, Stability::marginal);
  EXPECT_EQ(r.zero_modes, 3);
  EXPECT_EQ(r.morse_index, 0);
  for (const Mode& m : r.modes) {
    EXPECT_EQ(m.kind, ModeKind::zero);
    EXPECT_EQ(m.omega, 0.0);
    EXPECT_TRUE(std::isnan(m.damping_ratio));
    EXPECT_TRUE(std::isinf(m.period));
  }
}

// Two free masses m1 = 1, m2 = 3 joined by a stiff spring k = 1e3: one rigid
// motion (λ = 0) and λ = k(1/m1 + 1/m2) = 4000/3. The computed "zero" is only
// zero to rounding of k-sized numbers; its estimate must cover it.
TEST(SymmetricModes, RigidMotionOfSpringPairIsAZeroMode) {
  const double k = 1e3;
  const ModalResult r = modal::solve_modes(make_model(mat2(1, 0, 0, 3), mat2(k, -k, -k, k), {"a", "b"}));
  ASSERT_EQ(r.modes.size(), 2u);
  EXPECT_EQ(r.stability, Stability::marginal);
  EXPECT_EQ(r.zero_modes, 1);
  EXPECT_EQ(r.modes[0].kind, ModeKind::zero);
  EXPECT_LE(std::abs(r.modes[0].omega2), r.modes[0].error_estimate);
  // Rigid motion: both masses move alike; M-normalized: 1/√(m1 + m2) = 1/2.
  EXPECT_NEAR(r.modes[0].shape.real()(0), 0.5, 1e-13);
  EXPECT_NEAR(r.modes[0].shape.real()(1), 0.5, 1e-13);
  EXPECT_EQ(r.modes[1].kind, ModeKind::oscillatory);
  EXPECT_NEAR(r.modes[1].omega2, 4000.0 / 3.0, frequency_tolerance * 4000.0 / 3.0);
}

// A repeated eigenvalue: M block diagonal, K = 3M on the first block and 5 on
// the third coordinate (M₃₃ = 1): λ = 3, 3, 5. The two modes of λ = 3 are not
// unique; they must be an M-orthonormal basis of the eigenspace, which is
// spanned by the first two coordinates.
TEST(SymmetricModes, RepeatedEigenvalueGivesMOrthonormalBasis) {
  MatrixX M(3, 3);
  M << 2, 1, 0, 1, 2, 0, 0, 0, 1;
  MatrixX K = 3 * M;
  K(2, 2) = 5;
  const LinearModel model = make_model(M, K);
  const ModalResult r = modal::solve_modes(model);
  ASSERT_EQ(r.modes.size(), 3u);
  EXPECT_NEAR(r.modes[0].omega2, 3, 1e-12 * 3);
  EXPECT_NEAR(r.modes[1].omega2, 3, 1e-12 * 3);
  EXPECT_NEAR(r.modes[2].omega2, 5, 1e-12 * 5);
  for (int j = 0; j < 2; ++j) EXPECT_LE(std::abs(r.modes[static_cast<std::size_t>(j)].shape.real()(2)), 1e-13);
  expect_m_orthonormal_eigenpairs(model, r);
  bool noted = false;
  for (const std::string& note : r.notes) noted = noted || note.find("modes 1–2") != std::string::npos;
  EXPECT_TRUE(noted) << "a note should say that modes 1–2 are a basis, not unique";
}

// M-normalization and residuals on a dense problem with no special structure:
// M = BᵀB + I, K = CᵀC − I (some λ may be negative), entries from sin/cos.
TEST(SymmetricModes, DenseProblemIsMOrthonormalWithSmallResiduals) {
  const int n = 6;
  MatrixX B(n, n), C(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      B(i, j) = std::sin(1.0 + i + 2.0 * j);
      C(i, j) = std::cos(3.0 * i - j);
    }
  const MatrixX M = B.transpose() * B + MatrixX::Identity(n, n);
  const MatrixX K = C.transpose() * C - MatrixX::Identity(n, n);
  const LinearModel model = make_model(M, K);
  const ModalResult r = modal::solve_modes(model);
  ASSERT_EQ(r.modes.size(), static_cast<std::size_t>(n));
  for (std::size_t j = 1; j < r.modes.size(); ++j) EXPECT_LE(r.modes[j - 1].omega2, r.modes[j].omega2);
  expect_m_orthonormal_eigenpairs(model, r);
  expect_sign_convention(r);
}

// Singular and indefinite mass matrices are refused, naming the coordinates.
TEST(SymmetricModes, SingularMassMatrixNamesTheCoordinate) {
  MatrixX M = MatrixX::Zero(3, 3);
  M(0, 0) = 1;
  M(2, 2) = 2;  // lower.x carries no inertia
  try {
    modal::solve_modes(make_model(M, MatrixX::Identity(3, 3), {"upper", "lower.x", "lower.z"}));
    FAIL() << "expected SingularMassMatrix";
  } catch (const modal::SingularMassMatrix& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("singular"), std::string::npos) << what;
    EXPECT_NE(what.find("lower.x"), std::string::npos) << what;
    EXPECT_EQ(what.find("upper"), std::string::npos) << what;
    EXPECT_NE(what.find("no inertia"), std::string::npos) << what;
  }
  // A combination: M = [[1, 1], [1, 1]] has the null vector (1, −1)/√2.
  try {
    modal::solve_modes(make_model(mat2(1, 1, 1, 1), MatrixX::Identity(2, 2), {"a.rx", "a.rz"}));
    FAIL() << "expected SingularMassMatrix";
  } catch (const modal::SingularMassMatrix& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("0.71·a.rx − 0.71·a.rz"), std::string::npos) << what;
  }
  // Indefinite (negative inertia), also through the first-order solver.
  LinearModel damped = make_model(mat2(1, 0, 0, -1), MatrixX::Identity(2, 2), {"x", "y"});
  damped.D = MatrixX::Identity(2, 2);
  damped.has_damping = true;
  try {
    modal::solve_modes(damped);
    FAIL() << "expected SingularMassMatrix";
  } catch (const modal::SingularMassMatrix& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("negative inertia"), std::string::npos) << what;
    EXPECT_NE(what.find("coordinate y"), std::string::npos) << what;
  }
}

// A positive definite M whose smallest eigenvalue lies below the tolerance
// (16ε‖M‖_F after scaling) is refused, but in words that are true: singular
// to double precision, the direction's inertia unresolved, the tolerance
// stated; not "no inertia", which a positive eigenvalue contradicts.
// Generated: M = S [[1, 1 − kε], [1 − kε, 1]] S with S = diag(1, 2^e)
// graded over 2^±40, given M's diagonal as the inertia scale, so that the
// equilibrated M is exactly the middle matrix, whose eigenvalues are kε
// and 2 − kε (1 − kε is a double for these k); with and without damping
// (the first-order path factors M the same way).
TEST(SymmetricModes, ModestlyPositiveMassBelowTheToleranceIsSingularToDoublePrecision) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  int cases = 0;
  for (int k : {1, 2, 5, 16})
    for (int e : {-40, 0, 17, 40})
      for (bool damped : {false, true}) {
        const double c = 1 - k * eps;
        const double s = std::ldexp(1.0, e);
        MatrixX M = mat2(1, c * s, c * s, s * s);
        ASSERT_GT(M(0, 0) * M(1, 1) - M(0, 1) * M(1, 0), 0.0);  // positive definite as stored
        LinearModel model = make_model(M, MatrixX::Identity(2, 2), {"heavy", "light"});
        model.inertia_scale = Eigen::Vector2d(1, s * s);  // M_ii: the scaling S⁻¹ undoes S
        if (damped) {
          model.D = MatrixX::Identity(2, 2);
          model.has_damping = true;
        }
        try {
          modal::solve_modes(model);
          ADD_FAILURE() << "expected SingularMassMatrix (k " << k << ", e " << e << ")";
        } catch (const modal::SingularMassMatrix& error) {
          const std::string what = error.what();
          EXPECT_NE(what.find("singular to double precision"), std::string::npos) << what;
          EXPECT_NE(what.find("no inertia that double precision resolves"), std::string::npos) << what;
          EXPECT_NE(what.find("within the tolerance 16ε‖M‖_F"), std::string::npos) << what;
          EXPECT_EQ(what.find("negative"), std::string::npos) << what;
          ++cases;
        }
      }
  EXPECT_EQ(cases, 32);
}

// ---------------------------------------------------------------------------
// First-order problems.

// Damped single oscillator m ẍ + c ẋ + k x = 0, ω₀ = √(k/m), ζ = c/(2 m ω₀):
// s = −ζω₀ ± iω₀√(1 − ζ²).
TEST(FirstOrderModes, UnderdampedOscillator) {
  const double m = 2, k = 8, zeta = 0.1, w0 = std::sqrt(k / m);
  LinearModel model = make_model(MatrixX::Constant(1, 1, m), MatrixX::Constant(1, 1, k));
  model.D = MatrixX::Constant(1, 1, 2 * zeta * w0 * m);
  model.has_damping = true;
  const ModalResult r = modal::solve_modes(model);
  ASSERT_EQ(r.modes.size(), 1u);  // the conjugate pair is reported once
  const Mode& mode = r.modes[0];
  const Complex exact(-zeta * w0, w0 * std::sqrt(1 - zeta * zeta));
  EXPECT_NEAR(std::abs(mode.s - exact), 0.0, frequency_tolerance * w0);
  EXPECT_LE(std::abs(mode.s - exact), mode.error_estimate);
  EXPECT_NEAR(mode.damping_ratio, zeta, 1e-12);
  EXPECT_EQ(mode.kind, ModeKind::damped);
  EXPECT_TRUE(std::isnan(mode.omega2));
  EXPECT_EQ(mode.growth_rate, mode.s.real());
  EXPECT_EQ(mode.omega, mode.s.imag());
  EXPECT_EQ(mode.shape(0), Complex(1, 0));
  EXPECT_EQ(r.stability, Stability::asymptotically_stable);
  EXPECT_NE(r.solver.find("first-order"), std::string::npos);
}

// Overdamped, ζ = 2: two real eigenvalues s = −ω₀(ζ ∓ √(ζ² − 1)), both negative.
TEST(FirstOrderModes, OverdampedOscillatorHasTwoRealModes) {
  const double m = 2, k = 8, zeta = 2, w0 = std::sqrt(k / m);
  LinearModel model = make_model(MatrixX::Constant(1, 1, m), MatrixX::Constant(1, 1, k));
  model.D = MatrixX::Constant(1, 1, 2 * zeta * w0 * m);
  model.has_damping = true;
  const ModalResult r = modal::solve_modes(model);
  ASSERT_EQ(r.modes.size(), 2u);
  // Ascending ω (both 0), then σ: the faster decay first.
  const double exact[2] = {-w0 * (zeta + std::sqrt(zeta * zeta - 1)), -w0 * (zeta - std::sqrt(zeta * zeta - 1))};
  for (int j = 0; j < 2; ++j) {
    const Mode& mode = r.modes[static_cast<std::size_t>(j)];
    EXPECT_EQ(mode.s.imag(), 0.0);
    EXPECT_NEAR(mode.s.real(), exact[j], frequency_tolerance * std::abs(exact[j]));
    EXPECT_LE(std::abs(mode.s.real() - exact[j]), mode.error_estimate);
    EXPECT_EQ(mode.kind, ModeKind::damped);
    EXPECT_EQ(mode.damping_ratio, 1.0);
    EXPECT_TRUE(std::isinf(mode.period));
  }
  EXPECT_EQ(r.stability, Stability::asymptotically_stable);
}

// The first-order solver on R1 (flagged gyroscopic with G = 0 to force it):
// purely imaginary s = ±iω with the Kibble–Berkshire frequencies, "stable".
TEST(FirstOrderModes, UndampedDoublePendulumIsStable) {
  const DoublePendulum p{1, 2, 1, 1, 1};
  LinearModel model = make_model(p.M(), p.K());
  model.has_gyroscopic = true;
  const ModalResult r = modal::solve_modes(model);
  ASSERT_EQ(r.modes.size(), 2u);
  EXPECT_EQ(r.stability, Stability::stable);
  for (int j = 0; j < 2; ++j) {
    const Mode& mode = r.modes[static_cast<std::size_t>(j)];
    const double exact = double(std::sqrt(p.omega2(j == 0 ? -1 : 1)));
    EXPECT_EQ(mode.kind, ModeKind::oscillatory);
    EXPECT_NEAR(mode.omega, exact, frequency_tolerance * exact);
    EXPECT_LE(std::abs(mode.growth_rate), mode.error_estimate);
    EXPECT_LE(std::abs(mode.s - Complex(0, exact)), mode.error_estimate);
  }
}

// R6 Ziegler's pendulum, m = l = k = 1 so p = P: M = [[3, 1], [1, 1]],
// K = [[2 − p, p − 1], [−1, 1]] (not symmetric). λ = ω² solves
// 2λ² + (2p − 7)λ + 1 = 0:
//  - p < 7/2 − √2: two positive λ, s = ±i√λ: stable;
//  - 7/2 − √2 < p < 7/2 + √2: complex λ, s = ±√(−λ): a pair with σ > 0, flutter;
//  - p > 7/2 + √2: both λ negative (sum (7 − 2p)/2 < 0, product 1/2 > 0), s real
//    and positive: a dynamic divergence, although K is never singular
//    (det K = 1 for every p: "no static buckling").
LinearModel ziegler(double p) {
  LinearModel model = make_model(mat2(3, 1, 1, 1), mat2(2 - p, p - 1, -1, 1), {"theta1", "theta2"});
  model.circulatory = true;
  return model;
}

std::vector<Complex> ziegler_lambdas(double p) {
  const Complex b = 2 * p - 7, disc = std::sqrt(Complex(b * b - 8.0));
  return {(-b - disc) / 4.0, (-b + disc) / 4.0};
}

TEST(FirstOrderModes, ZieglerStableBelowCriticalLoad) {
  const double p_cr = 3.5 - std::sqrt(2.0);
  EXPECT_NEAR(p_cr, 2.08578643763, 1e-11);  // docs/design.md R6
  for (double p : {0.0, 1.0, 2.0}) {
    SCOPED_TRACE("p = " + std::to_string(p));
    const ModalResult r = modal::solve_modes(ziegler(p));
    ASSERT_EQ(r.modes.size(), 2u);
    EXPECT_EQ(r.stability, Stability::stable);
    const std::vector<Complex> lambda = ziegler_lambdas(p);  // real, ascending
    for (int j = 0; j < 2; ++j) {
      const Mode& mode = r.modes[static_cast<std::size_t>(j)];
      const double exact = std::sqrt(lambda[static_cast<std::size_t>(j)].real());
      EXPECT_EQ(mode.kind, ModeKind::oscillatory);
      EXPECT_NEAR(mode.omega, exact, frequency_tolerance * exact);
      EXPECT_LE(std::abs(mode.s - Complex(0, exact)), mode.error_estimate);
    }
  }
}

TEST(FirstOrderModes, ZieglerFluttersAboveCriticalLoad) {
  for (double p : {2.2, 3.0, 4.5}) {
    SCOPED_TRACE("p = " + std::to_string(p));
    const ModalResult r = modal::solve_modes(ziegler(p));
    EXPECT_EQ(r.stability, Stability::flutter);
    EXPECT_EQ(r.morse_index, 0);
    // Expected: s = ±√(−λ) for both complex λ, those with ω > 0.
    std::vector<Complex> expected;
    for (Complex l : ziegler_lambdas(p))
      for (Complex s : {std::sqrt(-l), -std::sqrt(-l)})
        if (s.imag() > 0) expected.push_back(s);
    ASSERT_EQ(r.modes.size(), expected.size());
    int fluttering = 0;
    for (const Mode& mode : r.modes) {
      double nearest = std::numeric_limits<double>::infinity();
      for (Complex s : expected) nearest = std::min(nearest, std::abs(mode.s - s));
      EXPECT_LE(nearest, 1e-12 * std::abs(mode.s));
      EXPECT_LE(nearest, mode.error_estimate);
      if (mode.kind == ModeKind::flutter) ++fluttering;
    }
    EXPECT_EQ(fluttering, 1);
  }
}

// Near p_cr the two frequencies coalesce and the eigenvalues become
// ill-conditioned (their error grows like ε/gap, up to √ε at the coalescence).
// The estimate must still bound the error (reference in long double), and the
// class must follow the side of p_cr: at p_cr ± 1e-8 the true |σ| is
// about 5e-5, far above the estimate.
TEST(FirstOrderModes, ZieglerErrorEstimateNearCoalescence) {
  using LongComplex = std::complex<Long>;
  const Long p_cr = Long(3.5) - std::sqrt(Long(2));
  for (Long dp : {-1e-6L, -1e-8L, 1e-8L, 1e-6L}) {
    const double p = double(p_cr + dp);
    SCOPED_TRACE("p − p_cr = " + std::to_string(double(dp)));
    const ModalResult r = modal::solve_modes(ziegler(p));
    EXPECT_EQ(r.stability, dp < 0 ? Stability::stable : Stability::flutter);
    const Long b = 2 * Long(p) - 7;
    const LongComplex disc = std::sqrt(LongComplex(b * b - 8));
    for (const Mode& mode : r.modes) {
      Long nearest = std::numeric_limits<Long>::infinity();
      for (LongComplex l : {(-b - disc) / Long(4), (-b + disc) / Long(4)})
        for (LongComplex s : {std::sqrt(-l), -std::sqrt(-l)})
          nearest = std::min(nearest, std::abs(LongComplex(mode.s.real(), mode.s.imag()) - s));
      EXPECT_LE(nearest, Long(mode.error_estimate));
    }
  }
}

TEST(FirstOrderModes, ZieglerDivergesDynamicallyAtHighLoad) {
  const double p = 6;  // > 7/2 + √2: λ = (−5 ± √17)/4, both negative
  const ModalResult r = modal::solve_modes(ziegler(p));
  EXPECT_EQ(r.stability, Stability::divergence);
  EXPECT_EQ(r.morse_index, 2);  // s = +√(−λ) for each λ
  int divergent = 0;
  for (const Mode& mode : r.modes)
    if (mode.kind == ModeKind::divergent) {
      ++divergent;
      const double l1 = (-5 - std::sqrt(17.0)) / 4, l2 = (-5 + std::sqrt(17.0)) / 4;
      const double d = std::min(std::abs(mode.growth_rate - std::sqrt(-l1)), std::abs(mode.growth_rate - std::sqrt(-l2)));
      EXPECT_LE(d, 1e-12 * mode.growth_rate);
    }
  EXPECT_EQ(divergent, 2);
}

// Gyroscopic stabilization: M = I, G = [[0, −g], [g, 0]], K = −I.
// det(s²I + sG + K) = (s² − 1)² + g²s² = s⁴ + (g² − 2)s² + 1.
//  - g > 2: s² = μ real negative (sum 2 − g² < 0, product 1, discriminant
//    g²(g² − 4) > 0): s = ±iω with ω = (g ∓ √(g² − 4))/2: stable.
//  - 0 < g < 2: s² = e^{±iθ}, cos θ = 1 − g²/2, so s = ±√(1 − g²/4) ± i g/2:
//    a pair with σ > 0: flutter.
//  - g = 0: s = ±1 (each twice): divergence, two real positive eigenvalues.
LinearModel gyroscopic(double g) {
  LinearModel model = make_model(MatrixX::Identity(2, 2), -MatrixX::Identity(2, 2), {"x", "y"});
  model.G = mat2(0, -g, g, 0);
  model.has_gyroscopic = true;
  return model;
}

TEST(FirstOrderModes, GyroscopicStabilization) {
  {
    const double g = 3;
    const ModalResult r = modal::solve_modes(gyroscopic(g));
    EXPECT_EQ(r.stability, Stability::stable);
    ASSERT_EQ(r.modes.size(), 2u);
    const double exact[2] = {(g - std::sqrt(g * g - 4)) / 2, (g + std::sqrt(g * g - 4)) / 2};
    for (int j = 0; j < 2; ++j) {
      const Mode& mode = r.modes[static_cast<std::size_t>(j)];
      EXPECT_EQ(mode.kind, ModeKind::oscillatory);
      EXPECT_NEAR(mode.omega, exact[j], frequency_tolerance * exact[j]);
      EXPECT_LE(std::abs(mode.s - Complex(0, exact[j])), mode.error_estimate);
    }
  }
  {
    const double g = 1;
    const ModalResult r = modal::solve_modes(gyroscopic(g));
    EXPECT_EQ(r.stability, Stability::flutter);
    ASSERT_EQ(r.modes.size(), 2u);  // σ = ±√3/2, ω = 1/2: two pairs, ω > 0 each
    const double sigma = std::sqrt(1 - g * g / 4);
    // Both at ω = 1/2 (to rounding: their order is not part of the answer).
    const bool first_decays = r.modes[0].growth_rate < 0;
    const Mode& decaying = r.modes[first_decays ? 0 : 1];
    const Mode& growing = r.modes[first_decays ? 1 : 0];
    EXPECT_NEAR(std::abs(decaying.s - Complex(-sigma, g / 2)), 0.0, 1e-12);
    EXPECT_NEAR(std::abs(growing.s - Complex(sigma, g / 2)), 0.0, 1e-12);
    EXPECT_EQ(decaying.kind, ModeKind::damped);
    EXPECT_EQ(growing.kind, ModeKind::flutter);
  }
  {
    const ModalResult r = modal::solve_modes(gyroscopic(0));
    EXPECT_EQ(r.stability, Stability::divergence);
    EXPECT_EQ(r.morse_index, 2);
  }
}

// ---------------------------------------------------------------------------
// Options and names.

TEST(ModalOptions, KeepsTheLowestModesButClassifiesAll) {
  // R2, N = 3, k = m = 1: keep 2 of 3.
  MatrixX K(3, 3);
  K << 2, -1, 0, -1, 2, -1, 0, -1, 2;
  const ModalResult r = modal::solve_modes(make_model(MatrixX::Identity(3, 3), K), {.modes = 2});
  ASSERT_EQ(r.modes.size(), 2u);
  EXPECT_NEAR(r.modes[0].omega, 0.7653668647, 6e-11);
  EXPECT_NEAR(r.modes[1].omega, 1.4142135624, 6e-11);
  EXPECT_EQ(modal::solve_modes(make_model(MatrixX::Identity(3, 3), K), {.modes = 10}).modes.size(), 3u);

  // Ziegler at p = 3 flutters; ascending ω then σ puts the damped partner of
  // the fluttering pair first (same ω). Keeping one mode must not hide flutter.
  const ModalResult z = modal::solve_modes(ziegler(3.0), {.modes = 1});
  ASSERT_EQ(z.modes.size(), 1u);
  EXPECT_EQ(z.stability, Stability::flutter);
  const ModalResult none = modal::solve_modes(ziegler(3.0), {.modes = 0});
  EXPECT_TRUE(none.modes.empty());
  EXPECT_EQ(none.stability, Stability::flutter);
}

TEST(ModalStrings, StabilityAndKindNames) {
  EXPECT_STREQ(modal::to_string(Stability::asymptotically_stable), "asymptotically stable");
  EXPECT_STREQ(modal::to_string(Stability::stable), "stable");
  EXPECT_STREQ(modal::to_string(Stability::marginal), "marginal");
  EXPECT_STREQ(modal::to_string(Stability::divergence), "divergence");
  EXPECT_STREQ(modal::to_string(Stability::flutter), "flutter");
  EXPECT_STREQ(modal::to_string(ModeKind::oscillatory), "oscillatory");
  EXPECT_STREQ(modal::to_string(ModeKind::damped), "damped");
  EXPECT_STREQ(modal::to_string(ModeKind::zero), "zero");
  EXPECT_STREQ(modal::to_string(ModeKind::divergent), "divergent");
  EXPECT_STREQ(modal::to_string(ModeKind::flutter), "flutter");
}

// A K that is not symmetric in a model that declares no circulatory forces is
// solved as a general problem (and says so) rather than silently symmetrized.
TEST(ModalOptions, UndeclaredAsymmetricStiffnessIsSolvedGenerally) {
  const LinearModel model = make_model(mat2(3, 1, 1, 1), mat2(1, 0, -1, 1));  // Ziegler at p = 1
  const ModalResult r = modal::solve_modes(model);
  EXPECT_NE(r.solver.find("first-order"), std::string::npos);
  ASSERT_FALSE(r.notes.empty());
  EXPECT_NE(r.notes.front().find("not symmetric"), std::string::npos);
  const double exact = std::sqrt((5 - std::sqrt(17.0)) / 4);  // 2λ² − 5λ + 1 = 0
  EXPECT_NEAR(r.modes[0].omega, exact, frequency_tolerance * exact);
}

// ---------------------------------------------------------------------------
// End to end: scene file → System → linearize → solve_modes, on the models
// shipped in models/ (they state the same references in their comments).

modal::System load_model(const std::string& name) {
  return modal::build_system(modal::load_scene(std::string(MODAL_SOURCE_DIR) + "/models/" + name));
}

// R1 with m = l = g = 1, in the scene's relative angles (upper absolute, lower
// relative to upper): hanging ω² = 2 ∓ √2; Morse indices 0, 1, 1, 2 at
// (0, 0), (0, π), (π, −π), (π, 0).
TEST(EndToEnd, DoublePendulumSceneAtItsFourEquilibria) {
  const modal::System sys = load_model("double_pendulum.toml");
  const ModalResult hanging = modal::solve_modes(modal::linearize(sys, VectorX::Zero(2)));
  ASSERT_EQ(hanging.modes.size(), 2u);
  EXPECT_EQ(hanging.stability, Stability::stable);
  const double exact[2] = {std::sqrt(2 - std::sqrt(2.0)), std::sqrt(2 + std::sqrt(2.0))};
  for (int j = 0; j < 2; ++j)
    EXPECT_NEAR(hanging.modes[static_cast<std::size_t>(j)].omega, exact[j], frequency_tolerance * exact[j]);

  const double pi = std::numbers::pi;
  const struct { double upper, lower; int morse; } equilibria[] = {{0, pi, 1}, {pi, -pi, 1}, {pi, 0, 2}};
  for (const auto& e : equilibria) {
    const ModalResult r = modal::solve_modes(modal::linearize(sys, (VectorX(2) << e.upper, e.lower).finished()));
    EXPECT_EQ(r.stability, Stability::divergence) << e.upper << ", " << e.lower;
    EXPECT_EQ(r.morse_index, e.morse) << e.upper << ", " << e.lower;
  }
}

// R2, N = 3, k = m = 1: ω = 0.7653668647, 1.4142135624, 1.8477590650.
TEST(EndToEnd, SpringChainScene) {
  const modal::System sys = load_model("spring_chain.toml");
  const ModalResult r = modal::solve_modes(modal::linearize(sys, VectorX::Zero(sys.size())));
  ASSERT_EQ(r.modes.size(), 3u);
  EXPECT_EQ(r.stability, Stability::stable);
  for (int j = 1; j <= 3; ++j) {
    const double exact = 2 * std::sin(j * std::numbers::pi / 8);
    EXPECT_NEAR(r.modes[static_cast<std::size_t>(j - 1)].omega, exact, frequency_tolerance * exact);
  }
}

// The residual bound (symmetric problems) is rigorous for the matrices as
// formed: for a 2×2 pencil, whose eigenvalues det(K − λM) = 0 are computed
// here in long double, each computed λ lies within its bound of one of them,
// and first-order solutions have none (NaN).
TEST(SymmetricModes, ResidualBoundIsRigorousForTheFormedMatrices) {
  const MatrixX M = mat2(2.7, 0.9, 0.9, 1.1), K = mat2(31.3, -7.7, -7.7, 12.9);
  const ModalResult r = modal::solve_modes(make_model(M, K));
  ASSERT_EQ(r.modes.size(), 2u);
  const Long a = Long(M(0, 0)) * M(1, 1) - Long(M(0, 1)) * M(1, 0);
  const Long b = -(Long(K(0, 0)) * M(1, 1) + Long(K(1, 1)) * M(0, 0) - 2 * Long(K(0, 1)) * M(0, 1));
  const Long c = Long(K(0, 0)) * K(1, 1) - Long(K(0, 1)) * K(1, 0);
  const Long root = std::sqrt(b * b - 4 * a * c);
  const Long lambda[2] = {(-b - root) / (2 * a), (-b + root) / (2 * a)};
  for (std::size_t j = 0; j < 2; ++j) {
    const Mode& m = r.modes[j];
    ASSERT_TRUE(std::isfinite(m.residual_bound));
    EXPECT_LE(static_cast<double>(std::abs(Long(m.omega2) - lambda[j])), m.residual_bound + 1e-17 * std::abs(m.omega2))
        << "mode " << j + 1;
  }
  LinearModel damped = make_model(M, K);
  damped.D = mat2(0.1, 0, 0, 0.1);
  damped.has_damping = true;
  for (const Mode& m : modal::solve_modes(damped).modes) EXPECT_TRUE(std::isnan(m.residual_bound));
}

// The two dense symmetric solvers (Eigen's QR, LAPACK's dsygvd) agree within
// their error estimates, give M-orthonormal shapes, and say which ran; the
// automatic choice follows the documented threshold.
TEST(SymmetricModes, EigenAndLapackAgree) {
  const int n = 200;  // a fixed–fixed spring chain (R2): λ_j = 4 (k/m) sin²(jπ/(2(n+1)))
  MatrixX K = MatrixX::Zero(n, n), M = MatrixX::Identity(n, n);
  for (int i = 0; i < n; ++i) {
    K(i, i) = 2;
    if (i + 1 < n) K(i, i + 1) = K(i + 1, i) = -1;
  }
  const LinearModel model = make_model(M, K);
  modal::ModalOptions eigen_options, lapack_options, automatic;
  eigen_options.dense_solver = modal::DenseSolver::eigen;
  lapack_options.dense_solver = modal::DenseSolver::lapack;
  const ModalResult a = modal::solve_modes(model, eigen_options), b = modal::solve_modes(model, lapack_options);
  EXPECT_NE(a.solver.find("Eigen"), std::string::npos) << a.solver;
  EXPECT_NE(b.solver.find("divide and conquer dsyevd"), std::string::npos) << b.solver;
  EXPECT_NE(modal::solve_modes(model, automatic).solver.find(n >= modal::lapack_threshold ? "LAPACK" : "Eigen"),
            std::string::npos);
  ASSERT_EQ(a.modes.size(), b.modes.size());
  for (std::size_t j = 0; j < a.modes.size(); ++j) {
    const double exact = 4 * std::pow(std::sin((j + 1) * std::numbers::pi / (2.0 * (n + 1))), 2);
    EXPECT_LE(std::abs(a.modes[j].omega2 - exact), a.modes[j].error_estimate + 4e-16 * exact) << j;
    EXPECT_LE(std::abs(b.modes[j].omega2 - exact), b.modes[j].error_estimate + 4e-16 * exact) << j;
  }
  expect_m_orthonormal_eigenpairs(model, b);
}

}  // namespace
