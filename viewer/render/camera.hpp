// An orbit camera: it looks at `target` from `distance` away, turned `yaw`
// degrees about the vertical (y) axis and raised `pitch` degrees above the
// horizontal plane.
#pragma once

#include <Eigen/Core>

#include "render/model.hpp"

namespace sculpt::view {

struct Camera {
  Eigen::Vector3f target{0, 0, 0};
  float yaw_deg = 20.0f;
  float pitch_deg = 25.0f;
  float distance = 1.0f;
  float fov_y_deg = 40.0f;

  // Places target and distance so the whole box is in view (yaw/pitch kept).
  void fit(const Aabb& box, float aspect);

  Eigen::Vector3f eye() const;
  Eigen::Matrix4f view() const;
  Eigen::Matrix4f projection(float aspect) const;

  // Mouse: orbit by degrees, pan by a fraction of the view height, zoom by a factor.
  void orbit(float dyaw_deg, float dpitch_deg);
  void pan(float dx_frac, float dy_frac);
  void zoom(float factor);
};

Eigen::Matrix4f look_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target, const Eigen::Vector3f& up);
Eigen::Matrix4f perspective(float fov_y_rad, float aspect, float near_z, float far_z);

}  // namespace sculpt::view
