// Runs the real sculptctl binary (meson passes its path in SCULPTCTL).
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/child_process.hpp"
#include "test_data.hpp"

namespace {

using sculpt::scene::testing::data_dir;

using CtlRun = sculpt::support::CommandRun;

CtlRun sculptctl(const std::vector<std::string>& args) {
  const char* exe = std::getenv("SCULPTCTL");
  if (!exe) {
    ADD_FAILURE() << "SCULPTCTL is not set (run through meson test)";
    return {};
  }
  return sculpt::support::run_command(exe, args);
}

std::vector<nlohmann::json> json_lines(const std::string& out) {
  std::vector<nlohmann::json> lines;
  std::istringstream in(out);
  std::string line;
  while (std::getline(in, line)) lines.push_back(nlohmann::json::parse(line));
  return lines;
}

TEST(Inspect, JsonForAMeshHasEveryField) {
  const auto file = (data_dir() / "meshes" / "icosphere_binary.stl").string();
  const CtlRun r = sculptctl({"inspect", "--json", file});
  ASSERT_EQ(r.status, 0) << r.err;
  const auto lines = json_lines(r.out);
  ASSERT_EQ(lines.size(), 1u);
  const auto& j = lines[0];
  EXPECT_EQ(j["file"], file);
  EXPECT_EQ(j["vertices"], 162);
  EXPECT_EQ(j["edges"], 480);
  EXPECT_EQ(j["triangles"], 320);
  EXPECT_EQ(j["boundary_edges"], 0);
  EXPECT_EQ(j["nonmanifold_edges"], 0);
  EXPECT_EQ(j["components"], 1);
  ASSERT_EQ(j["bbox_min"].size(), 3u);
  ASSERT_EQ(j["bbox_max"].size(), 3u);
  EXPECT_NEAR(j["bbox_max"][1].get<double>(), 0.1, 1e-6);
  EXPECT_GE(j["substeps"].get<int>(), 1);
  EXPECT_GT(j["dt_bound"].get<double>(), 0.0);
  // The chosen substep obeys the bound with the default safety factor.
  EXPECT_LE(j["substep_dt"].get<double>(), 0.5 * j["dt_bound"].get<double>() + 1e-15);
  EXPECT_TRUE(j["warnings"].is_array());
  EXPECT_TRUE(j["warnings"].empty());
}

TEST(Inspect, JsonForASceneHasOneObjectPerMesh) {
  const CtlRun r = sculptctl({"inspect", "--json", "builtin:default"});
  ASSERT_EQ(r.status, 0) << r.err;
  const auto lines = json_lines(r.out);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0]["name"], "ball");
  EXPECT_EQ(lines[2]["material"], "clay");
  for (const auto& j : lines) EXPECT_EQ(j["boundary_edges"], 0);
}

TEST(Inspect, WarningsAreListed) {
  const CtlRun r = sculptctl({"inspect", "--json", (data_dir() / "meshes" / "open_grid.obj").string()});
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = json_lines(r.out).at(0);
  ASSERT_EQ(j["warnings"].size(), 1u);
  EXPECT_EQ(j["warnings"][0], "open surface: 16 boundary edges (their springs have one side only)");
  const CtlRun text = sculptctl({"inspect", (data_dir() / "meshes" / "open_grid.obj").string()});
  EXPECT_NE(text.out.find("warning: open surface: 16 boundary edges"), std::string::npos) << text.out;
}

TEST(Inspect, TextReportHasCountsMaterialAndSubsteps) {
  const CtlRun r = sculptctl({"inspect", (data_dir() / "scenes" / "full.toml").string()});
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* s : {"4 meshes, 2 tools, 500 Hz, substeps 4", "tool finger: capsule radius 0.01 m",
                        "vertices 162  edges 480  triangles 320", "material putty: linear model",
                        "substeps 4 per tick at 500 Hz", "stability bound dt"}) {
    EXPECT_NE(r.out.find(s), std::string::npos) << s << "\n" << r.out;
  }
}

TEST(Inspect, BadInputExitsNonZeroWithOneLine) {
  for (const std::string f : {"bad/nan.obj", "bad/unknown_format.xyz", "bad/empty.stl", "scenes/bad/typo_key.toml",
                              "scenes/bad/wrong_type.toml", "scenes/bad/missing_mesh.toml", "no/such/file.stl"}) {
    const CtlRun r = sculptctl({"inspect", "--json", (data_dir() / f).string()});
    EXPECT_NE(r.status, 0) << f;
    EXPECT_TRUE(r.out.empty()) << f;
    ASSERT_FALSE(r.err.empty()) << f;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << f << ": " << r.err;
    EXPECT_EQ(r.err.rfind("sculptctl: error: " + (data_dir() / f).string(), 0), 0u) << r.err;
  }
}

TEST(Inspect, ListsFormats) {
  const CtlRun r = sculptctl({"inspect", "--formats"});
  ASSERT_EQ(r.status, 0);
  for (const char* e : {"\nobj\n", "\nply\n", "\nstl\n", "\nglb\n", "\noff\n"}) {
    EXPECT_NE(("\n" + r.out).find(e), std::string::npos) << e;
  }
}

}  // namespace
