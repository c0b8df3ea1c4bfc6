// sculpt-view's speed (numbers, not pass/fail; docs/viewer.md quotes the
// medians): the frame time of a 100k-triangle scene at 1280x720 headless
// (llvmpipe here), and the cost of applying a 10k-vertex delta: the stream's
// DeltaFrame through MeshMirror, into the model (normals around the moved
// vertices), and uploaded over the changed ranges.
//
//   meson test -C build --benchmark viewer_bench --verbose
//   build/tests/bench/viewer/viewer_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <capnp/message.h>
#include <fmt/format.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numeric>

#include "app/source.hpp"
#include "client/mesh_mirror.hpp"
#include "gl/egl_headless.hpp"
#include "gl/fbo.hpp"
#include "render/renderer.hpp"

namespace sculpt::view {
namespace {

// A torus of 250 x 200 quads: exactly 100 000 triangles, 50 000 vertices.
const char* kScene100k = R"toml(version = 1
[[mesh]]
name = "torus"
file = "builtin:torus"
params = { major_radius = 0.1, minor_radius = 0.04, rings = 250, sides = 200 }
material = "jelly"
rotation = [60.0, 0.0, 0.0]
)toml";

struct World {
  gl::HeadlessContext context;
  std::unique_ptr<Renderer> renderer;
  ViewModel model;
  Camera camera;
  World() {
    const auto file = std::filesystem::temp_directory_path() / ("viewer-bench-" + std::to_string(::getpid()) + ".toml");
    std::ofstream(file) << kScene100k;
    fill_from_scene_file(model, file.string());
    std::filesystem::remove(file);
    renderer = std::make_unique<Renderer>();
    camera.fit(model.bounds_now(), 16.0f / 9.0f);
  }
};

// CPU seconds of the whole process (every llvmpipe thread included): on a
// loaded machine the wall time mostly measures the wait for a CPU, this not.
double process_cpu_s() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

World& world() {
  static World w;
  return w;
}

void BM_Frame100kTriangles1280x720(benchmark::State& state) {
  World& w = world();
  gl::Fbo fbo(1280, 720, static_cast<int>(state.range(0)));
  RenderOptions options;
  options.wireframe = state.range(1) != 0;
  w.renderer->sync(w.model, options);
  const std::vector<std::string> overlay = {"SCULPTD 1000 HZ  JITTER P99 45 US", "AWAKE 1234/50000 VERTICES"};
  const double cpu0 = process_cpu_s();
  for (auto _ : state) {
    fbo.bind();
    w.renderer->draw(w.model, w.camera, 1280, 720, options, overlay);
    glFinish();
    if (state.range(2) != 0) benchmark::DoNotOptimize(fbo.read_rgba());
  }
  state.counters["triangles"] = static_cast<double>(w.model.meshes[0].triangle_count());
  state.counters["cpu_ms_all_threads"] = (process_cpu_s() - cpu0) * 1e3 / static_cast<double>(state.iterations());
  state.SetLabel(fmt::format("msaa {}{}{}", state.range(0), state.range(1) ? ", wireframe" : "",
                             state.range(2) ? ", + glReadPixels" : ""));
}
BENCHMARK(BM_Frame100kTriangles1280x720)
    ->Args({4, 0, 0})->Args({0, 0, 0})->Args({4, 1, 0})->Args({4, 0, 1})
    ->Unit(benchmark::kMillisecond)->MinTime(3.0)->UseRealTime();  // llvmpipe draws on its own threads

// A sculpt-like delta: the 10 000 vertices nearest one point (a dent), in
// ascending index order as the daemon sends them.
std::vector<std::uint32_t> dent_indices(const ViewMesh& mesh, std::size_t count) {
  const auto p = mesh.positions();
  std::vector<std::uint32_t> idx(mesh.vertex_count());
  std::iota(idx.begin(), idx.end(), 0u);
  const float c[3] = {p[0], p[1], p[2]};
  const auto d2 = [&](std::uint32_t v) {
    const float x = p[v * 3] - c[0], y = p[v * 3 + 1] - c[1], z = p[v * 3 + 2] - c[2];
    return x * x + y * y + z * z;
  };
  std::nth_element(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(count), idx.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return d2(a) < d2(b); });
  idx.resize(count);
  std::sort(idx.begin(), idx.end());
  return idx;
}

void fill_keyframe(proto::Keyframe::Builder s, const ViewMesh& mesh) {
  auto m = s.initMeshes(1)[0];
  m.setId(mesh.id());
  m.setName(mesh.name());
  auto tris = m.initTriangles(static_cast<unsigned>(mesh.triangles().size()));
  for (unsigned i = 0; i < tris.size(); ++i) tris.set(i, mesh.triangles()[i]);
  const auto bytes = [](std::span<const float> f) {
    return capnp::Data::Reader(reinterpret_cast<const capnp::byte*>(f.data()), f.size_bytes());
  };
  m.setRestPositions(bytes(mesh.rest()));
  m.setPositions(bytes(mesh.positions()));
}

// The whole path of one frame: decode into MeshMirror, copy the changed
// ranges into the model (normals recomputed around them), upload those ranges.
void BM_ApplyDelta10kVertices(benchmark::State& state) {
  World& w = world();
  const bool upload = state.range(0) != 0;
  ViewMesh& mesh = w.model.meshes[0];
  const std::vector<std::uint32_t> idx = dent_indices(mesh, 10000);

  capnp::MallocMessageBuilder keyframe_msg;
  fill_keyframe(keyframe_msg.initRoot<proto::Keyframe>(), mesh);
  client::MeshMirror mirror;
  mirror.apply(keyframe_msg.getRoot<proto::Keyframe>().asReader());

  // Two frames, alternating, so every apply really moves the vertices.
  capnp::MallocMessageBuilder frames[2];
  for (int k = 0; k < 2; ++k) {
    auto f = frames[k].initRoot<proto::DeltaFrame>();
    f.setSequence(static_cast<std::uint64_t>(k + 1));
    auto md = f.initMeshes(1)[0];
    md.setMeshId(mesh.id());
    auto list = md.initIndices(static_cast<unsigned>(idx.size()));
    std::vector<float> xyz;
    for (unsigned i = 0; i < idx.size(); ++i) {
      list.set(i, idx[i]);
      for (int c = 0; c < 3; ++c) xyz.push_back(mesh.positions()[idx[i] * 3 + c] * (k == 0 ? 0.98f : 1.0f));
    }
    md.setPositions(capnp::Data::Reader(reinterpret_cast<const capnp::byte*>(xyz.data()), xyz.size() * 4));
  }
  RenderOptions options;
  w.renderer->sync(w.model, options);
  std::size_t ranges = 0, uploaded = 0;
  int k = 0;
  for (auto _ : state) {
    const auto changed = mirror.apply(frames[k].getRoot<proto::DeltaFrame>().asReader());
    k ^= 1;
    for (const auto& r : changed) {
      const auto& mm = mirror.meshes()[r.mesh];
      mesh.set_range(r.begin, r.end,
                     std::span<const float>(mm.positions).subspan(std::size_t{r.begin} * 3, std::size_t{r.end - r.begin} * 3));
    }
    if (upload) {
      const UploadStats s = w.renderer->sync(w.model, options);
      ranges = s.ranges;
      uploaded = s.vertices;
      glFinish();
    } else {
      mesh.take_dirty();
    }
  }
  state.counters["delta_vertices"] = static_cast<double>(idx.size());
  if (upload) {
    state.counters["ranges"] = static_cast<double>(ranges);
    state.counters["uploaded_vertices"] = static_cast<double>(uploaded);
  }
  state.SetLabel(upload ? "decode + model + normals + upload" : "decode + model + normals");
}
BENCHMARK(BM_ApplyDelta10kVertices)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond)->MinTime(2.0)->UseRealTime();

}  // namespace
}  // namespace sculpt::view

BENCHMARK_MAIN();
