// The replug race, against the kernel: uinput answers ENODEV to an FF upload
// between a new device's node appearing and the device being marked created.
// Discovery that attaches as soon as the node appears (inotify, like sculptd's)
// hits that window; the engine must treat it as "not ready yet" and make the
// first upload succeed anyway. 50 replugs, every first upload a success, and
// the time from attach to the first upload printed (p50/p99).
#include <gtest/gtest.h>

#include <linux/input.h>
#include <poll.h>
#include <sys/inotify.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "haptics/haptics_thread.hpp"
#include "support/timing.hpp"
#include "support/virtual_joystick.hpp"

namespace sculpt::haptics {
namespace {

using namespace std::chrono_literals;
using support::rumble_pad_spec;
using support::VirtualJoystick;

constexpr int kSlot = 2;
constexpr int kReplugs = 50;

// Attaches every new /dev/input/event* node the moment inotify reports it,
// on its own thread (the io thread's part in sculptd).
class NodeWatcher {
 public:
  explicit NodeWatcher(HapticsThread& haptics) : haptics_(haptics) {
    fd_ = ::inotify_init1(IN_CLOEXEC | IN_NONBLOCK);
    if (fd_ < 0 || ::inotify_add_watch(fd_, "/dev/input", IN_CREATE) < 0) throw std::runtime_error("inotify");
    thread_ = std::thread([this] { run(); });
  }
  ~NodeWatcher() {
    stop_ = true;
    thread_.join();
    ::close(fd_);
  }
  int attached() const { return attached_.load(); }

 private:
  void run() {
    alignas(inotify_event) char buf[4096];
    while (!stop_) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      const ssize_t n = ::read(fd_, buf, sizeof buf);
      for (ssize_t off = 0; off < n;) {
        const auto* e = reinterpret_cast<const inotify_event*>(buf + off);
        if (e->len > 0 && std::string(e->name).rfind("event", 0) == 0) {
          haptics_.attach(kSlot, "/dev/input/" + std::string(e->name), {{0, StickPlane{}}});
          attached_.fetch_add(1);
        }
        off += static_cast<ssize_t>(sizeof(inotify_event) + e->len);
      }
    }
  }
  HapticsThread& haptics_;
  int fd_ = -1;
  std::atomic<bool> stop_{false};
  std::atomic<int> attached_{0};
  std::thread thread_;
};

using support::wait_until;

TEST(HapticsReplugVm, EveryFirstUploadAfterAReplugSucceeds) {
  VirtualJoystick joy(rumble_pad_spec());
  joy.unplug();
  FeedbackBoard board(1);
  HapticsSettings s;
  s.poll_interval = 2ms;
  HapticsThread haptics(board, s);
  haptics.start();
  NodeWatcher watcher(haptics);
  const HapticsStats& st = haptics.stats();
  std::vector<double> ms;
  for (int i = 0; i < kReplugs; ++i) {
    const auto firsts = st.first_uploads.load() + st.first_upload_failures.load();
    joy.plug();
    ASSERT_TRUE(wait_until([&] { return watcher.attached() > i; }, 5s)) << "replug " << i << ": no node seen";
    ASSERT_TRUE(wait_until([&] { return st.first_uploads.load() + st.first_upload_failures.load() > firsts; }, 5s))
        << "replug " << i << ": no first upload";
    ms.push_back(st.slot_first_upload_ns[kSlot].load() / 1e6);
    joy.unplug();
    haptics.detach(kSlot);  // what the io thread does when its read says ENODEV
    haptics.flush();
  }
  EXPECT_EQ(st.first_uploads.load(), static_cast<std::uint64_t>(kReplugs));
  EXPECT_EQ(st.first_upload_failures.load(), 0u);
  // (ff.errors may count a play that met the unplug before the detach did:
  // that is the unplug path, not a first upload.)
  std::sort(ms.begin(), ms.end());
  const auto at = [&](double q) { return ms[std::min(ms.size() - 1, static_cast<std::size_t>(q * ms.size()))]; };
  std::printf("replug: %d first uploads, %d failed, %llu not-ready retries, %llu errors; attach to first upload "
              "p50 %.2f ms, p99 %.2f ms, max %.2f ms\n",
              static_cast<int>(st.first_uploads.load()), static_cast<int>(st.first_upload_failures.load()),
              static_cast<unsigned long long>(st.not_ready_retries.load()),
              static_cast<unsigned long long>(st.ff.errors.load()), at(0.5), at(0.99), ms.back());
  haptics.stop();
}

}  // namespace
}  // namespace sculpt::haptics
