#include "sim/stepper.hpp"

#include <type_traits>

#include "sim/step_paths.hpp"

namespace sculpt::sim {

const char* name(StepPath path) {
  switch (path) {
    case StepPath::arrays: return "arrays";
    case StepPath::records: return "records";
    case StepPath::ring: return "ring";
  }
  return "?";
}

// The fused kernel steps in one pass: not velocity Verlet (its opening kick
// needs every block's a(t) first), and not linear-model clay (its records hold
// x − r, and its yield test needs x).
template <class S>
StepPath choose_step_path(const Body<S>& b, Integrator integrator, bool avx2) {
  if (b.ring_blocks > 0) return StepPath::ring;
  const bool fused = integrator != Integrator::velocity_verlet && avx2 &&
                     !(b.plastic && b.material.model == ForceModel::linear);
  if (std::is_same_v<S, float> && !b.packed[0].empty() && fused) return StepPath::records;
  return StepPath::arrays;
}

template <class S>
std::unique_ptr<Stepper<S>> make_stepper(StepPath path) {
  if constexpr (std::is_same_v<S, float>) {
    if (path == StepPath::ring) return std::make_unique<RingStepper>();
    if (path == StepPath::records) return std::make_unique<RecordsStepper>();
  }
  return std::make_unique<ArraysStepper<S>>();
}

template StepPath choose_step_path(const Body<float>&, Integrator, bool);
template StepPath choose_step_path(const Body<double>&, Integrator, bool);
template std::unique_ptr<Stepper<float>> make_stepper(StepPath);
template std::unique_ptr<Stepper<double>> make_stepper(StepPath);

}  // namespace sculpt::sim
