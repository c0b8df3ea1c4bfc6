// sculpt-bench throughput: steps per second of one mesh under a pressing tool.
//
//   sculpt-bench throughput [--mesh builtin:icosphere:7|builtin:torus:R:r:rings:sides|builtin:box:cells|FILE]
//                           [--model spring|linear] [--precision float|double] [--tool none|sphere]
//                           [--steps N] [--repeats R] [--impl both|fast|baseline] [--records auto|on|off]
//                           [--ring on|off] [--json]
//
// The fast path and the straightforward baseline run interleaved in one
// process (the machine is shared and noisy: compare them side by side), each
// repeat timed on its own; medians are reported.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "sim/baseline.hpp"
#include "sim/kernels.hpp"
#include "sim/shapes.hpp"
#include "sim/world.hpp"

namespace {

using namespace sculpt;
using namespace sculpt::bench;
using Clock = std::chrono::steady_clock;

sim::BodyOptions body_options(const ThroughputOptions& o) {
  sim::BodyOptions bo;
  bo.packed = o.records == "on"    ? sim::PackedRecords::always
              : o.records == "off" ? sim::PackedRecords::never
                                   : sim::PackedRecords::by_size;
  bo.ring = o.ring == "on";
  return bo;
}

// Where the tool presses: above the highest vertex, a fraction of the mesh's size.
struct Press {
  sim::Vec3d top{};
  double radius = 0.01, depth = 0.005;
  explicit Press(const sim::TriangleMesh& mesh) {
    double lo[3] = {1e30, 1e30, 1e30}, hi[3] = {-1e30, -1e30, -1e30};
    std::size_t best = 0;
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
      for (int k = 0; k < 3; ++k) lo[k] = std::min<double>(lo[k], mesh.positions[i][k]), hi[k] = std::max<double>(hi[k], mesh.positions[i][k]);
      if (mesh.positions[i][1] > mesh.positions[best][1]) best = i;
    }
    const double size = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    radius = 0.1 * size;
    depth = 0.05 * size;
    if (!mesh.positions.empty()) top = {mesh.positions[best][0], mesh.positions[best][1], mesh.positions[best][2]};
  }
  // Presses in over the first 50 ticks, then keeps working the surface.
  sim::Tool at(long tick) const {
    sim::Tool t;
    t.radius = radius;
    const double in = depth * std::min(1.0, tick / 50.0) * (1.0 + 0.2 * std::sin(tick * 0.05));
    t.position = {top[0] + 0.3 * radius * std::sin(tick * 0.013), top[1] + radius - in, top[2]};
    return t;
  }
};

struct Run {
  std::vector<double> seconds;
  std::uint64_t vertex_steps = 0;
};

template <class S>
nlohmann::json run_fast(const sim::TriangleMesh& mesh, const sim::Material& material, const ThroughputOptions& o,
                        const Press& press, std::optional<sim::BaselineBody>* baseline, Run& base_run) {
  // Kernel throughput: the whole mesh awake (sleeping off), a tool pressing in.
  sim::SimSettings awake_settings;
  awake_settings.sleep_speed = 0.0;
  const sim::BodyOptions bo = body_options(o);
  sim::World<S> world(awake_settings, 1);
  world.add_body(mesh, material, bo);
  world.wake_all(0);
  // The realistic scene: sleeping on, the tool sculpting one spot; and the same scene idle.
  sim::World<S> sculpt(sim::SimSettings{}, 1);
  sculpt.add_body(mesh, material, bo);
  sim::World<S> idle(sim::SimSettings{}, 1);
  idle.add_body(mesh, material, bo);

  const bool tool = o.tool == "sphere";
  long tick = 0, base_tick = 0;
  auto warm = [&](auto& w, long& t, bool with_tool) {
    for (int n = 0; n < 50; ++n, ++t) {
      const sim::Tool tl = press.at(t);
      w.step({&tl, with_tool ? 1u : 0u});
    }
  };
  warm(world, tick, tool);
  if (baseline && *baseline)
    for (int n = 0; n < 50; ++n, ++base_tick) {
      const sim::Tool tl = press.at(base_tick);
      (*baseline)->step(tool ? &tl : nullptr);
    }
  Run fast;
  for (int r = 0; r < o.repeats; ++r) {
    if (o.impl != "baseline") {
      const auto t0 = Clock::now();
      for (int n = 0; n < o.steps; ++n, ++tick) {
        const sim::Tool tl = press.at(tick);
        world.step({&tl, tool ? 1u : 0u});
        fast.vertex_steps += world.stats().vertex_steps;
      }
      fast.seconds.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    }
    if (baseline && *baseline) {
      const auto t0 = Clock::now();
      for (int n = 0; n < o.steps; ++n, ++base_tick) {
        const sim::Tool tl = press.at(base_tick);
        (*baseline)->step(tool ? &tl : nullptr);
      }
      base_run.seconds.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
      base_run.vertex_steps += std::uint64_t(o.steps) * (*baseline)->substeps() * mesh.positions.size();
    }
  }

  // Sculpting with sleeping on, then idle (tool gone, everything asleep).
  long sculpt_tick = 0;
  warm(sculpt, sculpt_tick, true);  // the sculpting scene always has its tool
  std::vector<double> sculpt_s, idle_s;
  std::uint64_t sculpt_vs = 0;
  for (int r = 0; r < o.repeats; ++r) {
    auto t0 = Clock::now();
    for (int n = 0; n < o.steps; ++n, ++sculpt_tick) {
      const sim::Tool tl = press.at(sculpt_tick);
      sculpt.step({&tl, 1});
      sculpt_vs += sculpt.stats().vertex_steps;
    }
    sculpt_s.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    t0 = Clock::now();
    for (int n = 0; n < o.steps; ++n) idle.step({});
    idle_s.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
  }

  const double n = static_cast<double>(mesh.positions.size());
  nlohmann::json j;
  j["substeps"] = world.substeps(0);
  j["clone"] = sim::kernel::active_clone();
  // How the body stepped (sim/stepper.hpp), and whose kernels ran it: the
  // hand-written AVX2 ones or the compiler's clones (double, no AVX2).
  const bool avx2 = sim::kernel::avx2_paths_active() && std::is_same_v<S, float>;  // AVX2 CPU, testing knob off
  j["path"] = sim::name(world.step_path(0));
  j["kernel"] = std::string(avx2 ? "avx2-" : "portable-") + sim::name(world.step_path(0));
  if (!fast.seconds.empty()) {
    const double per_step = median(fast.seconds) / o.steps;
    j["ms_per_step"] = per_step * 1e3;
    j["ns_per_vertex_step"] = per_step * 1e9 / (n * world.substeps(0));
    j["blowups"] = world.stats().blowups_total;
    j["memory_bytes"] = world.bytes();
    j["bytes_per_vertex"] = world.bytes() / n;
    j["huge_page_bytes"] = anon_huge_page_bytes();  // with the fast world alive: its arena, if THP backs it
    const double sculpt_ms = median(sculpt_s) / o.steps * 1e3, idle_ms = median(idle_s) / o.steps * 1e3;
    j["sculpting_with_sleep"] = {{"ms_per_step", sculpt_ms},
                                 {"awake_fraction", sculpt_vs / (n * world.substeps(0) * o.steps * o.repeats)}};
    j["idle"] = {{"ms_per_step", idle_ms}, {"fraction_of_sculpting", idle_ms / sculpt_ms},
                 {"fraction_of_all_awake", idle_ms / (per_step * 1e3)}};
  }
  return j;
}

// Peak resident memory of a process that only loads the mesh, builds the fast
// world and presses on it for 50 ticks: what sculptd would pay for this mesh.
long child_peak_rss(const ThroughputOptions& o) {
  int fd[2];
  if (pipe(fd) != 0) return -1;
  const pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    close(fd[0]);
    long rss = -1;
    try {
      const sim::TriangleMesh mesh = load_mesh_spec(o.mesh);
      sim::Material material;
      if (o.model == "linear") material.model = sim::ForceModel::linear;
      const Press press(mesh);
      auto run = [&](auto world) {
        world.add_body(mesh, material, body_options(o));
        for (long t = 0; t < 50; ++t) {
          const sim::Tool tl = press.at(t);
          world.step({&tl, 1});
        }
      };
      if (o.precision == "double") run(sim::World<double>(sim::SimSettings{}, 1));
      else run(sim::World<float>(sim::SimSettings{}, 1));
      rss = peak_rss_bytes();
    } catch (...) {
    }
    if (write(fd[1], &rss, sizeof rss) != sizeof rss) _exit(1);
    _exit(0);
  }
  close(fd[1]);
  long rss = -1;
  if (read(fd[0], &rss, sizeof rss) != sizeof rss) rss = -1;
  close(fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  return rss;
}

}  // namespace

namespace sculpt::bench {

int throughput(const ThroughputOptions& o) {
  // Only float bodies have packed records: asking double for a layout would measure the other one silently.
  if (o.records != "auto" && o.precision == "double")
    throw std::invalid_argument("--records " + o.records + " needs --precision float (double has no packed records)");
  if (o.ring != "on" && o.precision == "double")
    throw std::invalid_argument("--ring " + o.ring + " needs --precision float (double has no ring)");
  const long fast_only_rss = o.impl == "baseline" ? -1 : child_peak_rss(o);
  const sim::TriangleMesh mesh = load_mesh_spec(o.mesh);
  sim::Material material;
  if (o.model == "linear") material.model = sim::ForceModel::linear;
  const Press press(mesh);

  std::optional<sim::BaselineBody> baseline;
  if (o.impl != "fast") baseline.emplace(mesh, material, sim::SimSettings{});
  Run base_run;
  nlohmann::json fast = o.precision == "double" ? run_fast<double>(mesh, material, o, press, &baseline, base_run)
                                                : run_fast<float>(mesh, material, o, press, &baseline, base_run);

  const double n = static_cast<double>(mesh.positions.size());
  std::size_t springs = sim::unique_edges(mesh.triangles).size();
  nlohmann::json out = {{"command", "throughput"},
                        {"mesh", o.mesh},
                        {"vertices", mesh.positions.size()},
                        {"springs", springs},
                        {"model", o.model},
                        {"precision", o.precision},
                        {"tool", o.tool},
                        {"records", o.records},
                        {"ring", o.ring},
                        {"steps", o.steps},
                        {"repeats", o.repeats},
                        {"substeps", fast["substeps"]}};
  if (o.impl != "baseline") {
    for (const char* k : {"ns_per_vertex_step", "ms_per_step", "memory_bytes", "bytes_per_vertex", "clone", "path", "kernel", "blowups",
                          "huge_page_bytes", "sculpting_with_sleep", "idle"})
      out[k] = fast[k];
  }
  if (baseline) {
    const double per_step = median(base_run.seconds) / o.steps;
    nlohmann::json b = {{"ns_per_vertex_step", per_step * 1e9 / (n * baseline->substeps())},
                        {"ms_per_step", per_step * 1e3},
                        {"memory_bytes", baseline->bytes()},
                        {"bytes_per_vertex", baseline->bytes() / n}};
    if (o.impl == "baseline") {
      for (auto& [k, v] : b.items()) out[k] = v;
    } else {
      out["baseline"] = b;
      out["speedup_vs_baseline"] = b["ns_per_vertex_step"].get<double>() / out["ns_per_vertex_step"].get<double>();
    }
  }
  if (fast_only_rss > 0) {
    // A process holding just this mesh in the fast simulation (the mesh itself included).
    out["peak_memory_bytes"] = fast_only_rss;
    out["peak_memory_bytes_per_vertex"] = fast_only_rss / n;
  }
  out["bench_process_peak_rss_bytes"] = peak_rss_bytes();  // this process: every world and the baseline
  if (o.json) {
    std::cout << out.dump() << std::endl;
  } else {
    std::cout << out.dump(2) << std::endl;
  }
  return 0;
}

}  // namespace sculpt::bench
