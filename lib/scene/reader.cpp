// Typed, located reading of scene values (reader.hpp).
#include "scene/reader.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace modal::scene_detail {

std::string format_number(double value) {
  if (std::isnan(value)) return "nan";  // the sign bit of a NaN means nothing ("-nan" from sqrt(-1))
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

std::string count_text(double count) {
  return count < 1e15 ? std::to_string(static_cast<long long>(count)) : format_number(count);
}

bool is_identifier(std::string_view s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) != 0 || s[0] == '_')) return false;
  return std::all_of(s.begin(), s.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; });
}

std::string index_key(std::string_view array, std::size_t index) {
  return std::string(array) + "[" + std::to_string(index + 1) + "]";
}

std::string describe_type(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a float";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::date: return "a date";
    case toml::node_type::time: return "a time";
    case toml::node_type::date_time: return "a date-time";
    default: return "nothing";
  }
}

std::string file_stem(const std::string& path) { return std::filesystem::path(path).stem().string(); }

// --- Reader -----------------------------------------------------------------

void Reader::add_to_scene(const toml::node& node, const std::string& key, const std::string& what, double particles,
                          double bodies, double springs) const {
  particles_ += particles;
  bodies_ += bodies;
  springs_ += springs;
  const std::string in_all = particles_ > particles || springs_ > springs || bodies_ > bodies ? " in all" : "";
  if (particles > 0 && particles_ > static_cast<double>(limits_.particles))
    fail(node, key, "with " + what + " the scene would have " + count_text(particles_) + " particles" + in_all +
                        " (lattices and networks together); at most " + count_text(static_cast<double>(limits_.particles)) +
                        " are supported");
  if (springs > 0 && springs_ > static_cast<double>(limits_.springs))
    fail(node, key, "with " + what + " the scene would have " + count_text(springs_) + " springs" + in_all +
                        "; at most " + count_text(static_cast<double>(limits_.springs)) + " are supported");
  if (const auto refusal = memory_refusal(scene_memory(particles_, bodies_, springs_),
                                          "the scene's " + count_text(particles_ + bodies_) + " bodies" +
                                              (springs_ > 0 ? " and " + count_text(springs_) + " springs" : "") +
                                              in_all,
                                          limits_.memory))
    fail(node, key, "with " + what + " " + *refusal);
}

Reader::Reader(std::string file, std::string_view text, SceneLimits limits)
    : file_(std::move(file)), limits_(limits) {
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    lines_.push_back(text.substr(start, end - start));
    start = end + 1;
  }
}

SourceLocation Reader::location(const toml::source_region& region) const {
  return SourceLocation{file_, static_cast<int>(region.begin.line), static_cast<int>(region.begin.column)};
}

SourceLocation Reader::location_in_string(const toml::node& node, int position) const {
  SourceLocation where = location(node);
  const auto* value = node.as_string();
  if (value == nullptr || where.line < 1 || static_cast<std::size_t>(where.line) > lines_.size()) return where;
  // The string as written must be the value between quotes, with no escapes.
  const std::string_view line = lines_[static_cast<std::size_t>(where.line - 1)];
  const std::string& text = value->get();
  const auto open = static_cast<std::size_t>(where.column - 1);
  if (open + text.size() + 2 > line.size()) return where;
  const char quote = line[open];
  if ((quote != '"' && quote != '\'') || line.substr(open + 1, text.size()) != text ||
      line[open + 1 + text.size()] != quote)
    return where;
  where.column += 1 + position;
  return where;
}

void Reader::fail(const toml::node& node, const std::string& key, const std::string& reason) const {
  throw SceneError(location(node), key, reason);
}

void Reader::fail_expression(const toml::node& node, const std::string& key, const std::string& text,
                             int position, const std::string& message) const {
  throw SceneError(location_in_string(node, position), key,
                   "in \"" + excerpt(text, static_cast<std::size_t>(std::max(position, 0))) + "\" at " +
                       std::to_string(position + 1) + ": " + message);
}

double Reader::number(const toml::node& node, const std::string& key, Range range) const {
  double value = 0;
  if (const auto* i = node.as_integer()) {
    value = static_cast<double>(i->get());
  } else if (const auto* f = node.as_floating_point()) {
    value = f->get();
    if (!std::isfinite(value)) fail(node, key, "the value must be finite, got " + format_number(value));
  } else if (const auto* s = node.as_string()) {
    const std::string& text = s->get();
    try {
      const Expression e = Expression::parse(text, parameters_.names);
      value = e.evaluate(parameters_.values);
    } catch (const ExpressionError& error) {
      fail_expression(node, key, text, error.position(), error.what());
    }
    if (!std::isfinite(value))
      fail(node, key, "\"" + text + "\" evaluates to " + format_number(value) + "; the value must be finite");
  } else {
    fail(node, key, "expected a number or an expression string, got " + describe_type(node));
  }
  if (range == Range::nonnegative && value < 0)
    fail(node, key, "must be non-negative, got " + format_number(value));
  if (range == Range::positive && !(value > 0)) fail(node, key, "must be positive, got " + format_number(value));
  return value;
}

VectorX Reader::numbers(const toml::node& node, const std::string& key, int size, Range range) const {
  const std::string expected = "expected an array of " + std::to_string(size) + (size == 1 ? " number" : " numbers");
  const auto* array = node.as_array();
  if (array == nullptr) fail(node, key, expected + ", got " + describe_type(node));
  if (array->size() != static_cast<std::size_t>(size))
    fail(node, key, expected + ", got " + std::to_string(array->size()));
  VectorX v(size);
  for (int i = 0; i < size; ++i)
    v[i] = number((*array)[static_cast<std::size_t>(i)], key + "[" + std::to_string(i + 1) + "]", range);
  return v;
}

std::string Reader::string(const toml::node& node, const std::string& key) const {
  const auto* s = node.as_string();
  if (s == nullptr) fail(node, key, "expected a string, got " + describe_type(node));
  if (!is_printable(s->get()))
    fail(node, key, "the text \"" + printable(s->get()) + "\" contains control characters or bytes that are not "
                    "UTF-8 (shown escaped); names, titles and paths must be printable text");
  return s->get();
}

bool Reader::boolean(const toml::node& node, const std::string& key) const {
  const auto* b = node.as_boolean();
  if (b == nullptr) fail(node, key, "expected true or false, got " + describe_type(node));
  return b->get();
}

std::vector<const toml::table*> Reader::tables(const toml::node& node, const std::string& key) const {
  if (node.is_table()) fail(node, key, "expected an array of tables: write [[" + key + "]], not [" + key + "]");
  const auto* array = node.as_array();
  if (array == nullptr) fail(node, key, "expected an array of tables ([[" + key + "]]), got " + describe_type(node));
  std::vector<const toml::table*> result;
  for (std::size_t i = 0; i < array->size(); ++i) {
    const toml::node& element = (*array)[i];
    if (!element.is_table())
      fail(element, key + "[" + std::to_string(i + 1) + "]", "expected a table, got " + describe_type(element));
    result.push_back(element.as_table());
  }
  return result;
}

// --- Section ----------------------------------------------------------------

std::string Section::key(std::string_view name) const {
  return path_.empty() ? std::string(name) : path_ + "." + std::string(name);
}

void Section::check_keys(std::initializer_list<std::string_view> allowed,
                         std::initializer_list<std::string_view> later) const {
  for (auto&& [k, value] : table_) {
    const std::string_view name = k.str();
    if (std::find(allowed.begin(), allowed.end(), name) != allowed.end()) continue;
    const SourceLocation where = reader_.location(k.source());
    if (std::find(later.begin(), later.end(), name) != later.end())
      throw SceneError(where, key(name), "'" + std::string(name) + "' is not supported by this version of modal");
    throw SceneError(where, key(name),
                     "unknown key '" + std::string(name) + "' in " + kind_ +
                         did_you_mean(name, std::vector<std::string>(allowed.begin(), allowed.end())));
  }
}

void Section::fail(std::string_view name, const std::string& reason) const {
  const toml::node* node = find(name);
  if (node == nullptr) throw SceneError(location(), key(name), reason);
  reader_.fail(*node, key(name), reason);
}

void Section::missing(std::string_view name) const {
  throw SceneError(location(), key(name), "missing required key '" + std::string(name) + "' in " + kind_);
}

const toml::node& Section::required(std::string_view name) const {
  const toml::node* node = find(name);
  if (node == nullptr) missing(name);
  return *node;
}

double Section::number(std::string_view name, double fallback, Range range) const {
  const toml::node* node = find(name);
  return node != nullptr ? reader_.number(*node, key(name), range) : fallback;
}

double Section::required_number(std::string_view name, Range range) const {
  return reader_.number(required(name), key(name), range);
}

VectorX Section::numbers(std::string_view name, const VectorX& fallback, Range range) const {
  const toml::node* node = find(name);
  return node != nullptr ? reader_.numbers(*node, key(name), static_cast<int>(fallback.size()), range) : fallback;
}

Vec3 Section::vector3(std::string_view name, const Vec3& fallback) const {
  return numbers(name, VectorX(fallback));
}

Vec3 Section::required_vector3(std::string_view name) const {
  return reader_.numbers(required(name), key(name), 3);
}

Vec3 Section::unit_vector(std::string_view name, const Vec3& fallback) const {
  const Vec3 v = vector3(name, fallback);
  const double norm = v.stableNorm();  // no overflow for components near 1e308
  if (!(norm > 1e-12) || !std::isfinite(norm))
    fail(name, "must be a nonzero finite direction, got [" + format_number(v.x()) + ", " + format_number(v.y()) + ", " +
                   format_number(v.z()) + "]");
  return (v / norm).normalized();
}

std::string Section::string(std::string_view name, const std::string& fallback) const {
  const toml::node* node = find(name);
  return node != nullptr ? reader_.string(*node, key(name)) : fallback;
}

std::string Section::required_string(std::string_view name) const {
  return reader_.string(required(name), key(name));
}

bool Section::boolean(std::string_view name, bool fallback) const {
  const toml::node* node = find(name);
  return node != nullptr ? reader_.boolean(*node, key(name)) : fallback;
}

namespace {
// A computed value for messages, to 6 significant digits.
std::string approximate_value(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", value);
  return buffer;
}
}  // namespace

// inertia = [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] about the com, body frame (kg·m²);
// a physical tensor is positive semidefinite with principal moments obeying
// the triangle inequality.
Mat3 read_inertia(const Section& s) {
  const VectorX v = s.numbers("inertia", VectorX::Zero(6));
  Mat3 inertia;
  inertia << v[0], v[3], v[4],
             v[3], v[1], v[5],
             v[4], v[5], v[2];
  const Vec3 moments = Eigen::SelfAdjointEigenSolver<Mat3>(inertia, Eigen::EigenvaluesOnly).eigenvalues();  // ascending
  const double tolerance = 1e-12 * moments.cwiseAbs().maxCoeff();
  const std::string listed = approximate_value(moments[0]) + ", " + approximate_value(moments[1]) + ", " + approximate_value(moments[2]);
  if (moments[0] < -tolerance)
    s.fail("inertia", "the inertia tensor is not positive semidefinite (principal moments " + listed + " kg·m²)");
  if (moments[2] > moments[0] + moments[1] + tolerance)
    s.fail("inertia", "the principal moments " + listed +
                          " kg·m² violate the triangle inequality: the largest exceeds the sum of the other two");
  return inertia;
}

}  // namespace modal::scene_detail
