// Finds joysticks and gamepads and reads them (io thread).
//
// Discovery: with a running udevd, libudev enumeration plus a udev monitor
// (devices arrive after udev's rules ran, with ID_INPUT_JOYSTICK); without one
// (containers, minimal systems, the plain test VM) an inotify watch on
// /dev/input and classification from evdev capabilities. Also with udev, a
// node udev has no properties for is classified by capabilities.
//
// Reading: libevdev, one InputFrame per SYN_REPORT; SYN_DROPPED → the resync
// events libevdev computes, flagged; ENODEV (or a udev "remove") → detach.
//
// Slots are stable: a device that comes back with the same identity
// (vendor/product/uniq/phys/name) gets its old slot, hence the same tools.
//
// Not thread-safe: everything runs on the thread that calls dispatch().
// The owner polls fds() (kj FdObservers in sculptd) and calls dispatch(fd)
// when one is readable; the fd set changes only inside start()/dispatch(),
// after which the fds-changed callback runs.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "input/device_info.hpp"
#include "input/input_message.hpp"

namespace sculpt::input {

class DeviceListener {
 public:
  virtual ~DeviceListener() = default;
  virtual void on_attach(std::uint8_t slot, const DeviceInfo& info) = 0;
  virtual void on_detach(std::uint8_t slot) = 0;
  // One report (or a part of a long one); at_tick is 0: the owner schedules it.
  virtual void on_frame(const InputFrame& frame) = 0;
  // Something worth a log line (a node that cannot be opened, a device ignored...).
  virtual void on_log(int priority, const std::string& message) { (void)priority; (void)message; }
};

enum class Discovery : std::uint8_t {
  automatic,  // udev when udevd runs (/run/udev/control exists), else inotify
  udev,
  inotify,
};

struct DeviceManagerOptions {
  Discovery discovery = Discovery::automatic;
  std::filesystem::path dev_dir = "/dev/input";   // inotify mode: where event nodes appear
  bool accept_all = false;                        // also "other" devices (sculptctl record --all)
};

class DeviceManager {
 public:
  DeviceManager(DeviceListener& listener, DeviceManagerOptions options = {});
  ~DeviceManager();
  DeviceManager(const DeviceManager&) = delete;
  DeviceManager& operator=(const DeviceManager&) = delete;

  // Sets up discovery and opens every joystick already present (on_attach
  // for each). Throws std::system_error when neither udev nor inotify work.
  void start();

  // The fds to watch for readability: the discovery fd plus one per device.
  std::vector<int> fds() const;
  void on_fds_changed(std::function<void()> callback);
  // Handles whatever is ready on `fd` (never blocks). Unknown fds are ignored.
  void dispatch(int fd);

  // "udev" or "inotify" once started.
  std::string_view discovery() const;
  // Attached devices, by slot.
  std::vector<std::pair<std::uint8_t, DeviceInfo>> devices() const;
  std::size_t attached() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The description of an open evdev node (libevdev), kind from capabilities.
// Throws std::system_error naming the node.
DeviceInfo describe_node(const std::filesystem::path& node);

}  // namespace sculpt::input
