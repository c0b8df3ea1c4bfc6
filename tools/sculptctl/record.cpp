// `sculptctl record FILE [--duration S]`: captures the joysticks and gamepads
// present (and any plugged in meanwhile) into a recording
// (docs/recording-format.md) until the duration ends or SIGINT/SIGTERM.
#include <poll.h>
#include <signal.h>
#include <syslog.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <map>

#include <fmt/format.h>

#include "cli/conventions.hpp"
#include "commands.hpp"
#include "stop_signal.hpp"
#include "input/device_manager.hpp"
#include "input/evdev_device.hpp"
#include "input/recording.hpp"

namespace sculpt::ctl {
namespace {



// Collects frames in memory: the header (written first) lists every device
// seen, and a device can appear mid-recording.
class Recorder : public input::DeviceListener {
 public:
  explicit Recorder(bool verbose) : verbose_(verbose) {}

  void on_attach(std::uint8_t slot, const input::DeviceInfo& info) override {
    if (!index_.count(slot)) {
      index_[slot] = static_cast<std::uint32_t>(devices_.size());
      devices_.push_back(info);
      devices_.back().node.clear();
    }
    cli::note(fmt::format("record: device {}: {}", index_[slot], input::describe(info)));
  }
  void on_detach(std::uint8_t slot) override {
    cli::note(fmt::format("record: device {} unplugged", index_.count(slot) ? index_[slot] : 0u));
  }
  void on_frame(const input::InputFrame& f) override {
    if (!started_ || !index_.count(f.slot)) return;
    input::RecordingFrame s;
    s.t_us = std::max<std::int64_t>(0, f.kernel_time_us - t0_us_);
    s.device = index_[f.slot];
    s.events.assign(f.events.begin(), f.events.begin() + f.count);
    frames_.push_back(std::move(s));
  }
  void on_log(int priority, const std::string& message) override {
    if (priority <= LOG_ERR) cli::error("record: " + message);
    else if (priority <= LOG_WARNING) cli::warning("record: " + message);
    else if (verbose_) cli::note("record: " + message);
  }

  void start_clock() {
    started_ = true;
    t0_us_ = input::monotonic_us();
  }
  const std::vector<input::DeviceInfo>& devices() const { return devices_; }
  const std::vector<input::RecordingFrame>& frames() const { return frames_; }

 private:
  bool verbose_;
  bool started_ = false;
  std::int64_t t0_us_ = 0;
  std::map<std::uint8_t, std::uint32_t> index_;
  std::vector<input::DeviceInfo> devices_;
  std::vector<input::RecordingFrame> frames_;
};

void poll_once(input::DeviceManager& manager, int timeout_ms) {
  std::vector<pollfd> fds;
  for (int fd : manager.fds()) fds.push_back({fd, POLLIN, 0});
  const int n = ::poll(fds.data(), fds.size(), timeout_ms);
  if (n <= 0) return;
  for (const auto& p : fds)
    if (p.revents) manager.dispatch(p.fd);
}

}  // namespace

void record(const RecordArgs& args) {
  catch_stop_signals();

  Recorder recorder(args.verbose);
  input::DeviceManagerOptions opts;
  opts.accept_all = args.all;
  opts.discovery = args.discovery == "udev"      ? input::Discovery::udev
                   : args.discovery == "inotify" ? input::Discovery::inotify
                                                 : input::Discovery::automatic;
  input::DeviceManager manager(recorder, opts);
  try {
    manager.start();
  } catch (const std::exception& e) {
    cli::error(fmt::format("record: cannot watch input devices: {}", e.what()));
    throw CommandFailed{kExitCommandFailed};
  }
  using Clock = std::chrono::steady_clock;
  const auto wait_end = Clock::now() + std::chrono::duration<double>(args.wait_for ? args.wait_timeout : 0);
  while (!stop_requested() && manager.attached() < args.wait_for && Clock::now() < wait_end) poll_once(manager, 20);
  if (manager.attached() < std::max<std::size_t>(args.wait_for, 1)) {
    cli::error(fmt::format("record: {} joystick(s) found{}; nothing to record{}", manager.attached(),
               args.wait_for ? fmt::format(" within {} s, {} wanted", args.wait_timeout, args.wait_for) : "",
               args.all ? "" : " (--all records any input device)"));
    throw CommandFailed{kExitCommandFailed};
  }
  recorder.start_clock();
  // Say so on stdout: a script driving the devices waits for this line.
  fmt::print("recording {} device(s) to {}\n", manager.attached(), args.file);
  std::fflush(stdout);
  const auto end = Clock::now() + std::chrono::duration<double>(args.duration);
  while (!stop_requested() && (args.duration <= 0 || Clock::now() < end)) poll_once(manager, 10);
  // What is already queued belongs to the recording too.
  for (int fd : manager.fds()) manager.dispatch(fd);

  input::Recording recording;
  recording.header.devices = recorder.devices();
  recording.header.description = fmt::format("recorded by sculptctl record");
  recording.frames = recorder.frames();
  try {
    input::write_recording(args.file, recording);
  } catch (const input::RecordingError& e) {
    cli::error(fmt::format("record: {}", e.what()));
    throw CommandFailed{kExitCommandFailed};
  }
  fmt::print("recorded {} frames from {} device(s), {:.2f} s\n", recording.frames.size(), recording.header.devices.size(),
             recording.frames.empty() ? 0.0 : recording.frames.back().t_us / 1e6);
}

}  // namespace sculpt::ctl
