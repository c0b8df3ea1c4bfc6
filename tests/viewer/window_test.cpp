// The window mode under Xvfb (a private server on a display number it picks
// itself): the window opens, a screenshot of the X screen taken from outside
// (XGetImage on the root window) shows the meshes, the viewer's own
// screenshot (--screenshot from the window's back buffer) does too, and
// SIGTERM closes it cleanly.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "support/child_process.hpp"
#include "support/scratch_dir.hpp"
#include "image_compare.hpp"
#include "x11_grab.hpp"

namespace sculpt::viewtest {
namespace {

using namespace std::chrono_literals;
using support::ChildProcess;
using support::one_log_own_group;

class WindowMode : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = support::fresh_scratch_dir("window");
    // -displayfd: Xvfb picks a free display and writes its number to fd 1.
    xvfb_ = std::make_unique<ChildProcess>(
        std::vector<std::string>{"Xvfb", "-displayfd", "1", "-screen", "0", "800x600x24", "-nolisten", "tcp"},
        one_log_own_group());
    const auto deadline = std::chrono::steady_clock::now() + 30s;
    while (std::chrono::steady_clock::now() < deadline) {
      const std::string out = xvfb_->out().text();
      const auto nl = out.find('\n');
      if (nl != std::string::npos && nl > 0 && std::isdigit(static_cast<unsigned char>(out[0]))) {
        display_ = ":" + out.substr(0, nl);
        break;
      }
      ASSERT_TRUE(xvfb_->running()) << "Xvfb failed: " << out;
      std::this_thread::sleep_for(20ms);
    }
    ASSERT_FALSE(display_.empty()) << "Xvfb gave no display number: " << xvfb_->out().text();
  }
  void TearDown() override {
    xvfb_.reset();
    if (HasFailure()) support::keep_scratch_dir();
  }

  view::Image grab_screen() { return grab_root(display_); }

  // The private X server has no D-Bus session bus: say so, or SDL's libdbus
  // tries to autolaunch one through X11 (and, failing, leaks a buffer that
  // LeakSanitizer reports).
  std::vector<std::string> env() const {
    return {"DISPLAY=" + display_, "WAYLAND_DISPLAY=", "DBUS_SESSION_BUS_ADDRESS=disabled:"};
  }

  std::string dir_, display_;
  std::unique_ptr<ChildProcess> xvfb_;
};

TEST_F(WindowMode, ShowsTheMeshAndClosesOnSigterm) {
  ChildProcess view({SCULPT_VIEW_BIN, "--window", "--scene", "builtin:default", "--size", "640x480", "--fps", "10"},
                    one_log_own_group(env()));
  ASSERT_TRUE(view.out().wait_for("window on x11", 60s)) << view.out().text();
  // A few frames in, the screen shows the meshes.
  double seen = 0;
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  view::Image screen;
  while (std::chrono::steady_clock::now() < deadline && seen < 0.01) {
    std::this_thread::sleep_for(300ms);
    screen = grab_screen();
    if (!screen.rgba.empty()) seen = mesh_colour_fraction(screen);
  }
  if (!screen.rgba.empty()) view::write_png(dir_ + "/screen.png", screen);
  EXPECT_GT(seen, 0.01) << "no mesh on the X screen (kept " << dir_ << "/screen.png)";
  EXPECT_TRUE(view.running()) << view.out().text();
  view.signal(SIGTERM);
  EXPECT_EQ(view.wait(30s).value_or(-1), 0) << view.out().text();
}

// Keys: 'w' turns the wireframe on, 's' writes a screenshot into --screenshot-dir.
TEST_F(WindowMode, KeysToggleTheWireframeAndTakeScreenshots) {
  const std::string shots = dir_ + "/shots";
  std::filesystem::create_directories(shots);
  ChildProcess view({SCULPT_VIEW_BIN, "--window", "--scene", "builtin:default", "--size", "640x480", "--fps", "10",
                     "--screenshot-dir", shots},
                    one_log_own_group(env()));
  ASSERT_TRUE(view.out().wait_for("window on x11", 60s)) << view.out().text();
  const auto files = [&] {
    std::vector<std::filesystem::path> all;
    for (const auto& e : std::filesystem::directory_iterator(shots)) all.push_back(e.path());
    return all;
  };
  // Presses 's' until a screenshot appears that is not in `before`; returns it.
  const auto new_shot = [&](const std::vector<std::filesystem::path>& before) -> std::filesystem::path {
    const auto deadline = std::chrono::steady_clock::now() + 30s;
    while (std::chrono::steady_clock::now() < deadline) {
      for (const auto& f : files()) {
        if (std::find(before.begin(), before.end(), f) == before.end()) return f;
      }
      send_key(display_, "sculpt-view", "s");
      std::this_thread::sleep_for(500ms);
    }
    return {};
  };
  // A screenshot is read once the viewer says it wrote it (the file appears
  // before it is complete).
  const auto written = [&](const std::filesystem::path& f) { return view.out().wait_for("screenshot " + f.string(), 30s); };
  const std::filesystem::path first = new_shot({});
  ASSERT_FALSE(first.empty()) << view.out().text();
  ASSERT_TRUE(written(first)) << view.out().text();
  const view::Image plain = view::read_png(first);
  EXPECT_GT(mesh_colour_fraction(plain), 0.01);
  ASSERT_TRUE(send_key(display_, "sculpt-view", "w"));
  // An 's' pressed before the 'w' may still land after `first`: its
  // screenshot is plain. Screenshots until one shows the wireframe.
  std::filesystem::path second;
  std::vector<std::filesystem::path> seen = files();
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  while (second.empty() && std::chrono::steady_clock::now() < deadline) {
    const std::filesystem::path shot = new_shot(seen);
    if (shot.empty()) break;
    seen.push_back(shot);
    ASSERT_TRUE(written(shot)) << view.out().text();
    if (compare(plain, view::read_png(shot)).bad_fraction > 0.01) second = shot;
  }
  ASSERT_FALSE(second.empty()) << "'w' did not change the picture: " << view.out().text();
  const view::Image wire = view::read_png(second);
  EXPECT_GT(compare(plain, wire).bad_fraction, 0.01) << "'w' did not change the picture";
  EXPECT_NE(view.out().text().find("screenshot " + shots), std::string::npos) << view.out().text();
  view.signal(SIGTERM);
  EXPECT_EQ(view.wait(30s).value_or(-1), 0) << view.out().text();
}

TEST_F(WindowMode, AScreenshotFromTheWindowShowsTheMesh) {
  const std::string out = dir_ + "/shot.png";
  ChildProcess view({SCULPT_VIEW_BIN, "--window", "--scene", "builtin:default", "--size", "640x480", "--screenshot", out,
                     "--after-frames", "5", "--boxes"},
                    one_log_own_group(env()));
  ASSERT_EQ(view.wait(60s).value_or(-1), 0) << view.out().text();
  EXPECT_NE(view.out().text().find("window on x11"), std::string::npos) << view.out().text();
  const view::Image img = view::read_png(out);
  EXPECT_EQ(img.width, 640);
  EXPECT_EQ(img.height, 480);
  EXPECT_GT(mesh_colour_fraction(img), 0.01);
}

}  // namespace
}  // namespace sculpt::viewtest
