// The viewer's CPU side: dirty ranges, normals recomputed around a delta
// (equal to a full recomputation), errors named, options parsed, PNG files.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "app/options.hpp"
#include "gl/png_io.hpp"
#include "render/camera.hpp"
#include "render/font.hpp"
#include "render/model.hpp"

namespace sculpt::view {
namespace {

// An n x n grid of vertices in the xz plane, two triangles per cell, facing +y.
ViewMesh grid(std::uint32_t n) {
  std::vector<float> xyz;
  std::vector<std::uint32_t> tris;
  for (std::uint32_t z = 0; z < n; ++z) {
    for (std::uint32_t x = 0; x < n; ++x) xyz.insert(xyz.end(), {static_cast<float>(x), 0.0f, static_cast<float>(z)});
  }
  for (std::uint32_t z = 0; z + 1 < n; ++z) {
    for (std::uint32_t x = 0; x + 1 < n; ++x) {
      const std::uint32_t a = z * n + x, b = a + 1, c = a + n, d = c + 1;
      tris.insert(tris.end(), {a, c, b, b, c, d});
    }
  }
  return ViewMesh(7, "grid", "rubber", tris, xyz, xyz);
}

TEST(ViewerRanges, MergesRunsAndSmallGaps) {
  const std::vector<std::uint32_t> idx = {1, 2, 3, 3, 7, 20, 21, 40};
  EXPECT_EQ(to_ranges(idx, 0), (std::vector<Range>{{1, 4}, {7, 8}, {20, 22}, {40, 41}}));
  EXPECT_EQ(to_ranges(idx, 3), (std::vector<Range>{{1, 8}, {20, 22}, {40, 41}}));
  EXPECT_TRUE(to_ranges({}, 5).empty());
}

TEST(ViewerMesh, FlatGridNormalsPointUp) {
  ViewMesh m = grid(5);
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    EXPECT_NEAR(m.normals()[v * 3 + 1], 1.0f, 1e-6f) << v;
  }
  const auto d = m.take_dirty();
  EXPECT_TRUE(d.all);
  EXPECT_FALSE(m.dirty());
}

TEST(ViewerMesh, DeltaRecomputesNormalsAroundItAndMarksOnlyThatRegion) {
  ViewMesh m = grid(10);
  m.take_dirty();
  const std::uint32_t v = 5 * 10 + 5;
  const std::vector<std::uint32_t> idx = {v};
  const std::vector<float> up = {5.0f, 1.0f, 5.0f};
  m.set_positions(idx, up);
  // A neighbour now leans away from the raised vertex; a far vertex is untouched.
  EXPECT_LT(m.normals()[(v + 1) * 3 + 1], 0.99f);
  EXPECT_GT(m.normals()[(v + 1) * 3 + 0], 0.1f);
  EXPECT_NEAR(m.normals()[0 * 3 + 1], 1.0f, 1e-6f);
  const auto d = m.take_dirty(0);
  EXPECT_FALSE(d.all);
  std::uint32_t count = 0;
  for (const auto& r : d.ranges) {
    count += r.end - r.begin;
    EXPECT_GE(r.begin, v - 11);
    EXPECT_LE(r.end, v + 12);
  }
  EXPECT_EQ(count, 7u);   // the vertex and its 6 neighbours in this triangulation
  EXPECT_FALSE(m.dirty());
}

TEST(ViewerMesh, IncrementalNormalsEqualAFullRecomputation) {
  ViewMesh a = grid(30);
  std::mt19937 rng(42);
  std::uniform_int_distribution<std::uint32_t> pick(0, 30 * 30 - 1);
  std::uniform_real_distribution<float> jiggle(-0.3f, 0.3f);
  std::vector<float> all(a.positions().begin(), a.positions().end());
  for (int round = 0; round < 20; ++round) {
    std::vector<std::uint32_t> idx;
    std::vector<float> xyz;
    for (int k = 0; k < 40; ++k) {
      const std::uint32_t v = pick(rng);
      if (std::find(idx.begin(), idx.end(), v) != idx.end()) continue;
      idx.push_back(v);
      for (int c = 0; c < 3; ++c) {
        all[v * 3 + c] += jiggle(rng);
        xyz.push_back(all[v * 3 + c]);
      }
    }
    a.set_positions(idx, xyz);
  }
  ViewMesh b = grid(30);
  b.set_all_positions(all);
  for (std::size_t i = 0; i < all.size(); ++i) {
    EXPECT_NEAR(a.normals()[i], b.normals()[i], 1e-5f) << i;
    EXPECT_EQ(a.positions()[i], all[i]);
  }
}

TEST(ViewerMesh, SetRangeCopiesAndMarksTheRange) {
  ViewMesh m = grid(4);
  m.take_dirty();
  std::vector<float> xyz = {0.0f, 2.0f, 0.0f, 1.0f, 2.0f, 0.0f};
  m.set_range(0, 2, xyz);
  EXPECT_EQ(m.positions()[1], 2.0f);
  EXPECT_EQ(m.positions()[4], 2.0f);
  const auto d = m.take_dirty(0);
  ASSERT_FALSE(d.ranges.empty());
  EXPECT_EQ(d.ranges.front().begin, 0u);
  EXPECT_THROW(m.set_range(3, 17, xyz), std::out_of_range);
}

TEST(ViewerMesh, BadInputIsNamed) {
  try {
    ViewMesh m(3, "ball", "rubber", {0, 1, 5}, {0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 0, 0, 1, 0, 0, 0, 1, 0});
    FAIL() << "accepted an out-of-range index";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("ball"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("5"), std::string::npos) << e.what();
  }
  ViewMesh m = grid(3);
  const std::vector<std::uint32_t> idx = {100};
  const std::vector<float> xyz = {0, 0, 0};
  EXPECT_THROW(m.set_positions(idx, xyz), std::out_of_range);
  EXPECT_THROW(m.set_positions(idx, std::vector<float>{0, 0}), std::invalid_argument);
}

TEST(ViewerMesh, EdgesAreUnique) {
  ViewMesh m = grid(3);  // 9 vertices, 8 triangles: 16 edges
  EXPECT_EQ(m.edges().size(), 16u * 2);
}

TEST(ViewerTool, CapsuleBoundsFollowTheAxis) {
  ViewTool t;
  t.shape = ToolShape::capsule;
  t.radius = 0.01f;
  t.half_length = 0.03f;
  t.orientation = {0.70710678f, 0, 0, 0.70710678f};  // +x turned onto +y: upright
  const Aabb b = t.bounds();
  EXPECT_NEAR(b.max[1], 0.04f, 1e-5f);
  EXPECT_NEAR(b.max[0], 0.01f, 1e-5f);
}

TEST(ViewerCamera, FitKeepsTheBoxInFront) {
  Camera c;
  c.fit({{-1, -1, -1}, {1, 1, 1}}, 16.0f / 9.0f);
  EXPECT_GT(c.distance, 1.7f);
  EXPECT_NEAR(c.target.norm(), 0.0f, 1e-6f);
  const Eigen::Vector4f centre = c.projection(16.0f / 9.0f) * c.view() * Eigen::Vector4f(0, 0, 0, 1);
  EXPECT_NEAR(centre.x() / centre.w(), 0.0f, 1e-5f);
  EXPECT_NEAR(centre.y() / centre.w(), 0.0f, 1e-5f);
}

TEST(ViewerFont, UnknownCharactersDrawAsQuestionMarks) {
  EXPECT_EQ(font::glyph('~'), font::glyph('?'));
  EXPECT_EQ(font::glyph('a'), font::glyph('A'));
  std::vector<font::Rect> r;
  font::layout("I", 0, 0, 2, r);
  EXPECT_EQ(r.size(), 11u);  // pixels lit in the 'I' glyph
}

TEST(ViewerOptions, SizeAndCameraErrorsNameTheValue) {
  EXPECT_EQ(parse_size("640x480"), (std::pair<int, int>{640, 480}));
  for (const char* bad : {"640", "640x", "x480", "10x10", "640x480x2", "axb"}) {
    try {
      parse_size(bad);
      FAIL() << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
  CameraSpec spec;
  parse_camera("30,20,0.5", spec);
  EXPECT_EQ(*spec.yaw_deg, 30.0f);
  EXPECT_EQ(*spec.distance, 0.5f);
  EXPECT_THROW(parse_camera("30", spec), std::invalid_argument);
  EXPECT_THROW(parse_camera("30,up", spec), std::invalid_argument);
  EXPECT_THROW(parse_camera("30,20,-1", spec), std::invalid_argument);
}

TEST(ViewerOptions, NonFiniteNumbersAreRefusedByName) {
  CameraSpec spec;
  for (const char* bad : {"nan,20", "30,inf", "30,20,nan"}) {
    try {
      parse_camera(bad, spec);
      FAIL() << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(parse_vec3("0,0,-inf", "--target"), std::invalid_argument);
}

TEST(ViewerOptions, AScreenshotIntoAMissingDirectoryIsRefusedAtOnce) {
  Options o;
  o.screenshot = "/nonexistent-sculpt-dir/out.png";
  try {
    check_outputs(o);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-sculpt-dir/out.png"), std::string::npos) << e.what();
  }
  o.screenshot = "out.png";   // the current directory
  EXPECT_NO_THROW(check_outputs(o));
  o.screenshot.clear();
  EXPECT_NO_THROW(check_outputs(o));
}

TEST(ViewerPng, RoundTripAndNamedErrors) {
  const auto dir = std::filesystem::temp_directory_path() / ("viewer-png-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  Image img{3, 2, {}};
  for (int i = 0; i < 3 * 2 * 4; ++i) img.rgba.push_back(static_cast<std::uint8_t>(i * 10));
  write_png(dir / "a.png", img);
  const Image back = read_png(dir / "a.png");
  EXPECT_EQ(back.width, 3);
  EXPECT_EQ(back.height, 2);
  EXPECT_EQ(back.rgba, img.rgba);
  std::ofstream(dir / "bad.png") << "not a png";
  try {
    read_png(dir / "bad.png");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.png"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_png(dir / "missing.png"), std::runtime_error);
  EXPECT_THROW(write_png(dir / "no" / "such" / "dir.png", img), std::runtime_error);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sculpt::view
