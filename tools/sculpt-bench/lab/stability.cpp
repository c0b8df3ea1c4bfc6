#include "lab/stability.hpp"

#include <Eigen/SparseCore>
#include <cmath>

#include "lab/integrators.hpp"
#include "sim/world.hpp"

namespace sculpt::lab {
namespace {

// A deterministic kick of every vertex: every mode, the stiffest included.
double kick(std::size_t i, int d) { return 1e-3 * std::sin(double(i) * (12.9898 + 65.1 * d) + 0.37 * d); }

// Tracks the displacement: unstable once it reaches 100× its early maximum.
struct Growth {
  double early = 0, late = 0;
  bool finite = true;
  void add(int step, double disp) {
    if (!std::isfinite(disp)) finite = false;
    (step < 20 ? early : late) = std::max(step < 20 ? early : late, disp);
  }
  bool stable() const { return finite && late <= 100.0 * std::max(early, 1e-300); }
};

}  // namespace

PowerIteration power_iteration(const Model& m, int max_iterations, double tolerance) {
  using Vec = Eigen::VectorXd;
  PowerIteration out;
  Eigen::SparseMatrix<double> K, C;
  jacobians<double>(m, m.rest.data(), K, C);
  const Eigen::Index dof = K.rows();
  Vec free = Vec::Ones(dof);
  for (Eigen::Index q = 0; q < dof; ++q)
    if (m.pinned[q / 3]) free[q] = 0;
  Vec v(dof);
  for (Eigen::Index q = 0; q < dof; ++q) v[q] = free[q] * (1.0 + 0.5 * std::sin(double(q) * 0.7543 + 0.1));
  if (v.norm() == 0) return out;
  v.normalize();
  double lambda = 0;
  for (int it = 1; it <= max_iterations; ++it) {
    Vec w = -(K * v) / m.mass;
    w = w.cwiseProduct(free);
    const double next = v.dot(w);  // Rayleigh quotient (v normalised)
    const double nw = w.norm();
    out.iterations = it;
    if (nw == 0) break;
    v = w / nw;
    if (it > 10 && std::abs(next - lambda) <= tolerance * std::abs(next)) {
      lambda = next;
      out.converged = true;
      break;
    }
    lambda = next;
  }
  out.lambda_max = lambda;
  out.mu = -v.dot(C * v) / m.mass;
  return out;
}

double verlet_dt_limit(double lambda, double mu) {
  const double beta = 0.5 * mu;
  if (lambda <= 0 && beta <= 0) return INFINITY;
  return 2.0 / (std::sqrt(lambda + beta * beta) + beta);
}

bool verlet_stable_lab(const Model& m, double dt, int ticks) {
  std::vector<double> v0(m.rest.size());
  for (std::size_t q = 0; q < v0.size(); ++q) v0[q] = m.pinned[q / 3] ? 0.0 : kick(q / 3, int(q % 3));
  Stepper<double> st(m, Method::position_verlet, dt, m.rest, v0);
  Growth g;
  for (int n = 0; n < ticks; ++n) {
    st.step();
    double disp = 0;
    for (std::size_t q = 0; q < v0.size(); ++q) disp = std::max(disp, std::abs(st.x()[q] - m.rest[q]));
    if (std::isnan(disp)) disp = INFINITY;
    g.add(n, disp);
    if (!g.finite || (n >= 20 && !g.stable())) return false;
  }
  return g.stable();
}

bool verlet_stable_daemon(const sim::TriangleMesh& mesh, const sim::Material& material,
                          std::span<const std::uint32_t> pinned, double dt, int ticks) {
  sim::SimSettings s;
  s.rate_hz = 1.0 / dt;
  s.substeps = 1;
  s.sleep_speed = 0.0;
  sim::World<double> w(s, 1);
  sim::BodyOptions o;
  o.pinned.assign(pinned.begin(), pinned.end());
  w.add_body(mesh, material, o);
  w.wake_all(0);
  for (std::uint32_t i = 0; i < mesh.positions.size(); ++i) {
    const auto& p = mesh.positions[i];
    w.set_state(0, i, {p[0], p[1], p[2]}, {kick(i, 0), kick(i, 1), kick(i, 2)});
  }
  Growth g;
  for (int n = 0; n < ticks; ++n) {
    w.step({});
    if (w.stats().blowups_total > 0) return false;
    double disp = 0;
    for (std::uint32_t i = 0; i < mesh.positions.size(); ++i) {
      const sim::Vec3d p = w.position(0, i);
      for (int d = 0; d < 3; ++d) disp = std::max(disp, std::abs(p[d] - double(mesh.positions[i][d])));
    }
    if (std::isnan(disp)) disp = INFINITY;
    g.add(n, disp);
    if (!g.finite || (n >= 20 && !g.stable())) return false;
  }
  return g.stable();
}

}  // namespace sculpt::lab
