// The lock-free handoffs keep their promises under real contention: nothing
// lost or reordered (ring), never a torn value (seqlock), only whole and
// ever-newer values (triple buffer).
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <thread>
#include <vector>

#include "concurrency/seqlock.hpp"
#include "concurrency/spsc_ring.hpp"
#include "concurrency/triple_buffer.hpp"

using namespace sculpt::concurrency;

TEST(SpscRing, RoundsCapacityAndRefusesWhenFull) {
  SpscRing<int> ring(5);
  EXPECT_EQ(ring.capacity(), 8u);
  for (int i = 0; i < 8; ++i) EXPECT_TRUE(ring.try_push(i));
  EXPECT_FALSE(ring.try_push(99));
  EXPECT_EQ(ring.size(), 8u);
  EXPECT_EQ(*ring.try_pop(), 0);
  EXPECT_TRUE(ring.try_push(8));
  for (int i = 1; i <= 8; ++i) EXPECT_EQ(*ring.try_pop(), i);
  EXPECT_FALSE(ring.try_pop());
  EXPECT_EQ(ring.peek(), nullptr);
}

TEST(SpscRing, TwoThreadsLoseAndReorderNothing) {
  SpscRing<std::uint64_t> ring(64);
  constexpr std::uint64_t kCount = 200'000;
  // A full or empty ring yields: on a busy machine the other side may not
  // be running, and spinning out the time slice only waits for it longer.
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kCount;) {
      if (ring.try_push(i)) ++i;
      else std::this_thread::yield();
    }
  });
  std::uint64_t expected = 0;
  while (expected < kCount) {
    if (auto v = ring.try_pop()) {
      ASSERT_EQ(*v, expected);
      ++expected;
    } else {
      std::this_thread::yield();
    }
  }
  producer.join();
  EXPECT_FALSE(ring.try_pop());
}

struct Wide {
  std::array<std::uint64_t, 9> words;  // not a multiple of the copy unit on purpose
  std::uint32_t tail;
};

TEST(Seqlock, ReadersNeverSeeATornValue) {
  Seqlock<Wide> lock;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (std::uint64_t n = 1; n <= 100'000; ++n) {
      Wide w;
      w.words.fill(n);
      w.tail = static_cast<std::uint32_t>(n);
      lock.store(w);
    }
    done = true;
  });
  std::uint64_t last = 0;
  while (!done) {
    const Wide w = lock.load();
    for (auto x : w.words) ASSERT_EQ(x, w.words[0]);
    ASSERT_EQ(w.tail, static_cast<std::uint32_t>(w.words[0]));
    ASSERT_GE(w.words[0], last);  // never goes back in time
    last = w.words[0];
  }
  writer.join();
  EXPECT_EQ(lock.load().words[0], 100'000u);
  EXPECT_EQ(lock.version(), 100'000u);
}

TEST(TripleBuffer, ReaderGetsOnlyWholeNewerValues) {
  TripleBuffer<std::vector<int>> tb(std::vector<int>(256, 0));
  EXPECT_FALSE(tb.update());  // nothing published yet
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (int n = 1; n <= 50'000; ++n) {
      auto& back = tb.back();
      for (auto& x : back) x = n;  // same size: no reallocation on the writer
      tb.publish();
    }
    done = true;
  });
  int last = 0;
  for (;;) {
    const bool finished = done.load();
    if (tb.update()) {
      const auto& v = tb.front();
      for (int x : v) ASSERT_EQ(x, v[0]);
      ASSERT_GT(v[0], last);
      last = v[0];
    }
    if (finished && !tb.update()) break;
  }
  writer.join();
  EXPECT_EQ(last, 50'000);
}
