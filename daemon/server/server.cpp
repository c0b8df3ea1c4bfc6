// The server: its connections and their limits, and status. Viewer streams,
// undo and redo, and exports have their own files (server/server_parts.hpp).
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

// A connection is not taken for a silent one before it had this long to say hello.
constexpr std::int64_t kHelloGraceNs = 1'000'000'000;
// A refused client has this long to read its answer and close before the server closes it.
constexpr std::int64_t kRefusalGraceNs = 1'000'000'000;

}  // namespace

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
  keyframe_bytes_ = bytes;
  scratch_.assign(reader_->body_count(), {});
  for (auto& [id, s] : streams_) s->needs_keyframe = true;
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
      if (const std::uint64_t silent = oldest_silent(simloop::monotonic_ns() - kHelloGraceNs); silent != 0) {
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
        const std::int64_t now = simloop::monotonic_ns();
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
  c->connected_ns = simloop::monotonic_ns();
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

std::uint64_t Server::max_queued_bytes() const { return std::max(options_.max_queued_bytes, 4 * keyframe_bytes_); }

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
      const std::int64_t now = simloop::monotonic_ns();
      if (c->answered_ns == 0) c->answered_ns = now;
      else if (now - c->answered_ns > kRefusalGraceNs) over.emplace_back(id, c->refusal);
    }
  }
  for (const auto& [id, why] : over) drop(id, why);
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

DaemonStatus Server::status_now() {
  // The daemon's numbers, with the two only the server knows.
  DaemonStatus d = control_.status();
  d.stats.viewers = streams_.size();
  d.stats.bytes_sent = counters_.bytes_sent;
  return d;
}

void Server::fill_status(proto::Stats::Builder out) { server::fill_stats(out, status_now()); }

}  // namespace sculpt::server
