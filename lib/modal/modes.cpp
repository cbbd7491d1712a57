// lib/modal/modes.cpp — solve_modes(): validation, dispatch to the symmetric or
// first-order solver, stability classification; the Mode helpers both solvers
// share.
#include "detail.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace modal {

double dense_analysis_memory(const System& system) {
  const bool first_order = system.has_damping() || system.has_frame_coupling() || system.has_follower_loads();
  const double n = (first_order ? 2.0 : 1.0) * system.size();
  return 224 * n * n;
}

namespace {

constexpr double eps = std::numeric_limits<double>::epsilon();
constexpr double nan = std::numeric_limits<double>::quiet_NaN();

// Throws NumericalError when a matrix of the model has a non-finite entry,
// naming the matrix and the first such entry.
void require_finite(const MatrixX& A, const char* what) {
  for (Eigen::Index j = 0; j < A.cols(); ++j)
    for (Eigen::Index i = 0; i < A.rows(); ++i)
      if (!std::isfinite(A(i, j))) {
        std::ostringstream out;
        out << "the " << what << " of the linear model has a non-finite entry (" << A(i, j) << " at row "
            << i + 1 << ", column " << j + 1 << "): the model cannot be solved";
        throw NumericalError(out.str());
      }
}

// ‖A − Aᵀ‖_F ≤ tol·‖A‖_F with tol = 100·n·ε: symmetric up to the rounding of
// an assembly by sums of n terms (with a margin).
bool symmetric_within_rounding(const MatrixX& A) {
  const double tol = 100.0 * static_cast<double>(A.rows()) * eps;
  return (A - A.transpose()).norm() <= tol * A.norm();
}

// A ← (A + Aᵀ)/2, in place.
void make_symmetric(MatrixX& A) {
  for (Eigen::Index j = 0; j < A.cols(); ++j)
    for (Eigen::Index i = j + 1; i < A.rows(); ++i) A(i, j) = A(j, i) = 0.5 * (A(i, j) + A(j, i));
}

// The model's coordinate names, or q1 … qn when it has none.
std::vector<std::string> coordinate_labels(const LinearModel& model, Eigen::Index n) {
  if (!model.constrained()) return detail::names_or_default(model.coordinates, n);
  std::vector<std::string> names;
  for (Eigen::Index i = 0; i < n; ++i)
    names.push_back("direction " + std::to_string(i + 1) + " of the constraint manifold");
  return names;
}

// Shapes of the equilibrated pencil (SKS, SMS) to the model's coordinates:
// φ = Sφ̃ (M-normalization carries over), normalized again as each solver
// does: real shapes with their largest component positive, complex ones with
// it equal to 1.
void unscale_shapes(const VectorX& scale, bool real, std::vector<Mode>& modes) {
  const Eigen::VectorXcd s = scale.cast<std::complex<double>>();
  for (Mode& m : modes) {
    if (m.shape.size() == 0) continue;
    m.shape = s.cwiseProduct(m.shape);
    const std::complex<double> top = m.shape(detail::dominant_index(m.shape));
    if (!real) m.shape /= top;
    else if (top.real() < 0) m.shape = -m.shape;
  }
}

// Constrained models: shapes from the manifold's coordinates to all
// coordinates (N φ; M-normalization carries over since NᵀMN is the reduced M),
// real shapes signed again so that their largest component is positive.
void map_shapes_back(const LinearModel& model, bool real, std::vector<Mode>& modes) {
  if (!model.constrained()) return;
  if (model.basis.cols() != model.M.rows())
    throw std::invalid_argument("solve_modes: the constraint basis has " + std::to_string(model.basis.cols()) +
                                " columns, the reduced model " + std::to_string(model.M.rows()) + " coordinates");
  for (Mode& m : modes) {
    if (m.shape.size() == 0) continue;
    m.shape = model.basis.cast<std::complex<double>>() * m.shape;
    if (!real) continue;
    Eigen::Index big = 0;
    m.shape.cwiseAbs().maxCoeff(&big);
    if (m.shape[big].real() < 0) m.shape = -m.shape;
  }
}

// D + G, or an empty (0×0) matrix when both are zero. Empty matrices stand
// for zero; any other size than n×n is misuse.
MatrixX velocity_matrix(const LinearModel& model, Eigen::Index n) {
  MatrixX C;
  auto add = [&](const MatrixX& A, const char* what) {
    if (A.size() == 0) return;
    if (A.rows() != n || A.cols() != n)
      throw std::invalid_argument(std::string("solve_modes: the ") + what + " matrix is " +
                                  std::to_string(A.rows()) + "×" + std::to_string(A.cols()) +
                                  ", expected " + std::to_string(n) + "×" + std::to_string(n));
    require_finite(A, what);
    if (A.isZero(0.0)) return;  // a zero D or G given by hand
    if (C.size() == 0) C = A;
    else C += A;
  };
  add(model.D, "damping");
  add(model.G, "gyroscopic");
  return C;
}

// The constraint forces and redundant equations, with a note on the latter.
void copy_constraints(const LinearModel& model, ModalResult& result) {
  result.constraint_forces = model.constraint_forces;
  result.redundant_equations = model.redundant_equations;
  const std::size_t k = model.redundant_equations.size();
  if (k == 0) return;
  std::string list;
  for (std::size_t i = 0; i < k; ++i) list += (i == 0 ? "" : ", ") + model.redundant_equations[i];
  result.notes.push_back(std::to_string(k) + " redundant constraint equation" + (k == 1 ? "" : "s") + " (" + list +
                         "): " + (k == 1 ? "it depends" : "they depend") +
                         " on the others at this configuration, so statics does not determine " +
                         (k == 1 ? "its" : "their") + " share of the constraint forces (reported as not determined); "
                         "the analysis uses the independent equations, leaving " + std::to_string(model.M.rows()) +
                         " degree" + (model.M.rows() == 1 ? "" : "s") + " of freedom");
}

}  // namespace

const char* to_string(Stability s) {
  switch (s) {
    case Stability::asymptotically_stable: return "asymptotically stable";
    case Stability::stable: return "stable";
    case Stability::marginal: return "marginal";
    case Stability::divergence: return "divergence";
    case Stability::flutter: return "flutter";
  }
  return "unknown";
}

const char* to_string(ModeKind k) {
  switch (k) {
    case ModeKind::oscillatory: return "oscillatory";
    case ModeKind::damped: return "damped";
    case ModeKind::zero: return "zero";
    case ModeKind::divergent: return "divergent";
    case ModeKind::flutter: return "flutter";
  }
  return "unknown";
}

Stability classify(const std::vector<Mode>& modes) {
  auto any = [&](ModeKind k) {
    return std::any_of(modes.begin(), modes.end(), [k](const Mode& m) { return m.kind == k; });
  };
  if (any(ModeKind::divergent)) return Stability::divergence;
  if (any(ModeKind::flutter)) return Stability::flutter;
  if (any(ModeKind::zero)) return Stability::marginal;
  if (!modes.empty() &&
      std::all_of(modes.begin(), modes.end(), [](const Mode& m) { return m.kind == ModeKind::damped; }))
    return Stability::asymptotically_stable;
  return Stability::stable;
}

ModalResult solve_modes(const LinearModel& model, const ModalOptions& options) {
  const Eigen::Index n = model.M.rows();
  if (model.M.cols() != n || model.K.rows() != n || model.K.cols() != n)
    throw std::invalid_argument("solve_modes: M and K must be square and of the same size (M is " +
                                std::to_string(model.M.rows()) + "×" + std::to_string(model.M.cols()) +
                                ", K " + std::to_string(model.K.rows()) + "×" +
                                std::to_string(model.K.cols()) + ")");
  if (n == 0) {
    ModalResult empty;
    copy_constraints(model, empty);
    empty.solver = model.constrained() ? "none (the constraints leave no degree of freedom)" : "none (no coordinates)";
    return empty;
  }
  require_finite(model.M, "mass matrix M");
  require_finite(model.K, "stiffness matrix K");
  const std::vector<std::string> names = coordinate_labels(model, n);

  // Everything below works on the equilibrated pencil (SKS, SMS), S = diag(s)
  // of powers of two (detail::equilibrating_scale: exact, the same
  // eigenvalues); shapes are mapped back at the end. Unscaled only where the
  // scaling would overflow or underflow.
  // A graded chain of parallel hinges is solved in their absolute angles θ,
  // its pencil assembled there (LinearModel::absolute); shapes are mapped back.
  const AbsoluteAngleModel& abs = model.absolute;
  const bool absolute = !abs.empty() && !model.constrained() && abs.M.rows() == n && abs.K.rows() == n &&
                        static_cast<Eigen::Index>(abs.parent.size()) == n && !model.has_gyroscopic &&
                        !model.circulatory && (!model.has_damping || (abs.D.rows() == n && abs.D.cols() == n));
  const MatrixX& M_in = absolute ? abs.M : model.M;
  const MatrixX& K_in = absolute ? abs.K : model.K;
  const MatrixX& K_error_in = absolute ? abs.K_magnitude : model.K_error;
  const MatrixX& K_systematic_in = absolute ? model.absolute_systematic_error : model.K_systematic_error;
  // Working copies, scaled in place (each n×n matrix is copied once: on a
  // 1000-link chain every extra n×n temporary is 8 MB of fresh pages, and
  // touching fresh pages cost more than the products of the error estimate).
  VectorX scale = detail::coordinate_scale(absolute ? abs.inertia_scale : model.inertia_scale, n);
  auto square = [n](const MatrixX& A) { return A.rows() == n && A.cols() == n; };
  if (!detail::scales_exactly(M_in, scale) || !detail::scales_exactly(K_in, scale)) scale = VectorX::Ones(n);
  MatrixX Ms = M_in, Ks = K_in, K_error = square(K_error_in) ? K_error_in : MatrixX(),
          K_systematic = square(K_systematic_in) ? K_systematic_in : MatrixX(),
          G_error = square(model.G_error) ? model.G_error : MatrixX();
  // C = D + G (empty when the model has neither); in θ, D = TᵀDT and its rounding bound.
  MatrixX Cs = absolute ? (model.has_damping ? abs.D : MatrixX()) : velocity_matrix(model, n),
          C_rounding = absolute && model.has_damping && square(abs.D_rounding) ? abs.D_rounding : MatrixX();
  for (MatrixX* A : {&Ms, &Ks, &K_error, &K_systematic, &G_error, &Cs, &C_rounding})
    if (A->size() != 0) detail::scale_symmetric_in_place(*A, scale);
  // The rounding form (sparse, as K: S F S, then the magnitude's power of
  // four), for the kinds of both solvers; not in absolute angles.
  SparseMatrix rounding_form;
  if (!absolute && model.K_rounding_form.rows() == n && model.K_rounding_form.cols() == n)
    rounding_form = scale.asDiagonal() * model.K_rounding_form * scale.asDiagonal();
  detail::ScaledSprings springs;
  if (!absolute && rounding_form.size() != 0) springs = {&model.K_spring_rounding, scale, 1.0};
  if (!symmetric_within_rounding(Ms))
    throw std::invalid_argument("solve_modes: the mass matrix is not symmetric");
  make_symmetric(Ms);

  ModalResult result;
  std::string asymmetric_note;
  bool symmetric = model.symmetric() && Cs.isZero(0.0);
  if (symmetric && !symmetric_within_rounding(Ks)) {
    symmetric = false;
    asymmetric_note =
        "K is not symmetric although the model declares no circulatory forces; "
        "solved as a general (first-order) problem";
  }
  // Magnitudes: the solvers see (αM, √(αβ)C, βK) with α, β powers of four
  // that bring the largest entries of M and K near 1 (detail::Magnitudes),
  // so that ω² = 1e160 does not overflow to an infinite estimate (which made
  // every mode a "zero" mode); exact, and undone on the results.
  detail::Magnitudes magnitude = detail::magnitudes(Ms.cwiseAbs().maxCoeff(), Ks.cwiseAbs().maxCoeff());
  {
    const int a = 2 * magnitude.a, b = 2 * magnitude.b, ab = magnitude.a + magnitude.b;
    const std::pair<MatrixX*, int> scaled[] = {{&Ms, a}, {&Ks, b}, {&Cs, ab}, {&K_error, b},
                                               {&K_systematic, b}, {&G_error, ab}, {&C_rounding, ab}};
    bool exact = true;
    for (const auto& [A, p] : scaled) exact = exact && detail::scales_exactly(*A, p);
    if (exact) {
      for (const auto& [A, p] : scaled) detail::scale_exactly(*A, p);
      rounding_form *= std::ldexp(1.0, b);
      springs.factor = std::ldexp(1.0, b);
    } else {
      magnitude = {};
    }
  }
  if (symmetric) {
    make_symmetric(Ks);
  } else if (Cs.size() == 0) {
    Cs.setZero(n, n);  // the first-order solver's C (follower loads alone)
  }
  // A point-mass chain's structure, in the units of Ms: l_j s_j times the
  // magnitude's power of two (exact; m unchanged).
  std::optional<PointMassChain> chain;
  if (absolute && symmetric && !abs.chain.empty() && abs.chain.lever.size() == n) {
    chain = abs.chain;
    for (Eigen::Index j = 0; j < n; ++j) chain->lever(j) = std::ldexp(chain->lever(j) * scale(j), magnitude.a);
  }
  // Else M's structure as a chain of rigid links (detail::LinkChain), read
  // from its entries (O(n²), most scenes leave at the first), where its
  // path can be taken: LAPACK solving and K diagonal.
  std::optional<detail::LinkChain> links;
  if (absolute && symmetric && !chain && options.dense_solver != DenseSolver::eigen &&
      (options.dense_solver == DenseSolver::lapack || detail::lapack_wins(n)) && detail::is_diagonal(Ks))
    links = detail::link_chain(Ms);
  // M's factor and definiteness test: formed here, or, for a chain, where
  // its path needs it (detail::MassFactor).
  auto factor = [&] { return detail::factor_mass(Ms, names, scale, absolute ? abs.parent : std::vector<int>{}); };
  const detail::MassFactor mass = chain || links ? detail::MassFactor(factor) : detail::MassFactor(factor());
  result = symmetric ? detail::solve_symmetric(Ms, Ks, mass, K_error, K_systematic, options.dense_solver,
                                               options.modes, rounding_form, chain ? &*chain : nullptr,
                                               links ? &*links : nullptr, &springs)
                     : detail::solve_first_order(Ms, Ks, Cs, mass(), K_error, K_systematic, G_error, C_rounding,
                                                 rounding_form);
  detail::restore_magnitudes(result, magnitude, symmetric);
  // Classify with every mode, then keep the lowest ones asked for (the
  // symmetric solver analyzes the others only as far as their kind needs:
  // they have no shapes), and note clusters among those kept.
  result.stability = classify(result.modes);
  if (options.modes >= 0 && static_cast<std::size_t>(options.modes) < result.modes.size())
    result.modes.resize(static_cast<std::size_t>(options.modes));
  add_cluster_notes(result.modes, symmetric, result.notes);
  if (!asymmetric_note.empty()) result.notes.insert(result.notes.begin(), asymmetric_note);
  result.steady = model.steady;
  unscale_shapes(scale, symmetric, result.modes);
  if (absolute) detail::absolute_to_relative(abs.parent, symmetric, result.modes);
  map_shapes_back(model, symmetric, result.modes);
  copy_constraints(model, result);
  return result;
}

const char* to_string(DenseSolver s) {
  switch (s) {
    case DenseSolver::automatic: return "auto";
    case DenseSolver::eigen: return "eigen";
    case DenseSolver::lapack: return "lapack";
  }
  return "?";
}

void add_cluster_notes(const std::vector<Mode>& modes, bool symmetric, std::vector<std::string>& notes) {
  using detail::format_number;
  auto value = [&](const Mode& m) { return symmetric ? std::complex<double>(m.omega2, 0) : m.s; };
  // Modes are one eigenvalue when every member of the group lies within the
  // error estimates of the first (the group's whole spread, not a chain of
  // neighbours each close to the next: 300 distinct eigenvalues of a long
  // chain, each within its estimate of the next, are not one eigenvalue), or
  // when the two agree to rounding level (64ε of the larger |λ|). Not 64ε of
  // the largest |λ| of all: beside a stiff joint's 1e20 rad²/s², a
  // cart-pendulum's 19.62 (estimate 1.4e-3) was "not resolved" from its two
  // zero modes.
  // `systematic`: whether the systematic part of the estimates counts
  // (Mode::systematic_error); without it, what separates the eigenvalues of
  // the matrices as formed.
  auto close = [&](const Mode& a, const Mode& b, bool systematic) {
    const double gap = std::abs(value(a) - value(b));
    const double ea = systematic ? a.error_estimate : std::max(0.0, a.error_estimate - a.systematic_error);
    const double eb = systematic ? b.error_estimate : std::max(0.0, b.error_estimate - b.systematic_error);
    return gap <= ea + eb ||
           gap <= 64 * std::numeric_limits<double>::epsilon() * std::max(std::abs(value(a)), std::abs(value(b)));
  };
  // Groups [first, last] of consecutive modes, as above.
  auto groups = [&](bool systematic) {
    std::vector<std::pair<std::size_t, std::size_t>> found;
    for (std::size_t first = 0; first < modes.size();) {
      std::size_t last = first;
      while (last + 1 < modes.size() && close(modes[last], modes[last + 1], systematic) &&
             close(modes[first], modes[last + 1], systematic))
        ++last;
      if (last > first) found.emplace_back(first, last);
      first = last + 1;
    }
    return found;
  };
  const auto unresolved = groups(false);
  for (const auto& [first, last] : unresolved) {
    std::ostringstream out;
    // Said as what is known: the values lie within each other's error
    // estimates, so they cannot be told apart at the stated accuracy; a
    // true repeat (by symmetry) and two close eigenvalues look alike here.
    out << "modes " << first + 1 << "–" << last + 1 << " are not resolved: their eigenvalues ";
    if (symmetric)
      out << "(λ ≈ " << format_number(modes[first].omega2, 10)
          << ") lie within each other's error estimates, so they may be one repeated eigenvalue; if so, their "
             "shapes are one M-orthonormal basis of the eigenspace, not unique (any M-orthonormal combination "
             "of them is equally valid)";
    else
      out << "(s ≈ " << format_number(modes[first].s.real(), 8) << (modes[first].s.imag() < 0 ? " − " : " + ")
          << format_number(std::abs(modes[first].s.imag()), 8)
          << "i) lie within each other's error estimates; if they are one eigenvalue, their shapes span the "
             "invariant subspace and are not unique, and if it is defective (coalescing modes, as at critical "
             "damping or at the onset of flutter) it is accurate only to about the square root of the rounding "
             "level";
    notes.push_back(out.str());
  }
  // Estimates that overlap only through their systematic part (a loose
  // equilibrium, differences): the eigenvalues of the matrices as formed are
  // told apart, so no multiplicity is claimed; what is not known is how far
  // apart, and in which order, they are at the exact K.
  for (const auto& [first, last] : groups(true)) {
    const bool one_group = std::any_of(unresolved.begin(), unresolved.end(), [&](const auto& g) {
      return g.first == first && g.second == last;
    });
    if (one_group) continue;
    double systematic = 0;
    for (std::size_t j = first; j <= last; ++j) systematic = std::max(systematic, modes[j].systematic_error);
    std::ostringstream out;
    out << "modes " << first + 1 << "–" << last + 1 << ": their eigenvalues ";
    if (symmetric)
      out << "(λ from " << format_number(modes[first].omega2, 10) << " to " << format_number(modes[last].omega2, 10)
          << ")";
    else
      out << "(|s| from " << format_number(std::abs(modes[first].s), 8) << " to "
          << format_number(std::abs(modes[last].s), 8) << ")";
    out << " are closer together than the systematic part of their error estimates (up to "
        << format_number(systematic, 2)
        << ", from an equilibrium accepted at a loose tolerance or from derivatives by differences), so their "
           "spacing and order at the exact equilibrium are known only to within it; for the matrices as formed "
           "the solver's error tells them apart (but for any group of them that another note names)";
    notes.push_back(out.str());
  }
}

namespace detail {

// Shapes solved in the absolute angles θ of parallel hinges (LinearModel::
// absolute) to the model's coordinates: φ_q = T φ_θ, q_c = θ_c − θ_parent(c)
// (M-normalization carries over: φ_qᵀMφ_q = φ_θᵀ(TᵀMT)φ_θ), real shapes
// signed again so that their largest component is positive.
void absolute_to_relative(const std::vector<int>& parent, bool real, std::vector<Mode>& modes) {
  for (Mode& m : modes) {
    if (m.shape.size() != static_cast<Eigen::Index>(parent.size())) continue;
    const Eigen::VectorXcd theta = m.shape;
    for (std::size_t c = 0; c < parent.size(); ++c)
      if (parent[c] >= 0) m.shape[static_cast<Eigen::Index>(c)] -= theta[parent[c]];
    const std::complex<double> top = m.shape(detail::dominant_index(m.shape));
    if (real && top.real() < 0) m.shape = -m.shape;
    if (!real && top != std::complex<double>(0)) m.shape /= top;  // largest component 1, as solve_first_order's
  }
}

Mode make_mode(std::complex<double> s, double error, ModeKind kind) {
  Mode m;
  m.omega2 = nan;
  m.s = s;
  m.growth_rate = s.real();
  m.omega = s.imag();
  m.frequency_hz = m.omega / (2 * std::numbers::pi);
  m.period = m.omega > 0 ? 2 * std::numbers::pi / m.omega : std::numeric_limits<double>::infinity();
  m.damping_ratio = (kind == ModeKind::zero || std::abs(s) == 0) ? nan : -s.real() / std::abs(s);
  m.error_estimate = error;
  m.kind = kind;
  return m;
}

Magnitudes magnitudes(double largest_M, double largest_K) {
  // 4^k near 1/x: k = −⌊(e + 1)/2⌋ with e = ⌊log₂ x⌋, as equilibrating_scale.
  auto exponent = [](double x) {
    return x > 0 && std::isfinite(x) ? -static_cast<int>(std::floor((std::ilogb(x) + 1) / 2.0)) : 0;
  };
  return {exponent(largest_M), exponent(largest_K)};
}

// A product with 2^p is ldexp(·, p) (one correctly rounded operation either
// way) while 2^p and 2^−p are normal numbers; it is several times faster
// than the library call (1000×1000 matrices, several per analysis).
bool scales_exactly(const MatrixX& A, int p) {
  if (p == 0) return true;
  const bool product = std::abs(p) <= 1000;
  const double up = product ? std::ldexp(1.0, p) : 0.0, down = product ? std::ldexp(1.0, -p) : 0.0;
  for (Eigen::Index j = 0; j < A.cols(); ++j)
    for (Eigen::Index i = 0; i < A.rows(); ++i) {
      const double a = A(i, j), v = product ? a * up : std::ldexp(a, p);
      if (!std::isfinite(v) || (product ? v * down : std::ldexp(v, -p)) != a) return false;
    }
  return true;
}

bool scale_exactly(MatrixX& A, int p) {
  if (p == 0 || A.size() == 0) return true;
  if (!scales_exactly(A, p)) return false;
  if (std::abs(p) <= 1000) A *= std::ldexp(1.0, p);
  else A = A.unaryExpr([p](double v) { return std::ldexp(v, p); });
  return true;
}
void restore_magnitudes(ModalResult& result, const Magnitudes& m, bool symmetric) {
  const int d = m.a - m.b;  // λ = λ'·4^d, s = s'·2^d
  const double root = std::ldexp(1.0, d), shape = std::ldexp(1.0, m.a);
  for (std::size_t j = 0; j < result.modes.size(); ++j) {
    Mode& mode = result.modes[j];
    if (d != 0) {
      mode.s *= root;
      mode.growth_rate *= root;
      mode.omega *= root;
      mode.frequency_hz *= root;
      mode.period /= root;
      if (symmetric) {
        mode.omega2 = std::ldexp(mode.omega2, 2 * d);
        mode.error_estimate = std::ldexp(mode.error_estimate, 2 * d);
        mode.residual_bound = std::ldexp(mode.residual_bound, 2 * d);
        mode.systematic_error = std::ldexp(mode.systematic_error, 2 * d);
      } else {
        mode.error_estimate *= root;
        mode.systematic_error *= root;
      }
    }
    if (symmetric && m.a != 0) mode.shape *= shape;
    const bool finite = std::isfinite(mode.s.real()) && std::isfinite(mode.s.imag()) &&
                        std::isfinite(mode.error_estimate) &&
                        (!symmetric || (std::isfinite(mode.omega2) && std::isfinite(mode.residual_bound)));
    // An eigenvalue told from zero whose value fell below the normal range
    // when scaled back has lost its digits (a subnormal or 0).
    const double value = symmetric ? std::abs(mode.omega2) : std::abs(mode.s);
    if (mode.kind != ModeKind::zero && value < std::numeric_limits<double>::min())
      throw NumericalError("mode " + std::to_string(j + 1) + ": its eigenvalue (" + (symmetric ? "ω² " : "s ") +
                           format_number(value, 3) +
                           ") lies below the range of double precision, so it cannot be given to any accuracy; "
                           "rescale the scene's units (masses, lengths, stiffnesses or g)");
    if (!finite)
      throw NumericalError("mode " + std::to_string(j + 1) + ": its " +
                           (symmetric ? "eigenvalue ω², error estimate or residual bound" : "eigenvalue or error estimate") +
                           " is not finite (" + format_number(symmetric ? mode.omega2 : std::abs(mode.s), 3) + " ± " +
                           format_number(mode.error_estimate, 3) +
                           "): it exceeds the range of double precision, so no stability class can be given; "
                           "rescale the scene's units (masses, lengths, stiffnesses or g)");
  }
}

double typical_quotient_rounding(double width, double n, double rows, double sums, double entries) {
  return 2 * (eps * (std::sqrt(width) * rows + std::sqrt(n) * sums) + entries);
}

// With v_e the motion of spring e's ends apart, C = Σ_e v_eᵀ(a uuᵀ + (a +
// b)(I − uuᵀ))v_e is the part of its rounding that springs computed alike
// may share (their own computation and data: counted coherently, at its
// bound, each rounding ε, twice the unit roundoff) and R = (Σ_e (r
// v_eᵀ(uuᵀ + 2(I − uuᵀ))v_e)²)^½ its end points' rounding, independent
// from spring to spring, at the typical size of a sum of independent errors
// (SpringRounding). ε(C + R) in all: (C + R)/8 in units of 4ε, doubled by
// typical_quotient_rounding. The other terms as in F (4ε each, coherent).
// On a smooth mode of a net each v_e = φ_a − φ_b is small against φ (a
// spring's block [s −s; −s s] cancels along a smooth shape), which the
// entrywise figures (|K_ij φ_i φ_j| in squares) cannot see, and R is far
// below φᵀFφ's sum of the ends' rounding: the net of models/net.toml had
// estimates 120–410 × its true errors from the entrywise figure, 17–23 ×
// with this (results/estimate_honesty.md).
double spring_by_spring(const ScaledSprings& scaled, const VectorX& phi) {
  if (!scaled.fits(phi.size())) return std::numeric_limits<double>::infinity();
  const SpringRounding& springs = *scaled.springs;
  const bool scaling = scaled.scale.size() == phi.size();
  const VectorX v = scaling ? VectorX(springs.G * scaled.scale.cwiseProduct(phi)) : VectorX(springs.G * phi);
  double coherent = 0, spread = 0;
  for (Eigen::Index e = 0; e < springs.blocks.cols(); ++e) {
    const auto block = springs.blocks.col(e);
    const Eigen::Vector3d ve = v.segment<3>(3 * e);
    const double along = std::pow(block.head<3>().dot(ve), 2), across = std::max(0.0, ve.squaredNorm() - along);
    coherent += block(3) * along + (block(3) + block(4)) * across;
    spread += std::pow(block(5) * (along + 2 * across), 2);
  }
  const double others = scaling ? scaled.scale.cwiseProduct(phi).cwiseAbs2().dot(springs.others)
                                : phi.cwiseAbs2().dot(springs.others);
  return scaled.factor * ((coherent + std::sqrt(spread)) / 8 + others);
}

bool ScaledSprings::fits(Eigen::Index n) const {
  return springs != nullptr && !springs->empty() && springs->G.cols() == n &&
         springs->G.rows() == 3 * springs->blocks.cols() && springs->others.size() == n;
}

Eigen::Index dominant_index(const Eigen::VectorXcd& v) {
  // |z|, without hypot where z is real (the same value: hypot(x, 0) = |x|);
  // hypot per entry had cost a 1000-link chain's all-pairs analysis 7 %.
  auto size = [&v](Eigen::Index i) { return v(i).imag() == 0 ? std::abs(v(i).real()) : std::abs(v(i)); };
  double largest = 0;
  for (Eigen::Index i = 0; i < v.size(); ++i) largest = std::max(largest, size(i));
  for (Eigen::Index i = 0; i < v.size(); ++i)
    if (size(i) >= largest * (1 - 1e-12)) return i;
  return 0;
}

}  // namespace detail
}  // namespace modal
