// Strokes and block images (sim/strokes.hpp, World::exchange_block_image): a stroke
// captures every block it changes before the change (checked against
// World::state() taken apart by block, not against the images), exchanging
// the images back gives the body as it was when the stroke opened, on every
// step path; exchanging twice changes nothing; a world undone and redone, or
// undone and sculpted on, steps on as one that never was; a sink changes no
// result.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "block_images.hpp"
#include "sim/clay.hpp"
#include "sim/stroke_recorder.hpp"
#include "sim/kernel_testing.hpp"
#include "sim/shapes.hpp"
#include "sim/stability.hpp"
#include "sim/world.hpp"
#include "test_meshes.hpp"

namespace sculpt::sim {
namespace {

struct Case {
  const char* name;
  Integrator integrator = Integrator::position_verlet;
  bool clay = false;
  ForceModel model = ForceModel::spring;
  PackedRecords records = PackedRecords::by_size;
  bool ring = true;
  bool portable = false;
};

const Case kCases[] = {
    {.name = "elastic (ring)"},
    {.name = "clay (records)", .clay = true},
    {.name = "clay (arrays)", .clay = true, .records = PackedRecords::never},
    {.name = "velocity verlet clay", .integrator = Integrator::velocity_verlet, .clay = true},
    {.name = "elastic (records)", .records = PackedRecords::always},
    {.name = "elastic (arrays)", .records = PackedRecords::never, .ring = false},
    {.name = "symplectic euler clay", .integrator = Integrator::symplectic_euler, .clay = true},
    {.name = "linear clay", .clay = true, .model = ForceModel::linear},
    {.name = "portable kernels, elastic", .portable = true},
    {.name = "portable kernels, clay", .clay = true, .portable = true},
};
// The sanitized build checks memory and undefined behaviour, not the paths
// again: the first four (every step path, both velocity kinds) do.
const std::span<const Case> kRunCases(kCases, test::kSanitized ? 4 : std::size(kCases));

// A sphere pressed by tool 0 and a torus pushed, grabbed and
// pulled by tool 1, as in sim_state. The sanitized build's sphere has 642
// vertices, not 2 562: six blocks (one partial) instead of 21, both far below
// the ring's 64 and with no far springs, so every case takes the same step
// path.
template <class S>
void add_scene(World<S>& w, const Case& c) {
  Material m;
  m.plastic = c.clay;
  m.model = c.model;
  m.damping = m.anchor_damping = 0.2;  // at rest sooner
  BodyOptions o;
  o.packed = c.records;
  o.ring = c.ring;
  o.max_grabbed = 512;  // a smaller state to take apart every tick
  w.add_body(make_icosphere(0.1f, test::kSanitized ? 3 : 4), m, o);
  // Pins hold the elastic torus; clay's would keep it awake for ever (its
  // rest shape yields away from them, so they pull on it), and no stroke of it
  // would close at rest.
  BodyOptions pinned = o;
  if (!c.clay) pinned.pinned = {0, 1, 2, 3};
  w.add_body(make_torus(0.3f, 0.05f, 48, 16), m, pinned);
}

// Most ticks here wait for a world to sleep, so its strokes close. Sanitized,
// it sleeps below 1 mm/s, not 0.1: the same sleeping, waking and closing at
// rest, in fewer ticks.
SimSettings settings(Integrator integrator = Integrator::position_verlet) {
  SimSettings s;
  s.integrator = integrator;
  if (test::kSanitized) s.sleep_speed = 1e-3;
  return s;
}

template <class S>
std::unique_ptr<World<S>> make_world(const Case& c) {
  const SimSettings s = settings(c.integrator);
  auto w = std::make_unique<World<S>>(s, 2);
  add_scene(*w, c);
  return w;
}

Tool inactive() { return Tool{.active = false}; }

// Tool 0: presses 25 mm into the sphere's top, lifts off, comes back for a
// light touch before the sphere is still (the next onset after a release),
// and leaves. Tool 1: on the torus from the start, grabs at 40, lets go at
// 140, leaves at 160.
std::vector<Tool> stroke_script(int tick) {
  Tool press;
  press.radius = 0.02;
  if (tick < 200) press.position = {0.004 * std::sin(tick * 0.05), 0.14 - 0.045 * std::min(tick, 150) / 150.0, 0.0};
  else if (tick < 230) press.position = {0.0, 0.095 + 0.1 * (tick - 200) / 30.0, 0.0};
  else if (tick >= 240 && tick < 270) press.position = {0.0, 0.125 - 0.01 * (tick - 240) / 30.0, 0.0};
  else press = inactive();
  Tool grab;
  grab.radius = 0.03;
  grab.position = {0.3, 0.05 + 0.02 * std::max(0, tick - 50) / 100.0, 0.0};
  grab.grab = tick >= 40 && tick < 140;
  if (tick >= 160) grab = inactive();
  return {press, grab};
}

// Drives a world with a KeepingSink and checks each stroke as it closes:
// every block it did not capture has the bytes it had before the onset.
template <class S>
class Recorder {
 public:
  explicit Recorder(World<S>& w) : w_(w), sink_(w.body_count()), cur_(w.state()) { w_.set_stroke_sink(&sink_); }
  ~Recorder() { w_.set_stroke_sink(nullptr); }

  void step(std::span<const Tool> tools) {
    const std::vector<bool> closed = closed_now();
    prev_ = std::move(cur_);
    w_.step(tools);
    cur_ = w_.state();
    for (std::size_t k = closed.size(); k < sink_.strokes.size(); ++k) {  // opened this tick: the onset was before it
      EXPECT_EQ(sink_.strokes[k].summary.first_tick, w_.tick());
      onsets_.push_back(test::split_state<S>(prev_)[sink_.strokes[k].body]);
    }
    check_newly_closed(closed);
  }
  void close_strokes() {
    const std::vector<bool> closed = closed_now();
    w_.close_strokes();
    cur_ = w_.state();
    check_newly_closed(closed);
  }
  // Undoes strokes [first, end), newest first: after each, its body is as at its onset.
  void undo_all(const std::string& name, std::size_t first = 0) {
    for (std::size_t k = sink_.strokes.size(); k-- > first;) {
      test::RecordedStroke& e = sink_.strokes[k];
      for (std::size_t q = 0; q < e.blocks.size(); ++q) w_.exchange_block_image(e.body, e.blocks[q], e.images[q]);
      const test::BodyBytes now = test::split_state<S>(w_.state())[e.body];
      for (std::size_t blk = 0; blk < now.blocks.size(); ++blk)
        EXPECT_TRUE(now.blocks[blk] == onsets_[k].blocks[blk]) << name << ": stroke " << k << ", block " << blk;
      EXPECT_TRUE(now.derived == onsets_[k].derived) << name << ": stroke " << k << ": the awake count or the box";
    }
  }
  void redo_all() {
    for (test::RecordedStroke& e : sink_.strokes)
      for (std::size_t q = 0; q < e.blocks.size(); ++q) w_.exchange_block_image(e.body, e.blocks[q], e.images[q]);
  }
  std::vector<test::RecordedStroke>& strokes() { return sink_.strokes; }
  bool any_open() const { return sink_.any_open(); }

 private:
  std::vector<bool> closed_now() const {
    std::vector<bool> closed;
    for (const test::RecordedStroke& e : sink_.strokes) closed.push_back(e.closed);
    return closed;
  }
  // In the state it closed in: after the tick that closed it, or (closed by
  // the next onset) the one before.
  void check_newly_closed(const std::vector<bool>& closed_before) {
    for (std::size_t k = 0; k < sink_.strokes.size(); ++k) {
      const test::RecordedStroke& e = sink_.strokes[k];
      if (!e.closed || (k < closed_before.size() && closed_before[k])) continue;
      ASSERT_TRUE(e.summary.last_tick == w_.tick() || e.summary.last_tick + 1 == w_.tick());
      const test::BodyBytes now = test::split_state<S>(e.summary.last_tick == w_.tick() ? cur_ : prev_)[e.body];
      std::vector<bool> captured(now.blocks.size());
      for (std::uint32_t blk : e.blocks) captured.at(blk) = true;
      for (std::size_t blk = 0; blk < now.blocks.size(); ++blk)
        if (!captured[blk]) {
          EXPECT_TRUE(now.blocks[blk] == onsets_[k].blocks[blk]) << "stroke " << k << ": block " << blk << " changed uncaptured";
        }
      EXPECT_FALSE(e.blocks.empty()) << "stroke " << k << " captured nothing";
    }
  }

  World<S>& w_;
  test::KeepingSink sink_;
  std::vector<std::byte> prev_, cur_;
  std::vector<test::BodyBytes> onsets_;  // per stroke
};

template <class S>
bool at_rest(const World<S>& w) {
  for (std::size_t b = 0; b < w.body_count(); ++b)
    if (w.body(b).awake_blocks > 0) return false;
  return true;
}

// A stroke for afterwards: tool 0 presses the sphere's side.
std::vector<Tool> side_press(int tick) {
  Tool t;
  t.radius = 0.015;
  t.position = {0.13 - 0.04 * std::min(tick, 100) / 100.0, 0.02, 0.01};
  return {t};
}

template <class S>
void record_undo_redo(const Case& c) {
  const std::optional<kernel::testing::ScopedPortable> portable =
      c.portable ? std::optional<kernel::testing::ScopedPortable>(std::in_place, true) : std::nullopt;
  const auto world = make_world<S>(c), twin = make_world<S>(c);  // the twin has no sink
  World<S>& w = *world;
  Recorder<S> rec(w);
  int tick = 0;
  for (; tick < 300 || (rec.any_open() && tick < 8000); ++tick) {
    rec.step(stroke_script(tick));
    twin->step(stroke_script(tick));
    ASSERT_EQ(w.hash(), twin->hash()) << c.name << ": a sink changes nothing (tick " << tick << ")";
  }
  ASSERT_FALSE(rec.any_open()) << c.name << ": every stroke closes at rest";
  ASSERT_TRUE(at_rest(w)) << c.name;
  EXPECT_TRUE(twin->state() == w.state()) << c.name << ": a sink changes nothing";
  std::vector<test::RecordedStroke>& strokes = rec.strokes();
  // The sphere's: pressed, released, touched again before it was still.
  std::vector<const test::RecordedStroke*> sphere;
  for (const auto& e : strokes)
    if (e.body == 0) sphere.push_back(&e);
  ASSERT_EQ(sphere.size(), 2u) << c.name;
  EXPECT_GT(sphere[0]->summary.release_tick, sphere[0]->summary.first_tick) << c.name;
  EXPECT_EQ(sphere[1]->summary.first_tick, sphere[0]->summary.last_tick + 1) << c.name << ": closed by the next onset";
  EXPECT_EQ(sphere[0]->summary.tools, 1u) << c.name;
  EXPECT_GT(strokes.size(), sphere.size()) << c.name << ": the torus's too";

  const std::vector<std::byte> before = w.state();
  rec.undo_all(c.name);
  rec.redo_all();
  EXPECT_TRUE(w.state() == before) << c.name << ": undo then redo is the identity";
  // At rest before, so it steps on as the twin, which never undid anything.
  for (int t = 0; t < 150; ++t) {
    rec.step(side_press(t));
    twin->step(side_press(t));
    ASSERT_EQ(w.hash(), twin->hash()) << c.name << ", tick " << t << " after the redo";
  }
  EXPECT_TRUE(twin->state() == w.state()) << c.name;
}

TEST(Strokes, UndoGivesTheOnsetBackAndRedoTheSameBitsOnEveryPath) {
  for (const Case& c : kRunCases) record_undo_redo<float>(c);
  if (!test::kSanitized) record_undo_redo<double>({.name = "double, elastic"});
  record_undo_redo<double>({.name = "double, clay", .clay = true});
}

// Tool 0 presses 20 mm into the sphere along -dir for 100 ticks, holds,
// and is gone from tick 150.
std::vector<Tool> press_along(const Vec3d& dir, int tick) {
  Tool t;
  t.radius = 0.02;
  const double d = 0.14 - 0.04 * std::min(tick, 100) / 100.0;
  t.position = {dir[0] * d, dir[1] * d, dir[2] * d};
  if (tick >= 150) t = inactive();
  return {t};
}

// Runs `stroke` until tick `min_ticks` and the world is at rest; returns the ticks.
template <class S, class F>
int until_rest(World<S>& w, F&& step, int min_ticks) {
  int t = 0;
  for (; t < min_ticks || (!at_rest(w) && t < 8000); ++t) step(t);
  EXPECT_TRUE(at_rest(w));
  return t;
}

// Stroke 1, stroke 2, undo stroke 2, stroke 3 where stroke 2 was: the same
// bits as a world that had stroke 1, nothing, then stroke 3.
template <class S>
void undo_then_sculpt(const Case& c) {
  const std::optional<kernel::testing::ScopedPortable> portable =
      c.portable ? std::optional<kernel::testing::ScopedPortable>(std::in_place, true) : std::nullopt;
  const auto world = make_world<S>(c), twin = make_world<S>(c);
  test::KeepingSink sink(world->body_count());
  world->set_stroke_sink(&sink);
  const Vec3d top{0, 1, 0}, side{0.6, 0.0, 0.8};
  until_rest(*world, [&](int t) { world->step(press_along(top, t)), twin->step(press_along(top, t)); }, 150);
  ASSERT_TRUE(twin->state() == world->state()) << c.name;
  const std::size_t first = sink.strokes.size();
  until_rest(*world, [&](int t) { world->step(press_along(side, t)), twin->step({}); }, 150);
  ASSERT_GT(sink.strokes.size(), first) << c.name;
  ASSERT_FALSE(sink.any_open()) << c.name;
  ASSERT_TRUE(at_rest(*twin)) << c.name;
  for (std::size_t k = sink.strokes.size(); k-- > first;)
    for (std::size_t q = 0; q < sink.strokes[k].blocks.size(); ++q)
      world->exchange_block_image(sink.strokes[k].body, sink.strokes[k].blocks[q], sink.strokes[k].images[q]);
  for (int t = 0; t < 400; ++t) {
    world->step(press_along(side, t));
    twin->step(press_along(side, t));
    ASSERT_EQ(world->hash(), twin->hash()) << c.name << ": tick " << t << " of the stroke after the undo";
  }
  world->set_stroke_sink(nullptr);
}

TEST(Strokes, AnUndoneWorldStepsOnAsIfTheStrokeNeverWas) {
  for (const Case& c : kRunCases) undo_then_sculpt<float>(c);
  undo_then_sculpt<double>({.name = "double, clay", .clay = true});
}

// The guard's rollback changes every block, sleeping ones too (it puts
// them back to their checkpoint and wakes them): a stroke it happens in holds
// them all.
TEST(Strokes, TheGuardsRollbackIsCaptured) {
  Material m;
  m.stiffness = 2000.0;
  SimSettings s;
  const TriangleMesh sphere = make_icosphere(0.1f, test::kSanitized ? 4 : 5);
  s.rate_hz = 1.0 / (3.0 * stability_bound(sphere, m).dt_critical);  // diverges
  s.substeps = 1;
  World<float> w(s, 1);
  w.add_body(sphere, m);
  Recorder<float> rec(w);
  bool asleep_at_blowup = false;
  for (int n = 0; n < 300; ++n) {
    Tool tool;
    tool.radius = 0.03;
    tool.position = {0.0, 0.13 - 0.02 * std::min(n, 200) / 200.0, 0.0};
    const std::uint32_t awake = w.body(0).awake_blocks;
    rec.step({&tool, 1});
    if (w.stats().blowups == 0) continue;
    ASSERT_TRUE(rec.any_open());
    asleep_at_blowup = asleep_at_blowup || awake < w.body(0).blocks;
    EXPECT_EQ(rec.strokes().back().blocks.size(), w.body(0).blocks) << "tick " << n;
  }
  EXPECT_TRUE(asleep_at_blowup) << "the guard must have rolled back blocks that slept";
  rec.close_strokes();
  rec.undo_all("rollback");
}

// A clay cone whose apex has degree 400: its springs to the rim sit in the
// overflow list of the apex's block, which a press on the rim yields.
TEST(Strokes, ClayYieldingAnOverflowSpringInASleepingBlockIsCaptured) {
  World<float> w(settings(), 1);
  const TriangleMesh cone = test::closed_cone(400);
  Material m;
  m.plastic = true;
  w.add_body(cone, m);
  ASSERT_GT(w.body(0).overflow.size(), 0u);
  Recorder<float> rec(w);
  until_rest(w, [&](int t) {
    Tool tool;
    tool.radius = 0.01;
    tool.position = {0.062 - 0.02 * std::min(t, 100) / 100.0, 0.1, 0.0};
    if (t >= 150) tool = inactive();
    rec.step({&tool, 1});
  }, 150);
  const std::vector<std::byte> before = w.state();
  rec.undo_all("cone");
  rec.redo_all();
  EXPECT_TRUE(w.state() == before);
}

// An undone block reaches the viewers in the next step's changes, asleep or
// not, and only once; the body's box is right again.
TEST(Strokes, AnExchangeIsAnOrdinaryChangeForTheViewers) {
  Material clay;
  clay.plastic = true;
  World<float> w(settings(), 1), untouched(settings(), 1);
  w.add_body(make_icosphere(0.1f, 4), clay);
  untouched.add_body(make_icosphere(0.1f, 4), clay);
  test::KeepingSink sink(1);
  w.set_stroke_sink(&sink);
  until_rest(w, [&](int t) { w.step(press_along({0, 1, 0}, t)); }, 150);
  ASSERT_EQ(sink.strokes.size(), 1u);
  ASSERT_TRUE(sink.strokes[0].closed);
  w.step({});
  EXPECT_TRUE(w.changes().empty());
  EXPECT_NE(w.hash(), untouched.hash()) << "clay keeps the dent";
  const test::RecordedStroke& e = sink.strokes[0];
  std::vector<std::vector<std::byte>> images = e.images;
  for (std::size_t q = 0; q < e.blocks.size(); ++q) w.exchange_block_image(0, e.blocks[q], images[q]);
  EXPECT_EQ(w.hash(), untouched.hash()) << "the only stroke undone: the sphere as it was built";
  EXPECT_EQ(w.body(0).lo, untouched.body(0).lo);
  EXPECT_EQ(w.body(0).hi, untouched.body(0).hi);
  EXPECT_EQ(w.body(0).awake_blocks, 0u) << "as asleep as it was";
  w.step({});
  std::vector<bool> changed(w.body(0).blocks);
  for (const ChangeRange& r : w.changes())
    for (std::uint32_t i = r.begin; i < r.end; ++i) changed[i / kernel::kBlock] = true;
  std::vector<bool> exchanged(w.body(0).blocks);
  for (std::uint32_t blk : e.blocks) exchanged[blk] = true;
  EXPECT_EQ(changed, exchanged);
  EXPECT_EQ(w.body(0).awake_blocks, 0u);
  w.step({});
  EXPECT_TRUE(w.changes().empty());
}

}  // namespace
}  // namespace sculpt::sim

namespace sculpt::sim {
namespace {

// Clay's yield writes the rest length of a spring's other end, wherever it
// is: in a block that sleeps and that the stroke has not captured (a press
// too slow to wake its neighbours, in a running world), that block is
// captured first. Driven by hand here, on one body.
TEST(Strokes, AYieldWritingASleepingBlocksRestLengthCapturesItFirst) {
  Material clay;
  clay.plastic = true;
  BodyOptions options;
  options.packed = PackedRecords::never;  // the yield test reads x itself
  Body<float> b = make_body<float>(make_icosphere(0.1f, 3), clay, options, 1);
  // A spring from block A to block B, and where its mirror lives in B's row.
  std::uint32_t i = 0, j = 0;
  std::size_t mirror = 0;
  for (std::uint32_t v = 0; v < b.n && !mirror; ++v)
    for (int s = 0; s < b.columns && !mirror; ++s) {
      const std::uint32_t u = static_cast<std::uint32_t>(static_cast<std::int32_t>(v) + b.nbr[s * b.n + v]);
      if (u / kernel::kBlock == v / kernel::kBlock) continue;
      for (int r = 0; r < b.columns; ++r)
        if (static_cast<std::int32_t>(u) + b.nbr[r * b.n + u] == static_cast<std::int32_t>(v))
          i = v, j = u, mirror = static_cast<std::size_t>(r) * b.n + u;
    }
  ASSERT_NE(mirror, 0u);
  const std::uint32_t blk_a = i / kernel::kBlock, blk_b = j / kernel::kBlock;
  test::KeepingSink sink(1);
  StrokeRecorder<float> recorder(0, b);
  recorder.set_sink(&sink);
  b.strokes = &recorder;
  b.tools[0].candidate_count = 1;  // a tool near: the stroke opens
  recorder.begin_broadphase(b);
  recorder.end_broadphase(b, 1);
  will_change(b, blk_a);  // as the tick's start captures every awake block
  ASSERT_EQ(sink.strokes.size(), 1u);
  const float rest = b.rest_length[mirror];
  b.x[i] += 0.2f * (b.x[i] - b.x[j]), b.y[i] += 0.2f * (b.y[i] - b.y[j]), b.z[i] += 0.2f * (b.z[i] - b.z[j]);
  std::vector<std::uint8_t> mask(clay_mask_bytes(b));
  yield_block(b, blk_a, mask.data());
  ASSERT_NE(b.rest_length[mirror], rest) << "the spring must have yielded";
  ASSERT_EQ(sink.strokes[0].blocks, (std::vector<std::uint32_t>{blk_a, blk_b}));
  exchange_block_state(b, recorder.layout(), blk_b, sink.strokes[0].images[1].data());
  EXPECT_EQ(b.rest_length[mirror], rest) << "B's image holds its rest length from before the yield";
  b.strokes = nullptr, b.stroke_done = nullptr;
}

// A scripted change (World::set_state) between the ticks of a stroke is the
// stroke's too: its block, and the blocks whose forces it changes. (Sanitized:
// 21 blocks, not 81; the press still leaves the far side's blocks untouched.)
TEST(Strokes, ScriptedChangesDuringAnStrokeAreCaptured) {
  World<float> w(settings(), 1);
  w.add_body(make_icosphere(0.1f, test::kSanitized ? 4 : 5), Material{});
  Recorder<float> rec(w);
  for (int t = 0; t < 60; ++t) rec.step(press_along({0, 1, 0}, t));
  ASSERT_TRUE(rec.any_open());
  // The vertex farthest from the tool, in a block the stroke has not touched.
  std::uint32_t far = 0;
  for (std::uint32_t i = 0; i < w.body(0).n; ++i)
    if (w.position(0, i)[1] < w.position(0, far)[1]) far = i;
  const std::uint32_t blk = w.body(0).to_internal[far] / kernel::kBlock;
  for (std::uint32_t captured : rec.strokes().back().blocks) ASSERT_NE(captured, blk);
  w.set_state(0, far, {0.0, -0.11, 0.0}, {0.0, -0.1, 0.0});
  until_rest(w, [&](int t) { rec.step(press_along({0, 1, 0}, 60 + t)); }, 150);
  rec.undo_all("set_state");
}

// When a stroke opens, is released and closes, against what the broadphase
// and the sleeping say; the tools it records; close_strokes mid-stroke.
TEST(Strokes, AStrokeRunsFromTheFirstToolNearToRest) {
  World<float> w(settings(), 2);
  w.add_body(make_icosphere(0.1f, 4), Material{});
  test::KeepingSink sink(1);
  w.set_stroke_sink(&sink);
  std::uint64_t near_first = 0, near_last = 0, rest = 0;
  for (int n = 0; n < 8000 && (n < 300 || sink.any_open()); ++n) {
    Tool a, b;
    a.radius = 0.02;
    a.position = {0.0, 0.3 - 0.2 * std::min(n, 200) / 200.0, 0.0};  // down from far above, then away
    if (n >= 250) a = inactive();
    b.radius = 0.01;
    b.position = {0.115, 0.0, 0.0};  // beside the sphere for a while
    if (n < 150 || n >= 200) b = inactive();
    const Tool tools[2] = {a, b};
    w.step(tools);
    if (w.stats().candidate_blocks > 0) near_last = w.tick(), near_first = near_first ? near_first : w.tick();
    if (!rest && !sink.strokes.empty() && sink.strokes[0].closed) rest = w.tick();
  }
  ASSERT_EQ(sink.strokes.size(), 1u);
  const StrokeSummary& e = sink.strokes[0].summary;
  EXPECT_GT(near_first, 1u) << "it starts far away";
  EXPECT_EQ(e.first_tick, near_first);
  EXPECT_EQ(e.release_tick, near_last + 1);
  EXPECT_EQ(e.last_tick, rest);
  EXPECT_GT(e.last_tick, e.release_tick);
  EXPECT_EQ(e.tools, 3u);
  EXPECT_EQ(w.body(0).awake_blocks, 0u);

  // Closed mid-stroke: no release; the tool still near opens the next at once.
  Tool a;
  a.radius = 0.02;
  for (int n = 0; n < 50; ++n) {
    a.position = {0.0, 0.13 - 0.0004 * n, 0.0};
    w.step({&a, 1});
  }
  ASSERT_EQ(sink.strokes.size(), 2u);
  w.close_strokes();
  EXPECT_TRUE(sink.strokes[1].closed);
  EXPECT_EQ(sink.strokes[1].summary.release_tick, 0u);
  EXPECT_EQ(sink.strokes[1].summary.last_tick, w.tick());
  w.step({&a, 1});
  ASSERT_EQ(sink.strokes.size(), 3u);
  EXPECT_EQ(sink.strokes[2].summary.first_tick, w.tick());
  w.set_stroke_sink(nullptr);  // closes it
  EXPECT_TRUE(sink.strokes[2].closed);
  w.step({&a, 1});
  EXPECT_EQ(sink.strokes.size(), 3u) << "no sink, no strokes";
}

// sim_fuzz's random and degenerate meshes, materials and tool paths
// (teleports, grab toggles, garbage input, blow-ups): every stroke's capture
// complete, each undone to its onset, and redone to the same bytes.
TEST(Strokes, RandomMeshesAndToolsCaptureEverything) {
  std::mt19937 rng(20260321);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::size_t strokes = 0, blowups = 0;
  for (int round = 0; round < 16; ++round) {
    SimSettings s;
    s.integrator = static_cast<Integrator>(round % 3);
    s.substeps = round % 4 == 0 ? 1 : 0;
    World<float> w(s, 2);
    for (int b = 0; b < 2; ++b) {
      Material m;
      m.model = u(rng) < 0.5 ? ForceModel::spring : ForceModel::linear;
      m.mass = std::pow(10.0, -3 + 2 * u(rng));
      m.stiffness = std::pow(10.0, 3.3 * u(rng));
      m.plastic = u(rng) < 0.5;
      m.gravity = u(rng) < 0.2;
      w.add_body(test::random_mesh(rng), m);
    }
    Recorder<float> rec(w);
    Tool tools[2];
    for (int n = 0; n < 150; ++n) {
      for (Tool& t : tools) {
        const double r = u(rng);
        if (r < 0.05) t.position = {0.2 * u(rng) - 0.1, 0.2 * u(rng) - 0.1, 0.2 * u(rng) - 0.1};
        else if (r < 0.06) t.position = {NAN, 0, 0};
        else for (double& c : t.position) c = std::isfinite(c) ? c + 0.004 * (u(rng) - 0.5) : 0.0;
        t.radius = 0.001 + 0.03 * u(rng);
        t.shape = u(rng) < 0.5 ? ToolShape::sphere : ToolShape::capsule;
        t.half_axis = {0.02 * u(rng), 0.0, 0.01};
        if (u(rng) < 0.05) t.grab = !t.grab;
        t.active = u(rng) > 0.02;
      }
      rec.step(tools);
    }
    rec.close_strokes();
    strokes += rec.strokes().size();
    blowups += w.stats().blowups_total;
    const std::vector<std::byte> before = w.state();
    rec.undo_all("round " + std::to_string(round));
    rec.redo_all();
    EXPECT_TRUE(w.state() == before) << "round " << round;
  }
  EXPECT_GT(strokes, 16u);
  EXPECT_GT(blowups, 0u);
}

TEST(Strokes, BadExchangesAreRefusedByNameAndChangeNothing) {
  World<float> w(SimSettings{}, 1);
  w.add_body(make_icosphere(0.1f, 3), Material{});
  const std::size_t bytes = w.block_image_bytes(0);
  ASSERT_GT(bytes, 0u);
  std::vector<std::byte> image(bytes), longer(bytes + 1);
  w.block_image(0, 1, image);
  const std::vector<std::byte> before = w.state();
  auto refused = [&](auto&& call, const char* word) {
    try {
      call();
      ADD_FAILURE() << "accepted; wanted an error naming " << word;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
    }
    EXPECT_TRUE(w.state() == before) << word;
  };
  refused([&] { w.exchange_block_image(1, 0, image); }, "body 1");
  refused([&] { w.exchange_block_image(0, w.body(0).blocks, image); }, "block");
  refused([&] { w.exchange_block_image(0, 0, longer); }, "bytes");
  refused([&] { w.block_image(0, 0, longer); }, "bytes");
  refused([&] { (void)w.block_image_bytes(2); }, "body 2");
  test::KeepingSink sink(1);
  w.set_stroke_sink(&sink);
  Tool t;
  t.radius = 0.02;
  t.position = {0.0, 0.115, 0.0};
  w.step({&t, 1});
  ASSERT_EQ(sink.strokes.size(), 1u);
  const std::vector<std::byte> touched = w.state();
  try {
    w.exchange_block_image(0, 0, image);
    ADD_FAILURE() << "an exchange into an open stroke was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("close_strokes"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(w.state() == touched);
  w.close_strokes();
  w.exchange_block_image(0, 1, image);  // now it may
  w.set_stroke_sink(nullptr);
}

}  // namespace
}  // namespace sculpt::sim
