// A gamepad made through /dev/uhid that the kernel binds to its OWN driver
// (hid-playstation, hid-sony, hid-microsoft), for tests that assert on what
// the driver sends to the pad: the HID output reports, byte for byte.
//
//   UhidPad pad(uhid_pads::dualsense_usb());      // created, driver bound, evdev FF node found
//   EvdevClient ev(pad.ff_node());                // upload/play FF_RUMBLE as any client would
//   pad.wait_for([](const auto& reports) { ... });  // every output report, with its time
//   auto m = pad.last_motors();                   // the pad's motor bytes, parsed per pad
//
// The pads are a table (uhid_pads::all()), one small file each
// (support/uhid_pads/<pad>.cpp), like libinput's litest-device-*.c: name,
// bus, ids, report descriptor, the feature reports the driver asks for while
// probing (answered from the table), and how its output reports carry the
// motors. This header and uhid_pad.cpp are the harness they share.
//
// A reader thread answers the driver's UHID_GET_REPORT / UHID_SET_REPORT
// requests and records every UHID_OUTPUT (the driver's own reports and what
// a client writes through /dev/hidrawN alike) with a CLOCK_MONOTONIC
// (steady_clock) timestamp. Needs /dev/uhid and the driver's module: the vm
// suite's guest loads them (docs/testing.md); where either is missing the
// constructor throws saying which, and why the guest could not load it.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "support/unique_fd.hpp"

namespace sculpt::support {

// Motor bytes as the pad receives them. strong: the low-frequency (left,
// large) motor, where the kernel's FF_RUMBLE strong_magnitude goes; weak: the
// high-frequency (right, small) one. The scale is the pad's (0..255 for the
// Sony pads, 0..100 for the Xbox One S).
struct Motors {
  std::uint8_t strong = 0;
  std::uint8_t weak = 0;
  bool operator==(const Motors&) const = default;
};

// One report the driver (or a hidraw client) sent to the pad.
struct OutputReport {
  enum class Kind : std::uint8_t {
    output,      // UHID_OUTPUT: an output report (interrupt channel / hidraw write())
    set_report,  // UHID_SET_REPORT: a SET_REPORT request (feature reports, HIDIOCSFEATURE)
  };
  std::chrono::steady_clock::time_point at;  // CLOCK_MONOTONIC, when the reader thread got it
  Kind kind = Kind::output;
  std::uint8_t rtype = 0;           // UHID_OUTPUT_REPORT / UHID_FEATURE_REPORT / ...
  std::vector<std::uint8_t> data;   // data[0] is the report id
};

struct UhidPadSpec {
  std::string name;                  // UHID_CREATE2 name (what the driver sees as hdev->name)
  std::uint16_t bus = 0;             // BUS_USB, BUS_BLUETOOTH
  std::uint32_t vendor = 0, product = 0, version = 0;
  std::string driver;                // /sys/bus/hid/drivers/<driver> that must bind it
  std::string module;                // the .ko it comes from, for the error message
  std::vector<std::uint8_t> descriptor;
  // Canned GET_REPORT answers, each starting with its report id; a request
  // for a report not listed is answered with EIO.
  std::vector<std::vector<std::uint8_t>> features;
  // Feature reports whose bytes 1..6 are the pad's MAC address: each UhidPad
  // gets its own (byte 1 counts pads), since the Sony drivers refuse a pad
  // with the MAC of one still bound.
  std::vector<std::uint8_t> mac_reports;
  // The motor bytes an output report carries, or nullopt when the report
  // does not set the motors (LEDs only, another report id).
  std::function<std::optional<Motors>(const OutputReport&)> motors;
  // The largest motor byte (what FF_RUMBLE 0xffff becomes).
  std::uint8_t motor_max = 255;
  // An input report with everything at rest (sticks centred), for
  // send_input(); empty if the driver needs none.
  std::vector<std::uint8_t> idle_input;
};

namespace uhid_pads {
const UhidPadSpec& dualsense_usb();   // 054c:0ce6 on USB, hid-playstation
const UhidPadSpec& dualshock4_usb();  // 054c:09cc on USB, hid-sony
const UhidPadSpec& xbox_one_s_bt();   // 045e:02fd on Bluetooth, hid-microsoft (MS_QUIRK_FF)
std::vector<const UhidPadSpec*> all();
}  // namespace uhid_pads

class UhidPad {
 public:
  // Creates the device and waits (up to bind_timeout) until `spec.driver`
  // has bound it and an event node with EV_FF exists. Throws
  // std::runtime_error saying what is missing.
  explicit UhidPad(const UhidPadSpec& spec,
                   std::chrono::milliseconds bind_timeout = std::chrono::milliseconds(20000));
  ~UhidPad();  // UHID_DESTROY: the driver unbinds, its nodes go
  UhidPad(const UhidPad&) = delete;
  UhidPad& operator=(const UhidPad&) = delete;

  const UhidPadSpec& spec() const { return spec_; }
  const std::string& sysfs_dir() const { return sysfs_; }   // /sys/devices/virtual/misc/uhid/BBBB:VVVV:PPPP.NNNN
  const std::string& ff_node() const { return ff_node_; }    // /dev/input/eventN with EV_FF
  std::vector<std::string> event_nodes() const;              // every evdev node of the device
  std::string hidraw_node() const;                           // /dev/hidrawN ("" if none)
  const std::string& phys() const { return phys_; }          // unique per pad: how it is found

  // An input report to the driver (UHID_INPUT2).
  void send_input(std::span<const std::uint8_t> report);

  std::vector<OutputReport> outputs() const;
  std::size_t output_count() const;
  void clear_outputs();
  // Report ids the driver asked for with GET_REPORT, in order.
  std::vector<std::uint8_t> get_report_requests() const;
  // Whether the driver has the device open (UHID_OPEN without UHID_CLOSE).
  bool opened() const;

  // Waits until pred(outputs) holds; false after the timeout (scaled by
  // SCULPT_VM_SLOWDOWN). pred runs under the lock: keep it cheap.
  bool wait_for(const std::function<bool(const std::vector<OutputReport>&)>& pred,
                std::chrono::milliseconds timeout = std::chrono::milliseconds(20000)) const;

  // The motor reports among outputs (spec.motors), in order.
  struct MotorReport {
    std::chrono::steady_clock::time_point at;
    Motors motors;
  };
  std::vector<MotorReport> motor_reports() const;
  std::optional<Motors> last_motors() const;
  // Waits until the latest motor report satisfies pred.
  bool wait_for_motors(const std::function<bool(const Motors&)>& pred,
                       std::chrono::milliseconds timeout = std::chrono::milliseconds(20000)) const;

 private:
  void run();
  void teardown();  // UHID_DESTROY, reader joined; idempotent
  void write_event(const void* ev, std::size_t size);
  bool locate();

  UhidPadSpec spec_;
  std::string phys_;
  UniqueFd fd_;
  UniqueFd stop_;  // eventfd: wakes the reader to exit
  std::string sysfs_;
  std::string ff_node_;

  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::vector<OutputReport> outputs_;
  std::vector<std::uint8_t> get_requests_;
  bool opened_ = false;
  std::string reader_error_;
  std::thread reader_;
};

}  // namespace sculpt::support
