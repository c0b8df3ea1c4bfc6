// HapticsEngine's DualSense trigger slots: kept apart from the FF devices
// (one call each from attach, detach, configure, poll and shutdown) so the
// two evolve separately. The work is TriggerRenderer's.
#include <cerrno>
#include <exception>
#include <system_error>

#include "haptics/haptics_engine.hpp"

namespace sculpt::haptics {

namespace {
constexpr int kWarning = 4;
constexpr int kInfo = 6;
}  // namespace

void HapticsEngine::attach_triggers(int slot, const std::string& node, TriggerBinding binding) {
  detach_triggers(slot, false);
  if (node.empty() || !binding.any()) return;
  TriggerSlot& t = trigger_slots_[slot];
  t.slot = slot;
  t.node = node;
  t.binding = binding;
  open_triggers(t);
}

void HapticsEngine::open_triggers(TriggerSlot& t) {
  t.renderer.reset();
  if (!settings_.enabled || !settings_.triggers.enabled || !trigger_opener_) return;
  try {
    auto hidraw = trigger_opener_(t.node);
    if (!hidraw) return;  // not a DualSense: nothing to say
    const std::string hidraw_node = hidraw->port->node();
    const bool bt = hidraw->transport == dualsense::Transport::bluetooth;
    // The FF node's pacer when it has one (its interval is the bus's): one
    // firmware, one floor for the motors' writes and the triggers' together.
    auto pacer = slot_pacer(t.slot, t.node, dualsense::TriggerPacer::min_interval(hidraw->transport));
    t.renderer = std::make_unique<TriggerRenderer>(std::move(*hidraw), t.binding,
                                                   trigger_scale(settings_.triggers, settings_.force, tuning(t.slot)),
                                                   &stats_.triggers, settings_.stall_after, std::move(pacer), time_);
    say(kInfo, t.node + ": DualSense adaptive triggers through " + hidraw_node + (bt ? " (Bluetooth)" : " (USB)") +
                   ": left → tool " + (t.binding.left_tool >= 0 ? std::to_string(t.binding.left_tool) : "none") +
                   ", right → tool " + (t.binding.right_tool >= 0 ? std::to_string(t.binding.right_tool) : "none"));
  } catch (const std::system_error& e) {
    // Without the udev rule's uaccess the node is root's: rumble goes on, the
    // triggers stay as they are. Said once, not at every replug.
    const bool denied = e.code().value() == EACCES || e.code().value() == EPERM;
    if (denied && told_no_trigger_access_) return;
    if (denied) told_no_trigger_access_ = true;
    say(kWarning, "no adaptive triggers on " + t.node + ": " + e.what() +
                      (denied ? " (install sculptd's udev rule for the DualSense's hidraw node; rumble only)" : ""));
  } catch (const std::exception& e) {
    say(kWarning, "no adaptive triggers on " + t.node + ": " + e.what());
  }
}

void HapticsEngine::detach_triggers(int slot, bool unplugged) {
  auto it = trigger_slots_.find(slot);
  if (it == trigger_slots_.end()) return;
  if (it->second.renderer && unplugged) it->second.renderer->forget();  // no neutral to a pad that is gone
  trigger_slots_.erase(it);  // a renderer still there writes neutral as it goes
}

void HapticsEngine::configure_triggers() {
  for (auto& [slot, t] : trigger_slots_) {
    const bool want = settings_.enabled && settings_.triggers.enabled;
    if (want && t.renderer)
      t.renderer->set_scale(trigger_scale(settings_.triggers, settings_.force, tuning(slot)));
    else if (want != static_cast<bool>(t.renderer))
      open_triggers(t);  // turned on: open it; turned off: reset (neutral written)
  }
}

void HapticsEngine::poll_triggers(bool before_motors, bool quiet) {
  // Each renderer once per poll, before or after the FF devices. A DualSense's
  // triggers and motors share the pacer, so whichever goes first takes the
  // write when both want one: the triggers go first unless they wrote last
  // (neither starves the other), and never while quiet (the motors' zero first).
  for (auto& [slot, t] : trigger_slots_) {
    if (before_motors) t.polled = false;
    if (!t.renderer || t.polled) continue;
    if (before_motors && (quiet || t.renderer->wrote_last())) continue;
    t.polled = true;
    t.renderer->set_scale(trigger_scale(settings_.triggers, settings_.force, tuning(slot)));  // a run-time tune
    t.renderer->poll(board_, time_.now());
  }
}

void HapticsEngine::shutdown_triggers() {
  for (auto& [slot, t] : trigger_slots_)
    if (t.renderer) t.renderer->shutdown();
  trigger_slots_.clear();
}

const TriggerRenderer* HapticsEngine::triggers(int slot) const {
  auto it = trigger_slots_.find(slot);
  return it == trigger_slots_.end() ? nullptr : it->second.renderer.get();
}

}  // namespace sculpt::haptics
