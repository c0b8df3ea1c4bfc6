#include "host/worker.hpp"

#include <exception>
#include <memory>
#include <stdexcept>

#include <kj/debug.h>

namespace sculpt::daemon {

Worker::~Worker() {
  if (thread_.joinable()) thread_.join();
}

kj::Promise<void> Worker::run(std::function<void()> job) {
  KJ_REQUIRE(!busy_, "a job is already running");
  if (thread_.joinable()) thread_.join();  // the last job's thread, already past its fulfil
  auto paf = kj::newPromiseAndCrossThreadFulfiller<void>();
  busy_ = true;
  // Held by a shared_ptr: kj::Own's destructor may throw, std::thread's state must not.
  auto done = std::make_shared<kj::Own<kj::CrossThreadPromiseFulfiller<void>>>(kj::mv(paf.fulfiller));
  thread_ = std::thread([job = std::move(job), done]() mutable {
    try {
      job();
      (*done)->fulfill();
    } catch (const std::exception& e) {
      (*done)->reject(KJ_EXCEPTION(FAILED, "background job failed", e.what()));
    } catch (...) {
      (*done)->reject(KJ_EXCEPTION(FAILED, "background job failed"));
    }
  });
  return paf.promise.then([this] { busy_ = false; },
                          [this](kj::Exception&& e) -> void {
                            busy_ = false;
                            kj::throwFatalException(kj::mv(e));
                          });
}

}  // namespace sculpt::daemon
