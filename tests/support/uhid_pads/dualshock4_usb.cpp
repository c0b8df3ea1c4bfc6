// DualShock 4 (054c:09cc) on USB, bound by hid-sony.
#include <linux/input.h>

#include <cstring>
#include <optional>

#include "support/uhid_pad.hpp"
#include "support/uhid_pads/report_bytes.hpp"

namespace sculpt::support::uhid_pads {

namespace {

std::optional<Motors> dualshock4_usb_motors(const OutputReport& r) {
  // hid-sony, DS4 USB report 0x05: [1] flags (0x01 motors, 0x02 LEDs, 0x04
  // flash), [4] right (weak), [5] left (strong), [6..8] RGB.
  const auto& d = r.data;
  if (d.size() < 6 || d[0] != 0x05 || !(d[1] & 0x01)) return std::nullopt;
  return Motors{d[5], d[4]};
}

}  // namespace

const UhidPadSpec& dualshock4_usb() {
  static const UhidPadSpec spec = [] {
    UhidPadSpec s;
    s.name = "Sony Interactive Entertainment Wireless Controller";
    s.bus = BUS_USB;
    s.vendor = 0x054c;
    s.product = 0x09cc;  // DualShock 4, second revision
    s.version = 0x0100;
    s.driver = "sony";
    s.module = "hid-sony.ko";
    // DS4 over USB: input 0x01 (64 bytes with the id), output 0x05 (32),
    // features 0x02 calibration (37), 0x81 MAC (7), 0x12 pairing (16),
    // 0xa3 version info (49). hid-sony maps the sticks, hat, buttons and
    // triggers through hid-input (ds4 mappings), so those carry real usages.
    s.descriptor = {
        0x05, 0x01, 0x09, 0x05, 0xA1, 0x01,              // Generic Desktop, Game Pad, Application
        0x85, 0x01,                                      //   Report ID 1 (input)
        0x09, 0x30, 0x09, 0x31, 0x09, 0x32, 0x09, 0x35,  //   X, Y, Z, Rz (sticks)
        0x15, 0x00, 0x26, 0xFF, 0x00, 0x75, 0x08, 0x95, 0x04, 0x81, 0x02,
        0x09, 0x39, 0x15, 0x00, 0x25, 0x07, 0x35, 0x00, 0x46, 0x3B, 0x01,
        0x65, 0x14, 0x75, 0x04, 0x95, 0x01, 0x81, 0x42,  //   hat switch
        0x65, 0x00,
        0x05, 0x09, 0x19, 0x01, 0x29, 0x0E, 0x15, 0x00, 0x25, 0x01,
        0x75, 0x01, 0x95, 0x0E, 0x81, 0x02,              //   14 buttons
        0x06, 0x00, 0xFF, 0x09, 0x20, 0x75, 0x06, 0x95, 0x01, 0x15, 0x00, 0x25, 0x7F,
        0x81, 0x02,                                      //   6-bit counter
        0x05, 0x01, 0x09, 0x33, 0x09, 0x34, 0x15, 0x00, 0x26, 0xFF, 0x00,
        0x75, 0x08, 0x95, 0x02, 0x81, 0x02,              //   Rx, Ry (L2, R2)
        0x06, 0x00, 0xFF, 0x09, 0x21, 0x95, 0x36, 0x81, 0x02,  // 54 vendor bytes
        0x85, 0x05, 0x09, 0x22, 0x95, 0x1F, 0x91, 0x02,  //   Report ID 5: output, 31 bytes
        0x85, 0x02, 0x09, 0x24, 0x95, 0x24, 0xB1, 0x02,  //   Report ID 2: feature, 36 bytes
        0x85, 0x81, 0x09, 0x25, 0x95, 0x06, 0xB1, 0x02,  //   Report ID 0x81: feature, 6 bytes
        0x85, 0x12, 0x09, 0x26, 0x95, 0x0F, 0xB1, 0x02,  //   Report ID 0x12: feature, 15 bytes
        0x85, 0xA3, 0x09, 0x27, 0x95, 0x30, 0xB1, 0x02,  //   Report ID 0xa3: feature, 48 bytes
        0xC0,
    };
    std::vector<std::uint8_t> mac81(7, 0);
    mac81[0] = 0x81;
    const std::uint8_t mac[6] = {0x4c, 0xc4, 0x09, 0x00, 0xe6, 0x1c};
    std::memcpy(&mac81[1], mac, 6);
    std::vector<std::uint8_t> pairing12(16, 0);
    pairing12[0] = 0x12;
    std::memcpy(&pairing12[1], mac, 6);
    std::vector<std::uint8_t> version(49, 0);
    version[0] = 0xa3;
    put_le16(version, 35, 0x0100);  // hardware version
    put_le16(version, 41, 0x0800);  // firmware version
    s.features = {sony_calibration(0x02, 37), mac81, pairing12, version};
    s.mac_reports = {0x81, 0x12};
    s.motors = dualshock4_usb_motors;
    s.motor_max = 255;
    s.idle_input.assign(64, 0);
    s.idle_input[0] = 0x01;
    for (int i = 1; i <= 4; ++i) s.idle_input[i] = 0x80;
    s.idle_input[5] = 0x08;
    return s;
  }();
  return spec;
}

}  // namespace sculpt::support::uhid_pads
