// ReplayFeed reads a recording on its own thread and hands over exactly what
// ReplaySource gives, in order; a bad line later in the file is an error
// after everything before it, never a lost or reordered frame.
#include <fstream>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "input/replay_feed.hpp"
#include "test_devices.hpp"

namespace sculpt::input {
namespace {

std::filesystem::path long_recording(const std::string& name, int frames) {
  Recording s;
  s.header.devices = {testing::gamepad(), testing::flight_stick()};
  for (int i = 0; i < frames; ++i)
    s.frames.push_back({i * 700, static_cast<std::uint32_t>(i % 2), {{EV_ABS, ABS_X, i}, {EV_ABS, ABS_Y, -i}}});
  const auto p = testing::temp_file(name);
  write_recording(p, s);
  return p;
}

// Everything after the attaches, straight from the source.
std::vector<InputMessage> direct(const std::filesystem::path& file) {
  ReplaySource src(file, 1000.0, {});
  src.start(1);
  std::vector<InputMessage> out;
  while (auto m = src.next())
    if (m->kind == MessageKind::frame) out.push_back(*m);
  return out;
}

// Drains `feed` through a small ring, as the io thread does, until it is finished.
std::vector<InputMessage> drain(ReplayFeed& feed, std::size_t ring_size) {
  concurrency::SpscRing<InputMessage> ring(ring_size);
  std::vector<InputMessage> out;
  for (int idle = 0; !feed.finished();) {
    feed.pump(ring);
    bool any = false;
    while (auto m = ring.try_pop()) out.push_back(*m), any = true;
    if (!any && ++idle % 64 == 0) std::this_thread::yield();
  }
  return out;
}

void expect_same(const std::vector<InputMessage>& got, const std::vector<InputMessage>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) {
    ASSERT_EQ(got[i].kind, want[i].kind) << i;
    ASSERT_EQ(got[i].at_tick, want[i].at_tick) << i;
    ASSERT_EQ(got[i].slot, want[i].slot) << i;
    ASSERT_EQ(got[i].frame.count, want[i].frame.count) << i;
    for (std::size_t e = 0; e < want[i].frame.count; ++e)
      ASSERT_EQ(got[i].frame.events[e].value, want[i].frame.events[e].value) << i;
  }
}

ReplaySource after_attaches(const std::filesystem::path& file) {
  ReplaySource src(file, 1000.0, {});
  src.start(1);
  for (std::size_t d = 0; d < src.header().devices.size(); ++d) EXPECT_EQ(src.next()->kind, MessageKind::attach);
  return src;
}

TEST(ReplayFeed, HandsOverExactlyWhatTheSourceGivesInOrder) {
  const auto file = long_recording("feed_long.jsonl", 20000);
  ReplayFeed feed(after_attaches(file), 64);
  EXPECT_EQ(feed.header().devices.size(), 2u);
  expect_same(drain(feed, 16), direct(file));
  EXPECT_EQ(feed.error(), std::nullopt);
}

TEST(ReplayFeed, TheFirstMessagesAreReadBeforeItReturns) {
  const auto file = long_recording("feed_first.jsonl", 1000);
  ReplayFeed feed(after_attaches(file), 256);
  concurrency::SpscRing<InputMessage> ring(512);
  // No waiting: the constructor read them.
  EXPECT_GE(feed.pump(ring), 256u);
}

TEST(ReplayFeed, PumpLeavesTheSlotsItIsAskedToKeepFree) {
  const auto file = long_recording("feed_keep_free.jsonl", 1000);
  ReplayFeed feed(after_attaches(file), 256);
  concurrency::SpscRing<InputMessage> ring(64);
  EXPECT_EQ(feed.pump(ring, 8), 56u);
  EXPECT_EQ(ring.size(), 56u);
  EXPECT_EQ(feed.pump(ring, 8), 0u) << "no room beyond what is kept free";
  for (int i = 0; i < 8; ++i) EXPECT_TRUE(ring.try_push(InputMessage::detach(0))) << "the kept slots are there";
}

TEST(ReplayFeed, AShortRecordingIsFinishedWithoutAThread) {
  const auto file = long_recording("feed_short.jsonl", 10);
  ReplayFeed feed(after_attaches(file), 64);
  concurrency::SpscRing<InputMessage> ring(64);
  EXPECT_EQ(feed.pump(ring), 10u);
  EXPECT_TRUE(feed.finished());
}

TEST(ReplayFeed, ABadLineLaterIsAnErrorAfterEverythingBeforeIt) {
  const auto file = long_recording("feed_bad.jsonl", 5000);
  const std::vector<InputMessage> good = direct(file);
  {
    std::ofstream out(file, std::ios::app);
    out << "{\"t_us\": \"soon\"}\n";
  }
  ReplayFeed feed(after_attaches(file), 64);
  expect_same(drain(feed, 16), good);
  const auto error = feed.error();
  ASSERT_TRUE(error.has_value());
  EXPECT_NE(error->find(":5002"), std::string::npos) << *error;  // the header, 5000 frames, then this line
}

TEST(ReplayFeed, StopsWhileItsReaderWaitsOnAFullRing) {
  const auto file = long_recording("feed_stop.jsonl", 20000);
  ReplayFeed feed(after_attaches(file), 8);
  concurrency::SpscRing<InputMessage> ring(4);
  feed.pump(ring);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // the reader fills its ring and waits
  // The destructor must wake and join it (the test's time limit catches a hang).
}

}  // namespace
}  // namespace sculpt::input
