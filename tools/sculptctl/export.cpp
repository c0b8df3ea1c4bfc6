// `sculptctl export FILE [--force] [--json]`: the whole sculpt (scene,
// meshes, current state, history) as the one .sculpt file the daemon writes,
// fetched in chunks through its ExportReader (protocol 1.5) and written
// here, with the caller's permissions, atomically: into an unnamed file in
// FILE's directory (or FILE.tmp where the file system has none), fsync'd,
// then given FILE's name (renamed over it with --force; without it an
// existing FILE is never replaced, also when it appears meanwhile), and the
// directory fsync'd. Only a regular file is ever replaced: a device node, a
// FIFO, a socket, a directory or a symbolic link at FILE is refused by its
// kind, --force or not. A killed export leaves no FILE and (but for FILE.tmp
// on such file systems) nothing else. Every error names the file.
#include <fcntl.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string>
#include <string_view>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "daemon_link.hpp"
#include "files/regular_file.hpp"
#include "files/write_all.hpp"

namespace sculpt::ctl {
namespace fs = std::filesystem;
namespace {

constexpr std::uint16_t kExportMinor = 5;
constexpr std::uint32_t kChunk = 4u << 20;  // the daemon's largest answer (max_export_chunk)
// Written to the file in pieces: a daemon's real-time thread on this CPU
// waits out each write whole (files/write_all.hpp).
constexpr std::size_t kWritePiece = 128u << 10;

[[noreturn]] void fail_file(const std::string& file, const std::string& what) {
  fail(kExitCommandFailed, fmt::format("export: {}: {}", file, what));
}

std::string errno_text(const char* step) { return fmt::format("{}: {}", step, std::strerror(errno)); }

// Refuses what is at `file` unless it is nothing or a regular file: --force
// replaces a file, never a device node (as root a rename would put a regular
// file in its place), a FIFO, a socket, a directory or a symbolic link.
void check_replaceable(const std::string& file) {
  struct stat st {};
  if (::lstat(file.c_str(), &st) != 0 || S_ISREG(st.st_mode)) return;
  fail_file(file, fmt::format("is a {}, not a regular file: export writes or replaces only regular files",
                              files::kind_of(st.st_mode)));
}

// The file being written: unnamed (O_TMPFILE) until it is complete, or FILE.tmp.
class NewFile {
 public:
  NewFile(std::string file, bool force) : file_(std::move(file)), force_(force) {
    const fs::path p(file_);
    dir_ = p.has_parent_path() ? p.parent_path().string() : ".";
    tmp_ = file_ + ".tmp";
    // The unnamed file gets its name through /proc: without /proc it never could.
    if (::access("/proc/self/fd", F_OK) == 0) fd_ = ::open(dir_.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
    if (fd_ < 0) {
      if (errno == ENOENT || errno == ENOTDIR || errno == EACCES || errno == EROFS)
        fail_file(file_, errno_text(("cannot create a file in " + dir_).c_str()));
      fd_ = ::open(tmp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
      if (fd_ < 0 && errno == EEXIST)
        fail_file(file_, fmt::format("{} exists: another export to it is running, or one was killed (remove it)", tmp_));
      if (fd_ < 0) fail_file(file_, errno_text(("cannot create " + tmp_).c_str()));
      named_ = true;
    }
  }
  ~NewFile() {
    if (fd_ >= 0) ::close(fd_);
    if (named_ && !done_) ::unlink(tmp_.c_str());
  }
  NewFile(const NewFile&) = delete;
  NewFile& operator=(const NewFile&) = delete;

  void write(std::string_view bytes) {
    if (!files::write_all(fd_, bytes, kWritePiece))
      fail_file(file_, errno_text(named_ ? ("writing " + tmp_).c_str() : "write"));
  }

  // fsync, name, rename, fsync the directory.
  void commit() {
    if (::fsync(fd_) != 0) fail_file(file_, errno_text("fsync"));
    if (!named_) {
      const std::string self = fmt::format("/proc/self/fd/{}", fd_);
      if (!force_) {  // straight to its name: fails if FILE exists, whenever it appeared
        if (::linkat(AT_FDCWD, self.c_str(), AT_FDCWD, file_.c_str(), AT_SYMLINK_FOLLOW) != 0) {
          if (errno == EEXIST) fail_file(file_, "exists (--force replaces it)");
          fail_file(file_, errno_text("cannot give the new file its name"));
        }
        done_ = true;
        close_and_sync_dir();
        return;
      }
      if (::linkat(AT_FDCWD, self.c_str(), AT_FDCWD, tmp_.c_str(), AT_SYMLINK_FOLLOW) != 0) {
        if (errno == EEXIST)
          fail_file(file_, fmt::format("{} exists: another export to it is running, or one was killed (remove it)", tmp_));
        fail_file(file_, errno_text(("cannot name the new file " + tmp_).c_str()));
      }
      named_ = true;
    }
    if (::close(std::exchange(fd_, -1)) != 0) fail_file(file_, errno_text("close"));
    if (force_) {
      check_replaceable(file_);  // again: it may have changed while the sculpt came
      if (::rename(tmp_.c_str(), file_.c_str()) != 0) fail_file(file_, errno_text("cannot replace it"));
    } else if (::renameat2(AT_FDCWD, tmp_.c_str(), AT_FDCWD, file_.c_str(), RENAME_NOREPLACE) != 0) {
      if (errno == EEXIST) fail_file(file_, "exists (--force replaces it)");
      if (errno != EINVAL && errno != ENOSYS) fail_file(file_, errno_text(("cannot rename " + tmp_).c_str()));
      // A file system without RENAME_NOREPLACE: link (which never replaces), then unlink.
      if (::link(tmp_.c_str(), file_.c_str()) != 0) {
        if (errno == EEXIST) fail_file(file_, "exists (--force replaces it)");
        fail_file(file_, errno_text(("cannot rename " + tmp_).c_str()));
      }
      ::unlink(tmp_.c_str());
    }
    done_ = true;
    close_and_sync_dir();
  }

 private:
  void close_and_sync_dir() {
    if (fd_ >= 0) ::close(std::exchange(fd_, -1));
    // The data is in place; a directory that cannot be fsync'd is not worth failing for.
    const int dfd = ::open(dir_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd >= 0) {
      ::fsync(dfd);
      ::close(dfd);
    }
  }

  std::string file_, dir_, tmp_;
  bool force_;
  int fd_ = -1;
  bool named_ = false, done_ = false;
};

}  // namespace

void export_sculpt(const ExportArgs& args) {
  if (args.file.empty()) fail(kExitUsage, "export: the file name is empty");
  const std::string& file = args.file;
  check_replaceable(file);
  struct stat st {};
  if (::lstat(file.c_str(), &st) == 0 && !args.force) fail_file(file, "exists (--force replaces it)");
  NewFile out(file, args.force);
  std::uint64_t size = 0;
  with_daemon(args.daemon, [&](client::Connection& c, kj::WaitScope& ws) {
    require_minor(c, kExportMinor, "export");
    auto reply = c.session().exportSculptRequest().send().wait(ws);
    if (!reply.getResult().getOk()) fail(kExitCommandFailed, std::string("export: ") + reply.getResult().getError().cStr());
    size = reply.getSize();
    auto reader = reply.getReader();
    for (std::uint64_t offset = 0; offset < size;) {
      auto req = reader.readRequest();
      req.setOffset(offset);
      req.setCount(static_cast<std::uint32_t>(std::min<std::uint64_t>(kChunk, size - offset)));
      auto chunk = req.send().wait(ws);
      const auto data = chunk.getData();
      if (data.size() == 0)
        fail_file(file, fmt::format("the daemon's export ended at byte {} of {}", offset, size));
      if (data.size() > size - offset)
        fail_file(file, fmt::format("the daemon sent {} bytes at byte {} of {}", data.size(), offset, size));
      out.write(std::string_view(reinterpret_cast<const char*>(data.begin()), data.size()));
      offset += data.size();
    }
  });
  out.commit();
  if (args.daemon.json) std::cout << nlohmann::json{{"file", file}, {"bytes", size}}.dump() << "\n";
  else fmt::print("exported {} bytes to {}\n", size, file);
}

}  // namespace sculpt::ctl
