// What runs in the daemon's own process after the isolated importer: the
// result blob decoder (a dying child may write anything) and the
// check/weld/measure pipeline over arbitrary soups, NaNs and bad indices.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>

#include "scene/mesh_import.hpp"
#include "scene/raw_blob.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sculpt::scene;
  const std::span<const std::byte> bytes(reinterpret_cast<const std::byte*>(data), size);
  try {
    (void)decode_raw(bytes);
  } catch (const std::runtime_error&) {
  }
  if (size < 2) return 0;

  // Layout: tolerance selector, vertex count, then floats, then indices.
  ImportOptions options;
  static constexpr double kTolerances[] = {0.0, 1e-7, 1e-5, 1e-3, 1e-2};
  options.weld_tolerance = kTolerances[data[0] % 5];
  const std::size_t vertices = data[1];
  std::size_t at = 2;
  sculpt::sim::TriangleMesh raw;
  for (std::size_t i = 0; i < vertices && at + 12 <= size; ++i, at += 12) {
    sculpt::sim::Vec3f p;
    std::memcpy(p.data(), data + at, 12);
    raw.positions.push_back(p);
  }
  for (; at + 3 <= size; at += 3) {
    // Small indices so that most triangles are valid; 255 is out of range.
    raw.triangles.push_back({data[at], data[at + 1], data[at + 2]});
  }
  try {
    const LoadedMesh m = clean_mesh(raw, "fuzz-soup", options);
    if (m.mesh.triangles.empty()) __builtin_trap();  // clean_mesh promises a usable mesh
  } catch (const LoadError&) {
  }
  return 0;
}
