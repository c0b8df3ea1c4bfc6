// One force-feedback device, RAII: the effects it holds are erased when it is
// destroyed (or shut down), never leaked.
//
// The upload state machine, per effect kind (constant, rumble):
//   no id ──upload(id −1)──▶ id n ──upload(id n)──▶ id n ...   (update in place, never a new id)
//   EINVAL on an update (the id vanished)  → forget it; the next call uploads with −1 again
//   EINVAL on a new constant               → the device refuses constant force: rumble-only from now on
//   ENOSPC on a new constant               → no free id: the rumble (kick) gives its id up: the next
//                                             upload_constant() erases it, the one after uploads
//                                             (ff_effects_max = 1: the constant wins, or the rumble on
//                                             rumble-only pads); with nothing to give up the upload
//                                             fails (counted) and the caller retries it later
//   ENODEV                                 → unplugged: stop issuing anything; forget() drops the ids
//   ENODEV before anything succeeded, while wait_for_ready(true)
//                                          → not ready yet (uinput between the node appearing and the
//                                             device being created): not an error, not gone; retry
//
// Every public call makes at most ONE call to the driver (an upload, a play,
// FF_GAIN or an erase) — shutdown() one per effect held — and every one of
// them goes through the device's WritePacer: it waits until the pacer allows
// a write, and stamps the pacer with the time the call returned. ENODEV
// reached no driver and is not stamped.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "haptics/effect_math.hpp"
#include "haptics/ff_port.hpp"
#include "haptics/pacer.hpp"

namespace sculpt::haptics {

// Counters shared by every device of the haptics thread; the daemon reads them
// from other threads.
struct FfCounters {
  std::atomic<std::uint64_t> uploads{0};      // successful EVIOCSFF (new + in place)
  std::atomic<std::uint64_t> errors{0};       // failed ioctls/writes
  std::atomic<std::uint64_t> kicks{0};        // rumble kicks played
  std::atomic<std::int64_t> live_effects{0};  // effect ids held right now, all devices
};

enum class FfMode {
  none,          // no usable FF: input only
  constant,      // FF_CONSTANT (+ FF_RUMBLE kicks when there is an id for them)
  rumble_only,   // FF_RUMBLE: continuous contact rumble and kicks through one effect
};

struct FfDeviceOptions {
  std::uint16_t gain = 0xffff;  // FF_GAIN, written once when the device supports it
  bool gain_at_open = true;     // false: the caller writes it (set_gain), paced with the rest
  bool constant = true;         // allow FF_CONSTANT
  bool rumble = true;           // allow FF_RUMBLE (kicks; the force itself on rumble-only pads)
};

class FfDevice {
 public:
  // Reads the caps, decides the mode, sets FF_GAIN. counters may be null.
  // `pacer`: the device's, shared with its other writers and kept across
  // reopens (null: one of its own, interval 0: unpaced). `time` stamps it.
  FfDevice(std::unique_ptr<FfPort> port, const FfDeviceOptions& options, FfCounters* counters,
           std::shared_ptr<WritePacer> pacer = nullptr, TimeSource& time = steady_time());
  // Opens `node` (throws std::system_error naming it).
  static std::unique_ptr<FfDevice> open(const std::string& node, const FfDeviceOptions& options,
                                        FfCounters* counters);
  ~FfDevice();
  FfDevice(const FfDevice&) = delete;
  FfDevice& operator=(const FfDevice&) = delete;

  FfMode mode() const { return mode_; }
  const FfCaps& caps() const { return caps_; }
  const DeviceIdentity& identity() const { return identity_; }
  bool rumble_allowed() const;  // kicks possible in this mode (an id, a bit, the option)
  const std::string& node() const;

  // Uploads the constant force with this replay length (first time with id
  // −1, then in place with the same id). Returns whether the device now has
  // `c`. False without a write when the mode has no constant force.
  bool upload_constant(const ConstantCommand& c, std::uint16_t length_ms);
  // Uploads the rumble effect (new or in place) with r.length_ms. In
  // constant mode it is the kick; in rumble_only mode the one effect.
  bool upload_rumble(const RumbleCommand& r);
  enum class Effect { constant, rumble };
  // EV_FF id 1: (re)starts the effect; its replay length counts from now.
  bool play(Effect e);
  bool holds(Effect e) const { return (e == Effect::constant ? constant_id_ : rumble_id_) >= 0; }

  // An ENODEV before the first success means "not ready yet", not unplugged.
  void wait_for_ready(bool on) { wait_for_ready_ = on; }
  // The last write answered ENODEV as "not ready yet".
  bool not_ready() const { return not_ready_; }
  // Some write has succeeded since the device was opened.
  bool ready_seen() const { return ready_seen_; }

  // FF_GAIN (0..0xffff), when the device has it: one write. Returns whether
  // it wrote.
  bool set_gain(std::uint16_t gain);

  // Erases every effect this device holds (the kernel stops each one as it
  // erases it): one paced write per effect, waiting for the pacer. Idempotent.
  void shutdown();
  // The device is gone: drop the ids without talking to it (the kernel freed them).
  void forget();
  // An ioctl saw ENODEV: the node is dead; nothing more is sent.
  bool gone() const { return gone_; }

  std::int16_t constant_id() const { return constant_id_; }
  std::int16_t rumble_id() const { return rumble_id_; }
  int live_effects() const { return (constant_id_ >= 0) + (rumble_id_ >= 0); }
  // Successful uploads (new and in place) to this device since it was opened.
  std::uint64_t uploads() const { return uploads_; }
  // Calls that reached the driver (uploads, plays, FF_GAIN, erases; failed
  // ones too, ENODEV not), each stamped on the pacer.
  std::uint64_t writes() const { return writes_; }
  const WritePacer& pacer() const { return *pacer_; }
  // The constant the device has now (valid while constant_id() >= 0).
  const ConstantCommand& current_constant() const { return current_; }
  const RumbleCommand& current_rumble() const { return current_rumble_; }

 private:
  int upload(ff_effect& e, std::int16_t& id);  // the state machine step; 0 or errno
  bool usable() const { return !gone_ && !shut_; }
  bool erase(std::int16_t& id);
  // The one way to the driver: waits for the pacer, makes the call, stamps
  // the pacer when it returned. 0 or the errno.
  template <class Call>
  int paced(Call call);
  void count_error(int err);
  void add_live(int delta);

  std::unique_ptr<FfPort> port_;
  FfDeviceOptions options_;
  FfCounters* counters_;
  std::shared_ptr<WritePacer> pacer_;
  TimeSource* time_;
  FfCaps caps_;
  DeviceIdentity identity_;
  FfMode mode_ = FfMode::none;
  bool rumble_ok_ = false;
  bool gone_ = false;
  bool shut_ = false;       // shut down: nothing more is sent
  bool rumble_has_ = false; // FF_RUMBLE usable at all (bit, option, an id)
  bool give_up_rumble_ = false;  // ENOSPC for the constant: the rumble's id is erased next
  std::uint64_t uploads_ = 0;
  std::uint64_t writes_ = 0;
  std::int16_t constant_id_ = -1;
  std::int16_t rumble_id_ = -1;
  ConstantCommand current_{};
  RumbleCommand current_rumble_{};
  bool wait_for_ready_ = false;
  bool not_ready_ = false;
  bool ready_seen_ = false;
};

}  // namespace sculpt::haptics
