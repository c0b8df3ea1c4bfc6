// Pacing decisions with the time passed in: uploads only on a real change and
// never more often than the interval; onsets are merged, never lost.
#include <gtest/gtest.h>

#include "haptics/pacer.hpp"

namespace sculpt::haptics {
namespace {

using namespace std::chrono_literals;
const Clock::time_point t0{};
const ChangeThreshold kThreshold{256, 0x200};

TEST(ConstantPacer, FirstCommandGoesOutAtOnce) {
  ConstantPacer p(25ms, kThreshold);
  EXPECT_TRUE(p.should_send({0, 0}, t0));
  EXPECT_TRUE(p.should_send({5000, 0x4000}, t0));
}

TEST(ConstantPacer, OnlyARealChangeIsSent) {
  ConstantPacer p(25ms, kThreshold);
  p.sent({5000, 0x4000}, t0);
  EXPECT_FALSE(p.should_send({5000, 0x4000}, t0 + 1s));   // same
  EXPECT_FALSE(p.should_send({5100, 0x4010}, t0 + 1s));   // below both steps
  EXPECT_TRUE(p.should_send({5300, 0x4000}, t0 + 1s));    // level step
  EXPECT_TRUE(p.should_send({5000, 0x4400}, t0 + 1s));    // direction step
  EXPECT_TRUE(p.should_send({0, 0}, t0 + 1s));            // released
}

TEST(ConstantPacer, NoMoreOftenThanTheInterval) {
  ConstantPacer p(25ms, kThreshold);
  p.sent({5000, 0x4000}, t0);
  EXPECT_FALSE(p.should_send({20000, 0x8000}, t0 + 1ms));
  EXPECT_FALSE(p.should_send({20000, 0x8000}, t0 + 24ms));
  EXPECT_TRUE(p.should_send({20000, 0x8000}, t0 + 25ms));
}

TEST(ConstantPacer, AWaitingChangeIsNotLost) {
  // The force jumps, then stays: it is sent once the interval has passed.
  ConstantPacer p(25ms, kThreshold);
  p.sent({5000, 0x4000}, t0);
  for (auto t = 1ms; t < 25ms; t += 4ms) EXPECT_FALSE(p.should_send({9000, 0x4000}, t0 + t));
  EXPECT_TRUE(p.should_send({9000, 0x4000}, t0 + 28ms));
  p.sent({9000, 0x4000}, t0 + 28ms);
  EXPECT_EQ(p.last_sent(), (ConstantCommand{9000, 0x4000}));
  EXPECT_FALSE(p.should_send({9000, 0x4000}, t0 + 1s));
}

TEST(ConstantPacer, ManyUpdatesBoundedByTheInterval) {
  // 10 000 polls of a force that changes every poll (4 ms apart): at most one
  // upload per 25 ms.
  ConstantPacer p(25ms, kThreshold);
  int sends = 0;
  for (int i = 0; i < 10000; ++i) {
    const auto now = t0 + i * 4ms;
    const ConstantCommand want{static_cast<std::int16_t>((i % 2) ? 30000 : 1000), 0x4000};
    if (p.should_send(want, now)) {
      p.sent(want, now);
      ++sends;
    }
  }
  EXPECT_LE(sends, 40000 / 25 + 1);
  EXPECT_GE(sends, 40000 / 28);  // and it does keep up
}

TEST(ConstantPacer, FailureRetriesAfterTheIntervalEvenUnchanged) {
  ConstantPacer p(25ms, kThreshold);
  p.failed(t0);
  EXPECT_FALSE(p.should_send({5000, 0x4000}, t0 + 10ms));
  EXPECT_TRUE(p.should_send({5000, 0x4000}, t0 + 25ms));
}

TEST(ConstantPacer, ResetSendsTheNextCommandAtOnce) {
  ConstantPacer p(25ms, kThreshold);
  p.sent({5000, 0x4000}, t0);
  p.reset();
  EXPECT_TRUE(p.should_send({5000, 0x4000}, t0 + 1ms));
}

TEST(KickPacer, OnsetKicksAtOnceThenWaitsTheInterval) {
  KickPacer k(25ms);
  EXPECT_FALSE(k.due(t0));
  k.onset(0.01);
  EXPECT_TRUE(k.due(t0));
  EXPECT_DOUBLE_EQ(k.pending_impulse(), 0.01);
  k.kicked(t0);
  EXPECT_FALSE(k.due(t0 + 1ms));
  k.onset(0.002);
  k.onset(0.005);
  k.onset(0.001);
  EXPECT_FALSE(k.due(t0 + 24ms));
  EXPECT_TRUE(k.due(t0 + 25ms));
  EXPECT_DOUBLE_EQ(k.pending_impulse(), 0.005);  // merged: the largest
  k.kicked(t0 + 25ms);
  EXPECT_FALSE(k.due(t0 + 1s));                  // nothing pending
}

}  // namespace
}  // namespace sculpt::haptics
