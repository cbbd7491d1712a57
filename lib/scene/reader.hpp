// Private to lib/scene: reading typed values from a parsed TOML scene, each with
// its source location and dotted key, so that every error names the file, line,
// column and key (docs/design.md, "Scene format").
//
// A Reader knows the scene text (to point into expression strings) and the
// resolved parameters (to evaluate expressions); a Section is one table of the
// scene with its key path ("body[2]") and reads the keys of that table.
#pragma once

#include "modal/core.hpp"
#include "modal/expression.hpp"
#include "modal/scene.hpp"

#include <toml++/toml.h>

#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

namespace modal::scene_detail {

// Parameters visible to expressions: names and final values, file order.
struct Parameters {
  std::vector<std::string> names;
  std::vector<double> values;
};

// A constraint on a number read from the scene.
enum class Range { any, nonnegative, positive };

// "1.5", "-2", "nan": shortest round-trip text of a value, for messages.
std::string format_number(double value);
// "5000000" for a count (whole digits up to 10¹⁵, then as format_number).
std::string count_text(double count);
// A name expressions can use: letters, digits and _, not starting with a digit.
bool is_identifier(std::string_view s);
// "body[3]": the dotted key of entry `index` (0-based) of an array of tables.
std::string index_key(std::string_view array, std::size_t index);
// "an integer", "a string", "a table", …: a TOML node's type, for messages.
std::string describe_type(const toml::node& node);
// 'stem' of a path: "models/seesaw.toml" → "seesaw".
std::string file_stem(const std::string& path);

class Reader {
 public:
  Reader(std::string file, std::string_view text, SceneLimits limits = {});
  const SceneLimits& limits() const { return limits_; }

  const std::string& file() const { return file_; }
  SourceLocation location(const toml::source_region& region) const;
  SourceLocation location(const toml::node& node) const { return location(node.source()); }
  // The location of character `position` (0-based) of a string node's value,
  // when the string is written plainly on one line (else the string's start).
  SourceLocation location_in_string(const toml::node& node, int position) const;

  [[noreturn]] void fail(const toml::node& node, const std::string& key, const std::string& reason) const;

  void set_parameters(Parameters parameters) { parameters_ = std::move(parameters); }
  const Parameters& parameters() const { return parameters_; }

  // A number: TOML integer or float, or a string expression over the
  // parameters; finite, and within `range`.
  double number(const toml::node& node, const std::string& key, Range range = Range::any) const;
  // An array of exactly `size` numbers.
  VectorX numbers(const toml::node& node, const std::string& key, int size, Range range = Range::any) const;
  std::string string(const toml::node& node, const std::string& key) const;
  bool boolean(const toml::node& node, const std::string& key) const;
  // The tables of an array of tables ([[body]]), in file order.
  std::vector<const toml::table*> tables(const toml::node& node, const std::string& key) const;

  // Counts what a generator is about to add (before it allocates anything)
  // and refuses it at `node`, `key` when the scene would then hold more
  // particles (lattices and networks together) or springs than limits()
  // allow, or need more memory (scene_memory) than limits().memory or the
  // machine's available memory. `what` names the generator ("the lattice").
  void add_to_scene(const toml::node& node, const std::string& key, const std::string& what, double particles,
                    double bodies, double springs) const;

  // Turns an expression error in the string node `node` into a SceneError
  // pointing at the offending character.
  [[noreturn]] void fail_expression(const toml::node& node, const std::string& key, const std::string& text,
                                    int position, const std::string& message) const;

  // The data files the scene reads (a network's CSV files), as resolved, in
  // the order opened: inputs that no output of the run may replace.
  void note_data_file(const std::string& path) const { data_files_.push_back(path); }
  const std::vector<std::string>& data_files() const { return data_files_; }

 private:
  std::string file_;
  std::vector<std::string_view> lines_;  // the scene text, line by line
  Parameters parameters_;
  SceneLimits limits_;
  mutable double particles_ = 0, bodies_ = 0, springs_ = 0;  // added so far (add_to_scene)
  mutable std::vector<std::string> data_files_;
};

// One table of the scene: reads its keys with defaults and checks.
class Section {
 public:
  // `path`: dotted key of the table ("" at the top level, "body[2]");
  // `kind`: how messages name it ("[[body]]", "the top level").
  Section(const Reader& reader, const toml::table& table, std::string path, std::string kind)
      : reader_(reader), table_(table), path_(std::move(path)), kind_(std::move(kind)) {}

  const toml::table& table() const { return table_; }
  const std::string& path() const { return path_; }
  SourceLocation location() const { return reader_.location(table_); }
  std::string key(std::string_view name) const;  // dotted key of a key of this table
  const toml::node* find(std::string_view name) const { return table_.get(name); }
  bool has(std::string_view name) const { return find(name) != nullptr; }

  // Every key must be in `allowed`; keys in `later` belong to later versions
  // of the format and get their own message.
  void check_keys(std::initializer_list<std::string_view> allowed,
                  std::initializer_list<std::string_view> later = {}) const;

  [[noreturn]] void fail(std::string_view name, const std::string& reason) const;  // at the key's value
  [[noreturn]] void missing(std::string_view name) const;                          // at the table

  double number(std::string_view name, double fallback, Range range = Range::any) const;
  double required_number(std::string_view name, Range range = Range::any) const;
  VectorX numbers(std::string_view name, const VectorX& fallback, Range range = Range::any) const;
  Vec3 vector3(std::string_view name, const Vec3& fallback) const;
  Vec3 required_vector3(std::string_view name) const;
  // A direction: three numbers, not zero, returned normalized.
  Vec3 unit_vector(std::string_view name, const Vec3& fallback) const;
  std::string string(std::string_view name, const std::string& fallback) const;
  std::string required_string(std::string_view name) const;
  bool boolean(std::string_view name, bool fallback) const;

 private:
  const toml::node& required(std::string_view name) const;

  const Reader& reader_;
  const toml::table& table_;
  std::string path_, kind_;
};

// `inertia` of a table: [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] about the centre of
// mass, body frame (kg·m², default 0), checked to be a physical tensor.
Mat3 read_inertia(const Section& s);

// [coordinates], [[point]] and `potential` of the root (an expression-defined
// system, docs/design.md "Scene format") into d.map; false when the scene has none of them.
bool read_map(const Reader& reader, const toml::table& root, SystemDescription& d);

// Particles (bodies on the world) and springs made by a [[lattice]] or a
// [[network]] (network.cpp); the springs' ends index `bodies`, and parse_scene
// shifts them when it places the block among the other bodies.
struct Generated {
  std::string name;                       // the generator's name, prefix of its particles' names
  SourceLocation location;                // the table
  const toml::node* name_node = nullptr;  // where the name is written (null: the default)
  std::string name_key;
  std::vector<Body> bodies;               // particle or fixed joints, parent −1
  std::vector<Spring> springs;
  std::string csv;                        // network: the nodes file as resolved
  std::vector<int> lines;                 // network: each node's line in `csv`
  long long count = 0;                    // the block's particles in the whole scene
  // Read in parts (a GeneratorWindow): the block-local index of each body,
  // ascending; empty when the block holds all `count` particles in order.
  std::vector<long long> held;
  // A network read in parts: the rows of its edges file (its `springs` are
  // those this part owns); −1 otherwise.
  long long edge_rows = -1;
};

// The part of a generator's particles one process builds (distributed
// generation, docs/design.md "Distributed backend"). The serial path gives
// the whole range. Held are the owned particles [first, end), the other end
// particles of the springs whose first end is owned (ghosts: every spring
// belongs to its first end's owner), and the particles `named` by
// [[spring]], [[load]] or [[constraint]] tables (by their full names). Only
// the owned particles' springs are made. Every row and value is still read
// and checked, so the errors are those of the serial path, except what one
// part cannot see: an edge whose first node no part has, a node name
// repeated in two parts (the distributed backend checks them together).
struct GeneratorWindow {
  long long first = 0, end = -1;  // end < 0: the whole block
  const std::vector<std::string>* named = nullptr;
  // The scene is read in parts (also in the count pass, which has no range
  // yet): the limits (SceneLimits) then bound what this part builds, and the
  // whole only by what its indices can number (max_particles_in_parts).
  bool in_parts = false;
  bool whole(long long count) const { return first == 0 && (end < 0 || end >= count); }
};
// A lattice is read twice: first `count` (its size only, its particles added
// to the scene's totals, nothing generated), once for every lattice before
// any is generated, so that the one over the totals is refused before
// memory is spent on the others; then `generate`.
enum class LatticePass { count, generate };
Generated read_lattice(const Reader& reader, const toml::table& table, std::size_t index,
                       LatticePass pass = LatticePass::generate, const GeneratorWindow& window = {});
// A network counted only (`count`: the nodes file's rows counted as it is
// streamed, its header checked, nothing kept) or generated: with a window
// (end ≥ 0) both files streamed a row at a time, only the part kept (memory
// of the part's size), else both read whole.
Generated read_network(const Reader& reader, const toml::table& table, std::size_t index,
                       LatticePass pass = LatticePass::generate, const GeneratorWindow& window = {});

// Held particles of a window (GeneratorWindow): the owned range, the ends
// `others` of the owned springs and the `named` ones (block-local indices,
// −1 for none), ascending and unique; and the springs' ends turned from
// block-local indices into indices of the held list. Nothing is done for the
// whole block.
void hold_window(const GeneratorWindow& window, Generated& g, std::vector<long long> named);

// Resolves [parameters] (may be null) with the command-line overrides:
// definitions in any order, expressions over other parameters, cycles and
// undefined names reported with their location.
Parameters resolve_parameters(const Reader& reader, const toml::table* table,
                              const std::vector<ParameterOverride>& overrides);

}  // namespace modal::scene_detail
