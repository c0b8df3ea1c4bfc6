// Bounds on waits, for tests that wait on facts (never on sleeps). A bound
// only catches a hang: it is seconds, with margin for a busy machine.
#pragma once

#include <chrono>
#include <cstdlib>
#include <functional>
#include <thread>

namespace sculpt::support {

// How much slower than a plain build this run is: SCULPT_VM_SLOWDOWN (the vm
// runner's --slowdown, 3 in sanitized builds), or 1.
inline double slowdown() {
  const char* s = std::getenv("SCULPT_VM_SLOWDOWN");
  const double f = s != nullptr ? std::atof(s) : 1.0;
  return f >= 1.0 ? f : 1.0;
}

// A bound stretched by the slowdown.
inline std::chrono::milliseconds scaled(std::chrono::milliseconds t) {
  return std::chrono::milliseconds(static_cast<long long>(static_cast<double>(t.count()) * slowdown()));
}

// Polls pred every `every` until it holds (true) or the timeout passes (false).
inline bool wait_until(const std::function<bool()>& pred, std::chrono::milliseconds timeout,
                       std::chrono::milliseconds every = std::chrono::milliseconds(1)) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(every);
  }
  return true;
}

}  // namespace sculpt::support
