// How a body's awake blocks take one substep: a strategy per memory layout,
// chosen once when the body is added (choose_step_path), each in its own file
// behind one signature. All of them perform the same operations on the same
// inputs in the same order, so every path gives the same bits.
//
//   arrays   forces of every awake block into ax..az, then integrate them all.
//            Velocity Verlet (it keeps a(t) from one step to the next), clay
//            without packed records, and every body the two below do not take
//            (double precision, no AVX2, BodyOptions::ring off).
//   records  one fused pass per block from the double buffer of packed
//            records (float, AVX2 at setup; clay up to kPackedMaxVertices,
//            or PackedRecords::always). Clay's yields read every block's
//            step-start state after the sweep: the other buffer keeps it.
//   ring     one fused pass per block through the world's ring of packed
//            records (elastic float bodies, AVX2 at setup).
#pragma once

#include <memory>

#include "sim/body.hpp"
#include "sim/settings.hpp"
#include "sim/substep.hpp"

namespace sculpt::sim {

enum class StepPath { arrays, records, ring };

const char* name(StepPath path);

template <class S>
class Stepper {
 public:
  virtual ~Stepper() = default;
  // Every awake block of s.body one substep on: the grab springs, the forces,
  // clay's yield (first substep), the integration. Contacts and pins follow.
  virtual void substep(Substep<S>& s) = 0;
  // After the tick's last substep, contacts and pins included.
  virtual void end_tick(Substep<S>&) {}
};

// The path of a body built by make_body: the ring if it has one (make_body
// built it), the records if it has them and they can run, else the arrays.
template <class S>
StepPath choose_step_path(const Body<S>& b, Integrator integrator, bool avx2);

// Setup (allocates). The arrays path needs ax..az on the body (World sizes them).
template <class S>
std::unique_ptr<Stepper<S>> make_stepper(StepPath path);

}  // namespace sculpt::sim
