// One daemon per store: an exclusive flock(2) on the store's directory
// itself, held for the store's lifetime, and one on "<dir>/lock" (which
// holds the holder's PID, so a refused second opener can say who holds it,
// and which a daemon of an older version takes alone). The directory's lock
// is the one that counts: deleting the lock file cannot let a second daemon
// in, since it must lock the same directory. The kernel drops both when the
// process dies in any way (SIGKILL, OOM killer), so a stale file never
// blocks the next start.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>

#include "files/unique_fd.hpp"

namespace sculpt::store {

// Which file a path named when it was opened: a path that names another
// inode now, or none, means the file was replaced or removed.
struct FileId {
  dev_t dev = 0;
  ino_t ino = 0;
  bool operator==(const FileId&) const = default;
  static FileId of_fd(int fd);                              // {} when fstat fails
  static FileId of_path(const std::filesystem::path& p);    // {} when there is nothing there
  bool known() const { return ino != 0; }
};

class DirLock {
 public:
  // Throws StoreInUse (store.hpp) naming the directory's lock file and, when
  // it can be read, the holder's PID; StoreError when it cannot lock.
  explicit DirLock(const std::filesystem::path& dir);
  const std::filesystem::path& dir() const { return dir_; }
  const std::filesystem::path& file() const { return file_; }
  // Whether the directory's path still names the directory this holds.
  bool holds_path() const { return FileId::of_path(dir_) == dir_id_; }
  // Recreates the lock file (with the PID) if it was removed or replaced.
  void restore_file();

 private:
  void lock_file();

  std::filesystem::path dir_, file_;
  files::UniqueFd dir_fd_, fd_;
  FileId dir_id_;
};

}  // namespace sculpt::store
