// One open evdev node read through libevdev: frames per SYN_REPORT, the
// SYN_DROPPED resync, MSC_TIMESTAMP unwrapping, ENODEV as "gone". Owned by
// DeviceManager (io thread); separate so the reading logic reads on its own.
#pragma once

#include <linux/input.h>

#include <cstdint>
#include <filesystem>
#include <functional>

#include "input/device_info.hpp"
#include "input/input_message.hpp"
#include "files/unique_fd.hpp"

struct libevdev;

namespace sculpt::input {

class EvdevDevice {
 public:
  // Opens read-only, non-blocking; the kernel stamps events with
  // CLOCK_MONOTONIC. Throws std::system_error naming the node.
  explicit EvdevDevice(const std::filesystem::path& node);
  ~EvdevDevice();
  EvdevDevice(const EvdevDevice&) = delete;
  EvdevDevice& operator=(const EvdevDevice&) = delete;

  int fd() const { return fd_.get(); }
  const DeviceInfo& info() const { return info_; }
  DeviceInfo& info() { return info_; }
  void set_slot(std::uint8_t slot) { frame_.slot = slot; }
  std::uint8_t slot() const { return frame_.slot; }

  enum class ReadResult { drained, gone };
  // Reads everything available; calls `emit` once per complete report (or
  // part of an over-long one). `gone` once the device is unplugged (ENODEV)
  // or the fd failed otherwise; `error` (if given) receives the errno.
  ReadResult read(const std::function<void(const InputFrame&)>& emit, int* error = nullptr);

  std::uint64_t resyncs() const { return resyncs_; }

 private:
  void handle(const ::input_event& ev, bool resync, const std::function<void(const InputFrame&)>& emit);
  void flush(const std::function<void(const InputFrame&)>& emit, bool partial);

  files::UniqueFd fd_;
  libevdev* dev_ = nullptr;
  DeviceInfo info_;
  InputFrame frame_{};
  bool have_msc_ = false;          // this report carried MSC_TIMESTAMP
  bool msc_started_ = false;
  std::uint32_t msc_last_ = 0;
  std::int64_t msc_total_ = 0;     // unwrapped device clock, µs
  std::int64_t arrival_us_ = 0;
  std::uint64_t resyncs_ = 0;
};

// A description from an open libevdev handle (kind from capabilities).
DeviceInfo describe_evdev(libevdev* dev, int fd, const std::string& node);

std::int64_t monotonic_us();

}  // namespace sculpt::input
