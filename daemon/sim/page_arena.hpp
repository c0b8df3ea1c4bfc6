// One contiguous region for a big body's hot arrays, backed by transparent
// huge pages where the kernel allows them (madvise mode included). A 100k-
// vertex body's arrays span ~2 600 small pages, nearly the whole second-level
// TLB of this machine, and the force kernel's neighbour loads land on many of
// them at once; in 2 MiB pages the same bytes take six entries. Allocation is
// a bump pointer: buffers live as long as the arena and are never freed one
// by one. Sized once at setup; nothing here runs on the real-time path.
#pragma once

#include <cstddef>
#include <utility>

namespace sculpt::sim {

class PageArena {
 public:
  static constexpr std::size_t kHugePage = std::size_t{2} << 20;

  PageArena() = default;
  // Reserves `capacity` bytes of address space (rounded up to whole huge
  // pages; memory only as allocations open and touch it) and asks for huge pages.
  // On failure, and for capacity 0, the arena stays empty and allocate()
  // always returns null.
  explicit PageArena(std::size_t capacity);
  PageArena(PageArena&& o) noexcept { swap(o); }
  PageArena& operator=(PageArena&& o) noexcept {
    PageArena(std::move(o)).swap(*this);
    return *this;
  }
  PageArena(const PageArena&) = delete;
  PageArena& operator=(const PageArena&) = delete;
  ~PageArena();

  // `bytes` at `alignment` (a power of two ≤ 4096), or null when it does not fit.
  void* allocate(std::size_t bytes, std::size_t alignment);

  // Gives back the address space past what is used (whole small pages).
  void trim();

  bool contains(const void* p) const {
    auto* c = static_cast<const char*>(p);
    return c >= base_ && c < base_ + capacity_;
  }
  std::size_t capacity() const { return capacity_; }
  std::size_t used() const { return used_; }

 private:
  void swap(PageArena& o) noexcept;
  char* base_ = nullptr;       // huge-page aligned
  std::size_t capacity_ = 0;   // usable bytes from base_
  char* mapping_ = nullptr;    // what is mapped: base_ onwards
  std::size_t mapped_ = 0;
  std::size_t used_ = 0;
  std::size_t open_ = 0;       // bytes from base_ made accessible so far
};

}  // namespace sculpt::sim
