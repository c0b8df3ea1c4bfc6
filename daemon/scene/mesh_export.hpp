// Save the sculpted shape. Normals are recomputed from the current positions
// (area-weighted per vertex; per facet for STL) because the imported ones
// describe the shape before sculpting.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "sim/triangle_mesh.hpp"

namespace sculpt::scene {

enum class ExportFormat { obj, ply, stl, glb };

// By extension (.obj, .ply, .stl, .glb; case-insensitive), written atomically
// (atomic_file.hpp). Throws ExportError naming the file.
void export_mesh(const sim::TriangleMesh& mesh, const std::filesystem::path& file);

// The file content, for callers that send it elsewhere (and for tests).
std::string encode_mesh(const sim::TriangleMesh& mesh, ExportFormat format);

// Per-vertex unit normals, area-weighted; (0,0,1) where a vertex has no area.
std::vector<sim::Vec3f> vertex_normals(const sim::TriangleMesh& mesh);

}  // namespace sculpt::scene
