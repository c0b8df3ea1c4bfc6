// Shared by the input VM tests: a DeviceListener that records what it is
// told, and a pump that runs a DeviceManager (as sculptd's io loop would)
// until a condition holds. Tests wait on facts, bounded, never on sleeps.
#pragma once

#include <poll.h>
#include <unistd.h>

#include <chrono>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "input/device_manager.hpp"

namespace sculpt::input::vmtest {

struct Recorded : DeviceListener {
  struct Attach {
    std::uint8_t slot;
    DeviceInfo info;
  };
  std::vector<Attach> attaches;
  std::vector<std::uint8_t> detaches;
  std::vector<InputFrame> frames;
  std::vector<std::string> logs;

  void on_attach(std::uint8_t slot, const DeviceInfo& info) override { attaches.push_back({slot, info}); }
  void on_detach(std::uint8_t slot) override { detaches.push_back(slot); }
  void on_frame(const InputFrame& f) override { frames.push_back(f); }
  void on_log(int, const std::string& m) override { logs.push_back(m); }

  const Attach* attach_named(const std::string& name) const {
    for (auto it = attaches.rbegin(); it != attaches.rend(); ++it)
      if (it->info.name == name) return &*it;
    return nullptr;
  }
  // The last value each (type, code) took in the frames of `slot`.
  std::map<std::pair<int, int>, int> state(std::uint8_t slot) const {
    std::map<std::pair<int, int>, int> s;
    for (const auto& f : frames)
      if (f.slot == slot)
        for (std::size_t i = 0; i < f.count; ++i) s[{f.events[i].type, f.events[i].code}] = f.events[i].value;
    return s;
  }
};

// Polls the manager's fds and dispatches until pred() or the timeout.
inline bool pump_until(DeviceManager& m, const std::function<bool()>& pred,
                       std::chrono::milliseconds timeout = std::chrono::milliseconds(5000)) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
    if (left.count() <= 0) return false;
    std::vector<pollfd> fds;
    for (int fd : m.fds()) fds.push_back({fd, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), static_cast<int>(std::min<long>(left.count(), 50))) > 0)
      for (const auto& p : fds)
        if (p.revents) m.dispatch(p.fd);
  }
  return true;
}

// Whether this guest runs udevd (the vm-udev suite) or not (the plain vm suite).
inline bool udev_running() { return ::access("/run/udev/control", F_OK) == 0; }

}  // namespace sculpt::input::vmtest
