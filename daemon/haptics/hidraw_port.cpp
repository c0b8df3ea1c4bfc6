#include "haptics/hidraw_port.hpp"

#include <fcntl.h>
#include <linux/input.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <fstream>
#include <system_error>
#include <vector>

namespace sculpt::haptics {

namespace fs = std::filesystem;

namespace {

bool parse_hex(std::string_view text, std::uint32_t& out) {
  const auto r = std::from_chars(text.data(), text.data() + text.size(), out, 16);
  return r.ec == std::errc() && r.ptr == text.data() + text.size();
}

// "0003:054C:0CE6.0001" → bus, vendor, product (the kernel's hid_device name,
// dev_set_name(&hdev->dev, "%04X:%04X:%04X.%04X", bus, vendor, product, id)).
bool parse_hid_name(const std::string& name, HidrawInfo& info) {
  if (name.size() < 19 || name[4] != ':' || name[9] != ':' || name[14] != '.') return false;
  std::uint32_t bus = 0, vendor = 0, product = 0;
  if (!parse_hex(std::string_view(name).substr(0, 4), bus) || !parse_hex(std::string_view(name).substr(5, 4), vendor) ||
      !parse_hex(std::string_view(name).substr(10, 4), product))
    return false;
  info.bus = static_cast<std::uint16_t>(bus);
  info.vendor = static_cast<std::uint16_t>(vendor);
  info.product = static_cast<std::uint16_t>(product);
  return true;
}

class HidrawFd final : public HidrawPort {
 public:
  HidrawFd(int fd, std::string node) : fd_(fd), node_(std::move(node)) {}
  ~HidrawFd() override { ::close(fd_); }
  HidrawFd(const HidrawFd&) = delete;
  HidrawFd& operator=(const HidrawFd&) = delete;

  int write_report(std::span<const std::uint8_t> report) override {
    ssize_t n;
    do n = ::write(fd_, report.data(), report.size());
    while (n < 0 && errno == EINTR);
    if (n < 0) return errno;
    return static_cast<std::size_t>(n) == report.size() ? 0 : EIO;
  }
  const std::string& node() const override { return node_; }

 private:
  int fd_;
  std::string node_;
};

}  // namespace

std::optional<HidrawInfo> find_hidraw(const std::string& event_node, const fs::path& sys_root, const fs::path& dev_root) {
  const std::string event = fs::path(event_node).filename().string();
  if (event.rfind("event", 0) != 0) return std::nullopt;
  std::error_code ec;
  // eventN/device is the input device; its own `device` link is the parent,
  // the HID device for HID pads (a uinput device's parent is the uinput
  // misc device, which has no hidraw child).
  const fs::path hid = fs::canonical(sys_root / "class" / "input" / event / "device" / "device", ec);
  if (ec) return std::nullopt;
  HidrawInfo info;
  if (!parse_hid_name(hid.filename().string(), info)) return std::nullopt;
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(hid / "hidraw", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("hidraw", 0) == 0) names.push_back(name);
  }
  if (ec || names.empty()) return std::nullopt;
  std::sort(names.begin(), names.end());  // one per HID device; sorted for a stable answer anyway
  info.node = (dev_root / names.front()).string();
  return info;
}

std::optional<DualSenseHidraw> open_dualsense_hidraw(const std::string& event_node, const fs::path& sys_root,
                                                     const fs::path& dev_root) {
  const auto info = find_hidraw(event_node, sys_root, dev_root);
  if (!info || !dualsense::is_dualsense(info->vendor, info->product)) return std::nullopt;
  if (info->bus != BUS_USB && info->bus != BUS_BLUETOOTH) return std::nullopt;
  const int fd = ::open(info->node.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw std::system_error(errno, std::generic_category(), info->node);
  DualSenseHidraw out;
  out.port = std::make_unique<HidrawFd>(fd, info->node);
  out.transport = info->bus == BUS_BLUETOOTH ? dualsense::Transport::bluetooth : dualsense::Transport::usb;
  return out;
}

}  // namespace sculpt::haptics
