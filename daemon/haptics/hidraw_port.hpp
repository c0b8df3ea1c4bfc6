// The hidraw node behind an evdev node, for output reports the input layer
// has no ioctl for (the DualSense's trigger effects). Discovery walks sysfs:
//
//   /sys/class/input/eventN/device          → the input device (inputM)
//   /sys/class/input/eventN/device/device   → its HID device, named
//                                             BUS:VENDOR:PRODUCT.INSTANCE
//   <HID device>/hidraw/hidrawK             → /dev/hidrawK
//
// The sysfs and /dev roots are parameters so unit tests run against a fake
// tree in a temp dir.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include "haptics/dualsense_triggers.hpp"

namespace sculpt::haptics {

struct HidrawInfo {
  std::string node;         // /dev/hidrawK
  std::uint16_t bus = 0;    // BUS_USB 0x03, BUS_BLUETOOTH 0x05
  std::uint16_t vendor = 0;
  std::uint16_t product = 0;
};

// The hidraw node of the HID device behind `event_node` (/dev/input/eventN),
// or nullopt when there is none (not a HID device, hidraw not built, a
// uinput device).
std::optional<HidrawInfo> find_hidraw(const std::string& event_node, const std::filesystem::path& sys_root = "/sys",
                                      const std::filesystem::path& dev_root = "/dev");

// Writes output reports to one hidraw node; unit tests substitute a fake.
class HidrawPort {
 public:
  virtual ~HidrawPort() = default;
  // One whole report, its id first: 0 or the errno (a short write is EIO).
  virtual int write_report(std::span<const std::uint8_t> report) = 0;
  virtual const std::string& node() const = 0;
};

// A DualSense's hidraw node, opened.
struct DualSenseHidraw {
  std::unique_ptr<HidrawPort> port;
  dualsense::Transport transport = dualsense::Transport::usb;
};

// nullopt: the device behind `event_node` is not a DualSense (or has no
// hidraw node). Throws std::system_error (EACCES without the udev rule)
// when it is one but cannot be opened O_RDWR | O_NONBLOCK.
std::optional<DualSenseHidraw> open_dualsense_hidraw(const std::string& event_node,
                                                     const std::filesystem::path& sys_root = "/sys",
                                                     const std::filesystem::path& dev_root = "/dev");

}  // namespace sculpt::haptics
