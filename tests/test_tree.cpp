// The matrix-free path for trees (docs/design.md, "Matrix-free path"): the
// ordered form of K and M (modal::TreePencil), its O(bodies) products and
// LDLᵀ factorization, and the modes solved through it.
//
// Generated families (fixed seeds): random trees of hinges, slides and fixed
// joints with random axes, offsets, masses and inertias, joint springs,
// armatures and dead loads, sizes 1 to 60 bodies, masses and lengths graded
// over up to six decades. References:
// - products and solves: the dense M(q) and ∇∇V(q), which are themselves
//   checked against long double AD in test_graded; tolerance 1e-12 of the
//   magnitude bound (Σ|terms|), well above the recursions' rounding (depth ≤ 60);
// - the inertia: the eigenvalues of the dense αK + βM + γI;
// - the modes: the long double reference of test_graded (AD of the templated
//   kinematics and potential, solved by Eigen in long double);
// - a hanging chain of 10⁵ links: ω² = (g/a)·x_k with x_k the zeros of the
//   Laguerre polynomial L_N, counted by a Sturm sequence in long double.
#include "modal/linearize.hpp"
#include "modal/modes.hpp"
#include "modal/pipeline.hpp"
#include "modal/detail.hpp"
#include "program.hpp"
#include "reference_ld.hpp"

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

namespace {

using namespace modal;

Vec3 random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  Vec3 v(n(rng), n(rng), n(rng));
  return v.normalized();
}

// A random tree of `bodies` bodies (hinges, slides, a few fixed joints),
// each hanging from a random earlier body, masses and lengths log-uniform
// over `decades`.
System random_tree(std::mt19937_64& rng, int bodies, double decades, bool planar = false) {
  SystemDescription d;
  d.title = "random tree";
  d.gravity = Vec3(0, 0, -9.81);
  std::uniform_real_distribution<double> u(0, 1);
  auto graded = [&] { return std::pow(10.0, decades * (u(rng) - 0.5)); };
  for (int b = 0; b < bodies; ++b) {
    Body body;
    body.name = "b" + std::to_string(b);
    body.parent = b == 0 ? -1 : static_cast<int>(u(rng) * b);
    const double r = u(rng);
    body.joint = planar ? JointType::hinge : r < 0.65 ? JointType::hinge : r < 0.9 ? JointType::slide : JointType::fixed;
    body.axis = planar ? Vec3::UnitY() : random_unit(rng);
    const double l = graded();
    body.origin = b == 0 ? Vec3::Zero() : Vec3(l * (u(rng) - 0.5), l * (u(rng) - 0.5), -l);
    body.mass = graded();
    body.com = l * Vec3(u(rng) - 0.5, u(rng) - 0.5, -u(rng));
    const Vec3 principal(0.1 + u(rng), 0.1 + u(rng), 0.1 + u(rng));
    body.inertia = body.mass * l * l * 0.05 * principal.asDiagonal().toDenseMatrix();
    const int nq = body.joint == JointType::fixed ? 0 : 1;
    body.rest = VectorX::Zero(nq);
    body.initial = VectorX::Zero(nq);
    if (nq > 0 && u(rng) < 0.3) body.stiffness = body.mass * 9.81 * l * graded();
    if (nq > 0 && u(rng) < 0.3) body.armature = 0.1 * body.mass * l * l;
    d.bodies.push_back(body);
  }
  for (int i = 0; i < bodies / 5; ++i) {
    DeadLoad load;
    load.at.body = static_cast<int>(u(rng) * bodies);
    load.at.point = Vec3(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5);
    load.force = random_unit(rng) * graded();
    d.loads.push_back(load);
  }
  return System(d);
}

VectorX random_vector(std::mt19937_64& rng, int n) {
  std::normal_distribution<double> g;
  VectorX x(n);
  for (int i = 0; i < n; ++i) x[i] = g(rng);
  return x;
}

TEST(TreePencil, ProductsAndSolvesEqualTheDenseMatrices) {
  std::mt19937_64 rng(20261125);
  int cases = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const int bodies = 1 + static_cast<int>(rng() % 60);
    const System s = random_tree(rng, bodies, trial % 3 == 0 ? 6.0 : 1.0);
    if (s.size() == 0) continue;
    ASSERT_FALSE(tree_pencil_unsupported(s).has_value());
    Workspace w(s);
    const VectorX q = 0.3 * random_vector(rng, s.size());
    const TreePencil p = tree_pencil(s, w, q);
    const MatrixX M = mass_matrix(s, w, q);
    const MatrixX K = potential_hessian(s, w, q);
    const VectorX x = random_vector(rng, s.size());
    const double alpha = 0.7, beta = -1.3;
    const VectorX y = tree_product(p, alpha, beta, x);
    const VectorX bound = tree_product(p, alpha, beta, x, true);
    const VectorX dense = alpha * K * x + beta * M * x;
    for (int i = 0; i < s.size(); ++i) {
      EXPECT_NEAR(y[i], dense[i], 1e-12 * bound[i]) << "trial " << trial << " row " << i;
      // The magnitude recursion bounds Σ|terms| of the product up to rounding.
      EXPECT_GE(bound[i] * (1 + 1e-12), std::abs(dense[i])) << "trial " << trial << " row " << i;
    }
    // H = αK + βM + γI: the solve inverts it, and the negative pivots count its negative eigenvalues.
    const double gamma = 0.1 * M.diagonal().mean();
    const MatrixX H = alpha * K + beta * M + gamma * MatrixX::Identity(s.size(), s.size());
    TreeFactor f;
    ASSERT_TRUE(f.factor(p, alpha, beta, gamma)) << "trial " << trial;
    const VectorX z = f.solve(y);
    const MatrixX Hs = 0.5 * (H + H.transpose());
    const Eigen::SelfAdjointEigenSolver<MatrixX> eig(Hs);
    const double smallest = eig.eigenvalues().cwiseAbs().minCoeff(), largest = eig.eigenvalues().cwiseAbs().maxCoeff();
    if (smallest > 1e-6 * largest) {  // well enough conditioned to compare solutions
      const VectorX reference = Hs.ldlt().solve(y);
      EXPECT_LE((z - reference).norm(), 1e-7 * reference.norm()) << "trial " << trial;
      int negative = 0;
      for (int i = 0; i < s.size(); ++i) negative += eig.eigenvalues()[i] < 0;
      EXPECT_EQ(f.negative_pivots(), negative) << "trial " << trial;
      ++cases;
    }
  }
  EXPECT_GE(cases, 30);
}

// The matrix-free residual bound's worst case of rounding through M⁻¹ rests
// on μ ≤ λ_min(D^{-1/2}MD^{-1/2}) (detail::tree_mass_floor). Against the
// smallest eigenvalue of the dense M so scaled, solved in long double, on
// random trees with masses and lengths over 1, 6 and 12 decades at random
// q: μ is never above it (beyond 1e-6 relative: the factorization that
// confirms μ is exact to first order in ε only) and never 10³ below it
// (a bound that loose would inflate every residual bound as much).
TEST(TreePencil, MassFloorIsALowerBoundOfTheEquilibratedMass) {
  std::mt19937_64 rng(20261127);
  using MatrixL = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
  int cases = 0;
  double loosest = 1;
  for (int trial = 0; trial < 90; ++trial) {
    const int bodies = 1 + static_cast<int>(rng() % 80);
    const System s = random_tree(rng, bodies, trial % 3 == 0 ? 1.0 : trial % 3 == 1 ? 6.0 : 12.0);
    if (s.size() == 0) continue;
    Workspace w(s);
    const VectorX q = 0.5 * random_vector(rng, s.size());
    const TreePencil p = tree_pencil(s, w, q);
    TreeFactor mass;
    ASSERT_TRUE(mass.factor(p, 0.0, 1.0)) << "trial " << trial;
    const VectorX diagonal = tree_diagonal(p, 0.0, 1.0), d = diagonal.cwiseSqrt().cwiseInverse();
    const double mu = detail::tree_mass_floor(p, mass, diagonal);
    const MatrixX M = mass_matrix(s, w, q);
    const MatrixL A = (d.asDiagonal() * M * d.asDiagonal()).cast<long double>();
    const Eigen::SelfAdjointEigenSolver<MatrixL> eig(MatrixL(0.5L * (A + A.transpose())), Eigen::EigenvaluesOnly);
    const double smallest = static_cast<double>(eig.eigenvalues()(0));
    ASSERT_GT(smallest, 0) << "trial " << trial;
    EXPECT_LE(mu, smallest * (1 + 1e-6)) << "trial " << trial << ": not a lower bound";
    EXPECT_GE(mu, 1e-3 * smallest) << "trial " << trial << ": λ_min " << smallest;
    loosest = std::min(loosest, mu / smallest);
    ++cases;
  }
  std::printf("mass floor: %d trees, loosest μ/λ_min %.2e\n", cases, loosest);
  EXPECT_GE(cases, 80);
}

// Light bodies carrying heavy ones, beyond double precision in relative
// angles: a chain of hinges with alternating axes (no point-mass chain's
// structure) and, at a random place, 2–4 bodies of 1e-20 … 1e-17 kg on
// parallel hinges below which hangs a body of 1 kg. M is positive definite
// (every body has mass off its hinge axis), but in exact arithmetic a light
// body's pivot in the tree's LDLᵀ is its own inertia, 1e-17 or less of its
// diagonal entry, so in rounding it can take any sign. Where the Lanczos
// path refuses M, its words must be true: M cannot be factored in double
// precision, named at a light body (where the inertia vanishes), not "not
// positive definite" and not the least diagonal entry (which the
// coordinates' scaling makes about 1 everywhere: the message named a body
// far from the light ones before). Generated: chains of 205–300 bodies
// until 4 are refused (a tiny positive pivot, which rounding can give, is
// not refused: such a chain is answered or fails otherwise), at most 60.
TEST(TreeModes, LightBodiesCarryingHeavyOnesAreRefusedInTrueWords) {
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> u(0, 1);
  int refused = 0, trials = 0;
  for (int trial = 0; trial < 60 && refused < 4; ++trial, ++trials) {
    const int bodies = 205 + static_cast<int>(rng() % 96);
    const int light = 2 + static_cast<int>(rng() % 3);
    const int first_light = 20 + static_cast<int>(rng() % static_cast<unsigned>(bodies - light - 40));
    SystemDescription d;
    d.title = "light bodies carrying a heavy one";
    d.gravity = Vec3(0, 0, -9.81);
    std::vector<std::string> light_names;
    for (int b = 0; b < bodies; ++b) {
      Body body;
      body.name = "b" + std::to_string(b);
      body.parent = b - 1;
      body.joint = JointType::hinge;
      const bool is_light = b >= first_light && b < first_light + light;
      const bool parallel = b >= first_light - 1 && b <= first_light + light;  // the segment and its ends
      body.axis = parallel || b % 2 == 0 ? Vec3::UnitY() : Vec3::UnitX();
      const double l = std::pow(10.0, -2 + 2 * u(rng));
      body.origin = b == 0 ? Vec3::Zero() : Vec3(0, 0, -l);
      body.com = Vec3(0, 0, -l);
      body.mass = is_light ? std::pow(10.0, -20 + 3 * u(rng)) : 1.0;
      body.rest = VectorX::Zero(1);
      body.initial = VectorX::Zero(1);
      if (is_light) light_names.push_back(body.name);
      d.bodies.push_back(body);
    }
    const System s(d);
    ASSERT_GT(s.size(), 200) << "the Lanczos path starts above 200 coordinates";
    Workspace w(s);
    const VectorX q = VectorX::Zero(s.size());
    SparseModalOptions options;
    options.modes = 4;
    options.inertia_scale = inertia_scale(s, w, q);
    for (int b = 0; b < bodies; ++b) options.coordinate_names.push_back("b" + std::to_string(b));
    try {
      solve_tree_modes(tree_pencil(s, w, q), options);
    } catch (const SingularMassMatrix& e) {
      ++refused;
      const std::string what = e.what();
      EXPECT_NE(what.find("cannot be factored in double precision"), std::string::npos) << what;
      EXPECT_EQ(what.find("the mass matrix is not positive definite"), std::string::npos) << what;
      EXPECT_TRUE(std::any_of(light_names.begin(), light_names.end(),
                              [&](const std::string& name) { return what.find(name + " (") != std::string::npos ||
                                                                    what.find(name + "'s") != std::string::npos; }))
          << "trial " << trial << ", light bodies from b" << first_light << ": " << what;
    } catch (const NumericalError&) {
      // not refused for its mass matrix: beyond this test
    }
  }
  std::printf("light bodies over a heavy one: %d of %d chains refused\n", refused, trials);
  EXPECT_EQ(refused, 4) << "too few generated chains reached the refusal: the test no longer tests it";
}

// The lowest modes of random trees solved through the tree (Lanczos path:
// more than 200 coordinates) against the long double reference at the same
// q (not an equilibrium: the dead loads make K indefinite for some, which
// takes the divergent branch). Each ω² within its error estimate and within
// 1e-7 relative of the reference (the estimates are residual bounds of the
// Lanczos tolerance 1e-10, about 1e-9 relative here).
// The `modes` lowest modes of s at q by solve_tree_modes, its inertia scale
// as the pipeline passes it.
ModalResult matrix_free_modes(const System& s, const VectorX& q, int modes) {
  Workspace w(s);
  SparseModalOptions options;
  options.modes = modes;
  options.inertia_scale = inertia_scale(s, w, q);
  return solve_tree_modes(tree_pencil(s, w, q), options);
}

TEST(TreeModes, RandomTreesMatchTheLongDoubleReference) {
  std::mt19937_64 rng(7);
  int divergent = 0;
  for (int trial = 0; trial < 2; ++trial) {
    const int bodies = (trial == 0 ? 240 : 205) + static_cast<int>(rng() % 20);
    const System s = random_tree(rng, bodies, trial == 0 ? 4.0 : 1.0, trial == 1);
    ASSERT_GT(s.size(), 200) << "the Lanczos path starts above 200 coordinates";
    Workspace w(s);
    const VectorX q = trial == 1 ? VectorX(0.2 * random_vector(rng, s.size())) : VectorX::Zero(s.size());
    const ModalResult r = matrix_free_modes(s, q, 8);
    ASSERT_EQ(r.modes.size(), 8u);
    EXPECT_NE(r.solver.find("matrix-free"), std::string::npos) << r.solver;
    const std::vector<LD> reference = reference_omega2(s, q);
    // The Morse index counts the eigenvalues below −ζ, ζ = 1e-8 max K_ii/M_ii
    // (solve_sparse_modes), and those in [−ζ, 0) among the returned modes.
    const TreePencil p = tree_pencil(s, w, q);
    const double zeta = 1e-8 * (tree_diagonal(p, 1, 0).array() / tree_diagonal(p, 0, 1).array()).maxCoeff();
    int negative = 0, below = 0;
    for (const LD l : reference) {
      negative += l < 0;
      below += l < -zeta;
    }
    divergent += negative > 0;
    EXPECT_GE(r.morse_index, below) << "trial " << trial;
    EXPECT_LE(r.morse_index, negative) << "trial " << trial;
    for (std::size_t j = 0; j < r.modes.size(); ++j) {
      const double truth = static_cast<double>(reference[j]);
      const double error = std::abs(r.modes[j].omega2 - truth);
      EXPECT_LE(error, r.modes[j].error_estimate) << "trial " << trial << " mode " << j + 1 << ": " << r.modes[j].omega2
                                                  << " against " << truth;
      EXPECT_LE(error, 1e-7 * std::abs(truth)) << "trial " << trial << " mode " << j + 1;
    }
  }
  EXPECT_GE(divergent, 1);  // the family reaches the divergent branch
}

// Zeros of the Laguerre polynomial L_N: the eigenvalues of its Jacobi matrix
// T (diagonal 2i + 1, off-diagonal i + 1), which is L D Lᵀ with unit lower
// bidiagonal L (ones below the diagonal) and D = diag(1, 2, …, N), exactly.
// The number below σ is that of negative pivots of LDLᵀ − σI by the
// stationary qd transform, which is relatively accurate (Dhillon and Parlett,
// 2004); bisection in long double then gives each zero to about N·ε_LD.
LD laguerre_zero(int N, int k) {
  auto below = [N](LD sigma) {
    int count = 0;
    LD s = -sigma;
    for (int i = 0; i < N; ++i) {
      const LD d = i + 1;
      const LD plus = s + d;
      count += plus < 0;
      if (i + 1 < N) s = (plus == 0 ? d / std::numeric_limits<LD>::min() : d / plus) * s - sigma;  // L⁺_i l_i s_i − σ
    }
    return count;
  };
  LD lo = 0, hi = 1;
  while (below(hi) < k) hi *= 2;
  for (int it = 0; it < 200 && hi - lo > 1e-30L * hi; ++it) {
    const LD mid = (lo + hi) / 2;
    (below(mid) >= k ? hi : lo) = mid;
  }
  return (lo + hi) / 2;
}

// Hanging chains of point-mass links (models/hanging_chain.toml): N drawn
// from [1500, 3000] and [5000, 30000], and 10⁵ (the stated maximum of
// links), g drawn from [0.5, 20]. `modal analyze` takes the matrix-free path
// by itself (--solver tree below its automatic threshold) and its ten lowest
// ω² are (g/a)·x_k within their estimates. The estimates' looseness, against
// the true error floored at 1e-15 ω²: at most 10² × for mode 1 (where the
// residual dominates; measured 2.1–31×) and 10⁵ × for the others (measured up
// to 1.1e4 ×, mode 10 of N = 1662, where the worst-case rounding of the
// magnitude recursion dominates). Before the matrix-free path took
// Kato–Temple's δ²/g and the second-order size of r (its linear δ), the 10⁵
// chain's were 2.6e6 × (mode 1) to 2.2e5 × (mode 10).
std::string exact_text(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", x);
  return text;
}

TEST(TreeModes, HangingChainsMatchTheLaguerreZeros) {
  std::mt19937_64 rng(1526);
  const int lengths[] = {std::uniform_int_distribution<int>(1500, 3000)(rng),
                         std::uniform_int_distribution<int>(5000, 30000)(rng), 100000};
  double worst = 0;
  for (const int N : lengths) {
    const double gravity = std::exp(std::uniform_real_distribution<double>(std::log(0.5), std::log(20.0))(rng));
    const std::string what = "N = " + std::to_string(N) + ", g = " + std::to_string(gravity);
    const Model model = load_model(std::string(MODAL_SOURCE_DIR) + "/models/hanging_chain.toml",
                                   {"N=" + std::to_string(N), "g=" + exact_text(gravity)});
    AnalysisOptions options;
    options.modes = 10;
    if (N < 50000) options.solver = SolverChoice::tree;
    const Analysis a = analyze(model, options);
    ASSERT_TRUE(a.tree.has_value()) << what;
    EXPECT_FALSE(a.linear.has_value() || a.sparse.has_value()) << what;
    const ModalResult& r = a.result();
    ASSERT_EQ(r.modes.size(), 10u) << what;
    EXPECT_EQ(r.stability, Stability::stable) << what;
    const LD g = static_cast<LD>(gravity), length = 1.0L / N;
    for (int k = 1; k <= 10; ++k) {
      const double truth = static_cast<double>(g / length * laguerre_zero(N, k));
      const Mode& m = r.modes[static_cast<std::size_t>(k - 1)];
      const double error = std::abs(m.omega2 - truth);
      EXPECT_LE(error, m.error_estimate) << what << " mode " << k << ": " << m.omega2 << " against " << truth;
      EXPECT_LE(error, 1e-6 * truth) << what << " mode " << k;
      EXPECT_LE(m.error_estimate, (k == 1 ? 1e2 : 1e5) * std::max(error, 1e-15 * truth))
          << what << " mode " << k << ": error " << error;
      worst = std::max(worst, m.error_estimate / std::max(error, 1e-15 * truth));
    }
  }
  std::printf("hanging chains: worst estimate / max(error, 1e-15 ω²) %.0f\n", worst);
}

// The dense path on the same chains, every mode: N drawn from [150, 400]
// twice, g from [0.5, 20], in absolute link angles (M dense and positive).
// Every ω² within its estimate of the Laguerre reference, and the estimate at
// most 2e5 × max(error, 1e-15 ω²) (measured up to 8.8e4 ×, N = 385, where
// the typical rounding of the quotient's dense products dominates): the
// quotient's and the entries' rounding at their typical size
// (detail::typical_quotient_rounding). With the worst case of the entries'
// rounding, 4ε|λ||φ|ᵀ|M||φ|, and the quotient's √n ε|φ|ᵀ(|K| + |λ||M|)|φ|,
// the high modes' estimates were up to 5.5e5 × (166 modes over 2e4 ×).
TEST(TreeModes, DenseChainEstimatesAreTypicalNotWorstCase) {
  std::mt19937_64 rng(1127);
  double worst = 0;
  for (int trial = 0; trial < 2; ++trial) {
    const int N = std::uniform_int_distribution<int>(150, 400)(rng);
    const double gravity = std::exp(std::uniform_real_distribution<double>(std::log(0.5), std::log(20.0))(rng));
    const std::string what = "N = " + std::to_string(N) + ", g = " + std::to_string(gravity);
    const Model model = load_model(std::string(MODAL_SOURCE_DIR) + "/models/hanging_chain.toml",
                                   {"N=" + std::to_string(N), "g=" + exact_text(gravity)});
    AnalysisOptions options;
    options.solver = SolverChoice::dense;
    const Analysis a = analyze(model, options);
    ASSERT_TRUE(a.linear.has_value()) << what;
    const ModalResult& r = a.result();
    ASSERT_EQ(r.modes.size(), static_cast<std::size_t>(N)) << what;
    const LD g = static_cast<LD>(gravity), length = 1.0L / N;
    for (int k = 1; k <= N; ++k) {
      const double truth = static_cast<double>(g / length * laguerre_zero(N, k));
      const Mode& m = r.modes[static_cast<std::size_t>(k - 1)];
      const double error = std::abs(m.omega2 - truth);
      EXPECT_LE(error, m.error_estimate) << what << " mode " << k << ": " << m.omega2 << " against " << truth;
      const double looseness = m.error_estimate / std::max(error, 1e-15 * truth);
      EXPECT_LE(looseness, 2e5) << what << " mode " << k << ": error " << error;
      worst = std::max(worst, looseness);
    }
  }
  std::printf("dense chains: worst estimate / max(error, 1e-15 ω²) %.0f\n", worst);
}

// Inverted chains (g < 0: every mode divergent, λ_k = −(|g|/a)·x_{N+1−k})
// on the sparse path in joint angles, N drawn from [201, 700] twice (200 is
// the dense limit): the ten most negative within their estimates of the
// Laguerre reference, and their completeness checked by the inertia of
// K − bM. Before MUMPS's null pivots were taken at an absolute threshold for
// the counts (null_pivot_threshold, modes.hpp), its normwise default took a
// legitimate pivot row (between 1e-15 and 1e-14 of the norm) for null at
// every shift tried near b, 1e-6 of λ₁₀ from it while the nearest other
// eigenvalue lies 1e-2 of λ₁₀ away, and the check was reported as not made
// (N = 400 and 1200, and the second draw here), or b was moved by three
// false "zero pivots" past λ₁₀ itself, the note "just below the highest
// returned" then false (the first draw, N = 355).
TEST(TreeModes, InvertedChainsAreCheckedByTheInertia) {
  std::mt19937_64 rng(2911);
  for (int trial = 0; trial < 2; ++trial) {
    const int N = std::uniform_int_distribution<int>(201, 700)(rng);
    const double gravity = -std::exp(std::uniform_real_distribution<double>(std::log(0.5), std::log(20.0))(rng));
    const std::string what = "N = " + std::to_string(N) + ", g = " + std::to_string(gravity);
    const Model model = load_model(std::string(MODAL_SOURCE_DIR) + "/models/hanging_chain.toml",
                                   {"N=" + std::to_string(N), "g=" + exact_text(gravity)});
    AnalysisOptions options;
    options.modes = 10;
    options.solver = SolverChoice::sparse;
    const Analysis a = analyze(model, options);
    ASSERT_TRUE(a.sparse.has_value()) << what;
    const ModalResult& r = a.result();
    ASSERT_EQ(r.modes.size(), 10u) << what;
    EXPECT_EQ(r.stability, Stability::divergence) << what;
    EXPECT_EQ(r.morse_index, N) << what;
    const LD g = static_cast<LD>(-gravity), length = 1.0L / N;
    for (int k = 1; k <= 10; ++k) {
      const double truth = static_cast<double>(-g / length * laguerre_zero(N, N + 1 - k));
      const Mode& m = r.modes[static_cast<std::size_t>(k - 1)];
      EXPECT_LE(std::abs(m.omega2 - truth), m.error_estimate) << what << " mode " << k << ": " << m.omega2
                                                               << " against " << truth;
    }
    const bool checked = std::any_of(r.notes.begin(), r.notes.end(), [](const std::string& note) {
      return note.rfind("completeness checked by the inertia", 0) == 0 && note.find("exactly 9 eigenvalues") != std::string::npos;
    });
    EXPECT_TRUE(checked) << what << ": " << (r.notes.empty() ? std::string("no notes") : r.notes.front());
    for (const std::string& note : r.notes) EXPECT_EQ(note.find("zero pivot"), std::string::npos) << what << ": " << note;
  }
}

// The path is chosen by the documented rule and refused in words where it
// does not apply.
TEST(TreeModes, TheSolverChoiceFollowsTheRule) {
  const std::string models = std::string(MODAL_SOURCE_DIR) + "/models/";
  AnalysisOptions tree;
  tree.solver = SolverChoice::tree;
  tree.modes = 3;
  // A short chain on request: the same modes as the dense path.
  const Model chain = load_model(models + "hanging_chain.toml", {"N=300"});
  const Analysis a = analyze(chain, tree);
  ASSERT_TRUE(a.tree.has_value());
  AnalysisOptions dense;
  dense.solver = SolverChoice::dense;
  dense.modes = 3;
  const Analysis b = analyze(chain, dense);
  for (std::size_t j = 0; j < 3; ++j)
    EXPECT_NEAR(a.result().modes[j].omega2, b.result().modes[j].omega2,
                a.result().modes[j].error_estimate + b.result().modes[j].error_estimate);
  // Automatic: long chains go through the tree, a net of springs does not.
  const Model long_chain = load_model(models + "hanging_chain.toml", {"N=3000"});
  EXPECT_TRUE(analyze(long_chain, AnalysisOptions{}).tree.has_value());
  try {
    analyze(load_model(models + "net.toml"), tree);
    ADD_FAILURE() << "--solver tree accepted a net of springs";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("springs between points"), std::string::npos) << e.what();
  }
}


// Repeated eigenvalues on the matrix-free path: a chain of universal joints
// (a hinge about x, then one about y at the same point carrying the link's
// point mass) hanging straight down swings alike in both planes, so every
// eigenvalue is double: with N equal links of length a, the planar chain's
// (g/a)·x_k (x_k the zeros of the Laguerre polynomial L_N, as above), each
// twice. A pair's Ritz vectors may be any two of its plane, each with a
// residual far above a lone mode's, and Kato–Temple finds no gap: the bounds
// were 10⁵–10⁶ × the estimates (1.1e-8 against 3.6e-15 on the lowest pair
// of a 201-link chain). With the cluster bound (lanczos_modes: the pair's
// projected pencil and Mathias's δ²/η) every bound and estimate covers its
// distance to the closed form, and below the completeness check's b (every
// pair but the highest) each bound is within 100 × its estimate.
// N from [201, 230], g from [0.5, 20], a and the mass over two decades.
System universal_chain(int links, double mass, double length, double g) {
  SystemDescription d;
  d.title = "chain of universal joints";
  d.gravity = Vec3(0, 0, -g);
  for (int i = 0; i < links; ++i) {
    Body x;
    x.name = "x" + std::to_string(i);
    x.parent = static_cast<int>(d.bodies.size()) - 1;
    x.joint = JointType::hinge;
    x.axis = Vec3::UnitX();
    x.origin = i == 0 ? Vec3::Zero() : Vec3(0, 0, -length);
    x.rest = x.initial = VectorX::Zero(1);
    d.bodies.push_back(x);
    Body y = x;
    y.name = "y" + std::to_string(i);
    y.parent = static_cast<int>(d.bodies.size()) - 1;
    y.axis = Vec3::UnitY();
    y.origin = Vec3::Zero();
    y.mass = mass;
    y.com = Vec3(0, 0, -length);
    d.bodies.push_back(y);
  }
  return System(d);
}

TEST(TreeModes, RepeatedEigenvaluesHaveQuadraticBounds) {
  std::mt19937_64 rng(31220264);
  std::uniform_real_distribution<double> u(0, 1);
  for (int trial = 0; trial < 3; ++trial) {
    const int links = 201 + static_cast<int>(rng() % 30);
    const double g = 0.5 + 19.5 * u(rng), length = std::pow(10.0, 2 * u(rng) - 1), mass = std::pow(10.0, 2 * u(rng) - 1);
    const System s = universal_chain(links, mass, length, g);
    const ModalResult r = matrix_free_modes(s, VectorX::Zero(s.size()), 10);
    ASSERT_EQ(r.modes.size(), 10u);
    EXPECT_NE(r.solver.find("matrix-free sparse"), std::string::npos) << r.solver;
    char what[96];
    std::snprintf(what, sizeof what, "trial %d (%d links, g %.3g, a %.3g)", trial, links, g, length);
    for (std::size_t j = 0; j < r.modes.size(); ++j) {
      const Mode& mode = r.modes[j];
      const LD reference = static_cast<LD>(g) / static_cast<LD>(length) * laguerre_zero(links, static_cast<int>(j / 2 + 1));
      const double distance = static_cast<double>(std::abs(static_cast<LD>(mode.omega2) - reference));
      EXPECT_LE(distance, mode.residual_bound) << what << " mode " << j + 1;
      EXPECT_LE(distance, mode.error_estimate) << what << " mode " << j + 1;
      if (j + 2 < r.modes.size()) {
        EXPECT_LE(mode.residual_bound, 100 * mode.error_estimate)
            << what << " mode " << j + 1 << ": bound " << mode.residual_bound << ", estimate " << mode.error_estimate;
      }
    }
  }
}

}  // namespace
