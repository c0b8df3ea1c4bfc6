#include "lab/problems.hpp"

#include <cmath>
#include <stdexcept>

#include "sim/shapes.hpp"

namespace sculpt::lab {
namespace {

constexpr double kPi = 3.14159265358979323846;

sim::Material bare_linear(double mass, double k) {
  sim::Material m;
  m.model = sim::ForceModel::linear;
  m.mass = mass;
  m.stiffness = k;
  m.damping = m.anchor = m.anchor_damping = m.grab_stiffness = 0.0;
  return m;
}

std::vector<double> geometric(double coarse, int count) {
  std::vector<double> out;
  for (int i = 0; i < count; ++i) out.push_back(coarse / double(1 << i));
  return out;
}

// One free vertex between two pinned ones, linear springs: ω² = 2k/m, ω = 2π (1 s period).
Problem oscillator() {
  Problem p;
  p.name = "oscillator";
  p.mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  p.mesh.triangles = {{0, 1, 2}};
  p.material = bare_linear(1.0, 2.0 * kPi * kPi);
  p.pinned = {1, 2};
  p.model = Model::from_mesh(p.mesh, p.material, p.pinned);
  const double a = 0.1, w = 2.0 * kPi;
  p.omega = w;
  p.scale = a;
  p.undamped = true;
  p.t_end = 2.0;
  p.dts = geometric(1.0 / 25, 8);
  p.exact = [a, w](double t, std::vector<double>& x) { x = {a * std::cos(w * t), 0, 0, 1, 0, 0, 0, 1, 0}; };
  p.exact_velocity = [a, w](double t, std::vector<double>& v) {
    v.assign(9, 0.0);
    v[0] = -a * w * std::sin(w * t);
  };
  return p;
}

// Fixed-fixed chain of N masses: modes sin(jqπ/(N+1)), ω_q = 2√(k/m) sin(qπ/(2(N+1))).
// Modes 1 and 3, transverse (the linear model is the same on every axis).
Problem chain() {
  constexpr int N = 10;
  constexpr double k = 100.0, m = 0.5, A = 0.01, h = 0.1;
  Problem p;
  p.name = "chain";
  p.mesh = chain_mesh(N, float(h));
  p.material = bare_linear(m, k);
  p.pinned = {0, N + 1};
  p.model = Model::from_mesh(p.mesh, p.material, p.pinned);
  auto omega = [](int q) { return 2.0 * std::sqrt(k / m) * std::sin(q * kPi / (2.0 * (N + 1))); };
  auto shape = [](int j, int q) { return std::sin(j * q * kPi / (N + 1)); };
  const double w1 = omega(1), w3 = omega(3);
  p.omega = w1;
  p.scale = A;
  p.undamped = true;
  const double period = 2.0 * kPi / w1;
  p.t_end = 2.0 * period;
  p.dts = geometric(period / 25, 8);
  const std::vector<double> rest = p.model.rest;
  p.exact = [=](double t, std::vector<double>& x) {
    x = rest;
    for (int j = 1; j <= N; ++j)
      x[3 * j + 1] = A * shape(j, 1) * std::cos(w1 * t) + 0.5 * A * shape(j, 3) * std::cos(w3 * t);
  };
  p.exact_velocity = [=](double t, std::vector<double>& v) {
    v.assign(rest.size(), 0.0);
    for (int j = 1; j <= N; ++j)
      v[3 * j + 1] = -A * shape(j, 1) * w1 * std::sin(w1 * t) - 0.5 * A * shape(j, 3) * w3 * std::sin(w3 * t);
  };
  return p;
}

// A rubber ball (the default material) whose top is grabbed and pulled up and
// sideways and back, smoothly (zero velocity at the start), twice in 0.5 s.
Problem mesh() {
  Problem p;
  p.name = "mesh";
  p.mesh = sim::make_icosphere(0.1f, 2);
  p.material = sim::Material{};
  p.model = Model::from_mesh(p.mesh, p.material);
  std::size_t top = 0;
  for (std::size_t i = 0; i < p.mesh.positions.size(); ++i)
    if (p.mesh.positions[i][1] > p.mesh.positions[top][1]) top = i;
  const Vec3 c0{p.mesh.positions[top][0], p.mesh.positions[top][1], p.mesh.positions[top][2]};
  const double amp = 0.02, period = 0.25;
  p.tool_path = [=](double t) {
    const double s = 0.5 * amp * (1.0 - std::cos(2.0 * kPi * t / period));
    return Vec3{c0[0] + 0.3 * s, c0[1] + s, c0[2]};
  };
  p.tool_radius = 0.03;
  p.model.grab_within(c0, 1.25 * p.tool_radius);  // what World's grab holds (kGrabReach = 1.25 radii)
  p.model.tool = p.tool_path;
  p.scale = amp;
  p.t_end = 0.5;
  p.dts = geometric(0.004, 6);  // 4 ms .. 0.125 ms
  return p;
}

}  // namespace

sim::TriangleMesh chain_mesh(int free_masses, float spacing) {
  sim::TriangleMesh mesh;
  for (int i = 0; i < free_masses + 2; ++i) mesh.positions.push_back({spacing * float(i), 0.0f, 0.0f});
  // Degenerate triangles {i, i+1, i+1} contribute one edge each.
  for (std::uint32_t i = 0; i + 1 < mesh.positions.size(); ++i) mesh.triangles.push_back({i, i + 1, i + 1});
  return mesh;
}

std::vector<std::string> problem_names() { return {"oscillator", "chain", "mesh"}; }

Problem make_problem(std::string_view name) {
  if (name == "oscillator") return oscillator();
  if (name == "chain") return chain();
  if (name == "mesh") return mesh();
  throw std::invalid_argument("--problem " + std::string(name) + ": expected oscillator, chain or mesh");
}

}  // namespace sculpt::lab
