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
#include <stdexcept>
#include <system_error>

#include "support/read_file.hpp"
#include "support/timing.hpp"

namespace sculpt::support {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

// The pads themselves: uhid_pads/<pad>.cpp, one file each.
namespace uhid_pads {

std::vector<const UhidPadSpec*> all() { return {&dualsense_usb(), &dualshock4_usb(), &xbox_one_s_bt()}; }

}  // namespace uhid_pads

namespace {

std::string why_no_driver(const UhidPadSpec& spec) {
  std::string msg = "hid driver '" + spec.driver + "' (" + spec.module + ") is not loaded: no /sys/bus/hid/drivers/" +
                    spec.driver + ".";
  const std::string log = read_file("/lib/sculpt/insmod-failures");
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
    const std::string log = read_file("/lib/sculpt/insmod-failures");
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
      const std::string ue = read_file(d.path() / "uevent");
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
    std::string ff = read_file(in.path() / "capabilities" / "ff");
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
