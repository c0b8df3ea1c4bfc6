// The sim → haptics handoff: latest force per tool, onsets counted so none is
// missed between polls, publish without allocation, consistent reads while
// the writer runs.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "haptics/feedback_board.hpp"
#include "support/allocation_counter.hpp"

namespace sculpt::haptics {
namespace {

Felt feedback(double fx, double fy, double fz, std::uint32_t contacts, bool onset = false,
                           double impulse = 0) {
  Felt f;
  f.force = {fx, fy, fz};
  f.contacts = contacts;
  f.touching = contacts > 0;
  f.onset = onset;
  f.onset_impulse = impulse;
  return f;
}

TEST(FeedbackBoard, LatestForcePerTool) {
  FeedbackBoard board(2);
  EXPECT_EQ(board.tools(), 2);
  board.publish(0, feedback(1, 2, 3, 4));
  board.publish(1, feedback(-1, 0, 0, 1));
  board.publish(0, feedback(5, 6, 7, 8));
  const ToolForce a = board.read(0);
  EXPECT_EQ(a.force, (std::array<double, 3>{5, 6, 7}));
  EXPECT_EQ(a.contacts, 8u);
  EXPECT_EQ(a.ticks, 2u);
  EXPECT_EQ(board.read(1).force[0], -1);
}

TEST(FeedbackBoard, OnsetsAreCountedSoNoneIsMissedBetweenPolls) {
  FeedbackBoard board(1);
  board.publish(0, feedback(0, 0, 1, 3, true, 0.004));
  board.publish(0, feedback(0, 0, 0, 0));
  board.publish(0, feedback(0, 0, 1, 2, true, 0.007));
  board.publish(0, feedback(0, 0, 0, 0));
  // A poll now sees no force, but two onsets and the latest impulse.
  const ToolForce f = board.read(0);
  EXPECT_EQ(f.onsets, 2u);
  EXPECT_DOUBLE_EQ(f.last_onset_impulse, 0.007);
  EXPECT_EQ(f.contacts, 0u);
}

TEST(FeedbackBoard, ClearZeroesTheForceKeepsTheCounters) {
  FeedbackBoard board(1);
  board.publish(0, feedback(1, 1, 1, 5, true, 0.01));
  board.clear(0);
  const ToolForce f = board.read(0);
  EXPECT_EQ(f.force, (std::array<double, 3>{0, 0, 0}));
  EXPECT_EQ(f.contacts, 0u);
  EXPECT_EQ(f.onsets, 1u);
}

TEST(FeedbackBoard, OutOfRangeToolsAreIgnored) {
  FeedbackBoard board(1);
  board.publish(-1, feedback(1, 1, 1, 1));
  board.publish(1, feedback(1, 1, 1, 1));
  board.clear(7);
  EXPECT_EQ(board.read(5).ticks, 0u);
  EXPECT_EQ(board.read(0).ticks, 0u);
}

TEST(FeedbackBoard, PublishDoesNotAllocate) {
  FeedbackBoard board(4);
  sculpt::support::reset_counted_allocations();
  sculpt::support::count_allocations_on_this_thread(true);
  for (int i = 0; i < 10000; ++i) board.publish(i % 4, feedback(i, -i, 0.5, 1, i % 7 == 0, 0.001));
  sculpt::support::count_allocations_on_this_thread(false);
  EXPECT_EQ(sculpt::support::counted_allocations(), 0);
}

TEST(FeedbackBoard, ReadersNeverSeeATornValue) {
  // The writer keeps force = (k, −k, 2k) and contacts = k: a reader must only
  // ever see values that satisfy that.
  FeedbackBoard board(1);
  std::atomic<bool> reading{false}, done{false};
  std::thread writer([&] {
    while (!reading.load()) std::this_thread::yield();  // overlap with the reader for sure
    for (std::uint32_t k = 1; k <= 200000; ++k) board.publish(0, feedback(k, -double(k), 2.0 * k, k));
    done = true;
  });
  reading = true;
  long torn = 0;
  do {
    const ToolForce f = board.read(0);
    torn += f.force[0] != double(f.contacts) || f.force[1] != -double(f.contacts) ||
            f.force[2] != 2.0 * f.contacts || f.ticks != f.contacts;
  } while (!done.load());
  writer.join();
  EXPECT_EQ(torn, 0);
  EXPECT_EQ(board.read(0).contacts, 200000u);
}

}  // namespace
}  // namespace sculpt::haptics
