// Where the input comes from: a recording replayed (its frames read
// ahead on the feed's own thread and queued as far ahead as the ring holds)
// or the live devices (the DeviceManager, its fds watched on the kj loop).
// Either way the DeviceHub binds the devices and takes their messages.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <kj/async-unix.h>

#include "input/device_manager.hpp"
#include "input/replay_feed.hpp"
#include "devices/device_events.hpp"
#include "devices/device_hub.hpp"
#include "devices/input_spec.hpp"

namespace sculpt::daemon {

class InputSource {
 public:
  // Opens what `spec` names; throws naming what is wrong (a bad
  // recording line, no devices subsystem). A replay's attaches and first
  // frames are queued here, before the first tick.
  InputSource(const InputSpec& spec, InputClock clock, double rate_hz, DeviceHub& hub, kj::UnixEventPort& port);
  ~InputSource();

  // The live devices' event dispatch for the io loop's task set (none for a replay).
  std::optional<kj::Promise<void>> run();
  // Replay: queues what the ring has room for. A file that changed under us
  // since the start's check ends the replay (logged once), not the daemon.
  void pump(concurrency::SpscRing<input::InputMessage>& ring);
  // Devices attached now (or recorded).
  std::uint64_t count() const;
  bool replaying() const { return replay_ != nullptr; }
  // A replay's recorded devices, nullptr for live input.
  const std::vector<input::DeviceInfo>* recorded() const;
  // The live devices, nullptr for a replay.
  const input::DeviceManager* live() const { return devices_.get(); }
  // Closes the live devices (at shutdown, once the loop's tasks are gone).
  void close();

 private:
  void open_replay(const InputSpec& spec, double rate_hz, DeviceHub& hub);

  std::unique_ptr<input::ReplayFeed> replay_;
  bool replay_failed_ = false;
  std::unique_ptr<input::DeviceManager> devices_;
  std::unique_ptr<DeviceEvents> events_;  // after devices_: destroyed first
};

}  // namespace sculpt::daemon
