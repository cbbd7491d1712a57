// modal/simulate.hpp — nonlinear time integration of a System: how a motion
// predicted by the linear model holds up in the nonlinear equations.
//
//   modal::System sys = modal::build_system(modal::load_scene("models/double_pendulum.toml"));
//   modal::SimulationOptions o;
//   o.duration = 820;                                  // s: 100 periods of the slow mode
//   const Eigen::Vector2d q0(2.0, 1.0), qd0(0, 0);     // rad, rad/s: a chaotic motion
//   modal::Trajectory tr = modal::simulate(sys, q0, qd0, o);
//   std::cout << tr.time.back() << " s, " << tr.steps << " steps, energy error "
//             << tr.max_energy_error << "\n";          // 820 s, ~23000 steps, energy error ~1e-11
//
// Equations. The state is y = (q, q̇, W), 2n + 1 numbers, integrated from
// (q0, q̇0, 0) at t = 0 by
//   q̇ = q̇,   q̈ = accelerations(q, q̇),   Ẇ = Q(q, q̇)ᵀ q̇
// i.e. M q̈ + C q̇ + G q̇ + ∇V = Q (modal/core.hpp; V is V_eff = V − T₀ in a
// rotating frame). W is the work done by the non-conservative forces Q
// (dampers, follower loads; generalized_forces()), so that the energy balance
//   E(t) − E(0) = W(t),   E = energy() = ½q̇ᵀMq̇ + V (− T₀: the Jacobi integral)
// holds for every scene, conservative or not (dE/dt = Qᵀq̇, docs/design.md
// "Equations of motion"), and its defect measures the integration error.
// For a conservative scene W ≡ 0 and E is conserved.
//
// Constraints: q̈ solves Lagrange's equations of the first kind with the
// constraints held to second order (accelerations(), null-space method). The
// start must satisfy c(q0) = 0 to 1e-8 × the length scale (q0 is then
// projected onto the manifold exactly) and q̇0 is projected onto its tangent
// space (A q̇0 = 0: velocity components the constraints forbid are removed).
// The drift of c and A q̇ that integration error leaves is removed at every
// output sample by the same projections (and the integrator restarted there),
// so it never grows beyond one sample interval's worth.
//
// Integrator: GSL odeiv2 driver with the explicit Runge–Kutta Prince–Dormand
// 8(9) pair (rk8pd), adaptive steps. Each step keeps the local error estimate
// of every state component y_i below
//   tolerance × (|y_i| + s_i),
// a relative plus an absolute part, the absolute part in the component's own
// scale s_i: 1 for angles and rotation-vector components (rad, rad/s),
// System::length_scale() for lengths (m, m/s), and for W the energy scale at
// the start, max(|E(0)|, ½q̇0ᵀMq̇0, |V(q0)|) (1 J if that is 0). The driver
// lands exactly on every output time (no interpolation).
//
// Energy error. With E0 = E(0), at every output sample
//   energy_error = (E − E0 − W) / energy_scale,
//   energy_scale = max(|E0|, max over the samples of ½q̇ᵀMq̇, max over the samples of |W|)
// (J). The scale cannot be near 0 by accident: a system that moves has kinetic
// energy, one that dissipates has work, and |E0| covers a motion so small that
// the round-off of V itself (ε|V|) is the floor of any energy comparison. It is
// relative to the energy as the scene defines it: an arbitrary constant added to
// V (the zero of the potential) enlarges |E0| and so the scale. max_energy_error
// is the largest |energy_error| over the samples (the energy is only evaluated
// at samples; finer `interval` gives a finer check).
//
// Default tolerance 1e-12. The energy error of rk8pd grows in proportion to
// the tolerance; over 100 periods of the lowest mode of large-amplitude motions
// of the bundled models it was at most 1.9e-11 at 1e-12 (a factor 50 below the
// 1e-9 this project promises), 2e-10 at 1e-11, and 2e-9 at 1e-10, which breaks
// the promise. The cost grows only as tolerance^(−1/8): 1e-12 takes 1.25 times
// the steps of 1e-11 and 1.6 times those of 1e-10. Below ~1e-14 the round-off
// of a step (ε|y|) reaches the tolerance and steps are rejected in numbers.
// Measurements: docs/design.md ("Simulation tolerance"), tests/test_simulate.cpp.
#pragma once

#include "modal/core.hpp"

#include <functional>
#include <string>
#include <vector>

namespace modal {

// The smallest per-step error bound accepted: below it the bound is under the
// rounding of a step, and the integrator only takes more steps.
inline constexpr double min_simulation_tolerance = 1e-15;

struct SimulationOptions {
  double duration = 0;       // s, end time (the motion starts at t = 0); > 0, finite
  double interval = 0;       // s, spacing of the output samples, > 0; 0: duration / 1000
  double tolerance = 1e-12;  // per-step relative (and scaled absolute) error bound, in [min_simulation_tolerance, 1)
  // Called as output samples are reached (done of total; about 200 calls in
  // all, the last with done = total); none when empty. The CLI's progress bar.
  std::function<void(int done, int total)> progress = nullptr;
};

// The largest number of output samples simulate() accepts (duration / interval + 1).
inline constexpr long max_simulation_samples = 10'000'000;

// A sampled motion. All vectors have one entry per output sample: t = 0,
// interval, 2·interval, …, and the last sample at exactly t = duration (closer
// than `interval` to the previous one when duration is not a multiple of it).
struct Trajectory {
  std::vector<std::string> coordinates;  // names of the n coordinates (System::coordinate_names())
  std::vector<double> time;              // s
  std::vector<VectorX> q;                // n each: rad, m (System coordinates, not canonicalized)
  std::vector<VectorX> qd;               // n each: rad/s, m/s
  std::vector<double> energy;            // E = ½q̇ᵀMq̇ + V (− T₀), J
  std::vector<double> work;              // W = ∫ Qᵀq̇ dt, J (identically 0 for a conservative scene)
  std::vector<double> energy_error;      // (E − E0 − W) / energy_scale, signed, dimensionless
  double energy_scale = 0;               // J, see the header comment
  double max_energy_error = 0;           // max |energy_error|
  bool conservative = true;              // no dampers, no follower loads: Q ≡ 0 and E is conserved
  long steps = 0;                        // accepted rk8pd steps
  long rejected_steps = 0;               // steps retried with a smaller size
  long evaluations = 0;                  // evaluations of the right-hand side (~12–13 per step attempt)

  std::size_t size() const { return time.size(); }
};

// Integrates the equations of motion of `system` from q0 (n, rad or m, taken as
// given: not projected to an equilibrium) and q̇0 (n, rad/s or m/s) over
// [0, options.duration].
// Throws std::invalid_argument for wrong sizes, a non-finite start, duration not
// > 0 or not finite, interval < 0 or not finite, more than
// max_simulation_samples samples, tolerance not in (0, 1); NumericalError when
// the integration fails (singular mass matrix, non-finite state, step size
// that cannot meet the tolerance), its message saying at what time and why.
// A kinematic map whose ignorable coordinates are given by their rate is
// integrated as the free system at the momenta of the steady motion at q0
// (with_steady_momenta, kept coordinates at rest), as linearize() analyzes it:
// the ignorable coordinate turns freely, its momentum conserved.
Trajectory simulate(const System& system, const VectorX& q0, const VectorX& qd0, const SimulationOptions& options);

// --- validity of the linearization: frequency against amplitude -------------------
//
//   modal::AmplitudeResponse r = modal::amplitude_response(sys, eq.q, shape, omega, {});
//   // r.points: amplitude → measured ω; r.thresholds: where ω departs by 1 % and 10 %
//
// A mode of the linear model is released from rest at q̄ + a φ̂ (φ̂ the mode
// shape scaled so that its largest component is 1: the amplitude a is the
// displacement of that coordinate, rad or m) and the nonlinear equations are
// integrated (simulate(), rk8pd). With constraints the start is the
// projection of q̄ + b φ̂ onto c = 0 (project_onto_constraints), b chosen by a
// secant iteration so that the coordinate still moves by exactly a (a
// pendulum written as a particle on a rod of length l, released at x = a,
// starts at θ₀ = asin(a/l)); an amplitude the constraints do not allow is a
// NumericalError saying so. Ignorable coordinates given by their rate keep
// the momenta of the steady motion at q̄ (with_steady_momenta(system, q̄)), the
// system linearize() analyzes, for every start and every integration.
// The modal coordinate η(t) = φᵀM(q̄)(q − q̄) (φ M-normalized) starts at its
// maximum; its downward zero crossings are located to ~1e-13 of the period by
// Newton's method on the crossing time (re-integrating from the last sample
// before it, with η̇ = φᵀM q̇), and the period is the mean spacing of
// `cycles` + 1 successive crossings: ω = 2π/T. A one-degree-of-freedom motion
// is exactly periodic; a mode of a larger system exchanges energy with the
// others at finite amplitude, and the spread of the individual periods about
// their mean is reported as the measurement's uncertainty.
//
// Accuracy: the integrator's tolerance (default 1e-12) bounds the error of a
// period to about 1e-11 relative; the crossing times are refined until the
// Newton step is below 1e-13 of the period. R8 (the simple pendulum, whose
// period is 2K(sin(θ₀/2))/π times the linear one) is reproduced within 4e-12
// at 10°…150° (the rounding of R8's 12 digits), as a hinge and as a particle
// on a rod; the tests check 1e-9 (tests/test_amplitude.cpp).
struct AmplitudeOptions {
  // Amplitudes to measure (> 0, ascending); empty: `points` values from
  // 1e-3 × max_amplitude to max_amplitude, evenly spaced in log.
  std::vector<double> amplitudes;
  double max_amplitude = 0;  // 0: 2.5 rad for an angle or rotation, 0.5 × length scale for a length
  int points = 10;
  int cycles = 4;            // periods measured per amplitude (≥ 1)
  double tolerance = 1e-12;  // integrator (SimulationOptions::tolerance)
  std::vector<double> levels{0.01, 0.1};  // departures |ω/ω_lin − 1| whose amplitudes are sought
  double amplitude_tolerance = 1e-6;      // relative, of the amplitudes found for the levels
  // Called after each amplitude measured and each level's search (done of
  // total = amplitudes + levels); none when empty. The CLI's progress bar.
  std::function<void(int done, int total)> progress = nullptr;
};

struct AmplitudePoint {
  double amplitude = 0;     // of the largest component of the shape, in its unit
  bool oscillates = false;  // false: η did not return through zero (the motion left the well)
  double omega = 0;         // measured ω = 2π/T, rad/s (0 when it does not oscillate)
  double shift = 0;         // ω/ω_lin − 1
  double spread = 0;        // largest |T_i/T − 1| of the individual periods (0 for one DOF)
  int cycles = 0;           // periods measured
  double seconds = 0;       // simulated time, s
};

struct AmplitudeThreshold {
  double level = 0;        // |ω/ω_lin − 1| sought, e.g. 0.01
  bool reached = false;    // within the amplitudes measured
  double amplitude = 0;    // where it is reached (refined), or the largest measured when not
  // Same unit as amplitude: half the width of the final bracket plus the
  // measurement's uncertainty carried to the amplitude, spread × (1 + level)
  // over the slope of |ω/ω_lin − 1| in the scan's bracket (negligible for one
  // degree of freedom, where the motion is periodic).
  double error = 0;
  // In words (with the amplitude and its unit), when not reached, when already
  // reached at the smallest amplitude, or when the motion stops oscillating
  // first (the bracket then closes on the amplitude where it stops, given in
  // `amplitude`).
  std::string note;
};

struct AmplitudeResponse {
  double omega_linear = 0;       // rad/s
  std::string coordinate;        // the coordinate of the shape's largest component (the amplitude's unit)
  CoordinateKind kind = CoordinateKind::angle;
  std::vector<AmplitudePoint> points;
  std::vector<AmplitudeThreshold> thresholds;
  long evaluations = 0;          // motions integrated
};

// The frequency of the nonlinear motion from q̄ + a φ̂ at rest (see above).
// `shape` (n) is the mode shape in the coordinates (as ModalResult gives it),
// omega_linear its linear frequency (> 0). Throws std::invalid_argument for
// wrong sizes, a non-positive frequency or amplitude, NumericalError when the
// integration fails.
AmplitudePoint measure_frequency(const System& system, const VectorX& equilibrium, const VectorX& shape,
                                 double omega_linear, double amplitude, const AmplitudeOptions& options = {});

// The scan over amplitudes and the amplitudes at options.levels.
AmplitudeResponse amplitude_response(const System& system, const VectorX& equilibrium, const VectorX& shape,
                                     double omega_linear, const AmplitudeOptions& options = {});

}  // namespace modal
