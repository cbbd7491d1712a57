// MJCF and URDF files as modal scenes (modal/import.hpp, docs/design.md
// "Importing MJCF and URDF"): libmujoco compiles the file, and the compiled
// mjModel is written as a TOML tree of [[body]] tables.
//
// Frames. A MuJoCo body frame sits at body_pos, turned by body_quat, in its
// parent's frame; its joints act in turn, a hinge or ball about its anchor
// jnt_pos (body frame), a slide along its axis. A modal body's frame is its
// joint centre, so the MuJoCo body with joints j1 … jm becomes m modal bodies
// in series, each named after its joint, each frame the MuJoCo frame shifted
// to that joint's anchor (a slide's or free joint's anchor is taken as the
// body origin, where it makes no difference): the first one at
// body_pos − s_parent + body_quat·s_1 turned by body_quat (s_parent the shift of
// the parent's last modal body), the next ones at s_i − s_(i−1) unturned; the
// last one carries the mass, with its centre of mass at body_ipos − s_m and its
// inertia tensor R diag(body_inertia) Rᵀ (R from body_iquat). A body without
// joints is a fixed body.
#include "modal/import.hpp"

#include <mujoco/mujoco.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace modal {

const char* to_string(SceneFormat format) {
  switch (format) {
    case SceneFormat::automatic: return "auto";
    case SceneFormat::toml: return "toml";
    case SceneFormat::mjcf: return "mjcf";
    case SceneFormat::urdf: return "urdf";
  }
  return "?";
}

std::optional<SceneFormat> parse_scene_format(std::string_view word) {
  for (SceneFormat f : {SceneFormat::automatic, SceneFormat::toml, SceneFormat::mjcf, SceneFormat::urdf})
    if (word == to_string(f)) return f;
  return std::nullopt;
}

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// The name of the root element of an XML text ("" when the text is not XML):
// skips white space, <?…?> declarations, <!-- … --> comments and <!DOCTYPE …>.
std::string root_element(std::string_view text) {
  std::size_t i = 0;
  for (;;) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (text.substr(i, 4) == "<!--") {
      const std::size_t end = text.find("-->", i);
      if (end == std::string_view::npos) return "";
      i = end + 3;
    } else if (text.substr(i, 2) == "<?" || text.substr(i, 2) == "<!") {
      const std::size_t end = text.find('>', i);
      if (end == std::string_view::npos) return "";
      i = end + 1;
    } else {
      break;
    }
  }
  if (i >= text.size() || text[i] != '<') return "";
  std::size_t e = ++i;
  while (e < text.size() && (std::isalnum(static_cast<unsigned char>(text[e])) || text[e] == '_')) ++e;
  return std::string(text.substr(i, e - i));
}

}  // namespace

SceneFormat scene_format(const std::string& file, std::string_view text, SceneFormat requested) {
  if (requested != SceneFormat::automatic) return requested;
  const std::string ext = lower(std::filesystem::path(file).extension().string());
  if (ext == ".toml") return SceneFormat::toml;
  if (ext == ".xml" || ext == ".mjcf") return SceneFormat::mjcf;
  if (ext == ".urdf") return SceneFormat::urdf;
  const std::string root = root_element(text);
  if (root == "mujoco") return SceneFormat::mjcf;
  if (root == "robot") return SceneFormat::urdf;
  return SceneFormat::toml;
}

std::string mujoco_version() {
  const int v = mj_version();
  return std::to_string(v / 100) + "." + std::to_string(v / 10 % 10) + "." + std::to_string(v % 10);
}

namespace {

// MuJoCo reports errors through handlers that by default print and exit the
// process; modal's throw instead (the library is built with unwind tables),
// and warnings are dropped (they would be printed on standard output).
[[noreturn]] void throw_mujoco_error(const char* message) { throw std::runtime_error(message); }
void ignore_mujoco_warning(const char*) {}
std::mutex& mujoco_mutex() {  // the handlers and the XML reader are process-wide
  static std::mutex m;
  return m;
}

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

// The 1-based line of the element <tag … name="name" …> in `text`; 0 when not found.
int line_of(std::string_view text, std::string_view tag, std::string_view name) {
  if (name.empty()) return 0;
  for (const char quote : {'"', '\''}) {
    const std::string needle = std::string("name=") + quote + std::string(name) + quote;
    for (std::size_t at = text.find(needle); at != std::string_view::npos; at = text.find(needle, at + 1)) {
      if (at == 0 || !std::isspace(static_cast<unsigned char>(text[at - 1]))) continue;
      const std::size_t open = text.rfind('<', at);
      if (open == std::string_view::npos) continue;
      std::size_t e = open + 1;
      while (e < at && !std::isspace(static_cast<unsigned char>(text[e]))) ++e;
      if (text.substr(open + 1, e - open - 1) != tag) continue;
      return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(open), '\n'));
    }
  }
  return 0;
}

std::string number(double v) {
  if (v == 0.0) return "0";
  char buffer[40];
  const auto r = std::to_chars(buffer, buffer + sizeof buffer, v);
  return std::string(buffer, r.ptr);
}

template <class Vector> std::string numbers(const Vector& v, int n) {
  std::string s = "[";
  for (int i = 0; i < n; ++i) s += (i ? ", " : "") + number(v[i]);
  return s + "]";
}

// A TOML basic string.
std::string toml_string(std::string_view text) {
  std::string s = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      s += '\\';
      s += c;
    } else if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      char buffer[8];
      std::snprintf(buffer, sizeof buffer, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
      s += buffer;
    } else {
      s += c;
    }
  }
  return s + "\"";
}

class Importer {
 public:
  Importer(const mjModel& m, std::string_view text, std::string file, SceneFormat format)
      : m_(m), text_(text), file_(std::move(file)), format_(format) {}

  std::string name(int type, int id) const {
    const char* n = mj_id2name(&m_, type, id);
    return n != nullptr ? std::string(n) : std::string();
  }
  // How messages name an element: its name, or its number when it has none.
  std::string label(const char* what, int type, int id) const {
    const std::string n = name(type, id);
    return n.empty() ? std::string(what) + " #" + std::to_string(id) + " (unnamed)"
                     : std::string(what) + " '" + n + "'";
  }
  int line(int type, int id) const {
    const std::string n = name(type, id);
    if (format_ == SceneFormat::urdf) {
      if (type == mjOBJ_JOINT) return line_of(text_, "joint", n);
      if (type == mjOBJ_BODY) return line_of(text_, "link", n);
      return 0;
    }
    static constexpr std::array<std::pair<int, const char*>, 4> tags{
        {{mjOBJ_BODY, "body"}, {mjOBJ_JOINT, "joint"}, {mjOBJ_GEOM, "geom"}, {mjOBJ_ACTUATOR, ""}}};
    for (const auto& [t, tag] : tags)
      if (t == type && tag[0] != '\0') return line_of(text_, tag, n);
    // actuators, tendons and equalities have several element names: try each
    const std::vector<const char*> kinds =
        type == mjOBJ_ACTUATOR ? std::vector<const char*>{"general", "motor", "position", "velocity", "cylinder",
                                                          "muscle", "intvelocity", "damper", "adhesion"}
        : type == mjOBJ_TENDON ? std::vector<const char*>{"fixed", "spatial"}
        : type == mjOBJ_EQUALITY ? std::vector<const char*>{"connect", "weld", "joint", "tendon", "distance"}
                                 : std::vector<const char*>{};
    for (const char* k : kinds)
      if (const int l = line_of(text_, k, n)) return l;
    return 0;
  }
  [[noreturn]] void refuse(int type, int id, const char* what, const std::string& reason) const {
    throw SceneError({file_, line(type, id), 0}, label(what, type, id), reason);
  }

  void check_unsupported() const;
  std::string write() const;
  // Filled by write(): each modal body's name and the line of the element it
  // comes from (its joint; a fixed body's body or link; 0 when not found), and
  // the modal body of each MuJoCo joint.
  const std::vector<std::pair<std::string, int>>& body_lines() const { return body_lines_; }
  const std::vector<std::string>& joint_bodies() const { return joint_bodies_; }

 private:
  const mjModel& m_;
  std::string_view text_;
  std::string file_;
  SceneFormat format_;
  mutable std::vector<std::pair<std::string, int>> body_lines_;
  mutable std::vector<std::string> joint_bodies_;
  bool disabled(int flag) const { return (m_.opt.disableflags & flag) != 0; }
  bool limits_apply(int j) const {
    return m_.jnt_limited[j] && !disabled(mjDSBL_CONSTRAINT) && !disabled(mjDSBL_LIMIT);
  }
};

const char* joint_word(int type) {
  switch (type) {
    case mjJNT_FREE: return "free";
    case mjJNT_BALL: return "ball";
    case mjJNT_SLIDE: return "slide";
    case mjJNT_HINGE: return "hinge";
    default: return "?";
  }
}

const char* equality_word(int type) {
  switch (type) {
    case mjEQ_CONNECT: return "connect";
    case mjEQ_WELD: return "weld";
    case mjEQ_JOINT: return "joint";
    case mjEQ_TENDON: return "tendon";
    default: return "distance";
  }
}

void Importer::check_unsupported() const {
  const std::string rewrite = "; modal does not import it (write the scene in TOML, or remove it from the model)";
  const bool passive = !disabled(mjDSBL_PASSIVE);
  for (int t = 0; t < m_.ntendon; ++t)
    if (passive && (m_.tendon_stiffness[t] != 0.0 || m_.tendon_damping[t] != 0.0))
      refuse(mjOBJ_TENDON, t, "tendon",
             "a tendon with stiffness " + number(m_.tendon_stiffness[t]) + " and damping " +
                 number(m_.tendon_damping[t]) + " changes the linear model" + rewrite);
  if (!disabled(mjDSBL_ACTUATION))
    for (int a = 0; a < m_.nu; ++a) {
      const mjtNum* bias = m_.actuator_biasprm + a * mjNBIAS;
      if (m_.actuator_biastype[a] != mjBIAS_NONE && (bias[0] != 0.0 || bias[1] != 0.0 || bias[2] != 0.0))
        refuse(mjOBJ_ACTUATOR, a, "actuator",
               "its bias force " + number(bias[0]) + " + " + number(bias[1]) + "·length + " + number(bias[2]) +
                   "·velocity acts with zero control (a position or velocity servo: stiffness or damping)" + rewrite);
    }
  if (!disabled(mjDSBL_CONSTRAINT) && !disabled(mjDSBL_EQUALITY))
    for (int e = 0; e < m_.neq; ++e)
      if (m_.eq_active[e] && m_.eq_type[e] != mjEQ_CONNECT && m_.eq_type[e] != mjEQ_JOINT)  // [[constraint]]s (write())
        refuse(mjOBJ_EQUALITY, e, "equality",
               std::string("a ") + equality_word(m_.eq_type[e]) +
                   " equality constraint is not mapped onto modal's constraints" + rewrite);
  for (int j = 0; j < m_.njnt; ++j) {
    const int dof = m_.jnt_dofadr[j];
    if (!disabled(mjDSBL_CONSTRAINT) && !disabled(mjDSBL_FRICTIONLOSS) && m_.dof_frictionloss[dof] != 0.0)
      refuse(mjOBJ_JOINT, j, "joint", "dry friction (frictionloss " + number(m_.dof_frictionloss[dof]) +
                                          ") has no linear model" + rewrite);
    if (m_.jnt_type[j] == mjJNT_FREE && passive && m_.jnt_stiffness[j] != 0.0)
      refuse(mjOBJ_JOINT, j, "joint", "a free joint with stiffness" + rewrite);
    if (m_.jnt_type[j] == mjJNT_BALL) {
      const mjtNum* s = m_.qpos_spring + m_.jnt_qposadr[j];
      if (passive && m_.jnt_stiffness[j] != 0.0 && (s[0] != 1.0 || s[1] != 0.0 || s[2] != 0.0 || s[3] != 0.0))
        refuse(mjOBJ_JOINT, j, "joint", "a ball joint's spring reference other than its written orientation" + rewrite);
    }
    if (limits_apply(j) && (m_.jnt_type[j] == mjJNT_HINGE || m_.jnt_type[j] == mjJNT_SLIDE)) {
      const double q0 = m_.qpos0[m_.jnt_qposadr[j]];
      const double lo = m_.jnt_range[2 * j], hi = m_.jnt_range[2 * j + 1];
      if (!(q0 > lo + m_.jnt_margin[j] && q0 < hi - m_.jnt_margin[j]))
        refuse(mjOBJ_JOINT, j, "joint",
               "its limit is active in the written configuration (" + number(q0) + " is not inside the range [" +
                   number(lo) + ", " + number(hi) + "]" +
                   (m_.jnt_margin[j] == 0.0 ? std::string()
                    : lo + m_.jnt_margin[j] < hi - m_.jnt_margin[j]
                        ? " narrowed by its margin " + number(m_.jnt_margin[j]) + " to [" + number(lo + m_.jnt_margin[j]) +
                              ", " + number(hi - m_.jnt_margin[j]) + "]"
                        : " narrowed by its margin " + number(m_.jnt_margin[j]) + " to nothing") +
                   "): a limit has no linear model" + rewrite);
    }
  }
  if (m_.opt.viscosity != 0.0 || (m_.opt.density != 0.0 && (m_.opt.wind[0] != 0.0 || m_.opt.wind[1] != 0.0 ||
                                                             m_.opt.wind[2] != 0.0)))
    throw SceneError({file_, 0, 0}, "option",
                     "fluid forces (viscosity " + number(m_.opt.viscosity) + ", density " + number(m_.opt.density) +
                         " with wind) change the linear model" + rewrite);
  if (!disabled(mjDSBL_CONSTRAINT) && !disabled(mjDSBL_CONTACT) && m_.ngeom > 1) {
    // Contacts in the written configuration (MuJoCo's own collision detection).
    DataPtr d(mj_makeData(&m_));
    if (!d) throw std::bad_alloc();
    mj_forward(&m_, d.get());
    if (d->ncon > 0) {
      const mjContact& c = d->contact[0];
      refuse(mjOBJ_GEOM, c.geom1, "geom",
             "is in contact with " + label("geom", mjOBJ_GEOM, c.geom2) +
                 " in the written configuration (distance " + number(c.dist) +
                 " m): contacts have no linear model; exclude the pair (<contact><exclude>), set contype and "
                 "conaffinity to 0, or disable contacts (<option><flag contact=\"disable\"/>)");
    }
  }
}

Eigen::Matrix3d rotation(const mjtNum* quat) {
  return Eigen::Quaterniond(quat[0], quat[1], quat[2], quat[3]).normalized().toRotationMatrix();
}

std::string Importer::write() const {
  std::string out;
  const char* kind = format_ == SceneFormat::urdf ? "URDF" : "MJCF";
  out += "# The " + std::string(kind) + " model " + file_ + " as a modal scene, written by `modal convert` from the\n";
  out += "# model libmujoco " + mujoco_version() + " compiled (docs/design.md, \"Importing MJCF and URDF\").\n";
  out += "# Coordinates are the joints' values relative to the written configuration (MuJoCo's qpos0).\n";
  std::string title;
  if (m_.names != nullptr && m_.names[0] != '\0') title = m_.names;  // the model's name comes first in names
  if (title.empty()) title = std::filesystem::path(file_).stem().string();
  out += "title = " + toml_string(title) + "\n";
  Eigen::Vector3d g(m_.opt.gravity[0], m_.opt.gravity[1], m_.opt.gravity[2]);
  if (m_.opt.disableflags & mjDSBL_GRAVITY) g.setZero();
  out += "gravity = " + numbers(g, 3) + "\n";
  const bool passive = !disabled(mjDSBL_PASSIVE);

  // Modal body names: joints' names for bodies with joints, bodies' names for
  // fixed ones, made unique (and never "world").
  std::unordered_set<std::string> used{"world"};
  auto unique = [&used](std::string n) {
    std::string candidate = n;
    for (int k = 2; !used.insert(candidate).second; ++k) candidate = n + "_" + std::to_string(k);
    return candidate;
  };
  body_lines_.clear();
  joint_bodies_.assign(static_cast<std::size_t>(m_.njnt), std::string());
  std::vector<std::string> last_name(static_cast<std::size_t>(m_.nbody));   // the modal body holding each MuJoCo body
  std::vector<Eigen::Vector3d> last_shift(static_cast<std::size_t>(m_.nbody), Eigen::Vector3d::Zero());
  last_name[0] = "world";
  for (int b = 1; b < m_.nbody; ++b) {
    const auto bb = static_cast<std::size_t>(b);
    const int parent = m_.body_parentid[b];
    const std::string body_name = name(mjOBJ_BODY, b);
    const std::string body_label = body_name.empty() ? "body #" + std::to_string(b) : body_name;
    const Eigen::Vector3d pos(m_.body_pos + 3 * b);
    const Eigen::Matrix3d R0 = rotation(m_.body_quat + 4 * b);
    const Eigen::Vector4d quat(m_.body_quat + 4 * b);
    std::string parent_name = last_name[static_cast<std::size_t>(parent)];
    Eigen::Vector3d previous = last_shift[static_cast<std::size_t>(parent)];
    const int nj = m_.body_jntnum[b];
    const int count = std::max(nj, 1);
    for (int i = 0; i < count; ++i) {
      const bool has_joint = nj > 0;
      const int j = has_joint ? m_.body_jntadr[b] + i : -1;
      const int type = has_joint ? m_.jnt_type[j] : -1;
      const Eigen::Vector3d shift =
          has_joint && (type == mjJNT_HINGE || type == mjJNT_BALL) ? Eigen::Vector3d(m_.jnt_pos + 3 * j)
                                                                     : Eigen::Vector3d::Zero();
      std::string own = has_joint ? name(mjOBJ_JOINT, j) : body_label;
      if (own.empty()) own = nj == 1 ? body_label : body_label + ".joint" + std::to_string(i + 1);
      const std::string modal_name = unique(own);
      body_lines_.emplace_back(modal_name, has_joint ? line(mjOBJ_JOINT, j) : line(mjOBJ_BODY, b));
      if (has_joint) joint_bodies_[static_cast<std::size_t>(j)] = modal_name;
      const bool first = i == 0, last = i == count - 1;
      out += "\n[[body]]  # " + std::string(kind) + " " + (format_ == SceneFormat::urdf ? "link" : "body") + " " +
             toml_string(body_label);
      if (has_joint) {
        const int l = line(mjOBJ_JOINT, j);
        out += std::string(", ") + joint_word(type) + " joint" + (l > 0 ? " at line " + std::to_string(l) : "");
      }
      out += "\nname = " + toml_string(modal_name) + "\n";
      out += "parent = " + toml_string(parent_name) + "\n";
      out += std::string("joint = \"") + (has_joint ? joint_word(type) : "fixed") + "\"\n";
      const Eigen::Vector3d origin = first ? Eigen::Vector3d(pos - previous + R0 * shift) : Eigen::Vector3d(shift - previous);
      if (!origin.isZero(0.0)) out += "origin = " + numbers(origin, 3) + "\n";
      if (first && !R0.isIdentity(0.0)) out += "orientation = " + numbers(quat, 4) + "\n";
      if (has_joint && (type == mjJNT_HINGE || type == mjJNT_SLIDE))
        out += "axis = " + numbers(m_.jnt_axis + 3 * j, 3) + "\n";
      if (last && m_.body_mass[b] != 0.0) {
        out += "mass = " + number(m_.body_mass[b]) + "\n";
        const Eigen::Vector3d com = Eigen::Vector3d(m_.body_ipos + 3 * b) - shift;
        if (!com.isZero(0.0)) out += "com = " + numbers(com, 3) + "\n";
      }
      if (last && Eigen::Vector3d(m_.body_inertia + 3 * b).squaredNorm() != 0.0) {
        const Eigen::Matrix3d Ri = rotation(m_.body_iquat + 4 * b);
        const Eigen::Matrix3d I = Ri * Eigen::Vector3d(m_.body_inertia + 3 * b).asDiagonal() * Ri.transpose();
        const std::array<double, 6> six{I(0, 0), I(1, 1), I(2, 2), 0.5 * (I(0, 1) + I(1, 0)),
                                        0.5 * (I(0, 2) + I(2, 0)), 0.5 * (I(1, 2) + I(2, 1))};
        out += "inertia = " + numbers(six, 6) + "\n";
      }
      if (has_joint) {
        const int dof = m_.jnt_dofadr[j];
        const int qa = m_.jnt_qposadr[j];
        const bool scalar = type == mjJNT_HINGE || type == mjJNT_SLIDE;
        if (passive && m_.jnt_stiffness[j] != 0.0 && type != mjJNT_FREE) {
          out += "stiffness = " + number(m_.jnt_stiffness[j]) + "\n";
          if (scalar && m_.qpos_spring[qa] != m_.qpos0[qa])
            out += "rest = " + number(m_.qpos_spring[qa] - m_.qpos0[qa]) + "\n";
        }
        if (passive && m_.dof_damping[dof] != 0.0) {
          if (type == mjJNT_FREE)
            refuse(mjOBJ_JOINT, j, "joint", "a free joint with damping; modal does not import it");
          out += "damping = " + number(m_.dof_damping[dof]) + "\n";
        }
        if (m_.dof_armature[dof] != 0.0) out += "armature = " + number(m_.dof_armature[dof]) + "\n";
        if (scalar && limits_apply(j)) {  // the range by its margin (MuJoCo's limit acts from there on)
          const double margin = m_.jnt_margin[j];
          out += "range = [" + number(m_.jnt_range[2 * j] + margin - m_.qpos0[qa]) + ", " +
                 number(m_.jnt_range[2 * j + 1] - margin - m_.qpos0[qa]) + "]" +
                 (margin != 0.0 ? "  # the joint's range less its margin " + number(margin) : std::string()) + "\n";
        }
      }
      parent_name = modal_name;
      previous = shift;
    }
    last_name[bb] = parent_name;
    last_shift[bb] = previous;
  }
  // Active equalities, in file order. Connect: a point constraint; eq_data
  // holds the anchor in body1's frame and, computed by the compiler at qpos0,
  // in body2's frame. Joint: a coupling; MuJoCo's equation is
  // qpos1 − qpos0_1 = Σ_k eq_data[k]·(qpos2 − qpos0_2)^k (qpos1 − qpos0_1 =
  // eq_data[0] without joint2), in modal's coordinates (relative to qpos0)
  // q_a = p(q_b) with the same coefficients.
  if (!disabled(mjDSBL_CONSTRAINT) && !disabled(mjDSBL_EQUALITY))
    for (int e = 0; e < m_.neq; ++e) {
      const bool connect = m_.eq_type[e] == mjEQ_CONNECT;
      if (!m_.eq_active[e] || (!connect && m_.eq_type[e] != mjEQ_JOINT)) continue;
      const int o1 = m_.eq_obj1id[e], o2 = m_.eq_obj2id[e];
      const mjtNum* data = m_.eq_data + e * mjNEQDATA;
      std::string n = name(mjOBJ_EQUALITY, e);
      if (n.empty()) n = "equality" + std::to_string(e);
      const int l = line(mjOBJ_EQUALITY, e);
      out += "\n[[constraint]]  # " + std::string(kind) + (connect ? " connect" : " joint") + " equality" +
             (l > 0 ? " at line " + std::to_string(l) : std::string()) + "\n";
      out += std::string("type = \"") + (connect ? "point" : "coupling") + "\"\nname = " + toml_string(n) + "\n";
      if (connect) {
        const auto b1 = static_cast<std::size_t>(o1), b2 = static_cast<std::size_t>(o2);
        const Eigen::Vector3d a = Eigen::Vector3d(data) - last_shift[b1];
        const Eigen::Vector3d b = Eigen::Vector3d(data + 3) - last_shift[b2];
        out += "a = " + toml_string(last_name[b1]) + "\na_point = " + numbers(a, 3) + "\n";
        out += "b = " + toml_string(last_name[b2]) + "\nb_point = " + numbers(b, 3) + "\n";
      } else {
        out += "a = " + toml_string(joint_bodies_[static_cast<std::size_t>(o1)]) + "\n";
        if (o2 >= 0) out += "b = " + toml_string(joint_bodies_[static_cast<std::size_t>(o2)]) + "\n";
        out += "polynomial = " + (o2 >= 0 ? numbers(data, 5) : numbers(data, 1)) + "\n";
      }
    }
  return out;
}

}  // namespace

// The compiled model behind an imported scene (modal/import.hpp).
struct ImportedModel {
  std::shared_ptr<const mjModel> model;
  std::string text;                       // the file's text (lines for messages)
  std::string file;
  SceneFormat format = SceneFormat::mjcf;
  std::vector<std::string> joint_bodies;  // the modal body of each MuJoCo joint
};

ImportedScene import_model(std::string_view text, const std::string& file, SceneFormat format) {
  if (format != SceneFormat::mjcf && format != SceneFormat::urdf)
    throw std::invalid_argument("import_scene: the format must be mjcf or urdf");
  const std::lock_guard<std::mutex> lock(mujoco_mutex());
  mju_user_error = throw_mujoco_error;
  mju_user_warning = ignore_mujoco_warning;
  // MuJoCo decides MJCF or URDF by the root element; say which was expected.
  const std::string root = root_element(text);
  const char* expected = format == SceneFormat::urdf ? "robot" : "mujoco";
  if (root != expected)
    throw SceneError({file, 1, 0}, "",
                     std::string("not ") + (format == SceneFormat::urdf ? "a URDF" : "an MJCF") +
                         " file: its root element is " + (root.empty() ? "missing" : "<" + root + ">") +
                         ", expected <" + expected + "> (--format toml|mjcf|urdf chooses how a file is read)");
  char error[1024] = "";
  ModelPtr model;
  try {
    std::error_code ec;
    if (std::filesystem::is_regular_file(file, ec)) {
      model.reset(mj_loadXML(file.c_str(), nullptr, error, sizeof error));
    } else {  // from memory, through MuJoCo's virtual file system
      auto vfs = std::make_unique<mjVFS>();
      mj_defaultVFS(vfs.get());
      const std::string base = std::filesystem::path(file).filename().string();
      const std::string name = base.empty() ? std::string("model.xml") : base;
      if (mj_makeEmptyFileVFS(vfs.get(), name.c_str(), static_cast<int>(text.size())) != 0)
        throw SceneError({file, 0, 0}, "", "MuJoCo's virtual file system refused the model");
      std::memcpy(vfs->filedata[vfs->nfile - 1], text.data(), text.size());
      model.reset(mj_loadXML(name.c_str(), vfs.get(), error, sizeof error));
      mj_deleteVFS(vfs.get());
    }
  } catch (const std::runtime_error& e) {
    if (dynamic_cast<const SceneError*>(&e)) throw;
    throw SceneError({file, 0, 0}, "", std::string("MuJoCo could not load the model: ") + e.what());
  }
  if (!model) {
    std::string message = error;
    while (!message.empty() && std::isspace(static_cast<unsigned char>(message.back()))) message.pop_back();
    for (char& c : message)
      if (c == '\n') c = ' ';
    // MuJoCo's XML errors end with "Line L, column C"; keep its line for the location.
    int line = 0;
    const std::size_t at = message.rfind("line ");
    const std::size_t at2 = message.rfind("Line ");
    const std::size_t pos = at == std::string::npos ? at2 : (at2 == std::string::npos ? at : std::max(at, at2));
    if (pos != std::string::npos) line = std::atoi(message.c_str() + pos + 5);
    // An element or attribute this libmujoco does not know is often one of a
    // later MuJoCo (models from MuJoCo's own repository use them): say which
    // version read it.
    if (message.find("Schema violation: unrecognized") != std::string::npos)
      message += " (this is libmujoco " + mujoco_version() +
                 ", which does not know it; a model written for a later MuJoCo may use it: remove it, or convert "
                 "the model with a MuJoCo that reads it)";
    // A body that moves without mass: in URDF, a link without <inertial>
    // (display-only models, as ROS's tutorials); MuJoCo names the body.
    const std::string massless = "mass and inertia of moving bodies must be larger than mjMINVAL";
    if (const std::size_t at_name = message.find("Object name = ");
        message.find(massless) != std::string::npos && at_name != std::string::npos) {
      std::string body = message.substr(at_name + 14);
      body = body.substr(0, body.find(','));
      if (line == 0) line = line_of(text, format == SceneFormat::urdf ? "link" : "body", body);
      message += format == SceneFormat::urdf
                     ? " (link '" + body + "' moves, but has no <inertial>, as a URDF written for display only, or "
                       "its mass or a principal moment of inertia is below MuJoCo's minimum 1e-15: give every "
                       "moving link an <inertial>, and a point mass a small inertia, e.g. ixx = iyy = izz = 1e-9)"
                     : " (body '" + body + "' moves, but its mass or a principal moment of inertia is below MuJoCo's "
                       "minimum 1e-15: give it an <inertial> (a point mass a small diaginertia, e.g. \"1e-9 1e-9 "
                       "1e-9\"), or geoms with mass or density)";
    }
    // Meshes MuJoCo cannot read (ROS models' Collada files); modal needs a
    // link's geometry only for mass properties an <inertial> does not give.
    if (message.find("Unknown mesh file type") != std::string::npos)
      message += " (MuJoCo reads STL, OBJ and MSH meshes: convert it, or remove the mesh from a link whose "
                 "<inertial> gives its mass and inertia, since modal needs no geometry there)";
    throw SceneError({file, std::max(line, 0), 0}, "", "MuJoCo could not load the model: " + message);
  }
  if (model->nbody < 2)
    throw SceneError({file, 0, 0}, "",
                     std::string("the model has no body besides the world: nothing moves, nothing to analyze (") +
                         (format == SceneFormat::urdf
                              ? "a URDF file needs links joined by joints that move: revolute, continuous, "
                                "prismatic or floating; links joined by fixed joints are merged into one"
                              : "add a <body> to <worldbody>") +
                         ")");
  const Importer importer(*model, text, file, format);
  ImportedScene out;
  try {
    importer.check_unsupported();
    out.toml = importer.write();
  } catch (const SceneError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw SceneError({file, 0, 0}, "", std::string("MuJoCo failed on the model: ") + e.what());
  }
  out.body_lines = importer.body_lines();
  out.model = std::make_shared<const ImportedModel>(
      ImportedModel{std::shared_ptr<const mjModel>(model.release(), ModelDeleter{}), std::string(text), file, format,
                    importer.joint_bodies()});
  return out;
}

std::string import_scene(std::string_view text, const std::string& file, SceneFormat format) {
  return import_model(text, file, format).toml;
}

namespace {

// q (modal coordinates of `system`) as MuJoCo's qpos: hinge and slide
// coordinates add to qpos0, a ball joint's rotation vector φ turns qpos0's
// quaternion by exp(φ) after it, a free joint's translation adds to qpos0's
// position and its rotation vector turns the quaternion the same way.
std::vector<mjtNum> mujoco_configuration(const ImportedModel& im, const System& system, const VectorX& q) {
  const mjModel& m = *im.model;
  std::vector<mjtNum> qpos(m.qpos0, m.qpos0 + m.nq);
  std::unordered_map<std::string, int> body_index;
  for (std::size_t b = 0; b < system.bodies().size(); ++b) body_index.emplace(system.bodies()[b].name, static_cast<int>(b));
  auto turn = [](mjtNum* quat, const Eigen::Vector3d& phi) {
    const Eigen::Quaterniond q0(quat[0], quat[1], quat[2], quat[3]);
    const double angle = phi.norm();
    const Eigen::Quaterniond r = angle > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, phi / angle))
                                           : Eigen::Quaterniond::Identity();
    const Eigen::Quaterniond t = (q0 * r).normalized();
    quat[0] = t.w(), quat[1] = t.x(), quat[2] = t.y(), quat[3] = t.z();
  };
  for (int j = 0; j < m.njnt; ++j) {
    const auto found = body_index.find(im.joint_bodies[static_cast<std::size_t>(j)]);
    if (found == body_index.end()) continue;  // not in this system (cannot happen for an unedited conversion)
    const int i = system.first_coordinate(found->second);
    mjtNum* p = qpos.data() + m.jnt_qposadr[j];
    switch (m.jnt_type[j]) {
      case mjJNT_HINGE:
      case mjJNT_SLIDE: p[0] += q[i]; break;
      case mjJNT_BALL: turn(p, q.segment<3>(i)); break;
      case mjJNT_FREE:
        for (int k = 0; k < 3; ++k) p[k] += q[i + k];
        turn(p + 3, q.segment<3>(i + 3));
        break;
      default: break;
    }
  }
  return qpos;
}

}  // namespace

void check_imported_configuration(const ImportedModel& im, const System& system, const VectorX& q) {
  const mjModel& m = *im.model;
  if (q.size() != system.size()) throw std::invalid_argument("check_imported_configuration: q has the wrong size");
  const std::lock_guard<std::mutex> lock(mujoco_mutex());
  mju_user_error = throw_mujoco_error;
  mju_user_warning = ignore_mujoco_warning;
  const Importer names(m, im.text, im.file, im.format);
  const bool constraints = (m.opt.disableflags & mjDSBL_CONSTRAINT) == 0;
  const std::vector<mjtNum> qpos = mujoco_configuration(im, system, q);
  // A ball joint's cone limit: the rotation angle of its quaternion against range[1] less the margin.
  if (constraints && (m.opt.disableflags & mjDSBL_LIMIT) == 0)
    for (int j = 0; j < m.njnt; ++j) {
      if (m.jnt_type[j] != mjJNT_BALL || !m.jnt_limited[j]) continue;
      const mjtNum* w = qpos.data() + m.jnt_qposadr[j];
      const double angle = 2 * std::atan2(std::sqrt(w[1] * w[1] + w[2] * w[2] + w[3] * w[3]), std::abs(w[0]));
      const double limit = std::max(m.jnt_range[2 * j], m.jnt_range[2 * j + 1]) - m.jnt_margin[j];
      if (!(angle < limit))
        names.refuse(mjOBJ_JOINT, j, "joint",
                     "the ball joint is turned by " + number(angle) + " rad in the equilibrium found, not inside its "
                     "limit " + number(limit) + " rad: the stop would push there, and a limit has no linear model");
    }
  if (!constraints || (m.opt.disableflags & mjDSBL_CONTACT) != 0 || m.ngeom < 2) return;
  DataPtr d(mj_makeData(&m));
  if (!d) throw std::bad_alloc();
  std::copy(qpos.begin(), qpos.end(), d->qpos);
  try {
    mj_forward(&m, d.get());
  } catch (const std::runtime_error& e) {
    throw SceneError({im.file, 0, 0}, "", std::string("MuJoCo failed on the model at the equilibrium: ") + e.what());
  }
  if (d->ncon > 0) {
    const mjContact& c = d->contact[0];
    names.refuse(mjOBJ_GEOM, c.geom1, "geom",
                 "is in contact with " + names.label("geom", mjOBJ_GEOM, c.geom2) +
                     " in the equilibrium found (distance " + number(c.dist) +
                     " m): contacts have no linear model; exclude the pair (<contact><exclude>), set contype and "
                     "conaffinity to 0, or disable contacts (<option><flag contact=\"disable\"/>)");
  }
}

}  // namespace modal
