// The keeper on a 164k-vertex ball (the acceptance scene's layout with the
// ball at 163 842 vertices): a recording sculpted tick by tick as the
// sim thread runs it, the keeper beside it. Prints what issue 21 asks for:
// journal bytes per second while sculpting, snapshot size and time, undo
// time on the sim thread (the input stage of the tick that writes the
// images) and end to end (request to written), recovery time.
//
//   keeper_bench RECORDING [--material clay|rubber] [--ticks N] [--undos N]
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>
#include <algorithm>

#include <kj/async.h>

#include "keeper/keeper.hpp"
#include "support/sculpt_rig.hpp"

namespace sd = sculpt::daemon;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

std::string scene_text(const std::string& material) {
  return R"(version = 1
[simulation]
rate_hz = 1000
substeps = "auto"
sleep_speed = 1e-3

[[mesh]]
name = "ball"
file = "builtin:icosphere"
params = { radius = 0.07, subdivisions = 7 }
material = ")" + material + R"("
position = [-0.2, 0.0, 0.0]

[[tool]]
name = "left"
shape = "sphere"
radius = 0.02
device = 0
stick = "left"
position = [-0.15, 0.15, 0.05]

[[tool]]
name = "right"
shape = "capsule"
radius = 0.012
half_length = 0.03
device = 0
stick = "right"
position = [0.15, 0.15, 0.05]
)";
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s RECORDING [--material clay|rubber] [--ticks N] [--undos N]\n", argv[0]);
    return 2;
  }
  std::string material = "clay";
  std::uint64_t ticks = 8000;
  int undos = 5;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--material") material = argv[i + 1];
    else if (a == "--ticks") ticks = std::strtoull(argv[i + 1], nullptr, 10);
    else if (a == "--undos") undos = std::atoi(argv[i + 1]);
  }
  const fs::path dir = fs::temp_directory_path() / ("keeper-bench-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path scene = dir / "ball164k.toml";
  std::ofstream(scene) << scene_text(material);
  auto bundle = std::make_shared<sd::SceneBundle>(sd::read_bundle(scene, sculpt::simloop::SimulationSettings{}));

  sd::JournalTap tap;
  sd::testing::Rig rig(&tap, argv[1], {}, bundle);
  sd::KeeperSettings ks;
  ks.dir = dir / "store";
  double sculpt_s = 0, recover_s = 0;
  std::vector<double> undo_tick_ms, undo_total_ms;
  std::uint64_t strokes = 0, vertices = 0, journal_bytes = 0, state_bytes = 0, stored_bytes = 0;
  double snapshot_ms = 0;
  {
    sd::Keeper keeper(ks, tap);
    keeper.start_anew();
    keeper.scene_started(bundle, std::make_shared<const sculpt::scene::Scene>(rig.sim().scene), 0);
    keeper.start();
    rig.start_at(0);
    const auto began = Clock::now();
    rig.run(ticks);
    sculpt_s = std::chrono::duration<double>(Clock::now() - began).count();
    rig.run(3000);  // the tools let go; the ball settles
    kj::EventLoop loop;
    kj::WaitScope ws(loop);
    for (int i = 0; i < undos; ++i) {
      for (bool undo : {true, false}) {
        const auto asked = Clock::now();
        auto p = undo ? keeper.undo(1) : keeper.redo(1);
        double worst_input = 0;
        while (!p.poll(ws)) {
          rig.tick();
          worst_input = std::max(worst_input, rig.input_ns());
        }
        const sd::HistoryMoveResult r = p.wait(ws);
        if (!r.error.empty()) {
          std::fprintf(stderr, "%s: %s\n", undo ? "undo" : "redo", r.error.c_str());
          break;
        }
        undo_tick_ms.push_back(worst_input / 1e6);
        undo_total_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - asked).count());
      }
    }
    const sd::HistoryInfo h = keeper.history();
    strokes = h.strokes.size();
    for (const auto& s : h.strokes) vertices = std::max(vertices, s.vertices);
    keeper.stop();
    const sd::KeeperStats k = keeper.stats();
    journal_bytes = k.journal_bytes;
    state_bytes = k.snapshot_state_bytes;
    stored_bytes = k.snapshot_stored_bytes;
    snapshot_ms = k.snapshot_ms;
  }
  const std::uint64_t db = fs::file_size(ks.dir / "store.db");
  {
    sd::JournalTap tap2;
    sd::Keeper again(ks, tap2);
    const auto began = Clock::now();
    const auto rec = again.recover();
    recover_s = std::chrono::duration<double>(Clock::now() - began).count();
    if (!rec || rec->hash != rig.sim().world->hash()) std::fprintf(stderr, "recovery is not exact!\n");
  }
  const double recording_s = static_cast<double>(ticks) / 1000.0;
  std::printf("keeper_bench: 163842-vertex %s ball, %llu ticks of %s (sculpted in %.1f s)\n", material.c_str(),
              static_cast<unsigned long long>(ticks), fs::path(argv[1]).filename().c_str(), sculpt_s);
  std::printf("  journal: %llu bytes, %.0f bytes per second of sculpting\n",
              static_cast<unsigned long long>(journal_bytes), static_cast<double>(journal_bytes) / recording_s);
  std::printf("  snapshot (at exit): %llu bytes of state, %llu stored (with its new strokes), %.0f ms; store file %llu "
              "bytes\n",
              static_cast<unsigned long long>(state_bytes), static_cast<unsigned long long>(stored_bytes), snapshot_ms,
              static_cast<unsigned long long>(db));
  std::printf("  history: %llu strokes, the largest %llu vertices\n", static_cast<unsigned long long>(strokes),
              static_cast<unsigned long long>(vertices));
  std::printf("  undo/redo: %zu, on the sim thread median %.2f ms max %.2f ms; request to written median %.1f ms\n",
              undo_tick_ms.size(), median(undo_tick_ms),
              undo_tick_ms.empty() ? 0.0 : *std::max_element(undo_tick_ms.begin(), undo_tick_ms.end()),
              median(undo_total_ms));
  std::printf("  recovery (open, snapshot, replay): %.0f ms\n", recover_s * 1e3);
  fs::remove_all(dir);
  return 0;
}
