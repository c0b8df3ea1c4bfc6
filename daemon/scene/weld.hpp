// Welding: turns a triangle soup (what STL, faceted OBJ and most importers
// hand us: one vertex per triangle corner) into a mesh with one vertex per
// position, so the simulation gets one spring per real edge.
#pragma once

#include <cstddef>
#include <optional>
#include <string>

#include "sim/triangle_mesh.hpp"

namespace sculpt::scene {

struct WeldStats {
  std::size_t welded_away = 0;           // input vertices merged into an earlier one
  std::size_t degenerate_dropped = 0;    // triangles with a repeated vertex or ~zero area after welding
  std::size_t duplicates_dropped = 0;    // triangles over the same three vertices as an earlier one
  std::size_t unreferenced_dropped = 0;  // welded vertices no kept triangle uses
};

struct WeldResult {
  sim::TriangleMesh mesh;
  WeldStats stats;
};

// What is wrong with a raw mesh before welding (non-finite coordinates,
// indices out of range, no triangles), or nothing. Checked first so that
// weld() may assume sane input.
std::optional<std::string> find_raw_problem(const sim::TriangleMesh& raw);

// Merges vertices closer than `tolerance` (absolute, per axis and in
// distance; 0 = bit-identical positions only), then drops degenerate and
// duplicate triangles and unreferenced vertices. Deterministic: vertices keep
// the order of their first occurrence, each takes the position of that first
// occurrence, so the same input always gives the same output.
// Precondition: !find_raw_problem(raw).
WeldResult weld(const sim::TriangleMesh& raw, float tolerance);

}  // namespace sculpt::scene
