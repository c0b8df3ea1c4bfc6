// Runs one job at a time on its own thread and tells the io thread's kj
// event loop when it is done: loading a scene (reading files, importing
// meshes in their child process, building the world) takes as long as it
// takes, and meanwhile the io loop keeps serving clients, reading devices
// and feeding the watchdog.
//
//   worker.run([=] { ... }).then([this] { ... on the io thread ... });
//
// The job must not touch what the io thread uses: it gets copies, and
// leaves its result where the continuation picks it up (a shared_ptr both
// hold). A job's exceptions are its own to catch: one that escapes ends the
// promise with a kj::Exception describing it.
#pragma once

#include <functional>
#include <thread>

#include <kj/async.h>

namespace sculpt::daemon {

class Worker {
 public:
  Worker() = default;
  ~Worker();  // waits for a running job
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  // Starts `job`; the promise resolves on the calling thread's event loop
  // once it returned. Call only when !busy().
  kj::Promise<void> run(std::function<void()> job);
  // A job was started and its promise has not resolved yet.
  bool busy() const { return busy_; }

 private:
  std::thread thread_;
  bool busy_ = false;
};

}  // namespace sculpt::daemon
