// A bounded single-producer single-consumer queue of trivially copyable
// values. Wait-free on both sides: the real-time thread may push or pop
// without ever blocking, allocating or taking a lock. Capacity is fixed at
// construction (rounded up to a power of two); a full ring refuses the push
// and the caller decides what to drop.
#pragma once

#include <atomic>
#include <bit>
#include <cstddef>
#include <memory>
#include <new>
#include <optional>
#include <type_traits>

namespace sculpt::concurrency {

// Keeps producer and consumer indices on separate cache lines (no false sharing).
inline constexpr std::size_t kCacheLine = 64;

template <class T>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<T>, "SpscRing moves values with plain copies");

 public:
  explicit SpscRing(std::size_t capacity)
      : mask_(std::bit_ceil(capacity < 2 ? std::size_t{2} : capacity) - 1),
        cells_(std::make_unique<T[]>(mask_ + 1)) {}

  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;

  std::size_t capacity() const { return mask_ + 1; }

  // Producer side. False when full (nothing written).
  bool try_push(const T& value) {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_cache_ > mask_) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head - tail_cache_ > mask_) return false;
    }
    cells_[head & mask_] = value;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  // Consumer side. The oldest value, if any.
  std::optional<T> try_pop() {
    const T* front = peek();
    if (!front) return std::nullopt;
    T value = *front;
    pop();
    return value;
  }

  // Consumer side: look at the oldest value without taking it (nullptr when
  // empty); valid until pop().
  const T* peek() {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_cache_) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail == head_cache_) return nullptr;
    }
    return &cells_[tail & mask_];
  }
  void pop() { tail_.store(tail_.load(std::memory_order_relaxed) + 1, std::memory_order_release); }

  // Approximate (exact when called from either side with the other idle).
  std::size_t size() const {
    return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_acquire);
  }

 private:
  const std::size_t mask_;
  std::unique_ptr<T[]> cells_;
  alignas(kCacheLine) std::atomic<std::size_t> head_{0};  // written by the producer
  std::size_t tail_cache_ = 0;                            // producer's view of tail_
  alignas(kCacheLine) std::atomic<std::size_t> tail_{0};  // written by the consumer
  std::size_t head_cache_ = 0;                            // consumer's view of head_
};

}  // namespace sculpt::concurrency
