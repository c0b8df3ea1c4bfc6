#include "store/dir_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include <fmt/format.h>

#include "store/store.hpp"

namespace sculpt::store {
namespace {

// The PID the holder wrote, or "" if none can be read.
std::string holder_pid(int fd) {
  char buf[32] = {};
  const ssize_t n = ::pread(fd, buf, sizeof buf - 1, 0);
  if (n <= 0) return {};
  std::string s(buf, static_cast<std::size_t>(n));
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s.find_first_not_of("0123456789") == std::string::npos ? s : std::string();
}

}  // namespace

DirLock::DirLock(const std::filesystem::path& dir) : file_(dir / "lock") {
  fd_ = files::UniqueFd(::open(file_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0640));
  if (!fd_.valid()) throw StoreError(fmt::format("{}: cannot open the lock file: {}", file_.string(), std::strerror(errno)));
  if (::flock(fd_.get(), LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    if (e != EWOULDBLOCK)
      throw StoreError(fmt::format("{}: cannot lock: {}", file_.string(), std::strerror(e)));
    const std::string pid = holder_pid(fd_.get());
    throw StoreInUse(fmt::format("{}: the store is in use by another process{} (one daemon per store)", file_.string(),
                                 pid.empty() ? std::string() : fmt::format(" (PID {})", pid)));
  }
  const std::string pid = fmt::format("{}\n", ::getpid());
  // Best effort: the PID only improves the message of a refused opener.
  if (::ftruncate(fd_.get(), 0) == 0) {
    [[maybe_unused]] const ssize_t written = ::pwrite(fd_.get(), pid.data(), pid.size(), 0);
  }
}

}  // namespace sculpt::store
