// tests/test_sparse_modes.cpp — solve_sparse_modes() (shift-invert Lanczos with
// CHOLMOD / LDLᵀ factors) against closed forms and the dense solver.
//
// References: spring chains of unit masses and unit springs, whose
// eigenvalues are known in closed form (fixed–fixed, n masses:
// λ_j = 4 sin²(jπ/(2(n+1))), φ_ij ∝ sin(ijπ/(n+1)); free–free:
// λ_j = 4 sin²(jπ/(2n)), j = 0 … n−1, λ₀ = 0 the rigid translation), computed in
// long double; otherwise the dense symmetric solver (Eigen's self-adjoint QR,
// tested separately in test_modes.cpp).
//
// Tolerances: eigenvalues to 1e-10 relative (the chain's lowest eigenvalue,
// 6e-7 for n = 2000, is known to the rounding of K's entries times its
// condition; a few ε relative to ‖K‖ would still be 1e-9 relative to it, so
// 1e-10 checks that the shift-invert run resolves the low end to far better
// than normwise accuracy), ΦᵀMΦ = I to 1e-10.
#include "modal/equilibrium.hpp"
#include "modal/modes.hpp"
#include "modal/scene.hpp"
#include "modal/mumps.hpp"
#include "core/cholmod_factor.hpp"
#include "core/pairwise_dot.hpp"
#include "core/sparse_product.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <numeric>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using modal::LinearModel;
using modal::MatrixX;
using modal::ModalResult;
using modal::ModeKind;
using modal::SparseMatrix;
using modal::SparseModalOptions;
using modal::Stability;
using modal::VectorX;
using Long = long double;
using Triplets = std::vector<Eigen::Triplet<double>>;

constexpr double eigen_tolerance = 1e-10;   // relative
constexpr double orthonormal_tolerance = 1e-10;

// Options without designated initializers (GCC warns about the members left out).
SparseModalOptions options(int k, std::optional<double> shift = std::nullopt, double tolerance = 1e-10) {
  SparseModalOptions o;
  o.modes = k;
  o.shift = shift;
  o.tolerance = tolerance;
  return o;
}

SparseMatrix from_triplets(int n, const Triplets& t) {
  SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();
  return A;
}

// Unit masses joined by unit springs; `fixed`: also a spring from each end
// mass to the ground. `diagonal_shift[i]` is added to K_ii.
SparseMatrix chain_stiffness(int n, bool fixed, const std::vector<std::pair<int, double>>& diagonal_shift = {}) {
  Triplets t;
  for (int i = 0; i < n; ++i) {
    double d = 2.0;
    if (!fixed && (i == 0 || i == n - 1)) d = 1.0;
    t.emplace_back(i, i, d);
    if (i + 1 < n) {
      t.emplace_back(i, i + 1, -1.0);
      t.emplace_back(i + 1, i, -1.0);
    }
  }
  for (auto [i, s] : diagonal_shift) t.emplace_back(i, i, s);
  return from_triplets(n, t);
}

SparseMatrix identity(int n) {
  SparseMatrix I(n, n);
  I.setIdentity();
  return I;
}

MatrixX shapes(const ModalResult& r) {
  MatrixX Phi(r.modes.front().shape.size(), static_cast<Eigen::Index>(r.modes.size()));
  for (std::size_t j = 0; j < r.modes.size(); ++j) Phi.col(static_cast<Eigen::Index>(j)) = r.modes[j].shape.real();
  return Phi;
}

// ΦᵀMΦ = I; every shape real with its dominant component (the first of the
// largest |components|, ties within 1e-12 relative) positive; residual
// ‖Kφ − λMφ‖₂ and error estimate at most 1e-10·(‖K‖₁ + |λ|‖M‖₁)‖φ‖ (the
// Lanczos tolerance is 1e-10 relative; eigenvalues are far more accurate, the
// error being quadratic in the residual); ascending λ.
void expect_valid_modes(const ModalResult& r, const SparseMatrix& K, const SparseMatrix& M) {
  ASSERT_FALSE(r.modes.empty());
  const MatrixX Phi = shapes(r);
  const MatrixX G = Phi.transpose() * (M * Phi);
  EXPECT_LE((G - MatrixX::Identity(G.rows(), G.cols())).cwiseAbs().maxCoeff(), orthonormal_tolerance);
  const double k1 = MatrixX(K).cwiseAbs().colwise().sum().maxCoeff();
  const double m1 = MatrixX(M).cwiseAbs().colwise().sum().maxCoeff();
  for (std::size_t j = 0; j < r.modes.size(); ++j) {
    const auto& mode = r.modes[j];
    EXPECT_LE(mode.shape.imag().cwiseAbs().maxCoeff(), 0.0);
    const VectorX phi = mode.shape.real();
    const double largest = phi.cwiseAbs().maxCoeff();
    Eigen::Index dominant = 0;
    while (std::abs(phi(dominant)) < largest * (1 - 1e-12)) ++dominant;
    EXPECT_GT(phi(dominant), 0.0) << "mode " << j;
    const double scale = (k1 + std::abs(mode.omega2) * m1) * phi.norm();
    const double residual = (K * phi - mode.omega2 * (M * phi)).norm();
    EXPECT_LE(residual, 1e-10 * scale) << "mode " << j;
    EXPECT_GE(mode.error_estimate, 0.0);
    EXPECT_LE(mode.error_estimate, 1e-10 * scale) << "mode " << j;
    if (j > 0) {
      EXPECT_LE(r.modes[j - 1].omega2, mode.omega2);
    }
  }
}

void expect_relative(double value, double expected, double tolerance, const std::string& what) {
  EXPECT_LE(std::abs(value - expected), tolerance * std::abs(expected))
      << what << ": " << value << " vs " << expected << " (relative " << std::abs(value / expected - 1) << ")";
}

// Eigenvalues of the dense pencil (reference), ascending.
VectorX dense_eigenvalues(const SparseMatrix& K, const SparseMatrix& M) {
  Eigen::GeneralizedSelfAdjointEigenSolver<MatrixX> eig(MatrixX(K), MatrixX(M), Eigen::EigenvaluesOnly);
  return eig.eigenvalues();
}

// (a) Fixed–fixed chain, n = 2000: the ten lowest against the closed form.
TEST(SparseModes, FixedFixedChainLowestTen) {
  const int n = 2000;
  const SparseMatrix K = chain_stiffness(n, true), M = identity(n);
  const ModalResult r = modal::solve_sparse_modes(K, M, options(10));
  ASSERT_EQ(r.modes.size(), 10u);
  for (int j = 1; j <= 10; ++j) {
    const Long s = std::sin(static_cast<Long>(j) * std::numbers::pi_v<Long> / (2 * static_cast<Long>(n + 1)));
    expect_relative(r.modes[static_cast<std::size_t>(j - 1)].omega2, static_cast<double>(4 * s * s), eigen_tolerance,
                    "λ" + std::to_string(j));
    EXPECT_EQ(r.modes[static_cast<std::size_t>(j - 1)].kind, ModeKind::oscillatory);
    // The error estimate bounds the actual error.
    EXPECT_LE(std::abs(r.modes[static_cast<std::size_t>(j - 1)].omega2 - static_cast<double>(4 * s * s)),
              r.modes[static_cast<std::size_t>(j - 1)].error_estimate);
  }
  expect_valid_modes(r, K, M);
  // The first shape: sqrt(2/(n+1)) sin(iπ/(n+1)), all positive.
  const VectorX phi = r.modes[0].shape.real();
  double worst = 0;
  for (int i = 0; i < n; ++i)
    worst = std::max(worst, std::abs(phi(i) - std::sqrt(2.0 / (n + 1)) *
                                                  std::sin((i + 1) * std::numbers::pi / (n + 1))));
  EXPECT_LE(worst, 1e-8);
  EXPECT_EQ(r.stability, Stability::stable);
  EXPECT_EQ(r.morse_index, 0);
  EXPECT_EQ(r.zero_modes, 0);
  EXPECT_NE(r.solver.find("shift-invert Lanczos"), std::string::npos) << r.solver;
  EXPECT_NE(r.solver.find("CHOLMOD"), std::string::npos) << r.solver;
  EXPECT_NEAR(r.modes[0].omega, std::sqrt(r.modes[0].omega2), 1e-15);
}

// A random sparse symmetric positive definite pencil (M not diagonal).
void random_pencil(int n, unsigned seed, SparseMatrix& K, SparseMatrix& M) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), pos(0.1, 1.0);
  std::uniform_int_distribution<int> pick(0, n - 1);
  Triplets tk, tm;
  VectorX rowK = VectorX::Zero(n), rowM = VectorX::Zero(n);
  for (int i = 0; i < n; ++i)
    for (int e = 0; e < 3; ++e) {
      const int j = pick(rng);
      if (j == i) continue;
      const double a = u(rng), b = 0.2 * u(rng);
      tk.emplace_back(i, j, a);
      tk.emplace_back(j, i, a);
      tm.emplace_back(i, j, b);
      tm.emplace_back(j, i, b);
      rowK(i) += std::abs(a), rowK(j) += std::abs(a);
      rowM(i) += std::abs(b), rowM(j) += std::abs(b);
    }
  for (int i = 0; i < n; ++i) {
    tk.emplace_back(i, i, rowK(i) + pos(rng));
    tm.emplace_back(i, i, rowM(i) + 1.0 + pos(rng));
  }
  K = from_triplets(n, tk);
  M = from_triplets(n, tm);
}

// The estimates' matrices as a library caller may pass them: filled by
// insert() and not compressed (Eigen keeps gaps in the value array then).
// solve_sparse_modes scales its copies' values as one array (valuePtr,
// nonZeros), which is right because a copy is compressed; the modes and
// estimates must be those of the same matrices compressed.
TEST(SparseModes, UncompressedErrorMatricesGiveTheSameEstimates) {
  for (const int n : {150, 400}) {  // the dense fallback and the Lanczos path
    SparseMatrix K, M;
    random_pencil(n, 77u + static_cast<unsigned>(n), K, M);
    K *= 1e12;  // far from 1, so that the solver scales K and the estimates' matrices by a power of two
    modal::SparseModalOptions loose = options(6), packed = options(6);
    // Filled in place (a copy-assignment would compress them).
    SparseMatrix& magnitude = loose.K_magnitude;
    SparseMatrix& systematic = loose.K_systematic_error;
    magnitude.resize(n, n);
    systematic.resize(n, n);
    magnitude.reserve(Eigen::VectorXi::Constant(n, 8));
    systematic.reserve(Eigen::VectorXi::Constant(n, 8));
    for (Eigen::Index c = 0; c < K.outerSize(); ++c)
      for (SparseMatrix::InnerIterator it(K, c); it; ++it) {
        magnitude.insert(it.row(), c) = 3 * std::abs(it.value());
        systematic.insert(it.row(), c) = 1e-9 * std::abs(it.value());
      }
    ASSERT_FALSE(magnitude.isCompressed());
    ASSERT_FALSE(systematic.isCompressed());
    packed.K_magnitude = magnitude;  // compressed by the assignment
    packed.K_systematic_error = systematic;
    ASSERT_TRUE(packed.K_magnitude.isCompressed());
    const ModalResult a = modal::solve_sparse_modes(K, M, loose), b = modal::solve_sparse_modes(K, M, packed);
    ASSERT_EQ(a.modes.size(), b.modes.size());
    for (std::size_t j = 0; j < a.modes.size(); ++j) {
      EXPECT_EQ(a.modes[j].omega2, b.modes[j].omega2) << "n " << n << " mode " << j;
      EXPECT_EQ(a.modes[j].error_estimate, b.modes[j].error_estimate) << "n " << n << " mode " << j;
    }
  }
}

// (b) Agreement with solve_modes (dense) on a random sparse pencil, n = 300.
TEST(SparseModes, AgreesWithDenseSolver) {
  const int n = 300;
  SparseMatrix K, M;
  random_pencil(n, 12345u, K, M);
  const int k = 8;
  const ModalResult sparse = modal::solve_sparse_modes(K, M, options(k));
  EXPECT_NE(sparse.solver.find("shift-invert"), std::string::npos) << sparse.solver;

  LinearModel model;
  model.q = VectorX::Zero(n);
  model.M = MatrixX(M);
  model.K = MatrixX(K);
  const ModalResult dense = modal::solve_modes(model);
  ASSERT_EQ(sparse.modes.size(), static_cast<std::size_t>(k));
  for (std::size_t j = 0; j < sparse.modes.size(); ++j) {
    expect_relative(sparse.modes[j].omega2, dense.modes[j].omega2, eigen_tolerance, "λ" + std::to_string(j + 1));
    const VectorX a = sparse.modes[j].shape.real(), b = dense.modes[j].shape.real();
    EXPECT_LE(std::min((a - b).norm(), (a + b).norm()), 1e-8) << "shape " << j + 1;
  }
  expect_valid_modes(sparse, K, M);
  EXPECT_EQ(sparse.stability, Stability::stable);
  EXPECT_EQ(sparse.morse_index, 0);
}

// (c) Free–free chain: the rigid translation is a zero mode; marginal.
TEST(SparseModes, FreeFreeChainZeroMode) {
  const int n = 500;
  const SparseMatrix K = chain_stiffness(n, false), M = identity(n);
  const ModalResult r = modal::solve_sparse_modes(K, M, options(4));
  ASSERT_EQ(r.modes.size(), 4u);
  EXPECT_EQ(r.modes[0].kind, ModeKind::zero);
  EXPECT_LE(std::abs(r.modes[0].omega2), 1e-12);
  EXPECT_LE((r.modes[0].shape.real() - VectorX::Constant(n, 1 / std::sqrt(double(n)))).cwiseAbs().maxCoeff(), 1e-10);
  for (int j = 1; j < 4; ++j) {
    const Long s = std::sin(static_cast<Long>(j) * std::numbers::pi_v<Long> / (2 * static_cast<Long>(n)));
    expect_relative(r.modes[static_cast<std::size_t>(j)].omega2, static_cast<double>(4 * s * s), eigen_tolerance,
                    "λ" + std::to_string(j));
    EXPECT_EQ(r.modes[static_cast<std::size_t>(j)].kind, ModeKind::oscillatory);
  }
  expect_valid_modes(r, K, M);
  EXPECT_EQ(r.zero_modes, 1);
  EXPECT_EQ(r.morse_index, 0);
  EXPECT_EQ(r.stability, Stability::marginal);
}

// Masses 1 + 0.5 sin(i): a non-uniform diagonal M.
SparseMatrix uneven_masses(int n) {
  Triplets t;
  for (int i = 0; i < n; ++i) t.emplace_back(i, i, 1.0 + 0.5 * std::sin(static_cast<double>(i)));
  return from_triplets(n, t);
}

// (d) Three negative eigenvalues (softened springs to ground at three sites):
// returned first, morse_index 3, divergence; with k = 2 the two most negative,
// morse_index still 3.
TEST(SparseModes, NegativeModesReturnedFirst) {
  const int n = 400;
  const SparseMatrix K = chain_stiffness(n, true, {{100, -3.0}, {200, -4.0}, {300, -5.0}});
  const SparseMatrix M = uneven_masses(n);
  const VectorX reference = dense_eigenvalues(K, M);
  ASSERT_LT(reference(2), 0.0);
  ASSERT_GT(reference(3), 0.0);

  const ModalResult r = modal::solve_sparse_modes(K, M, options(10));
  ASSERT_EQ(r.modes.size(), 10u);
  for (std::size_t j = 0; j < 10; ++j) {
    expect_relative(r.modes[j].omega2, reference(static_cast<Eigen::Index>(j)), eigen_tolerance,
                    "λ" + std::to_string(j + 1));
    EXPECT_EQ(r.modes[j].kind, j < 3 ? ModeKind::divergent : ModeKind::oscillatory) << j;
  }
  expect_valid_modes(r, K, M);
  EXPECT_EQ(r.morse_index, 3);
  EXPECT_EQ(r.stability, Stability::divergence);
  EXPECT_GT(r.modes[0].growth_rate, 0.0);
  EXPECT_NEAR(r.modes[0].growth_rate, std::sqrt(-reference(0)), 1e-10);

  for (int k : {2, 3}) {
    const ModalResult few = modal::solve_sparse_modes(K, M, options(k));
    ASSERT_EQ(few.modes.size(), static_cast<std::size_t>(k));
    for (std::size_t j = 0; j < few.modes.size(); ++j) {
      expect_relative(few.modes[j].omega2, reference(static_cast<Eigen::Index>(j)), eigen_tolerance,
                      "k = " + std::to_string(k) + ": λ" + std::to_string(j + 1));
      EXPECT_EQ(few.modes[j].kind, ModeKind::divergent);
    }
    expect_valid_modes(few, K, M);
    EXPECT_EQ(few.morse_index, 3) << "k = " << k;
    EXPECT_EQ(few.stability, Stability::divergence);
  }
}

// A negative eigenvalue close to zero, among the k nearest the default shift:
// found by the first run alone.
TEST(SparseModes, SmallNegativeEigenvalue) {
  const int n = 400;
  const SparseMatrix K = chain_stiffness(n, true, {{200, -0.05}});
  const SparseMatrix M = identity(n);
  const VectorX reference = dense_eigenvalues(K, M);
  ASSERT_LT(reference(0), 0.0);
  ASSERT_GT(reference(1), 0.0);
  const ModalResult r = modal::solve_sparse_modes(K, M, options(6));
  ASSERT_EQ(r.modes.size(), 6u);
  for (std::size_t j = 0; j < 6; ++j)
    expect_relative(r.modes[j].omega2, reference(static_cast<Eigen::Index>(j)), eigen_tolerance,
                    "λ" + std::to_string(j + 1));
  EXPECT_EQ(r.modes[0].kind, ModeKind::divergent);
  expect_valid_modes(r, K, M);
  EXPECT_EQ(r.morse_index, 1);
  EXPECT_EQ(r.stability, Stability::divergence);
}

// (e) A shift in the middle of the spectrum: the k eigenvalues nearest it.
TEST(SparseModes, UserShiftReturnsNearestEigenvalues) {
  const int n = 2000;
  const SparseMatrix K = chain_stiffness(n, true), M = identity(n);
  const double sigma = 1.9;
  const int k = 6;
  std::vector<double> exact;
  for (int j = 1; j <= n; ++j) {
    const Long s = std::sin(static_cast<Long>(j) * std::numbers::pi_v<Long> / (2 * static_cast<Long>(n + 1)));
    exact.push_back(static_cast<double>(4 * s * s));
  }
  const auto below = std::count_if(exact.begin(), exact.end(), [&](double l) { return l < sigma; });
  std::vector<double> nearest = exact;
  std::sort(nearest.begin(), nearest.end(),
            [&](double a, double b) { return std::abs(a - sigma) < std::abs(b - sigma); });
  nearest.resize(k);
  std::sort(nearest.begin(), nearest.end());

  const ModalResult r = modal::solve_sparse_modes(K, M, options(k, sigma));
  ASSERT_EQ(r.modes.size(), static_cast<std::size_t>(k));
  for (std::size_t j = 0; j < nearest.size(); ++j)
    expect_relative(r.modes[j].omega2, nearest[j], eigen_tolerance, "λ near σ #" + std::to_string(j + 1));
  expect_valid_modes(r, K, M);
  EXPECT_EQ(r.morse_index, 0);
  EXPECT_EQ(r.stability, Stability::stable);
  const std::string expected_note = std::to_string(below) + " eigenvalues lie below σ";
  EXPECT_TRUE(std::any_of(r.notes.begin(), r.notes.end(),
                          [&](const std::string& note) { return note.find(expected_note) != std::string::npos; }))
      << "expected a note containing \"" << expected_note << "\"";
}

// A user shift exactly at an eigenvalue (0, the free chain's translation):
// the factorization of the singular K − σM is handled, the zero mode found.
TEST(SparseModes, UserShiftAtZeroOfFreeChain) {
  const int n = 400;
  const SparseMatrix K = chain_stiffness(n, false), M = identity(n);
  const ModalResult r = modal::solve_sparse_modes(K, M, options(3, 0.0));
  ASSERT_EQ(r.modes.size(), 3u);
  EXPECT_EQ(r.modes[0].kind, ModeKind::zero);
  for (int j = 1; j < 3; ++j) {
    const Long s = std::sin(static_cast<Long>(j) * std::numbers::pi_v<Long> / (2 * static_cast<Long>(n)));
    expect_relative(r.modes[static_cast<std::size_t>(j)].omega2, static_cast<double>(4 * s * s), eigen_tolerance,
                    "λ" + std::to_string(j));
  }
  expect_valid_modes(r, K, M);
  EXPECT_EQ(r.stability, Stability::marginal);
  EXPECT_EQ(r.morse_index, 0);
}

// A user shift high in the spectrum of the free chain: the zero mode is not
// among the returned ones, but the stability class still sees it.
TEST(SparseModes, UserShiftStillSeesUnreturnedZeroMode) {
  const int n = 400;
  const SparseMatrix K = chain_stiffness(n, false), M = identity(n);
  const ModalResult r = modal::solve_sparse_modes(K, M, options(3, 3.0));
  ASSERT_EQ(r.modes.size(), 3u);
  for (const auto& mode : r.modes) EXPECT_EQ(mode.kind, ModeKind::oscillatory);
  EXPECT_EQ(r.zero_modes, 0);
  EXPECT_EQ(r.stability, Stability::marginal);
}

// A 3-D grid of unit masses and springs (Dirichlet boundary), 9×8×7: dense
// enough fill that CHOLMOD takes its supernodal LLᵀ, which fails for an
// indefinite K − σM (the inertia then comes from the simplicial LDLᵀ).
// Eigenvalues Σ_d 4 sin²(j_d π/(2(N_d + 1))), all distinct here.
struct Grid {
  std::array<int, 3> N{9, 8, 7};
  int size() const { return N[0] * N[1] * N[2]; }
  SparseMatrix stiffness(const std::vector<std::pair<int, double>>& diagonal_shift = {}) const {
    Triplets t;
    for (int i = 0; i < size(); ++i) {
      t.emplace_back(i, i, 6.0);
      int stride = 1;
      for (int d = 0; d < 3; ++d) {
        if ((i / stride) % N[static_cast<std::size_t>(d)] + 1 < N[static_cast<std::size_t>(d)]) {
          t.emplace_back(i, i + stride, -1.0);
          t.emplace_back(i + stride, i, -1.0);
        }
        stride *= N[static_cast<std::size_t>(d)];
      }
    }
    for (auto [i, sh] : diagonal_shift) t.emplace_back(i, i, sh);
    return from_triplets(size(), t);
  }
  std::vector<double> eigenvalues() const {  // ascending
    std::vector<double> values;
    auto term = [&](int j, int d) {
      const Long s = std::sin(static_cast<Long>(j) * std::numbers::pi_v<Long> /
                              (2 * static_cast<Long>(N[static_cast<std::size_t>(d)] + 1)));
      return 4 * s * s;
    };
    for (int a = 1; a <= N[0]; ++a)
      for (int b = 1; b <= N[1]; ++b)
        for (int c = 1; c <= N[2]; ++c) values.push_back(static_cast<double>(term(a, 0) + term(b, 1) + term(c, 2)));
    std::sort(values.begin(), values.end());
    return values;
  }
};

TEST(SparseModes, GridSupernodalPaths) {
  const Grid grid;
  const int n = grid.size();
  const SparseMatrix K = grid.stiffness(), M = identity(n);
  const std::vector<double> exact = grid.eigenvalues();

  // Lowest modes: supernodal LLᵀ at the default shift.
  const ModalResult low = modal::solve_sparse_modes(K, M, options(6));
  EXPECT_NE(low.solver.find("supernodal"), std::string::npos) << low.solver;
  // The completeness check counted the eigenvalues below the 6th by MUMPS's LDLᵀ.
  const auto below_sixth = std::count_if(exact.begin(), exact.end(), [&](double l) { return l < exact[5] - 1e-6; });
  EXPECT_TRUE(std::any_of(low.notes.begin(), low.notes.end(), [&](const std::string& note) {
    return note.find("exactly " + std::to_string(below_sixth) + " eigenvalues lie below it") != std::string::npos;
  })) << "expected the completeness note";
  ASSERT_EQ(low.modes.size(), 6u);
  for (std::size_t j = 0; j < 6; ++j)
    expect_relative(low.modes[j].omega2, exact[j], eigen_tolerance, "λ" + std::to_string(j + 1));
  expect_valid_modes(low, K, M);
  EXPECT_EQ(low.stability, Stability::stable);

  // A shift inside the spectrum: the supernodal LLᵀ fails, LDLᵀ counts.
  const double sigma = 5.55;
  const ModalResult mid = modal::solve_sparse_modes(K, M, options(5, sigma));
  std::vector<double> nearest = exact;
  std::sort(nearest.begin(), nearest.end(),
            [&](double a, double b) { return std::abs(a - sigma) < std::abs(b - sigma); });
  nearest.resize(5);
  std::sort(nearest.begin(), nearest.end());
  ASSERT_EQ(mid.modes.size(), 5u);
  EXPECT_NE(mid.solver.find("MUMPS LDLᵀ with pivoting"), std::string::npos) << mid.solver;
  for (std::size_t j = 0; j < 5; ++j)
    expect_relative(mid.modes[j].omega2, nearest[j], eigen_tolerance, "λ near σ #" + std::to_string(j + 1));
  expect_valid_modes(mid, K, M);
  const auto below = std::count_if(exact.begin(), exact.end(), [&](double l) { return l < sigma; });
  const std::string expected_note = std::to_string(below) + " eigenvalues lie below σ";
  EXPECT_TRUE(std::any_of(mid.notes.begin(), mid.notes.end(),
                          [&](const std::string& note) { return note.find(expected_note) != std::string::npos; }))
      << "expected a note containing \"" << expected_note << "\"";

  // Two negative eigenvalues (softened sites): both phases of the default shift.
  const SparseMatrix Kd = grid.stiffness({{n / 2, -8.0}, {n / 3, -10.0}});
  const VectorX reference = dense_eigenvalues(Kd, M);
  ASSERT_LT(reference(1), 0.0);
  ASSERT_GT(reference(2), 0.0);
  const ModalResult d = modal::solve_sparse_modes(Kd, M, options(5));
  ASSERT_EQ(d.modes.size(), 5u);
  for (std::size_t j = 0; j < 5; ++j)
    expect_relative(d.modes[j].omega2, reference(static_cast<Eigen::Index>(j)), eigen_tolerance,
                    "λ" + std::to_string(j + 1));
  expect_valid_modes(d, Kd, M);
  EXPECT_EQ(d.morse_index, 2);
  EXPECT_EQ(d.stability, Stability::divergence);
}

// A given fill-reducing order (SparseModalOptions::fill_reducing_order): any
// permutation gives the same modes, including the MUMPS completeness check
// that reuses it; something that is not a permutation is ignored.
TEST(SparseModes, GivenFillReducingOrder) {
  const Grid grid;
  const int n = grid.size();
  const SparseMatrix K = grid.stiffness(), M = identity(n);
  const std::vector<double> exact = grid.eigenvalues();
  std::vector<int> reversed(static_cast<std::size_t>(n));
  std::iota(reversed.rbegin(), reversed.rend(), 0);  // a poor order, but a valid one
  std::vector<int> duplicate = reversed;
  duplicate[0] = duplicate[1];
  for (const std::vector<int>& order : {reversed, duplicate, std::vector<int>{0, 1, 2}}) {
    SparseModalOptions o = options(6);
    o.fill_reducing_order = order;
    const ModalResult r = modal::solve_sparse_modes(K, M, o);
    ASSERT_EQ(r.modes.size(), 6u);
    for (std::size_t j = 0; j < 6; ++j)
      expect_relative(r.modes[j].omega2, exact[j], eigen_tolerance, "λ" + std::to_string(j + 1));
    expect_valid_modes(r, K, M);
    EXPECT_TRUE(std::any_of(r.notes.begin(), r.notes.end(), [](const std::string& note) {
      return note.find("completeness checked") != std::string::npos;
    }));
  }
}

// End to end on a sagging net of 1200 coordinates (the large-scene
// equilibrium): the equilibrium hands over the pivot order of its Hessian's
// analysis, and the modes with it equal the modes without it.
TEST(SparseModes, EquilibriumHandsOverItsOrdering) {
  const modal::Scene scene = modal::parse_scene(
      "gravity = [0, 0, -9.81]\n[[lattice]]\nname = \"net\"\nsize = [22, 22, 1]\nspacing = 0.1\nmass = 0.002\n"
      "stiffness = 1000\nprestrain = 0.02\nfixed = \"boundary\"\n",
      "net.toml");
  const modal::System system = modal::build_system(scene);
  ASSERT_EQ(system.size(), 1200);
  const modal::Equilibrium eq = modal::find_equilibrium(system, system.initial_configuration());
  EXPECT_NE(eq.method.find("truncated Newton"), std::string::npos) << eq.method;
  std::vector<int> sorted = eq.fill_reducing_order;
  std::sort(sorted.begin(), sorted.end());
  std::vector<int> identity_order(1200);
  std::iota(identity_order.begin(), identity_order.end(), 0);
  EXPECT_EQ(sorted, identity_order);  // a permutation of the coordinates
  const modal::SparseLinearModel lin = modal::linearize_sparse(system, eq.q);
  SparseModalOptions with = options(8);
  with.fill_reducing_order = eq.fill_reducing_order;
  const ModalResult a = modal::solve_sparse_modes(lin.K, lin.M, with), b = modal::solve_sparse_modes(lin.K, lin.M, options(8));
  ASSERT_EQ(a.modes.size(), 8u);
  ASSERT_EQ(b.modes.size(), 8u);
  for (std::size_t j = 0; j < 8; ++j) expect_relative(a.modes[j].omega2, b.modes[j].omega2, 1e-10, "λ" + std::to_string(j + 1));
  expect_valid_modes(a, lin.K, lin.M);
}

// Small problems go to the dense solver, with the same conventions.
TEST(SparseModes, SmallProblemsUseTheDenseSolver) {
  const int n = 50;
  const SparseMatrix K = chain_stiffness(n, true), M = identity(n);
  const ModalResult r = modal::solve_sparse_modes(K, M, options(5));
  ASSERT_EQ(r.modes.size(), 5u);
  EXPECT_NE(r.solver.find("dense"), std::string::npos) << r.solver;
  for (int j = 1; j <= 5; ++j) {
    const Long s = std::sin(static_cast<Long>(j) * std::numbers::pi_v<Long> / (2 * static_cast<Long>(n + 1)));
    expect_relative(r.modes[static_cast<std::size_t>(j - 1)].omega2, static_cast<double>(4 * s * s), 1e-12,
                    "λ" + std::to_string(j));
  }
  expect_valid_modes(r, K, M);
  EXPECT_EQ(r.stability, Stability::stable);

  const SparseMatrix Kn = chain_stiffness(n, true, {{25, -3.0}});
  const ModalResult d = modal::solve_sparse_modes(Kn, M, options(1));
  ASSERT_EQ(d.modes.size(), 1u);
  EXPECT_EQ(d.morse_index, 1);
  EXPECT_EQ(d.stability, Stability::divergence);
}

// Matrices in Eigen's uncompressed mode (built by insert) and with only the
// structure differing between K and M give the same result as compressed ones.
TEST(SparseModes, UncompressedInput) {
  const int n = 300;
  SparseMatrix K(n, n), M(n, n);
  K.reserve(Eigen::VectorXi::Constant(n, 4));
  M.reserve(Eigen::VectorXi::Constant(n, 2));
  for (int i = 0; i < n; ++i) {
    K.insert(i, i) = 2.0;
    if (i + 1 < n) {
      K.insert(i, i + 1) = -1.0;
      K.insert(i + 1, i) = -1.0;
    }
    M.insert(i, i) = 1.0;
  }
  ASSERT_FALSE(K.isCompressed());
  const ModalResult r = modal::solve_sparse_modes(K, M, options(3));
  ASSERT_EQ(r.modes.size(), 3u);
  for (int j = 1; j <= 3; ++j) {
    const Long s = std::sin(static_cast<Long>(j) * std::numbers::pi_v<Long> / (2 * static_cast<Long>(n + 1)));
    expect_relative(r.modes[static_cast<std::size_t>(j - 1)].omega2, static_cast<double>(4 * s * s), eigen_tolerance,
                    "λ" + std::to_string(j));
  }
}

// (f) Errors: singular M, k < 1, sizes, non-finite entries.
TEST(SparseModes, Errors) {
  const int n = 300;
  const SparseMatrix K = chain_stiffness(n, true);
  SparseMatrix M = identity(n);
  M.coeffRef(41, 41) = 0.0;
  EXPECT_THROW(modal::solve_sparse_modes(K, M, options(4)), modal::SingularMassMatrix);
  try {
    modal::solve_sparse_modes(K, M, options(4));
  } catch (const modal::SingularMassMatrix& e) {
    EXPECT_NE(std::string(e.what()).find("q42"), std::string::npos) << e.what();
  }
  // Singular without a zero diagonal entry: two coordinates sharing one mass.
  Triplets t;
  for (int i = 0; i < n; ++i)
    if (i != 10 && i != 11) t.emplace_back(i, i, 1.0);
  for (int i : {10, 11})
    for (int j : {10, 11}) t.emplace_back(i, j, 1.0);
  EXPECT_THROW(modal::solve_sparse_modes(K, from_triplets(n, t), options(4)), modal::SingularMassMatrix);
  // Dense fallback: the same error type.
  SparseMatrix Ms = identity(20);
  Ms.coeffRef(3, 3) = 0.0;
  EXPECT_THROW(modal::solve_sparse_modes(chain_stiffness(20, true), Ms, options(2)), modal::SingularMassMatrix);

  EXPECT_THROW(modal::solve_sparse_modes(K, identity(n), options(0)), std::invalid_argument);
  EXPECT_THROW(modal::solve_sparse_modes(K, identity(n), options(-3)), std::invalid_argument);
  EXPECT_THROW(modal::solve_sparse_modes(K, identity(n + 1), options(2)), std::invalid_argument);
  EXPECT_THROW(modal::solve_sparse_modes(K, identity(n), options(2, std::nullopt, 0.0)), std::invalid_argument);
  SparseMatrix Kbad = K;
  Kbad.coeffRef(5, 5) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(modal::solve_sparse_modes(Kbad, identity(n), options(2)), modal::NumericalError);
  SparseMatrix Kasym = K;
  Kasym.coeffRef(5, 6) = 0.5;
  EXPECT_THROW(modal::solve_sparse_modes(Kasym, identity(n), options(2)), std::invalid_argument);
}

}  // namespace

namespace {

// c disjoint free–free chains (sizes in `sizes`): exactly c zero modes.
SparseMatrix free_chains(const std::vector<int>& sizes) {
  Triplets t;
  int offset = 0;
  for (const int n : sizes) {
    const SparseMatrix K = chain_stiffness(n, false);
    for (int j = 0; j < K.outerSize(); ++j)
      for (SparseMatrix::InnerIterator it(K, j); it; ++it)
        t.emplace_back(offset + static_cast<int>(it.row()), offset + static_cast<int>(it.col()), it.value());
    offset += n;
  }
  return from_triplets(offset, t);
}

}  // namespace

// The class verdict counts every zero mode from the inertia, not only the
// modes asked for: c free bodies (disjoint free–free chains, c = 2 … 7, random
// sizes, Lanczos path) have c zero modes whatever --modes is, 1 to c + 1.
TEST(SparseModes, ZeroModesAreCountedBeyondTheRequestedModes) {
  std::mt19937 rng(20261125);
  for (int c = 2; c <= 7; ++c) {
    std::vector<int> sizes;
    int n = 0;
    for (int i = 0; i < c; ++i) {
      sizes.push_back(std::uniform_int_distribution<int>(20, 120)(rng));
      n += sizes.back();
    }
    if (n <= 200) sizes.back() += 201 - n;  // the Lanczos path (n > 200)
    const SparseMatrix K = free_chains(sizes), M = identity(static_cast<int>(K.rows()));
    for (int k = 1; k <= c + 1; ++k) {
      const ModalResult r = modal::solve_sparse_modes(K, M, options(k));
      EXPECT_EQ(r.zero_modes, c) << c << " chains, --modes " << k;
      EXPECT_EQ(r.stability, Stability::marginal) << c << " chains, --modes " << k;
      EXPECT_EQ(r.morse_index, 0);
    }
  }
  // The dense fallback (n ≤ 200) counts all of them too.
  const SparseMatrix K = free_chains({30, 40, 50}), M = identity(120);
  for (int k = 1; k <= 4; ++k) EXPECT_EQ(modal::solve_sparse_modes(K, M, options(k)).zero_modes, 3) << k;
}

// Magnitudes at the ends of the double range: the fixed–fixed chain with K
// and M multiplied by 10^a and 10^b (λ = 10^(a−b) × 4 sin²(jπ/(2(n+1)))) is
// answered within its estimate, oscillatory, or refused as a numerical
// failure (λ beyond the range) — never a zero mode from an overflowed
// estimate (ω² = 1e160 was "marginal").
TEST(SparseModes, HugeAndTinyMagnitudesAreRightOrRefused) {
  const int n = 300;
  for (const int a : {-300, -200, -150, -60, 0, 60, 150, 160, 200, 300})
    for (const int b : {-200, -100, 0, 100, 200}) {
      const Long ka = std::pow(Long(10), a), mb = std::pow(Long(10), b);
      const SparseMatrix K = chain_stiffness(n, true) * static_cast<double>(ka);
      const SparseMatrix M = identity(n) * static_cast<double>(mb);
      const std::string what = "K × 1e" + std::to_string(a) + ", M × 1e" + std::to_string(b);
      if (!std::isfinite(static_cast<double>(ka)) || static_cast<double>(ka) == 0 || static_cast<double>(mb) == 0)
        continue;
      try {
        const ModalResult r = modal::solve_sparse_modes(K, M, options(4));
        ASSERT_EQ(r.modes.size(), 4u) << what;
        EXPECT_EQ(r.stability, Stability::stable) << what;
        for (int j = 1; j <= 4; ++j) {
          const Long s = std::sin(static_cast<Long>(j) * std::numbers::pi_v<Long> / (2 * static_cast<Long>(n + 1)));
          const Long exact = 4 * s * s * ka / mb;
          const auto& mode = r.modes[static_cast<std::size_t>(j - 1)];
          EXPECT_EQ(mode.kind, ModeKind::oscillatory) << what << " mode " << j;
          EXPECT_LE(std::abs(static_cast<Long>(mode.omega2) - exact), static_cast<Long>(mode.error_estimate))
              << what << " mode " << j << ": " << mode.omega2 << " vs " << static_cast<double>(exact);
        }
      } catch (const modal::NumericalError& e) {
        // Only where λ itself leaves the range of double precision or
        // its scale underflows (λ₁ ≈ 1e-4 × 10^(a−b)).
        EXPECT_TRUE(a - b > 300 || a - b < -300) << what << ": " << e.what();
      }
    }
}

// The completeness rule (modal::check_completeness) against a solver that is
// made to skip one copy of a double eigenvalue, and an exact inertia count
// of the same spectrum: the rule must repeat the run until the count
// agrees, say "incomplete" when the solver never returns the copy, and not
// check when the k-th eigenvalue is zero.
TEST(SparseModes, CompletenessRuleRepeatsARunThatSkippedACopy) {
  const std::vector<double> spectrum = {1.0, 2.0, 3.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0};
  const long n = static_cast<long>(spectrum.size());
  const double zeta = 1e-12;
  auto exact_count = [&](double& b, bool) {
    return static_cast<long>(std::count_if(spectrum.begin(), spectrum.end(), [&](double l) { return l < b; }));
  };
  // The nev lowest, but the second copy of 3 only once nev ≥ min_for_copy.
  auto skipping = [&](long min_for_copy) {
    return [&spectrum, min_for_copy](long nev) {
      std::vector<double> out;
      for (std::size_t j = 0; j < spectrum.size() && static_cast<long>(out.size()) < nev; ++j)
        if (!(j == 3 && nev < min_for_copy)) out.push_back(spectrum[j]);
      return out;
    };
  };
  std::vector<long> wanted;
  auto recording = [&](long min_for_copy) {
    return [&wanted, inner = skipping(min_for_copy)](long nev) {
      wanted.push_back(nev);
      return inner(nev);
    };
  };

  // k = 4: the first run returns 1, 2, 3, 4 (below b, just below 4, the
  // inertia counts 4 and the run found 3); the second (nev = 4 + 1 + 2 = 7)
  // returns 1, 2, 3, 3, …, whose 4th is the copy of 3: just below it 2 and 2.
  modal::CompletenessCheck c = modal::check_completeness(4, n, -zeta, zeta, recording(5), exact_count);
  EXPECT_EQ(c.outcome, modal::CompletenessCheck::Outcome::complete);
  EXPECT_EQ(wanted, (std::vector<long>{4, 7}));
  EXPECT_EQ(c.count, 2);
  EXPECT_EQ(c.found, 2);
  EXPECT_LT(c.bound, 3.0);  // just below the 4th returned eigenvalue, the copy of 3
  EXPECT_GT(c.bound, 3.0 - 1e-5);
  EXPECT_NE(modal::completeness_note(c, "b", "the iteration").find("exactly 2 eigenvalues lie below it"),
            std::string::npos);

  // A solver that never returns the copy: after the repeats, incomplete.
  wanted.clear();
  c = modal::check_completeness(4, n, -zeta, zeta, recording(1000), exact_count);
  EXPECT_EQ(c.outcome, modal::CompletenessCheck::Outcome::incomplete);
  EXPECT_GT(c.count, c.found);
  EXPECT_LE(wanted.back(), n - 2);
  EXPECT_NE(modal::completeness_note(c, "b", "the iteration").find("may be missing"), std::string::npos);

  // No skipping: complete at once, one run.
  wanted.clear();
  c = modal::check_completeness(6, n, -zeta, zeta, recording(0), exact_count);
  EXPECT_EQ(c.outcome, modal::CompletenessCheck::Outcome::complete);
  EXPECT_EQ(wanted.size(), 1u);

  // The k-th eigenvalue zero: nothing to check.
  c = modal::check_completeness(1, n, -zeta, zeta, [](long) { return std::vector<double>{0.0}; }, exact_count);
  EXPECT_EQ(c.outcome, modal::CompletenessCheck::Outcome::not_needed);
  EXPECT_TRUE(modal::completeness_note(c, "b", "the iteration").empty());
}

// MUMPS's LDLᵀ (the inertia and the estimates' solves with the factor at b)
// with several right-hand sides at once, as the estimates use it: on
// indefinite 2-D Laplacians shifted into their spectrum (random sizes and
// shifts, random right-hand sides), every column against its own one-vector
// solve and against the residual ‖AY − X‖ ≤ 1e-10 ‖A‖₁‖Y‖ (a backward-stable
// solve).
TEST(SparseModes, MumpsSolvesSeveralRightHandSidesAsOneAtATime) {
  std::mt19937 rng(1127);
  for (int trial = 0; trial < 6; ++trial) {
    const int a = std::uniform_int_distribution<int>(5, 40)(rng), b = std::uniform_int_distribution<int>(5, 40)(rng);
    const int n = a * b;
    std::vector<Eigen::Triplet<double>> t;
    auto index = [a](int i, int j) { return i + a * j; };
    // The Laplacian's eigenvalues 4 − 2cos(πp/(a + 1)) − 2cos(πq/(b + 1)): a
    // shift at least 0.01 from each (the condition at most 800 relative to ‖A‖).
    double shift = 0, nearest = 0;
    do {
      shift = std::uniform_real_distribution<double>(0.5, 7.5)(rng);
      nearest = std::numeric_limits<double>::infinity();
      for (int p = 1; p <= a; ++p)
        for (int q = 1; q <= b; ++q)
          nearest = std::min(nearest, std::abs(4 - 2 * std::cos(std::numbers::pi * p / (a + 1)) -
                                               2 * std::cos(std::numbers::pi * q / (b + 1)) - shift));
    } while (nearest < 0.01);
    for (int j = 0; j < b; ++j)
      for (int i = 0; i < a; ++i) {
        t.emplace_back(index(i, j), index(i, j), 4.0 - shift);
        if (i + 1 < a) {
          t.emplace_back(index(i, j), index(i + 1, j), -1.0);
          t.emplace_back(index(i + 1, j), index(i, j), -1.0);
        }
        if (j + 1 < b) {
          t.emplace_back(index(i, j), index(i, j + 1), -1.0);
          t.emplace_back(index(i, j + 1), index(i, j), -1.0);
        }
      }
    modal::SparseMatrix A(n, n);
    A.setFromTriplets(t.begin(), t.end());
    A.makeCompressed();
    modal::detail::MumpsLdlt ldlt(A, {});
    ASSERT_TRUE(ldlt.factor(A).has_value());
    const int columns = std::uniform_int_distribution<int>(2, 9)(rng);
    modal::MatrixX X(n, columns), Y(n, columns);
    std::normal_distribution<double> normal;
    for (Eigen::Index k = 0; k < X.size(); ++k) X.data()[k] = normal(rng);
    ASSERT_TRUE(ldlt.solve(X.data(), Y.data(), columns));
    const double norm1 = 8.0 + std::abs(4.0 - shift);
    for (int c = 0; c < columns; ++c) {
      modal::VectorX y(n);
      ASSERT_TRUE(ldlt.solve(X.col(c).data(), y.data()));
      EXPECT_LE((Y.col(c) - y).norm(), 1e-12 * y.norm()) << a << "×" << b << " column " << c;
      EXPECT_LE((A * Y.col(c) - X.col(c)).norm(), 1e-10 * norm1 * Y.col(c).norm()) << a << "×" << b << " column " << c;
    }
  }
}

// A singular mass matrix is described in the coordinates' names on both sides
// of the dense limit (the dense fallback and the Lanczos path's CHOLMOD
// factor); they had been named q1 … qn, which no scene has.
TEST(SparseModes, SingularMassMatrixNamesTheSceneCoordinates) {
  for (const int n : {12, 400}) {
    Triplets m, k;
    for (int i = 0; i < n; ++i) {
      k.emplace_back(i, i, 1.0 + i);
      if (i != 5 && i != 6) m.emplace_back(i, i, 1.0);
    }
    for (const int i : {5, 6})  // (1, −1)/√2 has inertia 5e-16 of M's 2: none, to rounding
      for (const int j : {5, 6}) m.emplace_back(i, j, i == 6 && j == 6 ? 1.0 + 1e-15 : 1.0);
    SparseMatrix K(n, n), M(n, n);
    K.setFromTriplets(k.begin(), k.end());
    M.setFromTriplets(m.begin(), m.end());
    SparseModalOptions options;
    options.modes = 3;
    for (int i = 0; i < n; ++i) options.coordinate_names.push_back("link" + std::to_string(i));
    try {
      modal::solve_sparse_modes(K, M, options);
      ADD_FAILURE() << "expected SingularMassMatrix, n = " << n;
    } catch (const modal::SingularMassMatrix& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("0.71·link5 − 0.71·link6"), std::string::npos) << what;
      EXPECT_EQ(what.find("·q"), std::string::npos) << what;
    }
  }
}

namespace {

// The lower triangle of an n × n arrow matrix: 4n on the diagonal, 1 down the
// first column (diagonally dominant, so positive definite).
SparseMatrix arrow_matrix(int n) {
  std::vector<Eigen::Triplet<double>> entries;
  for (int i = 0; i < n; ++i) entries.emplace_back(i, i, 4.0 * n);
  for (int i = 1; i < n; ++i) entries.emplace_back(i, 0, 1.0);
  SparseMatrix A(n, n);
  A.setFromTriplets(entries.begin(), entries.end());
  return A;
}

}  // namespace

// A symbolic analysis that gives no factor is reported, not read: an arrow
// matrix (first column full) in its natural order fills to a dense factor of
// n(n + 1)/2 entries, past the 2³¹ − 1 of CHOLMOD's int indices at n = 66 000
// while A itself holds 3n entries (CHOLMOD_TOO_LARGE, as on a 3-D lattice of
// 10⁶ coordinates, where Eigen's factorize then read a null factor and the
// program died of a segmentation fault).
TEST(SparseModes, CholmodAnalysisBeyondItsIndicesIsATrueErrorNotACrash) {
  const int n = 66000;
  const SparseMatrix A = arrow_matrix(n);
  for (const bool compute : {false, true}) {
    modal::detail::CholmodAccess<Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower>> llt;
    llt.cholmod().nmethods = 1;
    llt.cholmod().method[0].ordering = CHOLMOD_NATURAL;
    try {
      if (compute) {
        llt.compute(A);
      } else {
        llt.analyzePattern(A);
        llt.factorize(A);
      }
      FAIL() << "no error";
    } catch (const modal::NumericalError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("66000 × 66000"), std::string::npos) << what;
      EXPECT_NE(what.find("more than 2³¹ − 1 entries"), std::string::npos) << what;
    }
  }
  // The same matrix in CHOLMOD's own order (AMD puts the full column last):
  // a factor of about 2n entries, solved.
  modal::detail::CholmodAccess<Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower>> llt;
  llt.compute(A);
  ASSERT_EQ(llt.info(), Eigen::Success);
  const VectorX b = VectorX::Ones(n);
  EXPECT_LT((A.selfadjointView<Eigen::Lower>() * VectorX(llt.solve(b)) - b).norm(), 1e-12 * b.norm());
}

// A factor larger than the memory it may take is refused by its symbolic
// analysis, before its numbers are allocated (OutOfMemory, exit status 4),
// with its true size: the arrow matrix above at n = 20 000 in its natural
// order fills to a dense factor of n(n + 1)/2 = 2.0e8 entries, which
// CHOLMOD's supernodal factor holds in one supernode of n² values (3.2 GB)
// and its simplicial one as values and row indices (2.4 GB), while A holds
// 3n entries. Without the check a factor the kernel lets the
// process reserve but cannot give ends it by the out-of-memory killer.
TEST(SparseModes, FactorBeyondTheMemoryLimitIsRefusedBeforeItIsAllocated) {
  const int n = 20000;
  const SparseMatrix A = arrow_matrix(n);
  const double dense_entries = 0.5 * n * (n + 1.0);
  const auto natural = [](auto& f) {
    f.cholmod().nmethods = 1;
    f.cholmod().method[0].ordering = CHOLMOD_NATURAL;
  };
  {
    modal::detail::CholmodAccess<Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower>> llt;
    natural(llt);
    llt.memory_limit = 1e12;  // not the machine's MemAvailable: CI's may be below 3.2 GB
    llt.analyzePattern(A);
    const double bytes = llt.factor_bytes();
    EXPECT_GE(bytes, 8 * dense_entries);
    EXPECT_LE(bytes, 8.0 * n * n + 1e6);
    llt.memory_limit = 1e9;
    try {
      llt.analyzePattern(A);
      FAIL() << "no error";
    } catch (const modal::OutOfMemory& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("20000 × 20000"), std::string::npos) << what;
      EXPECT_NE(what.find("(3.2 GB, with the"), std::string::npos) << what;
      EXPECT_NE(what.find("more than the 1 GB allowed"), std::string::npos) << what;
      EXPECT_NE(what.find("found before allocating"), std::string::npos) << what;
    }
    // Nor does a factorization follow the refused analysis.
    EXPECT_THROW(llt.factorize(A), modal::OutOfMemory);
  }
  {
    modal::detail::CholmodAccess<Eigen::CholmodDecomposition<SparseMatrix, Eigen::Lower>> ldlt;
    ldlt.setMode(Eigen::CholmodLDLt);
    natural(ldlt);
    ldlt.memory_limit = 2e9;  // the values alone fit; with the row indices they do not
    try {
      ldlt.analyzePattern(A);
      FAIL() << "no error";
    } catch (const modal::OutOfMemory& e) {
      EXPECT_NE(std::string(e.what()).find("(2.4 GB, with the"), std::string::npos) << e.what();
    }
  }
  // In CHOLMOD's own order the factor holds about 2n entries: within the
  // same limit, factored and solved.
  modal::detail::CholmodAccess<Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower>> llt;
  llt.memory_limit = 1e9;
  llt.compute(A);
  ASSERT_EQ(llt.info(), Eigen::Success);
  EXPECT_LT(llt.factor_bytes(), 1e3 * n);
  const VectorX b = VectorX::Ones(n);
  EXPECT_LT((A.selfadjointView<Eigen::Lower>() * VectorX(llt.solve(b)) - b).norm(), 1e-12 * b.norm());
}

namespace {

// A generated stiffness of a 2-D (layers = 1) or 3-D grid of nodes with 3
// coordinates each: a random positive definite 3×3 block per bond to the
// neighbours along each axis and the face diagonals, its size log-uniform
// over `decades` decades, every node held to the ground by 1e-3 of the
// smallest bond; then graded by a random diagonal congruence D A D, D
// log-uniform over `grading` decades. Symmetric (to the bit) positive
// definite.
SparseMatrix generated_grid(int nx, int ny, int layers, double decades, double grading, std::mt19937_64& random) {
  std::uniform_real_distribution<double> unit(-1, 1);
  const int nodes = nx * ny * layers, n = 3 * nodes;
  auto node = [&](int i, int j, int l) { return (l * ny + j) * nx + i; };
  Triplets entries;
  auto bond = [&](int a, int b) {
    Eigen::Matrix3d g;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) g(r, c) = unit(random);
    const Eigen::Matrix3d block = std::pow(10.0, 0.5 * decades * unit(random)) * (g * g.transpose() + 0.1 * Eigen::Matrix3d::Identity());
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        entries.emplace_back(3 * a + r, 3 * a + c, block(r, c));
        entries.emplace_back(3 * b + r, 3 * b + c, block(r, c));
        entries.emplace_back(3 * a + r, 3 * b + c, -block(r, c));
        entries.emplace_back(3 * b + r, 3 * a + c, -block(r, c));
      }
  };
  for (int l = 0; l < layers; ++l)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (i + 1 < nx) bond(node(i, j, l), node(i + 1, j, l));
        if (j + 1 < ny) bond(node(i, j, l), node(i, j + 1, l));
        if (i + 1 < nx && j + 1 < ny) bond(node(i, j, l), node(i + 1, j + 1, l));
        if (l + 1 < layers) bond(node(i, j, l), node(i, j, l + 1));
      }
  const double ground = 1e-3 * std::pow(10.0, -0.5 * decades);
  for (int k = 0; k < n; ++k) entries.emplace_back(k, k, ground);
  SparseMatrix A(n, n);
  A.setFromTriplets(entries.begin(), entries.end());
  VectorX d(n);
  for (int k = 0; k < n; ++k) d[k] = std::pow(10.0, 0.5 * grading * unit(random));
  A = d.asDiagonal() * A * d.asDiagonal();
  // Symmetric to the bit (the sums of the bonds' blocks into an entry and
  // its mirror came in different orders: 1e-12 apart where they cancel).
  A = 0.5 * (A + SparseMatrix(A.transpose()));
  A.makeCompressed();
  return A;
}

// The componentwise backward error of x as a solution of A x = b:
// max_i |b − A x|_i / (|A||x| + |b|)_i, the measure a stable Cholesky
// solve keeps to a modest multiple of ε whatever the grading.
double backward_error(const SparseMatrix& A, const VectorX& x, const VectorX& b) {
  const VectorX r = b - A * x;
  const VectorX size = A.cwiseAbs() * x.cwiseAbs() + b.cwiseAbs();
  double worst = 0;
  for (Eigen::Index i = 0; i < r.size(); ++i) worst = std::max(worst, std::abs(r[i]) / size[i]);
  return worst;
}

}  // namespace

// The supernodal solve in two parts (core/supernodal_solve.hpp), on
// generated 2-D grids of random sizes (27 000–68 000 coordinates), uniform,
// with bond stiffnesses over 12 decades, and with a diagonal grading over 8
// more: the same factor solved by CHOLMOD is the reference. Its
// componentwise backward error stays within 10 × CHOLMOD's own plus 50ε
// (the measure a stable solve keeps whatever the grading; CHOLMOD's itself
// within 1000ε), on the uniform grids the two solutions agree to 1e-10, and
// a second solve, also in place, gives the same bits (the parts' sums in a
// fixed order). One factor object serves every trial: each new analysis
// (another pattern) makes a new cut. Left to CHOLMOD (false): a 3-D grid,
// whose separators hold more than a tenth of its factor; a small factor
// (below 2²⁰ entries); a chain in its natural order (a path: no cut).
TEST(SparseModes, SupernodalSolveInTwoPartsMatchesCholmodOnGeneratedGrids) {
  std::mt19937_64 random(1503);
  std::uniform_int_distribution<int> side(90, 150), depth(16, 22);
  std::uniform_real_distribution<double> unit(-1, 1);
  const double eps = std::numeric_limits<double>::epsilon();
  modal::detail::CholmodAccess<Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower>> llt;
  int cut = 0;
  for (int trial = 0; trial < 6; ++trial) {
    const bool three_d = trial == 5;
    const int nx = three_d ? depth(random) : side(random), ny = three_d ? depth(random) : side(random);
    const int layers = three_d ? depth(random) : 1;
    const double decades = trial < 2 ? 0.0 : 12.0, grading = trial < 4 ? 0.0 : 8.0;
    const SparseMatrix A = generated_grid(nx, ny, layers, decades, grading, random);
    llt.compute(A);
    ASSERT_EQ(llt.info(), Eigen::Success) << "trial " << trial;
    VectorX b(A.rows());
    for (Eigen::Index i = 0; i < b.size(); ++i) b[i] = unit(random);
    const VectorX reference = llt.solve(b);
    VectorX x(b.size()), again(b.size());
    const bool in_parts = llt.solve_in_parts(b.data(), x.data());
    EXPECT_EQ(in_parts, !three_d) << "trial " << trial << " (" << nx << "×" << ny << "×" << layers << ")";
    if (!in_parts) continue;
    ++cut;
    ASSERT_TRUE(llt.solve_in_parts(b.data(), again.data()));
    EXPECT_EQ(0, std::memcmp(x.data(), again.data(), sizeof(double) * static_cast<std::size_t>(x.size())))
        << "trial " << trial << ": a second solve differs";
    const double ours = backward_error(A, x, b), theirs = backward_error(A, reference, b);
    EXPECT_LE(ours, 10 * theirs + 50 * eps) << "trial " << trial << " (" << nx << "×" << ny << "×" << layers << ")";
    EXPECT_LE(theirs, 1e3 * eps) << "trial " << trial;
    if (grading == 0 && decades == 0) {
      EXPECT_LE((x - reference).norm(), 1e-10 * reference.norm()) << "trial " << trial;
    }
    // In place (x = b).
    VectorX y = b;
    ASSERT_TRUE(llt.solve_in_parts(y.data(), y.data()));
    EXPECT_EQ(0, std::memcmp(x.data(), y.data(), sizeof(double) * static_cast<std::size_t>(x.size())));
  }
  EXPECT_EQ(cut, 5);
  // Below the size that pays, and a path: CHOLMOD's.
  {
    const SparseMatrix A = generated_grid(20, 20, 1, 0, 0, random);
    llt.compute(A);
    VectorX x(A.rows());
    EXPECT_FALSE(llt.solve_in_parts(VectorX::Ones(A.rows()).eval().data(), x.data()));
  }
  {
    const int n = 700000;
    Triplets entries;
    for (int i = 0; i < n; ++i) entries.emplace_back(i, i, 2.5);
    for (int i = 1; i < n; ++i) {
      entries.emplace_back(i, i - 1, -1.0);
      entries.emplace_back(i - 1, i, -1.0);
    }
    SparseMatrix A(n, n);
    A.setFromTriplets(entries.begin(), entries.end());
    llt.cholmod().nmethods = 1;
    llt.cholmod().method[0].ordering = CHOLMOD_NATURAL;
    llt.compute(A);
    ASSERT_EQ(llt.info(), Eigen::Success);
    VectorX x(n);
    EXPECT_FALSE(llt.solve_in_parts(VectorX::Ones(n).eval().data(), x.data()));
  }
}

// Products with symmetric sparse matrices in two parts (core/sparse_product.hpp),
// on the generated grids below and above the size that pays (2²⁰ stored
// entries), uniform and graded over 12 + 12 decades, x over 6: against
// Eigen's A x entry by entry within both sums' worst-case rounding
// (4ε·terms·(|A||x|)_j), |A||x| against Eigen's on A.cwiseAbs() (2ε·terms),
// the sum of the entries' squares against a long double sum, and the same
// bits twice.
// pairwise_dot (the sparse path's Rayleigh quotients): on generated vectors
// of random sizes (1 … 3·10⁵): entries over 20 decades with random signs,
// such vectors made to cancel (y chosen so that xᵀy is 1e-10 of Σ|x_i y_i|
// or less), and positive entries within a decade; the computed sum lies within γ_m Σ|x_i y_i| of the exact one
// (__float128: each product of two doubles exact, the sum's own rounding
// ~1e-34 relative), m = pairwise_depth(n) = 32 + ⌈log₂ ⌈n/32⌉⌉, the bound
// the estimates and residual bounds now use; the same bits twice.
TEST(SparseModes, PairwiseDotsAreWithinTheirDepthsBound) {
  std::mt19937_64 random(312);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::uniform_int_distribution<int> exponent(1, 19);
  const double u = std::numeric_limits<double>::epsilon() / 2;
  for (int trial = 0; trial < 60; ++trial) {
    const auto n = static_cast<Eigen::Index>(std::pow(10.0, exponent(random) * 5.5 / 19.0));
    VectorX x(n), y(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      x[i] = unit(random) * std::pow(10.0, 10 * unit(random));
      y[i] = unit(random) * std::pow(10.0, 10 * unit(random));
    }
    if (trial % 3 == 2)  // all positive, within a decade (as φᵀMφ): the partial sums grow, and their rounding with them
      for (Eigen::Index i = 0; i < n; ++i) {
        x[i] = 1 + unit(random) * 0.45;
        y[i] = 1 + unit(random) * 0.45;
      }
    if (trial % 3 == 1 && n > 1) {  // cancelling: the last term nearly undoes the rest
      __float128 rest = 0;
      for (Eigen::Index i = 0; i + 1 < n; ++i) rest += static_cast<__float128>(x[i]) * y[i];
      y[n - 1] = static_cast<double>(-rest / x[n - 1]);
    }
    __float128 exact = 0, magnitude = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const __float128 term = static_cast<__float128>(x[i]) * y[i];
      exact += term;
      magnitude += term < 0 ? -term : term;
    }
    const double m = modal::detail::pairwise_depth(n);
    EXPECT_LE(m, static_cast<double>(std::max<Eigen::Index>(n, 1)));
    const double computed = modal::detail::pairwise_dot(x, y), again = modal::detail::pairwise_dot(x, y);
    EXPECT_EQ(0, std::memcmp(&computed, &again, sizeof computed));
    const __float128 error = static_cast<__float128>(computed) - exact;
    const double gamma = m * u / (1 - m * u);
    EXPECT_LE(static_cast<double>(error < 0 ? -error : error), gamma * static_cast<double>(magnitude))
        << "n " << n << ", depth " << m << ", trial " << trial;
  }
}

TEST(SparseModes, SymmetricProductsInTwoPartsMatchEigen) {
  std::mt19937_64 random(1504);
  std::uniform_real_distribution<double> unit(-1, 1);
  const double eps = std::numeric_limits<double>::epsilon();
  for (const auto& [nx, decades] : {std::pair{40, 0.0}, std::pair{200, 0.0}, std::pair{40, 12.0}, std::pair{220, 12.0}}) {
    const SparseMatrix A = generated_grid(nx, nx, 1, decades, decades, random);
    VectorX x(A.rows());
    for (Eigen::Index i = 0; i < x.size(); ++i) x[i] = unit(random) * std::pow(10.0, 3 * unit(random));
    EXPECT_EQ(modal::detail::second_part_column(A) < A.outerSize(), A.nonZeros() >= modal::detail::sparse_parts_from);
    const VectorX y = modal::detail::symmetric_product(A, x), again = modal::detail::symmetric_product(A, x);
    EXPECT_EQ(0, std::memcmp(y.data(), again.data(), sizeof(double) * static_cast<std::size_t>(y.size())));
    const VectorX reference = A * x;
    const SparseMatrix magnitudes = A.cwiseAbs();
    const VectorX sizes = magnitudes * x.cwiseAbs();
    const VectorX absolute = modal::detail::symmetric_product(A, x.cwiseAbs(), [](double v) { return std::abs(v); });
    for (Eigen::Index j = 0; j < A.outerSize(); ++j) {
      const double terms = static_cast<double>(A.col(j).nonZeros());
      EXPECT_LE(std::abs(y[j] - reference[j]), 4 * eps * terms * sizes[j]) << "n " << A.rows() << ", entry " << j;
      EXPECT_LE(std::abs(absolute[j] - sizes[j]), 2 * eps * terms * sizes[j]) << "n " << A.rows() << ", entry " << j;
    }
    Long exact = 0;
    for (Eigen::Index j = 0; j < A.outerSize(); ++j)
      for (SparseMatrix::InnerIterator it(A, j); it; ++it) exact += std::pow(static_cast<Long>(it.value()) * x[it.row()] * x[j], 2);
    const double squares = modal::detail::sum_over_entries(
        A, [&x](double v, Eigen::Index row, Eigen::Index column) { return std::pow(v * x[row] * x[column], 2); });
    EXPECT_LE(std::abs(squares - static_cast<double>(exact)), 8 * eps * static_cast<double>(A.nonZeros()) * static_cast<double>(exact));
  }
}

// kato_temple (both sparse paths and the distributed backend): generated
// pencils (n 20…60, M's diagonal over four decades, random K) with their
// eigenpairs in long double; the k lowest vectors disturbed by 1e-7…1e-3 of
// their size (along the next eigenvector, and randomly 1e-3 of that; the
// quotients' errors, size² of their gaps, stay well above the long double
// reference's own, ε_LD of the largest eigenvalue), their Rayleigh quotients λ_j and residual norms δ_j =
// ‖Kφ − λMφ‖_{M⁻¹} in long double, each mode's bound and estimate δ_j (and
// ε|λ_j| for λ_j's rounding to a double, as on the paths). With
// b between λ_k and λ_{k+1} (every eigenvalue below it returned), every
// replaced bound still covers its distance to the exact eigenvalue and is
// δ²/g; a mode at or above b, or a zero mode, keeps δ; where the disturbance
// is small against the gaps the bound is far below δ.
TEST(SparseModes, KatoTempleBoundsCoverTheExactEigenvalues) {
  using MatLD = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
  using VecLD = Eigen::Matrix<long double, Eigen::Dynamic, 1>;
  std::mt19937 rng(3122026);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> u(0, 1);
  int quadratic = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 20 + static_cast<int>(u(rng) * 40), k = 3 + trial % 5;
    MatLD A(n, n), M = MatLD::Zero(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) A(i, j) = normal(rng);
    const MatLD K = A * A.transpose() / n + MatLD::Identity(n, n);
    for (int i = 0; i < n; ++i) M(i, i) = std::pow(10.0L, static_cast<long double>(4 * u(rng) - 2));
    const Eigen::GeneralizedSelfAdjointEigenSolver<MatLD> exact(K, M);
    ASSERT_EQ(exact.info(), Eigen::Success);
    const VecLD& values = exact.eigenvalues();
    const MatLD Minv = M.inverse();
    std::vector<modal::Mode> modes(static_cast<std::size_t>(k));
    std::vector<double> bound(static_cast<std::size_t>(k)), typical(static_cast<std::size_t>(k));
    const long double size = std::pow(10.0L, static_cast<long double>(-7 + 4 * u(rng)));
    for (int j = 0; j < k; ++j) {
      // Mostly along the next eigenvector (for the highest returned mode, the
      // first one not returned: its error then hinges on the gap to b).
      VecLD phi = exact.eigenvectors().col(j) + size * exact.eigenvectors().col(j + 1);
      const long double scale = phi.norm();
      for (int i = 0; i < n; ++i) phi(i) += 1e-3L * size * scale * static_cast<long double>(normal(rng));
      phi /= std::sqrt(phi.dot(M * phi));
      const long double lambda = phi.dot(K * phi);
      const VecLD r = K * phi - lambda * (M * phi);
      const double delta = static_cast<double>(std::sqrt(r.dot(Minv * r)));
      modal::Mode& mode = modes[static_cast<std::size_t>(j)];
      mode.omega2 = static_cast<double>(lambda);
      mode.kind = j == 0 && trial % 7 == 0 ? ModeKind::zero : ModeKind::oscillatory;
      // Beside δ, the rounding of λ to a double (the paths' ε|λ|).
      mode.residual_bound = mode.error_estimate = delta + std::numeric_limits<double>::epsilon() * std::abs(mode.omega2);
      bound[static_cast<std::size_t>(j)] = typical[static_cast<std::size_t>(j)] = delta;
    }
    // b between the k-th and the next; at trial % 3 == 1 just below the k-th.
    const double b = trial % 3 == 1 ? static_cast<double>(values(k - 1)) * (1 - 1e-12)
                                    : static_cast<double>((values(k - 1) + values(k)) / 2);
    std::vector<modal::Mode> before = modes;
    const std::vector<double> parts = modal::kato_temple(modes, bound, typical, b);
    for (int j = 0; j < k; ++j) {
      const modal::Mode& mode = modes[static_cast<std::size_t>(j)];
      const double distance = static_cast<double>(std::abs(static_cast<long double>(mode.omega2) - values(j)));
      EXPECT_LE(distance, mode.residual_bound * (1 + 1e-12)) << "trial " << trial << " mode " << j + 1;
      EXPECT_LE(distance, mode.error_estimate * (1 + 1e-12)) << "trial " << trial << " mode " << j + 1;
      const bool kept = !(mode.omega2 < b) || mode.kind == ModeKind::zero;
      if (kept) {
        EXPECT_EQ(mode.residual_bound, before[static_cast<std::size_t>(j)].residual_bound) << "trial " << trial;
        EXPECT_TRUE(std::isnan(parts[static_cast<std::size_t>(j)])) << "trial " << trial;
      } else if (std::isfinite(parts[static_cast<std::size_t>(j)])) {
        EXPECT_LT(mode.residual_bound, bound[static_cast<std::size_t>(j)]);
        quadratic += mode.residual_bound < 1e-3 * bound[static_cast<std::size_t>(j)];
      }
    }
  }
  EXPECT_GE(quadratic, 20);  // the family reaches the quadratic regime
}
