#include "devices/device_hub.hpp"

#include <linux/input.h>

#include <bit>
#include <stdexcept>

#include <fmt/format.h>

#include "simloop/scene_tools.hpp"
#include "log/log.hpp"

namespace sculpt::daemon {
namespace {

// The tool driver moves tool component i along the scene's axis i, so the
// binding's components are the haptics' axes.
std::vector<haptics::ToolStick> tool_sticks(const input::DeviceBinding& b, std::size_t tools) {
  std::vector<haptics::ToolStick> out;
  for (std::size_t t = 0; t < tools; ++t) {
    if (!b.drives(t)) continue;
    const input::StickPlane p = input::stick_plane(b, t);
    haptics::ToolStick ts;
    ts.tool = static_cast<int>(t);
    if (p.valid) {
      ts.plane.x_axis = p.x_component;
      ts.plane.y_axis = p.y_component;
      ts.plane.x_sign = p.x_scale;
      ts.plane.y_sign = p.y_scale;
    } else {
      ts.plane.x_axis = -1;
      ts.plane.y_axis = -1;
    }
    out.push_back(ts);
  }
  return out;
}

// Which tool each analog trigger drives: the trigger axis (ABS_Z left,
// ABS_RZ right, as hid-playstation reports L2/R2) bound to a tool's depth
// role. The haptics opens the pad's hidraw node only for a DualSense.
haptics::TriggerBinding trigger_binding(const input::DeviceBinding& b) {
  haptics::TriggerBinding out;
  for (std::size_t i = 0; i < b.axis_count; ++i) {
    const input::AxisBinding& a = b.axes[i];
    if (a.tool == input::kNoTool || a.component != 2 || !a.calibration.unipolar) continue;  // a twist is no trigger
    if (a.code == ABS_Z && out.left_tool < 0) out.left_tool = a.tool;
    if (a.code == ABS_RZ && out.right_tool < 0) out.right_tool = a.tool;
  }
  return out;
}

// linux/input.h's bus types, as `sculptctl devices` shows them.
std::string bus_name(std::uint16_t bustype) {
  switch (bustype) {
    case 0: return "";
    case BUS_USB: return "usb";
    case BUS_BLUETOOTH: return "bluetooth";
    case BUS_VIRTUAL: return "virtual";
    case BUS_I2C: return "i2c";
    case BUS_HOST: return "host";
    default: return fmt::format("bus 0x{:02x}", bustype);
  }
}

}  // namespace

DeviceHub::DeviceHub(bool device_clock, double input_delay_ms, std::function<std::uint64_t()> current_tick)
    : device_clock_(device_clock), current_tick_(std::move(current_tick)), clock_(1000.0, input_delay_ms) {}

void DeviceHub::set_server(server::Server* server) {
  server_ = server;
  tell_server();
}

void DeviceHub::use_scene(const scene::Scene& scene, std::size_t tools, SculptStages& stages, double rate) {
  tools_ = tools;
  stages_ = &stages;
  clock_.set_rate(rate);
  router_.set_routes(simloop::tool_routes(scene));
}

void DeviceHub::push(const input::InputMessage& m, const char* what) {
  if (stages_->ring().try_push(m)) return;
  // The sim thread drains the ring every tick; a full ring means it is stuck.
  if (dropped_++ % 1000 == 0) log::warning("input ring full: dropped a {} message ({} so far)", what, dropped_);
}

input::DeviceBinding DeviceHub::bind(std::uint8_t slot, const input::DeviceInfo& info) {
  router_.detach(slot);
  const input::DeviceBinding b = router_.attach(slot, info, mapping_);
  for (const auto& w : router_.warnings()) log::warning("{}", w);
  table_.attached(slot, info, b);
  tell_server();
  return b;
}

void DeviceHub::rebind(const input::DeviceManager& devices) {
  for (const auto& [slot, info] : devices.devices()) on_attach(slot, info);
}

void DeviceHub::carry_over(SculptStages& old, const std::vector<input::DeviceInfo>* recorded) {
  if (recorded)
    for (std::uint8_t slot = 0; slot < recorded->size(); ++slot)
      if (old.mapper().attached(slot))
        push(input::InputMessage::attach(slot, bind(slot, (*recorded)[slot])), "attach");
  while (auto m = old.ring().try_pop()) push(*m, "queued");
}

std::vector<server::DeviceEntry> DeviceHub::entries() const {
  std::vector<server::DeviceEntry> out;
  for (const auto& [slot, d] : table_.entries()) {
    out.push_back(d);
    static_assert(haptics::HapticsStats::kSlots >= input::kMaxDevices, "a device slot without an FF counter");
    if (haptics_ && slot < haptics::HapticsStats::kSlots) {
      server::DeviceEntry& e = out.back();
      e.ff_uploads = haptics_->stats().slot_uploads[slot].load(std::memory_order_relaxed);
      e.bus = bus_name(haptics_->bustype(slot));
      const haptics::DeviceTuning t = haptics_->tuning(slot);
      e.gain = t.gain;
      e.limit = t.limit;
    }
  }
  return out;
}

server::HapticsTuneOutcome DeviceHub::tune_haptics(std::uint32_t slot, const server::HapticsTune& tune) {
  server::HapticsTuneOutcome out;
  if (slot > 0xff || !table_.entries().count(static_cast<std::uint8_t>(slot))) {
    out.error = fmt::format("no device on slot {} (sculptctl devices lists them)", slot);
    return out;
  }
  if (!haptics_) {
    out.error = "force feedback is off ([haptics] enabled = false)";
    return out;
  }
  haptics::DeviceTuning t = haptics_->tuning(static_cast<int>(slot));
  if (tune.gain) t.gain = *tune.gain;
  if (tune.limit) t.limit = *tune.limit;
  try {
    haptics_->tune(static_cast<int>(slot), t);
    // At info the first, then one line per slot per 10 s with the value in
    // force (the rest at debug): one client cannot fill the journal.
    const std::string line = fmt::format(
        "device on slot {}: force-feedback gain {:.3g}, limit {:.3g} (until a restart or reload)", slot, t.gain, t.limit);
    if (auto now_line = tunes_log_.changed(slot, line, std::chrono::steady_clock::now())) log::info("{}", *now_line);
    else log::debug("{}", line);
  } catch (const std::invalid_argument& e) {
    out.error = e.what();
    t = haptics_->tuning(static_cast<int>(slot));
  }
  out.gain = t.gain;
  out.limit = t.limit;
  return out;
}

void DeviceHub::log_held_tunes(std::chrono::steady_clock::time_point now) {
  for (const std::string& line : tunes_log_.due(now)) log::info("{}", line);
}

void DeviceHub::tell_server() {
  if (server_) server_->set_tool_devices(table_.slot_of_tools(tools_));
}

void DeviceHub::on_attach(std::uint8_t slot, const input::DeviceInfo& info) {
  const input::DeviceBinding b = bind(slot, info);
  clock_.forget(slot);
  push(input::InputMessage::attach(slot, b), "attach");
  log::info("device {}: {} [{}] on slot {}, drives {} tool(s)", info.node.empty() ? "(recorded)" : info.node,
            info.name, input::to_string(info.kind), slot, std::popcount(b.tool_mask));
  if (haptics_ && !info.node.empty()) haptics_->attach(slot, info.node, tool_sticks(b, tools_), trigger_binding(b));
}

void DeviceHub::on_detach(std::uint8_t slot) {
  router_.detach(slot);
  table_.detached(slot);
  tell_server();
  clock_.forget(slot);
  push(input::InputMessage::detach(slot), "detach");
  if (haptics_) haptics_->detach(slot);
  log::info("device on slot {} is gone", slot);
}

void DeviceHub::on_frame(const input::InputFrame& frame) {
  input::InputFrame f = frame;
  if (device_clock_) {
    const input::DeviceClock::Placement p = clock_.place(f, current_tick_());
    if (p.anchored)
      log::debug("slot {}: device clock anchored: device time {} us applies on tick {}", f.slot, f.device_time_us,
                 p.tick);
    f.at_tick = p.tick;
  }
  push(input::InputMessage::of_frame(f), "frame");
}

void DeviceHub::on_log(int priority, const std::string& message) {
  log::write_priority(priority, message);
}

}  // namespace sculpt::daemon
