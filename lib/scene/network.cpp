// Generators of particles and springs (docs/design.md, "Scene format": [[lattice]]
// and [[network]]):
//
//   [[lattice]]  particles on a regular grid, springs to the grid neighbours
//                (and the face diagonals); named "<name>.<i>.<j>.<k>" (a 2-D
//                net, size[3] = 1: "<name>.<i>.<j>"), indices from 0.
//   [[network]]  particles and springs read from two CSV files, nodes and
//                edges; a node called n is the particle "<name>.<n>".
//
// Both make a Generated block (reader.hpp): bodies on the world with particle
// joints (fixed joints for fixed particles) and springs whose ends index the
// block; parse_scene places the block among the other bodies. The loops touch
// each particle and spring once, without name lookups, so that a lattice of
// 10⁶ coordinates is read in a fraction of a second. CSV errors are
// SceneErrors located in the CSV file: "<csv>:<line>:<column>: <column name>: …".
#include "scene/reader.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <deque>
#include <exception>
#include <filesystem>
#include <limits>
#include <fstream>
#include <optional>
#include <sstream>
#include <unordered_map>

namespace modal::scene_detail {

namespace {

// The name of a generator: `fallback` by default, not empty, not "world".
void start_block(const Section& s, Generated& g, const std::string& fallback) {
  g.name = s.string("name", fallback);
  g.name_node = s.find("name");
  g.name_key = s.key("name");
  g.location = s.location();
  if (g.name.empty()) s.fail("name", "a " + fallback + " name must not be empty");
  if (g.name == "world") s.fail("name", "'world' is reserved for the fixed frame; choose another name");
}

double read_prestrain(const Section& s) {
  const double p = s.number("prestrain", 0.0, Range::nonnegative);
  if (!(p < 1))
    s.fail("prestrain", "must be less than 1 (a spring's rest length is (1 - prestrain) times its written length), got " +
                            format_number(p));
  return p;
}

// A particle on the world at `position`; `fixed` axes keep it there (all
// fixed: a fixed joint, as for [[particle]]).
void add_particle(std::vector<Body>& bodies, std::string name, const Vec3& position, double mass,
                  const std::array<bool, 3>& fixed) {
  Body& b = bodies.emplace_back();
  b.name = std::move(name);
  b.parent = -1;
  b.origin = position;
  b.mass = mass;
  for (std::size_t a = 0; a < 3; ++a) b.particle_axes[a] = !fixed[a];
  b.joint = fixed[0] && fixed[1] && fixed[2] ? JointType::fixed : JointType::particle;
  const int n = joint_coordinate_count(b);
  b.rest = VectorX::Zero(n);
  b.initial = VectorX::Zero(n);
}

// --- [[lattice]] ---------------------------------------------------------------

// Which ends of each lattice direction (i, j, k) are fixed.
struct FixedEnds {
  std::array<bool, 3> low{false, false, false}, high{false, false, false};
};

// One value of `fixed`: "none", "boundary" or a face "x-" … "z+" (named by
// world axes; a 2-D net has the four edges of its plane).
void read_fixed_value(const Reader& reader, const toml::node& node, const std::string& key,
                      const std::array<long long, 3>& n, bool net, bool xz, FixedEnds& ends) {
  const std::string value = reader.string(node, key);
  if (value == "none") return;
  if (value == "boundary") {
    for (std::size_t d = 0; d < 3; ++d)
      if (n[d] > 1) ends.low[d] = ends.high[d] = true;
    return;
  }
  const std::string plane = xz ? "xz" : "xy";
  const std::vector<std::string> faces = !net ? std::vector<std::string>{"x-", "x+", "y-", "y+", "z-", "z+"}
                                         : xz ? std::vector<std::string>{"x-", "x+", "z-", "z+"}
                                              : std::vector<std::string>{"x-", "x+", "y-", "y+"};
  std::string listed;
  for (std::size_t i = 0; i < faces.size(); ++i)
    listed += std::string(i == 0 ? "" : i + 1 == faces.size() ? " or " : ", ") + "\"" + faces[i] + "\"";
  if (std::find(faces.begin(), faces.end(), value) != faces.end()) {
    const char axis = value[0];
    const std::size_t d = axis == 'x' ? 0 : axis == 'y' ? 1 : net ? 1 : 2;  // a net in xz: j runs along z
    (value[1] == '-' ? ends.low : ends.high)[d] = true;
    return;
  }
  if (net && value.size() == 2 && (value[0] == 'y' || value[0] == 'z') && (value[1] == '-' || value[1] == '+'))
    reader.fail(node, key, "the net lies in the " + plane + " plane, so '" + value +
                               "' is not one of its edges; expected \"none\", \"boundary\", " + listed);
  std::vector<std::string> options{"none", "boundary"};
  options.insert(options.end(), faces.begin(), faces.end());
  reader.fail(node, key, "unknown value '" + value + "'; expected \"none\", \"boundary\" or " +
                             (net ? "an edge " : "a face ") + listed + did_you_mean(value, options));
}

}  // namespace

Generated read_lattice(const Reader& reader, const toml::table& table, std::size_t index, LatticePass pass,
                       const GeneratorWindow& window) {
  const Section s(reader, table, index_key("lattice", index), "[[lattice]]");
  s.check_keys({"name", "size", "spacing", "origin", "mass", "stiffness", "damping", "diagonals", "fixed", "prestrain",
                "plane"});
  Generated g;
  start_block(s, g, "lattice");
  // Read in parts, the limits bound the part (below) and the whole only its indices.
  const long long max_particles = window.in_parts ? max_particles_in_parts : reader.limits().particles;
  const std::string supported = window.in_parts ? " can be numbered in a scene read in parts" : " are supported";

  // size = [n1, n2, n3]: positive integers, at most max_particles in all.
  const toml::node* size_node = s.find("size");
  if (size_node == nullptr) s.missing("size");
  const std::string size_key = s.key("size");
  const auto* size_array = size_node->as_array();
  const std::string expected_size = "expected an array of 3 positive integers [nx, ny, nz] (nz = 1: a 2-D net)";
  if (size_array == nullptr) reader.fail(*size_node, size_key, expected_size + ", got " + describe_type(*size_node));
  if (size_array->size() != 3)
    reader.fail(*size_node, size_key, expected_size + ", got " + std::to_string(size_array->size()) + " elements");
  std::array<long long, 3> n{};
  double total = 1;
  for (std::size_t d = 0; d < 3; ++d) {
    const toml::node& element = (*size_array)[d];
    const std::string key = size_key + "[" + std::to_string(d + 1) + "]";
    const double value = reader.number(element, key);
    if (value != std::floor(value)) reader.fail(element, key, "must be an integer, got " + format_number(value));
    if (value < 1) reader.fail(element, key, "must be at least 1, got " + format_number(value));
    if (value > static_cast<double>(max_particles))
      reader.fail(element, key, "at most " + std::to_string(max_particles) + " particles" + supported + ", got " +
                                    count_text(value));
    n[d] = static_cast<long long>(value);
    total *= value;
  }
  if (total > static_cast<double>(max_particles))
    reader.fail(*size_node, size_key, "the lattice would have " + count_text(total) + " particles; at most " +
                                          std::to_string(max_particles) + supported);
  if (pass == LatticePass::count) {
    if (!window.in_parts) reader.add_to_scene(*size_node, size_key, "the lattice", total, 0, 0);
    g.count = static_cast<long long>(total);
    return g;
  }
  const bool net = n[2] == 1;

  // spacing: one number, or one per world axis [sx, sy, sz].
  const toml::node* spacing_node = s.find("spacing");
  if (spacing_node == nullptr) s.missing("spacing");
  const Vec3 spacing = spacing_node->is_array()
                           ? Vec3(reader.numbers(*spacing_node, s.key("spacing"), 3, Range::positive))
                           : Vec3::Constant(reader.number(*spacing_node, s.key("spacing"), Range::positive));
  const Vec3 origin = s.vector3("origin", Vec3::Zero());
  const double mass = s.required_number("mass", Range::nonnegative);
  const double stiffness = s.required_number("stiffness", Range::positive);
  const double damping = s.number("damping", 0.0, Range::nonnegative);
  const bool diagonals = s.boolean("diagonals", false);
  const double prestrain = read_prestrain(s);

  const std::string plane = s.string("plane", "xy");
  if (plane != "xy" && plane != "xz")
    s.fail("plane", "unknown plane '" + plane + "'; expected \"xy\" or \"xz\"" + did_you_mean(plane, {"xy", "xz"}));
  if (!net && s.has("plane"))
    s.fail("plane", "'plane' is for 2-D nets (size = [n1, n2, 1]); this lattice is 3-D (size[3] = " +
                        std::to_string(n[2]) + ")");
  const bool xz = plane == "xz";

  FixedEnds ends;
  if (const toml::node* node = s.find("fixed")) {
    const std::string key = s.key("fixed");
    if (const auto* array = node->as_array()) {
      for (std::size_t i = 0; i < array->size(); ++i)
        read_fixed_value(reader, (*array)[i], key + "[" + std::to_string(i + 1) + "]", n, net, xz, ends);
    } else if (node->is_string()) {
      read_fixed_value(reader, *node, key, n, net, xz, ends);
    } else {
      reader.fail(*node, key,
                  "expected a string (\"none\", \"boundary\" or a face such as \"x-\") or an array of them, got " +
                      describe_type(*node));
    }
  }

  // Direction steps in world coordinates: i along x, j along y (a net in the
  // xz plane: along z), k along z.
  const std::array<Vec3, 3> step{Vec3(spacing.x(), 0, 0), xz ? Vec3(0, 0, spacing.z()) : Vec3(0, spacing.y(), 0),
                                 Vec3(0, 0, spacing.z())};

  const Vec3 far = origin + static_cast<double>(n[0] - 1) * step[0] + static_cast<double>(n[1] - 1) * step[1] +
                  static_cast<double>(n[2] - 1) * step[2];
  if (!far.allFinite() || !std::isfinite((far - origin).stableNorm()))
    s.fail("spacing", "the lattice is too large to place: its far corner is not finite");

  // Springs to the neighbours along each direction and, with diagonals, to
  // both diagonal neighbours in each lattice plane; each pair once.
  std::vector<std::array<long long, 3>> offsets{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  if (diagonals) {
    offsets.insert(offsets.end(), {{1, 1, 0}, {1, -1, 0}});
    if (!net) offsets.insert(offsets.end(), {{1, 0, 1}, {1, 0, -1}, {0, 1, 1}, {0, 1, -1}});
  }
  std::vector<double> rest;
  double springs = 0;
  for (const auto& o : offsets) {
    rest.push_back((1 - prestrain) * (static_cast<double>(o[0]) * step[0] + static_cast<double>(o[1]) * step[1] +
                                      static_cast<double>(o[2]) * step[2]).stableNorm());
    if (!std::isfinite(rest.back()))
      s.fail("spacing", "a spring between neighbouring particles would be longer than the largest number (its rest "
                        "length overflows); give a smaller spacing");
    double count = 1;
    for (std::size_t d = 0; d < 3; ++d) count *= static_cast<double>(std::max(0LL, n[d] - std::abs(o[d])));
    springs += count;
  }
  // Particles, the last index fastest: index = (i n2 + j) n3 + k. Read in
  // parts, a process owns a range of this index: whole layers of i and a
  // part of one, its ghosts in the next layer.
  g.count = static_cast<long long>(total);
  const long long first = window.first, end = window.end < 0 ? g.count : std::min(window.end, g.count);
  const auto flat = [&](long long i, long long j, long long k) { return static_cast<int>((i * n[1] + j) * n[2] + k); };
  // The springs of the owned particles, ends as block-local indices.
  const double share = window.whole(g.count) ? 1.0 : static_cast<double>(std::max(0LL, end - first)) / total;
  // Its particles were counted in the first pass, unless read in parts: then
  // what the part owns, here (its springs' share of the whole, estimated).
  reader.add_to_scene(*size_node, size_key, window.in_parts ? "its part of the lattice" : "the lattice",
                      window.in_parts ? share * total : 0.0, 0, share * springs);
  g.springs.reserve(static_cast<std::size_t>(share * springs));
  for (long long f = first; f < end; ++f) {
    const long long i = f / (n[1] * n[2]), j = f / n[2] % n[1], k = f % n[2];
    for (std::size_t o = 0; o < offsets.size(); ++o) {
      const long long i2 = i + offsets[o][0], j2 = j + offsets[o][1], k2 = k + offsets[o][2];
      if (i2 >= n[0] || j2 < 0 || j2 >= n[1] || k2 < 0 || k2 >= n[2]) continue;
      Spring& spring = g.springs.emplace_back();
      spring.a.body = flat(i, j, k);
      spring.b.body = flat(i2, j2, k2);
      spring.stiffness = stiffness;
      spring.rest_length = rest[o];
      spring.damping = damping;
    }
  }
  // Particles named by the scene's tables: "<name>.<i>.<j>[.<k>]".
  std::vector<long long> named;
  if (window.named != nullptr && !window.whole(g.count))
    for (const std::string& full : *window.named) {
      if (!full.starts_with(g.name + ".")) continue;
      std::string_view rest = std::string_view(full).substr(g.name.size() + 1);
      std::array<long long, 3> at{0, 0, 0};
      bool valid = true;
      for (std::size_t d = 0; d < (net ? 2u : 3u) && valid; ++d) {
        const auto [ptr, error] = std::from_chars(rest.data(), rest.data() + rest.size(), at[d]);
        valid = error == std::errc() && at[d] >= 0 && at[d] < n[d];
        rest.remove_prefix(static_cast<std::size_t>(ptr - rest.data()));
        if (valid && !rest.empty()) {
          valid = rest.front() == '.' && d + 1 < (net ? 2u : 3u);
          rest.remove_prefix(1);
        }
      }
      if (valid && rest.empty()) named.push_back(flat(at[0], at[1], at[2]));
    }
  hold_window(window, g, std::move(named));

  g.bodies.reserve(window.whole(g.count) ? static_cast<std::size_t>(total) : g.held.size());
  // One index as ".<digits>", written where the name is built (no temporary strings).
  struct Index {
    std::array<char, 24> digits{};
    std::size_t size = 0;
    explicit Index(long long value) {
      digits[0] = '.';
      size = static_cast<std::size_t>(std::to_chars(digits.data() + 1, digits.data() + digits.size(), value).ptr -
                                      digits.data());
    }
  };
  const auto particle = [&](long long f) {
    const long long i = f / (n[1] * n[2]), j = f / n[2] % n[1], k = f % n[2];
    const Index a(i), b(j), c(k);
    std::string name;
    name.reserve(g.name.size() + a.size + b.size + (net ? 0 : c.size));  // exact: short names stay inline
    name.append(g.name).append(a.digits.data(), a.size).append(b.digits.data(), b.size);
    if (!net) name.append(c.digits.data(), c.size);
    const std::array<long long, 3> at{i, j, k};
    bool fixed = false;
    for (std::size_t d = 0; d < 3; ++d)
      fixed = fixed || (at[d] == 0 && ends.low[d]) || (at[d] == n[d] - 1 && ends.high[d]);
    const Vec3 position = origin + static_cast<double>(i) * step[0] + static_cast<double>(j) * step[1] +
                          static_cast<double>(k) * step[2];
    add_particle(g.bodies, std::move(name), position, mass, {fixed, fixed, fixed});
  };
  if (window.whole(g.count))
    for (long long f = 0; f < g.count; ++f) particle(f);
  else
    for (const long long f : g.held) particle(f);
  return g;
}

void hold_window(const GeneratorWindow& window, Generated& g, std::vector<long long> named) {
  if (window.whole(g.count)) return;
  const long long first = window.first, end = std::min(window.end, g.count);
  std::vector<long long>& held = g.held;
  held = std::move(named);
  std::erase(held, -1);
  for (long long f = first; f < end; ++f) held.push_back(f);
  for (const Spring& spring : g.springs) held.push_back(spring.b.body);  // a is owned
  std::sort(held.begin(), held.end());
  held.erase(std::unique(held.begin(), held.end()), held.end());
  const auto local = [&](int f) {
    return static_cast<int>(std::lower_bound(held.begin(), held.end(), static_cast<long long>(f)) - held.begin());
  };
  for (Spring& spring : g.springs) {
    spring.a.body = local(spring.a.body);
    spring.b.body = local(spring.b.body);
  }
}

// --- [[network]] ---------------------------------------------------------------

namespace {

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

struct CsvField {
  std::string_view text;  // trimmed
  int column = 1;         // 1-based, where the text starts
};
struct CsvRow {
  int line = 0;
  std::vector<CsvField> fields;
};

// A CSV file: a header line, then rows. Blank lines and lines starting with '#'
// are skipped; fields are separated by commas and trimmed (no quoting). Read
// whole (read_csv: `text` and `rows`, whose fields are views into `text`, so
// a CsvFile stays where it was read) or a row at a time (CsvStream: only the
// current line is held).
struct CsvFile {
  std::string path;         // as resolved
  std::string resolved;     // how messages name it: "'<path>'" and how it was written
  std::string what;         // "nodes", "edges": how messages name it
  std::string text;         // read whole: the file
  std::string header_text;  // the header line; `header`'s fields are views into it
  bool empty = true;        // the file has no bytes
  CsvRow header;
  std::vector<CsvRow> rows;  // read whole

  CsvFile() = default;
  CsvFile(const CsvFile&) = delete;
  CsvFile& operator=(const CsvFile&) = delete;

  [[noreturn]] void fail(int line, int column, const std::string& key, const std::string& reason) const {
    throw SceneError(SourceLocation{path, line, column}, key, reason);
  }
};

// The longest line a CSV file may have: a node or an edge takes a few dozen
// bytes, and a file read a row at a time holds one line (and a chunk) only.
constexpr std::size_t max_csv_line = std::size_t{1} << 20;  // 1 MiB

void split_row(std::string_view line, int number, CsvRow& row) {
  row.line = number;
  row.fields.clear();
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = std::min(line.find(',', start), line.size());
    const std::string_view raw = line.substr(start, comma - start);
    const auto first = raw.find_first_not_of(" \t");
    row.fields.push_back({trim(raw), static_cast<int>(start + (first == std::string_view::npos ? 0 : first)) + 1});
    if (comma == line.size()) break;
    start = comma + 1;
  }
}

[[noreturn]] void cannot_read(const Section& s, std::string_view key, const CsvFile& file) {
  s.fail(key, "cannot read the " + file.what + " file " + file.resolved + ": " + std::strerror(errno));
}

// Opens the CSV file named by the key `key` of `s` (relative to the scene
// file's directory) for `file` (its path, what and resolved), after the
// checks: inside the scene file's directory (unless allowed), not a
// directory, not a device.
std::ifstream open_csv(const Reader& reader, const Section& s, std::string_view key, CsvFile& file) {
  const std::string written = s.required_string(key);
  if (written.empty()) s.fail(key, "must name a CSV file");
  std::filesystem::path path(written);
  const bool relative = path.is_relative();
  if (relative) path = std::filesystem::path(reader.file()).parent_path() / path;
  file.path = path.lexically_normal().string();
  file.what = std::string(key);
  file.resolved = "'" + file.path + "'" +
                  (relative && file.path != written ? " (\"" + written + "\" relative to the scene file's directory)" : "");
  std::error_code ec;
  if (!reader.limits().allow_outside_data) {
    namespace fs = std::filesystem;
    const fs::path scene_directory = fs::path(reader.file()).parent_path();
    const fs::path base = fs::weakly_canonical(fs::absolute(scene_directory.empty() ? fs::path(".") : scene_directory, ec), ec);
    const fs::path target = fs::weakly_canonical(fs::absolute(path, ec), ec);
    const bool inside = !ec && std::mismatch(base.begin(), base.end(), target.begin(), target.end()).first == base.end();
    if (!inside)
      s.fail(key, "the " + file.what + " file " + file.resolved + " lies outside the scene file's directory '" +
                      base.string() + "' (symbolic links followed); data files are read only from there and below, "
                      "unless the command is given --allow-outside-data");
  }
  const std::filesystem::file_type type = std::filesystem::status(file.path, ec).type();
  if (type == std::filesystem::file_type::directory)
    s.fail(key, "cannot read the " + file.what + " file " + file.resolved + ": it is a directory");
  // A device (/dev/zero, a terminal) never ends or blocks: only files and pipes are read.
  if (type == std::filesystem::file_type::character || type == std::filesystem::file_type::block ||
      type == std::filesystem::file_type::socket)
    s.fail(key, "cannot read the " + file.what + " file " + file.resolved + ": it is a device, not a file");
  std::ifstream in(file.path, std::ios::binary);
  if (!in) s.fail(key, "cannot open the " + file.what + " file " + file.resolved + ": " + std::strerror(errno));
  reader.note_data_file(file.path);
  return in;
}

// The lines of a CSV file that are neither blank nor comments, in order, with
// their 1-based numbers (a UTF-8 byte order mark and the CR of CRLF ends
// taken off), from the whole text in memory or from a stream read a chunk at
// a time (then only the current line and a chunk are held). A line longer
// than max_csv_line is refused.
class CsvLines {
 public:
  CsvLines(CsvFile& file, std::string_view text) : file_(file), rest_(text) {
    file_.empty = text.empty();
    start();
  }
  CsvLines(CsvFile& file, std::istream& in, const Section& s, std::string_view key)
      : file_(file), in_(&in), section_(&s), key_(key) {
    more();
    start();
  }
  // The next line (valid until the next call) and its number; false at the end.
  bool next(std::string_view& line, int& number) {
    while (true) {
      std::size_t end = rest_.find('\n');
      while (end == std::string_view::npos && rest_.size() <= max_csv_line && more()) end = rest_.find('\n');
      if (rest_.empty()) return false;
      ++number_;
      if (end == std::string_view::npos) end = rest_.size();
      if (end > max_csv_line)
        file_.fail(number_, 1, "", "the line is longer than " + std::to_string(max_csv_line) + " bytes (1 MiB), the most a line of a " +
                                       file_.what + " file may have");
      std::string_view found = rest_.substr(0, end);
      rest_.remove_prefix(std::min(end + 1, rest_.size()));
      if (found.ends_with('\r')) found.remove_suffix(1);
      const std::string_view content = trim(found);
      if (content.empty() || content.front() == '#') continue;
      line = found;
      number = number_;
      return true;
    }
  }

 private:
  void start() {
    if (rest_.starts_with("\xEF\xBB\xBF")) rest_.remove_prefix(3);  // a UTF-8 byte order mark
  }
  // Reads the next chunk after what is left of the buffer; false at the end.
  bool more() {
    if (in_ == nullptr || !*in_) return false;
    constexpr std::size_t chunk = std::size_t{1} << 16;
    buffer_.erase(0, buffer_.size() - rest_.size());  // rest_ is the buffer's tail
    const std::size_t kept = buffer_.size();
    buffer_.resize(kept + chunk);
    in_->read(buffer_.data() + kept, static_cast<std::streamsize>(chunk));
    if (in_->bad()) cannot_read(*section_, key_, file_);
    const auto got = static_cast<std::size_t>(in_->gcount());
    buffer_.resize(kept + got);
    rest_ = buffer_;
    if (got > 0) file_.empty = false;
    return got > 0;
  }

  CsvFile& file_;
  std::istream* in_ = nullptr;
  const Section* section_ = nullptr;
  std::string_view key_;
  std::string buffer_;    // streamed: the current line and what follows it
  std::string_view rest_;  // what is not yet split into lines
  int number_ = 0;
};

// The header of `file`: its first line that is neither blank nor a comment
// (none: header.line stays 0).
void read_header(CsvFile& file, CsvLines& lines) {
  std::string_view line;
  int number = 0;
  if (!lines.next(line, number)) return;
  file.header_text = line;
  split_row(file.header_text, number, file.header);
}

// Reads the CSV file named by the key `key` of `s` (relative to the scene
// file's directory) whole into `file`.
void read_csv(const Reader& reader, const Section& s, std::string_view key, CsvFile& file) {
  std::ifstream in = open_csv(reader, s, key, file);
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) cannot_read(s, key, file);
  file.text = std::move(text).str();
  CsvLines lines(file, file.text);
  read_header(file, lines);
  std::string_view line;
  int number = 0;
  while (lines.next(line, number)) split_row(line, number, file.rows.emplace_back());
}

// The CSV file named by the key `key` of `s`, read a row at a time: its
// header when opened, then next().
class CsvStream {
 public:
  CsvStream(const Reader& reader, const Section& s, std::string_view key, CsvFile& file)
      : in_(open_csv(reader, s, key, file)), lines_(file, in_, s, key) {
    read_header(file, lines_);
  }
  // The next row (its fields valid until the next call); false at the end.
  bool next(CsvRow& row) {
    std::string_view line;
    int number = 0;
    if (!lines_.next(line, number)) return false;
    split_row(line, number, row);
    return true;
  }

 private:
  std::ifstream in_;
  CsvLines lines_;
};
// The columns of a CSV file: required ones, then optional ones.
struct Schema {
  std::vector<std::string_view> names;
  std::size_t required = 0;
  std::string written() const {  // "name,x,y,z[,mass][,fixed]"
    std::string s;
    for (std::size_t c = 0; c < names.size(); ++c)
      s += c < required ? (c > 0 ? "," : "") + std::string(names[c]) : "[," + std::string(names[c]) + "]";
    return s;
  }
};

// For each schema column, its index in the file's rows (−1: absent).
std::vector<int> match_header(const CsvFile& file, const Schema& schema) {
  const std::string expected = (file.what == "edges" ? "; an " : "; a ") + file.what + " file starts with the header " +
                               schema.written();
  if (file.header.line == 0)
    file.fail(1, 1, "", "the " + file.what + " file has no header line (it is empty" +
                            (file.empty ? "" : " or only comments") + ")" + expected);
  std::vector<int> index(schema.names.size(), -1);
  const auto& fields = file.header.fields;
  // A first line none of whose columns is one of the schema's is no header of
  // this kind of file: the file is then not named in words of its own content
  // (it may be any file, such as one of the system's), only by its place.
  const bool any_known = std::any_of(fields.begin(), fields.end(), [&](const CsvField& f) {
    return std::find(schema.names.begin(), schema.names.end(), f.text) != schema.names.end();
  });
  if (!any_known)
    file.fail(file.header.line, 1, "",
              "the first line is not the header of a " + file.what + " file (none of its " +
                  std::to_string(fields.size()) + (fields.size() == 1 ? " column" : " columns") +
                  " is a known column; its content is not shown)" + expected);
  for (std::size_t f = 0; f < fields.size(); ++f) {
    const CsvField& field = fields[f];
    if (field.text.empty())
      file.fail(file.header.line, field.column, "",
                "empty column name in the header, column " + std::to_string(f + 1) + expected);
    const auto it = std::find(schema.names.begin(), schema.names.end(), field.text);
    if (it == schema.names.end())
      file.fail(file.header.line, field.column, std::string(field.text),
                "unknown column '" + std::string(field.text) + "' in the " + file.what + " file" +
                    did_you_mean(field.text, std::vector<std::string>(schema.names.begin(), schema.names.end())) +
                    expected);
    const auto c = static_cast<std::size_t>(it - schema.names.begin());
    if (index[c] >= 0)
      file.fail(file.header.line, field.column, std::string(field.text),
                "the column '" + std::string(field.text) + "' appears twice in the header");
    index[c] = static_cast<int>(f);
  }
  for (std::size_t c = 0; c < schema.required; ++c)
    if (index[c] < 0)
      file.fail(file.header.line, 1, std::string(schema.names[c]),
                "missing column '" + std::string(schema.names[c]) + "' in the header" + expected);
  return index;
}

// "1.5", "-2e3", "+4": a whole field as a finite number.
std::optional<double> parse_number(std::string_view text) {
  if (text.starts_with('+') && text.size() > 1 && text[1] != '-' && text[1] != '+') text.remove_prefix(1);
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

// Reads the fields of one row by schema column.
class RowReader {
 public:
  RowReader(const CsvFile& file, const Schema& schema, const std::vector<int>& index, const CsvRow& row)
      : file_(file), schema_(schema), index_(index), row_(row) {
    if (row.fields.size() != file.header.fields.size()) {
      std::string header;
      for (const CsvField& f : file.header.fields) header += (header.empty() ? "" : ",") + std::string(f.text);
      file.fail(row.line, 1, "", "expected " + std::to_string(file.header.fields.size()) + " fields (" + header + "), got " +
                                     std::to_string(row.fields.size()));
    }
  }
  int line() const { return row_.line; }
  // The field of column c, empty when the file has no such column.
  std::string_view text(std::size_t c) const { return index_[c] < 0 ? std::string_view() : field(c).text; }
  bool has(std::size_t c) const { return !text(c).empty(); }
  std::string_view required_text(std::size_t c) const {
    if (!has(c)) fail(c, "missing value");
    return text(c);
  }
  double number(std::size_t c, Range range) const {
    const std::string_view t = required_text(c);
    const std::optional<double> value = parse_number(t);
    if (!value) fail(c, "expected a finite number, got '" + std::string(t) + "'");
    if (range == Range::nonnegative && *value < 0) fail(c, "must be non-negative, got " + format_number(*value));
    if (range == Range::positive && !(*value > 0)) fail(c, "must be positive, got " + format_number(*value));
    return *value;
  }
  // Where column c's field starts (the row's start when the column is absent).
  int column(std::size_t c) const { return index_[c] < 0 ? 1 : field(c).column; }
  // At the field of column c.
  [[noreturn]] void fail(std::size_t c, const std::string& reason) const {
    file_.fail(row_.line, column(c), std::string(schema_.names[c]), reason);
  }

 private:
  const CsvField& field(std::size_t c) const { return row_.fields[static_cast<std::size_t>(index_[c])]; }
  const CsvFile& file_;
  const Schema& schema_;
  const std::vector<int>& index_;
  const CsvRow& row_;
};

// The `fixed` field of a node: empty, 0 or false (free), 1 or true (fixed),
// or the fixed axes as letters ("z", "xy", "xyz").
std::optional<std::array<bool, 3>> parse_fixed(std::string_view text) {
  if (text.empty() || text == "0" || text == "false") return std::array<bool, 3>{false, false, false};
  if (text == "1" || text == "true") return std::array<bool, 3>{true, true, true};
  std::array<bool, 3> fixed{false, false, false};
  for (const char c : text) {
    if (c < 'x' || c > 'z' || fixed[static_cast<std::size_t>(c - 'x')]) return std::nullopt;
    fixed[static_cast<std::size_t>(c - 'x')] = true;
  }
  return fixed;
}

// The columns of the two files.
enum NodeColumn : std::size_t { name_column, x_column, y_column, z_column, mass_column, fixed_column };
enum EdgeColumn : std::size_t { a_column, b_column, stiffness_column, rest_column, damping_column };
const Schema& node_schema() {  // name,x,y,z[,mass][,fixed]
  static const Schema schema{{"name", "x", "y", "z", "mass", "fixed"}, 4};
  return schema;
}
const Schema& edge_schema() {  // a,b[,stiffness][,rest_length][,damping]
  static const Schema schema{{"a", "b", "stiffness", "rest_length", "damping"}, 2};
  return schema;
}

// What a [[network]] table gives for rows that leave values out (has_…:
// whether it gives one).
struct NetworkDefaults {
  bool has_mass = false, has_stiffness = false;
  double mass = 0, stiffness = 1, damping = 0, prestrain = 0;
};
NetworkDefaults read_defaults(const Section& s) {
  NetworkDefaults d;
  d.has_mass = s.has("mass");
  d.has_stiffness = s.has("stiffness");
  d.mass = s.number("mass", 0.0, Range::nonnegative);
  d.stiffness = s.number("stiffness", 1.0, Range::positive);
  d.damping = s.number("damping", 0.0, Range::nonnegative);
  d.prestrain = read_prestrain(s);
  return d;
}

// The nodes file's header checked (`has_rows`: whether any row follows it),
// and a default mass when it has no mass column: each column's index.
std::vector<int> check_nodes_header(const Section& s, const CsvFile& nodes, bool has_rows, const NetworkDefaults& d) {
  std::vector<int> index = match_header(nodes, node_schema());
  if (!has_rows) nodes.fail(nodes.header.line, 1, "", "the nodes file has a header but no nodes");
  if (index[mass_column] < 0 && !d.has_mass)
    s.fail("mass", "the nodes file '" + nodes.path + "' has no mass column, so [[network]] needs a default 'mass'");
  return index;
}
// The same for the edges file: a default stiffness when it has edges and no stiffness column.
std::vector<int> check_edges_header(const Section& s, const CsvFile& edges, bool has_rows, const NetworkDefaults& d) {
  std::vector<int> index = match_header(edges, edge_schema());
  if (index[stiffness_column] < 0 && !d.has_stiffness && has_rows)
    s.fail("stiffness",
           "the edges file '" + edges.path + "' has no stiffness column, so [[network]] needs a default 'stiffness'");
  return index;
}

// A node row's name, present and printable.
std::string_view node_name(const RowReader& r) {
  const std::string_view name = r.required_text(name_column);
  if (!is_printable(name))
    r.fail(name_column, "the node name \"" + printable(name) + "\" contains control characters or bytes that are "
                        "not UTF-8 (shown escaped); node names must be printable text");
  return name;
}
std::string duplicate_node(std::string_view name, int line) {
  return "duplicate node name '" + std::string(name) + "': already used on line " + std::to_string(line);
}

// A node row's values (read after its name).
struct NodeValues {
  Vec3 position = Vec3::Zero();
  double mass = 0;
  std::array<bool, 3> fixed{};
};
NodeValues node_values(const RowReader& r, std::string_view name, const NetworkDefaults& d) {
  NodeValues node;
  node.position = Vec3(r.number(x_column, Range::any), r.number(y_column, Range::any), r.number(z_column, Range::any));
  if (r.has(mass_column)) {
    node.mass = r.number(mass_column, Range::nonnegative);
  } else if (d.has_mass) {
    node.mass = d.mass;
  } else {
    r.fail(mass_column, "no mass for node '" + std::string(name) +
                            "': fill in the mass column or give [[network]] a default 'mass'");
  }
  const std::optional<std::array<bool, 3>> fixed = parse_fixed(r.text(fixed_column));
  if (!fixed)
    r.fail(fixed_column, "expected 0, 1, true, false or the fixed axes as letters (\"z\", \"xy\", \"xyz\"), got '" +
                             std::string(r.text(fixed_column)) + "'");
  node.fixed = *fixed;
  return node;
}

std::string unknown_node(std::string_view name, const std::vector<std::string>& candidates, const std::string& nodes) {
  return "unknown node '" + std::string(name) + "'" + did_you_mean(name, candidates) +
         "; an edge joins two nodes of the nodes file '" + nodes + "'" +
         (name == "world" ? " (to tie a node to the world, fix it: fixed = 1)" : "");
}
std::string same_ends(std::string_view a) {
  return "an edge must join two different nodes; both ends are '" + std::string(a) + "'";
}

// An edge row's values that its ends do not decide: stiffness, damping and
// the rest length when given (else −1).
Spring edge_values(const RowReader& r, const NetworkDefaults& d) {
  Spring spring;
  if (r.has(stiffness_column)) {
    spring.stiffness = r.number(stiffness_column, Range::positive);
  } else if (d.has_stiffness) {
    spring.stiffness = d.stiffness;
  } else {
    r.fail(stiffness_column, "no stiffness for the edge '" + std::string(r.text(a_column)) + "'-'" +
                                 std::string(r.text(b_column)) +
                                 "': fill in the stiffness column or give [[network]] a default 'stiffness'");
  }
  spring.damping = r.has(damping_column) ? r.number(damping_column, Range::nonnegative) : d.damping;
  spring.rest_length = r.has(rest_column) ? r.number(rest_column, Range::nonnegative) : -1;
  return spring;
}

// The rest length of an edge that gives none: its nodes' distance less the
// prestrain; `fail(reason)` reports the edge at its rest_length column.
template <class Fail>
double default_rest_length(const Vec3& xa, const Vec3& xb, std::string_view a, std::string_view b,
                           const NetworkDefaults& d, Fail&& fail) {
  const double length = (xa - xb).norm();
  if (!std::isfinite(length))
    fail("the distance between the nodes '" + std::string(a) + "' and '" + std::string(b) +
         "' is not finite; give a rest_length");
  if (!(length > 1e-12 * std::max(xa.norm(), xb.norm())))
    fail("the nodes '" + std::string(a) + "' and '" + std::string(b) +
         "' are at the same place, so the edge's rest length would be 0; give a rest_length");
  return (1 - d.prestrain) * length;
}

// The particle of node `node` ("<name>.<node>"), read on line `line`.
void add_node(Generated& g, std::string_view node, const NodeValues& v, int line) {
  std::string full;
  full.reserve(g.name.size() + 1 + node.size());
  full.append(g.name).append(".").append(node);
  add_particle(g.bodies, std::move(full), v.position, v.mass, v.fixed);
  g.lines.push_back(line);
}

// The nodes file's rows, counted a row at a time (its header checked).
long long count_nodes(const Reader& reader, const Section& s, const NetworkDefaults& d) {
  CsvFile nodes;
  CsvStream in(reader, s, "nodes", nodes);
  CsvRow row;
  const bool any = in.next(row);
  check_nodes_header(s, nodes, any, d);
  long long count = any ? 1 : 0;
  while (in.next(row)) ++count;
  return count;
}

// A [[network]] read in parts (window.end ≥ 0: docs/design.md "Distributed
// backend"), its files streamed, never held whole: (a) the nodes, every row
// checked, the owned rows [first, end) kept with a map of their names;
// (b) the edges, every row's values checked, those whose first node is owned
// kept, their second nodes' names when not owned remembered; (c) the nodes
// again for those names and for the nodes the scene's tables name; then the
// default rest lengths. An edge naming a node no part owns is not kept by
// any (Scene::owned_network_edges; the backend checks the parts together).
// A row error in (b) waits until the kept edges before it have been checked
// for an unknown second node, as the serial reading meets them first.
void read_network_in_parts(const Reader& reader, const Section& s, const NetworkDefaults& d,
                           const GeneratorWindow& window, Generated& g) {
  struct Held {
    std::string name;
    NodeValues values;
    int line = 0;
  };
  const long long first = window.first, end = std::max(window.end, first);
  std::vector<Held> owned;                                      // rows [first, end)
  std::unordered_map<std::string_view, long long> owned_index;  // name → row (views into `owned`: never moved)

  // (a) the nodes.
  CsvFile nodes;
  {
    CsvStream in(reader, s, "nodes", nodes);
    CsvRow row;
    bool any = in.next(row);
    const std::vector<int> index = check_nodes_header(s, nodes, any, d);
    reader.add_to_scene(*s.find("nodes"), s.key("nodes"), "its part of the network's nodes",
                        static_cast<double>(end - first), 0, 0);
    owned.reserve(static_cast<std::size_t>(end - first));
    owned_index.reserve(static_cast<std::size_t>(end - first));
    long long k = 0;
    for (; any; ++k, any = in.next(row)) {
      const RowReader r(nodes, node_schema(), index, row);
      const std::string_view name = node_name(r);
      if (k < first || k >= end) {
        (void)node_values(r, name, d);
        continue;
      }
      if (const auto it = owned_index.find(name); it != owned_index.end())
        r.fail(name_column, duplicate_node(name, owned[static_cast<std::size_t>(it->second - first)].line));
      Held& node = owned.emplace_back();
      node.name = name;
      node.line = row.line;
      node.values = node_values(r, name, d);
      owned_index.emplace(node.name, k);
    }
    g.count = k;
  }
  g.csv = nodes.path;

  // (b) the edges. The other nodes (not owned) that this part needs: by name,
  // with their row once found (−1: not yet); an owned edge's second end
  // −2 − slot until then.
  struct Other {
    Held node;  // its name from the start, the rest once found
    long long row = -1;
    bool named = false;  // by a table of the scene
  };
  std::deque<Other> others;                                // never moved: `slots` views their names
  std::unordered_map<std::string_view, std::size_t> slots;  // name → index in `others`
  const auto slot = [&](std::string_view name) {
    const auto it = slots.find(name);
    if (it != slots.end()) return it->second;
    others.emplace_back().node.name = name;
    slots.emplace(others.back().node.name, others.size() - 1);
    return others.size() - 1;
  };
  struct Where {  // a kept edge's line and the columns its late errors point at
    int line = 0, b_column = 1, rest_column = 1;
  };
  std::vector<Where> where;
  CsvFile edges;
  std::exception_ptr deferred;  // the first row error, thrown after the kept edges before it are checked
  int deferred_line = std::numeric_limits<int>::max();
  {
    CsvStream in(reader, s, "edges", edges);
    CsvRow row;
    bool any = in.next(row);
    const std::vector<int> index = check_edges_header(s, edges, any, d);
    std::size_t counted = 0;  // springs added to the scene's totals
    long long rows = 0;
    for (; any; any = in.next(row)) {
      ++rows;
      try {
        const RowReader r(edges, edge_schema(), index, row);
        const std::string_view a = r.required_text(a_column), b = r.required_text(b_column);
        const auto mine = owned_index.find(a);
        if (mine == owned_index.end()) {  // another part's, or no part's
          (void)edge_values(r, d);
          continue;
        }
        if (a == b) r.fail(b_column, same_ends(a));
        if (g.springs.size() == counted) {  // counted before allocated, in growing batches
          const std::size_t batch = std::max<std::size_t>(counted, 1024);
          reader.add_to_scene(*s.find("edges"), s.key("edges"), "its part of the network's edges", 0, 0,
                              static_cast<double>(batch));
          counted += batch;
          g.springs.reserve(counted);
          where.reserve(counted);
        }
        where.push_back({row.line, r.column(b_column), r.column(rest_column)});
        Spring& spring = g.springs.emplace_back();
        const auto other = owned_index.find(b);
        spring.a.body = static_cast<int>(mine->second);
        spring.b.body = other != owned_index.end() ? static_cast<int>(other->second) : -2 - static_cast<int>(slot(b));
        const Spring values = edge_values(r, d);
        spring.stiffness = values.stiffness;
        spring.damping = values.damping;
        spring.rest_length = values.rest_length;
      } catch (const SceneError&) {
        deferred = std::current_exception();
        deferred_line = row.line;
        break;
      }
    }
    g.edge_rows = rows;
  }

  // (c) the other nodes: the second ends wanted, and those the tables name.
  std::vector<long long> named;
  if (window.named != nullptr)
    for (const std::string& full : *window.named)
      if (full.starts_with(g.name + ".")) {
        const std::string_view name = std::string_view(full).substr(g.name.size() + 1);
        if (const auto it = owned_index.find(name); it != owned_index.end())
          named.push_back(it->second);
        else
          others[slot(name)].named = true;
      }
  if (!others.empty()) {
    reader.add_to_scene(*s.find("nodes"), s.key("nodes"), "its part of the network's nodes",
                        static_cast<double>(others.size()), 0, 0);
    CsvFile again;
    CsvStream in(reader, s, "nodes", again);
    const std::vector<int> index = match_header(again, node_schema());
    CsvRow row;
    for (long long k = 0; in.next(row); ++k) {
      if (k >= first && k < end) continue;
      const RowReader r(again, node_schema(), index, row);
      const auto it = slots.find(r.text(name_column));
      if (it == slots.end() || others[it->second].row >= 0) continue;
      Other& o = others[it->second];
      o.row = k;
      o.node.line = row.line;
      o.node.values = node_values(r, o.node.name, d);
      if (o.named) named.push_back(k);
    }
  }

  // The kept edges in file order, up to a row error: unknown second nodes,
  // default rest lengths.
  for (std::size_t e = 0; e < g.springs.size() && where[e].line <= deferred_line; ++e) {
    Spring& spring = g.springs[e];
    const Held& a = owned[static_cast<std::size_t>(spring.a.body - first)];
    const Held* b = nullptr;
    if (spring.b.body < -1) {
      const Other& o = others[static_cast<std::size_t>(-2 - spring.b.body)];
      if (o.row < 0) {
        std::vector<std::string> candidates;  // the names this part has read
        for (const Held& h : owned) candidates.push_back(h.name);
        for (const Other& h : others)
          if (h.row >= 0) candidates.push_back(h.node.name);
        edges.fail(where[e].line, where[e].b_column, "b", unknown_node(o.node.name, candidates, nodes.path));
      }
      spring.b.body = static_cast<int>(o.row);
      b = &o.node;
    } else {
      b = &owned[static_cast<std::size_t>(spring.b.body - first)];
    }
    if (where[e].line == deferred_line || spring.rest_length >= 0) continue;
    spring.rest_length = default_rest_length(a.values.position, b->values.position, a.name, b->name, d,
                                             [&](const std::string& reason) {
                                               edges.fail(where[e].line, where[e].rest_column, "rest_length", reason);
                                             });
  }
  if (deferred) std::rethrow_exception(deferred);

  // The held particles: all rows (the whole block), or the window's.
  hold_window(window, g, std::move(named));
  std::unordered_map<long long, const Other*> by_row;
  for (const Other& o : others)
    if (o.row >= 0) by_row.emplace(o.row, &o);
  const auto particle = [&](long long l) {
    const Held& h = l >= first && l < end ? owned[static_cast<std::size_t>(l - first)] : by_row.at(l)->node;
    add_node(g, h.name, h.values, h.line);
  };
  const std::size_t held = window.whole(g.count) ? owned.size() : g.held.size();
  g.bodies.reserve(held);
  g.lines.reserve(held);
  if (window.whole(g.count))
    for (long long l = 0; l < g.count; ++l) particle(l);
  else
    for (const long long l : g.held) particle(l);
}

}  // namespace

Generated read_network(const Reader& reader, const toml::table& table, std::size_t index, LatticePass pass,
                       const GeneratorWindow& window) {
  const Section s(reader, table, index_key("network", index), "[[network]]");
  s.check_keys({"name", "nodes", "edges", "mass", "stiffness", "damping", "prestrain"});
  Generated g;
  start_block(s, g, "network");
  const NetworkDefaults defaults = read_defaults(s);
  if (pass == LatticePass::count) {  // (only the scene read in parts counts first)
    g.count = count_nodes(reader, s, defaults);
    return g;
  }
  if (window.end >= 0) {
    read_network_in_parts(reader, s, defaults, window, g);
    return g;
  }

  // The whole network: both files read whole, every node and edge made.
  CsvFile nodes;
  read_csv(reader, s, "nodes", nodes);
  const std::vector<int> node_index = check_nodes_header(s, nodes, !nodes.rows.empty(), defaults);
  g.count = static_cast<long long>(nodes.rows.size());
  reader.add_to_scene(*s.find("nodes"), s.key("nodes"), "the network's nodes",
                      static_cast<double>(nodes.rows.size()), 0, 0);
  struct Node {
    std::string_view name;
    NodeValues values;
  };
  std::vector<Node> read;
  std::unordered_map<std::string_view, int> by_name;  // node name → its row index
  by_name.reserve(nodes.rows.size());
  read.reserve(nodes.rows.size());
  g.csv = nodes.path;
  for (const CsvRow& row : nodes.rows) {
    const RowReader r(nodes, node_schema(), node_index, row);
    const std::string_view name = node_name(r);
    const auto [it, inserted] = by_name.emplace(name, static_cast<int>(read.size()));
    if (!inserted)
      r.fail(name_column, duplicate_node(name, nodes.rows[static_cast<std::size_t>(it->second)].line));
    read.push_back({name, node_values(r, name, defaults)});
  }

  CsvFile edges;
  read_csv(reader, s, "edges", edges);
  const std::vector<int> edge_index = check_edges_header(s, edges, !edges.rows.empty(), defaults);
  reader.add_to_scene(*s.find("edges"), s.key("edges"), "the network's edges", 0, 0,
                      static_cast<double>(edges.rows.size()));
  g.springs.reserve(edges.rows.size());
  const auto node = [&](const RowReader& r, std::size_t c) {
    const std::string_view name = r.required_text(c);
    const auto it = by_name.find(name);
    if (it != by_name.end()) return it->second;
    std::vector<std::string> candidates;
    candidates.reserve(read.size());
    for (const Node& n : read) candidates.emplace_back(n.name);
    r.fail(c, unknown_node(name, candidates, nodes.path));
  };
  for (const CsvRow& row : edges.rows) {
    const RowReader r(edges, edge_schema(), edge_index, row);
    const int a = node(r, a_column), b = node(r, b_column);
    if (a == b) r.fail(b_column, same_ends(r.text(a_column)));
    Spring& spring = g.springs.emplace_back(edge_values(r, defaults));
    spring.a.body = a;
    spring.b.body = b;
    if (spring.rest_length < 0)
      spring.rest_length = default_rest_length(
          read[static_cast<std::size_t>(a)].values.position, read[static_cast<std::size_t>(b)].values.position,
          r.text(a_column), r.text(b_column), defaults, [&](const std::string& reason) { r.fail(rest_column, reason); });
  }

  g.bodies.reserve(read.size());
  g.lines.reserve(read.size());
  for (std::size_t l = 0; l < read.size(); ++l) add_node(g, read[l].name, read[l].values, nodes.rows[l].line);
  return g;
}

}  // namespace modal::scene_detail
