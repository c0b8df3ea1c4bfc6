// scripts/demo end to end, shortened (--quick), with the programs of this
// build: it exits 0, both viewers' snapshots and the image sequence exist and
// show the meshes, and the sequence moves (the session sculpts).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "child.hpp"
#include "image_compare.hpp"

namespace sculpt::viewtest {
namespace {

TEST(Demo, QuickRunWritesImagesThatShowTheSculpt) {
  const std::string dir = make_temp_dir("demo");
  const std::string out = dir + "/demo-output";
  Child demo({SCULPT_DEMO, "--quick", "--no-bootstrap", "--no-build", "--build-dir", SCULPT_BUILD_ROOT, "--out", out},
             dir + "/demo.txt", {"DISPLAY=", "WAYLAND_DISPLAY="});
  const auto rc = demo.wait(240s);
  ASSERT_TRUE(rc.has_value()) << "demo still running: " << demo.log();
  ASSERT_EQ(*rc, 0) << demo.log();
  EXPECT_NE(demo.log().find("demo: done. In " + out), std::string::npos) << demo.log();

  for (const char* name : {"viewer-a.png", "viewer-b.png"}) {
    const view::Image img = view::read_png(out + "/" + name);
    EXPECT_GT(content_fraction(img), 0.05) << name << " is blank";
  }
  EXPECT_GT(mesh_colour_fraction(view::read_png(out + "/viewer-a.png")), 0.01);

  std::vector<std::filesystem::path> frames;
  for (const auto& e : std::filesystem::directory_iterator(out + "/frames")) frames.push_back(e.path());
  std::sort(frames.begin(), frames.end());
  ASSERT_GE(frames.size(), 3u);
  const view::Image first = view::read_png(frames.front());
  const view::Image last = view::read_png(frames.back());
  EXPECT_GT(content_fraction(first), 0.05);
  EXPECT_GT(content_fraction(last), 0.05);
  EXPECT_GT(compare(first, last).bad_fraction, 0.001) << "the sequence does not move";
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sculpt::viewtest
