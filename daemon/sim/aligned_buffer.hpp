// A fixed-size, 64-byte aligned array: one cache line per SIMD load, sized
// once at setup and never reallocated (the real-time step must not allocate).
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <new>
#include <span>
#include <type_traits>

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

  void resize(std::size_t n, T fill = T{}) {
    // Round the allocation up to whole cache lines so vector tails stay inside it.
    const std::size_t bytes = ((n * sizeof(T) + kAlignment - 1) / kAlignment) * kAlignment;
    data_.reset(bytes ? static_cast<T*>(::operator new(bytes, std::align_val_t{kAlignment})) : nullptr);
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
    void operator()(T* p) const { ::operator delete(p, std::align_val_t{kAlignment}); }
  };
  std::unique_ptr<T[], Free> data_;
  std::size_t size_ = 0;
};

}  // namespace sculpt::sim
