// Expressions: values, precedence, derivatives through dual numbers, errors
// with their exact positions (modal/expression.hpp).
#include "modal/expression.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

namespace {

using modal::Expression;
using modal::ExpressionError;

const std::vector<std::string> names{"x", "y", "m"};
const std::vector<double> values{0.5, 2.0, 3.0};

double eval(const std::string& text) { return Expression::parse(text, names).evaluate(values); }

TEST(expression, ArithmeticAndPrecedence) {
  EXPECT_DOUBLE_EQ(eval("1"), 1.0);
  EXPECT_DOUBLE_EQ(eval(".5"), 0.5);
  EXPECT_DOUBLE_EQ(eval("2.5e-1"), 0.25);
  EXPECT_DOUBLE_EQ(eval("1E2"), 100.0);
  EXPECT_DOUBLE_EQ(eval("2+3*4"), 14.0);
  EXPECT_DOUBLE_EQ(eval("(2+3)*4"), 20.0);
  EXPECT_DOUBLE_EQ(eval("10-4-3"), 3.0);   // left associative
  EXPECT_DOUBLE_EQ(eval("8/4/2"), 1.0);    // left associative
  EXPECT_DOUBLE_EQ(eval("2^3^2"), 512.0);  // right associative
  EXPECT_DOUBLE_EQ(eval("2**3**2"), 512.0);
  EXPECT_DOUBLE_EQ(eval("-2^2"), -4.0);    // ^ binds tighter than unary minus
  EXPECT_DOUBLE_EQ(eval("(-2)^2"), 4.0);
  EXPECT_DOUBLE_EQ(eval("2^-1"), 0.5);
  EXPECT_DOUBLE_EQ(eval("2*-3"), -6.0);
  EXPECT_DOUBLE_EQ(eval("--2"), 2.0);
  EXPECT_DOUBLE_EQ(eval("+3 - -1"), 4.0);
  EXPECT_DOUBLE_EQ(eval("-x^2"), -0.25);
  EXPECT_DOUBLE_EQ(eval("2*x*y + m/y"), 3.5);
  EXPECT_DOUBLE_EQ(eval("  m * ( y - x )  "), 4.5);
  EXPECT_DOUBLE_EQ(eval("1/0"), INFINITY);  // evaluation is plain IEEE arithmetic; callers check finiteness
}

TEST(expression, Functions) {
  const double x = 0.5, y = 2.0;
  EXPECT_DOUBLE_EQ(eval("sin(x)"), std::sin(x));
  EXPECT_DOUBLE_EQ(eval("cos(x)"), std::cos(x));
  EXPECT_DOUBLE_EQ(eval("tan(x)"), std::tan(x));
  EXPECT_DOUBLE_EQ(eval("asin(x)"), std::asin(x));
  EXPECT_DOUBLE_EQ(eval("acos(x)"), std::acos(x));
  EXPECT_DOUBLE_EQ(eval("atan(x)"), std::atan(x));
  EXPECT_DOUBLE_EQ(eval("atan2(y, -x)"), std::atan2(y, -x));
  EXPECT_DOUBLE_EQ(eval("sinh(x)"), std::sinh(x));
  EXPECT_DOUBLE_EQ(eval("cosh(x)"), std::cosh(x));
  EXPECT_DOUBLE_EQ(eval("tanh(x)"), std::tanh(x));
  EXPECT_DOUBLE_EQ(eval("exp(x)"), std::exp(x));
  EXPECT_DOUBLE_EQ(eval("log(y)"), std::log(y));
  EXPECT_DOUBLE_EQ(eval("sqrt(y)"), std::sqrt(y));
  EXPECT_DOUBLE_EQ(eval("abs(-y)"), 2.0);
  EXPECT_DOUBLE_EQ(eval("pow(y, 0.5)"), std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(eval("hypot(3, 4)"), 5.0);
  EXPECT_DOUBLE_EQ(eval("min(x, y)"), 0.5);
  EXPECT_DOUBLE_EQ(eval("max(x, y)"), 2.0);
  EXPECT_DOUBLE_EQ(eval("pi"), std::numbers::pi);
  EXPECT_DOUBLE_EQ(eval("2*pi*sqrt(m/y)"), 2 * std::numbers::pi * std::sqrt(1.5));
  EXPECT_DOUBLE_EQ(eval("sin(cos(x)^2 + 1)"), std::sin(std::cos(x) * std::cos(x) + 1));
}

TEST(expression, VariablesShadowPi) {
  const Expression e = Expression::parse("2*pi", {"pi"});
  EXPECT_DOUBLE_EQ(e.evaluate(std::vector<double>{10.0}), 20.0);
  EXPECT_FALSE(e.is_constant());
}

TEST(expression, ConstantFoldingAndIntrospection) {
  const Expression c = Expression::parse("2*pi*(1 + 3)^2", names);
  EXPECT_TRUE(c.is_constant());
  EXPECT_TRUE(c.variables_used().empty());
  EXPECT_DOUBLE_EQ(c.evaluate(values), 32 * std::numbers::pi);
  EXPECT_EQ(c.text(), "2*pi*(1 + 3)^2");

  const Expression e = Expression::parse("m*x + m*2", names);
  EXPECT_FALSE(e.is_constant());
  EXPECT_EQ(e.variables_used(), (std::vector<int>{0, 2}));

  const Expression k = Expression::constant(1.25);
  EXPECT_TRUE(k.is_constant());
  EXPECT_DOUBLE_EQ(k.evaluate(std::vector<double>{}), 1.25);
  EXPECT_EQ(k.text(), "1.25");

  EXPECT_TRUE(Expression::is_function("atan2"));
  EXPECT_FALSE(Expression::is_function("pi"));
}

// f(x, y) = x³ y + sin(x y): gradient and Hessian by hand.
TEST(expression, DerivativesThroughDuals) {
  using D1 = modal::Dual<double, 2>;
  using D2 = modal::Dual<D1, 2>;
  const Expression f = Expression::parse("x^3*y + sin(x*y)", {"x", "y"});
  const double x = 0.7, y = -1.3;
  const double fx = 3 * x * x * y + y * std::cos(x * y);
  const double fy = x * x * x + x * std::cos(x * y);
  const double fxx = 6 * x * y - y * y * std::sin(x * y);
  const double fxy = 3 * x * x + std::cos(x * y) - x * y * std::sin(x * y);
  const double fyy = -x * x * std::sin(x * y);

  const D1 first[2] = {D1(x, 0), D1(y, 1)};
  const D1 g = f.evaluate(first);
  EXPECT_NEAR(g.v, x * x * x * y + std::sin(x * y), 1e-15);
  EXPECT_NEAR(g.d[0], fx, 1e-14);
  EXPECT_NEAR(g.d[1], fy, 1e-14);

  const D2 second[2] = {D2(D1(x, 0), 0), D2(D1(y, 1), 1)};
  const D2 h = f.evaluate(second);
  EXPECT_NEAR(h.v.d[0], fx, 1e-14);
  EXPECT_NEAR(h.d[0].d[0], fxx, 1e-14);
  EXPECT_NEAR(h.d[0].d[1], fxy, 1e-14);
  EXPECT_NEAR(h.d[1].d[0], fxy, 1e-14);
  EXPECT_NEAR(h.d[1].d[1], fyy, 1e-14);
}

TEST(expression, DerivativesOfEveryFunction) {
  using D = modal::Dual<double, 1>;
  const double x = 0.3;
  struct Case {
    const char* text;
    double derivative;
  };
  const Case cases[] = {
      {"tan(x)", 1 / (std::cos(x) * std::cos(x))},
      {"asin(x)", 1 / std::sqrt(1 - x * x)},
      {"acos(x)", -1 / std::sqrt(1 - x * x)},
      {"atan(x)", 1 / (1 + x * x)},
      {"atan2(x, 2)", 2 / (4 + x * x)},
      {"sinh(x)", std::cosh(x)},
      {"cosh(x)", std::sinh(x)},
      {"tanh(x)", 1 - std::tanh(x) * std::tanh(x)},
      {"exp(2*x)", 2 * std::exp(2 * x)},
      {"log(x)", 1 / x},
      {"sqrt(x)", 0.5 / std::sqrt(x)},
      {"abs(-x)", 1.0},
      {"pow(x, 3)", 3 * x * x},
      {"2^x", std::log(2.0) * std::pow(2.0, x)},
      {"x^x", std::pow(x, x) * (std::log(x) + 1)},
      {"hypot(x, 0.4)", x / std::hypot(x, 0.4)},
      {"min(x, 1 - x)", 1.0},  // x < 1 − x: the derivative of the selected branch
      {"max(x, 1 - x)", -1.0},
      {"1/x", -1 / (x * x)},
      {"-x/2", -0.5},
  };
  for (const Case& c : cases) {
    const D arg[1] = {D(x, 0)};
    EXPECT_NEAR(Expression::parse(c.text, {"x"}).evaluate(arg).d[0], c.derivative, 1e-14) << c.text;
  }
}

// Deep expressions of large scalars evaluate on the heap: same result.
TEST(expression, DeepExpressionWithNestedDuals) {
  std::string text = "x";
  for (int i = 0; i < 40; ++i) text = "x*(1+" + text + ")";
  using D1 = modal::Dual<double, 3>;
  using D2 = modal::Dual<D1, 3>;
  const Expression e = Expression::parse(text, {"x"});
  const double x = 0.1;
  const D2 arg[1] = {D2(D1(x, 0), 0)};
  const D2 r = e.evaluate(arg);
  EXPECT_NEAR(r.v.v, e.evaluate(std::vector<double>{x}), 1e-15);
  const double h = 1e-5;
  const double fd = (e.evaluate(std::vector<double>{x + h}) - e.evaluate(std::vector<double>{x - h})) / (2 * h);
  EXPECT_NEAR(r.d[0].v, fd, 1e-8);
  EXPECT_NEAR(r.v.d[0], fd, 1e-8);
}

struct ErrorCase {
  const char* text;
  int position;
  const char* message;
};

TEST(expression, ErrorsWithPositions) {
  const ErrorCase cases[] = {
      {"", 0, "empty expression"},
      {"   ", 0, "empty expression"},
      {"2*q", 2, "unknown name 'q'"},
      {"1 + yy", 4, "unknown name 'yy' (did you mean 'y'?)"},
      {"sine(1)", 0, "unknown function 'sine' (did you mean 'sin'"},
      {"x + atan2(1)", 4, "function 'atan2' takes 2 arguments, got 1"},
      {"sin(1, 2)", 0, "function 'sin' takes 1 argument, got 2"},
      {"hypot()", 0, "function 'hypot' takes 2 arguments, got 0"},
      {"2*(x+(1", 7, "expected ')' to close '(' at 5"},
      {"(1 2)", 3, "expected ')' to close '(' at 0, got number '2'"},
      {"sin(x", 5, "expected ')' to close '(' at 3"},
      {"x+1)", 3, "unmatched ')'"},
      {"2+", 2, "unexpected end of expression"},
      {"m*(", 3, "unexpected end of expression"},
      {"2 # 3", 2, "unexpected character '#'"},
      {"1.2.3", 0, "malformed number '1.2.3'"},
      {"3*1e+", 2, "malformed number '1e+'"},
      {"x*.", 2, "malformed number '.'"},
      {"1e999", 0, "number '1e999' is out of range"},
      {"2 3", 2, "expected an operator or the end of the expression, got number '3'"},
      {"2x", 1, "expected an operator or the end of the expression, got name 'x'"},
      {"*2", 0, "expected a number, a name or '(', got '*'"},
      {"()", 1, "expected a number, a name or '(', got ')'"},
      {"max(1,)", 6, "expected a number, a name or '(', got ')'"},
      {"2*sin", 2, "'sin' is a function: write sin(...)"},
      {"x(2)", 0, "'x' is a variable, not a function"},
  };
  for (const ErrorCase& c : cases) {
    try {
      (void)Expression::parse(c.text, names);
      ADD_FAILURE() << "no error for \"" << c.text << "\"";
    } catch (const ExpressionError& e) {
      EXPECT_EQ(e.position(), c.position) << c.text << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find(c.message), std::string::npos) << c.text << ": " << e.what();
    }
  }
}

TEST(expression, CloseMatches) {
  EXPECT_EQ(modal::close_matches("masss", {"mass", "com", "name"}), std::vector<std::string>{"mass"});
  EXPECT_EQ(modal::close_matches("stifness", {"stiffness", "damping"}), std::vector<std::string>{"stiffness"});
  EXPECT_EQ(modal::close_matches("Mass", {"mass"}), std::vector<std::string>{"mass"});
  EXPECT_TRUE(modal::close_matches("q", {"m", "g"}).empty());  // a complete rewrite is no suggestion
  EXPECT_EQ(modal::did_you_mean("l3", {"l1", "l2", "m"}), " (did you mean 'l1' or 'l2'?)");
  EXPECT_EQ(modal::did_you_mean("zzz", {"l1"}), "");
}

}  // namespace
