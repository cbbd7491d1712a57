// Expression-defined systems in scene files (docs/design.md, "Scene format"): [coordinates],
// [[point]] and `potential`, read into a KinematicMap.
//
//   [coordinates]                       # in file order; a number (the initial value) or a table
//   phi = 2.5
//   theta = { initial = 0, rate = "w" } # ignorable, steady rate (or momentum = …)
//   x = { initial = 0.1, kind = "length" }
//
//   [[point]]
//   mass = "m"
//   position = ["r*cos(theta)*sin(phi)", "r*sin(theta)*sin(phi)", "r*cos(phi)"]
//   inertia = [...]                                   # optional rigid body
//   orientation = [{ axis = [0, 0, 1], angle = "theta" }, …]
//
//   potential = "0.5*k*(phi - 1)^2"
//
// Expressions are over the coordinates, the time t and the parameters.
#include "scene/reader.hpp"

#include <algorithm>
#include <map>
#include <set>

namespace modal::scene_detail {

namespace {

// The expression variables: coordinates, then t, then the parameters.
struct Variables {
  std::vector<std::string> names;
};

Expression expression(const Reader& reader, const toml::node& node, const std::string& key, const Variables& vars) {
  if (node.is_integer() || node.is_floating_point()) return Expression::constant(reader.number(node, key));
  const auto* s = node.as_string();
  if (s == nullptr) reader.fail(node, key, "expected a number or an expression string, got " + describe_type(node));
  try {
    return Expression::parse(s->get(), vars.names);
  } catch (const ExpressionError& e) {
    reader.fail_expression(node, key, s->get(), e.position(), e.what());
  }
}

MapCoordinate read_coordinate(const Reader& reader, const std::string& name, const toml::node& node,
                              const std::string& key) {
  MapCoordinate c;
  c.name = name;
  const toml::table* t = node.as_table();
  if (t == nullptr) {
    c.initial = reader.number(node, key);
    return c;
  }
  const Section s(reader, *t, key, "a coordinate table");
  s.check_keys({"initial", "kind", "rate", "momentum"});
  c.initial = s.number("initial", 0.0);
  if (s.has("kind")) {
    const std::string kind = s.string("kind", "");
    if (kind == "angle")
      c.kind = CoordinateKind::angle;
    else if (kind == "length")
      c.kind = CoordinateKind::length;
    else
      s.fail("kind", "must be \"angle\" or \"length\", got \"" + kind + "\"");
  }
  if (s.has("rate") && s.has("momentum"))
    s.fail("momentum", "give an ignorable coordinate its steady rate or its momentum, not both");
  if (s.has("rate")) c.ignorable = Ignorable{Ignorable::Given::rate, s.required_number("rate")};
  if (s.has("momentum")) c.ignorable = Ignorable{Ignorable::Given::momentum, s.required_number("momentum")};
  return c;
}

MapMass read_point(const Reader& reader, const toml::table& table, std::size_t index, const Variables& vars) {
  const std::string path = index_key("point", index);
  const Section s(reader, table, path, "[[point]]");
  if (s.has("potential"))
    s.fail("potential", "`potential` is a top-level key, but here it is read as part of this [[point]]: in TOML, "
                        "write it before the first table ([parameters], [coordinates], [[point]])");
  s.check_keys({"name", "mass", "position", "inertia", "orientation"});
  MapMass p;
  p.name = s.string("name", "point " + std::to_string(index + 1));
  p.mass = s.required_number("mass", Range::nonnegative);
  const toml::node* position = s.find("position");
  if (position == nullptr) s.missing("position");
  const toml::array* xyz = position->as_array();
  if (xyz == nullptr || xyz->size() != 3)
    reader.fail(*position, s.key("position"), "expected an array of 3 numbers or expressions (x, y, z in m)");
  for (std::size_t c = 0; c < 3; ++c)
    p.position[c] = expression(reader, *xyz->get(c), s.key("position") + "[" + std::to_string(c + 1) + "]", vars);
  p.inertia = read_inertia(s);
  if (const toml::node* node = s.find("orientation")) {
    const toml::array* list = node->as_array();
    if (list == nullptr)
      reader.fail(*node, s.key("orientation"), "expected an array of rotations {axis = [x, y, z], angle = \"…\"}");
    for (std::size_t r = 0; r < list->size(); ++r) {
      const std::string key = s.key("orientation") + "[" + std::to_string(r + 1) + "]";
      const toml::table* rt = list->get(r)->as_table();
      if (rt == nullptr) reader.fail(*list->get(r), key, "expected a table {axis = [x, y, z], angle = \"…\"}");
      const Section rs(reader, *rt, key, "a rotation");
      rs.check_keys({"axis", "angle"});
      MapRotation rot;
      rot.axis = rs.unit_vector("axis", Vec3::UnitZ());
      const toml::node* angle = rs.find("angle");
      if (angle == nullptr) rs.missing("angle");
      rot.angle = expression(reader, *angle, rs.key("angle"), vars);
      p.orientation.push_back(std::move(rot));
    }
    if (p.inertia.isZero(0.0) && !p.orientation.empty())
      reader.fail(*node, s.key("orientation"), "an orientation only matters with an inertia: give `inertia` too");
  }
  return p;
}

}  // namespace

bool read_map(const Reader& reader, const toml::table& root, SystemDescription& d) {
  const toml::node* coordinates = root.get("coordinates");
  const toml::node* points = root.get("point");
  const toml::node* potential = root.get("potential");
  if (coordinates == nullptr && points == nullptr && potential == nullptr) return false;
  if (coordinates == nullptr)
    throw SceneError(reader.location(points != nullptr ? *points : *potential), "coordinates",
                     "an expression-defined system needs a [coordinates] table naming its generalized coordinates");
  const toml::table* table = coordinates->as_table();
  if (table == nullptr)
    reader.fail(*coordinates, "coordinates", "expected a table ([coordinates]), got " + describe_type(*coordinates));
  if (table->empty()) reader.fail(*coordinates, "coordinates", "no coordinates: name at least one, e.g. phi = 0.1");

  // Coordinates in file order (TOML tables are unordered).
  std::vector<std::pair<std::string, const toml::node*>> listed;
  for (auto&& [k, node] : *table) listed.emplace_back(std::string(k.str()), &node);
  std::sort(listed.begin(), listed.end(), [](const auto& a, const auto& b) {
    const auto& x = a.second->source().begin;
    const auto& y = b.second->source().begin;
    return std::tie(x.line, x.column) < std::tie(y.line, y.column);
  });
  Variables vars;
  const std::vector<std::string>& parameters = reader.parameters().names;
  if (std::find(parameters.begin(), parameters.end(), "t") != parameters.end()) {
    const toml::node* t = root.at_path("parameters.t").node();
    throw SceneError(t != nullptr ? reader.location(*t) : reader.location(*coordinates), "parameters.t",
                     "in an expression-defined system t is the time: rename the parameter 't'");
  }
  for (const auto& [name, node] : listed) {
    const std::string key = "coordinates." + name;
    std::string why;
    if (!is_identifier(name))
      why = "is not a valid name (letters, digits and _, not starting with a digit)";
    else if (Expression::is_function(name) || name == "pi" || name == "t")
      why = "is reserved (a function, pi, or the time t)";
    else if (std::find(parameters.begin(), parameters.end(), name) != parameters.end())
      why = "is also a parameter: a name is either a coordinate or a parameter";
    if (!why.empty()) reader.fail(*node, key, "the coordinate name '" + name + "' " + why);
    vars.names.push_back(name);
  }
  vars.names.push_back("t");
  vars.names.insert(vars.names.end(), parameters.begin(), parameters.end());

  KinematicMap& m = d.map;
  for (const auto& [name, node] : listed) m.coordinates.push_back(read_coordinate(reader, name, *node, "coordinates." + name));
  m.constants = reader.parameters().values;
  if (points != nullptr) {
    const std::vector<const toml::table*> tables = reader.tables(*points, "point");
    for (std::size_t i = 0; i < tables.size(); ++i) m.points.push_back(read_point(reader, *tables[i], i, vars));
  }
  if (potential != nullptr) m.potential = expression(reader, *potential, "potential", vars);
  if (m.points.empty())
    reader.fail(*coordinates, "point", "the system has no [[point]] masses: its kinetic energy would be zero");
  // A coordinate that no expression uses moves nothing: M would have a zero
  // row for it everywhere.
  std::vector<bool> used(listed.size(), false);
  auto mark = [&](const Expression& e) {
    for (const int v : e.variables_used())
      if (v < static_cast<int>(used.size())) used[static_cast<std::size_t>(v)] = true;
  };
  mark(m.potential);
  for (const MapMass& p : m.points) {
    for (const Expression& e : p.position) mark(e);
    if (!p.inertia.isZero(0.0))
      for (const MapRotation& r : p.orientation) mark(r.angle);
  }
  for (std::size_t i = 0; i < listed.size(); ++i)
    if (!used[i])
      reader.fail(*listed[i].second, "coordinates." + listed[i].first,
                  "the coordinate '" + listed[i].first +
                      "' appears in no position, orientation or potential: it moves nothing (its mass matrix row "
                      "would be zero)");
  return true;
}

}  // namespace modal::scene_detail
