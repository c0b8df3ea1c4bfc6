#include "devices/device_events.hpp"

#include <sys/epoll.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <system_error>

#include "log/log.hpp"

namespace sculpt::daemon {

DeviceEvents::DeviceEvents(kj::UnixEventPort& port, input::DeviceManager& devices)
    : devices_(devices), epoll_(::epoll_create1(EPOLL_CLOEXEC)) {
  if (!epoll_.valid()) throw std::system_error(errno, std::generic_category(), "epoll_create1");
  sync_fds();
  observer_ =
      kj::heap<kj::UnixEventPort::FdObserver>(port, epoll_.get(), kj::UnixEventPort::FdObserver::OBSERVE_READ);
  // Last: nothing above may throw once the manager holds a pointer to this.
  devices_.on_fds_changed([this] { fds_changed_ = true; });
}

DeviceEvents::~DeviceEvents() {
  devices_.on_fds_changed({});
  observer_ = nullptr;  // before the fd it watches closes
}

kj::Promise<void> DeviceEvents::run() {
  if (drain()) return kj::evalLater([this] { return run(); });
  return observer_->whenBecomesReadable().then([this] { return run(); });
}

bool DeviceEvents::drain() {
  std::array<epoll_event, 16> ev{};
  for (int round = 0; round < 32; ++round) {
    const int n = ::epoll_wait(epoll_.get(), ev.data(), static_cast<int>(ev.size()), 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    for (int i = 0; i < n; ++i) {
      devices_.dispatch(ev[static_cast<std::size_t>(i)].data.fd);
      if (fds_changed_) sync_fds();
    }
  }
  return true;
}

void DeviceEvents::sync_fds() {
  fds_changed_ = false;
  for (int fd : registered_) ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, fd, nullptr);  // errors: already gone
  registered_ = devices_.fds();
  for (int fd : registered_) {
    epoll_event e{};
    e.events = EPOLLIN;
    e.data.fd = fd;
    if (::epoll_ctl(epoll_.get(), EPOLL_CTL_ADD, fd, &e) != 0)
      log::warning("cannot watch device fd {}: {}", fd, std::strerror(errno));
  }
}

}  // namespace sculpt::daemon
