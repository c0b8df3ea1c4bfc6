// What a loaded mesh looks like to the simulation: counts that tell whether it
// is a closed surface, how much the import had to repair, and its extent.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "sim/triangle_mesh.hpp"

namespace sculpt::scene {

struct MeshReport {
  std::size_t vertices = 0;
  std::size_t edges = 0;               // unique edges = springs
  std::size_t triangles = 0;
  std::size_t boundary_edges = 0;      // used by one triangle: the mesh is open there
  std::size_t nonmanifold_edges = 0;   // used by three or more triangles
  std::size_t components = 0;          // pieces connected through edges
  std::size_t inconsistent_edges = 0;  // two triangles run along it the same way: winding flips there
  std::array<float, 3> bbox_min{0, 0, 0};
  std::array<float, 3> bbox_max{0, 0, 0};
  // What the import repaired (see weld.hpp).
  std::size_t welded_away = 0;
  std::size_t degenerate_dropped = 0;
  std::size_t duplicates_dropped = 0;
  std::size_t unreferenced_dropped = 0;
  std::size_t skipped_primitives = 0;  // points and lines in the file: not part of a surface
  bool flipped = false;                // the closed surface was inside out and got turned
  std::size_t source_meshes = 0;       // meshes merged into this one (as assimp groups them: by material)

  // V - E + F: 2 for a closed sphere-like surface, per component.
  long long euler_characteristic() const {
    return static_cast<long long>(vertices) - static_cast<long long>(edges) +
           static_cast<long long>(triangles);
  }
};

// Fills the geometric counts of `report` (vertices .. bbox) from `mesh`,
// leaving the repair counts as they are.
void measure(const sim::TriangleMesh& mesh, MeshReport& report);

// One readable sentence per thing a user should know about (open or
// non-manifold surface, several pieces, repairs made).
std::vector<std::string> describe_problems(const MeshReport& report);

}  // namespace sculpt::scene
