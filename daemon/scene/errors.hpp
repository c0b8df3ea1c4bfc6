// Errors of the scene module. Every message is one line that names the file
// (and, for scene files, the line) and says what is wrong, so a user can fix
// the input without reading code.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>

namespace sculpt::scene {

// A mesh file could not be turned into a usable mesh.
class LoadError : public std::runtime_error {
 public:
  LoadError(const std::filesystem::path& file, const std::string& what)
      : std::runtime_error(file.string() + ": " + what), file_(file) {}
  const std::filesystem::path& file() const noexcept { return file_; }

 private:
  std::filesystem::path file_;
};

// A scene file is malformed. line is 0 when no line applies (e.g. missing file).
class SceneError : public std::runtime_error {
 public:
  SceneError(const std::filesystem::path& file, unsigned line, const std::string& what)
      : std::runtime_error(file.string() + (line ? ":" + std::to_string(line) : std::string()) + ": " +
                           what),
        file_(file),
        line_(line) {}
  const std::filesystem::path& file() const noexcept { return file_; }
  unsigned line() const noexcept { return line_; }

 private:
  std::filesystem::path file_;
  unsigned line_;
};

// Writing an exported mesh failed; the previous file (if any) is untouched.
class ExportError : public std::runtime_error {
 public:
  ExportError(const std::filesystem::path& file, const std::string& what)
      : std::runtime_error(file.string() + ": " + what) {}
};

}  // namespace sculpt::scene
