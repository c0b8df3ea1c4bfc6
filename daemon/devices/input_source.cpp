#include "devices/input_source.hpp"

#include "input/recording.hpp"
#include "input/replay_source.hpp"
#include "log/log.hpp"

namespace sculpt::daemon {
namespace {

constexpr std::size_t kReplayReadAhead = 4096;  // messages read from the recording before the io thread takes them

}  // namespace

InputSource::InputSource(const InputSpec& spec, InputClock clock, double rate_hz, DeviceHub& hub,
                         kj::UnixEventPort& port) {
  if (spec.kind == InputSpec::Kind::replay) {
    open_replay(spec, rate_hz, hub);
    return;
  }
  input::DeviceManagerOptions o;
  o.discovery = spec.kind == InputSpec::Kind::evdev ? input::Discovery::inotify : input::Discovery::automatic;
  devices_ = std::make_unique<input::DeviceManager>(hub, o);
  devices_->start();
  events_ = std::make_unique<DeviceEvents>(port, *devices_);
  log::info("input: live devices ({}), {} attached, clock {}", devices_->discovery(), devices_->attached(),
            clock == InputClock::device ? "device" : "arrival");
}

InputSource::~InputSource() = default;

void InputSource::open_replay(const InputSpec& spec, double rate_hz, DeviceHub& hub) {
  // Every line checked before the first tick (one at a time: bounded
  // memory), so a bad line deep in the file is named now, not mid-run.
  input::check_recording(spec.replay);
  input::ReplaySource source(spec.replay, rate_hz,
                             [&hub](std::uint8_t slot, const input::DeviceInfo& info) { return hub.bind(slot, info); });
  source.start(1);
  // The attaches are bound here; the frames are read on the feed's own
  // thread, the first ring's worth before the first tick.
  for (std::size_t d = 0; d < source.header().devices.size(); ++d) hub.push(*source.next(), "attach");
  replay_ = std::make_unique<input::ReplayFeed>(std::move(source), kReplayReadAhead);
  log::info("input: replaying {} ({} devices)", spec.replay.string(), replay_->header().devices.size());
}

std::optional<kj::Promise<void>> InputSource::run() {
  if (!events_) return std::nullopt;
  return events_->run();
}

void InputSource::pump(concurrency::SpscRing<input::InputMessage>& ring) {
  if (!replay_ || replay_failed_) return;
  replay_->pump(ring, input::kMaxDevices);  // room for a swap's re-attaches
  if (const auto error = replay_->error()) {
    replay_failed_ = true;
    log::err("replay ended early: {}; the sculpt goes on without its remaining frames", *error);
  }
}

std::uint64_t InputSource::count() const {
  if (replay_) return replay_->header().devices.size();
  return devices_ ? devices_->attached() : 0;
}

const std::vector<input::DeviceInfo>* InputSource::recorded() const {
  return replay_ ? &replay_->header().devices : nullptr;
}

void InputSource::close() {
  events_.reset();
  devices_.reset();
}

}  // namespace sculpt::daemon
