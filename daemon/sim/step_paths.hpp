// The three stepping strategies (see stepper.hpp), internal to the sim.
#pragma once

#include "sim/stepper.hpp"

namespace sculpt::sim {

template <class S>
class ArraysStepper final : public Stepper<S> {
 public:
  void substep(Substep<S>& s) override;
  void end_tick(Substep<S>& s) override { pack_awake(s); }  // as the next tick's kernels expect

 private:
  static void open_kick(Substep<S>& s);
  static void pack_awake(Substep<S>& s);
};

class RecordsStepper final : public Stepper<float> {
 public:
  void substep(Substep<float>& s) override;
};

class RingStepper final : public Stepper<float> {
 public:
  void substep(Substep<float>& s) override;

 private:
  static void pack_into_ring(Substep<float>& s, std::uint32_t c);
};

// A block that holds grabbed vertices steps in pieces on the fused paths: its
// forces (neighbours from the records), the grab springs, integrate. Returns
// its potential energy. The same operations in the same order as the arrays
// path: the same bits.
float step_grabbed_block(Substep<float>& s, std::uint32_t q, std::uint8_t* yield_mask, float* packed_next);

}  // namespace sculpt::sim
