// scripts/demo end to end, shortened (--quick: 20 frames, however long they
// take), with the programs of this build: it exits 0, both viewers' screenshots and the image sequence exist and
// show the meshes, and the sequence moves (the recording sculpts). The sequence
// holds what the viewer drew, each picture once, and its timing file lists
// every frame with how long it was shown.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "support/child_process.hpp"
#include "support/scratch_dir.hpp"
#include "image_compare.hpp"

namespace sculpt::viewtest {
namespace {

using namespace std::chrono_literals;
using support::ChildProcess;
using support::one_log_own_group;

TEST(Demo, QuickRunWritesImagesThatShowTheSculpt) {
  const std::string dir = support::fresh_scratch_dir("demo");
  const std::string out = dir + "/demo-output";
  ChildProcess demo({SCULPT_DEMO, "--quick", "--no-bootstrap", "--no-build", "--build-dir", SCULPT_BUILD_ROOT, "--out", out},
                    one_log_own_group({"DISPLAY=", "WAYLAND_DISPLAY="}));
  const auto rc = demo.wait(240s);
  ASSERT_TRUE(rc.has_value()) << "demo still running: " << demo.out().text();
  ASSERT_EQ(*rc, 0) << demo.out().text();
  EXPECT_NE(demo.out().text().find("demo: done. In " + out), std::string::npos) << demo.out().text();

  for (const char* name : {"viewer-a.png", "viewer-b.png"}) {
    const view::Image img = view::read_png(out + "/" + name);
    EXPECT_GT(content_fraction(img), 0.05) << name << " is blank";
  }
  EXPECT_GT(mesh_colour_fraction(view::read_png(out + "/viewer-a.png")), 0.01);

  std::vector<std::filesystem::path> frames;
  for (const auto& e : std::filesystem::directory_iterator(out + "/frames"))
    if (e.path().extension() == ".png") frames.push_back(e.path());
  std::sort(frames.begin(), frames.end());
  ASSERT_GE(frames.size(), 3u);
  for (std::size_t i = 1; i < frames.size(); ++i)
    EXPECT_NE(view::read_png(frames[i - 1]).rgba, view::read_png(frames[i]).rgba)
        << frames[i] << " repeats the frame before it";
  std::ifstream timing(out + "/frames/frames.ffconcat");
  ASSERT_TRUE(timing) << "no timing file";
  std::string line;
  std::getline(timing, line);
  EXPECT_EQ(line, "ffconcat version 1.0");
  std::size_t listed = 0;
  double shown_s = 0;
  while (std::getline(timing, line)) {
    std::istringstream words(line);
    std::string key, value;
    words >> key >> value;
    if (key == "file") {
      EXPECT_TRUE(std::filesystem::exists(out + "/frames/" + value)) << line;
      ++listed;
    } else if (key == "duration") {
      EXPECT_GT(std::stod(value), 0.0) << line;
      shown_s += std::stod(value);
    }
  }
  EXPECT_EQ(listed, frames.size() + 1) << "each frame once, and the last once more for ffmpeg";
  // 20 frames paced at 5 a second: however slowly drawn, at least ~3.4 s.
  EXPECT_GT(shown_s, 1.0) << "the --quick run draws 20 frames at 5 a second";
  EXPECT_NE(demo.out().text().find("frames drawn in"), std::string::npos) << "the demo says the real rate: " << demo.out().text();
  const view::Image first = view::read_png(frames.front());
  const view::Image last = view::read_png(frames.back());
  EXPECT_GT(content_fraction(first), 0.05);
  EXPECT_GT(content_fraction(last), 0.05);
  EXPECT_GT(compare(first, last).bad_fraction, 0.001) << "the sequence does not move";
  if (HasFailure()) support::keep_scratch_dir();
}

}  // namespace
}  // namespace sculpt::viewtest
