// Feeds a recording into the input pipeline with no devices at all
// (`sculptd --input replay:FILE`). Runs on the io thread: produces one attach
// message per recorded device, then every frame with at_tick =
// start_tick + round(t_us · rate / 1e6), so the simulation thread applies each
// frame exactly on its tick whatever the io thread's timing: the same recording
// gives bit-identical meshes.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>

#include "concurrency/spsc_ring.hpp"
#include "input/input_message.hpp"
#include "input/recording.hpp"

namespace sculpt::input {

// The tick a frame recorded at t_us applies on: start_tick + round(t_us ·
// rate_hz / 1e6), halves up, in integer arithmetic for whole rates. Whoever
// schedules by device time (sculptd --input-clock device) should use this
// too, so uinput replays land on exactly the ticks ReplaySource gives.
std::uint64_t replay_tick(std::uint64_t start_tick, std::int64_t t_us, double rate_hz);

class ReplaySource {
 public:
  // Resolves a device's binding (ToolRouter::attach, usually).
  using Binder = std::function<DeviceBinding(std::uint8_t slot, const DeviceInfo& info)>;

  // Opens the recording (RecordingError on a bad header). At most kMaxDevices devices.
  ReplaySource(const std::filesystem::path& file, double rate_hz, Binder binder);

  const RecordingHeader& header() const { return reader_.header(); }

  // Fixes the tick of t_us = 0; call before the first next()/pump().
  void start(std::uint64_t start_tick);
  std::uint64_t tick_of(std::int64_t t_us) const;

  // The next message in order (attaches first), nullopt at the end. Reports
  // longer than kMaxFrameEvents become several frames on the same tick.
  std::optional<InputMessage> next();

  // Pushes messages into the ring until it is full or the recording ends, but
  // none due later than `horizon_tick` (0: no limit). Returns how many.
  std::size_t pump(concurrency::SpscRing<InputMessage>& ring, std::uint64_t horizon_tick = 0);

  bool finished() const { return finished_ && !pending_; }
  // The tick of the last message produced so far.
  std::uint64_t last_tick() const { return last_tick_; }

 private:
  RecordingReader reader_;
  double rate_hz_;
  Binder binder_;
  std::uint64_t start_tick_ = 1;
  std::size_t attached_ = 0;
  std::optional<RecordingFrame> frame_;   // being split
  std::size_t frame_pos_ = 0;
  std::optional<InputMessage> pending_; // produced but not yet pushed
  bool finished_ = false;
  std::uint64_t last_tick_ = 0;
};

}  // namespace sculpt::input
