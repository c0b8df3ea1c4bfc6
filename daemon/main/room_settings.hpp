// What the rooms read of the daemon's configuration: whether there is a
// keeper, where its store is, and its settings (keeper/keeper.hpp); the sim
// thread's settings (host/sim_host.hpp). A replay is saved only into a
// directory given explicitly (--state-dir, [keeper] dir), so that replaying
// a recording never resumes, or replaces, the sculpt a person saved.
#pragma once

#include <filesystem>

#include "main/config.hpp"
#include "keeper/keeper.hpp"
#include "host/sim_host.hpp"

namespace sculpt::daemon {

bool store_wanted(const DaemonConfig& config);
// [keeper] dir, else $STATE_DIRECTORY (its first entry), $XDG_STATE_HOME/sculptd,
// ~/.local/state/sculptd. Throws ConfigError when none can be found.
std::filesystem::path state_dir(const KeeperConfig& store);
KeeperSettings keeper_settings(const DaemonConfig& config);
// The sim thread's settings; none of them changes at a reload.
SimHostSettings sim_host_settings(const DaemonConfig& config);

}  // namespace sculpt::daemon
