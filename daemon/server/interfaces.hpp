// The Cap'n Proto interfaces one client holds (proto/sculpt.capnp):
// Sculptd (hello, the session), Session (control calls and subscribing),
// Subscription (one viewer's stream, removed when the client drops it) and
// ExportReader (one export's file, closed when the client drops it).
// Each turns its calls into the Server's public methods for its client.
#pragma once

#include <cstdint>
#include <string>

#include <kj/memory.h>

#include "server/server.hpp"

namespace sculpt::server {

kj::Own<proto::Sculptd::Server> make_sculptd(Server& server, std::uint64_t client, std::string peer);
// The capability for export `id` of `client` (Server::start_export); its
// end closes the export (Server::close_export).
proto::ExportReader::Client make_export_reader(Server& server, std::uint64_t id, std::uint64_t client);

}  // namespace sculpt::server
