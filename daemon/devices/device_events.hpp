// Live devices' events on the kj event loop: every device fd sits in one
// level-triggered epoll set, which a kj FdObserver watches; ready fds are
// dispatched to the DeviceManager, 32 rounds of 16 at most before the loop
// gets a turn. When the manager's fds change (a device comes or goes) the
// set is rebuilt from scratch: a closed fd's number may already belong to a
// new device.
#pragma once

#include <vector>

#include <kj/async-unix.h>

#include "files/unique_fd.hpp"
#include "input/device_manager.hpp"

namespace sculpt::daemon {

class DeviceEvents {
 public:
  // After devices.start(). Throws std::system_error when epoll cannot be made.
  DeviceEvents(kj::UnixEventPort& port, input::DeviceManager& devices);
  ~DeviceEvents();
  DeviceEvents(const DeviceEvents&) = delete;
  DeviceEvents& operator=(const DeviceEvents&) = delete;

  // Dispatches events until the promise is dropped.
  kj::Promise<void> run();

 private:
  bool drain();  // true when some fds may still be ready
  void sync_fds();

  input::DeviceManager& devices_;
  files::UniqueFd epoll_;
  std::vector<int> registered_;
  bool fds_changed_ = false;
  kj::Own<kj::UnixEventPort::FdObserver> observer_;
};

}  // namespace sculpt::daemon
