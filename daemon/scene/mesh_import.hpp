// Mesh files in, clean spring networks out: assimp reads the file (in a
// forked child by default), then we check, weld and measure it.
#pragma once

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "scene/errors.hpp"
#include "scene/mesh_report.hpp"
#include "sim/triangle_mesh.hpp"

namespace sculpt::scene {

struct ImportOptions {
  // Vertices closer than this fraction of the bounding-box diagonal become
  // one. 1e-5 closes STL/OBJ seams written with float precision and never
  // merges real features of a mesh under 100k vertices across.
  double weld_tolerance = 1e-5;
  // Parse in a forked child (see isolation.hpp). Off only where a crash
  // should be seen in-process (debugging, sanitizer runs of our own code).
  bool isolate = true;
  std::chrono::milliseconds timeout{30000};
  std::size_t memory_limit = std::size_t{8} << 30;
};

struct LoadedMesh {
  sim::TriangleMesh mesh;  // welded; vertex order is deterministic for a given file
  MeshReport report;
  std::vector<std::string> warnings;
};

// Throws LoadError naming the file and what is wrong.
LoadedMesh load_mesh(const std::filesystem::path& file, const ImportOptions& options = {});

// The same pipeline over bytes in memory; `format_hint` is an extension
// ("stl") or empty to let assimp sniff the content. `name` is used in errors.
LoadedMesh load_mesh_from_memory(std::span<const std::byte> bytes, const std::string& format_hint,
                                 const std::filesystem::path& name, const ImportOptions& options = {});

// Check, weld and measure a triangle soup (what every loader ends in; also
// used for generated shapes). Throws LoadError naming `name`.
LoadedMesh clean_mesh(const sim::TriangleMesh& raw, const std::filesystem::path& name,
                      const ImportOptions& options = {}, std::size_t skipped_primitives = 0,
                      std::size_t source_meshes = 1);

// Extensions (lower case, no dot) load_mesh reads.
std::vector<std::string> import_extensions();

}  // namespace sculpt::scene
