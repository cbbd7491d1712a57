// Expression parser: a hand-written recursive-descent parser over a small
// lexer, emitting postfix code (modal/expression.hpp for the grammar). Constant
// subexpressions are folded while the code is emitted: the operands of an
// operation are the last complete subexpressions of the code, so when those are
// constant instructions the operation can be applied at once.
#include "modal/expression.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <numbers>
#include <system_error>

namespace modal {
namespace {

using Op = Expression::Op;
using Instruction = Expression::Instruction;

struct Function {
  std::string_view name;
  Op op;
  int arguments;
};

constexpr std::array<Function, 18> functions{{
    {"sin", Op::sin, 1},     {"cos", Op::cos, 1},     {"tan", Op::tan, 1},
    {"asin", Op::asin, 1},   {"acos", Op::acos, 1},   {"atan", Op::atan, 1},
    {"atan2", Op::atan2, 2}, {"sinh", Op::sinh, 1},   {"cosh", Op::cosh, 1},
    {"tanh", Op::tanh, 1},   {"exp", Op::exp, 1},     {"log", Op::log, 1},
    {"sqrt", Op::sqrt, 1},   {"abs", Op::abs, 1},     {"pow", Op::pow, 2},
    {"hypot", Op::hypot, 2}, {"min", Op::min, 2},     {"max", Op::max, 2},
}};

const Function* find_function(std::string_view name) {
  for (const Function& f : functions)
    if (f.name == name) return &f;
  return nullptr;
}

std::vector<std::string> function_names() {
  std::vector<std::string> names;
  for (const Function& f : functions) names.emplace_back(f.name);
  return names;
}

enum class Kind { number, name, plus, minus, star, slash, caret, open, close, comma, end };

struct Token {
  Kind kind = Kind::end;
  int position = 0;        // 0-based offset in the text
  std::string_view text;   // as written
  double value = 0.0;      // numbers
};

bool is_name_start(char c) { return std::isalpha(static_cast<unsigned char>(c)) != 0 || c == '_'; }
bool is_name_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }

// How a token is named in messages: "number '2'", "name 'x'", "'*'", "the end".
std::string describe(const Token& t) {
  switch (t.kind) {
    case Kind::end: return "the end of the expression";
    case Kind::number: return "number '" + excerpt(t.text, 0, 40) + "'";
    case Kind::name: return "name '" + excerpt(t.text, 0, 40) + "'";
    default: return "'" + excerpt(t.text, 0, 40) + "'";
  }
}

class Parser {
 public:
  Parser(std::string_view text, const std::vector<std::string>& variables)
      : text_(text), variables_(variables) {}

  std::vector<Instruction> run() {
    if (std::all_of(text_.begin(), text_.end(), [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; }))
      throw ExpressionError("empty expression", 0);
    advance();
    expression();
    if (token_.kind == Kind::close) fail("unmatched ')'", token_.position);
    if (token_.kind != Kind::end)
      fail("expected an operator or the end of the expression, got " + describe(token_), token_.position);
    return std::move(code_);
  }

 private:
  [[noreturn]] static void fail(const std::string& message, int position) {
    throw ExpressionError(message, position);
  }

  int offset() const { return static_cast<int>(pos_); }

  // --- lexer -----------------------------------------------------------------
  void advance() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_])) != 0) ++pos_;
    token_ = Token{};
    token_.position = offset();
    if (pos_ >= text_.size()) return;
    const char c = text_[pos_];
    if (is_digit(c) || c == '.') return lex_number();
    if (is_name_start(c)) {
      const std::size_t start = pos_;
      while (pos_ < text_.size() && is_name_char(text_[pos_])) ++pos_;
      token_.kind = Kind::name;
      token_.text = text_.substr(start, pos_ - start);
      return;
    }
    std::size_t length = 1;
    switch (c) {
      case '+': token_.kind = Kind::plus; break;
      case '-': token_.kind = Kind::minus; break;
      case '/': token_.kind = Kind::slash; break;
      case '^': token_.kind = Kind::caret; break;
      case '(': token_.kind = Kind::open; break;
      case ')': token_.kind = Kind::close; break;
      case ',': token_.kind = Kind::comma; break;
      case '*':
        if (pos_ + 1 < text_.size() && text_[pos_ + 1] == '*') {
          token_.kind = Kind::caret;
          length = 2;
        } else {
          token_.kind = Kind::star;
        }
        break;
      default: {
        const auto byte = static_cast<unsigned char>(c);
        if (std::isprint(byte) != 0) fail(std::string("unexpected character '") + c + "'", offset());
        char hex[8];
        std::snprintf(hex, sizeof hex, "0x%02X", static_cast<unsigned>(byte));
        fail(std::string("unexpected character (byte ") + hex + ")", offset());
      }
    }
    token_.text = text_.substr(pos_, length);
    pos_ += length;
  }

  // digits [. digits] [(e|E) [+|-] digits], or . digits [...]
  void lex_number() {
    const std::size_t start = pos_;
    auto digits = [&] {
      const std::size_t from = pos_;
      while (pos_ < text_.size() && is_digit(text_[pos_])) ++pos_;
      return pos_ - from;
    };
    std::size_t mantissa = digits();
    if (pos_ < text_.size() && text_[pos_] == '.') {
      ++pos_;
      mantissa += digits();
    }
    bool ok = mantissa > 0;
    if (ok && pos_ < text_.size() && (text_[pos_] == 'e' || text_[pos_] == 'E')) {
      ++pos_;
      if (pos_ < text_.size() && (text_[pos_] == '+' || text_[pos_] == '-')) ++pos_;
      ok = digits() > 0;
    }
    if (pos_ < text_.size() && text_[pos_] == '.') ok = false;  // 1.2.3
    if (!ok) {
      while (pos_ < text_.size() && (is_name_char(text_[pos_]) || text_[pos_] == '.')) ++pos_;
      fail("malformed number '" + excerpt(text_.substr(start, pos_ - start), 0, 40) + "'", static_cast<int>(start));
    }
    token_.kind = Kind::number;
    token_.text = text_.substr(start, pos_ - start);
    const auto [end, error] = std::from_chars(token_.text.data(), token_.text.data() + token_.text.size(), token_.value);
    if (error == std::errc::result_out_of_range)
      fail("number '" + excerpt(token_.text, 0, 40) + "' is out of range", static_cast<int>(start));
    if (error != std::errc() || end != token_.text.data() + token_.text.size())
      fail("malformed number '" + excerpt(token_.text, 0, 40) + "'", static_cast<int>(start));
  }

  // --- code emission with constant folding ------------------------------------
  bool constant_at(std::size_t from_end) const {
    return code_.size() > from_end && code_[code_.size() - 1 - from_end].op == Op::constant;
  }

  void emit(Op op) {
    const int n = expression_detail::arity(op);
    if (n == 1 && constant_at(0)) {
      code_.back().value = expression_detail::apply_unary(op, code_.back().value);
      return;
    }
    if (n == 2 && constant_at(0) && constant_at(1)) {
      const double b = code_.back().value;
      code_.pop_back();
      code_.back().value = expression_detail::apply_binary(op, code_.back().value, b);
      return;
    }
    code_.push_back(Instruction{op, 0, 0.0});
  }
  void emit_constant(double value) { code_.push_back(Instruction{Op::constant, 0, value}); }

  // --- grammar ---------------------------------------------------------------
  // expression := term (('+' | '-') term)*
  void expression() {
    term();
    while (token_.kind == Kind::plus || token_.kind == Kind::minus) {
      const Op op = token_.kind == Kind::plus ? Op::add : Op::sub;
      advance();
      term();
      emit(op);
    }
  }

  // term := unary (('*' | '/') unary)*
  void term() {
    unary();
    while (token_.kind == Kind::star || token_.kind == Kind::slash) {
      const Op op = token_.kind == Kind::star ? Op::mul : Op::div;
      advance();
      unary();
      emit(op);
    }
  }

  // unary := ('-' | '+') unary | power        (so -x^2 = -(x^2), 2*-3 is fine)
  // Every recursion of the grammar (parentheses, signs, powers, arguments)
  // passes through here, so this is where the nesting is bounded: the parser
  // recurses, and an expression nested thousands deep would otherwise
  // overflow the machine stack.
  void unary() {
    if (++depth_ > max_expression_depth)
      fail("the expression is nested more than " + std::to_string(max_expression_depth) +
               " levels deep (parentheses, signs, powers and function calls inside one another); write it in "
               "simpler parts, e.g. as several parameters",
           token_.position);
    struct Leave {
      int& depth;
      ~Leave() { --depth; }
    } leave{depth_};
    if (token_.kind == Kind::minus) {
      advance();
      unary();
      emit(Op::neg);
    } else if (token_.kind == Kind::plus) {
      advance();
      unary();
    } else {
      power();
    }
  }

  // power := primary [('^' | '**') unary]     (right associative: 2^3^2 = 2^9)
  void power() {
    primary();
    if (token_.kind == Kind::caret) {
      advance();
      unary();
      emit(Op::pow);
    }
  }

  // primary := number | name | name '(' arguments ')' | '(' expression ')'
  void primary() {
    const Token t = token_;
    switch (t.kind) {
      case Kind::number:
        emit_constant(t.value);
        advance();
        return;
      case Kind::name:
        advance();
        if (token_.kind == Kind::open) return call(t);
        return name(t);
      case Kind::open:
        advance();
        expression();
        expect_close(t.position);
        return;
      case Kind::end:
        fail("unexpected end of expression", t.position);
      default:
        fail("expected a number, a name or '(', got " + describe(t), t.position);
    }
  }

  void expect_close(int open_position) {
    if (token_.kind == Kind::close) return advance();
    std::string message = "expected ')' to close '(' at " + std::to_string(open_position);
    if (token_.kind != Kind::end) message += ", got " + describe(token_);
    fail(message, token_.position);
  }

  void name(const Token& t) {
    const std::string_view n = t.text;
    const auto it = std::find(variables_.begin(), variables_.end(), n);
    if (it != variables_.end()) {
      code_.push_back(Instruction{Op::variable, static_cast<int>(it - variables_.begin()), 0.0});
      return;
    }
    if (n == "pi") return emit_constant(std::numbers::pi);
    if (find_function(n) != nullptr)
      fail("'" + std::string(n) + "' is a function: write " + std::string(n) + "(...)", t.position);
    std::vector<std::string> candidates = variables_;
    candidates.emplace_back("pi");
    fail("unknown name '" + excerpt(n, 0, 40) + "'" + did_you_mean(n, candidates), t.position);
  }

  void call(const Token& t) {
    const Function* f = find_function(t.text);
    if (f == nullptr) {
      if (std::find(variables_.begin(), variables_.end(), t.text) != variables_.end())
        fail("'" + std::string(t.text) + "' is a variable, not a function", t.position);
      fail("unknown function '" + excerpt(t.text, 0, 40) + "'" + did_you_mean(t.text, function_names()), t.position);
    }
    const int open_position = token_.position;
    advance();  // '('
    int count = 0;
    if (token_.kind != Kind::close) {
      expression();
      ++count;
      while (token_.kind == Kind::comma) {
        advance();
        expression();
        ++count;
      }
    }
    expect_close(open_position);
    if (count != f->arguments)
      fail("function '" + std::string(f->name) + "' takes " + std::to_string(f->arguments) +
               (f->arguments == 1 ? " argument" : " arguments") + ", got " + std::to_string(count),
           t.position);
    emit(f->op);
  }

  std::string_view text_;
  const std::vector<std::string>& variables_;
  std::size_t pos_ = 0;
  int depth_ = 0;  // nesting of unary(), see there
  Token token_;
  std::vector<Instruction> code_;
};

// Largest number of values on the evaluation stack.
int stack_depth(const std::vector<Instruction>& code) {
  int depth = 0, deepest = 0;
  for (const Instruction& ins : code) {
    depth += 1 - expression_detail::arity(ins.op);
    deepest = std::max(deepest, depth);
  }
  return deepest;
}

// Optimal-string-alignment distance (edits: insert, delete, replace, swap
// neighbours), case-insensitive.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  auto lower = [](char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); };
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1));
  for (std::size_t i = 0; i <= n; ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = lower(a[i - 1]) == lower(b[j - 1]) ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && lower(a[i - 1]) == lower(b[j - 2]) && lower(a[i - 2]) == lower(b[j - 1]))
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[n][m];
}

}  // namespace

Expression Expression::parse(std::string_view text, const std::vector<std::string>& variables) {
  Expression e;
  e.code_ = Parser(text, variables).run();
  e.stack_depth_ = stack_depth(e.code_);
  e.text_ = std::string(text);
  return e;
}

Expression Expression::constant(double value) {
  Expression e;
  e.code_.push_back(Instruction{Op::constant, 0, value});
  e.stack_depth_ = 1;
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  e.text_.assign(buffer, result.ptr);
  return e;
}

bool Expression::is_function(std::string_view name) { return find_function(name) != nullptr; }

bool Expression::is_constant() const {
  return std::none_of(code_.begin(), code_.end(), [](const Instruction& i) { return i.op == Op::variable; });
}

std::vector<int> Expression::variables_used() const {
  std::vector<int> used;
  for (const Instruction& i : code_)
    if (i.op == Op::variable) used.push_back(i.index);
  std::sort(used.begin(), used.end());
  used.erase(std::unique(used.begin(), used.end()), used.end());
  return used;
}

std::vector<std::string> close_matches(std::string_view name, const std::vector<std::string>& candidates) {
  const std::size_t limit = std::max<std::size_t>(1, name.size() / 3);
  std::vector<std::pair<std::size_t, std::size_t>> scored;  // (distance, candidate index)
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    if (candidates[i] == name) continue;
    const std::size_t d = edit_distance(name, candidates[i]);
    if (d <= limit && d < name.size()) scored.emplace_back(d, i);  // not a complete rewrite
  }
  std::stable_sort(scored.begin(), scored.end(),
                   [](const auto& x, const auto& y) { return x.first < y.first; });
  std::vector<std::string> matches;
  for (const auto& [d, i] : scored) {
    if (matches.size() == 3) break;
    if (std::find(matches.begin(), matches.end(), candidates[i]) == matches.end()) matches.push_back(candidates[i]);
  }
  return matches;
}

std::string excerpt(std::string_view text, std::size_t position, std::size_t width) {
  if (text.size() <= width) return std::string(text);
  auto continuation = [&](std::size_t i) { return i < text.size() && (static_cast<unsigned char>(text[i]) & 0xC0) == 0x80; };
  std::size_t from = position > width / 2 ? std::min(position - width / 2, text.size() - width) : 0;
  while (from > 0 && continuation(from)) --from;
  std::size_t to = std::min(from + width, text.size());
  while (continuation(to)) ++to;
  return (from > 0 ? "…" : "") + std::string(text.substr(from, to - from)) + (to < text.size() ? "…" : "");
}

std::string did_you_mean(std::string_view name, const std::vector<std::string>& candidates) {
  const std::vector<std::string> matches = close_matches(name, candidates);
  if (matches.empty()) return "";
  std::string s = " (did you mean ";
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (i > 0) s += i + 1 == matches.size() ? " or " : ", ";
    s += "'" + matches[i] + "'";
  }
  return s + "?)";
}

}  // namespace modal
