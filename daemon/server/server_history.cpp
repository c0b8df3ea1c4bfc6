// The server's undo and redo: a client's history moves, refused or passed
// to the daemon, and the history it pages through.
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

kj::Promise<bool> Server::until_paused(bool paused, int tries) {
  // The sim thread applies it within a period; a stopped one never does.
  if (control_.paused_now() == paused) return true;
  if (tries <= 0) return false;
  return io_.provider->getTimer().afterDelay(1 * kj::MILLISECONDS).then([this, paused, tries] {
    return until_paused(paused, tries - 1);
  });
}

std::string Server::history_move_refusal(std::uint64_t client, std::uint32_t count) const {
  if (count == 0 || count > options_.max_history_move_count)
    return fmt::format("count {} is out of range: 1 to {} strokes at once (max_history_move_count)", count,
                       options_.max_history_move_count);
  const auto it = clients_.find(client);
  if (it == clients_.end()) return "the connection is closing";
  if (it->second->pending_history_moves >= options_.max_pending_history_moves_per_client)
    return fmt::format("{} undo/redo calls of this connection are still being applied (limit: {}, "
                       "max_pending_history_moves_per_client); wait for their answers",
                       it->second->pending_history_moves, options_.max_pending_history_moves_per_client);
  return {};
}

kj::Promise<HistoryMoveOutcome> Server::move_history(std::uint64_t client, bool redo, std::uint32_t count) {
  if (const auto it = clients_.find(client); it != clients_.end()) ++it->second->pending_history_moves;
  auto answered = kj::defer([this, client] {
    if (const auto c = clients_.find(client); c != clients_.end()) --c->second->pending_history_moves;
  });
  const char* what = redo ? "redo" : "undo";
  return kj::evalNow([this, redo, count] { return redo ? control_.redo(count) : control_.undo(count); })
      .catch_([what](kj::Exception&& e) {
        HistoryMoveOutcome o;
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

}  // namespace sculpt::server
