#include "scene/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>
#include <vector>

#include "scene/errors.hpp"

namespace sculpt::scene {
namespace fs = std::filesystem;

void write_file_atomically(const fs::path& file, std::string_view bytes) {
  const fs::path dir = file.has_parent_path() ? file.parent_path() : fs::path(".");
  if (file.filename().empty()) throw ExportError(file, "no file name");
  std::string tmpl = (dir / ("." + file.filename().string() + ".tmp-XXXXXX")).string();
  std::vector<char> name(tmpl.begin(), tmpl.end());
  name.push_back('\0');

  auto fail = [&](const std::string& step, int err, bool remove_temp) {
    if (remove_temp) ::unlink(name.data());
    throw ExportError(file, step + ": " + std::strerror(err));
  };

  const int fd = ::mkostemp(name.data(), O_CLOEXEC);
  if (fd < 0) fail("cannot create a file in " + dir.string(), errno, false);
  ::fchmod(fd, 0644);  // mkstemp makes 0600; an exported mesh is meant to be shared
  const char* p = bytes.data();
  std::size_t left = bytes.size();
  while (left) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      ::close(fd);
      fail("write failed", err, true);
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    fail("fsync failed", err, true);
  }
  if (::close(fd) != 0) fail("close failed", errno, true);
  if (::rename(name.data(), file.c_str()) != 0) fail("cannot replace the file", errno, true);
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {  // the data is in place; a failing directory fsync is not worth failing the export
    ::fsync(dfd);
    ::close(dfd);
  }
}

}  // namespace sculpt::scene
