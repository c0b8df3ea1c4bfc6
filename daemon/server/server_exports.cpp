// The server's exports: a .sculpt file the daemon writes, held for one
// client's ExportReader and read in pieces, expired when left alone.
#include "server/server.hpp"

#include <fcntl.h>
#include <malloc.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include <capnp/rpc.h>
#include <fmt/format.h>

#include "files/unique_fd.hpp"
#include "server/checked_stream.hpp"
#include "server/encode.hpp"
#include "server/interfaces.hpp"
#include "server/server_parts.hpp"
#include "simloop/sim_thread.hpp"

namespace sculpt::server {
namespace {

constexpr std::uint64_t kExportReadPiece = 256u << 10;  // bytes per pread of an export

double seconds(kj::Duration d) { return static_cast<double>(d / kj::MICROSECONDS) * 1e-6; }

// "" when `fd` is a readable regular file of `bytes` bytes, else why not.
std::string check_export_file(int fd, std::uint64_t bytes) {
  if (fd < 0) return "the daemon gave no file";
  struct stat st {};
  if (::fstat(fd, &st) != 0) return fmt::format("fstat: {}", std::strerror(errno));
  if (!S_ISREG(st.st_mode)) return "the daemon's export is not a regular file";
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags < 0 || (flags & O_ACCMODE) == O_WRONLY) return "the daemon's export is not open for reading";
  if (static_cast<std::uint64_t>(st.st_size) != bytes)
    return fmt::format("the daemon reported {} bytes, its file holds {}", bytes, st.st_size);
  ::fcntl(fd, F_SETFD, FD_CLOEXEC);  // never inherited by whatever the daemon runs
  return {};
}

}  // namespace

std::string Server::export_refusal(std::uint64_t client) const {
  std::size_t mine = 0;
  for (const auto& [id, e] : exports_) mine += e->client == client;
  if (mine >= options_.max_exports_per_client)
    return fmt::format("{} exports of this connection are being written or held open (limit: {}, "
                       "max_exports_per_client); read one to its end and drop its reader first",
                       mine, options_.max_exports_per_client);
  if (exports_.size() >= options_.max_exports)
    return fmt::format("{} exports are being written or held open by the daemon's clients (limit: {}, "
                       "max_exports); try again later",
                       exports_.size(), options_.max_exports);
  return {};
}

void Server::land_export(std::uint64_t id, std::string error, int fd, std::uint64_t bytes) {
  files::UniqueFd file(fd);  // closed here unless the export still waits for it
  const auto it = exports_.find(id);
  if (it == exports_.end()) return;  // its call was cancelled (the client went)
  Export& e = *it->second;
  e.error = std::move(error);
  if (e.error.empty()) {
    if (const std::string why = check_export_file(file.get(), bytes); !why.empty()) {
      if (options_.log) options_.log(3, fmt::format("client {}: export refused: {}", e.client, why));
      e.error = "the daemon's export cannot be served: " + why;
    } else {
      e.fd = std::move(file);
      e.size = bytes;
    }
  }
  if (e.landed) e.landed->fulfill();
}

kj::Promise<void> Server::start_export(std::uint64_t client, std::uint64_t& id_out) {
  const std::uint64_t id = id_out = next_export_++;
  auto e = std::make_unique<Export>();
  e->client = client;
  auto paf = kj::newPromiseAndFulfiller<void>();
  e->landed = kj::mv(paf.fulfiller);
  exports_.emplace(id, std::move(e));
  // The daemon's answer is taken by a task of the server, which nothing
  // cancels: the file is the export's, or closed at once when its call is
  // gone (the client went).
  tasks_->add(kj::evalNow([this] { return control_.export_sculpt(); })
                  .then([this, id](ExportOutcome o) { land_export(id, std::move(o.error), o.fd, o.bytes); },
                        [this, id](kj::Exception&& x) {
                          land_export(id, fmt::format("the daemon's export failed: {}", x.getDescription().cStr()),
                                      -1, 0);
                        }));
  return kj::mv(paf.promise);
}

void Server::release_export(std::uint64_t id) {
  if (const auto it = exports_.find(id); it != exports_.end() && !it->second->open) exports_.erase(it);
}

std::string Server::open_export(std::uint64_t id, std::uint64_t& size) {
  const auto it = exports_.find(id);
  if (it == exports_.end()) return "the server is closing";
  Export& e = *it->second;
  if (!e.error.empty()) return e.error;
  e.open = true;
  e.last_read_ns = simloop::monotonic_ns();
  size = e.size;
  if (options_.log) options_.log(6, fmt::format("client {}: export {} ready, {} bytes", e.client, id, e.size));
  return {};
}

void Server::read_export(std::uint64_t id, std::uint64_t offset, std::uint32_t count,
                         proto::ExportReader::ReadResults::Builder out) {
  const auto it = exports_.find(id);
  if (it == exports_.end() || !it->second->open)
    kj::throwFatalException(KJ_EXCEPTION(
        FAILED, fmt::format("this export was closed after {:g} s without a read (export_idle_timeout); export again",
                            seconds(options_.export_idle_timeout))));
  Export& e = *it->second;
  if (offset > e.size)
    kj::throwFatalException(
        KJ_EXCEPTION(FAILED, fmt::format("offset {} is past the end of the export ({} bytes)", offset, e.size)));
  e.last_read_ns = simloop::monotonic_ns();
  const std::uint64_t n = std::min<std::uint64_t>({count, options_.max_export_chunk, e.size - offset});
  auto data = capnp::Orphanage::getForMessageContaining(out).newOrphan<capnp::Data>(static_cast<unsigned>(n));
  std::uint64_t got = 0;
  while (got < n) {
    // In pieces: a read is one stretch in the kernel that the sim thread,
    // waking on this CPU, waits out whole (files/write_all.hpp).
    const std::uint64_t piece = std::min<std::uint64_t>(n - got, kExportReadPiece);
    const ssize_t r = ::pread(e.fd.get(), data.get().begin() + got, piece, static_cast<off_t>(offset + got));
    if (r < 0 && errno == EINTR) continue;
    if (r < 0)
      kj::throwFatalException(
          KJ_EXCEPTION(FAILED, fmt::format("reading the export at offset {}: {}", offset + got, std::strerror(errno))));
    if (r == 0) break;  // the file is shorter than it was (it never should be)
    got += static_cast<std::uint64_t>(r);
  }
  if (got < n) data.truncate(static_cast<unsigned>(got));
  out.adoptData(kj::mv(data));
}

void Server::close_export(std::uint64_t id) {
  if (const auto it = exports_.find(id); it != exports_.end()) {
    if (options_.log) options_.log(7, fmt::format("client {}: export {} closed", it->second->client, id));
    exports_.erase(it);
  }
}

void Server::expire_exports(std::int64_t now) {
  const std::int64_t idle_ns = options_.export_idle_timeout / kj::NANOSECONDS;
  for (auto it = exports_.begin(); it != exports_.end();) {
    const Export& e = *it->second;
    if (e.open && now - e.last_read_ns > idle_ns) {
      if (options_.log)
        options_.log(5, fmt::format("client {}: export {} closed: not read for {:g} s (export_idle_timeout)", e.client,
                                    it->first, seconds(options_.export_idle_timeout)));
      it = exports_.erase(it);
    } else {
      ++it;
    }
  }
}

}  // namespace sculpt::server
