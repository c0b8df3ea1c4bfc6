// A private temporary directory that goes away with its files: where a
// scene's mesh bytes are written back for the importer, and the tests'
// scratch space.
#pragma once

#include <stdlib.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>

namespace sculpt::files {

class TempDir {
 public:
  // `prefix` names what it is for (ps and /tmp show it); made 0700 by mkdtemp.
  explicit TempDir(const std::string& prefix, const std::filesystem::path& base = std::filesystem::temp_directory_path()) {
    std::string pattern = (base / (prefix + "-XXXXXX")).string();
    if (!::mkdtemp(pattern.data()))
      throw std::system_error(errno, std::generic_category(), "cannot make a temporary directory in " + base.string());
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace sculpt::files
