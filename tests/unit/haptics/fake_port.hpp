// A fake FF device for unit tests: effect ids like the kernel's (id −1 takes the
// lowest free one, ENOSPC when full, EINVAL for an id not in use or an
// unsupported type), scripted errors, and a log of every call.
#pragma once

#include <linux/input.h>

#include <cerrno>
#include <chrono>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "haptics/ff_port.hpp"

namespace sculpt::haptics::testing {

struct FakeDeviceState {
  FfCaps caps;
  DeviceIdentity identity;               // EVIOCGID / EVIOCGNAME
  std::chrono::steady_clock::time_point now{};  // the test's clock: stamps each call
  std::vector<bool> used;                // effect id → in use
  std::deque<int> upload_errors;         // next uploads answer these (0 = normal)
  bool unplugged = false;                // every call answers ENODEV
  bool closed = false;                   // the port was destroyed (fd closed)

  struct Call {
    enum Kind { upload, erase, write } kind;
    ff_effect effect{};                  // upload: as sent (id as passed in)
    std::int16_t id = -1;                // upload: assigned id; erase: id; write: code
    std::int32_t value = 0;              // write: value
    int result = 0;
    std::chrono::steady_clock::time_point at{};
  };
  std::vector<Call> calls;

  std::vector<Call> of(Call::Kind k) const {
    std::vector<Call> out;
    for (const auto& c : calls)
      if (c.kind == k) out.push_back(c);
    return out;
  }
  int live() const {
    int n = 0;
    for (bool u : used) n += u;
    return n;
  }
};

inline std::shared_ptr<FakeDeviceState> fake_device(std::initializer_list<std::uint16_t> bits, int effects_max) {
  auto s = std::make_shared<FakeDeviceState>();
  for (auto b : bits) s->caps.bits.set(b);
  s->caps.effects_max = effects_max;
  s->used.assign(static_cast<std::size_t>(effects_max), false);
  return s;
}

class FakePort final : public FfPort {
 public:
  explicit FakePort(std::shared_ptr<FakeDeviceState> s, std::string node = "/dev/input/fake")
      : s_(std::move(s)), node_(std::move(node)) {}
  // Like the kernel's flush on close: the file's effects are erased.
  ~FakePort() override {
    s_->closed = true;
    s_->used.assign(s_->used.size(), false);
  }

  FfCaps caps() override { return s_->caps; }
  DeviceIdentity identity() override { return s_->identity; }

  int upload(ff_effect& e) override {
    FakeDeviceState::Call call{FakeDeviceState::Call::upload, e, e.id, 0, 0};
    int r = 0;
    if (s_->unplugged) {
      r = ENODEV;
    } else if (!s_->upload_errors.empty() && s_->upload_errors.front() != 0) {
      r = s_->upload_errors.front();
      s_->upload_errors.pop_front();
    } else {
      if (!s_->upload_errors.empty()) s_->upload_errors.pop_front();
      if (!s_->caps.has(e.type)) {
        r = EINVAL;
      } else if (e.id == -1) {
        r = ENOSPC;
        for (std::size_t i = 0; i < s_->used.size(); ++i)
          if (!s_->used[i]) {
            s_->used[i] = true;
            e.id = static_cast<std::int16_t>(i);
            r = 0;
            break;
          }
      } else if (e.id < 0 || static_cast<std::size_t>(e.id) >= s_->used.size() || !s_->used[e.id]) {
        r = EINVAL;
      }
    }
    call.id = e.id;
    call.result = r;
    call.at = s_->now;
    s_->calls.push_back(call);
    return r;
  }

  int erase(std::int16_t id) override {
    int r = 0;
    if (s_->unplugged)
      r = ENODEV;
    else if (id < 0 || static_cast<std::size_t>(id) >= s_->used.size() || !s_->used[id])
      r = EINVAL;
    else
      s_->used[id] = false;
    s_->calls.push_back({FakeDeviceState::Call::erase, {}, id, 0, r, s_->now});
    return r;
  }

  int write_ff(std::uint16_t code, std::int32_t value) override {
    const int r = s_->unplugged ? ENODEV : 0;
    s_->calls.push_back({FakeDeviceState::Call::write, {}, static_cast<std::int16_t>(code), value, r, s_->now});
    return r;
  }

  const std::string& node() const override { return node_; }

 private:
  std::shared_ptr<FakeDeviceState> s_;
  std::string node_;
};

}  // namespace sculpt::haptics::testing
