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
#include <filesystem>
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
// are skipped; fields are separated by commas and trimmed (no quoting).
// Fields are views into `text`, so a CsvFile stays where it was read.
struct CsvFile {
  std::string path;  // as resolved
  std::string text;
  std::string what;  // "nodes", "edges": how messages name it
  CsvRow header;
  std::vector<CsvRow> rows;

  CsvFile() = default;
  CsvFile(const CsvFile&) = delete;
  CsvFile& operator=(const CsvFile&) = delete;

  [[noreturn]] void fail(int line, int column, const std::string& key, const std::string& reason) const {
    throw SceneError(SourceLocation{path, line, column}, key, reason);
  }
};

CsvRow split_row(std::string_view line, int number) {
  CsvRow row;
  row.line = number;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = std::min(line.find(',', start), line.size());
    const std::string_view raw = line.substr(start, comma - start);
    const auto first = raw.find_first_not_of(" \t");
    row.fields.push_back({trim(raw), static_cast<int>(start + (first == std::string_view::npos ? 0 : first)) + 1});
    if (comma == line.size()) break;
    start = comma + 1;
  }
  return row;
}

// Reads the CSV file named by the key `key` of `s` (relative to the scene
// file's directory) into `file`.
void read_csv(const Reader& reader, const Section& s, std::string_view key, CsvFile& file) {
  const std::string written = s.required_string(key);
  if (written.empty()) s.fail(key, "must name a CSV file");
  std::filesystem::path path(written);
  const bool relative = path.is_relative();
  if (relative) path = std::filesystem::path(reader.file()).parent_path() / path;
  file.path = path.lexically_normal().string();
  file.what = std::string(key);
  const std::string resolved =
      "'" + file.path + "'" +
      (relative && file.path != written ? " (\"" + written + "\" relative to the scene file's directory)" : "");
  std::error_code ec;
  if (!reader.limits().allow_outside_data) {
    namespace fs = std::filesystem;
    const fs::path scene_directory = fs::path(reader.file()).parent_path();
    const fs::path base = fs::weakly_canonical(fs::absolute(scene_directory.empty() ? fs::path(".") : scene_directory, ec), ec);
    const fs::path target = fs::weakly_canonical(fs::absolute(path, ec), ec);
    const bool inside = !ec && std::mismatch(base.begin(), base.end(), target.begin(), target.end()).first == base.end();
    if (!inside)
      s.fail(key, "the " + file.what + " file " + resolved + " lies outside the scene file's directory '" +
                      base.string() + "' (symbolic links followed); data files are read only from there and below, "
                      "unless the command is given --allow-outside-data");
  }
  const std::filesystem::file_type type = std::filesystem::status(file.path, ec).type();
  if (type == std::filesystem::file_type::directory)
    s.fail(key, "cannot read the " + file.what + " file " + resolved + ": it is a directory");
  // A device (/dev/zero, a terminal) never ends or blocks: only files and pipes are read.
  if (type == std::filesystem::file_type::character || type == std::filesystem::file_type::block ||
      type == std::filesystem::file_type::socket)
    s.fail(key, "cannot read the " + file.what + " file " + resolved + ": it is a device, not a file");
  std::ifstream in(file.path, std::ios::binary);
  if (!in) s.fail(key, "cannot open the " + file.what + " file " + resolved + ": " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) s.fail(key, "cannot read the " + file.what + " file " + resolved + ": " + std::strerror(errno));
  file.text = std::move(text).str();

  std::string_view rest = file.text;
  if (rest.starts_with("\xEF\xBB\xBF")) rest.remove_prefix(3);  // a UTF-8 byte order mark
  bool header = false;
  for (int number = 1; !rest.empty(); ++number) {
    const std::size_t end = std::min(rest.find('\n'), rest.size());
    std::string_view line = rest.substr(0, end);
    rest.remove_prefix(std::min(end + 1, rest.size()));
    if (line.ends_with('\r')) line.remove_suffix(1);
    const std::string_view content = trim(line);
    if (content.empty() || content.front() == '#') continue;
    if (!header) {
      file.header = split_row(line, number);
      header = true;
    } else {
      file.rows.push_back(split_row(line, number));
    }
  }
}

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
                            (file.text.empty() ? "" : " or only comments") + ")" + expected);
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
  // At the field of column c (the row's start when the column is absent).
  [[noreturn]] void fail(std::size_t c, const std::string& reason) const {
    file_.fail(row_.line, index_[c] < 0 ? 1 : field(c).column, std::string(schema_.names[c]), reason);
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

}  // namespace

Generated read_network(const Reader& reader, const toml::table& table, std::size_t index, LatticePass pass,
                       const GeneratorWindow& window) {
  const Section s(reader, table, index_key("network", index), "[[network]]");
  s.check_keys({"name", "nodes", "edges", "mass", "stiffness", "damping", "prestrain"});
  Generated g;
  start_block(s, g, "network");
  // Defaults for rows that leave them out (has_…: whether the scene gives one).
  const bool has_mass = s.has("mass"), has_stiffness = s.has("stiffness");
  const double mass = s.number("mass", 0.0, Range::nonnegative);
  const double stiffness = s.number("stiffness", 1.0, Range::positive);
  const double damping = s.number("damping", 0.0, Range::nonnegative);
  const double prestrain = read_prestrain(s);

  // Nodes: name,x,y,z[,mass][,fixed].
  CsvFile nodes;
  read_csv(reader, s, "nodes", nodes);
  enum NodeColumn : std::size_t { name_column, x_column, y_column, z_column, mass_column, fixed_column };
  const Schema node_schema{{"name", "x", "y", "z", "mass", "fixed"}, 4};
  const std::vector<int> node_index = match_header(nodes, node_schema);
  if (nodes.rows.empty()) nodes.fail(nodes.header.line, 1, "", "the nodes file has a header but no nodes");
  if (node_index[mass_column] < 0 && !has_mass)
    s.fail("mass", "the nodes file '" + nodes.path + "' has no mass column, so [[network]] needs a default 'mass'");
  g.count = static_cast<long long>(nodes.rows.size());
  if (pass == LatticePass::count) return g;

  reader.add_to_scene(*s.find("nodes"), s.key("nodes"), "the network's nodes",
                      static_cast<double>(nodes.rows.size()), 0, 0);
  // Every node is read and checked (by every process when the scene is read
  // in parts); the particles are made for the held ones only, at the end.
  struct Node {
    std::string_view name;
    Vec3 position;
    double mass = 0;
    std::array<bool, 3> fixed{};
  };
  std::vector<Node> read;
  std::unordered_map<std::string_view, int> by_name;  // node name → its row index
  by_name.reserve(nodes.rows.size());
  read.reserve(nodes.rows.size());
  g.csv = nodes.path;
  for (const CsvRow& row : nodes.rows) {
    const RowReader r(nodes, node_schema, node_index, row);
    const std::string_view name = r.required_text(name_column);
    if (!is_printable(name))
      r.fail(name_column, "the node name \"" + printable(name) + "\" contains control characters or bytes that are "
                          "not UTF-8 (shown escaped); node names must be printable text");
    const auto [it, inserted] = by_name.emplace(name, static_cast<int>(read.size()));
    if (!inserted)
      r.fail(name_column, "duplicate node name '" + std::string(name) + "': already used on line " +
                              std::to_string(nodes.rows[static_cast<std::size_t>(it->second)].line));
    Node& node = read.emplace_back();
    node.name = name;
    node.position = Vec3(r.number(x_column, Range::any), r.number(y_column, Range::any), r.number(z_column, Range::any));
    if (r.has(mass_column)) {
      node.mass = r.number(mass_column, Range::nonnegative);
    } else if (has_mass) {
      node.mass = mass;
    } else {
      r.fail(mass_column, "no mass for node '" + std::string(name) +
                              "': fill in the mass column or give [[network]] a default 'mass'");
    }
    const std::optional<std::array<bool, 3>> fixed = parse_fixed(r.text(fixed_column));
    if (!fixed)
      r.fail(fixed_column, "expected 0, 1, true, false or the fixed axes as letters (\"z\", \"xy\", \"xyz\"), got '" +
                               std::string(r.text(fixed_column)) + "'");
    node.fixed = *fixed;
  }

  // Edges: a,b[,stiffness][,rest_length][,damping].
  CsvFile edges;
  read_csv(reader, s, "edges", edges);
  enum EdgeColumn : std::size_t { a_column, b_column, stiffness_column, rest_column, damping_column };
  const Schema edge_schema{{"a", "b", "stiffness", "rest_length", "damping"}, 2};
  const std::vector<int> edge_index = match_header(edges, edge_schema);
  if (edge_index[stiffness_column] < 0 && !has_stiffness && !edges.rows.empty())
    s.fail("stiffness",
           "the edges file '" + edges.path + "' has no stiffness column, so [[network]] needs a default 'stiffness'");
  reader.add_to_scene(*s.find("edges"), s.key("edges"), "the network's edges", 0, 0,
                      static_cast<double>(edges.rows.size()));
  const long long first = window.first, end = window.end < 0 ? g.count : window.end;
  if (window.whole(g.count)) g.springs.reserve(edges.rows.size());
  const auto node = [&](const RowReader& r, std::size_t c) {
    const std::string_view name = r.required_text(c);
    const auto it = by_name.find(name);
    if (it != by_name.end()) return it->second;
    std::vector<std::string> candidates;
    candidates.reserve(read.size());
    for (const Node& n : read) candidates.emplace_back(n.name);
    r.fail(c, "unknown node '" + std::string(name) + "'" + did_you_mean(name, candidates) +
                  "; an edge joins two nodes of the nodes file '" + nodes.path + "'" +
                  (name == "world" ? " (to tie a node to the world, fix it: fixed = 1)" : ""));
  };
  for (const CsvRow& row : edges.rows) {
    const RowReader r(edges, edge_schema, edge_index, row);
    Spring spring;
    spring.a.body = node(r, a_column);
    spring.b.body = node(r, b_column);
    if (spring.a.body == spring.b.body)
      r.fail(b_column, "an edge must join two different nodes; both ends are '" + std::string(r.text(a_column)) + "'");
    if (r.has(stiffness_column)) {
      spring.stiffness = r.number(stiffness_column, Range::positive);
    } else if (has_stiffness) {
      spring.stiffness = stiffness;
    } else {
      r.fail(stiffness_column, "no stiffness for the edge '" + std::string(r.text(a_column)) + "'-'" +
                                   std::string(r.text(b_column)) +
                                   "': fill in the stiffness column or give [[network]] a default 'stiffness'");
    }
    spring.damping = r.has(damping_column) ? r.number(damping_column, Range::nonnegative) : damping;
    if (r.has(rest_column)) {
      spring.rest_length = r.number(rest_column, Range::nonnegative);
    } else {
      const Vec3& xa = read[static_cast<std::size_t>(spring.a.body)].position;
      const Vec3& xb = read[static_cast<std::size_t>(spring.b.body)].position;
      const double length = (xa - xb).norm();
      if (!std::isfinite(length))
        r.fail(rest_column, "the distance between the nodes '" + std::string(r.text(a_column)) + "' and '" +
                                std::string(r.text(b_column)) + "' is not finite; give a rest_length");
      if (!(length > 1e-12 * std::max(xa.norm(), xb.norm())))
        r.fail(rest_column, "the nodes '" + std::string(r.text(a_column)) + "' and '" + std::string(r.text(b_column)) +
                                "' are at the same place, so the edge's rest length would be 0; give a rest_length");
      spring.rest_length = (1 - prestrain) * length;
    }
    if (spring.a.body >= first && spring.a.body < end) g.springs.push_back(spring);  // the owner's
  }

  // The held nodes' particles ("<name>.<node>"): all, or the window's.
  std::vector<long long> named;
  if (window.named != nullptr && !window.whole(g.count))
    for (const std::string& full : *window.named)
      if (full.starts_with(g.name + "."))
        if (const auto it = by_name.find(std::string_view(full).substr(g.name.size() + 1)); it != by_name.end())
          named.push_back(it->second);
  hold_window(window, g, std::move(named));
  const auto particle = [&](std::size_t l) {
    const Node& n = read[l];
    std::string full;
    full.reserve(g.name.size() + 1 + n.name.size());
    full.append(g.name).append(".").append(n.name);
    add_particle(g.bodies, std::move(full), n.position, n.mass, n.fixed);
    g.lines.push_back(nodes.rows[l].line);
  };
  const std::size_t held = window.whole(g.count) ? read.size() : g.held.size();
  g.bodies.reserve(held);
  g.lines.reserve(held);
  if (window.whole(g.count))
    for (std::size_t l = 0; l < read.size(); ++l) particle(l);
  else
    for (const long long l : g.held) particle(static_cast<std::size_t>(l));
  return g;
}

}  // namespace modal::scene_detail
