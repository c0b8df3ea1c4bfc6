// A sculptd serving on its own socket for a test (started, waited for, and
// stopped with SIGTERM at the end), raw connections for clients that break
// the protocol, and sculptctl as a child process.
#pragma once

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <optional>
#include <regex>
#include <stdexcept>
#include <string>
#include <vector>

#include "sculptd_process.hpp"
#include "support/child_process.hpp"

namespace sculpt::e2e {

inline std::string recordings(const std::string& name) { return std::string(SCULPT_RECORDINGS_DIR) + "/" + name; }

struct Daemon {
  std::string socket;
  std::unique_ptr<Sculptd> process;

  Daemon(const std::string& name, std::vector<std::string> args) : socket(temp_path(name + ".sock")) {
    ::unlink(socket.c_str());
    args.insert(args.end(), {"--socket", socket});
    process = std::make_unique<Sculptd>(args);
    if (!process->wait_for_log("sculptd ready", 60s)) throw std::runtime_error("sculptd did not start:\n" + process->log());
  }
  ~Daemon() {
    process->signal(SIGTERM);
    process->wait_exit(30s);
    ::unlink(socket.c_str());
  }
};

inline int connect_raw(const std::string& path) {
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd >= 0 && ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

inline bool write_all(int fd, const void* data, std::size_t n) {
  const auto* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::send(fd, p, n, MSG_NOSIGNAL);
    if (w <= 0) return false;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

using CtlRun = support::CommandRun;

inline CtlRun sculptctl(const std::vector<std::string>& args) { return support::run_command(SCULPTCTL_BIN, args); }

// What a restarted sculptd's log says it recovered.
struct Recovered {
  std::uint64_t tick = 0;  // the last tick the recovered state has run
  std::string hash;
};

inline std::optional<Recovered> parse_recovery(const std::string& log) {
  static const std::regex re(R"(recovered the sculpt of \S+ at tick (\d+) \(mesh hash ([0-9a-f]{16})\))");
  std::smatch m;
  if (!std::regex_search(log, m, re)) return std::nullopt;
  return Recovered{std::stoull(m[1]), m[2]};
}

// An uninterrupted run's mesh hash after `tick` (ticks 0..tick) of `recording`
// on builtin:default.
inline std::string reference_hash(const std::string& recording, std::uint64_t tick, const std::string& name) {
  const std::string out = temp_path(name + ".hash");
  char duration[32];
  std::snprintf(duration, sizeof duration, "%.3f", static_cast<double>(tick + 1) / 1000.0);
  Sculptd ref({"--scene", "builtin:default", "--input", "replay:" + recording, "--duration", duration, "--hash-out",
               out, "--socket", temp_path(name + ".sock")});
  if (ref.wait_exit(120s) != 0) return "(the reference run failed: " + ref.log() + ")";
  std::ifstream in(out);
  std::string hash;
  in >> hash;
  ::unlink(out.c_str());
  return hash;
}

// The resident set of a process, kB (0 once it is gone).
inline std::uint64_t rss_kb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stoull(line.substr(6));
  return 0;
}

}  // namespace sculpt::e2e
