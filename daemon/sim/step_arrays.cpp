// The arrays path: forces of every awake block into the body's ax..az, then
// integrate them all (Jacobi: every force sees the substep's start).
#include "sim/clay.hpp"
#include "sim/stepper.hpp"
#include "sim/step_paths.hpp"

namespace sculpt::sim {

// The opening half kick uses a(t), which the last closing force pass left in
// ax..az. A block that has not had one since it was created, woken, restored
// or set by hand gets its forces first (before any block drifts): otherwise
// its first step kicks with zero (or stale) acceleration and the integrator
// starts first order. Clay yields on the state the tick starts from: here,
// before the drift.
template <class S>
void ArraysStepper<S>::open_kick(Substep<S>& s) {
  Body<S>& b = s.body;
  if (s.first() && b.plastic)
    for (std::uint32_t q = 0; q < b.awake_count; ++q) yield_block(b, b.awake_list[q], s.mask_of(0));
  if (s.first())
    for (std::uint32_t q = 0; q < b.awake_count; ++q)
      if (!b.block[b.awake_list[q]].accel_current) s.block_forces(q);
  for (std::uint32_t q = 0; q < b.awake_count; ++q) {
    const std::uint32_t blk = b.awake_list[q];
    b.block[blk].accel_current = true;  // the closing pass recomputes them
    kernel::vv_open(s.integrate, b.begin_of(blk), b.end_of(blk));
  }
}

template <class S>
void ArraysStepper<S>::substep(Substep<S>& s) {
  Body<S>& b = s.body;
  if (s.integrator == Integrator::velocity_verlet) open_kick(s);
  pack_awake(s);  // clay's yield test reads the neighbours from them
  if (s.grabs.any()) {
    s.grabs.mark_blocks(true);
    s.grabs.pull_tools();
  }
  for (std::uint32_t q = 0; q < b.awake_count; ++q) s.potential[q] = s.block_forces(q);
  if (b.plastic && s.first() && s.integrator != Integrator::velocity_verlet)  // nothing has moved yet
    for (std::uint32_t q = 0; q < b.awake_count; ++q) yield_block(b, b.awake_list[q], s.mask_of(0));
  for (std::uint32_t q = 0; q < b.awake_count; ++q) {
    const std::uint32_t blk = b.awake_list[q];
    if (b.block[blk].grabbed) s.grabs.accelerate(blk, s.forces);
    s.account(q, s.block_integrate(q));
  }
  if (s.grabs.any()) s.grabs.mark_blocks(false);
}

// A body with packed records that steps here (velocity Verlet, linear clay,
// no AVX2 at setup) keeps them matching x and w for the kernels that read them.
template <class S>
void ArraysStepper<S>::pack_awake(Substep<S>& s) {
  if constexpr (std::is_same_v<S, float>) {
    Body<S>& b = s.body;
    if (b.packed[0].empty()) return;
    for (std::uint32_t q = 0; q < b.awake_count; ++q)
      kernel::pack(s.forces, b.material.model, s.velocity, b.packed[b.packed_cur].data(), b.begin_of(b.awake_list[q]),
                   b.end_of(b.awake_list[q]));
  }
}

template class ArraysStepper<float>;
template class ArraysStepper<double>;

}  // namespace sculpt::sim
