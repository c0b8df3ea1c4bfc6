// What the configuration says about the store: whether there is one, where,
// and the keeper's settings (keeper/keeper.hpp). A replay is saved only into
// a directory given explicitly (--state-dir, [store] dir), so that running
// a recorded session never resumes, or replaces, the sculpt a person saved.
#pragma once

#include <filesystem>

#include "main/config.hpp"
#include "keeper/keeper.hpp"
#include "host/sim_host.hpp"

namespace sculpt::daemon {

bool store_wanted(const DaemonConfig& config);
// [store] dir, else $STATE_DIRECTORY (its first entry), $XDG_STATE_HOME/sculptd,
// ~/.local/state/sculptd. Throws ConfigError when none can be found.
std::filesystem::path state_dir(const StoreConfig& store);
KeeperSettings keeper_settings(const DaemonConfig& config);
// The sim thread's settings; none of them changes at a reload.
SimHostSettings sim_host_settings(const DaemonConfig& config);

}  // namespace sculpt::daemon
