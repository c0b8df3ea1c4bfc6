#include "scene/mesh_export.hpp"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <random>
#include <cstring>
#include <sstream>

#include <gtest/gtest.h>

#include "files/atomic_file.hpp"
#include "scene/errors.hpp"
#include "scene/mesh_import.hpp"
#include "sim/shapes.hpp"
#include "test_data.hpp"

namespace sculpt::scene {
namespace {

using testing::error_of;
using testing::TempDir;

// A "sculpted" sphere: dented on one side, so exported normals must come from
// these positions, not from any sphere.
sim::TriangleMesh sculpted_sphere() {
  sim::TriangleMesh m = sim::make_icosphere(0.1f, 2);
  for (sim::Vec3f& p : m.positions) {
    if (p[0] > 0.05f) p[0] = 0.05f + (p[0] - 0.05f) * 0.3f;
  }
  return m;
}

float distance(const sim::Vec3f& a, const sim::Vec3f& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

class RoundTrip : public ::testing::TestWithParam<const char*> {};

// import → export → import keeps counts and positions (each vertex finds
// itself, exactly for these float formats), and the topology.
TEST_P(RoundTrip, KeepsCountsAndPositions) {
  TempDir dir;
  const sim::TriangleMesh original = sculpted_sphere();
  const LoadedMesh first = clean_mesh(original, "generated");
  const auto file = dir / (std::string("out.") + GetParam());
  export_mesh(first.mesh, file);
  const LoadedMesh second = load_mesh(file);
  EXPECT_EQ(second.report.vertices, first.report.vertices);
  EXPECT_EQ(second.report.edges, first.report.edges);
  EXPECT_EQ(second.report.triangles, first.report.triangles);
  EXPECT_EQ(second.report.boundary_edges, 0u);
  EXPECT_EQ(second.report.euler_characteristic(), 2);
  // Vertex order may change (STL stores corners per triangle): match by position.
  for (const sim::Vec3f& p : first.mesh.positions) {
    float best = 1e9f;
    for (const sim::Vec3f& q : second.mesh.positions) best = std::min(best, distance(p, q));
    EXPECT_LE(best, 1e-7f);
  }
  // And exporting what we read gives the same bytes again: nothing drifts.
  const auto again = dir / (std::string("again.") + GetParam());
  export_mesh(load_mesh(file).mesh, again);
  export_mesh(load_mesh(again).mesh, dir / (std::string("third.") + GetParam()));
  EXPECT_EQ(testing::read_file(again), testing::read_file(dir / (std::string("third.") + GetParam())));
}

INSTANTIATE_TEST_SUITE_P(Formats, RoundTrip, ::testing::Values("obj", "ply", "stl", "glb"));

TEST(Export, ExtensionIsCaseInsensitive) {
  TempDir dir;
  export_mesh(sim::make_icosphere(1.0f, 0), dir / "SHOUT.STL");
  EXPECT_EQ(load_mesh(dir / "SHOUT.STL").report.vertices, 12u);
}

TEST(Export, NormalsFollowTheSculptedShape) {
  const sim::TriangleMesh m = sculpted_sphere();
  const std::vector<sim::Vec3f> n = vertex_normals(m);
  ASSERT_EQ(n.size(), m.positions.size());
  for (std::size_t i = 0; i < n.size(); ++i) {
    EXPECT_NEAR(std::sqrt(n[i][0] * n[i][0] + n[i][1] * n[i][1] + n[i][2] * n[i][2]), 1.0, 1e-5);
    // Outward everywhere, and straight along +x in the middle of the flattened cap.
    EXPECT_GT(n[i][0] * m.positions[i][0] + n[i][1] * m.positions[i][1] + n[i][2] * m.positions[i][2], 0.0f);
    if (m.positions[i][0] > 0.05f && std::abs(m.positions[i][1]) < 1e-6f && std::abs(m.positions[i][2]) < 1e-6f) {
      EXPECT_GT(n[i][0], 0.99f);
    }
  }
  // The OBJ carries exactly those normals, one per vertex.
  const std::string obj = encode_mesh(m, ExportFormat::obj);
  std::istringstream in(obj);
  std::string line;
  std::size_t vn = 0;
  while (std::getline(in, line)) {
    if (line.rfind("vn ", 0) != 0) continue;
    std::istringstream f(line.substr(3));
    sim::Vec3f v{};
    f >> v[0] >> v[1] >> v[2];
    EXPECT_EQ(v, n[vn]) << vn;
    ++vn;
  }
  EXPECT_EQ(vn, m.positions.size());
}

TEST(Export, StlFacetNormalsAreRecomputed) {
  sim::TriangleMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 2}};
  const std::string stl = encode_mesh(m, ExportFormat::stl);
  ASSERT_EQ(stl.size(), 84u + 50u);
  EXPECT_NE(stl.rfind("solid", 0), 0u);  // a binary STL must not look like ASCII
  float normal[3];
  std::memcpy(normal, stl.data() + 84, sizeof normal);
  EXPECT_EQ(normal[0], 0.0f);
  EXPECT_EQ(normal[1], 0.0f);
  EXPECT_EQ(normal[2], 1.0f);
}

TEST(Export, ReplacesAnExistingFileAndLeavesNoTempFiles) {
  TempDir dir;
  const auto file = dir.write("mesh.obj", "old content");
  export_mesh(sim::make_icosphere(1.0f, 1), file);
  EXPECT_EQ(load_mesh(file).report.vertices, 42u);
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++entries;
  EXPECT_EQ(entries, 1u);
  EXPECT_EQ(std::filesystem::status(file).permissions() & std::filesystem::perms::others_read,
            std::filesystem::perms::others_read);
}

TEST(Export, AFailedWriteLeavesTheOldFileAndNoTemp) {
  TempDir dir;
  // The target is a directory: rename must fail after the temp file was written.
  std::filesystem::create_directories(dir / "taken.stl" / "inside");
  const std::string msg = error_of<ExportError>([&] { export_mesh(sim::make_icosphere(1.0f, 0), dir / "taken.stl"); });
  EXPECT_NE(msg.find("taken.stl: cannot replace the file"), std::string::npos) << msg;
  EXPECT_TRUE(std::filesystem::is_directory(dir / "taken.stl" / "inside"));
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++entries;
  EXPECT_EQ(entries, 1u);
}

TEST(Export, BadRequestsNameTheFile) {
  TempDir dir;
  const sim::TriangleMesh m = sim::make_icosphere(1.0f, 0);
  EXPECT_NE(error_of<ExportError>([&] { export_mesh(m, dir / "mesh.fbx"); }).find("unknown export format '.fbx'"),
            std::string::npos);
  EXPECT_NE(error_of<ExportError>([&] { export_mesh(m, dir / "no" / "dir.obj"); }).find("cannot create a file in"),
            std::string::npos);
  sim::TriangleMesh broken = m;
  broken.positions[3][1] = NAN;
  EXPECT_NE(error_of<ExportError>([&] { export_mesh(broken, dir / "nan.ply"); }).find("non-finite"),
            std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir / "nan.ply"));
}

TEST(AtomicFile, AWriterKilledAtAnyMomentLeavesTheOldOrTheNewFile) {
  TempDir dir;
  const auto file = dir / "scene.stl";
  const std::string old_bytes(1 << 20, 'o');
  const std::string new_bytes(24 << 20, 'n');  // big enough that kills land mid-write
  std::mt19937 rng(42);
  int saw_old = 0, saw_new = 0;
  for (int round = 0; round < 16; ++round) {
    files::write_file_atomically(file, old_bytes);
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      files::write_file_atomically(file, new_bytes);
      ::_exit(0);
    }
    ::usleep(std::uniform_int_distribution<int>(0, 40000)(rng));
    ::kill(pid, SIGKILL);
    ::waitpid(pid, nullptr, 0);
    const std::string now = testing::read_file(file);
    ASSERT_TRUE(now == old_bytes || now == new_bytes) << "round " << round << ": " << now.size() << " bytes";
    (now == old_bytes ? saw_old : saw_new)++;
    // A killed writer may leave its temporary behind (never the target): clean up for the next round.
    for (const auto& e : std::filesystem::directory_iterator(dir.path()))
      if (e.path() != file) std::filesystem::remove(e.path());
  }
  RecordProperty("old", saw_old);
  RecordProperty("new", saw_new);
}

TEST(AtomicFile, WritesExactlyTheBytes) {
  TempDir dir;
  const std::string bytes("a\0b\nc", 5);
  files::write_file_atomically(dir / "x.bin", bytes);
  EXPECT_EQ(testing::read_file(dir / "x.bin"), bytes);
}

}  // namespace
}  // namespace sculpt::scene
