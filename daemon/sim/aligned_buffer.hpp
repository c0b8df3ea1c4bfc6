// A fixed-size, 64-byte aligned array: one cache line per SIMD load, sized
// once at setup and never reallocated (the real-time step must not allocate).
// Its storage comes from the heap, or from a PageArena that outlives it.
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <new>
#include <span>
#include <type_traits>

#include "sim/page_arena.hpp"

namespace sculpt::sim {

template <class T>
class AlignedBuffer {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  static constexpr std::size_t kAlignment = 64;

  AlignedBuffer() = default;
  explicit AlignedBuffer(std::size_t n, T fill = T{}) { resize(n, fill); }
  AlignedBuffer(AlignedBuffer&&) noexcept = default;
  AlignedBuffer& operator=(AlignedBuffer&&) noexcept = default;

  // From `arena` when given and it has room, else from the heap.
  void resize(std::size_t n, T fill = T{}, PageArena* arena = nullptr) {
    // Round the allocation up to whole cache lines so vector tails stay inside it.
    const std::size_t bytes = ((n * sizeof(T) + kAlignment - 1) / kAlignment) * kAlignment;
    void* p = bytes && arena ? arena->allocate(bytes, kAlignment) : nullptr;
    const bool heap = !p;
    if (heap && bytes) p = ::operator new(bytes, std::align_val_t{kAlignment});
    data_ = std::unique_ptr<T[], Free>(static_cast<T*>(p), Free{heap});
    size_ = n;
    std::fill_n(data_.get(), n, fill);
  }

  T* data() { return data_.get(); }
  const T* data() const { return data_.get(); }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  T& operator[](std::size_t i) { return data_[i]; }
  const T& operator[](std::size_t i) const { return data_[i]; }
  std::span<T> span() { return {data_.get(), size_}; }
  std::span<const T> span() const { return {data_.get(), size_}; }
  std::size_t bytes() const { return ((size_ * sizeof(T) + kAlignment - 1) / kAlignment) * kAlignment; }

 private:
  struct Free {
    bool heap = true;  // arena storage goes with the arena
    void operator()(T* p) const {
      if (heap) ::operator delete(p, std::align_val_t{kAlignment});
    }
  };
  std::unique_ptr<T[], Free> data_;
  std::size_t size_ = 0;
};

}  // namespace sculpt::sim
