#include "simloop/simulation_settings.hpp"

#include <stdexcept>

#include <fmt/format.h>

namespace sculpt::simloop {

void check_settings(const SimulationSettings& s) {
  auto check = [](const SettingRange& r, double v) {
    if (!(v >= r.lo && v <= r.hi))
      throw std::invalid_argument(fmt::format("{} is {}, not within [{}, {}]", r.name, v, r.lo, r.hi));
  };
  if (s.rate_hz) check(kRateRange, *s.rate_hz);
  check(kToolMarginRange, s.tool_margin);
  check(kSizeStepRange, s.size_step);
  check(kMinScaleRange, s.min_scale);
  check(kMaxScaleRange, s.max_scale);
  check(kRingCapacityRange, static_cast<double>(s.ring_capacity));
}

}  // namespace sculpt::simloop
