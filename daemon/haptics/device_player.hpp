// What one device plays, written at most once per poll and never faster than
// its transport allows (the device's WritePacer, which FfDevice stamps after
// each write). The caller says what should be felt (want, kick, silence);
// step() picks the one write that matters most now:
//
//   1. the main effect has no id yet        → upload it (new id, then in place forever)
//   1a. silenced and the device still has something → upload the zero (before anything else)
//   1b. FF_GAIN to write (open, SIGHUP)     → write it (memless drivers send a report for it too)
//   2. the main effect is not playing        → play it (it is always playing: levels change in place)
//   3. a kick is pending                     → rumble-only: upload the kick mix into the one effect,
//                                               back to the contact level once kick length has passed;
//                                               constant: upload the kick effect, then play it
//                                               (after one force update if the force changed meanwhile)
//   4. the main effect differs really        → upload in place (to or from zero always counts)
//   5. the main effect's length runs out soon → play it again (re-arm, before driver limits)
//
// The main effect is FF_CONSTANT on constant-force devices, FF_RUMBLE on
// rumble-only pads. It gets a finite replay length (effect_length): some
// drivers stop a length-0 effect after ~65 s anyway.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>

#include "haptics/effect_math.hpp"
#include "haptics/ff_device.hpp"
#include "haptics/pacer.hpp"

namespace sculpt::haptics {

struct PlayerTiming {
  std::chrono::milliseconds effect_length{20000};                          // replay.length, < 65 s
  std::chrono::milliseconds rearm_every{5000};                             // replayed this often
  ChangeThreshold change{};
};

class DevicePlayer {
 public:
  explicit DevicePlayer(PlayerTiming timing) : timing_(timing) {}
  void set_timing(PlayerTiming timing) { timing_ = timing; }

  // The contact state wanted now, tuned: constant mode uses `constant`,
  // rumble-only mode `rumble` (its length is ignored).
  void want(const ConstantCommand& constant, const RumbleCommand& rumble) {
    want_constant_ = constant;
    want_rumble_ = rumble;
    silenced_ = false;
  }
  // FF_GAIN to write at the next write (when the device has it).
  void gain(std::uint16_t g) { gain_pending_ = g; }
  // Start a kick (tuned) as soon as pacing allows; kicks waiting merge (the
  // stronger one wins).
  void kick(const RumbleCommand& k);
  // Nothing may be felt (a stall, a hold): zero wanted, waiting kicks
  // dropped, a kick playing in the rumble effect ends at the next write; the
  // zero is the next write, before a waiting FF_GAIN or play. Until want().
  void silence();
  // The device was reopened: ids and playing state start afresh (the
  // device's pacer is the engine's, kept).
  void restart();

  // At most one write, when the device's pacer allows one at `now`. Returns
  // whether one was attempted.
  bool step(FfDevice& ff, Clock::time_point now);

  // Whether the device has nothing felt and nothing pending (zero reached).
  bool quiet(const FfDevice& ff) const;
  // Silenced and the zero not written yet: it goes out as soon as the pacer
  // allows (the engine wakes for it).
  bool zero_waiting(const FfDevice& ff) const;
  std::uint64_t kicks() const { return kicks_; }
  // The last write step() attempted was FF_GAIN (not an effect's).
  bool last_write_was_gain() const { return last_write_gain_; }

 private:
  RumbleCommand rumble_target(Clock::time_point now) const;
  bool main_playing(Clock::time_point now) const { return started_until_ && now < *started_until_; }

  PlayerTiming timing_;
  ConstantCommand want_constant_{};
  RumbleCommand want_rumble_{};
  std::optional<std::uint16_t> gain_pending_;       // FF_GAIN to write
  std::optional<RumbleCommand> kick_pending_;       // to upload
  bool kick_play_pending_ = false;                  // constant mode: uploaded, to play
  bool last_was_kick_ = false;                      // the last write was for a kick
  bool last_write_gain_ = false;
  bool silenced_ = false;                           // silence() since the last want()
  std::optional<Clock::time_point> kick_until_;     // rumble-only: the kick mix plays until then
  RumbleCommand kick_playing_{};
  std::optional<Clock::time_point> started_until_;  // the main effect plays until then (if not re-armed)
  FfMode main_mode_ = FfMode::none;                 // what started_until_ is about
  std::uint64_t kicks_ = 0;
};

}  // namespace sculpt::haptics
