// The only place that talks to assimp. It hands back a triangle soup with
// node transforms baked in; welding and checking happen elsewhere, outside
// the (possibly isolated) importer.
#pragma once

#include <cstddef>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "sim/triangle_mesh.hpp"

namespace sculpt::scene {

struct RawImport {
  sim::TriangleMesh mesh;              // unwelded: as the importer produced it
  std::size_t skipped_primitives = 0;  // points and lines
  std::size_t source_meshes = 0;       // assimp meshes merged into `mesh`
  std::vector<std::string> importer_warnings;  // what assimp logged as warnings and errors
};

// Throw std::runtime_error with assimp's own message on failure.
RawImport read_with_assimp(const std::filesystem::path& file);
RawImport read_with_assimp(std::span<const std::byte> bytes, const std::string& format_hint);

// Lower-case extension without the dot ("stl"), as assimp's importers claim them.
bool assimp_reads_extension(const std::string& extension);
std::vector<std::string> assimp_import_extensions();

}  // namespace sculpt::scene
