// Overrun attribution: which ticks overran, whether a late wake or a long
// step was to blame (and whether a long step was off the CPU), the fixed log
// of the last few, and the thread's own kernel counters.
#include <gtest/gtest.h>

#include <sys/mman.h>

#include <chrono>
#include <thread>

#include "simloop/overrun.hpp"

namespace sculpt::simloop {
namespace {

constexpr std::int64_t kUs = 1000;
constexpr std::int64_t kPeriod = 1000 * kUs;

// A tick due at 0 that woke `late` after it and whose stages took the given times.
TickTiming tick(std::int64_t late, std::int64_t input, std::int64_t step, std::int64_t publish,
                std::uint64_t collision = 0) {
  TickTiming t;
  t.deadline = 0;
  t.wake = late;
  t.input_end = t.wake + input;
  t.step_end = t.input_end + step;
  t.publish_end = t.step_end + publish;
  t.collision_ns = collision;
  return t;
}

TEST(Overrun, IsWorkEndingAfterTheNextDeadline) {
  EXPECT_FALSE(is_overrun(tick(30 * kUs, 1 * kUs, 900 * kUs, 10 * kUs), kPeriod));
  EXPECT_FALSE(is_overrun(tick(0, 0, kPeriod, 0), kPeriod));  // ends exactly at the next deadline
  EXPECT_TRUE(is_overrun(tick(0, 0, kPeriod + 1, 0), kPeriod));
  EXPECT_TRUE(is_overrun(tick(950 * kUs, 1 * kUs, 80 * kUs, 5 * kUs), kPeriod));  // short work, late wake
  EXPECT_EQ(lateness_ns(tick(950 * kUs, 0, 0, 0)), 950 * kUs);
  TickTiming early = tick(0, 0, 100, 0);
  early.wake = -5;  // woke before its deadline: not late, and the work starts at the wake
  EXPECT_EQ(lateness_ns(early), 0);
}

TEST(Overrun, TheCauseIsWhicheverOfLatenessAndWorkWasLarger) {
  EXPECT_EQ(classify(800 * kUs, 300 * kUs), OverrunCause::late_wake);
  EXPECT_EQ(classify(100 * kUs, 950 * kUs), OverrunCause::long_step);
  EXPECT_EQ(classify(600 * kUs, 600 * kUs), OverrunCause::late_wake);  // a tie: the work did not grow
  EXPECT_STREQ(overrun_cause_name(OverrunCause::late_wake), "late_wake");
  EXPECT_STREQ(overrun_cause_name(OverrunCause::long_step), "long_step");
}

TEST(Overrun, ALongStepWasOffTheCpuWhenItsCpuTimeFallsShortOfItsWallTime) {
  EXPECT_FALSE(off_cpu(1200 * kUs, 1150 * kUs));  // computed the whole time
  EXPECT_TRUE(off_cpu(1200 * kUs, 200 * kUs));    // preempted or stolen for most of it
  EXPECT_TRUE(off_cpu(1200 * kUs, 600 * kUs));    // half of it counts
  EXPECT_FALSE(off_cpu(1200 * kUs, 5000 * kUs));  // a CPU clock ahead of the wall clock is not "off the CPU"
  EXPECT_FALSE(off_cpu(0, 0));
}

TEST(Overrun, StageTimesSplitTheStepIntoCollisionAndIntegration) {
  const auto s = stage_times_ns(tick(5 * kUs, 2 * kUs, 900 * kUs, 40 * kUs, 300 * kUs));
  EXPECT_EQ(s[0], static_cast<std::uint64_t>(2 * kUs));
  EXPECT_EQ(s[1], static_cast<std::uint64_t>(300 * kUs));
  EXPECT_EQ(s[2], static_cast<std::uint64_t>(600 * kUs));
  EXPECT_EQ(s[3], static_cast<std::uint64_t>(40 * kUs));
  // A collision clock above the whole step (a clock read out of order) is clamped to it.
  const auto c = stage_times_ns(tick(0, 0, 100, 0, 500));
  EXPECT_EQ(c[1], 100u);
  EXPECT_EQ(c[2], 0u);
}

TEST(Overrun, ARecordCarriesTheTickItsCauseAndItsCounters) {
  TickCounters c;
  c.work_cpu_ns = 1100 * kUs;
  c.minflt = 3;
  c.nivcsw = 1;
  const OverrunRecord r = make_overrun_record(4242, 1, tick(60 * kUs, 3 * kUs, 1100 * kUs, 20 * kUs, 100 * kUs), c);
  EXPECT_EQ(r.tick, 4242u);
  EXPECT_EQ(r.cpu, 1);
  EXPECT_EQ(r.cause, OverrunCause::long_step);
  EXPECT_FALSE(r.off_cpu);
  EXPECT_EQ(r.late_ns, 60 * kUs);
  EXPECT_EQ(r.stage_ns[2], static_cast<std::uint64_t>(1000 * kUs));
  EXPECT_EQ(r.counters.minflt, 3u);
  EXPECT_EQ(r.counters.nivcsw, 1u);
  // A late wake is never "off the CPU": that split is the long step's.
  c.work_cpu_ns = 0;
  const OverrunRecord late = make_overrun_record(7, 0, tick(1500 * kUs, 1 * kUs, 100 * kUs, 5 * kUs), c);
  EXPECT_EQ(late.cause, OverrunCause::late_wake);
  EXPECT_FALSE(late.off_cpu);
  const OverrunRecord stolen = make_overrun_record(8, 0, tick(10 * kUs, 1 * kUs, 1500 * kUs, 5 * kUs), c);
  EXPECT_EQ(stolen.cause, OverrunCause::long_step);
  EXPECT_TRUE(stolen.off_cpu);
}

TEST(OverrunLog, CountsEveryCauseAndKeepsTheLastEightOldestFirst) {
  OverrunLog log;
  EXPECT_TRUE(log.recent().empty());
  for (std::uint64_t i = 0; i < 11; ++i) {
    OverrunRecord r;
    r.tick = 100 + i;
    r.cause = i % 3 == 0 ? OverrunCause::long_step : OverrunCause::late_wake;
    r.off_cpu = i == 9;
    log.record(r);
  }
  EXPECT_EQ(log.total(), 11u);
  EXPECT_EQ(log.count(OverrunCause::long_step), 4u);  // i = 0, 3, 6, 9
  EXPECT_EQ(log.count(OverrunCause::late_wake), 7u);
  EXPECT_EQ(log.long_steps_off_cpu(), 1u);
  const auto recent = log.recent();
  ASSERT_EQ(recent.size(), OverrunLog::kKeep);
  for (std::size_t i = 0; i < recent.size(); ++i) {
    EXPECT_EQ(recent[i].tick, 103 + i);
    EXPECT_EQ(recent[i].index, 3 + i);
  }
}

TEST(OverrunLog, AReaderGetsWholeRecordsWhileTheWriterRuns) {
  OverrunLog log;
  std::atomic<bool> done{false};
  std::atomic<std::uint64_t> reads{0};
  std::thread writer([&] {
    for (std::uint64_t i = 0; i < 20000; ++i) {
      // Halfway, wait for the reader to have read: on a busy machine the
      // writer could otherwise finish before the reader ran at all.
      if (i == 10000)
        while (reads.load() == 0) std::this_thread::yield();
      OverrunRecord r;
      r.tick = i;
      r.late_ns = static_cast<std::int64_t>(i);  // every field of a record derives from its tick
      r.stage_ns = {i, i, i, i};
      log.record(r);
    }
    done = true;
  });
  while (!done.load()) {
    std::uint64_t last = 0;
    bool first = true;
    for (const OverrunRecord& r : log.recent()) {
      ASSERT_EQ(r.index, r.tick);
      ASSERT_EQ(static_cast<std::uint64_t>(r.late_ns), r.tick);
      ASSERT_EQ(r.stage_ns[3], r.tick);
      if (!first) {
        ASSERT_GT(r.tick, last);
      }
      last = r.tick;
      first = false;
    }
    ++reads;
  }
  writer.join();
  EXPECT_GT(reads.load(), 0u);
  EXPECT_EQ(log.recent().back().tick, 19999u);
}

TEST(ThreadCounters, SeeThisThreadsPageFaultsAndCpuTime) {
  const ThreadTotals before = thread_totals();
  const std::uint64_t cpu_before = thread_cpu_ns();
  // Fresh anonymous pages fault in on first touch.
  constexpr std::size_t kPages = 64, kPage = 4096;
  void* p = mmap(nullptr, kPages * kPage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(p, MAP_FAILED);
  auto* bytes = static_cast<volatile char*>(p);
  for (std::size_t i = 0; i < kPages; ++i) bytes[i * kPage] = 1;
  munmap(p, kPages * kPage);
  // Spinning adds CPU time as it runs: 2 ms of it shows (a preempted
  // thread takes longer, not less; the bound only catches a clock that
  // never moves).
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (thread_cpu_ns() - cpu_before < 2'000'000u && std::chrono::steady_clock::now() < give_up) {
  }
  const ThreadTotals d = thread_totals() - before;
  EXPECT_GE(d.minflt + d.majflt, kPages / 2) << "touching fresh pages counted no faults";
  EXPECT_GE(thread_cpu_ns() - cpu_before, 2'000'000u) << "30 s of spinning counted less than 2 ms of CPU time";
}

TEST(ThreadCounters, SeeThisThreadsWaitsButNotAnotherThreads) {
  // A sleep is a voluntary switch: the thread gave up its CPU to wait.
  const ThreadTotals before = thread_totals();
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  EXPECT_GE((thread_totals() - before).nvcsw, 1u);
  // Another thread's waits are not this one's.
  const ThreadTotals mid = thread_totals();
  std::thread([] { std::this_thread::sleep_for(std::chrono::milliseconds(2)); }).join();
  const std::uint64_t joined = (thread_totals() - mid).nvcsw;  // join itself may wait once
  EXPECT_LE(joined, 1u);
}

TEST(ThreadCounters, ArithmeticNeverGoesNegative) {
  ThreadTotals a, b;
  a.minflt = 5;
  b.minflt = 7;
  b.nivcsw = 3;
  b.nvcsw = 2;
  const ThreadTotals d = a - b;
  EXPECT_EQ(d.minflt, 0u);
  EXPECT_EQ(d.nivcsw, 0u);
  EXPECT_EQ(d.nvcsw, 0u);
  EXPECT_EQ((b - a).nvcsw, 2u);
  EXPECT_EQ((b - a).minflt, 2u);
}

}  // namespace
}  // namespace sculpt::simloop
