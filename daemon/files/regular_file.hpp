// Reading the files a user names (scenes, meshes, recordings, configs) without
// letting the name hang or flood the reader. Only a regular file is read: a
// FIFO would block until someone writes to it, /dev/zero and /dev/urandom
// never end, /dev/null reads as an empty file. The file is opened with
// O_NONBLOCK (opening a FIFO does not wait for a writer), checked with
// fstat, and read up to a limit in bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace sculpt::files {

// One line naming the file and what is wrong: "x.toml: is a FIFO, not a
// regular file", "x.obj: is larger than 256 MiB", "x: no such file".
class FileError : public std::runtime_error {
 public:
  FileError(const std::filesystem::path& file, const std::string& what)
      : std::runtime_error(file.string() + ": " + what), file_(file), reason_(what) {}
  const std::filesystem::path& file() const noexcept { return file_; }
  const std::string& reason() const noexcept { return reason_; }  // without the file name

 private:
  std::filesystem::path file_;
  std::string reason_;
};

// "regular file", "directory", "FIFO", "character device", ... of a st_mode.
const char* kind_of(std::uint32_t st_mode);

// "256 MiB", "16 KiB", "100 bytes".
std::string size_text(std::uint64_t bytes);

// Throws FileError unless `file` is a regular file of at most `max_bytes`
// (for readers that open it themselves). Returns its size.
std::uint64_t check_regular(const std::filesystem::path& file, std::uint64_t max_bytes);

// The whole file, when it is a regular file of at most `max_bytes`; else
// FileError. A file that grows past the limit while being read is refused too.
std::string read_regular(const std::filesystem::path& file, std::uint64_t max_bytes);

// Creates `dir` and any missing parent with exactly `mode`, whatever the
// process's umask (a daemon started with umask 000 must not make
// world-writable directories). Existing directories are left as they are.
// Throws FileError.
void create_directories(const std::filesystem::path& dir, std::uint32_t mode);

}  // namespace sculpt::files
