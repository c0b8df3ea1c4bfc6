// Runs untrusted parsing in a forked child. assimp has crashed and hung on
// malformed files in the past; a crash or hang there must cost the daemon one
// failed load, never the running sculpt. The child writes its answer into a
// memfd; the parent waits on a pidfd with a deadline and kills it past that.
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <string>
#include <variant>
#include <vector>

namespace sculpt::scene {

struct ChildLimits {
  std::chrono::milliseconds timeout{30000};
  std::size_t memory_bytes = std::size_t{8} << 30;  // address space (not applied under ASan)
};

struct ChildFailure {
  std::string what;  // "crashed (signal 11: Segmentation fault)", "timed out after 30 s", ...
};

// Calls `work` in a child process and returns what it returned, or why the
// child failed. An exception thrown by `work` comes back as a ChildFailure
// carrying its message.
std::variant<std::vector<std::byte>, ChildFailure> run_in_child(
    const std::function<std::vector<std::byte>()>& work, const ChildLimits& limits);

}  // namespace sculpt::scene
