// PageArena: the huge-page region big bodies keep their arrays in (the
// layout test in world_test.cpp checks that they do).
#include <gtest/gtest.h>

#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>

#include "sim/page_arena.hpp"

namespace sculpt::sim {
namespace {

// The arena hands out aligned, disjoint pieces until it is full; trimming
// keeps what was handed out; a move takes the memory along.
TEST(PageArena, AlignedDisjointBoundedAndMovable) {
  PageArena a(std::size_t{1} << 20);
  ASSERT_GE(a.capacity(), std::size_t{1} << 20);
  auto* p = static_cast<char*>(a.allocate(1000, 64));
  auto* q = static_cast<char*>(a.allocate(3000, 256));
  ASSERT_NE(p, nullptr);
  ASSERT_NE(q, nullptr);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(p) % PageArena::kHugePage, 0u) << "starts on a huge page";
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(q) % 256, 0u);
  EXPECT_GE(q, p + 1000);
  EXPECT_EQ(a.allocate(a.capacity(), 64), nullptr) << "past the end";
  std::fill_n(p, 1000, 'p');
  std::fill_n(q, 3000, 'q');
  a.trim();
  EXPECT_EQ(a.capacity(), 4096u) << "trimmed to the used small pages";
  EXPECT_EQ(a.allocate(4096, 64), nullptr);
  PageArena b = std::move(a);
  EXPECT_EQ(a.capacity(), 0u);
  EXPECT_TRUE(b.contains(p) && b.contains(q + 2999));
  EXPECT_EQ(std::count(p, p + 1000, 'p') + std::count(q, q + 3000, 'q'), 4000);
  EXPECT_EQ(PageArena(0).allocate(1, 64), nullptr);
}

// sculptd --realtime locks its memory (mlockall, MCL_FUTURE): the arena's
// reservation, an upper bound, must not all become resident then; only what
// is allocated (in 2 MiB steps) does. In a child, so the test runner stays
// unlocked.
TEST(PageArena, LockedProcessPaysOnlyForWhatItUses) {
  auto resident_mb = [] {
    std::ifstream statm("/proc/self/statm");
    long size = 0, resident = 0;
    statm >> size >> resident;
    return resident * 4096 / (1 << 20);
  };
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) _exit(2);
    const long before = resident_mb();
    PageArena a(std::size_t{512} << 20);
    void* p = a.allocate(std::size_t{3} << 20, 64);
    if (!p) _exit(3);
    std::memset(p, 1, std::size_t{3} << 20);
    const long grew = resident_mb() - before;
    _exit(grew >= 3 && grew <= 8 ? 0 : 4);  // 3 MiB used: two huge pages open, not 512 MiB
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "2: mlockall refused, 3: allocation failed, 4: wrong resident growth";
}

}  // namespace
}  // namespace sculpt::sim
