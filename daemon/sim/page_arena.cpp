#include "sim/page_arena.hpp"

#include <sys/mman.h>

#include <cstdint>
#include <utility>

namespace sculpt::sim {

PageArena::PageArena(std::size_t capacity) {
  if (capacity == 0) return;
  const std::size_t size = (capacity + kHugePage - 1) / kHugePage * kHugePage;
  // One extra huge page of address space so the usable part can start on a
  // huge-page boundary (only touched pages ever take memory).
  void* m = ::mmap(nullptr, size + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE,
                   -1, 0);
  if (m == MAP_FAILED) return;
  mapping_ = static_cast<char*>(m);
  mapped_ = size + kHugePage;
  const auto addr = reinterpret_cast<std::uintptr_t>(m);
  base_ = mapping_ + ((kHugePage - addr % kHugePage) % kHugePage);
  capacity_ = size;
#ifdef MADV_HUGEPAGE
  huge_ = ::madvise(base_, capacity_, MADV_HUGEPAGE) == 0;  // THP "never" or no THP: small pages, same results
#endif
}

PageArena::~PageArena() {
  if (mapping_) ::munmap(mapping_, mapped_);
}

void* PageArena::allocate(std::size_t bytes, std::size_t alignment) {
  const std::size_t start = (used_ + alignment - 1) / alignment * alignment;
  if (!base_ || start > capacity_ || bytes > capacity_ - start) return nullptr;
  used_ = start + bytes;
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
}

void PageArena::swap(PageArena& o) noexcept {
  std::swap(base_, o.base_);
  std::swap(capacity_, o.capacity_);
  std::swap(mapping_, o.mapping_);
  std::swap(mapped_, o.mapped_);
  std::swap(used_, o.used_);
  std::swap(huge_, o.huge_);
}

}  // namespace sculpt::sim
