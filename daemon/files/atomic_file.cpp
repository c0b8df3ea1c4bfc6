#include "files/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <string>
#include <system_error>
#include <vector>

#include <fmt/format.h>

#include "files/write_all.hpp"

namespace sculpt::files {
namespace fs = std::filesystem;
namespace {

// Temp files left by an earlier writer of this file that was killed before
// O_TMPFILE was used, or between link and rename: named, and older than
// any write in progress.
void remove_stale_temps(const fs::path& dir, const std::string& prefix) {
  std::error_code ec;
  const auto now = fs::file_time_type::clock::now();
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    std::error_code mec;
    const auto mtime = fs::last_write_time(it->path(), mec);
    if (!mec && now - mtime > std::chrono::minutes(1)) fs::remove(it->path(), mec);
  }
}


}  // namespace

void write_file_atomically(const fs::path& file, std::string_view bytes) {
  const fs::path dir = file.has_parent_path() ? file.parent_path() : fs::path(".");
  if (file.filename().empty()) throw FileError(file, "no file name");
  const std::string prefix = "." + file.filename().string() + ".tmp-";
  remove_stale_temps(dir, prefix);
  // An unnamed file (O_TMPFILE): a writer killed while writing leaves
  // nothing behind. It gets a name only for the moment between link and
  // rename. File systems without O_TMPFILE get a named temp file.
  std::string name;
  // The unnamed file is named later through /proc: without /proc (a chroot,
  // a sandbox) it could never be, so a named temp file is used from the start.
  const bool proc = ::access("/proc/self/fd", F_OK) == 0;
  int fd = proc ? ::open(dir.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0644) : -1;
  const bool unnamed = fd >= 0;
  if (!unnamed) {
    std::string tmpl = (dir / (prefix + "XXXXXX")).string();
    fd = ::mkostemp(tmpl.data(), O_CLOEXEC);
    if (fd < 0) throw FileError(file, "cannot create a file in " + dir.string() + ": " + std::strerror(errno));
    name = tmpl;
  }
  auto fail = [&](const std::string& step) {
    const int err = errno;
    ::close(fd);
    if (!name.empty()) ::unlink(name.c_str());
    throw FileError(file, step + ": " + std::strerror(err));
  };
  ::fchmod(fd, 0644);  // whatever the umask: an exported mesh is meant to be shared
  if (!files::write_all(fd, bytes)) fail("write failed");
  if (::fsync(fd) != 0) fail("fsync failed");
  if (unnamed) {
    // linkat through /proc needs no privilege (AT_EMPTY_PATH would).
    for (int attempt = 0;; ++attempt) {
      name = (dir / fmt::format("{}{}-{}", prefix, ::getpid(), attempt)).string();
      if (::linkat(AT_FDCWD, fmt::format("/proc/self/fd/{}", fd).c_str(), AT_FDCWD, name.c_str(), AT_SYMLINK_FOLLOW) == 0)
        break;
      if (errno != EEXIST || attempt > 100) {
        name.clear();
        fail("cannot give the new file a name in " + dir.string());
      }
    }
  }
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(name.c_str());
    throw FileError(file, std::string("close failed: ") + std::strerror(err));
  }
  if (::rename(name.c_str(), file.c_str()) != 0) {
    const int err = errno;
    ::unlink(name.c_str());
    throw FileError(file, std::string("cannot replace the file: ") + std::strerror(err));
  }
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {  // the data is in place; a failing directory fsync is not worth failing the export
    ::fsync(dfd);
    ::close(dfd);
  }
}

}  // namespace sculpt::files
