// sculptd as a child process for the end-to-end tests: started with the
// given flags, its log (stderr) collected line by line on a thread, so a test
// waits for facts ("device ... on slot 0"), sends signals and reads the
// stats JSON it writes at exit. Killed and reaped on destruction.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <functional>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "support/virtual_joystick.hpp"

extern char** environ;

namespace sculpt::e2e {

using namespace std::chrono_literals;

inline std::string data_path(const std::string& rel) { return std::string(SCULPT_TEST_DATA) + "/" + rel; }

inline std::string temp_path(const std::string& name) {
  return "/tmp/sculptd-e2e-" + std::to_string(::getpid()) + "-" + name;
}

class Sculptd {
 public:
  // `binary`: another sculptd than this build's (a benchmark comparing two).
  explicit Sculptd(std::vector<std::string> args, const std::string& binary = SCULPTD_BIN) {
    // Never the default socket, where a real service may listen (tests run
    // on the host wherever /dev/uinput works).
    if (std::find(args.begin(), args.end(), "--socket") == args.end())
      args.insert(args.end(), {"--socket", temp_path("sculptd.sock")});
    // Nor the default store, where a person's sculpt may be saved: a test
    // that means to save passes --state-dir (or --open, --fresh).
    const auto has = [&args](const char* flag) { return std::find(args.begin(), args.end(), flag) != args.end(); };
    if (!has("--state-dir") && !has("--no-store") && !has("--open") && !has("--fresh")) args.push_back("--no-store");
    args.insert(args.begin(), binary);
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error("pipe2");
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, fds[1], 2);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const int rc = ::posix_spawn(&pid_, argv[0], &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    ::close(fds[1]);
    if (rc != 0) {
      ::close(fds[0]);
      throw std::runtime_error("posix_spawn " + binary + ": " + std::to_string(rc));
    }
    reader_ = std::thread([this, fd = fds[0]] { read_log(fd); });
  }
  ~Sculptd() {
    if (!exit_status_) {
      ::kill(pid_, SIGKILL);
      wait_exit(10s);
    }
    if (reader_.joinable()) reader_.join();
  }
  Sculptd(const Sculptd&) = delete;
  Sculptd& operator=(const Sculptd&) = delete;

  pid_t pid() const { return pid_; }
  void signal(int sig) { ::kill(pid_, sig); }

  // Waits until some log line contains `text` (counting from line `from`);
  // returns its index, or nullopt after the timeout.
  std::optional<std::size_t> wait_for_log(const std::string& text, std::chrono::milliseconds timeout = 20s,
                                          std::size_t from = 0) {
    std::unique_lock lock(mutex_);
    std::optional<std::size_t> found;
    changed_.wait_for(lock, timeout, [&] {
      for (std::size_t i = from; i < lines_.size(); ++i)
        if (lines_[i].find(text) != std::string::npos) return (found = i).has_value();
      return eof_;
    });
    return found;
  }
  std::size_t log_lines() const {
    std::lock_guard lock(mutex_);
    return lines_.size();
  }
  std::string log() const {
    std::lock_guard lock(mutex_);
    std::string all;
    for (const auto& l : lines_) all += l + "\n";
    return all;
  }

  // The exit status (WEXITSTATUS, or 128 + signal), nullopt on timeout.
  std::optional<int> wait_exit(std::chrono::milliseconds timeout = 30s) {
    if (exit_status_) return exit_status_;
    const auto end = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      int st = 0;
      const pid_t r = ::waitpid(pid_, &st, WNOHANG);
      if (r == pid_) {
        exit_status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        return exit_status_;
      }
      if (std::chrono::steady_clock::now() > end) return std::nullopt;
      std::this_thread::sleep_for(5ms);
    }
  }

 private:
  void read_log(int fd) {
    std::string buf;
    char tmp[4096];
    for (;;) {
      const ssize_t n = ::read(fd, tmp, sizeof tmp);
      if (n <= 0) break;
      buf.append(tmp, static_cast<std::size_t>(n));
      std::size_t nl;
      while ((nl = buf.find('\n')) != std::string::npos) {
        std::lock_guard lock(mutex_);
        lines_.push_back(buf.substr(0, nl));
        buf.erase(0, nl + 1);
        changed_.notify_all();
      }
    }
    ::close(fd);
    std::lock_guard lock(mutex_);
    if (!buf.empty()) lines_.push_back(buf);
    eof_ = true;
    changed_.notify_all();
  }

  pid_t pid_ = -1;
  std::optional<int> exit_status_;
  std::thread reader_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::string> lines_;
  bool eof_ = false;
};

inline nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  return nlohmann::json::parse(in);
}

inline std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// --- what a joystick's FF log says --------------------------------------------

inline bool is_upload_of(const support::FfUpload& u, std::uint16_t type) { return u.effect.type == type; }

inline std::size_t count_uploads(const support::FfLog& log, std::uint16_t type, bool new_only = false) {
  std::size_t n = 0;
  for (const auto& u : log.uploads)
    if (is_upload_of(u, type) && u.retval == 0 && (!new_only || !u.old)) ++n;
  return n;
}

// The most effect ids the device held at once, following uploads (new ids)
// and erases in order.
inline std::size_t max_live_ids(const support::FfLog& log) {
  std::vector<std::int16_t> live;
  std::size_t most = 0;
  for (const auto& r : log.sequence) {
    if (const auto* u = std::get_if<support::FfUpload>(&r)) {
      if (u->retval == 0 && !u->old) live.push_back(u->id);
    } else if (const auto* e = std::get_if<support::FfErase>(&r)) {
      std::erase(live, e->id);
    }
    most = std::max(most, live.size());
  }
  return most;
}

// Ids uploaded (successfully) and never erased afterwards.
inline std::vector<std::int16_t> ids_left(const support::FfLog& log) {
  std::vector<std::int16_t> live;
  for (const auto& r : log.sequence) {
    if (const auto* u = std::get_if<support::FfUpload>(&r)) {
      if (u->retval == 0 && !u->old && std::find(live.begin(), live.end(), u->id) == live.end()) live.push_back(u->id);
    } else if (const auto* e = std::get_if<support::FfErase>(&r)) {
      std::erase(live, e->id);
    }
  }
  return live;
}

// Pushes the left stick down (tool 0 towards the ball) until the device sees
// a constant-force upload with a non-zero level, or a rumble kick; then
// centres the stick.
inline bool press_until_felt(support::VirtualJoystick& pad, std::chrono::milliseconds timeout = 20s) {
  pad.move_axis(ABS_Y, 12000);  // ~0.17 m/s down
  const bool felt = pad.wait_for(
      [](const support::FfLog& log) {
        for (const auto& u : log.uploads)
          if (u.retval == 0 && ((u.effect.type == FF_CONSTANT && u.effect.u.constant.level != 0) ||
                                u.effect.type == FF_RUMBLE))
            return true;
        return false;
      },
      timeout);
  pad.move_axis(ABS_Y, 0);
  return felt;
}

}  // namespace sculpt::e2e
