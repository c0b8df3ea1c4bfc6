// The daemon's mesh path end to end: assimp in a forked child (so its crashes
// and hangs must come back as a LoadError), the result blob decoded and
// checked, welded, measured, and exported again in every format.
#include <cstddef>
#include <cstdint>
#include <span>

#include "scene/mesh_export.hpp"
#include "scene/mesh_import.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sculpt::scene;
  ImportOptions options;
  options.timeout = std::chrono::milliseconds(5000);
  try {
    const LoadedMesh m = load_mesh_from_memory(
        std::span<const std::byte>(reinterpret_cast<const std::byte*>(data), size), "", "fuzz-input", options);
    for (ExportFormat f : {ExportFormat::obj, ExportFormat::ply, ExportFormat::stl, ExportFormat::glb}) {
      (void)encode_mesh(m.mesh, f);
    }
  } catch (const LoadError&) {
    // Expected for most inputs: bad input must become exactly this.
  }
  return 0;
}
