// sculpt-view against a real sculptd (a replayed recording, no devices): a
// clear message when no daemon listens; two viewers of one paused daemon
// draw the same image, and it shows the sculpt (not the rest shape); a
// viewer waits for a daemon, and reconnects when it restarts.
#include <gtest/gtest.h>

#include <filesystem>

#include <nlohmann/json.hpp>

#include "support/child_process.hpp"
#include "support/scratch_dir.hpp"
#include "image_compare.hpp"

namespace sculpt::viewtest {
namespace {

using namespace std::chrono_literals;
using support::ChildProcess;
using support::one_log_own_group;

const std::string kData = SCULPT_TEST_DATA;

std::vector<std::string> view_args(const std::string& socket, const std::string& out) {
  // No overlay: it shows the tick and latency, which differ between viewers.
  return {SCULPT_VIEW_BIN, "--socket", socket, "--headless", "--size", "480x270", "--camera", "20,25",
          "--colormap", "--no-overlay", "--screenshot", out, "--after-frames", "3", "--after-seconds", "60"};
}

class Live : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = support::fresh_scratch_dir("live");
    socket_ = dir_ + "/sculptd.sock";
  }
  void TearDown() override {
    if (HasFailure()) support::keep_scratch_dir();
  }
  std::unique_ptr<ChildProcess> start_daemon(const std::string& input) {
    auto d = std::make_unique<ChildProcess>(
        std::vector<std::string>{SCULPTD_BIN, "--socket", socket_, "--input", input, "--no-store"},
        one_log_own_group());
    EXPECT_TRUE(d->out().wait_for("sculptd ready", 60s)) << d->out().text();
    return d;
  }
  std::string dir_, socket_;
};

TEST_F(Live, SaysClearlyWhenNoDaemonListens) {
  ChildProcess view({SCULPT_VIEW_BIN, "--socket", socket_, "--screenshot", dir_ + "/x.png"}, one_log_own_group());
  const auto rc = view.wait(30s);
  ASSERT_TRUE(rc.has_value());
  EXPECT_EQ(*rc, 1);
  const std::string log = view.out().text();
  EXPECT_NE(log.find("no daemon is listening on " + socket_), std::string::npos) << log;
  EXPECT_NE(log.find("--wait"), std::string::npos) << log;
  EXPECT_FALSE(std::filesystem::exists(dir_ + "/x.png"));
}

TEST_F(Live, TwoViewersOfOnePausedDaemonDrawTheSameSculpt) {
  auto daemon = start_daemon("replay:" + kData + "/recordings/push.jsonl");
  // Let the left tool press into the ball (5 s of simulated time, however
  // slow a sanitized daemon runs), then freeze the state.
  const auto deadline = std::chrono::steady_clock::now() + 120s;
  std::uint64_t ticks = 0;
  while (ticks < 5000 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(250ms);
    const support::CommandRun status = support::run_command(SCULPTCTL_BIN, {"status", "--json", "--socket", socket_});
    if (status.status != 0) continue;
    const auto j = nlohmann::json::parse(status.out, nullptr, false);
    if (j.is_object() && j.contains("ticks")) ticks = j["ticks"].get<std::uint64_t>();
  }
  ASSERT_GE(ticks, 5000u) << daemon->out().text();
  ChildProcess pause({SCULPTCTL_BIN, "pause", "--socket", socket_}, one_log_own_group());
  ASSERT_EQ(pause.wait(30s).value_or(-1), 0) << pause.out().text();

  ChildProcess a(view_args(socket_, dir_ + "/a.png"), one_log_own_group());
  ChildProcess b(view_args(socket_, dir_ + "/b.png"), one_log_own_group());
  ASSERT_EQ(a.wait(90s).value_or(-1), 0) << a.out().text();
  ASSERT_EQ(b.wait(90s).value_or(-1), 0) << b.out().text();
  const view::Image ia = view::read_png(dir_ + "/a.png");
  const view::Image ib = view::read_png(dir_ + "/b.png");
  const ImageDiff same = compare(ia, ib);
  EXPECT_TRUE(close_enough(same)) << describe(same);
  EXPECT_GT(content_fraction(ia), 0.05);

  // The same view of the scene as loaded: the sculpted one must differ (the
  // colour map shows the dent).
  ChildProcess rest({SCULPT_VIEW_BIN, "--scene", "builtin:default", "--headless", "--size", "480x270", "--camera",
                     "20,25", "--colormap", "--no-overlay", "--screenshot", dir_ + "/rest.png", "--quiet"},
                    one_log_own_group());
  ASSERT_EQ(rest.wait(60s).value_or(-1), 0) << rest.out().text();
  const ImageDiff sculpted = compare(ia, view::read_png(dir_ + "/rest.png"), 24);
  EXPECT_GT(sculpted.bad_fraction, 0.002) << "the live image looks like the rest shape: " << describe(sculpted);
  daemon->signal(SIGTERM);
  EXPECT_EQ(daemon->wait(30s).value_or(-1), 0) << daemon->out().text();
}

TEST_F(Live, WaitsForTheDaemonAndReconnectsWhenItRestarts) {
  const std::string frames = dir_ + "/frames";
  ChildProcess view({SCULPT_VIEW_BIN, "--socket", socket_, "--headless", "--wait", "--size", "160x90", "--fps", "10",
                     "--frames-dir", frames, "--after-seconds", "120"},
                    one_log_own_group());
  ASSERT_TRUE(view.out().wait_for("no daemon is listening", 30s)) << view.out().text();
  {
    auto first = start_daemon("replay:" + kData + "/recordings/push.jsonl");
    ASSERT_TRUE(view.out().wait_for("keyframe:", 30s)) << view.out().text();
    first->signal(SIGTERM);
    ASSERT_TRUE(first->wait(30s).has_value());
  }
  ASSERT_TRUE(view.out().wait_for("the daemon went away", 30s)) << view.out().text();
  const std::size_t before = view.out().text().find("the daemon went away");
  auto second = start_daemon("replay:" + kData + "/recordings/push.jsonl");
  ASSERT_TRUE(view.out().wait_for("connected to " + socket_, 30s)) << view.out().text();
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (view.out().text().find("keyframe:", before) == std::string::npos && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(50ms);
  }
  EXPECT_NE(view.out().text().find("keyframe:", before), std::string::npos) << view.out().text();
  EXPECT_TRUE(view.running()) << view.out().text();
  view.signal(SIGTERM);
  EXPECT_EQ(view.wait(30s).value_or(-1), 0) << view.out().text();
  EXPECT_FALSE(std::filesystem::is_empty(frames));
  second->signal(SIGTERM);
  second->wait(30s);
}

}  // namespace
}  // namespace sculpt::viewtest
