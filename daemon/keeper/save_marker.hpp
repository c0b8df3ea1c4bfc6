// How far the store got, kept outside it. The keeper's store thread rewrites
// a small file in memory (the runtime directory: it outlives a crashed or
// restarted daemon, not a reboot) at every journal commit: the ticks the
// sim thread had run, the ticks the store holds, and since when writes
// fail. A daemon that ends with everything saved removes it. What one that
// crashed leaves tells the next start what the store itself cannot: that
// sculpt held in memory while the disk refused writes was lost, or that
// commits are missing because the store's files were removed or replaced.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "files/unique_fd.hpp"

namespace sculpt::daemon {

struct SaveState {
  std::int64_t pid = 0;
  std::uint64_t ran = 0;          // store ticks before it: the sim thread had finished them
  std::uint64_t committed = 0;    // store ticks before it: in the store (its last mark committed)
  std::int64_t failing_since_ns = 0;  // CLOCK_REALTIME of the first write that failed and is not made good (0: none)
  std::string error;              // that failure
  bool unnamed = false;           // the store's files had no name (removed, not written back)
  bool ended = false;             // the daemon stopped by itself, with this left unsaved
};

// Where sculptd keeps what must outlive a crash but not a reboot:
// $RUNTIME_DIRECTORY, else $XDG_RUNTIME_DIR, else /dev/shm, else /tmp.
std::filesystem::path runtime_dir();

class SaveMarker {
 public:
  // The marker of the store in `store_dir`: in runtime_dir(), named by the
  // directory.
  static std::filesystem::path path_for(const std::filesystem::path& store_dir);
  // What the last daemon of `store_dir` left on this boot; nullopt: nothing
  // (none ran, or it ended with everything saved).
  static std::optional<SaveState> read(const std::filesystem::path& store_dir);

  // Best effort: a marker that cannot be written only makes the next
  // start's report less precise.
  explicit SaveMarker(const std::filesystem::path& store_dir);
  void write(const SaveState& state);
  void remove();  // everything is saved: nothing to tell

 private:
  std::filesystem::path path_;
  files::UniqueFd fd_;
  std::string header_;  // which store, which boot
  bool tried_ = false;
};

}  // namespace sculpt::daemon
