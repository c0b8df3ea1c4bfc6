// `sculptctl haptics SLOT [--gain G] [--limit L] [--json]`: a device's
// force-feedback gain and hard limit (each 0..1 of full) on a running
// sculptd, until it restarts or reloads its config. Without a value it
// prints the slot's tuning. The daemon checks the values and the slot; its
// refusal is printed and exits 1.
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "daemon_link.hpp"

namespace sculpt::ctl {
namespace {
constexpr std::uint16_t kHapticsMinor = 6;  // Session.tuneHaptics, Device.bus, gain, limit
}  // namespace

void haptics(const HapticsArgs& args) {
  with_daemon(args.daemon, [&](client::Connection& c, kj::WaitScope& ws) {
    require_minor(c, kHapticsMinor, "haptics");
    auto req = c.session().tuneHapticsRequest();
    req.setSlot(args.slot);
    req.setSetGain(args.gain.has_value());
    req.setGain(static_cast<float>(args.gain.value_or(0)));
    req.setSetLimit(args.limit.has_value());
    req.setLimit(static_cast<float>(args.limit.value_or(0)));
    auto reply = req.send().wait(ws);
    const auto r = reply.getResult();
    if (args.daemon.json)
      std::cout << nlohmann::json{{"command", "haptics"}, {"slot", args.slot},      {"ok", r.getOk()},
                                  {"error", r.getError().cStr()}, {"gain", reply.getGain()}, {"limit", reply.getLimit()}}
                       .dump()
                << "\n";
    if (!r.getOk()) {
      if (args.daemon.json) throw CommandFailed{kExitCommandFailed};
      fail(kExitCommandFailed, fmt::format("haptics: {}", r.getError().cStr()));
    }
    if (!args.daemon.json)
      fmt::print("slot {}: gain {:.3g}, limit {:.3g}\n", args.slot, reply.getGain(), reply.getLimit());
  });
}

}  // namespace sculpt::ctl
