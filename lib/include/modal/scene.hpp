// modal/scene.hpp — scene files (TOML, docs/design.md "Scene format") to validated Scenes to Systems.
//
//   modal::Scene scene = modal::load_scene("models/double_pendulum.toml", {{"m", "2"}});
//   modal::System sys = modal::build_system(scene);
//
// Every error names the file, line, column and key and says what is wrong
// (SceneError; command-line exit status 2).
#pragma once

#include "modal/core.hpp"

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace modal {

struct SourceLocation {
  std::string file;
  int line = 0;    // 1-based; 0 when unknown
  int column = 0;  // 1-based; 0 when unknown
};

// `text` as it may be shown on a terminal or in a log: control characters
// (C0, DEL and the C1 range U+0080–U+009F, which terminals act on) become
// escapes (a backslash, then x and two hex digits, or u{…} for C1), and so
// does every byte that is not part of valid UTF-8; everything else is kept.
// Every error message modal composes from a user's text goes through it
// (SceneError, error_message).
std::string printable(std::string_view text);
// Whether `text` needs no escaping (printable(text) == text).
bool is_printable(std::string_view text);

// what() is "<file>:<line>:<column>: <key>: <reason>" (key is a dotted path such
// as "body[2].mass" or "parameters.l"; the key part is omitted when empty, the
// line and column parts when unknown, e.g. for a missing file or a --set value,
// whose file is "--set"). Errors inside expression strings point at the
// offending character and quote it: `in "2*q" at 3: unknown name 'q'` (the
// position is 1-based, counted in the string).
class SceneError : public std::runtime_error {
 public:
  SceneError(SourceLocation where, std::string key, std::string reason);
  const SourceLocation& where() const { return where_; }
  const std::string& key() const { return key_; }
  const std::string& reason() const { return reason_; }

 private:
  SourceLocation where_;
  std::string key_, reason_;
};

// --set NAME=VALUE; VALUE may be an expression over the other parameters.
struct ParameterOverride {
  std::string name;
  std::string value;
};
// Parses "NAME=VALUE"; throws SceneError (file "--set") when malformed.
ParameterOverride parse_override(std::string_view text);

struct Scene {
  std::string file;                                       // as given
  std::vector<std::string> data_files;                    // files the scene read besides itself (a network's CSV files), as resolved
  SystemDescription description;                          // validated, generators expanded
  std::vector<std::pair<std::string, double>> parameters; // final values, file order
  std::vector<SourceLocation> body_locations;             // parallel to description.bodies
  // Read in parts (a SceneWindow): the index in the whole scene of each body
  // of `description` (ascending; empty: the whole scene, in order), the
  // whole scene's body count, and the bodies this part owns [first, end).
  std::vector<long long> global_bodies;
  long long total_bodies = 0, first_owned = 0, end_owned = 0;
  // Read in parts: the edge rows of the scene's [[network]]s, and those whose
  // springs this part owns. An edge whose first node no part has is owned by
  // none, so the parts' owned rows add up to fewer (the distributed backend
  // checks the sum: check_read_in_parts).
  long long network_edges = 0, owned_network_edges = 0;
};

// One part of a scene, for one of `parts` processes (the distributed backend:
// distributed generation, docs/design.md "Distributed backend"). The bodies
// of the whole scene, numbered as the serial path numbers them, are split
// into `parts` contiguous ranges (part p owns ⌊N/parts⌋ or one more); the
// part's description holds its owned bodies, the other end bodies of the
// springs it owns (a spring belongs to the owner of its first end, or of its
// second when the first is the world: ghosts), every hand-written body and
// every particle a [[spring]], [[load]] or [[constraint]] names. A
// [[lattice]] makes only those particles and the owned ones' springs; a
// [[network]]'s CSV files are streamed a row at a time, every row checked,
// and only those rows kept (memory of the part's size, never the whole).
// Every body must hang from the world (particles), and the names of
// generated particles are checked for clashes only among what the part
// holds; clashes between parts and edges naming a node no part has are left
// to the distributed backend, which checks the parts together
// (check_read_in_parts). The springs and loads of `description` are those whose ends it
// holds.
struct SceneWindow {
  int part = 0, parts = 1;
};
// A scene read in parts is bounded per part by its SceneLimits (what the
// process builds: its particles and springs, their memory), and as a whole
// only by what the indices can number: bodies and springs' ends are 32-bit
// integers, and the distributed backend's PETSc numbers the coordinates (3 per
// particle) with 32-bit integers.
inline constexpr long long max_particles_in_parts = 700'000'000;

// Upper bounds on what the generators may expand to. The defaults are what
// modal supports (a 5·10⁶-particle lattice with diagonals takes about 14 GB
// once built, as scene_memory estimates, and is refused where that does not
// fit); a
// caller that must bound memory and time more tightly (the fuzzer: a mutated
// size would otherwise exhaust its memory limit) passes smaller ones. Beyond
// them the scene is refused with a SceneError at the key. A scene read in
// parts (SceneWindow) is bounded per part: the limits apply to what the part
// builds.
struct SceneLimits {
  long long particles = 5'000'000;  // particles of one [[lattice]], and of all [[lattice]]s and [[network]]s together
  int links = 100'000;              // links of one [[chain]]
  long long springs = 50'000'000;   // springs of the whole scene (generated and written)
  // Bytes the scene may take once built (System, description and names,
  // estimated per body and spring before the generators run: scene_memory);
  // 0: the memory this machine has available (MemAvailable). The commands
  // check their own estimates against the same limit.
  double memory = 0;
  // Data files (a [[network]]'s CSV files) are read only from the scene
  // file's directory and below (symbolic links resolved), so that a scene
  // from someone else cannot read other files; true allows any path
  // (`--allow-outside-data`).
  bool allow_outside_data = false;
};

// The text of a scene file. Refuses, with a SceneError naming the file, what
// is not a regular file (a directory, a FIFO, a device such as /dev/zero:
// they could block or never end) and a file larger than max_scene_bytes
// (scene files are small: generators expand large scenes, and networks read
// their nodes and edges from separate CSV files).
inline constexpr std::size_t max_scene_bytes = 16u << 20;  // 16 MiB
// Bytes a built scene takes, estimated from what its generators will make
// (measured: a particle about 1.2 kB with its name and its entry in the
// description, a chain link or written body 2 kB, a spring 170 bytes).
double scene_memory(double particles, double bodies, double springs);
std::string read_scene_file(const std::string& path);
// read_scene_file + parse_scene.
Scene load_scene(const std::string& path, const std::vector<ParameterOverride>& overrides = {},
                 const SceneLimits& limits = {}, const SceneWindow* window = nullptr);
// Without a window the whole scene; with one, its part (SceneWindow).
Scene parse_scene(std::string_view text, const std::string& file_name,
                  const std::vector<ParameterOverride>& overrides = {}, const SceneLimits& limits = {},
                  const SceneWindow* window = nullptr);
System build_system(const Scene& scene);

}  // namespace modal
