// The straightforward implementation, kept as the yardstick for the fast path
// (sculpt-bench throughput --impl baseline): array-of-structs Eigen vectors,
// one loop over springs scattering into a force array, every vertex tested
// against the tool (no broadphase), no sleeping. Position Verlet only.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "sim/material.hpp"
#include "sim/settings.hpp"
#include "sim/tool.hpp"
#include "sim/triangle_mesh.hpp"

namespace sculpt::sim {

class BaselineBody {
 public:
  BaselineBody(const TriangleMesh& mesh, const Material& material, const SimSettings& settings);

  void step(const Tool* tool);  // one tick, same substeps as the fast path would choose
  int substeps() const { return substeps_; }
  std::size_t springs() const { return springs_.size(); }
  std::size_t bytes() const;
  const std::vector<Eigen::Vector3f>& positions() const { return x_; }

 private:
  struct Spring {
    std::uint32_t a, b;
    float rest_length;
  };
  Material material_;
  SimSettings settings_;
  int substeps_ = 1;
  std::vector<Eigen::Vector3f> x_, prev_, rest_, force_;
  std::vector<Spring> springs_;
};

}  // namespace sculpt::sim
