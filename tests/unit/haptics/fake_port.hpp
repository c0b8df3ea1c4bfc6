// A fake FF device for unit tests: effect ids like the kernel's (id −1 takes the
// lowest free one, ENOSPC when full, EINVAL for an id not in use or an
// unsupported type; an erase stops the effect first, as ff-core's does),
// scripted errors, a log of every call, and a clock: each call starts at the
// clock's time and takes its kind's cost (plus jitter), so a test can check
// the spacing between the END of one call and the START of the next.
#pragma once

#include <linux/input.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "haptics/ff_port.hpp"
#include "haptics/pacer.hpp"

namespace sculpt::haptics::testing {

// A clock that moves only when told: by a test (advance_to), by a fake
// device's call taking its time, or by a wait (sleep_until).
class FakeClock final : public TimeSource {
 public:
  Clock::time_point now() override { return t_; }
  void sleep_until(Clock::time_point t) override {
    ++sleeps_;
    advance_to(t);
  }
  // Never backwards: a poll "at" a time the clock has passed runs late.
  void advance_to(Clock::time_point t) { t_ = std::max(t_, t); }
  void advance(Clock::duration d) { t_ += d; }
  int sleeps() const { return sleeps_; }

 private:
  Clock::time_point t_{};
  int sleeps_ = 0;
};

// How long each kind of call takes on the fake device; `jitter` adds up to
// that much more, pseudo-randomly (deterministic).
struct CallCost {
  Clock::duration upload{};
  Clock::duration erase{};
  Clock::duration write{};  // EV_FF: a play, a stop, FF_GAIN
  Clock::duration jitter{};
};

struct FakeDeviceState {
  FfCaps caps;
  DeviceIdentity identity;               // EVIOCGID / EVIOCGNAME
  std::shared_ptr<FakeClock> clock = std::make_shared<FakeClock>();  // shared across devices by a test
  CallCost cost;
  std::uint32_t jitter_seed = 1;
  std::vector<bool> used;                // effect id → in use
  std::vector<bool> playing;             // effect id → played and not stopped or erased
  std::deque<int> upload_errors;         // next uploads answer these (0 = normal)
  bool unplugged = false;                // every call answers ENODEV
  bool closed = false;                   // the port was destroyed (fd closed)

  struct Call {
    enum Kind { upload, erase, write } kind;
    ff_effect effect{};                  // upload: as sent (id as passed in)
    std::int16_t id = -1;                // upload: assigned id; erase: id; write: code
    std::int32_t value = 0;              // write: value
    int result = 0;
    Clock::time_point at{};              // when the call started
    Clock::time_point end{};             // when it returned
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
  // Stamps a call: it starts now and takes its kind's cost.
  void log(Call c) {
    c.at = clock->now();
    Clock::duration d = c.kind == Call::upload ? cost.upload : c.kind == Call::erase ? cost.erase : cost.write;
    if (cost.jitter.count() > 0) {
      jitter_seed = jitter_seed * 1664525u + 1013904223u;
      d += cost.jitter * (jitter_seed >> 8) / (1u << 24);
    }
    clock->advance(d);
    c.end = clock->now();
    calls.push_back(c);
  }
};

inline std::shared_ptr<FakeDeviceState> fake_device(std::initializer_list<std::uint16_t> bits, int effects_max) {
  auto s = std::make_shared<FakeDeviceState>();
  for (auto b : bits) s->caps.bits.set(b);
  s->caps.effects_max = effects_max;
  s->used.assign(static_cast<std::size_t>(effects_max), false);
  s->playing.assign(static_cast<std::size_t>(effects_max), false);
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
    s_->playing.assign(s_->playing.size(), false);
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
      } else if (!valid(e.id)) {
        r = EINVAL;
      }
    }
    call.id = e.id;
    call.result = r;
    s_->log(call);
    return r;
  }

  int erase(std::int16_t id) override {
    int r = 0;
    if (s_->unplugged) {
      r = ENODEV;
    } else if (!valid(id)) {
      r = EINVAL;
    } else {
      s_->playing[static_cast<std::size_t>(id)] = false;  // ff-core stops it, then erases it
      s_->used[static_cast<std::size_t>(id)] = false;
    }
    s_->log({FakeDeviceState::Call::erase, {}, id, 0, r});
    return r;
  }

  int write_ff(std::uint16_t code, std::int32_t value) override {
    const int r = s_->unplugged ? ENODEV : 0;
    if (r == 0 && code != FF_GAIN && valid(static_cast<std::int16_t>(code))) s_->playing[code] = value != 0;
    s_->log({FakeDeviceState::Call::write, {}, static_cast<std::int16_t>(code), value, r});
    return r;
  }

  const std::string& node() const override { return node_; }

 private:
  bool valid(std::int16_t id) const {
    return id >= 0 && static_cast<std::size_t>(id) < s_->used.size() && s_->used[static_cast<std::size_t>(id)];
  }
  std::shared_ptr<FakeDeviceState> s_;
  std::string node_;
};

}  // namespace sculpt::haptics::testing
