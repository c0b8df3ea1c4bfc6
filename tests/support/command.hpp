// Runs a program as a test's child, without a shell: its exit status and
// everything it wrote to stdout and stderr (each through an unlinked
// temporary file, so neither can fill a pipe and block it).
#pragma once

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace sculpt::support {

struct CommandRun {
  int status = -1;  // the exit status; -1 when it could not run or was killed
  std::string out, err;
};

namespace detail {

inline int unlinked_temp() {
  char name[] = "/tmp/sculpt-command-XXXXXX";
  const int fd = ::mkstemp(name);
  if (fd >= 0) ::unlink(name);
  return fd;
}

inline std::string read_all(int fd) {
  std::string text;
  char buf[4096];
  ::lseek(fd, 0, SEEK_SET);
  for (ssize_t n; (n = ::read(fd, buf, sizeof buf)) > 0;) text.append(buf, static_cast<std::size_t>(n));
  ::close(fd);
  return text;
}

}  // namespace detail

inline CommandRun run_command(const std::string& program, const std::vector<std::string>& args) {
  CommandRun r;
  std::vector<std::string> argv_text{program};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_text) argv.push_back(a.data());
  argv.push_back(nullptr);
  const int out = detail::unlinked_temp(), err = detail::unlinked_temp();
  if (out < 0 || err < 0) {
    r.err = "cannot create a temporary file for the command's output";
    return r;
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out, STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, err, STDERR_FILENO);
  pid_t pid = -1;
  const int spawned = ::posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned == 0) {
    int st = 0;
    while (::waitpid(pid, &st, 0) < 0) {
    }
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  }
  r.out = detail::read_all(out);
  r.err = detail::read_all(err);
  if (spawned != 0) r.err = "cannot run " + program;
  return r;
}

}  // namespace sculpt::support
