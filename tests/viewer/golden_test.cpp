// Golden images: sculpt-view renders the built-in default scene offline
// (no daemon, so always the same state) from a fixed camera, with each
// drawing option, and each image must match tests/data/golden/ within a
// tolerance (never byte for byte: llvmpipe versions round differently).
//
// Regenerate after an intended change of the look:
//   SCULPT_UPDATE_GOLDEN=1 meson test -C build viewer_golden
// then look at the new files (git diff shows them changed) and commit them.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "support/child_process.hpp"
#include "support/scratch_dir.hpp"
#include "image_compare.hpp"

namespace sculpt::viewtest {
namespace {

using namespace std::chrono_literals;
using support::ChildProcess;
using support::one_log_own_group;

struct Case {
  const char* name;
  std::vector<std::string> flags;
};

class Golden : public ::testing::TestWithParam<Case> {};

TEST_P(Golden, MatchesWithinTolerance) {
  const Case& c = GetParam();
  const std::string dir = support::fresh_scratch_dir("golden");
  const std::string out = dir + "/" + c.name + ".png";
  std::vector<std::string> argv = {SCULPT_VIEW_BIN, "--scene", "builtin:default", "--headless", "--size", "480x270",
                                   "--camera", "20,25", "--screenshot", out, "--quiet"};
  argv.insert(argv.end(), c.flags.begin(), c.flags.end());
  ChildProcess view(argv, one_log_own_group());
  const auto rc = view.wait(60s);
  ASSERT_TRUE(rc.has_value()) << "sculpt-view did not finish";
  ASSERT_EQ(*rc, 0) << view.out().text();
  const view::Image got = view::read_png(out);
  const std::string golden = std::string(SCULPT_GOLDEN_DIR) + "/" + c.name + ".png";
  if (const char* update = std::getenv("SCULPT_UPDATE_GOLDEN"); update != nullptr && *update == '1') {
    std::filesystem::copy_file(out, golden, std::filesystem::copy_options::overwrite_existing);
    std::filesystem::remove_all(dir);
    GTEST_SUCCEED() << "wrote " << golden;
    return;
  }
  ASSERT_TRUE(std::filesystem::exists(golden)) << golden << " is missing (SCULPT_UPDATE_GOLDEN=1 makes it)";
  const view::Image want = view::read_png(golden);
  const ImageDiff d = compare(got, want);
  EXPECT_TRUE(close_enough(d)) << c.name << ": " << describe(d) << " (kept: " << out << ")";
  EXPECT_GT(content_fraction(got), 0.05) << "nothing drawn in " << out;
  if (!close_enough(d)) support::keep_scratch_dir();
}

INSTANTIATE_TEST_SUITE_P(DefaultScene, Golden,
                         ::testing::Values(Case{"default", {}}, Case{"wireframe", {"--wireframe"}},
                                           Case{"boxes", {"--boxes"}},
                                           Case{"all_options", {"--wireframe", "--boxes", "--colormap", "--no-overlay"}}),
                         [](const auto& info) { return std::string(info.param.name); });

// The options really change the picture (a golden test alone would also pass
// if a flag were ignored and its golden made without it).
TEST(GoldenSet, OptionsMakeDifferentImages) {
  const auto load = [](const char* n) { return view::read_png(std::string(SCULPT_GOLDEN_DIR) + "/" + n + ".png"); };
  const view::Image plain = load("default");
  for (const char* other : {"wireframe", "boxes", "all_options"}) {
    EXPECT_GT(compare(plain, load(other)).bad_fraction, 0.01) << other << " looks like default";
  }
}

// Bad input: a clear message naming what was wrong, and no crash.
TEST(ViewerCli, ErrorsNameWhatWasWrong) {
  const std::string dir = support::fresh_scratch_dir("cli");
  const auto run = [&](std::vector<std::string> args) {
    args.insert(args.begin(), SCULPT_VIEW_BIN);
    ChildProcess c(args, one_log_own_group());
    const int rc = c.wait(60s).value_or(-1);
    return std::pair{rc, c.out().text()};
  };
  auto [rc, log] = run({"--scene", dir + "/missing.toml", "--screenshot", dir + "/x.png"});
  EXPECT_EQ(rc, 1);
  EXPECT_NE(log.find("missing.toml"), std::string::npos) << log;
  std::tie(rc, log) = run({"--scene", std::string(SCULPT_TEST_DATA) + "/scenes/bad/bad_mesh_file.toml", "--screenshot",
                           dir + "/x.png"});
  EXPECT_EQ(rc, 1);
  EXPECT_NE(log.find("bad_mesh_file.toml:2"), std::string::npos) << log;
  std::tie(rc, log) = run({"--scene", "builtin:default", "--size", "640by480"});
  EXPECT_EQ(rc, 2);
  EXPECT_NE(log.find("--size '640by480'"), std::string::npos) << log;
  std::tie(rc, log) = run({"--scene", "builtin:default", "--screenshot", dir + "/no/such/dir/x.png", "--quiet"});
  EXPECT_EQ(rc, 1);
  EXPECT_NE(log.find("no/such/dir/x.png"), std::string::npos) << log;
  // Offscreen with nothing to write would render into the void forever.
  std::tie(rc, log) = run({"--scene", "builtin:default", "--headless"});
  EXPECT_EQ(rc, 2);
  EXPECT_NE(log.find("nothing to write"), std::string::npos) << log;
  std::tie(rc, log) = run({"--frobnicate"});
  EXPECT_EQ(rc, 2);
  EXPECT_NE(log.find("--frobnicate"), std::string::npos) << log;
  std::tie(rc, log) = run({"--help"});
  EXPECT_EQ(rc, 0);
  EXPECT_NE(log.find("--screenshot"), std::string::npos) << log;
  // --snapshot, the old name users' scripts still pass: it works, with one
  // warning line, and cannot be given with --screenshot.
  std::tie(rc, log) = run({"--scene", "builtin:default", "--size", "64x48", "--snapshot", dir + "/old.png", "--quiet"});
  EXPECT_EQ(rc, 0) << log;
  EXPECT_TRUE(std::filesystem::exists(dir + "/old.png"));
  const std::string warning = "sculpt-view: warning: --snapshot is deprecated: use --screenshot\n";
  ASSERT_NE(log.find(warning), std::string::npos) << log;
  EXPECT_EQ(log.find(warning, log.find(warning) + 1), std::string::npos) << "one warning line:\n" << log;
  std::tie(rc, log) = run({"--scene", "builtin:default", "--snapshot", dir + "/a.png", "--screenshot", dir + "/b.png"});
  EXPECT_EQ(rc, 2) << log;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sculpt::viewtest
