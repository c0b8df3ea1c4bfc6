#include "lab/integrators.hpp"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>
#include <cmath>
#include <limits>

namespace sculpt::lab {

std::string_view name(Method m) {
  switch (m) {
    case Method::position_verlet: return "verlet";
    case Method::velocity_verlet: return "velocity_verlet";
    case Method::symplectic_euler: return "symplectic_euler";
    case Method::explicit_euler: return "explicit_euler";
    case Method::implicit_euler: return "implicit_euler";
    case Method::xpbd: return "xpbd";
    case Method::rk4: return "rk4";
  }
  return "?";
}

std::optional<Method> parse_method(std::string_view s) {
  for (Method m : kAllMethods)
    if (s == name(m)) return m;
  if (s == "rk4") return Method::rk4;
  if (s == "position_verlet") return Method::position_verlet;
  if (s == "vverlet") return Method::velocity_verlet;
  if (s == "euler") return Method::explicit_euler;
  if (s == "implicit") return Method::implicit_euler;
  return std::nullopt;
}

template <class S>
Stepper<S>::Stepper(const Model& model, Method method, double h, std::span<const double> x0,
                    std::span<const double> v0, double t0)
    : m_(model), method_(method), h_(h), t_(t0) {
  const std::size_t dof = 3 * model.n();
  x_.resize(dof), w_.resize(dof), f_.resize(dof), scratch_.resize(dof);
  for (std::size_t q = 0; q < dof; ++q) {
    x_[q] = S(x0[q]);
    w_[q] = method == Method::position_verlet ? S(x0[q] - v0[q] * h) : S(v0[q]);
  }
}

template <class S>
std::vector<S> Stepper<S>::velocity() const {
  if (method_ != Method::position_verlet) return w_;
  std::vector<S> v(x_.size());
  const S inv_h = S(1.0 / h_);
  for (std::size_t q = 0; q < v.size(); ++q) v[q] = (x_[q] - w_[q]) * inv_h;
  return v;
}

template <class S>
bool Stepper<S>::finite() const {
  for (std::size_t q = 0; q < x_.size(); ++q)
    if (!std::isfinite(x_[q]) || !std::isfinite(w_[q])) return false;
  return true;
}

template <class S>
void Stepper<S>::step() {
  const std::size_t dof = x_.size();
  const S h = S(h_), inv_m = S(1.0 / m_.mass);
  auto pinned = [&](std::size_t q) { return m_.pinned[q / 3] != 0; };
  switch (method_) {
    case Method::position_verlet: {
      const S inv_h = S(1.0 / h_);
      for (std::size_t q = 0; q < dof; ++q) scratch_[q] = (x_[q] - w_[q]) * inv_h;
      forces(m_, x_.data(), scratch_.data(), t_, f_.data());
      ++passes_;
      for (std::size_t q = 0; q < dof; ++q) {
        if (pinned(q)) continue;
        const S next = S(2) * x_[q] - w_[q] + f_[q] * inv_m * h * h;
        w_[q] = x_[q];
        x_[q] = next;
      }
      break;
    }
    case Method::symplectic_euler:
      forces(m_, x_.data(), w_.data(), t_, f_.data());
      ++passes_;
      for (std::size_t q = 0; q < dof; ++q) {
        if (pinned(q)) continue;
        w_[q] += f_[q] * inv_m * h;
        x_[q] += w_[q] * h;
      }
      break;
    case Method::explicit_euler:
      forces(m_, x_.data(), w_.data(), t_, f_.data());
      ++passes_;
      for (std::size_t q = 0; q < dof; ++q) {
        if (pinned(q)) continue;
        x_[q] += w_[q] * h;
        w_[q] += f_[q] * inv_m * h;
      }
      break;
    case Method::velocity_verlet: {
      if (!have_forces_) {
        forces(m_, x_.data(), w_.data(), t_, f_.data());
        ++passes_;
        have_forces_ = true;
      }
      const S half = S(0.5) * h;
      for (std::size_t q = 0; q < dof; ++q) {
        if (pinned(q)) continue;
        w_[q] += f_[q] * inv_m * half;
        x_[q] += w_[q] * h;
      }
      forces(m_, x_.data(), w_.data(), t_ + h_, f_.data());
      ++passes_;
      for (std::size_t q = 0; q < dof; ++q)
        if (!pinned(q)) w_[q] += f_[q] * inv_m * half;
      break;
    }
    case Method::implicit_euler: implicit_step(); break;
    case Method::xpbd: xpbd_step(); break;
    case Method::rk4: rk4_step(); break;
  }
  t_ += h_;
}

template <class S>
void Stepper<S>::implicit_step() {
  using Vec = Eigen::Matrix<S, Eigen::Dynamic, 1>;
  using Mat = Eigen::SparseMatrix<S>;
  const Eigen::Index dof = Eigen::Index(x_.size());
  const S h = S(h_);
  forces(m_, x_.data(), w_.data(), t_ + h_, f_.data());  // forcing (grab target) at the end of the step
  ++passes_;
  Mat K, C;
  jacobians(m_, x_.data(), K, C);
  ++passes_;
  Eigen::Map<const Vec> v(w_.data(), dof), f(f_.data(), dof);
  Vec rhs = h * (f + h * (K * v));
  Mat A = -h * C - h * h * K;
  for (Eigen::Index q = 0; q < dof; ++q) A.coeffRef(q, q) += S(m_.mass);
  // Pinned degrees of freedom: Δv = 0 (identity rows and columns, zero right-hand side).
  for (Eigen::Index q = 0; q < dof; ++q)
    if (m_.pinned[q / 3]) rhs[q] = 0;
  for (int k = 0; k < A.outerSize(); ++k)
    for (typename Mat::InnerIterator it(A, k); it; ++it)
      if (m_.pinned[it.row() / 3] || m_.pinned[it.col() / 3]) it.valueRef() = it.row() == it.col() ? S(1) : S(0);
  Eigen::ConjugateGradient<Mat, Eigen::Lower | Eigen::Upper> cg;
  cg.setTolerance(std::is_same_v<S, float> ? S(1e-6) : S(1e-12));
  cg.setMaxIterations(int(dof));
  cg.compute(A);
  Vec dv = cg.solve(rhs);
  passes_ += std::uint64_t(cg.iterations());
  for (Eigen::Index q = 0; q < dof; ++q) {
    if (m_.pinned[q / 3]) continue;
    w_[q] += dv[q];
    x_[q] += w_[q] * h;
  }
}

template <class S>
void Stepper<S>::xpbd_step() {
  // Müller et al., "Small steps in physics simulation" (2019): one sweep of the
  // constraints per substep, λ reset every substep. Springs, the anchor and the
  // grab springs are compliant constraints (α = 1/stiffness); the dampers are
  // explicit forces in the prediction.
  const std::size_t dof = x_.size(), n = m_.n();
  const S h = S(h_), inv_h = S(1.0 / h_), inv_m = S(1.0 / m_.mass);
  if (m_.damped()) {
    // Damper forces only: a model copy without springs would allocate; do it by hand.
    for (std::size_t q = 0; q < dof; ++q) f_[q] = -S(m_.anchor_c) * w_[q];
    for (const Spring& s : m_.springs) {
      const std::size_t a = 3 * s.i, b = 3 * s.j;
      if (m_.force_model == sim::ForceModel::linear) {
        for (int d = 0; d < 3; ++d) {
          const S fd = S(m_.c) * (w_[b + d] - w_[a + d]);
          f_[a + d] += fd, f_[b + d] -= fd;
        }
      } else {
        S d3[3], len2 = 0;
        for (int d = 0; d < 3; ++d) d3[d] = x_[b + d] - x_[a + d], len2 += d3[d] * d3[d];
        if (len2 <= S(0)) continue;
        S dvn = 0;
        for (int d = 0; d < 3; ++d) dvn += (w_[b + d] - w_[a + d]) * d3[d];
        const S mag = S(m_.c) * dvn / len2;
        for (int d = 0; d < 3; ++d) f_[a + d] += mag * d3[d], f_[b + d] -= mag * d3[d];
      }
    }
    ++passes_;
    for (std::size_t q = 0; q < dof; ++q)
      if (!m_.pinned[q / 3]) w_[q] += f_[q] * inv_m * h;
  }
  // Predict.
  for (std::size_t q = 0; q < dof; ++q) {
    scratch_[q] = x_[q];  // x at the start of the substep
    if (!m_.pinned[q / 3]) x_[q] += w_[q] * h;
  }
  auto wgt = [&](std::uint32_t i) { return m_.pinned[i] ? S(0) : inv_m; };
  const S h2 = h * h;
  for (const Spring& s : m_.springs) {
    const std::size_t a = 3 * s.i, b = 3 * s.j;
    const S wa = wgt(s.i), wb = wgt(s.j), at = S(1.0 / m_.k) / h2;
    if (wa + wb == S(0) || m_.k <= 0) continue;
    if (m_.force_model == sim::ForceModel::linear) {
      for (int d = 0; d < 3; ++d) {  // C = u_j − u_i per axis
        const S cval = (x_[b + d] - x_[a + d]) - S(m_.rest[b + d] - m_.rest[a + d]);
        const S dl = -cval / (wa + wb + at);
        x_[a + d] -= wa * dl, x_[b + d] += wb * dl;
      }
    } else {
      S d3[3], len2 = 0;
      for (int d = 0; d < 3; ++d) d3[d] = x_[b + d] - x_[a + d], len2 += d3[d] * d3[d];
      const S len = std::sqrt(len2);
      if (len <= S(0)) continue;
      const S dl = -(len - S(s.rest)) / (wa + wb + at);
      for (int d = 0; d < 3; ++d) {
        const S g = d3[d] / len;
        x_[a + d] -= wa * dl * g, x_[b + d] += wb * dl * g;
      }
    }
  }
  if (m_.anchor > 0)
    for (std::size_t i = 0; i < n; ++i) {
      if (m_.pinned[i]) continue;
      const S at = S(1.0 / m_.anchor) / h2;
      for (int d = 0; d < 3; ++d) {
        const S cval = x_[3 * i + d] - S(m_.rest[3 * i + d]);
        x_[3 * i + d] += -cval / (inv_m + at) * inv_m;
      }
    }
  if (!m_.grabbed.empty() && m_.grab_k > 0) {
    const Vec3 c = m_.tool(t_ + h_);
    const S at = S(1.0 / m_.grab_k) / h2;
    for (std::size_t g = 0; g < m_.grabbed.size(); ++g)
      for (int d = 0; d < 3; ++d) {
        const std::size_t q = 3 * m_.grabbed[g] + d;
        const S cval = x_[q] - S(c[d] + m_.grab_offset[3 * g + d]);
        x_[q] += -cval / (inv_m + at) * inv_m;
      }
  }
  ++passes_;
  for (std::size_t q = 0; q < dof; ++q)
    if (!m_.pinned[q / 3]) w_[q] = (x_[q] - scratch_[q]) * inv_h;
}

template <class S>
void Stepper<S>::rk4_step() {
  const std::size_t dof = x_.size();
  const S h = S(h_), inv_m = S(1.0 / m_.mass);
  std::vector<S> xs(dof), vs(dof), kx(dof, 0), kv(dof, 0), f(dof);
  auto stage = [&](double t, S c, S weight, bool first) {
    // x_s = x + c·(k_x of the previous stage), same for v; accumulate the weighted slopes.
    for (std::size_t q = 0; q < dof; ++q) {
      xs[q] = first ? x_[q] : x_[q] + c * h * scratch_[q];
      vs[q] = first ? w_[q] : w_[q] + c * h * f_[q];
    }
    forces(m_, xs.data(), vs.data(), t, f.data());
    ++passes_;
    for (std::size_t q = 0; q < dof; ++q) {
      scratch_[q] = vs[q];          // dx/dt of this stage
      f_[q] = f[q] * inv_m;         // dv/dt of this stage
      kx[q] += weight * scratch_[q];
      kv[q] += weight * f_[q];
    }
  };
  stage(t_, 0, 1, true);
  stage(t_ + 0.5 * h_, S(0.5), 2, false);
  stage(t_ + 0.5 * h_, S(0.5), 2, false);
  stage(t_ + h_, S(1), 1, false);
  for (std::size_t q = 0; q < dof; ++q) {
    if (m_.pinned[q / 3]) continue;
    x_[q] += h / S(6) * kx[q];
    w_[q] += h / S(6) * kv[q];
  }
}

template class Stepper<float>;
template class Stepper<double>;

}  // namespace sculpt::lab
