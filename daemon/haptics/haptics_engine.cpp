#include "haptics/haptics_engine.hpp"

#include <cmath>
#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>
#include <utility>

namespace sculpt::haptics {

namespace {
constexpr int kWarning = 4;  // syslog / sd-daemon priorities
constexpr int kInfo = 6;

// An ENODEV that no unplug follows is not an unplug: a transport may blip.
// The input layer sends a detach within milliseconds of a real unplug, so a
// device still attached after this long is reopened (a few times, backing off).
constexpr auto kReopenAfter = std::chrono::milliseconds(250);
constexpr int kMaxReopens = 5;
// uinput answers ENODEV to an upload between a new device's node appearing
// and the device being marked created: for this long after the open such an
// answer means "not ready yet", retried at every poll.
constexpr auto kReadyWithin = std::chrono::seconds(1);
// CLOCK_BOOTTIME ahead of CLOCK_MONOTONIC by more than this since the last
// poll: the machine slept.
constexpr auto kSuspendJump = std::chrono::seconds(1);

double norm(const std::array<double, 3>& f) {
  const double n = std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
  return std::isfinite(n) ? n : 0.0;
}

bool valid_slot(int slot) { return slot >= 0 && slot < HapticsStats::kSlots; }
}  // namespace

bool DeviceMatch::matches(const DeviceIdentity& id) const {
  if (vendor && *vendor != id.vendor) return false;
  if (product && *product != id.product) return false;
  if (!name.empty() && id.name.find(name) == std::string::npos) return false;
  return true;
}

HapticsEngine::HapticsEngine(const FeedbackBoard& board, HapticsSettings settings, PortOpener opener,
                             HapticsStats& stats, LogSink log, TimeSource& time)
    : board_(board),
      settings_(std::move(settings)),
      opener_(std::move(opener)),
      stats_(stats),
      log_(std::move(log)),
      time_(time) {
  for (int s = 0; s < HapticsStats::kSlots; ++s) publish_tuning(s);
}

void HapticsEngine::say(int priority, const std::string& message) const {
  if (log_) {
    log_(priority, message);
    return;
  }
  // No sd-daemon prefix: on a terminal or in a file "<4>" is noise, and
  // only the one who knows where stderr goes can say it is the journal.
  std::fprintf(stderr, "haptics: %s%s\n", priority <= kWarning ? "warning: " : "", message.c_str());
}

HapticsEngine::~HapticsEngine() { shutdown(); }

PlayerTiming HapticsEngine::timing_for() const {
  return PlayerTiming{settings_.effect_length, settings_.rearm_every, settings_.change};
}

std::shared_ptr<WritePacer> HapticsEngine::slot_pacer(int slot, const std::string& node,
                                                      std::chrono::nanoseconds interval) {
  SlotPacer& p = pacers_[slot];
  if (!p.pacer || p.node != node) p = SlotPacer{node, std::make_shared<WritePacer>(interval)};
  return p.pacer;
}

DeviceTuning HapticsEngine::config_tuning(const Attached* d) const {
  if (d && d->ff)
    for (const auto& o : settings_.devices)
      if (o.match.matches(d->ff->identity())) return o.tuning;
  return settings_.tuning;
}

DeviceTuning HapticsEngine::tuning(int slot) const {
  if (auto t = tunes_.find(slot); t != tunes_.end()) return t->second;
  auto it = devices_.find(slot);
  return config_tuning(it == devices_.end() ? nullptr : &it->second);
}

void HapticsEngine::publish_tuning(int slot) {
  if (!valid_slot(slot)) return;
  const DeviceTuning t = tuning(slot);
  stats_.slot_gain[static_cast<std::size_t>(slot)].store(t.gain, std::memory_order_relaxed);
  stats_.slot_limit[static_cast<std::size_t>(slot)].store(t.limit, std::memory_order_relaxed);
}

void HapticsEngine::tune(int slot, DeviceTuning t) {
  check_tuning(t);
  if (!valid_slot(slot))
    throw std::invalid_argument("slot " + std::to_string(slot) + " is not within [0, " +
                                std::to_string(HapticsStats::kSlots - 1) + "]");
  tunes_[slot] = t;
  publish_tuning(slot);
}

void HapticsEngine::open_ff(Attached& d) {
  d.ff.reset();
  d.opened_at.reset();
  d.first_settled = false;
  d.uploads_counted = 0;
  d.player.restart();
  if (!settings_.enabled || d.node.empty()) return;
  FfDeviceOptions options;
  options.gain = settings_.gain;
  options.constant = settings_.constant;
  options.rumble = true;  // the force itself on rumble-only pads; kicks follow rumble_on_onset
  options.gain_at_open = false;  // the player writes it, paced like every other write
  try {
    auto pacer = slot_pacer(d.slot, d.node, settings_.pacing.other);
    auto ff = std::make_unique<FfDevice>(opener_(d.node), options, &stats_.ff, pacer, time_);
    const auto interval = interval_for_bus(ff->identity().bustype, settings_.pacing);
    pacer->set_interval(interval);
    if (valid_slot(d.slot))
      stats_.slot_bustype[static_cast<std::size_t>(d.slot)].store(ff->identity().bustype, std::memory_order_relaxed);
    if (ff->mode() == FfMode::none) {
      say(kInfo, d.node + ": no usable force feedback, input only");
      return;  // no fd kept open for nothing
    }
    ff->wait_for_ready(true);
    const int effects = ff->caps().effects_max;
    say(kInfo, d.node + ": " + (ff->mode() == FfMode::constant ? "constant force" : "rumble force") +
                   (ff->mode() == FfMode::constant && ff->rumble_allowed() ? " + rumble kicks" : "") + ", " +
                   std::to_string(effects) + (effects == 1 ? " effect slot" : " effect slots") + ", bus 0x" +
                   [&] {
                     char hex[8];
                     std::snprintf(hex, sizeof hex, "%02x", ff->identity().bustype);
                     return std::string(hex);
                   }() +
                   " paced " + std::to_string(interval.count()) + " ms");
    d.ff = std::move(ff);
    d.player.set_timing(timing_for());
    d.player.gain(settings_.gain);
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
  Attached d{slot, node, std::move(tools), nullptr, DevicePlayer(PlayerTiming{}), {}, false, std::nullopt, 0, 0,
             std::nullopt, false};
  d.onsets_seen.assign(d.tools.size(), 0);
  open_ff(d);
  devices_.emplace(slot, std::move(d));
  stats_.devices.fetch_add(1, std::memory_order_relaxed);
  publish_tuning(slot);
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
  pacers_.erase(slot);  // a device plugged in next is another one
  auto it = devices_.find(slot);
  if (it == devices_.end()) return;
  if (it->second.ff) {
    it->second.ff->forget();  // unplugged: the kernel dropped the effects with the device
    stats_.ff_devices.fetch_sub(1, std::memory_order_relaxed);
  }
  devices_.erase(it);
  stats_.devices.fetch_sub(1, std::memory_order_relaxed);
  if (valid_slot(slot)) stats_.slot_bustype[static_cast<std::size_t>(slot)].store(0, std::memory_order_relaxed);
  publish_tuning(slot);
}

void HapticsEngine::configure(const HapticsSettings& settings) {
  const bool reopen_all = settings.enabled != settings_.enabled || settings.constant != settings_.constant;
  settings_ = settings;
  tunes_.clear();  // the re-read config rules again
  for (auto& [slot, d] : devices_) {
    if (reopen_all) {
      if (d.ff) {
        d.ff->shutdown();
        stats_.ff_devices.fetch_sub(1, std::memory_order_relaxed);
      }
      open_ff(d);
    } else if (d.ff) {
      d.player.set_timing(timing_for());
      if (auto p = pacers_.find(slot); p != pacers_.end())
        p->second.pacer->set_interval(interval_for_bus(d.ff->identity().bustype, settings_.pacing));
      d.player.gain(settings_.gain);
    }
  }
  for (int s = 0; s < HapticsStats::kSlots; ++s) publish_tuning(s);
  configure_triggers();
}

bool HapticsEngine::silent(Clock::time_point now) {
  const Hold hold = board_.hold();
  const std::uint64_t beats = board_.beats();
  if (hold != Hold::none || hold != last_hold_) {
    // Held: no ticks are expected. The beat is watched afresh from the release.
    last_hold_ = hold;
    last_beats_ = beats;
    last_beat_at_ = now;
    stalled_ = false;
    return hold != Hold::none;
  }
  if (beats != last_beats_) {
    if (stalled_) say(kInfo, "the sim thread beats again: force feedback resumes");
    beats_moved_ = true;
    stalled_ = false;
    last_beats_ = beats;
    last_beat_at_ = now;
    return false;
  }
  // A thread that has not ticked yet has published nothing to feel.
  if (!beats_moved_ || stalled_ || now - last_beat_at_ < settings_.stall_after) return stalled_;
  stalled_ = true;
  stats_.stalls.fetch_add(1, std::memory_order_relaxed);
  say(kWarning, "the sim thread stalled (no tick for " +
                    std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(now - last_beat_at_).count()) +
                    " ms): force feedback zeroed until it ticks again");
  return true;
}

void HapticsEngine::watch_suspend(Clock::time_point now, std::optional<std::chrono::nanoseconds> boottime) {
  if (!boottime) return;
  const auto offset = *boottime - std::chrono::duration_cast<std::chrono::nanoseconds>(now.time_since_epoch());
  const auto previous = boot_offset_;
  const bool jumped = previous && offset - *previous > kSuspendJump;
  boot_offset_ = offset;
  if (jumped)
    resumed_at(now, "CLOCK_BOOTTIME jumped " +
                        std::to_string(std::chrono::duration_cast<std::chrono::seconds>(offset - *previous).count()) +
                        " s ahead of CLOCK_MONOTONIC");
}

void HapticsEngine::resumed(const std::string& how) { resumed_at(time_.now(), how); }

void HapticsEngine::resumed_at(Clock::time_point now, const std::string& how) {
  constexpr auto kSameResume = std::chrono::seconds(5);
  if (last_resume_ && now - *last_resume_ < kSameResume) return;
  last_resume_ = now;
  // Drivers may have lost their state over a suspend (a pad reconnected,
  // firmware reset): reopen every device, which uploads a fresh neutral state.
  stats_.resumes.fetch_add(1, std::memory_order_relaxed);
  say(kInfo, "resumed from suspend (" + how + "): reopening the force-feedback devices");
  for (auto& [slot, d] : devices_)
    if (d.ff) reopen(d);
}

void HapticsEngine::reopen(Attached& d) {
  // Erased here, paced, rather than by the kernel as the old fd closes: that
  // flush stops and erases each effect too, but behind the pacer's back.
  // (A device gone with ENODEV only forgets its ids.)
  d.ff->shutdown();
  stats_.ff_devices.fetch_sub(1, std::memory_order_relaxed);
  open_ff(d);
  d.gone_since.reset();
}

void HapticsEngine::poll(std::optional<std::chrono::nanoseconds> boottime) {
  const Clock::time_point now = time_.now();
  watch_suspend(now, boottime);
  const bool quiet = silent(now);
  poll_triggers(true, quiet);
  for (auto& [slot, d] : devices_) {
    if (!d.ff) continue;
    // Each device's own now: the writes to the ones before it took time.
    const Clock::time_point at = time_.now();
    if (d.ff->gone()) reopen_if_still_plugged(d, at);
    if (d.ff && !d.ff->gone()) poll_device(d, at, quiet);
    count_uploads(slot, d);
  }
  poll_triggers(false, quiet);
}

std::optional<Clock::time_point> HapticsEngine::next_due() const {
  std::optional<Clock::time_point> due;
  const Clock::time_point now = time_.now();
  for (const auto& [slot, d] : devices_) {
    if (!d.ff || !d.player.zero_waiting(*d.ff)) continue;
    const Clock::time_point at = d.ff->pacer().next_at(now);
    if (!due || at < *due) due = at;
  }
  return due;
}

void HapticsEngine::count_uploads(int slot, Attached& d) {
  if (!d.ff || !valid_slot(slot)) return;
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
  reopen(d);
}

void HapticsEngine::poll_device(Attached& d, Clock::time_point now, bool quiet) {
  StickForce stick;
  double magnitude = 0;
  bool touching = false;
  bool onset = false;
  double impulse = 0;
  for (std::size_t i = 0; i < d.tools.size(); ++i) {
    const ToolForce f = board_.read(d.tools[i].tool);
    const StickForce s = project_to_stick(f.force, d.tools[i].plane);
    stick.x += s.x;
    stick.y += s.y;
    magnitude += norm(f.force);
    touching = touching || f.touching;
    if (d.primed && f.onsets != d.onsets_seen[i]) {
      onset = true;
      impulse = std::max(impulse, f.last_onset_impulse);
    }
    d.onsets_seen[i] = f.onsets;
  }
  d.primed = true;

  if (quiet) {
    d.player.silence();
  } else {
    // Constant force follows the force in the stick's plane (it has a
    // direction); rumble has none, so it follows all of the device's
    // tools' force.
    const DeviceTuning t = tuning(d.slot);
    const double constant_level = tuned(level_from_force(std::hypot(stick.x, stick.y), touching, settings_.force), t);
    const double rumble_level = tuned(level_from_force(magnitude, touching, settings_.force), t);
    d.player.want(constant_from_level(stick, constant_level), rumble_from_level(rumble_level, settings_.rumble));
    if (onset && settings_.rumble_on_onset) d.player.kick(rumble_from_impulse(impulse, settings_.rumble, t));
  }
  if (!d.opened_at) d.opened_at = now;
  const std::uint64_t kicks_before = d.player.kicks();
  const bool attempted = d.player.step(*d.ff, now);
  if (d.player.kicks() != kicks_before) stats_.ff.kicks.fetch_add(1, std::memory_order_relaxed);
  watch_first_write(d, now, attempted);
}

void HapticsEngine::watch_first_write(Attached& d, Clock::time_point now, bool attempted) {
  if (d.first_settled || !attempted || d.player.last_write_was_gain()) return;
  FfDevice& ff = *d.ff;
  if (ff.ready_seen()) {
    d.first_settled = true;
    ff.wait_for_ready(false);  // from now on ENODEV is an unplug
    stats_.first_uploads.fetch_add(1, std::memory_order_relaxed);
    if (valid_slot(d.slot))
      stats_.slot_first_upload_ns[static_cast<std::size_t>(d.slot)].store(
          std::chrono::duration_cast<std::chrono::nanoseconds>(now - *d.opened_at).count(), std::memory_order_relaxed);
    return;
  }
  if (ff.not_ready()) {
    stats_.not_ready_retries.fetch_add(1, std::memory_order_relaxed);
    if (now - *d.opened_at >= kReadyWithin) ff.wait_for_ready(false);  // the next ENODEV is an unplug
    return;
  }
  d.first_settled = true;
  stats_.first_upload_failures.fetch_add(1, std::memory_order_relaxed);
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

const DevicePlayer* HapticsEngine::player(int slot) const {
  auto it = devices_.find(slot);
  return it == devices_.end() ? nullptr : &it->second.player;
}

}  // namespace sculpt::haptics
