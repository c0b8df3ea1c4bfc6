// A scene as the bytes it was built from: the scene file's text, every mesh
// file it names, and the build settings (simloop/simulation_settings.hpp). A sculpt's
// store and a .sculpt file keep the bundle, so recovery and another machine
// build the same world bit for bit, whatever became of the files since.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "simloop/simulation_settings.hpp"
#include "scene/scene.hpp"

namespace sculpt::daemon {

struct SceneBundle {
  std::string file;  // the scene's path as loaded, or "builtin:default"
  std::string text;  // the scene file
  struct MeshFile {
    std::string source;  // as the scene names it
    std::string bytes;
  };
  std::vector<MeshFile> meshes;
  simloop::SimulationSettings settings;

  std::vector<std::byte> bytes() const;
  // Throws std::invalid_argument naming what is wrong: the format, a size
  // beyond its cap (the scene text 1 MiB, a mesh file 1 GiB, 4096 files, a
  // name 4 KiB), settings outside a config file's ranges (check_settings).
  static SceneBundle from_bytes(std::span<const std::byte> bytes);
};

// Reads the scene file and its mesh files. Throws scene::SceneError /
// files::FileError naming the file.
SceneBundle read_bundle(const std::filesystem::path& scene, const simloop::SimulationSettings& settings);

// The scene, parsed and its meshes loaded from the bundle's own bytes
// (written to a private temporary directory for the importer, removed
// after). Throws scene::SceneError, also for a mesh file the scene does not
// name or one there twice (a bundle from a store holds only the scene's).
scene::Scene load_bundle(const SceneBundle& bundle);

}  // namespace sculpt::daemon
