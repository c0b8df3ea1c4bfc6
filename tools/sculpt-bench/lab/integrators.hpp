// Six integrators on the lab model, each in float or double. The first three
// mirror daemon/sim's (same formulas, so the lab's position Verlet reproduces
// World's to rounding: tested); the other three exist only here, for the study.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "lab/model.hpp"

namespace sculpt::lab {

enum class Method {
  position_verlet,   // x' = 2x − x_prev + a·h², damper on the backward difference (the daemon's default)
  velocity_verlet,   // half kick, drift, forces (damper sees the half-step velocity), half kick
  symplectic_euler,  // v' = v + a·h, x' = x + v'·h
  explicit_euler,    // x' = x + v·h, v' = v + a·h
  implicit_euler,    // (M − hC − h²K)Δv = h(f + hKv), one linearised step, Eigen conjugate gradients
  xpbd,              // small-steps XPBD: one constraint pass per substep, compliance 1/k, explicit dampers
  rk4,               // classical Runge-Kutta (4 force evaluations): the references, not a candidate
};

std::string_view name(Method m);
// Accepts the names above and the short forms "verlet", "vverlet", "euler", "implicit".
std::optional<Method> parse_method(std::string_view s);
inline constexpr Method kAllMethods[] = {Method::position_verlet, Method::velocity_verlet, Method::symplectic_euler,
                                         Method::explicit_euler,  Method::implicit_euler,  Method::xpbd};

template <class S>
class Stepper {
 public:
  // h: the step. State starts at x0 with velocity v0 (3 per vertex). Position
  // Verlet keeps x_prev = x0 − v0·h, exactly as World::set_state does.
  Stepper(const Model& model, Method method, double h, std::span<const double> x0, std::span<const double> v0,
          double t0 = 0.0);

  void step();
  double time() const { return t_; }
  const std::vector<S>& x() const { return x_; }
  // The integrator's own velocity (position Verlet: the backward difference).
  std::vector<S> velocity() const;
  // Work done so far, in passes over every spring (force evaluations, Jacobian
  // assemblies, conjugate-gradient iterations, constraint sweeps): the
  // deterministic cost measure.
  std::uint64_t spring_passes() const { return passes_; }
  bool finite() const;

 private:
  void implicit_step();
  void xpbd_step();
  void rk4_step();

  const Model& m_;
  Method method_;
  double h_, t_;
  std::vector<S> x_, w_, f_;  // w: previous positions (position Verlet) or velocities
  std::vector<S> scratch_;
  std::uint64_t passes_ = 0;
  bool have_forces_ = false;  // velocity Verlet keeps the last forces
  std::vector<double> xpbd_lambda_;
};

extern template class Stepper<float>;
extern template class Stepper<double>;

}  // namespace sculpt::lab
