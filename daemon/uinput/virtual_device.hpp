// A virtual input device through /dev/uinput: chosen axes, buttons and
// force-feedback capabilities, and a service thread that ANSWERS the kernel's
// FF upload and erase requests (recording them). Used by `sculptctl replay`
// to recreate recorded devices, and by the device tests.
//
// Why a service thread: a client's EVIOCSFF, EVIOCRMFF and even close() of its
// event fd block in the kernel until the uinput side answers, so the answers
// cannot come from the thread that writes the events (or that is the client).
#pragma once

#include <linux/input.h>
#include <linux/uinput.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <utility>
#include <variant>
#include <vector>

#include "files/unique_fd.hpp"

namespace sculpt::uinput {

using files::UniqueFd;

struct AxisSpec {
  std::uint16_t code;       // ABS_X, ABS_RY, ...
  input_absinfo info;       // value, minimum, maximum, fuzz, flat, resolution
};

// What the device looks like. Chainable setters keep set-ups short:
//   auto spec = DeviceSpec{}.named("pad").axis(ABS_X, -512, 511).button(BTN_SOUTH).ff(FF_RUMBLE);
struct DeviceSpec {
  std::string name = "sculpt virtual joystick";
  input_id id{BUS_USB, 0x5c17, 0x0001, 1};
  std::string phys;                    // UI_SET_PHYS when not empty
  std::vector<AxisSpec> axes;
  std::vector<std::uint16_t> buttons;
  std::vector<std::uint16_t> msc;      // EV_MSC codes, e.g. MSC_TIMESTAMP
  std::vector<std::uint16_t> ff_bits;  // FF_CONSTANT, FF_RUMBLE, FF_PERIODIC, FF_SINE, FF_GAIN, ...
  std::uint32_t ff_effects_max = 16;   // must be > 0 whenever ff_bits is not empty

  DeviceSpec& named(std::string n) { name = std::move(n); return *this; }
  DeviceSpec& ids(std::uint16_t bustype, std::uint16_t vendor, std::uint16_t product,
                  std::uint16_t version = 1) {
    id = input_id{bustype, vendor, product, version};
    return *this;
  }
  DeviceSpec& with_phys(std::string p) { phys = std::move(p); return *this; }
  DeviceSpec& axis(std::uint16_t code, std::int32_t min, std::int32_t max, std::int32_t fuzz = 0,
                   std::int32_t flat = 0, std::int32_t resolution = 0) {
    axes.push_back({code, input_absinfo{0, min, max, fuzz, flat, resolution}});
    return *this;
  }
  DeviceSpec& button(std::uint16_t code) { buttons.push_back(code); return *this; }
  DeviceSpec& misc(std::uint16_t code) { msc.push_back(code); return *this; }
  DeviceSpec& ff(std::initializer_list<std::uint16_t> bits) {
    ff_bits.insert(ff_bits.end(), bits);
    return *this;
  }
  DeviceSpec& ff(std::uint16_t bit) { ff_bits.push_back(bit); return *this; }
  DeviceSpec& effects_max(std::uint32_t n) { ff_effects_max = n; return *this; }
};

// --- what the device saw, in order -------------------------------------------

struct FfUpload {
  ff_effect effect;               // as the client sent it, with the id the kernel assigned
  std::optional<ff_effect> old;   // the effect it replaced (update in place), if any
  std::int16_t id;                // == effect.id
  std::int32_t retval;            // what we answered: 0 or -errno
};
struct FfErase {
  std::int16_t id;
  std::int32_t retval;
};
struct FfPlayback {               // EV_FF <id> <value>: value 0 stops, n plays n times
  std::int16_t id;
  std::int32_t value;
};
struct FfGain {                   // EV_FF FF_GAIN, 0..0xffff
  std::uint16_t gain;
};
struct FfAutocenter {             // EV_FF FF_AUTOCENTER, 0..0xffff
  std::uint16_t strength;
};
using FfRecord = std::variant<FfUpload, FfErase, FfPlayback, FfGain, FfAutocenter>;

struct FfLog {
  std::vector<FfRecord> sequence;  // everything, in arrival order
  std::vector<FfUpload> uploads;
  std::vector<FfErase> erases;
  std::vector<FfPlayback> playbacks;
  std::vector<FfGain> gains;
  std::vector<FfAutocenter> autocenters;

  void add(const FfRecord& r);
  void clear() { *this = FfLog{}; }
};

class VirtualDevice {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr std::chrono::milliseconds default_timeout{5000};

  // Creates the device and starts answering. Throws std::system_error naming
  // the failing step (open /dev/uinput, UI_DEV_SETUP, ...), std::invalid_argument
  // for a spec uinput would refuse.
  explicit VirtualDevice(DeviceSpec spec);
  ~VirtualDevice();
  VirtualDevice(const VirtualDevice&) = delete;
  VirtualDevice& operator=(const VirtualDevice&) = delete;

  const DeviceSpec& spec() const { return spec_; }
  bool plugged() const { return uinput_.valid(); }
  // "/dev/input/eventN" of the current incarnation (changes across plug()).
  const std::string& event_node() const { return event_node_; }
  // "inputN" (the sysfs name under /sys/class/input).
  const std::string& sysname() const { return sysname_; }

  // Hot-plug: unplug() destroys the kernel device (clients get ENODEV);
  // plug() creates it again with the same identity. The log is kept.
  void unplug();
  void plug();

  // Input events, each followed by SYN_REPORT unless stated otherwise.
  void emit(std::uint16_t type, std::uint16_t code, std::int32_t value);  // no SYN
  // Several events in one write (no SYN added).
  void emit_all(std::span<const input_event> events);
  void sync();
  void move_axis(std::uint16_t code, std::int32_t value);
  void move_axes(std::initializer_list<std::pair<std::uint16_t, std::int32_t>> values);
  void press(std::uint16_t button);
  void release(std::uint16_t button);

  // Answer every following upload (or erase) with -errno instead of success;
  // 0 accepts again. The kernel hands that errno to the client's ioctl.
  void fail_uploads_with(int errno_value);
  void fail_erases_with(int errno_value);

  // A copy of what was recorded so far.
  FfLog log() const;
  std::vector<FfUpload> uploads() const { return log().uploads; }
  std::vector<FfErase> erases() const { return log().erases; }
  std::vector<FfPlayback> playbacks() const { return log().playbacks; }
  std::vector<FfGain> gains() const { return log().gains; }
  std::vector<FfAutocenter> autocenters() const { return log().autocenters; }
  void clear_log();
  // Keep no log at all (a long replay must not grow memory); counts only.
  void set_recording(bool on);
  std::size_t uploads_answered() const;

  // Blocks until pred(log) holds or the timeout passes; returns whether it
  // held. Tests wait on facts, never on sleeps.
  bool wait_for(const std::function<bool(const FfLog&)>& pred,
                std::chrono::milliseconds timeout = default_timeout) const;

 private:
  void create_device();
  void destroy_device();
  void service();
  void handle(const input_event& ev);
  void answer_upload(std::int32_t request_id);
  void answer_erase(std::int32_t request_id);
  void record(const FfRecord& r);
  void write_event(std::uint16_t type, std::uint16_t code, std::int32_t value);

  DeviceSpec spec_;
  UniqueFd uinput_;
  UniqueFd stop_;          // eventfd: wakes the service thread to exit
  std::thread thread_;
  std::string sysname_;
  std::string event_node_;

  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  FfLog log_;
  bool recording_ = true;
  std::size_t uploads_answered_ = 0;
  int upload_errno_ = 0;
  int erase_errno_ = 0;
  std::string service_error_;  // set if the service thread died; reported by wait_for
};

}  // namespace sculpt::uinput
