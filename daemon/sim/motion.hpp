// What a body's w arrays hold, and the conversions to and from velocity,
// written once. Position Verlet keeps the last step d = x − x_prev (velocity
// d/dt): storing d rather than x_prev keeps float's rounding small. The other
// integrators keep the velocity itself (kernel::Velocity says which).
#pragma once

#include <cstdint>

#include "sim/body.hpp"
#include "sim/kernels.hpp"
#include "sim/settings.hpp"

namespace sculpt::sim {

inline kernel::Velocity velocity_kind(Integrator integrator) {
  return integrator == Integrator::position_verlet ? kernel::Velocity::step : kernel::Velocity::stored;
}

// The velocity a stored w stands for, over a substep of dt.
template <class T>
T velocity_of(kernel::Velocity kind, T w, T dt) {
  return kind == kernel::Velocity::step ? w / dt : w;
}

// The w that stands for velocity v over a substep of dt.
template <class T>
T stored_motion(kernel::Velocity kind, T v, T dt) {
  return kind == kernel::Velocity::step ? v * dt : v;
}

// Keep vertex i's packed records current after a change outside the kernels:
// the formula of kernel::pack (velocity w·(1/dt) for steps), in both buffers so
// a sleeping or just-pushed vertex reads the same from either.
template <class S>
void sync_records(Body<S>& b, std::uint32_t i, S inv_dt) {
  if (b.packed[0].empty()) return;
  for (auto& buf : b.packed) {
    S* q = buf.data() + 8 * static_cast<std::size_t>(i);
    if (b.material.model == ForceModel::linear) q[0] = b.x[i] - b.rx[i], q[1] = b.y[i] - b.ry[i], q[2] = b.z[i] - b.rz[i];
    else q[0] = b.x[i], q[1] = b.y[i], q[2] = b.z[i];
    q[3] = S(0);
    if (b.velocity == kernel::Velocity::step) {
      q[4] = b.wx[i] * inv_dt;
      q[5] = b.wy[i] * inv_dt;
      q[6] = b.wz[i] * inv_dt;
    } else {
      q[4] = b.wx[i], q[5] = b.wy[i], q[6] = b.wz[i];
    }
    q[7] = S(0);
  }
}

}  // namespace sculpt::sim
