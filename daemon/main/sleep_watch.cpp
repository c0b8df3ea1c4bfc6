#include "main/sleep_watch.hpp"

#include <systemd/sd-bus.h>

#include <cstring>

#include "log/log.hpp"

namespace sculpt::daemon {

SleepWatch::SleepWatch(std::function<void(bool sleeping)> on_sleep) : on_sleep_(std::move(on_sleep)) {}

SleepWatch::~SleepWatch() { stop(); }

void SleepWatch::start() {
  if (thread_.joinable()) return;
  stop_ = false;
  thread_ = std::thread([this] { run(); });
}

void SleepWatch::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void SleepWatch::run() {
  sd_bus* bus = nullptr;
  if (const int r = sd_bus_open_system(&bus); r < 0) {
    log::debug("no system bus ({}): resumes from suspend are seen by CLOCK_BOOTTIME only", std::strerror(-r));
    return;
  }
  auto handler = [](sd_bus_message* m, void* self, sd_bus_error*) -> int {
    int sleeping = 0;
    if (sd_bus_message_read(m, "b", &sleeping) >= 0) static_cast<SleepWatch*>(self)->on_sleep_(sleeping != 0);
    return 0;
  };
  if (const int r = sd_bus_match_signal(bus, nullptr, "org.freedesktop.login1", "/org/freedesktop/login1",
                                        "org.freedesktop.login1.Manager", "PrepareForSleep", handler, this);
      r < 0) {
    log::debug("cannot watch logind's PrepareForSleep ({}): resumes are seen by CLOCK_BOOTTIME only",
               std::strerror(-r));
    sd_bus_flush_close_unref(bus);
    return;
  }
  while (!stop_) {
    const int r = sd_bus_process(bus, nullptr);
    if (r < 0) {
      log::debug("system bus: {}; no more PrepareForSleep", std::strerror(-r));
      break;
    }
    if (r > 0) continue;
    (void)sd_bus_wait(bus, 100'000);  // µs: stop() is noticed within 100 ms
  }
  sd_bus_flush_close_unref(bus);
}

}  // namespace sculpt::daemon
