// The other end of a device test: what a program like sculptd does with an
// event node. Input goes through libevdev; force feedback through the raw
// ioctls and writes, because libevdev has no API for FF uploads.
#pragma once

#include <linux/input.h>

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "support/unique_fd.hpp"

struct libevdev;

namespace sculpt::support {

// Effects as a client would build them; id -1 asks the kernel for a new id.
ff_effect constant_effect(std::int16_t level, std::uint16_t direction, std::uint16_t length_ms,
                          std::int16_t id = -1);
ff_effect rumble_effect(std::uint16_t strong, std::uint16_t weak, std::uint16_t length_ms,
                        std::int16_t id = -1);
ff_effect sine_effect(std::int16_t magnitude, std::uint16_t period_ms, std::uint16_t length_ms,
                      std::int16_t id = -1);

class EvdevClient {
 public:
  // Opens the node read-write and non-blocking. Throws std::system_error
  // naming the node when it cannot.
  explicit EvdevClient(const std::string& node);
  ~EvdevClient();
  EvdevClient(const EvdevClient&) = delete;
  EvdevClient& operator=(const EvdevClient&) = delete;

  libevdev* dev() const { return dev_; }
  int fd() const { return fd_.get(); }
  std::string name() const;
  bool has_ff(std::uint16_t bit) const;
  int ff_effects_max() const;  // EVIOCGEFFECTS

  // Each returns 0 or the errno the kernel gave. upload() writes the
  // assigned id back into `effect`.
  int upload(ff_effect& effect);
  int erase(std::int16_t id);
  int play(std::int16_t id, std::int32_t count = 1);
  int stop(std::int16_t id);
  int set_gain(std::uint16_t gain);
  int set_autocenter(std::uint16_t strength);

  // The next input event, waiting up to `timeout`; nullopt on timeout.
  // Throws std::system_error with the errno (ENODEV once unplugged).
  std::optional<input_event> next_event(std::chrono::milliseconds timeout = std::chrono::milliseconds(20000));

  // Closes the fd; returns close()'s errno (0 on success). The kernel erases
  // this client's effects while closing.
  int close();

 private:
  int write_ff(std::uint16_t code, std::int32_t value);
  UniqueFd fd_;
  libevdev* dev_ = nullptr;
};

}  // namespace sculpt::support
