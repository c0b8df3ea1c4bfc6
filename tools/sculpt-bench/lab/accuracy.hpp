// One accuracy case: a problem, an integrator (run by daemon/sim's World for
// the three it has, by the lab's Stepper for the others), a precision, a tick
// and a number of substeps. Errors against the analytic solution or a
// tiny-step double-precision reference, sampled every tick.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "lab/integrators.hpp"
#include "lab/problems.hpp"

namespace sculpt::lab {

enum class Impl { daemon, lab };

struct CaseSpec {
  Method method = Method::position_verlet;
  Impl impl = Impl::daemon;  // daemon: sim::World (only its three integrators); lab: Stepper
  bool use_double = false;
  double dt = 1e-3;          // tick, s
  int substeps = 1;          // per tick
};

struct CaseResult {
  CaseSpec spec;
  int ticks = 0;
  double seconds = 0;               // wall time of the stepping only
  std::uint64_t spring_passes = 0;  // deterministic cost (see Stepper::spring_passes)
  double error_max = 0, error_rms = 0;  // m, over every vertex and tick
  double energy_error = -1;         // max |E − E0|/E0 (undamped problems), −1 when not measured
  bool diverged = false;            // non-finite, or error past 100× the problem's scale
  std::uint64_t blowups = 0;        // World's guard restores (daemon runs)
};

// Positions of a tiny-step reference run, sampled every `dt`.
struct Reference {
  double dt = 0;
  std::vector<std::vector<double>> x;
};

// Runge-Kutta 4 in double with a step of dt/refine (the tool path exact). Not position
// Verlet: its backward-difference damper is only first order, so it would converge slowly.
Reference make_reference(const Problem& p, double dt, int refine);

// Impl::daemon requires one of the daemon's integrators. `ref` is needed when p.exact is empty.
CaseResult run_case(const Problem& p, const CaseSpec& spec, const Reference* ref);

// Caches one reference per tick length (the mesh problem).
class ReferenceCache {
 public:
  // References take at least `refine` steps per step of the finest case measured.
  ReferenceCache(const Problem& p, double finest_dt, int refine = 16) : p_(p), finest_(finest_dt), refine_(refine) {}
  const Reference* get(double dt);

 private:
  const Problem& p_;
  double finest_;
  int refine_;
  std::map<double, Reference> refs_;
};

bool daemon_has(Method m);

// Least-squares slope of log(error_max) against log(h) over the given cases.
double convergence_order(const std::vector<CaseResult>& cases);

// Indices of the cases not dominated by another (cost: spring passes, error:
// error_max). A case dominates another if it costs no more and its error is
// smaller by more than `rel_margin` (errors within the margin are a tie: the
// precision and rounding noise of the measurement). Diverged cases are never on it.
std::vector<std::size_t> pareto_front(const std::vector<CaseResult>& cases, double rel_margin);

}  // namespace sculpt::lab
