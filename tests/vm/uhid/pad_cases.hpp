// Shared by the uhid VM tests: the pads as gtest parameters, the motor bytes
// each driver makes of an FF_RUMBLE magnitude, and a stand-in sim thread.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include "haptics/feedback_board.hpp"
#include "support/timing.hpp"
#include "support/uhid_pad.hpp"

namespace sculpt::support::uhidtest {

// What the driver writes for a (gain-scaled) FF_RUMBLE magnitude:
// hid-playstation and hid-sony take the high byte (magnitude / 256),
// hid-microsoft scales to 0..100 (magnitude * 100 / 0xffff).
inline std::uint8_t motor_byte(const UhidPadSpec& spec, std::uint16_t magnitude) {
  if (spec.motor_max == 100) return static_cast<std::uint8_t>(std::uint32_t{magnitude} * 100 / 0xffff);
  return static_cast<std::uint8_t>(magnitude / 256);
}

// The gtest name of a pad parameter: the module without ".ko", '_' for '-'.
struct PadName {
  template <class Info>
  std::string operator()(const Info& info) const {
    std::string n = info.param->module.substr(0, info.param->module.find('.'));
    std::replace(n.begin(), n.end(), '-', '_');
    return n;
  }
};

using support::scaled;

// Tool 0 pressing with `newton` along x, or not touching at all.
inline haptics::Felt touching(double newton) {
  haptics::Felt f;
  f.force = {newton, 0, 0};
  f.contacts = 4;
  f.touching = true;
  return f;
}
inline haptics::Felt free_air() { return haptics::Felt{}; }

// The sim thread's part: publishes tool 0's Felt and beats, about once a
// millisecond, until destroyed. A publish that starts touching marks an
// onset; with beating off the beat stops as a stalled sim thread's would.
class BoardPublisher {
 public:
  explicit BoardPublisher(haptics::FeedbackBoard& board) : board_(board) {
    thread_ = std::thread([this] {
      bool was_touching = false;
      while (!stop_.load()) {
        haptics::Felt f;
        {
          std::lock_guard lock(mutex_);
          f = felt_;
        }
        f.onset = f.touching && !was_touching;
        if (f.onset) f.onset_impulse = 0.001;
        was_touching = f.touching;
        board_.publish(0, f);
        if (beating_.load()) board_.beat();
        std::this_thread::sleep_for(std::chrono::milliseconds(1));  // the sim's own pace
      }
    });
  }
  ~BoardPublisher() {
    stop_.store(true);
    thread_.join();
  }
  BoardPublisher(const BoardPublisher&) = delete;
  BoardPublisher& operator=(const BoardPublisher&) = delete;

  void set(const haptics::Felt& f) {
    std::lock_guard lock(mutex_);
    felt_ = f;
  }
  void set_beating(bool b) { beating_.store(b); }

 private:
  haptics::FeedbackBoard& board_;
  std::mutex mutex_;
  haptics::Felt felt_{};
  std::atomic<bool> beating_{true};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace sculpt::support::uhidtest
