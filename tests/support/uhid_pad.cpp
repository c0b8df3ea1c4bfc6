#include "support/uhid_pad.hpp"

#include <fcntl.h>
#include <linux/input.h>
#include <linux/uhid.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>

namespace sculpt::support {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

double vm_slowdown() {
  const char* s = std::getenv("SCULPT_VM_SLOWDOWN");
  const double v = s ? std::atof(s) : 1.0;
  return v >= 1.0 ? v : 1.0;
}

namespace {

std::chrono::milliseconds scaled(std::chrono::milliseconds t) {
  return std::chrono::milliseconds(static_cast<long long>(static_cast<double>(t.count()) * vm_slowdown()));
}

void put_le16(std::vector<std::uint8_t>& b, std::size_t at, int v) {
  b[at] = static_cast<std::uint8_t>(v & 0xff);
  b[at + 1] = static_cast<std::uint8_t>((v >> 8) & 0xff);
}
void put_le32(std::vector<std::uint8_t>& b, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

// The IMU calibration both Sony drivers read (DualSense 0x05, DS4 0x02 over
// USB share the layout): biases 0, ±range for each gyro and accelerometer axis.
// Non-zero ranges: the drivers divide by (plus - minus).
std::vector<std::uint8_t> sony_calibration(std::uint8_t id, std::size_t size) {
  std::vector<std::uint8_t> b(size, 0);
  b[0] = id;
  // 1..6 gyro biases (0); 7..18 gyro pitch/yaw/roll plus, minus.
  for (int axis = 0; axis < 3; ++axis) {
    put_le16(b, 7 + 4 * axis, 8192);
    put_le16(b, 9 + 4 * axis, -8192);
  }
  put_le16(b, 19, 540);  // gyro speed plus
  put_le16(b, 21, 540);  // gyro speed minus
  for (int axis = 0; axis < 3; ++axis) {  // 23..34 accelerometer x/y/z plus, minus
    put_le16(b, 23 + 4 * axis, 8192);
    put_le16(b, 25 + 4 * axis, -8192);
  }
  return b;
}

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

std::optional<Motors> dualshock4_usb_motors(const OutputReport& r) {
  // hid-sony, DS4 USB report 0x05: [1] flags (0x01 motors, 0x02 LEDs, 0x04
  // flash), [4] right (weak), [5] left (strong), [6..8] RGB.
  const auto& d = r.data;
  if (d.size() < 6 || d[0] != 0x05 || !(d[1] & 0x01)) return std::nullopt;
  return Motors{d[5], d[4]};
}

std::optional<Motors> xbox_one_s_bt_motors(const OutputReport& r) {
  // hid-microsoft, struct xb1s_ff_report: report id 0x03, enable (bit 0
  // weak, bit 1 strong), magnitude[4] = {left trigger, right trigger,
  // strong, weak} in 0..100, duration_10ms, start_delay_10ms, loop_count.
  const auto& d = r.data;
  if (d.size() < 9 || d[0] != 0x03) return std::nullopt;
  return Motors{d[4], d[5]};
}

}  // namespace

namespace uhid_pads {

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

const UhidPadSpec& xbox_one_s_bt() {
  static const UhidPadSpec spec = [] {
    UhidPadSpec s;
    s.name = "Xbox Wireless Controller";
    s.bus = BUS_BLUETOOTH;
    s.vendor = 0x045e;
    s.product = 0x02fd;  // Xbox One S controller over Bluetooth: MS_QUIRK_FF in hid-microsoft
    s.version = 0x0903;
    s.driver = "microsoft";
    s.module = "hid-microsoft.ko";
    // The pad's Bluetooth layout: input 0x01 (sticks 16 bit, triggers 10
    // bit, hat, 15 buttons, Back), output 0x03 the PID-page rumble report
    // hid-microsoft writes (enable mask, 4 magnitudes, duration, delay, loops).
    s.descriptor = {
        0x05, 0x01, 0x09, 0x05, 0xA1, 0x01,  // Generic Desktop, Game Pad, Application
        0x85, 0x01,                          //   Report ID 1 (input)
        0x09, 0x01, 0xA1, 0x00,              //   Pointer, Physical
        0x09, 0x30, 0x09, 0x31, 0x15, 0x00, 0x27, 0xFF, 0xFF, 0x00, 0x00,
        0x95, 0x02, 0x75, 0x10, 0x81, 0x02,  //     X, Y: 16 bit
        0xC0,
        0x09, 0x01, 0xA1, 0x00,
        0x09, 0x32, 0x09, 0x35, 0x15, 0x00, 0x27, 0xFF, 0xFF, 0x00, 0x00,
        0x95, 0x02, 0x75, 0x10, 0x81, 0x02,  //     Z, Rz: 16 bit
        0xC0,
        0x05, 0x02, 0x09, 0xC5, 0x15, 0x00, 0x26, 0xFF, 0x03, 0x95, 0x01, 0x75, 0x0A, 0x81, 0x02,  // Brake
        0x15, 0x00, 0x25, 0x00, 0x75, 0x06, 0x95, 0x01, 0x81, 0x03,
        0x05, 0x02, 0x09, 0xC4, 0x15, 0x00, 0x26, 0xFF, 0x03, 0x95, 0x01, 0x75, 0x0A, 0x81, 0x02,  // Accelerator
        0x15, 0x00, 0x25, 0x00, 0x75, 0x06, 0x95, 0x01, 0x81, 0x03,
        0x05, 0x01, 0x09, 0x39, 0x15, 0x01, 0x25, 0x08, 0x35, 0x00, 0x46, 0x3B, 0x01,
        0x66, 0x14, 0x00, 0x75, 0x04, 0x95, 0x01, 0x81, 0x42,  // hat switch
        0x75, 0x04, 0x95, 0x01, 0x15, 0x00, 0x25, 0x00, 0x35, 0x00, 0x45, 0x00, 0x65, 0x00, 0x81, 0x03,
        0x05, 0x09, 0x19, 0x01, 0x29, 0x0F, 0x15, 0x00, 0x25, 0x01, 0x75, 0x01, 0x95, 0x0F, 0x81, 0x02,
        0x15, 0x00, 0x25, 0x00, 0x75, 0x01, 0x95, 0x01, 0x81, 0x03,  // 15 buttons
        0x05, 0x0C, 0x0A, 0x24, 0x02, 0x15, 0x00, 0x25, 0x01, 0x95, 0x01, 0x75, 0x01, 0x81, 0x02,  // AC Back
        0x15, 0x00, 0x25, 0x00, 0x75, 0x07, 0x95, 0x01, 0x81, 0x03,
        0x05, 0x0F, 0x09, 0x21, 0x85, 0x03, 0xA1, 0x02,  // PID: Set Effect Report, Report ID 3 (output)
        0x09, 0x97, 0x15, 0x00, 0x25, 0x01, 0x75, 0x04, 0x95, 0x01, 0x91, 0x02,  // DC Enable Actuators
        0x15, 0x00, 0x25, 0x00, 0x75, 0x04, 0x95, 0x01, 0x91, 0x03,
        0x09, 0x70, 0x15, 0x00, 0x25, 0x64, 0x75, 0x08, 0x95, 0x04, 0x91, 0x02,  // Magnitude x4, 0..100
        0x09, 0x50, 0x66, 0x01, 0x10, 0x55, 0x0E, 0x15, 0x00, 0x26, 0xFF, 0x00,
        0x75, 0x08, 0x95, 0x01, 0x91, 0x02,  // Duration (10 ms)
        0x09, 0xA7, 0x15, 0x00, 0x26, 0xFF, 0x00, 0x75, 0x08, 0x95, 0x01, 0x91, 0x02,  // Start Delay
        0x65, 0x00, 0x55, 0x00,
        0x09, 0x7C, 0x15, 0x00, 0x26, 0xFF, 0x00, 0x75, 0x08, 0x95, 0x01, 0x91, 0x02,  // Loop Count
        0xC0,
        0xC0,
    };
    s.motors = xbox_one_s_bt_motors;
    s.motor_max = 100;
    s.idle_input.assign(17, 0);
    s.idle_input[0] = 0x01;
    for (int i = 0; i < 4; ++i) put_le16(s.idle_input, 1 + 2 * i, 0x8000);
    return s;
  }();
  return spec;
}

std::vector<const UhidPadSpec*> all() { return {&dualsense_usb(), &dualshock4_usb(), &xbox_one_s_bt()}; }

}  // namespace uhid_pads

namespace {

std::string read_text(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::string why_no_driver(const UhidPadSpec& spec) {
  std::string msg = "hid driver '" + spec.driver + "' (" + spec.module + ") is not loaded: no /sys/bus/hid/drivers/" +
                    spec.driver + ".";
  const std::string log = read_text("/lib/sculpt/insmod-failures");
  if (!log.empty()) msg += " The guest's insmod failures: " + log;
  else msg += " (Outside the vm suite's guest: load the module; in it: is it in guest_kernel.MODULES?)";
  return msg;
}

std::atomic<int> pad_counter{0};

}  // namespace

UhidPad::UhidPad(const UhidPadSpec& spec, std::chrono::milliseconds bind_timeout) : spec_(spec) {
  const int number = pad_counter.fetch_add(1);
  phys_ = "sculpt-uhid/" + std::to_string(::getpid()) + "/" + std::to_string(number);
  for (auto& f : spec_.features)
    for (std::uint8_t id : spec_.mac_reports)
      if (f.size() > 6 && f[0] == id) f[1] = static_cast<std::uint8_t>(number);
  fd_ = UniqueFd(::open("/dev/uhid", O_RDWR | O_CLOEXEC | O_NONBLOCK));
  if (!fd_.valid()) {
    const int e = errno;
    std::string msg = "open /dev/uhid: " + std::string(std::strerror(e));
    const std::string log = read_text("/lib/sculpt/insmod-failures");
    if (!log.empty()) msg += ". The guest's insmod failures: " + log;
    throw std::runtime_error(msg);
  }
  if (!fs::exists("/sys/bus/hid/drivers/" + spec_.driver)) throw std::runtime_error(why_no_driver(spec_));
  stop_ = UniqueFd(::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK));
  if (!stop_.valid()) throw std::system_error(errno, std::generic_category(), "eventfd");

  uhid_event ev{};
  ev.type = UHID_CREATE2;
  auto& c = ev.u.create2;
  std::snprintf(reinterpret_cast<char*>(c.name), sizeof c.name, "%s", spec_.name.c_str());
  std::snprintf(reinterpret_cast<char*>(c.phys), sizeof c.phys, "%s", phys_.c_str());
  // A distinct uniq per pad: the Sony drivers refuse a second pad with the
  // MAC of one still connected (they read the MAC from a feature report).
  std::snprintf(reinterpret_cast<char*>(c.uniq), sizeof c.uniq, "%s", phys_.c_str());
  if (spec_.descriptor.size() > sizeof c.rd_data) throw std::runtime_error("report descriptor too large");
  c.rd_size = static_cast<std::uint16_t>(spec_.descriptor.size());
  c.bus = spec_.bus;
  c.vendor = spec_.vendor;
  c.product = spec_.product;
  c.version = spec_.version;
  c.country = 0;
  std::memcpy(c.rd_data, spec_.descriptor.data(), spec_.descriptor.size());
  // The reader first: the driver's probe asks for feature reports and waits
  // (5 s per request) for the answers.
  reader_ = std::thread([this] { run(); });
  try {
    write_event(&ev, sizeof ev);
  } catch (...) {
    std::uint64_t one = 1;
    (void)!::write(stop_.get(), &one, sizeof one);
    reader_.join();
    throw;
  }
  const auto deadline = std::chrono::steady_clock::now() + scaled(bind_timeout);
  while (!locate()) {
    if (std::chrono::steady_clock::now() > deadline) {
      std::string why = "the '" + spec_.driver + "' driver did not bind " + spec_.name + " (" + phys_ +
                        ") with an EV_FF event node within " + std::to_string(scaled(bind_timeout).count()) + " ms";
      if (!sysfs_.empty()) why += " (hid device " + sysfs_ + ")";
      {
        std::lock_guard lock(mutex_);
        why += "; feature reports asked for:";
        for (auto id : get_requests_) why += " 0x" + (std::stringstream() << std::hex << int(id)).str();
        if (!reader_error_.empty()) why += "; reader: " + reader_error_;
      }
      why += " (the driver's probe errors are in the guest's dmesg)";
      teardown();
      throw std::runtime_error(why);
    }
    std::this_thread::sleep_for(5ms);  // sysfs has no event to wait on without udev
  }
}

UhidPad::~UhidPad() { teardown(); }

void UhidPad::teardown() {
  if (reader_.joinable()) {
    if (fd_.valid()) {
      uhid_event ev{};
      ev.type = UHID_DESTROY;
      // Destroying is synchronous: the driver's remove (and its last reports)
      // runs inside this write.
      (void)!::write(fd_.get(), &ev, sizeof ev);
    }
    std::uint64_t one = 1;
    (void)!::write(stop_.get(), &one, sizeof one);
    reader_.join();
  }
}

void UhidPad::write_event(const void* ev, std::size_t size) {
  for (;;) {
    const ssize_t n = ::write(fd_.get(), ev, size);
    if (n == static_cast<ssize_t>(size)) return;
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    throw std::system_error(n < 0 ? errno : EIO, std::generic_category(), "write /dev/uhid");
  }
}

void UhidPad::run() {
  pollfd fds[2] = {{fd_.get(), POLLIN, 0}, {stop_.get(), POLLIN, 0}};
  for (;;) {
    if (::poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      std::lock_guard lock(mutex_);
      reader_error_ = std::string("poll: ") + std::strerror(errno);
      return;
    }
    if (fds[0].revents & (POLLIN | POLLHUP | POLLERR)) {
      uhid_event ev{};
      const ssize_t n = ::read(fd_.get(), &ev, sizeof ev);
      if (n < 0) {
        if (errno == EAGAIN || errno == EINTR) continue;
        std::lock_guard lock(mutex_);
        reader_error_ = std::string("read /dev/uhid: ") + std::strerror(errno);
        return;
      }
      const auto now = std::chrono::steady_clock::now();
      switch (ev.type) {
        case UHID_OPEN: {
          std::lock_guard lock(mutex_);
          opened_ = true;
          break;
        }
        case UHID_CLOSE: {
          std::lock_guard lock(mutex_);
          opened_ = false;
          break;
        }
        case UHID_OUTPUT: {
          OutputReport r;
          r.at = now;
          r.kind = OutputReport::Kind::output;
          r.rtype = ev.u.output.rtype;
          r.data.assign(ev.u.output.data, ev.u.output.data + std::min<std::size_t>(ev.u.output.size, UHID_DATA_MAX));
          {
            std::lock_guard lock(mutex_);
            outputs_.push_back(std::move(r));
          }
          changed_.notify_all();
          break;
        }
        case UHID_GET_REPORT: {
          uhid_event reply{};
          reply.type = UHID_GET_REPORT_REPLY;
          reply.u.get_report_reply.id = ev.u.get_report.id;
          const std::vector<std::uint8_t>* answer = nullptr;
          for (const auto& f : spec_.features)
            if (!f.empty() && f[0] == ev.u.get_report.rnum) answer = &f;
          if (answer && ev.u.get_report.rtype == UHID_FEATURE_REPORT) {
            reply.u.get_report_reply.err = 0;
            reply.u.get_report_reply.size = static_cast<std::uint16_t>(answer->size());
            std::memcpy(reply.u.get_report_reply.data, answer->data(), answer->size());
          } else {
            reply.u.get_report_reply.err = EIO;
          }
          {
            std::lock_guard lock(mutex_);
            get_requests_.push_back(ev.u.get_report.rnum);
          }
          try {
            write_event(&reply, sizeof reply);
          } catch (const std::exception& e) {
            std::lock_guard lock(mutex_);
            reader_error_ = e.what();
          }
          changed_.notify_all();
          break;
        }
        case UHID_SET_REPORT: {
          OutputReport r;
          r.at = now;
          r.kind = OutputReport::Kind::set_report;
          r.rtype = ev.u.set_report.rtype;
          r.data.assign(ev.u.set_report.data,
                        ev.u.set_report.data + std::min<std::size_t>(ev.u.set_report.size, UHID_DATA_MAX));
          uhid_event reply{};
          reply.type = UHID_SET_REPORT_REPLY;
          reply.u.set_report_reply.id = ev.u.set_report.id;
          reply.u.set_report_reply.err = 0;
          {
            std::lock_guard lock(mutex_);
            outputs_.push_back(std::move(r));
          }
          try {
            write_event(&reply, sizeof reply);
          } catch (const std::exception& e) {
            std::lock_guard lock(mutex_);
            reader_error_ = e.what();
          }
          changed_.notify_all();
          break;
        }
        default:  // UHID_START, UHID_STOP
          break;
      }
    }
    if (fds[1].revents & POLLIN) return;
  }
}

bool UhidPad::locate() {
  // The hid device whose uevent names our phys: /sys/bus/hid/devices/*.
  if (sysfs_.empty()) {
    std::error_code ec;
    for (const auto& d : fs::directory_iterator("/sys/bus/hid/devices", ec)) {
      const std::string ue = read_text(d.path() / "uevent");
      if (ue.find("HID_PHYS=" + phys_ + "\n") != std::string::npos) {
        sysfs_ = fs::canonical(d.path(), ec).string();
        break;
      }
    }
    if (sysfs_.empty()) return false;
  }
  std::error_code ec;
  const fs::path drv = fs::read_symlink(fs::path(sysfs_) / "driver", ec);
  if (ec || drv.filename() != spec_.driver) return false;
  // The input devices the driver made sit below the hid device (hid-input's
  // and the drivers' own, e.g. the DualSense's gamepad, motion sensors and
  // touchpad); the gamepad is the one with EV_FF.
  for (const auto& in : fs::directory_iterator(fs::path(sysfs_) / "input", ec)) {
    std::string ff = read_text(in.path() / "capabilities" / "ff");
    while (!ff.empty() && (ff.back() == '\n' || ff.back() == ' ')) ff.pop_back();
    if (ff.empty() || ff == "0") continue;
    std::error_code ec2;
    for (const auto& e : fs::directory_iterator(in.path(), ec2)) {
      const std::string n = e.path().filename().string();
      if (n.rfind("event", 0) == 0 && fs::exists("/dev/input/" + n)) {
        ff_node_ = "/dev/input/" + n;
        return true;
      }
    }
  }
  return false;
}

std::vector<std::string> UhidPad::event_nodes() const {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& in : fs::directory_iterator(fs::path(sysfs_) / "input", ec)) {
    std::error_code ec2;
    for (const auto& e : fs::directory_iterator(in.path(), ec2)) {
      const std::string n = e.path().filename().string();
      if (n.rfind("event", 0) == 0) out.push_back("/dev/input/" + n);
    }
  }
  return out;
}

std::string UhidPad::hidraw_node() const {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(fs::path(sysfs_) / "hidraw", ec)) {
    const std::string n = e.path().filename().string();
    if (n.rfind("hidraw", 0) == 0) return "/dev/" + n;
  }
  return "";
}

void UhidPad::send_input(std::span<const std::uint8_t> report) {
  uhid_event ev{};
  ev.type = UHID_INPUT2;
  if (report.size() > sizeof ev.u.input2.data) throw std::runtime_error("input report too large");
  ev.u.input2.size = static_cast<std::uint16_t>(report.size());
  std::memcpy(ev.u.input2.data, report.data(), report.size());
  write_event(&ev, sizeof ev);
}

std::vector<OutputReport> UhidPad::outputs() const {
  std::lock_guard lock(mutex_);
  return outputs_;
}

std::size_t UhidPad::output_count() const {
  std::lock_guard lock(mutex_);
  return outputs_.size();
}

void UhidPad::clear_outputs() {
  std::lock_guard lock(mutex_);
  outputs_.clear();
}

std::vector<std::uint8_t> UhidPad::get_report_requests() const {
  std::lock_guard lock(mutex_);
  return get_requests_;
}

bool UhidPad::opened() const {
  std::lock_guard lock(mutex_);
  return opened_;
}

bool UhidPad::wait_for(const std::function<bool(const std::vector<OutputReport>&)>& pred,
                       std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, scaled(timeout), [&] { return pred(outputs_); });
}

std::vector<UhidPad::MotorReport> UhidPad::motor_reports() const {
  std::vector<MotorReport> out;
  std::lock_guard lock(mutex_);
  for (const auto& r : outputs_)
    if (auto m = spec_.motors(r)) out.push_back({r.at, *m});
  return out;
}

std::optional<Motors> UhidPad::last_motors() const {
  std::lock_guard lock(mutex_);
  for (auto it = outputs_.rbegin(); it != outputs_.rend(); ++it)
    if (auto m = spec_.motors(*it)) return m;
  return std::nullopt;
}

bool UhidPad::wait_for_motors(const std::function<bool(const Motors&)>& pred,
                              std::chrono::milliseconds timeout) const {
  return wait_for(
      [&](const std::vector<OutputReport>& rs) {
        for (auto it = rs.rbegin(); it != rs.rend(); ++it)
          if (auto m = spec_.motors(*it)) return pred(*m);
        return false;
      },
      timeout);
}

}  // namespace sculpt::support
