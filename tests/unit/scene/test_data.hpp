// What the scene tests share: where the test data lives, a scratch
// directory per test that cleans up after itself (files::TempDir), and the
// message of an expected exception.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "files/temp_dir.hpp"
#include "support/read_file.hpp"

namespace sculpt::scene::testing {

// Set by meson (env SCULPT_TEST_DATA); the fallback keeps `./test` runnable from the source root.
inline std::filesystem::path data_dir() {
  const char* env = std::getenv("SCULPT_TEST_DATA");
  return env ? std::filesystem::path(env) : std::filesystem::path("tests/data");
}
inline std::filesystem::path mesh_file(const std::string& name) { return data_dir() / "meshes" / name; }

class TempDir : public files::TempDir {
 public:
  TempDir() : files::TempDir("sculpt-scene-test") {}
  std::filesystem::path operator/(const std::string& name) const { return path() / name; }

  std::filesystem::path write(const std::string& name, const std::string& text) const {
    const auto p = path() / name;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }
};

using support::read_file;

// The message of the exception `f` throws, or a failure if it throws none.
template <class E, class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an exception";
  return {};
}

}  // namespace sculpt::scene::testing
