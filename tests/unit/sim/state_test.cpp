// World::state / restore_state: a world built from the same scene continues
// from the bytes bit for bit, on every step path; a state that does not fit
// is refused by name and changes nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <vector>

#include "sim/kernel_testing.hpp"
#include "sim/shapes.hpp"
#include "sim/world.hpp"
#include "sim_test_util.hpp"

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

}  // namespace
}  // namespace sculpt::sim
