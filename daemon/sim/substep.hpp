// What every stepping strategy needs for one body's substeps, built once a
// tick by World (internal): the kernel arguments, the awake blocks'
// bookkeeping, the grab springs and the scratch the step may use without
// allocating.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "sim/body.hpp"
#include "sim/grab.hpp"
#include "sim/kernels.hpp"

namespace sculpt::sim {

template <class S>
struct Substep {
  Body<S>& body;
  kernel::ForceArgs<S> forces;        // network, material; accelerations out
  kernel::IntegrateArgs<S> integrate;  // state; accelerations in
  Integrator integrator;
  kernel::Velocity velocity;
  int count = 1;  // substeps this tick
  int index = 0;  // this one
  S dt = 0;
  GrabSprings<S>& grabs;
  double* potential;          // per awake-list entry: the block's potential energy this substep
  std::uint8_t* yield_masks;  // clay: one mask of clay_mask_bytes() per awake-list entry
  S* scratch;                 // accelerations of one block (3·kBlock)
  float* ring;                // the world's ring of packed records
  S speed_limit2 = 0;
  bool finite = true;  // no vertex went non-finite or faster than the speed limit

  bool first() const { return index == 0; }
  bool last() const { return index + 1 == count; }
  std::uint8_t* mask_of(std::uint32_t q) const { return yield_masks + q * clay_mask_bytes(body); }
  // The block at b0 takes its accelerations from the scratch.
  void use_scratch(std::uint32_t b0) {
    forces.ax = scratch, forces.ay = scratch + kernel::kBlock, forces.az = scratch + 2 * kernel::kBlock;
    integrate.ax = forces.ax, integrate.ay = forces.ay, integrate.az = forces.az;
    forces.acc_origin = integrate.acc_origin = b0;
  }
  // The integrated block at awake-list entry q: speed, divergence, energy.
  void account(std::uint32_t q, const kernel::BlockSums<S>& sums) {
    BlockState<S>& s = body.block[body.awake_list[q]];
    S v2;
    std::memcpy(&v2, &sums.max_speed2_bits, sizeof(S));
    if (!std::isfinite(v2) || v2 > speed_limit2) finite = false;
    const auto key = std::bit_cast<std::uint32_t>(static_cast<float>(std::isfinite(v2) ? v2 : S(0)));
    s.max_speed2_bits = std::max(s.max_speed2_bits, key);
    if (last()) s.energy = potential[q] + 0.5 * body.material.mass * double(sums.sum_speed2);
  }
  // Forces of the block at awake-list entry q into the current accelerations.
  S block_forces(std::uint32_t q) {
    const std::uint32_t blk = body.awake_list[q];
    return kernel::forces(forces, body.material.model, velocity, body.begin_of(blk), body.end_of(blk),
                          body.overflow_begin[blk], body.overflow_begin[blk + 1]);
  }
  kernel::BlockSums<S> block_integrate(std::uint32_t q) {
    const std::uint32_t blk = body.awake_list[q];
    return kernel::integrate(integrate, integrator, body.begin_of(blk), body.end_of(blk));
  }
};

}  // namespace sculpt::sim
