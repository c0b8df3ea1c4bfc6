#include "input/device_manager.hpp"

#include <libudev.h>
#include <sys/inotify.h>
#include <syslog.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <system_error>

#include <fmt/format.h>

#include "input/evdev_device.hpp"

namespace sculpt::input {
namespace {

bool is_event_node_name(std::string_view name) {
  return name.size() > 5 && name.substr(0, 5) == "event" &&
         std::all_of(name.begin() + 5, name.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// What udev says about a node: joystick, something else, or nothing at all
// (no rules ran for it: classify from capabilities).
enum class UdevVerdict { joystick, not_joystick, unknown };

UdevVerdict udev_verdict(udev_device* d) {
  if (!d) return UdevVerdict::unknown;
  const char* joy = udev_device_get_property_value(d, "ID_INPUT_JOYSTICK");
  if (joy && std::strcmp(joy, "1") == 0) return UdevVerdict::joystick;
  if (udev_device_get_property_value(d, "ID_INPUT")) return UdevVerdict::not_joystick;
  return UdevVerdict::unknown;
}

}  // namespace

struct DeviceManager::Impl {
  DeviceListener& listener;
  DeviceManagerOptions options;
  std::function<void()> fds_changed;

  bool started = false;
  bool use_udev = false;
  udev* udev_ctx = nullptr;
  udev_monitor* monitor = nullptr;
  files::UniqueFd inotify;
  int dir_watch = -1;     // dev_dir
  int parent_watch = -1;  // its parent, until dev_dir exists

  struct Slot {
    std::string identity;   // empty: never used
    bool live = false;
    std::uint64_t released = 0;  // when it last became free (a counter)
  };
  std::array<Slot, kMaxDevices> slots{};
  std::uint64_t releases = 0;

  std::map<int, std::unique_ptr<EvdevDevice>> open;  // by fd

  Impl(DeviceListener& l, DeviceManagerOptions o) : listener(l), options(std::move(o)) {}
  ~Impl() {
    if (monitor) udev_monitor_unref(monitor);
    if (udev_ctx) udev_unref(udev_ctx);
  }

  void log(int prio, const std::string& m) { listener.on_log(prio, m); }
  void changed() {
    if (fds_changed) fds_changed();
  }

  EvdevDevice* by_node(const std::string& node) {
    for (auto& [fd, d] : open)
      if (d->info().node == node) return d.get();
    return nullptr;
  }

  int assign_slot(const std::string& identity) {
    for (std::size_t i = 0; i < slots.size(); ++i)
      if (!slots[i].live && slots[i].identity == identity) return static_cast<int>(i);
    for (std::size_t i = 0; i < slots.size(); ++i)
      if (slots[i].identity.empty()) return static_cast<int>(i);
    // All used once: take the slot free the longest.
    int best = -1;
    for (std::size_t i = 0; i < slots.size(); ++i)
      if (!slots[i].live && (best < 0 || slots[i].released < slots[static_cast<std::size_t>(best)].released))
        best = static_cast<int>(i);
    return best;
  }

  // A node appeared (or was there at start-up): open it if it is ours.
  bool consider(const std::string& node, udev_device* ud) {
    if (by_node(node)) return false;
    const UdevVerdict verdict = use_udev ? udev_verdict(ud) : UdevVerdict::unknown;
    if (verdict == UdevVerdict::not_joystick && !options.accept_all) return false;
    std::unique_ptr<EvdevDevice> dev;
    try {
      dev = std::make_unique<EvdevDevice>(node);
    } catch (const std::system_error& e) {
      // EACCES right after creation is normal without udev's rules having
      // run yet (inotify: we retry on IN_ATTRIB); say it once at debug level.
      log(e.code().value() == EACCES ? LOG_DEBUG : LOG_WARNING, fmt::format("{}: {}", node, e.what()));
      return false;
    }
    DeviceInfo& info = dev->info();
    if (verdict == UdevVerdict::joystick) {
      info.kind = classify_udev_joystick(info);
      info.kind_from_udev = true;
    }
    if (info.kind == DeviceKind::other && !options.accept_all) {
      log(LOG_DEBUG, fmt::format("{}: '{}' is not a joystick or gamepad, ignored", node, info.name));
      return false;
    }
    const int slot = assign_slot(info.identity());
    if (slot < 0) {
      log(LOG_WARNING, fmt::format("{}: all {} device slots are in use, '{}' ignored", node, kMaxDevices, info.name));
      return false;
    }
    auto& s = slots[static_cast<std::size_t>(slot)];
    s.identity = info.identity();
    s.live = true;
    dev->set_slot(static_cast<std::uint8_t>(slot));
    const int fd = dev->fd();
    const DeviceInfo copy = info;
    open.emplace(fd, std::move(dev));
    changed();
    listener.on_attach(static_cast<std::uint8_t>(slot), copy);
    return true;
  }

  void detach(int fd, const std::string& why) {
    auto it = open.find(fd);
    if (it == open.end()) return;
    const std::uint8_t slot = it->second->slot();
    log(LOG_INFO, fmt::format("{}: '{}' gone ({}), slot {} kept for it", it->second->info().node,
                              it->second->info().name, why, slot));
    open.erase(it);  // closes the fd
    slots[slot].live = false;
    slots[slot].released = ++releases;
    // Every change, at once: a detach and an attach in one dispatch can leave
    // the fd count, even the fd numbers, as they were, yet the new node's
    // file is not the one the owner registered.
    changed();
    listener.on_detach(slot);
  }

  void scan_dir() {
    std::error_code ec;
    std::vector<std::string> nodes;
    for (const auto& e : std::filesystem::directory_iterator(options.dev_dir, ec)) {
      const std::string name = e.path().filename().string();
      if (is_event_node_name(name)) nodes.push_back(e.path().string());
    }
    // Plug-in order is the kernel's numbering order: event2 before event10.
    std::sort(nodes.begin(), nodes.end(), [](const std::string& a, const std::string& b) {
      return a.size() != b.size() ? a.size() < b.size() : a < b;
    });
    for (const auto& n : nodes) consider(n, nullptr);
  }

  void start_inotify() {
    inotify = files::UniqueFd(::inotify_init1(IN_NONBLOCK | IN_CLOEXEC));
    if (!inotify.valid()) throw std::system_error(errno, std::generic_category(), "inotify_init1");
    watch_dir();
    if (dir_watch >= 0) scan_dir();
  }

  void watch_dir() {
    dir_watch = ::inotify_add_watch(inotify.get(), options.dev_dir.c_str(),
                                    IN_CREATE | IN_ATTRIB | IN_DELETE | IN_MOVED_TO);
    if (dir_watch >= 0) {
      if (parent_watch >= 0) ::inotify_rm_watch(inotify.get(), parent_watch), parent_watch = -1;
      return;
    }
    if (errno != ENOENT)
      throw std::system_error(errno, std::generic_category(), "inotify watch " + options.dev_dir.string());
    // No input device yet, so no /dev/input either: wait for it to appear.
    if (parent_watch < 0) {
      parent_watch = ::inotify_add_watch(inotify.get(), options.dev_dir.parent_path().c_str(), IN_CREATE | IN_MOVED_TO);
      if (parent_watch < 0)
        throw std::system_error(errno, std::generic_category(),
                                "inotify watch " + options.dev_dir.parent_path().string());
    }
  }

  void read_inotify() {
    alignas(inotify_event) char buf[4096];
    for (;;) {
      const ssize_t n = ::read(inotify.get(), buf, sizeof buf);
      if (n <= 0) {
        if (n < 0 && errno == EINTR) continue;
        return;  // EAGAIN: drained
      }
      for (char* p = buf; p < buf + n;) {
        auto* e = reinterpret_cast<inotify_event*>(p);
        p += sizeof(inotify_event) + e->len;
        const std::string name = e->len ? e->name : "";
        if (e->wd == parent_watch) {
          if (name == options.dev_dir.filename().string() && (e->mask & (IN_CREATE | IN_MOVED_TO))) {
            watch_dir();
            if (dir_watch >= 0) scan_dir();
          }
          continue;
        }
        if (e->wd != dir_watch) continue;
        if (e->mask & IN_IGNORED) {  // the directory itself went away
          dir_watch = -1;
          watch_dir();
          continue;
        }
        if (!is_event_node_name(name)) continue;
        const std::string node = (options.dev_dir / name).string();
        if (e->mask & IN_DELETE) {
          if (EvdevDevice* d = by_node(node)) detach(d->fd(), "node removed");
        } else {
          consider(node, nullptr);  // created, or its permissions changed: try (again)
        }
      }
    }
  }

  void start_udev() {
    udev_ctx = udev_new();
    if (!udev_ctx) throw std::system_error(ENOMEM, std::generic_category(), "udev_new");
    monitor = udev_monitor_new_from_netlink(udev_ctx, "udev");
    if (!monitor) throw std::system_error(errno ? errno : EIO, std::generic_category(), "udev monitor");
    udev_monitor_filter_add_match_subsystem_devtype(monitor, "input", nullptr);
    const int rc = udev_monitor_enable_receiving(monitor);
    if (rc < 0) throw std::system_error(-rc, std::generic_category(), "udev monitor: enable receiving");
    // Listen before enumerating, so nothing plugged in between is missed.
    udev_enumerate* en = udev_enumerate_new(udev_ctx);
    udev_enumerate_add_match_subsystem(en, "input");
    udev_enumerate_scan_devices(en);
    std::vector<std::pair<std::string, std::string>> nodes;  // devnode, syspath
    for (udev_list_entry* e = udev_enumerate_get_list_entry(en); e; e = udev_list_entry_get_next(e)) {
      udev_device* d = udev_device_new_from_syspath(udev_ctx, udev_list_entry_get_name(e));
      if (!d) continue;
      const char* node = udev_device_get_devnode(d);
      const char* sys = udev_device_get_sysname(d);
      if (node && sys && is_event_node_name(sys)) nodes.emplace_back(node, udev_list_entry_get_name(e));
      udev_device_unref(d);
    }
    udev_enumerate_unref(en);
    std::sort(nodes.begin(), nodes.end(), [](const auto& a, const auto& b) {
      return a.first.size() != b.first.size() ? a.first.size() < b.first.size() : a.first < b.first;
    });
    for (const auto& [node, sys] : nodes) {
      udev_device* d = udev_device_new_from_syspath(udev_ctx, sys.c_str());
      consider(node, d);
      if (d) udev_device_unref(d);
    }
  }

  void read_udev() {
    while (udev_device* d = udev_monitor_receive_device(monitor)) {
      const char* action = udev_device_get_action(d);
      const char* node = udev_device_get_devnode(d);
      const char* sys = udev_device_get_sysname(d);
      if (action && node && sys && is_event_node_name(sys)) {
        if (std::strcmp(action, "add") == 0 || std::strcmp(action, "change") == 0) {
          consider(node, d);
        } else if (std::strcmp(action, "remove") == 0) {
          if (EvdevDevice* dev = by_node(node)) detach(dev->fd(), "udev remove");
        }
      }
      udev_device_unref(d);
    }
  }

  int discovery_fd() const { return use_udev ? udev_monitor_get_fd(monitor) : inotify.get(); }
};

DeviceManager::DeviceManager(DeviceListener& listener, DeviceManagerOptions options)
    : impl_(std::make_unique<Impl>(listener, std::move(options))) {}

DeviceManager::~DeviceManager() = default;

void DeviceManager::start() {
  Impl& m = *impl_;
  if (m.started) return;
  bool udev = m.options.discovery == Discovery::udev;
  if (m.options.discovery == Discovery::automatic) udev = ::access("/run/udev/control", F_OK) == 0;
  m.use_udev = udev;
  if (udev) {
    m.start_udev();
    m.log(LOG_INFO, "input: udev monitor for hot-plug");
  } else {
    m.start_inotify();
    m.log(LOG_INFO, fmt::format("input: no udev, watching {} with inotify", m.options.dev_dir.string()));
  }
  m.started = true;
  m.changed();
}

std::vector<int> DeviceManager::fds() const {
  std::vector<int> out;
  if (!impl_->started) return out;
  out.push_back(impl_->discovery_fd());
  for (const auto& [fd, d] : impl_->open) out.push_back(fd);
  return out;
}

void DeviceManager::on_fds_changed(std::function<void()> callback) { impl_->fds_changed = std::move(callback); }

void DeviceManager::dispatch(int fd) {
  Impl& m = *impl_;
  if (!m.started) return;
  if (fd == m.discovery_fd()) {
    if (m.use_udev) m.read_udev();
    else m.read_inotify();
  } else if (auto it = m.open.find(fd); it != m.open.end()) {
    int err = 0;
    const auto r = it->second->read([&](const InputFrame& f) { m.listener.on_frame(f); }, &err);
    if (r == EvdevDevice::ReadResult::gone) m.detach(fd, err == ENODEV ? "unplugged" : std::strerror(err));
  }
}

std::string_view DeviceManager::discovery() const {
  if (!impl_->started) return "";
  return impl_->use_udev ? "udev" : "inotify";
}

std::vector<std::pair<std::uint8_t, DeviceInfo>> DeviceManager::devices() const {
  std::vector<std::pair<std::uint8_t, DeviceInfo>> out;
  for (const auto& [fd, d] : impl_->open) out.emplace_back(d->slot(), d->info());
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return out;
}

std::size_t DeviceManager::attached() const { return impl_->open.size(); }

DeviceInfo describe_node(const std::filesystem::path& node) { return EvdevDevice(node).info(); }

}  // namespace sculpt::input
