// modal/expression_eval.hpp — evaluation of compiled expressions (included by
// modal/expression.hpp; not meant to be included on its own).
//
// The postfix code of an Expression runs on a small stack of scalars S. The
// elementary operations are written once, templated on S, and found by
// argument-dependent lookup for modal::Dual (modal/ad.hpp), so the same code
// evaluates values (S = double), gradients (Dual<double, N>) and Hessians
// (Dual<Dual<double, N>, N>). The parser folds constant subexpressions with the
// same functions (S = double), so folded and unfolded code agree bit for bit.
#pragma once

#include "modal/ad.hpp"
#include "modal/expression.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

namespace modal::expression_detail {

// Number of operands an operation takes from the stack (0 for leaves).
constexpr int arity(Expression::Op op) {
  using Op = Expression::Op;
  switch (op) {
    case Op::constant:
    case Op::variable: return 0;
    case Op::add: case Op::sub: case Op::mul: case Op::div: case Op::pow:
    case Op::atan2: case Op::hypot: case Op::min: case Op::max: return 2;
    default: return 1;
  }
}

// f(x) for a one-operand operation.
template <class S>
S apply_unary(Expression::Op op, const S& x) {
  using Op = Expression::Op;
  using std::sin, std::cos, std::tan, std::asin, std::acos, std::atan, std::sinh, std::cosh,
      std::tanh, std::exp, std::log, std::sqrt, std::abs;
  switch (op) {
    case Op::neg: return -x;
    case Op::sin: return sin(x);
    case Op::cos: return cos(x);
    case Op::tan: return tan(x);
    case Op::asin: return asin(x);
    case Op::acos: return acos(x);
    case Op::atan: return atan(x);
    case Op::sinh: return sinh(x);
    case Op::cosh: return cosh(x);
    case Op::tanh: return tanh(x);
    case Op::exp: return exp(x);
    case Op::log: return log(x);
    case Op::sqrt: return sqrt(x);
    case Op::abs: return abs(x);
    default: return x;  // not reached: the parser emits only the operations above
  }
}

// f(a, b) for a two-operand operation (a pushed first).
template <class S>
S apply_binary(Expression::Op op, const S& a, const S& b) {
  using Op = Expression::Op;
  using std::pow, std::atan2, std::hypot;
  switch (op) {
    case Op::add: return a + b;
    case Op::sub: return a - b;
    case Op::mul: return a * b;
    case Op::div: return a / b;
    case Op::pow: return pow(a, b);
    case Op::atan2: return atan2(a, b);
    case Op::hypot: return hypot(a, b);
    case Op::min: return b < a ? b : a;  // derivative of the selected branch
    case Op::max: return a < b ? b : a;
    default: return a;  // not reached
  }
}

}  // namespace modal::expression_detail

namespace modal {

template <class S>
S Expression::evaluate(const S* variables) const {
  if (code_.empty()) return S(0.0);  // a default-constructed Expression is 0
  // Small stacks live on the machine stack; deep expressions of large (nested
  // dual) scalars fall back to the heap.
  constexpr std::size_t inline_slots = std::clamp<std::size_t>(1024 / sizeof(S), 1, 16);
  std::array<S, inline_slots> local;
  std::vector<S> heap;
  S* stack = local.data();
  if (static_cast<std::size_t>(stack_depth_) > inline_slots) {
    heap.resize(static_cast<std::size_t>(stack_depth_));
    stack = heap.data();
  }
  std::size_t top = 0;  // number of values on the stack
  for (const Instruction& ins : code_) {
    switch (expression_detail::arity(ins.op)) {
      case 0:
        stack[top++] = ins.op == Op::constant ? S(ins.value)
                                              : variables[static_cast<std::size_t>(ins.index)];
        break;
      case 1:
        stack[top - 1] = expression_detail::apply_unary(ins.op, stack[top - 1]);
        break;
      default:
        stack[top - 2] = expression_detail::apply_binary(ins.op, stack[top - 2], stack[top - 1]);
        --top;
        break;
    }
  }
  return stack[0];
}

}  // namespace modal
