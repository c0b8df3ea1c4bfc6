#include "files/regular_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "files/unique_fd.hpp"

namespace sculpt::files {
namespace {

// Opens without waiting (a FIFO with no writer) and checks what it is.
UniqueFd open_regular(const std::filesystem::path& file, std::uint64_t max_bytes, std::uint64_t& size) {
  if (file.empty()) throw FileError(file, "the path is empty");
  UniqueFd fd(::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY));
  if (fd.get() < 0) {
    const int e = errno;
    if (e == ENOENT) throw FileError(file, "no such file");
    if (e == EACCES) throw FileError(file, "permission denied");
    if (e == ENXIO) throw FileError(file, "is a socket or a device with nothing behind it, not a regular file");
    throw FileError(file, fmt::format("cannot open: {}", std::strerror(e)));
  }
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0) throw FileError(file, fmt::format("cannot stat: {}", std::strerror(errno)));
  if (!S_ISREG(st.st_mode)) throw FileError(file, fmt::format("is a {}, not a regular file", kind_of(st.st_mode)));
  size = static_cast<std::uint64_t>(st.st_size);
  if (size > max_bytes) throw FileError(file, fmt::format("is larger than {} ({})", size_text(max_bytes), size_text(size)));
  return fd;
}

}  // namespace

const char* kind_of(std::uint32_t mode) {
  switch (mode & S_IFMT) {
    case S_IFREG: return "regular file";
    case S_IFDIR: return "directory";
    case S_IFIFO: return "FIFO";
    case S_IFCHR: return "character device";
    case S_IFBLK: return "block device";
    case S_IFSOCK: return "socket";
    case S_IFLNK: return "symbolic link";
    default: return "special file";
  }
}

std::string size_text(std::uint64_t bytes) {
  if (bytes >= (std::uint64_t{1} << 30) && bytes % (std::uint64_t{1} << 30) == 0) return fmt::format("{} GiB", bytes >> 30);
  if (bytes >= (std::uint64_t{1} << 20)) return fmt::format("{:.4g} MiB", static_cast<double>(bytes) / (1 << 20));
  if (bytes >= (std::uint64_t{1} << 10)) return fmt::format("{:.4g} KiB", static_cast<double>(bytes) / (1 << 10));
  return fmt::format("{} bytes", bytes);
}

std::uint64_t check_regular(const std::filesystem::path& file, std::uint64_t max_bytes) {
  std::uint64_t size = 0;
  open_regular(file, max_bytes, size);
  return size;
}

std::string read_regular(const std::filesystem::path& file, std::uint64_t max_bytes) {
  std::uint64_t size = 0;
  const UniqueFd fd = open_regular(file, max_bytes, size);
  // One byte more than fstat said: the read that finds the end. A file that
  // grows meanwhile is read on, up to the limit.
  std::string out(static_cast<std::size_t>(size) + 1, '\0');
  std::size_t got = 0;
  for (;;) {
    if (got == out.size()) out.resize(static_cast<std::size_t>(std::min<std::uint64_t>(max_bytes + 1, got + 65536)));
    const ssize_t n = ::read(fd.get(), out.data() + got, out.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw FileError(file, fmt::format("cannot read: {}", std::strerror(errno)));
    if (n == 0) break;
    got += static_cast<std::size_t>(n);
    if (got > max_bytes) throw FileError(file, fmt::format("is larger than {}", size_text(max_bytes)));
  }
  out.resize(got);
  return out;
}

void create_directories(const std::filesystem::path& dir, std::uint32_t mode) {
  if (dir.empty()) return;
  struct stat st {};
  if (::stat(dir.c_str(), &st) == 0) {
    if (!S_ISDIR(st.st_mode)) throw FileError(dir, fmt::format("is a {}, not a directory", kind_of(st.st_mode)));
    return;
  }
  if (dir.has_parent_path() && dir.parent_path() != dir) create_directories(dir.parent_path(), mode);
  if (::mkdir(dir.c_str(), static_cast<mode_t>(mode)) != 0 && errno != EEXIST)
    throw FileError(dir, fmt::format("cannot create the directory: {}", std::strerror(errno)));
  if (::chmod(dir.c_str(), static_cast<mode_t>(mode)) != 0)
    throw FileError(dir, fmt::format("cannot set its mode: {}", std::strerror(errno)));
}

}  // namespace sculpt::files
