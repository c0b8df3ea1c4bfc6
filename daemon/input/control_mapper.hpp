// The simulation thread's view of the controls: applies attach, detach and
// frame messages and keeps, per tool, the stick deflection (calibrated,
// dead zone applied), grab and the monotonic button counters. No allocation,
// no locks, no syscalls after construction.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "concurrency/spsc_ring.hpp"
#include "input/input_message.hpp"

namespace sculpt::sim {
class StateView;
}

namespace sculpt::input {

struct ToolControl {
  std::array<float, 3> stick{};     // -1..1 after calibration and dead zone: x, y, depth
  bool grab = false;
  std::uint32_t shape_toggles = 0;  // presses so far (monotonic: the driver sees every press)
  std::int32_t size_steps = 0;      // grow presses minus shrink presses so far
  bool connected = false;           // some attached device drives this tool
};

class ControlMapper {
 public:
  explicit ControlMapper(std::size_t tools = sim::kMaxTools);

  void apply(const InputMessage& message);

  // Applies every message at the front of the ring that is due at `tick`
  // (at_tick == 0 or at_tick <= tick), in order; stops at the first one that
  // is not due yet. Returns how many were applied.
  std::size_t drain(concurrency::SpscRing<InputMessage>& ring, std::uint64_t tick);
  // One message due at `tick` (what drain does with each).
  void take(const InputMessage& message, std::uint64_t tick);
  // Scheduled messages (at_tick != 0) applied after their tick: their
  // producer fell behind. A replay with any is not reproducible.
  std::uint64_t late() const { return late_; }

  std::span<const ToolControl> controls() const { return {controls_.data(), tools_}; }
  // Undo and redo presses so far, on any device (monotonic).
  std::uint32_t undo_presses() const { return undo_presses_; }
  std::uint32_t redo_presses() const { return redo_presses_; }

  // Everything later messages build on, as bytes (allocates): a mapper of
  // the same tool count continues from them exactly. restore_state throws
  // std::invalid_argument naming what does not match or cannot be (a flag
  // that is no flag, a binding the io thread could not make, a value out of
  // range), changing nothing.
  std::vector<std::byte> state() const;
  void restore_state(std::span<const std::byte> bytes);
  std::size_t tools() const { return tools_; }
  bool attached(std::uint8_t slot) const { return slot < kMaxDevices && devices_[slot].attached; }
  // The binding of a slot (for the haptics' stick plane), valid while attached.
  const DeviceBinding& binding(std::uint8_t slot) const { return devices_[slot % kMaxDevices].binding; }

 private:
  struct DeviceState {
    bool attached = false;
    DeviceBinding binding{};
    std::array<std::int32_t, kMaxBoundAxes> raw{};  // last raw value per bound axis
    std::array<float, kMaxBoundAxes> value{};
    std::array<bool, kMaxBoundButtons> held{};
  };
  void apply_event(DeviceState& d, const InputEvent& e);
  void check_state(const sim::StateView& view) const;
  void recompute();

  std::size_t tools_;
  std::array<DeviceState, kMaxDevices> devices_{};
  std::array<ToolControl, sim::kMaxTools> controls_{};
  std::uint64_t late_ = 0;
  std::uint32_t undo_presses_ = 0, redo_presses_ = 0;
};

}  // namespace sculpt::input
