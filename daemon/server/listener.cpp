#include "server/listener.hpp"

#include <fcntl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <systemd/sd-daemon.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "files/regular_file.hpp"

namespace sculpt::server {
namespace {

std::runtime_error fail(const std::string& path, const std::string& what, int err) {
  return std::runtime_error("socket " + path + ": " + what + ": " + std::strerror(err));
}

sockaddr_un address(const std::string& path) {
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof(a.sun_path))
    throw std::runtime_error("socket " + path + ": path must be 1.." + std::to_string(sizeof(a.sun_path) - 1) +
                             " bytes long");
  std::memcpy(a.sun_path, path.data(), path.size());
  return a;
}

}  // namespace

ListenSocket ListenSocket::open(const std::string& path) {
  ListenSocket s;
  const int n = sd_listen_fds(1);  // unsets LISTEN_FDS: children do not inherit it
  if (n > 1) throw std::runtime_error("socket activation: " + std::to_string(n) + " sockets passed, expected one");
  if (n == 1) {
    const int fd = SD_LISTEN_FDS_START;
    if (sd_is_socket_unix(fd, SOCK_STREAM, 1, nullptr, 0) <= 0)
      throw std::runtime_error("socket activation: the passed fd is not a listening Unix stream socket");
    ::fcntl(fd, F_SETFD, FD_CLOEXEC);
    s.fd_ = fd;
    s.activated_ = true;
    sockaddr_un a{};
    socklen_t len = sizeof a;
    if (::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0 && a.sun_path[0] != '\0')
      s.path_ = a.sun_path;
    return s;
  }

  const sockaddr_un addr = address(path);
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  if (!dir.empty()) {
    // 0750 whatever the umask: the group that may connect may look in.
    try {
      files::create_directories(dir, 0750);
    } catch (const files::FileError& e) {
      throw std::runtime_error("socket " + path + ": " + e.what());
    }
  }
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) throw std::runtime_error("socket " + path + ": exists and is not a socket");
    // A live daemon answers; a stale socket (a crashed daemon's) refuses.
    const int probe = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const bool live = probe >= 0 && ::connect(probe, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0;
    if (probe >= 0) ::close(probe);
    if (live) throw std::runtime_error("socket " + path + ": another sculptd is listening there");
    if (::unlink(path.c_str()) != 0 && errno != ENOENT) throw fail(path, "cannot remove the stale socket", errno);
  }
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) throw fail(path, "socket()", errno);
  s.fd_ = fd;
  s.path_ = path;
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) throw fail(path, "bind", errno);
  s.unlink_ = true;
  // Group may connect, nobody else. Nobody can connect before listen(), so
  // chmod here is enough (no process-wide umask flip under other threads).
  if (::chmod(path.c_str(), 0660) != 0) throw fail(path, "chmod 0660", errno);
  if (::listen(fd, 128) != 0) throw fail(path, "listen", errno);
  return s;
}

ListenSocket::ListenSocket(ListenSocket&& o) noexcept
    : fd_(std::exchange(o.fd_, -1)), path_(std::move(o.path_)), activated_(o.activated_),
      unlink_(std::exchange(o.unlink_, false)) {}

ListenSocket& ListenSocket::operator=(ListenSocket&& o) noexcept {
  if (this != &o) {
    this->~ListenSocket();
    new (this) ListenSocket(std::move(o));
  }
  return *this;
}

ListenSocket::~ListenSocket() {
  if (fd_ >= 0) ::close(fd_);
  if (unlink_) ::unlink(path_.c_str());
}

int ListenSocket::release() { return std::exchange(fd_, -1); }

}  // namespace sculpt::server
