// One daemon per store: an exclusive flock(2) on "<dir>/lock", held for the
// store's lifetime. The kernel drops it when the process dies in any way
// (SIGKILL, OOM killer), so a stale file never blocks the next start. The
// holder writes its PID into the file so a refused second opener can say
// who holds it.
#pragma once

#include <filesystem>

#include "files/unique_fd.hpp"

namespace sculpt::store {

class DirLock {
 public:
  // Throws StoreError (store.hpp) naming the lock file and, when it can be
  // read, the holder's PID.
  explicit DirLock(const std::filesystem::path& dir);
  const std::filesystem::path& file() const { return file_; }

 private:
  std::filesystem::path file_;
  files::UniqueFd fd_;
};

}  // namespace sculpt::store
