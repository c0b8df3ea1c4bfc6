// Every device slot this run has seen, plugged in or not: what `sculptctl
// devices` lists and which device drives each streamed tool.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <vector>

#include "input/device_info.hpp"
#include "input/input_message.hpp"
#include "server/daemon_control.hpp"

namespace sculpt::daemon {

class DeviceTable {
 public:
  // A device took `slot` (live or recorded), bound to the tools of `binding`.
  void attached(std::uint8_t slot, const input::DeviceInfo& info, const input::DeviceBinding& binding);
  // The device on `slot` is gone; the slot stays listed, unplugged.
  void detached(std::uint8_t slot);
  // For each of `tools` tools, the slot of the plugged-in device driving it, or -1.
  std::vector<std::int32_t> slot_of_tools(std::size_t tools) const;
  const std::map<std::uint8_t, server::DeviceEntry>& entries() const { return entries_; }

 private:
  std::map<std::uint8_t, server::DeviceEntry> entries_;
};

}  // namespace sculpt::daemon
