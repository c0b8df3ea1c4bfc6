#include "scene/isolation.hpp"

#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>

#include <fmt/format.h>

#include "files/unique_fd.hpp"
#include "files/write_all.hpp"

#if defined(__SANITIZE_ADDRESS__)
#define SCULPT_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SCULPT_ASAN 1
#endif
#endif

namespace sculpt::scene {
namespace {

[[noreturn]] void fail_errno(const char* what) {
  throw std::system_error(errno, std::generic_category(), what);
}


// Child side. Status byte 0 = payload follows, 1 = error message follows.
[[noreturn]] void child_main(int out_fd, const std::function<std::vector<std::byte>()>& work,
                             const ChildLimits& limits) {
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  // A crash here is the importer's, reported by the parent: the process's
  // own crash handlers (crash reporters, libFuzzer) must not run for it.
  for (int sig : {SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT}) ::signal(sig, SIG_DFL);
  // The caller's signal mask (a daemon blocks signals for its signalfd) and
  // real-time priority are inherited: an importer stuck in a loop must not
  // ignore SIGXCPU nor starve the machine at SCHED_FIFO until the deadline.
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  const sched_param normal{};
  ::sched_setscheduler(0, SCHED_OTHER, &normal);
  ::setpriority(PRIO_PROCESS, 0, 10);
  const rlimit no_core{0, 0};
  ::setrlimit(RLIMIT_CORE, &no_core);
  const auto cpu_s = static_cast<rlim_t>(limits.timeout.count() / 1000 + 2);
  const rlimit cpu{cpu_s, cpu_s + 1};
  ::setrlimit(RLIMIT_CPU, &cpu);  // a backstop: the parent's deadline is the real one
#ifndef SCULPT_ASAN
  const rlimit as{limits.memory_bytes, limits.memory_bytes};
  ::setrlimit(RLIMIT_AS, &as);  // ASan reserves terabytes of shadow: no limit there
#endif
  unsigned char status = 1;
  std::vector<std::byte> payload;
  std::string error;
  try {
    payload = work();
    status = 0;
  } catch (const std::bad_alloc&) {
    error = "ran out of memory";
  } catch (const std::exception& e) {
    error = e.what();
  } catch (...) {
    error = "failed";
  }
  const char status_byte = static_cast<char>(status);
  const std::string_view body = status == 0
                                    ? std::string_view(reinterpret_cast<const char*>(payload.data()), payload.size())
                                    : std::string_view(error);
  const bool ok = files::write_all(out_fd, std::string_view(&status_byte, 1)) && files::write_all(out_fd, body);
  ::_exit(ok ? 0 : 3);  // no atexit handlers, no stdio flush: the parent owns those
}

}  // namespace

std::variant<std::vector<std::byte>, ChildFailure> run_in_child(
    const std::function<std::vector<std::byte>()>& work, const ChildLimits& limits) {
  files::UniqueFd out(::memfd_create("sculpt-import", MFD_CLOEXEC));
  if (out.get() < 0) fail_errno("memfd_create");

  const pid_t pid = ::fork();
  if (pid < 0) fail_errno("fork");
  if (pid == 0) child_main(out.get(), work, limits);

  files::UniqueFd pidfd(static_cast<int>(::syscall(SYS_pidfd_open, pid, 0)));
  const auto deadline = std::chrono::steady_clock::now() + limits.timeout;
  bool timed_out = false;
  if (pidfd.get() >= 0) {
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) {
        timed_out = true;
        break;
      }
      pollfd p{pidfd.get(), POLLIN, 0};
      const int n = ::poll(&p, 1, static_cast<int>(std::min<long long>(left.count(), 1 << 30)));
      if (n > 0) break;
      if (n < 0 && errno != EINTR) fail_errno("poll");
    }
  } else {
    // No pidfd (kernel before 5.3): poll for the exit without reaping.
    for (;;) {
      siginfo_t info{};
      if (::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 &&
          info.si_pid == pid)
        break;
      if (std::chrono::steady_clock::now() >= deadline) {
        timed_out = true;
        break;
      }
      ::usleep(2000);
    }
  }
  if (timed_out) ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) fail_errno("waitpid");
  }
  if (timed_out) {
    return ChildFailure{fmt::format("the importer did not finish within {} s and was stopped",
                                    static_cast<double>(limits.timeout.count()) / 1000.0)};
  }
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    if (sig == SIGXCPU) return ChildFailure{"the importer used too much CPU time and was stopped"};
    return ChildFailure{fmt::format("the importer crashed (signal {}: {})", sig, ::strsignal(sig))};
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    return ChildFailure{fmt::format("the importer failed (exit status {})", WEXITSTATUS(status))};
  }

  struct stat st {};
  if (::fstat(out.get(), &st) != 0) fail_errno("fstat");
  if (st.st_size < 1) return ChildFailure{"the importer returned nothing"};
  auto read_at = [&](void* dst, std::size_t size, std::size_t offset) {
    std::size_t got = 0;
    while (got < size) {
      const ssize_t n = ::pread(out.get(), static_cast<char*>(dst) + got, size - got,
                                static_cast<off_t>(offset + got));
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) fail_errno("pread");
      got += static_cast<std::size_t>(n);
    }
  };
  unsigned char tag = 1;
  read_at(&tag, 1, 0);
  std::vector<std::byte> data(static_cast<std::size_t>(st.st_size) - 1);
  read_at(data.data(), data.size(), 1);
  if (tag != 0) return ChildFailure{std::string(reinterpret_cast<const char*>(data.data()), data.size())};
  return data;
}

}  // namespace sculpt::scene
