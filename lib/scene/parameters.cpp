// [parameters]: definitions in any order, expressions over other parameters,
// command-line overrides (--set NAME=VALUE) replacing definitions before
// evaluation. Evaluation follows the dependency order; a cycle is reported with
// the names along it.
#include "scene/reader.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

namespace modal::scene_detail {
namespace {

// One parameter's definition: from the file (node) or from --set (override).
struct Definition {
  std::string name;
  const toml::node* node = nullptr;          // the value in the file
  const ParameterOverride* replaced = nullptr;  // the --set that replaces it, if any
  Expression expression;
};

class Resolver {
 public:
  Resolver(const Reader& reader, std::vector<Definition>& definitions)
      : reader_(reader), definitions_(definitions) {
    for (const Definition& d : definitions_) names_.push_back(d.name);
  }

  // Parses every definition (numbers become constants).
  void parse() {
    for (Definition& d : definitions_) d.expression = d.replaced != nullptr ? parse_override(d) : parse_node(d);
  }

  Parameters evaluate() {
    values_.assign(definitions_.size(), 0.0);
    state_.assign(definitions_.size(), State::pending);
    for (std::size_t i = 0; i < definitions_.size(); ++i) visit(i);
    return Parameters{names_, values_};
  }

 private:
  enum class State { pending, active, done };

  std::string key(const Definition& d) const { return "parameters." + d.name; }

  [[noreturn]] void fail(const Definition& d, const std::string& reason) const {
    if (d.replaced != nullptr) throw SceneError(SourceLocation{"--set", 0, 0}, key(d), reason);
    reader_.fail(*d.node, key(d), reason);
  }

  Expression parse_node(const Definition& d) const {
    const toml::node& node = *d.node;
    if (const auto* s = node.as_string()) {
      try {
        return Expression::parse(s->get(), names_);
      } catch (const ExpressionError& e) {
        reader_.fail_expression(node, key(d), s->get(), e.position(), e.what());
      }
    }
    // Literal numbers: the common reader checks type and finiteness.
    return Expression::constant(reader_.number(node, key(d)));
  }

  Expression parse_override(const Definition& d) const {
    const std::string& text = d.replaced->value;
    try {
      return Expression::parse(text, names_);
    } catch (const ExpressionError& e) {
      fail(d, "in \"" + excerpt(text, static_cast<std::size_t>(std::max(e.position(), 0))) + "\" at " +
                  std::to_string(e.position() + 1) + ": " + e.what());
    }
  }

  // Depth-first evaluation in dependency order; `path` is the chain of
  // definitions being evaluated, to name a cycle.
  void visit(std::size_t i) {
    if (state_[i] == State::done) return;
    if (state_[i] == State::active) {
      const auto start = std::find(path_.begin(), path_.end(), i);
      std::string cycle;
      for (auto it = start; it != path_.end(); ++it) cycle += definitions_[*it].name + " -> ";
      cycle += definitions_[i].name;
      fail(definitions_[*start], "parameters depend on each other in a cycle: " + cycle);
    }
    state_[i] = State::active;
    path_.push_back(i);
    const Definition& d = definitions_[i];
    for (const int used : d.expression.variables_used()) visit(static_cast<std::size_t>(used));
    values_[i] = d.expression.evaluate(values_);
    if (!std::isfinite(values_[i]))
      fail(d, "\"" + d.expression.text() + "\" evaluates to " + format_number(values_[i]) +
                  "; the value must be finite");
    path_.pop_back();
    state_[i] = State::done;
  }

  const Reader& reader_;
  std::vector<Definition>& definitions_;
  std::vector<std::string> names_;
  std::vector<double> values_;
  std::vector<State> state_;
  std::vector<std::size_t> path_;
};

}  // namespace

Parameters resolve_parameters(const Reader& reader, const toml::table* table,
                              const std::vector<ParameterOverride>& overrides) {
  std::vector<Definition> definitions;
  if (table != nullptr) {
    for (auto&& [k, node] : *table) {
      const std::string name(k.str());
      const SourceLocation where = reader.location(k.source());
      if (!is_identifier(name))
        throw SceneError(where, "parameters." + name,
                         "a parameter name must be an identifier (letters, digits and '_', not starting with a digit)");
      if (Expression::is_function(name))
        throw SceneError(where, "parameters." + name, "'" + name + "' is a function name and cannot be a parameter");
      definitions.push_back(Definition{name, &node, nullptr, Expression{}});
    }
    // Tables iterate by name; parameters are listed in file order.
    std::stable_sort(definitions.begin(), definitions.end(), [](const Definition& a, const Definition& b) {
      const auto pa = a.node->source().begin, pb = b.node->source().begin;
      return pa.line != pb.line ? pa.line < pb.line : pa.column < pb.column;
    });
  }

  std::vector<std::string> names;
  for (const Definition& d : definitions) names.push_back(d.name);
  for (const ParameterOverride& o : overrides) {
    const auto it = std::find_if(definitions.begin(), definitions.end(),
                                 [&](const Definition& d) { return d.name == o.name; });
    if (it == definitions.end()) {
      std::string reason = "'" + o.name + "' is not a parameter of this scene" + did_you_mean(o.name, names);
      if (names.empty()) {
        reason += "; the scene has no [parameters]";
      } else {
        reason += "; its parameters are:";
        for (std::size_t i = 0; i < names.size(); ++i) reason += (i == 0 ? " " : ", ") + names[i];
      }
      throw SceneError(SourceLocation{"--set", 0, 0}, o.name, reason);
    }
    it->replaced = &o;
  }

  Resolver resolver(reader, definitions);
  resolver.parse();
  return resolver.evaluate();
}

}  // namespace modal::scene_detail
