// fake_sculptd SOCKET: the server on a fake daemon (fake_daemon.hpp) with a
// three-stroke history and a 10 KiB export, listening on SOCKET until
// SIGTERM or SIGINT. tests/fuzz/record_server_seeds.py records what
// sculptctl undo, redo, history and export send to it (sculptd's own daemon
// side need not implement them for that).
#include <signal.h>

#include <cstdio>

#include "fake_daemon.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fake_sculptd SOCKET\n");
    return 2;
  }
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGTERM);
  sigaddset(&stop, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop, nullptr);  // before the server's thread starts: it inherits the mask
  try {
    sculpt::test::FakeDaemon daemon(argv[1], [](sculpt::test::FakeControl& c) {
      c.history_now = sculpt::test::sample_history();
      c.export_bytes = sculpt::test::export_pattern(10240);
    });
    int signal = 0;
    sigwait(&stop, &signal);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fake_sculptd: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
