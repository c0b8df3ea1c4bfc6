// Problems with known answers for the accuracy study: a single oscillator and
// a fixed-fixed chain (linear model, analytic modal solutions), and a 3D mesh
// pulled by a grabbing tool (the default rubber; compared against a tiny-step
// double-precision reference).
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "lab/model.hpp"
#include "sim/material.hpp"
#include "sim/triangle_mesh.hpp"

namespace sculpt::lab {

struct Problem {
  std::string name;
  sim::TriangleMesh mesh;
  sim::Material material;
  std::vector<std::uint32_t> pinned;
  Model model;                      // mesh + material + pins (+ the grab set)
  double t_end = 1.0;               // s
  std::vector<double> dts;          // default tick lengths of the sweep, coarse to fine
  double scale = 1.0;               // m: the motion's amplitude (a run whose error passes 100× this diverged)
  bool undamped = false;            // energy error is meaningful
  // Analytic positions and velocities at t (3 per vertex); empty for the mesh.
  std::function<void(double, std::vector<double>&)> exact, exact_velocity;
  // The grabbing tool (mesh problem): its centre over time and radius.
  std::function<Vec3(double)> tool_path;
  double tool_radius = 0.0;
  // Natural frequency of the slowest mode (chain, oscillator), rad/s; 0 if unknown.
  double omega = 0.0;
};

// "oscillator", "chain" or "mesh"; throws std::invalid_argument naming the others.
Problem make_problem(std::string_view name);
std::vector<std::string> problem_names();

// The fixed-fixed chain the stability test also uses: N free masses, pinned ends.
sim::TriangleMesh chain_mesh(int free_masses, float spacing);

}  // namespace sculpt::lab
