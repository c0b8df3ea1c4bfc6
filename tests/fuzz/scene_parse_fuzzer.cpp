// Scene files: any text must parse or give a SceneError, nothing else.
// Meshes are not loaded (that path has its own fuzzers) but every key,
// including builtin shape parameters, is checked.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "scene/scene.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sculpt::scene;
  SceneOptions options;
  options.load_meshes = false;
  try {
    (void)parse_scene(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.toml", options);
  } catch (const SceneError&) {
  }
  return 0;
}
