#include "uinput/virtual_device.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <system_error>
#include <type_traits>

namespace sculpt::uinput {
namespace {

[[noreturn]] void throw_errno(const std::string& what) {
  throw std::system_error(errno, std::generic_category(), "VirtualDevice: " + what);
}

void xioctl(int fd, unsigned long request, long arg, const char* what) {
  if (::ioctl(fd, request, arg) < 0) throw_errno(what);
}

// The evdev handler's node for sysfs device "inputN": the "eventM" child.
std::string find_event_node(const std::string& sysname) {
  const std::string dir = "/sys/class/input/" + sysname;
  DIR* d = ::opendir(dir.c_str());
  if (!d) return {};
  std::string node;
  while (dirent* e = ::readdir(d)) {
    if (std::strncmp(e->d_name, "event", 5) == 0) {
      node = std::string("/dev/input/") + e->d_name;
      break;
    }
  }
  ::closedir(d);
  return node;
}

}  // namespace

void FfLog::add(const FfRecord& r) {
  sequence.push_back(r);
  std::visit(
      [this](const auto& v) {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, FfUpload>) uploads.push_back(v);
        else if constexpr (std::is_same_v<T, FfErase>) erases.push_back(v);
        else if constexpr (std::is_same_v<T, FfPlayback>) playbacks.push_back(v);
        else if constexpr (std::is_same_v<T, FfGain>) gains.push_back(v);
        else autocenters.push_back(v);
      },
      r);
}

VirtualDevice::VirtualDevice(DeviceSpec spec) : spec_(std::move(spec)) {
  if (!spec_.ff_bits.empty() && spec_.ff_effects_max == 0)
    throw std::invalid_argument(
        "VirtualDevice: FF bits are set but ff_effects_max is 0 (uinput refuses such a device)");
  if (spec_.name.size() >= UINPUT_MAX_NAME_SIZE)
    throw std::invalid_argument("VirtualDevice: name longer than " +
                                std::to_string(UINPUT_MAX_NAME_SIZE - 1) + " bytes: " + spec_.name);
  plug();
}

VirtualDevice::~VirtualDevice() {
  try {
    unplug();
  } catch (...) {
    // Destruction must not throw; the fds are closed by their owners anyway.
  }
}

void VirtualDevice::plug() {
  if (plugged()) return;
  create_device();
  stop_ = UniqueFd(::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK));
  if (!stop_.valid()) {
    destroy_device();
    throw_errno("eventfd");
  }
  thread_ = std::thread([this] { service(); });
}

void VirtualDevice::unplug() {
  if (!plugged()) return;
  if (thread_.joinable()) {
    const std::uint64_t one = 1;
    if (::write(stop_.get(), &one, sizeof one) != sizeof one) std::terminate();  // cannot stop the thread
    thread_.join();
  }
  stop_.reset();
  destroy_device();
}

void VirtualDevice::create_device() {
  UniqueFd fd(::open("/dev/uinput", O_RDWR | O_NONBLOCK | O_CLOEXEC));
  if (!fd.valid()) throw_errno("open /dev/uinput");
  const int f = fd.get();

  if (!spec_.buttons.empty()) {
    xioctl(f, UI_SET_EVBIT, EV_KEY, "UI_SET_EVBIT EV_KEY");
    for (auto b : spec_.buttons) xioctl(f, UI_SET_KEYBIT, b, "UI_SET_KEYBIT");
  }
  if (!spec_.axes.empty()) {
    xioctl(f, UI_SET_EVBIT, EV_ABS, "UI_SET_EVBIT EV_ABS");
    for (const auto& a : spec_.axes) xioctl(f, UI_SET_ABSBIT, a.code, "UI_SET_ABSBIT");
  }
  if (!spec_.msc.empty()) {
    xioctl(f, UI_SET_EVBIT, EV_MSC, "UI_SET_EVBIT EV_MSC");
    for (auto m : spec_.msc) xioctl(f, UI_SET_MSCBIT, m, "UI_SET_MSCBIT");
  }
  if (!spec_.phys.empty() && ::ioctl(f, UI_SET_PHYS, spec_.phys.c_str()) < 0) throw_errno("UI_SET_PHYS");
  if (!spec_.ff_bits.empty()) {
    xioctl(f, UI_SET_EVBIT, EV_FF, "UI_SET_EVBIT EV_FF");
    for (auto b : spec_.ff_bits) xioctl(f, UI_SET_FFBIT, b, "UI_SET_FFBIT");
  }

  uinput_setup setup{};
  setup.id = spec_.id;
  std::strncpy(setup.name, spec_.name.c_str(), UINPUT_MAX_NAME_SIZE - 1);
  setup.ff_effects_max = spec_.ff_bits.empty() ? 0 : spec_.ff_effects_max;
  if (::ioctl(f, UI_DEV_SETUP, &setup) < 0) throw_errno("UI_DEV_SETUP");
  for (const auto& a : spec_.axes) {
    uinput_abs_setup abs{};
    abs.code = a.code;
    abs.absinfo = a.info;
    if (::ioctl(f, UI_ABS_SETUP, &abs) < 0) throw_errno("UI_ABS_SETUP code " + std::to_string(a.code));
  }
  if (::ioctl(f, UI_DEV_CREATE) < 0) throw_errno("UI_DEV_CREATE for '" + spec_.name + "'");

  char name[64] = {};
  if (::ioctl(f, UI_GET_SYSNAME(sizeof name - 1), name) < 0) throw_errno("UI_GET_SYSNAME");
  sysname_ = name;

  // devtmpfs makes the node before UI_DEV_CREATE returns; with udev the
  // sysfs child and the node can lag a little behind. Wait, bounded.
  const auto deadline = Clock::now() + default_timeout;
  for (;;) {
    event_node_ = find_event_node(sysname_);
    struct stat st {};
    if (!event_node_.empty() && ::stat(event_node_.c_str(), &st) == 0 && S_ISCHR(st.st_mode)) break;
    if (Clock::now() > deadline) {
      ::ioctl(f, UI_DEV_DESTROY);
      throw std::runtime_error("VirtualDevice: no /dev/input/event* node for /sys/class/input/" +
                               sysname_ + " (is the evdev module loaded?)");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  uinput_ = std::move(fd);
}

void VirtualDevice::destroy_device() {
  if (!uinput_.valid()) return;
  ::ioctl(uinput_.get(), UI_DEV_DESTROY);  // close() would too; be explicit
  uinput_.reset();
  event_node_.clear();
  sysname_.clear();
}

void VirtualDevice::service() {
  try {
    pollfd fds[2] = {{uinput_.get(), POLLIN, 0}, {stop_.get(), POLLIN, 0}};
    for (;;) {
      if (::poll(fds, 2, -1) < 0) {
        if (errno == EINTR) continue;
        throw_errno("poll");
      }
      if (fds[1].revents) return;
      if (fds[0].revents & (POLLERR | POLLHUP | POLLNVAL))
        throw std::runtime_error("VirtualDevice: uinput fd reported an error");
      input_event evs[64];
      for (;;) {
        const ssize_t n = ::read(uinput_.get(), evs, sizeof evs);
        if (n < 0) {
          if (errno == EAGAIN || errno == EINTR) break;
          throw_errno("read uinput");
        }
        for (std::size_t i = 0; i < static_cast<std::size_t>(n) / sizeof(input_event); ++i) handle(evs[i]);
        if (static_cast<std::size_t>(n) < sizeof evs) break;
      }
    }
  } catch (const std::exception& e) {
    std::lock_guard lock(mutex_);
    service_error_ = e.what();
    changed_.notify_all();
  }
}

void VirtualDevice::handle(const input_event& ev) {
  if (ev.type == EV_UINPUT) {
    if (ev.code == UI_FF_UPLOAD) answer_upload(ev.value);
    else if (ev.code == UI_FF_ERASE) answer_erase(ev.value);
    return;
  }
  if (ev.type != EV_FF) return;  // LEDs, sounds: not ours to record
  if (ev.code == FF_GAIN) record(FfGain{static_cast<std::uint16_t>(ev.value)});
  else if (ev.code == FF_AUTOCENTER) record(FfAutocenter{static_cast<std::uint16_t>(ev.value)});
  else record(FfPlayback{static_cast<std::int16_t>(ev.code), ev.value});
}

void VirtualDevice::answer_upload(std::int32_t request_id) {
  uinput_ff_upload up{};
  up.request_id = static_cast<std::uint32_t>(request_id);
  if (::ioctl(uinput_.get(), UI_BEGIN_FF_UPLOAD, &up) < 0) throw_errno("UI_BEGIN_FF_UPLOAD");
  int err;
  {
    std::lock_guard lock(mutex_);
    err = upload_errno_;
  }
  up.retval = -err;
  FfUpload rec{up.effect, std::nullopt, up.effect.id, up.retval};
  if (up.old.type != 0) rec.old = up.old;  // the kernel zeroes `old` for a new effect
  // Record before answering: once the client's ioctl returns, the log has it.
  record(rec);
  if (::ioctl(uinput_.get(), UI_END_FF_UPLOAD, &up) < 0) throw_errno("UI_END_FF_UPLOAD");
}

void VirtualDevice::answer_erase(std::int32_t request_id) {
  uinput_ff_erase er{};
  er.request_id = static_cast<std::uint32_t>(request_id);
  if (::ioctl(uinput_.get(), UI_BEGIN_FF_ERASE, &er) < 0) throw_errno("UI_BEGIN_FF_ERASE");
  {
    std::lock_guard lock(mutex_);
    er.retval = -erase_errno_;
  }
  record(FfErase{static_cast<std::int16_t>(er.effect_id), er.retval});
  if (::ioctl(uinput_.get(), UI_END_FF_ERASE, &er) < 0) throw_errno("UI_END_FF_ERASE");
}

void VirtualDevice::record(const FfRecord& r) {
  std::lock_guard lock(mutex_);
  if (std::holds_alternative<FfUpload>(r)) ++uploads_answered_;
  if (recording_) log_.add(r);
  changed_.notify_all();
}

void VirtualDevice::write_event(std::uint16_t type, std::uint16_t code, std::int32_t value) {
  if (!plugged()) throw std::logic_error("VirtualDevice: emitting an event while unplugged");
  input_event ev{};
  ev.type = type;
  ev.code = code;
  ev.value = value;
  if (::write(uinput_.get(), &ev, sizeof ev) != static_cast<ssize_t>(sizeof ev))
    throw_errno("write event to uinput");
}

void VirtualDevice::emit(std::uint16_t type, std::uint16_t code, std::int32_t value) {
  write_event(type, code, value);
}
void VirtualDevice::emit_all(std::span<const input_event> events) {
  if (!plugged()) throw std::logic_error("VirtualDevice: emitting events while unplugged");
  const auto bytes = static_cast<ssize_t>(events.size_bytes());
  if (bytes == 0) return;
  if (::write(uinput_.get(), events.data(), events.size_bytes()) != bytes) throw_errno("write events to uinput");
}
void VirtualDevice::sync() { write_event(EV_SYN, SYN_REPORT, 0); }
void VirtualDevice::move_axis(std::uint16_t code, std::int32_t value) {
  write_event(EV_ABS, code, value);
  sync();
}
void VirtualDevice::move_axes(std::initializer_list<std::pair<std::uint16_t, std::int32_t>> values) {
  for (const auto& [code, value] : values) write_event(EV_ABS, code, value);
  sync();
}
void VirtualDevice::press(std::uint16_t button) {
  write_event(EV_KEY, button, 1);
  sync();
}
void VirtualDevice::release(std::uint16_t button) {
  write_event(EV_KEY, button, 0);
  sync();
}

void VirtualDevice::fail_uploads_with(int errno_value) {
  std::lock_guard lock(mutex_);
  upload_errno_ = errno_value;
}
void VirtualDevice::fail_erases_with(int errno_value) {
  std::lock_guard lock(mutex_);
  erase_errno_ = errno_value;
}

FfLog VirtualDevice::log() const {
  std::lock_guard lock(mutex_);
  return log_;
}

void VirtualDevice::set_recording(bool on) {
  std::lock_guard lock(mutex_);
  recording_ = on;
}

std::size_t VirtualDevice::uploads_answered() const {
  std::lock_guard lock(mutex_);
  return uploads_answered_;
}

void VirtualDevice::clear_log() {
  std::lock_guard lock(mutex_);
  log_.clear();
}

bool VirtualDevice::wait_for(const std::function<bool(const FfLog&)>& pred,
                               std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  const bool ok = changed_.wait_for(lock, timeout, [&] { return !service_error_.empty() || pred(log_); });
  if (!service_error_.empty()) throw std::runtime_error("VirtualDevice service thread failed: " + service_error_);
  return ok;
}

}  // namespace sculpt::uinput
