// modal/import.hpp — scenes from other tools: MJCF (MuJoCo) and URDF files as
// modal scenes (docs/design.md, "Importing MJCF and URDF").
//
//   std::string toml = modal::import_scene(text, "arm.xml", modal::SceneFormat::mjcf);
//   modal::Scene scene = modal::parse_scene(toml, "arm.xml");
//
// Both formats are read by libmujoco (mj_loadXML, which also reads URDF): the
// compiled model (inertias inferred from geoms where the file leaves them to
// the compiler, frames resolved, defaults applied) is written as the
// equivalent TOML scene, a tree of [[body]] tables, which modal then reads like
// any other scene, so every command and the exact derivatives apply to it.
// Active connect equalities become point [[constraint]]s, joint equalities
// coupling [[constraint]]s. What would change
// the linear model but has no counterpart in a modal scene (tendon springs,
// actuators acting at rest, weld, tendon and distance equalities, contacts or
// joint limits active in the written configuration, dry friction, fluid
// viscosity; contacts and ball-joint limits at an equilibrium:
// check_imported_configuration; hinge and slide limits become `range` keys) is refused with a SceneError naming the element, its name and,
// when it can be found in the text, its line.
#pragma once

#include "modal/scene.hpp"

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace modal {

enum class SceneFormat { automatic, toml, mjcf, urdf };
const char* to_string(SceneFormat format);  // "auto", "toml", "mjcf", "urdf"
// "auto", "toml", "mjcf" or "urdf"; nothing for another word.
std::optional<SceneFormat> parse_scene_format(std::string_view word);

// The format of a scene file: `requested` unless it is automatic; otherwise by
// the file name's extension (.toml; .xml or .mjcf; .urdf), and for any other
// name by the text (a root element mujoco or robot after optional XML
// declarations and comments; anything else is TOML).
SceneFormat scene_format(const std::string& file, std::string_view text,
                         SceneFormat requested = SceneFormat::automatic);

// An MJCF or URDF model as the equivalent TOML scene (the text `modal convert`
// writes). `text` is the file's content and `file` its path: when `file` is an
// existing file, MuJoCo reads it from there, so that meshes and included
// files are found relative to it; otherwise `text` is read from memory.
// Throws SceneError (file, line where known): MuJoCo's own message for a file it
// cannot load, or the unsupported element.
std::string import_scene(std::string_view text, const std::string& file, SceneFormat format);

// MuJoCo's compiled model behind an imported scene (opaque; constant once made).
struct ImportedModel;

// An imported scene with what its TOML text cannot carry: where each body
// comes from in the file, and the compiled model, which can still answer for
// contacts and ball-joint cone limits at any configuration of the scene.
struct ImportedScene {
  std::string toml;                                   // import_scene's text
  std::vector<std::pair<std::string, int>> body_lines;// each [[body]] of `toml`, in order: its name and the
                                                      // line of the element it comes from (its joint; a fixed
                                                      // body's body or link element; 0 when not found)
  std::shared_ptr<const ImportedModel> model;
};
// import_scene, keeping the compiled model (same arguments, same errors).
ImportedScene import_model(std::string_view text, const std::string& file, SceneFormat format);

// Whether `system` (built from `model`'s TOML text, unedited) may be
// linearized at q: throws SceneError naming the element and its line when
// MuJoCo's collision detection finds a contact there, or a ball joint is at
// or beyond its cone limit (hinge and slide limits are the scene's `range`
// keys, checked by the pipeline). Thread-safe (MuJoCo's handlers are
// process-wide: calls are serialized).
void check_imported_configuration(const ImportedModel& model, const System& system, const VectorX& q);

// The version of libmujoco in use, as "2.2.2".
std::string mujoco_version();

}  // namespace modal
