#include "store/dir_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include <fmt/format.h>

#include "store/store.hpp"

namespace sculpt::store {
namespace {

// The PID the holder wrote in `file`, or "" if none can be read.
std::string holder_pid(const std::filesystem::path& file) {
  files::UniqueFd fd(::open(file.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK));
  if (!fd.valid()) return {};
  char buf[32] = {};
  const ssize_t n = ::pread(fd.get(), buf, sizeof buf - 1, 0);
  if (n <= 0) return {};
  std::string s(buf, static_cast<std::size_t>(n));
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s.find_first_not_of("0123456789") == std::string::npos ? s : std::string();
}

[[noreturn]] void in_use(const std::filesystem::path& file) {
  const std::string pid = holder_pid(file);
  throw StoreInUse(fmt::format("{}: the store is in use by another process{} (one daemon per store)", file.string(),
                               pid.empty() ? std::string() : fmt::format(" (PID {})", pid)));
}

}  // namespace

FileId FileId::of_fd(int fd) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) return {};
  return {st.st_dev, st.st_ino};
}

FileId FileId::of_path(const std::filesystem::path& p) {
  struct stat st {};
  if (::stat(p.c_str(), &st) != 0) return {};
  return {st.st_dev, st.st_ino};
}

DirLock::DirLock(const std::filesystem::path& dir) : dir_(dir), file_(dir / "lock") {
  dir_fd_ = files::UniqueFd(::open(dir_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!dir_fd_.valid())
    throw StoreError(fmt::format("{}: cannot open the store's directory: {}", dir_.string(), std::strerror(errno)));
  if (::flock(dir_fd_.get(), LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    if (e != EWOULDBLOCK) throw StoreError(fmt::format("{}: cannot lock: {}", dir_.string(), std::strerror(e)));
    in_use(file_);
  }
  dir_id_ = FileId::of_fd(dir_fd_.get());
  lock_file();
}

void DirLock::lock_file() {
  fd_ = files::UniqueFd(::open(file_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0640));
  if (!fd_.valid()) throw StoreError(fmt::format("{}: cannot open the lock file: {}", file_.string(), std::strerror(errno)));
  // A daemon of an older version locks only this file.
  if (::flock(fd_.get(), LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    if (e != EWOULDBLOCK) throw StoreError(fmt::format("{}: cannot lock: {}", file_.string(), std::strerror(e)));
    in_use(file_);
  }
  const std::string pid = fmt::format("{}\n", ::getpid());
  // Best effort: the PID only improves the message of a refused opener.
  if (::ftruncate(fd_.get(), 0) == 0) {
    [[maybe_unused]] const ssize_t written = ::pwrite(fd_.get(), pid.data(), pid.size(), 0);
  }
}

void DirLock::restore_file() {
  if (fd_.valid() && FileId::of_path(file_) == FileId::of_fd(fd_.get())) return;
  try {
    lock_file();
  } catch (const StoreError&) {
    // The directory's lock still holds; the file only names the holder.
  }
}

}  // namespace sculpt::store
