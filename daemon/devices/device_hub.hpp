// Devices to tools, on the io thread: binds each device (live or recorded)
// to the installed scene's tools with the configured mapping, forwards its
// attach, detach and frames to the sim thread's input ring (on the device's
// own clock with --input-clock device), hands the force-feedback devices to
// the haptics thread, and keeps the device table the server lists.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "haptics/haptics_thread.hpp"
#include "input/device_clock.hpp"
#include "input/device_manager.hpp"
#include "input/mapping.hpp"
#include "devices/change_log.hpp"
#include "devices/device_table.hpp"
#include "host/sculpt_stages.hpp"
#include "scene/scene.hpp"
#include "server/server.hpp"

namespace sculpt::daemon {

class DeviceHub final : public input::DeviceListener {
 public:
  // `current_tick` says which tick a device-clock frame is placed against.
  DeviceHub(bool device_clock, double input_delay_ms, std::function<std::uint64_t()> current_tick);

  void set_mapping(input::MappingConfig mapping) { mapping_ = std::move(mapping); }
  void set_input_delay_ms(double ms) { clock_.set_delay_ms(ms); }
  void set_haptics(haptics::HapticsThread* haptics) { haptics_ = haptics; }
  // Told which device drives each tool, now and whenever that changes.
  void set_server(server::Server* server);
  // A scene was installed: its tools, their routes, its input ring, its rate.
  void use_scene(const scene::Scene& scene, std::size_t tools, SculptStages& stages, double rate);

  // Queues a message for the sim thread; a full ring drops it, with a warning.
  void push(const input::InputMessage& m, const char* what);
  // Binds a device on `slot` to the installed scene's tools and lists it
  // (a recorded device's attach is queued by its replay, a live one's by on_attach).
  input::DeviceBinding bind(std::uint8_t slot, const input::DeviceInfo& info);
  // Binds every live device again (a new mapping or scene).
  void rebind(const input::DeviceManager& devices);
  // After a swap: the recorded devices `old` had attached, bound again and
  // queued as attaches, then what `old` still had queued.
  void carry_over(SculptStages& old, const std::vector<input::DeviceInfo>* recorded);
  // `sculptctl devices`: the table, with each slot's FF upload count, bus
  // and force-feedback tuning.
  std::vector<server::DeviceEntry> entries() const;
  // `sculptctl haptics SLOT --gain G --limit L`: a listed slot's tuning, kept
  // by the haptics thread for the slot (across replug) until a config reload.
  server::HapticsTuneOutcome tune_haptics(std::uint32_t slot, const server::HapticsTune& tune);
  // Logs the tunings held back by the limit (one line per slot per 10 s).
  void log_held_tunes(std::chrono::steady_clock::time_point now);
  // Tells the server which device drives each tool (again, after its scene changed).
  void tell_server();

  // input::DeviceListener
  void on_attach(std::uint8_t slot, const input::DeviceInfo& info) override;
  void on_detach(std::uint8_t slot) override;
  void on_frame(const input::InputFrame& frame) override;
  void on_log(int priority, const std::string& message) override;

 private:
  bool device_clock_;
  std::function<std::uint64_t()> current_tick_;
  input::MappingConfig mapping_;
  input::ToolRouter router_;
  input::DeviceClock clock_;
  DeviceTable table_;
  std::size_t tools_ = 0;
  SculptStages* stages_ = nullptr;
  haptics::HapticsThread* haptics_ = nullptr;
  server::Server* server_ = nullptr;
  std::uint64_t dropped_ = 0;
  ChangeLog tunes_log_{std::chrono::seconds(10)};
};

}  // namespace sculpt::daemon
