// modal/expression.hpp — arithmetic expressions in scene files.
//
// Any number in a scene may be written as a string expression over the scene's
// parameters ("2*m", "l/2", "sqrt(k/m)"); expression-defined systems use the
// same expressions over coordinates and time. An Expression is parsed once into
// compact postfix code and evaluated with any scalar type, so that exact
// derivatives flow through it by automatic differentiation (modal/ad.hpp):
//
//   auto e = modal::Expression::parse("m*g*l*(1 - cos(theta))", {"m", "g", "l", "theta"});
//   double v = e.evaluate(std::vector<double>{1.0, 9.81, 2.0, 0.1});
//   modal::Dual<double, 1> th(0.1, 0);                  // d/dθ
//   auto d = e.evaluate<modal::Dual<double,1>>(std::array{...}.data());
//
// Grammar: numbers (1, 2.5, .5, 1e-3), names, + - * / and ^ (also **, right
// associative, binds tighter than unary minus: -x^2 = -(x^2)), parentheses,
// functions sin cos tan asin acos atan atan2(y,x) sinh cosh tanh exp log sqrt
// abs pow(x,y) hypot(x,y) min(a,b) max(a,b), and the constant pi.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace modal {

// A malformed expression. position() is the 0-based offset of the offending
// character in the expression text; message() says what is wrong, e.g.
// "unknown name 'q'", "expected ')' to close '(' at 3", "unexpected end".
// The deepest nesting an expression may have: parentheses, signs, powers and
// function calls inside one another count one level each (a deeper one is an
// ExpressionError, not a stack overflow).
inline constexpr int max_expression_depth = 200;

class ExpressionError : public std::runtime_error {
 public:
  ExpressionError(const std::string& message, int position)
      : std::runtime_error(message), position_(position) {}
  int position() const { return position_; }

 private:
  int position_;
};

class Expression {
 public:
  // Parses text; `variables` are the names it may use (index = position).
  // Throws ExpressionError.
  static Expression parse(std::string_view text, const std::vector<std::string>& variables);
  static Expression constant(double value);
  // True for the names of the built-in functions (sin, atan2, …), which cannot
  // be used as variable names.
  static bool is_function(std::string_view name);

  // Evaluates with variables[i] the value of variable i. S: double or modal::Dual.
  template <class S> S evaluate(const S* variables) const;
  double evaluate(const std::vector<double>& variables) const { return evaluate<double>(variables.data()); }

  bool is_constant() const;                 // uses no variable
  std::vector<int> variables_used() const;  // sorted, unique
  const std::string& text() const { return text_; }

  // Postfix code; public so the evaluator template below can read it.
  enum class Op : std::uint8_t {
    constant, variable, neg, add, sub, mul, div, pow,
    sin, cos, tan, asin, acos, atan, atan2, sinh, cosh, tanh, exp, log, sqrt, abs, hypot, min, max
  };
  struct Instruction {
    Op op;
    int index = 0;       // variable index
    double value = 0.0;  // constant
  };

 private:
  std::vector<Instruction> code_;
  int stack_depth_ = 0;
  std::string text_;
};

// At most `width` characters of `text` around byte `position` (whole UTF-8
// sequences), with "…" where it is cut: how a message quotes a user's text,
// which may be 100 000 characters long.
std::string excerpt(std::string_view text, std::size_t position = 0, std::size_t width = 60);

// Candidates close to `name` (small edit distance, or differing only in case),
// closest first: the suggestions of "did you mean …?" messages.
std::vector<std::string> close_matches(std::string_view name, const std::vector<std::string>& candidates);
// The same as a message suffix: " (did you mean 'a' or 'b'?)", or "" without matches.
std::string did_you_mean(std::string_view name, const std::vector<std::string>& candidates);

}  // namespace modal

#include "modal/expression_eval.hpp"  // the evaluate<S> template
