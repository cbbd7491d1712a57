// modal amplitude (issue 6, part 3): the frequency of the nonlinear motion
// released from a mode shape, against R8 (the simple pendulum, whose period
// is T/T₀ = 1/AGM(1, cos(θ₀/2))) and the amplitudes where it departs from the
// linear frequency by 1 % and 10 %, against the same closed form.
//
// Tolerances: the integrator runs at 1e-12 per step (the local error of
// rk8pd; over the few periods measured the phase error stays near 1e-12) and
// the crossing times are refined by Newton's method on the time until the
// step is below 1e-13 of the period, so a measured period is good to about
// 1e-11 relative; measured: within 4e-12 of R8 at every angle, the rounding
// of R8's 12 digits. The checks are 1e-9 (the issue asks for 1e-8), the closed
// form computed here to 1e-11. The amplitudes of the levels are bracketed to
// 1e-6 relative (AmplitudeOptions::amplitude_tolerance) and interpolated in
// the final bracket, where the departure is linear far below the bracket's
// width: they agree with the closed form to 1e-11, checked to 1e-9.
#include "modal/equilibrium.hpp"
#include "modal/linearize.hpp"
#include "modal/modes.hpp"
#include "modal/scene.hpp"
#include "modal/simulate.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

namespace {

using namespace modal;

// A point mass m on a massless rod l hanging from a hinge: ω₀² = g/l.
const char* const kPendulum =
    "gravity = [0, 0, -9.81]\n[[body]]\nname = \"rod\"\njoint = \"hinge\"\naxis = [0, 1, 0]\nmass = 1.3\n"
    "com = [0, 0, -0.7]\n";

// T/T₀ of the simple pendulum at amplitude θ₀: 1/AGM(1, cos(θ₀/2)).
double period_ratio(double theta0) {
  double a = 1, b = std::cos(theta0 / 2);
  for (int i = 0; i < 40 && std::abs(a - b) > 1e-16 * a; ++i) {
    const double m = 0.5 * (a + b);
    b = std::sqrt(a * b);
    a = m;
  }
  return 1 / a;
}

struct Pendulum {
  System system = build_system(parse_scene(kPendulum, "pendulum.toml"));
  Equilibrium equilibrium = find_equilibrium(system, system.initial_configuration());
  ModalResult modes = solve_modes(linearize(system, equilibrium.q));
};

TEST(Amplitude, ClosedFormMatchesReferenceR8) {  // the test's own reference against docs/design.md section 2
  const double deg = std::numbers::pi / 180;
  EXPECT_NEAR(period_ratio(10 * deg), 1.00190718814, 1e-11);
  EXPECT_NEAR(period_ratio(90 * deg), 1.18034059902, 1e-11);
  EXPECT_NEAR(period_ratio(150 * deg), 1.76220372950, 1e-11);
}

TEST(Amplitude, SimplePendulumPeriodsMatchR8) {
  const Pendulum p;
  const Mode& m = p.modes.modes.at(0);
  EXPECT_NEAR(m.omega, std::sqrt(9.81 / 0.7), 1e-12);
  const double deg = std::numbers::pi / 180;
  const double reference[][2] = {{10, 1.00190718814}, {30, 1.01740879760}, {60, 1.07318200715},
                                 {90, 1.18034059902}, {150, 1.76220372950}};
  for (const auto& [degrees, ratio] : reference) {
    const AmplitudePoint point =
        measure_frequency(p.system, p.equilibrium.q, m.shape.real(), m.omega, degrees * deg);
    ASSERT_TRUE(point.oscillates) << degrees;
    const double measured = m.omega / point.omega;  // T/T₀
    EXPECT_NEAR(measured, ratio, 1e-9 * ratio) << degrees << "°";
    EXPECT_LE(point.spread, 1e-10) << degrees << "°";  // one degree of freedom: periodic
  }
}

TEST(Amplitude, DepartureAmplitudesMatchTheClosedForm) {
  const Pendulum p;
  const Mode& m = p.modes.modes.at(0);
  AmplitudeOptions options;
  options.amplitudes = {0.05, 0.2, 0.6, 1.2, 2.0};
  const AmplitudeResponse r = amplitude_response(p.system, p.equilibrium.q, m.shape.real(), m.omega, options);
  EXPECT_EQ(r.coordinate, "rod");
  ASSERT_EQ(r.thresholds.size(), 2u);
  for (const AmplitudeThreshold& t : r.thresholds) {
    ASSERT_TRUE(t.reached) << t.level << " " << t.note;
    // ω/ω₀ = 1 − level ⇔ T/T₀ = 1/(1 − level): bisection on the closed form.
    double lo = 0.01, hi = 3.0;
    for (int i = 0; i < 200; ++i) {
      const double mid = 0.5 * (lo + hi);
      (1 / period_ratio(mid) > 1 - t.level ? lo : hi) = mid;
    }
    EXPECT_NEAR(t.amplitude, 0.5 * (lo + hi), 1e-9 * t.amplitude) << "level " << t.level;
    EXPECT_LE(t.error, 1e-6 * t.amplitude);
  }
}

// Beyond θ₀ = π the pendulum goes over the top: no oscillation about the
// equilibrium, said so. A level bracketed by such a point is still refined
// (ω/ω₀ = 0.5 at θ₀ = 2.7882311241, the closed form); a level whose period
// exceeds the 20 linear periods per cycle that a measurement waits (ω/ω₀ =
// 0.03, T/T₀ = 33) closes on the edge of the oscillations instead, in words.
TEST(Amplitude, OverTheTopIsNotAnOscillation) {
  const Pendulum p;
  const Mode& m = p.modes.modes.at(0);
  const AmplitudePoint over = measure_frequency(p.system, p.equilibrium.q, m.shape.real(), m.omega, 3.3);
  EXPECT_FALSE(over.oscillates);
  AmplitudeOptions options;
  options.amplitudes = {0.1, 3.3};
  options.levels = {0.5, 0.97};
  const AmplitudeResponse r = amplitude_response(p.system, p.equilibrium.q, m.shape.real(), m.omega, options);
  ASSERT_EQ(r.thresholds.size(), 2u);
  ASSERT_TRUE(r.thresholds[0].reached) << r.thresholds[0].note;
  EXPECT_NEAR(r.thresholds[0].amplitude, 2.7882311241072038, 1e-9 * 2.79);
  EXPECT_FALSE(r.thresholds[1].reached);
  EXPECT_NE(r.thresholds[1].note.find("stops oscillating"), std::string::npos) << r.thresholds[1].note;
  EXPECT_GT(r.thresholds[1].amplitude, 3.1);
  EXPECT_LT(r.thresholds[1].amplitude, std::numbers::pi);
}

// Two degrees of freedom: at small amplitude the measured frequency of each
// mode is the linear one (the nonlinear shift grows as a², 1e-7 at a = 1e-3),
// and the spread of the periods is small.
TEST(Amplitude, DoublePendulumSmallAmplitudeIsLinear) {
  const System sys = build_system(load_scene(std::string(MODAL_SOURCE_DIR) + "/models/double_pendulum.toml"));
  const Equilibrium eq = find_equilibrium(sys, sys.initial_configuration());
  const ModalResult modes = solve_modes(linearize(sys, eq.q));
  for (const Mode& m : modes.modes) {
    const AmplitudePoint point = measure_frequency(sys, eq.q, m.shape.real(), m.omega, 1e-3);
    ASSERT_TRUE(point.oscillates);
    EXPECT_NEAR(point.omega, m.omega, 1e-6 * m.omega);
    EXPECT_LE(point.spread, 1e-5);
  }
}

// The same pendulum written as a particle on a rod (a distance constraint,
// coordinates bob.x and bob.z): the amplitude is the displacement of bob.x,
// which the start keeps exactly on the circle, so x = l sin θ₀ starts the
// pendulum at θ₀ and R8 holds as for the hinge. The 1 % amplitude is
// l sin θ₁ with θ₁ that of the hinge pendulum.
TEST(Amplitude, ConstrainedPendulumMatchesR8) {
  const System sys = build_system(load_scene(std::string(MODAL_SOURCE_DIR) + "/models/particle_pendulum.toml"));
  ASSERT_TRUE(sys.has_constraints());
  const Equilibrium eq = find_equilibrium(sys, sys.initial_configuration());
  const ModalResult modes = solve_modes(linearize(sys, eq.q));
  const Mode& m = modes.modes.at(0);
  EXPECT_NEAR(m.omega, std::sqrt(9.81), 1e-12);
  const double deg = std::numbers::pi / 180;
  const double reference[][2] = {{10, 1.00190718814}, {30, 1.01740879760}, {60, 1.07318200715}};
  for (const auto& [degrees, ratio] : reference) {
    const AmplitudePoint point = measure_frequency(sys, eq.q, m.shape.real(), m.omega, std::sin(degrees * deg));
    ASSERT_TRUE(point.oscillates) << degrees;
    EXPECT_NEAR(m.omega / point.omega, ratio, 1e-9 * ratio) << degrees << "°";
  }
  AmplitudeOptions options;
  options.amplitudes = {0.2, 0.5};
  options.levels = {0.01};
  const AmplitudeResponse r = amplitude_response(sys, eq.q, m.shape.real(), m.omega, options);
  EXPECT_EQ(r.coordinate, "bob.x");
  EXPECT_EQ(r.kind, CoordinateKind::length);
  ASSERT_TRUE(r.thresholds.at(0).reached) << r.thresholds.at(0).note;
  double lo = 0.01, hi = 3.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (1 / period_ratio(mid) > 0.99 ? lo : hi) = mid;
  }
  EXPECT_NEAR(r.thresholds[0].amplitude, std::sin(0.5 * (lo + hi)), 1e-9 * r.thresholds[0].amplitude);
  // A displacement the rod does not allow (|x| > l) is refused in words.
  try {
    (void)measure_frequency(sys, eq.q, m.shape.real(), m.omega, 1.5);
    ADD_FAILURE() << "x = 1.5 m on a 1 m rod was accepted";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot be moved by"), std::string::npos) << e.what();
  }
}

// A steady motion (the conical pendulum, theta ignorable at the rate w = 5
// rad/s): the motion keeps the momentum of the steady motion at q̄, as
// linearize() analyzes it, so the frequency departs from the linear one as
// a² (not as a, which taking the momentum at the displaced start gave), and
// the small-amplitude frequency is the linear one.
TEST(Amplitude, SteadyMotionKeepsItsMomentum) {
  const System sys =
      build_system(load_scene(std::string(MODAL_SOURCE_DIR) + "/models/spherical_pendulum_angles.toml"));
  const Equilibrium eq = find_equilibrium(sys, sys.initial_configuration());
  const ModalResult modes = solve_modes(linearize(sys, eq.q));
  const Mode& m = modes.modes.at(0);
  const AmplitudePoint small = measure_frequency(sys, eq.q, m.shape.real(), m.omega, 1e-3);
  const AmplitudePoint larger = measure_frequency(sys, eq.q, m.shape.real(), m.omega, 1e-2);
  ASSERT_TRUE(small.oscillates && larger.oscillates);
  EXPECT_NEAR(small.omega, m.omega, 1e-6 * m.omega);
  EXPECT_NEAR(larger.shift / small.shift, 100, 5);  // ∝ a²
}

TEST(Amplitude, BadInput) {
  const Pendulum p;
  const Mode& m = p.modes.modes.at(0);
  EXPECT_THROW((void)measure_frequency(p.system, p.equilibrium.q, m.shape.real(), 0.0, 0.1), std::invalid_argument);
  EXPECT_THROW((void)measure_frequency(p.system, p.equilibrium.q, m.shape.real(), m.omega, -0.1),
               std::invalid_argument);
  EXPECT_THROW((void)measure_frequency(p.system, VectorX::Zero(2), m.shape.real(), m.omega, 0.1),
               std::invalid_argument);
  AmplitudeOptions descending;
  descending.amplitudes = {0.2, 0.1};
  EXPECT_THROW((void)amplitude_response(p.system, p.equilibrium.q, m.shape.real(), m.omega, descending),
               std::invalid_argument);
}

}  // namespace

// Progress of long work (issue 17 part 3): the amplitude scan reports each
// amplitude and each level's search, ending at done = total; a simulation
// reports its output samples, about 200 times, ending at done = total.
TEST(Amplitude, ProgressIsReportedUpToTheTotal) {
  const Pendulum p;
  const Mode& m = p.modes.modes.at(0);
  AmplitudeOptions o;
  o.points = 5;
  std::vector<std::pair<int, int>> calls;
  o.progress = [&calls](int done, int total) { calls.emplace_back(done, total); };
  amplitude_response(p.system, p.equilibrium.q, m.shape.real(), m.omega, o);
  ASSERT_EQ(calls.size(), 5u + o.levels.size());
  for (std::size_t i = 0; i < calls.size(); ++i) {
    EXPECT_EQ(calls[i].first, static_cast<int>(i) + 1);
    EXPECT_EQ(calls[i].second, static_cast<int>(calls.size()));
  }

  SimulationOptions so;
  so.duration = 2;
  so.interval = 0.001;  // 2001 samples
  calls.clear();
  so.progress = [&calls](int done, int total) { calls.emplace_back(done, total); };
  VectorX q0 = p.equilibrium.q;
  q0[0] += 0.1;
  const Trajectory tr = simulate(p.system, q0, VectorX::Zero(q0.size()), so);
  ASSERT_FALSE(calls.empty());
  EXPECT_LE(calls.size(), 220u);
  EXPECT_GE(calls.size(), 150u);
  for (std::size_t i = 1; i < calls.size(); ++i) EXPECT_GT(calls[i].first, calls[i - 1].first);
  EXPECT_EQ(calls.back().first, static_cast<int>(tr.size()));
  EXPECT_EQ(calls.back().second, static_cast<int>(tr.size()));
}
