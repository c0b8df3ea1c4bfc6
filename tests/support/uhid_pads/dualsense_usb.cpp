// DualSense (054c:0ce6) on USB, bound by hid-playstation.
#include <linux/input.h>

#include <cstring>
#include <optional>

#include "support/uhid_pad.hpp"
#include "support/uhid_pads/report_bytes.hpp"

namespace sculpt::support::uhid_pads {

namespace {

std::optional<Motors> dualsense_usb_motors(const OutputReport& r) {
  // hid-playstation, struct dualsense_output_report_common after the report
  // id 0x02: valid_flag0 (bit 0 COMPATIBLE_VIBRATION, bit 1 HAPTICS_SELECT),
  // valid_flag1, motor_right (weak), motor_left (strong), ... valid_flag2 at
  // byte 39 (bit 2 COMPATIBLE_VIBRATION2: firmware with the newer rumble).
  const auto& d = r.data;
  if (d.size() < 48 || d[0] != 0x02) return std::nullopt;
  const bool rumble = (d[1] & 0x01) || (d[39] & 0x04);
  if (!rumble) return std::nullopt;
  return Motors{d[4], d[3]};
}

}  // namespace

const UhidPadSpec& dualsense_usb() {
  static const UhidPadSpec spec = [] {
    UhidPadSpec s;
    s.name = "Sony Interactive Entertainment Wireless Controller";
    s.bus = BUS_USB;
    s.vendor = 0x054c;
    s.product = 0x0ce6;
    s.version = 0x0100;
    s.driver = "playstation";
    s.module = "hid-playstation.ko";
    // The DualSense's reports by id and size: input 0x01 (64 bytes with the
    // id), output 0x02 (63 with the id, as hid-playstation sends it), features 0x05 calibration (41), 0x09 pairing
    // info (20), 0x20 firmware info (64). Sticks, hat and buttons where the
    // real pad has them; the rest vendor-defined. hid-playstation parses
    // the raw bytes itself (it connects hidraw only), so only ids and sizes
    // matter to the driver; hidraw clients see the same layout as on a pad.
    s.descriptor = {
        0x05, 0x01, 0x09, 0x05, 0xA1, 0x01,              // Generic Desktop, Game Pad, Application
        0x85, 0x01,                                      //   Report ID 1 (input)
        0x09, 0x30, 0x09, 0x31, 0x09, 0x32, 0x09, 0x35,  //   X, Y, Z, Rz
        0x09, 0x33, 0x09, 0x34,                          //   Rx, Ry (triggers)
        0x15, 0x00, 0x26, 0xFF, 0x00, 0x75, 0x08, 0x95, 0x06, 0x81, 0x02,
        0x06, 0x00, 0xFF, 0x09, 0x20, 0x95, 0x01, 0x81, 0x02,  // vendor: sequence number
        0x05, 0x01, 0x09, 0x39, 0x15, 0x00, 0x25, 0x07, 0x35, 0x00, 0x46, 0x3B, 0x01,
        0x65, 0x14, 0x75, 0x04, 0x95, 0x01, 0x81, 0x42,  //   hat switch, 4 bits, null state
        0x65, 0x00,
        0x05, 0x09, 0x19, 0x01, 0x29, 0x0F, 0x15, 0x00, 0x25, 0x01,
        0x75, 0x01, 0x95, 0x0F, 0x81, 0x02,              //   15 buttons
        0x06, 0x00, 0xFF, 0x09, 0x21, 0x95, 0x0D, 0x81, 0x02,  // 13 vendor bits
        0x06, 0x00, 0xFF, 0x09, 0x22, 0x15, 0x00, 0x26, 0xFF, 0x00,
        0x75, 0x08, 0x95, 0x34, 0x81, 0x02,              //   52 vendor bytes (IMU, touch, status)
        0x85, 0x02, 0x09, 0x23, 0x95, 0x3E, 0x91, 0x02,  //   Report ID 2: output, 62 bytes
        0x85, 0x05, 0x09, 0x33, 0x95, 0x28, 0xB1, 0x02,  //   Report ID 5: feature, 40 bytes
        0x85, 0x09, 0x09, 0x24, 0x95, 0x13, 0xB1, 0x02,  //   Report ID 9: feature, 19 bytes
        0x85, 0x20, 0x09, 0x26, 0x95, 0x3F, 0xB1, 0x02,  //   Report ID 0x20: feature, 63 bytes
        0xC0,
    };
    std::vector<std::uint8_t> pairing(20, 0);
    pairing[0] = 0x09;
    const std::uint8_t mac[6] = {0x5c, 0x3e, 0x5a, 0x00, 0xe6, 0x0c};  // little-endian, as the pad sends it
    std::memcpy(&pairing[1], mac, 6);
    std::vector<std::uint8_t> firmware(64, 0);
    firmware[0] = 0x20;
    put_le32(firmware, 24, 0x00000411);  // hardware version
    put_le32(firmware, 28, 0x0110002a);  // firmware version
    put_le16(firmware, 44, 0x0000);      // update version < 2.21: the classic rumble (valid_flag0)
    s.features = {sony_calibration(0x05, 41), pairing, firmware};
    s.mac_reports = {0x09};
    s.motors = dualsense_usb_motors;
    s.motor_max = 255;
    s.idle_input.assign(64, 0);
    s.idle_input[0] = 0x01;
    for (int i = 1; i <= 4; ++i) s.idle_input[i] = 0x80;  // sticks centred
    s.idle_input[8] = 0x08;                                // hat: none
    return s;
  }();
  return spec;
}

}  // namespace sculpt::support::uhid_pads
