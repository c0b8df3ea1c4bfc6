// What FfDevice needs of an evdev event node, as an interface: the real one
// issues the FF ioctls and writes; unit tests substitute a fake device.
#pragma once

#include <linux/input.h>

#include <bitset>
#include <cstdint>
#include <memory>
#include <string>

namespace sculpt::haptics {

struct FfCaps {
  std::bitset<FF_CNT> bits;  // EVIOCGBIT(EV_FF): FF_CONSTANT, FF_RUMBLE, FF_GAIN, ...
  int effects_max = 0;       // EVIOCGEFFECTS: effects (ids) the device can hold at once
  bool has(std::uint16_t code) const { return code < FF_CNT && bits.test(code); }
  bool any_effect() const { return has(FF_CONSTANT) || has(FF_RUMBLE); }
};

// EVIOCGID + EVIOCGNAME: which device, and over which transport (BUS_USB,
// BUS_BLUETOOTH, ...; 0 when unknown).
struct DeviceIdentity {
  std::uint16_t bustype = 0;
  std::uint16_t vendor = 0;
  std::uint16_t product = 0;
  std::string name;
};

class FfPort {
 public:
  virtual ~FfPort() = default;
  virtual FfCaps caps() = 0;
  // EVIOCSFF: 0 or the errno. id -1 asks for a new id; the assigned id is
  // written back into effect.id.
  virtual int upload(ff_effect& effect) = 0;
  // EVIOCRMFF: 0 or the errno.
  virtual int erase(std::int16_t id) = 0;
  // An EV_FF event: code = effect id (value 0 stop, n play n times) or FF_GAIN.
  virtual int write_ff(std::uint16_t code, std::int32_t value) = 0;
  virtual DeviceIdentity identity() { return {}; }
  // Where it is, for messages.
  virtual const std::string& node() const = 0;
};

// Opens an event node O_RDWR for FF only (its input events are masked off, so
// nothing queues on this fd). Throws std::system_error naming the node.
std::unique_ptr<FfPort> open_evdev_port(const std::string& node);

}  // namespace sculpt::haptics
