// Where the keeper's store lives when the state directory fails, and what
// the log says of a recovery and of a run's saving: the keeper's policy, as
// the composition root (main/daemon.cpp) uses it.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "keeper/journal.hpp"
#include "keeper/keeper.hpp"

namespace sculpt::daemon {

struct OpenedKeeper {
  std::unique_ptr<Keeper> keeper;
  std::filesystem::path memory_dir;  // the store's directory in memory, when the state directory failed ("": none)
};

// The keeper and its store. A store another daemon holds stops the start
// (throws store::StoreInUse: two daemons never share one); one that cannot
// be opened otherwise (a read-only or full state directory) is replaced by
// one in memory: undo works, a crash loses the sculpt.
OpenedKeeper open_keeper(KeeperSettings settings, JournalTap& tap);

// The recovered sculpt, and what a crash lost, in the log. `configured_scene`:
// the config's scene (named when the sculpt is another's); `opened`: --open
// was given.
void log_recovery(const Recovered& r, const std::string& configured_scene, bool opened);

// The keeper's totals for the run, in the log (at the shutdown).
void log_keeper_stats(const KeeperStats& k);

}  // namespace sculpt::daemon
