#include "devices/device_table.hpp"

#include <linux/input.h>

#include <string>

namespace sculpt::daemon {

void DeviceTable::attached(std::uint8_t slot, const input::DeviceInfo& info, const input::DeviceBinding& binding) {
  server::DeviceEntry d;
  d.slot = slot;
  d.name = info.name;
  d.node = info.node;
  d.vendor = info.vendor;
  d.product = info.product;
  d.kind = std::string(input::to_string(info.kind));
  d.connected = true;
  d.ff = info.has_ff(FF_CONSTANT) ? 2 : info.has_ff(FF_RUMBLE) ? 1 : 0;
  for (std::uint32_t t = 0; t < sim::kMaxTools; ++t)
    if (binding.drives(t)) d.tools.push_back(t);
  entries_[slot] = std::move(d);
}

void DeviceTable::detached(std::uint8_t slot) {
  if (auto it = entries_.find(slot); it != entries_.end()) {
    it->second.connected = false;
    it->second.node.clear();
  }
}

std::vector<std::int32_t> DeviceTable::slot_of_tools(std::size_t tools) const {
  std::vector<std::int32_t> slot_of(tools, -1);
  for (const auto& [slot, d] : entries_)
    if (d.connected)
      for (std::uint32_t t : d.tools)
        if (t < slot_of.size()) slot_of[t] = static_cast<std::int32_t>(slot);
  return slot_of;
}

}  // namespace sculpt::daemon
