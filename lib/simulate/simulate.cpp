// Nonlinear time integration (modal/simulate.hpp): GSL odeiv2, rk8pd.
#include "modal/simulate.hpp"

#include "messages.hpp"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

namespace modal {

namespace {

using simulate_detail::number;

void check_options(const System& s, const VectorX& q0, const VectorX& qd0, const SimulationOptions& o) {
  const auto n = static_cast<Eigen::Index>(s.size());
  if (q0.size() != n || qd0.size() != n)
    throw std::invalid_argument("simulate: q0 and qd0 must have " + std::to_string(n) + " entries, got " +
                                std::to_string(q0.size()) + " and " + std::to_string(qd0.size()));
  if (!q0.allFinite() || !qd0.allFinite())
    throw std::invalid_argument("simulate: the initial state is not finite");
  if (!std::isfinite(o.duration) || o.duration <= 0)
    throw std::invalid_argument("simulate: the duration must be a finite number > 0 s, got " + number(o.duration));
  if (!std::isfinite(o.interval) || o.interval < 0)
    throw std::invalid_argument("simulate: the output interval must be a finite number > 0 s (0: duration/1000), got " +
                                number(o.interval));
  if (!(o.tolerance >= min_simulation_tolerance && o.tolerance < 1))
    throw std::invalid_argument("simulate: the tolerance must lie in [1e-15, 1), got " + number(o.tolerance));
}

// Output times: k·interval while below the duration, then the duration itself.
std::vector<double> sample_times(const SimulationOptions& o) {
  const double interval = o.interval > 0 ? o.interval : o.duration / 1000;
  const double ratio = o.duration / interval;
  // The (1 − 1e-12) absorbs the rounding of duration/interval for an exact multiple.
  if (!(ratio < static_cast<double>(max_simulation_samples)))
    throw std::invalid_argument(
        "simulate: " +
        (ratio < 1e15 ? std::to_string(static_cast<long long>(std::ceil(ratio * (1 - 1e-12))) + 1) : number(ratio)) +
        " samples (the start, then one every interval to the duration), more than the " +
        std::to_string(max_simulation_samples) + " allowed; give a longer interval or a shorter duration");
  const auto count = std::max<long>(1, static_cast<long>(std::ceil(ratio * (1 - 1e-12))));
  std::vector<double> times{0.0};
  for (long k = 1; k < count; ++k) {
    const double t = static_cast<double>(k) * interval;
    if (t >= o.duration) break;
    times.push_back(t);
  }
  times.push_back(o.duration);
  return times;
}

// The right-hand side f(t, y) for y = (q, q̇, W). Failures are recorded here and
// reported as a status to GSL (exceptions must not cross its C frames).
struct Rhs {
  const System* system = nullptr;
  Workspace* ws = nullptr;
  Eigen::Index n = 0;
  bool conservative = true;
  long evaluations = 0;
  bool last_failed = false;  // the most recent evaluation failed
  std::string failure;       // why it failed
  std::exception_ptr error;  // an unexpected exception, rethrown after the driver returns
};

int right_hand_side(double, const double y[], double f[], void* params) {
  Rhs& r = *static_cast<Rhs*>(params);
  ++r.evaluations;
  r.last_failed = true;
  const Eigen::Map<const VectorX> q(y, r.n), qd(y + r.n, r.n);
  if (!q.allFinite() || !qd.allFinite() || !std::isfinite(y[2 * r.n])) {
    r.failure = "the state is not finite (the motion blew up)";
    return GSL_EBADFUNC;
  }
  try {
    const VectorX qdd = accelerations(*r.system, *r.ws, q, qd);
    if (!qdd.allFinite()) {
      r.failure = "the accelerations are not finite";
      return GSL_FAILURE;  // GSL retries with a smaller step
    }
    Eigen::Map<VectorX>(f, r.n) = qd;
    Eigen::Map<VectorX>(f + r.n, r.n) = qdd;
    f[2 * r.n] = r.conservative ? 0.0 : generalized_forces(*r.system, *r.ws, q, qd).dot(qd);
  } catch (const NumericalError& e) {
    r.failure = e.what();
    return GSL_FAILURE;  // GSL retries with a smaller step
  } catch (...) {
    r.failure = "unexpected error";
    r.error = std::current_exception();
    return GSL_EBADFUNC;
  }
  r.last_failed = false;
  return GSL_SUCCESS;
}

// Constrained systems: q onto c(q) = 0 (project_onto_constraints) and q̇ onto
// the tangent space, q̇ ← N Nᵀ q̇ with N the orthonormal null-space basis of A.
// Returns whether anything moved.
bool project_state(const System& s, Workspace& w, Eigen::Ref<VectorX> q, Eigen::Ref<VectorX> qd) {
  const ConstraintProjection p = project_onto_constraints(s, w, q);
  const MatrixX& N = constraint_basis(constraint_jacobian(s, w, p.q)).null_space;
  const VectorX v = N * (N.transpose() * qd);
  const bool moved = p.q != q || v != qd;
  q = p.q;
  qd = v;
  return moved;
}

// GSL's explicit embedded Runge–Kutta Prince–Dormand (8, 9) step. GSL names
// its steppers by data objects, not functions; the program `modal` loads GSL
// on first use and fills in its copy of this object only then
// (cmake/ModalLazy.cmake, docs/design.md "Start-up"), so a call into GSL
// comes first: gsl_strerror, which has no side effect.
const gsl_odeiv2_step_type* prince_dormand_89() {
  static_cast<void>(gsl_strerror(GSL_SUCCESS));
  return gsl_odeiv2_step_rk8pd;
}

struct DriverFree {
  void operator()(gsl_odeiv2_driver* d) const { gsl_odeiv2_driver_free(d); }
};

}  // namespace

Trajectory simulate(const System& given, const VectorX& q0, const VectorX& qd0, const SimulationOptions& options) {
  check_options(given, q0, qd0, options);
  // Ignorable coordinates given by their rate: the free system at the momenta
  // of the steady motion at q0 (as linearize() analyzes it), not a drive.
  const System s = with_steady_momenta(given, q0);
  const std::vector<double> times = sample_times(options);
  const Eigen::Index n = s.size();
  Workspace ws(s);
  VectorX q_start = q0, qd_start = qd0;
  if (s.has_constraints()) {
    const double violation = constraint_values(s, ws, q0).norm();
    if (!(violation <= 1e-8 * s.length_scale()))
      throw std::invalid_argument("simulate: the initial configuration does not satisfy the constraints (‖c‖ = " +
                                  number(violation) + " m); start from an equilibrium or a point on the manifold");
    project_state(s, ws, q_start, qd_start);
  }

  Trajectory tr;
  tr.coordinates = s.coordinate_names();
  tr.conservative = !s.has_damping() && !s.has_follower_loads();

  // Absolute error scales per component (header comment).
  const double e0 = energy(s, ws, q_start, qd_start);
  const double t0 = kinetic_energy(s, ws, q_start, qd_start);
  double work_scale = std::max({std::abs(e0), t0, std::abs(e0 - t0)});
  if (!(work_scale > 0) || !std::isfinite(work_scale)) work_scale = 1;
  std::vector<double> scale(static_cast<std::size_t>(2 * n + 1), 1.0);
  for (Eigen::Index i = 0; i < n; ++i)
    if (s.coordinates()[static_cast<std::size_t>(i)].kind == CoordinateKind::length)
      scale[static_cast<std::size_t>(i)] = scale[static_cast<std::size_t>(n + i)] = s.length_scale();
  scale.back() = work_scale;

  Rhs rhs;
  rhs.system = &s;
  rhs.ws = &ws;
  rhs.n = n;
  rhs.conservative = tr.conservative;
  gsl_odeiv2_system ode{right_hand_side, nullptr, static_cast<std::size_t>(2 * n + 1), &rhs};
  // A first trial step of 1/100 of the sample spacing; the control adapts it.
  const double first_step =
      std::max((times.size() > 1 ? times[1] : options.duration) / 100, std::numeric_limits<double>::denorm_min());
  const std::unique_ptr<gsl_odeiv2_driver, DriverFree> driver(gsl_odeiv2_driver_alloc_scaled_new(
      &ode, prince_dormand_89(), first_step, options.tolerance, options.tolerance, 1.0, 0.0, scale.data()));
  if (!driver) throw NumericalError("simulate: GSL could not allocate the integrator");

  std::vector<double> y(static_cast<std::size_t>(2 * n + 1));
  Eigen::Map<VectorX>(y.data(), n) = q_start;
  Eigen::Map<VectorX>(y.data() + n, n) = qd_start;
  y.back() = 0;

  double t = 0, max_kinetic = 0, max_work = 0;
  long steps_before_reset = 0, rejected_before_reset = 0;  // counts of the integrator before restarts
  const int total = static_cast<int>(std::min<std::size_t>(times.size(), std::numeric_limits<int>::max()));
  const int stride = std::max(1, total / 200);
  int reached = 0;
  for (const double target : times) {
    if (options.progress && (++reached % stride == 0 || reached == total)) options.progress(reached, total);
    if (target > t) {
      const int status = gsl_odeiv2_driver_apply(driver.get(), &t, target, y.data());
      if (rhs.error) std::rethrow_exception(rhs.error);
      if (status != GSL_SUCCESS) {
        std::string why;
        if (rhs.last_failed)
          why = rhs.failure;
        else if (status == GSL_FAILURE)
          why = "the step size fell to " + number(std::abs(driver->h)) +
                " s and still cannot meet the tolerance (a singularity of the equations or of the coordinates?)";
        else
          why = gsl_strerror(status);
        throw NumericalError("simulate: the integration failed at t = " + number(t) + " s (after " +
                             std::to_string(driver->e->count) + " steps): " + why);
      }
    }
    const Eigen::Map<const VectorX> q(y.data(), n), qd(y.data() + n, n);
    if (!q.allFinite() || !qd.allFinite() || !std::isfinite(y.back()))
      throw NumericalError("simulate: the integration failed at t = " + number(t) +
                           " s: the state is not finite (the motion blew up)");
    if (s.has_constraints() &&
        project_state(s, ws, Eigen::Map<VectorX>(y.data(), n), Eigen::Map<VectorX>(y.data() + n, n))) {
      steps_before_reset += static_cast<long>(driver->e->count);
      rejected_before_reset += static_cast<long>(driver->e->failed_steps);
      gsl_odeiv2_driver_reset(driver.get());
    }
    tr.time.push_back(target);
    tr.q.emplace_back(q);
    tr.qd.emplace_back(qd);
    tr.energy.push_back(energy(s, ws, q, qd));
    tr.work.push_back(y.back());
    max_kinetic = std::max(max_kinetic, kinetic_energy(s, ws, q, qd));
    max_work = std::max(max_work, std::abs(y.back()));
  }

  tr.energy_scale = std::max({std::abs(tr.energy.front()), max_kinetic, max_work});
  tr.energy_error.reserve(tr.size());
  for (std::size_t k = 0; k < tr.size(); ++k) {
    const double defect = tr.energy[k] - tr.energy.front() - tr.work[k];
    const double relative = tr.energy_scale > 0 ? defect / tr.energy_scale : defect;
    tr.energy_error.push_back(relative);
    tr.max_energy_error = std::max(tr.max_energy_error, std::abs(relative));
  }
  tr.steps = steps_before_reset + static_cast<long>(driver->e->count);
  tr.rejected_steps = rejected_before_reset + static_cast<long>(driver->e->failed_steps);
  tr.evaluations = rhs.evaluations;
  return tr;
}

}  // namespace modal
