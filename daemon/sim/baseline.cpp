#include "sim/baseline.hpp"

#include "sim/stability.hpp"

namespace sculpt::sim {

BaselineBody::BaselineBody(const TriangleMesh& mesh, const Material& material, const SimSettings& settings)
    : material_(material), settings_(settings) {
  substeps_ = choose_substeps(mesh, material, settings).substeps;
  for (const Vec3f& p : mesh.positions) x_.emplace_back(p[0], p[1], p[2]);
  prev_ = rest_ = x_;
  force_.assign(x_.size(), Eigen::Vector3f::Zero());
  for (const Edge& e : unique_edges(mesh.triangles))
    springs_.push_back({e.a, e.b, (x_[e.b] - x_[e.a]).norm()});
}

std::size_t BaselineBody::bytes() const {
  return sizeof(*this) + 4 * x_.capacity() * sizeof(Eigen::Vector3f) + springs_.capacity() * sizeof(Spring);
}

void BaselineBody::step(const Tool* tool) {
  const float dt = static_cast<float>(1.0 / settings_.rate_hz / substeps_);
  const float inv_dt = 1.0f / dt, k = static_cast<float>(material_.stiffness);
  const float c = static_cast<float>(material_.damping), ka = static_cast<float>(material_.anchor);
  const float ca = static_cast<float>(material_.anchor_damping), inv_m = static_cast<float>(1.0 / material_.mass);
  const bool linear = material_.model == ForceModel::linear;
  for (int s = 0; s < substeps_; ++s) {
    for (std::size_t i = 0; i < x_.size(); ++i)
      force_[i] = ka * (rest_[i] - x_[i]) - ca * (x_[i] - prev_[i]) * inv_dt;
    for (const Spring& sp : springs_) {
      const Eigen::Vector3f d = x_[sp.b] - x_[sp.a];
      const Eigen::Vector3f dv = ((x_[sp.b] - prev_[sp.b]) - (x_[sp.a] - prev_[sp.a])) * inv_dt;
      Eigen::Vector3f f;
      if (linear) {
        f = k * (d - (rest_[sp.b] - rest_[sp.a])) + c * dv;
      } else {
        const float len = d.norm();
        if (len < 1e-12f) continue;
        const Eigen::Vector3f n = d / len;
        f = (k * (len - sp.rest_length) + c * dv.dot(n)) * n;
      }
      force_[sp.a] += f;
      force_[sp.b] -= f;
    }
    for (std::size_t i = 0; i < x_.size(); ++i) {
      const Eigen::Vector3f next = 2.0f * x_[i] - prev_[i] + force_[i] * (inv_m * dt * dt);
      prev_[i] = x_[i];
      x_[i] = next;
    }
    if (tool && tool->active) {
      const Eigen::Vector3f centre(tool->position[0], tool->position[1], tool->position[2]);
      const float r = static_cast<float>(tool->radius);
      for (Eigen::Vector3f& p : x_) {
        const Eigen::Vector3f d = p - centre;
        const float len = d.norm();
        if (len < r && len > 0.0f) p = centre + d * (r / len);
      }
    }
  }
}

}  // namespace sculpt::sim
