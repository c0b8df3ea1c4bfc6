// Scenes: what to sculpt (meshes and their materials), with what (tools and
// the joystick sticks that drive them) and how (simulation settings). Read
// from TOML files (docs/scene-format.md); the built-in default scene is such
// a file compiled in.
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "sim/limits.hpp"
#include "scene/errors.hpp"
#include "scene/mesh_import.hpp"
#include "sim/material.hpp"
#include "sim/settings.hpp"

namespace sculpt::scene {

using Vec3d = std::array<double, 3>;

// The rates the simulation thread runs at, and how many tools it can drive
// (sim::kMaxTools): a scene outside these is refused where it is read.
inline constexpr double kMinRateHz = 1.0;
inline constexpr double kMaxRateHz = 100000.0;

// Applied as p' = R·(scale ⊙ p) + position, R = Rz·Ry·Rx (degrees about the
// scene's fixed x, then y, then z axes).
struct MeshTransform {
  Vec3d position{0.0, 0.0, 0.0};
  Vec3d rotation_deg{0.0, 0.0, 0.0};
  Vec3d scale{1.0, 1.0, 1.0};
};

struct SceneMesh {
  std::string name;              // unique in the scene
  std::string source;            // as written: a path relative to the scene file, or "builtin:<shape>"
  std::filesystem::path path;    // the resolved file; empty for builtin shapes
  std::string material = "rubber";
  MeshTransform transform;       // already applied to loaded.mesh, kept for reference
  LoadedMesh loaded;             // scene-space positions (empty if SceneOptions::load_meshes is off)
  unsigned line = 0;             // where the [[mesh]] is declared
};

enum class ToolShape { sphere, capsule };

// Which stick of a device moves a tool: a gamepad's left stick (ABS_X/ABS_Y)
// or right stick (ABS_RX/ABS_RY), or the single stick of a 3-axis joystick
// (ABS_X/ABS_Y, with ABS_Z or the throttle for depth).
enum class Stick { left, right, main };

struct SceneTool {
  std::string name;
  ToolShape shape = ToolShape::sphere;
  double radius = 0.02;          // m
  double half_length = 0.04;     // m, capsules: half the distance between the cap centres
  int device = 0;                // index among joysticks in plug-in order...
  std::string device_name;       // ...or, when not empty, the first whose name contains this
  Stick stick = Stick::left;
  Vec3d position{0.0, 0.2, 0.0}; // start position, m
  double speed = 0.5;            // m/s at full deflection
  unsigned line = 0;
};

struct Scene {
  std::filesystem::path file;    // "builtin:default" for the built-in scene
  sim::SimSettings settings;
  std::map<std::string, sim::Material> materials;  // presets plus the scene's own
  std::vector<SceneMesh> meshes;
  std::vector<SceneTool> tools;
  std::vector<std::string> warnings;  // scene-level; per-mesh ones are in meshes[i].loaded.warnings

  const sim::Material& material_of(const SceneMesh& mesh) const { return materials.at(mesh.material); }
};

struct SceneOptions {
  ImportOptions import;
  bool load_meshes = true;  // off: parse and check the file only (meshes stay empty)
  // Where a mesh file named `source` in the scene is read from instead of
  // its path (a sculpt recovered or opened from its own copy of the files).
  std::function<std::filesystem::path(const std::string& source)> locate;
};

// Throws SceneError naming file:line and the key. "builtin:default" loads default_scene().
Scene load_scene(const std::filesystem::path& file, const SceneOptions& options = {});

// Parses scene text; `file` names it in errors and anchors relative paths.
Scene parse_scene(std::string_view text, const std::filesystem::path& file, const SceneOptions& options = {});

// The scene compiled into the binaries: an elastic sphere, a torus and a
// slab of clay, with two tools on a gamepad's two sticks. Needs no files.
Scene default_scene(const SceneOptions& options = {});
std::string_view default_scene_text();

// Material presets every scene starts with: "rubber" (sim::Material's
// defaults), "clay" (plastic) and "jelly" (soft, slow).
std::map<std::string, sim::Material> material_presets();

// Generated meshes for "builtin:<shape>" sources: icosphere, torus, box.
std::vector<std::string> builtin_shapes();

std::string_view to_string(ToolShape shape);
std::string_view to_string(Stick stick);

}  // namespace sculpt::scene
