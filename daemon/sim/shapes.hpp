// Procedural meshes: the built-in default scene, tests and benchmarks.
// All are closed, consistently oriented (counter-clockwise seen from outside)
// and welded (each position appears once). Throw std::invalid_argument on
// parameters that cannot make such a mesh.
#pragma once

#include <array>

#include "sim/triangle_mesh.hpp"

namespace sculpt::sim {

// Subdivided icosahedron on a sphere: 10·4^n + 2 vertices (n = 7 → 163842). n in [0, 9].
TriangleMesh make_icosphere(float radius, int subdivisions);

// Torus around the y axis: rings × sides vertices, rings, sides >= 3, 0 < minor < major.
TriangleMesh make_torus(float major_radius, float minor_radius, int rings, int sides);

// Closed box centred at the origin, each face a cells × cells grid of quads
// (two triangles each): a clay slab. cells_per_axis in [1, 1024].
TriangleMesh make_box_grid(std::array<float, 3> size, int cells_per_axis);

// Signed volume (divergence theorem): > 0 for a closed outward-oriented mesh.
double signed_volume(const TriangleMesh& mesh);

}  // namespace sculpt::sim
