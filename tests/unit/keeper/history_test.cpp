// The history's rules, on made-up images: undo takes the newest done strokes
// and redo the oldest undone ones, a new stroke drops the redo branch once it
// changes something, the budget drops the oldest, and a reload is a wall.
#include <gtest/gtest.h>

#include "keeper/history.hpp"

namespace sculpt::daemon {
namespace {

constexpr std::size_t kImage = 64;

// One stroke on `body` changing `blocks` blocks; returns its number.
std::uint32_t stroke(History& h, std::uint32_t body, std::uint64_t tick, int blocks = 2, std::uint32_t scene = 1) {
  h.opened(scene, body, "ball", tick);
  std::vector<std::byte> image(kImage, std::byte{7});
  for (int b = 0; b < blocks; ++b) h.captured(body, static_cast<std::uint32_t>(b), 16, image);
  const std::uint32_t number = h.next_number();
  h.closed(body, sim::StrokeSummary{tick, tick + 10, tick + 20, 1});
  return number;
}

std::vector<std::uint32_t> numbers(const History::Plan& p) {
  std::vector<std::uint32_t> out;
  for (const Stroke* s : p.strokes) out.push_back(s->number);
  return out;
}

TEST(History, UndoTakesTheNewestAndRedoTheOldestUndone) {
  History h(1 << 20);
  const auto a = stroke(h, 0, 10), b = stroke(h, 1, 50), c = stroke(h, 0, 90);
  EXPECT_EQ(numbers(h.plan_undo(2, 1)), (std::vector<std::uint32_t>{c, b}));
  for (Stroke* s : h.plan_undo(2, 1).strokes) h.swapped(*s);
  EXPECT_EQ(numbers(h.plan_undo(5, 1)), (std::vector<std::uint32_t>{a}));
  EXPECT_EQ(numbers(h.plan_redo(5, 1)), (std::vector<std::uint32_t>{b, c}));
  for (Stroke* s : h.plan_redo(1, 1).strokes) h.swapped(*s);
  EXPECT_EQ(numbers(h.plan_redo(5, 1)), (std::vector<std::uint32_t>{c}));
  EXPECT_EQ(h.plan_redo(0, 1).error, "nothing to redo");
}

TEST(History, NothingToUndoSaysSo) {
  History h(1 << 20);
  EXPECT_EQ(h.plan_undo(1, 1).error, "nothing to undo");
  EXPECT_EQ(h.plan_redo(1, 1).error, "nothing to redo");
}

TEST(History, AStrokeThatChangesNothingIsNotKept) {
  History h(1 << 20);
  h.opened(1, 0, "ball", 5);
  h.closed(0, sim::StrokeSummary{5, 6, 7, 1});
  EXPECT_TRUE(h.strokes().empty());
}

TEST(History, ANewStrokeDropsTheRedoBranchOnceItChangesSomething) {
  History h(1 << 20);
  stroke(h, 0, 10);
  const auto b = stroke(h, 0, 50);
  for (Stroke* s : h.plan_undo(1, 1).strokes) h.swapped(*s);
  h.opened(1, 0, "ball", 80);  // a tool comes near: nothing changed yet
  EXPECT_EQ(numbers(h.plan_redo(1, 1)), (std::vector<std::uint32_t>{b}));
  std::vector<std::byte> image(kImage);
  h.captured(0, 3, 16, image);  // now it changes a block
  EXPECT_EQ(h.plan_redo(1, 1).error, "nothing to redo");
  EXPECT_EQ(h.take_gone(), (std::vector<std::uint32_t>{b}));
}

TEST(History, TheBudgetDropsTheOldestFirst) {
  const std::uint64_t one = [] {
    History probe(1 << 20);
    stroke(probe, 0, 1);
    return probe.used();
  }();
  History h(3 * one);
  const auto a = stroke(h, 0, 10);
  stroke(h, 0, 20), stroke(h, 0, 30);
  EXPECT_EQ(h.strokes().size(), 3u);
  stroke(h, 0, 40);
  ASSERT_EQ(h.strokes().size(), 3u);
  EXPECT_NE(h.strokes().front().number, a);
  EXPECT_EQ(h.dropped(), 1u);
  EXPECT_LE(h.used(), h.budget());
  History none(0);
  stroke(none, 0, 10);
  EXPECT_TRUE(none.strokes().empty());
  EXPECT_EQ(none.dropped(), 1u);
}

TEST(History, UndoStopsAtASceneReload) {
  History h(1 << 20);
  const auto old = stroke(h, 0, 10, 2, /*scene=*/1);
  const auto now = stroke(h, 0, 50, 2, /*scene=*/2);
  EXPECT_EQ(numbers(h.plan_undo(5, 2)), (std::vector<std::uint32_t>{now}));
  for (Stroke* s : h.plan_undo(1, 2).strokes) h.swapped(*s);
  const History::Plan p = h.plan_undo(1, 2);
  EXPECT_TRUE(p.strokes.empty());
  EXPECT_NE(p.error.find("stroke " + std::to_string(old)), std::string::npos) << p.error;
  EXPECT_NE(p.error.find("reload"), std::string::npos) << p.error;
}

TEST(History, ImagesAndVerticesAddUp) {
  History h(1 << 20);
  stroke(h, 0, 10, 3);
  const Stroke& s = h.strokes().front();
  EXPECT_EQ(s.blocks.size(), 3u);
  EXPECT_EQ(s.images.size(), 3 * kImage);
  EXPECT_EQ(s.image_bytes, kImage);
  EXPECT_EQ(s.vertices, 48u);
  EXPECT_EQ(s.summary.release_tick, 20u);
}

}  // namespace
}  // namespace sculpt::daemon
