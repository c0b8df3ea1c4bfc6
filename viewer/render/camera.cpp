#include "render/camera.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace sculpt::view {

namespace {
constexpr float kDeg = 3.14159265358979f / 180.0f;
}

void Camera::fit(const Aabb& box, float aspect) {
  if (box.empty()) return;
  const Eigen::Vector3f lo(box.min[0], box.min[1], box.min[2]);
  const Eigen::Vector3f hi(box.max[0], box.max[1], box.max[2]);
  target = (lo + hi) * 0.5f;
  const float radius = std::max((hi - lo).norm() * 0.5f, 1e-3f);
  // The bounding sphere fits the narrower of the two fields of view.
  const float half_y = fov_y_deg * 0.5f * kDeg;
  const float half_x = std::atan(std::tan(half_y) * aspect);
  // 0.85: the sphere around the box is loose; the box itself still fits at any angle we start from.
  distance = radius / std::sin(std::min(half_y, half_x)) * 0.85f;
}

Eigen::Vector3f Camera::eye() const {
  const float yaw = yaw_deg * kDeg, pitch = pitch_deg * kDeg;
  const Eigen::Vector3f dir(std::cos(pitch) * std::sin(yaw), std::sin(pitch), std::cos(pitch) * std::cos(yaw));
  return target + dir * distance;
}

Eigen::Matrix4f Camera::view() const { return look_at(eye(), target, Eigen::Vector3f(0, 1, 0)); }

Eigen::Matrix4f Camera::projection(float aspect) const {
  const float near_z = std::max(distance * 0.02f, 1e-4f);
  return perspective(fov_y_deg * kDeg, aspect, near_z, distance * 10.0f + 1.0f);
}

void Camera::orbit(float dyaw, float dpitch) {
  yaw_deg = std::fmod(yaw_deg + dyaw, 360.0f);
  pitch_deg = std::clamp(pitch_deg + dpitch, -89.0f, 89.0f);
}

void Camera::pan(float dx, float dy) {
  const Eigen::Matrix4f v = view();
  const Eigen::Vector3f right(v(0, 0), v(0, 1), v(0, 2));
  const Eigen::Vector3f up(v(1, 0), v(1, 1), v(1, 2));
  const float height = 2.0f * distance * std::tan(fov_y_deg * 0.5f * kDeg);
  target += (-dx * right + dy * up) * height;
}

void Camera::zoom(float factor) { distance = std::clamp(distance * factor, 1e-3f, 1e4f); }

Eigen::Matrix4f look_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target, const Eigen::Vector3f& up) {
  const Eigen::Vector3f f = (target - eye).normalized();
  Eigen::Vector3f s = f.cross(up);
  if (s.squaredNorm() < 1e-12f) s = f.cross(Eigen::Vector3f(0, 0, 1));  // looking straight down
  s.normalize();
  const Eigen::Vector3f u = s.cross(f);
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m;
}

Eigen::Matrix4f perspective(float fov_y, float aspect, float n, float f) {
  const float t = 1.0f / std::tan(fov_y * 0.5f);
  Eigen::Matrix4f m = Eigen::Matrix4f::Zero();
  m(0, 0) = t / aspect;
  m(1, 1) = t;
  m(2, 2) = (f + n) / (n - f);
  m(2, 3) = 2.0f * f * n / (n - f);
  m(3, 2) = -1.0f;
  return m;
}

}  // namespace sculpt::view
