// After construction, ControlMapper::apply and drain allocate nothing (it
// runs on the real-time simulation thread): every operator new in this binary
// is counted.
#include <gtest/gtest.h>

#include "input/control_mapper.hpp"
#include "input/mapping.hpp"
#include "test_devices.hpp"
#include "support/allocation_counter.hpp"


namespace sculpt::input {
namespace {

TEST(RealTime, ControlMapperDoesNotAllocate) {
  ToolRouter router({{0, "", Stick::left}, {0, "", Stick::right}});
  const DeviceBinding binding = router.attach(0, testing::gamepad(), MappingConfig{});
  std::vector<InputMessage> script;
  script.push_back(InputMessage::attach(0, binding));
  for (int i = 0; i < 2000; ++i) {
    InputFrame f;
    f.slot = 0;
    f.at_tick = static_cast<std::uint64_t>(i + 1);
    f.push({EV_ABS, ABS_X, (i * 977) % 65536 - 32768});
    f.push({EV_ABS, ABS_RY, (i * 131) % 65536 - 32768});
    f.push({EV_ABS, ABS_Z, i % 256});
    f.push({EV_KEY, BTN_SOUTH, i % 3 == 0});
    f.push({EV_KEY, BTN_EAST, i % 5 == 0});
    script.push_back(InputMessage::of_frame(f));
    if (i % 500 == 499) {
      script.push_back(InputMessage::detach(0, static_cast<std::uint64_t>(i + 1)));
      script.push_back(InputMessage::attach(0, binding, static_cast<std::uint64_t>(i + 1)));
    }
  }
  concurrency::SpscRing<InputMessage> ring(script.size());
  ControlMapper mapper(2);

  support::count_allocations_on_this_thread(true);
  const long before = support::counted_allocations();
  for (const auto& m : script) ASSERT_TRUE(ring.try_push(m));
  std::size_t applied = 0;
  float sum = 0;
  for (std::uint64_t tick = 0; tick <= 2001; ++tick) {
    applied += mapper.drain(ring, tick);
    for (const ToolControl& c : mapper.controls()) sum += c.stick[0] + c.stick[1] + c.stick[2];
  }
  for (const auto& m : script) mapper.apply(m);
  const long after = support::counted_allocations();
  support::count_allocations_on_this_thread(false);
  EXPECT_EQ(after - before, 0) << "ControlMapper allocated on the simulation thread's path";
  EXPECT_EQ(applied, script.size());
  EXPECT_GT(mapper.controls()[1].shape_toggles, 0u);
  EXPECT_TRUE(std::isfinite(sum));
}

}  // namespace
}  // namespace sculpt::input
