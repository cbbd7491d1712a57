// Forward-mode AD (modal/ad.hpp) against hand-derived derivatives.
#include "modal/ad.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using modal::Dual;

// Tolerance: the derivative rules are exact up to rounding of a handful of
// floating-point operations, so a few ulps relative.
constexpr double kTol = 1e-14;

TEST(Dual, ElementaryFunctionsMatchHandDerivatives) {
  const double x0 = 0.7;
  using D = Dual<double, 1>;
  const D x(x0, 0);
  struct Case { const char* name; D y; double dy; };
  const Case cases[] = {
      {"sin", sin(x), std::cos(x0)},
      {"cos", cos(x), -std::sin(x0)},
      {"tan", tan(x), 1 / (std::cos(x0) * std::cos(x0))},
      {"asin", asin(x), 1 / std::sqrt(1 - x0 * x0)},
      {"acos", acos(x), -1 / std::sqrt(1 - x0 * x0)},
      {"atan", atan(x), 1 / (1 + x0 * x0)},
      {"sinh", sinh(x), std::cosh(x0)},
      {"cosh", cosh(x), std::sinh(x0)},
      {"tanh", tanh(x), 1 - std::tanh(x0) * std::tanh(x0)},
      {"exp", exp(x), std::exp(x0)},
      {"log", log(x), 1 / x0},
      {"sqrt", sqrt(x), 0.5 / std::sqrt(x0)},
      {"pow 2.5", pow(x, 2.5), 2.5 * std::pow(x0, 1.5)},
      {"x*x/x", x * x / x, 1.0},
      {"1/x", 1.0 / x, -1 / (x0 * x0)},
      {"3-x", 3.0 - x, -1.0},
  };
  for (const auto& c : cases) EXPECT_NEAR(c.y.d[0], c.dy, kTol * std::max(1.0, std::abs(c.dy))) << c.name;
}

TEST(Dual, PowerOfNegativeBaseWithIntegerExponent) {
  using D = Dual<double, 1>;
  const D x(-1.5, 0);
  const D y = pow(x, D(3.0));
  EXPECT_NEAR(y.v, -3.375, kTol);
  EXPECT_NEAR(y.d[0], 3 * 2.25, kTol);
}

TEST(Dual, Atan2PartialDerivatives) {
  using D = Dual<double, 2>;
  const D y(0.3, 0), x(-0.8, 1);
  const D a = atan2(y, x);
  const double r2 = 0.3 * 0.3 + 0.8 * 0.8;
  EXPECT_NEAR(a.v, std::atan2(0.3, -0.8), kTol);
  EXPECT_NEAR(a.d[0], -0.8 / r2, kTol);
  EXPECT_NEAR(a.d[1], -0.3 / r2, kTol);
}

TEST(Dual, NestedDualsGiveTheHessian) {
  // f(x, y) = sin(x) y² + exp(x y): gradient and Hessian by hand.
  auto f = [](const auto& v) { return sin(v[0]) * v[1] * v[1] + exp(v[0] * v[1]); };
  const Eigen::Vector2d p(0.4, -1.3);
  const auto r = modal::ad::hessian<2>(f, p);
  const double x = p[0], y = p[1], e = std::exp(x * y);
  EXPECT_NEAR(r.value, std::sin(x) * y * y + e, kTol);
  EXPECT_NEAR(r.gradient[0], std::cos(x) * y * y + y * e, kTol);
  EXPECT_NEAR(r.gradient[1], 2 * std::sin(x) * y + x * e, kTol);
  EXPECT_NEAR(r.hessian(0, 0), -std::sin(x) * y * y + y * y * e, kTol);
  EXPECT_NEAR(r.hessian(0, 1), 2 * std::cos(x) * y + e + x * y * e, kTol);
  EXPECT_NEAR(r.hessian(1, 0), r.hessian(0, 1), kTol);
  EXPECT_NEAR(r.hessian(1, 1), 2 * std::sin(x) + x * x * e, kTol);
}

TEST(Dual, WorksAsEigenScalar) {
  using D = Dual<double, 1>;
  Eigen::Matrix<D, 3, 3> R = Eigen::Matrix<D, 3, 3>::Identity();
  const D t(0.2, 0);
  R(0, 0) = cos(t); R(0, 1) = -sin(t); R(1, 0) = sin(t); R(1, 1) = cos(t);
  const Eigen::Matrix<D, 3, 1> v(D(1.0), D(0.0), D(0.0));
  const Eigen::Matrix<D, 3, 1> w = R * v;
  EXPECT_NEAR(w[1].v, std::sin(0.2), kTol);
  EXPECT_NEAR(w[1].d[0], std::cos(0.2), kTol);
  EXPECT_NEAR((R.transpose() * R)(0, 0).d[0], 0.0, kTol);
}

}  // namespace
