// `sculptctl status [--json]` and `sculptctl devices [--json]`: what a running
// sculptd says about itself. status --json prints exactly the keys of
// `sculptd --stats-json` (simloop/stats_json.hpp builds both).
#include <cstdio>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "daemon_link.hpp"
#include "simloop/stats_json.hpp"
#include "server/encode.hpp"

namespace sculpt::ctl {
namespace {

std::string quantiles(const simloop::Percentiles& p) {
  return fmt::format("p50 {:.1f}  p99 {:.1f}  max {:.1f} us", p.p50, p.p99, p.max);
}

void print_status(proto::Stats::Reader st, const std::string& server, const std::string& socket) {
  const simloop::StatsReading s = server::stats_from(st);
  fmt::print("{} on {}: {}\n", server, socket, st.getPaused() ? "paused" : "running");
  fmt::print("  scene       {}\n", st.getScene().cStr());
  fmt::print("  uptime      {:.1f} s, simulated {:.3f} s\n", st.getUptimeS(), static_cast<double>(st.getSimTimeNs()) * 1e-9);
  fmt::print("  rate        {:g} Hz, {} ticks, {} overruns\n", s.rate_hz, s.ticks, s.overruns);
  if (s.overruns != 0)
    fmt::print("  overruns by late wake {}, long step {} ({} of them off the CPU)\n",
               s.overrun_causes[static_cast<std::size_t>(simloop::OverrunCause::late_wake)],
               s.overrun_causes[static_cast<std::size_t>(simloop::OverrunCause::long_step)], s.long_steps_off_cpu);
  fmt::print("  jitter      {}\n", quantiles(s.jitter_us));
  for (int i = 0; i < static_cast<int>(simloop::Stage::count); ++i)
    fmt::print("  {:<11} {}\n", simloop::stage_name(static_cast<simloop::Stage>(i)), quantiles(s.stage_us[static_cast<std::size_t>(i)]));
  fmt::print("  vertices    {} awake of {}\n", s.vertices_awake, s.vertices_total);
  fmt::print("  viewers     {}, {} bytes sent\n", s.viewers, s.bytes_sent);
  fmt::print("  devices     {}, {} FF uploads\n", s.devices, s.ff_uploads);
  fmt::print("  blowups     {}\n", s.blowups);
}

const char* ff_name(proto::FfSupport ff) {
  switch (ff) {
    case proto::FfSupport::CONSTANT: return "constant";
    case proto::FfSupport::RUMBLE: return "rumble";
    default: return "none";
  }
}

}  // namespace

void status(const DaemonArgs& args) {
  with_daemon(args, [&](client::Connection& c, kj::WaitScope& ws) {
    auto reply = c.session().statusRequest().send().wait(ws);
    const auto st = reply.getStats();
    if (args.json) std::cout << simloop::stats_json(server::stats_from(st)).dump(2) << "\n";
    else print_status(st, c.server(), c.socket_path());
  });
}

void devices(const DaemonArgs& args) {
  with_daemon(args, [&](client::Connection& c, kj::WaitScope& ws) {
    auto reply = c.session().devicesRequest().send().wait(ws);
    const auto list = reply.getDevices();
    if (args.json) {
      auto out = nlohmann::json::array();
      for (const auto d : list) {
        auto tools = nlohmann::json::array();
        for (const auto t : d.getTools()) tools.push_back(t);
        out.push_back({{"slot", d.getSlot()}, {"name", d.getName().cStr()}, {"node", d.getNode().cStr()},
                       {"vendor", fmt::format("{:04x}", d.getVendor())},
                       {"product", fmt::format("{:04x}", d.getProduct())}, {"kind", d.getKind().cStr()},
                       {"connected", d.getConnected()}, {"ff", ff_name(d.getFf())},
                       {"ff_uploads", d.getFfUploads()}, {"tools", tools}, {"bus", d.getBus().cStr()},
                       {"gain", d.getGain()}, {"limit", d.getLimit()}});
      }
      std::cout << out.dump(2) << "\n";
      return;
    }
    if (list.size() == 0) {
      fmt::print("no devices\n");
      return;
    }
    for (const auto d : list) {
      std::string tools;
      for (const auto t : d.getTools()) tools += (tools.empty() ? "" : ",") + std::to_string(t);
      fmt::print("slot {}  {:<12} {:04x}:{:04x} {:<9} {:<9} ff {:<8} gain {:.2f} limit {:.2f} {:>6} uploads  tools {}  {}\n",
                 d.getSlot(), d.getConnected() ? (d.getNode().size() ? d.getNode().cStr() : "(recorded)") : "(unplugged)",
                 d.getVendor(), d.getProduct(), d.getKind().cStr(), d.getBus().size() ? d.getBus().cStr() : "-",
                 ff_name(d.getFf()), d.getGain(), d.getLimit(), d.getFfUploads(), tools.empty() ? "-" : tools,
                 d.getName().cStr());
    }
  });
}

}  // namespace sculpt::ctl
