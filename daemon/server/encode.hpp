// Cap'n Proto encoding of what the server sends: keyframes, tools, stats,
// devices. Pure functions of their inputs (unit tests build and read them
// without a socket).
#pragma once

#include <span>

#include "sculpt.capnp.h"
#include "server/daemon_control.hpp"
#include "server/published_state.hpp"

namespace sculpt::server {

// Every mesh (topology, rest and current positions, material, bounds), every
// tool, the scene's bounds. sequence = the reader's header tick.
void fill_keyframe(proto::Keyframe::Builder out, const SceneInfo& scene, const PublishedReader& reader);
void fill_tools(capnp::List<proto::Tool>::Builder out, const SceneInfo& scene, const PublishedHeader& header);
void fill_stats(proto::Stats::Builder out, const DaemonStatus& status);
void fill_devices(capnp::List<proto::Device>::Builder out, std::span<const DeviceEntry> devices);
void set_bounds(proto::Aabb::Builder out, const std::array<float, 6>& lo_hi);
// A page of the history (at most its newest `max_entries`, oldest first),
// its budget, and how many older and newer strokes were left out
// (History.omitted, newer).
void fill_history(proto::History::Builder out, const History& history, std::size_t max_entries);

// Reads a proto::Stats back into a stats reading (sculptctl status --json).
simloop::StatsReading stats_from(proto::Stats::Reader stats);

}  // namespace sculpt::server
