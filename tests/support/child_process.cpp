#include "support/child_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/eventfd.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <stdexcept>

extern char** environ;

namespace sculpt::support {

using namespace std::chrono_literals;

// --- OutputLines ------------------------------------------------------------

OutputLines::OutputLines(int fd) {
  stop_fd_ = ::eventfd(0, EFD_CLOEXEC);
  if (stop_fd_ < 0) {
    ::close(fd);
    throw std::runtime_error(std::string("eventfd: ") + std::strerror(errno));
  }
  reader_ = std::thread([this, fd] { read_lines(fd, stop_fd_); });
}

OutputLines::~OutputLines() {
  // The child is gone by now; a grandchild that still holds the pipe (and
  // was not in the child's killed group) must not hold the test up.
  if (!wait_ended(2s)) {
    const std::uint64_t one = 1;
    (void)!::write(stop_fd_, &one, sizeof one);
  }
  reader_.join();
  ::close(stop_fd_);
}

void OutputLines::read_lines(int fd, int stop_fd) {
  std::string partial;
  char buf[4096];
  for (;;) {
    pollfd p[2] = {{fd, POLLIN, 0}, {stop_fd, POLLIN, 0}};
    if (::poll(p, 2, -1) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    if (p[1].revents != 0) break;
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    partial.append(buf, static_cast<std::size_t>(n));
    std::size_t nl;
    std::lock_guard lock(mutex_);
    text_.append(buf, static_cast<std::size_t>(n));
    while ((nl = partial.find('\n')) != std::string::npos) {
      lines_.push_back(partial.substr(0, nl));
      partial.erase(0, nl + 1);
    }
    changed_.notify_all();
  }
  ::close(fd);
  std::lock_guard lock(mutex_);
  if (!partial.empty()) lines_.push_back(partial);
  ended_ = true;
  changed_.notify_all();
}

std::string OutputLines::text() const {
  std::lock_guard lock(mutex_);
  return text_;
}

std::size_t OutputLines::line_count() const {
  std::lock_guard lock(mutex_);
  return lines_.size();
}

std::optional<std::size_t> OutputLines::wait_for(const std::string& part, std::chrono::milliseconds timeout,
                                                 std::size_t from) const {
  std::unique_lock lock(mutex_);
  std::optional<std::size_t> found;
  changed_.wait_for(lock, timeout, [&] {
    for (std::size_t i = from; i < lines_.size(); ++i)
      if (lines_[i].find(part) != std::string::npos) return (found = i).has_value();
    return ended_;
  });
  return found;
}

std::optional<std::string> OutputLines::next(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  if (!changed_.wait_for(lock, timeout, [&] { return taken_ < lines_.size() || ended_; })) return std::nullopt;
  if (taken_ == lines_.size()) return std::nullopt;  // ended
  return lines_[taken_++];
}

bool OutputLines::wait_ended(std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] { return ended_; });
}

// --- ChildProcess -----------------------------------------------------------

namespace {

std::vector<std::string> environment_with(const std::vector<std::string>& changes) {
  const auto name_of = [](const std::string& entry) { return entry.substr(0, entry.find('=') + 1); };
  std::vector<std::string> env;
  for (char** e = environ; *e != nullptr; ++e) {
    bool changed = false;
    for (const auto& c : changes) changed = changed || name_of(c) == name_of(*e);
    if (!changed) env.emplace_back(*e);
  }
  for (const auto& c : changes)
    if (c.back() != '=') env.push_back(c);  // "NAME=" only removes NAME
  return env;
}

std::vector<char*> pointers(std::vector<std::string>& strings) {
  std::vector<char*> p;
  for (auto& s : strings) p.push_back(s.data());
  p.push_back(nullptr);
  return p;
}

// A pipe whose both ends close on exec; the child gets the write end by dup2.
std::pair<int, int> make_pipe() {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error(std::string("pipe2: ") + std::strerror(errno));
  return {fds[0], fds[1]};
}

}  // namespace

ChildProcess::ChildProcess(std::vector<std::string> argv, Options options)
    : own_group_(options.own_process_group) {
  if (argv.empty()) throw std::runtime_error("ChildProcess: no program");
  if (options.out == Output::into_stdout) throw std::runtime_error("ChildProcess: stdout cannot go into stdout");
  program_ = argv[0];
  std::vector<std::string> env = environment_with(options.env);
  std::vector<char*> cargv = pointers(argv), cenv = pointers(env);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  std::vector<int> write_ends;
  int out_read = -1, err_read = -1;
  if (options.out == Output::capture) {
    auto [r, w] = make_pipe();
    out_read = r;
    write_ends.push_back(w);
    posix_spawn_file_actions_adddup2(&actions, w, STDOUT_FILENO);
  }
  if (options.err == Output::capture) {
    auto [r, w] = make_pipe();
    err_read = r;
    write_ends.push_back(w);
    posix_spawn_file_actions_adddup2(&actions, w, STDERR_FILENO);
  } else if (options.err == Output::into_stdout) {
    posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  }
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  if (own_group_) {
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attr, 0);
  }
  const int rc = ::posix_spawnp(&pid_, cargv[0], &actions, &attr, cargv.data(), cenv.data());
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  for (int w : write_ends) ::close(w);
  if (rc != 0) {
    pid_ = -1;
    for (int r : {out_read, err_read})
      if (r >= 0) ::close(r);
    throw std::runtime_error("cannot start " + program_ + ": " + std::strerror(rc));
  }
  if (out_read >= 0) out_ = std::make_unique<OutputLines>(out_read);
  if (err_read >= 0) err_ = std::make_unique<OutputLines>(err_read);
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0 && !status_) {
    ::kill(own_group_ ? -pid_ : pid_, SIGKILL);
    reap(true);
  }
  // out_ and err_ end with the pipe (their destructors wait, bounded).
}

void ChildProcess::signal(int sig) { ::kill(pid_, sig); }

bool ChildProcess::running() { return !reap(false); }

bool ChildProcess::reap(bool block) {
  if (status_) return true;
  int st = 0;
  pid_t r;
  do r = ::waitpid(pid_, &st, block ? 0 : WNOHANG);
  while (r < 0 && errno == EINTR);
  if (r != pid_) return false;
  status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  return true;
}

std::optional<int> ChildProcess::wait(std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!reap(false)) {
    if (std::chrono::steady_clock::now() >= end) return std::nullopt;
    std::this_thread::sleep_for(5ms);
  }
  // The child has exited: what it wrote is in the pipes, or soon read.
  const auto left = std::max<std::chrono::milliseconds>(
      std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now()), 2s);
  for (OutputLines* o : {out_.get(), err_.get()})
    if (o != nullptr) o->wait_ended(left);
  return status_;
}

int ChildProcess::wait() {
  reap(true);
  for (OutputLines* o : {out_.get(), err_.get()})
    if (o != nullptr) o->wait_ended(std::chrono::hours(1));
  return *status_;
}

OutputLines& ChildProcess::out() {
  if (!out_) throw std::logic_error(program_ + "'s stdout is not captured");
  return *out_;
}
OutputLines& ChildProcess::err() {
  if (!err_) throw std::logic_error(program_ + "'s stderr is not captured");
  return *err_;
}
const OutputLines& ChildProcess::out() const { return const_cast<ChildProcess*>(this)->out(); }
const OutputLines& ChildProcess::err() const { return const_cast<ChildProcess*>(this)->err(); }

// --- run_command ------------------------------------------------------------

CommandRun run_command(const std::string& program, const std::vector<std::string>& args) {
  std::vector<std::string> argv{program};
  argv.insert(argv.end(), args.begin(), args.end());
  CommandRun r;
  try {
    ChildProcess child(argv, {.out = ChildProcess::Output::capture, .err = ChildProcess::Output::capture});
    r.status = child.wait();
    r.out = child.out().text();
    r.err = child.err().text();
  } catch (const std::runtime_error& e) {
    r.status = -1;
    r.err = e.what();
  }
  return r;
}

}  // namespace sculpt::support
