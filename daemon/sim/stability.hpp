// How small a (sub)step must be for the explicit integrators to stay stable,
// from a cheap bound on the stiffest mode. Computed when a mesh or material
// changes, never per tick.
#pragma once

#include "sim/material.hpp"
#include "sim/settings.hpp"
#include "sim/triangle_mesh.hpp"

namespace sculpt::sim {

struct StabilityBound {
  double lambda_max_bound;  // Gershgorin bound on λmax(M⁻¹K) incl. anchor, 1/s²
  double dt_critical;       // largest stable dt from that bound, shrunk for the damper (DESIGN.md)
};

// Row-sum (Gershgorin) bound over the vertices: λmax ≤ max_i (2·deg_i·k + anchor + grab)/m.
// It holds for both force models (a stretched length spring adds at most k per
// direction). The damper shrinks the limit: ωdt < 2(√(1+ζ²) − ζ), written here
// as dt < 2 / (√(λ + β²) + β) with β = λC/(2m) so that ω → 0 stays finite.
// A mesh with no stiffness and no damping returns dt_critical = +inf.
StabilityBound stability_bound(const TriangleMesh& mesh, const Material& material);

// The same bound from a precomputed maximum vertex degree (what Body uses).
StabilityBound stability_bound_for_degree(int max_degree, const Material& material);

struct SubstepChoice {
  int substeps;
  double substep_dt;
  StabilityBound bound;
};

// Never more substeps than this per tick: a material that would need more is
// reported by the caller (substeps == kMaxSubsteps) rather than stalling the loop.
inline constexpr int kMaxSubsteps = 4096;

// Fewest substeps with substep_dt <= safety * dt_critical; settings.substeps > 0 overrides.
// Throws std::invalid_argument naming the field when settings or material are nonsense
// (rate_hz <= 0, safety outside (0, 1], mass <= 0, negative stiffness...).
SubstepChoice choose_substeps(const TriangleMesh& mesh, const Material& material, const SimSettings& settings);
SubstepChoice choose_substeps_for_degree(int max_degree, const Material& material, const SimSettings& settings);

// Throws std::invalid_argument naming the first bad field of the material.
void validate(const Material& material);
// Throws std::invalid_argument naming the first bad field of the settings.
void validate(const SimSettings& settings);

}  // namespace sculpt::sim
