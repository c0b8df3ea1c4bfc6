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
#include "simloop/sim_thread.hpp"
#include "server/checked_stream.hpp"
#include "server/encode.hpp"
#include "server/interfaces.hpp"

namespace sculpt::server {
namespace {

constexpr std::uint64_t kExportReadPiece = 256u << 10;  // bytes per pread of an export
constexpr off_t kExportReleaseStep = 1 << 20;           // bytes freed per ftruncate of one let go

// A connection is not taken for a silent one before it had this long to say hello.
constexpr std::int64_t kHelloGraceNs = 1'000'000'000;
// A refused client has this long to read its answer and close before the server closes it.
constexpr std::int64_t kRefusalGraceNs = 1'000'000'000;

bool same_tools(const PublishedHeader& a, const PublishedHeader& b) {
  if (a.tool_count != b.tool_count) return false;
  return std::memcmp(a.tools.data(), b.tools.data(), sizeof(PublishedTool) * a.tool_count) == 0;
}

}  // namespace

float clamp_fps(float fps, float fallback) {
  if (!std::isfinite(fps) || fps <= 0) return fallback;
  return std::clamp(fps, 0.1f, 1000.0f);
}

// One viewer's stream: its own baseline (what it has: the positions it was
// last sent, per vertex), rate and tolerance. Bounded: one copy of the
// positions, one call in flight.
struct Server::Stream {
  std::uint64_t id = 0, client = 0;
  proto::Viewer::Client viewer;
  float tolerance = 0;
  float fps = 60;
  std::vector<std::vector<float>> baseline;   // per body, file order
  std::uint64_t evaluated = 0;                // reader serial its baseline was compared at
  PublishedHeader sent_header{};              // tools as last sent
  std::uint64_t sequence = 0;                 // of the last frame or snapshot sent
  std::uint64_t snapshots = 0;                // sent to this viewer
  std::int64_t last_send_ns = 0, last_stats_ns = 0;
  bool needs_snapshot = true;
  bool in_flight = false;
  bool dead = false;
  kj::Promise<void> pending = nullptr;

  explicit Stream(proto::Viewer::Client v) : viewer(kj::mv(v)) {}
};

struct Server::Client {
  std::uint64_t id = 0;
  std::string peer;
  std::string name;      // what its hello said it is
  bool hello = false;    // a valid hello arrived (else: garbage, a silent or truncated client)
  std::string refusal;   // served only to be told this (the client table was full)
  std::string violation; // the limit its messages broke (checked_stream.hpp), for the log
  std::int64_t connected_ns = 0;
  std::int64_t answered_ns = 0;  // a refusal: when its answer was written (0: not yet)
  bool closing = false;  // over a limit: dropped at the next turn of the loop
  std::size_t pending_edits = 0;  // undo/redo calls being applied
  int fd = -1;           // the socket (owned by `stream`), to see whether the peer is gone
  kj::Own<kj::AsyncIoStream> stream;
  kj::Own<CheckedMessageStream> messages;
  kj::Own<capnp::TwoPartyVatNetwork> network;
  kj::Own<capnp::RpcSystem<capnp::rpc::twoparty::VatId>> rpc;

  std::string who() const {
    return name.empty() ? fmt::format("client {} ({})", id, peer) : fmt::format("client {} ({}, \"{}\")", id, peer, name);
  }
};

// An export: a file the daemon is writing (`landed` fulfilled when it has
// answered: `fd` or `error`), then held by one client's ExportReader (`open`).
struct Server::Export {
  std::uint64_t client = 0;
  kj::Own<kj::PromiseFulfiller<void>> landed;
  std::string error;
  files::UniqueFd fd;
  std::uint64_t size = 0;
  std::int64_t last_read_ns = 0;
  bool open = false;
  // The file has no name: its last close frees all its pages in one stretch
  // in the kernel (a millisecond for 35 MB here), which a real-time thread
  // waking on this CPU waits out. Shrunk in steps first, each short.
  ~Export() {
    if (!fd.valid()) return;
    struct stat st {};
    if (::fstat(fd.get(), &st) != 0 || !S_ISREG(st.st_mode) || st.st_nlink != 0) return;
    for (off_t at = st.st_size; at > 0;) {
      at = at > kExportReleaseStep ? at - kExportReleaseStep : 0;
      if (::ftruncate(fd.get(), at) != 0) return;
    }
  }
};

void Server::Errors::taskFailed(kj::Exception&& e) {
  // The loops handle their own errors; this is only reached on a bug.
  KJ_LOG(ERROR, "sculptd server task failed", e);
}

Server::Server(kj::AsyncIoContext& io, DaemonControl& control, ServerOptions options)
    : io_(io), control_(control), options_(std::move(options)), tasks_(kj::heap<kj::TaskSet>(errors_)) {
  tasks_->add(pump_loop());
}

Server::~Server() { close(); }

void Server::close() {
  if (closed_) return;
  closed_ = true;
  tasks_ = nullptr;
  streams_.clear();
  clients_.clear();
  exports_.clear();
  listen_observer_ = nullptr;
  if (listen_fd_ >= 0) ::close(listen_fd_);
  listen_fd_ = -1;
  reader_.reset();
}

Server::Replaced Server::set_scene(SceneInfo info, const PublishedState& state,
                                   std::unique_ptr<PublishedReader> reader) {
  Replaced old{std::move(scene_), std::move(reader_)};
  scene_ = std::move(info);
  reader_ = reader ? std::move(reader) : std::make_unique<PublishedReader>(state);
  std::uint64_t bytes = 4096;
  for (const auto& m : scene_.meshes) bytes += m.rest.size() * 8 + m.triangles.size() * 4 + m.name.size() + 256;
  receive_limit_words_ = std::max<std::uint64_t>(options_.traversal_limit_words, bytes / 8 * 2);
  snapshot_bytes_ = bytes;
  scratch_.assign(reader_->body_count(), {});
  for (auto& [id, s] : streams_) s->needs_snapshot = true;
  return old;
}

void Server::set_tool_devices(const std::vector<std::int32_t>& slot_of_tool) {
  for (std::size_t t = 0; t < scene_.tools.size(); ++t)
    scene_.tools[t].device_slot = t < slot_of_tool.size() ? slot_of_tool[t] : -1;
}

void Server::listen(int fd) {
  listen_fd_ = fd;
  const int flags = ::fcntl(fd, F_GETFL, 0);
  ::fcntl(fd, F_SETFL, flags | O_NONBLOCK);
  listen_observer_ =
      kj::heap<kj::UnixEventPort::FdObserver>(io_.unixEventPort, fd, kj::UnixEventPort::FdObserver::OBSERVE_READ);
  tasks_->add(accept_loop());
}

kj::Promise<void> Server::accept_loop() {
  // A few connections per turn of the event loop: the disconnects of those
  // that closed at once (a burst of connect/close) free their places in
  // between.
  for (int batch = 0;; ++batch) {
    if (batch == 8) return kj::evalLater([this] { return accept_loop(); });
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
    if (fd < 0) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK && options_.log)
        options_.log(4, fmt::format("accept: {}", std::strerror(errno)));
      break;
    }
    ucred cred{};
    socklen_t len = sizeof cred;
    std::string peer = ::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0
                           ? fmt::format("pid {} uid {} gid {}", cred.pid, cred.uid, cred.gid)
                           : std::string("peer unknown");
    std::string refusal;
    if (clients_.size() >= options_.max_clients) sweep_closed();
    if (clients_.size() >= options_.max_clients) {
      // A connection that has said nothing yet makes room: silent or
      // half-open connections never lock the others out.
      if (const std::uint64_t silent = oldest_silent(loop::monotonic_ns() - kHelloGraceNs); silent != 0) {
        ++counters_.evicted;
        drop(silent, fmt::format("closed to make room for a new connection: it had said no hello, and {} clients "
                                 "are the limit (max_clients)",
                                 options_.max_clients));
      } else {
        ++counters_.refused;
        refusal = fmt::format("{} clients are connected, the limit (max_clients); try again later",
                              options_.max_clients);
        std::size_t refusing = 0;
        for (const auto& [cid, c] : clients_) refusing += !c->refusal.empty();
        const std::int64_t now = loop::monotonic_ns();
        if (options_.log && now - refused_logged_ns_ > 1'000'000'000) {
          options_.log(4, fmt::format("refusing a client ({}): {} ({} refused so far)", peer, refusal,
                                      counters_.refused));
          refused_logged_ns_ = now;
        }
        if (refusing >= options_.max_refusing) {  // no answer for this one: closed at once
          ::close(fd);
          continue;
        }
      }
    }
    serve_client(io_.lowLevelProvider->wrapSocketFd(fd, kj::LowLevelAsyncIoProvider::TAKE_OWNERSHIP), kj::mv(peer),
                 kj::mv(refusal), fd);
  }
  return listen_observer_->whenBecomesReadable().then([this] { return accept_loop(); });
}

void Server::serve(kj::Own<kj::AsyncIoStream> stream, std::string peer) {
  serve_client(kj::mv(stream), kj::mv(peer), {}, -1);
}

void Server::sweep_closed() {
  // Connections whose peer has already gone (a burst of connect and close)
  // give their place back now, not when the event loop reads their EOF.
  std::vector<std::uint64_t> gone;
  for (const auto& [id, c] : clients_) {
    if (c->hello || c->fd < 0) continue;
    char byte;
    const ssize_t n = ::recv(c->fd, &byte, 1, MSG_PEEK | MSG_DONTWAIT);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) gone.push_back(id);
  }
  for (const std::uint64_t id : gone) {
    ++counters_.disconnected;
    clients_.erase(id);
  }
}

void Server::serve_client(kj::Own<kj::AsyncIoStream> stream, std::string peer, std::string refusal, int fd) {
  auto c = std::make_unique<Client>();
  c->id = next_client_++;
  c->fd = fd;
  c->peer = std::move(peer);
  c->refusal = std::move(refusal);
  c->connected_ns = loop::monotonic_ns();
  c->stream = kj::mv(stream);
  MessageLimits incoming;
  incoming.max_bytes = options_.max_message_bytes;
  incoming.max_capabilities = options_.max_message_capabilities;
  incoming.nesting = options_.nesting_limit;
  c->messages = kj::heap<CheckedMessageStream>(*c->stream, io_.provider->getTimer(), incoming, c->violation);
  // These options bound what the daemon SENDS (capnp refuses to send more
  // than it would receive); what a client sends is bounded by `incoming`.
  capnp::ReaderOptions limits;
  limits.traversalLimitInWords = std::max(options_.traversal_limit_words, receive_limit_words_);
  limits.nestingLimit = options_.nesting_limit;
  c->network = kj::heap<capnp::TwoPartyVatNetwork>(*c->messages, capnp::rpc::twoparty::Side::SERVER, limits);
  c->rpc = kj::heap<capnp::RpcSystem<capnp::rpc::twoparty::VatId>>(
      capnp::makeRpcServer(*c->network, make_sculptd(*this, c->id, c->peer)));
  c->rpc->setFlowLimit(options_.flow_limit_words);
  ++counters_.connections;
  if (options_.log) options_.log(6, fmt::format("client {} connected ({})", c->id, c->peer));
  const std::uint64_t id = c->id;
  auto done = c->network->onDisconnect();
  clients_.emplace(id, std::move(c));
  tasks_->add(done.then(
      [this, id] {
        auto it = clients_.find(id);
        if (it == clients_.end()) return;  // dropped by the server: already logged
        const Client& c = *it->second;
        if (options_.log) {
          if (!c.violation.empty()) options_.log(4, fmt::format("{} disconnected: {}", c.who(), c.violation));
          else if (c.hello) options_.log(6, fmt::format("{} disconnected", c.who()));
          else options_.log(4, fmt::format("{} dropped: it sent no valid hello (garbage, truncated or nothing)", c.who()));
        }
        if (!c.violation.empty()) ++counters_.limits_hit;
        ++counters_.disconnected;
        for (auto& [sid, s] : streams_)
          if (s->client == id) s->dead = true;
        clients_.erase(it);
      },
      [this, id](kj::Exception&& e) {
        auto it = clients_.find(id);
        if (it == clients_.end()) return;
        if (options_.log)
          options_.log(4, fmt::format("{} dropped: {}", it->second->who(),
                                      it->second->violation.empty() ? e.getDescription().cStr()
                                                                    : it->second->violation.c_str()));
        ++counters_.disconnected;
        for (auto& [sid, s] : streams_)
          if (s->client == id) s->dead = true;
        clients_.erase(it);
      }));
  // A connection that says nothing holds a place; not for long.
  tasks_->add(io_.provider->getTimer().afterDelay(options_.hello_timeout).then([this, id] {
    auto it = clients_.find(id);
    if (it == clients_.end() || it->second->hello) return;
    drop(id, fmt::format("it said no hello within {} s (hello_timeout)", options_.hello_timeout / kj::SECONDS));
  }));
}

void Server::drop(std::uint64_t id, const std::string& why) {
  auto it = clients_.find(id);
  if (it == clients_.end()) return;
  if (options_.log) options_.log(4, fmt::format("{} disconnected: {}", it->second->who(), why));
  ++counters_.disconnected;
  if (it->second->refusal.empty()) ++counters_.limits_hit;
  for (auto& [sid, s] : streams_)
    if (s->client == id) s->dead = true;
  clients_.erase(it);  // closes the socket; its calls and their replies go with it
  // A queue of replies can be hundreds of MB: give it back, in a turn of
  // the loop of its own (after the next poll for I/O, as a message is read).
  tasks_->add(io_.provider->getTimer().afterDelay(0 * kj::NANOSECONDS).then([] { ::malloc_trim(0); }));
}

std::uint64_t Server::oldest_silent(std::int64_t connected_before_ns) const {
  std::uint64_t best = 0;
  std::int64_t at = 0;
  for (const auto& [id, c] : clients_)
    if (!c->hello && c->connected_ns < connected_before_ns && (best == 0 || c->connected_ns < at))
      best = id, at = c->connected_ns;
  return best;
}

bool Server::admit(std::uint64_t client) {
  const auto it = clients_.find(client);
  if (it == clients_.end()) return false;
  Client& c = *it->second;
  if (c.closing) return false;
  const std::size_t queued = c.network->getCurrentQueueSize();
  const std::uint64_t limit = max_queued_bytes();
  if (queued <= limit) return true;
  // Its calls are answered the moment they are read, so a burst of them
  // is checked call by call, not at the next pump.
  c.closing = true;
  const std::string why =
      fmt::format("{} bytes of replies and frames it has not read (limit: {}, max_queued_bytes)", queued, limit);
  tasks_->add(kj::evalLater([this, client, why] { drop(client, why); }));
  return false;
}

std::uint64_t Server::max_queued_bytes() const { return std::max(options_.max_queued_bytes, 4 * snapshot_bytes_); }

void Server::check_queues() {
  const std::uint64_t limit = max_queued_bytes();
  std::vector<std::pair<std::uint64_t, std::string>> over;
  for (const auto& [id, c] : clients_) {
    const std::size_t queued = c->network->getCurrentQueueSize();
    if (queued > limit)
      over.emplace_back(id, fmt::format("{} bytes of replies and frames it has not read (limit: {}, max_queued_bytes)",
                                        queued, limit));
    else if (!c->refusal.empty() && c->hello && c->network->getCurrentQueueCount() == 0) {
      // The refusal is written. The client closes once it has read it; a
      // close from this side first could fail the client's own next write
      // (EPIPE) before it reads the answer, so it gets a second to do so.
      const std::int64_t now = loop::monotonic_ns();
      if (c->answered_ns == 0) c->answered_ns = now;
      else if (now - c->answered_ns > kRefusalGraceNs) over.emplace_back(id, c->refusal);
    }
  }
  for (const auto& [id, why] : over) drop(id, why);
}

namespace {

// A tolerance is metres: finite and not negative (0: every change). The
// call fails with the reason otherwise.
float checked_tolerance(float tolerance) {
  KJ_REQUIRE(std::isfinite(tolerance) && tolerance >= 0,
             "toleranceM must be a finite number of metres >= 0 (0 sends every change)", tolerance);
  return tolerance;
}

}  // namespace

std::uint64_t Server::add_stream(proto::Viewer::Client viewer, float tolerance, float fps, std::uint64_t client) {
  std::size_t mine = 0;
  for (const auto& [id, st] : streams_) mine += st->client == client && !st->dead;
  KJ_REQUIRE(mine < options_.max_viewers_per_client,
             "too many subscriptions on one connection (max_viewers_per_client)", options_.max_viewers_per_client);
  auto s = std::make_unique<Stream>(kj::mv(viewer));
  s->id = next_stream_++;
  s->client = client;
  s->tolerance = checked_tolerance(tolerance);
  s->fps = clamp_fps(fps, options_.default_fps);
  const std::uint64_t id = s->id;
  if (options_.log)
    options_.log(6, fmt::format("client {}: viewer {} subscribed (tolerance {} m, {} fps)", client, id, s->tolerance,
                                s->fps));
  streams_.emplace(id, std::move(s));
  return id;
}

void Server::remove_stream(std::uint64_t id) {
  auto it = streams_.find(id);
  if (it == streams_.end()) return;
  // Not from inside its own pending promise: that only marks it dead.
  it->second->dead = true;
}

void Server::set_rate(std::uint64_t id, float fps) {
  if (auto it = streams_.find(id); it != streams_.end()) it->second->fps = clamp_fps(fps, options_.default_fps);
}

void Server::set_tolerance(std::uint64_t id, float tolerance) {
  const float checked = checked_tolerance(tolerance);
  if (auto it = streams_.find(id); it != streams_.end()) it->second->tolerance = checked;
}

kj::Promise<bool> Server::until_paused(bool paused, int tries) {
  // The sim thread applies it within a period; a stopped one never does.
  if (control_.paused_now() == paused) return true;
  if (tries <= 0) return false;
  return io_.provider->getTimer().afterDelay(1 * kj::MILLISECONDS).then([this, paused, tries] {
    return until_paused(paused, tries - 1);
  });
}

void Server::said_hello(std::uint64_t client, const std::string& name) {
  if (auto it = clients_.find(client); it != clients_.end()) {
    it->second->hello = true;
    it->second->name = name.substr(0, 128);
  }
}

std::string Server::refusal(std::uint64_t client) const {
  const auto it = clients_.find(client);
  return it == clients_.end() ? std::string() : it->second->refusal;
}

std::string Server::edit_refusal(std::uint64_t client, std::uint32_t count) const {
  if (count == 0 || count > options_.max_edit_count)
    return fmt::format("count {} is out of range: 1 to {} strokes at once (max_edit_count)", count,
                       options_.max_edit_count);
  const auto it = clients_.find(client);
  if (it == clients_.end()) return "the connection is closing";
  if (it->second->pending_edits >= options_.max_pending_edits_per_client)
    return fmt::format("{} undo/redo calls of this connection are still being applied (limit: {}, "
                       "max_pending_edits_per_client); wait for their answers",
                       it->second->pending_edits, options_.max_pending_edits_per_client);
  return {};
}

kj::Promise<EditOutcome> Server::edit(std::uint64_t client, bool redo, std::uint32_t count) {
  if (const auto it = clients_.find(client); it != clients_.end()) ++it->second->pending_edits;
  auto answered = kj::defer([this, client] {
    if (const auto c = clients_.find(client); c != clients_.end()) --c->second->pending_edits;
  });
  const char* what = redo ? "redo" : "undo";
  return kj::evalNow([this, redo, count] { return redo ? control_.redo(count) : control_.undo(count); })
      .catch_([what](kj::Exception&& e) {
        EditOutcome o;
        o.error = fmt::format("the daemon's {} failed: {}", what, e.getDescription().cStr());
        return o;
      })
      .attach(kj::mv(answered));
}

void Server::fill_history(proto::History::Builder out, std::uint32_t from, std::uint32_t limit) {
  const std::size_t most = std::max<std::size_t>(1, options_.max_history_entries);
  const std::uint32_t page = limit == 0 || limit > most ? static_cast<std::uint32_t>(std::min<std::size_t>(most, UINT32_MAX)) : limit;
  server::fill_history(out, control_.history(from, page), page);
}

namespace {

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
  e.last_read_ns = loop::monotonic_ns();
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
  e.last_read_ns = loop::monotonic_ns();
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

DaemonStatus Server::status_now() {
  // The daemon's numbers, with the two only the server knows.
  DaemonStatus d = control_.status();
  d.stats.viewers = streams_.size();
  d.stats.bytes_sent = counters_.bytes_sent;
  return d;
}

void Server::fill_status(proto::Stats::Builder out) { server::fill_stats(out, status_now()); }

void Server::fill_snapshot_now(proto::Snapshot::Builder out) {
  if (!reader_) return;
  reader_->sync();
  server::fill_snapshot(out, scene_, *reader_);
}

kj::Promise<void> Server::pump_loop() {
  return io_.provider->getTimer().afterDelay(options_.pump_period).then([this] {
    pump();
    return pump_loop();
  });
}

void Server::pump() {
  check_queues();
  if (!exports_.empty()) expire_exports(loop::monotonic_ns());
  // Ended streams go first (never from inside their own promise).
  for (auto it = streams_.begin(); it != streams_.end();) {
    if (it->second->dead) {
      if (options_.log) options_.log(7, fmt::format("viewer {} ended", it->first));
      it = streams_.erase(it);
    } else {
      ++it;
    }
  }
  if (streams_.empty() || !reader_) return;
  reader_->sync();
  const std::int64_t now = loop::monotonic_ns();
  for (auto& [id, s] : streams_) {
    if (s->in_flight || s->dead) continue;
    if (s->needs_snapshot) {
      send_snapshot(*s);
      continue;
    }
    const auto period = static_cast<std::int64_t>(1e9 / s->fps);
    if (now - s->last_send_ns < period) continue;
    send_frame(*s, now);
  }
}

kj::Promise<void> Server::track_send(std::uint64_t id, kj::Promise<void> sent) {
  // One stream call in flight per viewer: its return frees the viewer for
  // the next frame, its failure ends the stream.
  return sent
      .then([this, id] {
              if (auto it = streams_.find(id); it != streams_.end()) it->second->in_flight = false;
            },
            [this, id](kj::Exception&& e) {
              if (auto it = streams_.find(id); it != streams_.end()) {
                it->second->dead = true;
                if (options_.log) options_.log(4, fmt::format("viewer {} ended: {}", id, e.getDescription().cStr()));
              }
            })
      .eagerlyEvaluate(nullptr);
}

void Server::send_snapshot(Stream& s) {
  auto req = s.viewer.snapshotRequest(snapshot_size_hint());
  auto snap = req.initSnapshot();
  server::fill_snapshot(snap, scene_, *reader_);
  s.baseline.resize(reader_->body_count());
  for (std::size_t b = 0; b < reader_->body_count(); ++b) {
    const auto p = reader_->positions(b);
    s.baseline[b].assign(p.begin(), p.end());
  }
  s.evaluated = reader_->serial();
  s.sent_header = reader_->header();
  // Strictly increasing per viewer, also across a scene swap's new snapshot.
  s.sequence = s.snapshots == 0 ? reader_->header().tick : std::max(reader_->header().tick, s.sequence + 1);
  snap.setSequence(s.sequence);
  ++s.snapshots;
  s.needs_snapshot = false;
  s.in_flight = true;
  s.last_send_ns = loop::monotonic_ns();
  counters_.bytes_sent += req.totalSize().wordCount * 8;
  ++counters_.snapshots;
  s.pending = track_send(s.id, req.send());
}

bool Server::send_frame(Stream& s, std::int64_t now) {
  const PublishedReader& r = *reader_;
  const PublishedHeader& h = r.header();
  const float tol2 = s.tolerance * s.tolerance;
  std::size_t changed_meshes = 0;
  for (std::size_t b = 0; b < r.body_count(); ++b) {
    auto& idx = scratch_[b];
    idx.clear();
    const auto pos = r.positions(b);
    auto& base = s.baseline[b];
    for (std::uint32_t k = 0; k < r.blocks(b); ++k) {
      if (r.block_serial(b, k) <= s.evaluated) continue;
      for (const std::uint32_t o : r.block_vertices(b, k)) {
        const float* p = &pos[std::size_t{o} * 3];
        float* q = &base[std::size_t{o} * 3];
        const float dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
        const float d2 = dx * dx + dy * dy + dz * dz;
        if (d2 > tol2 || (tol2 == 0 && (p[0] != q[0] || p[1] != q[1] || p[2] != q[2]))) idx.push_back(o);
      }
    }
    if (!idx.empty()) {
      std::sort(idx.begin(), idx.end());
      ++changed_meshes;
    }
  }
  s.evaluated = r.serial();
  const bool tools_moved = !same_tools(h, s.sent_header);
  const bool keepalive = now - s.last_send_ns >= options_.keepalive_ns;
  if (changed_meshes == 0 && !tools_moved && !keepalive) return false;

  auto req = s.viewer.frameRequest();
  auto f = req.initFrame();
  // Strictly increasing per viewer: a frame at the same tick as the last
  // (a keep-alive while paused, tools moved) goes one past it.
  f.setSequence(std::max(h.tick, s.sequence + 1));
  f.setSimTimeNs(static_cast<std::uint64_t>(std::llround(static_cast<double>(h.tick) * 1e9 / scene_.rate_hz)));
  f.setPublishedNs(h.published_ns);
  auto meshes = f.initMeshes(static_cast<unsigned>(changed_meshes));
  unsigned m = 0;
  for (std::size_t b = 0; b < r.body_count(); ++b) {
    const auto& idx = scratch_[b];
    if (idx.empty()) continue;
    auto md = meshes[m++];
    md.setMeshId(static_cast<std::uint32_t>(b));
    auto list = md.initIndices(static_cast<unsigned>(idx.size()));
    auto bytes = md.initPositions(idx.size() * 12);
    const auto pos = r.positions(b);
    auto& base = s.baseline[b];
    auto* out = reinterpret_cast<float*>(bytes.begin());
    for (std::size_t k = 0; k < idx.size(); ++k) {
      const std::uint32_t o = idx[k];
      list.set(static_cast<unsigned>(k), o);
      std::memcpy(out + k * 3, &pos[std::size_t{o} * 3], 12);
      std::memcpy(&base[std::size_t{o} * 3], &pos[std::size_t{o} * 3], 12);
    }
    set_bounds(md.initBounds(), r.bounds(b));
  }
  fill_tools(f.initTools(static_cast<unsigned>(std::min<std::size_t>(h.tool_count, scene_.tools.size()))), scene_, h);
  if (now - s.last_stats_ns >= options_.stats_every_ns) {
    DaemonStatus d = status_now();
    d.jitter.clear();  // the overlay needs the quantiles, not the histogram
    d.stats.recent_overruns.clear();  // nor the overrun records (status has them)
    server::fill_stats(f.initStats(), d);
    f.setHasStats(true);
    s.last_stats_ns = now;
  }
  s.sent_header = h;
  s.sequence = f.getSequence();
  s.last_send_ns = now;
  s.in_flight = true;
  counters_.bytes_sent += req.totalSize().wordCount * 8;
  ++counters_.frames;
  if (changed_meshes == 0 && !tools_moved) ++counters_.keepalives;
  s.pending = track_send(s.id, req.send());
  return true;
}

}  // namespace sculpt::server
