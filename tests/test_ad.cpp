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

// Complex steps: Im f(x + ih)/h with h = 1e-30 equals the dual-number
// derivative to rounding for every elementary function, with no cancellation;
// as an Eigen scalar Complex is "real": squaredNorm() and dot() continue
// analytically (Σ z², no conjugate), which complex steps need.
TEST(Complex, StepDerivativesMatchDuals) {
  using modal::Complex;
  using D = Dual<double, 1>;
  const double x0 = 0.7, h = 1e-30;
  const Complex z(x0, h);
  const D x(x0, 0);
  auto check = [&](const char* name, const Complex& fz, const D& fx) {
    EXPECT_NEAR(fz.re, fx.v, kTol) << name;
    EXPECT_NEAR(fz.im / h, fx.d[0], kTol * (1 + std::abs(fx.d[0]))) << name;
  };
  check("sin", sin(z), sin(x));
  check("cos", cos(z), cos(x));
  check("tan", tan(z), tan(x));
  check("asin", asin(z), asin(x));
  check("acos", acos(z), acos(x));
  check("atan", atan(z), atan(x));
  check("sinh", sinh(z), sinh(x));
  check("exp", exp(z), exp(x));
  check("log", log(z), log(x));
  check("sqrt", sqrt(z), sqrt(x));
  check("pow 3", pow(z, 3.0), pow(x, 3.0));
  check("pow -2", pow(z, -2.0), pow(x, -2.0));
  check("pow 2.5", pow(z, 2.5), pow(x, 2.5));
  check("atan2", atan2(z, Complex(0.3)), atan2(x, D(0.3)));
  check("abs of a negative", abs(-z), abs(-x));
  check("quotient", (z * z + 1.0) / (2.0 - z), (x * x + 1.0) / (2.0 - x));
  // Nested: a dual number over a complex base (the gradient at a complex point).
  const Dual<Complex, 1> y(z, 0);
  const Dual<Complex, 1> f = sin(y) * y;  // f' = cos(y) y + sin(y)
  EXPECT_NEAR(f.d[0].re, std::cos(x0) * x0 + std::sin(x0), kTol);
  // f'' = 2cos(y) − y sin(y), from the imaginary part of f' at x0 + ih
  EXPECT_NEAR(f.d[0].im / h, 2 * std::cos(x0) - x0 * std::sin(x0), kTol);
  const Eigen::Matrix<Complex, 3, 1> v(z, Complex(0.2), Complex(-0.4, 2 * h));
  const Complex n2 = v.squaredNorm();  // x² + 0.04 + 0.16 with derivative 2x·1 + 2(−0.4)·2
  EXPECT_NEAR(n2.re, x0 * x0 + 0.2, kTol);
  EXPECT_NEAR(n2.im / h, 2 * x0 - 1.6, kTol);
  EXPECT_NEAR(v.dot(v).im / h, 2 * x0 - 1.6, kTol);
  EXPECT_TRUE(z < 0.8);  // comparisons by the real part
  EXPECT_TRUE(isfinite(z));
}

}  // namespace
