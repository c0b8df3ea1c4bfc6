// Overrun attribution: which ticks overran, whether a late wake or a long
// step was to blame (and, within that, what the thread's counters say), the
// fixed log of the last few, and the thread's own kernel counters.
#include <gtest/gtest.h>

#include <sys/mman.h>

#include <chrono>
#include <thread>

#include "loop/overrun.hpp"

namespace sculpt::loop {
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

TEST(Overrun, ALateWakeWaitedForTheCpuOnlyWhenItsRunDelaySaysSo) {
  TickCounters c;
  c.run_delay_ns = 700 * kUs;  // woken in time, then runnable behind another task
  EXPECT_EQ(classify_detail(OverrunCause::late_wake, 1200 * kUs, 100 * kUs, c), OverrunDetail::wake_waited_for_cpu);
  c.run_delay_ns = 10 * kUs;  // the timer itself fired late: the vCPU was away
  EXPECT_EQ(classify_detail(OverrunCause::late_wake, 1200 * kUs, 100 * kUs, c), OverrunDetail::wake_timer_late);
  EXPECT_STREQ(overrun_detail_name(OverrunDetail::wake_timer_late), "wake_timer_late");
}

TEST(Overrun, ALongStepWasOffTheCpuWhenItsCpuTimeFallsShortOfItsWallTime) {
  TickCounters c;
  c.work_cpu_ns = 1150 * kUs;  // computed the whole time
  EXPECT_EQ(classify_detail(OverrunCause::long_step, 20 * kUs, 1200 * kUs, c), OverrunDetail::step_on_cpu);
  c.work_cpu_ns = 200 * kUs;  // preempted or stolen for most of it
  EXPECT_EQ(classify_detail(OverrunCause::long_step, 20 * kUs, 1200 * kUs, c), OverrunDetail::step_off_cpu);
  c.work_cpu_ns = 5000 * kUs;  // a CPU clock ahead of the wall clock is not "off the CPU"
  EXPECT_EQ(classify_detail(OverrunCause::long_step, 20 * kUs, 1200 * kUs, c), OverrunDetail::step_on_cpu);
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
  EXPECT_EQ(r.detail, OverrunDetail::step_on_cpu);
  EXPECT_EQ(r.late_ns, 60 * kUs);
  EXPECT_EQ(r.stage_ns[2], static_cast<std::uint64_t>(1000 * kUs));
  EXPECT_EQ(r.counters.minflt, 3u);
  EXPECT_EQ(r.counters.nivcsw, 1u);
}

TEST(OverrunLog, CountsEveryCauseAndKeepsTheLastEightOldestFirst) {
  OverrunLog log;
  EXPECT_TRUE(log.recent().empty());
  for (std::uint64_t i = 0; i < 11; ++i) {
    OverrunRecord r;
    r.tick = 100 + i;
    r.cause = i % 3 == 0 ? OverrunCause::long_step : OverrunCause::late_wake;
    r.detail = i % 3 == 0 ? OverrunDetail::step_on_cpu : OverrunDetail::wake_timer_late;
    log.record(r);
  }
  EXPECT_EQ(log.total(), 11u);
  EXPECT_EQ(log.count(OverrunCause::long_step), 4u);  // i = 0, 3, 6, 9
  EXPECT_EQ(log.count(OverrunCause::late_wake), 7u);
  EXPECT_EQ(log.count(OverrunDetail::step_on_cpu), 4u);
  EXPECT_EQ(log.count(OverrunDetail::wake_waited_for_cpu), 0u);
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
  std::thread writer([&] {
    for (std::uint64_t i = 0; i < 20000; ++i) {
      OverrunRecord r;
      r.tick = i;
      r.late_ns = static_cast<std::int64_t>(i);  // every field of a record derives from its tick
      r.stage_ns = {i, i, i, i};
      log.record(r);
    }
    done = true;
  });
  std::uint64_t reads = 0;
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
  EXPECT_GT(reads, 0u);
  EXPECT_EQ(log.recent().back().tick, 19999u);
}

TEST(ThreadProbe, SeesThisThreadsPageFaultsAndCpuTime) {
  const ThreadProbe probe;
  const TickCounters before = probe.totals();
  const std::uint64_t cpu_before = ThreadProbe::cpu_ns();
  // Fresh anonymous pages fault in on first touch.
  constexpr std::size_t kPages = 64, kPage = 4096;
  void* p = mmap(nullptr, kPages * kPage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(p, MAP_FAILED);
  auto* bytes = static_cast<volatile char*>(p);
  for (std::size_t i = 0; i < kPages; ++i) bytes[i * kPage] = 1;
  munmap(p, kPages * kPage);
  const auto spin_until = std::chrono::steady_clock::now() + std::chrono::milliseconds(5);
  while (std::chrono::steady_clock::now() < spin_until) {
  }
  const TickCounters d = probe.totals() - before;
  EXPECT_GE(d.minflt + d.majflt, kPages / 2) << "touching fresh pages counted no faults";
  EXPECT_GT(ThreadProbe::cpu_ns() - cpu_before, 1'000'000u) << "5 ms of spinning used no CPU time";
  if (probe.has_run_delay()) {
    EXPECT_GE(probe.totals().run_delay_ns, before.run_delay_ns);  // cumulative
  }
}

TEST(ThreadProbe, CounterArithmeticNeverGoesNegative) {
  TickCounters a, b;
  a.minflt = 5;
  b.minflt = 7;
  b.run_delay_ns = 3;
  const TickCounters d = a - b;
  EXPECT_EQ(d.minflt, 0u);
  EXPECT_EQ(d.run_delay_ns, 0u);
  EXPECT_EQ((b - a).minflt, 2u);
}

}  // namespace
}  // namespace sculpt::loop
