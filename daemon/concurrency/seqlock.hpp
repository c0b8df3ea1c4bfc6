// A single-writer sequence lock for a small trivially copyable value: the
// writer never waits (the real-time thread publishes the latest tool force
// with it); readers retry while a write is in progress and always get a
// consistent copy. Readers never block the writer.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace sculpt::concurrency {

template <class T>
class Seqlock {
  static_assert(std::is_trivially_copyable_v<T>, "Seqlock copies values bytewise");

 public:
  Seqlock() = default;
  explicit Seqlock(const T& initial) { store(initial); }

  // Writer (exactly one thread).
  void store(const T& value) {
    const std::uint64_t s = seq_.load(std::memory_order_relaxed);
    seq_.store(s + 1, std::memory_order_relaxed);  // odd: write in progress
    std::atomic_thread_fence(std::memory_order_release);
    copy_in(value);
    seq_.store(s + 2, std::memory_order_release);
  }

  // Any number of readers.
  T load() const {
    T out;
    for (;;) {
      const std::uint64_t s0 = seq_.load(std::memory_order_acquire);
      if (s0 & 1) continue;
      copy_out(out);
      std::atomic_thread_fence(std::memory_order_acquire);
      if (seq_.load(std::memory_order_relaxed) == s0) return out;
    }
  }

  // How many stores so far: lets a reader tell a new value from one it has seen.
  std::uint64_t version() const { return seq_.load(std::memory_order_acquire) / 2; }

 private:
  // Word-wise relaxed atomics: the racy copy is then not a data race in the
  // C++ model (and ThreadSanitizer agrees); torn copies are discarded by the
  // sequence check.
  static constexpr std::size_t kWords = (sizeof(T) + sizeof(std::uint64_t) - 1) / sizeof(std::uint64_t);

  void copy_in(const T& value) {
    std::uint64_t tmp[kWords] = {};
    std::memcpy(tmp, &value, sizeof(T));
    for (std::size_t i = 0; i < kWords; ++i) words_[i].store(tmp[i], std::memory_order_relaxed);
  }
  void copy_out(T& value) const {
    std::uint64_t tmp[kWords];
    for (std::size_t i = 0; i < kWords; ++i) tmp[i] = words_[i].load(std::memory_order_relaxed);
    std::memcpy(&value, tmp, sizeof(T));
  }

  std::atomic<std::uint64_t> seq_{0};
  std::atomic<std::uint64_t> words_[kWords]{};
};

}  // namespace sculpt::concurrency
