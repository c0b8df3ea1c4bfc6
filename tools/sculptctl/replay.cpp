// `sculptctl replay FILE`: plays a recording through uinput. Each
// recorded device becomes a virtual device with the same name, ids, axes
// (absinfo), buttons and FF bits, which ANSWERS force-feedback uploads (a
// client's EVIOCSFF would otherwise block for 30 s). Frames go out at their
// recorded times, each with EV_MSC/MSC_TIMESTAMP = the recorded time, so a
// daemon scheduling by device time (sculptd --input-clock device) lands them
// on the same ticks as an in-process replay.
#include <signal.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>
#include <time.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <memory>

#include <fmt/format.h>

#include "cli/conventions.hpp"
#include "commands.hpp"
#include "stop_signal.hpp"
#include "input/recording.hpp"
#include "uinput/virtual_device.hpp"

namespace sculpt::ctl {
namespace {



uinput::DeviceSpec spec_of(const input::DeviceInfo& d) {
  uinput::DeviceSpec s;
  s.name = d.name.substr(0, UINPUT_MAX_NAME_SIZE - 1);
  s.id = input_id{d.bustype ? d.bustype : static_cast<std::uint16_t>(BUS_VIRTUAL), d.vendor, d.product, d.version};
  s.phys = d.phys;
  // fuzz 0: the recorded values were defuzzed when recorded; a second pass
  // in the kernel would change them (it averages near moves).
  for (const auto& a : d.axes)
    s.axes.push_back({a.code, input_absinfo{a.value, a.minimum, a.maximum, 0, a.flat, a.resolution}});
  s.buttons = d.buttons;
  s.msc = {MSC_TIMESTAMP};
  s.ff_bits = d.ff;
  s.ff_effects_max = d.ff.empty() ? 0u : static_cast<std::uint32_t>(d.ff_effects_max > 0 ? d.ff_effects_max : 16);
  return s;
}

// With udevd running, waits (bounded) until udev has processed the node:
// its database entry /run/udev/data/c<major>:<minor> exists.
void wait_for_udev(const std::string& node) {
  if (::access("/run/udev/control", F_OK) != 0) return;
  struct stat st {};
  if (::stat(node.c_str(), &st) != 0) return;
  const std::string db = fmt::format("/run/udev/data/c{}:{}", major(st.st_rdev), minor(st.st_rdev));
  for (int i = 0; i < 400 && ::access(db.c_str(), F_OK) != 0; ++i) ::usleep(5000);  // up to 2 s
}

timespec add_ns(timespec t, std::int64_t ns) {
  ns += t.tv_nsec;
  t.tv_sec += static_cast<time_t>(ns / 1000000000);
  t.tv_nsec = static_cast<long>(ns % 1000000000);
  return t;
}

// Sleeps until `deadline`; false when a signal asked us to stop.
bool sleep_until(const timespec& deadline) {
  for (;;) {
    if (stop_requested()) return false;
    const int rc = ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr);
    if (rc == 0) return !stop_requested();
    if (rc != EINTR) return false;
  }
}

}  // namespace

void replay(const ReplayArgs& args) {
  catch_stop_signals();

  std::unique_ptr<input::RecordingReader> reader;
  try {
    reader = std::make_unique<input::RecordingReader>(args.file);
  } catch (const input::RecordingError& e) {
    cli::error(fmt::format("replay: {}", e.what()));
    throw CommandFailed{kExitUsage};
  }
  std::vector<std::unique_ptr<uinput::VirtualDevice>> devices;
  try {
    for (const auto& d : reader->header().devices) {
      devices.push_back(std::make_unique<uinput::VirtualDevice>(spec_of(d)));
      devices.back()->set_recording(false);  // answer uploads, count them, keep no log
      // Clients number devices in plug-in order; with udevd that is the order
      // udev finishes them, so let it finish each before the next appears.
      wait_for_udev(devices.back()->event_node());
    }
  } catch (const std::exception& e) {
    cli::error(fmt::format("replay: cannot create the virtual devices ({}){}", e.what(),
               errno == ENOENT || errno == EACCES ? "; replay needs write access to /dev/uinput" : ""));
    throw CommandFailed{kExitCommandFailed};
  }
  for (std::size_t i = 0; i < devices.size(); ++i)
    fmt::print("device {}: {} '{}'\n", i, devices[i]->event_node(), devices[i]->spec().name);
  std::fflush(stdout);

  timespec start{};
  ::clock_gettime(CLOCK_MONOTONIC, &start);
  start = add_ns(start, static_cast<std::int64_t>(args.settle * 1e9));
  std::size_t frames = 0;
  std::vector<input_event> buf;
  try {
    while (auto f = reader->next()) {
      if (!sleep_until(add_ns(start, static_cast<std::int64_t>(static_cast<double>(f->t_us) * 1000.0 / args.speed))))
        break;
      buf.clear();
      for (const auto& e : f->events) {
        input_event ev{};
        ev.type = e.type;
        ev.code = e.code;
        ev.value = e.value;
        buf.push_back(ev);
      }
      input_event ts{};
      ts.type = EV_MSC;
      ts.code = MSC_TIMESTAMP;
      ts.value = static_cast<std::int32_t>(static_cast<std::uint32_t>(f->t_us));  // wraps like hardware's
      buf.push_back(ts);
      input_event syn{};
      syn.type = EV_SYN;
      syn.code = SYN_REPORT;
      buf.push_back(syn);
      devices[f->device]->emit_all(buf);
      ++frames;
    }
  } catch (const input::RecordingError& e) {
    cli::error(fmt::format("replay: {}", e.what()));
    throw CommandFailed{kExitUsage};
  }
  if (!stop_requested()) {
    timespec now{};
    ::clock_gettime(CLOCK_MONOTONIC, &now);
    sleep_until(add_ns(now, static_cast<std::int64_t>(args.hold * 1e9)));
  }
  std::size_t uploads = 0;
  for (const auto& d : devices) uploads += d->uploads_answered();
  if (!args.quiet)
    fmt::print("replayed {} frames on {} device(s){}; answered {} FF uploads\n", frames, devices.size(),
               stop_requested() ? " (stopped by a signal)" : "", uploads);
}

}  // namespace sculpt::ctl

