// A program run as a test's child, without a shell: sculptd, sculptctl,
// sculpt-view, Xvfb, the demo script. Every test that starts a process starts
// it here (sculptd's own wrapper, tests/e2e/sculptd_process.hpp, too).
//
//   ChildProcess d({SCULPTD_BIN, "--no-store"}, {.err = Output::capture});
//   d.err().wait_for("sculptd ready", 20s);   // its stderr, line by line
//   d.signal(SIGTERM);
//   d.wait(30s);                               // 0, or 128 + signal
//
//   CommandRun r = run_command(SCULPTCTL_BIN, {"status", "--json"});  // to the end
//
// A captured stream is read on a thread of its own as it is written (so the
// child never blocks on a full pipe) and kept whole. The destructor kills
// the child (its process group, when it has one) and reaps it.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace sculpt::support {

// One output stream of a child (stdout or stderr), captured line by line.
class OutputLines {
 public:
  explicit OutputLines(int fd);  // takes the pipe's read end
  ~OutputLines();
  OutputLines(const OutputLines&) = delete;
  OutputLines& operator=(const OutputLines&) = delete;

  // Everything read so far, byte for byte.
  std::string text() const;
  std::size_t line_count() const;
  // Waits until a line from index `from` on contains `part`: its index;
  // nullopt after the timeout or at the end of the stream.
  std::optional<std::size_t> wait_for(const std::string& part, std::chrono::milliseconds timeout,
                                      std::size_t from = 0) const;
  // The next line not taken yet (lines are taken in order); nullopt at the
  // end of the stream or after the timeout.
  std::optional<std::string> next(std::chrono::milliseconds timeout);
  // Waits for the end of the stream (every writer closed it).
  bool wait_ended(std::chrono::milliseconds timeout) const;

 private:
  void read_lines(int fd, int stop_fd);

  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::string text_;
  std::vector<std::string> lines_;  // text_ cut at each '\n'; a last line without one at the end
  std::size_t taken_ = 0;
  bool ended_ = false;
  int stop_fd_ = -1;  // eventfd: makes the reader give up on a pipe a grandchild still holds
  std::thread reader_;
};

class ChildProcess {
 public:
  enum class Output {
    inherit,      // the test's own (meson's log)
    capture,      // read line by line: out() / err()
    into_stdout,  // stderr only: written where stdout goes, in order with it
  };
  struct Options {
    Output out = Output::inherit;  // stdout
    Output err = Output::inherit;  // stderr
    // Changes to the environment: "NAME=value" sets NAME, "NAME=" removes it.
    std::vector<std::string> env = {};
    // A process group of its own: the destructor's kill reaches the child's
    // children too (a script that starts programs).
    bool own_process_group = false;
  };

  // argv[0] is looked up in PATH when it has no '/'. Throws
  // std::runtime_error naming the program when it cannot be started.
  explicit ChildProcess(std::vector<std::string> argv, Options options);
  explicit ChildProcess(std::vector<std::string> argv) : ChildProcess(std::move(argv), Options{}) {}
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  void signal(int sig);
  bool running();

  // The exit status (WEXITSTATUS, or 128 + the signal that ended it), once
  // the child has exited and its captured streams have ended (they are read
  // to the end within the same timeout); nullopt on timeout.
  std::optional<int> wait(std::chrono::milliseconds timeout);
  int wait();  // without a bound (a command that always ends)

  // The captured streams; calling one not captured is a test bug (throws).
  OutputLines& out();
  OutputLines& err();
  const OutputLines& out() const;
  const OutputLines& err() const;

 private:
  bool reap(bool block);

  std::string program_;
  pid_t pid_ = -1;
  bool own_group_ = false;
  std::optional<int> status_;
  std::unique_ptr<OutputLines> out_, err_;
};

// A child whose stdout and stderr are one log (out()), in a process group of
// its own so that killing it kills what it started: the viewer tests'
// programs, the demo script. `env` as Options::env.
inline ChildProcess::Options one_log_own_group(std::vector<std::string> env = {}) {
  return {.out = ChildProcess::Output::capture,
          .err = ChildProcess::Output::into_stdout,
          .env = std::move(env),
          .own_process_group = true};
}

// A command run to its end with stdout and stderr captured.
struct CommandRun {
  int status = -1;  // the exit status (128 + signal if killed); -1 when it could not start
  std::string out, err;
};
CommandRun run_command(const std::string& program, const std::vector<std::string>& args);

}  // namespace sculpt::support
