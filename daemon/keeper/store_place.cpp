#include "keeper/store_place.hpp"

#include <cstdlib>
#include <ctime>
#include <stdexcept>

#include <fmt/chrono.h>
#include <fmt/format.h>

#include "log/log.hpp"

namespace sculpt::daemon {
namespace {

std::filesystem::path make_memory_dir() {
  const char* shm = "/dev/shm";
  std::string pattern = std::string(std::filesystem::is_directory(shm) ? shm : "/tmp") + "/sculptd-store-XXXXXX";
  if (!mkdtemp(pattern.data())) throw std::runtime_error("keeper: cannot make a directory in memory for the store");
  return pattern;
}

}  // namespace

OpenedKeeper open_keeper(KeeperSettings settings, JournalTap& tap) {
  OpenedKeeper out;
  try {
    out.keeper = std::make_unique<Keeper>(settings, tap);
  } catch (const store::StoreInUse&) {
    throw;
  } catch (const store::StoreError& e) {
    out.memory_dir = make_memory_dir();
    log::warning("keeper: {}; the sculpt is kept in memory only ({}): undo works, a crash loses it", e.what(),
                 out.memory_dir.string());
    settings.dir = out.memory_dir;
    out.keeper = std::make_unique<Keeper>(settings, tap);
  }
  return out;
}

void log_recovery(const Recovered& r, const std::string& configured_scene, bool opened) {
  // What a crash loses is the input after the last commit: when that was says how much.
  std::string last;
  if (r.committed_ns > 0) {
    const std::time_t secs = static_cast<std::time_t>(r.committed_ns / 1000000000);
    std::tm tm{};
    gmtime_r(&secs, &tm);
    last = fmt::format(" (the journal's last commit {:%Y-%m-%d %H:%M:%S}.{:03d} UTC: input after it was not saved)", tm,
                       static_cast<int>(r.committed_ns / 1000000 % 1000));
  }
  log::notice("recovered the sculpt of {} at tick {} (mesh hash {:016x}){}: the snapshot of tick {} and {} journal "
              "entries, {} strokes of history, in {:.0f} ms; {}{}",
              r.bundle->file, r.next_tick > 0 ? r.next_tick - 1 : 0, r.hash, r.paused ? ", paused" : "",
              r.snapshot_tick, r.replayed, r.strokes, r.seconds * 1e3, r.loss, last);
  for (const std::string& l : r.lost) log::warning("recovery: {}", l);
  if (r.bundle->file != configured_scene && !opened)
    log::notice("the config names scene {}: start with --fresh to sculpt it instead", configured_scene);
}

void log_keeper_stats(const KeeperStats& k) {
  log::info("keeper: {} journal entries ({} bytes) in {} commits, the longest gap between two {:.0f} ms; {} "
            "snapshots, the last of {} bytes of state ({} stored) in {:.0f} ms",
            k.entries, k.journal_bytes, k.commits, k.longest_commit_gap_ms, k.snapshots, k.snapshot_state_bytes,
            k.snapshot_stored_bytes, k.snapshot_ms);
}

}  // namespace sculpt::daemon
