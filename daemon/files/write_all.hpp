// Writes all of `bytes` to `fd`, across short writes and EINTR. Only
// write(2): safe in a forked child and in a signal-time path. False on an
// error (errno says which; EIO for a write that wrote nothing).
#pragma once

#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <string_view>

namespace sculpt::files {

// `piece`: at most this many bytes per write(2). A write into the page
// cache is one stretch in the kernel that a kernel without full preemption
// does not interrupt, not even for a real-time thread waking on that CPU:
// a large one (4 MiB: 5 ms here) holds such a thread up for all of it.
inline bool write_all(int fd, std::string_view bytes, std::size_t piece = std::string_view::npos) {
  const char* p = bytes.data();
  std::size_t left = bytes.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left < piece ? left : piece);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = EIO;
      return false;
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace sculpt::files
