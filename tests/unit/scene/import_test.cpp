#include "scene/mesh_import.hpp"

#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <cmath>
#include <variant>

#include <gtest/gtest.h>

#include "scene/isolation.hpp"
#include "scene/raw_blob.hpp"
#include "test_data.hpp"

namespace sculpt::scene {
namespace {

using testing::data_dir;
using testing::error_of;
using testing::mesh_file;

struct Expected {
  const char* file;
  std::size_t vertices, edges, triangles;
};

class EveryFormat : public ::testing::TestWithParam<Expected> {};

// The same icosphere in every format must come out as the same closed mesh:
// STL and faceted OBJ included (they only close because we weld).
TEST_P(EveryFormat, LoadsAClosedWeldedSphere) {
  const Expected& e = GetParam();
  const LoadedMesh m = load_mesh(mesh_file(e.file));
  EXPECT_EQ(m.report.vertices, e.vertices);
  EXPECT_EQ(m.report.edges, e.edges);
  EXPECT_EQ(m.report.triangles, e.triangles);
  EXPECT_EQ(m.report.boundary_edges, 0u);
  EXPECT_EQ(m.report.nonmanifold_edges, 0u);
  EXPECT_EQ(m.report.components, 1u);
  EXPECT_EQ(m.report.euler_characteristic(), 2);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(m.report.bbox_min[k], -0.1f, 1e-6);
    EXPECT_NEAR(m.report.bbox_max[k], 0.1f, 1e-6);
  }
  for (const sim::Vec3f& p : m.mesh.positions) {
    EXPECT_NEAR(std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]), 0.1, 1e-6);
  }
  EXPECT_TRUE(m.warnings.empty()) << m.warnings.front();
}

INSTANTIATE_TEST_SUITE_P(Formats, EveryFormat,
                         ::testing::Values(Expected{"icosphere.obj", 162, 480, 320},
                                           Expected{"icosphere_faceted.obj", 162, 480, 320},
                                           Expected{"icosphere_ascii.ply", 162, 480, 320},
                                           Expected{"icosphere_binary.ply", 162, 480, 320},
                                           Expected{"icosphere_ascii.stl", 42, 120, 80},
                                           Expected{"icosphere_binary.stl", 162, 480, 320},
                                           Expected{"icosphere.off", 162, 480, 320},
                                           Expected{"icosphere.glb", 162, 480, 320}),
                         [](const auto& info) {
                           std::string n = info.param.file;
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

TEST(Import, FacetedFilesNeedOurWeld) {
  // Bit-exact welding only: the faceted sphere still closes (its corners are
  // written identically); a zero tolerance is the floor, not the fix.
  ImportOptions exact;
  exact.weld_tolerance = 0.0;
  EXPECT_EQ(load_mesh(mesh_file("icosphere_faceted.obj"), exact).report.boundary_edges, 0u);
  EXPECT_EQ(load_mesh(mesh_file("icosphere_binary.stl"), exact).report.welded_away, 3u * 320 - 162);
}

TEST(Import, GltfNodeTransformIsBaked) {
  // Unit cube, node: scale 2, rotate 90° about z, translate (1, 2, 3).
  const LoadedMesh m = load_mesh(mesh_file("cube_node_transform.gltf"));
  EXPECT_EQ(m.report.vertices, 8u);
  EXPECT_EQ(m.report.triangles, 12u);
  EXPECT_EQ(m.report.boundary_edges, 0u);
  const std::array<float, 3> lo{0, 1, 2}, hi{2, 3, 4};
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(m.report.bbox_min[k], lo[k], 1e-5);
    EXPECT_NEAR(m.report.bbox_max[k], hi[k], 1e-5);
  }
}

TEST(Import, GltfWithAnExternalBufferFindsIt) {
  const LoadedMesh m = load_mesh(mesh_file("cube_external.gltf"));
  EXPECT_EQ(m.report.vertices, 8u);
  EXPECT_EQ(m.report.boundary_edges, 0u);
  EXPECT_NEAR(m.report.bbox_min[2], -5.5f, 1e-6);
  EXPECT_NEAR(m.report.bbox_max[2], -4.5f, 1e-6);
}

TEST(Import, SeveralMeshesInOneFileBecomeOneBodyWithComponents) {
  const LoadedMesh m = load_mesh(mesh_file("two_cubes.obj"));
  EXPECT_EQ(m.report.vertices, 16u);
  EXPECT_EQ(m.report.components, 2u);
  EXPECT_EQ(m.report.euler_characteristic(), 4);
  ASSERT_EQ(m.warnings.size(), 1u);
  EXPECT_EQ(m.warnings[0], "2 separate pieces: they move independently");
}

TEST(Import, OpenSurfaceCountsItsBoundary) {
  const LoadedMesh m = load_mesh(mesh_file("open_grid.obj"));
  EXPECT_EQ(m.report.vertices, 25u);
  EXPECT_EQ(m.report.triangles, 32u);
  EXPECT_EQ(m.report.boundary_edges, 16u);
  EXPECT_EQ(m.report.euler_characteristic(), 1);
}

TEST(Import, SameFileGivesTheSameVertexOrder) {
  const LoadedMesh a = load_mesh(mesh_file("icosphere_binary.stl"));
  const LoadedMesh b = load_mesh(mesh_file("icosphere_binary.stl"));
  EXPECT_EQ(a.mesh.positions, b.mesh.positions);
  EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
}

TEST(Import, IsolatedAndInProcessAgree) {
  ImportOptions in_process;
  in_process.isolate = false;
  for (const char* f : {"icosphere.glb", "icosphere_faceted.obj", "two_cubes.obj"}) {
    const LoadedMesh a = load_mesh(mesh_file(f));
    const LoadedMesh b = load_mesh(mesh_file(f), in_process);
    EXPECT_EQ(a.mesh.positions, b.mesh.positions) << f;
    EXPECT_EQ(a.mesh.triangles, b.mesh.triangles) << f;
    EXPECT_EQ(a.warnings, b.warnings) << f;
  }
}

TEST(Import, FromMemorySniffsTheFormat) {
  const std::string bytes = testing::read_file(mesh_file("icosphere_binary.ply"));
  const auto* p = reinterpret_cast<const std::byte*>(bytes.data());
  const LoadedMesh m = load_mesh_from_memory({p, bytes.size()}, "", "memory");
  EXPECT_EQ(m.report.vertices, 162u);
}

// Each bad file: one LoadError whose message names the file and the problem.
struct BadFile {
  const char* file;
  const char* says;
};
class BadInput : public ::testing::TestWithParam<BadFile> {};

TEST_P(BadInput, GivesOneClearError) {
  const auto path = data_dir() / "bad" / GetParam().file;
  for (bool isolate : {true, false}) {
    ImportOptions options;
    options.isolate = isolate;
    const std::string msg = error_of<LoadError>([&] { load_mesh(path, options); });
    EXPECT_EQ(msg.rfind(path.string() + ": ", 0), 0u) << msg;
    EXPECT_NE(msg.find(GetParam().says), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Files, BadInput,
    ::testing::Values(BadFile{"nan.obj", "vertex 2 has a non-finite coordinate"},
                      BadFile{"inf.ply", "vertex 2 has a non-finite coordinate"},
                      BadFile{"index_out_of_range.ply", "out of range"},
                      BadFile{"empty.stl", "the file is empty"},
                      BadFile{"no_triangles.obj", "no faces"},
                      BadFile{"all_degenerate.stl", "all 2 triangles are degenerate"},
                      BadFile{"unknown_format.xyz", "unknown mesh format '.xyz'"},
                      BadFile{"truncated.glb", "damaged, truncated, or mislabelled"},
                      BadFile{"no_such_file.obj", "no such file"}),
    [](const auto& info) {
      std::string n = info.param.file;
      for (char& c : n)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return n;
    });

TEST(Import, IndexTheImporterClampedIsAnError) {
  // assimp clamps an out-of-range OFF index instead of failing; the face
  // would silently hang off the wrong vertex, so the load fails and says why.
  EXPECT_EQ(error_of<LoadError>([&] { load_mesh(data_dir() / "bad" / "index_out_of_range.off"); }),
            (data_dir() / "bad" / "index_out_of_range.off").string() +
                ": a face refers to a vertex index out of range (assimp: OFF: Vertex index is out of range)");
}

TEST(Import, DirectoryIsNotAMesh) {
  EXPECT_NE(error_of<LoadError>([&] { load_mesh(data_dir()); }).find("is a directory"), std::string::npos);
}

TEST(Import, ExtensionsIncludeTheCommonFormats) {
  const auto exts = import_extensions();
  for (const char* e : {"obj", "ply", "stl", "gltf", "glb", "off"}) {
    EXPECT_NE(std::find(exts.begin(), exts.end(), e), exts.end()) << e;
  }
}

// The isolation itself: what a crashing, hanging or throwing importer costs.
TEST(Isolation, ACrashBecomesAFailure) {
  ChildLimits limits;
  auto r = run_in_child([]() -> std::vector<std::byte> {
    ::raise(SIGSEGV);
    return {};
  }, limits);
  ASSERT_TRUE(std::holds_alternative<ChildFailure>(r));
  EXPECT_NE(std::get<ChildFailure>(r).what.find("crashed (signal 11"), std::string::npos);
}

TEST(Isolation, TheCallersBlockedSignalsDoNotCarryOver) {
  // A daemon blocks signals for its signalfd; the importer child must not inherit that.
  sigset_t block, old;
  sigemptyset(&block);
  sigaddset(&block, SIGSEGV);
  ASSERT_EQ(::pthread_sigmask(SIG_BLOCK, &block, &old), 0);
  auto r = run_in_child([]() -> std::vector<std::byte> {
    ::raise(SIGSEGV);  // stays pending (and the child returns normally) if SIGSEGV is still blocked
    return {};
  }, {});
  ::pthread_sigmask(SIG_SETMASK, &old, nullptr);
  ASSERT_TRUE(std::holds_alternative<ChildFailure>(r));
  EXPECT_NE(std::get<ChildFailure>(r).what.find("crashed (signal 11"), std::string::npos);
}

TEST(Isolation, AHangIsStoppedAtTheDeadline) {
  ChildLimits limits;
  limits.timeout = std::chrono::milliseconds(200);
  auto r = run_in_child([]() -> std::vector<std::byte> {
    for (;;) ::pause();
  }, limits);
  ASSERT_TRUE(std::holds_alternative<ChildFailure>(r));
  EXPECT_EQ(std::get<ChildFailure>(r).what, "the importer did not finish within 0.2 s and was stopped");
}

TEST(Isolation, AnExceptionCarriesItsMessage) {
  auto r = run_in_child([]() -> std::vector<std::byte> { throw std::runtime_error("bad header"); }, {});
  ASSERT_TRUE(std::holds_alternative<ChildFailure>(r));
  EXPECT_EQ(std::get<ChildFailure>(r).what, "bad header");
}

TEST(Isolation, ResultsComeBackWhole) {
  std::vector<std::byte> big(3'000'000);
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = std::byte(i * 7);
  auto r = run_in_child([&] { return big; }, {});
  ASSERT_TRUE(std::holds_alternative<std::vector<std::byte>>(r));
  EXPECT_EQ(std::get<std::vector<std::byte>>(r), big);
}

TEST(RawBlob, RoundTripsAndRejectsBadSizes) {
  RawImport raw;
  raw.mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  raw.mesh.triangles = {{0, 1, 2}};
  raw.skipped_primitives = 4;
  raw.source_meshes = 2;
  raw.importer_warnings = {"one", "two"};
  std::vector<std::byte> blob = encode_raw(raw);
  const RawImport back = decode_raw(blob);
  EXPECT_EQ(back.mesh.positions, raw.mesh.positions);
  EXPECT_EQ(back.mesh.triangles, raw.mesh.triangles);
  EXPECT_EQ(back.skipped_primitives, 4u);
  EXPECT_EQ(back.source_meshes, 2u);
  EXPECT_EQ(back.importer_warnings, raw.importer_warnings);
  blob.pop_back();
  EXPECT_THROW(decode_raw(blob), std::runtime_error);
  EXPECT_THROW(decode_raw(std::span<const std::byte>(blob.data(), 10)), std::runtime_error);
}

}  // namespace
}  // namespace sculpt::scene
