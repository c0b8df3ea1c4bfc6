// What clients ask of the daemon through the server (server::DaemonControl),
// answered on the io thread from the parts that know: the sim host (stats,
// pause, simulated time), the device hub (the device table), the input
// source (device count), the haptics thread (FF uploads). Loads and resets
// go to `load`, which builds off the loop and swaps the result in.
#pragma once

#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include <kj/async.h>

#include "haptics/haptics_thread.hpp"
#include "devices/device_hub.hpp"
#include "devices/input_source.hpp"
#include "keeper/keeper.hpp"
#include "host/sim_host.hpp"
#include "scene/scene.hpp"
#include "server/daemon_control.hpp"

namespace sculpt::daemon {

class ControlDesk final : public server::DaemonControl {
 public:
  // Builds read()'s scene and swaps it in; resolves to "" or the error.
  using Load = std::function<kj::Promise<std::string>(std::function<SceneSource()> read, const char* what)>;

  ControlDesk(SimHost& sims, DeviceHub& hub, Load load) : sims_(sims), hub_(hub), load_(std::move(load)) {}

  // Set once they exist (the server may be asked before).
  void set_input(const InputSource* input) { input_ = input; }
  void set_haptics(const haptics::HapticsThread* haptics) { haptics_ = haptics; }
  void set_started(std::chrono::steady_clock::time_point started) { started_ = started; }
  void set_keeper(Keeper* keeper) { keeper_ = keeper; }

  // Devices attached now (or recorded), for the status and the stats.
  std::uint64_t device_count() const { return input_ ? input_->count() : 0; }
  std::uint64_t ff_uploads() const { return haptics_ ? haptics_->stats().ff.uploads.load() : 0; }

  server::DaemonStatus status() override;
  std::vector<server::DeviceEntry> devices() override { return hub_.entries(); }
  kj::Promise<std::string> load_scene(const std::string& path) override;
  kj::Promise<std::string> reset() override;
  std::string set_paused(bool paused) override { return sims_.set_paused(paused); }
  bool paused_now() override { return sims_.paused(); }
  // The keeper's (none with --no-store: each says so).
  kj::Promise<server::HistoryMoveOutcome> undo(std::uint32_t count) override;
  kj::Promise<server::HistoryMoveOutcome> redo(std::uint32_t count) override;
  server::History history(std::uint32_t from, std::uint32_t limit) override;
  kj::Promise<server::ExportOutcome> export_sculpt() override;
  server::HapticsTuneOutcome tune_haptics(std::uint32_t slot, const server::HapticsTune& tune) override {
    return hub_.tune_haptics(slot, tune);
  }

 private:
  SimHost& sims_;
  DeviceHub& hub_;
  Load load_;
  const InputSource* input_ = nullptr;
  const haptics::HapticsThread* haptics_ = nullptr;
  Keeper* keeper_ = nullptr;
  kj::Promise<server::HistoryMoveOutcome> move_history(bool undo, std::uint32_t count);
  std::chrono::steady_clock::time_point started_{};
};

}  // namespace sculpt::daemon
