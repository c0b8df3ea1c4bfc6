#include "sim/stability.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace sculpt::sim {

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}

bool finite_nonneg(double v) { return std::isfinite(v) && v >= 0.0; }

}  // namespace

void validate(const Material& m) {
  const std::string where = "material '" + m.name + "': ";
  require(std::isfinite(m.mass) && m.mass > 0.0, where + "mass must be a finite number > 0 (kg per vertex)");
  require(finite_nonneg(m.stiffness), where + "stiffness must be finite and >= 0 (N/m)");
  require(finite_nonneg(m.damping), where + "damping must be finite and >= 0 (N·s/m)");
  require(finite_nonneg(m.anchor), where + "anchor must be finite and >= 0 (N/m)");
  require(finite_nonneg(m.anchor_damping), where + "anchor_damping must be finite and >= 0 (N·s/m)");
  require(finite_nonneg(m.grab_stiffness), where + "grab_stiffness must be finite and >= 0 (N/m)");
  require(std::isfinite(m.yield_strain) && m.yield_strain > 0.0, where + "yield_strain must be finite and > 0");
}

void validate(const SimSettings& s) {
  require(std::isfinite(s.rate_hz) && s.rate_hz > 0.0, "simulation: rate_hz must be a finite number > 0");
  require(s.substeps >= 0 && s.substeps <= kMaxSubsteps,
          "simulation: substeps must be 0 (automatic) or 1.." + std::to_string(kMaxSubsteps));
  require(std::isfinite(s.substep_safety) && s.substep_safety > 0.0 && s.substep_safety <= 1.0,
          "simulation: substep_safety must be in (0, 1]");
  for (double g : s.gravity) require(std::isfinite(g), "simulation: gravity must be finite");
  require(finite_nonneg(s.sleep_speed), "simulation: sleep_speed must be finite and >= 0");
  require(s.sleep_ticks >= 1, "simulation: sleep_ticks must be >= 1");
  require(std::isfinite(s.max_tool_speed) && s.max_tool_speed > 0.0,
          "simulation: max_tool_speed must be a finite number > 0");
}

StabilityBound stability_bound_for_degree(int max_degree, const Material& m) {
  validate(m);
  const double deg = std::max(0, max_degree);
  const double lambda = (2.0 * deg * m.stiffness + m.anchor + m.grab_stiffness) / m.mass;
  const double beta = (2.0 * deg * m.damping + m.anchor_damping) / (2.0 * m.mass);
  const double denom = std::sqrt(lambda + beta * beta) + beta;
  const double dt = denom > 0.0 ? 2.0 / denom : std::numeric_limits<double>::infinity();
  return {lambda, dt};
}

StabilityBound stability_bound(const TriangleMesh& mesh, const Material& material) {
  std::vector<int> degree(mesh.positions.size(), 0);
  for (const Edge& e : unique_edges(mesh.triangles)) {
    if (e.a < degree.size()) ++degree[e.a];
    if (e.b < degree.size()) ++degree[e.b];
  }
  const int max_degree = degree.empty() ? 0 : *std::max_element(degree.begin(), degree.end());
  return stability_bound_for_degree(max_degree, material);
}

SubstepChoice choose_substeps_for_degree(int max_degree, const Material& material, const SimSettings& settings) {
  validate(settings);
  const StabilityBound bound = stability_bound_for_degree(max_degree, material);
  const double dt = 1.0 / settings.rate_hz;
  int n = settings.substeps;
  if (n <= 0) {
    const double allowed = settings.substep_safety * bound.dt_critical;
    const double need = std::ceil(dt / allowed);  // +inf allowed → 0
    n = need <= 1.0 ? 1 : (need >= kMaxSubsteps ? kMaxSubsteps : static_cast<int>(need));
    // ceil can land one short when dt/allowed is an exact ratio that rounds down.
    while (n < kMaxSubsteps && dt / n > allowed) ++n;
  }
  return {n, dt / n, bound};
}

SubstepChoice choose_substeps(const TriangleMesh& mesh, const Material& material, const SimSettings& settings) {
  validate(settings);
  std::vector<int> degree(mesh.positions.size(), 0);
  for (const Edge& e : unique_edges(mesh.triangles)) {
    if (e.a < degree.size()) ++degree[e.a];
    if (e.b < degree.size()) ++degree[e.b];
  }
  const int max_degree = degree.empty() ? 0 : *std::max_element(degree.begin(), degree.end());
  return choose_substeps_for_degree(max_degree, material, settings);
}

}  // namespace sculpt::sim
