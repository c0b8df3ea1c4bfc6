// Scene-wide simulation settings (the [simulation] table of a scene file).
#pragma once

#include <array>

namespace sculpt::sim {

enum class Integrator {
  position_verlet,   // p' = 2p - p_prev + a dt²: the original, the default
  velocity_verlet,
  symplectic_euler,
};

struct SimSettings {
  double rate_hz = 1000.0;           // ticks per second
  int substeps = 0;                  // 0 = automatic, from the stiffness bound
  double substep_safety = 0.5;       // use at most this fraction of the critical dt
  Integrator integrator = Integrator::position_verlet;
  std::array<double, 3> gravity{0.0, -9.81, 0.0};
  double sleep_speed = 1e-4;         // m/s: a region slower than this for sleep_ticks sleeps
  int sleep_ticks = 50;
  double max_tool_speed = 20.0;      // m/s: a tool moving faster between ticks teleported (no sweep)
};

}  // namespace sculpt::sim
