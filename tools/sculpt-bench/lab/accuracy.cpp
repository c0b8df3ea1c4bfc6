#include "lab/accuracy.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "sim/world.hpp"

namespace sculpt::lab {
namespace {

using Clock = std::chrono::steady_clock;

sim::Integrator to_sim(Method m) {
  switch (m) {
    case Method::position_verlet: return sim::Integrator::position_verlet;
    case Method::velocity_verlet: return sim::Integrator::velocity_verlet;
    case Method::symplectic_euler: return sim::Integrator::symplectic_euler;
    default: throw std::invalid_argument("the daemon has no " + std::string(name(m)) + " integrator");
  }
}

// Initial state: the analytic one, or rest. Position Verlet (lab and daemon)
// gets the "velocity" that puts x_prev exactly on the solution one step back.
void initial_state(const Problem& p, Method method, double h, std::vector<double>& x0, std::vector<double>& v0) {
  if (!p.exact) {
    x0 = p.model.rest;
    v0.assign(x0.size(), 0.0);
    return;
  }
  p.exact(0.0, x0);
  if (method == Method::position_verlet) {
    std::vector<double> back;
    p.exact(-h, back);
    v0.resize(x0.size());
    for (std::size_t q = 0; q < x0.size(); ++q) v0[q] = (x0[q] - back[q]) / h;
  } else {
    p.exact_velocity(0.0, v0);
  }
}

// The tool as World sees it: a pose per tick end, interpolated linearly across substeps.
std::function<Vec3(double)> tick_interpolated(const std::function<Vec3(double)>& path, double dt) {
  return [path, dt](double t) {
    const double n = std::floor(t / dt + 1e-9);
    const double a = t / dt - n;
    const Vec3 p0 = path(n * dt), p1 = path((n + 1) * dt);
    return Vec3{p0[0] + (p1[0] - p0[0]) * a, p0[1] + (p1[1] - p0[1]) * a, p0[2] + (p1[2] - p0[2]) * a};
  };
}

// Errors and energy from the positions at each tick.
struct Tally {
  const Problem& p;
  const Reference* ref;
  double dt;
  std::vector<double> truth, prev, prev2, vel;
  double max = 0, sum2 = 0, energy0 = 0, energy_err = 0;
  std::uint64_t samples = 0;
  bool diverged = false;

  Tally(const Problem& pr, const Reference* r, double dt_) : p(pr), ref(r), dt(dt_) {
    if (p.undamped && p.exact) {
      std::vector<double> x, v;
      p.exact(0.0, x);
      p.exact_velocity(0.0, v);
      energy0 = energy<double>(p.model, x.data(), v.data(), 0.0);
    }
  }

  void add(int tick, const std::vector<double>& x) {
    const double t = tick * dt;
    if (p.exact) {
      p.exact(t, truth);
    } else {
      const double idx = t / ref->dt;
      const auto i = static_cast<std::size_t>(std::llround(idx));
      if (i >= ref->x.size() || std::abs(idx - double(i)) > 1e-6)
        throw std::logic_error("reference not sampled at t = " + std::to_string(t));
      truth = ref->x[i];
    }
    for (std::size_t i = 0; i < x.size() / 3; ++i) {
      double e2 = 0;
      for (int d = 0; d < 3; ++d) e2 += (x[3 * i + d] - truth[3 * i + d]) * (x[3 * i + d] - truth[3 * i + d]);
      if (!std::isfinite(e2)) {
        diverged = true;
        return;
      }
      max = std::max(max, std::sqrt(e2));
      sum2 += e2;
      ++samples;
    }
    if (max > 100.0 * p.scale) diverged = true;
    // Energy at the previous tick, from the central difference of positions.
    if (energy0 > 0 && !prev2.empty()) {
      vel.resize(x.size());
      for (std::size_t q = 0; q < x.size(); ++q) vel[q] = (x[q] - prev2[q]) / (2.0 * dt);
      const double e = energy<double>(p.model, prev.data(), vel.data(), t - dt);
      energy_err = std::max(energy_err, std::abs(e - energy0) / energy0);
    }
    prev2.swap(prev);
    prev = x;
  }
};

template <class S>
CaseResult run_lab(const Problem& p, const CaseSpec& spec, const Reference* ref) {
  CaseResult r;
  r.spec = spec;
  const double h = spec.dt / spec.substeps;
  Model model = p.model;
  if (p.tool_path) model.tool = tick_interpolated(p.tool_path, spec.dt);
  std::vector<double> x0, v0;
  initial_state(p, spec.method, h, x0, v0);
  Stepper<S> st(model, spec.method, h, x0, v0);
  Tally tally(p, ref, spec.dt);
  const int ticks = static_cast<int>(std::llround(p.t_end / spec.dt));
  std::vector<double> x(x0.size());
  double seconds = 0;
  for (int n = 1; n <= ticks && !tally.diverged; ++n) {
    const auto t0 = Clock::now();
    for (int s = 0; s < spec.substeps; ++s) st.step();
    seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    for (std::size_t q = 0; q < x.size(); ++q) x[q] = double(st.x()[q]);
    tally.add(n, x);
    r.ticks = n;
  }
  r.seconds = seconds;
  r.spring_passes = st.spring_passes();
  r.diverged = tally.diverged;
  r.error_max = tally.max;
  r.error_rms = tally.samples ? std::sqrt(tally.sum2 / double(tally.samples)) : 0.0;
  if (tally.energy0 > 0) r.energy_error = tally.energy_err;
  return r;
}

template <class S>
CaseResult run_daemon(const Problem& p, const CaseSpec& spec, const Reference* ref) {
  CaseResult r;
  r.spec = spec;
  sim::SimSettings settings;
  settings.rate_hz = 1.0 / spec.dt;
  settings.substeps = spec.substeps;
  settings.sleep_speed = 0.0;  // accuracy of the integrator, not of sleeping
  settings.integrator = to_sim(spec.method);
  sim::World<S> world(settings, 1);
  sim::BodyOptions options;
  options.pinned = p.pinned;
  world.add_body(p.mesh, p.material, options);
  world.wake_all(0);
  const double h = spec.dt / spec.substeps;
  std::vector<double> x0, v0;
  initial_state(p, spec.method, h, x0, v0);
  if (p.exact)
    for (std::uint32_t i = 0; i < p.model.n(); ++i)
      world.set_state(0, i, {x0[3 * i], x0[3 * i + 1], x0[3 * i + 2]}, {v0[3 * i], v0[3 * i + 1], v0[3 * i + 2]});
  Tally tally(p, ref, spec.dt);
  const int ticks = static_cast<int>(std::llround(p.t_end / spec.dt));
  std::vector<double> x(x0.size());
  double seconds = 0;
  sim::Tool tool;
  tool.radius = p.tool_radius;
  tool.grab = true;
  for (int n = 1; n <= ticks && !tally.diverged; ++n) {
    const std::size_t tools = p.tool_path ? 1 : 0;
    if (tools) {
      tool.position = p.tool_path(n * spec.dt);  // the pose at the end of this tick
      if (n == 1) {
        const Vec3 a = p.tool_path(0.0);
        for (int d = 0; d < 3; ++d) tool.velocity[d] = (tool.position[d] - a[d]) / spec.dt;
      }
    }
    const auto t0 = Clock::now();
    world.step({&tool, tools});
    seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    for (std::uint32_t i = 0; i < p.model.n(); ++i) {
      const sim::Vec3d q = world.position(0, i);
      x[3 * i] = q[0], x[3 * i + 1] = q[1], x[3 * i + 2] = q[2];
    }
    tally.add(n, x);
    r.ticks = n;
  }
  r.seconds = seconds;
  r.spring_passes = std::uint64_t(r.ticks) * std::uint64_t(world.substeps(0));
  r.blowups = world.stats().blowups_total;
  r.diverged = tally.diverged;
  r.error_max = tally.max;
  r.error_rms = tally.samples ? std::sqrt(tally.sum2 / double(tally.samples)) : 0.0;
  if (tally.energy0 > 0) r.energy_error = tally.energy_err;
  return r;
}

}  // namespace

bool daemon_has(Method m) {
  return m == Method::position_verlet || m == Method::velocity_verlet || m == Method::symplectic_euler;
}

Reference make_reference(const Problem& p, double dt, int refine) {
  Reference ref;
  ref.dt = dt;
  const double h = dt / refine;
  std::vector<double> x0, v0;
  initial_state(p, Method::rk4, h, x0, v0);
  Stepper<double> st(p.model, Method::rk4, h, x0, v0);
  const int ticks = static_cast<int>(std::llround(p.t_end / dt));
  ref.x.reserve(ticks + 1);
  ref.x.push_back(x0);
  for (int n = 1; n <= ticks; ++n) {
    for (int s = 0; s < refine; ++s) st.step();
    ref.x.push_back(st.x());
  }
  return ref;
}

const Reference* ReferenceCache::get(double dt) {
  if (p_.exact) return nullptr;
  auto it = refs_.find(dt);
  if (it != refs_.end()) return &it->second;
  const int refine = std::max(refine_, static_cast<int>(std::ceil(refine_ * dt / finest_ - 1e-9)));
  return &refs_.emplace(dt, make_reference(p_, dt, refine)).first->second;
}

CaseResult run_case(const Problem& p, const CaseSpec& spec, const Reference* ref) {
  if (!(spec.dt > 0) || spec.substeps < 1) throw std::invalid_argument("dt must be > 0 and substeps >= 1");
  if (!p.exact && !ref) throw std::invalid_argument("problem " + p.name + " needs a reference run");
  if (spec.impl == Impl::daemon) {
    if (!daemon_has(spec.method))
      throw std::invalid_argument("the daemon has no " + std::string(name(spec.method)) + " integrator");
    return spec.use_double ? run_daemon<double>(p, spec, ref) : run_daemon<float>(p, spec, ref);
  }
  return spec.use_double ? run_lab<double>(p, spec, ref) : run_lab<float>(p, spec, ref);
}

double convergence_order(const std::vector<CaseResult>& cases) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int n = 0;
  for (const CaseResult& c : cases) {
    if (c.diverged || !(c.error_max > 0)) continue;
    const double lx = std::log(c.spec.dt / c.spec.substeps), ly = std::log(c.error_max);
    sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly, ++n;
  }
  if (n < 2) return std::numeric_limits<double>::quiet_NaN();
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

std::vector<std::size_t> pareto_front(const std::vector<CaseResult>& cases, double rel_margin) {
  std::vector<std::size_t> front;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    if (cases[i].diverged) continue;
    bool dominated = false;
    for (std::size_t j = 0; j < cases.size() && !dominated; ++j)
      dominated = j != i && !cases[j].diverged && cases[j].spring_passes <= cases[i].spring_passes &&
                  cases[j].error_max < cases[i].error_max * (1.0 - rel_margin);
    if (!dominated) front.push_back(i);
  }
  return front;
}

}  // namespace sculpt::lab
