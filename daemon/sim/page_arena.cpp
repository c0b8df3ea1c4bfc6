#include "sim/page_arena.hpp"

#include <sys/mman.h>

#include <algorithm>
#include <cstdint>
#include <utility>

namespace sculpt::sim {

PageArena::PageArena(std::size_t capacity) {
  if (capacity == 0) return;
  const std::size_t size = (capacity + kHugePage - 1) / kHugePage * kHugePage;
  // Address space only, with one extra huge page so the usable part can start
  // on a huge-page boundary. Inaccessible until allocate() opens it, 2 MiB at
  // a time: under mlockall(MCL_FUTURE) (sculptd --realtime) an accessible
  // mapping is populated whole at once, and the reservation is an upper bound.
  void* m = ::mmap(nullptr, size + kHugePage, PROT_NONE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
  if (m == MAP_FAILED) return;
  char* const first = static_cast<char*>(m);
  const std::size_t head = (kHugePage - reinterpret_cast<std::uintptr_t>(m) % kHugePage) % kHugePage;
  if (head) ::munmap(first, head);
  ::munmap(first + head + size, kHugePage - head);  // head == 0: the whole spare page
  mapping_ = base_ = first + head;
  mapped_ = capacity_ = size;
  // Refused or ignored (no THP, or THP "never"): small pages, the same results.
  ::madvise(base_, capacity_, MADV_HUGEPAGE);
}

PageArena::~PageArena() {
  if (mapping_) ::munmap(mapping_, mapped_);
}

void* PageArena::allocate(std::size_t bytes, std::size_t alignment) {
  const std::size_t start = (used_ + alignment - 1) / alignment * alignment;
  if (!base_ || start > capacity_ || bytes > capacity_ - start) return nullptr;
  const std::size_t end = start + bytes;
  if (end > open_) {
    const std::size_t open = std::min(capacity_, (end + kHugePage - 1) / kHugePage * kHugePage);
    if (::mprotect(base_ + open_, open - open_, PROT_READ | PROT_WRITE) != 0) return nullptr;  // the heap, then
    open_ = open;
  }
  used_ = end;
  return base_ + start;
}

void PageArena::trim() {
  if (!base_) return;
  constexpr std::size_t kPage = 4096;
  const std::size_t keep = (used_ + kPage - 1) / kPage * kPage;
  char* end = base_ + keep;
  if (mapping_ + mapped_ > end) ::munmap(end, static_cast<std::size_t>(mapping_ + mapped_ - end));
  mapped_ = static_cast<std::size_t>(end - mapping_);
  capacity_ = keep;
  open_ = std::min(open_, keep);
}

void PageArena::swap(PageArena& o) noexcept {
  std::swap(base_, o.base_);
  std::swap(capacity_, o.capacity_);
  std::swap(mapping_, o.mapping_);
  std::swap(mapped_, o.mapped_);
  std::swap(used_, o.used_);
  std::swap(open_, o.open_);
}

}  // namespace sculpt::sim
