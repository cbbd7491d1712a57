// Scene files (docs/design.md, "Scene format", version 1) to validated SystemDescriptions.
//
// Reading goes section by section: [parameters] first (every other number may
// use them), then [[body]], [[chain]] (chains expand into hinge bodies),
// [[particle]] (point masses on a particle joint to the world, or a fixed joint
// when all three axes are fixed) and the generators [[lattice]] and
// [[network]] (network.cpp: blocks of particles on the world and the springs
// between them, from a grid or from CSV files). The bodies are ordered so that
// parents precede children and otherwise kept in file order, a generator's
// particles staying together where its table is; every name must be unique
// across all of them (one hash table, so that 10⁶ generated particles cost
// little). Then [[spring]], [[load]] and [[constraint]] (loop closures: two
// points coincide, or keep their distance), which refer to bodies and
// particles by name — generated ones too ("net.3.4", "tower.a3") — and last
// the generators' springs, their ends shifted to where their block was
// placed. A scene with [coordinates] is a kinematic map instead
// (lib/scene/map.cpp) and has none of these. Every check that System's
// constructor makes is made here first, with a located message, so that
// building never throws.
#include "modal/scene.hpp"

#include "scene/reader.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <numeric>
#include <queue>
#include <sstream>
#include <tuple>
#include <unordered_map>

namespace modal {

namespace {

std::string compose_message(const SourceLocation& where, const std::string& key, const std::string& reason) {
  std::string s = printable(where.file);
  if (where.line > 0) {
    s += ":" + std::to_string(where.line);
    if (where.column > 0) s += ":" + std::to_string(where.column);
  }
  s += ": ";
  if (!key.empty()) s += printable(key) + ": ";
  return s + printable(reason);
}

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

}  // namespace

namespace {
// Length of the valid UTF-8 sequence at `s[i]` and its code point, or 0.
std::size_t utf8_sequence(std::string_view s, std::size_t i, char32_t& code) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char b = byte(i);
  std::size_t n = 0;
  if (b < 0x80) return code = b, 1;
  if (b >= 0xC2 && b <= 0xDF) n = 2, code = b & 0x1F;
  else if (b >= 0xE0 && b <= 0xEF) n = 3, code = b & 0x0F;
  else if (b >= 0xF0 && b <= 0xF4) n = 4, code = b & 0x07;
  else return 0;
  if (i + n > s.size()) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
    code = (code << 6) | (byte(i + k) & 0x3F);
  }
  const char32_t least[5] = {0, 0, 0x80, 0x800, 0x10000};
  if (code < least[n] || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF)) return 0;  // overlong, surrogate
  return n;
}
bool is_control(char32_t c) { return c < 0x20 || c == 0x7F || (c >= 0x80 && c <= 0x9F); }
}  // namespace

std::string printable(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  char hex[16];
  for (std::size_t i = 0; i < text.size();) {
    char32_t code = 0;
    const std::size_t n = utf8_sequence(text, i, code);
    if (n == 0) {
      std::snprintf(hex, sizeof hex, "\\x%02X", static_cast<unsigned>(static_cast<unsigned char>(text[i])));
      out += hex;
      ++i;
    } else if (is_control(code)) {
      std::snprintf(hex, sizeof hex, code < 0x80 ? "\\x%02X" : "\\u{%02X}", static_cast<unsigned>(code));
      out += hex;
      i += n;
    } else {
      out.append(text.substr(i, n));
      i += n;
    }
  }
  return out;
}

bool is_printable(std::string_view text) { return printable(text) == text; }

SceneError::SceneError(SourceLocation where, std::string key, std::string reason)
    : std::runtime_error(compose_message(where, key, reason)),
      where_(std::move(where)),
      key_(std::move(key)),
      reason_(std::move(reason)) {}

ParameterOverride parse_override(std::string_view text) {
  const SourceLocation where{"--set", 0, 0};
  const auto equals = text.find('=');
  if (equals == std::string_view::npos)
    throw SceneError(where, "", "expected NAME=VALUE, got '" + std::string(text) + "'");
  const std::string_view name = trim(text.substr(0, equals));
  const std::string_view value = trim(text.substr(equals + 1));
  if (name.empty()) throw SceneError(where, "", "missing parameter name before '=' in '" + std::string(text) + "'");
  if (value.empty())
    throw SceneError(where, std::string(name), "missing value after '=' in '" + std::string(text) + "'");
  return ParameterOverride{std::string(name), std::string(value)};
}

namespace {

using scene_detail::Range;
using scene_detail::Reader;
using scene_detail::Section;
using scene_detail::format_number;

constexpr std::array<JointType, 5> joint_types{JointType::hinge, JointType::slide, JointType::ball,
                                                JointType::free, JointType::fixed};

// A body as read, before the bodies are ordered and parents resolved.
struct BodyEntry {
  Body body;
  std::string parent = "world";
  const toml::node* parent_node = nullptr;  // where the parent is named (null: default or generated)
  std::string parent_key;
  const toml::node* name_node = nullptr;    // where the name is given
  std::string name_key;
  std::string chain;                        // the generating chain's name, "" for [[body]] and [[particle]]
  bool particle = false;                    // read from a [[particle]]
  SourceLocation location;                  // the [[body]], [[chain]] or [[particle]] table
  std::tuple<int, int, int> order;          // file position of the table, then link number
};


// Joint values of size n (hinge/slide: one number; ball, free: an array).
VectorX joint_values(const Section& s, std::string_view key, int n) {
  if (n == 1) return VectorX::Constant(1, s.number(key, 0.0));
  return s.numbers(key, VectorX::Zero(n));
}

// An entry with its `name` read and checked (non-empty, not "world").
BodyEntry named_entry(const Section& s, const std::string& what) {
  BodyEntry e;
  e.body.name = s.required_string("name");
  e.name_node = s.find("name");
  e.name_key = s.key("name");
  if (e.body.name.empty()) s.fail("name", "a " + what + " name must not be empty");
  if (e.body.name == "world") s.fail("name", "'world' is reserved for the fixed frame; choose another name");
  return e;
}

BodyEntry read_body(const Reader& reader, const toml::table& table, std::size_t index) {
  const Section s(reader, table, scene_detail::index_key("body", index), "[[body]]");
  s.check_keys({"name", "parent", "joint", "axis", "origin", "orientation", "mass", "com", "inertia", "stiffness",
                "rest", "damping", "armature", "initial", "range"});
  BodyEntry e = named_entry(s, "body");
  Body& b = e.body;

  const std::string joint = s.required_string("joint");
  const auto type = std::find_if(joint_types.begin(), joint_types.end(), [&](JointType t) { return to_string(t) == joint; });
  if (type == joint_types.end())
    s.fail("joint", "unknown joint type '" + joint + "'; expected hinge, slide, ball, free or fixed" +
                        did_you_mean(joint, {"hinge", "slide", "ball", "free", "fixed"}));
  b.joint = *type;
  const bool has_axis = b.joint == JointType::hinge || b.joint == JointType::slide;
  const bool has_spring = has_axis || b.joint == JointType::ball;
  const bool has_initial = b.joint != JointType::fixed;
  for (const auto& [key, used] : {std::pair<std::string_view, bool>{"axis", has_axis}, {"stiffness", has_spring},
                                  {"rest", has_spring}, {"damping", has_spring}, {"initial", has_initial},
                                  {"range", has_axis}})
    if (!used && s.has(key)) s.fail(key, "'" + std::string(key) + "' is not used by a " + joint + " joint");
  if (b.joint == JointType::fixed && s.has("armature")) s.fail("armature", "'armature' is not used by a fixed joint");

  e.parent = s.string("parent", "world");
  e.parent_node = s.find("parent");
  e.parent_key = s.key("parent");
  if (has_axis) b.axis = s.unit_vector("axis", Vec3::UnitY());
  b.origin = s.vector3("origin", Vec3::Zero());
  if (s.has("orientation")) {  // a quaternion [w, x, y, z], normalized here
    const VectorX w = s.numbers("orientation", VectorX::Zero(4));
    const double norm = w.norm();
    if (!(norm > 0) || !std::isfinite(norm))
      s.fail("orientation", "a quaternion [w, x, y, z] must not be zero");
    b.orientation = Eigen::Quaterniond(w[0] / norm, w[1] / norm, w[2] / norm, w[3] / norm).toRotationMatrix();
  }
  b.mass = s.number("mass", 0.0, Range::nonnegative);
  b.com = s.vector3("com", Vec3::Zero());
  b.inertia = scene_detail::read_inertia(s);
  b.stiffness = s.number("stiffness", 0.0, Range::nonnegative);
  b.damping = s.number("damping", 0.0, Range::nonnegative);
  b.armature = s.number("armature", 0.0, Range::nonnegative);
  const int n = joint_coordinate_count(b.joint);
  b.rest = has_spring ? joint_values(s, "rest", n) : VectorX::Zero(n);
  b.initial = joint_values(s, "initial", n);
  if (s.has("range")) {  // [lower, upper], the coordinate's units
    const VectorX r = s.numbers("range", VectorX::Zero(2));
    if (!(r[0] < r[1]))
      s.fail("range", "a joint range [lower, upper] needs lower < upper, got [" + format_number(r[0]) + ", " +
                          format_number(r[1]) + "]");
    if (!(b.initial[0] > r[0] && b.initial[0] < r[1]))
      s.fail("range", "the initial value " + format_number(b.initial[0]) + " is not strictly inside the range [" +
                          format_number(r[0]) + ", " + format_number(r[1]) +
                          "]: the limit would be active from the start, and a limit has no linear model");
    b.lower = r[0];
    b.upper = r[1];
  }

  e.location = s.location();
  e.order = {e.location.line, e.location.column, 0};
  return e;
}

// [[chain]]: `links` equal hinge bodies in series, link i's joint at the far
// end of link i−1 (the first at `origin` in the parent).
std::vector<BodyEntry> read_chain(const Reader& reader, const toml::table& table, std::size_t index) {
  const Section s(reader, table, scene_detail::index_key("chain", index), "[[chain]]");
  s.check_keys({"name", "links", "length", "mass", "mass_model", "axis", "direction", "stiffness", "damping", "rest",
                "parent", "origin", "initial"});
  const std::string name = s.required_string("name");
  if (name.empty()) s.fail("name", "a chain name must not be empty");

  const double max_links = reader.limits().links;
  const double links_value = s.required_number("links");
  if (links_value != std::floor(links_value)) s.fail("links", "must be an integer, got " + format_number(links_value));
  if (links_value < 1) s.fail("links", "must be at least 1, got " + format_number(links_value));
  if (links_value > max_links)
    s.fail("links", "at most " + std::to_string(reader.limits().links) + " links are supported, got " +
                        scene_detail::count_text(links_value));
  const int links = static_cast<int>(links_value);
  reader.add_to_scene(*s.find("links"), s.key("links"), "the chain", 0, links, 0);

  const double length = s.required_number("length", Range::positive);  // total, m
  const double mass = s.required_number("mass", Range::nonnegative);   // total, kg
  const std::string model = s.string("mass_model", "point");
  if (model != "point" && model != "rod")
    s.fail("mass_model", "unknown mass model '" + model + "'; expected \"point\" (mass at each link's end) or "
                         "\"rod\" (uniform rods)" + did_you_mean(model, {"point", "rod"}));
  const Vec3 axis = s.unit_vector("axis", Vec3::UnitY());
  const Vec3 direction = s.unit_vector("direction", -Vec3::UnitZ());
  if (axis.cross(direction).norm() < 1e-9)
    s.fail("direction", "the chain's direction is parallel to its hinge axis, so its links could not swing");
  const double stiffness = s.number("stiffness", 0.0, Range::nonnegative);
  const double damping = s.number("damping", 0.0, Range::nonnegative);
  const double rest = s.number("rest", 0.0);
  const Vec3 origin = s.vector3("origin", Vec3::Zero());
  VectorX initial = VectorX::Zero(links);
  if (const toml::node* node = s.find("initial")) {
    if (node->is_array())
      initial = reader.numbers(*node, s.key("initial"), links);
    else
      initial[0] = reader.number(*node, s.key("initial"));
  }

  const double a = length / links;      // link length, m
  const double m = mass / links;        // link mass, kg
  if (model == "rod" && !std::isfinite(m * a * a / 12.0))
    s.fail("length", "each link's moment of inertia m·a²/12 (link mass m, link length a) overflows; give a smaller "
                     "length or mass");
  std::vector<BodyEntry> entries(static_cast<std::size_t>(links));
  for (int k = 0; k < links; ++k) {
    BodyEntry& e = entries[static_cast<std::size_t>(k)];
    Body& b = e.body;
    b.name = name + std::to_string(k + 1);
    b.joint = JointType::hinge;
    b.axis = axis;
    b.origin = k == 0 ? origin : Vec3(a * direction);
    b.mass = m;
    if (model == "point") {
      b.com = a * direction;
    } else {
      b.com = 0.5 * a * direction;
      b.inertia = m * a * a / 12.0 * (Mat3::Identity() - direction * direction.transpose());
    }
    b.stiffness = stiffness;
    b.damping = damping;
    b.rest = VectorX::Constant(1, rest);
    b.initial = VectorX::Constant(1, initial[k]);
    if (k == 0) {
      e.parent = s.string("parent", "world");
      e.parent_node = s.find("parent");
      e.parent_key = s.key("parent");
    } else {
      e.parent = name + std::to_string(k);
    }
    e.name_node = s.find("name");
    e.name_key = s.key("name");
    e.chain = name;
    e.location = s.location();
    e.order = {e.location.line, e.location.column, k};
  }
  return entries;
}

// [[particle]]: a point mass at `position` on a particle joint to the world
// (coordinates: displacements along the world x, y, z axes that are not
// `fixed`), or on a fixed joint when every axis is fixed.
BodyEntry read_particle(const Reader& reader, const toml::table& table, std::size_t index) {
  const Section s(reader, table, scene_detail::index_key("particle", index), "[[particle]]");
  s.check_keys({"name", "position", "mass", "fixed"});
  BodyEntry e = named_entry(s, "particle");
  Body& b = e.body;
  b.origin = s.required_vector3("position");
  b.mass = s.required_number("mass", Range::nonnegative);

  std::array<bool, 3> fixed{false, false, false};
  if (const toml::node* node = s.find("fixed")) {
    const std::string key = s.key("fixed");
    if (node->is_boolean()) {
      fixed.fill(reader.boolean(*node, key));
    } else {
      const std::string expected = "expected true, false or an array of 3 booleans [x, y, z]";
      const auto* array = node->as_array();
      if (array == nullptr) reader.fail(*node, key, expected + ", got " + scene_detail::describe_type(*node));
      if (array->size() != 3) reader.fail(*node, key, expected + ", got " + std::to_string(array->size()) + " elements");
      for (std::size_t a = 0; a < 3; ++a) fixed[a] = reader.boolean((*array)[a], key + "[" + std::to_string(a + 1) + "]");
    }
  }
  for (std::size_t a = 0; a < 3; ++a) b.particle_axes[a] = !fixed[a];
  b.joint = std::find(fixed.begin(), fixed.end(), false) == fixed.end() ? JointType::fixed : JointType::particle;
  const int n = joint_coordinate_count(b);
  b.rest = VectorX::Zero(n);
  b.initial = VectorX::Zero(n);

  e.particle = true;
  e.location = s.location();
  e.order = {e.location.line, e.location.column, 0};
  return e;
}

[[noreturn]] void fail_entry(const Reader& reader, const BodyEntry& e, const toml::node* node, const std::string& key,
                             const std::string& reason) {
  if (node != nullptr) reader.fail(*node, key, reason);
  throw SceneError(e.location, key, reason);
}

using scene_detail::Generated;

// What the ordering places as one: a body read from a [[body]], a chain link
// or a [[particle]] (an entry), or all the particles of a [[lattice]] or
// [[network]] (a block: bodies on the world, kept together).
struct Unit {
  bool block = false;
  std::size_t index = 0;  // into the entries or the blocks
  std::tuple<int, int, int> order;
};

// Where a body name is defined while the bodies are ordered.
struct NameRef {
  std::size_t unit = 0;
  int local = 0;  // index in a block's bodies; 0 for an entry
};

// "the [[body]] at line 3", "chain 'c' at line 5", "[[lattice]] 'net' at line
// 7", "node 'a' of [[network]] 'tower' (data/nodes.csv line 4)".
std::string describe_user(const std::vector<BodyEntry>& entries, const std::vector<Generated>& blocks, const Unit& u,
                          int local) {
  if (!u.block) {
    const BodyEntry& e = entries[u.index];
    return (!e.chain.empty() ? "chain '" + e.chain + "'" : e.particle ? "the [[particle]]" : "the [[body]]") +
           " at line " + std::to_string(e.location.line);
  }
  const Generated& g = blocks[u.index];
  const auto l = static_cast<std::size_t>(local);
  if (!g.csv.empty())
    return "node '" + g.bodies[l].name.substr(g.name.size() + 1) + "' of [[network]] '" + g.name + "' (" + g.csv +
           " line " + std::to_string(g.lines[l]) + ")";
  return "[[lattice]] '" + g.name + "' at line " + std::to_string(g.location.line);
}

// Orders bodies so that parents precede children, keeping file order where
// the tree allows (among the bodies whose parent is placed, the earliest in the
// file comes next), and resolves parent names to indices. Names must be unique
// across entries and blocks (one hash table, no per-body string work beyond
// hashing). Fills the scene's bodies and their locations, `particle` (whether
// each body is a particle) and the first body index of each block. A block
// read in parts (Generated::held) takes its whole count of places; its held
// bodies are kept, and scene.global_bodies says where each body is.
void order_bodies(const Reader& reader, std::vector<BodyEntry>& entries, std::vector<Generated>& blocks,
                  Scene& scene, std::vector<bool>& particle, std::vector<int>& block_start) {
  std::vector<Unit> units;
  units.reserve(entries.size() + blocks.size());
  std::size_t total = entries.size();
  for (std::size_t i = 0; i < entries.size(); ++i) units.push_back({false, i, entries[i].order});
  bool parts = false;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    units.push_back({true, i, {blocks[i].location.line, blocks[i].location.column, 0}});
    total += blocks[i].bodies.size();
    parts = parts || static_cast<long long>(blocks[i].bodies.size()) != blocks[i].count;
  }
  std::stable_sort(units.begin(), units.end(), [](const Unit& x, const Unit& y) { return x.order < y.order; });

  std::unordered_map<std::string_view, NameRef> by_name;
  by_name.reserve(total);
  for (std::size_t u = 0; u < units.size(); ++u) {
    const Unit& unit = units[u];
    if (!unit.block) {
      const BodyEntry& e = entries[unit.index];
      const auto [it, inserted] = by_name.emplace(e.body.name, NameRef{u, 0});
      if (inserted) continue;
      const std::string user = describe_user(entries, blocks, units[it->second.unit], it->second.local);
      const std::string reason =
          e.chain.empty() ? std::string(e.particle ? "duplicate particle name '" : "duplicate body name '") +
                                e.body.name + "': already used by " + user
                          : "chain '" + e.chain + "' generates the body name '" + e.body.name +
                                "', which is already used by " + user;
      fail_entry(reader, e, e.name_node, e.name_key, reason);
    }
    const Generated& g = blocks[unit.index];
    for (std::size_t l = 0; l < g.bodies.size(); ++l) {
      const auto [it, inserted] = by_name.emplace(g.bodies[l].name, NameRef{u, static_cast<int>(l)});
      if (inserted) continue;
      const std::string user = describe_user(entries, blocks, units[it->second.unit], it->second.local);
      if (!g.csv.empty())
        throw SceneError(SourceLocation{g.csv, g.lines[l], 1}, "name",
                         "node '" + g.bodies[l].name.substr(g.name.size() + 1) + "' of [[network]] '" + g.name +
                             "' is the particle '" + g.bodies[l].name + "', a name already used by " + user);
      const std::string reason = "[[lattice]] '" + g.name + "' generates the particle name '" + g.bodies[l].name +
                                 "', which is already used by " + user;
      if (g.name_node != nullptr) reader.fail(*g.name_node, g.name_key, reason);
      throw SceneError(g.location, g.name_key, reason);
    }
  }

  const std::size_t n = units.size();
  constexpr std::size_t world = static_cast<std::size_t>(-1);
  std::vector<NameRef> parent(n, NameRef{world, 0});
  std::vector<std::vector<std::size_t>> children(n);
  for (std::size_t u = 0; u < n; ++u) {
    if (units[u].block) continue;  // generated particles hang from the world
    const BodyEntry& e = entries[units[u].index];
    if (e.parent == "world") continue;
    const auto it = by_name.find(e.parent);
    if (it == by_name.end()) {
      std::vector<std::string> names;
      for (const Unit& unit : units) {
        if (!unit.block) names.push_back(entries[unit.index].body.name);
        else for (const Body& b : blocks[unit.index].bodies) names.push_back(b.name);
      }
      fail_entry(reader, e, e.parent_node, e.parent_key,
                 "unknown parent body '" + e.parent + "'" + did_you_mean(e.parent, names) +
                     "; a parent is \"world\" or the name of a body of this scene");
    }
    parent[u] = it->second;
    children[it->second.unit].push_back(u);
  }
  by_name.clear();  // its keys view names that are about to move

  std::priority_queue<std::size_t, std::vector<std::size_t>, std::greater<>> ready;
  for (std::size_t u = 0; u < n; ++u)
    if (parent[u].unit == world) ready.push(u);
  std::vector<int> start(n, -1);  // index of the unit's first body once placed
  std::vector<std::size_t> sequence;
  int placed = 0;
  while (!ready.empty()) {
    const std::size_t u = ready.top();
    ready.pop();
    start[u] = placed;
    placed += units[u].block ? static_cast<int>(blocks[units[u].index].count) : 1;
    sequence.push_back(u);
    for (const std::size_t c : children[u]) ready.push(c);
  }

  if (sequence.size() < n) {
    // Some bodies never reach the world: follow parents from one of them
    // until a body repeats; that part is a cycle (of entries: blocks are
    // placed at once).
    std::size_t i = static_cast<std::size_t>(std::find(start.begin(), start.end(), -1) - start.begin());
    std::vector<bool> seen(n, false);
    while (!seen[i]) {
      seen[i] = true;
      i = parent[i].unit;
    }
    std::vector<std::size_t> cycle{i};
    for (std::size_t j = parent[i].unit; j != i; j = parent[j].unit) cycle.push_back(j);
    // Report where a member names its parent, the earliest in the file.
    auto entry = [&](std::size_t u) -> const BodyEntry& { return entries[units[u].index]; };
    std::size_t culprit = cycle.front();
    for (const std::size_t j : cycle)
      if (entry(j).parent_node != nullptr && (entry(culprit).parent_node == nullptr || j < culprit)) culprit = j;
    const auto first = std::find(cycle.begin(), cycle.end(), culprit);
    std::rotate(cycle.begin(), first, cycle.end());
    std::string path;
    for (const std::size_t j : cycle) path += entry(j).body.name + " -> ";
    path += entry(culprit).body.name;
    const BodyEntry& e = entry(culprit);
    fail_entry(reader, e, e.parent_node, e.parent_key,
               "bodies form a parent cycle (each followed by its parent): " + path);
  }

  SystemDescription& description = scene.description;
  description.bodies.reserve(total);
  scene.body_locations.reserve(total);
  particle.reserve(total);
  block_start.assign(blocks.size(), 0);
  if (parts) scene.global_bodies.reserve(total);
  for (const std::size_t u : sequence) {
    if (!units[u].block) {
      BodyEntry& e = entries[units[u].index];
      if (parts) scene.global_bodies.push_back(start[u]);  // every body on the world (parse_scene)
      e.body.parent = parent[u].unit == world ? -1 : start[parent[u].unit] + parent[u].local;
      description.bodies.push_back(std::move(e.body));
      scene.body_locations.push_back(e.location);
      particle.push_back(e.particle);
      continue;
    }
    Generated& g = blocks[units[u].index];
    block_start[units[u].index] = static_cast<int>(description.bodies.size());
    for (std::size_t l = 0; l < g.bodies.size() && parts; ++l)
      scene.global_bodies.push_back(start[u] + (g.held.empty() ? static_cast<long long>(l) : g.held[l]));
    for (std::size_t l = 0; l < g.bodies.size(); ++l) {
      description.bodies.push_back(std::move(g.bodies[l]));
      scene.body_locations.push_back(g.csv.empty() ? g.location : SourceLocation{g.csv, g.lines[l], 1});
    }
    particle.insert(particle.end(), g.bodies.size(), true);
  }
}

// A body index by name ("world" is −1) for springs, loads and constraints;
// particles are bodies. "<chain>.tip" names the last link of the chain called
// <chain>, whatever its length (a body whose own name is exactly that takes
// precedence). Keeps views of the bodies' names: the bodies must outlive it
// unchanged. The hash table is made at the first look-up (a scene of
// generators alone needs none).
class BodyNames {
 public:
  BodyNames(const std::vector<Body>& bodies, std::map<std::string, std::string> chain_tips, std::vector<bool> particle)
      : bodies_(bodies), particle_(std::move(particle)), tips_(std::move(chain_tips)) {}
  const std::string& name(int index) const { return bodies_[static_cast<std::size_t>(index)].name; }
  // Whether body `index` (≥ 0) is a particle ([[particle]], [[lattice]] or [[network]]; possibly fixed).
  bool particle(int index) const { return particle_[static_cast<std::size_t>(index)]; }
  JointType joint(int index) const { return bodies_[static_cast<std::size_t>(index)].joint; }
  int find(const Section& s, std::string_view key, const std::string& name, bool allow_world) const {
    if (name == "world") {
      if (!allow_world) s.fail(key, "must name a body, not the world");
      return -1;
    }
    if (index_.empty()) {
      index_.reserve(bodies_.size());
      for (std::size_t i = 0; i < bodies_.size(); ++i) index_.emplace(bodies_[i].name, static_cast<int>(i));
    }
    const auto it = index_.find(name);
    if (it != index_.end()) return it->second;
    static constexpr std::string_view tip = ".tip";
    if (name.size() > tip.size() && name.ends_with(tip)) {
      const std::string chain = name.substr(0, name.size() - tip.size());
      const auto t = tips_.find(chain);
      if (t == tips_.end()) {
        std::vector<std::string> chains;
        for (const auto& [c, last] : tips_) chains.push_back(c);
        s.fail(key, "unknown chain '" + chain + "' in '" + name + "'" + did_you_mean(chain, chains) +
                        (chains.empty() ? "; the scene has no [[chain]]" : "; \"<chain>.tip\" names a chain's last link"));
      }
      return index_.at(t->second);
    }
    std::vector<std::string> candidates;
    candidates.reserve(bodies_.size() + 1);
    for (const Body& b : bodies_) candidates.push_back(b.name);
    if (allow_world) candidates.emplace_back("world");
    s.fail(key, "unknown body '" + name + "'" + did_you_mean(name, candidates));
  }

 private:
  const std::vector<Body>& bodies_;
  mutable std::unordered_map<std::string_view, int> index_;
  std::vector<bool> particle_;               // by body index
  std::map<std::string, std::string> tips_;  // chain name → its last body's name
};

// The point `key` (a_point, b_point) of an end attached to body `body`: in the
// body frame (world coordinates for the world, −1), default zero. A particle is
// itself the point, so giving one for a particle is an error.
Vec3 end_point(const Section& s, std::string_view key, int body, const BodyNames& names) {
  if (body >= 0 && names.particle(body) && s.has(key))
    s.fail(key, "a particle is a point: '" + std::string(key) + "' is not used for particle '" + names.name(body) + "'");
  return s.vector3(key, Vec3::Zero());
}

// World position of an attachment at q = 0.
Vec3 written_position(const Attachment& at, const std::vector<Pose>& frames) {
  if (at.body < 0) return at.point;
  const Pose& f = frames[static_cast<std::size_t>(at.body)];
  return f.position + f.rotation * at.point;
}

// World pose of each body frame at q = 0 (the parent's frame moved to the
// origin and turned by the body's orientation).
std::vector<Pose> frame_poses(const std::vector<Body>& bodies) {
  std::vector<Pose> p(bodies.size());
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const Pose parent = bodies[i].parent < 0 ? Pose{} : p[static_cast<std::size_t>(bodies[i].parent)];
    p[i].position = parent.position + parent.rotation * bodies[i].origin;
    p[i].rotation = parent.rotation * bodies[i].orientation;
  }
  return p;
}

Spring read_spring(const Reader& reader, const toml::table& table, std::size_t index, const BodyNames& names,
                   const std::vector<Pose>& frames) {
  const Section s(reader, table, scene_detail::index_key("spring", index), "[[spring]]");
  s.check_keys({"a", "b", "a_point", "b_point", "stiffness", "rest_length", "damping"});
  Spring spring;
  const std::string a = s.required_string("a");
  const std::string b = s.required_string("b");
  spring.a.body = names.find(s, "a", a, true);
  spring.b.body = names.find(s, "b", b, true);
  if (a == b) s.fail("b", "a spring must join two different bodies; both ends are '" + a + "'");
  spring.a.point = end_point(s, "a_point", spring.a.body, names);
  spring.b.point = end_point(s, "b_point", spring.b.body, names);
  spring.stiffness = s.required_number("stiffness", Range::positive);
  spring.damping = s.number("damping", 0.0, Range::nonnegative);
  if (s.has("rest_length")) {
    spring.rest_length = s.number("rest_length", 0.0, Range::nonnegative);
  } else {
    spring.rest_length = (written_position(spring.a, frames) - written_position(spring.b, frames)).stableNorm();
    if (!std::isfinite(spring.rest_length))
      s.fail("rest_length", "the distance between the spring's ends as written overflows (it is not finite), so it "
                            "cannot be the rest length; give a finite 'rest_length'");
  }
  return spring;
}

// A coupling [[constraint]] (its type and name read): the joint coordinate of
// body `a` (hinge or slide) equals the polynomial (1 to 5 coefficients, of
// 1, q_b, q_b², …) of body `b`'s joint coordinate; without `b`, the constant.
Constraint read_coupling(const Section& s, const BodyNames& names, Constraint c) {
  for (const char* key : {"a_point", "b_point", "length"})
    if (s.has(key))
      s.fail(key, std::string("'") + key + "' is not used by a coupling constraint (it joins joint coordinates, not points)");
  auto scalar_joint = [&](const char* key, const std::string& name) {
    const int body = names.find(s, key, name, false);
    const JointType t = names.joint(body);
    if (t != JointType::hinge && t != JointType::slide)
      s.fail(key, "'" + name + "' has a " + to_string(t) + " joint; a coupling joins hinge or slide coordinates");
    return body;
  };
  c.a.body = scalar_joint("a", s.required_string("a"));
  if (s.has("b")) {
    const std::string b = s.required_string("b");
    c.b.body = scalar_joint("b", b);
    if (c.b.body == c.a.body) s.fail("b", "a coupling joins two different joints; both are '" + b + "'");
  }
  const toml::node* node = s.find("polynomial");
  if (node == nullptr) s.fail("polynomial", "a coupling needs its polynomial: [c0, c1, …] (at most 5 coefficients)");
  const toml::array* array = node->as_array();
  const std::size_t count = array != nullptr ? array->size() : 0;
  if (count < 1 || count > 5)
    s.fail("polynomial", "expected an array of 1 to 5 numbers (coefficients of 1, q_b, q_b², q_b³, q_b⁴)");
  if (c.b.body < 0 && count > 1)
    s.fail("polynomial", "without 'b' the coupling holds 'a' at a constant: give one coefficient, [c0]");
  const VectorX p = s.numbers("polynomial", VectorX::Zero(static_cast<Eigen::Index>(count)));
  for (Eigen::Index k = 0; k < p.size(); ++k) c.polynomial[static_cast<std::size_t>(k)] = p[k];
  return c;
}

// [[constraint]]: a loop closure between a point of a and a point of b, which
// coincide ("point") or keep their distance ("distance", by default the
// distance as written). `index` is the table's 0-based position; `used` the
// names of the constraints read so far (names must be unique).
Constraint read_constraint(const Reader& reader, const toml::table& table, std::size_t index, const BodyNames& names,
                           const std::vector<Pose>& frames, std::map<std::string, int>& used) {
  const Section s(reader, table, scene_detail::index_key("constraint", index), "[[constraint]]");
  s.check_keys({"type", "name", "a", "b", "a_point", "b_point", "length", "polynomial"});
  Constraint c;
  const std::string type = s.required_string("type");
  if (type == "point") {
    c.type = Constraint::Type::point;
  } else if (type == "distance") {
    c.type = Constraint::Type::distance;
  } else if (type == "coupling") {
    c.type = Constraint::Type::coupling;
  } else {
    s.fail("type", "unknown constraint type '" + type + "'; expected \"point\" (two points coincide), \"distance\" "
                   "(two points keep their distance) or \"coupling\" (a joint follows another)" +
                       did_you_mean(type, {"point", "distance", "coupling"}));
  }

  c.name = s.string("name", "constraint" + std::to_string(index + 1));
  if (c.name.empty()) s.fail("name", "a constraint name must not be empty");
  const int line = s.has("name") ? reader.location(*s.find("name")).line : s.location().line;
  const auto [previous, inserted] = used.emplace(c.name, line);
  if (!inserted)
    s.fail("name", "duplicate constraint name '" + c.name + "': already used by the [[constraint]] at line " +
                       std::to_string(previous->second));

  if (c.type == Constraint::Type::coupling) return read_coupling(s, names, std::move(c));
  if (s.has("polynomial")) s.fail("polynomial", "'polynomial' is used by a coupling constraint only");
  const std::string a = s.required_string("a");
  const std::string b = s.required_string("b");
  c.a.body = names.find(s, "a", a, true);
  c.b.body = names.find(s, "b", b, true);
  if (c.a.body < 0 && c.b.body < 0)
    s.fail("b", "both ends of the constraint are the world; at least one must be a body or a particle");
  if (c.a.body == c.b.body)
    s.fail("b", "a constraint must join two different bodies; both ends are '" + names.name(c.b.body) + "'");
  c.a.point = end_point(s, "a_point", c.a.body, names);
  c.b.point = end_point(s, "b_point", c.b.body, names);

  if (c.type == Constraint::Type::point) {
    if (s.has("length")) s.fail("length", "'length' is not used by a point constraint (its points coincide)");
  } else if (s.has("length")) {
    c.length = s.number("length", 0.0, Range::positive);
  } else {
    const Vec3 xa = written_position(c.a, frames);
    const Vec3 xb = written_position(c.b, frames);
    c.length = (xa - xb).stableNorm();
    if (!std::isfinite(c.length))
      throw SceneError(s.location(), s.key("length"),
                       "the distance between the constraint's points as written overflows (it is not finite), so it "
                       "cannot be its length; give a finite 'length'");
    if (!(c.length > 1e-12 * std::max(xa.norm(), xb.norm())))
      throw SceneError(s.location(), s.key("length"),
                       "the two points of the distance constraint coincide as written, so its default length would "
                       "be 0; give a positive 'length'");
  }
  return c;
}

// A [[load]]: a dead load, or with `follower = true` a follower load whose
// force as written is its body-frame force (at q = 0 the scene frame turned by
// the orientations of the body and its ancestors).
void read_load(const Reader& reader, const toml::table& table, std::size_t index, const BodyNames& names,
               SystemDescription& d) {
  const Section s(reader, table, scene_detail::index_key("load", index), "[[load]]");
  s.check_keys({"body", "point", "force", "follower"});
  const bool follower = s.boolean("follower", false);
  Attachment at;
  at.body = names.find(s, "body", s.required_string("body"), false);
  at.point = s.vector3("point", Vec3::Zero());
  const Vec3 force = s.required_vector3("force");
  if (follower)
    d.followers.push_back({at, force});
  else
    d.loads.push_back({at, force});
}

// [[lattice]] and [[network]] names are unique among generators (they prefix
// their particles' names); checked before any generator is read, so that no
// CSV file is opened for a scene with this mistake. A name that is not a
// string is left to the generator to report.
void check_generator_names(const Reader& reader, const std::vector<const toml::table*>& lattices,
                           const std::vector<const toml::table*>& networks) {
  struct Named {
    std::string name, kind, key;
    const toml::node* node;
    SourceLocation location;
  };
  std::vector<Named> all;
  for (const auto& [tables, kind] : {std::pair{&lattices, "lattice"}, std::pair{&networks, "network"}})
    for (std::size_t i = 0; i < tables->size(); ++i) {
      const toml::table& table = *(*tables)[i];
      const toml::node* node = table.get("name");
      if (node != nullptr && !node->is_string()) continue;
      all.push_back({node != nullptr ? node->as_string()->get() : std::string(kind), "[[" + std::string(kind) + "]]",
                     scene_detail::index_key(kind, i) + ".name", node, reader.location(table)});
    }
  std::stable_sort(all.begin(), all.end(), [](const Named& x, const Named& y) {
    return std::pair(x.location.line, x.location.column) < std::pair(y.location.line, y.location.column);
  });
  std::map<std::string, const Named*> seen;
  for (const Named& g : all) {
    const auto [it, inserted] = seen.emplace(g.name, &g);
    if (inserted) continue;
    const std::string reason = "duplicate generator name '" + g.name + "': already used by the " + it->second->kind +
                               " at line " + std::to_string(it->second->location.line) +
                               (g.node == nullptr ? " (the default name; give each one a 'name')" : "");
    if (g.node != nullptr) reader.fail(*g.node, g.key, reason);
    throw SceneError(g.location, g.key, reason);
  }
}

// The tables of the array `key` of the root, or none.
std::vector<const toml::table*> tables_of(const Reader& reader, const toml::table& root, std::string_view key) {
  const toml::node* node = root.get(key);
  return node != nullptr ? reader.tables(*node, std::string(key)) : std::vector<const toml::table*>{};
}

// Read in parts: the owned range of the whole scene's bodies (into `scene`)
// and each generator's window in it. The bodies are placed as order_bodies
// places them when all hang from the world (as the distributed backend
// needs): in file order, a generator's particles together.
std::vector<scene_detail::GeneratorWindow> part_windows(const Reader& reader, const SceneWindow& window,
                                                         const std::vector<BodyEntry>& entries,
                                                         const std::vector<const toml::table*>& lattices,
                                                         const std::vector<const toml::table*>& networks,
                                                         const std::vector<long long>& counts, Scene& scene) {
  for (const BodyEntry& e : entries)
    if (e.parent != "world")
      fail_entry(reader, e, e.parent_node, e.parent_key,
                 "the scene is read in parts (the distributed backend), which needs every body on the world; '" +
                     e.body.name + "' hangs from '" + e.parent + "'");
  struct Placed {
    std::tuple<int, int, int> order;
    long long count;
    long long block;  // −1: an entry
  };
  std::vector<Placed> placed;
  for (const BodyEntry& e : entries) placed.push_back({e.order, 1, -1});
  std::size_t b = 0;
  for (const auto* tables : {&lattices, &networks})
    for (const toml::table* table : *tables) {
      const SourceLocation where = reader.location(*table);
      placed.push_back({{where.line, where.column, 0}, counts[b], static_cast<long long>(b)});
      ++b;
    }
  std::stable_sort(placed.begin(), placed.end(), [](const Placed& x, const Placed& y) { return x.order < y.order; });
  long long total = 0;
  for (const Placed& p : placed) total += p.count;
  if (total > max_particles_in_parts)  // each generator is within it: there are several
    reader.fail(lattices.empty() ? *networks.front() : *lattices.front(), "",
                "the scene's generators would make " + scene_detail::count_text(static_cast<double>(total)) +
                    " particles in all; at most " + std::to_string(max_particles_in_parts) +
                    " can be numbered in a scene read in parts (32-bit indices)");
  const long long parts = std::max(window.parts, 1), part = std::clamp<long long>(window.part, 0, parts - 1);
  const long long base = total / parts, extra = total % parts;
  scene.total_bodies = total;
  scene.first_owned = part * base + std::min(part, extra);
  scene.end_owned = scene.first_owned + base + (part < extra ? 1 : 0);
  std::vector<scene_detail::GeneratorWindow> windows(counts.size());
  long long start = 0;
  for (const Placed& p : placed) {
    if (p.block >= 0) {
      auto& w = windows[static_cast<std::size_t>(p.block)];
      w.first = std::clamp(scene.first_owned - start, 0LL, p.count);
      w.end = std::clamp(scene.end_owned - start, 0LL, p.count);
    }
    start += p.count;
  }
  return windows;
}

// The body names that [[spring]], [[load]] and [[constraint]] tables give
// (as strings; anything else is left to their readers to report).
std::vector<std::string> table_names(const toml::table& root) {
  std::vector<std::string> names;
  for (const auto& [array, keys] : {std::pair{"spring", std::vector<const char*>{"a", "b"}},
                                    std::pair{"load", std::vector<const char*>{"body"}},
                                    std::pair{"constraint", std::vector<const char*>{"a", "b"}}}) {
    const toml::array* tables = root.get(array) != nullptr ? root.get(array)->as_array() : nullptr;
    if (tables == nullptr) continue;
    for (const toml::node& node : *tables)
      if (const toml::table* table = node.as_table())
        for (const char* key : keys)
          if (const toml::node* value = table->get(key); value != nullptr && value->is_string())
            names.push_back(value->as_string()->get());
  }
  return names;
}

}  // namespace

Scene parse_scene(std::string_view text, const std::string& file_name, const std::vector<ParameterOverride>& overrides,
                  const SceneLimits& limits, const SceneWindow* window) {
  toml::table root;
  try {
    root = toml::parse(text, std::string_view(file_name));
  } catch (const toml::parse_error& e) {
    const auto& begin = e.source().begin;
    throw SceneError(SourceLocation{file_name, static_cast<int>(begin.line), static_cast<int>(begin.column)}, "",
                     std::string(e.description()));
  }

  Reader reader(file_name, text, limits);
  const Section top(reader, root, "", "the top level of the scene");
  top.check_keys({"title", "gravity", "frame_rotation", "parameters", "body", "chain", "particle", "lattice", "network",
                  "spring", "load", "constraint", "coordinates", "point", "potential"});

  const toml::table* parameters = nullptr;
  if (const toml::node* node = top.find("parameters")) {
    parameters = node->as_table();
    if (parameters == nullptr)
      reader.fail(*node, "parameters", "expected a table ([parameters]), got " + scene_detail::describe_type(*node));
  }
  reader.set_parameters(scene_detail::resolve_parameters(reader, parameters, overrides));

  Scene scene;
  scene.file = file_name;
  for (std::size_t i = 0; i < reader.parameters().names.size(); ++i)
    scene.parameters.emplace_back(reader.parameters().names[i], reader.parameters().values[i]);
  SystemDescription& d = scene.description;
  d.title = top.string("title", scene_detail::file_stem(file_name));
  d.gravity = top.vector3("gravity", Vec3(0, 0, -9.81));
  d.frame_rotation = top.vector3("frame_rotation", Vec3::Zero());  // rad/s, about the world origin

  if (scene_detail::read_map(reader, root, d)) {
    for (const char* key : {"body", "chain", "particle", "lattice", "network", "spring", "load", "constraint", "frame_rotation"})
      if (const toml::node* node = root.get(key))
        reader.fail(*node, key,
                    std::string("a scene is either a kinematic map ([coordinates], [[point]]) or a tree of bodies; '") +
                        key + "' belongs to the second" +
                        (std::string(key) == "frame_rotation" ? " (a map writes a moving frame with the time t)" : ""));
    try {
      const System check(d);  // steadiness, ignorable coordinates, definedness at the initial configuration
    } catch (const std::invalid_argument& e) {
      throw SceneError(reader.location(*root.get("coordinates")), "coordinates", e.what());
    } catch (const NumericalError& e) {
      throw SceneError(reader.location(*root.get("coordinates")), "coordinates", e.what());
    }
    return scene;
  }

  std::vector<BodyEntry> entries;
  const auto bodies = tables_of(reader, root, "body");
  for (std::size_t i = 0; i < bodies.size(); ++i) entries.push_back(read_body(reader, *bodies[i], i));
  const auto chains = tables_of(reader, root, "chain");
  std::map<std::string, std::string> chain_tips;  // chain name → its last link's body name
  for (std::size_t i = 0; i < chains.size(); ++i) {
    std::vector<BodyEntry> links = read_chain(reader, *chains[i], i);
    chain_tips[links.back().chain] = links.back().body.name;
    for (BodyEntry& e : links) entries.push_back(std::move(e));
  }
  const auto particles = tables_of(reader, root, "particle");
  for (std::size_t i = 0; i < particles.size(); ++i) entries.push_back(read_particle(reader, *particles[i], i));
  std::vector<scene_detail::Generated> blocks;  // [[lattice]] and [[network]]
  const auto lattices = tables_of(reader, root, "lattice");
  const auto networks = tables_of(reader, root, "network");
  check_generator_names(reader, lattices, networks);
  std::vector<long long> counts;  // the generators' particles
  scene_detail::GeneratorWindow counting;
  counting.in_parts = window != nullptr;
  for (std::size_t i = 0; i < lattices.size(); ++i)
    counts.push_back(
        scene_detail::read_lattice(reader, *lattices[i], i, scene_detail::LatticePass::count, counting).count);
  std::vector<scene_detail::GeneratorWindow> windows(lattices.size() + networks.size());
  std::vector<std::string> named;  // read in parts: the names the tables use
  if (window != nullptr) {
    for (std::size_t i = 0; i < networks.size(); ++i)
      counts.push_back(
          scene_detail::read_network(reader, *networks[i], i, scene_detail::LatticePass::count, counting).count);
    windows = part_windows(reader, *window, entries, lattices, networks, counts, scene);
    named = table_names(root);
    for (auto& w : windows) {
      w.named = &named;
      w.in_parts = true;
    }
  }
  for (std::size_t i = 0; i < lattices.size(); ++i)
    blocks.push_back(scene_detail::read_lattice(reader, *lattices[i], i, scene_detail::LatticePass::generate, windows[i]));
  for (std::size_t i = 0; i < networks.size(); ++i)
    blocks.push_back(scene_detail::read_network(reader, *networks[i], i, scene_detail::LatticePass::generate,
                                                windows[lattices.size() + i]));
  if (entries.empty() && blocks.empty())
    throw SceneError(reader.location(root), "", "the scene has no bodies: add a [[body]], a [[chain]], a [[particle]], a "
                                                "[[lattice]] or a [[network]] (or write it as a kinematic map: "
                                                "[coordinates] and [[point]])");
  std::stable_sort(entries.begin(), entries.end(),
                   [](const BodyEntry& x, const BodyEntry& y) { return x.order < y.order; });
  std::vector<bool> particle;   // by body index
  std::vector<int> block_start;  // first body index of each block
  order_bodies(reader, entries, blocks, scene, particle, block_start);
  if (window == nullptr) {
    scene.total_bodies = scene.end_owned = static_cast<long long>(d.bodies.size());
  } else if (scene.global_bodies.empty()) {  // every block whole: the bodies in order
    scene.global_bodies.resize(d.bodies.size());
    std::iota(scene.global_bodies.begin(), scene.global_bodies.end(), 0LL);
  }

  const BodyNames names(d.bodies, chain_tips, std::move(particle));
  const std::vector<Pose> frames = frame_poses(d.bodies);
  const auto springs = tables_of(reader, root, "spring");
  if (!springs.empty()) {
    std::size_t generated_springs = 0;
    for (const auto& g : blocks) generated_springs += g.springs.size();
    d.springs.reserve(springs.size() + generated_springs);
  }
  for (std::size_t i = 0; i < springs.size(); ++i) d.springs.push_back(read_spring(reader, *springs[i], i, names, frames));
  for (std::size_t b = 0; b < blocks.size(); ++b) {  // after the [[spring]]s, ends shifted to the block's place
    std::vector<Spring>& generated = blocks[b].springs;
    if (blocks[b].edge_rows >= 0) {  // a network read in parts
      scene.network_edges += blocks[b].edge_rows;
      scene.owned_network_edges += static_cast<long long>(generated.size());
    }
    for (Spring& spring : generated) {
      spring.a.body += block_start[b];
      spring.b.body += block_start[b];
    }
    if (d.springs.empty())
      d.springs = std::move(generated);  // a large block's springs are not copied
    else
      d.springs.insert(d.springs.end(), generated.begin(), generated.end());
  }
  const auto loads = tables_of(reader, root, "load");
  for (std::size_t i = 0; i < loads.size(); ++i) read_load(reader, *loads[i], i, names, d);
  const auto constraints = tables_of(reader, root, "constraint");
  std::map<std::string, int> constraint_names;  // name → line where it is given
  for (std::size_t i = 0; i < constraints.size(); ++i)
    d.constraints.push_back(read_constraint(reader, *constraints[i], i, names, frames, constraint_names));
  scene.data_files = reader.data_files();
  return scene;
}

double scene_memory(double particles, double bodies, double springs) {
  return 1200 * particles + 2000 * bodies + 170 * springs;
}

std::string read_scene_file(const std::string& path) {
  if (path.empty())
    throw SceneError(SourceLocation{"''", 0, 0}, "",
                     "the scene file's name is empty; give the path of a scene (.toml) or model (.xml, .urdf)");
  const SourceLocation where{path, 0, 0};
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status))
    throw SceneError(where, "", "cannot open the scene file: " + (ec ? ec.message() : std::string("no such file")));
  if (std::filesystem::is_directory(status))
    throw SceneError(where, "", "cannot read the scene file: it is a directory");
  if (!std::filesystem::is_regular_file(status))
    throw SceneError(where, "", "cannot read the scene file: it is not a regular file (a pipe, socket or device); "
                                "give a file");
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && size > max_scene_bytes)
    throw SceneError(where, "", "the scene file has " + std::to_string(size) + " bytes, more than the " +
                                    std::to_string(max_scene_bytes >> 20) +
                                    " MiB a scene may have (large scenes are written with generators such as "
                                    "[[lattice]], or as a [[network]] of CSV files)");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(where, "", std::string("cannot open the scene file: ") + std::strerror(errno));
  std::string text;
  text.resize(static_cast<std::size_t>(size));
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  if (in.bad() || static_cast<std::size_t>(in.gcount()) != text.size() || in.peek() != std::char_traits<char>::eof())
    throw SceneError(where, "", "cannot read the scene file: it changed while it was read");
  return text;
}

Scene load_scene(const std::string& path, const std::vector<ParameterOverride>& overrides, const SceneLimits& limits,
                 const SceneWindow* window) {
  return parse_scene(read_scene_file(path), path, overrides, limits, window);
}

System build_system(const Scene& scene) { return System(scene.description); }

}  // namespace modal
