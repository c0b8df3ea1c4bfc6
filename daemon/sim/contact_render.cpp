#include "sim/contact_render.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace sculpt::sim {

namespace {

constexpr double kFarReleases = 10.0;  // release_distances in any direction that end a contact

double dot(const Vec3d& a, const Vec3d& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

Vec3d sub(const Vec3d& a, const Vec3d& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }

bool finite(const Vec3d& a) { return std::isfinite(a[0]) && std::isfinite(a[1]) && std::isfinite(a[2]); }

}  // namespace

ContactRenderer::ContactRenderer(double dt, const ContactRenderSettings& settings) : dt_(dt), settings_(settings) {
  if (!(dt > 0.0) || !std::isfinite(dt)) throw std::invalid_argument("contact renderer: dt must be positive");
  if (settings.window_ticks < 1 || settings.window_ticks > ContactRenderSettings::kMaxWindow)
    throw std::invalid_argument("contact renderer: window_ticks must be 1.." +
                                std::to_string(ContactRenderSettings::kMaxWindow));
  if (!(settings.smoothing >= 0.0) || settings.release_ticks < 0 || !(settings.release_distance >= 0.0) ||
      !(settings.contact_stiffness >= 0.0) || !(settings.max_tool_speed > 0.0))
    throw std::invalid_argument(
        "contact renderer: smoothing, release_ticks, release_distance, contact_stiffness must be >= 0 and "
        "max_tool_speed > 0");
}

void ContactRenderer::reset() {
  const double dt = dt_;
  const ContactRenderSettings s = settings_;
  *this = ContactRenderer(dt, s);
}

const RenderedContact& ContactRenderer::update(const ToolFeedback& raw, const Vec3d& p) {
  // The tool's velocity over this tick, the motion the raw force answered.
  Vec3d v{};
  bool teleported = false;
  if (have_pose_ && finite(p)) {
    const Vec3d d = sub(p, pose_);
    if (std::sqrt(dot(d, d)) > settings_.max_tool_speed * dt_)
      teleported = true;
    else
      v = {d[0] / dt_, d[1] / dt_, d[2] / dt_};
  }
  if (finite(p)) {
    pose_ = p;
    have_pose_ = true;
  }
  out_.onset = false;
  out_.onset_impulse = 0;  // as the world's feedback: set on the onset tick only
  out_.damped = 0;
  out_.contacts = raw.contacts;
  update_contact_state(raw, pose_, teleported);
  update_force(raw, v);
  keep_passive(v);
  return out_;
}

void ContactRenderer::update_contact_state(const ToolFeedback& raw, const Vec3d& p, bool teleported) {
  auto release = [&] {
    out_.touching = false;
    impulses_.fill({});
    impulse_sum_ = {};
    smoothed_ = {};
    normal_ = {};
    out_.depth = 0;
    head_ = 0;
  };
  if (teleported && out_.touching) release();
  if (raw.contacts > 0) {
    ticks_since_contact_ = 0;
    last_touch_ = p;
    if (!out_.touching) {
      out_.touching = true;
      out_.onset = true;
      out_.onset_impulse = finite(raw.force) ? std::sqrt(dot(raw.force, raw.force)) * dt_ : 0.0;
      energy_ = energy_held_ = 0;  // a new contact starts with nothing stored
      out_.depth = 0;
    }
    return;
  }
  if (ticks_since_contact_ < settings_.release_ticks) ++ticks_since_contact_;
  if (!out_.touching || ticks_since_contact_ < settings_.release_ticks) return;
  // Away from the surface (along the normal), or far in any direction (slid
  // off the mesh, or into a void where clay has flowed away).
  const Vec3d away = sub(p, last_touch_);
  const double far = kFarReleases * settings_.release_distance;
  if (dot(away, normal_) >= settings_.release_distance || dot(away, away) >= far * far) release();
}

void ContactRenderer::update_force(const ToolFeedback& raw, const Vec3d& v) {
  if (!out_.touching) {
    out_.force = {};
    return;
  }
  const int w = settings_.window_ticks;
  const Vec3d j = finite(raw.force) ? Vec3d{raw.force[0] * dt_, raw.force[1] * dt_, raw.force[2] * dt_} : Vec3d{};
  impulses_[head_] = j;
  if (++head_ == w) head_ = 0;
  // Summed afresh every tick (64 adds): a running sum would keep rounding
  // residue once the window is all zeros, and its direction is the normal.
  impulse_sum_ = {};
  for (int i = 0; i < w; ++i)
    for (int k = 0; k < 3; ++k) impulse_sum_[k] += impulses_[i][k];
  const double alpha = dt_ / (settings_.smoothing + dt_);
  for (int k = 0; k < 3; ++k) {
    const double mean = impulse_sum_[k] / (w * dt_);
    smoothed_[k] += alpha * (mean - smoothed_[k]);
  }
  // The proxy: depth grows with motion against the reaction, shrinks with
  // motion along it, and ignores motion across it (sliding on the surface).
  // The normal is taken on ticks of contact only: once the window is down to
  // its tail, what is left says nothing about the surface.
  const double sum = std::sqrt(dot(impulse_sum_, impulse_sum_));
  if (raw.contacts > 0 && sum > 0.0) normal_ = {impulse_sum_[0] / sum, impulse_sum_[1] / sum, impulse_sum_[2] / sum};
  // Deeper only while the mesh is being met (a tool sliding off it gains none).
  double deeper = out_.onset ? 0.0 : -dot(v, normal_) * dt_;
  if (deeper > 0.0 && ticks_since_contact_ >= settings_.release_ticks) deeper = 0.0;
  out_.depth = std::max(0.0, out_.depth + deeper);
  const double proxy = settings_.contact_stiffness * out_.depth;
  for (int k = 0; k < 3; ++k) out_.force[k] = smoothed_[k] + proxy * normal_[k];
}

// Hannaford–Ryu: the observer's energy after this tick must stay ≥ 0; if the
// force would take more out than the contact has put in, a damper along the
// velocity, −λv, removes the difference (λ ≥ 0 is the least that does).
void ContactRenderer::keep_passive(const Vec3d& v) {
  // The force a device held since the last tick met this tick's motion too.
  energy_held_ = std::max(0.0, energy_held_ - dot(held_force_, v) * dt_);
  if (!out_.touching) {
    held_force_ = {};
    return;
  }
  const double v2 = dot(v, v);
  const double returned = dot(out_.force, v) * dt_;  // energy the force gives the tool this tick
  // The held pairing is guarded on the guess that the next tick moves as this one did.
  const double stored = std::min(energy_, energy_held_);
  if (returned > stored && v2 > 0.0) {
    const double lambda = (returned - stored) / (v2 * dt_) * (1.0 + 1e-9);  // rounding stays on the safe side
    for (int k = 0; k < 3; ++k) out_.force[k] -= lambda * v[k];
    out_.damped = returned - stored;
  }
  energy_ = std::max(0.0, energy_ - dot(out_.force, v) * dt_);
  held_force_ = out_.force;
}

}  // namespace sculpt::sim
