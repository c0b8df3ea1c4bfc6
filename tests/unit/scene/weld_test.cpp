#include "scene/weld.hpp"

#include <gtest/gtest.h>

#include "scene/mesh_import.hpp"
#include "scene/mesh_report.hpp"
#include "sim/shapes.hpp"

namespace sculpt::scene {
namespace {

using sim::TriangleMesh;

// The triangle soup of a mesh: three fresh vertices per triangle, like STL.
TriangleMesh soup_of(const TriangleMesh& m) {
  TriangleMesh s;
  for (const sim::Triangle& t : m.triangles) {
    const auto base = static_cast<std::uint32_t>(s.positions.size());
    for (std::uint32_t v : t) s.positions.push_back(m.positions[v]);
    s.triangles.push_back({base, base + 1, base + 2});
  }
  return s;
}

TEST(Weld, SoupOfAClosedSphereWeldsBackToTheSphere) {
  const TriangleMesh sphere = sim::make_icosphere(0.1f, 2);
  const WeldResult w = weld(soup_of(sphere), 1e-6f);
  EXPECT_EQ(w.mesh.positions.size(), sphere.positions.size());
  EXPECT_EQ(w.mesh.triangles.size(), sphere.triangles.size());
  EXPECT_EQ(w.stats.welded_away, 3 * sphere.triangles.size() - sphere.positions.size());
  MeshReport r;
  measure(w.mesh, r);
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_EQ(r.nonmanifold_edges, 0u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.euler_characteristic(), 2);
}

TEST(Weld, MergesWithinToleranceOnlyAndKeepsTheFirstPosition) {
  TriangleMesh raw;
  raw.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1.0000001f, 0, 0}, {1, 1, 0}, {0, 1.01f, 0}};
  raw.triangles = {{0, 1, 2}, {3, 4, 5}};
  const WeldResult w = weld(raw, 1e-4f);
  ASSERT_EQ(w.mesh.positions.size(), 5u);  // vertex 3 joins vertex 1; 5 is 0.01 from 2: kept apart
  EXPECT_EQ(w.stats.welded_away, 1u);
  EXPECT_EQ(w.mesh.positions[1], (sim::Vec3f{1, 0, 0}));
  EXPECT_EQ(w.mesh.triangles[1][0], 1u);
}

TEST(Weld, ToleranceZeroMergesBitIdenticalPositionsOnly) {
  TriangleMesh raw;
  raw.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1.0000001f, 0}, {-0.0f, 0, 0}};
  raw.triangles = {{0, 1, 2}, {3, 4, 5}, {6, 4, 3}};
  const WeldResult w = weld(raw, 0.0f);
  EXPECT_EQ(w.stats.welded_away, 2u);  // 3 = 1 and -0 = +0
  EXPECT_EQ(w.mesh.positions.size(), 5u);
}

TEST(Weld, DropsDegenerateDuplicateTrianglesAndUnusedVertices) {
  TriangleMesh raw;
  raw.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {5, 5, 5}, {0, 0, 0}};
  raw.triangles = {
      {0, 1, 2},  // kept
      {0, 1, 3},  // collinear: zero area
      {0, 5, 1},  // repeated corner after welding (5 == 0)
      {2, 1, 0},  // the first one, other winding: duplicate
  };
  const WeldResult w = weld(raw, 1e-6f);
  EXPECT_EQ(w.mesh.triangles.size(), 1u);
  EXPECT_EQ(w.stats.degenerate_dropped, 2u);
  EXPECT_EQ(w.stats.duplicates_dropped, 1u);
  EXPECT_EQ(w.stats.unreferenced_dropped, 2u);  // (2,0,0) and (5,5,5)
  EXPECT_EQ(w.mesh.positions.size(), 3u);
}

TEST(Weld, IsDeterministic) {
  const TriangleMesh soup = soup_of(sim::make_torus(0.1f, 0.03f, 30, 16));
  const WeldResult a = weld(soup, 1e-6f);
  const WeldResult b = weld(soup, 1e-6f);
  EXPECT_EQ(a.mesh.positions, b.mesh.positions);
  EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
}

TEST(Weld, MatchesAcrossCellBoundaries) {
  // Points straddling a cell edge (cells are tolerance-sized) must still weld.
  const float tol = 0.01f;
  TriangleMesh raw;
  raw.positions = {{0.0099f, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.0101f, 0, 0}, {1, 1, 0}, {0, 2, 0}};
  raw.triangles = {{0, 1, 2}, {3, 4, 5}};
  EXPECT_EQ(weld(raw, tol).stats.welded_away, 1u);
}

TEST(RawProblems, NamesTheVertexOrTriangle) {
  TriangleMesh raw;
  raw.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  raw.triangles = {{0, 1, 2}};
  EXPECT_FALSE(find_raw_problem(raw));
  raw.triangles.push_back({0, 1, 3});
  EXPECT_EQ(find_raw_problem(raw).value_or(""), "triangle 1 refers to vertex 3 but there are only 3 vertices");
  raw.triangles.pop_back();
  raw.positions[1][2] = std::numeric_limits<float>::infinity();
  EXPECT_NE(find_raw_problem(raw).value_or("").find("vertex 1 has a non-finite coordinate"), std::string::npos);
  EXPECT_EQ(find_raw_problem(TriangleMesh{}).value_or(""), "the file holds no triangles");
}

TEST(CleanMesh, ReportsRepairsAsWarnings) {
  TriangleMesh raw;
  raw.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}};
  raw.triangles = {{0, 1, 2}, {0, 1, 3}};
  const LoadedMesh m = clean_mesh(raw, "mem.obj");
  EXPECT_EQ(m.report.degenerate_dropped, 1u);
  EXPECT_EQ(m.report.boundary_edges, 3u);
  bool open = false, degenerate = false;
  for (const auto& w : m.warnings) {
    open |= w.find("open surface: 3 boundary edges") != std::string::npos;
    degenerate |= w.find("dropped 1 degenerate") != std::string::npos;
  }
  EXPECT_TRUE(open);
  EXPECT_TRUE(degenerate);
}

TEST(MeshReport, CountsComponentsAndNonManifoldEdges) {
  TriangleMesh m;
  // Three triangles sharing the edge 0-1 (a "book"), and a separate triangle.
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {5, 5, 5}, {6, 5, 5}, {5, 6, 5}};
  m.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}, {5, 6, 7}};
  MeshReport r;
  measure(m, r);
  EXPECT_EQ(r.nonmanifold_edges, 1u);
  EXPECT_EQ(r.components, 2u);
  EXPECT_EQ(r.bbox_min, (std::array<float, 3>{0, -1, 0}));
  EXPECT_EQ(r.bbox_max, (std::array<float, 3>{6, 6, 5}));
}

}  // namespace
}  // namespace sculpt::scene

namespace sculpt::scene {
namespace {

TEST(CleanMesh, TurnsAnInsideOutSurface) {
  sim::TriangleMesh m = sim::make_icosphere(1.0f, 1);
  for (sim::Triangle& t : m.triangles) std::swap(t[0], t[1]);
  ASSERT_LT(sim::signed_volume(m), 0.0);
  const LoadedMesh out = clean_mesh(m, "inside_out.obj");
  EXPECT_TRUE(out.report.flipped);
  EXPECT_GT(sim::signed_volume(out.mesh), 0.0);
  ASSERT_EQ(out.warnings.size(), 1u);
  EXPECT_NE(out.warnings[0].find("inside out"), std::string::npos);
  EXPECT_FALSE(clean_mesh(sim::make_icosphere(1.0f, 1), "fine.obj").report.flipped);
}

TEST(CleanMesh, ReportsInconsistentWinding) {
  sim::TriangleMesh m = sim::make_icosphere(1.0f, 1);
  std::swap(m.triangles[0][0], m.triangles[0][1]);  // one face turned: its 3 edges disagree
  const LoadedMesh out = clean_mesh(m, "patchy.obj");
  EXPECT_EQ(out.report.inconsistent_edges, 3u);
  EXPECT_FALSE(out.report.flipped);
  ASSERT_FALSE(out.warnings.empty());
  EXPECT_NE(out.warnings[0].find("inconsistent winding on 3 edges"), std::string::npos);
}

}  // namespace
}  // namespace sculpt::scene
