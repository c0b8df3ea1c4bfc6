// The listening socket: handed over by systemd (socket activation,
// sd_listen_fds) or bound at a path (its directory made, a stale socket from
// a crashed daemon removed, mode 0660). Another live daemon at the path is an
// error, never stolen from.
#pragma once

#include <string>

namespace sculpt::server {

class ListenSocket {
 public:
  // Throws std::runtime_error naming the path and the reason.
  static ListenSocket open(const std::string& path);
  ListenSocket() = default;
  ListenSocket(ListenSocket&& o) noexcept;
  ListenSocket& operator=(ListenSocket&& o) noexcept;
  ~ListenSocket();

  int fd() const { return fd_; }
  // Gives up the fd (the io loop takes ownership); the path is still removed on destruction.
  int release();
  const std::string& path() const { return path_; }  // "" when activated without a known path
  bool activated() const { return activated_; }

 private:
  int fd_ = -1;
  std::string path_;
  bool activated_ = false;
  bool unlink_ = false;  // we bound it: remove it when done
};

}  // namespace sculpt::server
