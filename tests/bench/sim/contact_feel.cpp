// What a tool feels pressing the built-in scene's ball (icosphere r = 7 cm,
// 642 vertices) with a 2 cm sphere, raw (World::feedback) against rendered
// (sim::ContactRenderer), for rubber (the default material) and clay:
// force vs depth, the spread of a steady press, onsets while resting, and
// the energy balance of press/release cycles. Prints tables; --csv prints
// the force-depth curve only (scripts/force_depth_svg.py plots it).
//
//   build/tests/bench/sim/contact_feel [--csv]
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "sim/contact_render.hpp"
#include "sim/shapes.hpp"
#include "sim/world.hpp"

using namespace sculpt::sim;

namespace {

constexpr double kDt = 1e-3, kBall = 0.07, kTool = 0.02, kTouchY = kBall + kTool;

double norm(const Vec3d& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

Material clay() {  // the "clay" preset of daemon/scene
  Material m;
  m.name = "clay";
  m.stiffness = 300, m.damping = 0.3, m.anchor = 4, m.plastic = true, m.yield_strain = 0.01;
  return m;
}

// One ball, one tool from above, the raw and the rendered view of each tick.
struct Rig {
  explicit Rig(const Material& m) : world(SimSettings{}, 1), render(kDt) {
    world.add_body(make_icosphere(float(kBall), 3), m);
    tool.radius = kTool;
    y = prev_y = kTouchY + 0.002;
  }
  void step(double to) {
    y = to;
    tool.position = {0, y, 0};
    Tool tools[1] = {tool};
    world.step(tools);
    raw = world.feedback()[0];
    felt = render.update(raw, tool.position);
    const double dy = y - prev_y;
    // Energy into the environment: the force with the motion it answered
    // (as the passivity observer pairs them), and with the next tick's
    // motion (a force held while the device moves on).
    const double in = -felt.force[1] * dy, held = -held_force * dy;
    energy += in, energy_held += held;
    (in > 0 ? put_in : taken_out) += std::abs(in);
    min_energy = std::min(min_energy, energy), min_energy_held = std::min(min_energy_held, energy_held);
    damped += felt.damped;
    held_force = felt.force[1];
    prev_y = y;
    raw_onsets += raw.onset, onsets += felt.onset;
  }
  void move_to(double to, double speed, int hold) {
    while (y != to) step(y > to ? std::max(to, y - speed * kDt) : std::min(to, y + speed * kDt));
    for (int k = 0; k < hold; ++k) step(to);
  }
  World<float> world;
  ContactRenderer render;
  Tool tool;
  ToolFeedback raw;
  RenderedContact felt;
  double y, prev_y, held_force = 0;
  double energy = 0, energy_held = 0, min_energy = 0, min_energy_held = 0, put_in = 0, taken_out = 0, damped = 0;
  int raw_onsets = 0, onsets = 0;
};

struct Stats {
  double felt_mean = 0, felt_cv = 0, raw_mean = 0, raw_cv = 0;
};

Stats hold(Rig& r, int ticks) {
  double fs = 0, fs2 = 0, rs = 0, rs2 = 0;
  for (int k = 0; k < ticks; ++k) {
    r.step(r.y);
    const double f = norm(r.felt.force), g = norm(r.raw.force);
    fs += f, fs2 += f * f, rs += g, rs2 += g * g;
  }
  Stats s;
  s.felt_mean = fs / ticks, s.raw_mean = rs / ticks;
  auto cv = [&](double sum2, double mean) {
    return mean > 0 ? std::sqrt(std::max(0.0, sum2 / ticks - mean * mean)) / mean : 0.0;
  };
  s.felt_cv = cv(fs2, s.felt_mean), s.raw_cv = cv(rs2, s.raw_mean);
  return s;
}

// Quasi-static: creep down to the first touch, then steps, each settled
// 0.8 s and averaged over 0.3 s.
void force_depth(const Material& m, bool csv) {
  Rig r(m);
  r.move_to(kTouchY + 0.001, 0.02, 200);
  while (!r.felt.touching) r.step(r.y - 2e-5);
  const double touch = r.y;
  if (!csv) std::printf("\n%s: force vs depth from the first touch (%.2f mm below the rest surface)\n%8s %10s %10s\n",
                        m.name.c_str(), (kTouchY - touch) * 1e3, "depth mm", "felt N", "raw N");
  for (int step = 1; step <= 48; ++step) {
    const double depth = step <= 8 ? step * 2.5e-4 : 2e-3 + (step - 8) * 5e-4;
    r.move_to(touch - depth, 0.01, 800);
    const Stats s = hold(r, 300);
    if (csv)
      std::printf("%s,%.5f,%.6f,%.6f\n", m.name.c_str(), depth * 1e3, s.felt_mean, s.raw_mean);
    else if (step <= 8 || step % 4 == 0)
      std::printf("%8.2f %10.5f %10.5f\n", depth * 1e3, s.felt_mean, s.raw_mean);
  }
}

void steady(const Material& m) {
  std::printf("\n%s: steady press (2 s to settle, then 1 s)\n%8s %10s %8s %10s %8s\n", m.name.c_str(), "depth mm",
              "felt N", "felt CV", "raw N", "raw CV");
  for (const double depth : {0.0005, 0.001, 0.002, 0.005, 0.01, 0.02}) {
    Rig r(m);
    r.move_to(kTouchY - depth, 0.02, 2000);
    const Stats s = hold(r, 1000);
    std::printf("%8.1f %10.5f %7.1f%% %10.5f %7.1f%%\n", depth * 1e3, s.felt_mean, s.felt_cv * 100, s.raw_mean,
                s.raw_cv * 100);
  }
}

void resting(const Material& m) {
  std::printf("\n%s: resting 5 s after coming to rest (onsets per second)\n%8s %8s %8s\n", m.name.c_str(), "depth mm",
              "raw", "felt");
  for (const double depth : {0.0001, 0.0005, 0.001, 0.002, 0.005}) {
    Rig r(m);
    r.move_to(kTouchY - depth, 0.02, 200);
    const int raw0 = r.raw_onsets, felt0 = r.onsets;
    for (int k = 0; k < 5000; ++k) r.step(r.y);
    std::printf("%8.1f %8.1f %8.1f\n", depth * 1e3, (r.raw_onsets - raw0) / 5.0, (r.onsets - felt0) / 5.0);
  }
}

// put in / taken out: the felt force against the tool's motion, summed by
// sign; E: their difference over time (force with the tick's motion);
// E held: the force a device held while the tool made the next tick's motion;
// PC held: what the force before the passivity controller would have given
// back on the ticks where the controller held it (not all of it is excess).
void cycles(const Material& m) {
  std::printf("\n%s: press/release, 3 cycles from 1 mm above to A deep, then 1 s resting at A/2 (mJ)\n"
              "%6s %6s %9s %9s %11s %11s %13s %8s\n",
              m.name.c_str(), "Hz", "A mm", "put in", "taken out", "E at end", "min E(t)", "min E held", "PC held");
  for (const double hz : {0.5, 2.0, 6.0}) {
    for (const double amplitude : {0.003, 0.012, 0.02}) {
      Rig r(m);
      r.move_to(kTouchY + 0.001, 0.05, 50);
      const int ticks = static_cast<int>(3.0 / hz / kDt);
      for (int k = 0; k <= ticks; ++k)
        r.step(kTouchY + 0.001 - (amplitude + 0.001) * 0.5 * (1 - std::cos(2 * M_PI * hz * k * kDt)));
      r.move_to(kTouchY - amplitude / 2, 0.05, 1000);
      std::printf("%6.1f %6.0f %9.4f %9.4f %11.4f %11.2e %13.2e %8.4f\n", hz, amplitude * 1e3, r.put_in * 1e3,
                  r.taken_out * 1e3, r.energy * 1e3, r.min_energy * 1e3, r.min_energy_held * 1e3, r.damped * 1e3);
    }
  }
}

void onset_spike(const Material& m) {
  std::printf("\n%s: the onset (approach at 5 cm/s): largest force in the first 50 ms of contact\n", m.name.c_str());
  Rig r(m);
  r.move_to(kTouchY + 0.001, 0.05, 50);
  while (!r.felt.touching) r.step(r.y - 5e-5);
  const double impulse = r.felt.onset_impulse;
  double raw = norm(r.raw.force), felt = norm(r.felt.force);
  for (int k = 0; k < 50; ++k) {
    r.step(r.y - 5e-5);
    raw = std::max(raw, norm(r.raw.force)), felt = std::max(felt, norm(r.felt.force));
  }
  std::printf("  raw %.4f N, felt %.4f N; onset impulse %.2e N·s\n", raw, felt, impulse);
}

}  // namespace

int main(int argc, char** argv) {
  const bool csv = argc > 1 && std::strcmp(argv[1], "--csv") == 0;
  const std::vector<Material> materials{Material{}, clay()};
  if (csv) {
    std::printf("material,depth_mm,felt_N,raw_N\n");
    for (const Material& m : materials) force_depth(m, true);
    return 0;
  }
  std::printf("ball: icosphere r = %.0f mm (642 vertices), tool: sphere r = %.0f mm, %.0f Hz; renderer defaults\n",
              kBall * 1e3, kTool * 1e3, 1 / kDt);
  for (const Material& m : materials) {
    force_depth(m, false);
    steady(m);
    resting(m);
    cycles(m);
    onset_spike(m);
  }
}
