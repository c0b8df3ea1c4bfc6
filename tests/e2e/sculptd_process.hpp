// sculptd as a child process for the end-to-end tests: started with the
// given flags, its log (stderr) collected line by line on a thread, so a test
// waits for facts ("device ... on slot 0"), sends signals and reads the
// stats JSON it writes at exit. Killed and reaped on destruction. A thin
// wrapper on support::ChildProcess: sculptd's defaults and its log.
#pragma once

#include <signal.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "support/child_process.hpp"
#include "support/read_file.hpp"
#include "support/scratch_dir.hpp"
#include "support/virtual_joystick.hpp"

namespace sculpt::e2e {

using namespace std::chrono_literals;

inline std::string data_path(const std::string& rel) { return std::string(SCULPT_TEST_DATA) + "/" + rel; }

// A path in this test process's scratch directory (removed at exit).
inline std::string temp_path(const std::string& name) { return support::scratch_path(name); }

class Sculptd {
 public:
  // `binary`: another sculptd than this build's (a benchmark comparing two).
  explicit Sculptd(std::vector<std::string> args, const std::string& binary = SCULPTD_BIN)
      : child_(with_test_defaults(std::move(args), binary), {.err = support::ChildProcess::Output::capture}) {}

  pid_t pid() const { return child_.pid(); }
  void signal(int sig) { child_.signal(sig); }

  // Waits until some log line contains `text` (counting from line `from`);
  // returns its index, or nullopt after the timeout.
  std::optional<std::size_t> wait_for_log(const std::string& text, std::chrono::milliseconds timeout = 20s,
                                          std::size_t from = 0) {
    return child_.err().wait_for(text, timeout, from);
  }
  std::size_t log_lines() const { return child_.err().line_count(); }
  std::string log() const { return child_.err().text(); }

  // The exit status (WEXITSTATUS, or 128 + signal), nullopt on timeout.
  std::optional<int> wait_exit(std::chrono::milliseconds timeout = 30s) { return child_.wait(timeout); }

 private:
  static std::vector<std::string> with_test_defaults(std::vector<std::string> args, const std::string& binary) {
    // Never the default socket, where a real service may listen (tests run
    // on the host wherever /dev/uinput works).
    if (std::find(args.begin(), args.end(), "--socket") == args.end())
      args.insert(args.end(), {"--socket", temp_path("sculptd.sock")});
    // Nor the default store, where a person's sculpt may be saved: a test
    // that means to save passes --state-dir (or --open, --fresh).
    const auto has = [&args](const char* flag) { return std::find(args.begin(), args.end(), flag) != args.end(); };
    if (!has("--state-dir") && !has("--no-store") && !has("--open") && !has("--fresh")) args.push_back("--no-store");
    args.insert(args.begin(), binary);
    return args;
  }

  support::ChildProcess child_;
};

inline nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  return nlohmann::json::parse(in);
}

using support::read_file;

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
