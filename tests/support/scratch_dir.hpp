// This test process's own scratch directory: a files::TempDir made on first
// use and removed when the process exits, so tests name their files freely
// ("sculptd.sock", "h1") without meeting another run's. A test that fails
// can keep it for a person to look at (keep_scratch_dir()).
#pragma once

#include <errno.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>

#include "files/temp_dir.hpp"

namespace sculpt::support {

class ScratchDir {
 public:
  static ScratchDir& instance() {
    static ScratchDir dir;
    return dir;
  }
  const std::filesystem::path& path() const { return dir_.path(); }
  void keep() { kept_ = true; }

  ~ScratchDir() {
    if (!kept_) return;
    // Out of files::TempDir's way (it removes its path), under a name that
    // says why it is there.
    const std::filesystem::path kept = path().string() + "-kept";
    std::error_code ec;
    std::filesystem::rename(path(), kept, ec);
    if (!ec) std::fprintf(stderr, "kept the test's files: %s is now %s\n", path().c_str(), kept.c_str());
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

 private:
  ScratchDir() : dir_(std::string("sculpt-") + program_invocation_short_name) {}
  files::TempDir dir_;
  bool kept_ = false;
};

inline const std::filesystem::path& scratch_dir() { return ScratchDir::instance().path(); }

inline std::string scratch_path(const std::string& name) { return (scratch_dir() / name).string(); }

// An empty directory `name` in the scratch directory (emptied if a test
// before used the name).
inline std::string fresh_scratch_dir(const std::string& name) {
  const std::filesystem::path d = scratch_dir() / name;
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d.string();
}

// Leaves the scratch directory at exit (renamed "<name>-kept"): a failed
// test's images and logs.
inline void keep_scratch_dir() { ScratchDir::instance().keep(); }

}  // namespace sculpt::support
