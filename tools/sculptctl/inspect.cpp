// `sculptctl inspect FILE [--json]`: loads a mesh or a scene exactly as
// sculptd would (same importer, same isolation, same welding) and reports
// what the simulation will get, without a daemon.
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/conventions.hpp"
#include "commands.hpp"
#include "scene/mesh_import.hpp"
#include "scene/scene.hpp"
#include "scene/scene_world.hpp"
#include "sim/stability.hpp"

namespace sculpt::ctl {
namespace {

namespace fs = std::filesystem;
using scene::Scene;
using scene::SceneMesh;


bool is_scene(const std::string& file) {
  return file.rfind("builtin:", 0) == 0 || fs::path(file).extension() == ".toml";
}

// A lone mesh file is inspected as a one-mesh scene with default settings
// and the chosen material preset.
Scene scene_of_mesh(const InspectArgs& args) {
  Scene s;
  s.file = args.file;
  s.materials = scene::material_presets();
  if (!s.materials.count(args.material)) {
    cli::error("inspect --material: no preset '" + args.material + "' (rubber, clay, jelly)");
    throw CommandFailed{kExitUsage};
  }
  scene::ImportOptions options;
  if (args.weld_tolerance) options.weld_tolerance = *args.weld_tolerance;
  SceneMesh m;
  m.name = fs::path(args.file).stem().string();
  m.source = args.file;
  m.path = args.file;
  m.material = args.material;
  m.loaded = scene::load_mesh(args.file, options);
  s.meshes.push_back(std::move(m));
  return s;
}

std::string fmt_vec(const std::array<float, 3>& v) { return fmt::format("[{:.6g}, {:.6g}, {:.6g}]", v[0], v[1], v[2]); }

std::string_view model_name(sim::ForceModel m) { return m == sim::ForceModel::spring ? "spring" : "linear"; }

void print_text(const Scene& s, const SceneMesh& m, const sim::SubstepChoice& sub) {
  const scene::MeshReport& r = m.loaded.report;
  const sim::Material& mat = s.material_of(m);
  fmt::print("{}  ({})\n", m.name, m.path.empty() ? m.source : m.path.string());
  fmt::print("  vertices {}  edges {}  triangles {}  boundary edges {}  non-manifold edges {}  components {}"
             "  (V-E+F = {})\n",
             r.vertices, r.edges, r.triangles, r.boundary_edges, r.nonmanifold_edges, r.components,
             r.euler_characteristic());
  fmt::print("  bbox {} .. {}\n", fmt_vec(r.bbox_min), fmt_vec(r.bbox_max));
  fmt::print("  import: {} vertices welded away, {} degenerate and {} duplicate triangles dropped, "
             "{} source meshes merged{}\n",
             r.welded_away, r.degenerate_dropped, r.duplicates_dropped, r.source_meshes,
             r.flipped ? ", turned right side out" : "");
  fmt::print("  material {}: {} model, mass {} kg, stiffness {} N/m, damping {} N·s/m, anchor {} N/m{}\n",
             mat.name, model_name(mat.model), mat.mass, mat.stiffness, mat.damping, mat.anchor,
             mat.plastic ? fmt::format(", plastic (yield strain {})", mat.yield_strain) : std::string());
  fmt::print("  substeps {} per tick at {} Hz: substep dt {:.4g} ms; stability bound dt {:.4g} ms "
             "(lambda_max <= {:.4g} 1/s^2, safety {})\n",
             sub.substeps, s.settings.rate_hz, sub.substep_dt * 1e3, sub.bound.dt_critical * 1e3,
             sub.bound.lambda_max_bound, s.settings.substep_safety);
  for (const std::string& w : m.loaded.warnings) fmt::print("  warning: {}\n", w);
}

nlohmann::json to_json(const Scene& s, const SceneMesh& m, const sim::SubstepChoice& sub,
                       const std::vector<std::string>& extra_warnings) {
  const scene::MeshReport& r = m.loaded.report;
  std::vector<std::string> warnings = m.loaded.warnings;
  warnings.insert(warnings.end(), extra_warnings.begin(), extra_warnings.end());
  return {
      {"file", m.path.empty() ? m.source : m.path.string()},
      {"name", m.name},
      {"scene", is_scene(s.file.string()) ? s.file.string() : std::string()},
      {"material", m.material},
      {"material_properties",
       {{"model", model_name(s.material_of(m).model)},
        {"mass", s.material_of(m).mass},
        {"stiffness", s.material_of(m).stiffness},
        {"damping", s.material_of(m).damping},
        {"anchor", s.material_of(m).anchor},
        {"plastic", s.material_of(m).plastic},
        {"yield_strain", s.material_of(m).yield_strain}}},
      {"vertices", r.vertices},
      {"edges", r.edges},
      {"triangles", r.triangles},
      {"boundary_edges", r.boundary_edges},
      {"nonmanifold_edges", r.nonmanifold_edges},
      {"components", r.components},
      {"inconsistent_edges", r.inconsistent_edges},
      {"flipped", r.flipped},
      {"euler_characteristic", r.euler_characteristic()},
      {"bbox_min", r.bbox_min},
      {"bbox_max", r.bbox_max},
      {"welded_away", r.welded_away},
      {"degenerate_dropped", r.degenerate_dropped},
      {"duplicates_dropped", r.duplicates_dropped},
      {"substeps", sub.substeps},
      {"substep_dt", sub.substep_dt},
      {"dt_bound", sub.bound.dt_critical},
      {"lambda_max_bound", sub.bound.lambda_max_bound},
      {"warnings", warnings},
  };
}

}  // namespace

void inspect(const InspectArgs& args) {
  if (args.formats) {
    for (const std::string& ext : scene::import_extensions()) fmt::print("{}\n", ext);
    return;
  }
  if (args.file.empty()) {
    cli::error("inspect: give a mesh or scene FILE (or builtin:default)");
    throw CommandFailed{kExitUsage};
  }
  Scene s;
  std::vector<std::string> unstable;  // per mesh, "" when stable
  try {
    s = is_scene(args.file) ? scene::load_scene(args.file) : scene_of_mesh(args);
    // What sculptd would check before running it, and a short stability probe.
    auto world = scene::build_world(s, s.settings.rate_hz);
    unstable = scene::probe_stability(*world, s);
  } catch (const std::exception& e) {  // LoadError / SceneError: already one line naming the file
    cli::error(e.what());
    throw CommandFailed{kExitCommandFailed};
  }
  if (!args.json) {
    if (is_scene(args.file)) {
      fmt::print("scene {}: {} meshes, {} tools, {} Hz, substeps {}\n", s.file.string(), s.meshes.size(),
                 s.tools.size(), s.settings.rate_hz,
                 s.settings.substeps ? std::to_string(s.settings.substeps) : std::string("auto"));
      for (const scene::SceneTool& t : s.tools) {
        fmt::print("tool {}: {} radius {} m{}, device {}, {} stick\n", t.name, scene::to_string(t.shape), t.radius,
                   t.shape == scene::ToolShape::capsule ? fmt::format(" half length {} m", t.half_length) : "",
                   t.device_name.empty() ? std::to_string(t.device) : "'" + t.device_name + "'",
                   scene::to_string(t.stick));
      }
      for (const std::string& w : s.warnings) fmt::print("warning: {}\n", w);
    }
  } else if (s.meshes.empty()) {
    for (const std::string& w : s.warnings) cli::warning(w);
  }
  for (std::size_t i = 0; i < s.meshes.size(); ++i) {
    const SceneMesh& m = s.meshes[i];
    sim::SubstepChoice sub{};
    std::vector<std::string> extra;
    if (i < unstable.size() && !unstable[i].empty()) extra.push_back(unstable[i]);
    try {
      sub = sim::choose_substeps(m.loaded.mesh, s.material_of(m), s.settings);
    } catch (const std::invalid_argument& e) {
      cli::error(s.file.string() + ": mesh '" + m.name + "': " + e.what());
      throw CommandFailed{kExitCommandFailed};
    }
    if (sub.substeps >= sim::kMaxSubsteps) {
      extra.push_back(fmt::format("material '{}' would need more than {} substeps per tick: it is too stiff or "
                                  "too light for {} Hz",
                                  m.material, sim::kMaxSubsteps, s.settings.rate_hz));
    }
    if (args.json) {
      std::vector<std::string> all = extra;
      all.insert(all.end(), s.warnings.begin(), s.warnings.end());
      std::cout << to_json(s, m, sub, all).dump() << "\n";
    } else {
      print_text(s, m, sub);
      for (const std::string& w : extra) fmt::print("  warning: {}\n", w);
    }
  }
}

}  // namespace sculpt::ctl
