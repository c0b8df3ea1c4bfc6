#include "keeper/scene_bundle.hpp"

#include <fstream>

#include <fmt/format.h>
#include <map>
#include <set>
#include <stdexcept>

#include "files/regular_file.hpp"
#include "files/temp_dir.hpp"
#include "sim/state_bytes.hpp"

namespace sculpt::daemon {
namespace {

namespace fs = std::filesystem;

constexpr char kMagic[8] = {'s', 'c', 'u', 'l', 'p', 't', 'b', 'n'};
constexpr std::uint32_t kFormat = 1;
constexpr std::uint64_t kMaxSceneBytes = std::uint64_t{1} << 20;
constexpr std::uint64_t kMaxMeshBytes = std::uint64_t{1} << 30;  // what the importer reads (scene/mesh_import.cpp)
constexpr std::uint64_t kMaxNameBytes = 4096;                      // a path, as the scene names it
constexpr std::uint64_t kMaxMeshFiles = 4096;

void put_text(sim::StateWriter& w, const std::string& s) { w.array(std::span<const char>(s.data(), s.size())); }

std::string get_text(sim::StateReader& r, const char* what, std::uint64_t max_bytes) {
  std::uint64_t n = 0;
  r.value(n, what);
  if (n > max_bytes)
    throw std::invalid_argument(fmt::format("scene bundle: the {} is {} bytes, more than the cap of {}", what, n,
                                            max_bytes));
  if (n > r.left()) throw std::invalid_argument(std::string("scene bundle: truncated in ") + what);
  std::string s(n, '\0');
  r.raw(s.data(), n, what);
  return s;
}

}  // namespace

std::vector<std::byte> SceneBundle::bytes() const {
  std::vector<std::byte> out;
  sim::StateWriter w(out);
  w.value(kMagic), w.value(kFormat);
  put_text(w, file), put_text(w, text);
  const simloop::SimulationSettings& s = settings;
  w.value(static_cast<std::uint8_t>(s.rate_hz.has_value())), w.value(s.rate_hz.value_or(0.0));
  w.value(s.tool_margin), w.value(s.size_step), w.value(s.min_scale), w.value(s.max_scale);
  w.value(static_cast<std::uint64_t>(s.ring_capacity));
  w.value(static_cast<std::uint64_t>(meshes.size()));
  for (const MeshFile& m : meshes) put_text(w, m.source), put_text(w, m.bytes);
  return out;
}

SceneBundle SceneBundle::from_bytes(std::span<const std::byte> bytes) {
  sim::StateReader r(bytes, /*dry=*/false);
  char magic[8];
  std::uint32_t format = 0;
  r.value(magic, "header"), r.value(format, "header");
  if (std::memcmp(magic, kMagic, sizeof kMagic) != 0) throw std::invalid_argument("scene bundle: not a scene bundle");
  if (format != kFormat) throw std::invalid_argument("scene bundle: format " + std::to_string(format) + ", this build reads 1");
  SceneBundle b;
  b.file = get_text(r, "scene name", kMaxNameBytes), b.text = get_text(r, "scene text", kMaxSceneBytes);
  std::uint8_t has_rate = 0;
  double rate = 0;
  std::uint64_t ring = 0, meshes = 0;
  simloop::SimulationSettings& s = b.settings;
  r.value(has_rate, "settings"), r.value(rate, "settings");
  r.value(s.tool_margin, "settings"), r.value(s.size_step, "settings"), r.value(s.min_scale, "settings");
  r.value(s.max_scale, "settings"), r.value(ring, "settings"), r.value(meshes, "mesh count");
  if (has_rate > 1) throw std::invalid_argument("scene bundle: the rate flag is " + std::to_string(has_rate));
  if (has_rate) s.rate_hz = rate;
  // As a config file's settings are held (the bundle's are the config's of the run that saved it).
  if (ring > static_cast<std::uint64_t>(simloop::kRingCapacityRange.hi))
    throw std::invalid_argument(fmt::format("scene bundle: input ring capacity is {}, not within [{}, {}]", ring,
                                            simloop::kRingCapacityRange.lo, simloop::kRingCapacityRange.hi));
  s.ring_capacity = static_cast<std::size_t>(ring);
  try {
    simloop::check_settings(s);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("scene bundle: ") + e.what());
  }
  if (meshes > kMaxMeshFiles)
    throw std::invalid_argument(fmt::format("scene bundle: {} mesh files, at most {}", meshes, kMaxMeshFiles));
  for (std::uint64_t i = 0; i < meshes; ++i) {
    MeshFile m;
    m.source = get_text(r, "mesh file name", kMaxNameBytes);
    m.bytes = get_text(r, "mesh file", kMaxMeshBytes);
    b.meshes.push_back(std::move(m));
  }
  if (!r.done()) throw std::invalid_argument("scene bundle: bytes left over");
  return b;
}

SceneBundle read_bundle(const fs::path& scene_file, const simloop::SimulationSettings& settings) {
  SceneBundle b;
  b.file = scene_file.string();
  b.settings = settings;
  if (scene_file == "builtin:default") {
    b.text = std::string(scene::default_scene_text());
  } else if (b.file.rfind("builtin:", 0) == 0) {
    (void)scene::load_scene(scene_file);  // throws: no such built-in scene
  } else {
    try {
      b.text = files::read_regular(scene_file, kMaxSceneBytes);
    } catch (const files::FileError& e) {
      throw scene::SceneError(scene_file, 0, e.reason());
    }
  }
  scene::SceneOptions check;
  check.load_meshes = false;
  const scene::Scene parsed = scene::parse_scene(b.text, scene_file, check);
  for (const scene::SceneMesh& m : parsed.meshes) {
    if (m.path.empty()) continue;  // builtin:<shape>
    bool known = false;
    for (const auto& have : b.meshes) known = known || have.source == m.source;
    if (known) continue;
    try {
      b.meshes.push_back({m.source, files::read_regular(m.path, kMaxMeshBytes)});
    } catch (const files::FileError& e) {
      throw scene::SceneError(scene_file, m.line, "mesh " + m.name + ": " + e.what());
    }
  }
  return b;
}

scene::Scene load_bundle(const SceneBundle& b) {
  // Every file the scene's: a bundle read back from a store carries nothing else.
  scene::SceneOptions names;
  names.load_meshes = false;
  std::set<std::string> named;
  for (const scene::SceneMesh& m : scene::parse_scene(b.text, b.file, names).meshes)
    if (!m.path.empty()) named.insert(m.source);
  std::set<std::string> seen;
  for (const SceneBundle::MeshFile& m : b.meshes)
    if (!named.count(m.source) || !seen.insert(m.source).second)
      throw scene::SceneError(b.file, 0, "the sculpt's copy of mesh file " + m.source +
                                             (named.count(m.source) ? " is there twice" : " is not named by its scene"));
  files::TempDir dir("sculptd-scene");
  std::map<std::string, fs::path> located;
  for (std::size_t i = 0; i < b.meshes.size(); ++i) {
    // The importer picks the format by the extension: keep it.
    const fs::path file = dir.path() / ("mesh-" + std::to_string(i) + fs::path(b.meshes[i].source).extension().string());
    std::ofstream out(file, std::ios::binary);
    out.write(b.meshes[i].bytes.data(), static_cast<std::streamsize>(b.meshes[i].bytes.size()));
    if (!out.flush()) throw scene::SceneError(b.file, 0, "cannot write the mesh copy " + file.string());
    located[b.meshes[i].source] = file;
  }
  scene::SceneOptions options;
  options.locate = [&located, &b](const std::string& source) {
    const auto it = located.find(source);
    if (it == located.end()) throw scene::SceneError(b.file, 0, "the sculpt has no copy of mesh file " + source);
    return it->second;
  };
  return scene::parse_scene(b.text, b.file, options);
}

}  // namespace sculpt::daemon
