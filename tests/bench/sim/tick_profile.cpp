// Where sculptd's long ticks come from: the acceptance scene and recording run
// through the daemon's own stages (replay → ControlMapper → ToolDriver →
// World::step), tick after tick on this thread with no sleeping, and every
// tick's step time, collision time, awake vertices, substeps, narrow-phase
// candidates, contacts and page faults are kept. Prints percentiles and the
// slowest ticks with what they were doing; --csv FILE writes every tick.
//
//   tick_profile --scene tests/data/scenes/sculpt_50k.toml
//                --recording tests/data/recordings/bench_sculpt.jsonl [--ticks 30000] [--csv FILE]
//
// Numbers only: it asserts nothing about time.
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include "concurrency/spsc_ring.hpp"
#include "input/control_mapper.hpp"
#include "input/mapping.hpp"
#include "input/replay_source.hpp"
#include "simloop/scene_tools.hpp"
#include "simloop/tool_driver.hpp"
#include "scene/scene.hpp"
#include "sim/world.hpp"

namespace {

using namespace sculpt;

std::uint64_t now_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000000ull + static_cast<std::uint64_t>(ts.tv_nsec);
}

// This thread's CPU time: a tick's cost without the time other processes took
// the CPU away (the machine is shared), which wall time includes.
std::uint64_t cpu_ns() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000000ull + static_cast<std::uint64_t>(ts.tv_nsec);
}

long minor_faults() {
  rusage u;
  getrusage(RUSAGE_THREAD, &u);
  return u.ru_minflt + u.ru_majflt;
}

struct TickRecord {
  std::uint64_t tick;
  double step_us, cpu_us, collision_us;
  std::uint32_t awake, candidates, contacts, blowups;
  long faults;
};

double pct(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

// How fast the awake blocks of each body move on one tick (are they awake for a reason?).
void print_blocks(const sim::World<float>& world, std::uint64_t tick) {
  for (std::size_t bi = 0; bi < world.body_count(); ++bi) {
    const auto& b = world.body(bi);
    int hist[8] = {};  // max speed: <1e-4, <1e-3, <3e-3, <1e-2, <3e-2, <0.1, <0.3, more (m/s)
    const double edges[7] = {1e-4, 1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3};
    std::uint32_t awake = 0;
    for (const auto& s : b.block) {
      if (!s.awake) continue;
      ++awake;
      const double v = std::sqrt(static_cast<double>(std::bit_cast<float>(s.max_speed2_bits)));
      int k = 0;
      while (k < 7 && v >= edges[k]) ++k;
      ++hist[k];
    }
    std::printf("tick %llu body %zu: %u of %u blocks awake; by max speed (m/s) <1e-4 %d <1e-3 %d <3e-3 %d <1e-2 %d "
                "<3e-2 %d <0.1 %d <0.3 %d more %d\n",
                static_cast<unsigned long long>(tick), bi, awake, b.blocks, hist[0], hist[1], hist[2], hist[3],
                hist[4], hist[5], hist[6], hist[7]);
  }
}

// A whole non-negative number, or an error naming the option.
bool parse_count(const char* option, const char* text, std::uint64_t& out) {
  char* end = nullptr;
  errno = 0;
  const unsigned long long v = std::strtoull(text, &end, 10);
  if (errno != 0 || end == text || *end != '\0' || text[0] == '-') {
    std::fprintf(stderr, "tick_profile: %s wants a whole number, not '%s'\n", option, text);
    return false;
  }
  out = v;
  return true;
}

int usage() {
  std::fprintf(stderr, "usage: tick_profile --scene FILE --recording FILE [--ticks N] [--csv FILE] [--top N] [--blocks-at TICK]\n");
  return 2;
}

int run(int argc, char** argv) {
  std::string scene_file, recording_file, csv;
  std::uint64_t ticks = 30000;
  std::uint64_t top = 15;
  std::uint64_t blocks_at = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return usage();
    if (a == "--scene") scene_file = argv[++i];
    else if (a == "--recording") recording_file = argv[++i];
    else if (a == "--csv") csv = argv[++i];
    else if (a == "--ticks" || a == "--top" || a == "--blocks-at") {
      std::uint64_t& v = a == "--ticks" ? ticks : a == "--top" ? top : blocks_at;
      if (!parse_count(a.c_str(), argv[++i], v)) return 2;
    } else return usage();
  }
  if (scene_file.empty() || recording_file.empty()) return usage();

  const scene::Scene sc = scene::load_scene(scene_file);
  const double rate = sc.settings.rate_hz;
  const int columns = static_cast<int>(std::max<std::size_t>(sc.tools.size(), 1));
  sim::World<float> world(sc.settings, columns);
  for (const auto& m : sc.meshes) world.add_body(m.loaded.mesh, sc.material_of(m));
  const std::vector<simloop::ToolSpec> specs = simloop::tool_specs(sc);
  simloop::DriverLimits limits;  // sculptd's defaults (tool margin 0.1 m)
  limits.bounds = simloop::tool_bounds(simloop::mesh_bounds(sc), specs, 0.1);
  simloop::ToolDriver driver(specs, limits, rate);
  concurrency::SpscRing<input::InputMessage> ring(4096);
  input::ControlMapper mapper(driver.size());
  input::ToolRouter router(simloop::tool_routes(sc));
  const input::MappingConfig mapping = input::parse_mapping(toml::table{});
  input::ReplaySource replay(recording_file, rate, [&](std::uint8_t slot, const input::DeviceInfo& info) {
    router.detach(slot);
    return router.attach(slot, info, mapping);
  });
  replay.start(1);
  world.set_stage_clock(now_ns);

  std::vector<sim::Tool> tools(sc.tools.size());
  std::vector<TickRecord> rec;
  rec.reserve(ticks);
  std::vector<int> substeps(world.body_count());
  for (std::size_t b = 0; b < world.body_count(); ++b) substeps[b] = world.substeps(b);
  for (std::uint64_t tick = 1; tick <= ticks; ++tick) {
    if (!replay.finished()) replay.pump(ring, tick + 1000);
    mapper.drain(ring, tick);  // what sculptd's input stage does
    driver.update_from(mapper.controls(), std::span<sim::Tool>(tools));
    const long f0 = minor_faults();
    const std::uint64_t c0 = cpu_ns(), t0 = now_ns();
    world.step(tools);
    const std::uint64_t t1 = now_ns(), c1 = cpu_ns();
    const long f1 = minor_faults();
    const sim::TickStats& st = world.stats();
    if (tick == blocks_at) print_blocks(world, tick);
    rec.push_back({tick, (t1 - t0) * 1e-3, (c1 - c0) * 1e-3, world.collision_ns() * 1e-3, st.awake_vertices, st.candidate_blocks,
                   st.contacts, st.blowups, f1 - f0});
  }

  std::vector<double> step, cpu, coll, awake;
  for (const auto& r : rec)
    step.push_back(r.step_us), cpu.push_back(r.cpu_us), coll.push_back(r.collision_us), awake.push_back(r.awake);
  std::printf("# %s, %s: %llu ticks; substeps per body:", scene_file.c_str(), recording_file.c_str(),
              static_cast<unsigned long long>(ticks));
  for (std::size_t b = 0; b < world.body_count(); ++b) std::printf(" %d (%u vertices)", substeps[b], world.body(b).n);
  std::printf("\nstep us      p50 %.1f p90 %.1f p99 %.1f p99.9 %.1f max %.1f\n", pct(step, 0.5), pct(step, 0.9),
              pct(step, 0.99), pct(step, 0.999), pct(step, 1.0));
  std::printf("step cpu us  p50 %.1f p90 %.1f p99 %.1f p99.9 %.1f max %.1f\n", pct(cpu, 0.5), pct(cpu, 0.9),
              pct(cpu, 0.99), pct(cpu, 0.999), pct(cpu, 1.0));
  std::printf("collision us p50 %.1f p90 %.1f p99 %.1f p99.9 %.1f max %.1f\n", pct(coll, 0.5), pct(coll, 0.9),
              pct(coll, 0.99), pct(coll, 0.999), pct(coll, 1.0));
  std::printf("awake verts  p50 %.0f p90 %.0f p99 %.0f max %.0f\n", pct(awake, 0.5), pct(awake, 0.9),
              pct(awake, 0.99), pct(awake, 1.0));
  long faults = 0;
  std::uint64_t over = 0, blowups = 0;
  std::uint64_t cpu_over = 0;
  for (const auto& r : rec)
    faults += r.faults, over += r.step_us > 1000.0, cpu_over += r.cpu_us > 1000.0, blowups += r.blowups;
  std::printf("page faults during steps: %ld; steps over 1 ms: %llu (cpu time: %llu); blowups %llu; final hash %016llx\n", faults,
              static_cast<unsigned long long>(over), static_cast<unsigned long long>(cpu_over),
              static_cast<unsigned long long>(blowups), static_cast<unsigned long long>(world.hash()));
  std::vector<TickRecord> slow = rec;
  std::sort(slow.begin(), slow.end(), [](const TickRecord& a, const TickRecord& b) { return a.cpu_us > b.cpu_us; });
  std::printf("costliest ticks (cpu time): tick step_us cpu_us collision_us awake candidates contacts blowups faults\n");
  for (std::size_t i = 0; i < top && i < slow.size(); ++i)
    std::printf("  %llu %.1f %.1f %.1f %u %u %u %u %ld\n", static_cast<unsigned long long>(slow[i].tick),
                slow[i].step_us, slow[i].cpu_us, slow[i].collision_us, slow[i].awake, slow[i].candidates, slow[i].contacts, slow[i].blowups,
                slow[i].faults);
  if (!csv.empty()) {
    FILE* f = std::fopen(csv.c_str(), "w");
    if (!f) {
      std::fprintf(stderr, "tick_profile: cannot write %s: %s\n", csv.c_str(), std::strerror(errno));
      return 1;
    }
    std::fprintf(f, "tick,step_us,cpu_us,collision_us,awake,candidates,contacts,blowups,faults\n");
    for (const auto& r : rec)
      std::fprintf(f, "%llu,%.2f,%.2f,%.2f,%u,%u,%u,%u,%ld\n", static_cast<unsigned long long>(r.tick), r.step_us,
                   r.cpu_us, r.collision_us, r.awake, r.candidates, r.contacts, r.blowups, r.faults);
    std::fclose(f);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {  // a bad scene or recording: its name and what is wrong
    std::fprintf(stderr, "tick_profile: %s\n", e.what());
    return 1;
  }
}
