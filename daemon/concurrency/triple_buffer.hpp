// A triple buffer: one writer publishes whole values, one reader takes the
// latest. Neither side ever waits; values may be large and need not be
// trivially copyable (e.g. a preallocated frame with vectors inside), since
// each side works on a buffer the other cannot touch. The reader sees only
// complete values and skips intermediate ones: what a slow consumer wants.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <utility>

namespace sculpt::concurrency {

template <class T>
class TripleBuffer {
 public:
  TripleBuffer() = default;
  // All three buffers start as copies of `initial` (so their capacity is
  // preallocated before the real-time thread starts).
  explicit TripleBuffer(const T& initial) : buffers_{initial, initial, initial} {}

  TripleBuffer(const TripleBuffer&) = delete;
  TripleBuffer& operator=(const TripleBuffer&) = delete;

  // Writer: fill this buffer, then publish().
  T& back() { return buffers_[back_]; }
  // Swap the filled back buffer with the middle one and flag it as new.
  void publish() {
    const std::uint8_t old = middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel);
    back_ = old & kIndex;
  }

  // Reader: take the newest published value, if one arrived since the last
  // call; the returned reference stays valid until the next update().
  bool update() {
    if (!(middle_.load(std::memory_order_relaxed) & kFresh)) return false;
    const std::uint8_t old = middle_.exchange(front_, std::memory_order_acq_rel);
    front_ = old & kIndex;
    return true;
  }
  const T& front() const { return buffers_[front_]; }
  T& front() { return buffers_[front_]; }

 private:
  static constexpr std::uint8_t kIndex = 0x3;
  static constexpr std::uint8_t kFresh = 0x4;

  std::array<T, 3> buffers_{};
  std::uint8_t back_ = 0;                 // writer's
  std::atomic<std::uint8_t> middle_{1};   // shared: index | kFresh
  std::uint8_t front_ = 2;                // reader's
};

}  // namespace sculpt::concurrency
