#include "haptics/haptics_engine.hpp"

#include <cstdio>
#include <exception>
#include <string>
#include <utility>

namespace sculpt::haptics {

namespace {
constexpr int kWarning = 4;  // syslog / sd-daemon priorities
constexpr int kInfo = 6;

// An ENODEV that no unplug follows is not an unplug: uinput answers ENODEV
// to an upload in the moment between a new device's node appearing and the
// device being marked created, and a transport may blip. The input layer
// sends a detach within milliseconds of a real unplug, so a device still
// attached after this long is reopened (a few times, backing off).
constexpr auto kReopenAfter = std::chrono::milliseconds(250);
constexpr int kMaxReopens = 5;
}  // namespace

HapticsEngine::HapticsEngine(const FeedbackBoard& board, HapticsSettings settings, PortOpener opener,
                             HapticsStats& stats, LogSink log)
    : board_(board), settings_(std::move(settings)), opener_(std::move(opener)), stats_(stats), log_(std::move(log)) {}

void HapticsEngine::say(int priority, const std::string& message) const {
  if (log_) {
    log_(priority, message);
    return;
  }
  std::fprintf(stderr, "<%d>haptics: %s\n", priority, message.c_str());
}

HapticsEngine::~HapticsEngine() { shutdown(); }

void HapticsEngine::open_ff(Attached& d) {
  d.ff.reset();
  if (!settings_.enabled || d.node.empty()) return;
  FfDeviceOptions options;
  options.gain = settings_.gain;
  options.constant = settings_.constant;
  options.rumble = settings_.rumble_on_onset;
  try {
    auto ff = std::make_unique<FfDevice>(opener_(d.node), options, &stats_.ff);
    if (ff->mode() == FfMode::none) {
      say(kInfo, d.node + ": no usable force feedback, input only");
      return;  // no fd kept open for nothing
    }
    const int effects = ff->caps().effects_max;
    say(kInfo, d.node + ": " + (ff->mode() == FfMode::constant ? "constant force" : "rumble only") +
                   (ff->mode() == FfMode::constant && ff->rumble_allowed() ? " + rumble kicks" : "") + ", " +
                   std::to_string(effects) + (effects == 1 ? " effect slot" : " effect slots"));
    d.ff = std::move(ff);
    stats_.ff_devices.fetch_add(1, std::memory_order_relaxed);
  } catch (const std::exception& e) {
    // A device we cannot open for FF still works as input: say so, go on.
    stats_.open_failures.fetch_add(1, std::memory_order_relaxed);
    last_error_ = e.what();
    say(kWarning, "no force feedback on " + d.node + ": " + e.what());
  }
}

void HapticsEngine::attach(int slot, const std::string& node, std::vector<ToolStick> tools, TriggerBinding triggers) {
  if (devices_.count(slot)) detach_alive(slot);
  const auto interval = std::chrono::duration_cast<std::chrono::nanoseconds>(settings_.min_upload_interval);
  Attached d{node, std::move(tools), nullptr, ConstantPacer(interval, settings_.change), KickPacer(interval), {}, false,
             std::nullopt, 0, 0};
  d.onsets_seen.assign(d.tools.size(), 0);
  open_ff(d);
  devices_.emplace(slot, std::move(d));
  stats_.devices.fetch_add(1, std::memory_order_relaxed);
  attach_triggers(slot, node, triggers);
}

void HapticsEngine::detach_alive(int slot) {
  // Replaced while still plugged in (no detach came): stop and erase properly.
  detach_triggers(slot, false);
  auto it = devices_.find(slot);
  if (it == devices_.end()) return;
  if (it->second.ff) {
    it->second.ff->shutdown();
    stats_.ff_devices.fetch_sub(1, std::memory_order_relaxed);
  }
  devices_.erase(it);
  stats_.devices.fetch_sub(1, std::memory_order_relaxed);
}

void HapticsEngine::detach(int slot) {
  detach_triggers(slot, true);
  auto it = devices_.find(slot);
  if (it == devices_.end()) return;
  if (it->second.ff) {
    it->second.ff->forget();  // unplugged: the kernel dropped the effects with the device
    stats_.ff_devices.fetch_sub(1, std::memory_order_relaxed);
  }
  devices_.erase(it);
  stats_.devices.fetch_sub(1, std::memory_order_relaxed);
}

void HapticsEngine::configure(const HapticsSettings& settings) {
  const bool reopen = settings.enabled != settings_.enabled || settings.constant != settings_.constant ||
                      settings.rumble_on_onset != settings_.rumble_on_onset;
  settings_ = settings;
  const auto interval = std::chrono::duration_cast<std::chrono::nanoseconds>(settings_.min_upload_interval);
  for (auto& [slot, d] : devices_) {
    d.constant.set_interval(interval);
    d.constant.set_threshold(settings_.change);
    d.kick.set_interval(interval);
    if (reopen) {
      if (d.ff) {
        d.ff->shutdown();
        stats_.ff_devices.fetch_sub(1, std::memory_order_relaxed);
      }
      open_ff(d);
      d.uploads_counted = 0;
      d.constant.reset();
    } else if (d.ff) {
      d.ff->set_gain(settings_.gain);
    }
  }
  configure_triggers();
}

void HapticsEngine::poll(Clock::time_point now) {
  for (auto& [slot, d] : devices_) {
    if (!d.ff) continue;
    if (d.ff->gone()) reopen_if_still_plugged(d, now);
    if (d.ff && !d.ff->gone()) poll_device(d, now);
    count_uploads(slot, d);
  }
  poll_triggers(now);
}

void HapticsEngine::count_uploads(int slot, Attached& d) {
  if (!d.ff || slot < 0 || slot >= HapticsStats::kSlots) return;
  const std::uint64_t n = d.ff->uploads();
  if (n == d.uploads_counted) return;
  stats_.slot_uploads[static_cast<std::size_t>(slot)].fetch_add(n - d.uploads_counted, std::memory_order_relaxed);
  d.uploads_counted = n;
}

void HapticsEngine::reopen_if_still_plugged(Attached& d, Clock::time_point now) {
  if (!d.gone_since) {
    d.gone_since = now;
    return;
  }
  if (d.reopens >= kMaxReopens || now - *d.gone_since < kReopenAfter * (1 << d.reopens)) return;
  ++d.reopens;
  say(kInfo, d.node + ": the device answered ENODEV but is still plugged in: reopening it (attempt " +
                 std::to_string(d.reopens) + ")");
  stats_.ff_devices.fetch_sub(1, std::memory_order_relaxed);
  open_ff(d);  // the old FfDevice forgets its ids: the kernel dropped them with the fd
  d.uploads_counted = 0;
  d.constant.reset();
  d.gone_since.reset();
}

void HapticsEngine::poll_device(Attached& d, Clock::time_point now) {
  StickForce total;
  for (std::size_t i = 0; i < d.tools.size(); ++i) {
    const ToolForce f = board_.read(d.tools[i].tool);
    const StickForce s = project_to_stick(f.force, d.tools[i].plane);
    total.x += s.x;
    total.y += s.y;
    if (d.primed && f.onsets != d.onsets_seen[i]) d.kick.onset(f.last_onset_impulse);
    d.onsets_seen[i] = f.onsets;
  }
  d.primed = true;

  FfDevice& ff = *d.ff;
  if (ff.mode() == FfMode::constant) {
    const ConstantCommand want = constant_from_force(total, settings_.force);
    if (d.constant.should_send(want, now)) {
      if (ff.set_constant(want))
        d.constant.sent(want, now);
      else
        d.constant.failed(now);
    }
  }
  if (d.kick.due(now)) {
    if (ff.rumble_allowed()) ff.kick(rumble_from_impulse(d.kick.pending_impulse(), settings_.rumble));
    d.kick.kicked(now);
  }
}

void HapticsEngine::shutdown() {
  shutdown_triggers();
  for (auto& [slot, d] : devices_) {
    if (d.ff) {
      d.ff->shutdown();
      stats_.ff_devices.fetch_sub(1, std::memory_order_relaxed);
    }
  }
  stats_.devices.fetch_sub(static_cast<int>(devices_.size()), std::memory_order_relaxed);
  devices_.clear();
}

const FfDevice* HapticsEngine::device(int slot) const {
  auto it = devices_.find(slot);
  return it == devices_.end() ? nullptr : it->second.ff.get();
}

}  // namespace sculpt::haptics
