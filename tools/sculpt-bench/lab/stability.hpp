// How large a step a mesh takes before position Verlet diverges: measured (by
// bisection on a kicked mesh), estimated (power iteration on M⁻¹K), and bounded
// (Gershgorin, daemon/sim/stability).
#pragma once

#include <cstdint>
#include <span>

#include "lab/model.hpp"
#include "sim/material.hpp"
#include "sim/settings.hpp"
#include "sim/triangle_mesh.hpp"

namespace sculpt::lab {

struct PowerIteration {
  double lambda_max = 0;  // largest eigenvalue of M⁻¹(−K) at rest, 1/s²
  double mu = 0;          // Rayleigh quotient of M⁻¹(−C) on its eigenvector, 1/s (the mode's damping rate)
  int iterations = 0;
  bool converged = false;
};

// Power iteration over the free degrees of freedom (pinned ones excluded), from a fixed start.
PowerIteration power_iteration(const Model& m, int max_iterations = 20000, double tolerance = 1e-9);

// Largest stable step of position Verlet with a backward-difference damper for
// a mode (λ, μ): x'' = −λx − μx' gives dt < 2/(√(λ + β²) + β), β = μ/2; 2/√λ undamped.
double verlet_dt_limit(double lambda, double mu);

struct Bisection {
  double dt = 0;     // largest step found stable (the bracket's lower end)
  double upper = 0;  // smallest step found unstable
  int probes = 0;
};

// Is position Verlet with step dt bounded for `ticks` steps after a kick of every
// vertex? Unstable = non-finite, or a displacement 100× the largest of the first
// 20 steps. Lab stepper (no guard), double precision.
bool verlet_stable_lab(const Model& m, double dt, int ticks);

// The same probe on daemon/sim's World<double> (one substep of dt, sleeping off);
// a guard restore counts as unstable too.
bool verlet_stable_daemon(const sim::TriangleMesh& mesh, const sim::Material& material,
                          std::span<const std::uint32_t> pinned, double dt, int ticks);

// Bisection to a relative bracket width of rel_tol, starting around `guess`.
template <class Probe>
Bisection bisect_critical_dt(Probe&& stable, double guess, double rel_tol) {
  Bisection b;
  double lo = guess, hi = guess;
  while (++b.probes, !stable(lo)) {
    hi = lo;
    lo *= 0.5;
    if (lo < guess * 1e-6) return {0.0, hi, b.probes};
  }
  if (hi == lo) {
    hi = lo * 2;
    while (++b.probes, stable(hi)) {
      lo = hi;
      hi *= 2;
      if (hi > guess * 1e6) return {lo, hi, b.probes};
    }
  }
  while ((hi - lo) > rel_tol * lo) {
    const double mid = 0.5 * (lo + hi);
    ++b.probes;
    (stable(mid) ? lo : hi) = mid;
  }
  b.dt = lo;
  b.upper = hi;
  return b;
}

}  // namespace sculpt::lab
