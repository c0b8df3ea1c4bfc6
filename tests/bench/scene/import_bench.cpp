// Import speed on a big binary STL: 1M triangles (a 1000 x 500 torus), the
// size of a fine 3D scan. Measured: wall time of load_mesh (the work happens
// in the importer child, so real time, not CPU time), the weld alone, the
// export, and peak RSS of this process and of the importer child.
//
// The STL is generated once into $TMPDIR (never the source tree), in a forked
// child so that generating it does not count towards this process's peak RSS.
#include <sys/resource.h>

#include <cstdlib>
#include <filesystem>
#include <variant>

#include <benchmark/benchmark.h>

#include "scene/isolation.hpp"
#include "scene/mesh_export.hpp"
#include "scene/mesh_import.hpp"
#include "scene/weld.hpp"
#include "sim/shapes.hpp"

namespace {

namespace fs = std::filesystem;
using namespace sculpt;

constexpr int kRings = 1000, kSides = 500;  // 2 * 1000 * 500 = 1M triangles

const fs::path& big_stl() {
  static const fs::path path = [] {
    fs::path p = fs::temp_directory_path() / "sculpt-bench-torus-1M.stl";
    const std::uintmax_t expected = 84 + 50ull * 2 * kRings * kSides;
    std::error_code ec;
    if (fs::file_size(p, ec) != expected) {
      auto r = scene::run_in_child([&] {
        scene::export_mesh(sim::make_torus(0.1f, 0.03f, kRings, kSides), p);
        return std::vector<std::byte>{};
      }, {std::chrono::milliseconds(120000)});
      if (std::holds_alternative<scene::ChildFailure>(r)) {
        throw std::runtime_error("generating the STL failed: " + std::get<scene::ChildFailure>(r).what);
      }
    }
    return p;
  }();
  return path;
}

double max_rss_mb(int who) {
  rusage u{};
  getrusage(who, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB
}

void report(benchmark::State& state, const scene::LoadedMesh& m) {
  state.counters["triangles"] = static_cast<double>(m.report.triangles);
  state.counters["vertices"] = static_cast<double>(m.report.vertices);
  state.counters["boundary_edges"] = static_cast<double>(m.report.boundary_edges);
  state.counters["peak_rss_self_MB"] = max_rss_mb(RUSAGE_SELF);
  state.counters["peak_rss_child_MB"] = max_rss_mb(RUSAGE_CHILDREN);
}

void BM_LoadBinaryStl1M(benchmark::State& state) {
  scene::ImportOptions options;
  options.isolate = state.range(0) != 0;
  const fs::path& file = big_stl();
  scene::LoadedMesh m;
  for (auto _ : state) {
    m = scene::load_mesh(file, options);
    benchmark::DoNotOptimize(m.mesh.positions.data());
  }
  report(state, m);
}
BENCHMARK(BM_LoadBinaryStl1M)->ArgName("isolated")->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->UseRealTime()
    ->Iterations(1)->Repetitions(5)->ReportAggregatesOnly(true);

// What isolation costs on a file too small for parsing to matter: the fork,
// the memfd round trip and the wait.
void BM_LoadSmallObj(benchmark::State& state) {
  scene::ImportOptions options;
  options.isolate = state.range(0) != 0;
  const char* data = std::getenv("SCULPT_TEST_DATA");
  const fs::path file = fs::path(data ? data : "tests/data") / "meshes" / "icosphere.obj";
  for (auto _ : state) {
    scene::LoadedMesh m = scene::load_mesh(file, options);
    benchmark::DoNotOptimize(m.mesh.positions.data());
  }
}
BENCHMARK(BM_LoadSmallObj)->ArgName("isolated")->Arg(1)->Arg(0)->Unit(benchmark::kMicrosecond)->UseRealTime()
    ->Repetitions(5)->ReportAggregatesOnly(true);

void BM_WeldSoup1M(benchmark::State& state) {
  const sim::TriangleMesh torus = sim::make_torus(0.1f, 0.03f, kRings, kSides);
  sim::TriangleMesh soup;  // three fresh corners per triangle, as STL stores it
  soup.positions.reserve(torus.triangles.size() * 3);
  for (const sim::Triangle& t : torus.triangles) {
    const auto base = static_cast<std::uint32_t>(soup.positions.size());
    for (std::uint32_t v : t) soup.positions.push_back(torus.positions[v]);
    soup.triangles.push_back({base, base + 1, base + 2});
  }
  for (auto _ : state) {
    scene::WeldResult w = scene::weld(soup, 1e-6f);
    benchmark::DoNotOptimize(w.mesh.positions.data());
  }
}
BENCHMARK(BM_WeldSoup1M)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)->Repetitions(5)
    ->ReportAggregatesOnly(true);

void BM_ExportStl1M(benchmark::State& state) {
  const sim::TriangleMesh torus = sim::make_torus(0.1f, 0.03f, kRings, kSides);
  const fs::path out = fs::temp_directory_path() / "sculpt-bench-export.stl";
  for (auto _ : state) scene::export_mesh(torus, out);
  fs::remove(out);
}
BENCHMARK(BM_ExportStl1M)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)->Repetitions(5)
    ->ReportAggregatesOnly(true);

}  // namespace

BENCHMARK_MAIN();
