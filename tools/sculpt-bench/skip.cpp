// sculpt-bench skip: what sleeping ("skip what the scene doesn't need") saves.
// A multi-mesh scene (default: builtin:default) with a tool sculpting one mesh:
// cost per tick simulating everything (sleeping off, every block awake) against
// skipping (the daemon's settings); the idle scene's cost once everything
// sleeps; and the bytes a viewer is streamed, as real Cap'n Proto DeltaFrames
// (lab/deltas), while active and idle (keep-alives). Sweeps of the delta
// tolerance and the sleep speed show what the defaults trade.
//
//   sculpt-bench skip [--scene FILE|builtin:default] [--ticks N] [--fps F] [--tolerance LIST]
//                     [--sleep-speed LIST] [--json] [--out DIR] [--quiet]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "commands.hpp"
#include "common.hpp"
#include "lab/deltas.hpp"
#include "scene/scene.hpp"
#include "sim/world.hpp"

namespace sculpt::bench {
namespace {

using Clock = std::chrono::steady_clock;

const std::vector<std::string> kColumns = {
    "scene",        "sweep",          "sleep_speed",      "tolerance",       "ms_per_tick_all", "ms_per_tick_skipping",
    "ms_per_tick_idle", "skip_over_all", "idle_over_all", "awake_fraction", "bytes_active",    "bytes_idle",
    "bytes_per_s_active", "bytes_per_s_idle", "vertices_per_frame", "max_viewer_lag", "ticks_to_sleep",
    "rest_error"};

// The sculpting tool: presses into the top of mesh 0 and circles there.
struct Sculptor {
  sim::Vec3d top{};
  double radius = 0.02, depth = 0.01;
  explicit Sculptor(const scene::Scene& sc) {
    const auto& pos = sc.meshes.at(0).loaded.mesh.positions;
    std::size_t best = 0;
    for (std::size_t i = 0; i < pos.size(); ++i)
      if (pos[i][1] > pos[best][1]) best = i;
    top = {pos[best][0], pos[best][1], pos[best][2]};
  }
  sim::Tool at(long tick, bool lifted) const {
    sim::Tool t;
    t.radius = radius;
    const double in = lifted ? -0.1 : depth * std::min(1.0, tick / 100.0);
    t.position = {top[0] + 0.01 * std::sin(tick * 0.01), top[1] + radius - in, top[2] + 0.01 * std::cos(tick * 0.01)};
    return t;
  }
};

struct Positions {
  std::vector<std::vector<sim::Vec3f>> data;
  std::vector<std::span<const sim::Vec3f>> spans;
  template <class W>
  void read(const W& w) {
    data.resize(w.body_count());
    spans.clear();
    for (std::size_t b = 0; b < w.body_count(); ++b) {
      data[b].resize(w.body(b).n);
      w.positions(b, data[b]);
      spans.emplace_back(data[b]);
    }
  }
};

double block_median_ms(const std::vector<double>& per_tick, int block = 50) {
  std::vector<double> blocks;
  for (std::size_t i = 0; i + block <= per_tick.size(); i += block) {
    double s = 0;
    for (int k = 0; k < block; ++k) s += per_tick[i + k];
    blocks.push_back(s / block);
  }
  return median(blocks) * 1e3;
}

nlohmann::json measure(const SkipOptions& o, const scene::Scene& sc, double sleep_speed, double tolerance) {
  sim::SimSettings all_s = sc.settings, skip_s = sc.settings;
  all_s.sleep_speed = 0.0;  // nothing ever sleeps
  skip_s.sleep_speed = sleep_speed;
  sim::World<float> all(all_s, 1), skip(skip_s, 1);
  for (const scene::SceneMesh& m : sc.meshes) {
    all.add_body(m.loaded.mesh, sc.material_of(m));
    skip.add_body(m.loaded.mesh, sc.material_of(m));
  }
  for (std::size_t b = 0; b < all.body_count(); ++b) all.wake_all(b);
  const Sculptor sculptor(sc);
  Positions pos;
  pos.read(skip);
  lab::DeltaEncoder viewer(tolerance);
  for (const auto& s : pos.spans) viewer.add_mesh(s);
  const int frame_every = std::max(1, int(std::lround(sc.settings.rate_hz / o.fps)));
  double total_vertices = 0;
  for (const auto& s : pos.spans) total_vertices += double(s.size());

  // Active: the tool sculpts mesh 0, both worlds step the same input, interleaved.
  std::vector<double> t_all, t_skip;
  double active_bytes = 0, active_vertices = 0, max_lag = 0, awake = 0;
  int active_frames = 0;
  for (long n = 0; n < o.ticks; ++n) {
    const sim::Tool tool = sculptor.at(n, false);
    auto t0 = Clock::now();
    all.step({&tool, 1});
    auto t1 = Clock::now();
    skip.step({&tool, 1});
    auto t2 = Clock::now();
    t_all.push_back(std::chrono::duration<double>(t1 - t0).count());
    t_skip.push_back(std::chrono::duration<double>(t2 - t1).count());
    awake += skip.stats().awake_vertices;
    if (n % frame_every == 0) {
      pos.read(skip);
      const lab::EncodedFrame f = viewer.encode(std::uint64_t(n), pos.spans, {&tool, 1}, skip.feedback());
      active_bytes += double(f.bytes), active_vertices += double(f.vertices), ++active_frames;
      max_lag = std::max(max_lag, viewer.max_lag(pos.spans));
    }
  }
  // Lift the tool away and let the scene come to rest (frames keep flowing).
  long settle = 0;
  const long max_settle = long(30 * sc.settings.rate_hz);
  for (; settle < max_settle; ++settle) {
    const sim::Tool tool = sculptor.at(o.ticks + settle, true);
    all.step({&tool, 1});
    skip.step({&tool, 1});
    if ((o.ticks + settle) % frame_every == 0) {
      pos.read(skip);
      viewer.encode(std::uint64_t(o.ticks + settle), pos.spans, {&tool, 1}, skip.feedback());
    }
    if (skip.stats().awake_blocks == 0 && settle > 0) break;
  }
  // What sleeping froze: the sleeping scene against the never-sleeping one, once both rest.
  for (int n = 0; n < 2000; ++n) {
    const sim::Tool tool = sculptor.at(o.ticks + settle + n, true);
    all.step({&tool, 1});
  }
  Positions ref;
  ref.read(all);
  pos.read(skip);
  double rest_error = 0;
  for (std::size_t b = 0; b < ref.data.size(); ++b)
    for (std::size_t i = 0; i < ref.data[b].size(); ++i) {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += double(ref.data[b][i][k] - pos.data[b][i][k]) * double(ref.data[b][i][k] - pos.data[b][i][k]);
      rest_error = std::max(rest_error, std::sqrt(d2));
    }
  // Idle: everything asleep, the tool parked away; keep-alive frames only.
  std::vector<double> t_idle;
  double idle_bytes = 0;
  int idle_frames = 0;
  const sim::Tool parked = sculptor.at(0, true);
  for (long n = 0; n < o.ticks; ++n) {
    const auto t0 = Clock::now();
    skip.step({&parked, 1});
    t_idle.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    if (n % frame_every == 0) {
      pos.read(skip);
      idle_bytes += double(viewer.encode(std::uint64_t(n), pos.spans, {&parked, 1}, skip.feedback()).bytes);
      ++idle_frames;
    }
  }
  nlohmann::json r;
  r["scene"] = sc.file.string();
  r["sleep_speed"] = sleep_speed;
  r["tolerance"] = tolerance;
  r["ms_per_tick_all"] = block_median_ms(t_all);
  r["ms_per_tick_skipping"] = block_median_ms(t_skip);
  r["ms_per_tick_idle"] = block_median_ms(t_idle);
  r["skip_over_all"] = r["ms_per_tick_skipping"].get<double>() / r["ms_per_tick_all"].get<double>();
  r["idle_over_all"] = r["ms_per_tick_idle"].get<double>() / r["ms_per_tick_all"].get<double>();
  r["awake_fraction"] = awake / (double(o.ticks) * total_vertices);
  r["bytes_active"] = active_bytes / active_frames;
  r["bytes_idle"] = idle_bytes / idle_frames;
  r["bytes_per_s_active"] = active_bytes / active_frames * o.fps;
  r["bytes_per_s_idle"] = idle_bytes / idle_frames * o.fps;
  r["vertices_per_frame"] = active_vertices / active_frames;
  r["max_viewer_lag"] = max_lag;
  r["ticks_to_sleep"] = settle < max_settle ? nlohmann::json(settle) : nlohmann::json();
  r["rest_error"] = rest_error;
  r["frames_per_s"] = o.fps;
  r["vertices"] = total_vertices;
  r["meshes"] = sc.meshes.size();
  return r;
}

}  // namespace

int skip(const SkipOptions& o) {
  if (o.ticks < 100) throw std::invalid_argument("--ticks must be >= 100");
  if (!(o.fps > 0)) throw std::invalid_argument("--fps must be > 0");
  const scene::Scene sc = scene::load_scene(o.scene);
  if (sc.meshes.size() < 1) throw std::invalid_argument("--scene " + o.scene + ": no meshes");
  const std::vector<double> tolerances = parse_list("--tolerance", o.tolerances);
  const std::vector<double> speeds = parse_list("--sleep-speed", o.sleep_speeds);
  const sim::SimSettings defaults;
  const double default_tolerance = 1e-4;
  Report report(o.out, "skip", kColumns);
  auto run = [&](const char* sweep, double speed, double tol) {
    report.progress(std::string(sweep) + ": sleep_speed " + std::to_string(speed) + ", tolerance " + std::to_string(tol));
    nlohmann::json r = measure(o, sc, speed, tol);
    r["sweep"] = sweep;
    report.add(r);
  };
  run("default", defaults.sleep_speed, default_tolerance);
  for (double t : tolerances)
    if (t != default_tolerance) run("tolerance", defaults.sleep_speed, t);
  for (double s : speeds)
    if (s != defaults.sleep_speed) run("sleep_speed", s, default_tolerance);
  if (report.writing()) {
    report.write_csv();
    report.plot("skip.png",
                "set multiplot layout 1,3 title 'skip: " + o.scene + " (a tool sculpting one mesh)'\n"
                "set key inside top right\nset logscale x\nset format x '%g'\n"
                "set title 'bytes per frame (" + std::to_string(int(o.fps)) + " fps) vs delta tolerance'\n"
                "set xlabel 'tolerance (m)'\nset ylabel 'bytes per frame'\nset logscale y\n"
                "plot 'skip.csv' using (strcol(2) ne 'sleep_speed' ? $4 : NaN):11 smooth unique with linespoints pt 7 title 'active', "
                "'' using (strcol(2) ne 'sleep_speed' ? $4 : NaN):12 smooth unique with linespoints pt 6 title 'idle (keep-alive)'\n"
                "set title 'ms per tick vs sleep speed'\nset xlabel 'sleep_speed (m/s)'\nset ylabel 'ms per tick'\n"
                "plot 'skip.csv' using (strcol(2) ne 'tolerance' ? $3 : NaN):5 smooth unique with linespoints pt 7 title 'all awake', "
                "'' using (strcol(2) ne 'tolerance' ? $3 : NaN):6 smooth unique with linespoints pt 5 title 'skipping (sculpting)', "
                "'' using (strcol(2) ne 'tolerance' ? $3 : NaN):7 smooth unique with linespoints pt 6 title 'idle'\n"
                "set title 'what sleeping freezes'\nset ylabel 'max distance from never-sleeping run (m)'\n"
                "plot 'skip.csv' using (strcol(2) ne 'tolerance' ? $3 : NaN):18 smooth unique with linespoints pt 7 title 'rest error'\n"
                "unset multiplot\n");
  }
  return 0;
}

}  // namespace sculpt::bench
