// The lab's spring-mass model: the same physics as daemon/sim (both force
// models, the parallel dampers, the anchor, pinned vertices, grab springs to a
// moving tool), written plainly — one loop over springs, interleaved xyz — so
// that integrators the real-time library does not carry (explicit and implicit
// Euler, XPBD) can be studied on exactly the problems the daemon solves.
// Study code: never in the sim thread, allocation and speed do not matter.
#pragma once

#include <Eigen/SparseCore>
#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "sim/material.hpp"
#include "sim/triangle_mesh.hpp"

namespace sculpt::lab {

using Vec3 = std::array<double, 3>;

struct Spring {
  std::uint32_t i, j;
  double rest;  // rest length (spring model)
};

struct Model {
  sim::ForceModel force_model = sim::ForceModel::spring;
  double mass = 0.01, k = 200.0, c = 0.05, anchor = 2.0, anchor_c = 0.05, grab_k = 50.0;
  std::vector<double> rest;              // 3 per vertex
  std::vector<Spring> springs;           // unique edges with two distinct ends
  std::vector<std::uint8_t> pinned;      // per vertex: held at its rest position
  std::vector<std::uint32_t> grabbed;    // vertices held by the tool's grab springs
  std::vector<double> grab_offset;       // 3 per grabbed vertex: offset from the tool centre
  std::function<Vec3(double)> tool;      // tool centre at time t (needed when grabbed is not empty)

  std::size_t n() const { return pinned.size(); }
  bool damped() const { return c != 0.0 || anchor_c != 0.0; }

  // One particle per vertex, one spring per unique edge, as sim::Body builds them.
  static Model from_mesh(const sim::TriangleMesh& mesh, const sim::Material& material,
                         std::span<const std::uint32_t> pinned = {});
  // Grab every vertex within `reach` of `centre` (what a grabbing sphere tool holds).
  void grab_within(const Vec3& centre, double reach);
};

// Forces (N) on every vertex at time t, 3 per vertex; pinned vertices get 0.
// Returns the potential energy (springs, anchor, grab springs), J.
template <class S>
double forces(const Model& m, const S* x, const S* v, double t, S* f);

// Kinetic + potential energy, J.
template <class S>
double energy(const Model& m, const S* x, const S* v, double t);

// Jacobians of the forces at x: K = ∂f/∂x, C = ∂f/∂v (3n × 3n, symmetric, negative
// semi-definite). The spring model's geometric term is clamped at zero for
// compressed springs so that K stays semi-definite (the usual implicit-Euler choice).
template <class S>
void jacobians(const Model& m, const S* x, Eigen::SparseMatrix<S>& K, Eigen::SparseMatrix<S>& C);

}  // namespace sculpt::lab
