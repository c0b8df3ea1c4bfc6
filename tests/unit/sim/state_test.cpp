// World::state / restore_state: a world built from the same scene continues
// from the bytes bit for bit, on every step path; a state that does not fit
// is refused by name and changes nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <cstddef>
#include <vector>

#include "sim/kernel_testing.hpp"
#include "sim/shapes.hpp"
#include "sim/world.hpp"
#include "test_meshes.hpp"

namespace sculpt::sim {
namespace {

struct Case {
  const char* name;
  Integrator integrator = Integrator::position_verlet;
  bool clay = false;
  PackedRecords records = PackedRecords::by_size;
  bool ring = true;
};

// Two meshes and two tools: one presses into the sphere, the other grabs the
// torus and pulls; gravity keeps everything awake, pins hold the torus.
// (Sanitized, a 642-vertex sphere, not 2 562: six blocks, not 21, the same
// step paths.)
template <class S>
World<S> scene(const Case& c) {
  SimSettings s;
  s.integrator = c.integrator;
  World<S> w(s, 2);
  Material m;
  m.plastic = c.clay;
  BodyOptions o;
  o.packed = c.records;
  o.ring = c.ring;
  w.add_body(make_icosphere(0.1f, test::kSanitized ? 3 : 4), m, o);
  Material torus = m;
  torus.gravity = true;
  BodyOptions pinned = o;
  pinned.pinned = {0, 1, 2, 3};
  w.add_body(make_torus(0.3f, 0.05f, 48, 16), torus, pinned);
  return w;
}

std::vector<Tool> tools_at(int tick) {
  Tool push, grab;
  push.radius = 0.02;
  push.position = {0.01 * std::sin(tick * 0.02), 0.125 - 0.03 * std::min(tick, 100) / 100.0, 0.0};
  grab.radius = 0.03;
  grab.position = {0.3, 0.05 + 0.02 * std::max(0, tick - 50) / 100.0, 0.0};
  grab.grab = tick >= 40 && tick < 140;
  return {push, grab};
}

template <class S>
void run(World<S>& w, int from, int to) {
  for (int t = from; t < to; ++t) w.step(tools_at(t));
}

template <class S>
void continues_bit_for_bit(const Case& c) {
  World<S> whole = scene<S>(c);
  run(whole, 0, 90);  // mid-grab, mid-press
  const std::vector<std::byte> bytes = whole.state();
  run(whole, 90, 180);

  World<S> resumed = scene<S>(c);
  resumed.restore_state(bytes);
  EXPECT_EQ(resumed.tick(), 90u) << c.name;
  run(resumed, 90, 180);
  EXPECT_EQ(resumed.hash(), whole.hash()) << c.name;
  for (std::size_t b = 0; b < whole.body_count(); ++b) EXPECT_EQ(resumed.energy(b), whole.energy(b)) << c.name;
  // And once more from the resumed world: what it saved is complete too.
  World<S> again = scene<S>(c);
  again.restore_state(resumed.state());
  run(again, 180, 240);
  run(whole, 180, 240);
  EXPECT_EQ(again.hash(), whole.hash()) << c.name;
  EXPECT_TRUE(test::all_finite(resumed)) << c.name;
}

TEST(State, AWorldContinuesFromItsStateBitForBit) {
  const Case cases[] = {
      {.name = "elastic"},
      {.name = "clay", .clay = true},
      {.name = "symplectic euler", .integrator = Integrator::symplectic_euler},
      {.name = "velocity verlet clay", .integrator = Integrator::velocity_verlet, .clay = true},
      {.name = "records", .records = PackedRecords::always},
      {.name = "arrays", .records = PackedRecords::never, .ring = false},
  };
  for (const Case& c : cases) continues_bit_for_bit<float>(c);
  continues_bit_for_bit<double>({.name = "double"});
  const kernel::testing::ScopedPortable portable(true);
  continues_bit_for_bit<float>({.name = "portable kernels"});
}

TEST(State, AStateThatDoesNotFitIsRefusedByNameAndChangesNothing) {
  World<float> w = scene<float>({});
  run(w, 0, 30);
  const std::vector<std::byte> good = w.state();
  const std::uint64_t before = w.hash();

  World<float> other(SimSettings{}, 2);
  other.add_body(make_icosphere(0.1f, 2), Material{});  // fewer vertices than scene()'s
  other.add_body(make_torus(0.3f, 0.05f, 48, 16), Material{});
  auto refused = [&](World<float>& target, std::span<const std::byte> bytes, const char* word) {
    const std::uint64_t h = target.hash();
    try {
      target.restore_state(bytes);
      ADD_FAILURE() << "accepted; wanted an error naming " << word;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
    }
    EXPECT_EQ(target.hash(), h) << "a refused state changes nothing";
  };
  refused(other, good, "vertices");
  std::vector<std::byte> cut(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(good.size() / 2));
  refused(w, cut, "truncated");
  std::vector<std::byte> longer = good;
  longer.push_back(std::byte{0});
  refused(w, longer, "left over");
  std::vector<std::byte> garbage(good.size(), std::byte{0x5a});
  refused(w, garbage, "not a world state");
  refused(w, World<double>(SimSettings{}, 2).state(), "precision");
  EXPECT_EQ(w.hash(), before);
}

// A cone whose apex and base centre join 48 vertices each: more than the
// widest neighbour table, so their springs overflow into the list.
TriangleMesh cone() {
  TriangleMesh m;
  m.positions = {{2.0f, 0.05f, 0.0f}, {2.0f, -0.05f, 0.0f}};
  const std::uint32_t ring = 48;
  for (std::uint32_t i = 0; i < ring; ++i) {
    const double a = 2 * M_PI * i / ring;
    m.positions.push_back({static_cast<float>(2.0 + 0.05 * std::cos(a)), -0.05f, static_cast<float>(0.05 * std::sin(a))});
  }
  for (std::uint32_t i = 0; i < ring; ++i) {
    const std::uint32_t p = 2 + i, q = 2 + (i + 1) % ring;
    m.triangles.push_back({0, q, p});
    m.triangles.push_back({1, p, q});
  }
  return m;
}

// The scene's two meshes mid-sculpt, and a cone far off that sleeps.
World<float> three_meshes(PackedRecords records = PackedRecords::by_size) {
  World<float> w = scene<float>({.name = "three meshes", .records = records});
  BodyOptions o;
  o.packed = records;
  w.add_body(cone(), Material{}, o);
  run(w, 0, 90);
  return w;
}

// Where `part` (bytes copied whole into the state) first lies in `state`
// (the first of equal arrays is the first in the state's order).
std::size_t offset_in(std::span<const std::byte> state, std::span<const std::byte> part, bool once = true) {
  const auto it = std::search(state.begin(), state.end(), part.begin(), part.end());
  EXPECT_NE(it, state.end());
  if (once) {
    EXPECT_EQ(std::search(it + 1, state.end(), part.begin(), part.end()), state.end()) << "found twice";
  }
  return static_cast<std::size_t>(it - state.begin());
}

template <class T>
std::span<const std::byte> bytes_of(const T& a) {
  return std::as_bytes(std::span(a.data(), a.size()));
}

template <class T>
void put(std::vector<std::byte>& state, std::size_t at, T v) {
  std::memcpy(state.data() + at, &v, sizeof v);
}

void expect_refused(const std::vector<std::byte>& bytes, const std::string& word, PackedRecords records = PackedRecords::by_size) {
  World<float> fresh = three_meshes(records);
  const std::uint64_t h = fresh.hash();
  try {
    fresh.restore_state(bytes);
    ADD_FAILURE() << "accepted; wanted an error naming " << word;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
  }
  EXPECT_EQ(fresh.hash(), h) << "a refused state changes nothing";
}

// Values no world of the scene can hold: each refused by name, naming the
// mesh, the field and the value, and nothing changed.
TEST(State, ValuesAWorldCannotHoldAreRefusedByNameAndChangeNothing) {
  const World<float> w = three_meshes();
  const std::vector<std::byte> good = w.state();
  const Body<float>& ball = w.body(0);
  const Body<float>& torus = w.body(1);
  const Body<float>& cone = w.body(2);
  ASSERT_FALSE(cone.overflow.empty()) << "the cone's apex overflows the neighbour table";
  ASSERT_TRUE(cone.block[0].awake == false) << "far from the tools, at rest: it sleeps";
  auto changed = [&](auto&& f) {
    std::vector<std::byte> b = good;
    f(b);
    return b;
  };
  const std::size_t over = offset_in(good, bytes_of(cone.overflow));
  expect_refused(changed([&](auto& b) { put(b, over + offsetof(kernel::Overflow<float>, j), std::int32_t{1} << 30); }),
                 "mesh 2: overflow spring 0 joins vertices");
  expect_refused(changed([&](auto& b) { put(b, over + sizeof(kernel::Overflow<float>) + offsetof(kernel::Overflow<float>, i), ~0u); }),
                 "mesh 2: overflow spring 1 joins vertices 4294967295");
  const std::size_t x = offset_in(good, bytes_of(ball.x));
  expect_refused(changed([&](auto& b) { put(b, x + 12, std::numeric_limits<float>::quiet_NaN()); }), "mesh 0: x[3] is nan");
  expect_refused(changed([&](auto& b) { put(b, x + 12, 1e7f); }), "mesh 0: x[3] is 10000000 (finite, within ±1000000)");
  expect_refused(changed([&](auto& b) { put(b, x + 12, ball.x[3] + 1.0f); }), "mesh 0: vertex 3 is at");
  const std::size_t wx = offset_in(good, bytes_of(torus.wx));
  expect_refused(changed([&](auto& b) { put(b, wx + 4 * 10, 1e6f); }), "mesh 1: vertex 10 moves at");
  // At rest its positions are its rest positions: x is the first of the two. wx follows x, y and z.
  const std::size_t cone_w = offset_in(good, bytes_of(cone.x), false) + 3 * (4 * cone.n + 8);
  expect_refused(changed([&](auto& b) { put(b, cone_w, 1e-3f); }), "mesh 2: vertex 0 moves in block 0, which sleeps");
  const std::size_t rx = offset_in(good, bytes_of(ball.rx));
  expect_refused(changed([&](auto& b) { put(b, rx, ball.rx[0] + 1e-4f); }), "mesh 0: rest x[0] is not the scene's");
  const std::size_t rest = offset_in(good, bytes_of(torus.rest_length));
  expect_refused(changed([&](auto& b) { put(b, rest + 4 * 5, torus.rest_length[5] * 0.5f); }), "mesh 1: rest length 5 is");
  const std::size_t blocks = offset_in(good, bytes_of(ball.block));
  expect_refused(changed([&](auto& b) { b[blocks + offsetof(BlockState<float>, awake)] = std::byte{2}; }),
                 "mesh 0: block 0 flag is 2, not a flag");
  expect_refused(changed([&](auto& b) { put(b, blocks + offsetof(BlockState<float>, reach), 5.0f); }),
                 "mesh 0: block 0: its reach is not the scene's");
  // The tail: the last mesh's energy, energy reference, blow-ups, boost, checkpoint age, input flag; then the
  // tools' tracks, the tick, the blow-ups and the last one's mesh and cause.
  const std::size_t tracks = good.size() - 21 - 2 * sizeof(ToolTrack<float>);
  const std::size_t boost = tracks - 8 - 1 - 4 - 4;
  expect_refused(changed([&](auto& b) { put(b, boost, 3); }), "mesh 2: substep boost 3 (a power of two up to 64)");
  expect_refused(changed([&](auto& b) { put(b, tracks + offsetof(ToolTrack<float>, shape), 7); }), "state: tool 0: shape 7");
  expect_refused(changed([&](auto& b) { put(b, good.size() - 5, std::uint32_t{99}); }),
                 "state: the last blow-up was of mesh 99, the scene has 3");
  // The torus is held by tool 1's grab: its vertices in order, each once.
  const auto& grabs = torus.tools[1].grabs;
  ASSERT_GT(torus.tools[1].grab_count, 1u);
  const std::size_t g = offset_in(good, bytes_of(grabs));
  expect_refused(changed([&](auto& b) { put(b, g + sizeof(Grab<float>), grabs[0].i); }), "grab's vertices are out of order");

  const World<float> records = three_meshes(PackedRecords::always);
  const std::vector<std::byte> rgood = records.state();
  const std::size_t packed = offset_in(rgood, bytes_of(records.body(0).packed[records.body(0).packed_cur]));
  std::vector<std::byte> rbad = rgood;
  put(rbad, packed + 3 * 4, 1.0f);
  expect_refused(rbad, "mesh 0: packed record 0[3] is 1", PackedRecords::always);
}

// Random bytes anywhere in a state: refused by name (nothing changed), or
// bytes no step reads (the unused slots of a grab list, the guard's
// quantized checkpoint): the world then steps on without a blow-up.
TEST(State, RandomBytesAreRefusedOrStepOnWithoutBlowingUp) {
  World<float> reference = three_meshes();
  const std::vector<std::byte> good = reference.state();
  std::uint64_t reference_blowups = 0;
  for (int t = 90; t < 150; ++t) {
    reference.step(tools_at(t));
    reference_blowups += reference.stats().blowups;
  }
  ASSERT_EQ(reference_blowups, 0u);
  int refused = 0;
  for (std::uint32_t seed = 1; seed <= 40; ++seed) {
    SCOPED_TRACE(seed);
    std::mt19937 gen(seed);
    const std::size_t len = std::uniform_int_distribution<std::size_t>(1, 64)(gen);
    const std::size_t at = std::uniform_int_distribution<std::size_t>(0, good.size() - len)(gen);
    std::vector<std::byte> bad = good;
    for (std::size_t i = at; i < at + len; ++i) bad[i] = static_cast<std::byte>(gen() & 0xff);
    World<float> w = scene<float>({.name = "random bytes"});
    w.add_body(cone(), Material{});
    const std::uint64_t h = w.hash();
    try {
      w.restore_state(bad);
    } catch (const std::invalid_argument& e) {
      ++refused;
      EXPECT_EQ(w.hash(), h);
      continue;
    }
    std::uint64_t blowups = 0;
    for (int t = 90; t < 150; ++t) {
      w.step(tools_at(t));
      blowups += w.stats().blowups;
    }
    EXPECT_EQ(blowups, 0u) << "bytes " << at << ".." << at + len << " accepted, then it blew up";
    EXPECT_TRUE(test::all_finite(w));
  }
  EXPECT_GT(refused, 0);
}

// A stroke's block image from outside is held to the same rules before a
// swap: the world's own pass, altered ones are refused by name.
TEST(State, ABlockImageFromOutsideIsCheckedBeforeASwap) {
  const World<float> w = three_meshes();
  for (std::uint32_t body = 0; body < w.body_count(); ++body) {
    std::vector<std::byte> image(w.block_image_bytes(body));
    for (std::uint32_t blk = 0; blk < w.body(body).blocks; ++blk) {
      w.block_image(body, blk, image);
      EXPECT_EQ(w.block_image_error(body, blk, image), "") << body << "/" << blk;
    }
  }
  std::vector<std::byte> image(w.block_image_bytes(0));
  w.block_image(0, 0, image);
  EXPECT_NE(w.block_image_error(0, 1, std::span<const std::byte>(image).first(image.size() - 1)).find("an image of body 0 is"),
            std::string::npos);
  EXPECT_NE(w.block_image_error(7, 0, image).find("body 7 does not exist"), std::string::npos);
  std::vector<std::byte> bad = image;
  bad[offsetof(BlockState<float>, dirty)] = std::byte{9};
  EXPECT_EQ(w.block_image_error(0, 0, bad), "block 0: a flag is not a flag");
  bad = image;
  const float far = 3.0f;  // the first position, out of the block's box
  std::memcpy(bad.data() + sizeof(BlockState<float>) + sizeof(CheckpointGrid<float>), &far, sizeof far);
  EXPECT_NE(w.block_image_error(0, 0, bad).find("block 0: a value is 3"), std::string::npos);
}

}  // namespace
}  // namespace sculpt::sim
